//! Building the sensor choosers (`kind = "chooser"`) and the fused localizer
//! (`kind = "fused"`) of `atrium_localization::chooser` ([004] §4) from a
//! scenario's `[[localizers]]` table.
//!
//! ```toml
//! [[localizers]]
//! name = "by_map"
//! kind = "chooser"
//! strategy = "data_driven"            # or "uncertainty", "mismatch"
//! members = ["laser", "depth", "wifi"] # other [[localizers]] entries of this scenario
//! training = "choosers_training.toml"  # or error_map = "error_map.csv" (data_driven only)
//! training_runs = 1
//! reseed = true
//! ```
//!
//! Members are seeded like the stand-alone localizers of the same name (paired: until a
//! re-seed they compute exactly what the stand-alone ones do, so the chooser's error is
//! compared with theirs on the same draws). In a run they are one filter per name, shared by
//! the stand-alone localizer and every chooser, which gets a copy of its own when it
//! re-seeds it (`atrium_localization::shared_member`); a chooser never disturbs the
//! stand-alone localizers or the other choosers. Keys:
//! - both kinds: `members`, `reseed` (default true), `reseed_members` (the members it may
//!   move; default all), `reseed_gate_sigmas` (3),
//!   `reseed_min_distance_m` (0.5), `reseed_min_sigma_xy` (0.3), `reseed_min_sigma_theta`
//!   (0.1), see [`ReseedParams`]; `anchor_gate` (default false): only members consistent
//!   (by the re-seeding test) with every member outside `reseed_members` may be chosen, see
//!   [`Chooser::set_anchor_gate`];
//! - `chooser`: `strategy`; with `data_driven` exactly one of `error_map` (an [`ErrorMap`]
//!   CSV, layers named like the members) or `training` (a scenario whose localizers are named
//!   like the members, run `training_runs` times, default 1, with seeds derived from its own),
//!   and `error_map_resolution` (m, default 2; training only) and `lookup_radius_cells`
//!   (default 3);
//! - `fused`: `training` and `training_runs` as above, `covariance_floor_m` (default 0.1; each member's floor in a group is its RMS
//!   training error there, if larger),
//!   `group_by` = "kind" (default: one weight vector per region kind) or "region" (per named
//!   region), `min_group_samples` (default 50: a group with fewer training samples uses the
//!   weights learnt from all samples).
//!
//! Training runs are memoised per process under the training scenario's full text, world and
//! run count (as the WiFi survey is), so the choosers of one scenario share one training.

use crate::error::ScenarioError;
use crate::registry::{BuildContext, LocalizerRegistry};
use crate::runner::{RunObserver, RunOptions, SimStream, Tick};
use crate::scenario::Scenario;
use crate::seeds::derive_seed;
use atrium_localization::chooser::{Chooser, ReseedParams, Strategy};
use atrium_localization::error_map::ErrorMap;
use atrium_localization::limits::{check_count, MAX_LOOKUP_RADIUS_CELLS, MAX_TRAINING_RUNS};
use atrium_localization::mixture::{log_density_xy, mixture_weights, MixtureGroup, RegionMixture};
use atrium_localization::{Estimate, Localizer};
use atrium_robots::{Pose2, Reading};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::{Arc, Mutex, OnceLock};

/// The localizer kinds built here (they cannot be members of one another).
pub const KINDS: [&str; 2] = ["chooser", "fused"];

const COMMON_KEYS: [&str; 8] = [
    "members",
    "anchor_gate",
    "reseed",
    "reseed_members",
    "reseed_gate_sigmas",
    "reseed_min_distance_m",
    "reseed_min_sigma_xy",
    "reseed_min_sigma_theta",
];
const CHOOSER_KEYS: [&str; 6] = [
    "strategy",
    "error_map",
    "training",
    "training_runs",
    "error_map_resolution",
    "lookup_radius_cells",
];
const FUSED_KEYS: [&str; 5] = [
    "training",
    "training_runs",
    "covariance_floor_m",
    "group_by",
    "min_group_samples",
];
/// Keys only a data-driven chooser reads.
const DATA_DRIVEN_KEYS: [&str; 5] = [
    "error_map",
    "training",
    "training_runs",
    "error_map_resolution",
    "lookup_radius_cells",
];
/// At most this many training samples per group go into the convex program (evenly spaced).
const MAX_MIXTURE_SAMPLES: usize = 3000;

/// One training run: at every scored instant the ground truth, and the position errors and
/// estimates (with covariances) of the training scenario's localizers, in `names` order.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainingRun {
    pub ground_truth: Vec<(f64, Pose2)>,
    /// `position_errors[localizer][instant]`, m.
    pub position_errors: Vec<Vec<f64>>,
    /// `estimates[instant][localizer]`.
    pub estimates: Vec<Vec<Estimate>>,
}

/// Part of the disk cache's key of training runs: bump when a run makes something else from
/// the same inputs (the executable's identity is in the key too).
const TRAINING_VERSION: u32 = 1;

/// The disk cache's encoding of training runs (every f64 bit for bit).
fn runs_to_bytes(runs: &[TrainingRun]) -> Vec<u8> {
    let mut w = crate::disk_cache::Writer::default();
    w.u64(runs.len() as u64);
    for run in runs {
        w.u64(run.ground_truth.len() as u64);
        for (t, p) in &run.ground_truth {
            for v in [*t, p.x, p.y, p.theta] {
                w.f64(v);
            }
        }
        w.u64(run.position_errors.len() as u64);
        for e in &run.position_errors {
            w.f64s(e);
        }
        w.u64(run.estimates.len() as u64);
        for instant in &run.estimates {
            w.u64(instant.len() as u64);
            for e in instant {
                for v in [e.stamp, e.pose.x, e.pose.y, e.pose.theta] {
                    w.f64(v);
                }
                for v in e.covariance.as_slice() {
                    w.f64(*v);
                }
            }
        }
    }
    w.0
}

fn runs_from_bytes(bytes: &[u8]) -> Option<Vec<TrainingRun>> {
    let mut r = crate::disk_cache::Reader::new(bytes);
    let n = r.len(24)?;
    let mut runs = Vec::with_capacity(n);
    for _ in 0..n {
        let m = r.len(32)?;
        let mut ground_truth = Vec::with_capacity(m);
        for _ in 0..m {
            let t = r.f64()?;
            ground_truth.push((t, Pose2::new(r.f64()?, r.f64()?, r.f64()?)));
        }
        let k = r.len(8)?;
        let position_errors = (0..k).map(|_| r.f64s()).collect::<Option<Vec<_>>>()?;
        let m2 = r.len(8)?;
        let mut estimates = Vec::with_capacity(m2);
        for _ in 0..m2 {
            let k2 = r.len(13 * 8)?;
            let mut instant = Vec::with_capacity(k2);
            for _ in 0..k2 {
                let stamp = r.f64()?;
                let pose = Pose2::new(r.f64()?, r.f64()?, r.f64()?);
                let mut cov = [0.0; 9];
                for c in &mut cov {
                    *c = r.f64()?;
                }
                instant.push(Estimate {
                    stamp,
                    pose,
                    covariance: nalgebra::Matrix3::from_column_slice(&cov),
                });
            }
            estimates.push(instant);
        }
        runs.push(TrainingRun {
            ground_truth,
            position_errors,
            estimates,
        });
    }
    r.is_empty().then_some(runs)
}

/// Every run of a training scenario.
pub struct Training {
    pub scenario: Scenario,
    pub names: Vec<String>,
    pub runs: Vec<TrainingRun>,
}

impl Training {
    /// The per-location error map of the runs (004 §3 Figure 2), cells of `resolution` m.
    pub fn error_map(&self, resolution: f64) -> Result<ErrorMap, String> {
        let (min, max) = self.scenario.world.bounds();
        let mut map = ErrorMap::new(min, max, resolution, self.names.clone())?;
        // As `crate::error_maps::accumulate` over each run's result.
        for run in &self.runs {
            for (name, errors) in self.names.iter().zip(&run.position_errors) {
                let Some(layer) = map.localizer_index(name) else {
                    continue;
                };
                for ((_, truth), e) in run.ground_truth.iter().zip(errors) {
                    map.add(layer, [truth.x, truth.y], *e);
                }
            }
        }
        Ok(map)
    }
}

struct Collect(Vec<Vec<Estimate>>);

impl RunObserver for Collect {
    fn instant(
        &mut self,
        _tick: &Tick,
        _readings: &[Reading],
        estimates: Option<&[Estimate]>,
    ) -> Result<(), ScenarioError> {
        if let Some(e) = estimates {
            self.0.push(e.to_vec());
        }
        Ok(())
    }
}

/// Runs `path` `runs` times (seeds derived from its own seed and the run index), without its
/// choosers and expectations. Memoised per process (see the module docs).
///
/// The training scenario drives `owner`'s generated world when it names the same generator
/// file ([`Scenario::load_training`]), so a sweep cell trains on its own world.
pub fn train(
    registry: &LocalizerRegistry,
    owner: &Scenario,
    path: &Path,
    runs: usize,
) -> Result<Arc<Training>, String> {
    type Slot = Arc<OnceLock<Result<Arc<Training>, String>>>;
    static CACHE: OnceLock<Mutex<HashMap<String, Slot>>> = OnceLock::new();
    let mut scenario = owner.load_training(path).map_err(|e| e.to_string())?;
    // The registry's kinds are part of the key: the same text may name a user's kind.
    let key = format!(
        "{}\n{}\n{runs}\n{:?}",
        scenario.text,
        serde_json::to_string(&scenario.world).unwrap_or_default(),
        registry
    );
    let slot = {
        let cache = CACHE.get_or_init(|| Mutex::new(HashMap::new()));
        let mut map = cache.lock().unwrap_or_else(|p| p.into_inner());
        map.entry(key).or_default().clone()
    };
    slot.get_or_init(|| {
        // On disk (`disk_cache`) under every input of the training scenario, the run count
        // and the registry's kinds; not when a localizer runs in another process (its
        // program is not part of the key).
        let mut disk_key =
            format!("chooser training {TRAINING_VERSION}\n{runs}\n{registry:?}\n").into_bytes();
        disk_key.extend(crate::disk_cache::scenario_inputs(&scenario));
        let external = scenario.localizers.iter().any(|l| l.kind == "process");
        // A chooser in the training scenario would train on it again: only single-sensor
        // localizers are evaluated.
        scenario
            .localizers
            .retain(|l| !KINDS.contains(&l.kind.as_str()));
        scenario.expect = toml::Table::new();
        if scenario.localizers.is_empty() {
            return Err(format!(
                "{}: has no localizers to train on besides choosers",
                path.display()
            ));
        }
        let names: Vec<String> = scenario.localizers.iter().map(|l| l.name.clone()).collect();
        let build = || run_training(registry, &scenario, runs);
        let out = if external {
            build()?
        } else {
            crate::disk_cache::cached(
                "chooser_training",
                &disk_key,
                build,
                |r| runs_to_bytes(r),
                |b| {
                    runs_from_bytes(b).filter(|r| {
                        r.len() == runs
                            && r.iter().all(|run| run.position_errors.len() == names.len())
                    })
                },
            )?
        };
        Ok(Arc::new(Training {
            scenario,
            names,
            runs: out,
        }))
    })
    .clone()
}

/// `runs` runs of the training scenario (choosers removed).
fn run_training(
    registry: &LocalizerRegistry,
    scenario: &Scenario,
    runs: usize,
) -> Result<Vec<TrainingRun>, String> {
    let mut out = Vec::with_capacity(runs);
    {
        for i in 0..runs {
            let seed = derive_seed(scenario.seed, &format!("chooser_training/{i}"));
            let mut stream = SimStream::new(scenario, seed).map_err(|e| e.to_string())?;
            let mut collect = Collect(Vec::new());
            let result = registry
                .run_stream(
                    scenario,
                    seed,
                    &mut stream,
                    &scenario.events,
                    RunOptions {
                        observer: Some(&mut collect),
                        ..Default::default()
                    },
                )
                .map_err(|e| e.to_string())?;
            out.push(TrainingRun {
                ground_truth: result.ground_truth,
                position_errors: result
                    .localizers
                    .iter()
                    .map(|l| l.samples.iter().map(|s| s.position_error).collect())
                    .collect(),
                estimates: collect.0,
            });
        }
        Ok(out)
    }
}

/// Mixture weights per group of the world's regions (by kind or by name) learnt from
/// `training` for `members` (indices of training localizers). Per group: each member's floor
/// is its RMS position error over the group's samples (at least `covariance_floor_m`), then
/// at every sample p_k = member k's floored Gaussian density at the true position, and
/// [`mixture_weights`] over them. Groups with fewer than `min_samples` samples, and places in
/// no region, take the group learnt from all samples.
pub fn learn_region_mixture(
    training: &Training,
    members: &[usize],
    covariance_floor_m: f64,
    by_kind: bool,
    min_samples: usize,
) -> Result<RegionMixture, String> {
    let world = &training.scenario.world;
    let key_of = |r: &atrium_worlds::Region| -> String {
        if by_kind {
            serde_json::to_value(r.kind)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default()
        } else {
            r.name.clone()
        }
    };
    // Every scored instant of every run: (truth, estimate per member).
    let mut samples: Vec<([f64; 2], Vec<Estimate>)> = Vec::new();
    let mut groups: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for run in &training.runs {
        for ((_, truth), est) in run.ground_truth.iter().zip(&run.estimates) {
            let p = [truth.x, truth.y];
            if let Some(r) = world.region_at(p) {
                groups.entry(key_of(r)).or_default().push(samples.len());
            }
            samples.push((p, members.iter().map(|&k| est[k]).collect()));
        }
    }
    let fit = |idx: &[usize]| -> Result<MixtureGroup, String> {
        let k = members.len();
        let mut sq = vec![0.0; k];
        for &i in idx {
            let (p, est) = &samples[i];
            for (c, e) in est.iter().enumerate() {
                sq[c] += (e.pose.x - p[0]).powi(2) + (e.pose.y - p[1]).powi(2);
            }
        }
        let floors_m: Vec<f64> = sq
            .iter()
            .map(|s| {
                let rms = (s / idx.len().max(1) as f64).sqrt();
                if rms.is_finite() {
                    rms.max(covariance_floor_m)
                } else {
                    covariance_floor_m
                }
            })
            .collect();
        // At most MAX_MIXTURE_SAMPLES rows, evenly spaced, each scaled by its largest
        // likelihood (same optimum, well-conditioned).
        let stride = idx.len().div_ceil(MAX_MIXTURE_SAMPLES).max(1);
        let mut rows = Vec::with_capacity(idx.len() / stride + 1);
        for &i in idx.iter().step_by(stride) {
            let (p, est) = &samples[i];
            let logs: Vec<f64> = est
                .iter()
                .zip(&floors_m)
                .map(|(e, f)| log_density_xy([e.pose.x, e.pose.y], &e.covariance, *f, *p))
                .collect();
            let max = logs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            if max.is_finite() {
                rows.push(logs.iter().map(|l| (l - max).exp()).collect::<Vec<f64>>());
            }
        }
        let weights = mixture_weights(&rows).map_err(|e| e.to_string())?;
        Ok(MixtureGroup { weights, floors_m })
    };
    let all: Vec<usize> = (0..samples.len()).collect();
    let default = fit(&all)?;
    let mut regions = Vec::new();
    for (g, idx) in &groups {
        let group = if idx.len() >= min_samples {
            fit(idx)?
        } else {
            default.clone()
        };
        for r in world.regions.iter().filter(|r| &key_of(r) == g) {
            regions.push((r.polygon.clone(), group.clone()));
        }
    }
    Ok(RegionMixture { regions, default })
}

/// Builds `kind = "chooser"` or `kind = "fused"`.
pub fn build(ctx: &mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError> {
    let (spec, scenario, registry) = (ctx.spec, ctx.scenario, ctx.registry);
    let file = &scenario.file;
    let field = format!("localizers[{}]", spec.name);
    let fused = spec.kind == "fused";
    let err = |key: &str, msg: String| {
        let f = if key.is_empty() {
            field.clone()
        } else {
            format!("{field}.{key}")
        };
        ScenarioError::field(file, f, msg)
    };
    let own_keys: &[&str] = if fused { &FUSED_KEYS } else { &CHOOSER_KEYS };
    for k in spec.params.keys() {
        if !COMMON_KEYS.contains(&k.as_str()) && !own_keys.contains(&k.as_str()) {
            let mut known: Vec<&str> = COMMON_KEYS.iter().chain(own_keys).copied().collect();
            known.sort_unstable();
            return Err(err(
                k,
                format!(
                    "unknown key for a {} (known: {})",
                    spec.kind,
                    known.join(", ")
                ),
            ));
        }
    }
    let p = &spec.params;
    let float = |key: &str, default: f64| -> Result<f64, ScenarioError> {
        match p.get(key) {
            None => Ok(default),
            Some(toml::Value::Float(f)) => Ok(*f),
            Some(toml::Value::Integer(i)) => Ok(*i as f64),
            Some(_) => Err(err(key, "must be a number".into())),
        }
    };
    let count = |key: &str, default: usize, min: usize| -> Result<usize, ScenarioError> {
        match p.get(key) {
            None => Ok(default),
            Some(toml::Value::Integer(i)) if *i >= min as i64 => Ok(*i as usize),
            Some(_) => Err(err(key, format!("must be an integer >= {min}"))),
        }
    };
    // A count with an upper limit; the message names the limit's constant.
    let bounded = |key: &str, default: usize, min: usize, limit: usize, name: &str| {
        let v = count(key, default, min)?;
        check_count(key, v, limit, name).map_err(|m| {
            let (_, why) = m.split_once(": ").unwrap_or(("", &m));
            err(key, why.to_string())
        })?;
        Ok::<usize, ScenarioError>(v)
    };
    let training_runs = || {
        bounded(
            "training_runs",
            1,
            1,
            MAX_TRAINING_RUNS,
            "MAX_TRAINING_RUNS",
        )
    };
    let text = |key: &str| -> Result<Option<String>, ScenarioError> {
        match p.get(key) {
            None => Ok(None),
            Some(toml::Value::String(s)) if !s.trim().is_empty() => Ok(Some(s.clone())),
            Some(_) => Err(err(key, "must be a non-empty string".into())),
        }
    };

    // Members: other single-sensor [[localizers]] entries, each once.
    let names: Vec<String> = match p.get("members") {
        None => return Err(err("members", "required: a list of localizer names".into())),
        Some(toml::Value::Array(a)) => a
            .iter()
            .map(|v| v.as_str().map(str::to_string))
            .collect::<Option<Vec<_>>>()
            .ok_or_else(|| err("members", "must be a list of strings".into()))?,
        Some(_) => return Err(err("members", "must be a list of strings".into())),
    };
    if names.is_empty() {
        return Err(err(
            "members",
            "is empty: name at least one localizer".into(),
        ));
    }
    let mut member_specs = Vec::with_capacity(names.len());
    for (i, name) in names.iter().enumerate() {
        let f = format!("members[{i}]");
        if names[..i].contains(name) {
            return Err(err(&f, format!("{name:?} is named twice")));
        }
        if name == &spec.name {
            return Err(err(&f, format!("{name:?} is this localizer itself")));
        }
        let Some(m) = scenario.localizers.iter().find(|l| &l.name == name) else {
            let known: Vec<&str> = scenario
                .localizers
                .iter()
                .filter(|l| l.name != spec.name)
                .map(|l| l.name.as_str())
                .collect();
            return Err(err(
                &f,
                format!(
                    "names no [[localizers]] entry of this scenario (known: {})",
                    known.join(", ")
                ),
            ));
        };
        if KINDS.contains(&m.kind.as_str()) {
            return Err(err(
                &f,
                format!(
                    "{name:?} is itself a {}: members must be single-sensor localizers",
                    m.kind
                ),
            ));
        }
        member_specs.push(m);
    }

    let reseed = match p.get("reseed") {
        None => true,
        Some(toml::Value::Boolean(b)) => *b,
        Some(_) => return Err(err("reseed", "must be true or false".into())),
    };
    // Members re-seeding may move: all unless listed.
    let reseedable: Vec<bool> = match p.get("reseed_members") {
        None => vec![true; names.len()],
        Some(toml::Value::Array(a)) => {
            let listed = a
                .iter()
                .map(|v| v.as_str().map(str::to_string))
                .collect::<Option<Vec<_>>>()
                .ok_or_else(|| err("reseed_members", "must be a list of strings".into()))?;
            for (i, n) in listed.iter().enumerate() {
                if !names.contains(n) {
                    return Err(err(
                        &format!("reseed_members[{i}]"),
                        format!("{n:?} is not one of the members ({})", names.join(", ")),
                    ));
                }
            }
            names.iter().map(|n| listed.contains(n)).collect()
        }
        Some(_) => return Err(err("reseed_members", "must be a list of strings".into())),
    };
    let anchor_gate = match p.get("anchor_gate") {
        None => false,
        Some(toml::Value::Boolean(b)) => *b,
        Some(_) => return Err(err("anchor_gate", "must be true or false".into())),
    };
    if anchor_gate && reseedable.iter().all(|r| *r) {
        return Err(err(
            "anchor_gate",
            "needs an anchor: a member left out of reseed_members".into(),
        ));
    }
    let d = ReseedParams::default();
    let reseed_params = ReseedParams {
        gate_sigmas: float("reseed_gate_sigmas", d.gate_sigmas)?,
        min_distance_m: float("reseed_min_distance_m", d.min_distance_m)?,
        min_sigma_xy: float("reseed_min_sigma_xy", d.min_sigma_xy)?,
        min_sigma_theta: float("reseed_min_sigma_theta", d.min_sigma_theta)?,
    };
    reseed_params.validate().map_err(|m| {
        let (k, why) = m.split_once(' ').unwrap_or(("", m.as_str()));
        err(k, why.to_string())
    })?;

    let dir = file.parent().unwrap_or(Path::new("."));
    let training_of = |runs: usize| -> Result<Option<Arc<Training>>, ScenarioError> {
        match text("training")? {
            None => Ok(None),
            Some(t) => train(registry, scenario, &dir.join(&t), runs)
                .map(Some)
                .map_err(|m| err("training", m)),
        }
    };
    // Indices of the members among the training scenario's localizers.
    let layers_in = |available: &[String], what: &str, key: &str| {
        names
            .iter()
            .map(|n| {
                available.iter().position(|a| a == n).ok_or_else(|| {
                    err(
                        key,
                        format!(
                            "{what} has no localizer named {n:?} (has: {})",
                            available.join(", ")
                        ),
                    )
                })
            })
            .collect::<Result<Vec<usize>, _>>()
    };

    let strategy = if fused {
        let runs = training_runs()?;
        let floor = float("covariance_floor_m", 0.1)?;
        if !(floor.is_finite() && floor > 0.0) {
            return Err(err(
                "covariance_floor_m",
                format!("must be finite and > 0, got {floor}"),
            ));
        }
        let by_kind = match text("group_by")?.as_deref() {
            None | Some("kind") => true,
            Some("region") => false,
            Some(other) => {
                return Err(err(
                    "group_by",
                    format!("unknown grouping {other:?} (known: kind, region)"),
                ))
            }
        };
        let min_samples = count("min_group_samples", 50, 1)?;
        let training = training_of(runs)?.ok_or_else(|| {
            err(
                "training",
                "required: a scenario whose localizers are named like the members".into(),
            )
        })?;
        let idx = layers_in(&training.names, "the training scenario", "training")?;
        let model = learn_region_mixture(&training, &idx, floor, by_kind, min_samples)
            .map_err(|m| err("training", format!("mixture weights: {m}")))?;
        Strategy::Fused {
            model: Arc::new(model),
        }
    } else {
        let strategy = text("strategy")?.ok_or_else(|| {
            err(
                "strategy",
                "required: \"uncertainty\", \"mismatch\" or \"data_driven\"".into(),
            )
        })?;
        if strategy != "data_driven" {
            if let Some(k) = DATA_DRIVEN_KEYS.iter().find(|k| p.contains_key(**k)) {
                return Err(err(
                    k,
                    "only a data_driven chooser takes this key".to_string(),
                ));
            }
        }
        match strategy.as_str() {
            "uncertainty" => Strategy::Uncertainty,
            "mismatch" => Strategy::Mismatch,
            "data_driven" => {
                let radius_cells = bounded(
                    "lookup_radius_cells",
                    3,
                    0,
                    MAX_LOOKUP_RADIUS_CELLS,
                    "MAX_LOOKUP_RADIUS_CELLS",
                )?;
                let map = match (text("error_map")?, p.contains_key("training")) {
                    (Some(_), true) => {
                        return Err(err(
                            "",
                            "give either `error_map` or `training`, not both".into(),
                        ))
                    }
                    (None, false) => {
                        return Err(err(
                            "error_map",
                            "a data_driven chooser needs `error_map = \"<file>.csv\"` or \
                             `training = \"<scenario>.toml\"`"
                                .into(),
                        ))
                    }
                    (Some(m), false) => {
                        if p.contains_key("error_map_resolution") || p.contains_key("training_runs")
                        {
                            return Err(err(
                                "error_map",
                                "error_map_resolution and training_runs go with `training`".into(),
                            ));
                        }
                        let path = dir.join(&m);
                        let csv = std::fs::read_to_string(&path).map_err(|e| {
                            err("error_map", format!("cannot read {}: {e}", path.display()))
                        })?;
                        ErrorMap::from_csv(&csv).map_err(|e| {
                            err(
                                "error_map",
                                format!("{}: line {}: {}", path.display(), e.line, e.message),
                            )
                        })?
                    }
                    (None, true) => {
                        let runs = training_runs()?;
                        let res = float("error_map_resolution", 2.0)?;
                        if !(res.is_finite() && res > 0.0) {
                            return Err(err(
                                "error_map_resolution",
                                format!("must be finite and > 0, got {res}"),
                            ));
                        }
                        // The map's size, from the training scenario's world, before the
                        // training runs.
                        if let Some(t) = text("training")? {
                            if let Ok(s) = scenario.load_training(&dir.join(&t)) {
                                let (min, max) = s.world.bounds();
                                ErrorMap::check_size(min, max, res, s.localizers.len()).map_err(
                                    |m| {
                                        let (_, why) = m.split_once(": ").unwrap_or(("", &m));
                                        err("error_map_resolution", why.to_string())
                                    },
                                )?;
                            }
                        }
                        let training = training_of(runs)?
                            .ok_or_else(|| err("training", "must be a non-empty string".into()))?;
                        training
                            .error_map(res)
                            .map_err(|m| err("error_map_resolution", m))?
                    }
                };
                let key = if p.contains_key("training") {
                    "training"
                } else {
                    "error_map"
                };
                let layers = layers_in(&map.localizers, "the error map", key)?;
                Strategy::DataDriven {
                    map: Arc::new(map),
                    layers,
                    radius_cells,
                }
            }
            other => {
                return Err(err(
                    "strategy",
                    format!(
                        "unknown strategy {other:?} (known: uncertainty, mismatch, data_driven)"
                    ),
                ))
            }
        }
    };

    let mut members = Vec::with_capacity(member_specs.len());
    for (m, moved) in member_specs.into_iter().zip(&reseedable) {
        // Seeded like the stand-alone localizer of the same name (see `localizer_seed`), so
        // it is that localizer's filter until this chooser re-seeds it.
        members.push(ctx.build_member(m, reseed && *moved)?);
    }
    let mut chooser = Chooser::new(
        &spec.name,
        members,
        strategy,
        reseed.then_some(reseed_params),
    )
    .map_err(|e| err("", e.to_string()))?;
    chooser
        .set_reseedable(reseedable)
        .map_err(|e| err("reseed_members", e.to_string()))?;
    chooser.set_anchor_gate(anchor_gate);
    Ok(Box::new(chooser))
}

#[cfg(test)]
mod tests {
    use super::*;
    use atrium_localization::localizer::reset_localizer;
    use atrium_robots::Pose2;

    /// A scenario with laser, depth and WiFi localizers and `extra` appended, written to a
    /// temporary folder (paths absolute, so side files can sit beside it).
    fn scenario_with(extra: &str, tag: &str) -> Result<Scenario, ScenarioError> {
        let root = env!("CARGO_MANIFEST_DIR");
        let dir = std::env::temp_dir().join(format!("atrium_chooser_{tag}_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = format!(
            r#"
name = "t"
world = "{root}/../worlds/campus.toml"
robot = "{root}/../robots/urdf/pioneer3dx.urdf"
duration_s = 1.0
[start]
pose = [20.0, 20.0, 0.0]
[route]
waypoints = [[25.0, 20.0]]
[depth_cameras.kinect]
preset = "kinect"
mount = "camera"
decimation = 4
[[localizers]]
name = "laser"
kind = "cgr_laser"
particles = 20
[[localizers]]
name = "depth"
kind = "cgr_depth"
particles = 20
fspf = {{ eta = 15 }}
[[localizers]]
name = "wifi"
kind = "wifi"
graph = "{dir}/missing_graph_is_not_needed_here.json"
{extra}
"#,
            dir = dir.display()
        );
        Scenario::from_toml_str(&text, &dir.join("s.toml"))
    }

    fn build_named(s: &Scenario, name: &str) -> Result<Box<dyn Localizer>, ScenarioError> {
        let spec = s.localizers.iter().find(|l| l.name == name).unwrap();
        crate::LocalizerRegistry::with_builtins().build(
            spec,
            s,
            &mut crate::maps::SharedMaps::default(),
            1,
        )
    }

    fn error_of(extra: &str, tag: &str) -> String {
        let s = scenario_with(extra, tag).unwrap();
        match build_named(&s, "c") {
            Ok(_) => panic!("{tag}: built"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn bad_parameters_are_errors_naming_the_field() {
        let cases = [
            (
                "unknown_member",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"uncertainty\"\nmembers = [\"laser\", \"sonar\"]",
                "localizers[c].members[1]",
                "names no [[localizers]] entry",
            ),
            (
                "chooser_member",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"uncertainty\"\nmembers = [\"laser\", \"d\"]\n[[localizers]]\nname = \"d\"\nkind = \"chooser\"\nstrategy = \"mismatch\"\nmembers = [\"laser\"]",
                "localizers[c].members[1]",
                "is itself a chooser",
            ),
            (
                "empty",
                "[[localizers]]\nname = \"c\"\nkind = \"fused\"\nmembers = []",
                "localizers[c].members",
                "is empty",
            ),
            (
                "strategy",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"coin_flip\"\nmembers = [\"laser\"]",
                "localizers[c].strategy",
                "unknown strategy \"coin_flip\"",
            ),
            (
                "no_strategy",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nmembers = [\"laser\"]",
                "localizers[c].strategy",
                "required",
            ),
            (
                "missing_map",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"data_driven\"\nmembers = [\"laser\"]\nerror_map = \"nowhere.csv\"",
                "localizers[c].error_map",
                "cannot read",
            ),
            (
                "no_map",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"data_driven\"\nmembers = [\"laser\"]",
                "localizers[c].error_map",
                "needs",
            ),
            (
                "map_key_elsewhere",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"uncertainty\"\nmembers = [\"laser\"]\nerror_map = \"x.csv\"",
                "localizers[c].error_map",
                "only a data_driven chooser",
            ),
            (
                "unknown_key",
                "[[localizers]]\nname = \"c\"\nkind = \"fused\"\nmembers = [\"laser\"]\nstrategy = \"uncertainty\"",
                "localizers[c].strategy",
                "unknown key for a fused",
            ),
            (
                "self",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"mismatch\"\nmembers = [\"c\"]",
                "localizers[c].members[0]",
                "itself",
            ),
            (
                "twice",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"mismatch\"\nmembers = [\"laser\", \"laser\"]",
                "localizers[c].members[1]",
                "named twice",
            ),
            (
                "fused_needs_training",
                "[[localizers]]\nname = \"c\"\nkind = \"fused\"\nmembers = [\"laser\"]",
                "localizers[c].training",
                "required",
            ),
            (
                "reseed_members",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"mismatch\"\nmembers = [\"laser\"]\nreseed_members = [\"depth\"]",
                "localizers[c].reseed_members[0]",
                "not one of the members",
            ),
            (
                "gate",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"mismatch\"\nmembers = [\"laser\"]\nreseed_gate_sigmas = -2.0",
                "localizers[c].reseed_gate_sigmas",
                "must be finite and >= 0",
            ),
            (
                "anchor_gate_type",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"uncertainty\"\nmembers = [\"laser\"]\nanchor_gate = \"yes\"",
                "localizers[c].anchor_gate",
                "must be true or false",
            ),
            (
                "training_runs_limit",
                "[[localizers]]\nname = \"c\"\nkind = \"fused\"\nmembers = [\"laser\"]\ntraining = \"t.toml\"\ntraining_runs = 101",
                "localizers[c].training_runs",
                "101 is more than the limit of 100 (MAX_TRAINING_RUNS)",
            ),
            (
                "lookup_radius_limit",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"data_driven\"\nmembers = [\"laser\"]\nerror_map = \"x.csv\"\nlookup_radius_cells = 1000000000",
                "localizers[c].lookup_radius_cells",
                "1000000000 is more than the limit of 100 (MAX_LOOKUP_RADIUS_CELLS)",
            ),
            (
                "anchor_gate_without_anchor",
                "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"uncertainty\"\nmembers = [\"laser\", \"depth\"]\nanchor_gate = true",
                "localizers[c].anchor_gate",
                "needs an anchor",
            ),
        ];
        for (tag, extra, field, msg) in cases {
            let e = error_of(extra, tag);
            assert!(e.contains(&format!("{field}: ")), "{tag}: {e}");
            assert!(e.contains(msg), "{tag}: {e}");
        }
    }

    #[test]
    fn data_driven_reads_an_error_map_csv_and_maps_layers_by_name() {
        // Layers in another order than the members, and one extra layer.
        let mut map = ErrorMap::new(
            [0.0, 0.0],
            [60.0, 40.0],
            2.0,
            vec!["other".into(), "depth".into(), "laser".into()],
        )
        .unwrap();
        map.add(1, [20.5, 20.5], 0.3);
        map.add(2, [20.5, 20.5], 0.02);
        let s = scenario_with("", "csv").unwrap();
        let dir = s.file.parent().unwrap().to_path_buf();
        std::fs::write(dir.join("map.csv"), map.to_csv()).unwrap();
        let extra = "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"data_driven\"\nmembers = [\"depth\", \"laser\"]\nerror_map = \"map.csv\"";
        let s = scenario_with(extra, "csv").unwrap();
        let mut c = build_named(&s, "c").unwrap();
        // Before any update the first member is the output; after one, the map's choice.
        assert_eq!(chooser(&mut *c).chosen(), 0);
        let scan = atrium_robots::LaserScan {
            stamp: 0.1,
            sensor: "laser".into(),
            mount: Pose2::default(),
            angle_min: 0.0,
            angle_increment: 0.1,
            range_min: 0.1,
            range_max: 8.0,
            ranges: vec![],
        };
        c.update(&Reading::Laser(scan)).unwrap();
        assert_eq!(chooser(&mut *c).chosen(), 1, "laser: 2 cm in the map");
        match chooser(&mut *c).strategy() {
            Strategy::DataDriven { map, layers, .. } => {
                let named: Vec<&str> = layers.iter().map(|&l| map.localizers[l].as_str()).collect();
                assert_eq!(named, ["depth", "laser"]);
            }
            other => panic!("{other:?}"),
        }
        // A member the map has no layer for is an error naming error_map.
        let extra = "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"data_driven\"\nmembers = [\"wifi\"]\nerror_map = \"map.csv\"";
        let e = error_of(extra, "csv");
        assert!(
            e.contains("localizers[c].error_map: the error map has no localizer named \"wifi\""),
            "{e}"
        );
    }

    #[test]
    fn a_hostile_error_map_is_refused_naming_the_csv_line_and_field() {
        let s = scenario_with("", "hostile_csv").unwrap();
        let dir = s.file.parent().unwrap().to_path_buf();
        let extra = "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"data_driven\"\nmembers = [\"laser\"]\nerror_map = \"bad.csv\"";
        let head = "localizer,i,j,x,y,mean_error,samples,sum\n";
        for (csv, want) in [
            (
                format!("# atrium error map: origin_x=NaN origin_y=0 resolution=2 width=30 height=20\n{head}"),
                "bad.csv: line 1: origin_x: must be finite, got NaN",
            ),
            (
                format!("# atrium error map: origin_x=0 origin_y=0 resolution=inf width=30 height=20\n{head}"),
                "bad.csv: line 1: resolution: must be finite, got inf",
            ),
            (
                format!("# atrium error map: origin_x=0 origin_y=0 resolution=1e-6 width=60000000 height=40000000\n{head}"),
                "bad.csv: line 1: width: 60000000 × 40000000 is 2.4e15 cells, more than the limit \
                 of 50000000 (ERROR_MAP_MAX_VALUES)",
            ),
            (
                format!("# atrium error map: origin_x=0 origin_y=0 resolution=2 width=30 height=20\n{head}laser,30,0,61,1,0.1,1,0.1\n"),
                "bad.csv: line 3: i: 30 lies outside the declared grid of 30 × 20 cells",
            ),
        ] {
            std::fs::write(dir.join("bad.csv"), csv).unwrap();
            let e = error_of(extra, "hostile_csv");
            assert!(e.contains("localizers[c].error_map: ") && e.contains(want), "{e}");
        }
    }

    /// A map over the training world at 1 µm is refused from the world's size, before the
    /// training runs.
    #[test]
    fn an_error_map_resolution_over_the_limit_is_refused_before_training() {
        let s = scenario_with("", "map_resolution").unwrap();
        let dir = s.file.parent().unwrap().to_path_buf();
        // The training scenario: a dead-reckoning run on the campus (never run here).
        let root = env!("CARGO_MANIFEST_DIR");
        std::fs::write(
            dir.join("t.toml"),
            format!(
                "name = \"t\"\nworld = \"{root}/../worlds/campus.toml\"\nrobot = \"{root}/../robots/urdf/pioneer3dx.urdf\"\nduration_s = 1.0\n[start]\npose = [20.0, 20.0, 0.0]\n[route]\nwaypoints = [[25.0, 20.0]]\n[[localizers]]\nname = \"laser\"\nkind = \"dead_reckoning\"\n"
            ),
        )
        .unwrap();
        let extra = "[[localizers]]\nname = \"c\"\nkind = \"chooser\"\nstrategy = \"data_driven\"\nmembers = [\"laser\"]\ntraining = \"t.toml\"\nerror_map_resolution = 1e-6";
        let started = std::time::Instant::now();
        let e = error_of(extra, "map_resolution");
        assert!(
            e.contains("localizers[c].error_map_resolution: 0.000001 m over the 60.3 m × 40.3 m area (1 layer)")
                && e.contains("ERROR_MAP_MAX_VALUES"),
            "{e}"
        );
        assert!(started.elapsed().as_secs_f64() < 5.0, "it ran the training");
    }

    /// Choosers re-seeding at every update (gates at zero): two alike and one other, over
    /// laser and depth CGR, on 12 s of the campus corridor.
    fn reseeding_choosers() -> Scenario {
        let root = env!("CARGO_MANIFEST_DIR");
        let chooser = |name: &str, strategy: &str| {
            format!(
                "[[localizers]]\nname = \"{name}\"\nkind = \"chooser\"\nstrategy = \"{strategy}\"\n\
                 members = [\"laser\", \"depth\"]\nreseed_gate_sigmas = 0.0\n\
                 reseed_min_distance_m = 0.0\n"
            )
        };
        let text = format!(
            r#"
name = "t"
world = "{root}/../worlds/campus.toml"
robot = "{root}/../robots/urdf/pioneer3dx.urdf"
duration_s = 12.0
[start]
pose = [20.0, 20.0, 0.0]
[route]
waypoints = [[29.0, 20.0], [40.0, 20.0]]
[depth_cameras.kinect]
preset = "kinect"
mount = "camera"
decimation = 4
rate_hz = 5
[[localizers]]
name = "laser"
kind = "cgr_laser"
particles = 20
[[localizers]]
name = "depth"
kind = "cgr_depth"
particles = 20
fspf = {{ eta = 15 }}
{}{}{}"#,
            chooser("a", "uncertainty"),
            chooser("b", "uncertainty"),
            chooser("c", "mismatch")
        );
        Scenario::from_toml_str(&text, Path::new(root).join("t.toml").as_path()).unwrap()
    }

    /// In a run the choosers' members are the stand-alone filters until re-seeded, and a
    /// chooser's results are bit for bit those it has with members of its own.
    #[test]
    fn shared_members_give_what_private_members_give() {
        let s = reseeding_choosers();
        let registry = crate::LocalizerRegistry::with_builtins();
        let mut shared = registry.build_all(&s, 7).unwrap();
        for (i, name) in [(0, "laser"), (1, "depth")] {
            let handle = shared[i]
                .capabilities()
                .and_then(|c| c.as_any())
                .and_then(|a| a.downcast_ref::<atrium_localization::SharedMember>());
            assert!(
                handle.is_some_and(|h| h.is_shared()),
                "{name}: the stand-alone filter is not shared with the choosers"
            );
        }
        let mut maps = crate::maps::SharedMaps::default();
        let private: Vec<Box<dyn Localizer>> = s
            .localizers
            .iter()
            .map(|spec| registry.build(spec, &s, &mut maps, 7).unwrap())
            .collect();
        let run = |localizers: Vec<Box<dyn Localizer>>| {
            let mut stream = SimStream::new(&s, 7).unwrap();
            crate::run_localizers(&s, 7, &mut stream, &[], localizers, RunOptions::default())
                .unwrap()
        };
        let (shared, private) = (run(shared), run(private));
        for (a, b) in shared.localizers.iter().zip(&private.localizers) {
            assert!(!a.trajectory.is_empty());
            assert_eq!(a.trajectory, b.trajectory, "{}", a.name);
        }
        // With the gates at zero every update re-seeds the member not chosen, so the run
        // made copies: shared by the two alike, apart for the other.
        let traj = |n: &str| {
            &shared
                .localizers
                .iter()
                .find(|l| l.name == n)
                .unwrap()
                .trajectory
        };
        assert_eq!(traj("a"), traj("b"));
        assert_ne!(traj("a"), traj("c"));
        // Each chooser's shares of time per member add up to the whole run; single-sensor
        // localizers choose nothing.
        for l in &shared.localizers {
            let chosen = &l.metrics.as_ref().unwrap().chosen;
            if ["a", "b", "c"].contains(&l.name.as_str()) {
                let total: f64 = chosen.values().sum();
                assert!((total - 1.0).abs() < 1e-9, "{}: {chosen:?}", l.name);
            } else {
                assert!(chosen.is_empty(), "{}: {chosen:?}", l.name);
            }
        }
    }

    fn chooser(l: &mut dyn Localizer) -> &Chooser {
        l.capabilities()
            .unwrap()
            .as_any()
            .unwrap()
            .downcast_ref::<Chooser>()
            .unwrap()
    }

    #[test]
    fn a_cgr_filter_is_reseeded_where_it_is_told() {
        let s = scenario_with("", "cgr").unwrap();
        let mut l = build_named(&s, "laser").unwrap();
        assert!(l.estimate().pose.distance(&Pose2::new(20.0, 20.0, 0.0)) < 0.1);
        let to = Pose2::new(40.0, 25.0, 1.0);
        assert!(reset_localizer(l.as_mut(), to, [0.5, 0.5, 0.1]));
        let e = l.estimate();
        // The mean of 20 draws with σ = 0.5 m has a standard error of 0.11 m per axis: 0.45 m
        // is about four of them, while the old pose is 20 m away.
        assert!(e.pose.distance(&to) < 0.45, "{:?}", e.pose);
        // 20 particles drawn with σ = 0.5 m: the spread is of that order.
        let sx = e.covariance[(0, 0)].sqrt();
        assert!((0.2..1.0).contains(&sx), "{sx}");
        assert!(!reset_localizer(
            l.as_mut(),
            Pose2::new(f64::NAN, 0.0, 0.0),
            [0.5, 0.5, 0.1]
        ));
    }
}
