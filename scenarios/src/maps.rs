//! Maps the localizers of a run derive from its world, built once and shared.

use crate::scenario::Scenario;
use atrium_localization::mcl::{MclMap, MclParams};
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
