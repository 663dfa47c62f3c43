//! Calibration of the simulation's models from a real log: the wheel odometry's systematic
//! and random errors ([`odometry`]) against the log's reference, and the laser's measurement
//! mixture ([`laser`]) against the map at the reference poses. `atrium calibrate` writes them
//! as the `[odometry]` and `[sensors.<name>]` tables a simulated scenario reads.

pub mod drift;
pub mod laser;
pub mod odometry;

use crate::error::ScenarioError;
use crate::scenario::Scenario;
use serde::Serialize;

/// Both calibrated models of a log scenario.
#[derive(Debug, Clone, Serialize)]
pub struct Calibration {
    pub scenario: String,
    pub odometry: odometry::OdometryFit,
    /// The laser's name in the scenario (`[sensors.<name>]`).
    pub laser_name: String,
    pub laser: laser::LaserFit,
}

/// Calibrates the odometry (against the reference) and the laser (against the map at the
/// reference poses) of the log scenario `scenario`; errors name the scenario's field.
pub fn calibrate(scenario: &Scenario) -> Result<Calibration, ScenarioError> {
    let log = scenario.log.as_deref().ok_or_else(|| {
        ScenarioError::field(
            &scenario.file,
            "log",
            "calibration needs a log scenario ([log] with a reference)",
        )
    })?;
    let map = scenario.grid_map.as_ref().ok_or_else(|| {
        ScenarioError::field(
            &scenario.file,
            "map",
            "calibrating the laser needs the log's map (map = \"X.yaml\")",
        )
    })?;
    let track = scenario.robot.drive().wheel_separation;
    let pairs = odometry::paired_from(&log.reference, |t| log.odometry_at(t));
    let odometry = odometry::fit_odometry(&pairs, track, crate::log::REFERENCE_MAX_GAP_S)
        .map_err(|e| ScenarioError::field(&scenario.file, "log.reference", e))?;
    let scans: Vec<laser::ScanAtPose> = log
        .scans
        .iter()
        .filter_map(|s| {
            log.reference_at(s.stamp).map(|base| laser::ScanAtPose {
                pose: base.compose(&s.mount),
                angle_min: s.angle_min,
                angle_increment: s.angle_increment,
                ranges: &s.ranges,
            })
        })
        .collect();
    let laser = laser::fit_laser(&map.grid, &scans, log.laser.range_max)
        .map_err(|e| ScenarioError::field(&scenario.file, "log.scan_topic", e))?;
    Ok(Calibration {
        scenario: scenario.name.clone(),
        odometry,
        laser_name: log.laser.name.clone(),
        laser,
    })
}

/// The `[odometry]` keys of a fit, one per line, each with its standard error as a comment.
pub fn odometry_lines(o: &odometry::OdometryFit) -> String {
    format!(
        "scale_error = {:.5}  # ± {:.5}\n\
         radius_error = {:.5}  # ± {:.5}\n\
         separation_error = {:.5}  # ± {:.5}\n\
         slip_sigma = {:.5}  # ± {:.5}\n\
         slip_correlation_m = {:.3}  # ± {:.3}\n",
        o.scale_error,
        o.stderr.scale_error,
        o.radius_error,
        o.stderr.radius_error,
        o.separation_error,
        o.stderr.separation_error,
        o.slip_sigma,
        o.stderr.slip_sigma,
        o.slip_correlation_m,
        o.stderr.slip_correlation_m,
    )
}

/// The laser noise keys of a fit (a `[sensors.<name>]` table's model), one per line, each
/// with its standard error as a comment.
pub fn laser_lines(l: &laser::LaserFit) -> String {
    let u = &l.uncertainty;
    format!(
        "sigma_hit = {:.4}  # ± {:.4}\n\
         sigma_hit_per_m = {:.5}  # ± {:.5}\n\
         p_short = {:.4}  # ± {:.4}\n\
         lambda_short = {:.3}  # ± {:.3}\n\
         p_max = {:.4}  # ± {:.4}\n\
         p_rand = {:.4}  # ± {:.4}\n",
        l.sigma_hit,
        u.sigma_hit,
        l.sigma_hit_per_m,
        u.sigma_hit_per_m,
        l.p_short,
        u.p_short,
        l.lambda_short,
        u.lambda_short,
        l.p_max,
        u.p_max,
        l.p_rand,
        u.p_rand,
    )
}

/// The `[odometry]` and `[sensors.<name>]` tables of a calibration, with each estimate's
/// standard error as a comment, for a simulated scenario to include.
pub fn to_toml(c: &Calibration) -> String {
    let o = &c.odometry;
    let l = &c.laser;
    format!(
        "# Calibrated from the log scenario {:?} by `atrium calibrate`: value  # ± standard error\n\
         # (odometry: {} segments over {:.0} m of path, for a wheel track of {:.3} m; laser: {} beams of {} scans).\n\
         [odometry]\n{}\n[sensors.{}]\n{}",
        c.scenario,
        o.segments,
        o.path_m,
        o.track_m,
        l.beams_used,
        l.scans_used,
        odometry_lines(o),
        c.laser_name,
        laser_lines(l),
    )
}
