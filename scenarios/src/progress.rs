//! Progress bars for long work (sweeps, `check` over seeds, map building, realism): drawn on
//! stderr when it is a terminal, hidden when it is piped or the command prints JSON, so logs
//! and scripts stay clean.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;

/// Whether bars may be drawn: stderr is a terminal and the command does not print JSON.
pub fn on_terminal(json: bool) -> bool {
    !json && std::io::stderr().is_terminal()
}

/// A bar counting `n` items of `unit` ("seeds", "trials", "scans"), with `msg` before it and
/// the rate and time left after; hidden unless `shown` and stderr is a terminal. Call
/// `inc(1)` per item (it is `Sync`: threads may share it) and `finish_and_clear()` at the end.
pub fn counting(shown: bool, n: u64, msg: &str, unit: &str) -> ProgressBar {
    if !(shown && std::io::stderr().is_terminal()) {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(n);
    let template = format!("{{msg}} [{{bar:40}}] {{pos}}/{{len}} {unit} (eta {{eta}})");
    bar.set_style(
        ProgressStyle::with_template(&template).unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(msg.to_string());
    bar
}

/// A bar over a fraction of work (0 to 1000 per mille), for a run's simulated time.
pub fn fraction(shown: bool, msg: &str) -> ProgressBar {
    if !(shown && std::io::stderr().is_terminal()) {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {percent}% (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(msg.to_string());
    bar
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bars_are_hidden_when_not_asked_for() {
        let b = counting(false, 10, "seeds", "seeds");
        assert!(b.is_hidden());
        b.inc(3);
        assert_eq!(b.position(), 3, "a hidden bar still counts");
        assert!(fraction(false, "run").is_hidden());
        assert!(!on_terminal(true), "never with --json");
    }
}
