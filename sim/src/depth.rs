//! Depth camera: one 3D ray per pixel from the camera link against the whole static scene
//! (floor, ceiling, walls, pillars, furniture), with the Kinect's failure modes and noise:
//! - no depth (0) beyond [range_min, range_max] (depth measured along the optical axis),
//! - no depth on glass (the projected infrared pattern is not reflected back diffusely),
//! - no depth at grazing incidence (angle between ray and surface normal above
//!   `max_incidence_deg`),
//! - axial noise σ(z) = 0.0012 + 0.0019 (z − 0.4)² m (ARCHITECTURE.md, sensors table; see
//!   `robots/src/depth_camera.rs`), then quantization to `quantization` metres.
//!
//! Pixel geometry follows [004] §2.2 (a w × h image with fields of view
//! f_h × f_v), written as pinhole intrinsics so that a point reconstructs exactly:
//! (x, y, z) = d · (1, −(u − cx)/fx, −(v − cy)/fy) in the camera's REP-103 frame.

use crate::error::SimError;
use crate::frustum::{FrustumCaster, Hit, Pinhole};
use crate::scene::{iso_to_pose, LaserSurface, Scene};
use atrium_robots::{DepthCameraSpec, DepthImage, Mount3};
use nalgebra::Isometry3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rapier3d::prelude::*;

/// One simulated depth camera with its mount, its noise stream and reused buffers.
#[derive(Debug, Clone)]
pub struct DepthCamera {
    spec: DepthCameraSpec,
    /// Camera frame in the base frame.
    mount: Pose,
    mount3: Mount3,
    /// Unit ray direction of every pixel in the camera frame, row-major.
    dirs: Vec<Vector>,
    /// Cosine between each pixel's ray and the optical axis: depth = distance · cos.
    axial: Vec<f32>,
    /// Longest ray that can still be within range (the corner pixels'), m.
    max_ray: f32,
    cos_max_incidence: f32,
    /// Noiseless depth of the last cast (0 = invalid), m.
    truth: Vec<f32>,
    depth: Vec<f32>,
    intrinsics: (f64, f64, f64, f64),
    pinhole: Pinhole,
    caster: FrustumCaster,
    rng: ChaCha8Rng,
}

impl DepthCamera {
    /// `mount` is the camera link's pose in the base frame; `field` names the camera in
    /// errors (e.g. `depth_cameras[0]`).
    pub fn new(
        spec: DepthCameraSpec,
        mount: &Isometry3<f64>,
        rng: ChaCha8Rng,
        field: &str,
    ) -> Result<Self, SimError> {
        spec.validate().map_err(|msg| {
            let (key, rest) = msg.split_once(": ").unwrap_or(("", msg.as_str()));
            SimError::config(format!("{field}.{key}"), rest.to_string())
        })?;
        let (w, h) = (spec.image_width(), spec.image_height());
        let (fx, fy, cx, cy) = spec.intrinsics();
        let mut dirs = Vec::with_capacity(w * h);
        let mut axial = Vec::with_capacity(w * h);
        let mut min_axial = 1.0f32;
        for v in 0..h {
            for u in 0..w {
                let d = nalgebra::Vector3::new(1.0, -(u as f64 - cx) / fx, -(v as f64 - cy) / fy);
                let n = d.norm();
                let c = (1.0 / n) as f32;
                dirs.push(Vector::new(
                    (d.x / n) as f32,
                    (d.y / n) as f32,
                    (d.z / n) as f32,
                ));
                axial.push(c);
                min_axial = min_axial.min(c);
            }
        }
        let (xyz, rpy) = {
            let t = mount.translation.vector;
            let (r, p, y) = mount.rotation.euler_angles();
            ([t.x, t.y, t.z], [r, p, y])
        };
        Ok(Self {
            mount: iso_to_pose(mount),
            mount3: Mount3 { xyz, rpy },
            max_ray: spec.range_max as f32 / min_axial,
            cos_max_incidence: spec.max_incidence_deg.to_radians().cos() as f32,
            truth: vec![0.0; w * h],
            depth: vec![0.0; w * h],
            dirs,
            axial,
            intrinsics: (fx, fy, cx, cy),
            pinhole: Pinhole {
                width: w,
                height: h,
                fx,
                fy,
                cx,
                cy,
                min_axial: min_axial as f64,
            },
            caster: FrustumCaster::new(),
            spec,
            rng,
        })
    }

    pub fn spec(&self) -> &DepthCameraSpec {
        &self.spec
    }

    /// Casts every pixel's ray with the base frame at `base` (world frame) into the truth
    /// buffer: the depth along the optical axis, or 0 where the camera returns nothing.
    /// Culled per frame (`frustum.rs`); gives exactly what [`DepthCamera::cast_reference`]
    /// gives.
    pub fn cast(&mut self, scene: &Scene, base: &Pose) {
        let cam = *base * self.mount;
        let filter = QueryFilter::default().groups(Scene::sensor_groups());
        let query = scene.physics.query_pipeline_with_filter(filter);
        let (lo, hi) = (self.spec.range_min as f32, self.spec.range_max as f32);
        let cos_max = self.cos_max_incidence;
        let (truth, axial) = (&mut self.truth, &self.axial);
        let mut last = None;
        self.caster.render(
            &query,
            &cam,
            &self.pinhole,
            &self.dirs,
            self.max_ray,
            |i, dir, hit| {
                truth[i] = pixel_depth(scene, &mut last, dir, hit, axial[i], lo, hi, cos_max);
            },
        );
    }

    /// [`DepthCamera::cast`] with one query-pipeline cast per pixel (the reference the
    /// culled renderer must reproduce bit for bit).
    pub fn cast_reference(&mut self, scene: &Scene, base: &Pose) {
        let cam = *base * self.mount;
        let filter = QueryFilter::default().groups(Scene::sensor_groups());
        let query = scene.physics.query_pipeline_with_filter(filter);
        let (lo, hi) = (self.spec.range_min as f32, self.spec.range_max as f32);
        for ((t, d), &c) in self.truth.iter_mut().zip(&self.dirs).zip(&self.axial) {
            let dir = cam.rotation * *d;
            let ray = Ray::new(cam.translation, dir);
            let hit = query.cast_ray_and_get_normal(&ray, self.max_ray, true);
            *t = pixel_depth(
                scene,
                &mut None,
                dir,
                hit,
                c,
                lo,
                hi,
                self.cos_max_incidence,
            );
        }
    }

    /// Pixels of the last [`DepthCamera::cast`] that fell back to the query pipeline.
    pub fn fallback_pixels(&self) -> usize {
        self.caster.fallbacks()
    }

    /// Noiseless depths of the last cast (0 = invalid), row-major.
    pub fn true_depths(&self) -> &[f32] {
        &self.truth
    }

    /// A full frame from the base pose `base`: cast, then noise from this camera's stream.
    pub fn frame(&mut self, scene: &Scene, base: &Pose, stamp: f64) -> DepthImage {
        self.cast(scene, base);
        apply_noise(&self.spec, &self.truth, &mut self.depth, &mut self.rng);
        self.to_image(stamp)
    }

    /// Like [`DepthCamera::frame`] with noise from `rng` (the camera's stream is untouched).
    pub fn frame_with(
        &mut self,
        scene: &Scene,
        base: &Pose,
        stamp: f64,
        rng: &mut ChaCha8Rng,
    ) -> DepthImage {
        self.cast(scene, base);
        apply_noise(&self.spec, &self.truth, &mut self.depth, rng);
        self.to_image(stamp)
    }

    fn to_image(&self, stamp: f64) -> DepthImage {
        let (fx, fy, cx, cy) = self.intrinsics;
        DepthImage {
            stamp,
            sensor: self.spec.name.clone(),
            mount: self.mount3,
            width: self.spec.image_width(),
            height: self.spec.image_height(),
            fx,
            fy,
            cx,
            cy,
            depth: self.depth.clone(),
        }
    }
}

/// The depth a pixel reports for its first hit: 0 on nothing, glass, grazing incidence or out
/// of range; else the distance along the optical axis (`c` = cosine to the axis). `last`
/// remembers the last collider looked up and whether it is glass: neighbouring pixels mostly
/// hit the same one.
#[inline]
#[allow(clippy::too_many_arguments)]
fn pixel_depth(
    scene: &Scene,
    last: &mut Option<(ColliderHandle, bool)>,
    dir: Vector,
    hit: Option<Hit>,
    c: f32,
    lo: f32,
    hi: f32,
    cos_max_incidence: f32,
) -> f32 {
    match hit {
        None => 0.0,
        Some((h, hit)) => {
            let z = hit.time_of_impact * c;
            let glass = match *last {
                Some((k, glass)) if k == h => glass,
                _ => {
                    let surface = scene.laser_surface(scene.physics.colliders[h].user_data);
                    let glass = matches!(surface, LaserSurface::Glass { .. });
                    *last = Some((h, glass));
                    glass
                }
            };
            let grazing = dir.dot(hit.normal).abs() < cos_max_incidence;
            // Without short-circuits: which test fails varies from pixel to pixel, and a
            // branch per test mispredicted.
            let invalid = glass | grazing | (z < lo) | (z > hi);
            if invalid {
                0.0
            } else {
                z
            }
        }
    }
}

/// Axial Gaussian noise with σ(z) of the true depth, then quantization. Invalid pixels stay
/// 0; a noisy depth is not re-checked against the range (the sensor's own cut-off is on the
/// measured disparity, which the truth stands in for).
fn apply_noise(s: &DepthCameraSpec, truth: &[f32], out: &mut [f32], rng: &mut ChaCha8Rng) {
    let q = s.quantization;
    for (z, &t) in out.iter_mut().zip(truth) {
        if t <= 0.0 {
            *z = 0.0;
            continue;
        }
        let n: f64 = rng.sample(StandardNormal);
        let mut d = t as f64 + s.sigma(t as f64) * n;
        if q > 0.0 {
            d = (d / q).round() * q;
        }
        *z = d.max(0.0) as f32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures;
    use rand::SeedableRng;

    fn camera(spec: DepthCameraSpec, z: f64) -> DepthCamera {
        let mount = Isometry3::translation(0.0, 0.0, z);
        DepthCamera::new(
            spec,
            &mount,
            ChaCha8Rng::seed_from_u64(1),
            "depth_cameras[0]",
        )
        .unwrap()
    }

    fn small(decimation: usize) -> DepthCameraSpec {
        let mut s = DepthCameraSpec::kinect("k", "camera");
        s.decimation = decimation;
        s
    }

    #[test]
    fn a_wall_ahead_reads_its_distance_along_the_axis_everywhere() {
        // Box room 10 × 10: the east wall's inner face is at x = 4.9. Camera at 1.2 m height
        // looking along +x from x = 2.0: the whole image sees that wall at depth 2.9.
        let world = fixtures::box_room(10.0, 10.0, "concrete");
        let scene = Scene::new(&world, 200.0).unwrap();
        let mut cam = camera(small(8), 1.2);
        let base = Pose::from_translation(Vector::new(2.0, 0.0, 0.0));
        cam.cast(&scene, &base);
        let t = cam.true_depths();
        assert_eq!(t.len(), 80 * 60);
        for &z in t {
            assert!((z - 2.9).abs() < 1e-4, "{z}");
        }
    }

    #[test]
    fn glass_far_range_and_grazing_floor_are_invalid() {
        let mut world = fixtures::box_room(30.0, 30.0, "concrete");
        // Glass 2 m ahead across the left half of the view only.
        world
            .walls
            .push(fixtures::wall([2.0, 0.05], [2.0, 5.0], "glass"));
        let scene = Scene::new(&world, 200.0).unwrap();
        let mut cam = camera(small(8), 0.5);
        cam.cast(&scene, &Pose::IDENTITY);
        let (w, h) = (80usize, 60usize);
        let t = cam.true_depths().to_vec();
        let (fx, fy, cx, cy) = cam.spec().intrinsics();
        for v in 0..h {
            for u in 0..w {
                let z = t[v * w + u];
                let dy = -(u as f64 - cx) / fx; // lateral slope
                let dz = -(v as f64 - cy) / fy; // vertical slope
                if dz >= 0.0 {
                    // Level or upwards: the east wall is 14.9 m away (beyond 4.5 m), or glass.
                    assert_eq!(z, 0.0, "pixel ({u}, {v})");
                    continue;
                }
                // Floor at depth 0.5 / −dz along the axis; the glass's near face at x = 1.9.
                let floor = 0.5 / -dz;
                let face = 2.0 - 0.5 * fixtures::WALL_THICKNESS;
                let y_at_face = dy * face;
                let on_glass = y_at_face > 0.05 && floor > face;
                // Incidence on the floor: cos = |dz| / |(1, dy, dz)|.
                let cos = -dz / (1.0 + dy * dy + dz * dz).sqrt();
                let grazing = cos < 75f64.to_radians().cos();
                // Pixels on a boundary could fall either way: skip them.
                let near = |a: f64, b: f64, tol: f64| (a - b).abs() < tol;
                if near(y_at_face, 0.05, 0.03)
                    || near(floor, face, 0.05)
                    || near(cos, 75f64.to_radians().cos(), 1e-3)
                    || near(floor, 4.5, 1e-3)
                    || near(floor, 0.8, 1e-3)
                {
                    continue;
                }
                if on_glass || grazing || !(0.8..=4.5).contains(&floor) {
                    assert_eq!(z, 0.0, "pixel ({u}, {v}): floor {floor}");
                } else {
                    assert!(
                        (z as f64 - floor).abs() < 1e-3,
                        "pixel ({u}, {v}): {z} vs {floor}"
                    );
                }
            }
        }
        // Something was valid (the floor nearby), something was not.
        assert!(t.iter().any(|z| *z > 0.0) && t.contains(&0.0));
    }

    /// The noise test: the measured standard deviation at 1, 2 and 4 m matches σ(z)
    /// within 10 %.
    #[test]
    fn axial_noise_matches_sigma_of_z() {
        for d in [1.0f64, 2.0, 4.0] {
            // A wall whose inner face is `d` ahead of the camera.
            let world = fixtures::box_room(2.0 * (d + 0.1), 12.0, "concrete");
            let scene = Scene::new(&world, 200.0).unwrap();
            let mut spec = small(4);
            spec.max_incidence_deg = 90.0;
            let mut cam = camera(spec.clone(), 1.5);
            let (mut n, mut sum, mut sq) = (0usize, 0.0f64, 0.0f64);
            for _ in 0..5 {
                let img = cam.frame(&scene, &Pose::IDENTITY, 0.0);
                for (&z, &t) in img.depth.iter().zip(cam.true_depths()) {
                    if t > 0.0 && (t as f64 - d).abs() < 1e-3 {
                        let e = z as f64 - t as f64;
                        n += 1;
                        sum += e;
                        sq += e * e;
                    }
                }
            }
            assert!(n > 10_000, "{n} samples at {d} m");
            let mean = sum / n as f64;
            let sd = (sq / n as f64 - mean * mean).sqrt();
            let want = spec.sigma(d);
            assert!(
                (sd - want).abs() < 0.1 * want,
                "at {d} m: measured σ {sd}, model {want}"
            );
            assert!(mean.abs() < 0.05 * want + 1e-4, "bias {mean} at {d} m");
        }
    }

    #[test]
    fn furniture_is_seen_and_bad_specs_are_named() {
        let mut world = fixtures::box_room(10.0, 10.0, "concrete");
        world.boxes.push(atrium_worlds::FurnitureBox {
            center: [2.5, 0.0],
            size: [1.0, 2.0, 1.0],
            yaw: 0.0,
            material: "concrete".into(),
        });
        let scene = Scene::new(&world, 200.0).unwrap();
        let mut cam = camera(small(8), 0.5);
        cam.cast(&scene, &Pose::IDENTITY);
        // The centre pixel looks level at the box's near face, x = 2.0.
        let centre = cam.true_depths()[30 * 80 + 40];
        assert!((centre - 2.0).abs() < 1e-3, "{centre}");

        let mut spec = small(1);
        spec.width = 0;
        let e = DepthCamera::new(
            spec,
            &Isometry3::identity(),
            ChaCha8Rng::seed_from_u64(0),
            "depth_cameras[1]",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("depth_cameras[1].width"), "{e}");
    }
}
