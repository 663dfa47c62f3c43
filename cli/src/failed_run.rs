//! What a failed run keeps, for `run` and `replay`.

use atrium_scenarios::output;

/// A run that failed keeps what is known: the localizers' logs and the error under `--out`
/// (the failed process localizer's stderr is what explains it), and a `--json` document.
pub(crate) fn keep_failed_run(
    e: atrium_scenarios::ScenarioError,
    out: Option<&std::path::Path>,
    json: bool,
) -> anyhow::Error {
    // Bad input found before the run (a bad table, a missing program) leaves no trace.
    if !matches!(e, atrium_scenarios::ScenarioError::Localizer { .. }) {
        return e.into();
    }
    if let Some(dir) = out {
        match output::write_failed_run(dir, &e) {
            Ok(written) => {
                for p in written {
                    eprintln!("kept {}", p.display());
                }
            }
            Err(w) => eprintln!("warning: could not keep the failed run's logs: {w}"),
        }
    }
    if json {
        if let Ok(text) = serde_json::to_string_pretty(&output::failed_run_json(&e)) {
            println!("{text}");
        }
    }
    e.into()
}
