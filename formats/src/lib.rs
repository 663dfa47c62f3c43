//! The file formats Atrium reads and writes, one module per format, each usable alone (no
//! simulator, no harness): they turn bytes into the plain data types of `atrium-robots` and
//! `atrium-worlds` and back, and every error names the file and the field, topic, line or
//! byte where the input is wrong.
//!
//! | module | format |
//! |---|---|
//! | [`mcap`] | MCAP container (checked reader) |
//! | [`cdr`] | CDR, the serialization of ROS 2 messages |
//! | [`rosbag2`] | rosbag2 message definitions |
//! | [`tum`] | TUM and CSV trajectories |
//! | [`relations`] | benchmark relations (relative poses between two stamps) |
//! | [`sdf`] | SDF worlds for Gazebo (written) |

pub mod cdr;
pub mod error;
pub mod mcap;
pub mod relations;
pub mod rosbag2;
pub mod sdf;
pub mod tum;

pub use error::FormatError;
