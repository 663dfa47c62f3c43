//! One self-contained HTML file per command (`--report FILE.html`): the scenario text, the
//! expectations and their verdicts, tables, the figures inline as SVG, timing and the Atrium
//! version. No external URL (no fonts, scripts or images fetched): it reads offline. CSS
//! follows the system's light or dark setting (`prefers-color-scheme`) and prints well
//! (`@media print`). Written atomically.
//!
//! A command builds a [`HtmlReport`], adds [`Section`]s and writes it:
//!
//! ```no_run
//! use atrium_scenarios::report_html::HtmlReport;
//! let mut report = HtmlReport::new("atrium realism fr079_real");
//! report.meta("command", "atrium realism scenarios/fr079_real.toml");
//! let s = report.section("Real against simulated errors");
//! s.paragraph("Position errors of the real log and of its twin, over 5 seeds.");
//! s.table(&["statistic", "real", "twin"], vec![vec!["median (m)".into(), "0.12".into(), "0.10".into()]]);
//! // s.figure(&fig, "caption");  // a figure::Figure, inlined as SVG
//! report.write(std::path::Path::new("realism.html")).unwrap();
//! ```

use crate::figure::{escape, Figure};
use crate::runner::RunResult;
use crate::verdict::Bound;
use std::path::Path;

/// One block of a section.
#[derive(Debug, Clone)]
enum Block {
    Paragraph(String),
    Pre(String),
    Table {
        header: Vec<String>,
        rows: Vec<Vec<String>>,
    },
    Figure {
        svg: String,
        caption: String,
    },
    Verdict {
        passed: bool,
        text: String,
    },
}

/// A titled part of the report.
#[derive(Debug, Clone)]
pub struct Section {
    title: String,
    blocks: Vec<Block>,
}

impl Section {
    pub fn paragraph(&mut self, text: impl Into<String>) -> &mut Section {
        self.blocks.push(Block::Paragraph(text.into()));
        self
    }

    /// Preformatted text (a scenario file, a text table).
    pub fn pre(&mut self, text: impl Into<String>) -> &mut Section {
        self.blocks.push(Block::Pre(text.into()));
        self
    }

    /// A table; cells are text (escaped). Cells reading `PASS` / `FAIL` are marked.
    pub fn table(&mut self, header: &[&str], rows: Vec<Vec<String>>) -> &mut Section {
        self.blocks.push(Block::Table {
            header: header.iter().map(|h| h.to_string()).collect(),
            rows,
        });
        self
    }

    /// A figure, inlined as SVG, with a caption.
    pub fn figure(&mut self, fig: &Figure, caption: impl Into<String>) -> &mut Section {
        self.blocks.push(Block::Figure {
            svg: fig.svg().to_string(),
            caption: caption.into(),
        });
        self
    }

    /// An SVG document already drawn (a figure file read back), inlined with a caption.
    pub fn svg(&mut self, svg: String, caption: impl Into<String>) -> &mut Section {
        self.blocks.push(Block::Figure {
            svg,
            caption: caption.into(),
        });
        self
    }

    /// A highlighted pass / fail line.
    pub fn verdict(&mut self, passed: bool, text: impl Into<String>) -> &mut Section {
        self.blocks.push(Block::Verdict {
            passed,
            text: text.into(),
        });
        self
    }
}

/// A report being built.
#[derive(Debug, Clone)]
pub struct HtmlReport {
    title: String,
    meta: Vec<(String, String)>,
    sections: Vec<Section>,
}

const CSS: &str = r#"
:root { --bg: #ffffff; --fg: #1b1b1b; --muted: #5a5a5a; --line: #d0d0d0; --head: #f2f2f2;
  --pass: #00734d; --fail: #b34000; --code: #f6f6f6; --figbg: #ffffff; }
@media (prefers-color-scheme: dark) {
  :root { --bg: #15171a; --fg: #e6e6e6; --muted: #a8a8a8; --line: #3a3d42; --head: #202328;
    --pass: #4fd1a1; --fail: #ff9f5a; --code: #1d2024; --figbg: #f4f4f4; }
}
* { box-sizing: border-box; }
body { background: var(--bg); color: var(--fg); margin: 0 auto; max-width: 70rem;
  padding: 1.5rem; font: 16px/1.5 "DejaVu Sans", system-ui, sans-serif; }
h1 { font-size: 1.6rem; margin: 0 0 .5rem; }
h2 { font-size: 1.25rem; margin: 2rem 0 .6rem; border-bottom: 1px solid var(--line); }
dl.meta { display: grid; grid-template-columns: max-content 1fr; gap: .1rem 1rem; color: var(--muted); }
dl.meta dt { font-weight: bold; }
dl.meta dd { margin: 0; }
pre { background: var(--code); border: 1px solid var(--line); padding: .75rem; overflow-x: auto;
  font: 13px/1.4 "DejaVu Sans Mono", ui-monospace, monospace; white-space: pre-wrap; }
table { border-collapse: collapse; margin: .5rem 0 1rem; font-size: .92rem; }
th, td { border: 1px solid var(--line); padding: .25rem .6rem; text-align: left; vertical-align: top; }
th { background: var(--head); }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.pass { color: var(--pass); font-weight: bold; }
.fail { color: var(--fail); font-weight: bold; }
p.verdict { font-size: 1.05rem; }
figure { margin: 1rem 0 1.5rem; }
figure svg { width: 100%; height: auto; background: var(--figbg); border-radius: 4px; }
figcaption { color: var(--muted); font-size: .9rem; }
footer { margin-top: 2rem; color: var(--muted); font-size: .85rem; }
@media print {
  :root { --bg: #fff; --fg: #000; --muted: #333; --line: #999; --head: #eee; --code: #fff; }
  body { max-width: none; padding: 0; font-size: 11pt; }
  h2 { break-after: avoid; }
  figure, table, pre { break-inside: avoid; }
  figure svg { max-height: 24cm; }
  pre { white-space: pre-wrap; }
}
"#;

fn looks_numeric(s: &str) -> bool {
    let t = s.trim().trim_start_matches(['<', '>', '≤', '≥']);
    !t.is_empty() && t.parse::<f64>().is_ok()
}

/// An SVG made for inlining: no XML declaration, no DOCTYPE.
fn inline_svg(svg: &str) -> &str {
    match svg.find("<svg") {
        Some(i) => &svg[i..],
        None => svg,
    }
}

impl HtmlReport {
    pub fn new(title: impl Into<String>) -> HtmlReport {
        HtmlReport {
            title: title.into(),
            meta: Vec::new(),
            sections: Vec::new(),
        }
    }

    /// A line of the header (command, version, time taken, ...).
    pub fn meta(&mut self, key: impl Into<String>, value: impl Into<String>) -> &mut HtmlReport {
        self.meta.push((key.into(), value.into()));
        self
    }

    /// A new section at the end; add blocks to what it returns.
    pub fn section(&mut self, title: impl Into<String>) -> &mut Section {
        self.sections.push(Section {
            title: title.into(),
            blocks: Vec::new(),
        });
        self.sections.last_mut().expect("just pushed")
    }

    /// The whole document.
    pub fn render(&self) -> String {
        let mut s = String::new();
        s.push_str("<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n");
        s.push_str(
            "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <meta name=\"color-scheme\" content=\"light dark\">\n",
        );
        s.push_str(&format!("<title>{}</title>\n", escape(&self.title)));
        s.push_str(&format!("<style>{CSS}</style>\n</head>\n<body>\n"));
        s.push_str(&format!("<header>\n<h1>{}</h1>\n", escape(&self.title)));
        if !self.meta.is_empty() {
            s.push_str("<dl class=\"meta\">\n");
            for (k, v) in &self.meta {
                s.push_str(&format!("<dt>{}</dt><dd>{}</dd>\n", escape(k), escape(v)));
            }
            s.push_str("</dl>\n");
        }
        s.push_str("</header>\n<main>\n");
        for (i, sec) in self.sections.iter().enumerate() {
            s.push_str(&format!(
                "<section id=\"s{i}\">\n<h2>{}</h2>\n",
                escape(&sec.title)
            ));
            for b in &sec.blocks {
                match b {
                    Block::Paragraph(t) => s.push_str(&format!("<p>{}</p>\n", escape(t))),
                    Block::Pre(t) => s.push_str(&format!("<pre>{}</pre>\n", escape(t))),
                    Block::Verdict { passed, text } => s.push_str(&format!(
                        "<p class=\"verdict\"><span class=\"{}\">{}</span> {}</p>\n",
                        if *passed { "pass" } else { "fail" },
                        if *passed { "PASS" } else { "FAIL" },
                        escape(text)
                    )),
                    Block::Table { header, rows } => {
                        s.push_str("<table>\n<thead><tr>");
                        for h in header {
                            s.push_str(&format!("<th>{}</th>", escape(h)));
                        }
                        s.push_str("</tr></thead>\n<tbody>\n");
                        for row in rows {
                            s.push_str("<tr>");
                            for c in row {
                                let class = match c.as_str() {
                                    "PASS" => " class=\"pass\"",
                                    "FAIL" => " class=\"fail\"",
                                    c if looks_numeric(c) => " class=\"num\"",
                                    _ => "",
                                };
                                s.push_str(&format!("<td{class}>{}</td>", escape(c)));
                            }
                            s.push_str("</tr>\n");
                        }
                        s.push_str("</tbody>\n</table>\n");
                    }
                    Block::Figure { svg, caption } => {
                        s.push_str("<figure>\n");
                        s.push_str(inline_svg(svg));
                        s.push_str(&format!(
                            "\n<figcaption>{}</figcaption>\n</figure>\n",
                            escape(caption)
                        ));
                    }
                }
            }
            s.push_str("</section>\n");
        }
        s.push_str(&format!(
            "</main>\n<footer>Written by Atrium {}.</footer>\n</body>\n</html>\n",
            env!("CARGO_PKG_VERSION")
        ));
        s
    }

    /// Writes the document to `path` atomically (whole or not at all).
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        crate::atomic::write_atomic(path, self.render().as_bytes())
    }
}

fn num(v: f64) -> String {
    crate::figure::format_number(v)
}

/// Adds what a run has to say: its summary, the expectations and their verdicts, the
/// metrics per localizer, a figure per localizer (the trajectory coloured by its error, as
/// `atrium run --out` writes it) and timing. `world` draws the figures (none without it).
pub fn add_run(
    report: &mut HtmlReport,
    run: &RunResult,
    world: Option<&atrium_worlds::World>,
) -> Result<(), crate::figure::FigureError> {
    let s = report.section(format!("Run: {} (seed {})", run.scenario, run.seed));
    s.verdict(
        run.passed(),
        format!(
            "{} of {} localizers met every expectation",
            run.localizers.iter().filter(|l| l.passed).count(),
            run.localizers.len()
        ),
    );
    if !run.description.is_empty() {
        s.paragraph(run.description.clone());
    }
    s.paragraph(match &run.log {
        Some(log) => format!(
            "Real log {} ({} scans), {:.1} s, {:.1} m along the reference {}.",
            log.path, log.scans, run.sim_time_s, run.distance_m, log.reference
        ),
        None => format!(
            "{} in {}: {:.1} s simulated, {:.1} m driven{}.",
            run.robot,
            run.world,
            run.sim_time_s,
            run.distance_m,
            if run.route_completed {
                ""
            } else {
                " (route not completed)"
            }
        ),
    });
    let mut rows = Vec::new();
    for l in &run.localizers {
        for e in &l.expectations {
            rows.push(vec![
                l.name.clone(),
                e.metric.clone(),
                format!(
                    "{} {}",
                    match e.bound {
                        Bound::Max => "≤",
                        Bound::Min => "≥",
                    },
                    num(e.limit)
                ),
                e.value.map_or("none".into(), num),
                if e.passed { "PASS" } else { "FAIL" }.into(),
            ]);
        }
    }
    if rows.is_empty() {
        s.paragraph("The scenario states no expectations.");
    } else {
        s.table(&["localizer", "metric", "bound", "value", "verdict"], rows);
    }
    let rows = run
        .localizers
        .iter()
        .map(|l| match &l.metrics {
            Some(m) => vec![
                l.name.clone(),
                l.kind.clone(),
                num(m.position_error.median),
                num(m.position_error.mean),
                num(m.position_error.p95),
                num(m.position_error.max),
                num(m.final_position_error),
                num(m.heading_error.median.to_degrees()),
                m.converged_after_s.map_or("never".into(), num),
            ],
            None => vec![l.name.clone(), l.kind.clone(), "not scored".into()],
        })
        .collect();
    s.table(
        &[
            "localizer",
            "kind",
            "median error (m)",
            "mean (m)",
            "p95 (m)",
            "max (m)",
            "final (m)",
            "median heading error (°)",
            "converged after (s)",
        ],
        rows,
    );
    if let Some(world) = world {
        for l in &run.localizers {
            let fig = crate::plot::trajectory_figure(world, run, l)?;
            s.figure(
                &fig,
                format!(
                    "{}: the estimate coloured by its position error (log scale, metres); \
                     the {} in black; glass walls dashed cyan.",
                    l.name,
                    if run.log.is_some() {
                        "reference"
                    } else {
                        "ground truth"
                    }
                ),
            );
        }
    }
    let t = &run.timing;
    let mut rows = vec![
        vec!["whole run (wall clock)".to_string(), num(t.wall_s)],
        vec!["simulator".to_string(), num(t.sim_s)],
    ];
    rows.extend(
        t.localizers_s
            .iter()
            .map(|(n, v)| vec![format!("localizer {n}"), num(*v)]),
    );
    s.table(&["timing", "seconds"], rows);
    s.paragraph(format!(
        "Real-time factor {}, {} physics steps.",
        num(t.real_time_factor),
        t.physics_steps
    ));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_text_marks_verdicts_and_inlines_svg_without_prolog() {
        let mut r = HtmlReport::new("a <b> & c");
        r.meta("version", "0.1.0");
        let s = r.section("S");
        s.paragraph("x < y")
            .table(&["k", "v"], vec![vec!["PASS".into(), "1.5".into()]])
            .verdict(false, "bad");
        let html = r.render();
        assert!(html.contains("<title>a &lt;b&gt; &amp; c</title>"));
        assert!(html.contains("<p>x &lt; y</p>"));
        assert!(html.contains("<td class=\"pass\">PASS</td><td class=\"num\">1.5</td>"));
        assert!(html.contains("<span class=\"fail\">FAIL</span> bad"));
        assert!(html.contains("prefers-color-scheme: dark") && html.contains("@media print"));
        assert_eq!(inline_svg("<?xml version=\"1.0\"?>\n<svg a>"), "<svg a>");
    }
}
