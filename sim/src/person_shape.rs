//! The shape of a person: parry's cylinder, with rays cast on it in closed form.
//!
//! Parry casts a ray on a cylinder by GJK on its support map, an iterative search that takes
//! microseconds per ray, hit or miss; in a crowded atrium a depth camera's rays spent 70 % of
//! a run there. A ray meets a cylinder where it meets the disc's circle within the slab of
//! its two caps, which two square roots' worth of algebra answers exactly. Everything else
//! (bounding boxes, point queries, the support map, mass) is the cylinder's own.

use crate::scene::vec3;
use rapier3d::parry::bounding_volume::{Aabb, BoundingSphere};
use rapier3d::parry::mass_properties::MassProperties;
use rapier3d::parry::math::{Pose, Real, Vector};
use rapier3d::parry::query::{PointProjection, PointQuery, Ray, RayCast, RayIntersection};
use rapier3d::parry::shape::{Cylinder, FeatureId, Shape, ShapeType, SupportMap, TypedShape};

/// A cylinder whose axis is its local +Y, as parry's [`Cylinder`], ray-cast analytically.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PersonShape(pub Cylinder);

/// Where a ray enters and leaves a cylinder, in units of its direction, and the outward
/// normals there; `None` when the line misses it or the span lies wholly behind the origin.
struct Span {
    enter: f64,
    enter_normal: [f64; 3],
    exit: f64,
    exit_normal: [f64; 3],
}

/// The span of the line `o + t d` inside the cylinder of half-height `h` and radius `r`
/// about the local Y axis (in f64: the cylinder's f32 parameters and the ray's are exact
/// there, so the only rounding is this function's own).
fn span(o: [f64; 3], d: [f64; 3], h: f64, r: f64) -> Option<Span> {
    // Between the caps: the slab |y| <= h.
    let (mut enter, mut exit) = (f64::NEG_INFINITY, f64::INFINITY);
    let (mut enter_normal, mut exit_normal) = ([0.0; 3], [0.0; 3]);
    if d[1] == 0.0 {
        if o[1].abs() > h {
            return None;
        }
    } else {
        let (t1, t2) = ((-h - o[1]) / d[1], (h - o[1]) / d[1]);
        // Entering through the cap the ray faces: the bottom one when it rises.
        let (near, far, facing) = if d[1] > 0.0 {
            (t1, t2, -1.0)
        } else {
            (t2, t1, 1.0)
        };
        (enter, exit) = (near, far);
        enter_normal = [0.0, facing, 0.0];
        exit_normal = [0.0, -facing, 0.0];
    }
    // Within the circle x² + z² <= r²: a t² + 2 b t + c <= 0. Its discriminant is taken as
    // a r² − (o × d)², free of the cancellation of b² − a c when the ray starts far away.
    let a = d[0] * d[0] + d[2] * d[2];
    if a == 0.0 {
        if o[0] * o[0] + o[2] * o[2] > r * r {
            return None;
        }
    } else {
        let b = o[0] * d[0] + o[2] * d[2];
        let cross = o[0] * d[2] - o[2] * d[0];
        let disc = a * r * r - cross * cross;
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let (t1, t2) = ((-b - root) / a, (-b + root) / a);
        let radial = |t: f64| {
            let (x, z) = (o[0] + t * d[0], o[2] + t * d[2]);
            let n = x.hypot(z);
            if n > 0.0 {
                [x / n, 0.0, z / n]
            } else {
                [0.0; 3]
            }
        };
        if t1 > enter {
            enter = t1;
            enter_normal = radial(t1);
        }
        if t2 < exit {
            exit = t2;
            exit_normal = radial(t2);
        }
    }
    (enter <= exit && exit >= 0.0).then_some(Span {
        enter,
        enter_normal,
        exit,
        exit_normal,
    })
}

impl RayCast for PersonShape {
    /// As parry's casts: from outside, the entry and its outward normal; from inside, time 0
    /// when `solid`, else the exit with the normal facing inwards.
    fn cast_local_ray_and_get_normal(
        &self,
        ray: &Ray,
        max_time_of_impact: Real,
        solid: bool,
    ) -> Option<RayIntersection> {
        let c = &self.0;
        let s = span(
            ray.origin.as_dvec3().to_array(),
            ray.dir.as_dvec3().to_array(),
            c.half_height as f64,
            c.radius as f64,
        )?;
        let (toi, normal) = if s.enter >= 0.0 {
            (s.enter, s.enter_normal)
        } else if solid {
            (0.0, [0.0; 3])
        } else {
            let n = s.exit_normal;
            (s.exit, [-n[0], -n[1], -n[2]])
        };
        let toi = toi as Real;
        (toi <= max_time_of_impact).then(|| {
            RayIntersection::new(
                toi,
                vec3(normal[0], normal[1], normal[2]),
                FeatureId::Unknown,
            )
        })
    }
}

impl PointQuery for PersonShape {
    fn project_local_point(&self, pt: Vector, solid: bool) -> PointProjection {
        self.0.project_local_point(pt, solid)
    }

    fn project_local_point_and_get_feature(&self, pt: Vector) -> (PointProjection, FeatureId) {
        self.0.project_local_point_and_get_feature(pt)
    }
}

impl Shape for PersonShape {
    fn compute_local_aabb(&self) -> Aabb {
        self.0.local_aabb()
    }

    fn compute_local_bounding_sphere(&self) -> BoundingSphere {
        self.0.local_bounding_sphere()
    }

    fn compute_aabb(&self, position: &Pose) -> Aabb {
        self.0.aabb(position)
    }

    fn clone_dyn(&self) -> Box<dyn Shape> {
        Box::new(*self)
    }

    fn scale_dyn(&self, _scale: Vector, _num_subdivisions: u32) -> Option<Box<dyn Shape>> {
        None
    }

    fn mass_properties(&self, density: Real) -> MassProperties {
        self.0.mass_properties(density)
    }

    fn is_convex(&self) -> bool {
        true
    }

    fn shape_type(&self) -> ShapeType {
        ShapeType::Custom
    }

    fn as_typed_shape(&self) -> TypedShape<'_> {
        TypedShape::Custom(self)
    }

    fn ccd_thickness(&self) -> Real {
        self.0.ccd_thickness()
    }

    fn ccd_angular_thickness(&self) -> Real {
        self.0.ccd_angular_thickness()
    }

    fn as_support_map(&self) -> Option<&dyn SupportMap> {
        Some(&self.0 as &dyn SupportMap)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn person() -> PersonShape {
        PersonShape(Cylinder::new(0.9, 0.25))
    }

    fn cast(o: [f32; 3], d: [f32; 3], solid: bool) -> Option<RayIntersection> {
        let ray = Ray::new(Vector::from(o), Vector::from(d));
        person().cast_local_ray_and_get_normal(&ray, 100.0, solid)
    }

    #[test]
    fn hand_computed_rays() {
        // Level, through the axis: the side at x = −r.
        let hit = cast([-5.0, 0.3, 0.0], [1.0, 0.0, 0.0], true).unwrap();
        assert_eq!(hit.time_of_impact, 4.75);
        assert_eq!(hit.normal, Vector::new(-1.0, 0.0, 0.0));
        // Straight down onto the top cap.
        let hit = cast([0.1, 5.0, 0.0], [0.0, -2.0, 0.0], true).unwrap();
        assert_eq!(hit.time_of_impact, 2.05);
        assert_eq!(hit.normal, Vector::new(0.0, 1.0, 0.0));
        // Level, offset by 0.15 from the axis: x = −√(0.25² − 0.15²) = −0.2.
        let hit = cast([-5.0, 0.0, 0.15], [1.0, 0.0, 0.0], true).unwrap();
        assert!((hit.time_of_impact - 4.8).abs() < 1e-6);
        assert!((hit.normal - Vector::new(-0.8, 0.0, 0.6)).length() < 1e-6);
        // Passing beside it, above it, and away from it.
        assert!(cast([-5.0, 0.0, 0.26], [1.0, 0.0, 0.0], true).is_none());
        assert!(cast([-5.0, 0.91, 0.0], [1.0, 0.0, 0.0], true).is_none());
        assert!(cast([-5.0, 0.0, 0.0], [-1.0, 0.0, 0.0], true).is_none());
        // Beyond the longest time asked for.
        let ray = Ray::new(Vector::new(-5.0, 0.0, 0.0), Vector::new(1.0, 0.0, 0.0));
        assert!(person()
            .cast_local_ray_and_get_normal(&ray, 4.7, true)
            .is_none());
        // From inside: time 0 when solid, else the far side facing inwards.
        assert_eq!(
            cast([0.0; 3], [1.0, 0.0, 0.0], true)
                .unwrap()
                .time_of_impact,
            0.0
        );
        let hit = cast([0.0; 3], [1.0, 0.0, 0.0], false).unwrap();
        assert_eq!(hit.time_of_impact, 0.25);
        assert_eq!(hit.normal, Vector::new(-1.0, 0.0, 0.0));
    }

    /// Parry's GJK cast on the same cylinder agrees to its own tolerance on random rays from
    /// around a person: the same hits, ours on the surface and GJK's within 5 mm of it
    /// (its tolerance), and the same normals within 3° (GJK's are the coarser ones), except
    /// for rays that graze the side within 0.1 mm or come within 1 cm of a rim.
    #[test]
    fn agrees_with_parrys_cylinder() {
        let shape = person();
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let (mut hits, mut compared) = (0, 0);
        for _ in 0..20_000 {
            let o = Vector::new(
                rng.random_range(-6.0..6.0),
                rng.random_range(-2.0..2.0),
                rng.random_range(-6.0..6.0),
            );
            // Aimed near the person, so that about half the rays hit.
            let target = Vector::new(
                rng.random_range(-0.5..0.5),
                rng.random_range(-1.2..1.2),
                rng.random_range(-0.5..0.5),
            );
            let ray = Ray::new(o, (target - o) * rng.random_range(0.2f32..3.0));
            let ours = shape.cast_local_ray_and_get_normal(&ray, 50.0, true);
            let gjk = shape.0.cast_local_ray_and_get_normal(&ray, 50.0, true);
            // Skip grazing rays: the line's distance from the axis within 0.1 mm of the radius
            // or a hit within 1 cm of a rim, where GJK's hits stray by millimetres (it finds
            // rays that pass 2 mm over a cap) and its normals lean towards the rim.
            let d = ray.dir.normalize();
            let closest = {
                let (ox, oz, dx, dz) = (o.x as f64, o.z as f64, d.x as f64, d.z as f64);
                let a = dx * dx + dz * dz;
                if a < 1e-12 {
                    ox.hypot(oz)
                } else {
                    (ox * dz - oz * dx).abs() / a.sqrt()
                }
            };
            let near_rim = |h: &RayIntersection| {
                let p = ray.point_at(h.time_of_impact);
                (p.y.abs() - 0.9).abs() < 1e-2 && ((p.x.hypot(p.z)) - 0.25).abs() < 1e-2
            };
            if (closest - 0.25).abs() < 1e-4
                || ours.as_ref().is_some_and(near_rim)
                || gjk.as_ref().is_some_and(near_rim)
            {
                continue;
            }
            compared += 1;
            match (ours, gjk) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    hits += 1;
                    // Ours lies on the surface; GJK's within its tolerance of it, which on a
                    // slanting ray reaches over a millimetre.
                    let off = |t: Real| {
                        let p = ray.point_at(t);
                        let side = p.x.hypot(p.z) - 0.25;
                        let cap = p.y.abs() - 0.9;
                        if side > 0.0 || cap > 0.0 {
                            // Outside: the distance to the solid (exact enough off the rims).
                            side.max(0.0).hypot(cap.max(0.0))
                        } else {
                            -side.max(cap)
                        }
                    };
                    if a.time_of_impact > 0.0 {
                        let (ours, theirs) = (off(a.time_of_impact), off(b.time_of_impact));
                        assert!(ours < 2e-6, "{ray:?}: {a:?} is {ours} m off the surface");
                        assert!(
                            theirs < 5e-3,
                            "{ray:?}: {b:?} is {theirs} m off the surface"
                        );
                    }
                    if a.time_of_impact > 0.0 {
                        let n = (a.normal - b.normal).length();
                        assert!(n < 0.05, "{ray:?}: {a:?} vs {b:?}");
                    }
                }
                (a, b) => panic!("{ray:?}: ours {a:?}, parry's {b:?}"),
            }
        }
        assert!(compared > 19_000, "{compared}");
        assert!(
            hits > 5_000 && hits < compared - 5_000,
            "{hits} of {compared}"
        );
    }
}
