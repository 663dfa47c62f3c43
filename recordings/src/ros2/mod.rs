//! ROS 2 recordings (`atrium record --profile ros2`): a rosbag2 folder, `metadata.yaml` plus
//! one MCAP file with `ros2msg` schemas and CDR messages, encoded here in pure Rust (no ROS
//! installation needed), which `ros2 bag play` and the `rosbags` Python package read, and
//! which `atrium replay` and `atrium score` read back ([`read`]).
//!
//! | topic | type | what |
//! |---|---|---|
//! | `/clock` | `rosgraph_msgs/msg/Clock` | the simulation time at every instant |
//! | `/robot_description` | `std_msgs/msg/String` | the URDF text (transient local) |
//! | `/map` | `nav_msgs/msg/OccupancyGrid` | the scenario's map (its resolution and glass setting; outside the building −1, unknown; transient local) |
//! | `/tf_static` | `tf2_msgs/msg/TFMessage` | every fixed URDF joint from its parent link to its child link (the tree `robot_state_publisher` builds), camera frames not in the URDF and their `<camera>_optical` frames (transient local; each message holds them all) |
//! | `/joint_states` | `sensor_msgs/msg/JointState` | the driven wheels' angles (from the encoder ticks) and rates at each odometry reading; every other moving joint at 0 |
//! | `/tf` | `tf2_msgs/msg/TFMessage` | `odom -> <base link>` (wheel odometry) at each odometry reading; with `--tf-ground-truth` also `map -> odom` (so that `map -> base` is the true pose) |
//! | `/odom` | `nav_msgs/msg/Odometry` | wheel odometry pose in `odom`, child the base link; twist from the motion between readings; pose and twist covariances from the odometry model ([`odom_model`]) |
//! | `/scan/<laser>` | `sensor_msgs/msg/LaserScan` | each laser, in its URDF link's frame; no-return beams +Inf (REP 117); `scan_time` 1 / rate, `time_increment` that of a scanner turning once per scan |
//! | `/depth/<camera>` (+ `/camera_info`) | `sensor_msgs/msg/Image` `32FC1` + `sensor_msgs/msg/CameraInfo` | depth in metres, NaN = invalid (REP 118), in `<camera>_optical` |
//! | `/image/<camera>` (+ `/camera_info`) | `sensor_msgs/msg/Image` `mono8` + `CameraInfo` | intensity; a panorama's CameraInfo has distortion model `atrium_cylindrical` |
//! | `/disparity/<rig>` (+ `/camera_info`) | `sensor_msgs/msg/Image` `32FC1` + `CameraInfo` | disparity in pixels, NaN = missing; P[3] = −fx · baseline |
//! | `/wifi/<sensor>` | `atrium_msgs/msg/WifiScan` | access point, channel, RSSI per AP heard |
//! | `/landmarks/<sensor>` | `atrium_msgs/msg/LandmarkDetections` | range-bearing detections (id −1 = unknown) |
//! | `/ground_truth` | `nav_msgs/msg/Odometry` | true base pose in `map`, child the base link, at each scoring instant (twist from the previous instant; covariances zero) |
//! | `/estimate/<localizer>` | `geometry_msgs/msg/PoseWithCovarianceStamped` | each localizer's estimate and covariance (x, y, yaw) at each scoring instant |
//! | `/atrium/events` | `std_msgs/msg/String` | events as they took effect, as JSON |
//! | `/odom/wheels` | `atrium_msgs/msg/WheelOdometry` | exact: the odometry pose with its heading and the encoder ticks |
//! | `/atrium/score` | `atrium_msgs/msg/ScoringInstant` | exact: the scoring instants and true poses |
//! | `/atrium/ranges/<laser>` | `atrium_msgs/msg/LaserRanges` | exact: each scan's ranges in float64 |
//!
//! The `atrium_msgs` types are defined by the ROS 2 interface package in `ros/atrium_msgs`;
//! `docs/ros2.md` walks through playing a bag into nav2's AMCL and scoring it.
//!
//! The three exact side channels exist because ROS messages round some values (float32
//! ranges, headings as quaternions): replay reads them, so that a replay scores exactly like
//! the live run, while ROS tools read the standard topics.

pub mod odom_model;
pub mod read;
pub mod record;

pub use record::{record_ros2, record_ros2_with, Ros2Options, Ros2Recorder};
