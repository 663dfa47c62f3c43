//! The runner: the simulator's time-ordered reading stream goes to every localizer, and each
//! estimate is scored against the ground truth of the same instant.

use crate::error::ScenarioError;
use crate::expect::{self, ExpectationResult, MetricSource};
use crate::metrics::{self, LocalizerMetrics, Sample};
use crate::scenario::{Event, Scenario};
use crate::seeds::derive_seed;
use atrium_localization::{Estimate, Localizer, LocalizerError, OdometryDelta};
use atrium_robots::{Pose2, Reading};
use atrium_sim::Simulation;
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::Instant;

/// Per-run choices that are not part of the scenario.
#[derive(Default)]
pub struct RunOptions<'a> {
    /// Replaces the scenario's seed.
    pub seed: Option<u64>,
    /// Called now and then with (simulated time, scenario duration).
    pub progress: Option<&'a mut dyn FnMut(f64, f64)>,
    /// Sees every instant of the run (the MCAP recorder).
    pub observer: Option<&'a mut dyn RunObserver>,
}

/// One localizer's run.
#[derive(Debug, Clone, Serialize)]
pub struct LocalizerRun {
    pub name: String,
    pub kind: String,
    /// Estimates at the scoring instants.
    #[serde(skip)]
    pub trajectory: Vec<(f64, Pose2)>,
    #[serde(skip)]
    pub samples: Vec<Sample>,
    pub metrics: Option<LocalizerMetrics>,
    /// Per kidnapping: seconds until the localizer converged again (None: never).
    pub recoveries: Vec<Option<f64>>,
    pub expectations: Vec<ExpectationResult>,
    pub passed: bool,
    /// Wall-clock seconds spent inside this localizer.
    #[serde(skip)]
    pub cpu_s: f64,
    /// Map, covariance monitor and snapshots of an EKF-SLAM localizer.
    #[serde(skip)]
    pub slam: Option<crate::slam::SlamRun>,
    /// What a landmark filter did at each node of a node route (empty otherwise).
    #[serde(skip)]
    pub node_events: Vec<atrium_localization::landmark_filter::NodeEvent>,
    /// Text the localizer kept with the run (a process localizer's stderr; see
    /// `Capabilities::log`); `--out` writes it to `log_<localizer>.txt`.
    #[serde(skip)]
    pub log: Option<String>,
    /// On a real log with benchmark relations: the relations metric of [Kümmerle 2009].
    pub relations: Option<crate::relations::RelationsScore>,
}

/// Wall-clock figures, kept apart from the results because they vary between runs.
#[derive(Debug, Clone, Serialize)]
pub struct Timing {
    pub wall_s: f64,
    pub real_time_factor: f64,
    pub physics_steps: u64,
    /// Seconds spent in the simulator (physics, sensors).
    pub sim_s: f64,
    /// Seconds per localizer, in scenario order.
    pub localizers_s: Vec<(String, f64)>,
}

#[derive(Debug, Clone)]
pub struct RunResult {
    pub scenario: String,
    /// The scenario's `description`: what the run shows (printed under the report's title,
    /// so a designed failure is not mistaken for a bug).
    pub description: String,
    pub seed: u64,
    pub world: String,
    pub robot: String,
    pub sim_time_s: f64,
    pub distance_m: f64,
    pub route_completed: bool,
    pub events: Vec<Event>,
    /// Ground truth at the scoring instants, and the region (name, kind) it lies in.
    pub ground_truth: Vec<(f64, Pose2)>,
    pub regions: Vec<Option<(String, String)>>,
    pub localizers: Vec<LocalizerRun>,
    pub timing: Timing,
    /// What a run on a real log scored against (`None` for a simulated run).
    pub log: Option<LogRunInfo>,
}

/// What a run on a real log was scored against, for reports.
#[derive(Debug, Clone, Serialize)]
pub struct LogRunInfo {
    pub path: String,
    pub scan_topic: String,
    pub odom_topic: String,
    /// The log time of the run's t = 0, s: add it to a run time to get the log's stamp.
    pub t0: f64,
    pub scans: usize,
    pub reference: String,
    /// Instants scored against the reference.
    pub scored_instants: usize,
    /// Scans the reference does not cover, which are not scored.
    pub unscored_scans: usize,
    pub reference_accuracy: Option<crate::log::ReferenceAccuracy>,
    pub laser_mount: [f64; 3],
    pub laser_mount_source: String,
    pub relations: Option<String>,
}

impl RunResult {
    /// The offset from the run's clock to the recording's own stamps (0 for a simulated run).
    pub fn time_offset_s(&self) -> f64 {
        self.log.as_ref().map_or(0.0, |l| l.t0)
    }

    pub fn passed(&self) -> bool {
        self.localizers.iter().all(|l| l.passed)
    }
}

/// NEES over (x, y) when the covariance is usable.
fn nees_xy(err: [f64; 2], cov: &nalgebra::Matrix3<f64>) -> Option<f64> {
    let (a, b, c) = (cov[(0, 0)], cov[(0, 1)], cov[(1, 1)]);
    let det = a * c - b * b;
    if !(det.is_finite() && det > 1e-18) {
        return None;
    }
    Some((c * err[0] * err[0] - 2.0 * b * err[0] * err[1] + a * err[1] * err[1]) / det)
}

/// One instant of a reading stream: the readings stamped at it are in the caller's buffer.
#[derive(Debug, Clone, Default)]
pub struct Tick {
    /// Stream time, s (sim time for a live run).
    pub t: f64,
    /// Ground truth at `t`, when the stream knows it (always for a live run; a recording
    /// holds it only at the scoring instants).
    pub truth: Option<Pose2>,
    /// Whether the localizers are scored at this instant (then `truth` is `Some`).
    pub score: bool,
    /// Events that took effect just before this instant (a kidnapping moves the robot before
    /// the step whose readings follow).
    pub events: Vec<Event>,
}

/// What a stream knows about the whole run once it has ended.
#[derive(Debug, Clone, Default)]
pub struct StreamSummary {
    pub sim_time_s: f64,
    pub distance_m: f64,
    pub route_completed: bool,
    pub physics_steps: u64,
    /// Seconds spent producing the stream (simulating, or decoding a recording).
    pub source_s: f64,
}

/// A time-ordered stream of readings with ground truth: the live simulator
/// ([`SimStream`]) or a recording (`dataset::replay`). The runner's consumption and scoring
/// loop takes its input from either, which is what makes a replay score exactly like the
/// live run it recorded.
pub trait ReadingStream {
    /// Clears `readings`, fills it with the next instant's readings in the order the
    /// localizers must see them (odometry before the sensors of the same instant), and
    /// returns that instant; `None` once the stream has ended.
    fn next(&mut self, readings: &mut Vec<Reading>) -> Result<Option<Tick>, ScenarioError>;
    /// Totals of the run, valid once `next` has returned `None`.
    fn summary(&self) -> StreamSummary;
    /// A localizer verified node `node` of a node route (002 Algorithm 1): a live robot stops
    /// and its node controller takes the localizer's `pose` after the reset; a recording
    /// already holds what happened.
    fn verify_node(&mut self, _node: usize, _pose: Pose2) {}
    /// The pedestrians at the current instant, when the stream has any (a live run with
    /// `[people]`; recordings replay readings, not people).
    fn people(&self) -> Option<PeopleFrame<'_>> {
        None
    }
}

/// Where the pedestrians are at one instant, for observers that draw them.
#[derive(Debug, Clone, Copy)]
pub struct PeopleFrame<'a> {
    /// Centres of the people's discs on the floor, world frame, m.
    pub positions: &'a [[f64; 2]],
    pub radius: f64,
    pub height: f64,
}

/// Watches a run as it is consumed (the MCAP recorder is one). Called once per instant after
/// the localizers have seen its readings, with their estimates at scoring instants.
pub trait RunObserver {
    fn instant(
        &mut self,
        tick: &Tick,
        readings: &[Reading],
        estimates: Option<&[Estimate]>,
    ) -> Result<(), ScenarioError>;
    /// Called after [`RunObserver::instant`] at every instant of a run with people.
    fn people(&mut self, _tick: &Tick, _people: &PeopleFrame<'_>) -> Result<(), ScenarioError> {
        Ok(())
    }
}

/// The live stream: the scenario's simulation, stepped at `physics_hz`, its events applied on
/// time, scored every `physics_hz / eval_hz` steps, until `duration_s` or `settle_s` after the
/// route's end.
pub struct SimStream<'a> {
    scenario: &'a Scenario,
    sim: Simulation,
    dt: f64,
    eval_every: f64,
    next_eval: f64,
    step: u64,
    next_event: usize,
    finished_at: Option<f64>,
    distance: f64,
    prev_gt: Pose2,
    sim_s: f64,
}

/// A simulator error under the scenario field it is about: a spawn collision is the start
/// pose's, a bad world the world file's, a bad robot the robot file's; anything else names the
/// simulator's own field.
fn sim_error(scenario: &Scenario, e: atrium_sim::SimError) -> ScenarioError {
    let field = match &e {
        atrium_sim::SimError::Spawn { .. } => "start.pose".to_string(),
        atrium_sim::SimError::World { .. } => "world".to_string(),
        atrium_sim::SimError::Robot { .. } => "robot".to_string(),
        atrium_sim::SimError::Config { .. } => "simulation".to_string(),
    };
    ScenarioError::field(&scenario.file, field, e.to_string())
}

impl<'a> SimStream<'a> {
    /// The simulation of `scenario` with the simulator's stream derived from `seed`.
    pub fn new(scenario: &'a Scenario, seed: u64) -> Result<Self, ScenarioError> {
        let config = scenario.sim_config(derive_seed(seed, "sim"));
        let mut sim = Simulation::new(&scenario.world, &scenario.robot, config)
            .map_err(|e| sim_error(scenario, e))?;
        // A run reads the scene only through the simulation's own sensors.
        sim.set_people_placement(atrium_sim::PeoplePlacement::SensorInstants);
        match &scenario.node_route {
            Some(route) => sim
                .set_node_route(&route.nodes, route.params)
                .map_err(|e| ScenarioError::field(&scenario.file, "route", e.to_string()))?,
            None => {
                sim.set_route(&crate::route_jitter::jittered_waypoints(
                    &scenario.world,
                    [scenario.start.x, scenario.start.y],
                    &scenario.waypoints,
                    scenario.route_jitter,
                    seed,
                ));
                if !scenario.route_speeds.is_empty() {
                    sim.set_leg_speeds(&scenario.route_speeds).map_err(|e| {
                        ScenarioError::field(&scenario.file, "route.speeds", e.to_string())
                    })?;
                }
            }
        }
        let eval_every = scenario.physics_hz / scenario.eval_hz;
        Ok(SimStream {
            prev_gt: sim.ground_truth(),
            scenario,
            sim,
            dt: 1.0 / scenario.physics_hz,
            eval_every,
            next_eval: eval_every,
            step: 0,
            next_event: 0,
            finished_at: None,
            distance: 0.0,
            sim_s: 0.0,
        })
    }

    pub fn simulation(&self) -> &Simulation {
        &self.sim
    }
}

impl ReadingStream for SimStream<'_> {
    fn next(&mut self, readings: &mut Vec<Reading>) -> Result<Option<Tick>, ScenarioError> {
        let scenario = self.scenario;
        readings.clear();
        let t = self.sim.time();
        if t >= scenario.duration_s - 0.5 * self.dt {
            return Ok(None);
        }
        if let Some(done) = self.finished_at {
            if t >= done + scenario.settle_s {
                return Ok(None);
            }
        }
        let mut events = Vec::new();
        while let Some(ev) = scenario.events.get(self.next_event) {
            if ev.at_s() > t {
                break;
            }
            match ev {
                Event::Kidnap { to, .. } => {
                    self.sim.teleport(*to).map_err(|e| {
                        ScenarioError::field(
                            &scenario.file,
                            format!("events[{}].to", self.next_event),
                            e.to_string(),
                        )
                    })?;
                    self.prev_gt = *to;
                }
            }
            events.push(*ev);
            self.next_event += 1;
        }

        let t0 = Instant::now();
        let gt = self.sim.step(readings);
        self.sim_s += t0.elapsed().as_secs_f64();
        self.step += 1;
        self.distance += self.prev_gt.distance(&gt);
        self.prev_gt = gt;
        if self.finished_at.is_none() && self.sim.route_finished() {
            self.finished_at = Some(self.sim.time());
        }
        let score = self.step as f64 + 1e-9 >= self.next_eval;
        if score {
            self.next_eval += self.eval_every;
        }
        Ok(Some(Tick {
            t: self.sim.time(),
            truth: Some(gt),
            score,
            events,
        }))
    }

    fn verify_node(&mut self, node: usize, pose: Pose2) {
        self.sim.verify_node(node, Some(pose));
    }

    fn people(&self) -> Option<PeopleFrame<'_>> {
        self.sim.people().map(|p| PeopleFrame {
            positions: p.positions(),
            radius: p.params().radius,
            height: p.params().height,
        })
    }

    fn summary(&self) -> StreamSummary {
        StreamSummary {
            sim_time_s: self.sim.time(),
            distance_m: self.distance,
            route_completed: self.finished_at.is_some(),
            physics_steps: self.step,
            source_s: self.sim_s,
        }
    }
}

/// The consumption and scoring loop: every reading of `stream` goes to every localizer of
/// `localizers` (built for `scenario`'s `[[localizers]]` entries, in order, e.g. by the
/// localizer registry), each scoring instant is scored against the stream's ground truth, and
/// the expectations are checked. `events` are the events the stream's run went through (their
/// times anchor the recovery metrics). A localizer that fails ends the run with an error
/// naming it, the reading and the instant.
pub fn run_localizers(
    scenario: &Scenario,
    seed: u64,
    stream: &mut dyn ReadingStream,
    events: &[Event],
    mut localizers: Vec<Box<dyn Localizer>>,
    mut options: RunOptions,
) -> Result<RunResult, ScenarioError> {
    let started = Instant::now();
    // Checked before the run, so a typo in `[expect]` costs no simulation.
    let expectations = expect::parse_expectations(scenario)?;
    if localizers.len() != scenario.localizers.len() {
        return Err(ScenarioError::field(
            &scenario.file,
            "localizers",
            format!(
                "{} localizers were built for {} [[localizers]] entries",
                localizers.len(),
                scenario.localizers.len()
            ),
        ));
    }
    let n = localizers.len();
    let mut trajectories: Vec<Vec<(f64, Pose2)>> = vec![Vec::new(); n];
    let mut samples: Vec<Vec<Sample>> = vec![Vec::new(); n];
    let mut cpu = vec![0.0f64; n];
    // Per chooser: scored instants at which each member was its output.
    let mut chosen: Vec<BTreeMap<String, usize>> = vec![BTreeMap::new(); n];
    let mut ground_truth = Vec::new();
    let mut regions = Vec::new();
    let mut estimates: Vec<Estimate> = Vec::with_capacity(n);

    let mut readings: Vec<Reading> = Vec::new();
    let mut last_odom: Option<Pose2> = None;

    // A localizer's failure ends the run; the logs of all are kept with the error (below).
    let mut failure: Option<ScenarioError> = None;
    'ticks: while let Some(tick) = stream.next(&mut readings)? {
        for r in &readings {
            match r {
                Reading::Odometry(o) => {
                    if let Some(from) = last_odom {
                        let delta = OdometryDelta {
                            stamp: o.stamp,
                            from,
                            to: o.pose,
                        };
                        for (l, c) in localizers.iter_mut().zip(cpu.iter_mut()) {
                            let t1 = Instant::now();
                            if let Err(e) = l.predict(&delta) {
                                failure = Some(failed(l.as_ref(), "odometry", o.stamp, e));
                                break 'ticks;
                            }
                            *c += t1.elapsed().as_secs_f64();
                        }
                    }
                    last_odom = Some(o.pose);
                }
                other => {
                    for (l, c) in localizers.iter_mut().zip(cpu.iter_mut()) {
                        let t1 = Instant::now();
                        if let Err(e) = l.update(other) {
                            failure =
                                Some(failed(l.as_ref(), reading_kind(other), other.stamp(), e));
                            break 'ticks;
                        }
                        *c += t1.elapsed().as_secs_f64();
                    }
                }
            }
        }

        // Closes the loop of a node route: the robot stops at a node the landmark verified.
        for l in localizers.iter_mut() {
            let verified = l.capabilities().and_then(|c| c.take_node_verification());
            if let Some(node) = verified {
                // The controller steers on the localizer's pose after its reset (002
                // Algorithm 1 line 14), not on a separate copy that kept the old offsets.
                stream.verify_node(node, l.estimate().pose);
            }
        }

        let scored = match (tick.score, tick.truth) {
            (true, Some(gt)) => {
                let now = tick.t;
                ground_truth.push((now, gt));
                regions.push(scenario.world.region_at([gt.x, gt.y]).map(|r| {
                    let kind = serde_json::to_value(r.kind)
                        .ok()
                        .and_then(|v| v.as_str().map(str::to_string))
                        .unwrap_or_default();
                    (r.name.clone(), kind)
                }));
                estimates.clear();
                for (i, l) in localizers.iter_mut().enumerate() {
                    if let Some(member) = l.capabilities().and_then(|c| c.chosen_member()) {
                        match chosen[i].get_mut(member) {
                            Some(k) => *k += 1,
                            None => {
                                chosen[i].insert(member.to_owned(), 1);
                            }
                        }
                    }
                    let est = l.estimate();
                    trajectories[i].push((now, est.pose));
                    samples[i].push(Sample {
                        t: now,
                        position_error: est.pose.distance(&gt),
                        heading_error: est.pose.heading_error(&gt),
                        nees_xy: nees_xy([est.pose.x - gt.x, est.pose.y - gt.y], &est.covariance),
                    });
                    estimates.push(est);
                }
                if let Some(p) = options.progress.as_mut() {
                    p(now, scenario.duration_s);
                }
                true
            }
            _ => false,
        };
        if let Some(obs) = options.observer.as_mut() {
            obs.instant(&tick, &readings, scored.then_some(estimates.as_slice()))?;
            if let Some(people) = stream.people() {
                obs.people(&tick, &people)?;
            }
        }
    }
    if let Some(mut e) = failure {
        // What every localizer kept (a process localizer's stderr): `--out` writes it beside
        // the error, since the failed one's log is what explains the failure.
        if let ScenarioError::Localizer { logs, .. } = &mut e {
            for (l, spec) in localizers.iter_mut().zip(&scenario.localizers) {
                if let Some(log) = l.capabilities().and_then(|c| c.log()) {
                    logs.push((spec.name.clone(), log));
                }
            }
        }
        return Err(e);
    }
    let summary = stream.summary();

    let mut runs: Vec<LocalizerRun> = Vec::with_capacity(n);
    for (i, spec) in scenario.localizers.iter().enumerate() {
        let mut metrics = metrics::score(
            &samples[i],
            &regions,
            scenario.metrics.converge_threshold_m,
            scenario.metrics.converge_hold_s,
        );
        if let Some(m) = metrics.as_mut() {
            let scored = samples[i].len() as f64;
            m.chosen = std::mem::take(&mut chosen[i])
                .into_iter()
                .map(|(member, k)| (member, k as f64 / scored))
                .collect();
        }
        let recoveries = events
            .iter()
            .map(|ev| {
                metrics::converged_after(
                    &samples[i],
                    scenario.metrics.converge_threshold_m,
                    scenario.metrics.converge_hold_s,
                    ev.at_s(),
                )
                .map(|t| t - ev.at_s())
            })
            .collect();
        runs.push(LocalizerRun {
            name: spec.name.clone(),
            kind: spec.kind.clone(),
            trajectory: std::mem::take(&mut trajectories[i]),
            samples: std::mem::take(&mut samples[i]),
            metrics,
            recoveries,
            expectations: Vec::new(),
            passed: true,
            cpu_s: cpu[i],
            slam: crate::slam::SlamRun::of(localizers[i].as_mut(), scenario),
            node_events: crate::node_route::node_events(localizers[i].as_mut()),
            log: localizers[i].capabilities().and_then(|c| c.log()),
            relations: None,
        });
    }
    // Relations first: expectations may bound them.
    if let Some(rels) = scenario.log.as_deref().and_then(|l| l.relations.as_ref()) {
        for r in runs.iter_mut() {
            r.relations =
                crate::relations::score(&r.trajectory, rels, crate::log::REFERENCE_MAX_GAP_S);
        }
    }
    for i in 0..runs.len() {
        let own_exps = expectations
            .iter()
            .filter(|(l, _)| *l == runs[i].name)
            .map(|(_, e)| e);
        let results = match &runs[i].metrics {
            Some(m) => {
                let own = MetricSource {
                    metrics: m,
                    recoveries: &runs[i].recoveries,
                    relations: runs[i].relations.as_ref(),
                };
                let lookup = |name: &str| {
                    runs.iter().find(|r| r.name == name).and_then(|r| {
                        r.metrics.as_ref().map(|m| MetricSource {
                            metrics: m,
                            recoveries: &r.recoveries,
                            relations: r.relations.as_ref(),
                        })
                    })
                };
                expect::evaluate(own_exps, &own, &lookup)
            }
            None => own_exps
                .map(|e| ExpectationResult {
                    metric: format!("{e:?}"),
                    bound: expect::Bound::Max,
                    limit: f64::NAN,
                    value: None,
                    passed: false,
                })
                .collect(),
        };
        let mut results = results;
        results.extend(crate::slam::evaluate(
            scenario,
            &runs[i].name,
            runs[i].slam.as_ref(),
            &runs[i].samples,
        )?);
        runs[i].passed = results.iter().all(|r| r.passed);
        runs[i].expectations = results;
    }

    let log = scenario.log.as_deref().map(|l| LogRunInfo {
        path: l.path.display().to_string(),
        scan_topic: l.scan_topic.clone(),
        odom_topic: l.odom_topic.clone(),
        t0: l.t0,
        scans: l.scans.len(),
        reference: l.reference_source.clone(),
        scored_instants: ground_truth.len(),
        unscored_scans: l.unscored_scans,
        reference_accuracy: l.reference_accuracy.clone(),
        laser_mount: [l.mount.x, l.mount.y, l.mount.theta],
        laser_mount_source: l.mount_source.clone(),
        relations: l.relations_file.as_ref().map(|p| p.display().to_string()),
    });
    let wall_s = started.elapsed().as_secs_f64();
    let sim_time_s = summary.sim_time_s;
    Ok(RunResult {
        scenario: scenario.name.clone(),
        description: scenario.description.clone(),
        seed,
        world: scenario.world.name.clone(),
        robot: scenario.robot.name.clone(),
        sim_time_s,
        distance_m: summary.distance_m,
        route_completed: summary.route_completed,
        events: events.to_vec(),
        ground_truth,
        regions,
        timing: Timing {
            wall_s,
            real_time_factor: sim_time_s / wall_s.max(1e-9),
            physics_steps: summary.physics_steps,
            sim_s: summary.source_s,
            localizers_s: runs.iter().map(|r| (r.name.clone(), r.cpu_s)).collect(),
        },
        localizers: runs,
        log,
    })
}

/// A localizer's failure as a run error: which localizer, on which reading, at what time.
fn failed(l: &dyn Localizer, reading: &str, t: f64, e: LocalizerError) -> ScenarioError {
    ScenarioError::Localizer {
        name: l.name().to_string(),
        reading: reading.to_string(),
        t,
        msg: e.0,
        logs: Vec::new(),
    }
}

/// The name of a reading's kind in messages and protocols.
pub fn reading_kind(r: &Reading) -> &'static str {
    match r {
        Reading::Odometry(_) => "odometry",
        Reading::Laser(_) => "laser",
        Reading::Depth(_) => "depth",
        Reading::Wifi(_) => "wifi",
        Reading::Landmarks(_) => "landmarks",
        Reading::Intensity(_) => "intensity",
        Reading::Disparity(_) => "disparity",
        _ => "other",
    }
}
