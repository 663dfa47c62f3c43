//! Intensity cameras: a ray-cast renderer of grey images ([000] §VII: 160 × 120 grey
//! images under `tube`, `bulb` and `natural` light; [001]: omnidirectional images whose
//! columns shift when the robot turns, and the brightness of the ceiling above the robot).
//!
//! Every pixel casts one ray through the rapier scene (glass is transparent to cameras). The
//! hit point's albedo comes from its material's procedural solid texture (value noise at the
//! surface's `scale`, amplitude `contrast`), its radiance from Lambert shading by the lights
//! the lighting condition switches on, with inverse-square falloff (softened within 0.5 m)
//! plus an ambient term; lamps and windows are also seen directly (emissive footprints on the
//! ceiling, bright window panes). Shadows are not cast: each light sample would cost one more
//! ray per pixel, and the lab-like rooms this serves have their lights in open view. The
//! sensor applies a gain, Gaussian noise and 8-bit quantisation, clipped to [0, 1].

mod avx;
mod light_sample;

use crate::frustum::{FrustumCaster, Pinhole};
use crate::scene::{decode_tag, iso_to_pose, LaserSurface, Scene, StaticKind};
use atrium_robots::{IntensityImage, Mount3, Pose2};
use atrium_worlds::lighting::{LightKind, LightingCondition, Surface};
use atrium_worlds::World;
use light_sample::LightSample;
use nalgebra::Isometry3;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rapier3d::prelude::*;

/// Tube lights are sampled at this many points along their length.
const TUBE_SAMPLES: usize = 4;
/// Windows are sampled on a grid of this many points per side.
const WINDOW_SAMPLES: usize = 3;
/// Half-width of a lamp's bright footprint on the ceiling, m.
const LAMP_HALF_WIDTH: f64 = 0.1;
/// Softening of the inverse-square falloff, m² (a light never divides by ~0).
const FALLOFF_SOFTENING: f32 = 0.25;

/// A camera's geometry and sensor response.
#[derive(Debug, Clone, PartialEq)]
pub struct CameraSpec {
    pub name: String,
    pub width: usize,
    pub height: usize,
    /// Horizontal field of view, rad (pinhole); vertical follows from square pixels.
    pub hfov: f64,
    /// Camera frame in the robot's base frame; the optical axis is the mount's +x.
    pub mount: Mount3,
    /// Multiplies radiance into pixel values.
    pub gain: f64,
    /// Standard deviation of the per-pixel Gaussian noise (pixel units, [0, 1] scale).
    pub noise_sigma: f64,
    /// Rays travel at most this far, m.
    pub max_range: f64,
}

impl CameraSpec {
    /// The paper's camera: 160 × 120 grey, about 60° wide, 1 m above the floor.
    pub fn paper(name: &str) -> Self {
        Self {
            name: name.into(),
            width: 160,
            height: 120,
            hfov: 60f64.to_radians(),
            mount: Mount3 {
                xyz: [0.1, 0.0, 1.0],
                rpy: [0.0, 0.0, 0.0],
            },
            gain: 1.0,
            noise_sigma: 0.01,
            max_range: 30.0,
        }
    }

    /// Checks the numbers; errors name `field.<key>`.
    pub fn validate(&self, field: &str) -> Result<(), crate::SimError> {
        let err = |k: &str, m: String| crate::SimError::config(format!("{field}.{k}"), m);
        if self.width < 2 || self.height < 2 || self.width * self.height > 4_000_000 {
            return Err(err(
                "width",
                format!(
                    "image must be between 2 × 2 and 4 Mpixel, got {} × {}",
                    self.width, self.height
                ),
            ));
        }
        if !(self.hfov.is_finite() && self.hfov > 0.0 && self.hfov < 3.0) {
            return Err(err(
                "hfov",
                format!("must be in (0, 3) rad, got {}", self.hfov),
            ));
        }
        if !(self.gain.is_finite() && self.gain > 0.0) {
            return Err(err(
                "gain",
                format!("must be finite and > 0, got {}", self.gain),
            ));
        }
        if !(self.noise_sigma.is_finite() && self.noise_sigma >= 0.0) {
            return Err(err(
                "noise_sigma",
                format!("must be finite and >= 0, got {}", self.noise_sigma),
            ));
        }
        if !(self.max_range.is_finite() && self.max_range > 0.0) {
            return Err(err(
                "max_range",
                format!("must be finite and > 0, got {}", self.max_range),
            ));
        }
        if !self
            .mount
            .xyz
            .iter()
            .chain(&self.mount.rpy)
            .all(|v| v.is_finite())
        {
            return Err(err("mount", "must be finite".into()));
        }
        Ok(())
    }

    /// Focal length in pixels.
    pub fn fx(&self) -> f64 {
        0.5 * self.width as f64 / (0.5 * self.hfov).tan()
    }
}

#[derive(Debug, Clone, Copy)]
struct Emitter {
    kind: LightKind,
    a: [f64; 3],
    b: [f64; 3],
    radiance: f32,
}

/// Everything shading needs, precomputed for one world under one lighting condition.
#[derive(Debug, Clone)]
pub struct Shader {
    /// By scene material index, then floor, then ceiling.
    surfaces: Vec<Surface>,
    samples: Vec<LightSample>,
    /// `samples` in columns, for the AVX sum, and whether this processor runs it.
    columns: avx::SampleColumns,
    avx: bool,
    emitters: Vec<Emitter>,
    windows: Vec<Emitter>,
    ambient: f32,
    condition: LightingCondition,
    any_glass: bool,
}

impl Shader {
    /// The shader of `world` (whose materials are the scene's, in order) under `condition`.
    pub fn new(world: &World, scene: &Scene, condition: LightingCondition) -> Shader {
        let mut surfaces: Vec<Surface> = scene
            .materials()
            .iter()
            .map(|m| world.lighting.surface(&m.name))
            .collect();
        surfaces.push(world.lighting.surface("floor"));
        surfaces.push(world.lighting.surface("ceiling"));
        let on = condition.lights();
        let mut samples = Vec::new();
        let mut emitters = Vec::new();
        let mut windows = Vec::new();
        for l in &world.lighting.lights {
            let p = l.intensity() as f32;
            let a = l.from;
            let b = l.to.unwrap_or(l.from);
            let v = |x: [f64; 3]| Vector::new(x[0] as f32, x[1] as f32, x[2] as f32);
            let emitter = Emitter {
                kind: l.kind,
                a,
                b,
                radiance: if l.kind == on { 1.0 } else { 0.08 },
            };
            if l.kind == LightKind::Window {
                windows.push(emitter);
            } else {
                emitters.push(emitter);
            }
            if l.kind != on {
                continue;
            }
            match l.kind {
                LightKind::Bulb => samples.push(LightSample {
                    pos: v(a),
                    power: p,
                    dir: Vector::new(0.0, 0.0, -1.0),
                    isotropic: 0.4,
                }),
                LightKind::Tube => {
                    for k in 0..TUBE_SAMPLES {
                        let t = (k as f64 + 0.5) / TUBE_SAMPLES as f64;
                        let q = [0, 1, 2].map(|i| a[i] + t * (b[i] - a[i]));
                        samples.push(LightSample {
                            pos: v(q),
                            power: p / TUBE_SAMPLES as f32,
                            dir: Vector::new(0.0, 0.0, -1.0),
                            isotropic: 0.3,
                        });
                    }
                }
                LightKind::Window => {
                    // Daylight enters on the left of from → to (seen from above).
                    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                    let len = dx.hypot(dy);
                    // Slightly downward: the sky is above the horizon.
                    let inward =
                        Vector::new((-dy / len) as f32, (dx / len) as f32, -0.35).normalize();
                    let n = WINDOW_SAMPLES * WINDOW_SAMPLES;
                    for i in 0..WINDOW_SAMPLES {
                        for j in 0..WINDOW_SAMPLES {
                            let s = (i as f64 + 0.5) / WINDOW_SAMPLES as f64;
                            let t = (j as f64 + 0.5) / WINDOW_SAMPLES as f64;
                            let q = [a[0] + s * dx, a[1] + s * dy, a[2] + t * (b[2] - a[2])];
                            // Just inside the room, so the wall it sits in is lit from the front.
                            let pos = v(q) + inward * 0.05;
                            samples.push(LightSample {
                                pos,
                                power: p / n as f32,
                                dir: inward,
                                isotropic: 0.0,
                            });
                        }
                    }
                }
            }
        }
        let ambient = match condition {
            LightingCondition::Tube => 0.12,
            LightingCondition::Bulb => 0.05,
            LightingCondition::Natural => 0.2,
        };
        let any_glass = scene
            .materials()
            .iter()
            .any(|m| matches!(m.laser, LaserSurface::Glass { .. }));
        Shader {
            surfaces,
            columns: avx::SampleColumns::new(&samples),
            avx: avx::available(),
            samples,
            emitters,
            windows,
            ambient,
            condition,
            any_glass,
        }
    }

    pub fn condition(&self) -> LightingCondition {
        self.condition
    }

    /// Radiance leaving point `p` (normal `n`, towards the viewer) of surface `s`.
    fn shade(&self, p: Vector, n: Vector, s: usize, ceiling: bool) -> f32 {
        let surf = &self.surfaces[s];
        if ceiling {
            if let Some(e) = self.lamp_at(p) {
                return e;
            }
        } else if let Some(e) = self.window_at(p) {
            return e;
        }
        let albedo = albedo(surf, s as u32, p);
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where the processor has AVX.
            let e =
                unsafe { avx::add_samples(&self.columns, p, n, FALLOFF_SOFTENING, self.ambient) };
            return albedo * e;
        }
        albedo * self.add_samples(p, n)
    }

    /// The ambient term plus every lit sample's Lambert term: the scalar loop that
    /// `avx::add_samples` reproduces.
    fn add_samples(&self, p: Vector, n: Vector) -> f32 {
        let mut e = self.ambient;
        for l in &self.samples {
            let d = l.pos - p;
            let r2 = d.length_squared();
            let dir = d / r2.sqrt();
            let lambert = n.dot(dir);
            if lambert <= 0.0 {
                continue;
            }
            let emit = l.isotropic + (1.0 - l.isotropic) * (-dir).dot(l.dir).max(0.0);
            e += l.power * lambert * emit / (r2 + FALLOFF_SOFTENING);
        }
        e
    }

    /// A lamp seen directly: the ceiling point lies in its footprint.
    fn lamp_at(&self, p: Vector) -> Option<f32> {
        let (x, y) = (p.x as f64, p.y as f64);
        for e in &self.emitters {
            let (dx, dy) = match e.kind {
                LightKind::Bulb => (x - e.a[0], y - e.a[1]),
                _ => offset_from_segment([x, y], [e.a[0], e.a[1]], [e.b[0], e.b[1]]),
            };
            if shorter_than(dx, dy, LAMP_HALF_WIDTH) {
                return Some(e.radiance);
            }
        }
        None
    }

    /// A window pane seen directly: bright by day (`natural`), dark otherwise.
    fn window_at(&self, p: Vector) -> Option<f32> {
        let (x, y, z) = (p.x as f64, p.y as f64, p.z as f64);
        for w in &self.windows {
            let (lo, hi) = (w.a[2].min(w.b[2]), w.a[2].max(w.b[2]));
            if z < lo || z > hi {
                continue;
            }
            // Within 0.1 m of the pane's line (the wall face it is painted on).
            let (dx, dy) = offset_from_segment([x, y], [w.a[0], w.a[1]], [w.b[0], w.b[1]]);
            if shorter_than(dx, dy, 0.1) {
                return Some(if w.radiance >= 1.0 { 0.95 } else { 0.04 });
            }
        }
        None
    }
}

/// The offset from the point of segment a–b nearest to `p` to `p`.
fn offset_from_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> (f64, f64) {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let l2 = dx * dx + dy * dy;
    let t = if l2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)
}

/// `dx.hypot(dy) < r`, with `hypot` (a library call, a twentieth of a camera frame when every
/// pixel tested every lamp) only where the plain square sum, off by a few ulps at most, is
/// within a margin of r²: the same answer for every input, NaN included.
#[inline]
fn shorter_than(dx: f64, dy: f64, r: f64) -> bool {
    if dx * dx + dy * dy > r * r * (1.0 + 1e-6) {
        return false;
    }
    dx.hypot(dy) < r
}

/// Lattice hash → [0, 1).
#[inline]
fn hash3(x: i32, y: i32, z: i32, seed: u32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343)
        ^ (y as u32).wrapping_mul(0xd816_3841)
        ^ (z as u32).wrapping_mul(0xcb1a_b31f)
        ^ seed.wrapping_mul(0x9e37_79b9);
    h ^= h >> 13;
    h = h.wrapping_mul(0x5bd1_e995);
    h ^= h >> 15;
    (h & 0x00ff_ffff) as f32 / 16_777_216.0
}

/// `x.floor()` bit for bit, without the library call the baseline x86-64 target makes of
/// it (it has no rounding instruction): truncation, one down for negative non-integers, and
/// `x` itself where it is integral (so −0.0 stays −0.0). Beyond 2²³ every f32 is integral,
/// and NaN falls through to the library.
#[inline(always)]
fn floor(x: f32) -> f32 {
    if x.abs() < 8_388_608.0 {
        let t = x as i32 as f32;
        if t > x {
            t - 1.0
        } else if t == x {
            x
        } else {
            t
        }
    } else {
        x.floor()
    }
}

/// Trilinear value noise in [0, 1) with smoothstep weights.
#[inline]
fn value_noise(p: Vector, seed: u32) -> f32 {
    let f = Vector::new(floor(p.x), floor(p.y), floor(p.z));
    let (ix, iy, iz) = (f.x as i32, f.y as i32, f.z as i32);
    let t = p - f;
    let s = t * t * (Vector::splat(3.0) - 2.0 * t);
    let mut acc = 0.0;
    for dz in 0..2 {
        for dy in 0..2 {
            for dx in 0..2 {
                let w = (if dx == 1 { s.x } else { 1.0 - s.x })
                    * (if dy == 1 { s.y } else { 1.0 - s.y })
                    * (if dz == 1 { s.z } else { 1.0 - s.z });
                acc += w * hash3(ix + dx, iy + dy, iz + dz, seed);
            }
        }
    }
    acc
}

/// The albedo of a surface at world point `p`: a solid texture (two octaves of value noise
/// at the surface's feature scale), so no texture coordinates are needed.
#[inline]
fn albedo(s: &Surface, seed: u32, p: Vector) -> f32 {
    if s.contrast == 0.0 {
        return s.albedo as f32;
    }
    let q = p / s.scale as f32;
    let n = 0.65 * value_noise(q, seed) + 0.35 * value_noise(q * 2.7, seed ^ 0x5555);
    let v = s.albedo as f32 * (1.0 + 2.0 * s.contrast as f32 * (n - 0.5) * 2.0);
    v.clamp(0.0, 1.0)
}

/// A bundle of rays fixed to a sensor: unit directions in the sensor frame and, per ray, the
/// factor from distance along the ray to depth along the optical axis.
#[derive(Debug, Clone)]
pub struct RayBundle {
    pub dirs: Vec<Vector>,
    pub axial: Vec<f32>,
    /// The intrinsics of a pinhole bundle, for [`render_radiance_culled`]; None for others.
    pub pinhole: Option<Pinhole>,
}

impl RayBundle {
    /// A pinhole camera looking along +x: pixel (u, v) through (1, −(u − cx)/f, −(v − cy)/f).
    pub fn pinhole(width: usize, height: usize, f: f64) -> RayBundle {
        let (cx, cy) = (0.5 * (width as f64 - 1.0), 0.5 * (height as f64 - 1.0));
        let mut dirs = Vec::with_capacity(width * height);
        let mut axial = Vec::with_capacity(width * height);
        for v in 0..height {
            for u in 0..width {
                let d = nalgebra::Vector3::new(1.0, -(u as f64 - cx) / f, -(v as f64 - cy) / f);
                let n = d.norm();
                dirs.push(Vector::new(
                    (d.x / n) as f32,
                    (d.y / n) as f32,
                    (d.z / n) as f32,
                ));
                axial.push((1.0 / n) as f32);
            }
        }
        let min_axial = axial.iter().fold(1.0f32, |m, &c| m.min(c));
        let pinhole = Some(Pinhole {
            width,
            height,
            fx: f,
            fy: f,
            cx,
            cy,
            min_axial: f64::from(min_axial),
        });
        RayBundle {
            dirs,
            axial,
            pinhole,
        }
    }

    /// A panoramic (omnidirectional) camera: column j looks at azimuth 2π j / width
    /// counter-clockwise from the sensor's +x, rows span elevations from `elev_max` (top) to
    /// `elev_min` (bottom). Turning the sensor by 2π k / width shifts the columns by k.
    pub fn panorama(width: usize, height: usize, elev_min: f64, elev_max: f64) -> RayBundle {
        let mut dirs = Vec::with_capacity(width * height);
        for v in 0..height {
            let t = if height > 1 {
                v as f64 / (height - 1) as f64
            } else {
                0.5
            };
            let e = elev_max + t * (elev_min - elev_max);
            for u in 0..width {
                let a = std::f64::consts::TAU * u as f64 / width as f64;
                dirs.push(Vector::new(
                    (e.cos() * a.cos()) as f32,
                    (e.cos() * a.sin()) as f32,
                    e.sin() as f32,
                ));
            }
        }
        let axial = vec![1.0; dirs.len()];
        RayBundle {
            dirs,
            axial,
            pinhole: None,
        }
    }
}

/// Renders the rays of `bundle` from the sensor pose `sensor` (world frame) into radiance
/// (`out`, before gain and noise) and optionally axial depth (`depth`, 0 where nothing is hit),
/// one query-pipeline cast per ray.
pub fn render_radiance(
    scene: &Scene,
    shader: &Shader,
    bundle: &RayBundle,
    sensor: &Pose,
    max_range: f32,
    out: &mut [f32],
    mut depth: Option<&mut [f32]>,
) {
    with_camera_query(scene, shader, |query| {
        for (i, d) in bundle.dirs.iter().enumerate() {
            let dir = sensor.rotation * *d;
            let hit =
                query.cast_ray_and_get_normal(&Ray::new(sensor.translation, dir), max_range, true);
            let (value, z) = shade_hit(scene, shader, sensor, dir, bundle.axial[i], hit);
            out[i] = value;
            if let Some(dd) = depth.as_deref_mut() {
                dd[i] = z;
            }
        }
    });
}

/// [`render_radiance`], bit for bit, with the rays of a pinhole bundle cast by `caster` on
/// the colliders each pixel can see (`frustum.rs`): several times cheaper per frame. Other
/// bundles (panoramas) take the per-ray path.
#[allow(clippy::too_many_arguments)]
pub fn render_radiance_culled(
    scene: &Scene,
    shader: &Shader,
    bundle: &RayBundle,
    caster: &mut FrustumCaster,
    sensor: &Pose,
    max_range: f32,
    out: &mut [f32],
    mut depth: Option<&mut [f32]>,
) {
    let Some(pin) = &bundle.pinhole else {
        return render_radiance(scene, shader, bundle, sensor, max_range, out, depth);
    };
    with_camera_query(scene, shader, |query| {
        caster.render(
            query,
            sensor,
            pin,
            &bundle.dirs,
            max_range,
            |i, dir, hit| {
                let (value, z) = shade_hit(scene, shader, sensor, dir, bundle.axial[i], hit);
                out[i] = value;
                if let Some(dd) = depth.as_deref_mut() {
                    dd[i] = z;
                }
            },
        );
    });
}

/// Runs `f` with the query pipeline cameras see through: the sensor collision groups, and
/// glass left out when the shader makes it transparent.
fn with_camera_query<R>(scene: &Scene, shader: &Shader, f: impl FnOnce(&QueryPipeline) -> R) -> R {
    let opaque = |_: ColliderHandle, co: &Collider| {
        matches!(scene.laser_surface(co.user_data), LaserSurface::Opaque)
    };
    let mut filter = QueryFilter::default().groups(Scene::sensor_groups());
    if shader.any_glass {
        filter = filter.predicate(&opaque);
    }
    f(&scene.physics.query_pipeline_with_filter(filter))
}

/// A ray's radiance and axial depth from its first hit ((0, 0) for nothing hit); `dir` is the
/// ray's world direction, `axial` its bundle factor from distance to depth.
#[inline]
fn shade_hit(
    scene: &Scene,
    shader: &Shader,
    sensor: &Pose,
    dir: Vector,
    axial: f32,
    hit: Option<(ColliderHandle, RayIntersection)>,
) -> (f32, f32) {
    let Some((h, hit)) = hit else {
        return (0.0, 0.0);
    };
    let n_mat = shader.surfaces.len() - 2;
    let p = sensor.translation + dir * hit.time_of_impact;
    let (s, ceiling) = match decode_tag(scene.physics.colliders[h].user_data) {
        Some((StaticKind::Floor, _)) => (n_mat, false),
        Some((StaticKind::Ceiling, _)) => (n_mat + 1, true),
        Some((_, Some(m))) => (m, false),
        _ => (n_mat, false),
    };
    // Shade the side facing the camera.
    let n = if hit.normal.dot(dir) > 0.0 {
        -hit.normal
    } else {
        hit.normal
    };
    (shader.shade(p, n, s, ceiling), hit.time_of_impact * axial)
}

/// Gain, Gaussian noise, clipping to [0, 1] and 8-bit quantisation, in place.
pub fn expose(pixels: &mut [f32], gain: f64, noise_sigma: f64, rng: &mut ChaCha8Rng) {
    let g = gain as f32;
    let s = noise_sigma as f32;
    for p in pixels {
        let noise: f32 = if s > 0.0 {
            s * rng.sample::<f32, _>(StandardNormal)
        } else {
            0.0
        };
        let v = (*p * g + noise).clamp(0.0, 1.0);
        *p = (v * 255.0).round() / 255.0;
    }
}

/// A pinhole intensity camera.
#[derive(Debug, Clone)]
pub struct Camera {
    spec: CameraSpec,
    bundle: RayBundle,
    mount: Pose,
    radiance: Vec<f32>,
    depth: Vec<f32>,
    caster: FrustumCaster,
}

impl Camera {
    pub fn new(spec: CameraSpec, field: &str) -> Result<Camera, crate::SimError> {
        spec.validate(field)?;
        let bundle = RayBundle::pinhole(spec.width, spec.height, spec.fx());
        let mount = iso_to_pose(&spec.mount.to_isometry());
        let n = spec.width * spec.height;
        Ok(Camera {
            spec,
            bundle,
            mount,
            radiance: vec![0.0; n],
            depth: vec![0.0; n],
            caster: FrustumCaster::new(),
        })
    }

    pub fn spec(&self) -> &CameraSpec {
        &self.spec
    }

    /// Renders with the robot's base at `base` (world frame), keeping the noiseless axial
    /// depth of every pixel (0 = nothing hit) for [`Camera::true_depths`].
    pub fn render(
        &mut self,
        scene: &Scene,
        shader: &Shader,
        base: &Pose,
        stamp: f64,
        rng: &mut ChaCha8Rng,
    ) -> IntensityImage {
        let mut pixels = vec![0.0; self.radiance.len()];
        self.render_into(scene, shader, base, rng, &mut pixels);
        let f = self.spec.fx();
        IntensityImage {
            stamp,
            sensor: self.spec.name.clone(),
            mount: self.spec.mount,
            width: self.spec.width,
            height: self.spec.height,
            fx: f,
            fy: f,
            cx: 0.5 * (self.spec.width as f64 - 1.0),
            cy: 0.5 * (self.spec.height as f64 - 1.0),
            pixels,
        }
    }

    /// [`Camera::render`] into a caller's buffer (width × height), allocation-free.
    pub fn render_into(
        &mut self,
        scene: &Scene,
        shader: &Shader,
        base: &Pose,
        rng: &mut ChaCha8Rng,
        pixels: &mut [f32],
    ) {
        let sensor = *base * self.mount;
        render_radiance_culled(
            scene,
            shader,
            &self.bundle,
            &mut self.caster,
            &sensor,
            self.spec.max_range as f32,
            &mut self.radiance,
            Some(&mut self.depth),
        );
        pixels.copy_from_slice(&self.radiance);
        expose(pixels, self.spec.gain, self.spec.noise_sigma, rng);
    }

    /// Axial depths of the last render (0 = nothing hit), row-major.
    pub fn true_depths(&self) -> &[f32] {
        &self.depth
    }
}

/// The base pose of a robot standing at `p` (base frame on the floor).
pub fn floor_pose(p: &Pose2) -> Pose {
    iso_to_pose(&Isometry3::from_parts(
        nalgebra::Translation3::new(p.x, p.y, 0.0),
        nalgebra::UnitQuaternion::from_euler_angles(0.0, 0.0, p.theta),
    ))
}

/// An omnidirectional camera ([001]): a panorama of `width` columns (azimuth, starting
/// at the robot's heading and turning counter-clockwise) × `height` rows of elevation.
#[derive(Debug, Clone)]
pub struct OmniCamera {
    pub width: usize,
    pub height: usize,
    /// Height of the mirror above the floor, m.
    pub z: f64,
    pub gain: f64,
    pub noise_sigma: f64,
    bundle: RayBundle,
}

impl OmniCamera {
    /// Elevations from −30° to +30°.
    pub fn new(width: usize, height: usize, z: f64) -> Result<OmniCamera, crate::SimError> {
        if width < 2 || height < 1 || width * height > 4_000_000 {
            return Err(crate::SimError::config(
                "omni_camera.width",
                format!(
                    "panorama must be at least 2 × 1 and at most 4 Mpixel, got {width} × {height}"
                ),
            ));
        }
        if !(z.is_finite() && z > 0.0) {
            return Err(crate::SimError::config(
                "omni_camera.z",
                format!("must be finite and > 0, got {z}"),
            ));
        }
        let e = 30f64.to_radians();
        Ok(OmniCamera {
            width,
            height,
            z,
            gain: 1.0,
            noise_sigma: 0.0,
            bundle: RayBundle::panorama(width, height, -e, e),
        })
    }

    /// The panorama seen from `pose` (row-major, `height` rows of `width`).
    pub fn render(
        &self,
        scene: &Scene,
        shader: &Shader,
        pose: &Pose2,
        rng: &mut ChaCha8Rng,
        out: &mut [f32],
    ) {
        let mut sensor = floor_pose(pose);
        sensor.translation.z = self.z as f32;
        render_radiance(scene, shader, &self.bundle, &sensor, 50.0, out, None);
        expose(out, self.gain, self.noise_sigma, rng);
    }
}

/// An upward-looking camera reduced to one number: the mean brightness of the ceiling in a
/// small cone above the robot (Dellaert's ceiling-brightness MCL, [001]).
#[derive(Debug, Clone)]
pub struct CeilingCamera {
    pub z: f64,
    pub noise_sigma: f64,
    bundle: RayBundle,
}

impl CeilingCamera {
    /// A 9 × 9-ray camera with a 40° field of view, `z` above the floor.
    pub fn new(z: f64, noise_sigma: f64) -> Result<CeilingCamera, crate::SimError> {
        if !(z.is_finite() && z > 0.0) {
            return Err(crate::SimError::config(
                "ceiling_camera.z",
                format!("must be finite and > 0, got {z}"),
            ));
        }
        if !(noise_sigma.is_finite() && noise_sigma >= 0.0) {
            return Err(crate::SimError::config(
                "ceiling_camera.noise_sigma",
                format!("must be finite and >= 0, got {noise_sigma}"),
            ));
        }
        let f = 4.5 / (20f64.to_radians()).tan();
        Ok(CeilingCamera {
            z,
            noise_sigma,
            bundle: RayBundle::pinhole(9, 9, f),
        })
    }

    /// Ceiling brightness above `(x, y)` (heading does not matter: the cone is symmetric).
    pub fn brightness(
        &self,
        scene: &Scene,
        shader: &Shader,
        x: f64,
        y: f64,
        rng: &mut ChaCha8Rng,
    ) -> f64 {
        let mut sensor = floor_pose(&Pose2::new(x, y, 0.0));
        sensor.translation.z = self.z as f32;
        // Optical axis (+x) turned to point up (+z): pitch −90°.
        sensor.rotation *= Rotation::from_rotation_y(-std::f32::consts::FRAC_PI_2);
        let mut buf = [0f32; 81];
        render_radiance(scene, shader, &self.bundle, &sensor, 50.0, &mut buf, None);
        let mean = buf.iter().map(|v| *v as f64).sum::<f64>() / 81.0;
        let noise: f64 = if self.noise_sigma > 0.0 {
            self.noise_sigma * rng.sample::<f64, _>(StandardNormal)
        } else {
            0.0
        };
        mean + noise
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures;
    use atrium_worlds::lighting::Light;
    use rand::{Rng, SeedableRng};

    #[test]
    fn floor_is_the_library_floor_bit_for_bit() {
        let mut values = vec![
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            2.999_999_8,
            -2.999_999_8,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            -8_388_609.0,
            1e30,
            -1e30,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        // And a sweep over the range the noise sees (world metres over feature scales).
        values.extend((0..20_000).map(|k| (k as f32 - 10_000.0) * 0.013_7));
        for x in values {
            assert_eq!(floor(x).to_bits(), x.floor().to_bits(), "{x}");
        }
        assert!(floor(f32::NAN).is_nan());
    }

    #[test]
    fn shorter_than_is_hypot_below_the_radius_for_every_input() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let r = LAMP_HALF_WIDTH;
        let mut cases = vec![
            (f64::NAN, 0.0),
            (0.0, f64::NAN),
            (f64::INFINITY, 0.0),
            (1e200, 1e200),
            (1e-200, -1e-200),
            (0.0, -0.0),
            (r, 0.0),
            (0.0, -r),
        ];
        for _ in 0..200_000 {
            // Around the circle (where the two tests could part) and anywhere.
            let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let ulps: i64 = rng.random_range(-4..=4);
            let dx = f64::from_bits(((r * a.cos()).to_bits() as i64 + ulps) as u64);
            cases.push((dx, r * a.sin()));
            cases.push((rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0)));
        }
        let mut inside = 0;
        for (dx, dy) in cases {
            let want = dx.hypot(dy) < r;
            assert_eq!(shorter_than(dx, dy, r), want, "{dx} {dy}");
            inside += want as usize;
        }
        assert!(inside > 50_000, "{inside}");
    }

    fn lit_room() -> World {
        let mut w = fixtures::box_room(6.0, 4.0, "concrete");
        w.lighting.lights.push(Light {
            kind: LightKind::Tube,
            from: [-1.0, 0.0, 2.9],
            to: Some([1.0, 0.0, 2.9]),
            intensity: None,
        });
        w.lighting.lights.push(Light {
            kind: LightKind::Bulb,
            from: [2.0, 1.0, 2.5],
            to: None,
            intensity: None,
        });
        w
    }

    /// The AVX sum of the light samples is the scalar loop's, bit for bit: on the lab's
    /// lights (tubes, bulbs, windows: 24, 3 and 27 samples, so partial groups of eight too) under
    /// every condition, at random points and normals, and at a light sample itself (r = 0,
    /// where both give NaN).
    #[test]
    fn avx_light_sum_is_the_scalar_loop_bit_for_bit() {
        use rand::Rng;
        if !avx::available() {
            return;
        }
        let lab = World::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/lab.toml"),
        )
        .unwrap();
        let scene = Scene::new(&lab, 200.0).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut partial = 0;
        for condition in [
            LightingCondition::Tube,
            LightingCondition::Bulb,
            LightingCondition::Natural,
        ] {
            let shader = Shader::new(&lab, &scene, condition);
            partial += usize::from(!shader.samples.len().is_multiple_of(8));
            let mut points: Vec<Vector> = (0..2000)
                .map(|_| {
                    Vector::new(
                        rng.random_range(-2.0..14.0),
                        rng.random_range(-2.0..10.0),
                        rng.random_range(0.0..3.0),
                    )
                })
                .collect();
            points.push(shader.samples[0].pos);
            for p in points {
                let n = Vector::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )
                .normalize();
                let albedo = rng.random_range(0.1f32..1.0);
                let want = albedo * shader.add_samples(p, n);
                // SAFETY: checked above.
                let e = unsafe {
                    avx::add_samples(&shader.columns, p, n, FALLOFF_SOFTENING, shader.ambient)
                };
                let got = albedo * e;
                assert!(
                    want.to_bits() == got.to_bits() || (want.is_nan() && got.is_nan()),
                    "{condition:?} at {p:?}, n {n:?}: {want} vs {got}"
                );
            }
        }
        assert!(partial > 0, "a partial group of eight is covered");
    }

    #[test]
    fn depth_matches_geometry_and_lighting_changes_the_image() {
        let world = lit_room();
        let scene = Scene::new(&world, 200.0).unwrap();
        let mut spec = CameraSpec::paper("cam");
        spec.width = 32;
        spec.height = 24;
        spec.noise_sigma = 0.0;
        let mut cam = Camera::new(spec, "camera").unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let tube = Shader::new(&world, &scene, LightingCondition::Tube);
        let bulb = Shader::new(&world, &scene, LightingCondition::Bulb);
        // Facing +x from the centre: the east wall's inner face is at x = 2.9 (box_room walls
        // are 0.2 m thick around 6 m); the camera sits 0.1 m ahead of the base.
        let base = floor_pose(&Pose2::new(0.0, 0.0, 0.0));
        let a = cam.render(&scene, &tube, &base, 0.0, &mut rng);
        let centre = 12 * 32 + 16;
        let z = cam.true_depths()[centre];
        let want = (2.9 - 0.1) as f32;
        assert!((z - want).abs() < 0.02, "depth {z}, want {want}");
        let b = cam.render(&scene, &bulb, &base, 0.0, &mut rng);
        let mean = |i: &IntensityImage| i.pixels.iter().sum::<f32>() / i.pixels.len() as f32;
        assert!(mean(&a) > 0.05 && mean(&a) < 0.95, "{}", mean(&a));
        assert!(
            (mean(&a) - mean(&b)).abs() > 0.01,
            "{} vs {}",
            mean(&a),
            mean(&b)
        );
        assert!(a.pixels.iter().all(|p| (0.0..=1.0).contains(p)));
    }

    #[test]
    fn turning_the_omnicam_shifts_its_columns() {
        let world = lit_room();
        let scene = Scene::new(&world, 200.0).unwrap();
        let shader = Shader::new(&world, &scene, LightingCondition::Tube);
        let omni = OmniCamera::new(64, 8, 1.0).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut a = vec![0.0; 64 * 8];
        let mut b = vec![0.0; 64 * 8];
        omni.render(
            &scene,
            &shader,
            &Pose2::new(0.5, 0.3, 0.0),
            &mut rng,
            &mut a,
        );
        let k = 5;
        let turn = std::f64::consts::TAU * k as f64 / 64.0;
        omni.render(
            &scene,
            &shader,
            &Pose2::new(0.5, 0.3, turn),
            &mut rng,
            &mut b,
        );
        let mut worst = 0.0f32;
        for v in 0..8 {
            for u in 0..64 {
                // Column u of the turned view looks where column u + k of the first did.
                let d = (b[v * 64 + u] - a[v * 64 + (u + k) % 64]).abs();
                worst = worst.max(d);
            }
        }
        assert!(worst <= 2.0 / 255.0, "{worst}");
    }

    #[test]
    fn ceiling_is_bright_under_a_lit_lamp_only() {
        let world = lit_room();
        let scene = Scene::new(&world, 200.0).unwrap();
        let tube = Shader::new(&world, &scene, LightingCondition::Tube);
        let bulb = Shader::new(&world, &scene, LightingCondition::Bulb);
        let cam = CeilingCamera::new(0.5, 0.0).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let under_tube = cam.brightness(&scene, &tube, 0.0, 0.0, &mut rng);
        let away = cam.brightness(&scene, &tube, -2.5, 1.5, &mut rng);
        let tube_off = cam.brightness(&scene, &bulb, 0.0, 0.0, &mut rng);
        assert!(under_tube > away + 0.05, "{under_tube} vs {away}");
        assert!(under_tube > tube_off + 0.05, "{under_tube} vs {tube_off}");
        assert!(CeilingCamera::new(f64::NAN, 0.0).is_err());
    }

    #[test]
    fn bad_specs_are_named() {
        let mut s = CameraSpec::paper("cam");
        s.width = 0;
        assert!(Camera::new(s, "cameras[0]")
            .unwrap_err()
            .to_string()
            .contains("cameras[0].width"));
        let mut s = CameraSpec::paper("cam");
        s.gain = f64::NAN;
        assert!(Camera::new(s, "cameras[0]")
            .unwrap_err()
            .to_string()
            .contains("gain"));
    }

    #[test]
    fn textures_vary_with_contrast_only() {
        let flat = Surface {
            albedo: 0.6,
            contrast: 0.0,
            scale: 0.1,
        };
        let rough = Surface {
            albedo: 0.6,
            contrast: 0.5,
            scale: 0.1,
        };
        let pts: Vec<Vector> = (0..200)
            .map(|i| Vector::new(i as f32 * 0.013, 0.3, 1.1))
            .collect();
        let var = |s: &Surface| {
            let v: Vec<f32> = pts.iter().map(|p| albedo(s, 1, *p)).collect();
            let m = v.iter().sum::<f32>() / v.len() as f32;
            v.iter().map(|x| (x - m) * (x - m)).sum::<f32>() / v.len() as f32
        };
        assert!(var(&flat) < 1e-10, "{}", var(&flat));
        assert!(var(&rough) > 0.005, "{}", var(&rough));
    }
}
