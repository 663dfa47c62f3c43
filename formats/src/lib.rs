//! The file formats Atrium reads and writes, one module per format, each usable alone (no
//! simulator, no harness): they turn bytes into the plain data types of `atrium-robots` and
//! `atrium-worlds` and back, and every error names the file and the field, topic, line or
//! byte where the input is wrong.
//!
//! | module | format |
//! |---|---|
//! | [`mcap`] | MCAP container (checked reader) |
//! | [`cdr`] | CDR, the serialization of ROS 2 messages |
//! | [`ros_msgs`] | the standard ROS messages a localizer reads, from ROS 1 or ROS 2 bytes |
//! | [`rosbag2`] | rosbag2 folders (MCAP or sqlite3 storage) |
//! | [`ros1`] | ROS 1 bags (bz2 and lz4 chunks) |
//! | [`carmen`] | CARMEN logs |
//! | [`robot_log`] | any of the three robot logs behind one interface |
//! | [`ros_map`] | ROS map_server maps (YAML + PGM/PNG) |
//! | [`tum`] | TUM and CSV trajectories |
//! | [`output_path`] | where an output may be written (no devices, FIFOs or sockets) |
//! | [`relations`] | benchmark relations (relative poses between two stamps) |
//! | [`sdf`] | SDF worlds for Gazebo (written) |

pub mod carmen;
pub mod cdr;
pub mod error;
pub mod mcap;
pub mod output_path;
pub mod relations;
pub mod robot_log;
pub mod ros1;
pub mod ros_map;
pub mod ros_msgs;
pub mod rosbag2;
pub mod sdf;
pub mod tum;

pub use error::FormatError;
