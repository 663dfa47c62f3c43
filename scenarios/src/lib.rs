//! The harness: the scenario format, the runner (a reading stream -> localizers -> metrics),
//! expectations, the localizer registry with Atrium's own kinds, and reports (tables, JSON,
//! SVG/PNG pictures, TUM trajectories). Experiments, sweeps, datasets and the `atrium` CLI
//! build on it in `atrium-experiments` and `atrium-cli`.
//!
//! Modules depend one way, in this order: the format (`error`, `seeds`, `trajectory`, `scenario`,
//! `camera_sensors`, `route_jitter`, `node_route`) → expectations (`verdict`, `metrics`,
//! `relations`, `slam`, `expect`) → `runner` → `maps` and `registry` → `builtins` and `error_maps` →
//! reports (`report`, `output`, `plot`, `slam_plot`), drawn with `figure`, `report_html` for
//! `--report`; files are written through `atomic`; `progress` draws bars on a terminal.

pub mod atomic;
pub mod builtins;
pub mod calibrate;
pub mod camera_sensors;
pub mod disk_cache;
pub mod error;
pub mod error_maps;
pub mod expect;
pub mod figure;
pub mod grid_map;
pub mod load_cache;
pub mod log;
pub mod log_stream;
pub mod map_build;
pub mod map_cache;
pub mod maps;
pub mod metrics;
pub mod node_route;
pub mod output;
pub mod plot;
pub mod progress;
pub mod realism;
pub mod realism_figures;
pub mod reference_build;
pub mod registry;
pub mod relations;
pub mod report;
pub mod report_html;
pub mod robot_input;
pub mod route_jitter;
pub mod runner;
pub mod scenario;
pub mod seeds;
pub mod sensor_needs;
pub mod slam;
pub mod slam_plot;
pub mod trajectory;
pub mod twin;
pub mod verdict;

pub use atrium_localization::{Capabilities, Estimate, Localizer, LocalizerError, OdometryDelta};
pub use error::ScenarioError;
pub use registry::{
    run_scenario, BuildContext, LocalizerFactory, LocalizerRegistry, RegistryError,
};
pub use runner::{run_localizers, RunOptions, RunResult};
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
