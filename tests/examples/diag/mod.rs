//! What the diagnosis examples share: which scenario and seeds to diagnose (environment
//! variables, since an example takes no flags through `cargo run`), and an observer that
//! keeps the latest true pose for a localizer wrapper to compare against.

use atrium_robots::{Pose2, Reading};
use atrium_scenarios::runner::{RunObserver, Tick};
use atrium_scenarios::{Estimate, ScenarioError};
use std::sync::{Arc, Mutex};

/// `DIAG_SCENARIO`, else the bundled scenario `default` (a file name in `scenarios/`).
pub fn scenario_path(default: &str) -> String {
    std::env::var("DIAG_SCENARIO").unwrap_or_else(|_| {
        atrium_scenarios::bundled_scenarios_dir()
            .join(default)
            .display()
            .to_string()
    })
}

/// `DIAG_SEEDS` (comma-separated), else seed 1.
pub fn seeds() -> Vec<u64> {
    std::env::var("DIAG_SEEDS")
        .unwrap_or_else(|_| "1".into())
        .split(',')
        .map(|s| {
            s.trim()
                .parse()
                .expect("DIAG_SEEDS: comma-separated integers")
        })
        .collect()
}

/// Keeps the latest ground-truth pose of a run where a localizer wrapper can read it.
pub struct LatestTruth(pub Arc<Mutex<Pose2>>);

impl RunObserver for LatestTruth {
    fn instant(
        &mut self,
        tick: &Tick,
        _: &[Reading],
        _: Option<&[Estimate]>,
    ) -> Result<(), ScenarioError> {
        if let Some(t) = tick.truth {
            *self.0.lock().unwrap() = t;
        }
        Ok(())
    }
}
