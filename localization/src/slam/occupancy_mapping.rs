//! Occupancy grid mapping with known poses: log-odds per cell, each laser beam traced through
//! the grid, free along its way and occupied where it ends ([Thrun 2005] §9.2, Table 9.1, with
//! the inverse range sensor model of Table 9.2). Used to build a map from a robot log whose
//! poses are known (ground truth or an optimised pose graph).
//!
//! Per scan, every cell gets at most one update, as in Table 9.1 where each cell in the
//! perceptual field is updated once per measurement: the cells that a beam's end falls in
//! (within `hit_thickness`, Table 9.2's α) get `l_occ`, then every other cell crossed by a
//! beam before its end gets `l_free`; a cell that is both the end of one beam and crossed by
//! another is occupied. The prior is p = 0.5 (l₀ = 0), and values are
//! clamped to `[l_min, l_max]` so that the map can still change after many scans.
//!
//! Beams are traced with the exact grid traversal of [Amanatides 1987]: every cell the beam
//! passes through over a positive length, in order, none counted twice (the cell the beam
//! ends in is the one its end point falls in, so rounding at a cell edge can only drop a
//! sliver of the last cell).
//!
//! Ranges: NaN and readings below `range_min` (including −∞) are skipped. A reading at or
//! beyond the usable maximum (the smaller of [`MappingParams::max_range`] and the scan's
//! `range_max`, including +∞ for "no return") says there is nothing up to that maximum:
//! its cells up to the maximum are cleared and no cell is marked occupied (Table 9.2's
//! `z < z_max` condition for `l_occ`, `r ≤ z` for `l_free`).

use atrium_robots::Pose2;
use atrium_worlds::{Cell, GridSize, OccupancyGrid};

use crate::error::LocalizationError;

/// Largest grid the mapper allocates: 8 bytes a cell (an f32 log-odds, a u32 scan stamp),
/// 400 MB at the limit; 50 m × 50 m at 2 cm is 6.25 million cells.
pub const MAPPING_MAX_CELLS: u64 = 50_000_000;

/// The inverse sensor model and its limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MappingParams {
    /// Log-odds added to a cell where a beam ends (> 0).
    pub l_occ: f64,
    /// Log-odds added to a cell a beam passes through (< 0).
    pub l_free: f64,
    /// Clamps of a cell's log-odds (`l_min < 0 < l_max`).
    pub l_min: f64,
    pub l_max: f64,
    /// Beams at or beyond this range (metres, > 0) only clear free space up to it.
    pub max_range: f64,
    /// α of [Thrun 2005] Table 9.2, metres (≥ 0): the cells crossed within ±α/2 of a beam's
    /// end are occupied. 0 marks the one cell the end falls in.
    pub hit_thickness: f64,
}

impl Default for MappingParams {
    /// p = 0.7 for a hit, 0.4 for a pass, clamped to p ∈ [0.12, 0.97]; 30 m beams; α = 0.
    fn default() -> Self {
        let logit = |p: f64| (p / (1.0 - p)).ln();
        MappingParams {
            l_occ: logit(0.7),
            l_free: logit(0.4),
            l_min: logit(0.12),
            l_max: logit(0.97),
            max_range: 30.0,
            hit_thickness: 0.0,
        }
    }
}

impl MappingParams {
    fn validate(&self) -> Result<(), LocalizationError> {
        let bad = |msg: String| Err(LocalizationError::InvalidParameter(msg));
        if !(self.l_occ.is_finite() && self.l_occ > 0.0) {
            return bad(format!("l_occ must be finite and > 0, got {}", self.l_occ));
        }
        if !(self.l_free.is_finite() && self.l_free < 0.0) {
            return bad(format!(
                "l_free must be finite and < 0, got {}",
                self.l_free
            ));
        }
        if !(self.l_min.is_finite() && self.l_min < 0.0) {
            return bad(format!("l_min must be finite and < 0, got {}", self.l_min));
        }
        if !(self.l_max.is_finite() && self.l_max > 0.0) {
            return bad(format!("l_max must be finite and > 0, got {}", self.l_max));
        }
        if !(self.max_range.is_finite() && self.max_range > 0.0) {
            return bad(format!(
                "max_range must be finite and > 0, got {}",
                self.max_range
            ));
        }
        if !(self.hit_thickness.is_finite() && self.hit_thickness >= 0.0) {
            return bad(format!(
                "hit_thickness must be finite and >= 0, got {}",
                self.hit_thickness
            ));
        }
        Ok(())
    }
}

/// The frame of a grid that covers every point within `max_range + margin` of the poses, its
/// origin on a multiple of `resolution` (so grids of the same resolution share a lattice).
pub fn grid_covering(
    poses: &[Pose2],
    max_range: f64,
    margin: f64,
    resolution: f64,
) -> Result<GridSize, LocalizationError> {
    let bad = |msg: String| Err(LocalizationError::InvalidParameter(msg));
    if !(resolution.is_finite() && resolution > 0.0) {
        return bad(format!(
            "resolution must be finite and > 0, got {resolution}"
        ));
    }
    if !(max_range.is_finite() && max_range >= 0.0 && margin.is_finite() && margin >= 0.0) {
        return bad(format!(
            "max_range and margin must be finite and >= 0, got {max_range} and {margin}"
        ));
    }
    if poses.is_empty() {
        return bad("no poses to cover".into());
    }
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for (k, p) in poses.iter().enumerate() {
        if !p.is_finite() {
            return bad(format!("pose {k} is not finite: {p:?}"));
        }
        lo = [lo[0].min(p.x), lo[1].min(p.y)];
        hi = [hi[0].max(p.x), hi[1].max(p.y)];
    }
    let reach = max_range + margin;
    // The tolerances keep a bound that is a whole number of cells (-14 / 0.1) from growing a
    // cell of rounding error.
    let origin = [
        ((lo[0] - reach) / resolution + 1e-9).floor() * resolution,
        ((lo[1] - reach) / resolution + 1e-9).floor() * resolution,
    ];
    let width = ((hi[0] + reach - origin[0]) / resolution - 1e-9)
        .ceil()
        .max(1.0);
    let height = ((hi[1] + reach - origin[1]) / resolution - 1e-9)
        .ceil()
        .max(1.0);
    if width * height > MAPPING_MAX_CELLS as f64 {
        return bad(format!(
            "a grid covering the poses at {resolution} m would be {width} x {height} cells, \
             more than the limit of {MAPPING_MAX_CELLS} (MAPPING_MAX_CELLS)"
        ));
    }
    Ok(GridSize {
        origin,
        resolution,
        width: width as usize,
        height: height as usize,
    })
}

/// A log-odds occupancy grid under construction; see the module documentation.
#[derive(Debug, Clone)]
pub struct OccupancyMapper {
    frame: Frame,
    params: MappingParams,
    /// Per cell, `j * width + i`.
    cells: Vec<MapCell>,
    /// 0: never observed; 1: observed before the current numbering; `2s` / `2s + 1`: marked
    /// occupied / free by scan `s`.
    scan: u32,
}

/// A cell's log-odds and stamp side by side, so that an update touches one cache line.
#[derive(Debug, Clone, Copy, Default)]
struct MapCell {
    log_odds: f32,
    stamp: u32,
}

/// The grid's lattice, copied out so that traversal can borrow the cells mutably.
#[derive(Debug, Clone, Copy)]
struct Frame {
    origin: [f64; 2],
    resolution: f64,
    width: usize,
    height: usize,
}

impl OccupancyMapper {
    /// An empty (all unknown) map: cell (i, j) covers x ∈ [origin.x + i·res, origin.x +
    /// (i+1)·res), y likewise, as in [`OccupancyGrid`].
    pub fn new(
        origin: [f64; 2],
        resolution: f64,
        width: usize,
        height: usize,
        params: MappingParams,
    ) -> Result<Self, LocalizationError> {
        params.validate()?;
        let bad = |msg: String| Err(LocalizationError::InvalidParameter(msg));
        if !(resolution.is_finite() && resolution > 0.0) {
            return bad(format!(
                "resolution must be finite and > 0, got {resolution}"
            ));
        }
        if !(origin[0].is_finite() && origin[1].is_finite()) {
            return bad(format!("origin must be finite, got {origin:?}"));
        }
        let cells = width as u128 * height as u128;
        if cells == 0 || cells > MAPPING_MAX_CELLS as u128 {
            return bad(format!(
                "grid of {width} x {height} cells: must have between 1 and {MAPPING_MAX_CELLS} \
                 cells (MAPPING_MAX_CELLS)"
            ));
        }
        let n = cells as usize;
        Ok(OccupancyMapper {
            frame: Frame {
                origin,
                resolution,
                width,
                height,
            },
            params,
            cells: vec![MapCell::default(); n],
            scan: 0,
        })
    }

    /// A map over [`grid_covering`] the poses with `params.max_range` plus `margin`.
    pub fn covering(
        poses: &[Pose2],
        margin: f64,
        resolution: f64,
        params: MappingParams,
    ) -> Result<Self, LocalizationError> {
        params.validate()?;
        let g = grid_covering(poses, params.max_range, margin, resolution)?;
        Self::new(g.origin, g.resolution, g.width, g.height, params)
    }

    /// The grid's frame and size.
    pub fn size(&self) -> GridSize {
        GridSize {
            origin: self.frame.origin,
            resolution: self.frame.resolution,
            width: self.frame.width,
            height: self.frame.height,
        }
    }

    pub fn params(&self) -> &MappingParams {
        &self.params
    }

    /// The log-odds of cell (i, j), `None` outside the grid or if no beam has reached it.
    pub fn log_odds(&self, i: usize, j: usize) -> Option<f64> {
        if i >= self.frame.width || j >= self.frame.height {
            return None;
        }
        let k = j * self.frame.width + i;
        let c = self.cells[k];
        (c.stamp != 0).then(|| f64::from(c.log_odds))
    }

    /// Integrates one laser scan taken from `laser_pose_in_world` (the laser's own frame, beam
    /// k at bearing `angle_min + k · angle_increment` from its x axis). Returns how many beams
    /// were used; nothing is integrated when the pose or the angles are not finite. Does not
    /// allocate.
    pub fn insert_scan(
        &mut self,
        laser_pose_in_world: Pose2,
        angle_min: f64,
        angle_increment: f64,
        ranges: &[f64],
        range_min: f64,
        range_max: f64,
    ) -> usize {
        if !(laser_pose_in_world.is_finite()
            && angle_min.is_finite()
            && angle_increment.is_finite())
        {
            return 0;
        }
        let usable_max = if range_max.is_finite() && range_max > 0.0 {
            self.params.max_range.min(range_max)
        } else {
            self.params.max_range
        };
        let range_min = if range_min.is_finite() {
            range_min
        } else {
            0.0
        };
        self.next_scan();
        let occ_tag = 2 * self.scan;
        let free_tag = occ_tag + 1;
        let frame = self.frame;
        let params = self.params;
        let half_alpha = 0.5 * params.hit_thickness;
        let (l_occ, l_free) = (params.l_occ as f32, params.l_free as f32);
        let (l_min, l_max) = (params.l_min as f32, params.l_max as f32);
        let p = laser_pose_in_world;
        let beam = |k: usize| {
            let (s, c) = (p.theta + angle_min + k as f64 * angle_increment).sin_cos();
            (c, s)
        };
        // Which beams count, and how far each one reaches: (range, hit?).
        let classify = |r: f64| -> Option<(f64, bool)> {
            if r.is_nan() || r < range_min {
                None
            } else if r >= usable_max {
                Some((usable_max, false))
            } else {
                Some((r, true))
            }
        };

        // Pass 1: the ends of the beams that hit something.
        let mut used = 0;
        for (k, &r) in ranges.iter().enumerate() {
            let Some((r, hit)) = classify(r) else {
                continue;
            };
            used += 1;
            if !hit {
                continue;
            }
            let (c, s) = beam(k);
            let mut mark = |cell: usize| {
                let c = &mut self.cells[cell];
                if c.stamp != occ_tag {
                    c.stamp = occ_tag;
                    c.log_odds = (c.log_odds + l_occ).clamp(l_min, l_max);
                }
            };
            if let Some(cell) = frame.cell_of([p.x + r * c, p.y + r * s]) {
                mark(cell);
            }
            if half_alpha > 0.0 {
                let (t0, t1) = ((r - half_alpha).max(0.0), r + half_alpha);
                frame.traverse([p.x, p.y], [c, s], t0, t1, |cell, t_in, t_out| {
                    if t_out > t_in {
                        mark(cell);
                    }
                });
            }
        }
        // Pass 2: free space up to each beam's end (or band of ends).
        for (k, &r) in ranges.iter().enumerate() {
            let Some((r, hit)) = classify(r) else {
                continue;
            };
            let end = if hit { r - half_alpha } else { r };
            if end <= 0.0 {
                continue;
            }
            let (c, s) = beam(k);
            frame.traverse([p.x, p.y], [c, s], 0.0, end, |cell, t_in, t_out| {
                let c = &mut self.cells[cell];
                if t_out > t_in && c.stamp != occ_tag && c.stamp != free_tag {
                    c.stamp = free_tag;
                    c.log_odds = (c.log_odds + l_free).clamp(l_min, l_max);
                }
            });
        }
        used
    }

    /// Starts a new scan's stamps, renumbering when the counter would overflow.
    fn next_scan(&mut self) {
        if self.scan >= u32::MAX / 2 - 1 {
            for c in self.cells.iter_mut() {
                if c.stamp != 0 {
                    c.stamp = 1;
                }
            }
            self.scan = 0;
        }
        self.scan += 1;
    }

    /// The map as an occupancy grid: Occupied where the log-odds is above `occupied_above`,
    /// Free where it is below `free_below`, Unknown in between and where no beam has reached.
    pub fn to_grid(&self, occupied_above: f64, free_below: f64) -> OccupancyGrid {
        let cells = self
            .cells
            .iter()
            .map(|c| {
                let l = f64::from(c.log_odds);
                if c.stamp == 0 {
                    Cell::Unknown
                } else if l > occupied_above {
                    Cell::Occupied
                } else if l < free_below {
                    Cell::Free
                } else {
                    Cell::Unknown
                }
            })
            .collect();
        OccupancyGrid {
            origin: self.frame.origin,
            resolution: self.frame.resolution,
            width: self.frame.width,
            height: self.frame.height,
            cells,
        }
    }
}

impl Frame {
    /// Index of the cell containing `p`, if it is in the grid.
    #[inline]
    fn cell_of(&self, p: [f64; 2]) -> Option<usize> {
        let fi = ((p[0] - self.origin[0]) / self.resolution).floor();
        let fj = ((p[1] - self.origin[1]) / self.resolution).floor();
        let inside = fi >= 0.0 && fj >= 0.0 && fi < self.width as f64 && fj < self.height as f64;
        inside.then(|| fj as usize * self.width + fi as usize)
    }

    /// Calls `visit(cell, t_in, t_out)` for every grid cell the ray `start + t · dir` (`dir` a
    /// unit vector, t in metres) meets for t ∈ [t0, t1], in order, with the part of [t0, t1]
    /// inside the cell; `t_in == t_out` when the ray only touches a cell's corner or the
    /// interval is a point. The part of the ray outside the grid is skipped. [Amanatides
    /// 1987]
    fn traverse(
        &self,
        start: [f64; 2],
        dir: [f64; 2],
        t0: f64,
        t1: f64,
        mut visit: impl FnMut(usize, f64, f64),
    ) {
        let res = self.resolution;
        // Grid units: cell (i, j) is [i, i+1) x [j, j+1); t stays in metres.
        let g = [
            (start[0] - self.origin[0]) / res,
            (start[1] - self.origin[1]) / res,
        ];
        let size = [self.width as f64, self.height as f64];
        // Clip [t0, t1] to the grid box (slabs).
        let (mut lo, mut hi) = (t0, t1);
        for a in 0..2 {
            let d = dir[a] / res;
            if d == 0.0 {
                if !(g[a] >= 0.0 && g[a] < size[a]) {
                    return;
                }
            } else {
                let ta = (0.0 - g[a]) / d;
                let tb = (size[a] - g[a]) / d;
                lo = lo.max(ta.min(tb));
                hi = hi.min(ta.max(tb));
            }
        }
        // NaN (from a non-finite input) compares false too.
        if lo.partial_cmp(&hi).is_none_or(|o| o.is_gt()) {
            return;
        }
        let at = |t: f64, a: usize| g[a] + t * dir[a] / res;
        // Per axis: first cell, cell of the end point, step, offset of a step in `cells`,
        // parameter of the next boundary crossing and between crossings.
        let mut first = [0usize; 2];
        let mut steps = [0usize; 2];
        let mut offset = [0isize; 2];
        let mut t_max = [f64::INFINITY; 2];
        let mut t_delta = [f64::INFINITY; 2];
        let stride = [1isize, self.width as isize];
        for a in 0..2 {
            let x = at(lo, a);
            // Entry and end points can sit on the far edge of the box by rounding.
            let c = x.floor().clamp(0.0, size[a] - 1.0);
            let e = at(hi, a).floor().clamp(0.0, size[a] - 1.0);
            first[a] = c as usize;
            steps[a] = (e - c).abs() as usize;
            let d = dir[a] / res;
            if d > 0.0 {
                offset[a] = stride[a];
                t_delta[a] = 1.0 / d;
                t_max[a] = lo + (c + 1.0 - x) / d;
            } else if d < 0.0 {
                offset[a] = -stride[a];
                t_delta[a] = -1.0 / d;
                t_max[a] = lo + (c - x) / d;
            }
            if steps[a] == 0 {
                t_max[a] = f64::INFINITY;
            }
        }
        // Exactly `steps[a]` steps along each axis (between the first and the end cell), so
        // the index never leaves the grid; an axis out of steps is not stepped again. Where
        // rounding disagrees with the end cell, the walk stops a rounding-sized sliver early
        // or visits cells with t_in == t_out == hi.
        let mut index = (first[1] * self.width + first[0]) as isize;
        let mut t_in = lo;
        let mut left = steps;
        for _ in 0..steps[0] + steps[1] {
            // Branch-free choice of the axis: it is a coin flip for a diagonal beam.
            let a = usize::from(t_max[1] < t_max[0]);
            if left[a] == 0 {
                // Only if both axes are out of steps, which the loop count rules out.
                return;
            }
            let next = t_max[a];
            let t_out = if next < hi { next } else { hi };
            let t_out = if t_out > t_in { t_out } else { t_in };
            visit(index as usize, t_in, t_out);
            index += offset[a];
            left[a] -= 1;
            t_max[a] = if left[a] == 0 {
                f64::INFINITY
            } else {
                t_max[a] + t_delta[a]
            };
            t_in = t_out;
        }
        visit(index as usize, t_in, hi.max(t_in));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::f64::consts::PI;

    const RES: f64 = 0.05;
    /// The room's inner faces at ±2.025 m: the middle of a cell column/row of a grid with
    /// origin (-3, -3) at 5 cm, so that beam ends fall well inside the wall cells.
    const HALF: f64 = 2.025;

    fn mapper() -> OccupancyMapper {
        OccupancyMapper::new([-3.0, -3.0], RES, 120, 120, MappingParams::default()).unwrap()
    }

    /// Distance from `p` along `dir` to the square room's walls.
    fn room_range(p: [f64; 2], dir: [f64; 2]) -> f64 {
        let mut t = f64::INFINITY;
        for a in 0..2 {
            if dir[a] > 0.0 {
                t = t.min((HALF - p[a]) / dir[a]);
            } else if dir[a] < 0.0 {
                t = t.min((-HALF - p[a]) / dir[a]);
            }
        }
        t
    }

    fn room_scan(pose: Pose2, beams: usize) -> (f64, f64, Vec<f64>) {
        let angle_min = -PI;
        let inc = 2.0 * PI / beams as f64;
        let ranges = (0..beams)
            .map(|k| {
                let a = pose.theta + angle_min + k as f64 * inc;
                room_range([pose.x, pose.y], [a.cos(), a.sin()])
            })
            .collect();
        (angle_min, inc, ranges)
    }

    #[test]
    fn square_room_gives_occupied_walls_and_free_inside() {
        let mut m = mapper();
        for pose in [
            Pose2::new(0.3, -0.2, 0.4),
            Pose2::new(-1.0, 1.0, -2.0),
            Pose2::new(1.2, 1.1, 3.0),
        ] {
            let (a0, inc, ranges) = room_scan(pose, 360);
            assert_eq!(m.insert_scan(pose, a0, inc, &ranges, 0.05, 20.0), 360);
        }
        let g = m.to_grid(0.5, -0.2);
        let (mut wall, mut wall_occupied, mut inside, mut inside_free) = (0, 0, 0, 0);
        for j in 0..g.height {
            for i in 0..g.width {
                let c = g.cell_center(i, j);
                let cell = g.cells[g.index(i, j)];
                let inf = c[0].abs().max(c[1].abs());
                if (inf - HALF).abs() < 0.5 * RES {
                    // A wall cell: beam ends fall in it; a grazing beam may also cross it.
                    wall += 1;
                    wall_occupied += usize::from(cell == Cell::Occupied);
                } else if inf < HALF {
                    assert_ne!(cell, Cell::Occupied, "{c:?} inside the room");
                    inside += 1;
                    inside_free += usize::from(cell == Cell::Free);
                } else {
                    // No beam goes beyond the walls.
                    assert_eq!(cell, Cell::Unknown, "{c:?} outside the room");
                }
            }
        }
        // 82 cell centres from -2.025 to 2.025 on each side, corners shared.
        assert_eq!(wall, 4 * 82 - 4);
        println!("room: {wall_occupied} of {wall} wall cells occupied, {inside_free} of {inside} inside free");
        assert!(wall_occupied as f64 > 0.8 * wall as f64, "{wall_occupied}");
        assert!(
            inside_free as f64 > 0.98 * inside as f64,
            "{inside_free} of {inside}"
        );
    }

    #[test]
    fn max_range_beam_marks_no_occupied_cell() {
        let params = MappingParams {
            max_range: 1.0,
            ..Default::default()
        };
        let mut m = OccupancyMapper::new([-3.0, -3.0], RES, 120, 120, params).unwrap();
        let pose = Pose2::new(0.025, 0.025, 0.0);
        // At the parameter's maximum, beyond it, and a "no return" +inf.
        let n = m.insert_scan(pose, 0.0, PI / 2.0, &[1.0, 4.0, f64::INFINITY], 0.0, 10.0);
        assert_eq!(n, 3);
        let g = m.to_grid(0.0, 0.0);
        assert!(!g.cells.contains(&Cell::Occupied));
        // Beam 0 along +x cleared x ∈ [0.025, 1.025): cells 60..80 of row 60.
        for i in 60..=80 {
            assert_eq!(g.cells[g.index(i, 60)], Cell::Free, "{i}");
        }
        assert_eq!(g.cells[g.index(81, 60)], Cell::Unknown);
        // Beam 1 along +y stopped at 1 m too, beam 2 along -x likewise.
        assert_eq!(g.cells[g.index(60, 80)], Cell::Free);
        assert_eq!(g.cells[g.index(60, 81)], Cell::Unknown);
        assert_eq!(g.cells[g.index(40, 60)], Cell::Free);
        assert_eq!(g.cells[g.index(39, 60)], Cell::Unknown);
        // The scan's range_max is the maximum when it is smaller.
        let mut m = OccupancyMapper::new([-3.0, -3.0], RES, 120, 120, params).unwrap();
        m.insert_scan(pose, -PI / 2.0, 0.0, &[0.5], 0.0, 0.5);
        let g = m.to_grid(0.0, 0.0);
        assert!(!g.cells.contains(&Cell::Occupied));
        // Along -y from y = 0.025 to -0.475: rows 50..=60.
        assert_eq!(g.cells.iter().filter(|&&c| c == Cell::Free).count(), 11);
    }

    #[test]
    fn hit_and_invalid_ranges() {
        let mut m = mapper();
        let pose = Pose2::new(0.025, 0.025, PI / 2.0);
        // Along +y: a hit at 0.5 m; NaN, below range_min and -inf are skipped.
        let used = m.insert_scan(
            pose,
            0.0,
            0.1,
            &[0.5, f64::NAN, 0.01, f64::NEG_INFINITY],
            0.02,
            10.0,
        );
        assert_eq!(used, 1);
        let p = MappingParams::default();
        // Cell rows 60..69 free (y from 0.025 to 0.5), row 70 (y ∈ [0.5, 0.55)) occupied.
        for j in 60..70 {
            assert!((m.log_odds(60, j).unwrap() - p.l_free).abs() < 1e-6, "{j}");
        }
        assert!((m.log_odds(60, 70).unwrap() - p.l_occ).abs() < 1e-6);
        assert_eq!(m.log_odds(60, 71), None);
        assert_eq!(m.log_odds(61, 65), None);
        assert_eq!(m.log_odds(500, 0), None);
        // Non-finite pose: nothing.
        assert_eq!(
            m.insert_scan(Pose2::new(f64::NAN, 0.0, 0.0), 0.0, 0.1, &[1.0], 0.0, 5.0),
            0
        );
    }

    #[test]
    fn hit_thickness_widens_the_occupied_band() {
        let params = MappingParams {
            hit_thickness: 0.2,
            ..Default::default()
        };
        let mut m = OccupancyMapper::new([-3.0, -3.0], RES, 120, 120, params).unwrap();
        // Along +x from the middle of cell 60: end at x = 1.025, band x ∈ [0.925, 1.125].
        m.insert_scan(Pose2::new(0.025, 0.025, 0.0), 0.0, 0.0, &[1.0], 0.0, 10.0);
        let g = m.to_grid(0.0, 0.0);
        let row: Vec<Cell> = (55..=85).map(|i| g.cells[g.index(i, 60)]).collect();
        // Cells 60..=77 free (x < 0.9), 78..=82 occupied (x ∈ [0.9, 1.15) meets the band; cell
        // 78 straddles its start), beyond unknown.
        for (k, c) in row.iter().enumerate() {
            let i = 55 + k;
            let want = match i {
                60..=77 => Cell::Free,
                78..=82 => Cell::Occupied,
                _ => Cell::Unknown,
            };
            assert_eq!(*c, want, "cell {i}");
        }
    }

    #[test]
    fn log_odds_are_clamped_and_a_cell_is_updated_once_per_scan() {
        let mut m = mapper();
        let p = MappingParams::default();
        let pose = Pose2::new(0.025, 0.025, 0.0);
        // 50 identical beams in one scan count once.
        m.insert_scan(pose, 0.0, 0.0, &[1.0; 50], 0.0, 10.0);
        assert!((m.log_odds(80, 60).unwrap() - p.l_occ).abs() < 1e-6);
        assert!((m.log_odds(70, 60).unwrap() - p.l_free).abs() < 1e-6);
        for _ in 0..20 {
            m.insert_scan(pose, 0.0, 0.0, &[1.0], 0.0, 10.0);
        }
        assert!((m.log_odds(80, 60).unwrap() - p.l_max).abs() < 1e-6);
        assert!((m.log_odds(70, 60).unwrap() - p.l_min).abs() < 1e-6);
        // A beam through a cell another beam of the same scan ends in leaves it occupied.
        let mut m = mapper();
        m.insert_scan(pose, 0.0, 0.0, &[0.5, 1.0], 0.0, 10.0);
        assert!((m.log_odds(70, 60).unwrap() - p.l_occ).abs() < 1e-6);
    }

    #[test]
    fn traversal_matches_dense_sampling() {
        let m = OccupancyMapper::new([-1.3, 0.7], 0.1, 37, 23, MappingParams::default()).unwrap();
        let f = m.frame;
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut visited = Vec::new();
        for _ in 0..500 {
            // Starts inside and outside the grid, any direction.
            let s = [rng.random_range(-2.5..3.5), rng.random_range(-0.5..4.0)];
            let a: f64 = rng.random_range(-PI..PI);
            let d = [a.cos(), a.sin()];
            let len = rng.random_range(0.0..6.0);
            visited.clear();
            let mut last_t = f64::NEG_INFINITY;
            f.traverse(s, d, 0.0, len, |cell, t_in, t_out| {
                assert!(t_in <= t_out && t_in >= last_t - 1e-12);
                last_t = t_out;
                if t_out > t_in {
                    visited.push(cell);
                }
            });
            let mut sorted = visited.clone();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), visited.len(), "a cell visited twice");
            // Every sampled point's cell is visited (except within rounding of an edge).
            let n = 4000;
            for k in 0..=n {
                let t = len * k as f64 / n as f64;
                let p = [s[0] + t * d[0], s[1] + t * d[1]];
                let gx = (p[0] - f.origin[0]) / f.resolution;
                let gy = (p[1] - f.origin[1]) / f.resolution;
                if (gx - gx.round()).abs() < 1e-6 || (gy - gy.round()).abs() < 1e-6 {
                    continue;
                }
                if let Some(cell) = f.cell_of(p) {
                    assert!(visited.contains(&cell), "{s:?} {a} {len}: {p:?}");
                }
            }
            // ... and every visited cell holds some point of the segment: consecutive cells
            // are edge neighbours.
            for w in visited.windows(2) {
                let (i0, j0) = (w[0] % f.width, w[0] / f.width);
                let (i1, j1) = (w[1] % f.width, w[1] / f.width);
                assert_eq!(i0.abs_diff(i1) + j0.abs_diff(j1), 1, "{s:?} {a}");
            }
        }
    }

    #[test]
    fn covering_grid_and_bad_parameters() {
        let poses = [Pose2::new(1.0, 2.0, 0.0), Pose2::new(-3.0, 5.5, 1.0)];
        let g = grid_covering(&poses, 10.0, 1.0, 0.1).unwrap();
        // x from -14 to 12, y from -9 to 16.5: 260 x 255 cells.
        assert!((g.origin[0] + 14.0).abs() < 1e-9 && (g.origin[1] + 9.0).abs() < 1e-9);
        assert_eq!((g.width, g.height), (260, 255));
        let m = OccupancyMapper::covering(&poses, 1.0, 0.1, MappingParams::default()).unwrap();
        // Reach 30 + 1 m: x from -34 to 32.
        assert_eq!(m.size().width, 660);
        assert!(grid_covering(&[], 10.0, 1.0, 0.1).is_err());
        assert!(grid_covering(&[Pose2::new(f64::NAN, 0.0, 0.0)], 1.0, 1.0, 0.1).is_err());
        assert!(grid_covering(&poses, 10.0, 1.0, 0.0).is_err());
        let e = grid_covering(&poses, 1e4, 0.0, 0.01)
            .unwrap_err()
            .to_string();
        assert!(e.contains("MAPPING_MAX_CELLS"), "{e}");
        let bad = |p: MappingParams| OccupancyMapper::new([0.0; 2], 0.1, 10, 10, p).is_err();
        let d = MappingParams::default();
        assert!(bad(MappingParams { l_occ: 0.0, ..d }));
        assert!(bad(MappingParams { l_free: 0.1, ..d }));
        assert!(bad(MappingParams {
            l_max: f64::NAN,
            ..d
        }));
        assert!(bad(MappingParams {
            max_range: 0.0,
            ..d
        }));
        assert!(bad(MappingParams {
            hit_thickness: -1.0,
            ..d
        }));
        assert!(OccupancyMapper::new([0.0; 2], 0.1, 0, 10, d).is_err());
        assert!(OccupancyMapper::new([0.0; 2], -0.1, 10, 10, d).is_err());
    }

    /// 5,000 scans of 360 beams in a 20 m x 12 m room at 5 cm; run with
    /// `cargo test --release -p atrium-localization --lib occupancy_mapping -- --ignored`.
    #[test]
    #[ignore = "timing; run in release"]
    fn timing_5000_scans_of_360_beams() {
        let (hx, hy) = (10.0, 6.0);
        let range = |p: [f64; 2], d: [f64; 2]| {
            let tx = if d[0] > 0.0 {
                (hx - p[0]) / d[0]
            } else {
                (-hx - p[0]) / d[0]
            };
            let ty = if d[1] > 0.0 {
                (hy - p[1]) / d[1]
            } else {
                (-hy - p[1]) / d[1]
            };
            tx.min(ty)
        };
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let scans: Vec<(Pose2, Vec<f64>)> = (0..5000)
            .map(|_| {
                let pose = Pose2::new(
                    rng.random_range(-9.0..9.0),
                    rng.random_range(-5.0..5.0),
                    rng.random_range(-PI..PI),
                );
                let ranges = (0..360)
                    .map(|k| {
                        let a = pose.theta - PI + k as f64 * PI / 180.0;
                        range([pose.x, pose.y], [a.cos(), a.sin()])
                    })
                    .collect();
                (pose, ranges)
            })
            .collect();
        let mut m =
            OccupancyMapper::new([-11.0, -7.0], RES, 440, 280, MappingParams::default()).unwrap();
        let t = std::time::Instant::now();
        for (pose, ranges) in &scans {
            m.insert_scan(*pose, -PI, PI / 180.0, ranges, 0.02, 30.0);
        }
        let dt = t.elapsed();
        let g = m.to_grid(0.5, -0.5);
        let occ = g.cells.iter().filter(|&&c| c == Cell::Occupied).count();
        // Cells a beam of length r at bearing a crosses: about r (|cos a| + |sin a|) / res + 1.
        let visits: f64 = scans
            .iter()
            .flat_map(|(pose, ranges)| {
                ranges.iter().enumerate().map(move |(k, r)| {
                    let a = pose.theta - PI + k as f64 * PI / 180.0;
                    r * (a.cos().abs() + a.sin().abs()) / RES + 1.0
                })
            })
            .sum();
        println!(
            "5000 x 360 beams: {:.3} s ({:.1} us/scan, {:.1} ns per cell crossed of {:.3e}), \
             {occ} occupied cells",
            dt.as_secs_f64(),
            dt.as_secs_f64() * 1e6 / 5000.0,
            dt.as_secs_f64() * 1e9 / visits,
            visits
        );
    }
}
