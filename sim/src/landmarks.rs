//! An ideal point-feature detector with noise: it reports the centre of every pillar of the
//! world that lies within range and field of view and is not occluded, as range and bearing
//! with Gaussian noise (the observation model of [003] §2.1, eq. 5).
//!
//! Not derived from laser clusters: an ideal detector isolates the estimator under test from
//! the detector's own failure modes (split or merged clusters, wall corners mistaken for
//! pillars), which is what the covariance checks need. Visibility is decided by one ray from
//! the sensor to the pillar's centre at the sensor's height through the same rapier scene
//! the laser reads: the pillar is seen when that ray's first returning surface is the
//! pillar's own face. So opaque walls and nearer pillars occlude, glass lets it through
//! except near normal incidence (as for the laser), and a pillar lower than the sensor is not
//! seen. A pillar half hidden behind a door frame counts as seen when its centre ray is clear.

use crate::error::SimError;
use crate::laser::cast_beam;
use crate::scene::{iso_to_pose, vec3, Scene};
use atrium_robots::{
    normalize_angle, Association, LandmarkDetection, LandmarkDetections, LandmarkDetectorSpec,
    Pose2,
};
use atrium_worlds::World;
use nalgebra::Isometry3;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use rapier3d::prelude::*;

/// A pillar counts as the first surface hit when the ray stops within this of its face, m.
/// Covers f32 ray-cast precision (about 1e-5 m at 30 m) with a wide margin and is far below
/// any gap between a pillar and something in front of it.
const FACE_TOLERANCE: f64 = 0.005;

/// One detector on the robot.
#[derive(Debug, Clone)]
pub struct LandmarkDetector {
    spec: LandmarkDetectorSpec,
    /// Detector frame in the base frame (3D, for the ray origin and heading).
    mount: Pose,
    /// The mount projected to the floor plane (what the readings report).
    mount2: Pose2,
    /// (centre, radius) of every pillar of the world, in world order (the feature ids).
    pillars: Vec<([f64; 2], f64)>,
    rng: ChaCha8Rng,
}

impl LandmarkDetector {
    /// `mount` is the detector link's pose in the base frame; `rng` the sensor's own stream.
    /// `field` names the config entry in errors.
    pub fn new(
        spec: LandmarkDetectorSpec,
        mount: &Isometry3<f64>,
        world: &World,
        rng: ChaCha8Rng,
        field: &str,
    ) -> Result<Self, SimError> {
        spec.validate()
            .map_err(|msg| SimError::config(format!("{field}.{msg}"), "invalid"))?;
        let t = mount.translation.vector;
        let x_axis = mount.rotation * nalgebra::Vector3::x();
        Ok(Self {
            mount: iso_to_pose(mount),
            mount2: Pose2::new(t.x, t.y, x_axis.y.atan2(x_axis.x)),
            pillars: world.pillars.iter().map(|p| (p.center, p.radius)).collect(),
            spec,
            rng,
        })
    }

    pub fn spec(&self) -> &LandmarkDetectorSpec {
        &self.spec
    }

    /// The noiseless detections from base pose `base` (world frame): (pillar index, range,
    /// bearing) of every visible pillar, in pillar order.
    pub fn visible(&self, scene: &Scene, base: &Pose) -> Vec<(usize, f64, f64)> {
        let sensor = *base * self.mount;
        let o = sensor.translation;
        let x_axis = sensor.rotation * Vector::X;
        let yaw = (x_axis.y as f64).atan2(x_axis.x as f64);
        let (ox, oy) = (o.x as f64, o.y as f64);
        let half_fov = 0.5 * self.spec.fov;
        let mut out = Vec::new();
        for (i, &(c, radius)) in self.pillars.iter().enumerate() {
            let (dx, dy) = (c[0] - ox, c[1] - oy);
            let range = dx.hypot(dy);
            if range < self.spec.range_min || range > self.spec.range_max || range <= radius {
                continue;
            }
            let bearing = normalize_angle(dy.atan2(dx) - yaw);
            if bearing.abs() > half_fov {
                continue;
            }
            let dir = vec3(dx / range, dy / range, 0.0);
            let seen = cast_beam(scene, o, dir, range as f32)
                .is_some_and(|toi| (toi as f64) >= range - radius - FACE_TOLERANCE);
            if seen {
                out.push((i, range, bearing));
            }
        }
        out
    }

    /// One reading from base pose `base`: the visible pillars with range and bearing noise
    /// from this sensor's stream. Identities are attached only with known association.
    pub fn detect(&mut self, scene: &Scene, base: &Pose, stamp: f64) -> LandmarkDetections {
        let visible = self.visible(scene, base);
        let mut detections = Vec::with_capacity(visible.len());
        for (i, range, bearing) in visible {
            let nr: f64 = StandardNormal.sample(&mut self.rng);
            let nb: f64 = StandardNormal.sample(&mut self.rng);
            let r = range + self.spec.sigma_range * nr;
            // Gaussian noise can in principle push a range below zero; such a reading is
            // not physical, and dropping it keeps every reported range positive.
            if r <= 0.0 {
                continue;
            }
            detections.push(LandmarkDetection {
                range: r,
                bearing: normalize_angle(bearing + self.spec.sigma_bearing * nb),
                id: match self.spec.association {
                    Association::Known => Some(i),
                    Association::Unknown => None,
                },
            });
        }
        LandmarkDetections {
            stamp,
            sensor: self.spec.name.clone(),
            mount: self.mount2,
            detections,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures;
    use atrium_worlds::{Pillar, Wall};
    use rand::SeedableRng;

    fn world() -> World {
        let mut w = fixtures::box_room(20.0, 20.0, "concrete");
        // Pillars: 0 ahead in view, 1 behind the robot, 2 hidden behind a wall, 3 out of
        // range, 4 at the edge of the field of view, 5 too low for the sensor.
        for (c, h) in [
            ([3.0, 0.0], 3.0),
            ([-3.0, 0.0], 3.0),
            ([0.0, 5.0], 3.0),
            ([8.0, 2.0], 3.0),
            ([0.1, 2.0], 3.0),
            ([2.0, -2.0], 0.1),
        ] {
            w.pillars.push(Pillar {
                center: c,
                radius: 0.1,
                height: h,
                material: "concrete".into(),
            });
        }
        w.walls.push(Wall {
            a: [-1.0, 3.0],
            b: [1.0, 3.0],
            thickness: 0.1,
            height: 3.0,
            material: "concrete".into(),
        });
        w
    }

    fn spec() -> LandmarkDetectorSpec {
        LandmarkDetectorSpec {
            range_max: 6.0,
            ..Default::default()
        }
    }

    #[test]
    fn sees_what_is_in_range_view_and_line_of_sight() {
        let w = world();
        let mut scene = Scene::new(&w, 200.0).unwrap();
        // Colliders enter the query structure only after a step.
        scene.physics.step();
        let mount = Isometry3::translation(0.0, 0.0, 0.3);
        let det =
            LandmarkDetector::new(spec(), &mount, &w, ChaCha8Rng::seed_from_u64(1), "d").unwrap();
        let base = iso_to_pose(&Isometry3::identity());
        let seen = det.visible(&scene, &base);
        let ids: Vec<usize> = seen.iter().map(|s| s.0).collect();
        assert_eq!(ids, vec![0, 4]);
        // Pillar 0 at (3, 0): range 3, bearing 0. Pillar 4 at (0.1, 2): atan2(2, 0.1).
        assert!((seen[0].1 - 3.0).abs() < 1e-9 && seen[0].2.abs() < 1e-9);
        assert!((seen[1].2 - 2.0f64.atan2(0.1)).abs() < 1e-9);
    }

    #[test]
    fn noise_has_the_specified_spread_and_ids_follow_association() {
        let w = world();
        let mut scene = Scene::new(&w, 200.0).unwrap();
        scene.physics.step();
        let mount = Isometry3::translation(0.0, 0.0, 0.3);
        let base = iso_to_pose(&Isometry3::identity());
        let mut det =
            LandmarkDetector::new(spec(), &mount, &w, ChaCha8Rng::seed_from_u64(2), "d").unwrap();
        let n = 4000;
        let (mut s, mut s2) = (0.0, 0.0);
        for _ in 0..n {
            let r = det.detect(&scene, &base, 0.0);
            let d = r.detections.iter().find(|d| d.id == Some(0)).unwrap();
            s += d.range - 3.0;
            s2 += (d.range - 3.0).powi(2);
        }
        let mean = s / n as f64;
        let sd = (s2 / n as f64 - mean * mean).sqrt();
        assert!(mean.abs() < 0.002, "{mean}");
        assert!((sd - 0.02).abs() < 0.002, "{sd}");
        let unknown = LandmarkDetectorSpec {
            association: Association::Unknown,
            ..spec()
        };
        let mut det =
            LandmarkDetector::new(unknown, &mount, &w, ChaCha8Rng::seed_from_u64(2), "d").unwrap();
        assert!(det
            .detect(&scene, &base, 0.0)
            .detections
            .iter()
            .all(|d| d.id.is_none()));
    }
}
