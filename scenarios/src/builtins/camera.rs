//! The localizers of [001] on maps trained from the scenario's own
//! world and camera: `kind = "ceiling_mcl"` (ceiling-brightness MCL,
//! `atrium_localization::ceiling_mcl`) and `kind = "omni"` (MCL on the omnicam eigenimage
//! map, `atrium_localization::omni_mcl`). Like `kind = "appearance"`
//! (`appearance.rs`), the map is rendered at a grid of training poses under the
//! training light, once per process for equal inputs (`map_cache`) and once per set of
//! inputs across processes (`disk_cache`, kinds `omni_map` and `ceiling_map`): rendering the
//! omnicam panoramas and their eigenimages is most of `omni_lab`'s startup.
//!
//! ```toml
//! lighting = "bulb"
//! [sensors.ceiling]
//! kind = "ceiling"
//!
//! [[localizers]]
//! name = "ceiling"
//! kind = "ceiling_mcl"
//! sensor = "ceiling"           # a kind = "ceiling" camera; default: the first one
//! training = { area = [1.0, 1.0, 10.0, 6.0], step = 0.25 }   # rotation_step_deg unused
//! training_lighting = "bulb"   # the light of the map (default tube); the world must have
//!                              # lights of that kind, and they must make the ceiling vary
//! training_seed = 1            # image noise of the training renders (default 1)
//! particles = 20000            # ... and every other field of CeilingMclParams
//!
//! [sensors.omni]
//! kind = "omni"
//! width = 64
//!
//! [[localizers]]
//! name = "omni"
//! kind = "omni"
//! sensor = "omni"              # a kind = "omni" camera; default: the first one
//! training = { area = [1.0, 1.0, 10.0, 6.0], step = 0.5 }
//! training_lighting = "tube"
//! rotations = 32               # rotated copies per training panorama (001: 32); must
//!                              # divide the camera's width
//! d = 20                       # eigenimages kept
//! pca_locations = 10           # locations whose rotated panoramas give the eigenimages
//! training_seed = 1
//! particles = 2000             # ... and every other field of OmniMclParams
//! ```

use crate::builtins::appearance_filters::TrainingGrid;
use crate::builtins::camera_maps::{
    cached_ceiling_map, cached_omni_map, CeilingInputs, OmniInputs,
};
use crate::disk_cache::DiskCache;
use crate::error::ScenarioError;
use crate::scenario::{InitialBelief, LocalizerSpec, Scenario};
use atrium_localization::ceiling_mcl::{CeilingMcl, CeilingMclParams};
use atrium_localization::limits::{
    fmt_count, MAX_PCA_SAMPLES, OMNI_MAX_FEATURES, TRAINING_MAX_PIXELS,
};
use atrium_localization::mcl::InitialBelief as FilterBelief;
use atrium_localization::omni_map::OmniMapParams;
use atrium_localization::omni_mcl::{OmniMcl, OmniMclParams};
use atrium_localization::Localizer;
use atrium_worlds::lighting::LightingCondition;

/// A localizer table split into the keys read here (`own`) and the filter's parameters.
struct Table<'a> {
    scenario: &'a Scenario,
    field: String,
    own: toml::Table,
    params: toml::Table,
}

impl<'a> Table<'a> {
    fn new(spec: &LocalizerSpec, scenario: &'a Scenario, own_keys: &[&str]) -> Table<'a> {
        let mut params = spec.params.clone();
        let mut own = toml::Table::new();
        for k in own_keys {
            if let Some(v) = params.remove(*k) {
                own.insert(k.to_string(), v);
            }
        }
        Table {
            scenario,
            field: format!("localizers[{}]", spec.name),
            own,
            params,
        }
    }

    fn err(&self, key: &str, msg: impl Into<String>) -> ScenarioError {
        let f = if key.is_empty() {
            self.field.clone()
        } else {
            format!("{}.{key}", self.field)
        };
        ScenarioError::field(&self.scenario.file, f, msg)
    }

    /// The camera named `sensor`, or the first of `cams`, with its name (`name_of`); `what`
    /// names the camera kind for the messages.
    fn camera<C: Clone>(
        &self,
        cams: &[C],
        name_of: impl Fn(&C) -> &str,
        what: &str,
    ) -> Result<(String, C), ScenarioError> {
        let found = match self.own.get("sensor") {
            Some(v) => {
                let s = v
                    .as_str()
                    .ok_or_else(|| self.err("sensor", "must be a string"))?;
                cams.iter().find(|c| name_of(c) == s).ok_or_else(|| {
                    self.err(
                        "sensor",
                        format!("no camera with kind = \"{what}\" named {s:?} in [sensors]"),
                    )
                })
            }
            None => cams.first().ok_or_else(|| {
                self.err(
                    "kind",
                    format!("needs a camera: add a [sensors.<name>] table with kind = \"{what}\""),
                )
            }),
        }?;
        Ok((name_of(found).to_string(), found.clone()))
    }

    fn grid(&self) -> Result<TrainingGrid, ScenarioError> {
        let grid: TrainingGrid = self
            .own
            .get("training")
            .ok_or_else(|| {
                self.err(
                    "training",
                    "missing: give the training grid, e.g. { area = [x0, y0, x1, y1], step = 0.5 }",
                )
            })?
            .clone()
            .try_into()
            .map_err(|e: toml::de::Error| self.err("training", e.message()))?;
        grid.validate().map_err(|m| self.err("training", m))?;
        Ok(grid)
    }

    fn lighting(&self) -> Result<LightingCondition, ScenarioError> {
        match self.own.get("training_lighting") {
            None => Ok(LightingCondition::Tube),
            Some(v) => v
                .as_str()
                .and_then(LightingCondition::parse)
                .ok_or_else(|| {
                    self.err(
                        "training_lighting",
                        format!("must be \"tube\", \"bulb\" or \"natural\", got {v}"),
                    )
                }),
        }
    }

    fn int(&self, k: &str, default: usize) -> Result<usize, ScenarioError> {
        match self.own.get(k) {
            None => Ok(default),
            Some(v) => v
                .as_integer()
                .filter(|i| *i >= 0)
                .map(|i| i as usize)
                .ok_or_else(|| self.err(k, format!("must be a non-negative integer, got {v}"))),
        }
    }

    /// The filter's parameters from the remaining keys.
    fn params<P: serde::de::DeserializeOwned>(&self) -> Result<P, ScenarioError> {
        toml::Value::Table(self.params.clone())
            .try_into()
            .map_err(|e: toml::de::Error| self.err("", e.message()))
    }

    fn belief(&self) -> FilterBelief {
        match &self.scenario.initial_belief {
            InitialBelief::Tracking { sigma } => FilterBelief::Tracking {
                pose: self.scenario.start,
                sigma: *sigma,
            },
            InitialBelief::Global { polygons } => FilterBelief::Global {
                regions: polygons.clone(),
            },
        }
    }
}

/// `kind = "ceiling_mcl"`.
pub fn build_ceiling_mcl(
    spec: &LocalizerSpec,
    scenario: &Scenario,
    seed: u64,
) -> Result<Box<dyn Localizer>, ScenarioError> {
    let t = Table::new(
        spec,
        scenario,
        &["sensor", "training", "training_lighting", "training_seed"],
    );
    let (sensor, camera) = t.camera(&scenario.cameras.ceiling, |c| &c.name, "ceiling")?;
    let grid = t.grid()?;
    let lighting = t.lighting()?;
    let training_seed = t.int("training_seed", 1)? as u64;
    let mut params: CeilingMclParams = t.params()?;
    params.sensor = sensor.clone();
    params.validate().map_err(|m| {
        crate::builtins::param_errors::param_error(&scenario.file, &t.field, &params, &m)
    })?;
    // Without lights of the training kind the ceiling is dark everywhere: no map.
    let kind = lighting.lights();
    if !scenario
        .world
        .lighting
        .lights
        .iter()
        .any(|l| l.kind == kind)
    {
        return Err(t.err(
            "training_lighting",
            format!(
                "world {:?} has no {kind:?} lights: a ceiling map under {:?} light would be dark everywhere; add [[lights]] of that kind or choose another training_lighting",
                scenario.world.name,
                lighting.name()
            ),
        ));
    }
    let inputs = CeilingInputs {
        camera,
        grid,
        lighting,
        seed: training_seed,
    };
    let map = crate::map_cache::shared(inputs.memory_key(scenario), || {
        cached_ceiling_map(DiskCache::global().as_ref(), &inputs, scenario)
    })
    .map_err(|m| t.err("training", m))?;
    // One number per reading: a ceiling that hardly varies cannot tell places apart.
    let (lo, hi) = map.range();
    if hi - lo < 3.0 * params.sigma {
        return Err(t.err(
            "training_lighting",
            format!(
                "the ceiling under {:?} light varies by only {:.4} over the training area (less than 3 sigma = {:.4}): the lights do not make it informative",
                lighting.name(),
                hi - lo,
                3.0 * params.sigma
            ),
        ));
    }
    let f = CeilingMcl::new(&spec.name, params, map, &t.belief(), seed)
        .map_err(|e| t.err("", e.to_string()))?;
    Ok(Box::new(f))
}

/// `kind = "omni"`.
pub fn build_omni(
    spec: &LocalizerSpec,
    scenario: &Scenario,
    seed: u64,
) -> Result<Box<dyn Localizer>, ScenarioError> {
    let t = Table::new(
        spec,
        scenario,
        &[
            "sensor",
            "training",
            "training_lighting",
            "training_seed",
            "rotations",
            "d",
            "pca_locations",
        ],
    );
    let (sensor, camera) = t.camera(&scenario.cameras.omni, |c| &c.name, "omni")?;
    let grid = t.grid()?;
    let lighting = t.lighting()?;
    let defaults = OmniMapParams::default();
    let map_params = OmniMapParams {
        rotations: t.int("rotations", defaults.rotations)?,
        d: t.int("d", defaults.d)?,
        pca_locations: t.int("pca_locations", defaults.pca_locations)?,
        seed: t.int("training_seed", 1)? as u64,
    };
    let r = map_params.rotations;
    if r == 0 || !camera.width.is_multiple_of(r) {
        return Err(t.err(
            "rotations",
            format!(
                "{r} rotations must be >= 1 and divide the panorama width of sensors.{sensor} ({} columns): a rotation is a shift by width / rotations columns",
                camera.width
            ),
        ));
    }
    let (nx, ny) = grid.nodes();
    if nx < 2 || ny < 2 {
        return Err(t.err(
            "training",
            format!("the grid has {nx} × {ny} nodes: need at least 2 × 2 to interpolate"),
        ));
    }
    let n_images = map_params
        .pca_locations
        .clamp(1, nx.saturating_mul(ny))
        .saturating_mul(r);
    if n_images > MAX_PCA_SAMPLES {
        return Err(t.err(
            "pca_locations",
            format!(
                "{} locations × {r} rotations are {n_images} images for the eigenimages, more \
                 than the limit of {MAX_PCA_SAMPLES} (MAX_PCA_SAMPLES)",
                map_params.pca_locations.clamp(1, nx.saturating_mul(ny))
            ),
        ));
    }
    // The map's features and the training panoramas, before anything is rendered.
    let nodes = nx as f64 * ny as f64;
    let features = nodes * r as f64 * map_params.d as f64;
    if features > OMNI_MAX_FEATURES as f64 {
        return Err(t.err(
            "d",
            format!(
                "{nx} × {ny} nodes × {r} rotations × d = {} are {} features, more than the \
                 limit of {OMNI_MAX_FEATURES} (OMNI_MAX_FEATURES); lower d or rotations, or \
                 raise the training step",
                map_params.d,
                fmt_count(features)
            ),
        ));
    }
    let pixels = nodes * camera.width as f64 * camera.height as f64;
    if pixels > TRAINING_MAX_PIXELS as f64 {
        return Err(t.err(
            "training",
            format!(
                "{nx} × {ny} nodes × {} × {} pixels are {} values, more than the limit of \
                 {TRAINING_MAX_PIXELS} (TRAINING_MAX_PIXELS); raise the step or use a smaller \
                 camera",
                camera.width,
                camera.height,
                fmt_count(pixels)
            ),
        ));
    }
    if map_params.d == 0 || map_params.d >= n_images {
        return Err(t.err(
            "d",
            format!(
                "must be within [1, {n_images}) (pca_locations × rotations images give the eigenimages), got {}",
                map_params.d
            ),
        ));
    }
    let mut params: OmniMclParams = t.params()?;
    params.sensor = sensor.clone();
    params.validate().map_err(|m| {
        crate::builtins::param_errors::param_error(&scenario.file, &t.field, &params, &m)
    })?;
    let inputs = OmniInputs {
        camera,
        grid,
        lighting,
        params: map_params,
    };
    let map = crate::map_cache::shared(inputs.memory_key(scenario), || {
        cached_omni_map(DiskCache::global().as_ref(), &inputs, scenario)
    })
    .map_err(|m| t.err("training", m))?;
    let f = OmniMcl::new(&spec.name, params, map, &t.belief(), seed)
        .map_err(|e| t.err("", e.to_string()))?;
    Ok(Box::new(f))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A lab scenario with `sensors` and `table` as its localizer; building must fail.
    fn build_err(sensors: &str, kind: &str, table: &str) -> String {
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
name = "x"
kind = "{kind}"
{table}
"#
        );
        let file = crate::bundled_scenarios_dir().join("t.toml");
        let scenario = Scenario::from_toml_str(&text, &file).unwrap();
        let r = match kind {
            "ceiling_mcl" => build_ceiling_mcl(&scenario.localizers[0], &scenario, 1),
            _ => build_omni(&scenario.localizers[0], &scenario, 1),
        };
        match r {
            Ok(_) => panic!("expected an error for {table}"),
            Err(e) => e.to_string(),
        }
    }

    const CEILING: &str = "[sensors.ceiling]\nkind = \"ceiling\"";
    const OMNI: &str = "[sensors.omni]\nkind = \"omni\"\nwidth = 60\nheight = 4";
    const GRID: &str = "training = { area = [2.0, 2.0, 3.0, 3.0] }";

    #[test]
    fn bad_ceiling_tables_name_the_field() {
        let e = build_err("", "ceiling_mcl", GRID);
        assert!(
            e.contains("localizers[x].kind") && e.contains("kind = \"ceiling\""),
            "{e}"
        );
        let e = build_err(CEILING, "ceiling_mcl", &format!("sensor = \"up\"\n{GRID}"));
        assert!(
            e.contains("localizers[x].sensor") && e.contains("\"up\""),
            "{e}"
        );
        let e = build_err(CEILING, "ceiling_mcl", "");
        assert!(
            e.contains("localizers[x].training") && e.contains("missing"),
            "{e}"
        );
        let e = build_err(CEILING, "ceiling_mcl", &format!("particlez = 3\n{GRID}"));
        assert!(
            e.contains("localizers[x]") && e.contains("particlez"),
            "{e}"
        );
        let e = build_err(CEILING, "ceiling_mcl", &format!("sigma = -1.0\n{GRID}"));
        assert!(e.contains("sigma"), "{e}");
        // The lab has tubes and bulbs but its windows are lights too; a world without any
        // light of the training kind is refused before rendering.
        let mut s = Scenario::from_toml_str(
            &format!(
                "name = \"t\"\nworld = \"../worlds/lab.toml\"\nrobot = \"../robots/urdf/pioneer3dx.urdf\"\n\
                 duration_s = 5.0\n[start]\npose = [2.6, 2.2, 0.0]\n[route]\nwaypoints = [[3.0, 2.2]]\n\
                 {CEILING}\n[[localizers]]\nname = \"x\"\nkind = \"ceiling_mcl\"\ntraining_lighting = \"bulb\"\n{GRID}\n"
            ),
            &crate::bundled_scenarios_dir().join("t.toml"),
        )
        .unwrap();
        let lights = std::mem::take(&mut s.world.lighting.lights);
        let e = build_ceiling_mcl(&s.localizers[0], &s, 1)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("t.toml")
                && e.contains("localizers[x].training_lighting")
                && e.contains("no Bulb lights"),
            "{e}"
        );
        // One bulb far from a small training area lights its ceiling evenly: refused after
        // training, since one number per reading could not tell its places apart.
        s.world.lighting.lights = lights
            .into_iter()
            .filter(|l| l.kind == atrium_worlds::lighting::LightKind::Bulb)
            .take(1)
            .collect();
        s.localizers[0].params.insert(
            "training".into(),
            toml::Value::Table("area = [8.0, 5.0, 8.5, 5.5]".parse().unwrap()),
        );
        let e = build_ceiling_mcl(&s.localizers[0], &s, 1)
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.contains("localizers[x].training_lighting") && e.contains("varies by only"),
            "{e}"
        );
    }

    #[test]
    fn bad_omni_tables_name_the_field() {
        let e = build_err("", "omni", GRID);
        assert!(
            e.contains("localizers[x].kind") && e.contains("kind = \"omni\""),
            "{e}"
        );
        let e = build_err(OMNI, "omni", &format!("rotations = 32\n{GRID}"));
        assert!(
            e.contains("t.toml")
                && e.contains("localizers[x].rotations")
                && e.contains("divide")
                && e.contains("60 columns"),
            "{e}"
        );
        let e = build_err(OMNI, "omni", &format!("rotations = 12\nd = 500\n{GRID}"));
        assert!(e.contains("localizers[x].d"), "{e}");
        let e = build_err(
            OMNI,
            "omni",
            "rotations = 12\ntraining = { area = [2.0, 2.0, 2.0, 3.0] }",
        );
        assert!(
            e.contains("localizers[x].training") && e.contains("2 × 2"),
            "{e}"
        );
        let e = build_err(
            OMNI,
            "omni",
            &format!("rotations = 12\ninject = 2.0\n{GRID}"),
        );
        assert!(e.contains("localizers[x]") && e.contains("inject"), "{e}");
        let e = build_err(
            OMNI,
            "omni",
            &format!("rotations = 12\ntraining_lighting = \"disco\"\n{GRID}"),
        );
        assert!(e.contains("localizers[x].training_lighting"), "{e}");
    }

    #[test]
    fn omni_sizes_above_their_limits_are_refused_before_rendering() {
        let lab =
            "training = { area = [1.0, 1.0, 10.0, 6.0], step = 0.5, rotation_step_deg = 360 }";
        let e = build_err(
            OMNI,
            "omni",
            &format!("pca_locations = 100\nrotations = 60\n{lab}"),
        );
        assert!(
            e.contains("localizers[x].pca_locations: 100 locations × 60 rotations are 6000 images for the eigenimages, more than the limit of 2000 (MAX_PCA_SAMPLES)"),
            "{e}"
        );
        let fine =
            "training = { area = [1.0, 1.0, 10.0, 6.0], step = 0.05, rotation_step_deg = 360 }";
        let e = build_err(
            OMNI,
            "omni",
            &format!("rotations = 60\nd = 1000\npca_locations = 30\n{fine}"),
        );
        assert!(
            e.contains("localizers[x].d: 181 × 101 nodes × 60 rotations × d = 1000 are 1096860000 features, more than the limit of 50000000 (OMNI_MAX_FEATURES)"),
            "{e}"
        );
        let e = build_err(
            OMNI,
            "omni",
            &format!("rotations = 60\nparticles = 2000000\n{GRID}"),
        );
        assert!(
            e.contains("localizers[x].particles: 2000000 is more than the limit of 1000000 (MAX_PARTICLES)"),
            "{e}"
        );
    }
}
