//! How far each cell's robot drove, and whether its cells can be compared on error.
//!
//! A trial ends at the scenario's `duration_s` or when the route is done. Position errors
//! depend on how far the robot drove (odometry's drift grows with distance) and where (an
//! open atrium's far end, which a cut-short trial never reaches), so two cells whose trials
//! end on the clock after different distances (a robot that waits for people drives less)
//! differ in error for that reason alone, whatever the axis does to the localizers. The sweep
//! records each trial's `distance_m` and `route_completed` (results.csv) and says so when its
//! cells drove unlike drives.

use super::csv::{self, Results};
use atrium_scenarios::metrics::ErrorStats;
use std::collections::{BTreeMap, BTreeSet};

/// Cells whose median distances differ by more than this fraction of the larger are called
/// unlike drives.
pub const DISTANCE_SPREAD: f64 = 0.1;

/// One cell's drives over its trials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellDrive {
    pub trials: usize,
    /// Min, median and max over trials of the distance driven, m.
    pub min_m: f64,
    pub median_m: f64,
    pub max_m: f64,
    /// Trials that completed their route.
    pub completed: usize,
}

/// Per cell, its trials' drives; empty for files without the distance columns.
pub fn per_cell(results: &Results) -> BTreeMap<usize, CellDrive> {
    let mut seen = BTreeSet::new();
    let mut trials: BTreeMap<usize, (Vec<f64>, usize)> = BTreeMap::new();
    for r in &results.rows {
        let (Some(d), Some(done)) = (csv::distance_m(r), csv::route_completed(r)) else {
            continue;
        };
        // Every localizer's row of a trial holds the same drive: count the trial once.
        if !seen.insert((r.cell, r.trial)) {
            continue;
        }
        let cell = trials.entry(r.cell).or_default();
        cell.0.push(d);
        cell.1 += usize::from(done);
    }
    trials
        .into_iter()
        .filter_map(|(cell, (d, completed))| {
            let s = ErrorStats::of(d)?;
            let drive = CellDrive {
                trials: s.samples,
                min_m: s.min,
                median_m: s.median,
                max_m: s.max,
                completed,
            };
            Some((cell, drive))
        })
        .collect()
}

/// The warning a sweep prints when its cells drove unlike drives: median distances more
/// than [`DISTANCE_SPREAD`] apart, or routes completed in some cell's trials and not in
/// another's. `None` when the cells are comparable (or fewer than two have drives).
pub fn unlike_drives(drives: &BTreeMap<usize, CellDrive>) -> Option<String> {
    if drives.len() < 2 {
        return None;
    }
    let median = |c: &(&usize, &CellDrive)| c.1.median_m;
    let lo = drives
        .iter()
        .min_by(|a, b| median(a).total_cmp(&median(b)))?;
    let hi = drives
        .iter()
        .max_by(|a, b| median(a).total_cmp(&median(b)))?;
    let all_done = drives.values().all(|d| d.completed == d.trials);
    let none_done = drives.values().all(|d| d.completed == 0);
    if median(&hi) - median(&lo) <= DISTANCE_SPREAD * median(&hi) && (all_done || none_done) {
        return None;
    }
    let said = |(cell, d): (&usize, &CellDrive)| {
        format!(
            "cell {cell}: {:.1} m, route completed in {}/{} trials",
            d.median_m, d.completed, d.trials
        )
    };
    Some(format!(
        "the cells drove unlike drives (median distance per trial, {}; {}): errors depend on \
         how far and where the robot drove, so a cell whose trials were cut short scores the \
         errors of part of the route only. Compare cells with results.csv's distance_m and \
         route_completed in view, or give the trials a duration that lets every route \
         complete.",
        said(lo),
        said(hi)
    ))
}

/// The drive line of a cell in `summary.md`.
pub fn markdown_line(d: &CellDrive) -> String {
    format!(
        "Distance driven per trial: {:.1} m median ({:.1}–{:.1}); route completed in {} of {} \
         trials.\n\n",
        d.median_m, d.min_m, d.max_m, d.completed, d.trials
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::csv::Row;

    fn results(trials: &[(usize, usize, f64, bool)]) -> Results {
        let rows = trials
            .iter()
            .flat_map(|&(cell, trial, d, done)| {
                ["mcl", "odometry"].map(|l| Row {
                    params: vec![cell.to_string()],
                    cell,
                    trial,
                    seed: 1,
                    localizer: l.into(),
                    values: ["0", "1", "1", "1", "1", "1", "", "true", "0.1"]
                        .iter()
                        .map(|s| s.to_string())
                        .chain([format!("{d}"), done.to_string(), "1.0".into()])
                        .collect(),
                })
            })
            .collect();
        Results {
            hash: "h".into(),
            name: "n".into(),
            layout: None,
            axis_paths: vec!["people.density".into()],
            rows,
            dropped_partial: false,
        }
    }

    #[test]
    fn each_trial_counts_once_and_cells_get_their_quantiles() {
        let r = results(&[
            (0, 0, 100.0, true),
            (0, 1, 112.0, true),
            (0, 2, 104.0, false),
            (1, 0, 43.0, false),
        ]);
        let d = per_cell(&r);
        assert_eq!(
            d[&0],
            CellDrive {
                trials: 3,
                min_m: 100.0,
                median_m: 104.0,
                max_m: 112.0,
                completed: 2
            }
        );
        assert_eq!(d[&1].trials, 1);
        assert_eq!(d[&1].completed, 0);
    }

    #[test]
    fn unlike_distances_or_completions_are_named_and_like_ones_are_not() {
        // The atrium_people shape: the crowded cell drove 43 m of a 112 m route.
        let crowded = results(&[(0, 0, 112.0, true), (1, 0, 43.0, false)]);
        let w = unlike_drives(&per_cell(&crowded)).unwrap();
        assert!(
            w.contains("cell 1: 43.0 m") && w.contains("cell 0: 112.0 m"),
            "{w}"
        );
        // Within 10 %, all completed: comparable.
        let like = results(&[(0, 0, 112.0, true), (1, 0, 104.0, true)]);
        assert_eq!(unlike_drives(&per_cell(&like)), None);
        // Within 10 %, none completed (all end on the clock): comparable.
        let clock = results(&[(0, 0, 60.0, false), (1, 0, 58.0, false)]);
        assert_eq!(unlike_drives(&per_cell(&clock)), None);
        // Same distance, but one cell's route was cut short where the other's completed.
        let mixed = results(&[(0, 0, 112.0, true), (1, 0, 111.0, false)]);
        assert!(unlike_drives(&per_cell(&mixed)).is_some());
        // One cell, or a file without the columns: nothing to compare.
        assert_eq!(
            unlike_drives(&per_cell(&results(&[(0, 0, 5.0, false)]))),
            None
        );
        let mut old = crowded.clone();
        for r in &mut old.rows {
            r.values.drain(9..11);
        }
        assert!(per_cell(&old).is_empty());
        assert_eq!(unlike_drives(&per_cell(&old)), None);
    }
}
