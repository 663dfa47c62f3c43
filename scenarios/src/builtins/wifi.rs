//! Where a scenario's WiFi localizer (`kind = "wifi"`) gets its graph. Exactly one of:
//!
//! - `training = "wifi_survey.toml"`: a logging scenario, run first. Its robot drives its
//!   route (not from chosen spots) and every WiFi scan is logged with the ground-truth pose
//!   of that instant ([004] §2.3: "examples are first collected across the
//!   map while driving the robot around"); the graph is then learnt from those pairs. The
//!   survey is deterministic (its own seed, its own scan-noise stream; the shadow field is the
//!   world's), so the graph is a pure function of the survey file, its world and robot, and
//!   the `learn` parameters. Within one process the result is memoised under exactly that
//!   input (the full texts, not a hash), so scenarios sharing a survey learn it once, and
//!   across processes on disk (`crate::disk_cache`); a cache hit returns what a
//!   recomputation would, so no result depends on the cache.
//! - `graph = "campus_wifi.json"`: a graph saved by `atrium wifi-graph` (or
//!   [`atrium_localization::wifi_graph::WifiGraph::save`]).
//!
//! Optional `[localizers.learn]` sets [`WifiGraphParams`]; every other key is a
//! [`WifiMclParams`] field. Paths are relative to the scenario file.

use crate::builtins::param_errors::{localization_error, param_error};
use crate::error::ScenarioError;
use crate::scenario::{InitialBelief, LocalizerSpec, Scenario};
use crate::seeds::derive_seed;
use atrium_localization::mcl::InitialBelief as MclBelief;
use atrium_localization::wifi_graph::{WifiGraph, WifiGraphParams};
use atrium_localization::wifi_mcl::{WifiMcl, WifiMclParams};
use atrium_localization::Localizer;
use atrium_robots::{Pose2, Reading, WifiScan};
use atrium_sim::Simulation;
use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

type Slot = Arc<OnceLock<Result<Arc<WifiGraph>, String>>>;

/// Part of the disk cache's key of a learnt graph: bump when the survey or the learning
/// changes what it makes from the same inputs (the executable's identity is in the key too).
const WIFI_GRAPH_VERSION: u32 = 1;

fn cache() -> &'static Mutex<HashMap<String, Slot>> {
    static CACHE: OnceLock<Mutex<HashMap<String, Slot>>> = OnceLock::new();
    CACHE.get_or_init(|| Mutex::new(HashMap::new()))
}

/// Runs a logging scenario and returns its (ground-truth position, scan) pairs. Errors name
/// the survey file.
pub fn survey(survey: &Scenario) -> Result<Vec<(Pose2, WifiScan)>, ScenarioError> {
    let file = &survey.file;
    if survey.wifi.is_none() {
        return Err(ScenarioError::field(
            file,
            "wifi",
            "a WiFi survey needs a WiFi scanner: the robot's sensor file has no [wifi] and \
             the scenario adds none",
        ));
    }
    if survey.world.access_points.is_empty() {
        return Err(ScenarioError::field(
            file,
            "world",
            format!("world {:?} has no [[access_points]]", survey.world.name),
        ));
    }
    let mut config = survey.sim_config(derive_seed(survey.seed, "sim"));
    // The survey logs WiFi only; the lasers would cost time and change nothing here (each
    // sensor draws from its own stream).
    config.lasers.clear();
    let mut sim = Simulation::new(&survey.world, &survey.robot, config)
        .map_err(|e| ScenarioError::field(file, "start.pose", e.to_string()))?;
    sim.set_route(&survey.waypoints);
    let dt = 1.0 / survey.physics_hz;
    let mut out = Vec::new();
    let mut samples = Vec::new();
    let mut finished: Option<f64> = None;
    while sim.time() < survey.duration_s - 0.5 * dt {
        if let Some(t) = finished {
            if sim.time() >= t + survey.settle_s {
                break;
            }
        }
        out.clear();
        let truth = sim.step(&mut out);
        for r in out.drain(..) {
            if let Reading::Wifi(scan) = r {
                samples.push((truth, scan));
            }
        }
        if finished.is_none() && sim.route_finished() {
            finished = Some(sim.time());
        }
    }
    Ok(samples)
}

/// Learns the graph of a survey scenario over its world's bounds.
pub fn learn_from_survey(
    survey_scenario: &Scenario,
    params: &WifiGraphParams,
) -> Result<WifiGraph, ScenarioError> {
    let samples = survey(survey_scenario)?;
    let pairs: Vec<([f64; 2], &WifiScan)> = samples.iter().map(|(p, s)| ([p.x, p.y], s)).collect();
    let (lo, hi) = survey_scenario.world.bounds();
    let world = &survey_scenario.world;
    WifiGraph::learn(&pairs, lo, hi, params, &|p| world.is_free(p, 0.0))
        .map_err(|e| ScenarioError::field(&survey_scenario.file, "wifi", e.to_string()))
}

/// The graph learnt from the survey scenario at `path`, on `owner`'s generated world when the
/// survey drives the same generator file ([`Scenario::load_training`]).
fn graph_from_training(
    owner: &Scenario,
    path: &Path,
    params: &WifiGraphParams,
    field: &str,
) -> Result<Arc<WifiGraph>, ScenarioError> {
    let file = &owner.file;
    let survey_scenario = owner.load_training(path)?;
    // The graph's size, from the survey world's bounds and access points, before the survey.
    let (lo, hi) = survey_scenario.world.bounds();
    params
        .check_graph_size(lo, hi, survey_scenario.world.access_points.len())
        .map_err(|msg| {
            crate::builtins::param_errors::param_error(
                file,
                &format!("{field}.learn"),
                params,
                &msg,
            )
        })?;
    let key = format!(
        "{}\n{}\n{:?}\n{:?}\n{:?}",
        survey_scenario.text,
        serde_json::to_string(&survey_scenario.world).unwrap_or_default(),
        survey_scenario.robot,
        survey_scenario.wifi,
        params
    );
    let slot = {
        let mut map = cache().lock().unwrap_or_else(|p| p.into_inner());
        map.entry(key).or_default().clone()
    };
    // Outside the map's lock: a second scenario asking for the same survey waits here for
    // the first to finish, others proceed.
    let result = slot.get_or_init(|| {
        // Then on disk (`disk_cache`), under every input of the survey and the parameters.
        let mut disk_key = format!("wifi graph {WIFI_GRAPH_VERSION}\n{params:?}\n").into_bytes();
        disk_key.extend(crate::disk_cache::scenario_inputs(&survey_scenario));
        crate::disk_cache::cached(
            "wifi_graph",
            &disk_key,
            || learn_from_survey(&survey_scenario, params),
            WifiGraph::to_bytes,
            WifiGraph::from_bytes,
        )
        .map(Arc::new)
        .map_err(|e| e.to_string())
    });
    result
        .clone()
        .map_err(|msg| ScenarioError::field(file, format!("{field}.training"), msg))
}

fn string_param(
    params: &mut toml::Table,
    key: &str,
    file: &Path,
    field: &str,
) -> Result<Option<String>, ScenarioError> {
    match params.remove(key) {
        None => Ok(None),
        Some(toml::Value::String(s)) if !s.trim().is_empty() => Ok(Some(s)),
        Some(_) => Err(ScenarioError::field(
            file,
            format!("{field}.{key}"),
            "must be a non-empty string (a path relative to the scenario file)",
        )),
    }
}

/// Builds `kind = "wifi"`.
pub fn build_wifi_localizer(
    spec: &LocalizerSpec,
    scenario: &Scenario,
    grid: &atrium_worlds::OccupancyGrid,
    seed: u64,
) -> Result<Box<dyn Localizer>, ScenarioError> {
    let file = &scenario.file;
    let field = format!("localizers[{}]", spec.name);
    let mut params = spec.params.clone();
    let training = string_param(&mut params, "training", file, &field)?;
    let graph_file = string_param(&mut params, "graph", file, &field)?;
    let learn: WifiGraphParams = match params.remove("learn") {
        None => WifiGraphParams::default(),
        Some(v) => v.try_into().map_err(|e: toml::de::Error| {
            ScenarioError::field(file, format!("{field}.learn"), e.message().to_string())
        })?,
    };
    learn
        .validate()
        .map_err(|msg| param_error(file, &format!("{field}.learn"), &learn, &msg))?;
    let mcl_params: WifiMclParams =
        toml::Value::Table(params)
            .try_into()
            .map_err(|e: toml::de::Error| {
                ScenarioError::field(file, &field, e.message().to_string())
            })?;
    mcl_params
        .validate()
        .map_err(|msg| param_error(file, &field, &mcl_params, &msg))?;
    let dir = file.parent().unwrap_or(Path::new("."));
    let graph =
        match (training, graph_file) {
            (Some(t), None) => graph_from_training(scenario, &dir.join(t), &learn, &field)?,
            (None, Some(g)) => Arc::new(
                WifiGraph::load(&dir.join(g))
                    .map_err(|msg| ScenarioError::field(file, format!("{field}.graph"), msg))?,
            ),
            (Some(_), Some(_)) => return Err(ScenarioError::field(
                file,
                &field,
                "give either `training` (a survey scenario) or `graph` (a saved graph), not both",
            )),
            (None, None) => {
                return Err(ScenarioError::field(
                    file,
                    &field,
                    "a wifi localizer needs `training = \"<survey scenario>\"` or \
                 `graph = \"<saved graph>\"`",
                ))
            }
        };
    let init = match &scenario.initial_belief {
        InitialBelief::Tracking { sigma } => MclBelief::Tracking {
            pose: scenario.start,
            sigma: *sigma,
        },
        InitialBelief::Global { polygons } => MclBelief::Global {
            regions: polygons.clone(),
        },
    };
    let f = WifiMcl::new(&spec.name, mcl_params.clone(), graph, grid, init, seed)
        .map_err(|e| localization_error(file, &field, &mcl_params, e))?;
    Ok(Box::new(f))
}
