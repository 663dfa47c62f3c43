//! Node routes and the landmark-filter experiment of [002]
//! (§IV-A, Table II).
//!
//! - `[route] controller = "nodes"`, `nodes = [...]` (and optionally `gamma_theta`, `gamma_d`)
//!   makes the robot drive the node list with the node controller of Table I.
//! - `[[localizers]] kind = "landmark_filter"` builds a [`LandmarkFilter`] after a training run
//!   over the same route ([`train_landmark_filter`]).
//! - `[node_experiment]` states how many runs make the table and what they must show;
//!   [`run_experiment`] runs them (seeds `seed`, `seed + 1`, …) and [`NodeExperiment`] prints
//!   Table II for the filter and for every other localizer of the same runs
//!   (`atrium nodes SCENARIO`).

use atrium_localization::landmark_filter::NodeModel;
use atrium_robots::Pose2;
use atrium_scenarios::builtins::landmark::trained_models;
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::node_route::NodeRoute;
use atrium_scenarios::runner::{RunOptions, RunResult};
use atrium_scenarios::scenario::{LocalizerSpec, Scenario};
use atrium_scenarios::seeds::derive_seed;
use atrium_scenarios::LocalizerRegistry;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// `[node_experiment]`: the multi-run table and what it must show.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NodeExperimentSettings {
    /// Runs, with seeds `seed`, `seed + 1`, … (002 §IV-A: five).
    pub runs: usize,
    /// The localizer whose verifications define the node instants (a landmark_filter).
    pub localizer: String,
    /// Every node of every run must be verified by the landmark (not only reached by
    /// odometry).
    pub all_verified: bool,
    /// At least this many node instants of the table (nodes × runs) verified by the landmark.
    pub verified_min: Option<usize>,
    /// Bound on the filter's mean node error over the whole table, m.
    pub mean_error_max: Option<f64>,
    /// Bound on the filter's largest node error, m.
    pub max_error_max: Option<f64>,
    /// Bound on the mean true distance of the robot from the node at the node instants, m
    /// (002 Table II's own measure; the paper reports about ρ).
    pub reach_mean_max: Option<f64>,
    /// `baseline`'s mean node error divided by the filter's must be at least this.
    pub improvement_min: Option<f64>,
    /// The localizer the improvement is measured against (dead reckoning).
    pub baseline: String,
    /// Run-to-run spread of the odometry calibration: each run scales the scenario's
    /// `radius_error`, `separation_error` and `scale_error` by factors drawn uniformly (each
    /// its own) from [1 − s, 1 + s] (tyre pressure and load differ between runs of a real
    /// chair). 0: every run has the scenario's calibration, and runs differ only in sensor
    /// noise.
    pub calibration_spread: f64,
    /// Also run the filter with 002's own reset (Table I update(): x, y := x_n, y_n, heading
    /// kept; `scan_alignment = false`, `gamma_rule = "rim"`) on the same seeds and
    /// calibrations, in runs of its own (the filter steers the robot, so two filters cannot
    /// share a run), and print its table beside the scenario's filter. No claim is checked
    /// on it: see [`NodeExperiment::paper`].
    pub paper_reset: bool,
}

/// The most runs one node table may ask for: each is a whole scenario run (seconds to
/// minutes), so 1,000 is already a day of computing, and the per-run tables are allocated up
/// front.
pub const MAX_RUNS: usize = 1000;

fn check_runs(runs: usize) -> Result<(), String> {
    if runs == 0 || runs > MAX_RUNS {
        return Err(format!(
            "{runs} runs: must be between 1 and the limit of {MAX_RUNS}"
        ));
    }
    Ok(())
}

impl Default for NodeExperimentSettings {
    fn default() -> Self {
        Self {
            runs: 5,
            localizer: String::new(),
            all_verified: true,
            verified_min: None,
            mean_error_max: None,
            max_error_max: None,
            reach_mean_max: None,
            improvement_min: None,
            baseline: String::new(),
            calibration_spread: 0.0,
            paper_reset: false,
        }
    }
}

/// Reads and checks `[node_experiment]` against the scenario's localizers.
pub fn parse_settings(
    file: &Path,
    table: &toml::Table,
    localizers: &[LocalizerSpec],
    node_route: Option<&NodeRoute>,
) -> Result<NodeExperimentSettings, ScenarioError> {
    let s: NodeExperimentSettings =
        toml::Value::Table(table.clone())
            .try_into()
            .map_err(|e: toml::de::Error| {
                ScenarioError::field(file, "node_experiment", e.message().to_string())
            })?;
    if node_route.is_none() {
        return Err(ScenarioError::field(
            file,
            "node_experiment",
            "needs a node route ([route] controller = \"nodes\")",
        ));
    }
    check_runs(s.runs).map_err(|msg| ScenarioError::field(file, "node_experiment.runs", msg))?;
    match localizers.iter().find(|l| l.name == s.localizer) {
        Some(l) if l.kind == "landmark_filter" => {}
        _ => {
            return Err(ScenarioError::field(
                file,
                "node_experiment.localizer",
                format!(
                    "{:?} names no landmark_filter localizer of this scenario",
                    s.localizer
                ),
            ))
        }
    }
    if s.improvement_min.is_some() && !localizers.iter().any(|l| l.name == s.baseline) {
        return Err(ScenarioError::field(
            file,
            "node_experiment.baseline",
            format!("{:?} names no localizer of this scenario", s.baseline),
        ));
    }
    if !(s.calibration_spread.is_finite() && (0.0..1.0).contains(&s.calibration_spread)) {
        return Err(ScenarioError::field(
            file,
            "node_experiment.calibration_spread",
            format!("must lie in [0, 1), got {}", s.calibration_spread),
        ));
    }
    if s.verified_min == Some(0) {
        return Err(ScenarioError::field(
            file,
            "node_experiment.verified_min",
            "must be at least 1",
        ));
    }
    for (key, v) in [
        ("mean_error_max", s.mean_error_max),
        ("max_error_max", s.max_error_max),
        ("reach_mean_max", s.reach_mean_max),
        ("improvement_min", s.improvement_min),
    ] {
        if let Some(v) = v {
            if !(v.is_finite() && v > 0.0) {
                return Err(ScenarioError::field(
                    file,
                    format!("node_experiment.{key}"),
                    format!("must be a positive number, got {v}"),
                ));
            }
        }
    }
    Ok(s)
}

/// Node errors of one localizer: `errors[node][run]`, m (None: the node was never reached).
#[derive(Debug, Clone, Serialize)]
pub struct NodeTable {
    pub localizer: String,
    pub errors: Vec<Vec<Option<f64>>>,
}

impl NodeTable {
    fn all(&self) -> impl Iterator<Item = f64> + '_ {
        self.errors.iter().flatten().filter_map(|e| *e)
    }

    /// Mean over every node of every run, m.
    pub fn mean(&self) -> Option<f64> {
        let (s, n) = self.all().fold((0.0, 0), |(s, n), e| (s + e, n + 1));
        (n > 0).then(|| s / n as f64)
    }

    pub fn max(&self) -> Option<f64> {
        self.all().reduce(f64::max)
    }

    fn node_mean(&self, node: usize) -> Option<f64> {
        let v: Vec<f64> = self.errors[node].iter().filter_map(|e| *e).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    }

    fn run_mean(&self, run: usize) -> Option<f64> {
        let v: Vec<f64> = self.errors.iter().filter_map(|r| r[run]).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    }
}

/// One expectation of `[node_experiment]` and its outcome.
#[derive(Debug, Clone, Serialize)]
pub struct NodeCheck {
    pub what: String,
    pub limit: f64,
    pub value: Option<f64>,
    pub passed: bool,
}

/// The multi-run experiment: Table II per localizer.
#[derive(Debug, Clone, Serialize)]
pub struct NodeExperiment {
    pub scenario: String,
    /// The landmark filter whose node instants make the table.
    pub filter: String,
    pub seeds: Vec<u64>,
    /// Per run: the odometry's (radius_error, separation_error, scale_error).
    pub calibration: Vec<(f64, f64, f64)>,
    /// The trained node models (γ_n and the γ range seen in training).
    pub models: Vec<NodeModel>,
    pub nodes: Vec<[f64; 2]>,
    /// `verified[node][run]`: whether the landmark verified the node (rather than odometry
    /// reaching it, or the run ending first).
    pub verified: Vec<Vec<bool>>,
    /// `aligned[node][run]`: whether the filter's reset there came from the scan alignment.
    pub aligned: Vec<Vec<bool>>,
    /// Per localizer: its position error at the node instants.
    pub tables: Vec<NodeTable>,
    /// How far the robot really stood from the node at those instants (002 Table II's own
    /// measure: "the difference between an ideal node … and the robot's current pose when
    /// reaching this node").
    pub reach: NodeTable,
    pub checks: Vec<NodeCheck>,
    /// With `paper_reset`: the same experiment with 002's reset (its own runs, same seeds and
    /// calibrations; no checks).
    pub paper: Option<Box<NodeExperiment>>,
}

impl NodeExperiment {
    pub fn passed(&self) -> bool {
        self.checks.iter().all(|c| c.passed)
    }

    pub fn table(&self, localizer: &str) -> Option<&NodeTable> {
        self.tables.iter().find(|t| t.localizer == localizer)
    }

    /// Table II as the paper prints it: node error per run in millimetres, with the averages
    /// per node and per run; one table per localizer. A `*` marks a node reached by odometry
    /// without the landmark verifying it.
    pub fn to_text(&self) -> String {
        let mut s = format!(
            "{}: node errors over {} runs (seeds {:?}), millimetres\n",
            self.scenario,
            self.seeds.len(),
            self.seeds
        );
        // The scale error is printed only where some run has one (older tables unchanged).
        if self.calibration.iter().any(|c| c.2 != 0.0) {
            s.push_str(
                "odometry calibration per run (radius_error, separation_error, scale_error):",
            );
            for (a, b, c) in &self.calibration {
                s.push_str(&format!(" ({a:.4}, {b:.4}, {c:.4})"));
            }
        } else {
            s.push_str("odometry calibration per run (radius_error, separation_error):");
            for (a, b, _) in &self.calibration {
                s.push_str(&format!(" ({a:.4}, {b:.4})"));
            }
        }
        s.push('\n');
        s.push_str(&self.tables_text());
        if let Some(p) = &self.paper {
            s.push_str(&format!(
                "\n--- {:?} with 002's reset (Table I: x, y := node, heading kept), same seeds \
                 and calibrations, runs of its own ---\n",
                p.filter
            ));
            s.push_str(&p.tables_text());
        }
        s.push_str(&self.summary());
        if !self.checks.is_empty() {
            s.push('\n');
            for c in &self.checks {
                s.push_str(&format!(
                    "{} {} (limit {}): {}\n",
                    if c.passed { "PASS" } else { "FAIL" },
                    c.what,
                    c.limit,
                    c.value.map_or("-".to_string(), |v| format!("{v:.4}"))
                ));
            }
        }
        s
    }

    /// The trained models and the node tables (no title, summary or checks).
    fn tables_text(&self) -> String {
        let mut s = String::new();
        s.push_str(
            "trained nodes: gamma_n | largest gamma inside rho | smallest gamma beyond 2 rho\n",
        );
        for (n, m) in self.models.iter().enumerate() {
            s.push_str(&format!(
                "{:>6}  {:.3e} | {:.3e} | {}\n",
                n + 1,
                m.gamma_n,
                m.gamma_inside_max,
                m.gamma_outside_min
                    .map_or("-".into(), |g| format!("{g:.3e}"))
            ));
        }
        for t in self.tables.iter().chain(std::iter::once(&self.reach)) {
            s.push_str(&format!("\n{}\n{:>6}", t.localizer, "node"));
            for r in 1..=self.seeds.len() {
                s.push_str(&format!("{r:>10}"));
            }
            s.push_str(&format!("{:>10}\n", "average"));
            let cell = |e: Option<f64>| e.map_or("-".to_string(), |e| format!("{:.1}", 1000.0 * e));
            for (n, row) in t.errors.iter().enumerate() {
                s.push_str(&format!("{:>6}", n + 1));
                for (r, e) in row.iter().enumerate() {
                    let mark = if self.verified[n][r] { "" } else { "*" };
                    s.push_str(&format!("{:>10}", format!("{}{mark}", cell(*e))));
                }
                s.push_str(&format!("{:>10}\n", cell(t.node_mean(n))));
            }
            s.push_str(&format!("{:>6}", "avg"));
            for r in 0..self.seeds.len() {
                s.push_str(&format!("{:>10}", cell(t.run_mean(r))));
            }
            s.push_str(&format!("{:>10}\n", cell(t.mean())));
        }
        if self.verified.iter().flatten().any(|v| !v) {
            s.push_str("\n* reached by odometry, not verified by the landmark\n");
        }
        s
    }
}

impl NodeExperiment {
    /// One line per method: nodes verified, mean and largest node error, mm.
    fn summary(&self) -> String {
        let verified = |e: &NodeExperiment| {
            let v = e.verified.iter().flatten().filter(|v| **v).count();
            format!("{v}/{}", e.verified.iter().flatten().count())
        };
        let mm = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{:.1}", 1000.0 * v));
        let mut s = format!(
            "\nsummary over seeds {:?}: method | nodes verified | mean node error | largest, mm\n",
            self.seeds
        );
        let mut rows: Vec<(String, &NodeExperiment, &NodeTable)> = Vec::new();
        if let Some(f) = self.table(&self.filter) {
            rows.push((format!("{} (as configured)", f.localizer), self, f));
        }
        if let Some(p) = &self.paper {
            if let Some(f) = p.table(&p.filter) {
                rows.push((format!("{} with 002's reset", f.localizer), p, f));
            }
            for t in p.tables.iter().filter(|t| t.localizer != p.filter) {
                rows.push((format!("{} (runs of 002's reset)", t.localizer), p, t));
            }
        }
        for t in self.tables.iter().filter(|t| t.localizer != self.filter) {
            rows.push((format!("{} (runs of the first row)", t.localizer), self, t));
        }
        for (name, e, t) in rows {
            s.push_str(&format!(
                "  {name:<44} {:>7} {:>9} {:>9}\n",
                verified(e),
                mm(t.mean()),
                mm(t.max())
            ));
        }
        s
    }
}

/// Ground truth and a localizer's estimate at the scoring instant nearest `t`.
fn nearest(samples: &[(f64, Pose2)], t: f64) -> Option<Pose2> {
    let i = samples.partition_point(|(s, _)| *s < t);
    let candidates = [i.checked_sub(1), Some(i)];
    candidates
        .into_iter()
        .flatten()
        .filter_map(|j| samples.get(j))
        .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs()))
        .map(|(_, p)| *p)
}

/// Runs the scenario `runs` times (seeds `seed`, `seed + 1`, …; `runs` defaults to
/// `[node_experiment] runs`) and tabulates, per localizer, the position error at the instant
/// the filter updated at each node (002 §IV-A: "the difference between an ideal node … and
/// the robot's current pose when reaching this node"). For the filter that is the error of
/// its pose right after the reset (under Table I's reset, the distance from the node to the
/// true pose); for the others, their own estimate's error at the same instant of the same
/// run; and the `reach` table holds the true distance of the robot from the node.
pub fn run_experiment(
    registry: &LocalizerRegistry,
    scenario: &Scenario,
    runs: Option<usize>,
) -> Result<NodeExperiment, ScenarioError> {
    let file = &scenario.file;
    let table = scenario.node_experiment.as_ref().ok_or_else(|| {
        ScenarioError::field(
            file,
            "node_experiment",
            "the scenario has no [node_experiment] table",
        )
    })?;
    let settings = &parse_settings(
        file,
        table,
        &scenario.localizers,
        scenario.node_route.as_ref(),
    )?;
    let route = scenario
        .node_route
        .as_ref()
        .ok_or_else(|| ScenarioError::field(file, "route.controller", "not a node route"))?;
    let runs = match runs {
        Some(runs) => {
            check_runs(runs).map_err(|msg| ScenarioError::field(file, "--runs", msg))?;
            runs
        }
        None => settings.runs,
    };
    let seeds: Vec<u64> = (0..runs as u64)
        .map(|i| scenario.seed.wrapping_add(i))
        .collect();
    let mut exp = run_variant(registry, scenario, route, settings, &seeds)?;
    exp.checks = checks(&exp, settings);
    if settings.paper_reset {
        // 002's own method: the same filter with Table I's reset and the γ_n of Fig. 4c.
        let mut paper = scenario.clone();
        let spec = paper
            .localizers
            .iter_mut()
            .find(|l| l.name == settings.localizer)
            .ok_or_else(|| ScenarioError::field(file, "node_experiment.localizer", "not found"))?;
        spec.params
            .insert("scan_alignment".into(), toml::Value::Boolean(false));
        spec.params
            .insert("gamma_rule".into(), toml::Value::String("rim".into()));
        // The ρ/2 model disk of the default: Table I's reset inherits where the robot
        // stands, so the node's model must be where the robot should be, not the whole
        // disk it may cross.
        spec.params.remove("model_radius");
        exp.paper = Some(Box::new(run_variant(
            registry, &paper, route, settings, &seeds,
        )?));
    }
    Ok(exp)
}

/// The runs of one filter configuration (seeds `seeds`, each with its drawn calibration),
/// without checks.
fn run_variant(
    registry: &LocalizerRegistry,
    scenario: &Scenario,
    route: &NodeRoute,
    settings: &NodeExperimentSettings,
    seeds: &[u64],
) -> Result<NodeExperiment, ScenarioError> {
    let file = &scenario.file;
    let runs = seeds.len();
    let spec = scenario
        .localizers
        .iter()
        .find(|l| l.name == settings.localizer)
        .ok_or_else(|| ScenarioError::field(file, "node_experiment.localizer", "not found"))?;
    let models = trained_models(spec, scenario)?;
    let mut calibration = Vec::with_capacity(runs);
    let nn = route.nodes.len();
    let mut verified = vec![vec![false; runs]; nn];
    let mut aligned = vec![vec![false; runs]; nn];
    let mut reach = NodeTable {
        localizer: "true distance of the robot from the node (002 Table II's measure)".into(),
        errors: vec![vec![None; runs]; nn],
    };
    let mut tables: Vec<NodeTable> = scenario
        .localizers
        .iter()
        .map(|l| NodeTable {
            localizer: l.name.clone(),
            errors: vec![vec![None; runs]; nn],
        })
        .collect();
    for (r, seed) in seeds.iter().enumerate() {
        let mut run = scenario.clone();
        let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(*seed, "node_experiment/calibration"));
        let spread = settings.calibration_spread;
        if spread > 0.0 {
            run.odometry.radius_error *= rng.random_range(1.0 - spread..=1.0 + spread);
            run.odometry.separation_error *= rng.random_range(1.0 - spread..=1.0 + spread);
            // Drawn after the other two, so scenarios without a scale error keep their runs.
            run.odometry.scale_error *= rng.random_range(1.0 - spread..=1.0 + spread);
        }
        calibration.push((
            run.odometry.radius_error,
            run.odometry.separation_error,
            run.odometry.scale_error,
        ));
        let result: RunResult = registry.run(
            &run,
            RunOptions {
                seed: Some(*seed),
                ..Default::default()
            },
        )?;
        let filter = result
            .localizers
            .iter()
            .find(|l| l.name == settings.localizer)
            .ok_or_else(|| ScenarioError::field(file, "node_experiment.localizer", "not run"))?;
        for ev in &filter.node_events {
            if ev.node >= nn {
                continue;
            }
            verified[ev.node][r] = ev.verified;
            aligned[ev.node][r] = ev.aligned;
            let Some(truth) = nearest(&result.ground_truth, ev.stamp) else {
                continue;
            };
            let n = route.nodes[ev.node];
            reach.errors[ev.node][r] = Some((truth.x - n[0]).hypot(truth.y - n[1]));
            for (t, run) in tables.iter_mut().zip(&result.localizers) {
                // The filter's estimate at its own event is its pose right after the reset
                // (the node itself under Table I; the aligned pose with scan_alignment).
                let est = if run.name == settings.localizer {
                    Some(ev.pose)
                } else {
                    nearest(&run.trajectory, ev.stamp)
                };
                t.errors[ev.node][r] = est.map(|e| e.distance(&truth));
            }
        }
    }
    Ok(NodeExperiment {
        scenario: scenario.name.clone(),
        filter: settings.localizer.clone(),
        seeds: seeds.to_vec(),
        calibration,
        models,
        nodes: route.nodes.clone(),
        verified,
        aligned,
        tables,
        reach,
        checks: Vec::new(),
        paper: None,
    })
}

fn checks(exp: &NodeExperiment, s: &NodeExperimentSettings) -> Vec<NodeCheck> {
    let mut out = Vec::new();
    let filter = exp.table(&s.localizer);
    if s.all_verified {
        let n = exp.verified.iter().flatten().filter(|v| !**v).count();
        out.push(NodeCheck {
            what: format!("{}: nodes not verified", s.localizer),
            limit: 0.0,
            value: Some(n as f64),
            passed: n == 0,
        });
    }
    if let Some(limit) = s.verified_min {
        let n = exp.verified.iter().flatten().filter(|v| **v).count();
        out.push(NodeCheck {
            what: format!("{}: nodes verified by the landmark, at least", s.localizer),
            limit: limit as f64,
            value: Some(n as f64),
            passed: n >= limit,
        });
    }
    let mean = filter.and_then(NodeTable::mean);
    if let Some(limit) = s.mean_error_max {
        out.push(NodeCheck {
            what: format!("{}: mean node error, m, at most", s.localizer),
            limit,
            value: mean,
            passed: mean.is_some_and(|v| v <= limit),
        });
    }
    if let Some(limit) = s.reach_mean_max {
        let v = exp.reach.mean();
        out.push(NodeCheck {
            what: "mean true distance of the robot from the node, m, at most".into(),
            limit,
            value: v,
            passed: v.is_some_and(|v| v <= limit),
        });
    }
    if let Some(limit) = s.max_error_max {
        let v = filter.and_then(NodeTable::max);
        out.push(NodeCheck {
            what: format!("{}: largest node error, m, at most", s.localizer),
            limit,
            value: v,
            passed: v.is_some_and(|v| v <= limit),
        });
    }
    if let Some(limit) = s.improvement_min {
        let base = exp.table(&s.baseline).and_then(NodeTable::mean);
        let v = match (base, mean) {
            (Some(b), Some(m)) if m > 0.0 => Some(b / m),
            _ => None,
        };
        out.push(NodeCheck {
            what: format!(
                "{} mean node error / {} mean node error, at least",
                s.baseline, s.localizer
            ),
            limit,
            value: v,
            passed: v.is_some_and(|v| v >= limit),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_sample_is_found_on_either_side() {
        let s = [
            (0.1, Pose2::new(1.0, 0.0, 0.0)),
            (0.2, Pose2::new(2.0, 0.0, 0.0)),
            (0.3, Pose2::new(3.0, 0.0, 0.0)),
        ];
        assert_eq!(nearest(&s, 0.21).unwrap().x, 2.0);
        assert_eq!(nearest(&s, 0.27).unwrap().x, 3.0);
        assert_eq!(nearest(&s, 5.0).unwrap().x, 3.0);
        assert_eq!(nearest(&s, 0.0).unwrap().x, 1.0);
        assert!(nearest(&[], 0.0).is_none());
    }

    #[test]
    fn table_statistics_skip_missing_nodes() {
        let t = NodeTable {
            localizer: "f".into(),
            errors: vec![vec![Some(0.2), Some(0.3)], vec![None, Some(0.4)]],
        };
        assert!((t.mean().unwrap() - 0.3).abs() < 1e-12);
        assert_eq!(t.max(), Some(0.4));
        assert_eq!(t.node_mean(1), Some(0.4));
        assert!((t.run_mean(1).unwrap() - 0.35).abs() < 1e-12);
    }
}

#[cfg(test)]
mod scenario_tests {
    use super::*;

    fn scenario(route: &str, localizer: &str) -> Result<Scenario, ScenarioError> {
        let dir = env!("CARGO_MANIFEST_DIR");
        let text = format!(
            "name = \"t\"\nworld = \"{dir}/../worlds/campus.toml\"\n\
             robot = \"{dir}/../robots/urdf/wheelchair.urdf\"\nduration_s = 120.0\n\
             [start]\npose = [12.4, 22.4, 0.0]\n[route]\n{route}\n\
             [[localizers]]\nname = \"filter\"\nkind = \"landmark_filter\"\n{localizer}\n"
        );
        Scenario::from_toml_str(&text, Path::new("t.toml"))
    }

    #[test]
    fn bad_node_routes_are_rejected_naming_the_field() {
        let e = scenario("controller = \"nodes\"\nnodes = []", "")
            .unwrap_err()
            .to_string();
        assert!(e.contains("route.nodes") && e.contains("empty"), "{e}");
        // (10.0, 20.0) is in the office corridor; (11.05, 30.0) is on ne1's west wall.
        let e = scenario(
            "controller = \"nodes\"\nnodes = [[16.0, 23.0], [11.05, 30.0]]",
            "",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("route.nodes[1]") && e.contains("inside a wall"),
            "{e}"
        );
        let e = scenario(
            "controller = \"nodes\"\nnodes = [[16.0, 23.0]]\ngamma_d = 0.0",
            "",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("gamma_d"), "{e}");
        let e = scenario("controller = \"spline\"\nnodes = [[16.0, 23.0]]", "")
            .unwrap_err()
            .to_string();
        assert!(e.contains("route.controller"), "{e}");
        let e = scenario("waypoints = [[16.0, 23.0]]\nnodes = [[16.0, 23.0]]", "")
            .unwrap_err()
            .to_string();
        assert!(e.contains("route.nodes") && e.contains("controller"), "{e}");
    }

    #[test]
    fn odometry_scale_error_is_read_and_checked() {
        let route = "controller = \"nodes\"\nnodes = [[16.0, 23.0]]";
        let s = scenario(route, "[odometry]\nscale_error = -0.03").unwrap();
        assert_eq!(s.odometry.scale_error, -0.03);
        // The wheelchair's sensor file has none: 0, the model without it.
        assert_eq!(scenario(route, "").unwrap().odometry.scale_error, 0.0);
        for bad in ["1.0", "-1.5", "nan", "inf"] {
            let e = scenario(route, &format!("[odometry]\nscale_error = {bad}"))
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("t.toml: odometry.scale_error: must be"),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn rho_must_be_positive_and_the_filter_needs_a_node_route() {
        for rho in ["0.0", "-0.25"] {
            let s = scenario(
                "controller = \"nodes\"\nnodes = [[16.0, 23.0]]",
                &format!("rho = {rho}"),
            )
            .unwrap();
            let e = atrium_scenarios::run_scenario(&s, RunOptions::default())
                .err()
                .unwrap()
                .to_string();
            assert!(e.contains("localizers[filter]") && e.contains("rho"), "{e}");
        }
        let s = scenario("waypoints = [[16.0, 23.0]]", "").unwrap();
        let e = atrium_scenarios::run_scenario(&s, RunOptions::default())
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("node route"), "{e}");
    }

    #[test]
    fn a_node_is_verified_near_it_and_the_chair_stops_there() {
        // One 3.8 m leg toward the south-east cabinet of ne1 with exact odometry: the filter
        // verifies the node while the chair is within ρ of it, and resets its pose to it.
        let mut s = scenario(
            "controller = \"nodes\"\nnodes = [[16.2, 23.2]]\nsettle_s = 1.0",
            "",
        )
        .unwrap();
        s.odometry.radius_error = 0.0;
        s.odometry.separation_error = 0.0;
        let r = atrium_scenarios::run_scenario(&s, RunOptions::default()).unwrap();
        let f = &r.localizers[0];
        assert_eq!(f.node_events.len(), 1);
        let ev = f.node_events[0];
        assert!(ev.verified, "{ev:?}");
        let truth = nearest(&r.ground_truth, ev.stamp).unwrap();
        let d = (truth.x - 16.2).hypot(truth.y - 23.2);
        assert!(d <= 0.25, "verified {d} m from the node");
        assert!(r.route_completed);
        // The reset is the aligned pose, which matches the truth far better than ρ.
        assert!(
            ev.aligned && ev.pose.distance(&truth) < 0.03,
            "{ev:?} vs {truth:?}"
        );
    }

    #[test]
    fn the_aligned_reset_corrects_the_heading_that_odometry_lost() {
        // Start facing north: the chair turns 78° to the node on a track 3 % off, so its
        // odometry heading is ~2° wrong at the node. The paper's reset keeps that heading;
        // the aligned reset measures it from the scan.
        let mut s = scenario(
            "controller = \"nodes\"\nnodes = [[16.2, 23.2]]\nsettle_s = 0.5",
            "",
        )
        .unwrap();
        s.start = Pose2::new(12.4, 22.4, std::f64::consts::FRAC_PI_2);
        s.odometry.separation_error = 0.03;
        let r = atrium_scenarios::run_scenario(&s, RunOptions::default()).unwrap();
        let ev = r.localizers[0].node_events[0];
        let truth = nearest(&r.ground_truth, ev.stamp).unwrap();
        assert!(ev.verified && ev.aligned, "{ev:?}");
        let th = |p: &Pose2| atrium_robots::normalize_angle(p.theta - truth.theta).abs();
        assert!(th(&ev.pose) < 0.3f64.to_radians(), "{ev:?} vs {truth:?}");
        assert!(ev.pose.distance(&truth) < 0.03, "{ev:?} vs {truth:?}");
        // Without alignment the heading error stays what odometry accumulated (> 1°).
        let mut paper = s.clone();
        paper.localizers[0]
            .params
            .insert("scan_alignment".into(), toml::Value::Boolean(false));
        let r = atrium_scenarios::run_scenario(&paper, RunOptions::default()).unwrap();
        let ev = r.localizers[0].node_events[0];
        let truth = nearest(&r.ground_truth, ev.stamp).unwrap();
        assert!(ev.verified && !ev.aligned, "{ev:?}");
        assert_eq!((ev.pose.x, ev.pose.y), (16.2, 23.2));
        let err = atrium_robots::normalize_angle(ev.pose.theta - truth.theta).abs();
        assert!(err > 1f64.to_radians(), "heading error {err} rad");
    }
}
