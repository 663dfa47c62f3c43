//! A map from a real log (`atrium map build`): every scan placed at the reference pose of its
//! stamp (the base pose composed with the laser's mount) and integrated into a log-odds
//! occupancy grid with ray-traced free space ([Thrun 2005] §9.2, in
//! `atrium_localization::occupancy_mapping`), cut to the cells any beam reached.
//!
//! Scans the reference does not cover (no reference pose within
//! [`REFERENCE_MAX_GAP_S`](crate::log::REFERENCE_MAX_GAP_S)) are left out. Beams without a
//! return (read as the scan's `range_max`) are left out too rather than clearing space: a
//! laser also fails to return from near black or glancing surfaces, and clearing along such
//! a beam would erase the wall it missed.

use crate::error::ScenarioError;
use crate::log::RealLog;
use atrium_localization::occupancy_mapping::{MappingParams, OccupancyMapper};
use atrium_worlds::{Cell, OccupancyGrid};
use serde::Serialize;

/// Cells are occupied above this probability and free below this one: map_server's
/// defaults, so the written map reads back as it was built.
pub const OCCUPIED_P: f64 = 0.65;
pub const FREE_P: f64 = 0.196;

/// What went into a map.
#[derive(Debug, Clone, Serialize)]
pub struct MapSummary {
    pub scans_used: usize,
    pub scans_skipped: usize,
    pub beams_used: usize,
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    pub origin: [f64; 2],
    pub occupied_cells: usize,
    pub free_cells: usize,
}

fn logit(p: f64) -> f64 {
    (p / (1.0 - p)).ln()
}

/// The map of `log`'s scans at its reference poses, `resolution` m a cell, beams used up to
/// `max_range` m.
pub fn build_map(
    log: &RealLog,
    resolution: f64,
    max_range: f64,
) -> Result<(OccupancyGrid, MapSummary), ScenarioError> {
    build_map_with_progress(
        log,
        resolution,
        max_range,
        &indicatif::ProgressBar::hidden(),
    )
}

/// [`build_map`], counting the scans inserted on `bar` (see [`crate::progress::counting`];
/// its length is set to the scans the reference covers).
pub fn build_map_with_progress(
    log: &RealLog,
    resolution: f64,
    max_range: f64,
    bar: &indicatif::ProgressBar,
) -> Result<(OccupancyGrid, MapSummary), ScenarioError> {
    let bad = |field: &str, msg: String| ScenarioError::field(&log.path, field, msg);
    if !(resolution.is_finite() && (0.005..=1.0).contains(&resolution)) {
        return Err(bad(
            "--resolution",
            format!("must be between 0.005 and 1 m, got {resolution}"),
        ));
    }
    let placed: Vec<(usize, atrium_robots::Pose2)> = log
        .scans
        .iter()
        .enumerate()
        .filter_map(|(i, s)| log.reference_at(s.stamp).map(|p| (i, p.compose(&s.mount))))
        .collect();
    if placed.is_empty() {
        return Err(bad(
            "reference",
            "covers none of the log's scans: there is nothing to map".into(),
        ));
    }
    let params = MappingParams {
        max_range,
        ..MappingParams::default()
    };
    let poses: Vec<atrium_robots::Pose2> = placed.iter().map(|(_, p)| *p).collect();
    let mut mapper = OccupancyMapper::covering(&poses, 1.0, resolution, params)
        .map_err(|e| bad("--resolution", e.to_string()))?;
    let mut ranges: Vec<f64> = Vec::new();
    let mut beams_used = 0;
    bar.set_length(placed.len() as u64);
    for (i, pose) in &placed {
        bar.inc(1);
        let s = &log.scans[*i];
        ranges.clear();
        ranges.extend(
            s.ranges
                .iter()
                .map(|&r| if r >= s.range_max { f64::NAN } else { r }),
        );
        beams_used += mapper.insert_scan(
            *pose,
            s.angle_min,
            s.angle_increment,
            &ranges,
            s.range_min,
            s.range_max,
        );
    }
    bar.finish_and_clear();
    let grid = crop(&mapper.to_grid(logit(OCCUPIED_P), logit(FREE_P)), 0.5);
    let count = |c: Cell| grid.cells.iter().filter(|x| **x == c).count();
    let summary = MapSummary {
        scans_used: placed.len(),
        scans_skipped: log.scans.len() - placed.len(),
        beams_used,
        resolution,
        width: grid.width,
        height: grid.height,
        origin: grid.origin,
        occupied_cells: count(Cell::Occupied),
        free_cells: count(Cell::Free),
    };
    Ok((grid, summary))
}

/// `grid` cut to the cells that are known, plus `margin` m of unknown around them.
pub fn crop(grid: &OccupancyGrid, margin: f64) -> OccupancyGrid {
    let (mut i0, mut j0, mut i1, mut j1) = (usize::MAX, usize::MAX, 0, 0);
    for j in 0..grid.height {
        for i in 0..grid.width {
            if grid.cells[j * grid.width + i] != Cell::Unknown {
                i0 = i0.min(i);
                j0 = j0.min(j);
                i1 = i1.max(i);
                j1 = j1.max(j);
            }
        }
    }
    if i0 == usize::MAX {
        return grid.clone();
    }
    let m = (margin / grid.resolution).ceil() as usize;
    let (i0, j0) = (i0.saturating_sub(m), j0.saturating_sub(m));
    let (i1, j1) = ((i1 + m).min(grid.width - 1), (j1 + m).min(grid.height - 1));
    let (w, h) = (i1 - i0 + 1, j1 - j0 + 1);
    let mut cells = Vec::with_capacity(w * h);
    for j in j0..=j1 {
        cells.extend_from_slice(&grid.cells[j * grid.width + i0..=j * grid.width + i1]);
    }
    // Rounded to the nanometre, so that the YAML reads -25.15, not -25.150000000000002.
    let nm = |v: f64| (v * 1e9).round() / 1e9;
    OccupancyGrid {
        origin: [
            nm(grid.origin[0] + i0 as f64 * grid.resolution),
            nm(grid.origin[1] + j0 as f64 * grid.resolution),
        ],
        resolution: grid.resolution,
        width: w,
        height: h,
        cells,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crop_keeps_the_known_cells_in_place() {
        let mut cells = vec![Cell::Unknown; 10 * 8];
        cells[3 * 10 + 4] = Cell::Occupied;
        cells[5 * 10 + 6] = Cell::Free;
        let g = OccupancyGrid {
            origin: [1.0, 2.0],
            resolution: 0.5,
            width: 10,
            height: 8,
            cells,
        };
        let c = crop(&g, 0.5);
        assert_eq!((c.width, c.height), (5, 5));
        assert_eq!(c.origin, [1.0 + 3.0 * 0.5, 2.0 + 2.0 * 0.5]);
        assert_eq!(c.at(g.cell_center(4, 3)), Cell::Occupied);
        assert_eq!(c.at(g.cell_center(6, 5)), Cell::Free);
    }
}
