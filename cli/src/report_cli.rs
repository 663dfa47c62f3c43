//! `--report FILE.html` for every command that has one: a [`Report`] is started before the
//! work (so an unwritable path is refused before a long run), commands add what they know,
//! and [`finish`] writes the file once, atomically, with the command line, the Atrium version
//! and the time taken — also when the command failed, with the error, so a report never holds
//! half a document and never claims a run that did not happen.
//!
//! A command adds its own sections and figures through [`Report::html`], one call each — how
//! the realism command joins in:
//!
//! ```ignore
//! let mut report = Report::start(args.report.clone(), format!("atrium realism {}", name))?;
//! let outcome = (|| {
//!     // ... the work ...
//!     if let Some(html) = report.html() {
//!         html.section("Real against simulated")
//!             .paragraph("Position errors of the real log and its twin.")
//!             .figure(&fig, "histogram of position errors");
//!     }
//!     Ok(passed)
//! })();
//! report.finish(outcome)
//! ```

use anyhow::Context;
use atrium_scenarios::report_html::{self, HtmlReport};
use atrium_scenarios::RunResult;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A report being gathered (or nothing, without `--report`).
pub struct Report {
    target: Option<(PathBuf, HtmlReport)>,
    started: Instant,
}

impl Report {
    /// Starts a report for `--report path` (nothing when `None`), titled `title`. Refuses a
    /// path that cannot be written, before any work.
    pub fn start(path: Option<PathBuf>, title: impl Into<String>) -> anyhow::Result<Report> {
        let target = match path {
            None => None,
            Some(p) => {
                atrium_scenarios::output::check_writable_file(&p, "--report")
                    .map_err(anyhow::Error::msg)?;
                let mut html = HtmlReport::new(title);
                let args: Vec<String> = std::env::args().collect();
                html.meta("command", args.join(" "));
                html.meta("Atrium version", env!("CARGO_PKG_VERSION"));
                Some((p, html))
            }
        };
        Ok(Report {
            target,
            started: Instant::now(),
        })
    }

    /// The document to add sections to (`None` without `--report`).
    pub fn html(&mut self) -> Option<&mut HtmlReport> {
        self.target.as_mut().map(|(_, h)| h)
    }

    /// Adds the text of the scenario file at `path` (as written: comments and all).
    pub fn scenario_text(&mut self, path: &Path) {
        if let Some(html) = self.html() {
            let text = std::fs::read_to_string(path)
                .unwrap_or_else(|e| format!("({}: cannot read: {e})", path.display()));
            html.section(format!("Scenario {}", path.display()))
                .pre(text);
        }
    }

    /// Adds a run: verdicts, metrics, trajectory figures and timing.
    pub fn run(
        &mut self,
        run: &RunResult,
        world: Option<&atrium_worlds::World>,
    ) -> anyhow::Result<()> {
        if let Some(html) = self.html() {
            report_html::add_run(html, run, world).context("--report: drawing the run")?;
        }
        Ok(())
    }

    /// Writes the report (if one was asked for) with the outcome and the time taken, and
    /// passes the outcome on. A failed command's report says so and holds what was added.
    pub fn finish<E: std::fmt::Display>(
        self,
        outcome: Result<bool, E>,
    ) -> Result<bool, FinishError<E>> {
        let Some((path, mut html)) = self.target else {
            return outcome.map_err(FinishError::Command);
        };
        html.meta(
            "time taken",
            format!("{:.1} s", self.started.elapsed().as_secs_f64()),
        );
        match &outcome {
            Ok(true) => html.meta("outcome", "passed (exit 0)"),
            Ok(false) => html.meta("outcome", "expectations not met (exit 1)"),
            Err(e) => {
                html.section("Error").verdict(false, format!("{e}"));
                html.meta("outcome", "error (exit 2)")
            }
        };
        let written = html
            .write(&path)
            .with_context(|| format!("--report {}: cannot write file", path.display()));
        match (outcome, written) {
            (Err(e), _) => Err(FinishError::Command(e)),
            (Ok(_), Err(w)) => Err(FinishError::Report(w)),
            (Ok(b), Ok(())) => {
                eprintln!("wrote {}", path.display());
                Ok(b)
            }
        }
    }
}

/// Why [`Report::finish`] failed: the command's own error, or writing the report.
#[derive(Debug)]
pub enum FinishError<E> {
    Command(E),
    Report(anyhow::Error),
}
