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
    /// The concrete localizer, for callers that report kind-specific diagnostics (the
    /// EKF-SLAM map and covariance monitor) by downcasting. `None` unless a localizer opts in.
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        None
    }
    /// A node of a node route this localizer has just verified (002 Algorithm 1), taken once:
    /// the runner passes it to the node controller, which stops and resets its pose to the
    /// node. Localizers that verify nothing keep this default.
    fn take_node_verification(&mut self) -> Option<usize> {
        None
    }
}
