//! Cameras in the simulation stream: intensity cameras and stereo rigs ([000] §III, §VII),
//! upward ceiling cameras and panoramic (omnidirectional) cameras ([001]), rendered in
//! [`crate::Simulation::step`] at their own rates under the run's lighting condition, pushed
//! as [`Reading::Intensity`] and [`Reading::Disparity`].
//!
//! Ceiling and omni cameras sit on the robot's vertical axis, level, at a height `z` above
//! the floor: their rays leave from the robot's floor pose (the chassis' slight tilt is
//! ignored), exactly as the training renders of their maps place them
//! (`atrium_scenarios::appearance_filters`), so a map and a run see the same images at the
//! same pose. Their readings' intrinsics are documented at [`CeilingSensorSpec`] and
//! [`OmniSensorSpec`].
//!
//! A stereo rig pushes its left image as a `Reading::Intensity` and its disparity map as a
//! `Reading::Disparity`, both under the rig's name (the paper's Small Vision System delivers
//! both from one head). Nothing is built when no camera is configured, so runs without
//! cameras pay nothing.

use crate::camera::{
    expose, floor_pose, render_radiance, Camera, CameraSpec, OmniCamera, RayBundle, Shader,
};
use crate::robot::project;
use crate::scene::Scene;
use crate::schedule::Schedule;
use crate::stereo::{StereoRig, StereoSpec};
use crate::SimError;
use atrium_robots::{IntensityImage, Mount3, Pose2, Reading};
use atrium_worlds::lighting::LightingCondition;
use atrium_worlds::World;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rapier3d::prelude::{Pose, Rotation};

/// Random stream ids under the run seed (see `simulation.rs`): one per camera and per rig.
const STREAM_CAMERA: u64 = 0x7000;
const STREAM_STEREO: u64 = 0x8000;
const STREAM_CEILING: u64 = 0x9000;
const STREAM_OMNI: u64 = 0xa000;

/// An intensity camera and its frame rate.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSensorSpec {
    pub camera: CameraSpec,
    pub rate_hz: f64,
}

/// A stereo rig and its frame rate.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoSensorSpec {
    pub stereo: StereoSpec,
    pub rate_hz: f64,
}

/// An upward-looking camera ([001], Dellaert's ceiling-brightness MCL): a small square
/// pinhole image of the ceiling straight above the robot. Its reading is a
/// `Reading::Intensity` under `name` of `size × size` pixels whose mean is the ceiling
/// brightness the map holds; the mount is `xyz = [0, 0, z]`, `rpy = [0, −π/2, 0]` (the
/// optical axis +x turned to +z), `fx = fy` the focal length, `cx = cy = (size − 1) / 2`.
#[derive(Debug, Clone, PartialEq)]
pub struct CeilingSensorSpec {
    pub name: String,
    /// Image side, pixels (default 9: 81 rays, the `CeilingCamera` of `camera.rs`).
    pub size: usize,
    /// Field of view of a side, rad (default 40°).
    pub fov: f64,
    /// Height of the lens above the floor, m (default 0.5).
    pub z: f64,
    pub gain: f64,
    /// Per-pixel Gaussian noise ([0, 1] scale); the mean of the image has 1/size of it.
    pub noise_sigma: f64,
    pub rate_hz: f64,
}

impl CeilingSensorSpec {
    pub fn new(name: &str) -> Self {
        Self {
            name: name.into(),
            size: 9,
            fov: 40f64.to_radians(),
            z: 0.5,
            gain: 1.0,
            noise_sigma: 0.01,
            rate_hz: 2.0,
        }
    }

    /// Checks the numbers; errors name `field.<key>`.
    pub fn validate(&self, field: &str) -> Result<(), SimError> {
        let err = |k: &str, m: String| SimError::config(format!("{field}.{k}"), m);
        if !(1..=256).contains(&self.size) {
            return Err(err(
                "size",
                format!("must be within [1, 256] pixels, got {}", self.size),
            ));
        }
        if !(self.fov.is_finite() && self.fov > 0.0 && self.fov < 3.0) {
            return Err(err(
                "fov_deg",
                format!(
                    "must be within (0, 170) degrees, got {}",
                    self.fov.to_degrees()
                ),
            ));
        }
        validate_rendering(field, self.z, self.gain, self.rate_hz, self.noise_sigma)
    }

    /// Focal length in pixels.
    pub fn f(&self) -> f64 {
        0.5 * self.size as f64 / (0.5 * self.fov).tan()
    }

    pub fn mount(&self) -> Mount3 {
        Mount3 {
            xyz: [0.0, 0.0, self.z],
            rpy: [0.0, -std::f64::consts::FRAC_PI_2, 0.0],
        }
    }
}

/// A panoramic camera ([001]'s omnicam, unwarped): `width` columns over 360° of azimuth,
/// column c looking 2π c / width counter-clockwise from the robot's heading (so a turn of the
/// robot by 2π k / width is a circular shift of the columns by k), `height` rows of elevation
/// from +30° (top) to −30° (bottom), at height `z` on the robot's axis.
///
/// Its reading is a `Reading::Intensity` whose intrinsics encode the cylinder (see
/// `atrium_scenarios::dataset::images`): `fx = width / 2π` pixels per radian of azimuth with
/// `cx = 0` (azimuth of column u is `(u − cx) / fx`), `fy` pixels per radian of elevation
/// with `cy` the row at elevation 0 (elevation of row v is `(cy − v) / fy`); the mount is
/// `xyz = [0, 0, z]`, `rpy = 0`.
#[derive(Debug, Clone, PartialEq)]
pub struct OmniSensorSpec {
    pub name: String,
    /// Columns over 360° (default 64).
    pub width: usize,
    /// Rows over the ±30° elevation band (default 16).
    pub height: usize,
    /// Height of the mirror above the floor, m (default 1.0).
    pub z: f64,
    pub gain: f64,
    pub noise_sigma: f64,
    pub rate_hz: f64,
}

/// Elevation band of the panorama (`OmniCamera`), rad: ±30°.
pub const OMNI_ELEVATION: f64 = std::f64::consts::PI / 6.0;

impl OmniSensorSpec {
    pub fn new(name: &str) -> Self {
        Self {
            name: name.into(),
            width: 64,
            height: 16,
            z: 1.0,
            gain: 1.0,
            noise_sigma: 0.01,
            rate_hz: 2.0,
        }
    }

    /// Checks the numbers; errors name `field.<key>`.
    pub fn validate(&self, field: &str) -> Result<(), SimError> {
        let err = |k: &str, m: String| SimError::config(format!("{field}.{k}"), m);
        if self.width < 2 || self.width > 4096 {
            return Err(err(
                "width",
                format!("must be within [2, 4096] columns, got {}", self.width),
            ));
        }
        if self.height < 1 || self.width * self.height > 1_000_000 {
            return Err(err(
                "height",
                format!(
                    "must be >= 1 with at most 1 Mpixel in all, got {} × {}",
                    self.width, self.height
                ),
            ));
        }
        validate_rendering(field, self.z, self.gain, self.rate_hz, self.noise_sigma)
    }

    /// The renderer (the same one the omni map is trained with).
    pub fn camera(&self, field: &str) -> Result<OmniCamera, SimError> {
        self.validate(field)?;
        let mut c = OmniCamera::new(self.width, self.height, self.z)?;
        c.gain = self.gain;
        c.noise_sigma = self.noise_sigma;
        Ok(c)
    }

    /// The cylinder's intrinsics `(fx, fy, cx, cy)` as the readings carry them.
    pub fn intrinsics(&self) -> (f64, f64, f64, f64) {
        let fx = self.width as f64 / std::f64::consts::TAU;
        if self.height > 1 {
            let fy = (self.height - 1) as f64 / (2.0 * OMNI_ELEVATION);
            (fx, fy, 0.0, 0.5 * (self.height - 1) as f64)
        } else {
            // One row, at elevation 0: fy has no meaning, keep it equal to fx.
            (fx, fx, 0.0, 0.0)
        }
    }
}

/// A ceiling camera ready to render: the rays of [`CeilingSensorSpec`] from the lens.
#[derive(Debug, Clone)]
pub struct CeilingImager {
    spec: CeilingSensorSpec,
    bundle: RayBundle,
}

impl CeilingImager {
    pub fn new(spec: CeilingSensorSpec, field: &str) -> Result<CeilingImager, SimError> {
        spec.validate(field)?;
        let bundle = RayBundle::pinhole(spec.size, spec.size, spec.f());
        Ok(CeilingImager { spec, bundle })
    }

    pub fn spec(&self) -> &CeilingSensorSpec {
        &self.spec
    }

    /// The image (size², row-major, exposed and quantised like every camera) above the robot
    /// standing at `pose`; heading turns the image, not its mean.
    pub fn render_into(
        &self,
        scene: &Scene,
        shader: &Shader,
        pose: &Pose2,
        rng: &mut ChaCha8Rng,
        out: &mut [f32],
    ) {
        let mut sensor = floor_pose(pose);
        sensor.translation.z = self.spec.z as f32;
        sensor.rotation *= Rotation::from_rotation_y(-std::f32::consts::FRAC_PI_2);
        render_radiance(scene, shader, &self.bundle, &sensor, 50.0, out, None);
        expose(out, self.spec.gain, self.spec.noise_sigma, rng);
    }

    /// The reading's image at `pose`.
    pub fn image(
        &self,
        scene: &Scene,
        shader: &Shader,
        pose: &Pose2,
        stamp: f64,
        rng: &mut ChaCha8Rng,
    ) -> IntensityImage {
        let s = &self.spec;
        let mut pixels = vec![0.0; s.size * s.size];
        self.render_into(scene, shader, pose, rng, &mut pixels);
        let c = 0.5 * (s.size as f64 - 1.0);
        IntensityImage {
            stamp,
            sensor: s.name.clone(),
            mount: s.mount(),
            width: s.size,
            height: s.size,
            fx: s.f(),
            fy: s.f(),
            cx: c,
            cy: c,
            pixels,
        }
    }
}

/// A panoramic camera ready to render.
#[derive(Debug, Clone)]
pub struct OmniImager {
    spec: OmniSensorSpec,
    camera: OmniCamera,
}

impl OmniImager {
    pub fn new(spec: OmniSensorSpec, field: &str) -> Result<OmniImager, SimError> {
        let camera = spec.camera(field)?;
        Ok(OmniImager { spec, camera })
    }

    pub fn spec(&self) -> &OmniSensorSpec {
        &self.spec
    }

    /// The reading's panorama with the robot at `pose`.
    pub fn image(
        &self,
        scene: &Scene,
        shader: &Shader,
        pose: &Pose2,
        stamp: f64,
        rng: &mut ChaCha8Rng,
    ) -> IntensityImage {
        let s = &self.spec;
        let mut pixels = vec![0.0; s.width * s.height];
        self.camera.render(scene, shader, pose, rng, &mut pixels);
        let (fx, fy, cx, cy) = s.intrinsics();
        IntensityImage {
            stamp,
            sensor: s.name.clone(),
            mount: Mount3 {
                xyz: [0.0, 0.0, s.z],
                rpy: [0.0; 3],
            },
            width: s.width,
            height: s.height,
            fx,
            fy,
            cx,
            cy,
            pixels,
        }
    }
}

/// The cameras of a run and the lighting they see (`SimConfig::cameras`).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSensors {
    /// The world's lighting condition during the run (default `tube`).
    pub lighting: LightingCondition,
    pub cameras: Vec<CameraSensorSpec>,
    pub stereo: Vec<StereoSensorSpec>,
    /// Upward ceiling cameras ([001]).
    pub ceiling: Vec<CeilingSensorSpec>,
    /// Panoramic cameras ([001]).
    pub omni: Vec<OmniSensorSpec>,
}

impl Default for CameraSensors {
    fn default() -> Self {
        Self {
            lighting: LightingCondition::Tube,
            cameras: Vec::new(),
            stereo: Vec::new(),
            ceiling: Vec::new(),
            omni: Vec::new(),
        }
    }
}

impl CameraSensors {
    pub fn is_empty(&self) -> bool {
        self.cameras.is_empty()
            && self.stereo.is_empty()
            && self.ceiling.is_empty()
            && self.omni.is_empty()
    }
}

/// The built cameras of a running simulation.
pub(crate) struct CameraStream {
    shader: Shader,
    cameras: Vec<(Camera, Schedule, ChaCha8Rng)>,
    rigs: Vec<(StereoRig, Schedule, ChaCha8Rng)>,
    ceiling: Vec<(CeilingImager, Schedule, ChaCha8Rng)>,
    omni: Vec<(OmniImager, Schedule, ChaCha8Rng)>,
}

fn stream(seed: u64, id: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(id);
    rng
}

impl CameraStream {
    /// `None` when no camera is configured (the shader is not even built then).
    pub(crate) fn new(
        world: &World,
        scene: &Scene,
        config: &CameraSensors,
        physics_hz: f64,
        seed: u64,
    ) -> Result<Option<CameraStream>, SimError> {
        if config.is_empty() {
            return Ok(None);
        }
        let mut cameras = Vec::with_capacity(config.cameras.len());
        for (i, c) in config.cameras.iter().enumerate() {
            let field = format!("cameras[{i}]");
            let camera = Camera::new(c.camera.clone(), &field)?;
            let schedule = Schedule::new(physics_hz, c.rate_hz, &format!("{field}.rate_hz"))?;
            cameras.push((camera, schedule, stream(seed, STREAM_CAMERA + i as u64)));
        }
        let mut rigs = Vec::with_capacity(config.stereo.len());
        for (i, s) in config.stereo.iter().enumerate() {
            let field = format!("stereo[{i}]");
            let rig = StereoRig::new(s.stereo.clone(), &field)?;
            let schedule = Schedule::new(physics_hz, s.rate_hz, &format!("{field}.rate_hz"))?;
            rigs.push((rig, schedule, stream(seed, STREAM_STEREO + i as u64)));
        }
        let mut ceiling = Vec::with_capacity(config.ceiling.len());
        for (i, c) in config.ceiling.iter().enumerate() {
            let field = format!("ceiling[{i}]");
            let imager = CeilingImager::new(c.clone(), &field)?;
            let schedule = Schedule::new(physics_hz, c.rate_hz, &format!("{field}.rate_hz"))?;
            ceiling.push((imager, schedule, stream(seed, STREAM_CEILING + i as u64)));
        }
        let mut omni = Vec::with_capacity(config.omni.len());
        for (i, c) in config.omni.iter().enumerate() {
            let field = format!("omni[{i}]");
            let imager = OmniImager::new(c.clone(), &field)?;
            let schedule = Schedule::new(physics_hz, c.rate_hz, &format!("{field}.rate_hz"))?;
            omni.push((imager, schedule, stream(seed, STREAM_OMNI + i as u64)));
        }
        Ok(Some(CameraStream {
            shader: Shader::new(world, scene, config.lighting),
            cameras,
            rigs,
            ceiling,
            omni,
        }))
    }

    /// Whether any camera reads the scene at `step`.
    pub(crate) fn due_at(&self, step: u64) -> bool {
        self.cameras.iter().any(|(_, s, _)| s.due_at(step))
            || self.rigs.iter().any(|(_, s, _)| s.due_at(step))
            || self.ceiling.iter().any(|(_, s, _)| s.due_at(step))
            || self.omni.iter().any(|(_, s, _)| s.due_at(step))
    }

    /// Renders the cameras that are due at `step` with the base at `base`; intensity cameras
    /// first, then each rig's left image and disparity map, then ceiling and omni cameras.
    pub(crate) fn step(
        &mut self,
        scene: &Scene,
        base: &Pose,
        step: u64,
        stamp: f64,
        out: &mut Vec<Reading>,
    ) {
        for (camera, schedule, rng) in &mut self.cameras {
            if schedule.due(step) {
                out.push(Reading::Intensity(camera.render(
                    scene,
                    &self.shader,
                    base,
                    stamp,
                    rng,
                )));
            }
        }
        for (rig, schedule, rng) in &mut self.rigs {
            if schedule.due(step) {
                let frame = rig.frame(scene, &self.shader, base, stamp, rng);
                let c = &rig.spec().camera;
                let f = c.fx();
                out.push(Reading::Intensity(IntensityImage {
                    stamp,
                    sensor: c.name.clone(),
                    mount: c.mount,
                    width: c.width,
                    height: c.height,
                    fx: f,
                    fy: f,
                    cx: 0.5 * (c.width as f64 - 1.0),
                    cy: 0.5 * (c.height as f64 - 1.0),
                    pixels: frame.left,
                }));
                out.push(Reading::Disparity(frame.disparity));
            }
        }
        if self.ceiling.is_empty() && self.omni.is_empty() {
            return;
        }
        // The robot's floor pose: where the training renders of 001's maps put the robot.
        let floor = project(base);
        for (imager, schedule, rng) in &mut self.ceiling {
            if schedule.due(step) {
                let image = imager.image(scene, &self.shader, &floor, stamp, rng);
                out.push(Reading::Intensity(image));
            }
        }
        for (imager, schedule, rng) in &mut self.omni {
            if schedule.due(step) {
                let image = imager.image(scene, &self.shader, &floor, stamp, rng);
                out.push(Reading::Intensity(image));
            }
        }
    }
}

/// The checks every camera shares: mount height `z`, `gain` and `rate_hz` positive, pixel
/// `noise_sigma` non-negative; errors name `field.<key>`.
fn validate_rendering(
    field: &str,
    z: f64,
    gain: f64,
    rate_hz: f64,
    noise_sigma: f64,
) -> Result<(), SimError> {
    let err = |k: &str, m: String| SimError::config(format!("{field}.{k}"), m);
    for (k, v) in [("z", z), ("gain", gain), ("rate_hz", rate_hz)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(err(k, format!("must be finite and > 0, got {v}")));
        }
    }
    if !(noise_sigma.is_finite() && noise_sigma >= 0.0) {
        return Err(err(
            "noise_sigma",
            format!("must be finite and >= 0, got {noise_sigma}"),
        ));
    }
    Ok(())
}
