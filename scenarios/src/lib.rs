//! Scenarios: the format, the runner (sim stream -> localizers -> metrics), expectations,
//! reports (tables, JSON, SVG/PNG pictures, TUM trajectories) and benchmarks. The `atrium`
//! binary in `main.rs` is a thin shell over this library.

pub mod appearance_filters;
pub mod appearance_lab;
pub mod appearance_localizers;
pub mod bench;
pub mod bench_appearance;
pub mod camera_localizers;
pub mod camera_sensors;
pub mod cgr_localizers;
pub mod chooser_localizers;
pub mod dataset;
pub mod end_error;
pub mod error;
pub mod error_maps;
pub mod expect;
pub mod inspect;
pub mod localizers;
pub mod map_cache;
pub mod metrics;
pub mod node_experiment;
pub mod output;
pub mod plot;
pub mod report;
pub mod route_jitter;
pub mod runner;
pub mod scenario;
pub mod seeds;
pub mod slam;
pub mod slam_plot;
pub mod sweep;
pub mod tum;
pub mod wifi_training;

pub use error::ScenarioError;
pub use runner::{run_scenario, RunOptions, RunResult};
pub use scenario::Scenario;

/// The folder holding the bundled scenarios (`scenarios/` of the source tree).
pub fn bundled_scenarios_dir() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

/// The bundled scenario files (`scenarios/*.toml` beside this crate's manifest), sorted.
pub fn bundled_scenarios() -> std::io::Result<Vec<std::path::PathBuf>> {
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(bundled_scenarios_dir())?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .filter(|p| p.file_name().is_some_and(|n| n != "Cargo.toml"))
        .collect();
    files.sort();
    Ok(files)
}

/// The scenario `atrium` runs with no arguments.
pub fn default_scenario() -> std::path::PathBuf {
    bundled_scenarios_dir().join("tour.toml")
}
