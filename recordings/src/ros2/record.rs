//! `atrium record --profile ros2`: a live run written as a rosbag2 folder that `ros2 bag play`
//! and the `rosbags` Python package read: `metadata.yaml` (rosbag2 format version 5, storage
//! `mcap`) and one MCAP file (profile `ros2`, `ros2msg` schemas, CDR messages, zstd chunks).
//! Topics and types are listed in `super` (the module docs); log times are the simulation
//! clock (0 at the start of the run) and every header stamp equals its message's log time.
//!
//! The folder is written as `<output>.partial/` and renamed once complete, like the Foxglove
//! recorder's `.partial` file: the final name never holds half a bag. An existing output
//! folder is replaced only when it holds nothing but a bag (`metadata.yaml` and `.mcap`
//! files), so a mistyped `-o` cannot delete a folder of other files.
//!
//! Besides the topics, the MCAP file carries the same `atrium` and `atrium.summary` metadata
//! records as a Foxglove-profile recording (scenario text, seed, content hashes, the run's
//! metrics), and every sensor channel the same channel metadata (mounts, angles, intrinsics
//! in round-trip notation), which is what lets replay reproduce the live run exactly.

use crate::record::{content_hash, events_from_json, run_observed, METADATA_NAME, SUMMARY_NAME};
use crate::{topics, Recorded};
use atrium_formats::cdr::CdrWriter;
use atrium_formats::mcap::foxglove::{self as codec, ns_of};
use atrium_formats::mcap::images;
use atrium_formats::rosbag2::schemas as msgs;
use atrium_localization::Estimate;
use atrium_robots::{Mount3, Pose2, Reading};
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::runner::{RunObserver, RunOptions, RunResult, Tick};
use atrium_scenarios::scenario::{Event, Scenario};
use atrium_scenarios::LocalizerRegistry;
use foxglove::messages as fg;
use nalgebra::Matrix3;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// Topics only the ROS 2 profile has (the others are named as in `dataset::topics`).
pub mod ros_topics {
    pub const TF_STATIC: &str = "/tf_static";
    pub const MAP: &str = "/map";
    pub const ROBOT_DESCRIPTION: &str = "/robot_description";
    pub const CLOCK: &str = "/clock";
    pub const JOINT_STATES: &str = "/joint_states";
    /// `/atrium/ranges/<laser>`: a scan's ranges in float64, for an exact replay.
    pub const RANGES_PREFIX: &str = "/atrium/ranges/";
    /// Suffix of the `sensor_msgs/CameraInfo` topic beside each image topic.
    pub const CAMERA_INFO_SUFFIX: &str = "/camera_info";
    /// Suffix of the optical frame beside each camera's frame (z forward, x right, y down).
    pub const OPTICAL_SUFFIX: &str = "_optical";
}

/// The rosbag2 metadata format version written (that of ROS 2 Humble, readable by every
/// later release and by `rosbags`).
pub const BAG_VERSION: u32 = 5;

/// The offered QoS profile of a topic as rosbag2 records it (a YAML list in a string):
/// reliable; transient local for latched topics (`/map`, `/tf_static`,
/// `/robot_description`), so `ros2 bag play` republishes them to late subscribers, else
/// volatile. History and lifespans as a recorder sees them (unknown, infinite).
pub fn qos_profile(transient_local: bool) -> String {
    let inf = "\n    sec: 9223372036\n    nsec: 854775807";
    format!(
        "- history: 3\n  depth: 0\n  reliability: 1\n  durability: {}\n  deadline:{inf}\n  lifespan:{inf}\n  liveliness: 1\n  liveliness_lease_duration:{inf}\n  avoid_ros_namespace_conventions: false",
        if transient_local { 1 } else { 2 }
    )
}

fn is_transient_local(topic: &str) -> bool {
    matches!(
        topic,
        ros_topics::MAP | ros_topics::TF_STATIC | ros_topics::ROBOT_DESCRIPTION
    )
}

/// A YAML double-quoted scalar.
fn yaml_quoted(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\x{:02x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// One topic of the bag: its type and message count.
#[derive(Debug, Clone)]
pub struct TopicStat {
    pub name: String,
    pub msg_type: &'static str,
    pub count: u64,
}

/// The `metadata.yaml` of a bag with one storage file `file`.
pub fn metadata_yaml(file: &str, topics: &[TopicStat], start_ns: u64, end_ns: u64) -> String {
    let total: u64 = topics.iter().map(|t| t.count).sum();
    let duration = end_ns.saturating_sub(start_ns);
    let mut y = String::new();
    y.push_str("rosbag2_bagfile_information:\n");
    y.push_str(&format!("  version: {BAG_VERSION}\n"));
    y.push_str("  storage_identifier: mcap\n");
    y.push_str(&format!("  duration:\n    nanoseconds: {duration}\n"));
    y.push_str(&format!(
        "  starting_time:\n    nanoseconds_since_epoch: {start_ns}\n"
    ));
    y.push_str(&format!("  message_count: {total}\n"));
    y.push_str("  topics_with_message_count:\n");
    for t in topics {
        y.push_str("    - topic_metadata:\n");
        y.push_str(&format!("        name: {}\n", t.name));
        y.push_str(&format!("        type: {}\n", t.msg_type));
        y.push_str("        serialization_format: cdr\n");
        y.push_str(&format!(
            "        offered_qos_profiles: {}\n",
            yaml_quoted(&qos_profile(is_transient_local(&t.name)))
        ));
        y.push_str(&format!("      message_count: {}\n", t.count));
    }
    y.push_str("  compression_format: \"\"\n");
    y.push_str("  compression_mode: \"\"\n");
    y.push_str(&format!("  relative_file_paths:\n    - {file}\n"));
    y.push_str("  files:\n");
    y.push_str(&format!("    - path: {file}\n"));
    y.push_str(&format!(
        "      starting_time:\n        nanoseconds_since_epoch: {start_ns}\n"
    ));
    y.push_str(&format!(
        "      duration:\n        nanoseconds: {duration}\n"
    ));
    y.push_str(&format!("      message_count: {total}\n"));
    y
}

fn write_err(path: &Path, e: impl std::fmt::Display) -> ScenarioError {
    ScenarioError::field(
        path,
        "output",
        format!("cannot write {}: {e}", path.display()),
    )
}

/// The partial folder a bag at `dir` is written under until complete.
pub fn partial_dir(dir: &Path) -> Option<PathBuf> {
    crate::record::partial_path(dir)
}

/// Whether `dir` holds nothing but a bag (or nothing): only then may a recording replace it.
fn only_a_bag(dir: &Path) -> std::io::Result<bool> {
    for e in std::fs::read_dir(dir)? {
        let e = e?;
        let name = e.file_name();
        let name = name.to_string_lossy();
        let file = e.file_type()?.is_file();
        if !(file && (name == "metadata.yaml" || name.ends_with(".mcap"))) {
            return Ok(false);
        }
    }
    Ok(true)
}

/// Checks that `dir` can be the output folder of a bag, before any run: its parent exists;
/// `dir` is no file, and if it exists holds only a bag (replaced at the end).
pub fn check_output(dir: &Path) -> Result<(), ScenarioError> {
    let fail = |why: String| write_err(dir, why);
    if dir.file_name().is_none() {
        return Err(fail("it names no folder".into()));
    }
    let parent = match dir.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match std::fs::metadata(parent) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(fail(format!("{} is not a folder", parent.display()))),
        Err(e) => return Err(fail(format!("folder {}: {e}", parent.display()))),
    }
    if let Ok(m) = std::fs::metadata(dir) {
        if !m.is_dir() {
            return Err(fail(
                "it is a file; a ROS 2 bag is a folder (metadata.yaml and an MCAP file)".into(),
            ));
        }
        match only_a_bag(dir) {
            Ok(true) => {}
            Ok(false) => {
                return Err(fail(
                    "the folder exists and holds other things than a bag (metadata.yaml, .mcap files); name a new folder".into(),
                ))
            }
            Err(e) => return Err(fail(e.to_string())),
        }
    }
    Ok(())
}

fn event_json(e: &Event) -> serde_json::Value {
    match e {
        Event::Kidnap { at_s, to } => serde_json::json!({
            "kind": "kidnap",
            "at_s": at_s,
            "to": {"x": to.x, "y": to.y, "theta": to.theta},
        }),
    }
}

// ---- CDR encoders of the message types (field order as in `msgs`). ----

fn time(w: &mut CdrWriter, ns: u64) {
    w.i32((ns / 1_000_000_000) as i32);
    w.u32((ns % 1_000_000_000) as u32);
}

fn header(w: &mut CdrWriter, ns: u64, frame: &str) {
    time(w, ns);
    w.string(frame);
}

fn planar_pose(w: &mut CdrWriter, p: &Pose2) {
    let (s, c) = (0.5 * p.theta).sin_cos();
    for v in [p.x, p.y, 0.0, 0.0, 0.0, s, c] {
        w.f64(v);
    }
}

/// A 6×6 covariance (x, y, z, roll, pitch, yaw) from the planar one (x, y, yaw); z, roll and
/// pitch are exactly known (0) for a robot on the floor.
fn covariance6(w: &mut CdrWriter, c: Option<&Matrix3<f64>>) {
    let mut m = [0.0; 36];
    if let Some(c) = c {
        let idx = [0usize, 1, 5];
        for r in 0..3 {
            for k in 0..3 {
                m[6 * idx[r] + idx[k]] = c[(r, k)];
            }
        }
    }
    w.f64_array(&m);
}

fn transform_stamped(w: &mut CdrWriter, t: &fg::FrameTransform) {
    let ns = t.timestamp.map_or(0, |s| {
        u64::from(s.sec()) * 1_000_000_000 + u64::from(s.nsec())
    });
    header(w, ns, &t.parent_frame_id);
    w.string(&t.child_frame_id);
    let v = t.translation.unwrap_or_default();
    let q = t.rotation.unwrap_or(fg::Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    });
    for x in [v.x, v.y, v.z, q.x, q.y, q.z, q.w] {
        w.f64(x);
    }
}

pub(crate) fn tf_message(buf: &mut Vec<u8>, transforms: &[fg::FrameTransform]) {
    let mut w = CdrWriter::start(buf);
    w.len(transforms.len());
    for t in transforms {
        transform_stamped(&mut w, t);
    }
}

pub(crate) fn pose_cov_stamped(
    buf: &mut Vec<u8>,
    ns: u64,
    frame: &str,
    p: &Pose2,
    c: Option<&Matrix3<f64>>,
) {
    let mut w = CdrWriter::start(buf);
    header(&mut w, ns, frame);
    planar_pose(&mut w, p);
    covariance6(&mut w, c);
}

/// `nav_msgs/Odometry`: pose in `frame`, twist (vx, vy, wz) in the `child` frame, each with
/// its planar covariance (None: exact, all zero).
#[allow(clippy::too_many_arguments)]
pub(crate) fn odometry(
    buf: &mut Vec<u8>,
    ns: u64,
    frame: &str,
    child: &str,
    p: &Pose2,
    pose_cov: Option<&Matrix3<f64>>,
    twist: [f64; 3],
    twist_cov: Option<&Matrix3<f64>>,
) {
    let mut w = CdrWriter::start(buf);
    header(&mut w, ns, frame);
    w.string(child);
    planar_pose(&mut w, p);
    covariance6(&mut w, pose_cov);
    for v in [twist[0], twist[1], 0.0, 0.0, 0.0, twist[2]] {
        w.f64(v);
    }
    covariance6(&mut w, twist_cov);
}

/// The planar twist (vx, vy, wz) between two poses `dt` s apart: the motion in the earlier
/// pose's frame over `dt`.
fn planar_twist(from: &Pose2, to: &Pose2, dt: f64) -> [f64; 3] {
    if dt <= 0.0 {
        return [0.0; 3];
    }
    let d = from.inverse().compose(to);
    [
        d.x / dt,
        d.y / dt,
        atrium_robots::normalize_angle(d.theta) / dt,
    ]
}

pub(crate) fn string_msg(buf: &mut Vec<u8>, s: &str) {
    CdrWriter::start(buf).string(s);
}

/// A transform from a 3D isometry (a URDF joint origin).
fn isometry_transform(
    ns: u64,
    parent: &str,
    child: &str,
    iso: &nalgebra::Isometry3<f64>,
) -> fg::FrameTransform {
    let (t, q) = (iso.translation.vector, iso.rotation);
    fg::FrameTransform {
        timestamp: Some(codec::timestamp(ns)),
        parent_frame_id: parent.to_string(),
        child_frame_id: child.to_string(),
        translation: Some(fg::Vector3 {
            x: t.x,
            y: t.y,
            z: t.z,
        }),
        rotation: Some(fg::Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        }),
    }
}

/// A mount's transform with the camera optical frame convention (REP 103: z forward, x right,
/// y down) as a child of the camera's x-forward frame.
fn optical_transform(ns: u64, frame: &str) -> fg::FrameTransform {
    let m = Mount3 {
        xyz: [0.0; 3],
        rpy: [
            -std::f64::consts::FRAC_PI_2,
            0.0,
            -std::f64::consts::FRAC_PI_2,
        ],
    };
    codec::frame_transform(
        ns,
        frame,
        &format!("{frame}{}", ros_topics::OPTICAL_SUFFIX),
        &m,
    )
}

/// `sensor_msgs/CameraInfo` of a pinhole camera (no distortion); `tx` is P[3]
/// (−fx · baseline for a stereo rig's disparity, 0 otherwise).
#[allow(clippy::too_many_arguments)]
pub(crate) fn camera_info(
    buf: &mut Vec<u8>,
    ns: u64,
    frame: &str,
    width: usize,
    height: usize,
    model: &str,
    [fx, fy, cx, cy]: [f64; 4],
    tx: f64,
) {
    let mut w = CdrWriter::start(buf);
    header(&mut w, ns, frame);
    w.u32(height as u32);
    w.u32(width as u32);
    w.string(model);
    w.f64_seq(if model == "plumb_bob" {
        &[0.0; 5][..]
    } else {
        &[]
    });
    w.f64_array(&[fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]);
    w.f64_array(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
    w.f64_array(&[fx, 0.0, cx, tx, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]);
    w.u32(0);
    w.u32(0);
    // roi: all zero = the full image.
    for _ in 0..4 {
        w.u32(0);
    }
    w.bool(false);
}

/// `sensor_msgs/Image` with `bytes_per_pixel`-wide little-endian pixels.
fn image(
    buf: &mut Vec<u8>,
    ns: u64,
    frame: &str,
    (width, height): (usize, usize),
    encoding: &str,
    bytes_per_pixel: usize,
    pixels: impl FnOnce(&mut Vec<u8>),
) {
    let mut w = CdrWriter::start(&mut *buf);
    header(&mut w, ns, frame);
    w.u32(height as u32);
    w.u32(width as u32);
    w.string(encoding);
    w.u8(0); // is_bigendian
    w.u32((width * bytes_per_pixel) as u32);
    w.len(width * height * bytes_per_pixel);
    pixels(buf);
}

/// The driven wheel joints with their side (0 left, 1 right) and the sign that turns an
/// encoder angle (positive forward) into the joint's position about its own axis.
fn wheel_joints(robot: &atrium_robots::RobotModel) -> Vec<(String, usize, f64)> {
    let (left, right): (Vec<_>, Vec<_>) = match &robot.drive_kind {
        atrium_robots::model::DriveKind::SkidSteer(s) => {
            (s.left.iter().collect(), s.right.iter().collect())
        }
        _ => (vec![&robot.left_wheel], vec![&robot.right_wheel]),
    };
    let sign = |w: &atrium_robots::Wheel| if w.axis.y >= 0.0 { 1.0 } else { -1.0 };
    left.into_iter()
        .map(|w| (w.joint.clone(), 0, sign(w)))
        .chain(right.into_iter().map(|w| (w.joint.clone(), 1, sign(w))))
        .collect()
}

/// Writes one run to a rosbag2 folder (see the module docs). Create it, pass it to the runner
/// as its observer, then [`Ros2Recorder::finish`]; dropped unfinished, it removes its partial
/// folder.
pub struct Ros2Recorder {
    writer: Option<mcap::Writer<BufWriter<File>>>,
    dir: PathBuf,
    tmp_dir: PathBuf,
    file_name: String,
    _unfinished: atrium_scenarios::output::Unfinished,
    schemas: HashMap<&'static str, u16>,
    /// Topic -> (channel id, index into `stats`).
    channels: HashMap<String, (u16, usize)>,
    stats: Vec<TopicStat>,
    buf: Vec<u8>,
    laser_frames: HashMap<String, String>,
    /// Scan rate per laser, Hz (`scan_time`, `time_increment`).
    laser_rates: HashMap<String, f64>,
    base_link: String,
    /// `/odom`'s twist and covariances from the odometry model.
    odom_model: super::odom_model::OdomModel,
    /// The true pose at the last scoring instant (for `/ground_truth`'s twist).
    last_truth: Option<(f64, Pose2)>,
    /// Whether `/tf` also carries `map -> odom` from the ground truth (`--tf-ground-truth`).
    tf_ground_truth: bool,
    /// The URDF's joints (fixed ones on `/tf_static`, moving ones on `/joint_states`).
    joints: Vec<atrium_robots::UrdfJoint>,
    /// Driven wheel joints: (joint, side 0 left / 1 right, sign of forward rotation).
    wheel_joints: Vec<(String, usize, f64)>,
    /// Wheel rotation per encoder tick, rad.
    rad_per_tick: f64,
    /// Wheel angles at the last odometry reading (for `/joint_states` velocities).
    last_wheels: Option<(f64, [f64; 2])>,
    localizer_names: Vec<String>,
    world: atrium_worlds::World,
    map: atrium_scenarios::scenario::MapSettings,
    /// The robot's start pose (it is inside the building, for `/map`'s unknown cells).
    start: Pose2,
    urdf: String,
    /// Every static transform so far: each `/tf_static` message repeats them all, since a
    /// transient-local subscriber is handed the last message only.
    statics: Vec<fg::FrameTransform>,
    started: bool,
    first_ns: Option<u64>,
    last_ns: u64,
    messages: u64,
}

impl Ros2Recorder {
    /// Checks the output ([`check_output`]), creates `<dir>.partial/` (replacing one an
    /// earlier killed run left) with the MCAP file in it, and writes the `atrium` metadata.
    pub fn create(
        dir: &Path,
        scenario: &Scenario,
        seed: u64,
    ) -> Result<Ros2Recorder, ScenarioError> {
        check_output(dir)?;
        let tmp_dir = partial_dir(dir).ok_or_else(|| write_err(dir, "it names no folder"))?;
        let read = |file: &Path| {
            std::fs::read(file).map_err(|err| ScenarioError::Io {
                file: file.to_path_buf(),
                err,
            })
        };
        let world_hash = content_hash(&read(&scenario.world_file)?);
        let urdf_bytes = read(&scenario.robot_file)?;
        let robot_hash = content_hash(&urdf_bytes);
        let joints = atrium_robots::RobotModel::joint_tree(
            &String::from_utf8_lossy(&urdf_bytes),
            &scenario.robot_file.display().to_string(),
        )
        .map_err(|e| write_err(dir, format!("the robot's joints for /tf_static: {e}")))?;
        if tmp_dir.exists() {
            // Left by a killed run: only ever a bag of ours, never a user's folder.
            if tmp_dir.is_dir() && only_a_bag(&tmp_dir).unwrap_or(false) {
                std::fs::remove_dir_all(&tmp_dir).map_err(|e| write_err(dir, e))?;
            } else {
                return Err(write_err(
                    dir,
                    format!("{} exists and is not a partial bag", tmp_dir.display()),
                ));
            }
        }
        std::fs::create_dir(&tmp_dir).map_err(|e| write_err(dir, e))?;
        let stem = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "bag".into());
        let file_name = format!("{stem}_0.mcap");
        let file_path = tmp_dir.join(&file_name);
        // The folder, not just the file: an interrupt must leave no empty `<dir>.partial/`.
        let unfinished = atrium_scenarios::output::Unfinished::register_dir(&tmp_dir);
        let cleanup = |e: ScenarioError| {
            let _ = std::fs::remove_dir_all(&tmp_dir);
            e
        };
        let file = File::create(&file_path)
            .map_err(|e| write_err(dir, e))
            .map_err(cleanup)?;
        let mut writer = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .profile("ros2")
            .library(format!("atrium {}", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(|e| write_err(dir, e))
            .map_err(cleanup)?;
        let absolute = |p: &Path| {
            std::fs::canonicalize(p)
                .unwrap_or_else(|_| p.to_path_buf())
                .to_string_lossy()
                .into_owned()
        };
        let localizers: Vec<serde_json::Value> = scenario
            .localizers
            .iter()
            .map(|l| serde_json::json!({"name": l.name, "kind": l.kind}))
            .collect();
        let events: Vec<serde_json::Value> = scenario.events.iter().map(event_json).collect();
        let metadata = BTreeMap::from([
            (
                "atrium_version".to_string(),
                env!("CARGO_PKG_VERSION").to_string(),
            ),
            ("profile".into(), "ros2".into()),
            ("seed".into(), seed.to_string()),
            ("scenario_name".into(), scenario.name.clone()),
            ("scenario_file".into(), absolute(&scenario.file)),
            ("scenario".into(), scenario.text.clone()),
            ("world".into(), scenario.world.name.clone()),
            ("world_file".into(), absolute(&scenario.world_file)),
            ("world_hash".into(), world_hash),
            ("robot".into(), scenario.robot.name.clone()),
            ("robot_file".into(), absolute(&scenario.robot_file)),
            ("robot_hash".into(), robot_hash),
            ("base_link".into(), scenario.robot.base_link.clone()),
            ("physics_hz".into(), format!("{:?}", scenario.physics_hz)),
            ("eval_hz".into(), format!("{:?}", scenario.eval_hz)),
            (
                "localizers".into(),
                serde_json::Value::from(localizers).to_string(),
            ),
            ("events".into(), serde_json::Value::from(events).to_string()),
        ]);
        let mut schemas = HashMap::new();
        let started = (|| {
            writer
                .write_metadata(&mcap::records::Metadata {
                    name: METADATA_NAME.into(),
                    metadata,
                })
                .map_err(|e| write_err(dir, e))?;
            for name in msgs::TOP_LEVEL {
                let text = msgs::schema_text(name).expect("top-level types are defined");
                let id = writer
                    .add_schema(name, "ros2msg", text.as_bytes())
                    .map_err(|e| write_err(dir, e))?;
                schemas.insert(*name, id);
            }
            Ok(())
        })();
        if let Err(e) = started {
            drop(writer);
            return Err(cleanup(e));
        }
        // The events parse back (the same check replay makes), so a bag never holds events
        // replay would refuse.
        debug_assert!(events_from_json(&serde_json::Value::Array(
            scenario.events.iter().map(event_json).collect()
        ))
        .is_ok());
        Ok(Ros2Recorder {
            writer: Some(writer),
            dir: dir.to_path_buf(),
            tmp_dir,
            file_name,
            _unfinished: unfinished,
            schemas,
            channels: HashMap::new(),
            stats: Vec::new(),
            buf: Vec::with_capacity(1 << 16),
            laser_frames: scenario
                .lasers
                .iter()
                .map(|l| (l.name.clone(), l.mount.clone()))
                .collect(),
            laser_rates: scenario
                .lasers
                .iter()
                .map(|l| (l.name.clone(), l.rate_hz))
                .collect(),
            base_link: scenario.robot.base_link.clone(),
            odom_model: super::odom_model::OdomModel::new(
                &scenario.odometry,
                scenario.robot.wheel_radius,
                scenario.robot.drive().wheel_separation,
            ),
            last_truth: None,
            tf_ground_truth: false,
            joints,
            wheel_joints: wheel_joints(&scenario.robot),
            rad_per_tick: std::f64::consts::TAU / f64::from(scenario.odometry.ticks_per_rev.max(1)),
            last_wheels: None,
            localizer_names: scenario.localizers.iter().map(|l| l.name.clone()).collect(),
            world: scenario.world.clone(),
            map: scenario.map,
            start: scenario.start,
            urdf: String::from_utf8_lossy(&urdf_bytes).into_owned(),
            statics: Vec::new(),
            started: false,
            first_ns: None,
            last_ns: 0,
            messages: 0,
        })
    }

    /// Also publish `map -> odom` on `/tf`, from the ground truth (so that `map -> base` is
    /// the true pose), for viewing a run; off by default, so that a localizer under test is
    /// the only `map -> odom` publisher (`atrium record --tf-ground-truth`).
    pub fn with_tf_ground_truth(mut self, on: bool) -> Self {
        self.tf_ground_truth = on;
        self
    }

    /// Messages written so far.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    fn channel(
        &mut self,
        topic: &str,
        msg_type: &'static str,
        metadata: impl FnOnce() -> BTreeMap<String, String>,
    ) -> Result<u16, ScenarioError> {
        if let Some(&(id, _)) = self.channels.get(topic) {
            return Ok(id);
        }
        let mut meta = metadata();
        meta.insert(
            "offered_qos_profiles".into(),
            qos_profile(is_transient_local(topic)),
        );
        let schema = self.schemas[msg_type];
        let writer = self.writer.as_mut().expect("the writer lives until finish");
        let id = writer
            .add_channel(schema, topic, "cdr", &meta)
            .map_err(|e| write_err(&self.dir, e))?;
        self.channels
            .insert(topic.to_string(), (id, self.stats.len()));
        self.stats.push(TopicStat {
            name: topic.to_string(),
            msg_type,
            count: 0,
        });
        Ok(id)
    }

    /// Writes `self.buf` on `topic` (a channel of `msg_type`, created with `metadata` the
    /// first time) at `ns`.
    fn put_with(
        &mut self,
        topic: &str,
        msg_type: &'static str,
        ns: u64,
        metadata: impl FnOnce() -> BTreeMap<String, String>,
    ) -> Result<(), ScenarioError> {
        let id = self.channel(topic, msg_type, metadata)?;
        let idx = self.channels[topic].1;
        let stat = &mut self.stats[idx];
        stat.count += 1;
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: stat.count as u32,
            log_time: ns,
            publish_time: ns,
        };
        let writer = self.writer.as_mut().expect("the writer lives until finish");
        writer
            .write_to_known_channel(&header, &self.buf)
            .map_err(|e| write_err(&self.dir, e))?;
        self.messages += 1;
        self.first_ns.get_or_insert(ns);
        self.last_ns = self.last_ns.max(ns);
        Ok(())
    }

    fn put(&mut self, topic: &str, msg_type: &'static str, ns: u64) -> Result<(), ScenarioError> {
        self.put_with(topic, msg_type, ns, BTreeMap::new)
    }

    fn write_statics(&mut self, ns: u64) -> Result<(), ScenarioError> {
        let mut buf = std::mem::take(&mut self.buf);
        tf_message(&mut buf, &self.statics);
        self.buf = buf;
        self.put(ros_topics::TF_STATIC, msgs::TF_MESSAGE, ns)
    }

    /// The latched topics, at the first instant: the URDF, the map and the robot's frames.
    fn write_start(&mut self, ns: u64) -> Result<(), ScenarioError> {
        let urdf = std::mem::take(&mut self.urdf);
        string_msg(&mut self.buf, &urdf);
        self.urdf = urdf;
        self.put(ros_topics::ROBOT_DESCRIPTION, msgs::STRING, ns)?;

        let mut grid = self
            .world
            .try_occupancy_grid(self.map.resolution, self.map.include_glass)
            .map_err(|e| write_err(&self.dir, format!("the /map occupancy grid: {e}")))?;
        // Outside the building is unknown (-1), not free: AMCL's particles and a planner's
        // paths stay inside. The robot's start pose marks the inside.
        grid.mark_outside_unknown(&[[self.start.x, self.start.y]]);
        {
            let mut w = CdrWriter::start(&mut self.buf);
            header(&mut w, ns, topics::MAP_FRAME);
            time(&mut w, ns);
            w.f32(grid.resolution as f32);
            w.u32(grid.width as u32);
            w.u32(grid.height as u32);
            planar_pose(&mut w, &Pose2::new(grid.origin[0], grid.origin[1], 0.0));
            w.len(grid.cells.len());
            // ROS occupancy: 0 free, 100 occupied, -1 unknown; same row order (y rows
            // from the origin up).
            for c in &grid.cells {
                w.i8(match c {
                    atrium_worlds::Cell::Free => 0,
                    atrium_worlds::Cell::Occupied => 100,
                    atrium_worlds::Cell::Unknown => -1,
                });
            }
        }
        self.put(ros_topics::MAP, msgs::OCCUPANCY_GRID, ns)?;

        // REP 105 / robot_state_publisher: each fixed joint from its parent to its child, as
        // the URDF's tree has it; moving joints go on /joint_states.
        self.statics = self
            .joints
            .iter()
            .filter(|j| j.fixed)
            .map(|j| isometry_transform(ns, &j.parent, &j.child, &j.origin))
            .collect();
        self.write_statics(ns)
    }

    /// A camera's frame and its optical frame, added to the static transforms the first time
    /// the camera is seen.
    fn camera_frames(
        &mut self,
        ns: u64,
        sensor: &str,
        mount: Option<&Mount3>,
    ) -> Result<(), ScenarioError> {
        let optical = format!("{sensor}{}", ros_topics::OPTICAL_SUFFIX);
        if self.statics.iter().any(|t| t.child_frame_id == optical) {
            return Ok(());
        }
        // A camera named after a URDF link has its frame from the tree already.
        let in_tree = self.statics.iter().any(|t| t.child_frame_id == sensor)
            || self.joints.iter().any(|j| j.child == sensor)
            || sensor == self.base_link;
        if let (Some(m), false) = (mount, in_tree) {
            self.statics
                .push(codec::frame_transform(ns, &self.base_link, sensor, m));
        }
        self.statics.push(optical_transform(ns, sensor));
        self.write_statics(ns)
    }

    /// `/joint_states` at an odometry reading: the driven wheels' angles from the encoder
    /// ticks (and their rates), every other moving joint of the URDF held at 0 (as the
    /// simulator holds casters and the like for the frames).
    fn joint_states(
        &mut self,
        ns: u64,
        o: &atrium_robots::WheelOdometry,
    ) -> Result<(), ScenarioError> {
        let angles = [
            o.left_ticks as f64 * self.rad_per_tick,
            o.right_ticks as f64 * self.rad_per_tick,
        ];
        let rates = match self.last_wheels.replace((o.stamp, angles)) {
            Some((t0, a0)) if o.stamp > t0 => [
                (angles[0] - a0[0]) / (o.stamp - t0),
                (angles[1] - a0[1]) / (o.stamp - t0),
            ],
            _ => [0.0; 2],
        };
        let mut names = Vec::new();
        let mut position = Vec::new();
        let mut velocity = Vec::new();
        for (joint, side, sign) in &self.wheel_joints {
            names.push(joint.as_str());
            position.push(sign * angles[*side]);
            velocity.push(sign * rates[*side]);
        }
        for j in &self.joints {
            if !j.fixed && !names.contains(&j.name.as_str()) {
                names.push(&j.name);
                position.push(0.0);
                velocity.push(0.0);
            }
        }
        {
            let mut w = CdrWriter::start(&mut self.buf);
            header(&mut w, ns, "");
            w.len(names.len());
            for n in &names {
                w.string(n);
            }
            w.f64_seq(&position);
            w.f64_seq(&velocity);
            w.len(0); // effort: unknown
        }
        self.put(ros_topics::JOINT_STATES, msgs::JOINT_STATE, ns)
    }

    fn write_reading(
        &mut self,
        r: &Reading,
        ns: u64,
        truth: Option<Pose2>,
    ) -> Result<(), ScenarioError> {
        let optical = |s: &str| format!("{s}{}", ros_topics::OPTICAL_SUFFIX);
        let info_topic = |t: &str| format!("{t}{}", ros_topics::CAMERA_INFO_SUFFIX);
        match r {
            Reading::Odometry(o) => {
                let u = self.odom_model.update(o.stamp, o.pose);
                odometry(
                    &mut self.buf,
                    ns,
                    topics::ODOM_FRAME,
                    &self.base_link,
                    &o.pose,
                    Some(&u.pose),
                    u.twist,
                    Some(&u.twist_covariance),
                );
                self.put(topics::ODOM, msgs::ODOMETRY, ns)?;
                self.joint_states(ns, o)?;
                {
                    let mut w = CdrWriter::start(&mut self.buf);
                    header(&mut w, ns, topics::ODOM_FRAME);
                    w.f64(o.pose.x);
                    w.f64(o.pose.y);
                    w.f64(o.pose.theta);
                    w.i64(o.left_ticks);
                    w.i64(o.right_ticks);
                }
                self.put(topics::ODOM_WHEELS, msgs::WHEEL_ODOMETRY, ns)?;
                // REP 105: odom -> base from the wheels; with --tf-ground-truth also map ->
                // odom such that map -> base is the true pose (else the localizer under test
                // publishes map -> odom alone).
                let mut transforms = vec![codec::planar_transform(
                    ns,
                    topics::ODOM_FRAME,
                    &self.base_link,
                    &o.pose,
                )];
                if let (true, Some(gt)) = (self.tf_ground_truth, truth) {
                    transforms.push(codec::planar_transform(
                        ns,
                        topics::MAP_FRAME,
                        topics::ODOM_FRAME,
                        &gt.compose(&o.pose.inverse()),
                    ));
                }
                tf_message(&mut self.buf, &transforms);
                self.put(topics::TF, msgs::TF_MESSAGE, ns)?;
            }
            Reading::Laser(scan) => {
                let frame = self
                    .laser_frames
                    .get(&scan.sensor)
                    .cloned()
                    .unwrap_or_else(|| self.base_link.clone());
                // The exact ranges first: replay takes them for the scan at the same time.
                {
                    let mut w = CdrWriter::start(&mut self.buf);
                    header(&mut w, ns, &frame);
                    w.f64_seq(&scan.ranges);
                }
                let topic = format!("{}{}", ros_topics::RANGES_PREFIX, scan.sensor);
                self.put(&topic, msgs::LASER_RANGES, ns)?;
                {
                    let mut w = CdrWriter::start(&mut self.buf);
                    header(&mut w, ns, &frame);
                    let last = scan.ranges.len().saturating_sub(1);
                    // scan_time from the rate; time_increment as a spinning scanner's: the
                    // mirror turns 2π per scan, so one increment takes that share of it.
                    let scan_time = self
                        .laser_rates
                        .get(&scan.sensor)
                        .filter(|r| **r > 0.0)
                        .map_or(0.0, |r| 1.0 / r);
                    let time_increment =
                        scan_time * scan.angle_increment.abs() / std::f64::consts::TAU;
                    for v in [
                        scan.angle_min,
                        scan.beam_angle(last),
                        scan.angle_increment,
                        time_increment,
                        scan_time,
                        scan.range_min,
                        scan.range_max,
                    ] {
                        w.f32(v as f32);
                    }
                    // REP 117: a beam with no return (the simulator reads it as range_max)
                    // is +Inf, so that costmaps clear along it.
                    let max = scan.range_max;
                    w.f32_seq(scan.ranges.iter().map(|&r| {
                        if r >= max {
                            f32::INFINITY
                        } else {
                            r as f32
                        }
                    }));
                    w.len(0); // intensities
                }
                let topic = format!("{}{}", topics::SCAN_PREFIX, scan.sensor);
                self.put_with(&topic, msgs::LASER_SCAN, ns, || codec::laser_metadata(scan))?;
            }
            Reading::Depth(d) => {
                self.camera_frames(ns, &d.sensor, Some(&d.mount))?;
                let frame = optical(&d.sensor);
                let topic = format!("{}{}", topics::DEPTH_PREFIX, d.sensor);
                camera_info(
                    &mut self.buf,
                    ns,
                    &frame,
                    d.width,
                    d.height,
                    "plumb_bob",
                    [d.fx, d.fy, d.cx, d.cy],
                    0.0,
                );
                self.put(&info_topic(&topic), msgs::CAMERA_INFO, ns)?;
                image(
                    &mut self.buf,
                    ns,
                    &frame,
                    (d.width, d.height),
                    codec::DEPTH_ENCODING,
                    4,
                    |b| {
                        // REP 118: NaN where a pixel is invalid (0 in the readings).
                        for &z in &d.depth {
                            let v = if z > 0.0 && z.is_finite() {
                                z
                            } else {
                                f32::NAN
                            };
                            b.extend_from_slice(&v.to_le_bytes());
                        }
                    },
                );
                self.put_with(&topic, msgs::IMAGE, ns, || codec::depth_metadata(d))?;
            }
            Reading::Intensity(i) => {
                self.camera_frames(ns, &i.sensor, Some(&i.mount))?;
                let frame = optical(&i.sensor);
                let topic = format!("{}{}", topics::IMAGE_PREFIX, i.sensor);
                // A panorama has no pinhole model; its columns are azimuths (docs/datasets.md).
                let model = if images::is_panorama(i) {
                    "atrium_cylindrical"
                } else {
                    "plumb_bob"
                };
                camera_info(
                    &mut self.buf,
                    ns,
                    &frame,
                    i.width,
                    i.height,
                    model,
                    [i.fx, i.fy, i.cx, i.cy],
                    0.0,
                );
                self.put(&info_topic(&topic), msgs::CAMERA_INFO, ns)?;
                image(
                    &mut self.buf,
                    ns,
                    &frame,
                    (i.width, i.height),
                    images::INTENSITY_ENCODING,
                    1,
                    |b| {
                        // The simulator quantises to k/255, so this is exact.
                        b.extend(
                            i.pixels
                                .iter()
                                .map(|p| (p.clamp(0.0, 1.0) * 255.0).round() as u8),
                        );
                    },
                );
                self.put_with(&topic, msgs::IMAGE, ns, || images::intensity_metadata(i))?;
            }
            Reading::Disparity(d) => {
                self.camera_frames(ns, &d.sensor, None)?;
                let frame = optical(&d.sensor);
                let topic = format!("{}{}", topics::DISPARITY_PREFIX, d.sensor);
                // Only fx and the baseline (P[3] = -fx * baseline) describe a disparity map;
                // the principal point is put in the middle.
                let (cx, cy) = (0.5 * d.width as f64, 0.5 * d.height as f64);
                camera_info(
                    &mut self.buf,
                    ns,
                    &frame,
                    d.width,
                    d.height,
                    "plumb_bob",
                    [d.fx, d.fx, cx, cy],
                    -d.fx * d.baseline,
                );
                self.put(&info_topic(&topic), msgs::CAMERA_INFO, ns)?;
                image(
                    &mut self.buf,
                    ns,
                    &frame,
                    (d.width, d.height),
                    images::DISPARITY_ENCODING,
                    4,
                    |b| {
                        for v in &d.disparity {
                            b.extend_from_slice(&v.to_le_bytes());
                        }
                    },
                );
                self.put_with(&topic, msgs::IMAGE, ns, || images::disparity_metadata(d))?;
            }
            Reading::Wifi(s) => {
                {
                    let mut w = CdrWriter::start(&mut self.buf);
                    header(&mut w, ns, &self.base_link);
                    w.string(&s.sensor);
                    w.len(s.readings.len());
                    for a in &s.readings {
                        w.string(&a.ap);
                        w.u32(a.channel);
                        w.f64(a.rssi_dbm);
                    }
                }
                let topic = format!("{}{}", topics::WIFI_PREFIX, s.sensor);
                self.put(&topic, msgs::WIFI_SCAN, ns)?;
            }
            Reading::Landmarks(l) => {
                {
                    let mut w = CdrWriter::start(&mut self.buf);
                    header(&mut w, ns, &self.base_link);
                    w.string(&l.sensor);
                    w.f64(l.mount.x);
                    w.f64(l.mount.y);
                    w.f64(l.mount.theta);
                    w.len(l.detections.len());
                    for d in &l.detections {
                        w.f64(d.range);
                        w.f64(d.bearing);
                        w.i64(d.id.map_or(-1, |i| i as i64));
                    }
                }
                let topic = format!("{}{}", topics::LANDMARKS_PREFIX, l.sensor);
                self.put(&topic, msgs::LANDMARKS, ns)?;
            }
            // `Reading` is non-exhaustive: a sensor added later without an encoder here is
            // left out of the recording rather than failing the run.
            #[allow(unreachable_patterns)]
            _ => {}
        }
        Ok(())
    }

    /// Writes the run's totals, completes the MCAP file, writes `metadata.yaml` and renames
    /// the folder to its final name. Returns the bag's size in bytes.
    pub fn finish(mut self, run: &RunResult) -> Result<u64, ScenarioError> {
        let dir = self.dir.clone();
        let mut metrics = atrium_scenarios::report::to_json(run);
        if let Some(o) = metrics.as_object_mut() {
            o.remove("timing");
        }
        let summary = BTreeMap::from([
            ("sim_time_s".to_string(), format!("{:?}", run.sim_time_s)),
            ("distance_m".into(), format!("{:?}", run.distance_m)),
            ("route_completed".into(), run.route_completed.to_string()),
            ("physics_steps".into(), run.timing.physics_steps.to_string()),
            ("metrics".into(), metrics.to_string()),
        ]);
        let mut writer = self.writer.take().expect("the writer lives until finish");
        let yaml = metadata_yaml(
            &self.file_name,
            &self.stats,
            self.first_ns.unwrap_or(0),
            self.last_ns,
        );
        let done = (|| -> Result<u64, ScenarioError> {
            writer
                .write_metadata(&mcap::records::Metadata {
                    name: SUMMARY_NAME.into(),
                    metadata: summary,
                })
                .map_err(|e| write_err(&dir, e))?;
            writer.finish().map_err(|e| write_err(&dir, e))?;
            let file = writer
                .into_inner()
                .into_inner()
                .map_err(|e| write_err(&dir, e.error()))?;
            file.sync_all().map_err(|e| write_err(&dir, e))?;
            let len = file.metadata().map_err(|e| write_err(&dir, e))?.len();
            std::fs::write(self.tmp_dir.join("metadata.yaml"), &yaml)
                .map_err(|e| write_err(&dir, e))?;
            // A bag already there (checked to be only a bag) is moved aside, then removed.
            let old = if dir.exists() {
                let mut name = dir.file_name().unwrap_or_default().to_os_string();
                name.push(format!(".old-{}", std::process::id()));
                let old = dir.with_file_name(name);
                std::fs::rename(&dir, &old).map_err(|e| write_err(&dir, e))?;
                Some(old)
            } else {
                None
            };
            let renamed = std::fs::rename(&self.tmp_dir, &dir);
            if let Some(old) = old {
                match &renamed {
                    Ok(()) => {
                        let _ = std::fs::remove_dir_all(&old);
                    }
                    Err(_) => {
                        let _ = std::fs::rename(&old, &dir);
                    }
                }
            }
            renamed.map_err(|e| write_err(&dir, e))?;
            Ok(len + yaml.len() as u64)
        })();
        if done.is_err() {
            let _ = std::fs::remove_dir_all(&self.tmp_dir);
        }
        done
    }
}

impl Drop for Ros2Recorder {
    fn drop(&mut self) {
        if let Some(w) = self.writer.take() {
            // Unfinished (an error during the run): no bag under any name.
            drop(w);
            let _ = std::fs::remove_dir_all(&self.tmp_dir);
        }
    }
}

impl RunObserver for Ros2Recorder {
    fn instant(
        &mut self,
        tick: &Tick,
        readings: &[Reading],
        estimates: Option<&[Estimate]>,
    ) -> Result<(), ScenarioError> {
        let ns = ns_of(tick.t);
        if !self.started {
            self.started = true;
            self.write_start(ns)?;
        }
        {
            let mut w = CdrWriter::start(&mut self.buf);
            time(&mut w, ns);
        }
        self.put(ros_topics::CLOCK, msgs::CLOCK, ns)?;
        for e in &tick.events {
            string_msg(&mut self.buf, &event_json(e).to_string());
            self.put(topics::EVENTS, msgs::STRING, ns)?;
        }
        for r in readings {
            self.write_reading(r, ns, tick.truth)?;
        }
        if let (true, Some(gt)) = (tick.score, tick.truth) {
            // nav_msgs/Odometry in map, child the base link; the twist from the previous
            // scoring instant; exact (covariances zero).
            let twist = self
                .last_truth
                .map_or([0.0; 3], |(t0, p0)| planar_twist(&p0, &gt, tick.t - t0));
            self.last_truth = Some((tick.t, gt));
            let base = self.base_link.clone();
            odometry(
                &mut self.buf,
                ns,
                topics::MAP_FRAME,
                &base,
                &gt,
                None,
                twist,
                None,
            );
            self.put(topics::GROUND_TRUTH, msgs::ODOMETRY, ns)?;
            {
                let mut w = CdrWriter::start(&mut self.buf);
                header(&mut w, ns, topics::MAP_FRAME);
                for v in [tick.t, gt.x, gt.y, gt.theta] {
                    w.f64(v);
                }
            }
            self.put(topics::SCORE, msgs::SCORING_INSTANT, ns)?;
            for (i, est) in estimates.unwrap_or_default().iter().enumerate() {
                let Some(name) = self.localizer_names.get(i).cloned() else {
                    break;
                };
                pose_cov_stamped(
                    &mut self.buf,
                    ns,
                    topics::MAP_FRAME,
                    &est.pose,
                    Some(&est.covariance),
                );
                let topic = format!("{}{}", topics::ESTIMATE_PREFIX, name);
                self.put(&topic, msgs::POSE_COV_STAMPED, ns)?;
            }
        }
        Ok(())
    }
}

/// Runs `scenario` live and records it as a ROS 2 bag in the folder `dir` (see the module
/// docs).
pub fn record_ros2(
    registry: &LocalizerRegistry,
    scenario: &Scenario,
    dir: &Path,
    options: RunOptions,
) -> Result<Recorded, ScenarioError> {
    record_ros2_with(registry, scenario, dir, options, Ros2Options::default())
}

/// How a ROS 2 bag is written, beyond the run.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Ros2Options {
    /// `--tf-ground-truth`: `/tf` also carries `map -> odom` from the ground truth (see
    /// [`Ros2Recorder::with_tf_ground_truth`]).
    pub tf_ground_truth: bool,
}

/// [`record_ros2`] with [`Ros2Options`].
pub fn record_ros2_with(
    registry: &LocalizerRegistry,
    scenario: &Scenario,
    dir: &Path,
    options: RunOptions,
    ros2: Ros2Options,
) -> Result<Recorded, ScenarioError> {
    let seed = options.seed.unwrap_or(scenario.seed);
    let mut recorder =
        Ros2Recorder::create(dir, scenario, seed)?.with_tf_ground_truth(ros2.tf_ground_truth);
    let run = run_observed(registry, scenario, seed, options, &mut recorder)?;
    let messages = recorder.messages();
    let bytes = recorder.finish(&run)?;
    Ok(Recorded {
        run,
        path: dir.to_path_buf(),
        bytes,
        messages,
    })
}
