//! Where a robot can be: the free space of an occupancy grid, less the outside of the building.
//!
//! The WiFi localizer of [004] §2.3 builds on graph-based WiFi localization
//! ("fast, accurate robot localization when constrained to a graph"): its particles live on
//! the navigation graph, never in walls or outside the building. Our WiFi graph is a regular
//! lattice over the whole map, so the constraint comes from the occupancy grid instead: a
//! particle must stay in the building's free space.
//! Without it, a cloud near an outer wall can leave the building, where the graph is clamped
//! (flat likelihood) and nothing pulls it back: it then follows odometry for good.
//!
//! "Outside" is the free space connected to the grid's border (the grid has a margin around
//! the world): a flood fill from the border. A map without any enclosed free space (an open
//! test room) has no outside we could tell, and all its free space counts.

use atrium_worlds::{Cell, OccupancyGrid};

/// Mask cells are about this size (m): fine enough to keep 0.1 m walls, small to build.
const MASK_CELL: f64 = 0.05;
/// Projection targets lie on a lattice of about this spacing (m).
const ANCHOR_SPACING: f64 = 0.25;

/// The building's free space on a mask grid, with a nearest-free-position lookup.
#[derive(Debug, Clone)]
pub struct FreeSpace {
    origin: [f64; 2],
    res: f64,
    width: usize,
    height: usize,
    /// Per mask cell: free and inside the building.
    inside: Vec<bool>,
    /// Mask cells per lookup block (each side).
    block: usize,
    bw: usize,
    bh: usize,
    /// Per lookup block: index into `anchors` of the inside position nearest the block's
    /// centre (a vector distance transform over blocks).
    nearest: Vec<u32>,
    /// Inside positions, at most one per block (the inside mask cell nearest its centre).
    anchors: Vec<[f64; 2]>,
}

impl FreeSpace {
    /// The inside free space of `grid`. A mask cell is free only if every grid cell it covers
    /// is Free, so walls never get thinner.
    pub fn from_grid(grid: &OccupancyGrid) -> FreeSpace {
        let k = ((MASK_CELL / grid.resolution).floor() as usize).max(1);
        let res = k as f64 * grid.resolution;
        let (width, height) = (grid.width / k, grid.height / k);
        let inside = inside_mask(grid, k, width, height);
        let block = ((ANCHOR_SPACING / res).round() as usize).max(1);
        let blocks = Blocks {
            origin: grid.origin,
            res,
            width,
            height,
            block,
            bw: width.div_ceil(block).max(1),
            bh: height.div_ceil(block).max(1),
        };
        let (anchors, mut nearest) = blocks.anchors(&inside);
        blocks.propagate_nearest(&anchors, &mut nearest);
        FreeSpace {
            origin: grid.origin,
            res,
            width,
            height,
            inside,
            block,
            bw: blocks.bw,
            bh: blocks.bh,
            nearest,
            anchors,
        }
    }

    /// True when the map has no inside free space at all (nothing to constrain to).
    pub fn is_empty(&self) -> bool {
        self.anchors.is_empty()
    }

    /// Inside positions on a lattice of about 0.25 m (one per lookup block).
    pub fn anchors(&self) -> &[[f64; 2]] {
        &self.anchors
    }

    /// Spacing of the anchor lattice, m.
    pub fn anchor_spacing(&self) -> f64 {
        self.block as f64 * self.res
    }

    /// Whether (x, y) lies in the building's free space. Off the grid is outside.
    #[inline]
    pub fn contains(&self, x: f64, y: f64) -> bool {
        let fi = (x - self.origin[0]) / self.res;
        let fj = (y - self.origin[1]) / self.res;
        if !(fi >= 0.0 && fj >= 0.0 && fi < self.width as f64 && fj < self.height as f64) {
            return false;
        }
        self.inside[fj as usize * self.width + fi as usize]
    }

    /// Whether the straight path from `a` to `b` stays inside: no wall crossed, the building
    /// not left. Sampled every half mask cell, so every wall of the map (at least one mask
    /// cell thick) is hit. Allocation-free.
    #[inline]
    pub fn path_clear(&self, a: [f64; 2], b: [f64; 2]) -> bool {
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len = dx.hypot(dy);
        if !len.is_finite() {
            return false;
        }
        let n = (len / (0.5 * self.res)).ceil() as usize;
        (0..=n).all(|s| {
            let t = if n == 0 { 0.0 } else { s as f64 / n as f64 };
            self.contains(a[0] + t * dx, a[1] + t * dy)
        })
    }

    /// (x, y) itself when inside, else the anchor nearest the centre of its lookup block: an
    /// inside position within about a block (0.25 m) of the nearest one. Positions off the grid
    /// are clamped onto it first. None for an empty free space.
    #[inline]
    pub fn project(&self, x: f64, y: f64) -> Option<[f64; 2]> {
        if self.contains(x, y) {
            return Some([x, y]);
        }
        if self.anchors.is_empty() {
            return None;
        }
        let span = self.block as f64 * self.res;
        let cell = |v: f64, o: f64, n: usize| -> usize {
            let f = ((v - o) / span).floor();
            if f.is_nan() || f < 0.0 {
                0
            } else {
                (f as usize).min(n - 1)
            }
        };
        let bi = cell(x, self.origin[0], self.bw);
        let bj = cell(y, self.origin[1], self.bh);
        Some(self.anchors[self.nearest[bj * self.bw + bi] as usize])
    }
}

/// The inside mask of `grid` on cells of `k` × `k` grid cells (`width` × `height` of them):
/// a mask cell is free only if every grid cell it covers is Free, and inside when it is free
/// and not reached from the border (all free cells when none is enclosed).
fn inside_mask(grid: &OccupancyGrid, k: usize, width: usize, height: usize) -> Vec<bool> {
    // 0: blocked, 1: free (not yet reached from the border), 2: free, outside.
    let mut state = vec![0u8; width * height];
    for mj in 0..height {
        for mi in 0..width {
            let free = (0..k).all(|dj| {
                let row = (mj * k + dj) * grid.width;
                (0..k).all(|di| grid.cells[row + mi * k + di] == Cell::Free)
            });
            if free {
                state[mj * width + mi] = 1;
            }
        }
    }
    // Flood fill (4-connected) from every free border cell: the outside.
    let mut stack: Vec<u32> = Vec::new();
    let seed = |c: usize, state: &mut [u8], stack: &mut Vec<u32>| {
        if state[c] == 1 {
            state[c] = 2;
            stack.push(c as u32);
        }
    };
    for i in 0..width {
        seed(i, &mut state, &mut stack);
        seed(
            (height.saturating_sub(1)) * width + i,
            &mut state,
            &mut stack,
        );
    }
    for j in 0..height {
        seed(j * width, &mut state, &mut stack);
        seed(j * width + width.saturating_sub(1), &mut state, &mut stack);
    }
    while let Some(c) = stack.pop() {
        let c = c as usize;
        let (i, j) = (c % width, c / width);
        if i > 0 {
            seed(c - 1, &mut state, &mut stack);
        }
        if i + 1 < width {
            seed(c + 1, &mut state, &mut stack);
        }
        if j > 0 {
            seed(c - width, &mut state, &mut stack);
        }
        if j + 1 < height {
            seed(c + width, &mut state, &mut stack);
        }
    }
    let enclosed = state.contains(&1);
    state
        .iter()
        .map(|&s| s == 1 || (!enclosed && s == 2))
        .collect()
}

/// The mask's lookup blocks: `block` mask cells a side, `bw` × `bh` of them.
struct Blocks {
    origin: [f64; 2],
    res: f64,
    width: usize,
    height: usize,
    block: usize,
    bw: usize,
    bh: usize,
}

impl Blocks {
    /// Per block, the inside mask cell nearest its centre as an anchor; and per block the
    /// index of its own anchor (`u32::MAX` for a block with none).
    fn anchors(&self, inside: &[bool]) -> (Vec<[f64; 2]>, Vec<u32>) {
        let Blocks {
            origin,
            res,
            width,
            height,
            block,
            bw,
            bh,
        } = *self;
        let mut anchors = Vec::new();
        let mut nearest = vec![u32::MAX; bw * bh];
        for bj in 0..bh {
            for bi in 0..bw {
                let (ci, cj) = (bi * block + block / 2, bj * block + block / 2);
                let mut best: Option<(usize, usize, usize)> = None;
                for mj in bj * block..((bj + 1) * block).min(height) {
                    for mi in bi * block..((bi + 1) * block).min(width) {
                        if inside[mj * width + mi] {
                            let d = mi.abs_diff(ci).pow(2) + mj.abs_diff(cj).pow(2);
                            if best.is_none_or(|b| d < b.0) {
                                best = Some((d, mi, mj));
                            }
                        }
                    }
                }
                if let Some((_, mi, mj)) = best {
                    nearest[bj * bw + bi] = anchors.len() as u32;
                    anchors.push([
                        origin[0] + (mi as f64 + 0.5) * res,
                        origin[1] + (mj as f64 + 0.5) * res,
                    ]);
                }
            }
        }
        (anchors, nearest)
    }

    /// Gives every block the anchor nearest its centre.
    fn propagate_nearest(&self, anchors: &[[f64; 2]], nearest: &mut [u32]) {
        let Blocks {
            origin,
            bw,
            bh,
            block,
            res,
            ..
        } = *self;
        // Nearest anchor of every block by propagating anchor ids between neighbours, each
        // block keeping the candidate nearest (Euclidean) to its centre: two raster passes
        // (down-right, then up-left), repeated once. This is the vector distance transform
        // (Danielsson 1980); its rare errors are a fraction of a block.
        let span = block as f64 * res;
        let centre = |b: usize| {
            [
                origin[0] + ((b % bw) as f64 + 0.5) * span,
                origin[1] + ((b / bw) as f64 + 0.5) * span,
            ]
        };
        let dist2 = |b: usize, a: u32| {
            let (c, p) = (centre(b), anchors[a as usize]);
            (c[0] - p[0]).powi(2) + (c[1] - p[1]).powi(2)
        };
        let relax = |b: usize, nb: usize, nearest: &mut [u32]| {
            let cand = nearest[nb];
            if cand != u32::MAX && (nearest[b] == u32::MAX || dist2(b, cand) < dist2(b, nearest[b]))
            {
                nearest[b] = cand;
            }
        };
        if !anchors.is_empty() {
            for _ in 0..2 {
                for bj in 0..bh {
                    for bi in 0..bw {
                        let b = bj * bw + bi;
                        if bi > 0 {
                            relax(b, b - 1, nearest);
                        }
                        if bj > 0 {
                            relax(b, b - bw, nearest);
                            if bi > 0 {
                                relax(b, b - bw - 1, nearest);
                            }
                            if bi + 1 < bw {
                                relax(b, b - bw + 1, nearest);
                            }
                        }
                    }
                }
                for bj in (0..bh).rev() {
                    for bi in (0..bw).rev() {
                        let b = bj * bw + bi;
                        if bi + 1 < bw {
                            relax(b, b + 1, nearest);
                        }
                        if bj + 1 < bh {
                            relax(b, b + bw, nearest);
                            if bi + 1 < bw {
                                relax(b, b + bw + 1, nearest);
                            }
                            if bi > 0 {
                                relax(b, b + bw - 1, nearest);
                            }
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 10 × 6 m box of 0.1 m walls (centre lines x 0 and 10, y 0 and 6) split by an inner
    /// wall at x = 5 with a 1 m door at y ∈ [2.5, 3.5], on a 0.02 m grid with a 1 m margin.
    fn building() -> OccupancyGrid {
        let res = 0.02;
        let origin = [-1.0, -1.0];
        let (w, h) = (600, 400);
        let mut cells = vec![Cell::Free; w * h];
        for j in 0..h {
            for i in 0..w {
                let x = origin[0] + (i as f64 + 0.5) * res;
                let y = origin[1] + (j as f64 + 0.5) * res;
                let in_box = (-0.05..=10.05).contains(&x) && (-0.05..=6.05).contains(&y);
                let outer = in_box
                    && (x.abs() <= 0.05
                        || (x - 10.0).abs() <= 0.05
                        || y.abs() <= 0.05
                        || (y - 6.0).abs() <= 0.05);
                let inner = (x - 5.0).abs() <= 0.05 && !(2.5..=3.5).contains(&y) && in_box;
                if outer || inner {
                    cells[j * w + i] = Cell::Occupied;
                }
            }
        }
        OccupancyGrid {
            origin,
            resolution: res,
            width: w,
            height: h,
            cells,
        }
    }

    #[test]
    fn the_outside_margin_and_the_walls_are_not_inside() {
        let fs = FreeSpace::from_grid(&building());
        assert!(fs.contains(2.0, 3.0) && fs.contains(8.0, 1.0) && fs.contains(5.0, 3.0));
        // The margin is free in the grid but outside the building.
        assert!(!fs.contains(-0.5, 3.0) && !fs.contains(5.0, 6.6));
        // Walls and off the grid.
        assert!(!fs.contains(5.0, 1.0) && !fs.contains(0.0, 3.0) && !fs.contains(50.0, 3.0));
        // Every anchor is inside; the lattice is about 0.25 m.
        assert!(fs.anchors().iter().all(|a| fs.contains(a[0], a[1])));
        let area = fs.anchors().len() as f64 * 0.24 * 0.24;
        assert!((55.0..66.0).contains(&area), "{area}");
    }

    #[test]
    fn paths_through_walls_are_blocked_and_doors_are_not() {
        let fs = FreeSpace::from_grid(&building());
        assert!(fs.path_clear([4.0, 1.0], [4.9, 1.0]));
        assert!(!fs.path_clear([4.0, 1.0], [6.0, 1.0]));
        assert!(fs.path_clear([4.0, 3.0], [6.0, 3.0]));
        assert!(!fs.path_clear([9.0, 3.0], [11.0, 3.0]));
        assert!(!fs.path_clear([9.0, 3.0], [f64::NAN, 3.0]));
    }

    #[test]
    fn projection_returns_the_nearest_inside_position() {
        let fs = FreeSpace::from_grid(&building());
        assert_eq!(fs.project(2.0, 3.0), Some([2.0, 3.0]));
        for (p, near) in [
            ([-0.6, 3.0], [0.05, 3.0]),
            ([3.0, 6.8], [3.0, 5.95]),
            ([40.0, -20.0], [9.95, 0.05]),
            ([5.0, 1.0], [5.0, 1.0]),
        ] {
            let q = fs.project(p[0], p[1]).unwrap();
            assert!(fs.contains(q[0], q[1]), "{p:?} -> {q:?}");
            let d = (q[0] - near[0]).hypot(q[1] - near[1]);
            assert!(d < 0.4, "{p:?} -> {q:?}, expected near {near:?}");
        }
    }

    #[test]
    fn an_open_map_counts_all_its_free_space() {
        let grid = OccupancyGrid {
            origin: [0.0, 0.0],
            resolution: 0.1,
            width: 50,
            height: 50,
            cells: vec![Cell::Free; 2500],
        };
        let fs = FreeSpace::from_grid(&grid);
        assert!(fs.contains(0.05, 0.05) && fs.contains(4.9, 2.0));
        assert!(!fs.contains(5.1, 2.0));
        assert!(!fs.is_empty());
    }
}
