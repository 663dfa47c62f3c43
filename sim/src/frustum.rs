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
//!
//! This module culls (which colliders each pixel may hit) and drives the render; the search
//! of one row among its candidates is in `search.rs`, its eight-pixel AVX kernels in
//! `avx.rs`.

use rapier3d::parry::bounding_volume::Aabb;
use rapier3d::parry::shape::Cuboid;
use rapier3d::prelude::*;

#[cfg(target_arch = "x86_64")]
mod avx;
mod search;

pub use search::{cast_cuboid, CuboidHit};
use search::{Columns, CuboidGroup, CuboidLanes, Found, RowSearch, LANES, TIE};

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
                            near: c.near,
                            origin: c.local_origin,
                            inv_rotation: c.inv_rotation,
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
