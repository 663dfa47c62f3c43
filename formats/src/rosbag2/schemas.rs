//! ROS 2 message definitions (`.msg` text) of every type a ROS 2 recording holds, as the
//! `ros2msg` schemas of its MCAP file: the type's own definition followed, for every type it
//! uses (transitively, each once), by a line of 80 `=`, `MSG: pkg/Type` and that type's
//! definition, which is how rosbag2's MCAP storage writes them and what
//! `rosbags.typesys.get_types_from_msg` and the Foxglove tools parse. Field lists are those of
//! ROS 2 Humble (comments left out).
//!
//! Atrium's own types are in the package `atrium_msgs` (documented in docs/datasets.md):
//! `WifiScan` / `WifiReading`, `LandmarkDetections` / `LandmarkDetection`, and three exact
//! side channels replay reads so that it scores exactly as the live run: `WheelOdometry`
//! (the odometry pose with its heading as a number, not a quaternion, and the tick counts),
//! `ScoringInstant` (the time and true pose at which the localizers are scored) and
//! `LaserRanges` (a scan's ranges in float64; `sensor_msgs/LaserScan` has float32).

/// (full type name, own definition, the types it uses).
const DEFS: &[(&str, &str, &[&str])] = &[
    (
        "builtin_interfaces/msg/Time",
        "int32 sec\nuint32 nanosec\n",
        &[],
    ),
    (
        "std_msgs/msg/Header",
        "builtin_interfaces/Time stamp\nstring frame_id\n",
        &["builtin_interfaces/msg/Time"],
    ),
    ("std_msgs/msg/String", "string data\n", &[]),
    (
        "rosgraph_msgs/msg/Clock",
        "builtin_interfaces/Time clock\n",
        &["builtin_interfaces/msg/Time"],
    ),
    (
        "geometry_msgs/msg/Vector3",
        "float64 x\nfloat64 y\nfloat64 z\n",
        &[],
    ),
    (
        "geometry_msgs/msg/Point",
        "float64 x\nfloat64 y\nfloat64 z\n",
        &[],
    ),
    (
        "geometry_msgs/msg/Quaternion",
        "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n",
        &[],
    ),
    (
        "geometry_msgs/msg/Pose",
        "Point position\nQuaternion orientation\n",
        &["geometry_msgs/msg/Point", "geometry_msgs/msg/Quaternion"],
    ),
    (
        "geometry_msgs/msg/PoseWithCovariance",
        "Pose pose\nfloat64[36] covariance\n",
        &["geometry_msgs/msg/Pose"],
    ),
    (
        "geometry_msgs/msg/PoseWithCovarianceStamped",
        "std_msgs/Header header\nPoseWithCovariance pose\n",
        &["std_msgs/msg/Header", "geometry_msgs/msg/PoseWithCovariance"],
    ),
    (
        "geometry_msgs/msg/Twist",
        "Vector3 linear\nVector3 angular\n",
        &["geometry_msgs/msg/Vector3"],
    ),
    (
        "geometry_msgs/msg/TwistWithCovariance",
        "Twist twist\nfloat64[36] covariance\n",
        &["geometry_msgs/msg/Twist"],
    ),
    (
        "geometry_msgs/msg/Transform",
        "Vector3 translation\nQuaternion rotation\n",
        &["geometry_msgs/msg/Vector3", "geometry_msgs/msg/Quaternion"],
    ),
    (
        "geometry_msgs/msg/TransformStamped",
        "std_msgs/Header header\nstring child_frame_id\nTransform transform\n",
        &["std_msgs/msg/Header", "geometry_msgs/msg/Transform"],
    ),
    (
        "tf2_msgs/msg/TFMessage",
        "geometry_msgs/TransformStamped[] transforms\n",
        &["geometry_msgs/msg/TransformStamped"],
    ),
    (
        "nav_msgs/msg/Odometry",
        "std_msgs/Header header\nstring child_frame_id\ngeometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist\n",
        &[
            "std_msgs/msg/Header",
            "geometry_msgs/msg/PoseWithCovariance",
            "geometry_msgs/msg/TwistWithCovariance",
        ],
    ),
    (
        "nav_msgs/msg/MapMetaData",
        "builtin_interfaces/Time map_load_time\nfloat32 resolution\nuint32 width\nuint32 height\ngeometry_msgs/Pose origin\n",
        &["builtin_interfaces/msg/Time", "geometry_msgs/msg/Pose"],
    ),
    (
        "nav_msgs/msg/OccupancyGrid",
        "std_msgs/Header header\nMapMetaData info\nint8[] data\n",
        &["std_msgs/msg/Header", "nav_msgs/msg/MapMetaData"],
    ),
    (
        "sensor_msgs/msg/LaserScan",
        "std_msgs/Header header\nfloat32 angle_min\nfloat32 angle_max\nfloat32 angle_increment\nfloat32 time_increment\nfloat32 scan_time\nfloat32 range_min\nfloat32 range_max\nfloat32[] ranges\nfloat32[] intensities\n",
        &["std_msgs/msg/Header"],
    ),
    (
        "sensor_msgs/msg/Image",
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data\n",
        &["std_msgs/msg/Header"],
    ),
    (
        "sensor_msgs/msg/RegionOfInterest",
        "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify\n",
        &[],
    ),
    (
        "sensor_msgs/msg/CameraInfo",
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nRegionOfInterest roi\n",
        &["std_msgs/msg/Header", "sensor_msgs/msg/RegionOfInterest"],
    ),
    (
        "sensor_msgs/msg/JointState",
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n",
        &["std_msgs/msg/Header"],
    ),
    (
        "atrium_msgs/msg/WifiReading",
        "string ap\nuint32 channel\nfloat64 rssi_dbm\n",
        &[],
    ),
    (
        "atrium_msgs/msg/WifiScan",
        "std_msgs/Header header\nstring sensor\nWifiReading[] readings\n",
        &["std_msgs/msg/Header", "atrium_msgs/msg/WifiReading"],
    ),
    (
        "atrium_msgs/msg/LandmarkDetection",
        "float64 range\nfloat64 bearing\nint64 id\n",
        &[],
    ),
    (
        "atrium_msgs/msg/LandmarkDetections",
        "std_msgs/Header header\nstring sensor\nfloat64 mount_x\nfloat64 mount_y\nfloat64 mount_theta\nLandmarkDetection[] detections\n",
        &["std_msgs/msg/Header", "atrium_msgs/msg/LandmarkDetection"],
    ),
    (
        "atrium_msgs/msg/WheelOdometry",
        "std_msgs/Header header\nfloat64 x\nfloat64 y\nfloat64 theta\nint64 left_ticks\nint64 right_ticks\n",
        &["std_msgs/msg/Header"],
    ),
    (
        "atrium_msgs/msg/ScoringInstant",
        "std_msgs/Header header\nfloat64 t\nfloat64 x\nfloat64 y\nfloat64 theta\n",
        &["std_msgs/msg/Header"],
    ),
    (
        "atrium_msgs/msg/LaserRanges",
        "std_msgs/Header header\nfloat64[] ranges\n",
        &["std_msgs/msg/Header"],
    ),
];

pub const STRING: &str = "std_msgs/msg/String";
pub const CLOCK: &str = "rosgraph_msgs/msg/Clock";
pub const POSE_COV_STAMPED: &str = "geometry_msgs/msg/PoseWithCovarianceStamped";
pub const TF_MESSAGE: &str = "tf2_msgs/msg/TFMessage";
pub const ODOMETRY: &str = "nav_msgs/msg/Odometry";
pub const OCCUPANCY_GRID: &str = "nav_msgs/msg/OccupancyGrid";
pub const LASER_SCAN: &str = "sensor_msgs/msg/LaserScan";
pub const IMAGE: &str = "sensor_msgs/msg/Image";
pub const CAMERA_INFO: &str = "sensor_msgs/msg/CameraInfo";
pub const JOINT_STATE: &str = "sensor_msgs/msg/JointState";
pub const WIFI_SCAN: &str = "atrium_msgs/msg/WifiScan";
pub const LANDMARKS: &str = "atrium_msgs/msg/LandmarkDetections";
pub const WHEEL_ODOMETRY: &str = "atrium_msgs/msg/WheelOdometry";
pub const SCORING_INSTANT: &str = "atrium_msgs/msg/ScoringInstant";
pub const LASER_RANGES: &str = "atrium_msgs/msg/LaserRanges";

/// The message types a topic of a ROS 2 recording may have (what Atrium writes and reads).
pub const TOP_LEVEL: &[&str] = &[
    STRING,
    CLOCK,
    POSE_COV_STAMPED,
    TF_MESSAGE,
    ODOMETRY,
    OCCUPANCY_GRID,
    LASER_SCAN,
    IMAGE,
    CAMERA_INFO,
    JOINT_STATE,
    WIFI_SCAN,
    LANDMARKS,
    WHEEL_ODOMETRY,
    SCORING_INSTANT,
    LASER_RANGES,
];

fn def(name: &str) -> Option<&'static (&'static str, &'static str, &'static [&'static str])> {
    DEFS.iter().find(|d| d.0 == name)
}

/// A type's own definition (its fields, without the types it uses), as in its `.msg` file
/// with the comments left out; None for a type not defined here.
pub fn own_definition(name: &str) -> Option<&'static str> {
    def(name).map(|d| d.1)
}

/// Every type of the package `atrium_msgs` (`atrium_msgs/msg/Type`), whose `.msg` files are in
/// the repository's `ros/atrium_msgs/msg/`.
pub fn atrium_msgs_types() -> impl Iterator<Item = &'static str> {
    DEFS.iter()
        .map(|d| d.0)
        .filter(|n| n.starts_with("atrium_msgs/"))
}

/// A `.msg` file's text as a definition here spells it: comments, blank lines and trailing
/// spaces left out, one field per line ending in a newline.
pub fn msg_without_comments(text: &str) -> String {
    let mut out = String::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        if !line.is_empty() {
            out.push_str(&line.split_whitespace().collect::<Vec<_>>().join(" "));
            out.push('\n');
        }
    }
    out
}

/// The sections of a `ros2msg` schema text: (type name, definition), the top-level type
/// (named `top`) first, then each `MSG:` section with its name as written (`pkg/Type`).
pub fn schema_sections(top: &str, text: &str) -> Vec<(String, String)> {
    let mut out = vec![(top.to_string(), String::new())];
    for line in text.lines() {
        if line.len() == 80 && line.bytes().all(|b| b == b'=') {
            continue;
        }
        if let Some(name) = line.strip_prefix("MSG: ") {
            out.push((name.trim().to_string(), String::new()));
            continue;
        }
        let last = out.last_mut().expect("starts with the top-level type");
        last.1.push_str(line);
        last.1.push('\n');
    }
    out
}

/// `pkg/msg/Type` -> `pkg/Type`, the spelling of `MSG:` lines.
fn short(name: &str) -> String {
    name.replacen("/msg/", "/", 1)
}

/// The full `ros2msg` schema text of `name`, or None for a type not defined here.
pub fn schema_text(name: &str) -> Option<String> {
    let (_, own, _) = def(name)?;
    let mut order = Vec::new();
    let mut stack: Vec<&str> = def(name)?.2.iter().rev().copied().collect();
    // Depth-first in field order, each dependency once.
    while let Some(d) = stack.pop() {
        if order.contains(&d) {
            continue;
        }
        order.push(d);
        stack.extend(def(d).expect("dependencies are defined").2.iter().rev());
    }
    let mut text = own.to_string();
    for d in order {
        text.push_str(&"=".repeat(80));
        text.push_str(&format!("\nMSG: {}\n", short(d)));
        text.push_str(def(d).expect("dependencies are defined").1);
    }
    Some(text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_resolves_with_its_dependencies_once() {
        for name in TOP_LEVEL {
            let text = schema_text(name).unwrap();
            // Every type named in a field is defined in the text (or is a primitive).
            for line in text
                .lines()
                .filter(|l| !l.is_empty() && !l.starts_with('=') && !l.starts_with("MSG: "))
            {
                let ty = line.split_whitespace().next().unwrap();
                let ty = ty.split('[').next().unwrap();
                if ty.chars().next().unwrap().is_lowercase() && !ty.contains('/') {
                    continue; // a primitive
                }
                let last = ty.rsplit('/').next().unwrap();
                assert!(
                    text.lines()
                        .any(|l| l.starts_with("MSG: ") && l.ends_with(&format!("/{last}"))),
                    "{name}: {ty} undefined in\n{text}"
                );
            }
            let sections: Vec<&str> = text.lines().filter(|l| l.starts_with("MSG: ")).collect();
            let mut dedup = sections.clone();
            dedup.sort_unstable();
            dedup.dedup();
            assert_eq!(sections.len(), dedup.len(), "{name}");
        }
        let odom = schema_text(ODOMETRY).unwrap();
        assert!(odom.starts_with("std_msgs/Header header\nstring child_frame_id\n"));
        assert!(odom.contains(&format!(
            "{}\nMSG: builtin_interfaces/Time\n",
            "=".repeat(80)
        )));
        assert!(schema_text("foo_msgs/msg/Bar").is_none());
    }
}
