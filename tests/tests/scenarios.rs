//! Every bundled scenario (`scenarios/*.toml`) that states expectations is a test: it runs the
//! scenario with its own seed and fails with the report when an expectation is not met.

use atrium_scenarios::{report, run_scenario, RunOptions, Scenario};
use libtest_mimic::{Arguments, Failed, Trial};
use std::path::{Path, PathBuf};

fn scenario_files() -> Vec<PathBuf> {
    let dir = atrium_scenarios::bundled_scenarios_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files
}

fn has_expectations(path: &Path) -> bool {
    std::fs::read_to_string(path)
        .ok()
        .and_then(|t| t.parse::<toml::Table>().ok())
        .and_then(|t| {
            t.get("expect")
                .and_then(|e| e.as_table())
                .map(|e| !e.is_empty())
        })
        .unwrap_or(false)
}

fn run_one(path: &Path) -> Result<(), Failed> {
    let scenario = Scenario::load(path).map_err(|e| Failed::from(e.to_string()))?;
    let result =
        run_scenario(&scenario, RunOptions::default()).map_err(|e| Failed::from(e.to_string()))?;
    if result.passed() {
        Ok(())
    } else {
        Err(Failed::from(report::to_text(&result)))
    }
}

fn main() {
    let args = Arguments::from_args();
    let trials = scenario_files()
        .into_iter()
        .filter(|p| has_expectations(p))
        .map(|p| {
            let name = p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            Trial::test(format!("scenario::{name}"), move || run_one(&p))
        })
        .collect();
    libtest_mimic::run(&args, trials).exit();
}
