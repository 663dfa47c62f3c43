//! The runner: the simulator's time-ordered reading stream goes to every localizer, and each
//! estimate is scored against the ground truth of the same instant.

use crate::error::ScenarioError;
use crate::expect::{self, ExpectationResult, MetricSource};
use crate::localizers::{build_localizer, SharedMaps};
use crate::metrics::{self, LocalizerMetrics, Sample};
use crate::scenario::{Event, Scenario};
use crate::seeds::derive_seed;
use atrium_localization::OdometryDelta;
use atrium_robots::{Pose2, Reading};
use atrium_sim::Simulation;
use serde::Serialize;
use std::time::Instant;

/// Per-run choices that are not part of the scenario.
#[derive(Default)]
pub struct RunOptions<'a> {
    /// Replaces the scenario's seed.
    pub seed: Option<u64>,
    /// Called now and then with (simulated time, scenario duration).
    pub progress: Option<&'a mut dyn FnMut(f64, f64)>,
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
}

impl RunResult {
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

/// Runs a scenario to the end and scores every localizer.
pub fn run_scenario(
    scenario: &Scenario,
    mut options: RunOptions,
) -> Result<RunResult, ScenarioError> {
    let started = Instant::now();
    let seed = options.seed.unwrap_or(scenario.seed);
    let file = &scenario.file;

    let config = scenario.sim_config(derive_seed(seed, "sim"));
    let mut sim = Simulation::new(&scenario.world, &scenario.robot, config)
        .map_err(|e| ScenarioError::field(file, "start.pose", e.to_string()))?;
    sim.set_route(&scenario.waypoints);

    let mut maps = SharedMaps::default();
    let mut localizers = Vec::with_capacity(scenario.localizers.len());
    for spec in &scenario.localizers {
        let loc_seed = derive_seed(seed, &format!("localizer/{}", spec.name));
        localizers.push(build_localizer(spec, scenario, &mut maps, loc_seed)?);
    }
    let n = localizers.len();
    let mut trajectories: Vec<Vec<(f64, Pose2)>> = vec![Vec::new(); n];
    let mut samples: Vec<Vec<Sample>> = vec![Vec::new(); n];
    let mut cpu = vec![0.0f64; n];
    let mut ground_truth = Vec::new();
    let mut regions = Vec::new();

    let dt = 1.0 / scenario.physics_hz;
    let eval_every = scenario.physics_hz / scenario.eval_hz;
    let mut next_eval = eval_every;
    let mut step: u64 = 0;
    let mut readings: Vec<Reading> = Vec::new();
    let mut last_odom: Option<Pose2> = None;
    let mut next_event = 0;
    let mut finished_at: Option<f64> = None;
    let mut distance = 0.0;
    let mut prev_gt = sim.ground_truth();
    let mut sim_s = 0.0;

    loop {
        let t = sim.time();
        if t >= scenario.duration_s - 0.5 * dt {
            break;
        }
        if let Some(done) = finished_at {
            if t >= done + scenario.settle_s {
                break;
            }
        }
        while let Some(ev) = scenario.events.get(next_event) {
            if ev.at_s() > t {
                break;
            }
            match ev {
                Event::Kidnap { to, .. } => {
                    sim.teleport(*to).map_err(|e| {
                        ScenarioError::field(
                            file,
                            format!("events[{next_event}].to"),
                            e.to_string(),
                        )
                    })?;
                    prev_gt = *to;
                }
            }
            next_event += 1;
        }

        let t0 = Instant::now();
        readings.clear();
        let gt = sim.step(&mut readings);
        sim_s += t0.elapsed().as_secs_f64();
        step += 1;
        distance += prev_gt.distance(&gt);
        prev_gt = gt;
        if finished_at.is_none() && sim.route_finished() {
            finished_at = Some(sim.time());
        }

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
                            l.predict(&delta);
                            *c += t1.elapsed().as_secs_f64();
                        }
                    }
                    last_odom = Some(o.pose);
                }
                other => {
                    for (l, c) in localizers.iter_mut().zip(cpu.iter_mut()) {
                        let t1 = Instant::now();
                        l.update(other);
                        *c += t1.elapsed().as_secs_f64();
                    }
                }
            }
        }

        if step as f64 + 1e-9 >= next_eval {
            next_eval += eval_every;
            let now = sim.time();
            ground_truth.push((now, gt));
            regions.push(scenario.world.region_at([gt.x, gt.y]).map(|r| {
                let kind = serde_json::to_value(r.kind)
                    .ok()
                    .and_then(|v| v.as_str().map(str::to_string))
                    .unwrap_or_default();
                (r.name.clone(), kind)
            }));
            for (i, l) in localizers.iter().enumerate() {
                let est = l.estimate();
                trajectories[i].push((now, est.pose));
                samples[i].push(Sample {
                    t: now,
                    position_error: est.pose.distance(&gt),
                    heading_error: est.pose.heading_error(&gt),
                    nees_xy: nees_xy([est.pose.x - gt.x, est.pose.y - gt.y], &est.covariance),
                });
            }
            if let Some(p) = options.progress.as_mut() {
                p(now, scenario.duration_s);
            }
        }
    }

    let expectations = expect::parse_expectations(scenario)?;
    let mut runs: Vec<LocalizerRun> = Vec::with_capacity(n);
    for (i, spec) in scenario.localizers.iter().enumerate() {
        let metrics = metrics::score(
            &samples[i],
            &regions,
            scenario.metrics.converge_threshold_m,
            scenario.metrics.converge_hold_s,
        );
        let recoveries = scenario
            .events
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
        });
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
                };
                let lookup = |name: &str| {
                    runs.iter().find(|r| r.name == name).and_then(|r| {
                        r.metrics.as_ref().map(|m| MetricSource {
                            metrics: m,
                            recoveries: &r.recoveries,
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
        runs[i].passed = results.iter().all(|r| r.passed);
        runs[i].expectations = results;
    }

    let wall_s = started.elapsed().as_secs_f64();
    let sim_time_s = sim.time();
    Ok(RunResult {
        scenario: scenario.name.clone(),
        seed,
        world: scenario.world.name.clone(),
        robot: scenario.robot.name.clone(),
        sim_time_s,
        distance_m: distance,
        route_completed: finished_at.is_some(),
        events: scenario.events.clone(),
        ground_truth,
        regions,
        timing: Timing {
            wall_s,
            real_time_factor: sim_time_s / wall_s.max(1e-9),
            physics_steps: step,
            sim_s,
            localizers_s: runs.iter().map(|r| (r.name.clone(), r.cpu_s)).collect(),
        },
        localizers: runs,
    })
}
