//! Planar laser rangefinder: ray casts against the static world from the laser link, glass
//! that is transparent except near normal incidence, and the beam model's errors (Thrun,
//! Burgard & Fox, Probabilistic Robotics, §6.3: Gaussian hit noise, exponential short
//! readings, max-range failures, uniform random readings).

use crate::error::SimError;
use crate::scene::{iso_to_pose, LaserSurface, Scene};
use atrium_robots::{LaserScan, LaserSpec, Pose2};
use nalgebra::Isometry3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rapier3d::prelude::*;

/// At most this many glass surfaces are passed on one beam; a beam that would pass more is
/// reported as "nothing returned" (a maze of glass is not worth unbounded casts).
const MAX_PASS_THROUGH: usize = 16;

/// Casts one beam from `origin` along the unit `dir` against the static world and returns
/// the distance to the first surface that returns it, or `None` when nothing does within
/// `max_range`. Glass returns the beam only when the angle between the beam and the surface
/// normal is within the material's `reflect_within_deg`; otherwise the beam continues
/// past that collider.
pub fn cast_beam(scene: &Scene, origin: Vector, dir: Vector, max_range: f32) -> Option<f32> {
    let ray = Ray::new(origin, dir);
    let groups = Scene::sensor_groups();
    let mut passed = [ColliderHandle::invalid(); MAX_PASS_THROUGH];
    let mut n = 0;
    loop {
        let skip = &passed[..n];
        let not_passed = |h: ColliderHandle, _: &Collider| !skip.contains(&h);
        let mut filter = QueryFilter::default().groups(groups);
        if n > 0 {
            filter = filter.predicate(&not_passed);
        }
        let (h, toi) = scene
            .physics
            .query_pipeline_with_filter(filter)
            .cast_ray(&ray, max_range, true)?;
        let co = &scene.physics.colliders[h];
        match scene.laser_surface(co.user_data) {
            LaserSurface::Opaque => return Some(toi),
            LaserSurface::Glass { cos_reflect } => {
                // The normal only matters on glass: fetch it from that one collider.
                let normal = co
                    .shape()
                    .cast_ray_and_get_normal(co.position(), &ray, max_range, true)
                    .map_or(Vector::ZERO, |hit| hit.normal);
                let cos_incidence = dir.dot(normal).abs() as f64;
                if cos_incidence >= cos_reflect {
                    return Some(toi);
                }
                if n == MAX_PASS_THROUGH {
                    return None;
                }
                passed[n] = h;
                n += 1;
            }
        }
    }
}

/// Checks a laser spec; `field` prefixes the names in errors (e.g. `lasers[0]`).
pub fn validate_spec(spec: &LaserSpec, field: &str) -> Result<(), SimError> {
    let err = |f: &str, msg: String| SimError::config(format!("{field}.{f}"), msg);
    crate::error::positive(&format!("{field}.rate_hz"), spec.rate_hz)?;
    if spec.beams == 0 {
        return Err(err("beams", "must be at least 1".into()));
    }
    if !(spec.fov.is_finite() && spec.fov > 0.0 && spec.fov <= std::f64::consts::TAU) {
        return Err(err(
            "fov",
            format!("must be in (0, 2π] rad, got {}", spec.fov),
        ));
    }
    if !(spec.range_min.is_finite() && spec.range_min >= 0.0) {
        return Err(err(
            "range_min",
            format!("must be finite and >= 0, got {}", spec.range_min),
        ));
    }
    if !(spec.range_max.is_finite() && spec.range_max > spec.range_min) {
        return Err(err(
            "range_max",
            format!(
                "must be finite and > range_min ({}), got {}",
                spec.range_min, spec.range_max
            ),
        ));
    }
    if !(spec.sigma_hit.is_finite() && spec.sigma_hit >= 0.0) {
        return Err(err(
            "sigma_hit",
            format!("must be finite and >= 0, got {}", spec.sigma_hit),
        ));
    }
    if !(spec.sigma_hit_per_m.is_finite() && spec.sigma_hit_per_m >= 0.0) {
        return Err(err(
            "sigma_hit_per_m",
            format!("must be finite and >= 0, got {}", spec.sigma_hit_per_m),
        ));
    }
    for (f, p) in [
        ("p_short", spec.p_short),
        ("p_max", spec.p_max),
        ("p_rand", spec.p_rand),
    ] {
        if !(p.is_finite() && (0.0..=1.0).contains(&p)) {
            return Err(err(f, format!("must be a probability in [0, 1], got {p}")));
        }
    }
    let sum = spec.p_short + spec.p_max + spec.p_rand;
    if sum > 1.0 {
        return Err(err(
            "p_short",
            format!("p_short + p_max + p_rand must be at most 1, got {sum}"),
        ));
    }
    if spec.p_short > 0.0 && !(spec.lambda_short.is_finite() && spec.lambda_short > 0.0) {
        return Err(err(
            "lambda_short",
            format!(
                "must be finite and > 0 when p_short > 0, got {}",
                spec.lambda_short
            ),
        ));
    }
    Ok(())
}

/// One simulated laser with its mount, its noise stream and a reused range buffer.
#[derive(Debug, Clone)]
pub struct Laser {
    spec: LaserSpec,
    /// Laser frame in the base frame.
    mount: Pose,
    /// The mount projected to the floor plane (what `LaserScan::mount` reports).
    mount2: Pose2,
    /// Beam directions in the laser frame.
    dirs: Vec<Vector>,
    /// True range of each beam from the last cast; `range_max` when nothing returned.
    truth: Vec<f64>,
    /// Noisy ranges of the last scan.
    ranges: Vec<f64>,
    rng: ChaCha8Rng,
}

impl Laser {
    /// `mount` is the laser link's pose in the base frame; `rng` the sensor's own stream.
    pub fn new(
        spec: LaserSpec,
        mount: &Isometry3<f64>,
        rng: ChaCha8Rng,
        field: &str,
    ) -> Result<Self, SimError> {
        validate_spec(&spec, field)?;
        let dirs = (0..spec.beams)
            .map(|i| {
                let a = spec.angle_min() + i as f64 * spec.angle_increment();
                Vector::new(a.cos() as f32, a.sin() as f32, 0.0)
            })
            .collect();
        let t = mount.translation.vector;
        let x_axis = mount.rotation * nalgebra::Vector3::x();
        let mount2 = Pose2::new(t.x, t.y, x_axis.y.atan2(x_axis.x));
        let n = spec.beams;
        Ok(Self {
            mount: iso_to_pose(mount),
            mount2,
            dirs,
            truth: vec![spec.range_max; n],
            ranges: vec![spec.range_max; n],
            spec,
            rng,
        })
    }

    pub fn spec(&self) -> &LaserSpec {
        &self.spec
    }

    /// Casts every beam with the base frame at `base` (world frame) into the truth buffer.
    pub fn cast(&mut self, scene: &Scene, base: &Pose) {
        let laser = *base * self.mount;
        let (lo, hi) = (self.spec.range_min, self.spec.range_max);
        for (t, d) in self.truth.iter_mut().zip(&self.dirs) {
            let dir = laser.rotation * *d;
            *t = match cast_beam(scene, laser.translation, dir, hi as f32) {
                Some(r) if (r as f64) >= lo => r as f64,
                // Closer than range_min: the sensor cannot see it and reports no return.
                _ => hi,
            };
        }
    }

    /// True ranges of the last cast (no noise), m.
    pub fn true_ranges(&self) -> &[f64] {
        &self.truth
    }

    /// A full scan from the base pose `base`: cast, then the beam model's noise from this
    /// sensor's stream.
    pub fn scan(&mut self, scene: &Scene, base: &Pose, stamp: f64) -> LaserScan {
        self.cast(scene, base);
        apply_noise(&self.spec, &self.truth, &mut self.ranges, &mut self.rng);
        self.to_scan(stamp)
    }

    /// Like [`Laser::scan`] but drawing noise from `rng` (leaves the sensor's stream alone).
    pub fn scan_with(
        &mut self,
        scene: &Scene,
        base: &Pose,
        stamp: f64,
        rng: &mut ChaCha8Rng,
    ) -> LaserScan {
        self.cast(scene, base);
        apply_noise(&self.spec, &self.truth, &mut self.ranges, rng);
        self.to_scan(stamp)
    }

    fn to_scan(&self, stamp: f64) -> LaserScan {
        LaserScan {
            stamp,
            sensor: self.spec.name.clone(),
            mount: self.mount2,
            angle_min: self.spec.angle_min(),
            angle_increment: self.spec.angle_increment(),
            range_min: self.spec.range_min,
            range_max: self.spec.range_max,
            ranges: self.ranges.clone(),
        }
    }
}

/// The beam model (Probabilistic Robotics §6.3): each beam is, with probability p_short,
/// an exponential(λ_short) reading truncated to [0, z*]; with p_max a max-range failure;
/// with p_rand uniform on [0, z_max); otherwise the true range z* plus N(0, σ(z*)²), with
/// σ(z*) = σ_hit + σ_hit_per_m·z* (a zero growth leaves σ_hit itself, so the draws and
/// readings of a laser without growth are those of a constant σ, bit for bit).
/// Readings are clamped to [range_min, range_max]; a beam with no return reads range_max
/// unless the short or random component fires.
fn apply_noise(s: &LaserSpec, truth: &[f64], ranges: &mut [f64], rng: &mut ChaCha8Rng) {
    let (lo, hi) = (s.range_min, s.range_max);
    for (z, &zt) in ranges.iter_mut().zip(truth) {
        let u: f64 = rng.random();
        let returned = zt < hi;
        let r = if u < s.p_short {
            // Inverse CDF of the exponential truncated at z*.
            let v: f64 = rng.random();
            let tail = 1.0 - (-s.lambda_short * zt).exp();
            -(1.0 - v * tail).ln() / s.lambda_short
        } else if u < s.p_short + s.p_max {
            hi
        } else if u < s.p_short + s.p_max + s.p_rand {
            rng.random_range(0.0..hi)
        } else if returned {
            let n: f64 = rng.sample(StandardNormal);
            zt + (s.sigma_hit + s.sigma_hit_per_m * zt) * n
        } else {
            hi
        };
        *z = r.clamp(lo, hi);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures;
    use rand::SeedableRng;

    #[test]
    fn beams_pass_several_glass_panes_and_stop_at_concrete() {
        let mut world = fixtures::box_room(12.0, 12.0, "concrete");
        for x in [1.0, 2.0] {
            world
                .walls
                .push(fixtures::wall([x, -3.0], [x, 3.0], "glass"));
        }
        world
            .walls
            .push(fixtures::wall([3.0, -3.0], [3.0, 3.0], "concrete"));
        let scene = Scene::new(&world, 200.0).unwrap();
        let a = 45f64.to_radians();
        let dir = Vector::new(a.cos() as f32, a.sin() as f32, 0.0);
        let r = cast_beam(&scene, Vector::new(0.0, 0.0, 1.0), dir, 8.0).unwrap();
        assert!((r as f64 - 2.9 / a.cos()).abs() < 1e-4, "{r}");
        // Straight on, the first pane returns the beam.
        let r = cast_beam(&scene, Vector::new(0.0, 0.0, 1.0), Vector::X, 8.0).unwrap();
        assert!((r - 0.9).abs() < 1e-5, "{r}");
        // Nothing within range: no return.
        assert_eq!(
            cast_beam(&scene, Vector::new(0.0, 0.0, 1.0), Vector::X * -1.0, 2.0),
            None
        );
    }

    #[test]
    fn beam_model_mixes_in_the_stated_proportions() {
        let world = fixtures::box_room(6.0, 6.0, "concrete");
        let scene = Scene::new(&world, 200.0).unwrap();
        let mut spec = LaserSpec::sick_lms200("front", "laser");
        (spec.beams, spec.fov) = (20_000, std::f64::consts::TAU);
        (spec.p_short, spec.p_max, spec.p_rand, spec.sigma_hit) = (0.1, 0.05, 0.05, 0.01);
        let rng = ChaCha8Rng::seed_from_u64(3);
        let mount = Isometry3::translation(0.0, 0.0, 0.3);
        let mut laser = Laser::new(spec, &mount, rng, "lasers[0]").unwrap();
        let scan = laser.scan(&scene, &Pose::IDENTITY, 0.0);
        let n = scan.ranges.len() as f64;
        let truth = laser.true_ranges();
        let frac = |f: &dyn Fn(f64, f64) -> bool| {
            scan.ranges
                .iter()
                .zip(truth)
                .filter(|(z, t)| f(**z, **t))
                .count() as f64
                / n
        };
        // Every beam sees a wall within 2.9·√2 m; only p_max (and nothing else) gives 8 m.
        let at_max = frac(&|z, _| z == 8.0);
        assert!((at_max - 0.05).abs() < 0.01, "{at_max}");
        // Short readings plus the random ones that land short (about 0.05 · 2.5/8).
        let short = frac(&|z, t| z < t - 0.05);
        assert!((short - 0.115).abs() < 0.02, "{short}");
        // Hits: within 3σ of the truth for ≈ 0.8 · 0.997 of the beams.
        let hits = frac(&|z, t| (z - t).abs() < 0.03);
        assert!((hits - 0.8).abs() < 0.02, "{hits}");
    }

    #[test]
    fn hit_noise_grows_with_the_true_range() {
        let world = fixtures::box_room(12.0, 4.0, "concrete");
        let scene = Scene::new(&world, 200.0).unwrap();
        let mut spec = LaserSpec::sick_lms200("front", "laser");
        (spec.beams, spec.fov, spec.range_max) = (40_000, std::f64::consts::TAU, 20.0);
        (spec.p_short, spec.p_max, spec.p_rand) = (0.0, 0.0, 0.0);
        (spec.sigma_hit, spec.sigma_hit_per_m) = (0.002, 0.01);
        let rng = ChaCha8Rng::seed_from_u64(5);
        let mount = Isometry3::translation(0.0, 0.0, 0.3);
        let mut laser = Laser::new(spec, &mount, rng, "lasers[0]").unwrap();
        let scan = laser.scan(&scene, &Pose::IDENTITY, 0.0);
        // The relative spread (z − z*)/σ(z*) is a unit normal at every range, near and far.
        for (lo, hi) in [(1.9, 2.5), (4.0, 5.8)] {
            let (mut n, mut sum2) = (0.0, 0.0);
            for (z, t) in scan.ranges.iter().zip(laser.true_ranges()) {
                if (lo..hi).contains(t) {
                    let e = (z - t) / (0.002 + 0.01 * t);
                    (n, sum2) = (n + 1.0, sum2 + e * e);
                }
            }
            let sd = (sum2 / n).sqrt();
            assert!(
                n > 2000.0 && (sd - 1.0).abs() < 0.05,
                "{lo}..{hi}: {sd} of {n}"
            );
        }
    }

    #[test]
    fn without_growth_the_noise_is_the_constant_sigma_draw_for_draw() {
        let mut spec = LaserSpec::sick_lms200("front", "laser");
        (spec.p_short, spec.p_max, spec.p_rand) = (0.1, 0.05, 0.05);
        let truth: Vec<f64> = (0..5000).map(|i| 0.1 + 7.0 * (i as f64 / 5000.0)).collect();
        let mut got = vec![0.0; truth.len()];
        apply_noise(&spec, &truth, &mut got, &mut ChaCha8Rng::seed_from_u64(11));
        // The model as it was before σ could grow with range, drawn from the same stream.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let s = &spec;
        for (z, &zt) in got.iter().zip(&truth) {
            let u: f64 = rng.random();
            let r = if u < s.p_short {
                let v: f64 = rng.random();
                let tail = 1.0 - (-s.lambda_short * zt).exp();
                -(1.0 - v * tail).ln() / s.lambda_short
            } else if u < s.p_short + s.p_max {
                s.range_max
            } else if u < s.p_short + s.p_max + s.p_rand {
                rng.random_range(0.0..s.range_max)
            } else {
                let n: f64 = rng.sample(StandardNormal);
                zt + s.sigma_hit * n
            };
            assert_eq!(z.to_bits(), r.clamp(s.range_min, s.range_max).to_bits());
        }
    }

    #[test]
    fn bad_specs_are_named() {
        let mut spec = LaserSpec::sick_lms200("front", "laser");
        spec.range_max = 0.01;
        let e = validate_spec(&spec, "lasers[2]").unwrap_err().to_string();
        assert!(e.contains("lasers[2].range_max"), "{e}");
        let mut spec = LaserSpec::sick_lms200("front", "laser");
        spec.beams = 0;
        assert!(validate_spec(&spec, "l")
            .unwrap_err()
            .to_string()
            .contains("l.beams"));
        let mut spec = LaserSpec::sick_lms200("front", "laser");
        spec.sigma_hit_per_m = -0.01;
        assert!(validate_spec(&spec, "l")
            .unwrap_err()
            .to_string()
            .contains("l.sigma_hit_per_m"));
        let mut spec = LaserSpec::sick_lms200("front", "laser");
        spec.lambda_short = 0.0;
        assert!(validate_spec(&spec, "l")
            .unwrap_err()
            .to_string()
            .contains("lambda_short"));
    }
}
