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
}

/// Per-frame culling state; keep one per camera and reuse it (no allocation per frame once
/// warmed up).
#[derive(Debug, Clone, Default)]
pub struct FrustumCaster {
    candidates: Vec<Candidate>,
    /// Candidates whose rows cover the current row (indices into `candidates`).
    row: Vec<usize>,
    /// Pixels that fell back to the pipeline in the last frame (for tests and benches).
    fallbacks: usize,
}

/// What one pixel's cast found: the collider and the pipeline's hit.
pub type Hit = (ColliderHandle, RayIntersection);

impl FrustumCaster {
    pub fn new() -> Self {
        Self::default()
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
        let colliders = query.colliders;
        let origin = cam.translation;
        for v in 0..pin.height {
            self.row.clear();
            self.row.extend(
                self.candidates
                    .iter()
                    .enumerate()
                    .filter(|(_, c)| c.v0 <= v && v <= c.v1)
                    .map(|(k, _)| k),
            );
            for u in 0..pin.width {
                let i = v * pin.width + u;
                let dir = cam.rotation * dirs[i];
                let ray = Ray::new(origin, dir);
                // Best so far: candidate index and its hit (in the candidate's frame for a
                // cuboid, until it is returned).
                let mut best: Option<(usize, Found)> = None;
                let mut second = f32::INFINITY;
                for &k in &self.row {
                    let c = &self.candidates[k];
                    if u < c.u0 || u > c.u1 {
                        continue;
                    }
                    if let Some((_, b)) = &best {
                        // Sorted by `near`: nothing further on can be nearer or tie.
                        if c.near > b.toi() * (1.0 + 2.0 * TIE) {
                            break;
                        }
                    }
                    let hit = match &c.cuboid {
                        Some(cuboid) => {
                            let local = Ray::new(c.local_origin, c.inv_rotation * dir);
                            match cast_cuboid(cuboid.half_extents, &local, max_toi) {
                                Some(hit) => hit.map(Found::Cuboid),
                                None => cuboid
                                    .cast_local_ray_and_get_normal(&local, max_toi, true)
                                    .map(Found::Shape),
                            }
                        }
                        None => {
                            let co = &colliders[c.handle];
                            co.shape()
                                .cast_ray_and_get_normal(co.position(), &ray, max_toi, true)
                                .map(Found::Shape)
                        }
                    };
                    let Some(hit) = hit else {
                        continue;
                    };
                    match &best {
                        Some((_, b)) if hit.toi() >= b.toi() => {
                            second = second.min(hit.toi());
                        }
                        _ => {
                            if let Some((_, b)) = &best {
                                second = second.min(b.toi());
                            }
                            best = Some((k, hit));
                        }
                    }
                }
                let best: Option<Hit> = best.map(|(k, hit)| {
                    let c = &self.candidates[k];
                    let hit = hit.intersection();
                    match c.cuboid {
                        Some(_) => (c.handle, hit.transform_by(&c.pose)),
                        None => (c.handle, hit),
                    }
                });
                let certain = match &best {
                    None => true,
                    Some((_, b)) => {
                        let t = b.time_of_impact;
                        second - t > TIE * t.max(1e-3) && max_toi - t > TIE * max_toi
                    }
                };
                if certain {
                    out(i, dir, best);
                } else {
                    self.fallbacks += 1;
                    out(i, dir, query.cast_ray_and_get_normal(&ray, max_toi, true));
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
            let mut cand = Candidate {
                handle,
                u0: 0,
                u1: w - 1,
                v0: 0,
                v1: h - 1,
                near: (dist - 1e-3) as f32,
                cuboid: co.shape().as_cuboid().copied(),
                pose,
                inv_rotation,
                // `Pose::inverse_transform_point`, as `Ray::inverse_transform_by` computes it.
                local_origin: pose.inverse_transform_point(o),
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
