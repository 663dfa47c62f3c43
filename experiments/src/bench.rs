//! `atrium bench`: whole-run throughput figures, measured on this machine. (Kernel-level
//! figures are criterion benchmarks in the crates: `cargo bench`.)

use atrium_scenarios::scenario::Scenario;
use atrium_scenarios::{run_scenario, RunOptions};
use serde_json::{json, Value};
use std::time::Instant;

pub const WHAT: [&str; 7] = [
    "all",
    "corridor_tracking",
    "tour",
    "cgr_corridor",
    "laser",
    "empca",
    "ros1_bag",
];

fn machine() -> Value {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into());
    json!({
        "cpu": cpu,
        "cores": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        "os": std::env::consts::OS,
        "arch": std::env::consts::ARCH,
    })
}

/// Real-time factor of the bundled `corridor_tracking` scenario, single-threaded.
pub fn corridor_tracking() -> Result<Value, String> {
    bundled_run("corridor_tracking")
}

/// One bundled scenario, run once on this thread. `real_time_factor` is over the drive
/// (simulated time / wall time from the first step on, as `atrium run` prints it);
/// `startup_s` is loading the scenario and building its localizers (a WiFi survey run and
/// GP training, likelihood fields, training runs), and `real_time_factor_total` counts it.
/// `disk_cache` says whether the on-disk cache could serve what startup builds
/// (`atrium bench --with-cache`; off by default, so startup is timed building everything).
/// Within one process a value already built for an earlier scenario (the same survey) is
/// reused whatever the setting.
pub fn bundled_run(name: &str) -> Result<Value, String> {
    let path = atrium_scenarios::bundled_scenarios_dir().join(format!("{name}.toml"));
    let started = Instant::now();
    let scenario = Scenario::load(&path).map_err(|e| e.to_string())?;
    let r = run_scenario(&scenario, RunOptions::default()).map_err(|e| e.to_string())?;
    let total_s = started.elapsed().as_secs_f64();
    Ok(json!({
        "scenario": r.scenario,
        "sim_time_s": r.sim_time_s,
        "wall_s": r.timing.wall_s,
        "real_time_factor": r.timing.real_time_factor,
        "startup_s": (total_s - r.timing.wall_s).max(0.0),
        "total_s": total_s,
        "real_time_factor_total": r.sim_time_s / total_s.max(1e-9),
        "disk_cache": if atrium_scenarios::disk_cache::enabled() { "on" } else { "off" },
        "physics_hz": scenario.physics_hz,
        "physics_steps": r.timing.physics_steps,
        "sim_s": r.timing.sim_s,
        "localizers_s": r.timing.localizers_s.iter().map(|(k, v)| (k.clone(), json!(v))).collect::<serde_json::Map<_, _>>(),
        "lasers": scenario.lasers.iter().map(|l| json!({"name": l.name, "beams": l.beams, "rate_hz": l.rate_hz})).collect::<Vec<_>>(),
    }))
}

/// Laser rays per second: full scans from poses along the office corridor of the bundled
/// campus, through the simulator's ray-cast path (beam model noise included).
pub fn laser() -> Result<Value, String> {
    let path = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let scenario = Scenario::load(&path).map_err(|e| e.to_string())?;
    let config = scenario.sim_config(1);
    let mut sim = atrium_sim::Simulation::new(&scenario.world, &scenario.robot, config)
        .map_err(|e| e.to_string())?;
    let mut out = Vec::new();
    sim.step(&mut out); // colliders join the query structure on the first step
    let beams = scenario
        .lasers
        .first()
        .map(|l| l.beams)
        .ok_or("corridor_tracking has no laser")?;
    let scans = 2000;
    let started = Instant::now();
    let mut checksum = 0.0;
    for i in 0..scans {
        let pose =
            atrium_robots::Pose2::new(2.0 + 26.0 * (i as f64 / scans as f64), 20.0, 0.3 * i as f64);
        let scan = sim.scan_at(pose, 0).map_err(|e| e.to_string())?;
        checksum += scan.ranges[beams / 2];
    }
    let secs = started.elapsed().as_secs_f64();
    Ok(json!({
        "scans": scans,
        "beams": beams,
        "seconds": secs,
        "rays_per_s": (scans * beams) as f64 / secs,
        "scans_per_s": scans as f64 / secs,
        "checksum": checksum,
    }))
}

/// Reading the bundled ROS 1 bag whole (`datasets/fr079/fr079.orig.bag`, bz2 chunks): every
/// scan, odometry and /tf message and the static mount, as `atrium replay` of the log does.
pub fn ros1_bag() -> Result<Value, String> {
    let path = atrium_scenarios::bundled_scenarios_dir().join("../datasets/fr079/fr079.orig.bag");
    let started = Instant::now();
    let log = atrium_formats::robot_log::RobotLog::open(&path).map_err(|e| e.to_string())?;
    let scans = log.scans("/scan").map_err(|e| e.to_string())?;
    let odometry = log.odometry("/odom").map_err(|e| e.to_string())?;
    let tf = log.transforms("/tf").map_err(|e| e.to_string())?;
    let mount = log.static_transforms().map_err(|e| e.to_string())?;
    let secs = started.elapsed().as_secs_f64();
    Ok(json!({
        "file": "datasets/fr079/fr079.orig.bag",
        "seconds": secs,
        "scans": scans.len(),
        "odometry": odometry.len(),
        "tf": tf.len(),
        "static_transforms": mount.len(),
    }))
}

pub fn run(what: &str) -> Result<Value, String> {
    let mut doc = serde_json::Map::new();
    doc.insert("machine".into(), machine());
    for name in ["corridor_tracking", "tour", "cgr_corridor"] {
        if what == "all" || what == name {
            doc.insert(name.into(), bundled_run(name)?);
        }
    }
    if what == "all" || what == "laser" {
        doc.insert("laser".into(), laser()?);
    }
    if what == "all" || what == "empca" {
        let b = crate::bench_appearance::EmPcaBench::default();
        doc.insert("empca".into(), crate::bench_appearance::empca(&b)?);
    }
    if what == "all" || what == "ros1_bag" {
        doc.insert("ros1_bag".into(), ros1_bag()?);
    }
    if doc.len() == 1 {
        return Err(format!(
            "unknown benchmark {what:?} (known: {})",
            WHAT.join(", ")
        ));
    }
    Ok(Value::Object(doc))
}
