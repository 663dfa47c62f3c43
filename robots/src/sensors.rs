//! Sensor specifications: what a sensor is, where it is mounted and how it errs. A robot's
//! sensor file (`<robot>.sensors.toml` beside its URDF) lists them; a scenario may override.

use serde::{Deserialize, Serialize};

/// A planar laser rangefinder with the beam model's error terms (Thrun et al., ch. 6.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserSpec {
    pub name: String,
    /// URDF link the laser frame is attached to.
    pub mount: String,
    pub rate_hz: f64,
    pub beams: usize,
    /// Total field of view, radians, centred on the laser's +x.
    pub fov: f64,
    pub range_min: f64,
    pub range_max: f64,
    /// Standard deviation of the Gaussian range noise, m.
    pub sigma_hit: f64,
    /// Probability that a beam returns short (unmodelled obstacle), exponential with `lambda_short`.
    pub p_short: f64,
    pub lambda_short: f64,
    /// Probability that a beam fails and reads `range_max`.
    pub p_max: f64,
    /// Probability of a uniformly random reading.
    pub p_rand: f64,
}

impl LaserSpec {
    /// SICK LMS200-like: 181 beams over 180°, 8 m indoor range.
    pub fn sick_lms200(name: &str, mount: &str) -> Self {
        Self {
            name: name.into(),
            mount: mount.into(),
            rate_hz: 10.0,
            beams: 181,
            fov: std::f64::consts::PI,
            range_min: 0.05,
            range_max: 8.0,
            sigma_hit: 0.01,
            p_short: 0.01,
            lambda_short: 1.0,
            p_max: 0.005,
            p_rand: 0.005,
        }
    }

    /// Hokuyo URG-04LX-like: 683 beams over 240°, 5.6 m range.
    pub fn hokuyo_urg04lx(name: &str, mount: &str) -> Self {
        Self {
            name: name.into(),
            mount: mount.into(),
            rate_hz: 10.0,
            beams: 683,
            fov: 240f64.to_radians(),
            range_min: 0.02,
            range_max: 5.6,
            sigma_hit: 0.015,
            p_short: 0.01,
            lambda_short: 1.0,
            p_max: 0.01,
            p_rand: 0.005,
        }
    }

    pub fn preset(preset: &str, name: &str, mount: &str) -> Option<Self> {
        match preset {
            "sick_lms200" => Some(Self::sick_lms200(name, mount)),
            "hokuyo_urg04lx" => Some(Self::hokuyo_urg04lx(name, mount)),
            _ => None,
        }
    }

    pub fn angle_min(&self) -> f64 {
        -0.5 * self.fov
    }

    pub fn angle_increment(&self) -> f64 {
        if self.beams > 1 {
            self.fov / (self.beams - 1) as f64
        } else {
            0.0
        }
    }
}

/// Wheel encoders and the systematic errors of the odometry computed from them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometrySpec {
    pub ticks_per_rev: u32,
    /// Relative mismatch between the believed radii of the two wheels: odometry uses
    /// r·(1 + e/2) for the left wheel and r·(1 − e/2) for the right.
    pub radius_error: f64,
    /// Relative error of the believed wheel separation: odometry uses b·(1 + e).
    pub separation_error: f64,
    /// Odometry publication rate, Hz.
    pub rate_hz: f64,
}

impl Default for OdometrySpec {
    fn default() -> Self {
        Self {
            ticks_per_rev: 500,
            radius_error: 0.005,
            separation_error: 0.01,
            rate_hz: 50.0,
        }
    }
}

/// The contents of a robot's sensor file.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotSensors {
    pub odometry: OdometrySpec,
    pub lasers: Vec<LaserSpec>,
}
