//! Diagnosis of the landmark filter on a node route (issue 16): run with
//! `DIAG_SCENARIO=<scenario> DIAG_SEEDS=1,2 cargo run --release -p atrium-tests --example
//! landmark_node_diagnosis -- diagnose|gamma_map|approach_profile`. `diagnose`: per node, γ against γ_n,
//! the true distance when γ first fell below γ_n and when odometry entered ρ, and the heading
//! error at the node (`DIAG_CAL` sets the odometry per seed, as for `oracle`); `gamma_map`: settled γ on rings around each node (`DIAG_HR`, `DIAG_MR`);
//! `approach_profile`: γ along the teach-run approach (002 Fig. 4c).

#[path = "diag/mod.rs"]
mod diag;

use atrium_localization::landmark_filter::LandmarkFilter;
use atrium_robots::{Pose2, Reading};
use atrium_scenarios::builtins::landmark::train_landmark_filter;
use atrium_scenarios::runner::{RunObserver, SimStream, Tick};
use atrium_scenarios::{
    run_localizers, Capabilities, Estimate, Localizer, LocalizerError, OdometryDelta, RunOptions,
    Scenario, ScenarioError,
};
use std::sync::{Arc, Mutex};

#[derive(Clone, Copy, Debug)]
struct Row {
    t: f64,
    next: usize,
    gamma: f64,
    pose: Pose2,
}

struct Spy {
    inner: LandmarkFilter,
    rows: Arc<Mutex<Vec<Row>>>,
}

impl Localizer for Spy {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn predict(&mut self, d: &OdometryDelta) -> Result<(), LocalizerError> {
        self.inner.predict(d)
    }
    fn update(&mut self, r: &Reading) -> Result<(), LocalizerError> {
        let next = self.inner.next_node();
        self.inner.update(r)?;
        if let Reading::Laser(l) = r {
            self.rows.lock().unwrap().push(Row {
                t: l.stamp,
                next,
                gamma: self.inner.gamma(),
                pose: self.inner.estimate().pose,
            });
        }
        Ok(())
    }
    fn estimate(&self) -> Estimate {
        self.inner.estimate()
    }
    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        self.inner.capabilities()
    }
}

struct Truth(Vec<(f64, Pose2)>);
impl RunObserver for Truth {
    fn instant(
        &mut self,
        tick: &Tick,
        _: &[Reading],
        _: Option<&[Estimate]>,
    ) -> Result<(), ScenarioError> {
        if let Some(t) = tick.truth {
            self.0.push((tick.t, t));
        }
        Ok(())
    }
}

fn diagnose() {
    let path = diag::scenario_path("wheelchair_nodes.toml");
    let seeds = diag::seeds();
    let mut scenario = Scenario::load(std::path::Path::new(&path)).unwrap();
    if std::env::var("DIAG_PAPER").is_ok() {
        paper_params(&mut scenario);
    }
    let route = scenario.node_route.clone().unwrap();
    let spec = scenario.localizers[0].clone();
    let filter = train_landmark_filter(&spec, &scenario).unwrap();
    for m in filter.models() {
        println!(
            "node {:?} gamma_n {:.3e} inside {:.3e} outside {:?}",
            m.node, m.gamma_n, m.gamma_inside_max, m.gamma_outside_min
        );
    }
    let cal = diag_cal();
    for (i, seed) in seeds.into_iter().enumerate() {
        let rows = Arc::new(Mutex::new(Vec::new()));
        let spy = Spy {
            inner: filter.clone(),
            rows: rows.clone(),
        };
        let mut one = scenario.clone();
        one.localizers.truncate(1);
        set_cal(&mut one, cal.get(i));
        let mut stream = SimStream::new(&one, seed).unwrap();
        let mut truth = Truth(Vec::new());
        let result = run_localizers(
            &one,
            seed,
            &mut stream,
            &[],
            vec![Box::new(spy)],
            RunOptions {
                seed: Some(seed),
                observer: Some(&mut truth),
                ..Default::default()
            },
        )
        .unwrap();
        let rows = rows.lock().unwrap();
        let truth_at = |t: f64| {
            let i = truth.0.partition_point(|(s, _)| *s < t - 1e-9);
            truth.0[i.min(truth.0.len() - 1)].1
        };
        println!("seed {seed}");
        let models = filter.models();
        let mut from = [scenario.start.x, scenario.start.y];
        for (n, node) in route.nodes.iter().enumerate() {
            let dir = (node[1] - from[1]).atan2(node[0] - from[0]);
            from = *node;
            let leg: Vec<&Row> = rows.iter().filter(|r| r.next == n).collect();
            let d = |p: &Pose2| (p.x - node[0]).hypot(p.y - node[1]);
            // gamma minimum over the leg, with true distance there.
            let mut best = (f64::INFINITY, 0.0, 0.0);
            let mut enter_rho: Option<(f64, f64, f64)> = None;
            let mut below_true: Option<f64> = None;
            for (k, r) in leg.iter().enumerate() {
                let tr = truth_at(r.t);
                if k > 30 && r.gamma < best.0 {
                    best = (r.gamma, d(&tr), d(&r.pose));
                }
                if enter_rho.is_none() && d(&r.pose) <= 0.25 {
                    enter_rho = Some((d(&tr), r.gamma, k as f64));
                }
                if k > 30 && below_true.is_none() && r.gamma < models[n].gamma_n {
                    below_true = Some(d(&tr));
                }
            }
            let ev = result.localizers[0]
                .node_events
                .iter()
                .find(|e| e.node == n);
            let ev_s = ev.map(|e| {
                let tr = truth_at(e.stamp);
                // The true position in the leg's frame: along (negative: short of the node)
                // and to the left of the leg.
                let (dx, dy) = (tr.x - node[0], tr.y - node[1]);
                let along = dx * dir.cos() + dy * dir.sin();
                let left = -dx * dir.sin() + dy * dir.cos();
                format!(
                    "{} true {:.3} (along {:+.2}, left {:+.2}) heading err {:.1} deg",
                    if e.verified { "VER" } else { "odo" },
                    d(&tr),
                    along,
                    left,
                    atrium_robots::normalize_angle(e.pose.theta - tr.theta).to_degrees()
                )
            });
            println!(
                "  node {} scans {} gamma_n {:.2e} min gamma {:.2e} at true {:.2} (odo {:.2}); \
                 first gamma<gamma_n at true {:?}; entering rho by odo: true {:?}; {:?}",
                n + 1,
                leg.len(),
                models[n].gamma_n,
                best.0,
                best.1,
                best.2,
                below_true.map(|v| (v * 100.0).round() / 100.0),
                enter_rho.map(|(a, b, c)| format!("{a:.2} gamma {b:.2e} k {c}")),
                ev_s
            );
        }
    }
}

/// Settled γ around each node at the leg's heading: how far from the node the landmark still
/// "matches" (max / min over 16 directions per ring).
fn gamma_map() {
    use atrium_localization::landmark_filter::{LandmarkSignature, RecursiveLandmarkModel};
    let path = std::env::var("DIAG_SCENARIO").unwrap();
    let mut scenario = Scenario::load(std::path::Path::new(&path)).unwrap();
    let hr: f64 = std::env::var("DIAG_HR")
        .ok()
        .map(|s| s.parse().unwrap())
        .unwrap_or(0.0);
    scenario.localizers[0]
        .params
        .insert("histogram_range".into(), toml::Value::Float(hr));
    if let Ok(mr) = std::env::var("DIAG_MR") {
        scenario.localizers[0].params.insert(
            "model_radius".into(),
            toml::Value::Float(mr.parse().unwrap()),
        );
    }
    let route = scenario.node_route.clone().unwrap();
    let spec = scenario.localizers[0].clone();
    let filter = train_landmark_filter(&spec, &scenario).unwrap();
    let config = scenario.sim_config(7);
    let mut sim = atrium_sim::Simulation::new(&scenario.world, &scenario.robot, config).unwrap();
    let mut from = [scenario.start.x, scenario.start.y];
    let w: f64 = 0.8;
    for (n, node) in route.nodes.iter().enumerate() {
        let m = &filter.models()[n];
        let model = RecursiveLandmarkModel::new(m.conditional, w);
        let heading = (node[1] - from[1]).atan2(node[0] - from[0]);
        from = *node;
        print!("node {} gamma_n {:.2e}:", n + 1, m.gamma_n);
        for r in [0.0, 0.125, 0.25, 0.375, 0.5, 0.75, 1.0, 1.5] {
            let mut lo = f64::INFINITY;
            let mut hi: f64 = 0.0;
            let mut below = 0;
            for k in 0..16 {
                for dth in [-0.05, 0.0, 0.05] {
                    let a = std::f64::consts::TAU * k as f64 / 16.0;
                    let pose =
                        Pose2::new(node[0] + r * a.cos(), node[1] + r * a.sin(), heading + dth);
                    let s = sim.scan_at(pose, 0).unwrap();
                    let range = if hr > 0.0 { hr } else { s.range_max };
                    let h = LandmarkSignature::from_ranges(&s.ranges, range);
                    let g = model.settled_gamma(h.bins());
                    lo = lo.min(g);
                    hi = hi.max(g);
                    if g < m.gamma_n {
                        below += 1;
                    }
                }
            }
            print!(" r{r}: {lo:.1e}..{hi:.1e} ({below}/48)");
        }
        println!();
    }
}

/// γ along the teach-run approach to each node (the recursion as the filter runs it).
fn approach_profile() {
    use atrium_localization::landmark_filter::{LandmarkSignature, RecursiveLandmarkModel};
    let path = std::env::var("DIAG_SCENARIO").unwrap();
    let mut scenario = Scenario::load(std::path::Path::new(&path)).unwrap();
    if let Ok(mr) = std::env::var("DIAG_MR") {
        scenario.localizers[0].params.insert(
            "model_radius".into(),
            toml::Value::Float(mr.parse().unwrap()),
        );
    }
    let route = scenario.node_route.clone().unwrap();
    let spec = scenario.localizers[0].clone();
    let filter = train_landmark_filter(&spec, &scenario).unwrap();
    let (scans, _) = atrium_scenarios::builtins::landmark::training_scans(
        &scenario, &route, "laser", 0.25, 3, 0.07,
    )
    .unwrap();
    for (n, node) in route.nodes.iter().enumerate() {
        let m = &filter.models()[n];
        let mut model = RecursiveLandmarkModel::new(m.conditional, 0.8);
        let mut prev = usize::MAX;
        let mut line = format!("node {} gamma_n {:.1e}:", n + 1, m.gamma_n);
        let marks = [3.0, 2.0, 1.5, 1.0, 0.75, 0.5, 0.375, 0.25, 0.125, 0.0];
        let mut next_mark = 0;
        for s in &scans {
            if s.target != prev {
                model.reset();
                prev = s.target;
                next_mark = 0;
                if s.target == n {
                    line.push_str(" |");
                }
            }
            if s.target != n {
                continue;
            }
            let h = LandmarkSignature::from_ranges(&s.ranges, s.range_max);
            model.update(h.bins());
            let d = (s.pose.x - node[0]).hypot(s.pose.y - node[1]);
            while next_mark < marks.len() && d <= marks[next_mark] + 0.03 {
                if model.steps() > 30 {
                    line.push_str(&format!(" {}:{:.1e}", marks[next_mark], model.gamma()));
                }
                next_mark += 1;
            }
        }
        println!("{line}");
    }
}

/// The parameters `[node_experiment] paper_reset` runs 002's reset with (`DIAG_PAPER=1`).
fn paper_params(scenario: &mut Scenario) {
    let p = &mut scenario.localizers[0].params;
    p.insert("scan_alignment".into(), toml::Value::Boolean(false));
    p.insert("gamma_rule".into(), toml::Value::String("rim".into()));
    p.remove("model_radius");
}

/// (node, verified, true distance, dead-reckoning error, heading error of the pose, degrees)
type NodeInstant = (usize, bool, f64, f64, f64);

/// The best any landmark could do under 002's gate and reset (`oracle`): a node counts as
/// recognised on the first scan (after the warm-up) at which the odometry is within ρ of the
/// node (Algorithm 1 line 12) and the robot truly is within `DIAG_TRUE_R` of it (default ρ),
/// and the reset is Table I's (x, y := node, heading kept). Per run: the true distance at
/// each node instant and dead reckoning's error there. `DIAG_CAL="r,s[,k];r,s[,k];..."` sets
/// the odometry calibration (radius_error, separation_error and, if given, scale_error) per
/// seed in `DIAG_SEEDS` order.
struct Oracle {
    nodes: Vec<[f64; 2]>,
    rho: f64,
    true_r: f64,
    gamma_d: f64,
    pose: Pose2,
    dr: Pose2,
    next: usize,
    leg: Option<atrium_robots::node_route::Leg>,
    steps: usize,
    truth: Arc<Mutex<Pose2>>,
    pending: Option<usize>,
    events: Arc<Mutex<Vec<NodeInstant>>>,
}

impl Oracle {
    fn arrive(&mut self, verified: bool) {
        let node = self.nodes[self.next];
        let tr = *self.truth.lock().unwrap();
        self.events.lock().unwrap().push((
            self.next,
            verified,
            (tr.x - node[0]).hypot(tr.y - node[1]),
            self.dr.distance(&tr),
            atrium_robots::normalize_angle(self.pose.theta - tr.theta).to_degrees(),
        ));
        self.pose.x = node[0];
        self.pose.y = node[1];
        if verified {
            self.pending = Some(self.next);
        }
        self.next += 1;
        self.steps = 0;
        self.leg = self
            .nodes
            .get(self.next)
            .map(|n| atrium_robots::node_route::Leg {
                from: node,
                node: *n,
            });
    }
}

impl Localizer for Oracle {
    fn name(&self) -> &str {
        "oracle"
    }
    fn predict(&mut self, d: &OdometryDelta) -> Result<(), LocalizerError> {
        let step = d.from.between(&d.to);
        self.pose = self.pose.compose(&step);
        self.dr = self.dr.compose(&step);
        if let Some(leg) = self.leg {
            if leg.reached(&self.pose, self.gamma_d) {
                self.arrive(false);
            }
        }
        Ok(())
    }
    fn update(&mut self, r: &Reading) -> Result<(), LocalizerError> {
        let (Reading::Laser(_), Some(leg)) = (r, self.leg) else {
            return Ok(());
        };
        self.steps += 1;
        let node = self.nodes[self.next];
        let tr = *self.truth.lock().unwrap();
        if self.steps > 30
            && leg.current(&self.pose) <= self.rho
            && (tr.x - node[0]).hypot(tr.y - node[1]) <= self.true_r
        {
            self.arrive(true);
        }
        Ok(())
    }
    fn estimate(&self) -> Estimate {
        Estimate {
            stamp: 0.0,
            pose: self.pose,
            covariance: Default::default(),
        }
    }
    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        Some(self)
    }
}

impl Capabilities for Oracle {
    fn take_node_verification(&mut self) -> Option<usize> {
        self.pending.take()
    }
}

/// `DIAG_CAL="r,s[,k];..."`: per seed (in `DIAG_SEEDS` order) the odometry's radius_error,
/// separation_error and, if given, scale_error (`oracle` and `diagnose`).
fn diag_cal() -> Vec<(f64, f64, Option<f64>)> {
    std::env::var("DIAG_CAL")
        .map(|c| {
            c.split(';')
                .map(|p| {
                    let v: Vec<f64> = p.split(',').map(|x| x.parse().unwrap()).collect();
                    (v[0], v[1], v.get(2).copied())
                })
                .collect()
        })
        .unwrap_or_default()
}

fn set_cal(s: &mut Scenario, cal: Option<&(f64, f64, Option<f64>)>) {
    if let Some(&(r, e, k)) = cal {
        s.odometry.radius_error = r;
        s.odometry.separation_error = e;
        if let Some(k) = k {
            s.odometry.scale_error = k;
        }
    }
}

fn oracle() {
    let path = diag::scenario_path("wheelchair_nodes.toml");
    let seeds = diag::seeds();
    let cal = diag_cal();
    let true_r: f64 = std::env::var("DIAG_TRUE_R")
        .map(|s| s.parse().unwrap())
        .unwrap_or(0.25);
    let scenario = Scenario::load(std::path::Path::new(&path)).unwrap();
    let route = scenario.node_route.clone().unwrap();
    let (mut reach_all, mut dr_all, mut ver) = (Vec::new(), Vec::new(), 0);
    for (i, seed) in seeds.iter().enumerate() {
        let mut one = scenario.clone();
        one.localizers.truncate(1);
        set_cal(&mut one, cal.get(i));
        let truth = Arc::new(Mutex::new(one.start));
        let events = Arc::new(Mutex::new(Vec::new()));
        let o = Oracle {
            nodes: route.nodes.clone(),
            rho: 0.25,
            true_r,
            gamma_d: route.params.gamma_d,
            pose: one.start,
            dr: one.start,
            next: 0,
            leg: Some(atrium_robots::node_route::Leg {
                from: [one.start.x, one.start.y],
                node: route.nodes[0],
            }),
            steps: 0,
            truth: truth.clone(),
            pending: None,
            events: events.clone(),
        };
        let mut stream = SimStream::new(&one, *seed).unwrap();
        let mut obs = diag::LatestTruth(truth);
        run_localizers(
            &one,
            *seed,
            &mut stream,
            &[],
            vec![Box::new(o)],
            RunOptions {
                seed: Some(*seed),
                observer: Some(&mut obs),
                ..Default::default()
            },
        )
        .unwrap();
        print!(
            "seed {seed} ({:.4}, {:.4}, {:.4}):",
            one.odometry.radius_error, one.odometry.separation_error, one.odometry.scale_error
        );
        for (n, v, d, e, th) in events.lock().unwrap().iter() {
            print!(
                " n{} {}{:.0}/{:.0} ({:+.1} deg)",
                n + 1,
                if *v { "" } else { "*" },
                1000.0 * d,
                1000.0 * e,
                th
            );
            reach_all.push(*d);
            dr_all.push(*e);
            ver += *v as usize;
        }
        println!();
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    println!(
        "oracle (true radius {true_r} m): verified {ver}/{}, true distance at the node instants \
         mean {:.0} mm, max {:.0} mm; dead reckoning there mean {:.0} mm",
        reach_all.len(),
        1000.0 * mean(&reach_all),
        1000.0 * reach_all.iter().cloned().fold(0.0, f64::max),
        1000.0 * mean(&dr_all)
    );
}

fn main() {
    match std::env::args().nth(1).as_deref() {
        Some("diagnose") => diagnose(),
        Some("gamma_map") => gamma_map(),
        Some("approach_profile") => approach_profile(),
        Some("oracle") => oracle(),
        other => {
            eprintln!("usage: landmark_node_diagnosis diagnose|gamma_map|approach_profile|oracle (got {other:?})");
            std::process::exit(2);
        }
    }
}
