//! Training the appearance localizers of issue 5 from a world rendered with the simulator's
//! cameras: the appearance map of the auxiliary particle filter ([000] §VII: a grid of
//! training poses with rotations, stereo left images and sparse disparity maps), the omnicam
//! eigenimage map and the ceiling-brightness map ([001]).
//!
//! The robot is placed at the training poses directly (the papers drove it there); nothing
//! here depends on the physics. Poses render in parallel chunks, each pose with its own noise
//! stream, so the maps do not depend on the thread count.

use atrium_localization::appearance_apf::{AppearanceModel, AppearanceTraining};
use atrium_localization::ceiling_mcl::CeilingMap;
use atrium_localization::limits::{fmt_count, fmt_length, fmt_value, TRAINING_MAX_POSES};
use atrium_localization::omni_map::{OmniMap, OmniMapParams};
use atrium_robots::{normalize_angle, Pose2};
use atrium_sim::camera::{floor_pose, Camera, CameraSpec, CeilingCamera, OmniCamera, Shader};
use atrium_sim::camera_stream::CeilingImager;
use atrium_sim::stereo::{StereoRig, StereoSpec};
use atrium_sim::Scene;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// A training grid: positions every `step` metres over `area` (x0, y0, x1, y1), each at
/// headings every `rotation_step_deg` (000 §VII: 50 cm and 10°).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainingGrid {
    pub area: [f64; 4],
    #[serde(default = "default_step")]
    pub step: f64,
    #[serde(default = "default_rotation")]
    pub rotation_step_deg: f64,
}

fn default_step() -> f64 {
    0.5
}

fn default_rotation() -> f64 {
    10.0
}

impl TrainingGrid {
    /// Checks the numbers; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        let [x0, y0, x1, y1] = self.area;
        if !(self.area.iter().all(|v| v.is_finite()) && x1 >= x0 && y1 >= y0) {
            return Err(format!(
                "area must be finite [x0, y0, x1, y1] with x1 >= x0 and y1 >= y0, got {:?}",
                self.area
            ));
        }
        if !(self.step.is_finite() && self.step > 0.0) {
            return Err(format!("step must be finite and > 0, got {}", self.step));
        }
        if !(self.rotation_step_deg.is_finite()
            && self.rotation_step_deg > 0.0
            && self.rotation_step_deg <= 360.0)
        {
            return Err(format!(
                "rotation_step_deg must be within (0, 360], got {}",
                self.rotation_step_deg
            ));
        }
        // In f64: a tiny step must not overflow the count before it is compared.
        let side = |e: f64| (e / self.step + 1e-9).floor() + 1.0;
        let rotations = (360.0 / self.rotation_step_deg).round().max(1.0);
        let n = side(x1 - x0) * side(y1 - y0) * rotations;
        if n > TRAINING_MAX_POSES as f64 {
            return Err(format!(
                "step {} m and rotation_step_deg {} over the {} m × {} m area give {} \
                 training poses, more than the limit of {TRAINING_MAX_POSES} \
                 (TRAINING_MAX_POSES); raise step or rotation_step_deg",
                fmt_value(self.step),
                self.rotation_step_deg,
                fmt_length(x1 - x0),
                fmt_length(y1 - y0),
                fmt_count(n)
            ));
        }
        Ok(())
    }

    /// Training poses: nodes × rotations (after [`TrainingGrid::validate`], at most
    /// [`TRAINING_MAX_POSES`]).
    pub fn pose_count(&self) -> usize {
        let (nx, ny) = self.nodes();
        nx.saturating_mul(ny).saturating_mul(self.rotations())
    }

    /// Grid nodes along x and y.
    pub fn nodes(&self) -> (usize, usize) {
        let [x0, y0, x1, y1] = self.area;
        (
            ((x1 - x0) / self.step + 1e-9).floor() as usize + 1,
            ((y1 - y0) / self.step + 1e-9).floor() as usize + 1,
        )
    }

    pub fn rotations(&self) -> usize {
        ((360.0 / self.rotation_step_deg).round() as usize).max(1)
    }

    /// Every training pose: node by node, all rotations of a node together.
    pub fn poses(&self) -> Vec<Pose2> {
        let (nx, ny) = self.nodes();
        let r = self.rotations();
        let mut out = Vec::with_capacity(nx * ny * r);
        for j in 0..ny {
            for i in 0..nx {
                for k in 0..r {
                    out.push(Pose2::new(
                        self.area[0] + i as f64 * self.step,
                        self.area[1] + j as f64 * self.step,
                        normalize_angle((k as f64 * 360.0 / r as f64).to_radians()),
                    ));
                }
            }
        }
        out
    }
}

/// The noise stream of training image `i`.
fn image_rng(seed: u64, i: usize) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(i as u64);
    rng
}

/// One stereo frame as training data: the left intensity image and the disparity map.
pub type StereoViews = (Vec<f32>, Vec<f32>);

/// Stereo frames at `poses`.
pub fn render_stereo(
    scene: &Scene,
    shader: &Shader,
    spec: &StereoSpec,
    poses: &[Pose2],
    seed: u64,
) -> Result<Vec<StereoViews>, String> {
    StereoRig::new(spec.clone(), "stereo").map_err(|e| e.to_string())?;
    Ok(poses
        .par_chunks(64)
        .enumerate()
        .flat_map_iter(|(c, chunk)| {
            let mut rig = StereoRig::new(spec.clone(), "stereo").expect("validated above");
            chunk
                .iter()
                .enumerate()
                .map(move |(k, p)| {
                    let i = c * 64 + k;
                    let mut rng = image_rng(seed, i);
                    let f = rig.frame(scene, shader, &floor_pose(p), i as f64, &mut rng);
                    (f.left, f.disparity.disparity)
                })
                .collect::<Vec<_>>()
        })
        .collect())
}

/// Intensity images of a single camera at `poses`.
pub fn render_intensity(
    scene: &Scene,
    shader: &Shader,
    spec: &CameraSpec,
    poses: &[Pose2],
    seed: u64,
) -> Result<Vec<Vec<f32>>, String> {
    Camera::new(spec.clone(), "camera").map_err(|e| e.to_string())?;
    let n = spec.width * spec.height;
    Ok(poses
        .par_chunks(64)
        .enumerate()
        .flat_map_iter(|(c, chunk)| {
            let mut cam = Camera::new(spec.clone(), "camera").expect("validated above");
            chunk
                .iter()
                .enumerate()
                .map(move |(k, p)| {
                    let mut out = vec![0.0; n];
                    cam.render_into(
                        scene,
                        shader,
                        &floor_pose(p),
                        &mut image_rng(seed, c * 64 + k),
                        &mut out,
                    );
                    out
                })
                .collect::<Vec<_>>()
        })
        .collect())
}

/// The appearance map of 000 §VII: stereo frames at every pose of `grid` (seen through
/// `shader`, i.e. under the training light), PCA features of the left images and, with
/// `disparity`, EM-PCA features of the disparity maps.
pub fn train_appearance_model(
    scene: &Scene,
    shader: &Shader,
    spec: &StereoSpec,
    grid: &TrainingGrid,
    disparity: bool,
    training: AppearanceTraining,
) -> Result<AppearanceModel, String> {
    grid.validate()?;
    let poses = grid.poses();
    let frames = render_stereo(scene, shader, spec, &poses, training.seed)?;
    let left: Vec<&[f32]> = frames.iter().map(|f| f.0.as_slice()).collect();
    let disp: Vec<&[f32]> = frames.iter().map(|f| f.1.as_slice()).collect();
    AppearanceModel::train(
        &poses,
        spec.camera.width,
        spec.camera.height,
        &left,
        disparity.then_some(disp.as_slice()),
        training,
    )
    .map_err(|e| e.to_string())
}

/// The omnicam eigenimage map of 001 over the nodes of `grid` (its rotations are not used:
/// the map makes its own by shifting columns, `params.rotations` of them).
pub fn train_omni_map(
    scene: &Scene,
    shader: &Shader,
    camera: &OmniCamera,
    grid: &TrainingGrid,
    params: OmniMapParams,
) -> Result<OmniMap, String> {
    grid.validate()?;
    let (nx, ny) = grid.nodes();
    let dim = camera.width * camera.height;
    let nodes: Vec<Pose2> = (0..ny)
        .flat_map(|j| {
            (0..nx).map(move |i| {
                Pose2::new(
                    grid.area[0] + i as f64 * grid.step,
                    grid.area[1] + j as f64 * grid.step,
                    0.0,
                )
            })
        })
        .collect();
    let images: Vec<Vec<f32>> = nodes
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let mut out = vec![0.0; dim];
            camera.render(scene, shader, p, &mut image_rng(params.seed, i), &mut out);
            out
        })
        .collect();
    let refs: Vec<&[f32]> = images.iter().map(|v| v.as_slice()).collect();
    OmniMap::build(
        [grid.area[0], grid.area[1]],
        grid.step,
        nx,
        ny,
        camera.width,
        camera.height,
        &refs,
        params,
    )
    .map_err(|e| e.to_string())
}

/// The ceiling-brightness map of 001: one upward-camera reading at every node of `grid`.
pub fn train_ceiling_map(
    scene: &Scene,
    shader: &Shader,
    camera: &CeilingCamera,
    grid: &TrainingGrid,
    seed: u64,
) -> Result<CeilingMap, String> {
    grid.validate()?;
    let (nx, ny) = grid.nodes();
    let samples: Vec<[f64; 3]> = (0..nx * ny)
        .into_par_iter()
        .map(|n| {
            let x = grid.area[0] + (n % nx) as f64 * grid.step;
            let y = grid.area[1] + (n / nx) as f64 * grid.step;
            let b = camera.brightness(scene, shader, x, y, &mut image_rng(seed, n));
            [x, y, b]
        })
        .collect();
    CeilingMap::from_samples(&samples, [grid.area[0], grid.area[1]], grid.step, nx, ny)
        .map_err(|e| e.to_string())
}

/// The ceiling-brightness map of 001 as the stream's ceiling camera sees it
/// (`atrium_sim::camera_stream::CeilingImager`): at every node of `grid`, the mean of the
/// camera's image rendered with the robot standing there (each node its own noise stream).
/// A run's readings are the same images, so map and readings agree to the noise.
pub fn train_ceiling_map_from_images(
    scene: &Scene,
    shader: &Shader,
    imager: &CeilingImager,
    grid: &TrainingGrid,
    seed: u64,
) -> Result<CeilingMap, String> {
    grid.validate()?;
    let (nx, ny) = grid.nodes();
    let n_px = imager.spec().size * imager.spec().size;
    let samples: Vec<[f64; 3]> = (0..nx * ny)
        .into_par_iter()
        .map(|n| {
            let x = grid.area[0] + (n % nx) as f64 * grid.step;
            let y = grid.area[1] + (n / nx) as f64 * grid.step;
            let mut px = vec![0.0; n_px];
            let pose = Pose2::new(x, y, 0.0);
            imager.render_into(scene, shader, &pose, &mut image_rng(seed, n), &mut px);
            let b = px.iter().map(|v| *v as f64).sum::<f64>() / n_px as f64;
            [x, y, b]
        })
        .collect();
    CeilingMap::from_samples(&samples, [grid.area[0], grid.area[1]], grid.step, nx, ny)
        .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use atrium_localization::appearance::sensor_model_error;
    use atrium_localization::appearance_apf::{ApfParams, AppearanceApf};
    use atrium_localization::ceiling_mcl::{CeilingMcl, CeilingMclParams};
    use atrium_localization::mcl::InitialBelief;
    use atrium_localization::{Localizer, OdometryDelta, ReadingCounts};
    use atrium_robots::{DisparityImage, IntensityImage, Mount3, Reading};
    use atrium_worlds::lighting::LightingCondition;
    use atrium_worlds::World;
    use rand::Rng;
    use std::sync::Arc;

    fn lab() -> World {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/lab.toml");
        World::load(&path).unwrap()
    }

    /// Poses every `step` m along a polyline, turning in place at the corners in 0.2 rad
    /// steps (so odometry sees the turns).
    fn drive(path: &[[f64; 2]], step: f64) -> Vec<Pose2> {
        let mut out = Vec::new();
        let mut heading = (path[1][1] - path[0][1]).atan2(path[1][0] - path[0][0]);
        for w in path.windows(2) {
            let (a, b) = (w[0], w[1]);
            let th = (b[1] - a[1]).atan2(b[0] - a[0]);
            while normalize_angle(th - heading).abs() > 1e-9 {
                let d = normalize_angle(th - heading).clamp(-0.2, 0.2);
                heading = normalize_angle(heading + d);
                out.push(Pose2::new(a[0], a[1], heading));
            }
            let len = (b[0] - a[0]).hypot(b[1] - a[1]);
            let n = (len / step).ceil() as usize;
            for k in 0..n {
                let t = k as f64 / n as f64;
                out.push(Pose2::new(
                    a[0] + t * (b[0] - a[0]),
                    a[1] + t * (b[1] - a[1]),
                    th,
                ));
            }
        }
        out
    }

    /// Odometry of a drive: the true increments with 3 % scale error and random noise.
    fn odometry(truth: &[Pose2], seed: u64) -> Vec<Pose2> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut odo = vec![Pose2::new(0.0, 0.0, 0.0)];
        for w in truth.windows(2) {
            let d = w[0].between(&w[1]);
            // Uniform noise of standard deviation s.
            let n = |rng: &mut ChaCha8Rng, s: f64| s * 3f64.sqrt() * rng.random_range(-1.0..1.0);
            let noisy = Pose2::new(
                1.03 * d.x + n(&mut rng, 0.005),
                d.y + n(&mut rng, 0.005),
                d.theta * 0.98 + n(&mut rng, 0.005),
            );
            let last = *odo.last().unwrap();
            odo.push(last.compose(&noisy));
        }
        odo
    }

    fn small_stereo() -> StereoSpec {
        // The size of the illumination experiment (`appearance_lab.rs`): 48 × 36.
        let mut s = StereoSpec::paper("stereo");
        s.camera.width = 48;
        s.camera.height = 36;
        s.max_disparity = 10;
        s.window_radius = 2;
        s
    }

    /// The auxiliary particle filter of 000 §VI tracks a drive through the lab under the
    /// training light, fusing intensity and disparity (w_d = w_i = ½), with the error a 50 cm
    /// grid with 10° rotations allows.
    #[test]
    fn apf_tracks_a_lab_path_under_tube_light() {
        let world = lab();
        let scene = Scene::new(&world, 200.0).unwrap();
        let shader = Shader::new(&world, &scene, LightingCondition::Tube);
        let spec = small_stereo();
        // The part of the training area the path crosses, on the paper's 50 cm grid; 15°
        // rotations rather than 10° keep the test to 1,584 stereo pairs.
        let grid = TrainingGrid {
            area: [2.5, 2.0, 7.5, 4.5],
            step: 0.5,
            rotation_step_deg: 15.0,
        };
        let model = train_appearance_model(
            &scene,
            &shader,
            &spec,
            &grid,
            true,
            AppearanceTraining {
                d: 20,
                pca_samples: 100,
                seed: 3,
            },
        )
        .unwrap();
        let truth = drive(&[[2.6, 2.2], [7.3, 2.4], [7.1, 4.4], [3.0, 4.3]], 0.1);
        let odo = odometry(&truth, 5);
        let mut apf = AppearanceApf::new(
            "apf",
            ApfParams {
                intensity_sensor: Some("stereo".into()),
                disparity_sensor: Some("stereo".into()),
                ..Default::default()
            },
            Arc::new(model),
            &InitialBelief::Tracking {
                pose: truth[0],
                sigma: [0.3, 0.3, 0.2],
            },
            9,
        )
        .unwrap();
        // A frame every 3 poses (30 cm of travel), as a 2 Hz camera on a slow robot.
        let frame_poses: Vec<Pose2> = (3..truth.len()).step_by(3).map(|k| truth[k]).collect();
        let rendered = render_stereo(&scene, &shader, &spec, &frame_poses, 77).unwrap();
        let mount = spec.camera.mount;
        let (mut errs, mut headings, mut sm) = (Vec::new(), Vec::new(), Vec::new());
        for k in 1..truth.len() {
            let stamp = k as f64 * 0.1;
            apf.predict(&OdometryDelta {
                stamp,
                from: odo[k - 1],
                to: odo[k],
            })
            .unwrap();
            if k % 3 != 0 {
                continue;
            }
            let (left, disp) = &rendered[k / 3 - 1];
            apf.update(&Reading::Intensity(IntensityImage {
                stamp,
                sensor: "stereo".into(),
                mount,
                width: 48,
                height: 36,
                fx: spec.camera.fx(),
                fy: spec.camera.fx(),
                cx: 23.5,
                cy: 17.5,
                pixels: left.clone(),
            }))
            .unwrap();
            apf.update(&Reading::Disparity(DisparityImage {
                stamp,
                sensor: "stereo".into(),
                width: 48,
                height: 36,
                fx: spec.camera.fx(),
                baseline: spec.baseline,
                disparity: disp.clone(),
            }))
            .unwrap();
            let e = apf.estimate().pose;
            errs.push(e.distance(&truth[k]));
            headings.push(e.heading_error(&truth[k]).to_degrees());
            sm.push(
                sensor_model_error(&truth[k], apf.last_sensor_model())
                    .unwrap()
                    .0,
            );
        }
        assert_eq!(apf.rejected(), 0);
        assert_eq!(apf.updates(), errs.len());
        let n = errs.len() as f64;
        let mean = errs.iter().sum::<f64>() / n;
        let max = errs.iter().cloned().fold(0.0, f64::max);
        let mean_h = headings.iter().sum::<f64>() / n;
        let mean_sm = sm.iter().sum::<f64>() / n;
        let report = format!(
            "{} frames: mean {mean:.3} m, max {max:.3} m, heading {mean_h:.1}°, sensor-model e {mean_sm:.1}",
            errs.len()
        );
        eprintln!("apf lab tube: {report}");
        assert!(mean < 0.25 && max < 0.5 && mean_h < 10.0, "{report}");
    }

    /// Ceiling-brightness MCL (001) converges from a belief spread over the lab under its
    /// bulbs: three lamps at different places make the brightness along a path unique.
    #[test]
    fn ceiling_mcl_converges_from_a_spread_belief() {
        let world = lab();
        let scene = Scene::new(&world, 200.0).unwrap();
        let shader = Shader::new(&world, &scene, LightingCondition::Bulb);
        let camera = CeilingCamera::new(0.5, 0.0).unwrap();
        let grid = TrainingGrid {
            area: [1.0, 1.0, 10.0, 6.0],
            step: 0.25,
            rotation_step_deg: 360.0,
        };
        let map = Arc::new(train_ceiling_map(&scene, &shader, &camera, &grid, 1).unwrap());
        let noisy = CeilingCamera::new(0.5, 0.01).unwrap();
        let truth = drive(
            &[[2.0, 2.0], [8.5, 2.0], [8.5, 5.0], [3.0, 5.0], [3.0, 3.0]],
            0.1,
        );
        let odo = odometry(&truth, 2);
        let mut mcl = CeilingMcl::new(
            "ceiling",
            CeilingMclParams {
                particles: 20_000,
                sigma: 0.02,
                ..Default::default()
            },
            map,
            &InitialBelief::Global { regions: vec![] },
            4,
        )
        .unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let mut errs = Vec::new();
        for k in 1..truth.len() {
            mcl.predict(&OdometryDelta {
                stamp: k as f64,
                from: odo[k - 1],
                to: odo[k],
            })
            .unwrap();
            let z = noisy.brightness(&scene, &shader, truth[k].x, truth[k].y, &mut rng);
            mcl.update(&Reading::Intensity(IntensityImage {
                stamp: k as f64,
                sensor: "ceiling".into(),
                mount: Mount3 {
                    xyz: [0.0, 0.0, 0.5],
                    rpy: [0.0, -std::f64::consts::FRAC_PI_2, 0.0],
                },
                width: 1,
                height: 1,
                fx: 1.0,
                fy: 1.0,
                cx: 0.0,
                cy: 0.0,
                pixels: vec![z as f32],
            }))
            .unwrap();
            errs.push(mcl.estimate().pose.distance(&truth[k]));
        }
        let start = errs[0];
        let tail = &errs[errs.len() - 20..];
        let worst_tail = tail.iter().cloned().fold(0.0, f64::max);
        eprintln!(
            "ceiling mcl: {} readings, first error {start:.2} m, last-20 max {worst_tail:.3} m",
            errs.len()
        );
        assert!(start > 1.0, "the belief starts spread: {start}");
        assert!(worst_tail < 0.3, "{errs:?}");
    }

    /// A training pose is found again from its own panorama under rotation; a panorama taken
    /// between grid points lands on one of its neighbours (001's energy minimum).
    #[test]
    fn omni_map_finds_training_poses_and_neighbours() {
        let world = lab();
        let scene = Scene::new(&world, 200.0).unwrap();
        let shader = Shader::new(&world, &scene, LightingCondition::Tube);
        let camera = OmniCamera::new(64, 16, 1.0).unwrap();
        let grid = TrainingGrid {
            area: [1.0, 1.0, 10.0, 6.0],
            step: 0.5,
            rotation_step_deg: 360.0,
        };
        let map = train_omni_map(
            &scene,
            &shader,
            &camera,
            &grid,
            OmniMapParams {
                rotations: 32,
                d: 20,
                pca_locations: 10,
                seed: 2,
            },
        )
        .unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let mut img = vec![0.0; 64 * 16];
        // Training nodes, turned by whole rotation steps.
        for (i, j, r) in [(3, 2, 5), (12, 7, 20), (17, 9, 31), (8, 4, 0)] {
            let th = 2.0 * std::f64::consts::PI * r as f64 / 32.0;
            let p = Pose2::new(1.0 + 0.5 * i as f64, 1.0 + 0.5 * j as f64, th);
            camera.render(&scene, &shader, &p, &mut rng, &mut img);
            let hit = map.lookup(&img).unwrap();
            assert_eq!((hit.node, hit.rotation), ((i, j), r), "{p:?}: {hit:?}");
        }
        // Between grid points and rotations: a neighbouring node, the nearest rotations.
        let mut landed = 0;
        let tests = [
            Pose2::new(2.25, 2.25, 0.3),
            Pose2::new(5.75, 3.4, 2.0),
            Pose2::new(8.1, 4.75, -1.2),
            Pose2::new(3.6, 5.2, 3.0),
        ];
        for p in tests {
            camera.render(&scene, &shader, &p, &mut rng, &mut img);
            let hit = map.lookup(&img).unwrap();
            let dx = (hit.pose.x - p.x).abs();
            let dy = (hit.pose.y - p.y).abs();
            let dth = hit.pose.heading_error(&p).to_degrees();
            eprintln!("omni between nodes: {p:?} -> {hit:?}");
            if dx <= 0.5 && dy <= 0.5 && dth <= 11.25 {
                landed += 1;
            }
        }
        assert_eq!(landed, tests.len());
        // Bad input: the wrong panorama size.
        assert!(map.lookup(&img[..100]).is_err());
    }

    #[test]
    fn a_tiny_training_step_is_refused_without_overflow() {
        let grid = |step: f64, area: [f64; 4]| TrainingGrid {
            area,
            step,
            rotation_step_deg: 360.0,
        };
        let e = grid(1e-300, [0.0, 0.0, 10.0, 10.0]).validate().unwrap_err();
        assert!(
            e.starts_with("step 1e-300 m and rotation_step_deg 360 over the 10 m × 10 m area give")
                && e.contains("more than the limit of 200000 (TRAINING_MAX_POSES)"),
            "{e}"
        );
        assert!(grid(1.0, [0.0, 0.0, 1e300, 1.0]).validate().is_err());
        // 447 × 447 = 199,809 nodes fit; 448 × 448 do not.
        assert!(grid(1.0, [0.0, 0.0, 446.0, 446.0]).validate().is_ok());
        assert!(grid(1.0, [0.0, 0.0, 447.0, 447.0]).validate().is_err());
        assert_eq!(grid(1.0, [0.0, 0.0, 446.0, 446.0]).pose_count(), 199_809);
    }
}
