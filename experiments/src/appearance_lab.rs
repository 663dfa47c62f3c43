//! The illumination experiment of Porta, Verbeek and Kröse ([000] §VII) in the bundled
//! lab (`worlds/lab.toml`): a training set of intensity images and sparse disparity maps on a
//! 50 cm grid over a 9 × 5 m area with 10° rotations under `tube` light; PCA (intensity) and
//! EM-PCA (disparity) features from N randomly chosen training images; then, along a test
//! path under `tube`, `bulb` and `natural` light, the sensor-model error e = min ‖r − n‖ over
//! the training poses the nearest-neighbour model uses: intensity alone with J = 10, and
//! intensity + disparity with J = 5 + 5.
//!
//! The robot is placed at the training and test poses directly (the paper drove it there);
//! nothing here depends on the physics.
//!
//! The bundled scenario `scenarios/appearance_lab.toml` holds the setup in its
//! `[appearance_experiment]` table ([`AppearanceSettings`]); `atrium appearance SCENARIO`
//! runs it ([`run_experiment`]) and prints the paper-style table ([`AppearanceOutcome::to_text`]).

use atrium_localization::appearance::{sensor_model_error, AppearanceMap, Component};
use atrium_localization::em_pca::{EmPca, EmPcaParams, ProjectionScratch};
use atrium_localization::pca::{Pca, PcaMethod};
use atrium_robots::Pose2;
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::scenario::Scenario;
use atrium_sim::camera::{floor_pose, Shader};
use atrium_sim::stereo::{disparity_quality, StereoRig, StereoSpec};
use atrium_sim::Scene;
use atrium_worlds::lighting::LightingCondition;
use atrium_worlds::World;
use rand::seq::index::sample;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The experiment's parameters; `Default` is the paper's setup at a reduced image size.
#[derive(Debug, Clone, PartialEq)]
pub struct LabExperiment {
    /// Training area (x0, y0, x1, y1), m.
    pub area: [f64; 4],
    pub grid_step: f64,
    pub rotation_step_deg: f64,
    pub stereo: StereoSpec,
    /// Training images used to compute the principal components (N) and their number (d).
    pub n_components_from: usize,
    pub d: usize,
    pub j_intensity: usize,
    pub j_each: usize,
    /// Test path (closed polyline) and spacing of the test positions along it, m.
    pub test_path: Vec<[f64; 2]>,
    pub test_spacing: f64,
    pub seed: u64,
    /// The light of the training images.
    pub training_lighting: LightingCondition,
    /// The lights of the test runs, in report order.
    pub test_lighting: Vec<LightingCondition>,
    /// §VI fusion weight of the disparity model, w_d (w_i = 1 − w_d).
    pub fusion_weight: f64,
    /// EM-PCA on this many training disparity maps rendered at the paper's full 160 × 120
    /// (D = 19200; 0 = skip): the iterations the paper's size needs (000 §VII).
    pub empca_full_maps: usize,
}

impl Default for LabExperiment {
    fn default() -> Self {
        let mut stereo = StereoSpec::paper("stereo");
        // 48 × 36 rather than 160 × 120: the image size is not what the experiment is
        // about, and 7,524 stereo pairs must render in seconds.
        stereo.camera.width = 48;
        stereo.camera.height = 36;
        stereo.max_disparity = 10;
        stereo.window_radius = 2;
        Self {
            area: [1.0, 1.0, 10.0, 6.0],
            grid_step: 0.5,
            rotation_step_deg: 10.0,
            stereo,
            n_components_from: 100,
            d: 20,
            j_intensity: 10,
            j_each: 5,
            test_path: vec![[1.8, 1.7], [8.7, 1.9], [8.9, 5.2], [2.1, 5.4]],
            test_spacing: 0.6,
            seed: 1,
            training_lighting: LightingCondition::Tube,
            test_lighting: LightingCondition::ALL.to_vec(),
            fusion_weight: 0.5,
            empca_full_maps: 100,
        }
    }
}

/// Mean and (population) variance of one error series.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MeanVar {
    pub mean: f64,
    pub variance: f64,
}

impl MeanVar {
    fn of(v: impl Iterator<Item = f64> + Clone) -> Self {
        let n = v.clone().count().max(1) as f64;
        let mean = v.clone().sum::<f64>() / n;
        let variance = v.map(|x| (x - mean).powi(2)).sum::<f64>() / n;
        Self { mean, variance }
    }
}

/// The sensor model's error over the test positions (000 §VII): e = min ‖r − n‖ with r in
/// (cm, cm, degrees), and the position (cm) and heading (degrees) errors of that n.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorStats {
    pub mean: f64,
    pub variance: f64,
    pub position_cm: MeanVar,
    pub heading_deg: MeanVar,
}

impl ErrorStats {
    fn of(e: &[(f64, f64, f64)]) -> Self {
        let all = MeanVar::of(e.iter().map(|v| v.0));
        Self {
            mean: all.mean,
            variance: all.variance,
            position_cm: MeanVar::of(e.iter().map(|v| v.1)),
            heading_deg: MeanVar::of(e.iter().map(|v| v.2)),
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConditionResult {
    pub lighting: String,
    pub test_positions: usize,
    pub intensity: ErrorStats,
    pub intensity_disparity: ErrorStats,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LabReport {
    pub training_images: usize,
    pub pixels: usize,
    pub disparity_missing: f64,
    pub disparity_within_1px: f64,
    pub empca_iterations: usize,
    pub empca_sigma2: f64,
    /// EM-PCA at the paper's size on real training disparity maps (`empca_full_maps`).
    pub empca_full: Option<EmPcaFull>,
    pub conditions: Vec<ConditionResult>,
}

/// EM-PCA on N training disparity maps at 160 × 120 (D = 19200).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EmPcaFull {
    pub n: usize,
    pub d: usize,
    pub dim: usize,
    pub missing: f64,
    pub iterations: usize,
    pub converged: bool,
    pub sigma2: f64,
}

struct Views {
    intensity: Vec<Vec<f32>>,
    disparity: Vec<Vec<f32>>,
    good: f64,
    missing: f64,
}

fn render_all(
    world: &World,
    scene: &Scene,
    spec: &StereoSpec,
    condition: LightingCondition,
    poses: &[Pose2],
    seed: u64,
) -> Result<Views, String> {
    let shader = Shader::new(world, scene, condition);
    StereoRig::new(spec.clone(), "stereo").map_err(|e| e.to_string())?;
    // Poses render in parallel chunks, each with its own rig (scratch buffers); every pose
    // has its own noise stream, so the images do not depend on the thread count.
    let frames: Vec<(Vec<f32>, Vec<f32>, f64, f64)> = poses
        .par_chunks(64)
        .enumerate()
        .flat_map_iter(|(c, chunk)| {
            let mut rig = StereoRig::new(spec.clone(), "stereo").expect("validated above");
            let shader = &shader;
            chunk
                .iter()
                .enumerate()
                .map(move |(k, p)| {
                    let i = c * 64 + k;
                    let mut rng = ChaCha8Rng::seed_from_u64(seed);
                    rng.set_stream(i as u64);
                    let f = rig.frame(scene, shader, &floor_pose(p), i as f64, &mut rng);
                    let (g, m) = disparity_quality(&f.disparity.disparity, &f.truth, 1.0);
                    (f.left, f.disparity.disparity, g, m)
                })
                .collect::<Vec<_>>()
        })
        .collect();
    let n = poses.len().max(1) as f64;
    let mut v = Views {
        intensity: Vec::with_capacity(poses.len()),
        disparity: Vec::with_capacity(poses.len()),
        good: 0.0,
        missing: 0.0,
    };
    for (l, d, g, m) in frames {
        v.good += g / n;
        v.missing += m / n;
        v.intensity.push(l);
        v.disparity.push(d);
    }
    Ok(v)
}

/// Points every `spacing` metres along the closed polyline, heading along the path.
fn path_poses(path: &[[f64; 2]], spacing: f64) -> Vec<Pose2> {
    let mut out = Vec::new();
    let mut carry = 0.0;
    for k in 0..path.len() {
        let a = path[k];
        let b = path[(k + 1) % path.len()];
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        let th = (b[1] - a[1]).atan2(b[0] - a[0]);
        let mut s = carry;
        while s < len {
            let t = s / len;
            out.push(Pose2::new(
                a[0] + t * (b[0] - a[0]),
                a[1] + t * (b[1] - a[1]),
                th,
            ));
            s += spacing;
        }
        carry = s - len;
    }
    out
}

pub fn run(world: &World, exp: &LabExperiment) -> Result<LabReport, String> {
    exp.stereo.validate("stereo").map_err(|e| e.to_string())?;
    let scene = Scene::new(world, 200.0).map_err(|e| e.to_string())?;
    let [x0, y0, x1, y1] = exp.area;
    let nx = ((x1 - x0) / exp.grid_step).round() as usize + 1;
    let ny = ((y1 - y0) / exp.grid_step).round() as usize + 1;
    let nr = (360.0 / exp.rotation_step_deg).round() as usize;
    let mut train = Vec::with_capacity(nx * ny * nr);
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nr {
                train.push(Pose2::new(
                    x0 + i as f64 * exp.grid_step,
                    y0 + j as f64 * exp.grid_step,
                    atrium_robots::normalize_angle((k as f64 * exp.rotation_step_deg).to_radians()),
                ));
            }
        }
    }
    let views = render_all(
        world,
        &scene,
        &exp.stereo,
        exp.training_lighting,
        &train,
        exp.seed,
    )?;

    // Principal components from N randomly chosen training images (000 §VII).
    let mut rng = ChaCha8Rng::seed_from_u64(exp.seed ^ 0xa11ce);
    let n = exp.n_components_from.min(train.len());
    let chosen = sample(&mut rng, train.len(), n).into_vec();
    let pick_i: Vec<&[f32]> = chosen
        .iter()
        .map(|&i| views.intensity[i].as_slice())
        .collect();
    let pick_d: Vec<&[f32]> = chosen
        .iter()
        .map(|&i| views.disparity[i].as_slice())
        .collect();
    let pca = Pca::fit(&pick_i, exp.d, PcaMethod::Snapshot).map_err(|e| e.to_string())?;
    let em = EmPca::fit(
        &pick_d,
        exp.d,
        EmPcaParams {
            seed: exp.seed,
            ..Default::default()
        },
    )
    .map_err(|e| e.to_string())?;

    let mut scratch = ProjectionScratch::new(exp.d);
    let mut project_d = |m: &[f32]| -> Vec<f64> {
        let mut y = vec![0.0; exp.d];
        // A map with nothing matched has no disparity features: it sits at the origin.
        if em.project_into(m, &mut scratch, &mut y).is_err() {
            y.fill(0.0);
        }
        y
    };
    let fi: Result<Vec<Vec<f64>>, _> = views.intensity.iter().map(|m| pca.project(m)).collect();
    let imap = AppearanceMap::new(train.clone(), fi.map_err(|e| e.to_string())?)
        .map_err(|e| e.to_string())?;
    let fd: Vec<Vec<f64>> = views.disparity.iter().map(|m| project_d(m)).collect();
    let dmap = AppearanceMap::new(train.clone(), fd).map_err(|e| e.to_string())?;

    let test = path_poses(&exp.test_path, exp.test_spacing);
    let mut conditions = Vec::new();
    for (c, &condition) in exp.test_lighting.iter().enumerate() {
        let tv = render_all(
            world,
            &scene,
            &exp.stereo,
            condition,
            &test,
            exp.seed + 100 + c as u64,
        )?;
        let (mut ei, mut ef) = (Vec::new(), Vec::new());
        let (mut ci, mut cd, mut cj): (Vec<Component>, Vec<Component>, Vec<Component>) =
            (Vec::new(), Vec::new(), Vec::new());
        for (k, r) in test.iter().enumerate() {
            let yi = pca.project(&tv.intensity[k]).map_err(|e| e.to_string())?;
            let yd = project_d(&tv.disparity[k]);
            imap.sensor_model(&yi, exp.j_intensity, &mut cj)
                .map_err(|e| e.to_string())?;
            ei.push(sensor_model_error(r, &cj).ok_or("empty sensor model")?);
            imap.sensor_model(&yi, exp.j_each, &mut ci)
                .map_err(|e| e.to_string())?;
            dmap.sensor_model(&yd, exp.j_each, &mut cd)
                .map_err(|e| e.to_string())?;
            let mut both = Vec::new();
            atrium_localization::appearance::fuse(&cd, &ci, exp.fusion_weight, &mut both)
                .map_err(|e| e.to_string())?;
            ef.push(sensor_model_error(r, &both).ok_or("empty sensor model")?);
        }
        conditions.push(ConditionResult {
            lighting: condition.name().into(),
            test_positions: test.len(),
            intensity: ErrorStats::of(&ei),
            intensity_disparity: ErrorStats::of(&ef),
        });
    }
    let empca_full = if exp.empca_full_maps > 0 {
        Some(empca_full_size(
            world,
            &scene,
            exp,
            &train,
            &chosen_full(exp, train.len()),
        )?)
    } else {
        None
    };
    Ok(LabReport {
        training_images: train.len(),
        pixels: exp.stereo.camera.width * exp.stereo.camera.height,
        disparity_missing: views.missing,
        disparity_within_1px: views.good,
        empca_iterations: em.iterations,
        empca_sigma2: em.sigma2,
        empca_full,
        conditions,
    })
}

/// The N training poses EM-PCA at full size uses (seeded, distinct from the N of the PCA).
fn chosen_full(exp: &LabExperiment, n_train: usize) -> Vec<usize> {
    let mut rng = ChaCha8Rng::seed_from_u64(exp.seed ^ 0xf011);
    sample(&mut rng, n_train, exp.empca_full_maps.min(n_train)).into_vec()
}

/// EM-PCA (000 §V) on training disparity maps rendered at the paper's 160 × 120 under the
/// training light: how many iterations the paper's size takes on real sparse maps.
fn empca_full_size(
    world: &World,
    scene: &Scene,
    exp: &LabExperiment,
    train: &[Pose2],
    chosen: &[usize],
) -> Result<EmPcaFull, String> {
    let spec = StereoSpec::paper("stereo");
    let poses: Vec<Pose2> = chosen.iter().map(|&i| train[i]).collect();
    let v = render_all(
        world,
        scene,
        &spec,
        exp.training_lighting,
        &poses,
        exp.seed ^ 0xf0,
    )?;
    let maps: Vec<&[f32]> = v.disparity.iter().map(|m| m.as_slice()).collect();
    let em = EmPca::fit(
        &maps,
        exp.d,
        EmPcaParams {
            seed: exp.seed,
            ..Default::default()
        },
    )
    .map_err(|e| e.to_string())?;
    Ok(EmPcaFull {
        n: maps.len(),
        d: exp.d,
        dim: spec.camera.width * spec.camera.height,
        missing: v.missing,
        iterations: em.iterations,
        converged: em.converged,
        sigma2: em.sigma2,
    })
}

/// `[appearance_experiment]` of a scenario: the setup of 000 §VII and the claims to check.
/// Every key has a default (the paper's setup at 48 × 36 images, see [`LabExperiment`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AppearanceSettings {
    /// Training area (x0, y0, x1, y1), m.
    pub area: [f64; 4],
    pub grid_step: f64,
    pub rotation_step_deg: f64,
    pub training_lighting: LightingCondition,
    pub test_lighting: Vec<LightingCondition>,
    /// Width and height of the experiment's stereo images.
    pub image: [usize; 2],
    pub max_disparity: usize,
    pub window_radius: usize,
    /// N: training images the principal components come from.
    pub components_from: usize,
    /// d: principal components.
    pub d: usize,
    /// J of the intensity-only model.
    pub j_intensity: usize,
    /// J of each model in the intensity + disparity fusion (J = j_each + j_each).
    pub j_each: usize,
    /// w_d of the §VI fusion.
    pub fusion_weight: f64,
    /// The test path (closed polyline); default: the scenario's start and route.
    pub test_path: Option<Vec<[f64; 2]>>,
    pub test_spacing: f64,
    /// N of the full-size (160 × 120) EM-PCA run; 0 skips it.
    pub empca_full_maps: usize,
    /// Seed of the experiment; default: the scenario's.
    pub seed: Option<u64>,
    /// Claim: under the training light the mean error e of both models is at most this
    /// (what the grid allows).
    pub training_error_max: Option<f64>,
    /// Claim: under these lights intensity + disparity has a lower mean and a lower variance
    /// of e than intensity alone.
    pub disparity_helps: Vec<LightingCondition>,
    /// Claim: at least this share of valid training disparities within 1 px of the truth.
    pub within_1px_min: Option<f64>,
    /// Claim: the training maps' missing fraction lies in [lo, hi].
    pub missing_range: Option<[f64; 2]>,
}

impl Default for AppearanceSettings {
    fn default() -> Self {
        let e = LabExperiment::default();
        Self {
            area: e.area,
            grid_step: e.grid_step,
            rotation_step_deg: e.rotation_step_deg,
            training_lighting: e.training_lighting,
            test_lighting: e.test_lighting,
            image: [e.stereo.camera.width, e.stereo.camera.height],
            max_disparity: e.stereo.max_disparity,
            window_radius: e.stereo.window_radius,
            components_from: e.n_components_from,
            d: e.d,
            j_intensity: e.j_intensity,
            j_each: e.j_each,
            fusion_weight: e.fusion_weight,
            test_path: None,
            test_spacing: e.test_spacing,
            empca_full_maps: e.empca_full_maps,
            seed: None,
            training_error_max: None,
            disparity_helps: Vec::new(),
            within_1px_min: None,
            missing_range: None,
        }
    }
}

impl AppearanceSettings {
    /// The experiment for `scenario` (its seed and, unless `test_path` is given, its start
    /// and route as the test path).
    pub fn experiment(&self, scenario: &Scenario) -> LabExperiment {
        let mut stereo = LabExperiment::default().stereo;
        stereo.camera.width = self.image[0];
        stereo.camera.height = self.image[1];
        stereo.max_disparity = self.max_disparity;
        stereo.window_radius = self.window_radius;
        let test_path = self.test_path.clone().unwrap_or_else(|| {
            let mut p = vec![[scenario.start.x, scenario.start.y]];
            p.extend(scenario.waypoints.iter().copied());
            p
        });
        LabExperiment {
            area: self.area,
            grid_step: self.grid_step,
            rotation_step_deg: self.rotation_step_deg,
            stereo,
            n_components_from: self.components_from,
            d: self.d,
            j_intensity: self.j_intensity,
            j_each: self.j_each,
            test_path,
            test_spacing: self.test_spacing,
            seed: self.seed.unwrap_or(scenario.seed),
            training_lighting: self.training_lighting,
            test_lighting: self.test_lighting.clone(),
            fusion_weight: self.fusion_weight,
            empca_full_maps: self.empca_full_maps,
        }
    }
}

/// Reads and checks `[appearance_experiment]`; errors name the file and the key.
pub fn parse_settings(
    file: &Path,
    table: &toml::Table,
) -> Result<AppearanceSettings, ScenarioError> {
    const T: &str = "appearance_experiment";
    let s: AppearanceSettings = toml::Value::Table(table.clone())
        .try_into()
        .map_err(|e: toml::de::Error| ScenarioError::field(file, T, e.message().to_string()))?;
    let bad = |k: &str, m: String| Err(ScenarioError::field(file, format!("{T}.{k}"), m));
    let [x0, y0, x1, y1] = s.area;
    if !(s.area.iter().all(|v| v.is_finite()) && x0 < x1 && y0 < y1) {
        return bad(
            "area",
            format!(
                "must be finite [x0, y0, x1, y1] with x0 < x1 and y0 < y1, got {:?}",
                s.area
            ),
        );
    }
    if !(s.grid_step.is_finite() && s.grid_step > 0.0) || (x1 - x0) / s.grid_step > 1000.0 {
        return bad(
            "grid_step",
            format!(
                "must be > 0 and give at most 1000 steps, got {}",
                s.grid_step
            ),
        );
    }
    if !(s.rotation_step_deg.is_finite()
        && s.rotation_step_deg >= 1.0
        && s.rotation_step_deg <= 360.0)
    {
        return bad(
            "rotation_step_deg",
            format!("must be in [1, 360], got {}", s.rotation_step_deg),
        );
    }
    if s.test_lighting.is_empty() {
        return bad(
            "test_lighting",
            "name at least one lighting condition".into(),
        );
    }
    if s.d == 0 || s.d >= s.components_from {
        return bad(
            "d",
            format!(
                "must satisfy 1 <= d < components_from ({}), got {}",
                s.components_from, s.d
            ),
        );
    }
    if s.j_intensity == 0 || s.j_each == 0 {
        return bad(
            "j_each",
            format!(
                "J must be at least 1 (j_intensity = {}, j_each = {})",
                s.j_intensity, s.j_each
            ),
        );
    }
    if !(s.fusion_weight.is_finite() && (0.0..=1.0).contains(&s.fusion_weight)) {
        return bad(
            "fusion_weight",
            format!("must be in [0, 1], got {}", s.fusion_weight),
        );
    }
    if !(s.test_spacing.is_finite() && s.test_spacing > 0.0) {
        return bad(
            "test_spacing",
            format!("must be finite and > 0, got {}", s.test_spacing),
        );
    }
    if let Some(p) = &s.test_path {
        if p.len() < 2 || !p.iter().flatten().all(|v| v.is_finite()) {
            return bad("test_path", "needs at least two finite points".into());
        }
    }
    if s.empca_full_maps != 0 && s.empca_full_maps <= s.d {
        return bad(
            "empca_full_maps",
            format!(
                "must be 0 or more than d ({}), got {}",
                s.d, s.empca_full_maps
            ),
        );
    }
    let mut stereo = LabExperiment::default().stereo;
    stereo.camera.width = s.image[0];
    stereo.camera.height = s.image[1];
    stereo.max_disparity = s.max_disparity;
    stereo.window_radius = s.window_radius;
    if let Err(atrium_sim::SimError::Config { field, msg }) = stereo.validate(T) {
        // The camera's width/height errors come back as `<T>.camera.width`: name `image`.
        let field = if field.contains(".camera.") {
            format!("{T}.image")
        } else {
            field
        };
        return Err(ScenarioError::field(file, field, msg));
    }
    for (k, v) in [
        ("training_error_max", s.training_error_max),
        ("within_1px_min", s.within_1px_min),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return bad(k, format!("must be a positive number, got {v}"));
            }
        }
    }
    if let Some([lo, hi]) = s.missing_range {
        if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi && hi <= 1.0) {
            return bad(
                "missing_range",
                format!("must be [lo, hi] within [0, 1], got [{lo}, {hi}]"),
            );
        }
    }
    for (i, c) in s.disparity_helps.iter().enumerate() {
        if !s.test_lighting.contains(c) {
            return bad(
                &format!("disparity_helps[{i}]"),
                format!("{:?} is not among test_lighting", c.name()),
            );
        }
    }
    Ok(s)
}

/// One claim of the experiment and whether it held.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AppearanceCheck {
    pub claim: String,
    pub passed: bool,
    pub detail: String,
}

/// `atrium appearance`: the report and the claims checked.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct AppearanceOutcome {
    pub scenario: String,
    pub image: [usize; 2],
    pub j_intensity: usize,
    pub j_each: usize,
    pub report: LabReport,
    pub checks: Vec<AppearanceCheck>,
}

impl AppearanceOutcome {
    pub fn passed(&self) -> bool {
        self.checks.iter().all(|c| c.passed)
    }

    /// The paper-style table (000 §VII, Fig. 4): mean and variance of the position and
    /// heading errors per lighting and feature set, then the checks.
    pub fn to_text(&self) -> String {
        use std::fmt::Write;
        let r = &self.report;
        let mut t = String::new();
        let _ = writeln!(
            t,
            "{}: {} training images ({} × {}), disparity {:.1} % missing, {:.1} % of valid within 1 px",
            self.scenario,
            r.training_images,
            self.image[0],
            self.image[1],
            100.0 * r.disparity_missing,
            100.0 * r.disparity_within_1px
        );
        let _ = writeln!(
            t,
            "EM-PCA on the {}-pixel maps: {} iterations, sigma2 {:.3e}",
            r.pixels, r.empca_iterations, r.empca_sigma2
        );
        if let Some(f) = &r.empca_full {
            let _ = writeln!(
                t,
                "EM-PCA at N = {}, d = {}, D = {}, {:.1} % missing: {} iterations{}, sigma2 {:.3e}",
                f.n,
                f.d,
                f.dim,
                100.0 * f.missing,
                f.iterations,
                if f.converged { "" } else { " (not converged)" },
                f.sigma2
            );
        }
        let _ = writeln!(
            t,
            "\n{:<9} {:<26} {:>9} {:>11} {:>11} {:>11} {:>10} {:>10}",
            "lighting",
            "features",
            "e mean",
            "e var",
            "pos mean cm",
            "pos var",
            "head mean°",
            "head var"
        );
        for c in &r.conditions {
            for (label, e) in [
                (
                    format!("intensity (J = {})", self.j_intensity),
                    &c.intensity,
                ),
                (
                    format!("intensity+disparity ({}+{})", self.j_each, self.j_each),
                    &c.intensity_disparity,
                ),
            ] {
                let _ = writeln!(
                    t,
                    "{:<9} {:<26} {:>9.1} {:>11.1} {:>11.1} {:>11.1} {:>10.1} {:>10.1}",
                    c.lighting,
                    label,
                    e.mean,
                    e.variance,
                    e.position_cm.mean,
                    e.position_cm.variance,
                    e.heading_deg.mean,
                    e.heading_deg.variance
                );
            }
        }
        if !self.checks.is_empty() {
            let _ = writeln!(t, "\nchecks:");
            for c in &self.checks {
                let _ = writeln!(
                    t,
                    "  [{}] {}: {}",
                    if c.passed { "ok" } else { "FAIL" },
                    c.claim,
                    c.detail
                );
            }
        }
        t
    }
}

/// Runs the scenario's `[appearance_experiment]` and checks its claims.
pub fn run_experiment(scenario: &Scenario) -> Result<AppearanceOutcome, ScenarioError> {
    let table = scenario.appearance_experiment.as_ref().ok_or_else(|| {
        ScenarioError::field(
            &scenario.file,
            "appearance_experiment",
            "the scenario has no [appearance_experiment] table",
        )
    })?;
    let settings = &parse_settings(&scenario.file, table)?;
    let exp = settings.experiment(scenario);
    let report = run(&scenario.world, &exp)
        .map_err(|e| ScenarioError::field(&scenario.file, "appearance_experiment", e))?;
    let mut checks = Vec::new();
    if let Some(max) = settings.training_error_max {
        if let Some(c) = report
            .conditions
            .iter()
            .find(|c| c.lighting == settings.training_lighting.name())
        {
            let (a, b) = (c.intensity.mean, c.intensity_disparity.mean);
            checks.push(AppearanceCheck {
                claim: format!("{}: mean error within what the grid allows", c.lighting),
                passed: a <= max && b <= max,
                detail: format!("intensity {a:.1}, intensity+disparity {b:.1} (max {max})"),
            });
        }
    }
    for l in &settings.disparity_helps {
        if let Some(c) = report.conditions.iter().find(|c| c.lighting == l.name()) {
            let (i, f) = (&c.intensity, &c.intensity_disparity);
            checks.push(AppearanceCheck {
                claim: format!("{}: disparity lowers the mean and variance of the error", c.lighting),
                passed: f.mean < i.mean && f.variance < i.variance,
                detail: format!(
                    "mean {:.1} vs {:.1}, variance {:.1} vs {:.1} (intensity+disparity vs intensity)",
                    f.mean, i.mean, f.variance, i.variance
                ),
            });
        }
    }
    if let Some(min) = settings.within_1px_min {
        checks.push(AppearanceCheck {
            claim: "valid training disparities within 1 px of the truth".into(),
            passed: report.disparity_within_1px >= min,
            detail: format!("{:.3} (min {min})", report.disparity_within_1px),
        });
    }
    if let Some([lo, hi]) = settings.missing_range {
        checks.push(AppearanceCheck {
            claim: "missing fraction of the training disparity maps".into(),
            passed: (lo..=hi).contains(&report.disparity_missing),
            detail: format!("{:.3} (range [{lo}, {hi}])", report.disparity_missing),
        });
    }
    Ok(AppearanceOutcome {
        scenario: scenario.name.clone(),
        image: settings.image,
        j_intensity: settings.j_intensity,
        j_each: settings.j_each,
        report,
        checks,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn path_poses_are_evenly_spaced() {
        let p = path_poses(&[[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [0.0, 1.0]], 0.5);
        assert_eq!(p.len(), 12);
        assert!(
            (p[4].x - 2.0).abs() < 1e-12
                && (p[4].theta - std::f64::consts::FRAC_PI_2).abs() < 1e-12
        );
    }
}
