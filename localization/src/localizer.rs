//! The one interface every localizer implements.

use atrium_robots::{Pose2, Reading};
use nalgebra::Matrix3;

/// Two consecutive odometry poses (Thrun et al., Probabilistic Robotics §5.4: the control is
/// the pair of odometry readings, not a velocity).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryDelta {
    pub stamp: f64,
    pub from: Pose2,
    pub to: Pose2,
}

/// A pose estimate with its covariance over (x, y, θ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub stamp: f64,
    pub pose: Pose2,
    pub covariance: Matrix3<f64>,
}

pub trait Localizer: Send {
    /// Name from the scenario, used in reports.
    fn name(&self) -> &str;
    /// Motion update from wheel odometry.
    fn predict(&mut self, delta: &OdometryDelta);
    /// Measurement update; readings a localizer does not use are ignored.
    fn update(&mut self, reading: &Reading);
    fn estimate(&self) -> Estimate;
}
