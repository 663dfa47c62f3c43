//! Robot descriptions and the data every sensor produces.
//!
//! This crate is a leaf: it knows URDF and kinematics, never physics. `sim` turns a
//! [`RobotModel`] into rapier bodies; `localization` consumes the [`Reading`]s.

pub mod diff_drive;
pub mod error;
pub mod model;
pub mod pose;
pub mod readings;
pub mod sensors;
mod urdf;

pub use diff_drive::DiffDrive;
pub use error::RobotError;
pub use model::{Caster, LinkMount, RobotModel, Shape, ShapeInstance, Wheel};
pub use pose::{normalize_angle, Pose2};
pub use readings::{
    DepthImage, LandmarkDetection, LandmarkDetections, LaserScan, Mount3, Reading, WheelOdometry,
    WifiReading, WifiScan,
};
pub use sensors::{LaserSpec, OdometrySpec, RobotSensors};
