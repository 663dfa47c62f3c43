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
    /// How well recent observations agree with the belief (the sensing mismatch of
    /// 004_5bf198ec52fcbc0c.txt §4.2): the mean unnormalised observation likelihood over the
    /// belief, short-term average over long-term average (w_fast / w_slow of Augmented MCL,
    /// see `observation_fit::FitTracker`). About 1 as usual, below 1 when the belief fits the
    /// observations worse than it used to. `None` for localizers that do not measure it.
    fn observation_fit(&self) -> Option<f64> {
        None
    }
    /// Re-seeds the belief around `pose` with standard deviations `sigma` (x, y, θ), dropping
    /// odometry not yet applied (`pose` is a current estimate). Used by the sensor choosers
    /// (`chooser.rs`) to bring a member that has lost track back to the chosen estimate.
    /// Returns false, doing nothing, for localizers that cannot be re-seeded.
    fn reset_to(&mut self, _pose: Pose2, _sigma: [f64; 3]) -> bool {
        false
    }
}
