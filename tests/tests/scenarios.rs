//! Every bundled scenario (`scenarios/*.toml`) that states expectations is a test: it runs the
//! scenario with its own seed and fails with the report when an expectation is not met.

use atrium_scenarios::{report, run_scenario, RunOptions, Scenario};
use libtest_mimic::{Arguments, Failed, Trial};
use std::path::{Path, PathBuf};

fn scenario_files() -> Vec<PathBuf> {
    atrium_scenarios::bundled_scenarios().expect("read the bundled scenarios folder")
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
    let files = scenario_files();
    assert!(!files.is_empty(), "no bundled scenarios found");
    let stem = |p: &Path| {
        p.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    // Every bundled scenario must at least load and validate, expectations or not.
    let mut trials: Vec<Trial> = files
        .iter()
        .map(|p| {
            let p = p.clone();
            Trial::test(format!("loads::{}", stem(&p)), move || {
                Scenario::load(&p)
                    .map(|_| ())
                    .map_err(|e| Failed::from(e.to_string()))
            })
        })
        .collect();
    trials.extend(files.into_iter().filter(|p| has_expectations(p)).map(|p| {
        let name = stem(&p);
        Trial::test(format!("scenario::{name}"), move || run_one(&p))
    }));
    libtest_mimic::run(&args, trials).exit();
}
