//! Robot descriptions and the data every sensor produces.
//!
//! This crate is a leaf: it knows URDF and kinematics, never physics. `sim` turns a
//! [`RobotModel`] into rapier bodies; `localization` consumes the [`Reading`]s.

pub mod depth_camera;
pub mod diff_drive;
pub mod error;
pub mod images;
pub mod landmark_detector;
pub mod model;
pub mod node_route;
pub mod pose;
pub mod readings;
pub mod sensors;
mod urdf;
pub mod wifi;

pub use depth_camera::DepthCameraSpec;
pub use diff_drive::DiffDrive;
pub use error::RobotError;
pub use images::{DisparityImage, IntensityImage};
pub use landmark_detector::{Association, LandmarkDetectorSpec};
pub use model::{Caster, LinkMount, RobotModel, Shape, ShapeInstance, Wheel};
pub use pose::{normalize_angle, Pose2};
pub use readings::{
    DepthImage, LandmarkDetection, LandmarkDetections, LaserScan, Mount3, Reading, WheelOdometry,
    WifiReading, WifiScan,
};
pub use sensors::{LaserSpec, OdometrySpec, RobotSensors};
pub use wifi::WifiSpec;
