//! The twin of a log scenario: a simulated scenario of the same run. Its world is the log
//! scenario's map, its robot the generic differential drive with the log's laser where the
//! log says it was, its laser and odometry the models calibrated from the log, its route the
//! reference trajectory, and its localizers and initial belief the log scenario's own.
//!
//! Where the twin differs from the run it copies, by construction: the route is followed by
//! Atrium's waypoint controller at the log's median moving speed (the real robot's speed
//! profile and its stops are not replayed), the robot is the Pioneer-sized generic one
//! whatever the real robot was, and unknown map cells are empty space.

use crate::calibrate::{laser::LaserFit, odometry::OdometryFit};
use crate::error::ScenarioError;
use crate::log::{RealLog, LOG_LASER_LINK};
use crate::scenario::Scenario;
use atrium_robots::Pose2;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Waypoints are taken every this much path of the reference, m.
pub const WAYPOINT_SPACING_M: f64 = 1.0;
/// Below this speed the reference counts as standing, m/s.
const MOVING_M_S: f64 = 0.05;

/// The twin's two files, as text.
#[derive(Debug, Clone)]
pub struct Twin {
    pub toml: String,
    pub urdf: String,
}

/// The reference's waypoints: every [`WAYPOINT_SPACING_M`] of path, and its last pose.
pub fn waypoints(reference: &[(f64, Pose2)]) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    let mut path = 0.0;
    for w in reference.windows(2) {
        path += w[0].1.distance(&w[1].1);
        if path >= WAYPOINT_SPACING_M {
            out.push([w[1].1.x, w[1].1.y]);
            path = 0.0;
        }
    }
    if let Some((_, last)) = reference.last() {
        if path > 0.1 || out.is_empty() {
            out.push([last.x, last.y]);
        }
    }
    out
}

/// The median speed of the reference while it moves, m/s.
pub fn moving_speed(reference: &[(f64, Pose2)]) -> f64 {
    let speeds: Vec<f64> = reference
        .windows(2)
        .filter(|w| w[1].0 > w[0].0)
        .map(|w| w[0].1.distance(&w[1].1) / (w[1].0 - w[0].0))
        .filter(|v| *v > MOVING_M_S && v.is_finite())
        .collect();
    let q = crate::calibrate::drift::quantile(&speeds, 0.5);
    if q.is_finite() {
        q
    } else {
        0.3
    }
}

fn toml_path(p: &Path) -> String {
    toml::Value::String(p.display().to_string()).to_string()
}

/// Makes a relative path key of a localizer table absolute against `dir`.
fn absolutize(table: &mut toml::Table, key: &str, dir: &Path) {
    if let Some(toml::Value::String(s)) = table.get(key) {
        let p = Path::new(s);
        if p.is_relative() {
            let abs = dir.join(p);
            let abs = abs.canonicalize().unwrap_or(abs);
            table.insert(key.into(), toml::Value::String(abs.display().to_string()));
        }
    }
}

/// Writes the twin of `scenario` (a log scenario) for the file `twin_file` (its URDF goes
/// beside it as `<stem>.urdf`); `odometry` and `laser` are the calibrated models.
pub fn twin(
    scenario: &Scenario,
    odometry: &OdometryFit,
    laser: Option<&LaserFit>,
    twin_file: &Path,
) -> Result<Twin, ScenarioError> {
    let log: &RealLog = scenario.log.as_deref().ok_or_else(|| {
        ScenarioError::field(
            &scenario.file,
            "log",
            "a twin copies a log scenario: this one has no [log]",
        )
    })?;
    let map = scenario.grid_map.as_ref().ok_or_else(|| {
        ScenarioError::field(
            &scenario.file,
            "map",
            "a twin's world is the log scenario's map = \"X.yaml\"",
        )
    })?;
    let text = std::fs::read_to_string(&scenario.file).map_err(|err| ScenarioError::Io {
        file: scenario.file.clone(),
        err,
    })?;
    let raw: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        ScenarioError::field(&scenario.file, "toml", e.to_string())
    })?;
    let dir = scenario.file.parent().unwrap_or(Path::new("."));
    let stem = twin_file
        .file_stem()
        .map_or("twin".into(), |s| s.to_string_lossy().into_owned());
    let urdf_file: PathBuf = twin_file.with_file_name(format!("{stem}.urdf"));
    let urdf = atrium_robots::generic_robot_urdf(&format!("{stem}_robot"), log.laser_mount_3());

    let start = log.start_pose();
    let route = waypoints(&log.reference);
    let speed = moving_speed(&log.reference);
    let map_abs = map.file.canonicalize().unwrap_or(map.file.clone());
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# The twin of {} (written by `atrium twin`): the same run simulated, with the models\n\
         # calibrated from the log. Route: the reference every {WAYPOINT_SPACING_M} m, driven at \
         the log's\n# median moving speed ({speed:.2} m/s).",
        scenario.file.display()
    );
    let _ = writeln!(
        t,
        "name = {}",
        toml::Value::String(format!("{}_twin", scenario.name))
    );
    let _ = writeln!(t, "map = {}", toml_path(&map_abs));
    let _ = writeln!(
        t,
        "robot = {}",
        toml_path(Path::new(&format!("{stem}.urdf")))
    );
    let _ = writeln!(t, "seed = {}", scenario.seed);
    let _ = writeln!(t, "duration_s = {:.1}", 1.5 * log.duration_s() + 30.0);
    let _ = writeln!(
        t,
        "\n[start]\npose = [{}, {}, {}]",
        start.x, start.y, start.theta
    );
    let _ = writeln!(t, "\n[route]\nwaypoints = [");
    for w in &route {
        let _ = writeln!(t, "  [{:.3}, {:.3}],", w[0], w[1]);
    }
    let _ = writeln!(t, "]");
    // A looser goal and a quicker turn than the defaults: at a real robot's speed the
    // default follower orbits a waypoint it passes within a metre of.
    let _ = writeln!(
        t,
        "\n[controller]\nmax_speed = {speed:.3}\ngoal_tolerance = 0.3\nmax_turn_rate = 2.0"
    );
    let _ = writeln!(
        t,
        "\n# Calibrated from the log (atrium calibrate): value ± standard error.\n[odometry]\n{}rate_hz = {:.1}",
        crate::calibrate::odometry_lines(odometry),
        log.odometry_rate_hz().clamp(1.0, 200.0),
    );
    let l = &log.laser;
    let _ = writeln!(
        t,
        "\n[sensors.{}]\nmount = {}\nrate_hz = {:.3}\nbeams = {}\nfov = {}\nrange_min = {}\nrange_max = {}",
        l.name,
        toml::Value::String(LOG_LASER_LINK.into()),
        l.rate_hz,
        l.beams,
        l.fov,
        l.range_min,
        l.range_max
    );
    match laser {
        Some(f) => t.push_str(&crate::calibrate::laser_lines(f)),
        None => {
            let _ = writeln!(
                t,
                "sigma_hit = {}\nsigma_hit_per_m = 0.0\np_short = {}\nlambda_short = {}\np_max = {}\np_rand = {}",
                l.sigma_hit, l.p_short, l.lambda_short, l.p_max, l.p_rand
            );
        }
    }
    // The log scenario's own localizers, belief and metrics, paths made absolute.
    let mut rest = toml::Table::new();
    for key in ["initial_belief", "metrics"] {
        if let Some(v) = raw.get(key) {
            rest.insert(key.into(), v.clone());
        }
    }
    if let Some(toml::Value::Array(locs)) = raw.get("localizers") {
        let mut out = Vec::new();
        for l in locs {
            let mut l = l.as_table().cloned().unwrap_or_default();
            for key in ["cwd", "training", "map"] {
                absolutize(&mut l, key, dir);
            }
            out.push(toml::Value::Table(l));
        }
        rest.insert("localizers".into(), toml::Value::Array(out));
    }
    let rest = toml::to_string(&rest)
        .map_err(|e| ScenarioError::field(&scenario.file, "localizers", e.to_string()))?;
    let _ = writeln!(t, "\n{rest}");
    let _ = urdf_file;
    Ok(Twin { toml: t, urdf })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn waypoints_follow_the_path_every_metre() {
        let r: Vec<(f64, Pose2)> = (0..=50)
            .map(|k| (k as f64, Pose2::new(0.1 * k as f64, 0.0, 0.0)))
            .collect();
        let w = waypoints(&r);
        assert_eq!(w.len(), 5);
        assert!((w[0][0] - 1.0).abs() < 1e-9 && (w[4][0] - 5.0).abs() < 1e-9);
        assert!((moving_speed(&r) - 0.1).abs() < 1e-9);
    }
}
