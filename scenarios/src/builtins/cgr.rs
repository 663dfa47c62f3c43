//! Building the CGR localizers (`kind = "cgr_laser"` and `kind = "cgr_depth"`, see
//! `atrium_localization::cgr`) from a scenario's `[[localizers]]` table. Parameters are the
//! fields of `CgrParams`; FSPF's are an inline table, e.g. `fspf = { eta = 15 }`.

use crate::builtins::param_errors::{localization_error, param_error};
use crate::error::ScenarioError;
use crate::maps::SharedMaps;
use crate::scenario::{InitialBelief, LocalizerSpec, Scenario};
use atrium_localization::{Cgr, CgrParams, Localizer};

/// Keys that only a depth CGR reads.
const DEPTH_ONLY: [&str; 3] = ["fspf", "max_normal_z", "normal_tolerance_deg"];

pub fn build(
    spec: &LocalizerSpec,
    scenario: &Scenario,
    maps: &mut SharedMaps,
    seed: u64,
) -> Result<Box<dyn Localizer>, ScenarioError> {
    let file = &scenario.file;
    let field = format!("localizers[{}]", spec.name);
    let depth = spec.kind == "cgr_depth";
    if !depth {
        if let Some(k) = DEPTH_ONLY.iter().find(|k| spec.params.contains_key(**k)) {
            return Err(ScenarioError::field(
                file,
                format!("{field}.{k}"),
                "only a cgr_depth localizer takes this key",
            ));
        }
    }
    let params: CgrParams =
        toml::Value::Table(spec.params.clone())
            .try_into()
            .map_err(|e: toml::de::Error| {
                ScenarioError::field(file, &field, e.message().to_string())
            })?;
    params
        .validate()
        .map_err(|msg| param_error(file, &field, &params, &msg))?;
    let sigma = match &scenario.initial_belief {
        InitialBelief::Tracking { sigma } => *sigma,
        InitialBelief::Global { .. } => {
            return Err(ScenarioError::field(
                file,
                format!("{field}.kind"),
                format!(
                    "{} tracks from a known start only: use [initial_belief] mode = \"tracking\"",
                    spec.kind
                ),
            ))
        }
    };
    if depth {
        if scenario.depth_cameras.is_empty() {
            return Err(ScenarioError::field(
                file,
                format!("{field}.kind"),
                "cgr_depth needs a depth camera: add a [depth_cameras.<name>] table \
                 (e.g. preset = \"kinect\", mount = \"camera\")",
            ));
        }
        for cam in &scenario.depth_cameras {
            params
                .fspf
                .validate_for_image(cam.image_width(), cam.image_height())
                .map_err(|msg| {
                    ScenarioError::field(
                        file,
                        format!("{field}.fspf"),
                        format!("{msg} (depth camera {:?})", cam.name),
                    )
                })?;
        }
    } else if scenario.lasers.is_empty() {
        return Err(ScenarioError::field(
            file,
            format!("{field}.kind"),
            "cgr_laser needs a laser: the robot's sensor file or [sensors.<name>] must give one",
        ));
    }
    let map = maps.vector_map(scenario);
    let build = if depth { Cgr::depth } else { Cgr::laser };
    let cgr = build(&spec.name, params.clone(), map, scenario.start, sigma, seed)
        .map_err(|e| localization_error(file, &field, &params, e))?;
    Ok(Box::new(cgr))
}
