//! Dead reckoning: the odometry pose carried over to the map frame, with a covariance that
//! grows with the distance travelled and the rotation accumulated.

use crate::localizer::{Estimate, Localizer, LocalizerError, OdometryDelta};
use atrium_robots::{normalize_angle, Pose2, Reading};
use nalgebra::Matrix3;

/// Drift model of [`DeadReckoning`]. Wheel odometry errors are dominated by systematic
/// calibration errors (wheel radius, wheelbase), which make the error grow linearly with the
/// distance and the rotation rather than with their square root:
///
/// σ_xy = k_d · d  (isotropic, per axis)
/// σ_θ  = k_θ · d + k_r · R
///
/// with d the distance travelled and R the accumulated absolute rotation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriftModel {
    /// Position standard deviation per metre travelled (m/m). Default 0.02.
    pub k_d: f64,
    /// Heading standard deviation per metre travelled (rad/m). Default 0.01.
    pub k_theta: f64,
    /// Heading standard deviation per radian turned (rad/rad). Default 0.02, twice the 1 %
    /// wheelbase error the simulated odometry has by default.
    pub k_r: f64,
}

impl Default for DriftModel {
    fn default() -> Self {
        Self {
            k_d: 0.02,
            k_theta: 0.01,
            k_r: 0.02,
        }
    }
}

/// Localizer that only integrates odometry: pose = start ⊕ (first odometry pose⁻¹ ⊕ current
/// odometry pose). The baseline every other localizer must beat.
#[derive(Debug, Clone)]
pub struct DeadReckoning {
    name: String,
    start: Pose2,
    drift: DriftModel,
    first: Option<Pose2>,
    last: Pose2,
    stamp: f64,
    distance: f64,
    rotation: f64,
}

impl DeadReckoning {
    pub fn new(name: &str, start: Pose2) -> Self {
        Self {
            name: name.to_owned(),
            start,
            drift: DriftModel::default(),
            first: None,
            last: Pose2::default(),
            stamp: 0.0,
            distance: 0.0,
            rotation: 0.0,
        }
    }

    pub fn with_drift(mut self, drift: DriftModel) -> Self {
        self.drift = drift;
        self
    }

    /// Distance travelled so far according to odometry, metres.
    pub fn distance(&self) -> f64 {
        self.distance
    }

    /// Absolute rotation accumulated so far according to odometry, radians.
    pub fn rotation(&self) -> f64 {
        self.rotation
    }

    fn pose(&self) -> Pose2 {
        match self.first {
            Some(first) => self.start.compose(&first.between(&self.last)),
            None => self.start,
        }
    }
}

impl Localizer for DeadReckoning {
    fn name(&self) -> &str {
        &self.name
    }

    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError> {
        if !delta.from.is_finite() || !delta.to.is_finite() {
            return Ok(());
        }
        if self.first.is_none() {
            self.first = Some(delta.from);
            self.last = delta.from;
        }
        // Measured from the last pose seen rather than `delta.from`, so a repeated or gapped
        // delta neither double-counts nor loses distance.
        self.distance += self.last.distance(&delta.to);
        self.rotation += normalize_angle(delta.to.theta - self.last.theta).abs();
        self.last = delta.to;
        self.stamp = delta.stamp;
        Ok(())
    }

    /// Dead reckoning uses no exteroceptive reading; odometry arrives through `predict`.
    fn update(&mut self, _reading: &Reading) -> Result<(), LocalizerError> {
        Ok(())
    }

    fn estimate(&self) -> Estimate {
        let s_xy = self.drift.k_d * self.distance;
        let s_th = self.drift.k_theta * self.distance + self.drift.k_r * self.rotation;
        Estimate {
            stamp: self.stamp,
            pose: self.pose(),
            covariance: Matrix3::from_diagonal(&nalgebra::Vector3::new(
                s_xy * s_xy,
                s_xy * s_xy,
                s_th * s_th,
            )),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn delta(stamp: f64, from: Pose2, to: Pose2) -> OdometryDelta {
        OdometryDelta { stamp, from, to }
    }

    #[test]
    fn carries_odometry_into_the_start_frame() {
        // Odometry starts at (10, 5, π/2); the map start is (1, 2, 0). Driving 1 m "up" in
        // odometry is 1 m forward, i.e. +x in the map.
        let mut dr = DeadReckoning::new("dr", Pose2::new(1.0, 2.0, 0.0));
        let o0 = Pose2::new(10.0, 5.0, FRAC_PI_2);
        let o1 = Pose2::new(10.0, 6.0, FRAC_PI_2);
        let o2 = Pose2::new(10.0, 6.0, 0.0); // turn right in place
        dr.predict(&delta(0.1, o0, o1)).unwrap();
        dr.predict(&delta(0.2, o1, o2)).unwrap();
        let e = dr.estimate();
        assert!((e.pose.x - 2.0).abs() < 1e-12);
        assert!((e.pose.y - 2.0).abs() < 1e-12);
        assert!((e.pose.theta + FRAC_PI_2).abs() < 1e-12);
        assert_eq!(e.stamp, 0.2);
        // d = 1 m, R = π/2.
        let s_xy = 0.02;
        let s_th = 0.01 + 0.02 * FRAC_PI_2;
        assert!((e.covariance[(0, 0)] - s_xy * s_xy).abs() < 1e-15);
        assert!((e.covariance[(1, 1)] - s_xy * s_xy).abs() < 1e-15);
        assert!((e.covariance[(2, 2)] - s_th * s_th).abs() < 1e-15);
    }

    #[test]
    fn repeated_delta_does_not_double_count() {
        let mut dr = DeadReckoning::new("dr", Pose2::default());
        let a = Pose2::new(0.0, 0.0, 0.0);
        let b = Pose2::new(3.0, 4.0, 0.0);
        dr.predict(&delta(1.0, a, b)).unwrap();
        dr.predict(&delta(1.0, a, b)).unwrap();
        assert!((dr.distance() - 5.0).abs() < 1e-12);
        assert!((dr.estimate().pose.x - 3.0).abs() < 1e-12);
    }

    #[test]
    fn before_any_odometry_the_estimate_is_the_start() {
        let dr = DeadReckoning::new("dr", Pose2::new(1.0, -1.0, 0.5));
        let e = dr.estimate();
        assert_eq!(e.pose, Pose2::new(1.0, -1.0, 0.5));
        assert_eq!(e.covariance, Matrix3::zeros());
    }
}
