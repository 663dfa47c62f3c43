//! One interface over the three kinds of robot log Atrium reads: a rosbag2 folder
//! ([`crate::rosbag2`], MCAP or sqlite3 storage, CDR), a ROS 1 bag ([`crate::ros1`]) and a
//! CARMEN log ([`crate::carmen`], plain or gzipped).
//!
//! The kind is told from the path: a folder holding `metadata.yaml` (or that file itself) is a
//! rosbag2 bag; a file starting with `#ROSBAG V2.0` a ROS 1 bag; any other file is read as a
//! CARMEN log, which must then consist of CARMEN lines (so a file of neither kind is an error
//! naming it). Topics are listed with ROS 2 type names. A CARMEN log shows synthetic topics:
//! `/scan` (FLASER or ROBOTLASER1), `/rear_scan` (RLASER), `/odom` (ODOM, or the odometry
//! poses of the scan lines) and `/tf_static` (the front laser's mount, `base_link` ->
//! `laser`).
//!
//! Messages come in the log's order (bags: receive time, a stable sort; CARMEN: file order)
//! with their header stamps, which may differ from the receive time and are not reordered or
//! checked for going backwards here. Asking for a topic the log lacks, or of another type
//! than the method reads, is an error naming the topic, its type and the type expected.

use crate::carmen::{self, CarmenLog, CarmenScan, OdomPose};
use crate::ros1::Ros1Bag;
use crate::ros_msgs::{
    normalize_type_name, quaternion_of_yaw, Encoding, Header, LaserScanMsg, MessageKind,
    OdometryMsg, PoseMsg, TransformMsg,
};
use crate::rosbag2::storage::Rosbag2;
use crate::FormatError;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The frames CARMEN logs are given.
pub const CARMEN_ODOM_FRAME: &str = "odom";
pub const CARMEN_BASE_FRAME: &str = "base_link";
pub const CARMEN_LASER_FRAME: &str = "laser";
pub const CARMEN_REAR_LASER_FRAME: &str = "rear_laser";

/// The kind of a log.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LogKind {
    Rosbag2,
    Ros1,
    Carmen,
}

/// A topic of a log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicInfo {
    pub name: String,
    /// ROS 2 spelling, `pkg/msg/Type`.
    pub msg_type: String,
    pub count: u64,
}

impl TopicInfo {
    pub fn kind(&self) -> Option<MessageKind> {
        MessageKind::from_type_name(&self.msg_type)
    }
}

enum Inner {
    Rosbag2(Rosbag2),
    Ros1(Ros1Bag),
    Carmen(Box<CarmenLog>),
}

/// An opened robot log.
pub struct RobotLog {
    path: PathBuf,
    inner: Inner,
    topics: Vec<TopicInfo>,
}

impl std::fmt::Debug for RobotLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RobotLog")
            .field("path", &self.path)
            .field("kind", &self.kind())
            .field("topics", &self.topics)
            .finish()
    }
}

/// The magic of the MCAP files a rosbag2 folder holds, to point at the folder instead.
const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";

impl RobotLog {
    /// Opens the log at `path`, telling its kind.
    pub fn open(path: &Path) -> Result<RobotLog, FormatError> {
        let meta = std::fs::metadata(path).map_err(|e| FormatError::io(path, e))?;
        let inner = if meta.is_dir() {
            if !path.join("metadata.yaml").is_file() {
                return Err(FormatError::field(
                    path,
                    "folder",
                    "holds no metadata.yaml: not a rosbag2 bag (ROS 1 bags and CARMEN logs are files)",
                ));
            }
            Inner::Rosbag2(Rosbag2::open(path)?)
        } else if path.file_name().is_some_and(|n| n == "metadata.yaml") {
            Inner::Rosbag2(Rosbag2::open(path.parent().unwrap_or(Path::new(".")))?)
        } else {
            let head = first_bytes(path, 16)?;
            if head.starts_with(crate::ros1::MAGIC) {
                Inner::Ros1(Ros1Bag::open(path)?)
            } else if head.starts_with(b"#ROSBAG") {
                return Err(FormatError::field(
                    path,
                    "file",
                    "a ROS bag of a version other than 2.0, which is not read",
                ));
            } else if head.starts_with(MCAP_MAGIC) {
                return Err(FormatError::field(
                    path,
                    "file",
                    "an MCAP file: open the rosbag2 folder holding it (with its metadata.yaml)",
                ));
            } else {
                Inner::Carmen(Box::new(
                    carmen::read(path).map_err(|e| not_a_log(path, e))?,
                ))
            }
        };
        let topics = match &inner {
            Inner::Rosbag2(b) => rosbag2_topics(b),
            Inner::Ros1(b) => ros1_topics(b),
            Inner::Carmen(c) => carmen_topics(c),
        };
        Ok(RobotLog {
            path: path.to_path_buf(),
            inner,
            topics,
        })
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    pub fn kind(&self) -> LogKind {
        match self.inner {
            Inner::Rosbag2(_) => LogKind::Rosbag2,
            Inner::Ros1(_) => LogKind::Ros1,
            Inner::Carmen(_) => LogKind::Carmen,
        }
    }

    /// The CARMEN log itself (mount and range sources, PARAMs), for a CARMEN log.
    pub fn carmen(&self) -> Option<&CarmenLog> {
        match &self.inner {
            Inner::Carmen(c) => Some(c),
            _ => None,
        }
    }

    /// Every topic, ordered by name.
    pub fn topics(&self) -> &[TopicInfo] {
        &self.topics
    }

    /// The topics whose type is `kind`.
    pub fn topics_of_type(&self, kind: MessageKind) -> Vec<&TopicInfo> {
        self.topics
            .iter()
            .filter(|t| t.kind() == Some(kind))
            .collect()
    }

    /// The `sensor_msgs/LaserScan` messages of `topic`.
    pub fn scans(&self, topic: &str) -> Result<Vec<LaserScanMsg>, FormatError> {
        self.check_topic(topic, &[MessageKind::LaserScan])?;
        if let Inner::Carmen(c) = &self.inner {
            let (scans, frame, range_max) = if topic == "/rear_scan" {
                let max = c
                    .params
                    .get("robot_rear_laser_max")
                    .and_then(|v| v.parse::<f64>().ok())
                    .filter(|v| v.is_finite() && *v > 0.0)
                    .unwrap_or(carmen::NO_RETURN_M);
                (&c.rear_scans, CARMEN_REAR_LASER_FRAME, max)
            } else {
                (&c.front_scans, CARMEN_LASER_FRAME, c.range_max)
            };
            return Ok(scans
                .iter()
                .map(|s| carmen_scan(s, frame, range_max))
                .collect());
        }
        self.decode(topic, |b, e, _| LaserScanMsg::decode(b, e).map(|m| vec![m]))
    }

    /// The `nav_msgs/Odometry` messages of `topic`.
    pub fn odometry(&self, topic: &str) -> Result<Vec<OdometryMsg>, FormatError> {
        self.check_topic(topic, &[MessageKind::Odometry])?;
        if let Inner::Carmen(c) = &self.inner {
            return Ok(c.odometry.iter().map(carmen_odometry).collect());
        }
        self.decode(topic, |b, e, _| OdometryMsg::decode(b, e).map(|m| vec![m]))
    }

    /// Poses of `topic`: PoseStamped, PoseWithCovarianceStamped or Odometry messages.
    pub fn poses(&self, topic: &str) -> Result<Vec<PoseMsg>, FormatError> {
        self.check_topic(
            topic,
            &[
                MessageKind::PoseStamped,
                MessageKind::PoseWithCovarianceStamped,
                MessageKind::Odometry,
            ],
        )?;
        if let Inner::Carmen(c) = &self.inner {
            return Ok(c
                .odometry
                .iter()
                .map(|o| PoseMsg::from(&carmen_odometry(o)))
                .collect());
        }
        self.decode(topic, |b, e, k| PoseMsg::decode(b, e, k).map(|m| vec![m]))
    }

    /// The transforms of `/tf_static` (every connection on it, in a ROS 1 bag), in log order;
    /// none when the log has no such topic.
    pub fn static_transforms(&self) -> Result<Vec<TransformMsg>, FormatError> {
        const TOPIC: &str = "/tf_static";
        if !self.topics.iter().any(|t| t.name == TOPIC) {
            return Ok(Vec::new());
        }
        self.check_topic(TOPIC, &[MessageKind::TfMessage])?;
        if let Inner::Carmen(c) = &self.inner {
            return Ok(vec![carmen_mount(c)]);
        }
        self.decode(TOPIC, |b, e, _| TransformMsg::decode_tf_message(b, e))
    }

    /// The `/tf` transforms (or another TFMessage topic), in log order.
    pub fn transforms(&self, topic: &str) -> Result<Vec<TransformMsg>, FormatError> {
        self.check_topic(topic, &[MessageKind::TfMessage])?;
        if let Inner::Carmen(c) = &self.inner {
            return Ok(vec![carmen_mount(c)]);
        }
        self.decode(topic, |b, e, _| TransformMsg::decode_tf_message(b, e))
    }

    /// The kind of `topic`, which must be one of `expected`.
    fn check_topic(
        &self,
        topic: &str,
        expected: &[MessageKind],
    ) -> Result<MessageKind, FormatError> {
        let Some(t) = self.topics.iter().find(|t| t.name == topic) else {
            let names: Vec<&str> = self.topics.iter().map(|t| t.name.as_str()).collect();
            return Err(FormatError::field(
                &self.path,
                format!("topic {topic}"),
                format!("the log has no such topic (it has {})", names.join(", ")),
            ));
        };
        match t.kind() {
            Some(k) if expected.contains(&k) => Ok(k),
            _ => {
                let want: Vec<&str> = expected.iter().map(|k| k.type_name()).collect();
                Err(FormatError::field(
                    &self.path,
                    format!("topic {topic}"),
                    format!("is of type {}, not {}", t.msg_type, want.join(" or ")),
                ))
            }
        }
    }

    /// Decodes every message of `topic` (a bag's) with `f`, in log order.
    fn decode<T>(
        &self,
        topic: &str,
        f: impl Fn(&[u8], Encoding, MessageKind) -> Result<Vec<T>, String>,
    ) -> Result<Vec<T>, FormatError> {
        let bad = |k: usize, time: f64, ty: &str, e: String| {
            FormatError::field(
                &self.path,
                format!("topic {topic}, message {k} (log time {time:.6} s)"),
                format!("cannot be read as {ty}: {e}"),
            )
        };
        let mut out = Vec::new();
        match &self.inner {
            Inner::Rosbag2(b) => {
                for (k, m) in b.messages(&[topic])?.into_iter().enumerate() {
                    let kind = kind_of(&m.msg_type, &self.path, topic)?;
                    let v = f(&m.data, Encoding::Cdr, kind)
                        .map_err(|e| bad(k, m.time, &m.msg_type, e))?;
                    out.extend(v);
                }
            }
            Inner::Ros1(b) => {
                // Decoded straight from the decompressed chunks, then put in time order.
                let mut timed: Vec<(u64, Vec<T>)> = Vec::new();
                b.for_each_message(&[topic], |c, time, data| {
                    let kind = kind_of(&c.msg_type, &self.path, topic)?;
                    let v = f(data, Encoding::Ros1, kind).map_err(|e| {
                        bad(timed.len(), crate::ros1::seconds(time), &c.msg_type, e)
                    })?;
                    timed.push((time, v));
                    Ok(())
                })?;
                timed.sort_by_key(|(t, _)| *t);
                out.extend(timed.into_iter().flat_map(|(_, v)| v));
            }
            Inner::Carmen(_) => {}
        }
        Ok(out)
    }
}

/// The kind of a type name found on a message (a ROS 1 topic may mix connections).
fn kind_of(ty: &str, path: &Path, topic: &str) -> Result<MessageKind, FormatError> {
    MessageKind::from_type_name(ty).ok_or_else(|| {
        FormatError::field(
            path,
            format!("topic {topic}"),
            format!("holds messages of type {ty}, which is not read"),
        )
    })
}

/// A CARMEN parse error on a file that may be of no log kind at all: say so.
fn not_a_log(path: &Path, e: FormatError) -> FormatError {
    match e {
        FormatError::Field { field, msg, .. } if msg.contains("not a CARMEN log") => {
            FormatError::field(
                path,
                field,
                format!("{msg} (nor a ROS 1 bag or a rosbag2 folder)"),
            )
        }
        e => e,
    }
}

fn first_bytes(path: &Path, n: usize) -> Result<Vec<u8>, FormatError> {
    let mut f = std::fs::File::open(path).map_err(|e| FormatError::io(path, e))?;
    let mut buf = Vec::with_capacity(n);
    f.by_ref()
        .take(n as u64)
        .read_to_end(&mut buf)
        .map_err(|e| FormatError::io(path, e))?;
    Ok(buf)
}

fn rosbag2_topics(b: &Rosbag2) -> Vec<TopicInfo> {
    let mut v: Vec<TopicInfo> = b
        .metadata()
        .topics_with_message_count
        .iter()
        .map(|t| TopicInfo {
            name: t.topic_metadata.name.clone(),
            msg_type: normalize_type_name(&t.topic_metadata.msg_type),
            count: t.message_count,
        })
        .collect();
    v.sort_by(|a, b| a.name.cmp(&b.name));
    v
}

/// Connections grouped by topic; the type is the first connection's (mixed types on one
/// topic are reported when the messages are read).
fn ros1_topics(b: &Ros1Bag) -> Vec<TopicInfo> {
    let mut v: Vec<TopicInfo> = Vec::new();
    for c in b.connections() {
        match v.iter_mut().find(|t| t.name == c.topic) {
            Some(t) => t.count += c.count,
            None => v.push(TopicInfo {
                name: c.topic.clone(),
                msg_type: normalize_type_name(&c.msg_type),
                count: c.count,
            }),
        }
    }
    v.sort_by(|a, b| a.name.cmp(&b.name));
    v
}

fn carmen_topics(c: &CarmenLog) -> Vec<TopicInfo> {
    let mut v = Vec::new();
    let mut add = |name: &str, kind: MessageKind, count: usize| {
        if count > 0 {
            v.push(TopicInfo {
                name: name.into(),
                msg_type: kind.type_name().into(),
                count: count as u64,
            });
        }
    };
    add("/odom", MessageKind::Odometry, c.odometry.len());
    add("/rear_scan", MessageKind::LaserScan, c.rear_scans.len());
    add("/scan", MessageKind::LaserScan, c.front_scans.len());
    add("/tf_static", MessageKind::TfMessage, 1);
    v
}

fn carmen_scan(s: &CarmenScan, frame: &str, range_max: f64) -> LaserScanMsg {
    let n = s.ranges.len();
    LaserScanMsg {
        header: Header {
            stamp: s.stamp,
            frame_id: frame.into(),
        },
        angle_min: s.angle_min,
        angle_max: s.angle_min + n.saturating_sub(1) as f64 * s.angle_increment,
        angle_increment: s.angle_increment,
        time_increment: 0.0,
        scan_time: 0.0,
        range_min: 0.0,
        range_max,
        ranges: s.ranges.clone(),
        intensities: Vec::new(),
    }
}

fn carmen_odometry(o: &OdomPose) -> OdometryMsg {
    let [tv, rv] = o.velocity.unwrap_or([0.0; 2]);
    OdometryMsg {
        header: Header {
            stamp: o.stamp,
            frame_id: CARMEN_ODOM_FRAME.into(),
        },
        child_frame_id: CARMEN_BASE_FRAME.into(),
        position: [o.pose[0], o.pose[1], 0.0],
        orientation: quaternion_of_yaw(o.pose[2]),
        pose_covariance: [0.0; 36],
        linear: [tv, 0.0, 0.0],
        angular: [0.0, 0.0, rv],
        twist_covariance: [0.0; 36],
    }
}

/// The front laser's mount as a static transform, stamped with the first message's time.
fn carmen_mount(c: &CarmenLog) -> TransformMsg {
    let first = c
        .front_scans
        .first()
        .map(|s| s.stamp)
        .or_else(|| c.odometry.first().map(|o| o.stamp))
        .unwrap_or(0.0);
    let [x, y, theta] = c.front_mount.pose;
    TransformMsg {
        header: Header {
            stamp: first,
            frame_id: CARMEN_BASE_FRAME.into(),
        },
        child_frame_id: CARMEN_LASER_FRAME.into(),
        translation: [x, y, 0.0],
        rotation: quaternion_of_yaw(theta),
    }
}
