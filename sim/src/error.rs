//! The one error type of the simulator. Every variant names what it is about (the world, the
//! robot, the config field or the pose) and what is wrong, so a caller can print it as is.

use atrium_robots::Pose2;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The robot, placed at `pose`, overlaps a wall or pillar.
    #[error(
        "cannot place the robot at x = {:.3} m, y = {:.3} m, theta = {:.3} rad: it overlaps {obstacle} (material `{material}`)",
        .pose.x, .pose.y, .pose.theta
    )]
    Spawn {
        pose: Pose2,
        /// For example `walls[3]` or `pillars[0]`, indices into the `World`'s lists.
        obstacle: String,
        material: String,
    },
    /// A simulation setting is missing, non-finite or out of range.
    #[error("sim config: {field}: {msg}")]
    Config { field: String, msg: String },
    /// The world cannot be turned into a physics scene.
    #[error("world `{world}`: {field}: {msg}")]
    World {
        world: String,
        field: String,
        msg: String,
    },
    /// The robot model cannot be turned into physics bodies.
    #[error("robot `{robot}`: {field}: {msg}")]
    Robot {
        robot: String,
        field: String,
        msg: String,
    },
}

impl SimError {
    pub(crate) fn config(field: impl Into<String>, msg: impl Into<String>) -> Self {
        SimError::Config {
            field: field.into(),
            msg: msg.into(),
        }
    }
}

/// `Ok` when `v` is finite and strictly positive; the error names `field`.
pub(crate) fn positive(field: &str, v: f64) -> Result<f64, SimError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(SimError::config(
            field,
            format!("must be finite and > 0, got {v}"),
        ))
    }
}
