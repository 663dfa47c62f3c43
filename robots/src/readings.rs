//! The stamped readings sensors produce. Localizers consume these, whether they come from
//! the simulator, a recording or a real robot.

use crate::pose::Pose2;
use serde::{Deserialize, Serialize};

/// One planar laser sweep. Beam `i` points at `angle_min + i * angle_increment` in the laser
/// frame. A reading equal to `range_max` means "nothing returned"; ranges are in metres.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LaserScan {
    /// Seconds of simulation (or recording) time.
    pub stamp: f64,
    /// Sensor name from the robot's sensor file.
    pub sensor: String,
    /// The laser frame in the robot's base frame (projected to the floor plane).
    pub mount: Pose2,
    pub angle_min: f64,
    pub angle_increment: f64,
    pub range_min: f64,
    pub range_max: f64,
    pub ranges: Vec<f64>,
}

impl LaserScan {
    pub fn beam_angle(&self, i: usize) -> f64 {
        self.angle_min + i as f64 * self.angle_increment
    }
}

/// Wheel odometry: the pose integrated from the wheel encoders in the odometry frame (it
/// drifts), plus the raw cumulative tick counts it came from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WheelOdometry {
    pub stamp: f64,
    pub pose: Pose2,
    pub left_ticks: i64,
    pub right_ticks: i64,
}

/// Every kind of reading, in one time-ordered stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Reading {
    Odometry(WheelOdometry),
    Laser(LaserScan),
}

impl Reading {
    pub fn stamp(&self) -> f64 {
        match self {
            Reading::Odometry(o) => o.stamp,
            Reading::Laser(l) => l.stamp,
        }
    }
}
