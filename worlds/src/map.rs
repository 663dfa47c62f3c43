//! Maps a localizer may be given. They are exports of a [`crate::World`], never the
//! simulator's scene.

use serde::{Deserialize, Serialize};

use crate::error::MapError;
use crate::geometry::{
    convex_overlap, distance, point_box_distance, regular_polygon, wall_corners,
    wall_signed_distance, P2,
};
use crate::world::World;

/// A line segment in the floor plane, metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    pub a: [f64; 2],
    pub b: [f64; 2],
}

/// The vector map: the outline of every wall face and pillar as line segments.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct VectorMap {
    pub segments: Vec<Segment>,
}

/// Occupancy of one grid cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Cell {
    Free,
    Occupied,
    Unknown,
}

/// A 2D occupancy grid. Cell (i, j) covers x ∈ [origin.x + i·res, origin.x + (i+1)·res),
/// y likewise with j; cells are stored row-major with j (y) as the row: `cells[j * width + i]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    pub origin: [f64; 2],
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    pub cells: Vec<Cell>,
}

/// The frame and size of an occupancy grid, known before it is built
/// ([`World::grid_size`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSize {
    pub origin: [f64; 2],
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
}

impl GridSize {
    /// Number of cells (one byte each in an [`OccupancyGrid`]).
    pub fn cells(&self) -> u64 {
        self.width as u64 * self.height as u64
    }
}

/// Pillars enter the vector map as regular polygons with this many sides.
pub const PILLAR_SIDES: usize = 16;
/// Margin around the world's bounds in an occupancy grid, metres.
pub const GRID_MARGIN: f64 = 1.0;
/// Largest occupancy grid `occupancy_grid` builds (one byte per cell).
pub const MAX_GRID_CELLS: usize = 200_000_000;
/// A solid must overlap a cell by more than this (metres) to occupy it, so that a wall face
/// lying exactly on a cell edge does not spill into the neighbouring cell.
const TOUCH_TOLERANCE: f64 = 1e-9;

impl World {
    /// The outline of every wall footprint (4 segments each) and pillar (a 16-gon). Glass is
    /// left out when `include_glass` is false, as in a map built from laser scans.
    pub fn vector_map(&self, include_glass: bool) -> VectorMap {
        let mut segments = Vec::new();
        for w in &self.walls {
            if !include_glass && self.is_glass(&w.material) {
                continue;
            }
            let c = wall_corners(w.a, w.b, w.thickness);
            for k in 0..4 {
                segments.push(Segment {
                    a: c[k],
                    b: c[(k + 1) % 4],
                });
            }
        }
        for p in &self.pillars {
            if !include_glass && self.is_glass(&p.material) {
                continue;
            }
            let v: Vec<P2> = regular_polygon(p.center, p.radius, PILLAR_SIDES).collect();
            for k in 0..v.len() {
                segments.push(Segment {
                    a: v[k],
                    b: v[(k + 1) % v.len()],
                });
            }
        }
        VectorMap { segments }
    }

    /// An occupancy grid over the world's bounds plus a 1 m margin. A cell is Occupied when its
    /// centre lies in a solid or a solid passes through it (so walls thinner than a cell still
    /// show), Free otherwise. Glass is left out when `include_glass` is false.
    ///
    /// Infallible for callers that checked [`World::grid_size`] (do that where the resolution
    /// is chosen, e.g. when a scenario is loaded, to report a grid that is too large with its
    /// size). When the resolution is not finite and > 0, the grid would exceed
    /// [`MAX_GRID_CELLS`] or its memory cannot be allocated, the result is an empty grid
    /// (0 × 0, every query Unknown); [`World::try_occupancy_grid`] gives the reason instead.
    pub fn occupancy_grid(&self, resolution: f64, include_glass: bool) -> OccupancyGrid {
        self.try_occupancy_grid(resolution, include_glass)
            .unwrap_or_else(|_| OccupancyGrid {
                origin: self.bounds().0,
                resolution,
                width: 0,
                height: 0,
                cells: Vec::new(),
            })
    }

    /// The frame and size [`World::occupancy_grid`] would have at `resolution`, without
    /// building it: an error for a bad resolution, a world without solids, or a grid of more
    /// than [`MAX_GRID_CELLS`] cells (the error says how many cells it would need and the
    /// finest resolution that fits).
    pub fn grid_size(&self, resolution: f64) -> Result<GridSize, MapError> {
        if !(resolution.is_finite() && resolution > 0.0) {
            return Err(MapError::Resolution(resolution));
        }
        if self.walls.is_empty() && self.pillars.is_empty() {
            return Err(MapError::Empty);
        }
        let (lo, hi) = self.bounds();
        if !lo.iter().chain(&hi).all(|v| v.is_finite()) {
            return Err(MapError::NotFinite { lo, hi });
        }
        let origin = [lo[0] - GRID_MARGIN, lo[1] - GRID_MARGIN];
        let extent = [
            hi[0] - lo[0] + 2.0 * GRID_MARGIN,
            hi[1] - lo[1] + 2.0 * GRID_MARGIN,
        ];
        // The tolerance keeps an extent that is a whole number of cells (6.0 / 0.1 evaluates
        // to 60.000000000000007) from growing a column of rounding error.
        let count = |r: f64| ((extent[0] / r - 1e-9).ceil(), (extent[1] / r - 1e-9).ceil());
        let (wf, hf) = count(resolution);
        if wf * hf > MAX_GRID_CELLS as f64 {
            // Finest resolution that fits: from the area, then up to 3 significant digits
            // (the cell count only falls as the resolution grows).
            let mut r = (extent[0] * extent[1] / MAX_GRID_CELLS as f64).sqrt();
            let fits = |r: f64| {
                let (w, h) = count(r);
                w * h <= MAX_GRID_CELLS as f64
            };
            for _ in 0..1000 {
                if fits(r) || !r.is_finite() {
                    break;
                }
                r *= 1.001;
            }
            // Rounded up to 3 significant digits, as k / 10^n or k · 10^n with k an integer
            // (so that it prints as short as it reads).
            let e = r.log10().floor() as i32 - 2;
            let at = |k: f64| {
                if e < 0 {
                    k / 10f64.powi(-e)
                } else {
                    k * 10f64.powi(e)
                }
            };
            let mut k = if e < 0 {
                (r * 10f64.powi(-e)).ceil()
            } else {
                (r / 10f64.powi(e)).ceil()
            };
            while !fits(at(k)) && k < 1e4 {
                k += 1.0;
            }
            let min_resolution = at(k);
            let sat = |v: f64| {
                if v >= usize::MAX as f64 {
                    usize::MAX
                } else {
                    v as usize
                }
            };
            let (width, height) = (sat(wf), sat(hf));
            return Err(MapError::TooLarge {
                resolution,
                width,
                height,
                cells: width as u128 * height as u128,
                limit: MAX_GRID_CELLS,
                min_resolution,
            });
        }
        Ok(GridSize {
            origin,
            resolution,
            width: wf as usize,
            height: hf as usize,
        })
    }

    /// [`World::occupancy_grid`], with an error for a bad resolution, an oversized grid, a
    /// world without solids, or memory that cannot be allocated.
    pub fn try_occupancy_grid(
        &self,
        resolution: f64,
        include_glass: bool,
    ) -> Result<OccupancyGrid, MapError> {
        let size = self.grid_size(resolution)?;
        let n = size.width * size.height;
        let mut cells = Vec::new();
        // Up to MAX_GRID_CELLS bytes: an allocation failure is an error, not an abort.
        cells
            .try_reserve_exact(n)
            .map_err(|_| MapError::OutOfMemory { cells: n })?;
        cells.resize(n, Cell::Free);
        let mut grid = OccupancyGrid {
            origin: size.origin,
            resolution,
            width: size.width,
            height: size.height,
            cells,
        };

        for w in &self.walls {
            if !include_glass && self.is_glass(&w.material) {
                continue;
            }
            let corners = wall_corners(w.a, w.b, w.thickness);
            let mut bmin = [f64::INFINITY; 2];
            let mut bmax = [f64::NEG_INFINITY; 2];
            for c in corners {
                for k in 0..2 {
                    bmin[k] = bmin[k].min(c[k]);
                    bmax[k] = bmax[k].max(c[k]);
                }
            }
            grid.mark(bmin, bmax, |centre, cmin, cmax| {
                let cell = [cmin, [cmax[0], cmin[1]], cmax, [cmin[0], cmax[1]]];
                wall_signed_distance(centre, w.a, w.b, w.thickness) <= 0.0
                    || convex_overlap(&corners, &cell) > TOUCH_TOLERANCE
            });
        }
        for p in &self.pillars {
            if !include_glass && self.is_glass(&p.material) {
                continue;
            }
            let bmin = [p.center[0] - p.radius, p.center[1] - p.radius];
            let bmax = [p.center[0] + p.radius, p.center[1] + p.radius];
            grid.mark(bmin, bmax, |centre, cmin, cmax| {
                distance(centre, p.center) <= p.radius
                    || point_box_distance(p.center, cmin, cmax) < p.radius - TOUCH_TOLERANCE
            });
        }
        Ok(grid)
    }
}

impl OccupancyGrid {
    /// Marks Unknown every Free cell outside the building: those a 4-connected walk over Free
    /// cells reaches from the grid's border (its margin lies outside every wall). When that
    /// walk reaches one of the `inside` points (the building is open to the outside, so the
    /// walk entered it), nothing is marked. Returns how many cells became Unknown.
    pub fn mark_outside_unknown(&mut self, inside: &[P2]) -> usize {
        let (w, h) = (self.width, self.height);
        if w == 0 || h == 0 {
            return 0;
        }
        let mut outside = vec![false; w * h];
        let mut stack = Vec::new();
        let visit = |i: usize, j: usize, outside: &mut Vec<bool>, stack: &mut Vec<usize>| {
            let k = j * w + i;
            if !outside[k] && self.cells[k] == Cell::Free {
                outside[k] = true;
                stack.push(k);
            }
        };
        for i in 0..w {
            visit(i, 0, &mut outside, &mut stack);
            visit(i, h - 1, &mut outside, &mut stack);
        }
        for j in 0..h {
            visit(0, j, &mut outside, &mut stack);
            visit(w - 1, j, &mut outside, &mut stack);
        }
        while let Some(k) = stack.pop() {
            let (i, j) = (k % w, k / w);
            if i > 0 {
                visit(i - 1, j, &mut outside, &mut stack);
            }
            if i + 1 < w {
                visit(i + 1, j, &mut outside, &mut stack);
            }
            if j > 0 {
                visit(i, j - 1, &mut outside, &mut stack);
            }
            if j + 1 < h {
                visit(i, j + 1, &mut outside, &mut stack);
            }
        }
        let reached_inside = inside.iter().any(|&p| {
            let i = ((p[0] - self.origin[0]) / self.resolution).floor();
            let j = ((p[1] - self.origin[1]) / self.resolution).floor();
            i >= 0.0
                && j >= 0.0
                && (i as usize) < w
                && (j as usize) < h
                && outside[j as usize * w + i as usize]
        });
        if reached_inside {
            return 0;
        }
        let mut n = 0;
        for (c, o) in self.cells.iter_mut().zip(&outside) {
            if *o {
                *c = Cell::Unknown;
                n += 1;
            }
        }
        n
    }

    /// Marks Occupied every cell overlapping the box `[bmin, bmax]` for which
    /// `hit(centre, cell_min, cell_max)` holds.
    fn mark(&mut self, bmin: P2, bmax: P2, hit: impl Fn(P2, P2, P2) -> bool) {
        let Some((i0, j0)) = self.clamped_cell(bmin) else {
            return;
        };
        let Some((i1, j1)) = self.clamped_cell(bmax) else {
            return;
        };
        let r = self.resolution;
        for j in j0..=j1 {
            for i in i0..=i1 {
                let cmin = [self.origin[0] + i as f64 * r, self.origin[1] + j as f64 * r];
                let cmax = [cmin[0] + r, cmin[1] + r];
                if hit(self.cell_center(i, j), cmin, cmax) {
                    let k = self.index(i, j);
                    self.cells[k] = Cell::Occupied;
                }
            }
        }
    }

    fn clamped_cell(&self, p: P2) -> Option<(usize, usize)> {
        if self.width == 0 || self.height == 0 {
            return None;
        }
        let fi = ((p[0] - self.origin[0]) / self.resolution).floor();
        let fj = ((p[1] - self.origin[1]) / self.resolution).floor();
        let i = fi.clamp(0.0, (self.width - 1) as f64) as usize;
        let j = fj.clamp(0.0, (self.height - 1) as f64) as usize;
        Some((i, j))
    }

    /// Position of cell (i, j) in `cells`.
    #[inline]
    pub fn index(&self, i: usize, j: usize) -> usize {
        j * self.width + i
    }

    /// The cell containing `p`, or `None` outside the grid.
    pub fn world_to_cell(&self, p: [f64; 2]) -> Option<(usize, usize)> {
        let fi = ((p[0] - self.origin[0]) / self.resolution).floor();
        let fj = ((p[1] - self.origin[1]) / self.resolution).floor();
        // NaN fails both comparisons, so non-finite points fall out here too.
        let inside = fi >= 0.0 && fj >= 0.0 && fi < self.width as f64 && fj < self.height as f64;
        inside.then_some((fi as usize, fj as usize))
    }

    /// Centre of cell (i, j), metres.
    #[inline]
    pub fn cell_center(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.origin[0] + (i as f64 + 0.5) * self.resolution,
            self.origin[1] + (j as f64 + 0.5) * self.resolution,
        ]
    }

    /// The cell at `p`; Unknown outside the grid.
    pub fn at(&self, p: [f64; 2]) -> Cell {
        self.world_to_cell(p)
            .and_then(|(i, j)| self.cells.get(self.index(i, j)).copied())
            .unwrap_or(Cell::Unknown)
    }

    /// Binary PGM (P5) in ROS map_server trinary values: 254 free, 0 occupied, 205 unknown.
    /// The first image row is the largest y, as map_server expects.
    pub fn to_pgm(&self) -> Vec<u8> {
        let header = format!("P5\n{} {}\n255\n", self.width, self.height);
        let mut out = Vec::with_capacity(header.len() + self.width * self.height);
        out.extend_from_slice(header.as_bytes());
        for j in (0..self.height).rev() {
            for i in 0..self.width {
                let cell = self
                    .cells
                    .get(self.index(i, j))
                    .copied()
                    .unwrap_or(Cell::Unknown);
                out.push(match cell {
                    Cell::Free => 254,
                    Cell::Occupied => 0,
                    Cell::Unknown => 205,
                });
            }
        }
        out
    }

    /// The map_server YAML for this grid saved as `image_file` by [`Self::to_pgm`].
    /// `free_thresh` is map_saver's 0.196 so that 205 (p = 50/255 ≈ 0.1961) reads as unknown.
    pub fn ros_yaml(&self, image_file: &str) -> String {
        // A JSON string is a valid YAML double-quoted scalar: safe for any file name.
        let image = serde_json::to_string(image_file).unwrap_or_else(|_| "\"\"".into());
        format!(
            "image: {image}\nmode: trinary\nresolution: {}\norigin: [{}, {}, 0.0]\nnegate: 0\n\
             occupied_thresh: 0.65\nfree_thresh: 0.196\n",
            self.resolution, self.origin[0], self.origin[1]
        )
    }
}

impl VectorMap {
    /// One `x1,y1,x2,y2` line per segment; numbers round-trip exactly.
    pub fn to_text(&self) -> String {
        let mut s = String::with_capacity(self.segments.len() * 48);
        for seg in &self.segments {
            s.push_str(&format!(
                "{},{},{},{}\n",
                seg.a[0], seg.a[1], seg.b[0], seg.b[1]
            ));
        }
        s
    }

    /// Parses [`Self::to_text`] output. Blank lines and lines starting with `#` are skipped.
    pub fn from_text(text: &str) -> Result<VectorMap, MapError> {
        let mut segments = Vec::new();
        for (n, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let err = |msg: String| MapError::Text { line: n + 1, msg };
            let mut v = [0.0; 4];
            let mut count = 0;
            for field in line.split(',') {
                if count == 4 {
                    return Err(err(format!(
                        "expected 4 numbers x1,y1,x2,y2, got more: {line:?}"
                    )));
                }
                let x: f64 = field
                    .trim()
                    .parse()
                    .map_err(|_| err(format!("not a number: {:?}", field.trim())))?;
                if !x.is_finite() {
                    return Err(err(format!("not a finite number: {:?}", field.trim())));
                }
                v[count] = x;
                count += 1;
            }
            if count != 4 {
                return Err(err(format!("expected 4 numbers x1,y1,x2,y2, got {count}")));
            }
            segments.push(Segment {
                a: [v[0], v[1]],
                b: [v[2], v[3]],
            });
        }
        Ok(VectorMap { segments })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::{LaserBehaviour, Material, Pillar, Wall};

    /// A 0.2 m concrete wall along y = 0 and a 0.04 m glass wall along y = 2, both x ∈ [0, 4].
    fn two_walls() -> World {
        let wall = |y: f64, thickness: f64, material: &str| Wall {
            a: [0.0, y],
            b: [4.0, y],
            thickness,
            height: 3.0,
            material: material.into(),
        };
        World {
            name: "two".into(),
            ceiling_height: 3.0,
            materials: vec![
                Material {
                    name: "concrete".into(),
                    laser: LaserBehaviour::Opaque,
                    wifi_attenuation_db: 0.0,
                },
                Material {
                    name: "glass".into(),
                    laser: LaserBehaviour::Glass {
                        reflect_within_deg: 5.0,
                    },
                    wifi_attenuation_db: 0.0,
                },
            ],
            walls: vec![wall(0.0, 0.2, "concrete"), wall(2.0, 0.04, "glass")],
            pillars: vec![],
            regions: vec![],
            access_points: vec![],
            wifi: Default::default(),
            boxes: Vec::new(),
            lighting: Default::default(),
        }
    }

    #[test]
    fn grid_extent_and_thin_glass_wall() {
        let w = two_walls();
        let g = w.occupancy_grid(0.1, true);
        // Bounds x ∈ [0, 4], y ∈ [-0.1, 2.02], plus 1 m on each side.
        assert!((g.origin[0] + 1.0).abs() < 1e-12 && (g.origin[1] + 1.1).abs() < 1e-12);
        assert_eq!((g.width, g.height), (60, 42));
        assert_eq!(g.cells.len(), 60 * 42);
        // The glass occupies y ∈ [1.98, 2.02]: it straddles the cell edge at y = 2.0, so rows
        // [1.9, 2.0) and [2.0, 2.1) are occupied although neither centre (1.95, 2.05) is in it.
        for k in 0..40 {
            let x = 0.05 + 0.1 * k as f64;
            assert_eq!(g.at([x, 1.95]), Cell::Occupied, "x = {x}");
            assert_eq!(g.at([x, 2.05]), Cell::Occupied, "x = {x}");
            assert_eq!(g.at([x, 1.85]), Cell::Free, "x = {x}");
            assert_eq!(g.at([x, 2.15]), Cell::Free, "x = {x}");
            // The concrete wall y ∈ [-0.1, 0.1] fills rows [-0.1, 0) and [0, 0.1) exactly;
            // the rows beyond only touch its faces.
            assert_eq!(g.at([x, -0.05]), Cell::Occupied);
            assert_eq!(g.at([x, 0.05]), Cell::Occupied);
            assert_eq!(g.at([x, -0.15]), Cell::Free);
            assert_eq!(g.at([x, 0.15]), Cell::Free);
        }
        // Just past the walls' ends.
        assert_eq!(g.at([4.05, 0.05]), Cell::Free);
        assert_eq!(g.at([-0.05, 2.05]), Cell::Free);
        let occupied = g.cells.iter().filter(|&&c| c == Cell::Occupied).count();
        assert_eq!(occupied, 4 * 40);

        let no_glass = w.occupancy_grid(0.1, false);
        assert_eq!(no_glass.at([2.0, 1.95]), Cell::Free);
        assert_eq!(no_glass.at([2.0, 0.05]), Cell::Occupied);
        assert_eq!(
            no_glass.origin, g.origin,
            "same frame with or without glass"
        );
    }

    #[test]
    fn grid_pillar_disc() {
        let mut w = two_walls();
        w.pillars.push(Pillar {
            center: [1.0, 1.0],
            radius: 0.12,
            height: 3.0,
            material: "concrete".into(),
        });
        let g = w.occupancy_grid(0.1, true);
        // Cells are [k/10, (k+1)/10) offset by the origin (-1, -1.1): columns end on
        // x = 0.9, 1.0, 1.1 and rows on y = 0.9, 1.0, 1.1. The disc of radius 0.12 around
        // (1, 1) reaches into the four cells around (1, 1) and their edge neighbours, not into
        // the diagonal ones (corner distance √2·0.1 = 0.141 > 0.12).
        for (x, y) in [(0.95, 0.95), (1.05, 0.95), (0.95, 1.05), (1.05, 1.05)] {
            assert_eq!(g.at([x, y]), Cell::Occupied, "({x}, {y})");
        }
        for (x, y) in [(0.85, 0.95), (1.15, 1.05), (0.95, 0.85), (1.05, 1.15)] {
            assert_eq!(g.at([x, y]), Cell::Occupied, "({x}, {y})");
        }
        for (x, y) in [(0.85, 0.85), (1.15, 1.15), (0.85, 1.15), (1.15, 0.85)] {
            assert_eq!(g.at([x, y]), Cell::Free, "({x}, {y})");
        }
    }

    #[test]
    fn grid_bad_resolution() {
        let w = two_walls();
        assert_eq!(
            w.try_occupancy_grid(0.0, true),
            Err(MapError::Resolution(0.0))
        );
        assert!(matches!(
            w.try_occupancy_grid(f64::NAN, true),
            Err(MapError::Resolution(r)) if r.is_nan()
        ));
        assert!(matches!(
            w.try_occupancy_grid(1e-5, true),
            Err(MapError::TooLarge { .. })
        ));
        let mut empty = w.clone();
        empty.walls.clear();
        assert_eq!(empty.try_occupancy_grid(0.1, true), Err(MapError::Empty));
        // The infallible form degrades to an empty grid that knows nothing.
        let g = w.occupancy_grid(-0.1, true);
        assert_eq!((g.width, g.height, g.cells.len()), (0, 0, 0));
        assert_eq!(g.at([1.0, 0.0]), Cell::Unknown);
        assert!(g.to_pgm().starts_with(b"P5\n0 0\n255\n"));
    }

    fn grid_3x2() -> OccupancyGrid {
        OccupancyGrid {
            origin: [-1.0, 2.0],
            resolution: 0.5,
            width: 3,
            height: 2,
            // Row j = 0: free, occupied, unknown; row j = 1: occupied, free, free.
            cells: vec![
                Cell::Free,
                Cell::Occupied,
                Cell::Unknown,
                Cell::Occupied,
                Cell::Free,
                Cell::Free,
            ],
        }
    }

    #[test]
    fn grid_indexing() {
        let g = grid_3x2();
        assert_eq!(g.index(2, 1), 5);
        assert_eq!(g.world_to_cell([-1.0, 2.0]), Some((0, 0)));
        assert_eq!(g.world_to_cell([0.49, 2.99]), Some((2, 1)));
        assert_eq!(g.world_to_cell([0.5, 2.5]), None, "x = 0.5 is the far edge");
        assert_eq!(g.world_to_cell([-1.01, 2.5]), None);
        assert_eq!(g.world_to_cell([f64::NAN, 2.5]), None);
        assert_eq!(g.cell_center(1, 1), [-0.25, 2.75]);
        assert_eq!(g.at([-0.3, 2.2]), Cell::Occupied);
        assert_eq!(g.at([0.2, 2.2]), Cell::Unknown);
        assert_eq!(g.at([-0.9, 2.9]), Cell::Occupied);
        assert_eq!(g.at([5.0, 5.0]), Cell::Unknown, "outside");
    }

    #[test]
    fn pgm_is_trinary_with_top_row_first() {
        let pgm = grid_3x2().to_pgm();
        let header = b"P5\n3 2\n255\n";
        assert_eq!(&pgm[..header.len()], header);
        // First image row is j = 1 (largest y), then j = 0.
        assert_eq!(&pgm[header.len()..], &[0, 254, 254, 254, 0, 205]);
    }

    #[test]
    fn ros_yaml_thresholds_classify_the_trinary_values() {
        let yaml = grid_3x2().ros_yaml("campus map.pgm");
        let value = |key: &str| -> String {
            let line = yaml.lines().find(|l| l.starts_with(key)).unwrap();
            line[key.len() + 1..].trim().to_string()
        };
        assert_eq!(value("image"), "\"campus map.pgm\"");
        assert_eq!(value("mode"), "trinary");
        assert_eq!(value("resolution"), "0.5");
        assert_eq!(value("origin"), "[-1, 2, 0.0]");
        assert_eq!(value("negate"), "0");
        let occ: f64 = value("occupied_thresh").parse().unwrap();
        let free: f64 = value("free_thresh").parse().unwrap();
        // map_server: p = (255 - v) / 255; occupied if p > occ, free if p < free.
        let p = |v: u8| (255.0 - v as f64) / 255.0;
        assert!(p(0) > occ);
        assert!(p(254) < free);
        assert!(p(205) >= free && p(205) <= occ, "205 must read as unknown");
    }

    #[test]
    fn vector_map_outlines_and_glass() {
        let mut w = two_walls();
        let with = w.vector_map(true);
        let without = w.vector_map(false);
        assert_eq!(with.segments.len(), 8);
        assert_eq!(without.segments.len(), 4);
        assert_eq!(
            without.segments[0],
            Segment {
                a: [0.0, -0.1],
                b: [4.0, -0.1]
            }
        );
        assert_eq!(without.segments, with.segments[..4]);
        w.pillars.push(Pillar {
            center: [1.0, 1.0],
            radius: 0.2,
            height: 3.0,
            material: "concrete".into(),
        });
        let with_pillar = w.vector_map(false);
        assert_eq!(with_pillar.segments.len(), 4 + PILLAR_SIDES);
        for s in &with_pillar.segments[4..] {
            assert!((distance(s.a, [1.0, 1.0]) - 0.2).abs() < 1e-12);
        }
    }

    #[test]
    fn vector_map_text_round_trip_and_errors() {
        let mut m = two_walls().vector_map(true);
        m.segments.push(Segment {
            a: [0.1 + 0.2, -1e-7],
            b: [1.0 / 3.0, 12345.678],
        });
        let text = m.to_text();
        assert_eq!(text.lines().next(), Some("0,-0.1,4,-0.1"));
        assert_eq!(
            VectorMap::from_text(&text).unwrap(),
            m,
            "round-trips exactly"
        );
        let commented = "# campus\n\n 1, 2 ,3,4 \n";
        assert_eq!(
            VectorMap::from_text(commented).unwrap().segments,
            vec![Segment {
                a: [1.0, 2.0],
                b: [3.0, 4.0]
            }]
        );
        let err = |t: &str| VectorMap::from_text(t).unwrap_err().to_string();
        assert_eq!(
            err("1,2,3,4\n1,2,3\n"),
            "vector map line 2: expected 4 numbers x1,y1,x2,y2, got 3"
        );
        assert_eq!(err("1,2,x,4"), "vector map line 1: not a number: \"x\"");
        assert_eq!(
            err("1,2,3,NaN"),
            "vector map line 1: not a finite number: \"NaN\""
        );
        assert!(err("1,2,3,4,5").starts_with("vector map line 1: expected 4 numbers"));
    }

    /// Walls around a square of `half` metres on each side of the origin.
    fn square(half: f64) -> World {
        let mut w = two_walls();
        let c = [[-half, -half], [half, -half], [half, half], [-half, half]];
        w.walls = (0..4)
            .map(|k| Wall {
                a: c[k],
                b: c[(k + 1) % 4],
                thickness: 0.2,
                height: 3.0,
                material: "concrete".into(),
            })
            .collect();
        w
    }

    #[test]
    fn grid_size_matches_the_grid_it_announces() {
        let w = two_walls();
        let size = w.grid_size(0.1).unwrap();
        let g = w.occupancy_grid(0.1, true);
        assert_eq!(
            (size.width, size.height, size.origin),
            (g.width, g.height, g.origin)
        );
        assert_eq!(size.cells(), g.cells.len() as u64);
        assert_eq!(w.grid_size(0.0), Err(MapError::Resolution(0.0)));
        let mut empty = w.clone();
        empty.walls.clear();
        assert_eq!(empty.grid_size(0.1), Err(MapError::Empty));
    }

    #[test]
    fn too_large_world_says_how_large_not_empty() {
        // A valid world 18 km across: at 5 cm its grid needs 1.3e11 cells.
        let w = square(9000.0);
        w.validate(std::path::Path::new("<big>")).unwrap();
        let err = w.grid_size(0.05).unwrap_err();
        let MapError::TooLarge {
            width,
            height,
            cells,
            limit,
            min_resolution,
            ..
        } = err.clone()
        else {
            panic!("{err:?}");
        };
        // The walls span 18,000.2 m, 18,002.2 m with the 1 m margins: 360,044 cells of 5 cm.
        assert_eq!((width, height), (360_044, 360_044));
        assert_eq!(cells, 360_044u128 * 360_044);
        assert_eq!(limit, MAX_GRID_CELLS);
        let msg = err.to_string();
        for part in [
            "at 0.05 m would be 360044 x 360044 = 129631681936 cells",
            "over the limit of 200000000 cells (MAX_GRID_CELLS)",
            &format!("use a resolution of at least {min_resolution} m"),
        ] {
            assert!(msg.contains(part), "{part}: {msg}");
        }
        // The suggestion fits, and is the finest that does (to 3 significant digits).
        assert!(w.grid_size(min_resolution).is_ok(), "{min_resolution}");
        assert!(
            w.grid_size(0.98 * min_resolution).is_err(),
            "{min_resolution}"
        );
        assert!((1.2..1.35).contains(&min_resolution), "{min_resolution}");
        // The checked builder says the same; the infallible one still degrades to empty.
        assert_eq!(w.try_occupancy_grid(0.05, true), Err(err));
        assert_eq!(w.occupancy_grid(0.05, true).cells.len(), 0);
        // An unvalidated world with infinite coordinates says so.
        let mut inf = w.clone();
        inf.walls[0].a[0] = f64::INFINITY;
        let e = inf.grid_size(1.0).unwrap_err();
        assert!(matches!(e, MapError::NotFinite { .. }), "{e:?}");
        assert!(e.to_string().contains("World::validate"), "{e}");
        assert!(inf.occupancy_grid(1.0, true).cells.is_empty());
        // Absurd resolutions saturate instead of overflowing.
        let tiny = w.grid_size(1e-300).unwrap_err();
        assert!(
            matches!(
                tiny,
                MapError::TooLarge {
                    width: usize::MAX,
                    height: usize::MAX,
                    ..
                }
            ),
            "{tiny:?}"
        );
    }
}
