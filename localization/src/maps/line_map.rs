//! The vector map (line segments) prepared for point-to-line correspondences: each segment's
//! unit normal, and a grid that lists, per cell, the few segments nearest to it, so that the
//! nearest segment to a point is found by checking a handful of candidates instead of all of
//! them. Used by CGR ([004] §2.1–2.2), whose observation model and its
//! gradient are built on point-to-line distances to the map.

use crate::error::LocalizationError;
use crate::limits::{check_grid, check_positive, LINE_MAP_MAX_CELLS};
use atrium_worlds::VectorMap;

/// Candidate segments kept per grid cell.
pub const CANDIDATES: usize = 4;
const NONE: u32 = u32::MAX;
/// Sub-cells per cell side for the dominance masks.
const SUB: usize = 4;
// `Cell::single` keeps a nibble per sub-cell in a u64.
const _: () = assert!(SUB * SUB * 4 <= 64);
/// Distance by which a dominated candidate is farther everywhere in its sub-cell, m: far
/// above the float error of a point's cell and of its computed distances (about 1e-13 m).
const DOMINANCE_MARGIN: f64 = 1e-9;
/// Marks a `LineMap::sub_cells` entry that is its cell's only record, not an offset.
const ONE_RECORD: u32 = 1 << 31;

/// One map segment with what the correspondence search needs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line {
    pub a: [f64; 2],
    pub b: [f64; 2],
    /// Unit direction a → b.
    pub dir: [f64; 2],
    /// Unit normal (dir turned +90°).
    pub normal: [f64; 2],
    pub length: f64,
}

impl Line {
    /// Distance from `p` to the segment (not the infinite line).
    #[inline]
    pub fn segment_distance(&self, p: [f64; 2]) -> f64 {
        let r = self.residual(p);
        r[0].hypot(r[1])
    }

    /// The vector from the segment's point closest to `p` to `p`.
    #[inline]
    pub fn residual(&self, p: [f64; 2]) -> [f64; 2] {
        let (dx, dy) = (p[0] - self.a[0], p[1] - self.a[1]);
        let t = (dx * self.dir[0] + dy * self.dir[1]).clamp(0.0, self.length);
        let (cx, cy) = (self.a[0] + t * self.dir[0], self.a[1] + t * self.dir[1]);
        [p[0] - cx, p[1] - cy]
    }

    /// Signed distance from `p` to the segment's infinite line, along `normal`.
    #[inline]
    pub fn line_offset(&self, p: [f64; 2]) -> f64 {
        (p[0] - self.a[0]) * self.normal[0] + (p[1] - self.a[1]) * self.normal[1]
    }
}

/// One grid cell: what a correspondence needs first, in one cache line, so that the common
/// case (one candidate left in the point's sub-cell) costs one load before the segment's.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(32))]
struct Cell {
    /// `CANDIDATES` segment indices, nearest first, `NONE`-padded.
    ids: [u32; CANDIDATES],
    /// Nibble s per sub-cell s (row-major): bit 3 set when exactly one candidate is left
    /// there with every candidate eligible (as without a normal constraint), bits 0–1 its
    /// index in `ids`. What `sub_cells` and `dominated` say of that case, without their two
    /// dependent loads and the branch between them.
    single: u64,
}

/// The vector map with a candidate grid.
#[derive(Debug, Clone)]
pub struct LineMap {
    lines: Vec<Line>,
    origin: [f64; 2],
    resolution: f64,
    width: usize,
    height: usize,
    /// Per cell, its candidates and which of them is the one left in each sub-cell.
    cells: Vec<Cell>,
    /// Per cell with two or more candidates, the offset of its `SUB`² records in
    /// `dominated`; otherwise `ONE_RECORD` | the candidates present (bit k = candidate k).
    sub_cells: Vec<u32>,
    /// Per sub-cell, row-major: nibble k of the low 16 bits holds the candidates (bit j =
    /// candidate j) nearer than candidate k everywhere in the sub-cell, so that k can never
    /// be the nearest while any of them is eligible; bits 16–19 hold the candidates left
    /// when all are eligible (no normal constraint).
    dominated: Vec<u32>,
    /// Candidates are complete for points within this distance of a segment, m.
    reach: f64,
}

impl LineMap {
    /// Indexes `map` on a grid of `resolution` metres; a cell lists the `CANDIDATES`
    /// segments nearest to its centre among those within `reach` (plus half a cell
    /// diagonal). Zero-length segments are dropped.
    pub fn new(map: &VectorMap, resolution: f64, reach: f64) -> Result<Self, LocalizationError> {
        check_positive("map_resolution", resolution)
            .and_then(|()| check_positive("max_correspondence", reach))
            .map_err(LocalizationError::InvalidParameter)?;
        let mut lines = Vec::with_capacity(map.segments.len());
        for s in &map.segments {
            let (dx, dy) = (s.b[0] - s.a[0], s.b[1] - s.a[1]);
            let length = dx.hypot(dy);
            if !s.a.iter().chain(&s.b).all(|v| v.is_finite()) || length <= 1e-9 {
                continue;
            }
            let dir = [dx / length, dy / length];
            lines.push(Line {
                a: s.a,
                b: s.b,
                dir,
                normal: [-dir[1], dir[0]],
                length,
            });
        }
        if lines.is_empty() {
            return Err(LocalizationError::InvalidParameter(
                "the vector map has no segment".into(),
            ));
        }
        let margin = reach + resolution;
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for l in &lines {
            for p in [l.a, l.b] {
                for k in 0..2 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        let origin = [lo[0] - margin, lo[1] - margin];
        // One cell more than the extent needs on each axis; checked in f64 before the casts.
        let extent = [
            hi[0] - lo[0] + 2.0 * margin + resolution,
            hi[1] - lo[1] + 2.0 * margin + resolution,
        ];
        check_grid(
            "map_resolution",
            resolution,
            extent,
            "vector map",
            LINE_MAP_MAX_CELLS,
            "LINE_MAP_MAX_CELLS",
        )
        .map_err(LocalizationError::InvalidParameter)?;
        let width = ((hi[0] - lo[0] + 2.0 * margin) / resolution).ceil() as usize + 1;
        let height = ((hi[1] - lo[1] + 2.0 * margin) / resolution).ceil() as usize + 1;
        let mut cells = vec![[NONE; CANDIDATES]; width * height];
        let mut dist = vec![[f64::INFINITY; CANDIDATES]; width * height];
        let half_diag = 0.5 * resolution * std::f64::consts::SQRT_2;
        let cutoff = reach + half_diag;
        for (li, l) in lines.iter().enumerate() {
            let i0 = ((l.a[0].min(l.b[0]) - cutoff - origin[0]) / resolution)
                .floor()
                .max(0.0) as usize;
            let i1 = (((l.a[0].max(l.b[0]) + cutoff - origin[0]) / resolution).ceil() as usize)
                .min(width - 1);
            let j0 = ((l.a[1].min(l.b[1]) - cutoff - origin[1]) / resolution)
                .floor()
                .max(0.0) as usize;
            let j1 = (((l.a[1].max(l.b[1]) + cutoff - origin[1]) / resolution).ceil() as usize)
                .min(height - 1);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let c = [
                        origin[0] + (i as f64 + 0.5) * resolution,
                        origin[1] + (j as f64 + 0.5) * resolution,
                    ];
                    let d = l.segment_distance(c);
                    if d > cutoff {
                        continue;
                    }
                    let k = j * width + i;
                    // Insertion into the sorted candidate list.
                    let (ids, ds) = (&mut cells[k], &mut dist[k]);
                    if d >= ds[CANDIDATES - 1] {
                        continue;
                    }
                    let mut pos = CANDIDATES - 1;
                    while pos > 0 && ds[pos - 1] > d {
                        ds[pos] = ds[pos - 1];
                        ids[pos] = ids[pos - 1];
                        pos -= 1;
                    }
                    ds[pos] = d;
                    ids[pos] = li as u32;
                }
            }
        }
        let (sub_cells, dominated) = dominance(&lines, &cells, &dist, origin, resolution, width);
        let cells = cells
            .iter()
            .zip(&sub_cells)
            .map(|(&ids, &entry)| Cell {
                ids,
                single: single_candidates(entry, &dominated),
            })
            .collect();
        Ok(Self {
            lines,
            origin,
            resolution,
            width,
            height,
            cells,
            sub_cells,
            dominated,
            reach,
        })
    }

    pub fn lines(&self) -> &[Line] {
        &self.lines
    }

    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// The cell holding `p` and the sub-cell within it (row-major), if on the grid.
    #[inline]
    fn locate(&self, p: [f64; 2]) -> Option<(usize, usize)> {
        // Scaled by SUB, a power of two, exactly: the integer part over SUB is the cell the
        // unscaled quotient's integer part picks, the remainder its sub-cell.
        let fi = (p[0] - self.origin[0]) / self.resolution * SUB as f64;
        let fj = (p[1] - self.origin[1]) / self.resolution * SUB as f64;
        // Bounds in f64 (exact for these small integers) before the casts: a saturating
        // f64 → usize cast costs a dozen instructions, and this runs for every observed
        // point of every particle's evaluation. NaN fails the test.
        if !(fi >= 0.0
            && fj >= 0.0
            && fi < (self.width * SUB) as f64
            && fj < (self.height * SUB) as f64)
        {
            return None;
        }
        // In [0, 2³²): the grid has at most LINE_MAP_MAX_CELLS cells.
        let (i, j) = (fi as u32 as usize, fj as u32 as usize);
        Some(((j / SUB) * self.width + i / SUB, (j % SUB) * SUB + i % SUB))
    }

    /// The candidate segments of the cell holding `p` (empty off the grid or far from walls).
    #[inline]
    pub fn candidates(&self, p: [f64; 2]) -> &[u32] {
        let Some((cell, _)) = self.locate(p) else {
            return &[];
        };
        let c = &self.cells[cell].ids;
        let n = c.iter().position(|&x| x == NONE).unwrap_or(CANDIDATES);
        &c[..n]
    }

    /// The segment nearest to `p` within `reach`, optionally only among segments whose normal
    /// is within the angle whose cosine is `min_cos` of `normal` (either direction); returns
    /// (segment index, distance to the segment).
    #[inline]
    pub fn nearest(&self, p: [f64; 2], normal: Option<([f64; 2], f64)>) -> Option<(usize, f64)> {
        self.correspondence(p, normal).map(|c| (c.line, c.distance))
    }

    /// [`LineMap::nearest`] with the residual vector from the segment's closest point to `p`
    /// (what CGR's gradient needs), computed by the very operations `Line::segment_distance`
    /// performs, so `distance` is bit for bit `residual[0].hypot(residual[1])`, and the
    /// segment is the first of the cell's candidates at the least such distance, as a
    /// search through all of them finds.
    ///
    /// Two shortcuts keep that result. Candidates that a nearer eligible one dominates in
    /// `p`'s sub-cell are skipped. Of those left (usually one), candidates are ranked by
    /// squared distance, and `hypot` (a libm call) is taken only of those within a relative
    /// 10⁻¹² of the smallest. That ranks exactly as comparing `hypot`s would: the squares
    /// carry a relative error below 4·10⁻¹⁶ and `hypot` one below 2.3·10⁻¹⁶, so a candidate
    /// whose square is larger by 10⁻¹² has the larger `hypot` too, strictly. Squares near
    /// underflow or overflow, where that bound fails, take every candidate's `hypot`.
    // Always inlined: CGR calls it for every point, and a call returns the result through
    // memory and keeps the caller's constraint test.
    #[inline(always)]
    pub fn correspondence(
        &self,
        p: [f64; 2],
        normal: Option<([f64; 2], f64)>,
    ) -> Option<Correspondence> {
        let (cell, sub) = self.locate(p)?;
        let Cell { ids, single } = &self.cells[cell];
        // The common case: one candidate left in the sub-cell when all are eligible. Every
        // other candidate is dominated there by a chain of candidates, each nearer everywhere
        // in the sub-cell, that ends at this one; so this one is nearer than all of them, and
        // the answer whenever it is eligible, as the general search below would find.
        // Ineligible and alone in its cell, there is none.
        let pick = (single >> (4 * sub)) & 0xf;
        if pick & 8 != 0 {
            let id = ids[(pick & 3) as usize];
            let eligible = normal.is_none_or(|(n, min_cos)| {
                let l = &self.lines[id as usize];
                (n[0] * l.normal[0] + n[1] * l.normal[1]).abs() >= min_cos
            });
            if eligible {
                return self.within_reach(id, p);
            }
            if ids[1] == NONE {
                return None;
            }
        }
        let entry = self.sub_cells[cell];
        let record = if entry & ONE_RECORD != 0 {
            (entry & 0xf) << 16
        } else {
            self.dominated[entry as usize + sub]
        };
        let left = match normal {
            None => record >> 16,
            Some((n, min_cos)) => {
                let mut eligible = 0u32;
                for (k, &id) in ids.iter().enumerate() {
                    if id == NONE {
                        break;
                    }
                    let l = &self.lines[id as usize];
                    if (n[0] * l.normal[0] + n[1] * l.normal[1]).abs() >= min_cos {
                        eligible |= 1 << k;
                    }
                }
                let mut blocked = 0u32;
                for k in 0..CANDIDATES {
                    blocked |= u32::from((record >> (4 * k)) & 0xf & eligible != 0) << k;
                }
                eligible & !blocked
            }
        };
        if left == 0 {
            return None;
        }
        if left.is_power_of_two() {
            return self.within_reach(ids[left.trailing_zeros() as usize], p);
        }
        let mut squares = [f64::INFINITY; CANDIDATES];
        let mut residuals = [[0.0; 2]; CANDIDATES];
        let mut least = f64::INFINITY;
        for (k, &id) in ids.iter().enumerate() {
            if left & (1 << k) == 0 {
                continue;
            }
            let r = self.lines[id as usize].residual(p);
            squares[k] = r[0] * r[0] + r[1] * r[1];
            residuals[k] = r;
            least = least.min(squares[k]);
        }
        let tie = if (1e-280..1e280).contains(&least) {
            least * (1.0 + 1e-12)
        } else {
            f64::INFINITY
        };
        let mut best: Option<Correspondence> = None;
        for (k, &id) in ids.iter().enumerate() {
            if left & (1 << k) == 0 || squares[k] > tie {
                continue;
            }
            let r = residuals[k];
            let d = residual_length(r);
            if d <= self.reach && best.is_none_or(|b| d < b.distance) {
                best = Some(Correspondence {
                    line: id as usize,
                    distance: d,
                    residual: r,
                });
            }
        }
        best
    }

    /// Segment `id` as `p`'s correspondence, if within reach.
    #[inline(always)]
    fn within_reach(&self, id: u32, p: [f64; 2]) -> Option<Correspondence> {
        let r = self.lines[id as usize].residual(p);
        let d = residual_length(r);
        (d <= self.reach).then_some(Correspondence {
            line: id as usize,
            distance: d,
            residual: r,
        })
    }
}

/// `r[0].hypot(r[1])`, without the library call when a component is zero: the residual
/// from an axis-aligned segment's interior, where the subtractions are exact (coordinates
/// within a factor of two of each other), as in most indoor maps. C's Annex F (IEC 60559)
/// makes `hypot(x, ±0)` equivalent to `fabs(x)`, so this is `hypot` bit for bit.
#[inline(always)]
fn residual_length(r: [f64; 2]) -> f64 {
    if r[0] == 0.0 {
        r[1].abs()
    } else if r[1] == 0.0 {
        r[0].abs()
    } else {
        r[0].hypot(r[1])
    }
}

/// A cell's `Cell::single` from its `LineMap::sub_cells` entry and the dominance records.
fn single_candidates(entry: u32, dominated: &[u32]) -> u64 {
    let left_in = |s: usize| {
        if entry & ONE_RECORD != 0 {
            entry & 0xf
        } else {
            dominated[entry as usize + s] >> 16
        }
    };
    (0..SUB * SUB)
        .filter(|&s| left_in(s).is_power_of_two())
        .fold(0, |acc, s| {
            acc | (8 | u64::from(left_in(s).trailing_zeros())) << (4 * s)
        })
}

/// The dominance records of every cell (see `LineMap::dominated`): candidate k is dominated
/// by j in a sub-cell when k's distance at the sub-cell's centre, less the sub-cell's half
/// diagonal, exceeds j's plus the half diagonal (a distance to a segment changes by at most
/// the distance moved). Pairs that differ by the whole cell's diagonal at its centre are
/// decided for all its sub-cells at once. Only the margins need the distances, so they are
/// plain square roots here, not the `hypot`s of the search.
fn dominance(
    lines: &[Line],
    cells: &[[u32; CANDIDATES]],
    centre_distances: &[[f64; CANDIDATES]],
    origin: [f64; 2],
    resolution: f64,
    width: usize,
) -> (Vec<u32>, Vec<u32>) {
    let mut sub_cells = Vec::with_capacity(cells.len());
    let mut dominated = Vec::new();
    let half_diag = 0.5 * resolution * std::f64::consts::SQRT_2;
    let sub_res = resolution / SUB as f64;
    let sub_half_diag = 0.5 * sub_res * std::f64::consts::SQRT_2;
    let distance = |l: &Line, c: [f64; 2]| {
        let r = l.residual(c);
        (r[0] * r[0] + r[1] * r[1]).sqrt()
    };
    for (cell, ids) in cells.iter().enumerate() {
        let n = ids.iter().take_while(|&&id| id != NONE).count();
        let present = (1u32 << n) - 1;
        if n < 2 {
            sub_cells.push(ONE_RECORD | present);
            continue;
        }
        let offset = dominated.len();
        sub_cells.push(offset as u32);
        dominated.resize(offset + SUB * SUB, 0u32);
        let records = &mut dominated[offset..];
        let corner = [
            origin[0] + (cell % width) as f64 * resolution,
            origin[1] + (cell / width) as f64 * resolution,
        ];
        let dc = &centre_distances[cell];
        // Sub-cell centre distances, computed once a pair needs them.
        let mut sub_d: [Option<[f64; SUB * SUB]>; CANDIDATES] = [None; CANDIDATES];
        for k in 0..n {
            for j in (0..n).filter(|&j| j != k) {
                let bit = 1u32 << (4 * k + j);
                if dc[k] - half_diag > dc[j] + half_diag + DOMINANCE_MARGIN {
                    for r in records.iter_mut() {
                        *r |= bit;
                    }
                    continue;
                }
                if dc[j] - half_diag > dc[k] + half_diag + DOMINANCE_MARGIN {
                    continue;
                }
                for m in [k, j] {
                    if sub_d[m].is_none() {
                        let l = &lines[ids[m] as usize];
                        sub_d[m] = Some(std::array::from_fn(|s| {
                            let (si, sj) = ((s % SUB) as f64, (s / SUB) as f64);
                            distance(
                                l,
                                [
                                    corner[0] + (si + 0.5) * sub_res,
                                    corner[1] + (sj + 0.5) * sub_res,
                                ],
                            )
                        }));
                    }
                }
                let (dk, dj) = (sub_d[k].unwrap(), sub_d[j].unwrap());
                for (s, r) in records.iter_mut().enumerate() {
                    if dk[s] - sub_half_diag > dj[s] + sub_half_diag + DOMINANCE_MARGIN {
                        *r |= bit;
                    }
                }
            }
        }
        for r in records.iter_mut() {
            let mut left = present;
            for k in 0..n {
                if (*r >> (4 * k)) & 0xf != 0 {
                    left &= !(1 << k);
                }
            }
            *r |= left << 16;
        }
    }
    (sub_cells, dominated)
}

/// A point's nearest map segment.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correspondence {
    /// Index into [`LineMap::lines`].
    pub line: usize,
    /// Distance from the point to the segment.
    pub distance: f64,
    /// From the segment's closest point to the point.
    pub residual: [f64; 2],
}

#[cfg(test)]
mod tests {
    use super::*;
    use atrium_worlds::Segment;

    fn square() -> VectorMap {
        // A 4 × 4 m square room plus a short partition from (2, 0) to (2, 1).
        let s = |a: [f64; 2], b: [f64; 2]| Segment { a, b };
        VectorMap {
            segments: vec![
                s([0.0, 0.0], [4.0, 0.0]),
                s([4.0, 0.0], [4.0, 4.0]),
                s([4.0, 4.0], [0.0, 4.0]),
                s([0.0, 4.0], [0.0, 0.0]),
                s([2.0, 0.0], [2.0, 1.0]),
            ],
        }
    }

    #[test]
    fn nearest_matches_brute_force() {
        let map = square();
        let lm = LineMap::new(&map, 0.1, 0.6).unwrap();
        let mut checked = 0;
        for i in 0..80 {
            for j in 0..80 {
                let p = [-0.5 + 0.0625 * i as f64, -0.5 + 0.0625 * j as f64];
                let brute = lm
                    .lines()
                    .iter()
                    .enumerate()
                    .map(|(k, l)| (k, l.segment_distance(p)))
                    .min_by(|a, b| a.1.total_cmp(&b.1))
                    .unwrap();
                match lm.nearest(p, None) {
                    Some((_, d)) => {
                        assert!((d - brute.1).abs() < 1e-12, "{p:?}");
                        checked += 1;
                    }
                    None => assert!(brute.1 > 0.6 - 1e-12, "{p:?}: {}", brute.1),
                }
            }
        }
        assert!(checked > 1000);
        // With a normal constraint: near the partition's end, a point with a y-normal
        // corresponds to the bottom wall, not the (closer) vertical partition.
        let p = [2.05, 0.3];
        assert_eq!(lm.nearest(p, None).unwrap().0, 4);
        let (id, d) = lm.nearest(p, Some(([0.0, 1.0], 0.8))).unwrap();
        assert_eq!(id, 0);
        assert!((d - 0.3).abs() < 1e-12);
        // Signed offset along the normal (bottom wall's normal is +y).
        assert!((lm.lines()[0].line_offset([1.0, 0.25]) - 0.25).abs() < 1e-12);
        assert!(LineMap::new(&VectorMap::default(), 0.1, 0.5).is_err());
        assert!(LineMap::new(&map, 0.0, 0.5).is_err());
    }

    #[test]
    fn residual_length_is_hypot_bit_for_bit() {
        let values = [
            0.0,
            -0.0,
            5e-324,
            1e-310,
            3.7e-9,
            0.1,
            -2.25,
            1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
        ];
        for a in values {
            for b in values {
                let (got, want) = (residual_length([a, b]), a.hypot(b));
                assert!(
                    got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                    "({a}, {b}): {got} against {want}"
                );
            }
        }
    }

    /// The search as it was before `correspondence` ranked by squares: `hypot` of every
    /// candidate, the first strictly nearest within reach wins.
    fn nearest_by_hypot(
        lm: &LineMap,
        p: [f64; 2],
        normal: Option<([f64; 2], f64)>,
    ) -> Option<(usize, f64)> {
        let mut best: Option<(usize, f64)> = None;
        for &id in lm.candidates(p) {
            let l = &lm.lines()[id as usize];
            if let Some((n, min_cos)) = normal {
                if (n[0] * l.normal[0] + n[1] * l.normal[1]).abs() < min_cos {
                    continue;
                }
            }
            let d = l.segment_distance(p);
            if d <= lm.reach() && best.is_none_or(|(_, bd)| d < bd) {
                best = Some((id as usize, d));
            }
        }
        best
    }

    #[test]
    fn correspondence_is_the_hypot_search_bit_for_bit() {
        // Equidistant points (diagonals of the square's corners, the partition's mid-line)
        // and random ones, with and without a normal constraint; in the square, and with a
        // 0.1 m and a 0.05 m thick wall (both faces and end caps, one at an angle) inside
        // it, whose near and far faces share cells and split them into dominated sub-cells.
        let s = |a: [f64; 2], b: [f64; 2]| atrium_worlds::Segment { a, b };
        let rect = |map: &mut VectorMap, c: [[f64; 2]; 4]| {
            for k in 0..4 {
                map.segments.push(s(c[k], c[(k + 1) % 4]));
            }
        };
        let mut thick = square();
        rect(&mut thick, [[0.5, 2.0], [3.5, 2.0], [3.5, 2.1], [0.5, 2.1]]);
        let (u, v) = ([0.8, 0.6], [-0.6 * 0.05, 0.8 * 0.05]);
        let a = [1.0, 2.6];
        let b = [a[0] + 2.0 * u[0], a[1] + 2.0 * u[1]];
        rect(
            &mut thick,
            [a, b, [b[0] + v[0], b[1] + v[1]], [a[0] + v[0], a[1] + v[1]]],
        );
        for (seed, lm) in [
            (0, LineMap::new(&square(), 0.1, 0.6).unwrap()),
            (1, LineMap::new(&thick, 0.1, 0.6).unwrap()),
            (2, LineMap::new(&thick, 0.07, 0.5).unwrap()),
        ] {
            check_against_hypot_search(&lm, seed);
        }
    }

    fn check_against_hypot_search(lm: &LineMap, seed: u64) {
        let mut rng = 0x2545_f491_4f6c_dd1du64 + seed;
        let mut uniform = || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let mut points = Vec::new();
        for k in 0..4000 {
            let t = 0.6 * uniform() - 0.05;
            points.push([t, t]);
            points.push([4.0 - t, t]);
            points.push([2.0 + (k % 3) as f64 * 1e-17, uniform() * 1.5]);
            points.push([uniform() * 5.0 - 0.5, uniform() * 5.0 - 0.5]);
        }
        let normals = [None, Some(([0.0, 1.0], 0.8)), Some(([0.6, 0.8], 0.5))];
        let mut found = 0;
        for p in &points {
            for n in normals {
                let c = lm.correspondence(*p, n);
                let reference = nearest_by_hypot(lm, *p, n);
                assert_eq!(
                    c.map(|c| (c.line, c.distance.to_bits())),
                    reference.map(|(i, d)| (i, d.to_bits())),
                    "{p:?} {n:?}"
                );
                if let Some(c) = c {
                    let r = lm.lines()[c.line].residual(*p);
                    assert_eq!(c.residual, r);
                    found += 1;
                }
            }
        }
        assert!(found > 20_000, "{found}");
        // The thick walls put two or more candidates in many cells, and the masks leave one
        // in most of their sub-cells.
        if seed > 0 {
            let records = lm.dominated.len();
            let pruned = lm.dominated.iter().filter(|&&d| d & 0xffff != 0).count();
            assert!(records > 1000 && pruned > records / 2, "{records} {pruned}");
        }
    }

    #[test]
    fn a_grid_over_the_limit_is_refused_before_it_is_allocated() {
        let e = LineMap::new(&square(), 1e-6, 0.5).unwrap_err().to_string();
        assert!(
            e.contains("map_resolution: 0.000001 m over the 5 m × 5 m vector map")
                && e.contains("more than the limit of 20000000 (LINE_MAP_MAX_CELLS)"),
            "{e}"
        );
        // 1e-300 used to overflow the width to usize::MAX + 1.
        assert!(LineMap::new(&square(), 1e-300, 0.5).is_err());
        // The finest resolution the limit allows for this square: 5 m / √(2·10⁷) ≈ 1.12 mm.
        let r = crate::limits::finest_resolution([5.0, 5.0], crate::limits::LINE_MAP_MAX_CELLS);
        assert!(crate::limits::check_grid("g", r, [5.0, 5.0], "m", 20_000_000, "L").is_ok());
    }
}
