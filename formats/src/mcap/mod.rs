//! MCAP files: the checked container reader every recording and ROS 2 bag goes through, and
//! the Foxglove well-known schemas (protobuf) and Atrium's JSON schemas its recordings use.
//!
//! Imports run one way: `container` alone; `foxglove` (readings and poses to messages and
//! back) ← `images` (camera images) and `scene` (the world and the robot's frames).

pub mod container;
pub mod foxglove;
pub mod images;
pub mod scene;
