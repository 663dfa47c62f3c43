//! The simulator: a rapier3d scene built from a [`atrium_worlds::World`] and a
//! [`atrium_robots::RobotModel`], driven by a waypoint follower through wheel motors, read by
//! wheel encoders and laser rangefinders on a fixed-step schedule, with ground truth.

pub mod camera;
pub mod camera_stream;
pub mod controller;
pub mod depth;
pub mod encoders;
pub mod error;
pub mod fixtures;
pub mod frustum;
pub mod landmarks;
pub mod laser;
pub mod node_controller;
pub mod people;
pub mod person_shape;
pub mod robot;
pub mod scene;
mod schedule;
pub mod simulation;
pub mod stereo;
pub mod wifi;

pub use controller::{ControllerParams, WaypointFollower};
pub use depth::DepthCamera;
pub use encoders::{Encoder, Odometry};
pub use error::SimError;
pub use landmarks::LandmarkDetector;
pub use laser::{cast_beam, Laser};
pub use node_controller::{NodeArrival, NodeController, NodeControllerParams};
pub use people::{People, PeopleParams, PeoplePlacement};
pub use robot::RobotBodies;
pub use scene::{LaserSurface, Scene, SceneMaterial, StaticKind};
pub use simulation::{SimConfig, Simulation};
pub use wifi::{WifiField, WifiSensor};
