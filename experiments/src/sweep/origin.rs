//! Where a cell's error comes from. A cell's scenario is the base scenario's table with the
//! sweep's own `[[localizers]]` / `[expect]` and the cell's axis values written into it,
//! serialised and parsed again; an error of that parse points into text nobody wrote. These
//! helpers turn its position (or a field path such as `localizers[mcl].beams`) into a path of
//! keys, and find the line of a path in the files the user did write.

use toml::de::{DeTable, DeValue};
use toml::Spanned;

/// The 1-based line of byte `offset` of `text`.
pub fn line_at(text: &str, offset: usize) -> usize {
    1 + text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&c| c == b'\n')
        .count()
}

/// A field path as errors write it (`a.b`, `route.waypoints[0]`, `localizers[mcl].beams`)
/// split into its keys (`["localizers", "mcl", "beams"]`).
pub fn field_keys(field: &str) -> Vec<String> {
    let mut keys = Vec::new();
    let mut cur = String::new();
    let mut chars = field.chars();
    while let Some(c) = chars.next() {
        match c {
            '.' => keys.push(std::mem::take(&mut cur)),
            '[' => {
                if !cur.is_empty() {
                    keys.push(std::mem::take(&mut cur));
                }
                let inner: String = chars.by_ref().take_while(|&c| c != ']').collect();
                keys.push(inner);
                // A `.` may follow `]`; it separates nothing new.
                let rest = chars.as_str();
                if let Some(r) = rest.strip_prefix('.') {
                    chars = r.chars();
                }
            }
            c => cur.push(c),
        }
    }
    if !cur.is_empty() {
        keys.push(cur);
    }
    keys
}

/// Whether `inner` lies at or below `outer` (keys compared one by one).
pub fn within(inner: &[String], outer: &[String]) -> bool {
    inner.len() >= outer.len() && inner[..outer.len()] == *outer
}

/// The entry of a scenario's `localizers` array that a key names: its `name`, or its index
/// when a name is missing (as errors about unnamed entries write it).
fn localizer_entry<'a, 'i>(
    list: &'a [Spanned<DeValue<'i>>],
    key: &str,
) -> Option<&'a Spanned<DeValue<'i>>> {
    list.iter()
        .find(|e| {
            e.get_ref()
                .as_table()
                .and_then(|t| t.iter().find(|(k, _)| k.get_ref() == "name"))
                .and_then(|(_, v)| v.get_ref().as_str().map(|s| s == key))
                .unwrap_or(false)
        })
        .or_else(|| key.parse::<usize>().ok().and_then(|i| list.get(i)))
}

/// The line of the deepest item of `keys` found in `text` (`localizers.<name>` finds the
/// `[[localizers]]` entry of that name), or `None` when not even the first key is there.
pub fn line_of(text: &str, keys: &[String]) -> Option<usize> {
    let doc = DeTable::parse(text).ok()?;
    let mut table: Option<&DeTable> = Some(doc.get_ref());
    let mut array: Option<(&[Spanned<DeValue>], bool)> = None;
    let mut found = None;
    for (depth, key) in keys.iter().enumerate() {
        let (span, value) = if let Some(t) = table {
            let Some((k, v)) = t.iter().find(|(k, _)| k.get_ref() == key) else {
                break;
            };
            (k.span(), v)
        } else if let Some((list, by_name)) = array {
            let entry = if by_name {
                localizer_entry(list, key)
            } else {
                key.parse::<usize>().ok().and_then(|i| list.get(i))
            };
            let Some(e) = entry else { break };
            (e.span(), e)
        } else {
            break;
        };
        found = Some(span.start);
        table = value.get_ref().as_table();
        array = value
            .get_ref()
            .as_array()
            .map(|a| (a.as_ref(), depth == 0 && key == "localizers"));
    }
    found.map(|at| line_at(text, at))
}

/// The keys of the innermost item of `text` whose key or value holds byte `offset` (array
/// elements by index; `localizers` entries by name, as [`line_of`] takes them).
pub fn keys_at(text: &str, offset: usize) -> Vec<String> {
    fn walk(
        t: &DeTable,
        offset: usize,
        path: &mut Vec<String>,
        best: &mut Option<(usize, Vec<String>)>,
    ) {
        for (k, v) in t.iter() {
            path.push(k.get_ref().to_string());
            consider(k.span(), offset, path, best);
            visit(v, offset, path, best);
            path.pop();
        }
    }
    fn consider(
        span: std::ops::Range<usize>,
        offset: usize,
        path: &[String],
        best: &mut Option<(usize, Vec<String>)>,
    ) {
        // An empty span (the end of the text) holds the offset it starts at.
        if span.start <= offset && (offset < span.end || offset == span.start) {
            let len = span.end - span.start;
            if best
                .as_ref()
                .is_none_or(|(l, p)| len < *l || (len == *l && path.len() > p.len()))
            {
                *best = Some((len, path.to_vec()));
            }
        }
    }
    fn visit(
        v: &Spanned<DeValue>,
        offset: usize,
        path: &mut Vec<String>,
        best: &mut Option<(usize, Vec<String>)>,
    ) {
        consider(v.span(), offset, path, best);
        match v.get_ref() {
            DeValue::Table(t) => walk(t, offset, path, best),
            DeValue::Array(a) => {
                let localizers = path.len() == 1 && path[0] == "localizers";
                for (i, e) in a.iter().enumerate() {
                    let name = localizers
                        .then(|| e.get_ref().as_table())
                        .flatten()
                        .and_then(|t| t.iter().find(|(k, _)| k.get_ref() == "name"))
                        .and_then(|(_, n)| n.get_ref().as_str().map(String::from));
                    path.push(name.unwrap_or_else(|| i.to_string()));
                    visit(e, offset, path, best);
                    path.pop();
                }
            }
            _ => {}
        }
    }
    let Ok(doc) = DeTable::parse(text) else {
        return Vec::new();
    };
    let mut best = None;
    walk(doc.get_ref(), offset, &mut Vec::new(), &mut best);
    best.map(|(_, p)| p).unwrap_or_default()
}

/// A TOML error message as `toml` displays it (`TOML parse error at line L, column C`, the
/// quoted line, a caret line, then the description): the byte offset it points at in `text`
/// and the description alone.
pub fn parse_toml_message(msg: &str, text: &str) -> (Option<usize>, String) {
    let lines: Vec<&str> = msg.lines().collect();
    let position = lines.first().and_then(|first| {
        let rest = first.strip_prefix("TOML parse error at line ")?;
        let (l, c) = rest.split_once(", column ")?;
        Some((
            l.trim().parse::<usize>().ok()?,
            c.trim().parse::<usize>().ok()?,
        ))
    });
    let Some((line, column)) = position else {
        return (None, msg.trim().to_string());
    };
    // The description follows the quoted source line and its caret line.
    let caret = lines
        .iter()
        .position(|l| l.trim_start().starts_with('|') && l.contains('^'))
        .unwrap_or(0);
    let desc = lines[caret + 1..].join("\n");
    let line_start = text
        .split_inclusive('\n')
        .take(line.saturating_sub(1))
        .map(str::len)
        .sum::<usize>();
    let offset = text[line_start.min(text.len())..]
        .char_indices()
        .nth(column.saturating_sub(1))
        .map_or(text.len(), |(i, _)| line_start + i);
    let desc = desc.trim().to_string();
    (
        Some(offset),
        if desc.is_empty() {
            msg.trim().to_string()
        } else {
            desc
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = "a = 1\n[axes]\n\"x.y\" = [1, 2]\n[axes.c]\nm = [3]\n[[localizers]]\nname = \"l\"\np = 2\n[[localizers]]\nname = \"k\"\nq = \"s\"\n";

    fn keys(s: &[&str]) -> Vec<String> {
        s.iter().map(|k| k.to_string()).collect()
    }

    #[test]
    fn field_paths_split_into_keys() {
        assert_eq!(
            field_keys("localizers[mcl].beams"),
            keys(&["localizers", "mcl", "beams"])
        );
        assert_eq!(
            field_keys("route.waypoints[0]"),
            keys(&["route", "waypoints", "0"])
        );
        assert_eq!(field_keys("duration_s"), keys(&["duration_s"]));
        assert_eq!(field_keys("localizers[x]"), keys(&["localizers", "x"]));
    }

    #[test]
    fn lines_of_keys_and_named_localizers() {
        assert_eq!(line_of(DOC, &keys(&["a"])), Some(1));
        assert_eq!(line_of(DOC, &keys(&["axes", "x.y"])), Some(3));
        assert_eq!(line_of(DOC, &keys(&["axes", "c", "m"])), Some(5));
        assert_eq!(line_of(DOC, &keys(&["localizers", "k", "q"])), Some(11));
        assert_eq!(line_of(DOC, &keys(&["localizers", "l"])), Some(6));
        // The deepest key found: `nope` is not there, its table is.
        assert_eq!(line_of(DOC, &keys(&["localizers", "k", "nope"])), Some(9));
        assert_eq!(line_of(DOC, &keys(&["zz"])), None);
    }

    #[test]
    fn offsets_map_to_the_innermost_keys() {
        let at = |needle: &str| keys_at(DOC, DOC.find(needle).unwrap());
        assert_eq!(at("2]"), keys(&["axes", "x.y", "1"]));
        assert_eq!(at("\"s\""), keys(&["localizers", "k", "q"]));
        assert_eq!(at("p = 2"), keys(&["localizers", "l", "p"]));
    }

    #[test]
    fn toml_messages_give_offset_and_description() {
        let text = "a = 1\nb = \"x\"\n";
        let err = toml::from_str::<std::collections::BTreeMap<String, f64>>(text).unwrap_err();
        let (offset, desc) = parse_toml_message(&err.to_string(), text);
        assert_eq!(offset, Some(text.find("\"x\"").unwrap()));
        assert!(
            desc.contains("invalid type") && !desc.contains('|'),
            "{desc}"
        );
        assert_eq!(parse_toml_message("plain", text), (None, "plain".into()));
    }
}
