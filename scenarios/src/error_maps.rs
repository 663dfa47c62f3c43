//! Filling per-location error maps ([`ErrorMap`], [004] §3 Figure 2)
//! from finished runs: every scored instant adds each localizer's position error to the cell
//! of the robot's true position.

use crate::runner::RunResult;
use crate::scenario::Scenario;
use atrium_localization::error_map::ErrorMap;

/// An empty map over the scenario's world bounds with one layer per localizer of the scenario.
pub fn empty_for(scenario: &Scenario, resolution: f64) -> Result<ErrorMap, String> {
    let (min, max) = scenario.world.bounds();
    ErrorMap::new(
        min,
        max,
        resolution,
        scenario.localizers.iter().map(|l| l.name.clone()).collect(),
    )
}

/// Adds every scored instant of `result` to `map` (localizers the map has no layer for are
/// skipped). Returns the number of samples added.
pub fn accumulate(map: &mut ErrorMap, result: &RunResult) -> usize {
    let mut added = 0;
    for run in &result.localizers {
        let Some(layer) = map.localizer_index(&run.name) else {
            continue;
        };
        for ((_, truth), sample) in result.ground_truth.iter().zip(&run.samples) {
            if map.add(layer, [truth.x, truth.y], sample.position_error) {
                added += 1;
            }
        }
    }
    added
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{run_scenario, RunOptions};

    #[test]
    fn a_run_fills_the_cells_it_drove_through() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("corridor_tracking.toml");
        let mut scenario = Scenario::load(&path).unwrap();
        scenario.duration_s = scenario.duration_s.min(10.0);
        let result = run_scenario(&scenario, RunOptions::default()).unwrap();
        let mut map = empty_for(&scenario, 1.0).unwrap();
        let added = accumulate(&mut map, &result);
        let per_localizer = result.ground_truth.len();
        assert_eq!(added, per_localizer * scenario.localizers.len());
        // The start cell holds samples of every localizer, a far corner none.
        let s = scenario.start;
        for l in 0..map.localizers.len() {
            assert!(map.mean_at(l, [s.x, s.y]).is_some());
            assert!(map
                .mean_at(l, [map.origin[0] + 0.5, map.origin[1] + 0.5])
                .is_none());
        }
    }
}
