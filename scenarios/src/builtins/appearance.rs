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
//! sweep share one map.

use crate::builtins::appearance_filters::{render_intensity, render_stereo, TrainingGrid};
use crate::error::ScenarioError;
use crate::scenario::{InitialBelief, LocalizerSpec, Scenario};
use atrium_localization::appearance_apf::{
    ApfParams, AppearanceApf, AppearanceModel, AppearanceTraining,
};
use atrium_localization::limits::{check_count, fmt_count, MAX_PCA_SAMPLES, TRAINING_MAX_PIXELS};
use atrium_localization::mcl::InitialBelief as FilterBelief;
use atrium_localization::Localizer;
use atrium_sim::camera::{CameraSpec, Shader};
use atrium_sim::stereo::StereoSpec;
use atrium_sim::Scene;
use atrium_worlds::lighting::LightingCondition;

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
        .map_err(|m| crate::builtins::param_error(file, &field, &params, &m))?;

    let key = format!(
        "appearance_model\n{}\n{}\n{:?}\n{:?}\n{}\n{disparity}\n{:?}",
        serde_json::to_string(&scenario.world).unwrap_or_default(),
        lighting.name(),
        grid,
        training,
        match &source {
            Source::Stereo(s) => format!("{s:?}"),
            Source::Camera(c) => format!("{c:?}"),
        },
        scenario.physics_hz,
    );
    let model = crate::map_cache::shared(key, || -> Result<AppearanceModel, String> {
        let scene = Scene::new(&scenario.world, scenario.physics_hz).map_err(|e| e.to_string())?;
        let shader = Shader::new(&scenario.world, &scene, lighting);
        let poses = grid.poses();
        let (camera, left, disp) = match &source {
            Source::Stereo(s) => {
                let frames = render_stereo(&scene, &shader, s, &poses, training.seed)?;
                let (l, d): (Vec<_>, Vec<_>) = frames.into_iter().unzip();
                (&s.camera, l, Some(d))
            }
            Source::Camera(c) => (
                c,
                render_intensity(&scene, &shader, c, &poses, training.seed)?,
                None,
            ),
        };
        let lrefs: Vec<&[f32]> = left.iter().map(|v| v.as_slice()).collect();
        let drefs: Option<Vec<&[f32]>> = disp
            .as_ref()
            .filter(|_| disparity)
            .map(|d| d.iter().map(|v| v.as_slice()).collect());
        AppearanceModel::train(
            &poses,
            camera.width,
            camera.height,
            &lrefs,
            drefs.as_deref(),
            training,
        )
        .map_err(|e| e.to_string())
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
}
