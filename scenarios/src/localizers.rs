//! The localizers a scenario can name (`[[localizers]] kind = ...`) and how each is built.

use crate::error::ScenarioError;
use crate::scenario::{InitialBelief, LocalizerSpec, Scenario};
use atrium_localization::{
    dead_reckoning::DeadReckoning,
    mcl::{InitialBelief as MclBelief, Mcl, MclMap, MclParams},
    Localizer,
};
use atrium_worlds::OccupancyGrid;
use std::sync::Arc;

/// Maps exported from the world and shared by the localizers that need them: within a run,
/// and through [`crate::map_cache`] with every other run in the process that holds the same
/// map at the time (a sweep's trials). Holding a `SharedMaps` keeps its maps alive.
#[derive(Default)]
pub struct SharedMaps {
    /// The world as JSON: the key part naming the world (computed once).
    world_key: Option<String>,
    grid: Option<Arc<OccupancyGrid>>,
    vector: Option<Arc<atrium_worlds::VectorMap>>,
    /// MCL likelihood fields built so far, by key.
    mcl: Vec<(String, Arc<MclMap>)>,
}

impl SharedMaps {
    fn world_key(&mut self, scenario: &Scenario) -> String {
        self.world_key
            .get_or_insert_with(|| serde_json::to_string(&scenario.world).unwrap_or_default())
            .clone()
    }

    /// The vector map (wall faces and pillars as segments; glass per `[map] include_glass`).
    pub fn vector_map(&mut self, scenario: &Scenario) -> &atrium_worlds::VectorMap {
        let v = match &self.vector {
            Some(v) => v.clone(),
            None => {
                let glass = scenario.map.include_glass;
                let key = format!("vector_map\n{}\n{glass}", self.world_key(scenario));
                let built = crate::map_cache::shared(key, || {
                    Ok::<_, std::convert::Infallible>(scenario.world.vector_map(glass))
                });
                match built {
                    Ok(v) => v,
                    Err(never) => match never {},
                }
            }
        };
        self.vector.insert(v)
    }

    /// The occupancy grid of the scenario's `[map]` settings.
    pub fn occupancy_grid(&mut self, scenario: &Scenario) -> &OccupancyGrid {
        let g = self.shared_grid(scenario);
        self.grid.insert(g)
    }

    fn shared_grid(&mut self, scenario: &Scenario) -> Arc<OccupancyGrid> {
        if let Some(g) = &self.grid {
            return g.clone();
        }
        let (res, glass) = (scenario.map.resolution, scenario.map.include_glass);
        let key = format!(
            "occupancy_grid\n{}\n{res}\n{glass}",
            self.world_key(scenario)
        );
        let built = crate::map_cache::shared(key, || {
            Ok::<_, std::convert::Infallible>(scenario.world.occupancy_grid(res, glass))
        });
        match built {
            Ok(g) => g,
            Err(never) => match never {},
        }
    }

    /// The likelihood field and free cells an MCL filter with `params` needs, built for the
    /// range of the scenario's first laser (so the filter need not rebuild its table).
    pub fn mcl_map(
        &mut self,
        scenario: &Scenario,
        params: &MclParams,
    ) -> Result<Arc<MclMap>, atrium_localization::LocalizationError> {
        let range_max = scenario.lasers.first().map_or(8.0, |l| l.range_max);
        let grid = self.shared_grid(scenario);
        self.grid = Some(grid.clone());
        let key = format!(
            "mcl_map\n{}\n{}\n{}\n{:?}\n{range_max}",
            self.world_key(scenario),
            scenario.map.resolution,
            scenario.map.include_glass,
            [
                params.z_hit,
                params.z_rand,
                params.sigma_hit,
                params.max_dist,
                params.grid_resolution
            ]
        );
        if let Some((_, m)) = self.mcl.iter().find(|(k, _)| *k == key) {
            return Ok(m.clone());
        }
        let map = crate::map_cache::shared(key.clone(), || MclMap::new(&grid, params, range_max))?;
        self.mcl.push((key, map.clone()));
        Ok(map)
    }
}

/// The seed of the localizer named `name` in a run seeded `run_seed`. A chooser's member gets
/// the seed of the stand-alone localizer of the same name, so the two see the same random
/// draws and a comparison between them is paired (common random numbers).
pub fn localizer_seed(run_seed: u64, name: &str) -> u64 {
    crate::seeds::derive_seed(run_seed, &format!("localizer/{name}"))
}

/// Builds the localizer a scenario names, seeded by [`localizer_seed`] from the run's seed.
/// Each kind takes its parameters from the `[[localizers]]` table (checked here, errors name
/// the field) and its map from `maps`.
pub fn build_localizer(
    spec: &LocalizerSpec,
    scenario: &Scenario,
    maps: &mut SharedMaps,
    run_seed: u64,
) -> Result<Box<dyn Localizer>, ScenarioError> {
    let seed = localizer_seed(run_seed, &spec.name);
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
            let map = maps
                .mcl_map(scenario, &params)
                .map_err(|e| ScenarioError::field(file, &field, e.to_string()))?;
            let init = match &scenario.initial_belief {
                InitialBelief::Tracking { sigma } => MclBelief::Tracking {
                    pose: scenario.start,
                    sigma: *sigma,
                },
                InitialBelief::Global { polygons } => MclBelief::Global {
                    regions: polygons.clone(),
                },
            };
            let mcl = Mcl::with_map(&spec.name, params, &map, init, seed)
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
        "appearance" => crate::appearance_localizers::build(spec, scenario, seed),
        "ceiling_mcl" => crate::camera_localizers::build_ceiling_mcl(spec, scenario, seed),
        "omni" => crate::camera_localizers::build_omni(spec, scenario, seed),
        "chooser" | "fused" => crate::chooser_localizers::build(spec, scenario, maps, run_seed),
        "landmark_filter" => crate::node_experiment::train_landmark_filter(spec, scenario),
        "wifi" => {
            let grid = maps.occupancy_grid(scenario);
            crate::wifi_training::build_wifi_localizer(spec, scenario, grid, seed)
        }
        other => Err(ScenarioError::field(
            file,
            format!("{field}.kind"),
            format!("unknown localizer kind {other:?} (known: mcl, dead_reckoning, ekf_slam, cgr_laser, cgr_depth, landmark_filter, wifi, chooser, fused, appearance, ceiling_mcl, omni)"),
        )),
    }
}
