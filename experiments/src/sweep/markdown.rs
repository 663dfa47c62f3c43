//! Text helpers shared by the sweep's Markdown reports (`summary.md`, its end-error and
//! failure-curve sections).

/// `s` on one line of Markdown: control characters (a newline in an axis value or sweep
/// name) written as escapes, so a value cannot break the document's structure.
pub(crate) fn one_line(s: &str) -> String {
    s.chars()
        .map(|c| match c.is_control() {
            true => c.escape_default().to_string(),
            false => c.to_string(),
        })
        .collect()
}
