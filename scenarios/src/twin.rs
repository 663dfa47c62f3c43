//! The twin of a log scenario: a simulated scenario of the same run. Its world is the log
//! scenario's map, its robot the generic differential drive with the log's laser where the
//! log says it was, its laser and odometry the models calibrated from the log, its route the
//! reference trajectory, and its localizers and initial belief the log scenario's own.
//!
//! Where the twin differs from the run it copies, by construction: the route is followed by
//! Atrium's waypoint controller, each leg at the speed the log moved along it (the real
//! robot's stops are not replayed, and it turns in place at sharp corners where the real one
//! may have turned while driving), the robot is the Pioneer-sized generic one
//! whatever the real robot was, and unknown map cells are empty space.
//!
//! The twin's map is the log's map with every occupied cell within the generic robot's reach
//! (plus [`PATH_CLEARANCE_MARGIN_M`]) of the reference path made free: the real robot drove
//! there, so that space was free when it passed, but a map built over a whole run keeps
//! people and doors that moved, and the generic robot may be wider than the real one. Without
//! this, the twin's robot jams against such blobs and every later figure measures the jam.

use crate::calibrate::{laser::LaserFit, odometry::OdometryFit};
use crate::error::ScenarioError;
use crate::log::{RealLog, LOG_LASER_LINK};
use crate::scenario::Scenario;
use atrium_robots::{Pose2, RobotModel, Shape};
use atrium_worlds::{Cell, OccupancyGrid};
use std::fmt::Write as _;
use std::path::Path;

/// The twin's route keeps within this distance of the reference path, m.
pub const ROUTE_TOLERANCE_M: f64 = 0.05;
/// The waypoint follower's goal tolerance in the twin, m: small, so that the robot passes
/// where the reference passed (a loose one cuts corners by about its own size).
pub const TWIN_GOAL_TOLERANCE_M: f64 = 0.15;
/// Below this speed the reference counts as standing, m/s.
const MOVING_M_S: f64 = 0.05;

/// Clearance kept beyond the robot's reach around the reference path, m: the route's own
/// tolerance and the follower's corner cutting (about its goal tolerance).
pub const PATH_CLEARANCE_MARGIN_M: f64 = ROUTE_TOLERANCE_M + TWIN_GOAL_TOLERANCE_M;

/// The twin's files: the scenario and the robot as text, and the map it names.
#[derive(Debug, Clone)]
pub struct Twin {
    pub toml: String,
    pub urdf: String,
    /// The log's map with the reference path swept free (see the module doc); written as
    /// `<stem>.map.yaml` and its PGM beside the twin.
    pub map: OccupancyGrid,
    /// How many occupied cells the sweep made free.
    pub cleared_cells: usize,
}

/// The farthest any part of the robot reaches from its base frame's origin in the floor
/// plane, m: chassis shapes, wheels and casters.
pub fn planar_reach(model: &RobotModel) -> f64 {
    let xy = |v: &nalgebra::Vector3<f64>| v.x.hypot(v.y);
    let chassis = model.chassis_shapes.iter().map(|s| {
        let half = match s.shape {
            Shape::Box { size } => (0.5 * size[0]).hypot(0.5 * size[1]).max(0.5 * size[2]),
            Shape::Cylinder { radius, length } => radius.max(0.5 * length),
            Shape::Sphere { radius } => radius,
        };
        xy(&s.pose.translation.vector) + half
    });
    let wheels = [&model.left_wheel, &model.right_wheel]
        .into_iter()
        .map(|w| xy(&w.center) + w.radius.hypot(0.5 * w.width));
    let casters = model.casters.iter().map(|c| xy(&c.center) + c.radius);
    chassis.chain(wheels).chain(casters).fold(0.0, f64::max)
}

/// Makes every occupied cell within `radius` m of a pose of `path` free; returns how many.
pub fn clear_along_path(grid: &mut OccupancyGrid, path: &[(f64, Pose2)], radius: f64) -> usize {
    let res = grid.resolution;
    let reach = (radius / res).ceil() as i64 + 1;
    let mut cleared = 0;
    let mut last: Option<Pose2> = None;
    for (_, p) in path {
        // Poses closer than half a cell to the last swept one add nothing.
        if last.is_some_and(|l| l.distance(p) < 0.5 * res) {
            continue;
        }
        last = Some(*p);
        let ci = ((p.x - grid.origin[0]) / res).floor() as i64;
        let cj = ((p.y - grid.origin[1]) / res).floor() as i64;
        for j in (cj - reach).max(0)..=(cj + reach).min(grid.height as i64 - 1) {
            for i in (ci - reach).max(0)..=(ci + reach).min(grid.width as i64 - 1) {
                let c = grid.cell_center(i as usize, j as usize);
                if (c[0] - p.x).hypot(c[1] - p.y) > radius {
                    continue;
                }
                let k = grid.index(i as usize, j as usize);
                if grid.cells[k] == Cell::Occupied {
                    grid.cells[k] = Cell::Free;
                    cleared += 1;
                }
            }
        }
    }
    cleared
}

/// The reference's waypoints: its positions simplified by Douglas–Peucker, so that the
/// straight lines between them stay within [`ROUTE_TOLERANCE_M`] of the path (a 180° loop
/// keeps its shape, a straight corridor becomes one segment), plus its last pose.
pub fn waypoints(reference: &[(f64, Pose2)]) -> Vec<[f64; 2]> {
    route(reference).0
}

/// The reference's waypoints (as [`waypoints`]) and the speed of each leg, the one ending at
/// each waypoint: the reference's distance along that leg over the time it took, counting
/// only the time it moved (faster than [`MOVING_M_S`]), so that the twin drives each stretch
/// as fast as the real robot drove it, without its stops. A leg on which the reference never
/// moved gets the run's median moving speed.
pub fn route(reference: &[(f64, Pose2)]) -> (Vec<[f64; 2]>, Vec<f64>) {
    let points: Vec<[f64; 2]> = reference.iter().map(|(_, p)| [p.x, p.y]).collect();
    if points.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let keep = douglas_peucker(&points, ROUTE_TOLERANCE_M);
    let fallback = moving_speed(reference);
    let leg = |a: usize, b: usize| {
        let (mut dist, mut time) = (0.0, 0.0);
        for w in reference[a..=b].windows(2) {
            let (dt, d) = (w[1].0 - w[0].0, w[0].1.distance(&w[1].1));
            if dt > 0.0 && d / dt > MOVING_M_S && d.is_finite() {
                dist += d;
                time += dt;
            }
        }
        if time > 0.0 {
            dist / time
        } else {
            fallback
        }
    };
    // The start is where the robot already stands.
    let (mut out, mut speeds) = (Vec::new(), Vec::new());
    for pair in keep.windows(2) {
        out.push(points[pair[1]]);
        speeds.push(leg(pair[0], pair[1]));
    }
    if out.is_empty() {
        out.push(points[points.len() - 1]);
        speeds.push(fallback);
    }
    (out, speeds)
}

/// Distance of `p` from the segment `a`–`b`.
fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let u = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - u * dx).hypot(p[1] - a[1] - u * dy)
}

/// Indices of the points Douglas–Peucker keeps at tolerance `eps` (first and last always).
pub fn douglas_peucker(points: &[[f64; 2]], eps: f64) -> Vec<usize> {
    let n = points.len();
    if n < 3 {
        return (0..n).collect();
    }
    let mut keep = vec![false; n];
    keep[0] = true;
    keep[n - 1] = true;
    let mut stack = vec![(0, n - 1)];
    while let Some((a, b)) = stack.pop() {
        let (mut worst, mut at) = (0.0, a);
        for k in a + 1..b {
            let d = segment_distance(points[k], points[a], points[b]);
            if d > worst {
                worst = d;
                at = k;
            }
        }
        if worst > eps {
            keep[at] = true;
            stack.push((a, at));
            stack.push((at, b));
        }
    }
    (0..n).filter(|&k| keep[k]).collect()
}

/// The median speed of the reference while it moves, m/s.
pub fn moving_speed(reference: &[(f64, Pose2)]) -> f64 {
    quantile_or(&moving_speeds(reference), 0.5, 0.3)
}

/// The reference's speed between successive poses where it moves, m/s.
fn moving_speeds(reference: &[(f64, Pose2)]) -> Vec<f64> {
    reference
        .windows(2)
        .filter(|w| w[1].0 > w[0].0)
        .map(|w| w[0].1.distance(&w[1].1) / (w[1].0 - w[0].0))
        .filter(|v| *v > MOVING_M_S && v.is_finite())
        .collect()
}

/// Quantile `q` of `v`, or `fallback` when `v` has none.
fn quantile_or(v: &[f64], q: f64, fallback: f64) -> f64 {
    let x = crate::calibrate::drift::quantile(v, q);
    if x.is_finite() {
        x
    } else {
        fallback
    }
}

/// Share of the reference's samples whose speed, turn rate or acceleration a limit fitted
/// from it may exceed: the top 1 %, where a reference fitted to relations jumps rather than
/// the robot (MIT CSAIL's has a few legs that would be driven at 3-4 m/s).
const LIMIT_QUANTILE: f64 = 0.99;
/// Poses over which the reference's speed is averaged before differencing it into an
/// acceleration (at a laser's 5 Hz, about a second).
const ACCEL_SMOOTHING_POSES: usize = 5;

/// The waypoint follower's limits fitted from the reference, as the real robot drove:
/// (top speed m/s, acceleration m/s², turn rate rad/s), each the [`LIMIT_QUANTILE`] of the
/// reference's own values and never below the controller's defaults' order of magnitude
/// (a log that barely moves still gets a drivable twin).
pub fn drive_limits(reference: &[(f64, Pose2)]) -> (f64, f64, f64) {
    let top = quantile_or(&moving_speeds(reference), LIMIT_QUANTILE, 0.5).max(0.1);
    let mut speeds = Vec::new();
    let mut turns = Vec::new();
    for w in reference.windows(2) {
        let dt = w[1].0 - w[0].0;
        if dt > 0.0 {
            let v = w[0].1.distance(&w[1].1) / dt;
            let dth = atrium_robots::normalize_angle(w[1].1.theta - w[0].1.theta);
            if v.is_finite() && dth.is_finite() {
                speeds.push((0.5 * (w[0].0 + w[1].0), v));
                turns.push(dth.abs() / dt);
            }
        }
    }
    let smoothed: Vec<(f64, f64)> = speeds
        .windows(ACCEL_SMOOTHING_POSES)
        .map(|w| {
            let n = w.len() as f64;
            (
                w.iter().map(|s| s.0).sum::<f64>() / n,
                w.iter().map(|s| s.1).sum::<f64>() / n,
            )
        })
        .collect();
    let accels: Vec<f64> = smoothed
        .windows(2)
        .filter(|w| w[1].0 > w[0].0)
        .map(|w| (w[1].1 - w[0].1).abs() / (w[1].0 - w[0].0))
        .collect();
    let accel = quantile_or(&accels, LIMIT_QUANTILE, 0.5).max(0.2);
    let turn = quantile_or(&turns, LIMIT_QUANTILE, 1.0).max(0.5);
    (top, accel, turn)
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
    let urdf = atrium_robots::generic_robot_urdf(&format!("{stem}_robot"), log.laser_mount_3());
    let model = RobotModel::from_urdf_str(&urdf, "the twin's generic robot")
        .map_err(|e| ScenarioError::field(twin_file, "robot", e.to_string()))?;
    let clearance = planar_reach(&model) + PATH_CLEARANCE_MARGIN_M;
    let mut grid = (*map.grid).clone();
    let cleared_cells = clear_along_path(&mut grid, &log.reference, clearance);

    let start = log.start_pose();
    let (route, leg_speeds) = route(&log.reference);
    let speed = moving_speed(&log.reference);
    let (top_speed, max_accel, max_turn_rate) = drive_limits(&log.reference);
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# The twin of {} (written by `atrium twin`): the same run simulated, with the models\n\
         # calibrated from the log. Route: the reference within {ROUTE_TOLERANCE_M} m, each leg \
         driven at the\n# speed the log moved along it (median {speed:.2} m/s; stops are not \
         replayed). Map: {}, with {cleared_cells} occupied \
         cells within\n# {clearance:.2} m of the reference path made free.",
        scenario.file.display(),
        map.file.display(),
    );
    let _ = writeln!(
        t,
        "name = {}",
        toml::Value::String(format!("{}_twin", scenario.name))
    );
    let _ = writeln!(
        t,
        "map = {}",
        toml_path(Path::new(&format!("{stem}.map.yaml")))
    );
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
    let _ = writeln!(t, "# m/s on the leg ending at each waypoint\nspeeds = [");
    for row in leg_speeds.chunks(10) {
        let row: Vec<String> = row.iter().map(|v| format!("{v:.3}")).collect();
        let _ = writeln!(t, "  {},", row.join(", "));
    }
    let _ = writeln!(t, "]");
    let _ = writeln!(
        t,
        "\n# Speed, acceleration and turn rate: the 99th percentiles of the reference's.\n\
         [controller]\nmax_speed = {top_speed:.3}\nmax_accel = {max_accel:.3}\n\
         max_turn_rate = {max_turn_rate:.3}\ngoal_tolerance = {TWIN_GOAL_TOLERANCE_M}"
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
    Ok(Twin {
        toml: t,
        urdf,
        map: grid,
        cleared_cells,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn waypoints_keep_the_path_s_shape() {
        // 5 m straight, then a half circle of radius 0.5 m back.
        let mut r: Vec<(f64, Pose2)> = (0..=50)
            .map(|k| (k as f64, Pose2::new(0.1 * k as f64, 0.0, 0.0)))
            .collect();
        for k in 1..=30 {
            let a = std::f64::consts::PI * k as f64 / 30.0 - std::f64::consts::FRAC_PI_2;
            r.push((
                50.0 + k as f64,
                Pose2::new(5.0 + 0.5 * a.cos(), 0.5 + 0.5 * a.sin(), 0.0),
            ));
        }
        let w = waypoints(&r);
        // The straight part is one segment; the half circle needs several.
        assert!(
            (w[0][0] - 5.0).abs() < 0.11 && w[0][1].abs() < ROUTE_TOLERANCE_M,
            "{w:?}"
        );
        assert!((5..15).contains(&w.len()), "{w:?}");
        let last = w[w.len() - 1];
        assert!((last[0] - 5.0).abs() < 1e-9 && (last[1] - 1.0).abs() < 1e-9);
        // Every reference point is within the tolerance of the route.
        let mut route = vec![[0.0, 0.0]];
        route.extend(&w);
        for (_, p) in &r {
            let d = route
                .windows(2)
                .map(|s| segment_distance([p.x, p.y], s[0], s[1]))
                .fold(f64::INFINITY, f64::min);
            assert!(d <= ROUTE_TOLERANCE_M + 1e-9, "{p:?} {d}");
        }
        let straight: Vec<(f64, Pose2)> = r[..=50].to_vec();
        assert!((moving_speed(&straight) - 0.1).abs() < 1e-9);
    }

    #[test]
    fn each_leg_is_driven_at_the_speed_the_reference_moved_along_it() {
        // 5 m east at 0.2 m/s, a 10 s stop, then 5 m north at 0.8 m/s.
        let mut r: Vec<(f64, Pose2)> = (0..=25)
            .map(|k| (k as f64, Pose2::new(0.2 * k as f64, 0.0, 0.0)))
            .collect();
        r.extend((1..=10).map(|k| (25.0 + k as f64, Pose2::new(5.0, 0.0, 0.0))));
        r.extend((1..=25).map(|k| (35.0 + 0.25 * k as f64, Pose2::new(5.0, 0.2 * k as f64, 0.0))));
        let (w, v) = route(&r);
        assert_eq!(w.len(), 2, "{w:?}");
        assert_eq!(w.len(), v.len());
        // The stop is not counted as slow driving.
        assert!((v[0] - 0.2).abs() < 1e-9, "{v:?}");
        assert!((v[1] - 0.8).abs() < 1e-9, "{v:?}");
        let (top, accel, turn) = drive_limits(&r);
        assert!((0.79..=0.81).contains(&top), "{top}");
        assert!(accel > 0.2 && accel.is_finite(), "{accel}");
        assert!((0.5..1.0).contains(&turn), "{turn}");
    }

    #[test]
    fn a_jump_in_the_reference_does_not_set_the_top_speed() {
        // 200 poses at 0.5 m/s with one 5 m jump: the top speed stays the robot's.
        let mut r: Vec<(f64, Pose2)> = Vec::new();
        let mut x = 0.0;
        for k in 0..200 {
            x += if k == 100 { 5.0 } else { 0.1 };
            r.push((0.2 * k as f64, Pose2::new(x, 0.0, 0.0)));
        }
        let (top, _, _) = drive_limits(&r);
        assert!((top - 0.5).abs() < 1e-6, "{top}");
    }

    #[test]
    fn the_path_is_swept_free_and_nothing_else() {
        // A 2 m × 1 m grid at 0.1 m, all occupied; a path along y = 0.5 from x = 0.5 to 1.5.
        let mut g = OccupancyGrid {
            origin: [0.0, 0.0],
            resolution: 0.1,
            width: 20,
            height: 10,
            cells: vec![Cell::Occupied; 200],
        };
        let path: Vec<(f64, Pose2)> = (0..=10)
            .map(|k| (k as f64, Pose2::new(0.5 + 0.1 * k as f64, 0.5, 0.0)))
            .collect();
        let n = clear_along_path(&mut g, &path, 0.2);
        assert_eq!(g.at([1.0, 0.5]), Cell::Free);
        assert_eq!(g.at([0.36, 0.5]), Cell::Free);
        assert_eq!(g.at([1.0, 0.85]), Cell::Occupied);
        assert_eq!(g.at([0.15, 0.5]), Cell::Occupied);
        let free = g.cells.iter().filter(|c| **c == Cell::Free).count();
        assert_eq!(n, free);
        // A band 1 m long and 0.4 m wide with round ends: about 0.4 + π·0.04 m² of 0.01 m².
        assert!((45..=60).contains(&n), "{n}");
    }

    #[test]
    fn the_generic_robot_reaches_a_pioneer_s_half_diagonal() {
        let urdf = atrium_robots::generic_robot_urdf("r", Pose2::new(0.0, 0.0, 0.0));
        let m = RobotModel::from_urdf_str(&urdf, "generic").unwrap();
        let r = planar_reach(&m);
        // The Pioneer 3-DX is 0.455 m × 0.381 m (about 0.30 m from centre to corner).
        assert!((0.25..0.4).contains(&r), "{r}");
    }
}
