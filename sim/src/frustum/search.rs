//! The search of one image row (see `frustum.rs`): each pixel's nearest hit among the
//! candidates that cover it, kept in columns so that a cuboid is cast on eight pixels at a
//! time (`avx.rs`), with the scalar twin of every kernel. Also the cuboid cast itself
//! ([`cast_cuboid`]), parry's, in brief.

use rapier3d::parry::query::RayCast;
use rapier3d::parry::shape::{Cuboid, FeatureId};
use rapier3d::prelude::*;

/// Relative separation under which two hits (or a hit and the maximum length) count as tied.
pub(super) const TIE: f32 = 1e-5;

/// Pixels cast together: a row's rays are turned into the world, and into each cuboid's frame
/// and slab-tested, this many at a time (`avx.rs`).
pub(super) const LANES: usize = 8;
/// [`CuboidLanes::code`]s: what `cast_cuboid` returned for a lane.
pub(super) const MISS: f32 = 0.0;
pub(super) const INSIDE: f32 = 1.0;
pub(super) const ENTERS: f32 = 2.0;
pub(super) const ASK: f32 = 3.0;

/// One row's world ray directions in columns, a whole group of lanes longer than the row.
#[derive(Debug, Clone, Default)]
pub(super) struct Columns {
    pub(super) x: Vec<f32>,
    pub(super) y: Vec<f32>,
    pub(super) z: Vec<f32>,
}

impl Columns {
    pub(super) fn resize(&mut self, n: usize) {
        for c in [&mut self.x, &mut self.y, &mut self.z] {
            c.resize(n, 0.0);
        }
    }

    #[inline]
    pub(super) fn get(&self, u: usize) -> Vector {
        Vector::new(self.x[u], self.y[u], self.z[u])
    }
}

/// `cast_cuboid` for the rays of `LANES` consecutive pixels, in columns: `code` says what it
/// returned (MISS for no hit, ASK for None), `toi` and `side` describe a hit, and `dir` holds
/// each ray's direction in the cuboid's frame for the lanes parry must cast.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct CuboidLanes {
    pub(super) dir: [[f32; LANES]; 3],
    pub(super) code: [f32; LANES],
    pub(super) toi: [f32; LANES],
    pub(super) side: [f32; LANES],
}

impl CuboidLanes {
    /// Lane `j`'s hit where `cast_cuboid` answered.
    #[inline]
    pub(super) fn found(&self, j: usize) -> Option<Found> {
        let side = self.side[j] as i8;
        match self.code[j] {
            INSIDE => Some(Found::Cuboid(CuboidHit::Inside { side })),
            ENTERS => Some(Found::Cuboid(CuboidHit::Enters {
                toi: self.toi[j],
                side,
            })),
            _ => None,
        }
    }

    /// Lane `j`'s hit where `cast_cuboid` could not answer: parry's.
    #[inline]
    pub(super) fn ask_parry(
        &self,
        j: usize,
        cuboid: &Cuboid,
        origin: Vector,
        max_toi: f32,
    ) -> Option<Found> {
        let dir = Vector::new(self.dir[0][j], self.dir[1][j], self.dir[2][j]);
        cuboid
            .cast_local_ray_and_get_normal(&Ray::new(origin, dir), max_toi, true)
            .map(Found::Shape)
    }

    /// What the AVX kernel computes, lane by lane with the scalar code, for the lanes in
    /// `active` (a bit per lane).
    pub(super) fn cast_scalar(&mut self, g: &CuboidGroup, active: u32) {
        for j in (0..LANES).filter(|j| active & (1 << j) != 0) {
            let dir = g.inv_rotation * g.world.get(g.u + j);
            for (col, x) in self.dir.iter_mut().zip(dir.to_array()) {
                col[j] = x;
            }
            let (code, toi, side) = match cast_cuboid(g.half, &Ray::new(g.origin, dir), g.max_toi) {
                None => (ASK, 0.0, 0),
                Some(None) => (MISS, 0.0, 0),
                Some(Some(CuboidHit::Inside { side })) => (INSIDE, 0.0, side),
                Some(Some(CuboidHit::Enters { toi, side })) => (ENTERS, toi, side),
            };
            self.code[j] = code;
            self.toi[j] = toi;
            self.side[j] = side as f32;
        }
    }
}

/// One candidate cuboid (`k`: of half extents `half`, no hit nearer than `near`, the camera
/// at `origin` in its frame, `inv_rotation` turning world directions into it) and the pixels
/// `u..u + n` of a row (world directions in `world`) it is cast on together.
#[derive(Clone, Copy)]
pub(super) struct CuboidGroup<'a> {
    pub(super) near: f32,
    pub(super) origin: Vector,
    pub(super) inv_rotation: Rotation,
    pub(super) half: Vector,
    pub(super) k: usize,
    pub(super) world: &'a Columns,
    pub(super) u: usize,
    pub(super) n: usize,
    pub(super) max_toi: f32,
}

/// [`RowSearch::code`] of a nearest hit kept in [`RowSearch::shape`].
pub(super) const SHAPE: f32 = 4.0;

/// Each pixel's search so far, for one row, in columns (the AVX kernel reads and updates
/// eight pixels at a time): its nearest hit, the nearest other hit (for ties), and whether
/// the remaining candidates are all too far to matter. The columns run a whole group of
/// lanes past the row.
#[derive(Debug, Clone, Default)]
pub(super) struct RowSearch {
    /// Time of the nearest hit (∞ before the first).
    pub(super) toi: Vec<f32>,
    pub(super) second: Vec<f32>,
    /// All bits set once the pixel is done.
    pub(super) done: Vec<u32>,
    /// The nearest hit's candidate.
    pub(super) cand: Vec<u32>,
    /// The nearest hit: MISS for none yet, INSIDE or ENTERS (with `side` and `toi`) for a
    /// cuboid's, SHAPE for one in `shape`.
    pub(super) code: Vec<f32>,
    pub(super) side: Vec<f32>,
    pub(super) shape: Vec<RayIntersection>,
}

impl RowSearch {
    pub(super) fn reset(&mut self, n: usize) {
        for (c, x) in [
            (&mut self.toi, f32::INFINITY),
            (&mut self.second, f32::INFINITY),
        ] {
            c.clear();
            c.resize(n, x);
        }
        self.code.clear();
        self.code.resize(n, MISS);
        self.done.clear();
        self.done.resize(n, 0);
        self.cand.resize(n, 0);
        self.side.resize(n, 0.0);
        self.shape.resize(
            n,
            RayIntersection::new(0.0, Vector::ZERO, FeatureId::Unknown),
        );
    }

    /// Whether candidate `near` (sorted by it) may still give or tie pixel `u`'s hit; once
    /// it may not, no later candidate can.
    #[inline]
    pub(super) fn wants(&mut self, u: usize, near: f32) -> bool {
        if self.done[u] != 0 {
            return false;
        }
        // Before the first hit the threshold is ∞: every candidate is wanted.
        if near > self.toi[u] * (1.0 + 2.0 * TIE) {
            self.done[u] = u32::MAX;
            return false;
        }
        true
    }

    #[inline]
    pub(super) fn offer(&mut self, u: usize, k: usize, hit: Option<Found>) {
        let Some(hit) = hit else {
            return;
        };
        let t = hit.toi();
        // Not nearer: the nearest other. Nearer: the old nearest (∞ if none) is.
        if t >= self.toi[u] {
            self.second[u] = self.second[u].min(t);
            return;
        }
        self.second[u] = self.second[u].min(self.toi[u]);
        self.toi[u] = t;
        self.cand[u] = k as u32;
        match hit {
            Found::Cuboid(CuboidHit::Inside { side }) => {
                self.code[u] = INSIDE;
                self.side[u] = side as f32;
            }
            Found::Cuboid(CuboidHit::Enters { side, .. }) => {
                self.code[u] = ENTERS;
                self.side[u] = side as f32;
            }
            Found::Shape(r) => {
                self.code[u] = SHAPE;
                self.shape[u] = r;
            }
        }
    }

    /// Pixel `u`'s nearest hit and its candidate.
    #[inline]
    pub(super) fn best(&self, u: usize) -> Option<(usize, Found)> {
        let side = self.side[u] as i8;
        let found = match self.code[u] {
            INSIDE => Found::Cuboid(CuboidHit::Inside { side }),
            ENTERS => Found::Cuboid(CuboidHit::Enters {
                toi: self.toi[u],
                side,
            }),
            SHAPE => Found::Shape(self.shape[u]),
            _ => return None,
        };
        Some((self.cand[u] as usize, found))
    }

    /// The scalar twin of `avx::cuboid_lanes`: the group's cuboid offered to its pixels.
    /// Returns the lanes parry must cast (their rays in `lanes.dir`).
    pub(super) fn cuboid_scalar(&mut self, g: &CuboidGroup, lanes: &mut CuboidLanes) -> u32 {
        let mut active = 0u32;
        for j in 0..g.n {
            if self.wants(g.u + j, g.near) {
                active |= 1 << j;
            }
        }
        if active == 0 {
            return 0;
        }
        lanes.cast_scalar(g, active);
        let mut ask = 0;
        for j in (0..g.n).filter(|j| active & (1 << j) != 0) {
            if lanes.code[j] == ASK {
                ask |= 1 << j;
            } else {
                self.offer(g.u + j, g.k, lanes.found(j));
            }
        }
        ask
    }
}

/// A pixel's hit on one candidate: a cuboid's in brief, or a shape's as parry gives it.
#[derive(Debug, Clone, Copy)]
pub(super) enum Found {
    Cuboid(CuboidHit),
    Shape(RayIntersection),
}

impl Found {
    #[inline]
    pub(super) fn toi(&self) -> f32 {
        match self {
            Found::Cuboid(h) => h.toi(),
            Found::Shape(h) => h.time_of_impact,
        }
    }

    #[inline]
    pub(super) fn intersection(self) -> RayIntersection {
        match self {
            Found::Cuboid(h) => h.intersection(),
            Found::Shape(h) => h,
        }
    }
}

/// What [`cast_cuboid`] found, in brief: a time and a face, which fit in a register where
/// parry's `RayIntersection` went through memory (reading it back after each cast stalled:
/// 14 % of a depth frame's samples fell on that one load). [`CuboidHit::intersection`]
/// builds parry's answer, for the nearest hit of a pixel only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CuboidHit {
    /// The origin is inside the box; the ray leaves through `side`.
    Inside { side: i8 },
    /// The ray enters through `side` at time `toi`.
    Enters { toi: f32, side: i8 },
}

impl CuboidHit {
    #[inline]
    pub fn toi(self) -> f32 {
        match self {
            CuboidHit::Inside { .. } => 0.0,
            CuboidHit::Enters { toi, .. } => toi,
        }
    }

    /// parry's `RayIntersection` of this hit: sides ±1..±3 are the faces of +x..+z
    /// (negative: of −x..−z); an entered face's normal points against the ray, and a ray
    /// from inside has time 0 and a zero normal.
    #[inline]
    pub fn intersection(self) -> RayIntersection {
        let feature = |side: i8| {
            if side < 0 {
                FeatureId::Face((-side) as u32 - 1 + 3)
            } else {
                FeatureId::Face(side as u32 - 1)
            }
        };
        match self {
            CuboidHit::Inside { side } => RayIntersection::new(0.0, Vector::ZERO, feature(side)),
            CuboidHit::Enters { toi, side } => {
                // Built in registers: an array written one lane and read whole stalled.
                let (axis, n) = if side < 0 { (-side, 1.0) } else { (side, -1.0) };
                let normal = match axis {
                    1 => Vector::new(n, 0.0, 0.0),
                    2 => Vector::new(0.0, n, 0.0),
                    _ => Vector::new(0.0, 0.0, n),
                };
                RayIntersection::new(toi, normal, feature(side))
            }
        }
    }
}

/// `Cuboid::cast_local_ray_and_get_normal(ray, max_toi, true)` (parry's `clip_aabb_line`
/// and `ray_aabb` on the box ±`half`) for the common case, with the very operations parry
/// performs there, in its order, minus the generic per-axis indexing and tuple returns that
/// made it a third of a depth frame. The common case: every direction component non-zero
/// with a finite inverse, and no two slabs entered or left at the same parameter. For
/// anything else (`None`), parry itself must be asked.
#[inline]
pub fn cast_cuboid(half: Vector, ray: &Ray, max_toi: f32) -> Option<Option<CuboidHit>> {
    let (o, d) = (ray.origin.to_array(), ray.dir.to_array());
    let (mins, maxs) = ((-half).to_array(), half.to_array());
    let mut tmax = f32::MAX;
    let mut tmin = -tmax;
    let (mut near_side, mut far_side) = (0i8, 0i8);
    let (mut near_diag, mut far_diag) = (false, false);
    for i in 0..3 {
        // parry's zero-direction branch (and NaN) are left to parry.
        if d[i] == 0.0 || d[i].is_nan() {
            return None;
        }
        let denom = 1.0 / d[i];
        if !denom.is_finite() {
            return None;
        }
        let mut near = (mins[i] - o[i]) * denom;
        let mut far = (maxs[i] - o[i]) * denom;
        let flip = near > far;
        if flip {
            std::mem::swap(&mut near, &mut far);
        }
        let side = i as i8 + 1;
        if near > tmin {
            tmin = near;
            near_side = if flip { -side } else { side };
            near_diag = false;
        } else if near == tmin {
            near_diag = true;
        }
        if far < tmax {
            tmax = far;
            far_side = if flip { side } else { -side };
            far_diag = false;
        } else if far == tmax {
            far_diag = true;
        }
        if tmax < 0.0 || tmin > tmax {
            return Some(None);
        }
    }
    if near_diag || far_diag || near_side == 0 || far_side == 0 {
        return None;
    }
    Some(if tmin < 0.0 {
        Some(CuboidHit::Inside { side: far_side })
    } else if tmin <= max_toi {
        Some(CuboidHit::Enters {
            toi: tmin,
            side: near_side,
        })
    } else {
        None
    })
}
