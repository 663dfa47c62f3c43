//! The one interface every localizer implements, and the optional capabilities the harness
//! uses when a localizer offers them.

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

/// Why a localizer could not take a reading: the run stops with this message, naming the
/// localizer and the instant. In-process filters skip readings they cannot use; a localizer
/// behind a process boundary fails when its process dies, hangs or answers garbage.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct LocalizerError(pub String);

impl LocalizerError {
    pub fn new(message: impl Into<String>) -> Self {
        Self(message.into())
    }
}

/// What a localizer must do: take odometry, take readings, say where it thinks it is.
pub trait Localizer: Send {
    /// Name from the scenario, used in reports.
    fn name(&self) -> &str;
    /// Motion update from wheel odometry.
    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError>;
    /// Measurement update; readings a localizer does not use are ignored (`Ok`).
    fn update(&mut self, reading: &Reading) -> Result<(), LocalizerError>;
    fn estimate(&self) -> Estimate;
    /// The optional harness capabilities this localizer offers (see [`Capabilities`]). A
    /// localizer that offers none keeps this default.
    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        None
    }
}

/// Harness features a localizer may take part in. Every method has a default meaning "not
/// offered", so a localizer implements only what it supports.
pub trait Capabilities {
    /// The concrete localizer, for callers that report kind-specific diagnostics (the
    /// EKF-SLAM map and covariance monitor) by downcasting.
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        None
    }
    /// A node of a node route this localizer has just verified ([002] Algorithm 1), taken
    /// once: the runner passes it to the node controller, which stops and resets its pose to
    /// the node.
    fn take_node_verification(&mut self) -> Option<usize> {
        None
    }
    /// How well recent observations agree with the belief (the sensing mismatch of [004]
    /// §4.2): the mean unnormalised observation likelihood over the belief, short-term
    /// average over long-term average (w_fast / w_slow of Augmented MCL, see
    /// `observation_fit::FitTracker`). About 1 as usual, below 1 when the belief fits the
    /// observations worse than it used to.
    fn observation_fit(&self) -> Option<f64> {
        None
    }
    /// Re-seeds the belief around `pose` with standard deviations `sigma` (x, y, θ), dropping
    /// odometry not yet applied (`pose` is a current estimate). Used by the sensor choosers
    /// (`chooser.rs`) to bring a member that has lost track back to the chosen estimate.
    /// Returns false, doing nothing, when the belief cannot be re-seeded.
    fn reset_to(&mut self, _pose: Pose2, _sigma: [f64; 3]) -> bool {
        false
    }
    /// Text the localizer wants kept with the run (a process localizer's stderr), taken once
    /// when the run has ended: the runner stores it in its `LocalizerRun` and `--out` writes
    /// it to `log_<localizer>.txt`. A localizer may finish its work first (a process
    /// localizer says goodbye to its process and waits for it to exit).
    fn log(&mut self) -> Option<String> {
        None
    }
    /// The member a chooser outputs now, by name (`chooser.rs`): the runner records it at
    /// every scored instant, so that a run reports the share of time each member was chosen.
    fn chosen_member(&self) -> Option<&str> {
        None
    }
    /// A copy in the present state, random streams included, that goes on exactly as this
    /// one would. Choosers share one filter per member and copy it only when they re-seed it
    /// (`shared_member.rs`); a localizer that cannot be copied keeps a private instance per
    /// chooser.
    fn clone_localizer(&self) -> Option<Box<dyn Localizer>> {
        None
    }
}

/// The observation fit of `l`, if it measures one.
pub fn observation_fit_of(l: &mut dyn Localizer) -> Option<f64> {
    l.capabilities().and_then(|c| c.observation_fit())
}

/// Re-seeds `l` around `pose` if it can be re-seeded (see [`Capabilities::reset_to`]).
pub fn reset_localizer(l: &mut dyn Localizer, pose: Pose2, sigma: [f64; 3]) -> bool {
    l.capabilities().is_some_and(|c| c.reset_to(pose, sigma))
}
