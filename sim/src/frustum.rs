//! First-hit ray casts for a pinhole image (every ray from one origin), bit-identical to
//! rapier's `QueryPipeline::cast_ray_and_get_normal` and several times cheaper.
//!
//! The query pipeline walks its BVH for every ray; in a building most of that walk tests node
//! boxes (the floor and ceiling slabs span the whole world, so every ray enters the root's
//! children). Here, once per frame, every collider the pipeline could return within the
//! maximum ray length is projected into the image: its BVH leaf box (which contains the
//! shape, as the pipeline relies on too) clipped to the half-space in front of the camera,
//! widened by a pixel. A pixel then casts only on the colliders whose image rectangle covers
//! it — typically the floor or the ceiling and one to three walls — with the very same
//! per-shape call the pipeline makes (`Shape::cast_ray_and_get_normal` at the collider's
//! position), and keeps the nearest.
//!
//! Why the result is the pipeline's, bit for bit: both evaluate the same function on the same
//! inputs for each collider (the pipeline's `max_toi` argument only decides acceptance, never
//! the value), and the pipeline returns the nearest of those hits. Where that is not certain —
//! two colliders within a relative 1e-5 of each other (a corner; the pipeline keeps whichever
//! its traversal met first), or a nearest hit within 1e-5 of the maximum length (where its
//! node tests cut off) — the pixel falls back to the pipeline itself. A ray can only hit a
//! collider in front of the camera plane (x ≥ ε in the camera frame) or within ε / cos of the
//! origin; colliders reaching that close get the whole image.

use rapier3d::parry::bounding_volume::Aabb;
use rapier3d::parry::query::RayCast;
use rapier3d::parry::shape::{Cuboid, FeatureId};
use rapier3d::prelude::*;

#[cfg(target_arch = "x86_64")]
mod avx;

/// Image-plane intrinsics of a pinhole camera whose REP-103 frame looks along +x: a camera-
/// frame direction (1, −(u − cx)/fx, −(v − cy)/fy) goes through pixel (u, v).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pinhole {
    pub width: usize,
    pub height: usize,
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    /// Smallest cosine between any pixel's ray and the optical axis.
    pub min_axial: f64,
}

/// Camera-frame depth of the clipping plane, m: hits nearer than this along the axis are
/// only possible on colliders within `NEAR / min_axial` of the origin.
const NEAR: f64 = 0.01;
/// Growth of each projected rectangle, pixels (float error of the projection is far below).
const MARGIN_PX: f64 = 1.0;
/// Relative separation under which two hits (or a hit and the maximum length) count as tied.
const TIE: f32 = 1e-5;

#[derive(Debug, Clone, Copy)]
struct Candidate {
    handle: ColliderHandle,
    u0: usize,
    u1: usize,
    v0: usize,
    v1: usize,
    /// Lower bound on any hit's distance (to the leaf box, less a millimetre), m.
    near: f32,
    /// Cuboids (walls, boxes, floor, ceiling) are cast here without the trait object, with
    /// the ray's origin moved into their frame once per frame — the very operations
    /// `RayCast::cast_ray_and_get_normal` performs, in the same order.
    cuboid: Option<Cuboid>,
    pose: Pose,
    inv_rotation: Rotation,
    local_origin: Vector,
    /// A cuboid's face normals in the world, `pose.rotation` times the local ones, as
    /// `RayIntersection::transform_by` turns them: sides −3..3 at 0..6 (3: a ray from
    /// inside, whose normal is zero). Turned once per frame instead of once per pixel.
    world_normals: [Vector; 7],
}

impl Candidate {
    /// A cuboid hit in the world frame: `hit.intersection().transform_by(&self.pose)`.
    #[inline]
    fn world_hit(&self, hit: CuboidHit) -> RayIntersection {
        let side = match hit {
            CuboidHit::Inside { .. } => 0,
            CuboidHit::Enters { side, .. } => side,
        };
        let mut r = hit.intersection();
        r.normal = self.world_normals[(side + 3) as usize];
        r
    }
}

/// Pixels cast together: a row's rays are turned into the world, and into each cuboid's frame
/// and slab-tested, this many at a time (`avx.rs`).
const LANES: usize = 8;
/// [`CuboidLanes::code`]s: what `cast_cuboid` returned for a lane.
const MISS: f32 = 0.0;
const INSIDE: f32 = 1.0;
const ENTERS: f32 = 2.0;
const ASK: f32 = 3.0;

/// One row's world ray directions in columns, a whole group of lanes longer than the row.
#[derive(Debug, Clone, Default)]
struct Columns {
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
}

impl Columns {
    fn resize(&mut self, n: usize) {
        for c in [&mut self.x, &mut self.y, &mut self.z] {
            c.resize(n, 0.0);
        }
    }

    fn get(&self, u: usize) -> Vector {
        Vector::new(self.x[u], self.y[u], self.z[u])
    }
}

/// `cast_cuboid` for the rays of `LANES` consecutive pixels, in columns: `code` says what it
/// returned (MISS for no hit, ASK for None), `toi` and `side` describe a hit, and `dir` holds
/// each ray's direction in the cuboid's frame for the lanes parry must cast.
#[derive(Debug, Clone, Copy, Default)]
struct CuboidLanes {
    dir: [[f32; LANES]; 3],
    code: [f32; LANES],
    toi: [f32; LANES],
    side: [f32; LANES],
}

impl CuboidLanes {
    /// Lane `j`'s hit where `cast_cuboid` answered.
    #[inline]
    fn found(&self, j: usize) -> Option<Found> {
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
    fn ask_parry(&self, j: usize, cuboid: &Cuboid, origin: Vector, max_toi: f32) -> Option<Found> {
        let dir = Vector::new(self.dir[0][j], self.dir[1][j], self.dir[2][j]);
        cuboid
            .cast_local_ray_and_get_normal(&Ray::new(origin, dir), max_toi, true)
            .map(Found::Shape)
    }

    /// What the AVX kernel computes, lane by lane with the scalar code, for the lanes in
    /// `active` (a bit per lane).
    #[allow(clippy::too_many_arguments)]
    fn cast_scalar(
        &mut self,
        half: Vector,
        origin: Vector,
        inv_rotation: Rotation,
        world: &Columns,
        u: usize,
        max_toi: f32,
        active: u32,
    ) {
        for j in (0..LANES).filter(|j| active & (1 << j) != 0) {
            let dir = inv_rotation * world.get(u + j);
            for (col, x) in self.dir.iter_mut().zip(dir.to_array()) {
                col[j] = x;
            }
            let (code, toi, side) = match cast_cuboid(half, &Ray::new(origin, dir), max_toi) {
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

/// One candidate cuboid (`k`, of half extents `half`) and the pixels `u..u + n` of a row
/// (world directions in `world`) it is cast on together.
#[derive(Clone, Copy)]
struct CuboidGroup<'a> {
    c: &'a Candidate,
    half: Vector,
    k: usize,
    world: &'a Columns,
    u: usize,
    n: usize,
    max_toi: f32,
}

/// [`RowSearch::code`] of a nearest hit kept in [`RowSearch::shape`].
const SHAPE: f32 = 4.0;

/// Each pixel's search so far, for one row, in columns (the AVX kernel reads and updates
/// eight pixels at a time): its nearest hit, the nearest other hit (for ties), and whether
/// the remaining candidates are all too far to matter. The columns run a whole group of
/// lanes past the row.
#[derive(Debug, Clone, Default)]
struct RowSearch {
    /// Time of the nearest hit (∞ before the first).
    toi: Vec<f32>,
    second: Vec<f32>,
    /// All bits set once the pixel is done.
    done: Vec<u32>,
    /// The nearest hit's candidate.
    cand: Vec<u32>,
    /// The nearest hit: MISS for none yet, INSIDE or ENTERS (with `side` and `toi`) for a
    /// cuboid's, SHAPE for one in `shape`.
    code: Vec<f32>,
    side: Vec<f32>,
    shape: Vec<RayIntersection>,
}

impl RowSearch {
    fn reset(&mut self, n: usize) {
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
    fn wants(&mut self, u: usize, near: f32) -> bool {
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
    fn offer(&mut self, u: usize, k: usize, hit: Option<Found>) {
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
    fn best(&self, u: usize) -> Option<(usize, Found)> {
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
    fn cuboid_scalar(&mut self, g: &CuboidGroup, lanes: &mut CuboidLanes) -> u32 {
        let CuboidGroup {
            c,
            half,
            k,
            world,
            u,
            n,
            max_toi,
        } = *g;
        let mut active = 0u32;
        for j in 0..n {
            if self.wants(u + j, c.near) {
                active |= 1 << j;
            }
        }
        if active == 0 {
            return 0;
        }
        lanes.cast_scalar(
            half,
            c.local_origin,
            c.inv_rotation,
            world,
            u,
            max_toi,
            active,
        );
        let mut ask = 0;
        for j in (0..n).filter(|j| active & (1 << j) != 0) {
            if lanes.code[j] == ASK {
                ask |= 1 << j;
            } else {
                self.offer(u + j, k, lanes.found(j));
            }
        }
        ask
    }
}

/// Per-frame culling state; keep one per camera and reuse it (no allocation per frame once
/// warmed up).
#[derive(Debug, Clone)]
pub struct FrustumCaster {
    candidates: Vec<Candidate>,
    /// Candidates whose rows cover the current row (indices into `candidates`).
    row: Vec<usize>,
    /// The current row's world ray directions and per-pixel searches.
    world: Columns,
    search: RowSearch,
    lanes: CuboidLanes,
    /// Whether the AVX kernels run (else their scalar twins).
    simd: bool,
    /// Pixels that fell back to the pipeline in the last frame (for tests and benches).
    fallbacks: usize,
}

/// What one pixel's cast found: the collider and the pipeline's hit.
pub type Hit = (ColliderHandle, RayIntersection);

impl Default for FrustumCaster {
    fn default() -> Self {
        Self::new()
    }
}

impl FrustumCaster {
    pub fn new() -> Self {
        #[cfg(target_arch = "x86_64")]
        let simd = avx::available();
        #[cfg(not(target_arch = "x86_64"))]
        let simd = false;
        Self {
            candidates: Vec::new(),
            row: Vec::new(),
            world: Columns::default(),
            search: RowSearch::default(),
            lanes: CuboidLanes::default(),
            simd,
            fallbacks: 0,
        }
    }

    /// A caster that never runs the AVX kernels: the portable path, for tests and benches
    /// on processors that have AVX.
    pub fn without_simd() -> Self {
        Self {
            simd: false,
            ..Self::new()
        }
    }

    /// Pixels of the last [`FrustumCaster::render`] that needed the pipeline.
    pub fn fallbacks(&self) -> usize {
        self.fallbacks
    }

    /// Casts one ray per pixel from the camera at `cam` (world frame), row-major: `dirs[i]`
    /// is pixel i's unit direction in the camera frame. Calls `out(i, world_dir, hit)` for
    /// every pixel, in order, with exactly what
    /// `query.cast_ray_and_get_normal(&Ray::new(cam.translation, cam.rotation * dirs[i]),
    /// max_toi, true)` returns.
    ///
    /// A row is searched candidate by candidate, nearest first, over the pixels each covers,
    /// so that the rays of neighbouring pixels are cast on a cuboid together. Each pixel still
    /// meets its candidates in the same order, and stops at the same one, as when it was
    /// searched on its own.
    pub fn render(
        &mut self,
        query: &QueryPipeline,
        cam: &Pose,
        pin: &Pinhole,
        dirs: &[Vector],
        max_toi: f32,
        mut out: impl FnMut(usize, Vector, Option<Hit>),
    ) {
        debug_assert_eq!(dirs.len(), pin.width * pin.height);
        self.prepare(query, cam, pin, max_toi);
        self.fallbacks = 0;
        let origin = cam.translation;
        let w = pin.width;
        self.world.resize(w.div_ceil(LANES) * LANES + LANES);
        for v in 0..pin.height {
            self.search_row(query, cam, v, &dirs[v * w..(v + 1) * w], max_toi);
            // Only this loop is generic in `out`, so that `out` is inlined into it: a hit
            // passed to it through memory just after being written stalled its reads.
            for u in 0..w {
                let i = v * w + u;
                let dir = self.world.get(u);
                let best: Option<Hit> = self.search.best(u).map(|(k, hit)| {
                    let c = &self.candidates[k];
                    let hit = match (c.cuboid, hit) {
                        (Some(_), Found::Cuboid(h)) => c.world_hit(h),
                        (Some(_), Found::Shape(h)) => h.transform_by(&c.pose),
                        (None, h) => h.intersection(),
                    };
                    (c.handle, hit)
                });
                let certain = match &best {
                    None => true,
                    Some((_, b)) => {
                        let t = b.time_of_impact;
                        let second = self.search.second[u];
                        second - t > TIE * t.max(1e-3) && max_toi - t > TIE * max_toi
                    }
                };
                if certain {
                    out(i, dir, best);
                } else {
                    self.fallbacks += 1;
                    let ray = Ray::new(origin, dir);
                    out(i, dir, query.cast_ray_and_get_normal(&ray, max_toi, true));
                }
            }
        }
    }

    /// Searches row `v` (its camera-frame directions `row_dirs`): the row's world directions
    /// and each pixel's nearest hit and nearest other hit, in `world` and `search`.
    fn search_row(
        &mut self,
        query: &QueryPipeline,
        cam: &Pose,
        v: usize,
        row_dirs: &[Vector],
        max_toi: f32,
    ) {
        let colliders = query.colliders;
        let origin = cam.translation;
        let w = row_dirs.len();
        let Self {
            candidates,
            row,
            world,
            search,
            lanes,
            simd,
            ..
        } = self;
        let simd = *simd;
        row.clear();
        row.extend(
            candidates
                .iter()
                .enumerate()
                .filter(|(_, c)| c.v0 <= v && v <= c.v1)
                .map(|(k, _)| k),
        );
        if simd {
            // SAFETY: `simd` is set only where the processor has AVX, and the columns
            // hold a whole group past the row.
            #[cfg(target_arch = "x86_64")]
            unsafe {
                avx::rotate_row(cam.rotation, row_dirs, world)
            };
        } else {
            for (u, d) in row_dirs.iter().enumerate() {
                let r = cam.rotation * *d;
                (world.x[u], world.y[u], world.z[u]) = (r.x, r.y, r.z);
            }
        }
        search.reset(w + LANES);
        for &k in row.iter() {
            let c = &candidates[k];
            for u in (c.u0..=c.u1).step_by(LANES) {
                let n = (c.u1 + 1 - u).min(LANES);
                match &c.cuboid {
                    Some(cuboid) => {
                        let group = CuboidGroup {
                            c,
                            half: cuboid.half_extents,
                            k,
                            world,
                            u,
                            n,
                            max_toi,
                        };
                        let ask = if simd {
                            // SAFETY: as above; the columns hold `u + LANES` values.
                            #[cfg(target_arch = "x86_64")]
                            unsafe {
                                avx::cuboid_lanes(&group, search, lanes)
                            }
                            #[cfg(not(target_arch = "x86_64"))]
                            unreachable!()
                        } else {
                            search.cuboid_scalar(&group, lanes)
                        };
                        for j in (0..n).filter(|j| ask & (1 << j) != 0) {
                            let hit = lanes.ask_parry(j, cuboid, c.local_origin, max_toi);
                            search.offer(u + j, k, hit);
                        }
                    }
                    None => {
                        let co = &colliders[c.handle];
                        for j in 0..n {
                            if !search.wants(u + j, c.near) {
                                continue;
                            }
                            let ray = Ray::new(origin, world.get(u + j));
                            let hit = co
                                .shape()
                                .cast_ray_and_get_normal(co.position(), &ray, max_toi, true)
                                .map(Found::Shape);
                            search.offer(u + j, k, hit);
                        }
                    }
                }
            }
        }
    }

    /// Projects every collider the pipeline could return within `max_toi` of the camera.
    fn prepare(&mut self, query: &QueryPipeline, cam: &Pose, pin: &Pinhole, max_toi: f32) {
        self.candidates.clear();
        let o = cam.translation;
        let reach = Vector::splat(max_toi);
        let region = Aabb::new(o - reach, o + reach);
        // The camera frame in f64: p_cam = R⁻¹ (p − o).
        let q = cam.rotation;
        let rot = nalgebra::UnitQuaternion::new_normalize(nalgebra::Quaternion::new(
            q.w as f64, q.x as f64, q.y as f64, q.z as f64,
        ));
        let inv = rot.inverse();
        let origin = nalgebra::Vector3::new(o.x as f64, o.y as f64, o.z as f64);
        let near_radius = 2.0 * NEAR / pin.min_axial;
        for id in query.bvh.intersect_aabb(&region) {
            let Some((co, handle)) = query.colliders.get_unknown_gen(id) else {
                continue;
            };
            if !query.filter.test(query.bodies, handle, co) {
                continue;
            }
            let Some(node) = query.bvh.leaf_node(id) else {
                continue;
            };
            let aabb = node.aabb();
            let (lo, hi) = (aabb.mins, aabb.maxs);
            // Near the origin: any pixel may hit it.
            let nearest = nalgebra::Vector3::new(
                (origin.x).clamp(lo.x as f64, hi.x as f64),
                (origin.y).clamp(lo.y as f64, hi.y as f64),
                (origin.z).clamp(lo.z as f64, hi.z as f64),
            );
            let (w, h) = (pin.width, pin.height);
            let dist = (nearest - origin).norm();
            let pose = *co.position();
            let inv_rotation = pose.rotation.inverse();
            let cuboid = co.shape().as_cuboid().copied();
            let mut world_normals = [Vector::ZERO; 7];
            if cuboid.is_some() {
                for (side, n) in (-3i8..=3).zip(&mut world_normals) {
                    let local = if side == 0 {
                        CuboidHit::Inside { side: 1 }
                    } else {
                        CuboidHit::Enters { toi: 0.0, side }
                    };
                    *n = pose.rotation * local.intersection().normal;
                }
            }
            let mut cand = Candidate {
                handle,
                u0: 0,
                u1: w - 1,
                v0: 0,
                v1: h - 1,
                near: (dist - 1e-3) as f32,
                cuboid,
                pose,
                inv_rotation,
                // `Pose::inverse_transform_point`, as `Ray::inverse_transform_by` computes it.
                local_origin: pose.inverse_transform_point(o),
                world_normals,
            };
            if dist <= near_radius {
                self.candidates.push(cand);
                continue;
            }
            let mut corners = [nalgebra::Vector3::zeros(); 8];
            for (k, c) in corners.iter_mut().enumerate() {
                let p = nalgebra::Vector3::new(
                    if k & 1 == 0 { lo.x } else { hi.x } as f64,
                    if k & 2 == 0 { lo.y } else { hi.y } as f64,
                    if k & 4 == 0 { lo.z } else { hi.z } as f64,
                );
                *c = inv * (p - origin);
            }
            let (mut umin, mut umax, mut vmin, mut vmax) = (
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            );
            let mut add = |p: &nalgebra::Vector3<f64>| {
                let u = pin.cx - pin.fx * p.y / p.x;
                let v = pin.cy - pin.fy * p.z / p.x;
                umin = umin.min(u);
                umax = umax.max(u);
                vmin = vmin.min(v);
                vmax = vmax.max(v);
            };
            for c in &corners {
                if c.x >= NEAR {
                    add(c);
                }
            }
            // Edges (corner pairs differing in one bit) crossing the clipping plane.
            for a in 0..8usize {
                for bit in [1usize, 2, 4] {
                    let b = a | bit;
                    if b == a {
                        continue;
                    }
                    let (pa, pb) = (corners[a], corners[b]);
                    if (pa.x - NEAR) * (pb.x - NEAR) < 0.0 {
                        let s = (NEAR - pa.x) / (pb.x - pa.x);
                        let mut p = pa + (pb - pa) * s;
                        p.x = NEAR;
                        add(&p);
                    }
                }
            }
            if umin > umax {
                // Wholly behind the clipping plane and not near the origin: no ray reaches it.
                continue;
            }
            let (umin, umax) = (umin - MARGIN_PX, umax + MARGIN_PX);
            let (vmin, vmax) = (vmin - MARGIN_PX, vmax + MARGIN_PX);
            if umax < 0.0 || vmax < 0.0 || umin > (w - 1) as f64 || vmin > (h - 1) as f64 {
                continue;
            }
            let clamp = |x: f64, n: usize| x.clamp(0.0, (n - 1) as f64);
            cand.u0 = clamp(umin, w).floor() as usize;
            cand.u1 = clamp(umax, w).ceil() as usize;
            cand.v0 = clamp(vmin, h).floor() as usize;
            cand.v1 = clamp(vmax, h).ceil() as usize;
            self.candidates.push(cand);
        }
        // Nearest first, so a pixel can stop at the first candidate beyond its best hit.
        self.candidates.sort_by(|a, b| {
            a.near.total_cmp(&b.near).then(
                a.handle
                    .into_raw_parts()
                    .0
                    .cmp(&b.handle.into_raw_parts().0),
            )
        });
    }
}

/// A pixel's hit on one candidate: a cuboid's in brief, or a shape's as parry gives it.
#[derive(Debug, Clone, Copy)]
enum Found {
    Cuboid(CuboidHit),
    Shape(RayIntersection),
}

impl Found {
    fn toi(&self) -> f32 {
        match self {
            Found::Cuboid(h) => h.toi(),
            Found::Shape(h) => h.time_of_impact,
        }
    }

    fn intersection(self) -> RayIntersection {
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
    pub fn toi(self) -> f32 {
        match self {
            CuboidHit::Inside { .. } => 0.0,
            CuboidHit::Enters { toi, .. } => toi,
        }
    }

    /// parry's `RayIntersection` of this hit: sides ±1..±3 are the faces of +x..+z
    /// (negative: of −x..−z); an entered face's normal points against the ray, and a ray
    /// from inside has time 0 and a zero normal.
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

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn columns(dirs: &[Vector]) -> Columns {
        let mut c = Columns::default();
        c.resize(dirs.len() + LANES);
        for (u, d) in dirs.iter().enumerate() {
            (c.x[u], c.y[u], c.z[u]) = (d.x, d.y, d.z);
        }
        c
    }

    fn random_rotation(rng: &mut ChaCha8Rng) -> Rotation {
        (Rotation::from_rotation_z(rng.random_range(-3.2..3.2))
            * Rotation::from_rotation_y(rng.random_range(-1.6..1.6))
            * Rotation::from_rotation_x(rng.random_range(-3.2..3.2)))
        .normalize()
    }

    /// Rays from random, axis-aligned and zero directions (every branch of the slab test:
    /// misses, hits from inside and outside, ties at edges and corners, parry's cases).
    fn random_dirs(rng: &mut ChaCha8Rng, n: usize) -> Vec<Vector> {
        (0..n)
            .map(|k| {
                let mut d = Vector::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                match k % 11 {
                    0 => d.x = 0.0,
                    1 => d = Vector::new(1.0, 1.0, 1.0),
                    2 => d = Vector::new(-0.0, 0.0, 1.0),
                    3 => d.z = 1e-40,
                    4 => d.y = f32::NAN,
                    _ => {}
                }
                d
            })
            .collect()
    }

    #[test]
    fn avx_kernels_are_the_scalar_code_bit_for_bit() {
        if !avx::available() {
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (mut codes, mut total) = ([0usize; 4], 0);
        for k in 0..3000 {
            let q = if k % 5 == 0 {
                Rotation::IDENTITY
            } else {
                random_rotation(&mut rng)
            };
            let dirs = random_dirs(&mut rng, 2 * LANES + 3);
            let mut simd = Columns::default();
            simd.resize(dirs.len().div_ceil(LANES) * LANES + LANES);
            // SAFETY: checked above; the columns hold a group past the row.
            unsafe { avx::rotate_row(q, &dirs, &mut simd) };
            for (u, d) in dirs.iter().enumerate() {
                let want = (q * *d).to_array().map(f32::to_bits);
                assert_eq!(
                    simd.get(u).to_array().map(f32::to_bits),
                    want,
                    "{q:?} {d:?}"
                );
            }
            let world = columns(&dirs);
            let half = Vector::new(
                rng.random_range(0.01..3.0),
                rng.random_range(0.01..3.0),
                rng.random_range(0.01..3.0),
            );
            // Half the origins on a face, edge or corner's extension (tied slabs).
            let mut origin = Vector::new(
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
            );
            if k % 2 == 0 {
                origin.x = half.x;
            }
            let inv = random_rotation(&mut rng);
            let max_toi = rng.random_range(0.5..8.0);
            let mut cand = Candidate {
                handle: ColliderHandle::invalid(),
                u0: 0,
                u1: 0,
                v0: 0,
                v1: 0,
                near: rng.random_range(-0.5..4.0),
                cuboid: Some(Cuboid::new(half)),
                pose: Pose::IDENTITY,
                inv_rotation: inv,
                local_origin: origin,
                world_normals: [Vector::ZERO; 7],
            };
            for u in [0, LANES, LANES + 3] {
                // A search part-way through: some pixels done, some with a hit already, some
                // of those at exactly the time this cuboid gives (ties).
                let mut probe = CuboidLanes::default();
                probe.cast_scalar(half, origin, inv, &world, u, max_toi, u32::MAX);
                let mut search = RowSearch::default();
                search.reset(world.x.len());
                for p in 0..world.x.len() {
                    let toi = match p.checked_sub(u) {
                        Some(j) if j < LANES && probe.code[j] == ENTERS && k % 3 == 0 => {
                            probe.toi[j]
                        }
                        _ => rng.random_range(0.0..6.0),
                    };
                    match rng.random_range(0..4) {
                        0 => search.done[p] = u32::MAX,
                        1 | 2 => search.offer(
                            p,
                            7,
                            Some(Found::Cuboid(CuboidHit::Enters { toi, side: -2 })),
                        ),
                        _ => {}
                    }
                }
                // Now and then a candidate exactly at a pixel's threshold.
                if k % 4 == 1 && search.toi[u].is_finite() {
                    cand.near = search.toi[u] * (1.0 + 2.0 * TIE);
                }
                let n = rng.random_range(1..=LANES);
                let (mut a, mut b) = (search.clone(), search);
                let (mut la, mut lb) = (CuboidLanes::default(), CuboidLanes::default());
                // Lanes the scalar twin casts get a code; the others keep this one.
                lb.code = [-1.0; LANES];
                // SAFETY: as above.
                let group = CuboidGroup {
                    c: &cand,
                    half,
                    k: 3,
                    world: &world,
                    u,
                    n,
                    max_toi,
                };
                let ask_a = unsafe { avx::cuboid_lanes(&group, &mut a, &mut la) };
                let ask_b = b.cuboid_scalar(&group, &mut lb);
                let what = format!("{half:?} {origin:?} {inv:?} {u} {n}");
                assert_eq!(ask_a, ask_b, "{what}");
                for j in (0..n).filter(|j| ask_b & (1 << j) != 0) {
                    let bits = |l: &CuboidLanes| l.dir.map(|c| c[j].to_bits());
                    assert_eq!(bits(&la), bits(&lb), "{what}");
                }
                let bits = |c: &[f32]| c.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&a.toi), bits(&b.toi), "{what}");
                assert_eq!(a.second, b.second, "{what}");
                assert_eq!(a.done, b.done, "{what}");
                assert_eq!(bits(&a.code), bits(&b.code), "{what}");
                for p in 0..a.code.len() {
                    if a.code[p] != MISS {
                        assert_eq!(a.cand[p], b.cand[p], "{what}");
                        assert_eq!(a.side[p], b.side[p], "{what}");
                    }
                }
                for j in (0..n).filter(|&j| lb.code[j] >= 0.0) {
                    codes[lb.code[j] as usize] += 1;
                    total += 1;
                }
            }
        }
        // Every answer occurs often enough to have been compared.
        assert!(
            codes.iter().all(|&c| c * 50 > total),
            "{codes:?} of {total}"
        );
    }
}
