//! Robot descriptions and the data every sensor produces.
//!
//! This crate is a leaf: it knows URDF and kinematics, never physics. `sim` turns a
//! [`RobotModel`] into rapier bodies; `localization` consumes the [`Reading`]s.

pub mod depth_camera;
pub mod diff_drive;
pub mod drive_override;
pub mod error;
pub mod gazebo;
pub mod generic;
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
pub use gazebo::{read_gazebo_sensors, GazeboSensors};
pub use generic::generic_robot_urdf;
pub use images::{DisparityImage, IntensityImage};
pub use landmark_detector::{Association, LandmarkDetectorSpec};
pub use model::{
    Caster, DriveOverride, DriveSource, ExcludedJoint, LinkMount, RobotInspection, RobotModel,
    Shape, ShapeInstance, UrdfJoint, Wheel,
};
pub use pose::{normalize_angle, Mount3, Pose2};
pub use readings::{
    DepthImage, LandmarkDetection, LandmarkDetections, LaserScan, Reading, WheelOdometry,
    WifiReading, WifiScan,
};
pub use sensors::{LaserSpec, OdometrySpec, RobotSensors};
/// The limits the URDF loader enforces (each refusal names the file, the field and the limit).
pub mod urdf_limits {
    pub use crate::urdf::{
        MAX_ANGLE_RAD, MAX_INERTIA, MAX_LENGTH_M, MAX_MASS_KG, MAX_WHEEL_RADIUS_M,
        MAX_WHEEL_RADIUS_PER_SEPARATION, MAX_XML_DEPTH, MIN_MASS_KG, MIN_WHEEL_RADIUS_M,
        MIN_WHEEL_SEPARATION_M, QUAT_NORM_RANGE,
    };
}
pub use wifi::WifiSpec;
