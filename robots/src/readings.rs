//! The stamped readings sensors produce. Localizers consume these, whether they come from
//! the simulator, a recording or a real robot.

use crate::pose::{Mount3, Pose2};
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

/// A depth image from a pinhole camera whose optical frame looks along the mount's +x
/// (REP-103 body convention: x forward, y left, z up). Pixel (u, v) is column u from the
/// left, row v from the top; `depth[v * width + u]` is the distance along the optical axis
/// (metres), 0 where the pixel is invalid (out of range, glass, grazing incidence).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DepthImage {
    pub stamp: f64,
    pub sensor: String,
    pub mount: Mount3,
    pub width: usize,
    pub height: usize,
    /// Pinhole intrinsics in pixels: focal lengths and principal point.
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub depth: Vec<f32>,
}

/// One access point heard in a WiFi scan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WifiReading {
    /// Access point name (or BSSID) as the world names it.
    pub ap: String,
    pub channel: u32,
    /// Received signal strength, dBm.
    pub rssi_dbm: f64,
}

/// A WiFi scan: the access points heard (those below the sensitivity cut-off are absent).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WifiScan {
    pub stamp: f64,
    pub sensor: String,
    pub readings: Vec<WifiReading>,
}

/// A range-bearing detection of a point feature (a pillar's centre).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LandmarkDetection {
    pub range: f64,
    /// Radians, counter-clockwise from the sensor's +x.
    pub bearing: f64,
    /// The feature's identity when data association is known; None when the localizer must
    /// associate it itself.
    pub id: Option<usize>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LandmarkDetections {
    pub stamp: f64,
    pub sensor: String,
    /// The detector's frame in the base frame (floor plane).
    pub mount: Pose2,
    pub detections: Vec<LandmarkDetection>,
}

/// Every kind of reading, in one time-ordered stream.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Reading {
    Odometry(WheelOdometry),
    Laser(LaserScan),
    Depth(DepthImage),
    Wifi(WifiScan),
    Landmarks(LandmarkDetections),
    /// A grey image from a camera ([000] §III; also the omnidirectional and ceiling
    /// cameras of [001]).
    Intensity(crate::images::IntensityImage),
    /// A stereo disparity map with missing values ([000] §III).
    Disparity(crate::images::DisparityImage),
}

impl Reading {
    pub fn stamp(&self) -> f64 {
        match self {
            Reading::Odometry(o) => o.stamp,
            Reading::Laser(l) => l.stamp,
            Reading::Depth(d) => d.stamp,
            Reading::Wifi(w) => w.stamp,
            Reading::Landmarks(l) => l.stamp,
            Reading::Intensity(i) => i.stamp,
            Reading::Disparity(d) => d.stamp,
        }
    }
}
