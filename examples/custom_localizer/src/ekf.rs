//! An extended Kalman filter over the pose (x, y, θ): odometry motion model for the
//! prediction, laser ranges to the mapped walls for the correction.

use crate::walls::Walls;
use atrium_localization::{Estimate, Localizer, LocalizerError, OdometryDelta};
use atrium_robots::{normalize_angle, LaserScan, Pose2, Reading};
use nalgebra::{Matrix3, Vector3};
use serde::Deserialize;

/// The `[[localizers]]` keys of a `wall_ekf` (every one optional).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Beams used per scan, spread evenly over it.
    pub beams: usize,
    /// Range noise of a beam, m: the laser's own noise and what the map gets wrong.
    pub sigma_range: f64,
    /// A beam whose innovation exceeds `gate` of its standard deviations is dropped (glass,
    /// furniture, people: anything the map does not hold).
    pub gate: f64,
    /// Odometry noise as random walks, so the figures do not depend on the odometry rate:
    /// position std after 1 m travelled (m/√m), heading std after 1 rad turned (rad/√rad)
    /// and after 1 m travelled (rad/√m). The defaults cover the bundled robots' random wheel
    /// slip (σ 0.04 over 0.05 m per wheel: about 0.009 m/√m and, on a 0.33 m track,
    /// 0.054 rad/√m).
    pub odom_trans: f64,
    pub odom_rot: f64,
    pub odom_drift: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            beams: 30,
            sigma_range: 0.05,
            gate: 3.0,
            odom_trans: 0.01,
            odom_rot: 0.05,
            odom_drift: 0.05,
        }
    }
}

impl Params {
    /// The first bad key and what is wrong with it.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if self.beams == 0 {
            return Err(("beams", "must be at least 1".into()));
        }
        let positive = [
            ("sigma_range", self.sigma_range),
            ("gate", self.gate),
            ("odom_trans", self.odom_trans),
            ("odom_rot", self.odom_rot),
            ("odom_drift", self.odom_drift),
        ];
        match positive.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
            Some((key, v)) => Err((key, format!("must be a positive number, got {v}"))),
            None => Ok(()),
        }
    }
}

/// Beams meeting a wall at less than this cosine of incidence are skipped: near grazing,
/// the range is too sensitive to the heading for a linearisation to hold.
const MIN_INCIDENCE_COS: f64 = 0.25;

/// The filter: a Gaussian belief N(pose, cov) over (x, y, θ).
pub struct WallEkf {
    name: String,
    pose: Pose2,
    cov: Matrix3<f64>,
    stamp: f64,
    walls: Walls,
    params: Params,
}

impl WallEkf {
    /// A filter starting at `start` with standard deviations `sigma` (x, y, θ).
    pub fn new(name: &str, start: Pose2, sigma: [f64; 3], walls: Walls, params: Params) -> Self {
        let var = Vector3::from(sigma).map(|s| s * s);
        Self {
            name: name.to_owned(),
            pose: start,
            cov: Matrix3::from_diagonal(&var),
            stamp: 0.0,
            walls,
            params,
        }
    }

    /// One beam's expected range and its gradient with respect to (x, y, θ), None when the
    /// map gives it no usable wall within the laser's range.
    fn predict_beam(&self, scan: &LaserScan, i: usize) -> Option<(f64, Vector3<f64>)> {
        let sensor = self.pose.compose(&scan.mount);
        let phi = sensor.theta + scan.beam_angle(i);
        let hit = self.walls.cast([sensor.x, sensor.y], phi, scan.range_max)?;
        let (u, du) = ([phi.cos(), phi.sin()], [-phi.sin(), phi.cos()]);
        let n = hit.normal;
        let n_u = n[0] * u[0] + n[1] * u[1];
        if n_u.abs() < MIN_INCIDENCE_COS {
            return None;
        }
        // range = (n·a − n·p) / (n·u): the sensor moving by dp changes it by −n·dp / (n·u),
        // the beam turning by dφ by −range (n·u′) / (n·u).
        let d_range_d_phi = -hit.range * (n[0] * du[0] + n[1] * du[1]) / n_u;
        let (s, c) = self.pose.theta.sin_cos();
        let (mx, my) = (scan.mount.x, scan.mount.y);
        let dp_dtheta = [-s * mx - c * my, c * mx - s * my];
        let dx = -n[0] / n_u;
        let dy = -n[1] / n_u;
        let dtheta = dx * dp_dtheta[0] + dy * dp_dtheta[1] + d_range_d_phi;
        Some((hit.range, Vector3::new(dx, dy, dtheta)))
    }
}

impl Localizer for WallEkf {
    fn name(&self) -> &str {
        &self.name
    }

    /// x' = x ⊕ u with u the odometry increment in the robot frame; P' = F P Fᵀ + Q.
    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError> {
        let u = delta.from.between(&delta.to);
        let (s, c) = self.pose.theta.sin_cos();
        #[rustfmt::skip]
        let f = Matrix3::new(
            1.0, 0.0, -s * u.x - c * u.y,
            0.0, 1.0, c * u.x - s * u.y,
            0.0, 0.0, 1.0,
        );
        let p = &self.params;
        let dist = u.x.hypot(u.y);
        let var_xy = p.odom_trans.powi(2) * dist;
        let var_theta = p.odom_rot.powi(2) * u.theta.abs() + p.odom_drift.powi(2) * dist;
        let q = Matrix3::from_diagonal(&Vector3::new(var_xy, var_xy, var_theta));
        self.pose = self.pose.compose(&u);
        self.cov = f * self.cov * f.transpose() + q;
        self.stamp = delta.stamp;
        Ok(())
    }

    /// All gated beams of a scan in one update, in information form:
    /// P⁺ = (P⁻¹ + Hᵀ H / σ²)⁻¹, x⁺ = x + P⁺ Hᵀ (z − h(x)) / σ².
    fn update(&mut self, reading: &Reading) -> Result<(), LocalizerError> {
        let Reading::Laser(scan) = reading else {
            return Ok(());
        };
        let Some(prior_info) = self.cov.try_inverse() else {
            return Err(LocalizerError::new("wall_ekf: covariance became singular"));
        };
        let var = self.params.sigma_range.powi(2);
        let step = (scan.ranges.len() as f64 / self.params.beams as f64).max(1.0);
        let (mut info, mut grad) = (Matrix3::zeros(), Vector3::zeros());
        for i in (0..self.params.beams).map(|k| (k as f64 * step) as usize) {
            let Some(&z) = scan.ranges.get(i) else { break };
            if !(z > scan.range_min && z < scan.range_max) {
                continue; // no return: says little about where the walls are
            }
            let Some((expected, h)) = self.predict_beam(scan, i) else {
                continue;
            };
            let residual = z - expected;
            let innovation_var = (h.transpose() * self.cov * h)[0] + var;
            if residual.abs() > self.params.gate * innovation_var.sqrt() {
                continue; // not the mapped wall
            }
            info += h * h.transpose() / var;
            grad += h * residual / var;
        }
        if info == Matrix3::zeros() {
            return Ok(());
        }
        let Some(cov) = (prior_info + info).try_inverse() else {
            return Ok(());
        };
        let dx = cov * grad;
        self.pose = Pose2::new(
            self.pose.x + dx[0],
            self.pose.y + dx[1],
            normalize_angle(self.pose.theta + dx[2]),
        );
        self.cov = (cov + cov.transpose()) * 0.5;
        self.stamp = self.stamp.max(scan.stamp);
        Ok(())
    }

    fn estimate(&self) -> Estimate {
        Estimate {
            stamp: self.stamp,
            pose: self.pose,
            covariance: self.cov,
        }
    }
}
