//! The localizers a scenario can name (`[[localizers]] kind = ...`) and how each is built.

use crate::error::ScenarioError;
use crate::scenario::{InitialBelief, LocalizerSpec, Scenario};
use atrium_localization::{
    dead_reckoning::DeadReckoning,
    mcl::{InitialBelief as MclBelief, Mcl, MclParams},
    Localizer,
};
use atrium_worlds::OccupancyGrid;

/// Maps exported from the world once per run and shared by the localizers that need them.
#[derive(Default)]
pub struct SharedMaps {
    grid: Option<OccupancyGrid>,
    vector: Option<atrium_worlds::VectorMap>,
}

impl SharedMaps {
    /// The vector map (wall faces and pillars as segments; glass per `[map] include_glass`).
    pub fn vector_map(&mut self, scenario: &Scenario) -> &atrium_worlds::VectorMap {
        self.vector
            .get_or_insert_with(|| scenario.world.vector_map(scenario.map.include_glass))
    }

    /// The occupancy grid of the scenario's `[map]` settings.
    pub fn occupancy_grid(&mut self, scenario: &Scenario) -> &OccupancyGrid {
        self.grid.get_or_insert_with(|| {
            scenario
                .world
                .occupancy_grid(scenario.map.resolution, scenario.map.include_glass)
        })
    }
}

/// Builds the localizer a scenario names. Each kind takes its parameters from the
/// `[[localizers]]` table (checked here, errors name the field) and its map from `maps`.
pub fn build_localizer(
    spec: &LocalizerSpec,
    scenario: &Scenario,
    maps: &mut SharedMaps,
    seed: u64,
) -> Result<Box<dyn Localizer>, ScenarioError> {
    let file = &scenario.file;
    let field = format!("localizers[{}]", spec.name);
    match spec.kind.as_str() {
        "dead_reckoning" => {
            if let Some(k) = spec.params.keys().next() {
                return Err(ScenarioError::field(
                    file,
                    format!("{field}.{k}"),
                    "dead_reckoning takes no parameters",
                ));
            }
            Ok(Box::new(DeadReckoning::new(&spec.name, scenario.start)))
        }
        "mcl" => {
            let params: MclParams = toml::Value::Table(spec.params.clone()).try_into().map_err(
                |e: toml::de::Error| ScenarioError::field(file, &field, e.message().to_string()),
            )?;
            params
                .validate()
                .map_err(|msg| ScenarioError::field(file, &field, msg))?;
            let grid = maps.occupancy_grid(scenario);
            let init = match &scenario.initial_belief {
                InitialBelief::Tracking { sigma } => MclBelief::Tracking {
                    pose: scenario.start,
                    sigma: *sigma,
                },
                InitialBelief::Global { polygons } => MclBelief::Global {
                    regions: polygons.clone(),
                },
            };
            let mcl = Mcl::new(&spec.name, params, grid, init, seed)
                .map_err(|e| ScenarioError::field(file, &field, e.to_string()))?;
            Ok(Box::new(mcl))
        }
        "ekf_slam" => {
            use atrium_localization::ekf_slam::{EkfSlam, EkfSlamParams};
            let mut params: EkfSlamParams = toml::Value::Table(spec.params.clone())
                .try_into()
                .map_err(|e: toml::de::Error| {
                    ScenarioError::field(file, &field, e.message().to_string())
                })?;
            // The filter assumes the detector's noise unless the file says otherwise.
            if let Some(d) = scenario.landmark_detectors.first() {
                params.sigma_range.get_or_insert(d.sigma_range);
                params.sigma_bearing.get_or_insert(d.sigma_bearing);
            }
            if scenario.landmark_detectors.is_empty() {
                return Err(ScenarioError::field(
                    file,
                    format!("{field}.kind"),
                    "ekf_slam needs point features: add a [landmark_detector] table",
                ));
            }
            let slam = EkfSlam::new(&spec.name, params, scenario.start)
                .map_err(|msg| ScenarioError::field(file, &field, msg))?;
            Ok(Box::new(slam))
        }
        "cgr_laser" | "cgr_depth" => crate::cgr_localizers::build(spec, scenario, maps, seed),
        "landmark_filter" => crate::node_experiment::train_landmark_filter(spec, scenario),
        "wifi" => {
            let grid = maps.occupancy_grid(scenario);
            crate::wifi_training::build_wifi_localizer(spec, scenario, grid, seed)
        }
        other => Err(ScenarioError::field(
            file,
            format!("{field}.kind"),
            format!("unknown localizer kind {other:?} (known: mcl, dead_reckoning, ekf_slam, cgr_laser, cgr_depth, landmark_filter, wifi)"),
        )),
    }
}
