//! The simulator: a rapier3d scene built from a [`atrium_worlds::World`] and a
//! [`atrium_robots::RobotModel`], driven by a waypoint follower through wheel motors, read by
//! wheel encoders and laser rangefinders on a fixed-step schedule, with ground truth.

pub mod controller;
pub mod encoders;
pub mod error;
pub mod fixtures;
pub mod laser;
pub mod robot;
pub mod scene;
pub mod simulation;

pub use controller::{ControllerParams, WaypointFollower};
pub use encoders::{Encoder, Odometry};
pub use error::SimError;
pub use laser::{cast_beam, Laser};
pub use robot::RobotBodies;
pub use scene::{LaserSurface, Scene, SceneMaterial, StaticKind};
pub use simulation::{SimConfig, Simulation};
