//! Worlds and vector maps made from an occupancy grid (e.g. a ROS map_server map), for logs
//! recorded where no hand-made world exists.
//!
//! * [`world_from_grid`]: a [`World`] whose solid walls are the grid's Occupied cells, merged
//!   into few axis-aligned rectangles ([`occupied_rectangles`]).
//! * [`vector_map_from_grid`]: the boundaries between Occupied and other cells as line
//!   segments for line-matching localizers ([`boundary_loops`], simplified with
//!   Douglas–Peucker [Douglas 1973]).
//!
//! Only Occupied cells are solid. Unknown cells are treated like Free ones: a world made from
//! a grid has nothing in unknown space, so simulated sensors see nothing there (a laser beam
//! passes through it) and a robot may drive into it.

use crate::geometry::{point_segment_distance, P2};
use crate::map::{Cell, OccupancyGrid, Segment, VectorMap};
use crate::world::{LaserBehaviour, Material, Wall, World};

/// Name of the one material of a world made from a grid.
pub const GRID_MATERIAL: &str = "map";
/// What one crossing of a grid wall costs a WiFi signal, dB.
pub const GRID_WALL_ATTENUATION_DB: f64 = 10.0;
/// The ceiling of a world made from a grid is this much above its walls, metres.
pub const GRID_CEILING_CLEARANCE: f64 = 0.5;

/// A block of grid cells: columns `i0..i1`, rows `j0..j1` (ends exclusive).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellRect {
    pub i0: usize,
    pub j0: usize,
    pub i1: usize,
    pub j1: usize,
}

impl CellRect {
    /// Number of cells in the block.
    pub fn cells(&self) -> usize {
        (self.i1 - self.i0) * (self.j1 - self.j0)
    }
}

/// Whether the grid's `cells` holds exactly `width * height` cells. A malformed grid is
/// treated as having no Occupied cell.
fn well_formed(grid: &OccupancyGrid) -> bool {
    grid.width.checked_mul(grid.height) == Some(grid.cells.len())
}

/// Whether cell (i, j) is Occupied; cells outside the grid are not.
#[inline]
fn occupied(grid: &OccupancyGrid, i: usize, j: usize) -> bool {
    i < grid.width && j < grid.height && grid.cells.get(j * grid.width + i) == Some(&Cell::Occupied)
}

/// The grid's Occupied cells as disjoint rectangles that cover exactly them.
///
/// Greedy: each line of cells is cut into maximal runs of Occupied cells, and a run with the
/// same extent as a run of the previous line extends that run's rectangle. This is done with
/// rows as lines and with columns as lines, and the partition with fewer rectangles is kept
/// (so a building's vertical walls merge as well as its horizontal ones). Rectangles come
/// sorted by their first line. A grid whose `cells` is not `width * height` long gives none.
pub fn occupied_rectangles(grid: &OccupancyGrid) -> Vec<CellRect> {
    if !well_formed(grid) {
        return Vec::new();
    }
    let by_rows = merge_runs(grid.height, grid.width, |line, k| occupied(grid, k, line));
    let by_columns = merge_runs(grid.width, grid.height, |line, k| occupied(grid, line, k));
    if by_columns.len() < by_rows.len() {
        by_columns
            .into_iter()
            .map(|r| CellRect {
                i0: r.j0,
                j0: r.i0,
                i1: r.j1,
                j1: r.i1,
            })
            .collect()
    } else {
        by_rows
    }
}

/// Run merging over `lines` lines of `len` cells each; `occ(line, k)`. The result's `i` is
/// the position along a line, `j` the line.
fn merge_runs(lines: usize, len: usize, occ: impl Fn(usize, usize) -> bool) -> Vec<CellRect> {
    let mut out = Vec::new();
    // Open rectangles ending at the previous line, as (start, end, first line), by start.
    let mut open: Vec<(usize, usize, usize)> = Vec::new();
    let mut next: Vec<(usize, usize, usize)> = Vec::new();
    for line in 0..lines {
        next.clear();
        let mut o = 0;
        let mut k = 0;
        while k < len {
            if !occ(line, k) {
                k += 1;
                continue;
            }
            let start = k;
            while k < len && occ(line, k) {
                k += 1;
            }
            // Close every open rectangle that starts before this run: runs are disjoint and
            // sorted, so none of them can continue any more.
            while o < open.len() && open[o].0 < start {
                close(&mut out, open[o], line);
                o += 1;
            }
            if o < open.len() && open[o].0 == start && open[o].1 == k {
                next.push(open[o]);
                o += 1;
            } else {
                next.push((start, k, line));
            }
        }
        for &r in &open[o..] {
            close(&mut out, r, line);
        }
        std::mem::swap(&mut open, &mut next);
    }
    for &r in &open {
        close(&mut out, r, lines);
    }
    out
}

fn close(out: &mut Vec<CellRect>, (i0, i1, j0): (usize, usize, usize), j1: usize) {
    out.push(CellRect { i0, j0, i1, j1 });
}

/// A world whose walls are the grid's Occupied cells; see the module documentation for what
/// Unknown cells become.
///
/// The cells are merged into rectangles ([`occupied_rectangles`]); each becomes a [`Wall`]
/// whose centre line runs along the rectangle's longer side (horizontal for a square), with
/// its shorter side as thickness, `wall_height` high, of the one opaque material
/// [`GRID_MATERIAL`] ([`GRID_WALL_ATTENUATION_DB`] per crossing for WiFi). No pillars and no
/// regions; the ceiling is [`GRID_CEILING_CLEARANCE`] above the walls.
/// `world.occupancy_grid(grid.resolution, _)` of the result marks exactly the grid's
/// Occupied cells whenever its lattice is the grid's (its origin is 1 m outside the walls, so
/// when 1 m is a whole number of cells).
///
/// The world passes [`World::validate`] when the grid has at least one Occupied cell, its
/// resolution is at least [`crate::MIN_SIZE_M`], its cells lie within
/// ±[`crate::MAX_COORDINATE_M`], `name` is not blank and `wall_height` is a valid length;
/// [`try_world_from_grid`] checks that.
pub fn world_from_grid(grid: &OccupancyGrid, name: &str, wall_height: f64) -> World {
    let res = grid.resolution;
    let walls = occupied_rectangles(grid)
        .into_iter()
        .map(|r| {
            let x0 = grid.origin[0] + r.i0 as f64 * res;
            let x1 = grid.origin[0] + r.i1 as f64 * res;
            let y0 = grid.origin[1] + r.j0 as f64 * res;
            let y1 = grid.origin[1] + r.j1 as f64 * res;
            let (a, b, thickness) = if x1 - x0 >= y1 - y0 {
                let y = 0.5 * (y0 + y1);
                ([x0, y], [x1, y], y1 - y0)
            } else {
                let x = 0.5 * (x0 + x1);
                ([x, y0], [x, y1], x1 - x0)
            };
            Wall {
                a,
                b,
                thickness,
                height: wall_height,
                material: GRID_MATERIAL.into(),
            }
        })
        .collect();
    World {
        name: name.into(),
        ceiling_height: wall_height + GRID_CEILING_CLEARANCE,
        materials: vec![Material {
            name: GRID_MATERIAL.into(),
            laser: LaserBehaviour::Opaque,
            wifi_attenuation_db: GRID_WALL_ATTENUATION_DB,
        }],
        walls,
        pillars: Vec::new(),
        regions: Vec::new(),
        access_points: Vec::new(),
        wifi: Default::default(),
        boxes: Vec::new(),
        lighting: Default::default(),
    }
}

/// [`world_from_grid`], checked with [`World::validate`] (messages name the world "`name`
/// (from an occupancy grid)").
pub fn try_world_from_grid(
    grid: &OccupancyGrid,
    name: &str,
    wall_height: f64,
) -> Result<World, crate::WorldError> {
    let world = world_from_grid(grid, name, wall_height);
    let origin = format!("{name} (from an occupancy grid)");
    world.validate(std::path::Path::new(&origin))?;
    Ok(world)
}

/// Directions along cell edges, counter-clockwise: +x, +y, -x, -y.
const STEP: [(isize, isize); 4] = [(1, 0), (0, 1), (-1, 0), (0, -1)];

/// The boundaries between Occupied and other cells (cells outside the grid count as not
/// Occupied) as closed polylines of cell-corner points, metres, without their collinear
/// points and without repeating the first point at the end.
///
/// Each loop keeps the Occupied cells on its left: outer boundaries run counter-clockwise,
/// holes clockwise. Occupied cells that touch only at a corner are joined into one loop (the
/// occupied set is 8-connected), so that a one-cell-thick diagonal wall is one outline, not a
/// chain of squares. A grid whose `cells` is not `width * height` long gives none.
pub fn boundary_loops(grid: &OccupancyGrid) -> Vec<Vec<P2>> {
    if !well_formed(grid) {
        return Vec::new();
    }
    let (w, h) = (grid.width, grid.height);
    let vw = w + 1;
    let nv = vw * (h + 1);
    // Outgoing boundary edges of every cell corner, one bit per direction.
    let mut out = vec![0u8; nv];
    for j in 0..h {
        for i in 0..w {
            if !occupied(grid, i, j) {
                continue;
            }
            let v = |i: usize, j: usize| j * vw + i;
            if j == 0 || !occupied(grid, i, j - 1) {
                out[v(i, j)] |= 1 << 0;
            }
            if !occupied(grid, i + 1, j) {
                out[v(i + 1, j)] |= 1 << 1;
            }
            if !occupied(grid, i, j + 1) {
                out[v(i + 1, j + 1)] |= 1 << 2;
            }
            if i == 0 || !occupied(grid, i - 1, j) {
                out[v(i, j + 1)] |= 1 << 3;
            }
        }
    }
    let point = |v: usize| {
        [
            grid.origin[0] + (v % vw) as f64 * grid.resolution,
            grid.origin[1] + (v / vw) as f64 * grid.resolution,
        ]
    };
    let mut used = vec![0u8; nv];
    let mut loops = Vec::new();
    for v0 in 0..nv {
        while out[v0] & !used[v0] != 0 {
            let d0 = (out[v0] & !used[v0]).trailing_zeros() as usize;
            let (mut v, mut d) = (v0, d0);
            let mut corners = Vec::new();
            loop {
                used[v] |= 1 << d;
                let (di, dj) = STEP[d];
                // A boundary edge never leaves the vertex lattice.
                let vi = (v % vw).wrapping_add_signed(di);
                let vj = (v / vw).wrapping_add_signed(dj);
                let nv_ = vj * vw + vi;
                // Right turn first: at a corner shared by two diagonal Occupied cells this
                // goes on around the other cell. The boundary has no dead ends, so one of the
                // three exists.
                let nd = [(d + 3) % 4, d, (d + 1) % 4]
                    .into_iter()
                    .find(|&c| out[nv_] & (1 << c) != 0)
                    .unwrap_or(d);
                if nd != d {
                    corners.push(point(nv_));
                }
                v = nv_;
                d = nd;
                if used[v] & (1 << d) != 0 {
                    break;
                }
            }
            loops.push(corners);
        }
    }
    loops
}

/// The vector map of a grid: [`boundary_loops`] simplified with Douglas–Peucker
/// [Douglas 1973] at `tolerance` metres (about one cell is a good choice), one segment per
/// pair of consecutive kept points, the Occupied side on each segment's left.
///
/// An axis-aligned wall gives one segment per face; a diagonal wall gives one or a few
/// diagonal segments per side instead of a staircase of cell edges. Every kept point is a
/// corner of the cells' boundary, and every boundary corner lies within `tolerance` of the
/// simplified outline. A `tolerance` that is not > 0 keeps every corner.
pub fn vector_map_from_grid(grid: &OccupancyGrid, tolerance: f64) -> VectorMap {
    let mut segments = Vec::new();
    for l in boundary_loops(grid) {
        let kept = simplify_closed(&l, tolerance);
        for k in 0..kept.len() {
            segments.push(Segment {
                a: kept[k],
                b: kept[(k + 1) % kept.len()],
            });
        }
    }
    VectorMap { segments }
}

/// Douglas–Peucker on a closed polyline (not repeating its first point). The loop is split at
/// two far-apart points (the farthest from the first point, and the farthest from that one),
/// which are kept, and each half is simplified as an open polyline.
pub fn simplify_closed(points: &[P2], tolerance: f64) -> Vec<P2> {
    let n = points.len();
    if n <= 3 || tolerance.is_nan() || tolerance <= 0.0 {
        return points.to_vec();
    }
    let farthest_from = |p: P2| {
        (0..n)
            .max_by(|&a, &b| {
                let da = (points[a][0] - p[0]).hypot(points[a][1] - p[1]);
                let db = (points[b][0] - p[0]).hypot(points[b][1] - p[1]);
                da.total_cmp(&db)
            })
            .unwrap_or(0)
    };
    let a = farthest_from(points[0]);
    let b = farthest_from(points[a]);
    if a == b {
        return points.to_vec();
    }
    // The loop rotated to start at `a`, closed with `a` again, so `b` sits at index m.
    let rotated: Vec<P2> = (0..=n).map(|k| points[(a + k) % n]).collect();
    let m = (b + n - a) % n;
    let mut keep = vec![false; n + 1];
    keep[0] = true;
    keep[m] = true;
    keep[n] = true;
    // Each half keeps at least its farthest point, so that a loop never collapses to a
    // sliver of two points (a wall one tolerance thin keeps its four faces).
    douglas_peucker(&rotated, 0, m, tolerance, &mut keep);
    douglas_peucker(&rotated, m, n, tolerance, &mut keep);
    (0..n).filter(|&k| keep[k]).map(|k| rotated[k]).collect()
}

/// Marks in `keep` the points of `points[first..=last]` that Douglas–Peucker keeps (the ends
/// are the caller's), keeping the farthest point of the first split whatever its distance.
/// Iterative, so that a long loop cannot overflow the stack.
fn douglas_peucker(points: &[P2], first: usize, last: usize, tolerance: f64, keep: &mut [bool]) {
    let mut stack = vec![(first, last, true)];
    while let Some((s, e, force)) = stack.pop() {
        if e <= s + 1 {
            continue;
        }
        let mut worst = (f64::NEG_INFINITY, s + 1);
        for k in s + 1..e {
            let d = point_segment_distance(points[k], points[s], points[e]);
            if d > worst.0 {
                worst = (d, k);
            }
        }
        if force || worst.0 > tolerance {
            keep[worst.1] = true;
            stack.push((s, worst.1, false));
            stack.push((worst.1, e, false));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::point_box_distance;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A grid from text rows, top row (largest j) first: '#' Occupied, '?' Unknown, else Free.
    fn grid_from_rows(origin: P2, resolution: f64, rows: &[&str]) -> OccupancyGrid {
        let height = rows.len();
        let width = rows[0].len();
        let mut cells = vec![Cell::Free; width * height];
        for (r, row) in rows.iter().enumerate() {
            let j = height - 1 - r;
            for (i, c) in row.chars().enumerate() {
                cells[j * width + i] = match c {
                    '#' => Cell::Occupied,
                    '?' => Cell::Unknown,
                    _ => Cell::Free,
                };
            }
        }
        OccupancyGrid {
            origin,
            resolution,
            width,
            height,
            cells,
        }
    }

    fn blank(origin: P2, resolution: f64, width: usize, height: usize) -> OccupancyGrid {
        OccupancyGrid {
            origin,
            resolution,
            width,
            height,
            cells: vec![Cell::Free; width * height],
        }
    }

    fn set(g: &mut OccupancyGrid, i: usize, j: usize) {
        let k = g.index(i, j);
        g.cells[k] = Cell::Occupied;
    }

    fn random_grid(seed: u64, width: usize, height: usize, p: f64) -> OccupancyGrid {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut g = blank([0.4, -1.2], 0.05, width, height);
        for c in g.cells.iter_mut() {
            let u: f64 = rng.random();
            *c = if u < p {
                Cell::Occupied
            } else if u < p + 0.1 {
                Cell::Unknown
            } else {
                Cell::Free
            };
        }
        g
    }

    /// A 40 m x 30 m floor at 5 cm: outer walls 4 cells thick, inner walls 2 cells thick with
    /// door gaps, a few unknown patches.
    fn building() -> OccupancyGrid {
        let (w, h) = (800, 600);
        let mut g = blank([-3.0, -2.0], 0.05, w, h);
        let fill = |g: &mut OccupancyGrid, i0: usize, i1: usize, j0: usize, j1: usize| {
            for j in j0..j1 {
                for i in i0..i1 {
                    set(g, i, j);
                }
            }
        };
        fill(&mut g, 0, w, 0, 4);
        fill(&mut g, 0, w, h - 4, h);
        fill(&mut g, 0, 4, 0, h);
        fill(&mut g, w - 4, w, 0, h);
        // Corridor walls along y, doors every 100 cells.
        for y in [250, 350] {
            for x0 in (4..w - 4).step_by(100) {
                fill(&mut g, x0, (x0 + 84).min(w - 4), y, y + 2);
            }
        }
        // Room partitions along x.
        for x in (100..w - 4).step_by(100) {
            fill(&mut g, x, x + 2, 4, 250);
            fill(&mut g, x, x + 2, 352, h - 4);
        }
        for k in (0..w * h).step_by(997) {
            if g.cells[k] == Cell::Free {
                g.cells[k] = Cell::Unknown;
            }
        }
        g
    }

    /// Every cell of `world.occupancy_grid(res)` is Occupied exactly when the input cell
    /// under its centre is; and every input cell was looked at.
    fn assert_rasterizes_back(grid: &OccupancyGrid, world: &World) {
        let back = world.occupancy_grid(grid.resolution, false);
        assert!(back.width > 0, "{}", back.width);
        let mut seen = 0;
        for j in 0..back.height {
            for i in 0..back.width {
                let c = back.cell_center(i, j);
                let want = grid
                    .world_to_cell(c)
                    .map(|(gi, gj)| {
                        seen += 1;
                        occupied(grid, gi, gj)
                    })
                    .unwrap_or(false);
                let got = back.cells[back.index(i, j)] == Cell::Occupied;
                assert_eq!(got, want, "cell at {c:?}");
            }
        }
        // The rebuilt grid spans the occupied cells' bounding box plus 1 m each side.
        assert!(seen > 0);
        for j in 0..grid.height {
            for i in 0..grid.width {
                if occupied(grid, i, j) {
                    assert_eq!(back.at(grid.cell_center(i, j)), Cell::Occupied);
                }
            }
        }
    }

    fn assert_rectangles_partition(grid: &OccupancyGrid, rects: &[CellRect]) {
        let mut count = vec![0u8; grid.width * grid.height];
        for r in rects {
            assert!(r.i0 < r.i1 && r.j0 < r.j1 && r.i1 <= grid.width && r.j1 <= grid.height);
            for j in r.j0..r.j1 {
                for i in r.i0..r.i1 {
                    count[grid.index(i, j)] += 1;
                }
            }
        }
        for (k, &c) in count.iter().enumerate() {
            let want = u8::from(grid.cells[k] == Cell::Occupied);
            assert_eq!(c, want, "cell {k}");
        }
    }

    #[test]
    fn rectangles_of_a_hand_made_grid() {
        // Rows top first; j = 3 is the top row.
        let g = grid_from_rows(
            [0.0, 0.0],
            1.0,
            &[
                "##?...", //
                "##....", //
                "..####", //
                "#.####",
            ],
        );
        let rects = occupied_rectangles(&g);
        assert_rectangles_partition(&g, &rects);
        // Rows: (0,0), (2..6 over rows 0-1), (0..2 over rows 2-3) = 3; columns give 3 too, and
        // a tie keeps the rows.
        assert_eq!(
            rects,
            vec![
                CellRect {
                    i0: 0,
                    j0: 0,
                    i1: 1,
                    j1: 1
                },
                CellRect {
                    i0: 2,
                    j0: 0,
                    i1: 6,
                    j1: 2
                },
                CellRect {
                    i0: 0,
                    j0: 2,
                    i1: 2,
                    j1: 4
                },
            ]
        );
        // A vertical bar merges by columns: one rectangle.
        let bar = grid_from_rows([0.0, 0.0], 1.0, &[".#.", ".#.", "##.", ".#."]);
        let r = occupied_rectangles(&bar);
        assert_rectangles_partition(&bar, &r);
        assert_eq!(r.len(), 2, "{r:?}");
        assert!(r.contains(&CellRect {
            i0: 1,
            j0: 0,
            i1: 2,
            j1: 4
        }));
    }

    #[test]
    fn hand_made_grid_becomes_valid_walls() {
        let g = grid_from_rows(
            [-2.3, 1.7],
            0.1,
            &[
                "?#######..", //
                ".#.....#..", //
                ".#.??..#..", //
                ".#.....##.", //
                "##########", //
                "#.........",
            ],
        );
        let w = world_from_grid(&g, "hand", 2.5);
        w.validate(std::path::Path::new("<hand>")).unwrap();
        assert_eq!(w.ceiling_height, 3.0);
        assert_eq!(w.materials.len(), 1);
        assert_eq!(w.materials[0].name, "map");
        assert_eq!(w.materials[0].laser, LaserBehaviour::Opaque);
        assert_eq!(w.materials[0].wifi_attenuation_db, 10.0);
        assert!(w.pillars.is_empty() && w.regions.is_empty());
        // By rows: row 0's cell, row 1, column 1 over rows 2-4, columns 7-8 in row 2,
        // column 7 over rows 3-4 and the top row's run = 6 rectangles; by columns 7.
        assert_eq!(w.walls.len(), 6, "{:#?}", w.walls);
        // The bottom-left cell alone: a 0.1 m square wall with a horizontal centre line.
        let first = &w.walls[0];
        let close = |a: P2, b: P2| (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12;
        assert!(close(first.a, [-2.3, 1.75]) && close(first.b, [-2.2, 1.75]));
        assert!((first.thickness - 0.1).abs() < 1e-12);
        assert_eq!(first.height, 2.5);
        // Column 1 over rows 2..5: a vertical wall 0.3 m long, 0.1 m thick.
        assert!(w.walls.iter().any(|wall| close(wall.a, [-2.15, 1.9])
            && close(wall.b, [-2.15, 2.2])
            && (wall.thickness - 0.1).abs() < 1e-12));
        assert_rasterizes_back(&g, &w);
        assert!(try_world_from_grid(&g, "hand", 2.5).is_ok());
    }

    #[test]
    fn random_grid_rasterizes_back_exactly() {
        let g = random_grid(7, 120, 90, 0.1);
        let w = world_from_grid(&g, "random", 2.0);
        w.validate(std::path::Path::new("<random>")).unwrap();
        assert_rectangles_partition(&g, &occupied_rectangles(&g));
        assert_rasterizes_back(&g, &w);
    }

    #[test]
    fn building_rasterizes_back_with_few_walls() {
        let g = building();
        let w = world_from_grid(&g, "building", 2.5);
        w.validate(std::path::Path::new("<building>")).unwrap();
        // 4 outer + 2 x 8 corridor + 2 x 7 partitions = 34 walls in the plan; the merge may
        // cut a few more at junctions.
        assert!(w.walls.len() <= 50, "{}", w.walls.len());
        assert_rasterizes_back(&g, &w);
    }

    #[test]
    fn wall_counts() {
        let random = world_from_grid(&random_grid(1, 400, 400, 0.1), "r", 2.0);
        let building = world_from_grid(&building(), "b", 2.0);
        let occupied = random_grid(1, 400, 400, 0.1)
            .cells
            .iter()
            .filter(|&&c| c == Cell::Occupied)
            .count();
        println!(
            "400x400 random 10 %: {occupied} occupied cells -> {} walls; building 800x600: {} walls",
            random.walls.len(),
            building.walls.len()
        );
        assert!(random.walls.len() < occupied);
    }

    #[test]
    fn empty_grid_and_bad_inputs_are_refused_by_the_checked_form() {
        let g = blank([0.0, 0.0], 0.1, 5, 5);
        assert!(world_from_grid(&g, "empty", 2.0).walls.is_empty());
        let e = try_world_from_grid(&g, "empty", 2.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least one wall"), "{e}");
        let mut one = g.clone();
        set(&mut one, 2, 2);
        assert!(try_world_from_grid(&one, "one", 2.0).is_ok());
        assert!(try_world_from_grid(&one, "one", f64::NAN).is_err());
        assert!(try_world_from_grid(&one, " ", 2.0).is_err());
        // A malformed grid (cells missing, or absurd dimensions) has no occupied cell.
        let mut short = one.clone();
        short.cells.truncate(3);
        assert!(world_from_grid(&short, "s", 2.0).walls.is_empty());
        assert!(vector_map_from_grid(&short, 0.1).segments.is_empty());
        let absurd = OccupancyGrid {
            width: usize::MAX,
            height: 2,
            ..one.clone()
        };
        assert!(world_from_grid(&absurd, "a", 2.0).walls.is_empty());
        assert!(boundary_loops(&absurd).is_empty());
    }

    fn seg_len(s: &Segment) -> f64 {
        (s.b[0] - s.a[0]).hypot(s.b[1] - s.a[1])
    }

    #[test]
    fn rectangle_block_gives_its_four_faces() {
        let mut g = blank([1.0, 2.0], 0.5, 8, 6);
        for j in 1..4 {
            for i in 2..7 {
                set(&mut g, i, j);
            }
        }
        let m = vector_map_from_grid(&g, 0.5);
        // Counter-clockwise (solid on the left) from the corner farthest from the first traced
        // one, (4.5, 2.5).
        let want = [
            ([2.0, 4.0], [2.0, 2.5]),
            ([2.0, 2.5], [4.5, 2.5]),
            ([4.5, 2.5], [4.5, 4.0]),
            ([4.5, 4.0], [2.0, 4.0]),
        ];
        assert_eq!(m.segments.len(), 4, "{:?}", m.segments);
        for (s, (a, b)) in m.segments.iter().zip(want) {
            assert_eq!((s.a, s.b), (a, b));
        }
        // Without simplification the loop is already these 4 corners.
        let raw = vector_map_from_grid(&g, 0.0).segments;
        assert_eq!(raw.len(), 4);
        assert!(raw.iter().all(|s| m.segments.contains(s)));
        assert_eq!(boundary_loops(&g).len(), 1);
        // A wall exactly one tolerance thin keeps its four faces.
        let mut thin = blank([0.0, 0.0], 0.1, 30, 3);
        for i in 1..29 {
            set(&mut thin, i, 1);
        }
        let m = vector_map_from_grid(&thin, 0.1);
        assert_eq!(m.segments.len(), 4, "{:?}", m.segments);
        assert!(m
            .segments
            .iter()
            .all(|s| s.a[0] == s.b[0] || s.a[1] == s.b[1]));
    }

    #[test]
    fn block_at_the_grid_edge_and_a_hole() {
        // A 5 x 5 block filling the grid with a one-cell hole: outer loop ccw, hole cw.
        let g = grid_from_rows(
            [0.0, 0.0],
            1.0,
            &["#####", "#####", "##.##", "#####", "#####"],
        );
        let loops = boundary_loops(&g);
        assert_eq!(loops.len(), 2);
        let area = |l: &Vec<P2>| crate::geometry::polygon_area(l);
        assert_eq!(area(&loops[0]), 25.0);
        assert_eq!(area(&loops[1]), -1.0);
        assert_eq!(vector_map_from_grid(&g, 1.0).segments.len(), 8);
    }

    #[test]
    fn diagonal_touching_cells_are_one_outline() {
        let g = grid_from_rows([0.0, 0.0], 1.0, &["..#", ".#.", "#.."]);
        let loops = boundary_loops(&g);
        assert_eq!(loops.len(), 1, "{loops:?}");
        // 3 squares joined at corners: 12 edges, all corners.
        assert_eq!(loops[0].len(), 12);
        assert_eq!(crate::geometry::polygon_area(&loops[0]), 3.0);
    }

    fn diagonal_band(n: usize, half_width: usize) -> OccupancyGrid {
        let mut g = blank([0.0, 0.0], 0.1, n, n);
        for j in 0..n {
            for i in 0..n {
                if i.abs_diff(j) <= half_width {
                    set(&mut g, i, j);
                }
            }
        }
        g
    }

    #[test]
    fn diagonal_wall_gives_diagonal_segments() {
        for (n, hw) in [(60, 1), (60, 0), (45, 2)] {
            let g = diagonal_band(n, hw);
            let tol = g.resolution;
            let m = vector_map_from_grid(&g, tol);
            let total: f64 = m.segments.iter().map(seg_len).sum();
            let mut diagonal = 0.0;
            for s in &m.segments {
                if seg_len(s) < 5.0 * g.resolution {
                    continue;
                }
                let deg = (s.b[1] - s.a[1]).atan2(s.b[0] - s.a[0]).to_degrees();
                let off = (deg - 45.0).rem_euclid(180.0);
                let off = off.min(180.0 - off);
                assert!(off < 5.0, "{n} {hw}: {s:?} at {deg} deg");
                diagonal += seg_len(s);
            }
            assert!(diagonal > 0.9 * total, "{n} {hw}: {:?}", m.segments);
            assert!(m.segments.len() <= 8, "{n} {hw}: {:?}", m.segments);
            assert_segments_near_cells(&g, &m, tol);
        }
    }

    /// Every endpoint is within tolerance + one cell of an occupied cell (here: on its
    /// boundary), and every boundary corner within tolerance of a segment.
    fn assert_segments_near_cells(g: &OccupancyGrid, m: &VectorMap, tol: f64) {
        let res = g.resolution;
        let occupied_boxes: Vec<(P2, P2)> = (0..g.height)
            .flat_map(|j| (0..g.width).map(move |i| (i, j)))
            .filter(|&(i, j)| occupied(g, i, j))
            .map(|(i, j)| {
                let lo = [g.origin[0] + i as f64 * res, g.origin[1] + j as f64 * res];
                (lo, [lo[0] + res, lo[1] + res])
            })
            .collect();
        for s in &m.segments {
            for p in [s.a, s.b] {
                let d = occupied_boxes
                    .iter()
                    .map(|&(lo, hi)| point_box_distance(p, lo, hi))
                    .fold(f64::INFINITY, f64::min);
                assert!(d <= tol + res, "{p:?} is {d} from the cells");
            }
        }
        for l in boundary_loops(g) {
            for p in l {
                let d = m
                    .segments
                    .iter()
                    .map(|s| point_segment_distance(p, s.a, s.b))
                    .fold(f64::INFINITY, f64::min);
                assert!(d <= tol + 1e-12, "corner {p:?} is {d} from the outline");
            }
        }
    }

    #[test]
    fn random_and_building_outlines_stay_on_the_cells() {
        let g = random_grid(3, 50, 40, 0.3);
        assert_segments_near_cells(&g, &vector_map_from_grid(&g, 0.05), 0.05);
        let b = building();
        let m = vector_map_from_grid(&b, 0.05);
        // Axis-aligned walls: one segment per face, all axis-aligned.
        for s in &m.segments {
            assert!(s.a[0] == s.b[0] || s.a[1] == s.b[1], "{s:?}");
        }
        println!("building vector map: {} segments", m.segments.len());
    }

    #[test]
    fn loop_simplification_of_a_wobbly_square() {
        // A closed polyline with a 0.2 bump on one side: kept at tolerance 0.1, dropped at 0.3.
        let pts = vec![[0.0, 0.0], [2.0, 0.0], [2.2, 1.0], [2.0, 2.0], [0.0, 2.0]];
        assert_eq!(simplify_closed(&pts, 0.1).len(), 5);
        let s = simplify_closed(&pts, 0.3);
        assert_eq!(s.len(), 4, "{s:?}");
        assert!(!s.contains(&[2.2, 1.0]));
        assert_eq!(simplify_closed(&pts, f64::NAN), pts);
    }
}
