//! `kind = "appearance"`: the auxiliary particle filter of [000] §VI
//! (`atrium_localization::appearance_apf`) on an appearance map trained from the scenario's
//! own world and camera, rendered at a grid of training poses under the training light.
//!
//! ```toml
//! [sensors.stereo]                 # the camera it uses (camera_sensors.rs)
//! kind = "stereo"
//! width = 48
//! height = 36
//!
//! [[localizers]]
//! name = "apf"
//! kind = "appearance"
//! sensor = "stereo"                # a [sensors.<name>] camera or stereo rig; default: the
//!                                  # first stereo rig, else the first camera
//! training = { area = [1.0, 1.0, 10.0, 6.0], step = 0.5, rotation_step_deg = 10.0 }
//! training_lighting = "tube"       # the light of the training images (default tube)
//! disparity = true                 # fuse disparity features (default: true for a rig)
//! d = 20                           # principal components (default 20)
//! pca_samples = 100                # N images they come from (default 100)
//! training_seed = 1                # image noise and the choice of the N (default 1)
//! particles = 500                  # ... and every other field of ApfParams
//! ```
//!
//! Training renders once per process for equal inputs (`map_cache`), so the trials of a
//! sweep share one map, and once per set of inputs across processes (`disk_cache`, kind
//! `appearance_model`): rendering and PCA are most of such a run's startup.

use crate::builtins::appearance_filters::{render_intensity, render_stereo, TrainingGrid};
use crate::disk_cache::{DiskCache, Reader, Writer};
use crate::error::ScenarioError;
use crate::scenario::{InitialBelief, LocalizerSpec, Scenario};
use atrium_localization::appearance::AppearanceMap;
use atrium_localization::appearance_apf::{
    ApfParams, AppearanceApf, AppearanceModel, AppearanceTraining, DisparityFeatures,
    IntensityFeatures,
};
use atrium_localization::em_pca::EmPca;
use atrium_localization::limits::{check_count, fmt_count, MAX_PCA_SAMPLES, TRAINING_MAX_PIXELS};
use atrium_localization::mcl::InitialBelief as FilterBelief;
use atrium_localization::pca::Pca;
use atrium_localization::Localizer;
use atrium_robots::Pose2;
use atrium_sim::camera::{CameraSpec, Shader};
use atrium_sim::stereo::StereoSpec;
use atrium_sim::Scene;
use atrium_worlds::lighting::LightingCondition;
use nalgebra::{DMatrix, DVector};

/// Keys of the table that are not `ApfParams` fields.
const OWN_KEYS: [&str; 7] = [
    "sensor",
    "training",
    "training_lighting",
    "disparity",
    "d",
    "pca_samples",
    "training_seed",
];

enum Source {
    Camera(CameraSpec),
    Stereo(StereoSpec),
}

/// Everything an appearance model is trained from besides the scenario's world.
struct ModelInputs {
    source: Source,
    grid: TrainingGrid,
    lighting: LightingCondition,
    training: AppearanceTraining,
    disparity: bool,
}

/// Part of the disk cache's key of appearance models: bump when training makes another model
/// from the same inputs (the executable's identity is in the key too).
const MODEL_VERSION: u32 = 1;

impl ModelInputs {
    /// The in-process key: the parsed world and every training input.
    fn memory_key(&self, scenario: &Scenario) -> String {
        format!(
            "appearance_model\n{}\n{}\n{:?}\n{:?}\n{}\n{}\n{:?}",
            serde_json::to_string(&scenario.world).unwrap_or_default(),
            self.lighting.name(),
            self.grid,
            self.training,
            match &self.source {
                Source::Stereo(s) => format!("{s:?}"),
                Source::Camera(c) => format!("{c:?}"),
            },
            self.disparity,
            scenario.physics_hz,
        )
    }

    /// The disk cache's key ([`crate::disk_cache::world_derived_key`]).
    fn disk_key(&self, scenario: &Scenario) -> Vec<u8> {
        let label = format!("appearance model {MODEL_VERSION}");
        crate::disk_cache::world_derived_key(&label, &self.memory_key(scenario), scenario)
    }

    /// Renders the training images and trains the model (000 §VII).
    fn train(&self, scenario: &Scenario) -> Result<AppearanceModel, String> {
        let scene = Scene::new(&scenario.world, scenario.physics_hz).map_err(|e| e.to_string())?;
        let shader = Shader::new(&scenario.world, &scene, self.lighting);
        let poses = self.grid.poses();
        let seed = self.training.seed;
        let (camera, left, disp) = match &self.source {
            Source::Stereo(s) => {
                let frames = render_stereo(&scene, &shader, s, &poses, seed)?;
                let (l, d): (Vec<_>, Vec<_>) = frames.into_iter().unzip();
                (&s.camera, l, Some(d))
            }
            Source::Camera(c) => (c, render_intensity(&scene, &shader, c, &poses, seed)?, None),
        };
        let lrefs: Vec<&[f32]> = left.iter().map(|v| v.as_slice()).collect();
        let drefs: Option<Vec<&[f32]>> = disp
            .as_ref()
            .filter(|_| self.disparity)
            .map(|d| d.iter().map(|v| v.as_slice()).collect());
        AppearanceModel::train(
            &poses,
            camera.width,
            camera.height,
            &lrefs,
            drefs.as_deref(),
            self.training,
        )
        .map_err(|e| e.to_string())
    }
}

/// The model of `inputs` from `cache` when it holds it (trained and stored otherwise);
/// trained when `cache` is `None`. A stored model is the trained one bit for bit.
fn cached_model(
    cache: Option<&DiskCache>,
    inputs: &ModelInputs,
    scenario: &Scenario,
) -> Result<AppearanceModel, String> {
    let Some(cache) = cache else {
        return inputs.train(scenario);
    };
    cache.get_or_build(
        "appearance_model",
        &inputs.disk_key(scenario),
        || inputs.train(scenario),
        model_to_bytes,
        model_from_bytes,
    )
}

/// A matrix's shape and column-major entries (also the omnicam map's eigenimages, `camera.rs`).
pub(super) fn write_matrix(w: &mut Writer, m: &DMatrix<f64>) {
    w.u64(m.nrows() as u64);
    w.u64(m.ncols() as u64);
    w.f64s(m.as_slice());
}

/// A matrix stored by [`write_matrix`]; `None` unless its entries fill its shape.
pub(super) fn read_matrix(r: &mut Reader) -> Option<DMatrix<f64>> {
    let rows = usize::try_from(r.u64()?).ok()?;
    let cols = usize::try_from(r.u64()?).ok()?;
    let data = r.f64s()?;
    (rows.checked_mul(cols)? == data.len()).then(|| DMatrix::from_vec(rows, cols, data))
}

fn write_map(w: &mut Writer, m: &AppearanceMap) {
    w.u64(m.len() as u64);
    for i in 0..m.len() {
        let p = m.pose(i);
        for v in [p.x, p.y, p.theta] {
            w.f64(v);
        }
    }
    w.u64(m.d() as u64);
    w.f64s(m.features());
}

fn read_map(r: &mut Reader) -> Option<AppearanceMap> {
    let n = r.len(24)?;
    let poses = (0..n)
        .map(|_| Some(Pose2::new(r.f64()?, r.f64()?, r.f64()?)))
        .collect::<Option<Vec<_>>>()?;
    let d = usize::try_from(r.u64()?).ok()?;
    let flat = r.f64s()?;
    if d == 0 || n.checked_mul(d)? != flat.len() {
        return None;
    }
    AppearanceMap::new(poses, flat.chunks(d).map(<[f64]>::to_vec).collect()).ok()
}

/// The disk cache's encoding of a model (every f64 bit for bit; C Cᵀ of EM-PCA is not
/// stored but recomputed exactly).
fn model_to_bytes(m: &AppearanceModel) -> Vec<u8> {
    let mut w = Writer::default();
    let i = &m.intensity;
    w.f64s(i.pca.mean.as_slice());
    write_matrix(&mut w, &i.pca.components);
    w.f64s(i.pca.eigenvalues.as_slice());
    write_map(&mut w, &i.map);
    w.u64(i.width as u64);
    w.u64(i.height as u64);
    match &m.disparity {
        None => w.u64(0),
        Some(d) => {
            w.u64(1);
            w.f64s(d.em.mean.as_slice());
            write_matrix(&mut w, &d.em.c);
            w.f64(d.em.sigma2);
            w.u64(d.em.iterations as u64);
            w.u64(u64::from(d.em.converged));
            w.f64s(&d.em.psi);
            w.f64(d.em.missing_fraction);
            write_map(&mut w, &d.map);
            w.u64(d.width as u64);
            w.u64(d.height as u64);
        }
    }
    w.0
}

/// A model stored by [`model_to_bytes`]; `None` for anything else, or parts that do not fit
/// together.
fn model_from_bytes(bytes: &[u8]) -> Option<AppearanceModel> {
    let mut r = Reader::new(bytes);
    let size = |r: &mut Reader| usize::try_from(r.u64()?).ok();
    let mean = DVector::from_vec(r.f64s()?);
    let components = read_matrix(&mut r)?;
    let eigenvalues = DVector::from_vec(r.f64s()?);
    let intensity = IntensityFeatures {
        pca: Pca::from_parts(mean, components, eigenvalues).ok()?,
        map: read_map(&mut r)?,
        width: size(&mut r)?,
        height: size(&mut r)?,
    };
    let disparity = match r.u64()? {
        0 => None,
        1 => {
            let mean = DVector::from_vec(r.f64s()?);
            let c = read_matrix(&mut r)?;
            let sigma2 = r.f64()?;
            let iterations = size(&mut r)?;
            let converged = match r.u64()? {
                0 => false,
                1 => true,
                _ => return None,
            };
            let psi = r.f64s()?;
            let missing = r.f64()?;
            let em =
                EmPca::from_parts(mean, c, sigma2, iterations, converged, psi, missing).ok()?;
            Some(DisparityFeatures {
                em,
                map: read_map(&mut r)?,
                width: size(&mut r)?,
                height: size(&mut r)?,
            })
        }
        _ => return None,
    };
    if !r.is_empty() {
        return None;
    }
    AppearanceModel::from_parts(intensity, disparity).ok()
}

pub fn build(
    spec: &LocalizerSpec,
    scenario: &Scenario,
    seed: u64,
) -> Result<Box<dyn Localizer>, ScenarioError> {
    let file = &scenario.file;
    let field = format!("localizers[{}]", spec.name);
    let err = |k: &str, msg: String| {
        let f = if k.is_empty() {
            field.clone()
        } else {
            format!("{field}.{k}")
        };
        ScenarioError::field(file, f, msg)
    };
    let mut table = spec.params.clone();
    let mut own = toml::Table::new();
    for k in OWN_KEYS {
        if let Some(v) = table.remove(k) {
            own.insert(k.to_string(), v);
        }
    }
    let cams = &scenario.cameras;
    let sensor = match own.get("sensor") {
        Some(v) => v
            .as_str()
            .ok_or_else(|| err("sensor", "must be a string".into()))?
            .to_string(),
        None => cams
            .stereo
            .first()
            .map(|s| s.stereo.camera.name.clone())
            .or_else(|| cams.cameras.first().map(|c| c.camera.name.clone()))
            .ok_or_else(|| {
                err(
                    "kind",
                    "appearance needs a camera: add a [sensors.<name>] table with kind = \"stereo\" or \"camera\"".into(),
                )
            })?,
    };
    let source = if let Some(s) = cams.stereo.iter().find(|s| s.stereo.camera.name == sensor) {
        Source::Stereo(s.stereo.clone())
    } else if let Some(c) = cams.cameras.iter().find(|c| c.camera.name == sensor) {
        Source::Camera(c.camera.clone())
    } else {
        return Err(err(
            "sensor",
            format!("no camera or stereo rig named {sensor:?} in [sensors]"),
        ));
    };
    let disparity = match own.get("disparity") {
        Some(v) => v
            .as_bool()
            .ok_or_else(|| err("disparity", "must be true or false".into()))?,
        None => matches!(source, Source::Stereo(_)),
    };
    if disparity && matches!(source, Source::Camera(_)) {
        return Err(err(
            "disparity",
            format!("sensor {sensor:?} is a camera, not a stereo rig: it has no disparity"),
        ));
    }
    let grid: TrainingGrid = own
        .get("training")
        .ok_or_else(|| {
            err(
                "training",
                "missing: give the training grid, e.g. { area = [x0, y0, x1, y1], step = 0.5, rotation_step_deg = 10 }".into(),
            )
        })?
        .clone()
        .try_into()
        .map_err(|e: toml::de::Error| err("training", e.message().to_string()))?;
    grid.validate().map_err(|m| err("training", m))?;
    let lighting = match own.get("training_lighting") {
        None => LightingCondition::Tube,
        Some(v) => v
            .as_str()
            .and_then(LightingCondition::parse)
            .ok_or_else(|| {
                err(
                    "training_lighting",
                    format!("must be \"tube\", \"bulb\" or \"natural\", got {v}"),
                )
            })?,
    };
    let int = |k: &str, default: usize| -> Result<usize, ScenarioError> {
        match own.get(k) {
            None => Ok(default),
            Some(v) => v
                .as_integer()
                .filter(|i| *i >= 0)
                .map(|i| i as usize)
                .ok_or_else(|| err(k, format!("must be a non-negative integer, got {v}"))),
        }
    };
    let training = AppearanceTraining {
        d: int("d", 20)?,
        pca_samples: int("pca_samples", 100)?,
        seed: int("training_seed", 1)? as u64,
    };
    // Sizes, before anything is rendered: the PCA's N and d, and every training image held.
    for (key, v) in [("pca_samples", training.pca_samples), ("d", training.d)] {
        check_count(key, v, MAX_PCA_SAMPLES, "MAX_PCA_SAMPLES").map_err(|m| {
            err(
                key,
                m.split_once(": ").map_or(m.clone(), |x| x.1.to_string()),
            )
        })?;
    }
    let (width, height) = match &source {
        Source::Stereo(s) => (s.camera.width, s.camera.height),
        Source::Camera(c) => (c.width, c.height),
    };
    let images = if disparity { 2.0 } else { 1.0 };
    let pixels = grid.pose_count() as f64 * width as f64 * height as f64 * images;
    if pixels > TRAINING_MAX_PIXELS as f64 {
        return Err(err(
            "training",
            format!(
                "{} training poses × {width} × {height} pixels{} are {} values, more than the \
                 limit of {TRAINING_MAX_PIXELS} (TRAINING_MAX_PIXELS); raise step or \
                 rotation_step_deg, or use a smaller camera",
                grid.pose_count(),
                if disparity { " × 2 (disparity)" } else { "" },
                fmt_count(pixels)
            ),
        ));
    }
    let mut params: ApfParams = toml::Value::Table(table)
        .try_into()
        .map_err(|e: toml::de::Error| err("", e.message().to_string()))?;
    params.intensity_sensor = Some(sensor.clone());
    params.disparity_sensor = Some(sensor.clone());
    params
        .validate()
        .map_err(|m| crate::builtins::param_errors::param_error(file, &field, &params, &m))?;

    let inputs = ModelInputs {
        source,
        grid,
        lighting,
        training,
        disparity,
    };
    let key = inputs.memory_key(scenario);
    let model = crate::map_cache::shared(key, || {
        cached_model(DiskCache::global().as_ref(), &inputs, scenario)
    })
    .map_err(|m| err("training", m))?;
    let init = match &scenario.initial_belief {
        InitialBelief::Tracking { sigma } => FilterBelief::Tracking {
            pose: scenario.start,
            sigma: *sigma,
        },
        InitialBelief::Global { polygons } => FilterBelief::Global {
            regions: polygons.clone(),
        },
    };
    let apf = AppearanceApf::new(&spec.name, params, model, &init, seed)
        .map_err(|e| err("", e.to_string()))?;
    Ok(Box::new(apf))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bundled scenario's text with `apf_table` as its first localizer and `sensors` as
    /// its camera tables; building fails before any rendering.
    fn build_err(sensors: &str, apf_table: &str) -> String {
        let text = format!(
            r#"
name = "t"
world = "../worlds/lab.toml"
robot = "../robots/urdf/pioneer3dx.urdf"
duration_s = 5.0
[start]
pose = [2.6, 2.2, 0.0]
[route]
waypoints = [[3.0, 2.2]]
{sensors}
[[localizers]]
name = "apf"
kind = "appearance"
{apf_table}
"#
        );
        let file = crate::bundled_scenarios_dir().join("t.toml");
        let scenario = Scenario::from_toml_str(&text, &file).unwrap();
        match build(&scenario.localizers[0], &scenario, 1) {
            Ok(_) => panic!("expected an error for {apf_table}"),
            Err(e) => e.to_string(),
        }
    }

    const STEREO: &str = "[sensors.stereo]\nkind = \"stereo\"\nwidth = 48\nheight = 36\nmax_disparity = 10\nwindow_radius = 2";
    const CAMERA: &str = "[sensors.front]\nkind = \"camera\"\nwidth = 48\nheight = 36";
    const GRID: &str = "training = { area = [2.5, 2.0, 3.5, 3.0] }";

    #[test]
    fn bad_tables_name_the_field() {
        let e = build_err("", GRID);
        assert!(
            e.contains("localizers[apf].kind") && e.contains("needs a camera"),
            "{e}"
        );
        let e = build_err(STEREO, &format!("sensor = \"left\"\n{GRID}"));
        assert!(
            e.contains("localizers[apf].sensor") && e.contains("\"left\""),
            "{e}"
        );
        let e = build_err(STEREO, "");
        assert!(
            e.contains("localizers[apf].training") && e.contains("missing"),
            "{e}"
        );
        let e = build_err(STEREO, "training = { area = [3.0, 2.0, 2.0, 3.0] }");
        assert!(
            e.contains("localizers[apf].training") && e.contains("x1 >= x0"),
            "{e}"
        );
        let e = build_err(CAMERA, &format!("disparity = true\n{GRID}"));
        assert!(
            e.contains("localizers[apf].disparity") && e.contains("not a stereo rig"),
            "{e}"
        );
        let e = build_err(STEREO, &format!("particlez = 3\n{GRID}"));
        assert!(
            e.contains("localizers[apf]") && e.contains("particlez"),
            "{e}"
        );
        let e = build_err(STEREO, &format!("w_d = 1.5\n{GRID}"));
        assert!(e.contains("w_d"), "{e}");
        let e = build_err(STEREO, &format!("training_lighting = \"disco\"\n{GRID}"));
        assert!(e.contains("localizers[apf].training_lighting"), "{e}");
        let e = build_err(STEREO, &format!("d = 200\n{GRID}"));
        assert!(
            e.contains("localizers[apf].training") && e.contains("d < N"),
            "{e}"
        );
    }

    #[test]
    fn training_sizes_above_their_limits_are_refused_before_rendering() {
        let e = build_err(STEREO, &format!("pca_samples = 2001\n{GRID}"));
        assert!(
            e.contains("localizers[apf].pca_samples: 2001 is more than the limit of 2000 (MAX_PCA_SAMPLES)"),
            "{e}"
        );
        let e = build_err(STEREO, &format!("d = 1000000000000\n{GRID}"));
        assert!(
            e.contains("localizers[apf].d: 1000000000000 is more than the limit"),
            "{e}"
        );
        // 9 × 5 m at 2 cm and 10°: 451 × 251 nodes × 36 rotations.
        let e = build_err(
            STEREO,
            "training = { area = [1.0, 1.0, 10.0, 6.0], step = 0.02 }",
        );
        assert!(
            e.contains("localizers[apf].training: step 0.02 m and rotation_step_deg 10 over the 9 m × 5 m area give 4075236 training poses, more than the limit of 200000 (TRAINING_MAX_POSES)"),
            "{e}"
        );
        // 91 × 51 nodes × 25 rotations = 116,025 poses (within the limit) of 48 × 36 stereo
        // pairs: 4e8 values.
        let e = build_err(
            STEREO,
            "training = { area = [1.0, 1.0, 10.0, 6.0], step = 0.1, rotation_step_deg = 14.4 }",
        );
        assert!(
            e.contains(
                "localizers[apf].training: 116025 training poses × 48 × 36 pixels × 2 (disparity)"
            ) && e.contains("more than the limit of 250000000 (TRAINING_MAX_PIXELS)"),
            "{e}"
        );
        let e = build_err(STEREO, &format!("particles = 300000\n{GRID}"));
        assert!(
            e.contains("localizers[apf].particles: 300000 is more than the limit of 200000 (APF_MAX_PARTICLES)"),
            "{e}"
        );
    }

    /// The lab with the small stereo head, and a small training set: 9 nodes × 4 headings.
    fn small_inputs() -> (Scenario, ModelInputs) {
        let text = format!(
            "name = \"t\"\nworld = \"../worlds/lab.toml\"\n\
             robot = \"../robots/urdf/pioneer3dx.urdf\"\nduration_s = 5.0\n\
             [start]\npose = [2.6, 2.2, 0.0]\n[route]\nwaypoints = [[3.0, 2.2]]\n{STEREO}\n\
             [[localizers]]\nname = \"odometry\"\nkind = \"dead_reckoning\"\n"
        );
        let file = crate::bundled_scenarios_dir().join("t.toml");
        let scenario = Scenario::from_toml_str(&text, &file).unwrap();
        let inputs = ModelInputs {
            source: Source::Stereo(scenario.cameras.stereo[0].stereo.clone()),
            grid: TrainingGrid {
                area: [2.5, 2.0, 3.5, 3.0],
                step: 0.5,
                rotation_step_deg: 90.0,
            },
            lighting: LightingCondition::Tube,
            training: AppearanceTraining {
                d: 5,
                pca_samples: 20,
                seed: 1,
            },
            disparity: true,
        };
        (scenario, inputs)
    }

    #[test]
    fn appearance_models_from_the_disk_cache_are_the_trained_ones() {
        let (scenario, inputs) = small_inputs();
        let dir = std::env::temp_dir().join(format!(
            "atrium-appearance-cache-{}-{}",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos())
        ));
        let cache = DiskCache::at(&dir);
        let trained = inputs.train(&scenario).unwrap();
        assert!(trained.disparity.is_some());
        let bytes = model_to_bytes(&trained);
        let first = cached_model(Some(&cache), &inputs, &scenario).unwrap();
        let key = inputs.disk_key(&scenario);
        let entry = cache.entry_path("appearance_model", &key);
        assert!(entry.is_file(), "the first build stores its model");
        let second = cached_model(Some(&cache), &inputs, &scenario).unwrap();
        // Bit for bit: every matrix, eigenvalue and feature (and EM-PCA's C Cᵀ, recomputed).
        assert_eq!(model_to_bytes(&first), bytes);
        assert_eq!(model_to_bytes(&second), bytes);
        assert_eq!(second, trained);

        // The second build reads the entry: another model stored under the key comes back.
        let other = AppearanceModel::from_parts(trained.intensity.clone(), None).unwrap();
        cache
            .put("appearance_model", &key, &model_to_bytes(&other))
            .unwrap();
        let read = cached_model(Some(&cache), &inputs, &scenario).unwrap();
        assert!(read.disparity.is_none());

        // A truncated, flipped or empty entry, or a payload whose parts do not fit: retrained.
        let mut misfit = Writer::default();
        misfit.bytes(&bytes);
        let mut short = bytes.clone();
        short.truncate(bytes.len() - 8);
        let mut wider = trained.clone();
        wider.intensity.width += 1;
        for bad in [short, misfit.0, model_to_bytes(&wider), Vec::new()] {
            cache.put("appearance_model", &key, &bad).unwrap();
            let m = cached_model(Some(&cache), &inputs, &scenario).unwrap();
            assert_eq!(model_to_bytes(&m), bytes);
        }
        let whole = std::fs::read(&entry).unwrap();
        let mut flipped = whole.clone();
        flipped[whole.len() - 100] ^= 0x04;
        for bad in [whole[..whole.len() / 2].to_vec(), flipped] {
            std::fs::write(&entry, &bad).unwrap();
            let m = cached_model(Some(&cache), &inputs, &scenario).unwrap();
            assert_eq!(model_to_bytes(&m), bytes);
            assert_eq!(std::fs::read(&entry).unwrap(), whole, "rewritten whole");
        }

        // Any other training input is another key.
        let variants: [fn(&mut ModelInputs); 6] = [
            |i| i.training.d = 6,
            |i| i.training.seed = 2,
            |i| i.training.pca_samples = 21,
            |i| i.grid.step = 0.25,
            |i| i.lighting = LightingCondition::Bulb,
            |i| i.disparity = false,
        ];
        for change in variants {
            let (_, mut changed) = small_inputs();
            change(&mut changed);
            let path = cache.entry_path("appearance_model", &changed.disk_key(&scenario));
            assert_ne!(path, entry);
        }
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
