//! A sweep with this crate's localizer: `sweeps/odometry_error.toml` adds wall_ekf and its
//! `[expect.wall_ekf]` to the bundled corridor_tracking scenario and varies the wheels.

use atrium_experiments::sweep::{csv, run_sweep, Sweep, SweepSettings};
use atrium_scenarios::LocalizerRegistry;
use std::path::Path;

#[test]
fn wall_ekf_survives_eight_times_the_wheel_radius_error() {
    let mut registry = LocalizerRegistry::with_builtins();
    custom_localizer::register(&mut registry).unwrap();
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("sweeps/odometry_error.toml");
    let sweep = Sweep::load_with(&file, registry).unwrap();
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("custom_localizer_sweep");
    let _ = std::fs::remove_dir_all(&out);
    let settings = SweepSettings {
        out,
        jobs: None,
        shard: None,
        resume: false,
        progress: false,
    };
    let outcome = run_sweep(&sweep, &settings).unwrap();
    assert_eq!(outcome.ran, 4); // 2 cells x 2 trials

    let results = csv::read_results(&outcome.results_csv).unwrap();
    let radius = results
        .axis_paths
        .iter()
        .position(|p| p == "odometry.radius_error")
        .unwrap();
    let passed = csv::FIXED_COLUMNS
        .iter()
        .position(|c| *c == "passed")
        .unwrap()
        - 4;
    assert_eq!(results.rows.len(), 4 * 3); // mcl, odometry, wall_ekf per trial
    for row in results.rows.iter().filter(|r| r.localizer == "wall_ekf") {
        let context = format!("radius_error {}, trial {}", row.params[radius], row.trial);
        // [expect.wall_ekf] of the sweep file, checked by the runner: median <= 3 cm,
        // max <= 10 cm, at 0.5 % and at 4 % wheel-radius mismatch.
        assert_eq!(row.values[passed], "true", "{context}");
        assert!(row.median().unwrap() <= 0.03, "{context}");
        // Dead reckoning on the same trial misses that bound by metres.
        let dr = results
            .rows
            .iter()
            .find(|r| r.localizer == "odometry" && (r.cell, r.trial) == (row.cell, row.trial))
            .unwrap();
        assert!(dr.median().unwrap() > 1.0, "{context}");
    }
}
