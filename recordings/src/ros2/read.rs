//! Reading ROS 2 bags (a rosbag2 folder with MCAP storage) for `atrium replay` and
//! `atrium score`: `metadata.yaml` is read and checked first (storage `mcap`, one storage
//! file, CDR, every topic of a message type Atrium reads: the refusal names the topic), then
//! the MCAP file goes through the same checked reader and checks as a Foxglove-profile
//! recording (`replay::Recording`), and [`Decoder`] turns its CDR messages into readings.
//!
//! Exactness: with Atrium's exact side channels (`/odom/wheels`, `/atrium/score`,
//! `/atrium/ranges/<laser>`) and channel metadata a replay is exactly the live run; a bag from
//! elsewhere falls back to `/odom`, `/ground_truth`, the float32 ranges and the range limits
//! and intrinsics of its `LaserScan` and `CameraInfo` messages.

use super::record::ros_topics;
use crate::record::events_from_json;
use crate::topics;
use atrium_formats::cdr::CdrReader;
use atrium_formats::mcap::foxglove as codec;
use atrium_formats::mcap::images;
use atrium_formats::rosbag2::schemas as msgs;
use atrium_robots::{
    LandmarkDetection, LandmarkDetections, Pose2, Reading, WheelOdometry, WifiReading, WifiScan,
};
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::scenario::Event;
use foxglove::messages as fg;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

fn bad(file: &Path, what: impl Into<String>, msg: impl Into<String>) -> ScenarioError {
    ScenarioError::field(file, what, msg)
}

/// One topic as `metadata.yaml` lists it.
#[derive(Debug, Clone, PartialEq)]
pub struct BagTopic {
    pub name: String,
    pub msg_type: String,
    pub count: u64,
}

/// What `metadata.yaml` says of a bag.
#[derive(Debug, Clone)]
pub struct BagInfo {
    pub dir: PathBuf,
    pub version: u64,
    /// The one storage file.
    pub storage: PathBuf,
    pub topics: Vec<BagTopic>,
}

/// Whether `path` is a folder (a bag, for replay and score).
pub fn is_bag(path: &Path) -> bool {
    path.is_dir()
}

/// Reads and checks `<dir>/metadata.yaml`: format, storage `mcap`, one storage file that
/// exists, CDR, and every topic's type one Atrium reads ([`msgs::TOP_LEVEL`]).
pub fn bag_info(dir: &Path) -> Result<BagInfo, ScenarioError> {
    let yaml_path = dir.join("metadata.yaml");
    let text = match std::fs::read_to_string(&yaml_path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(bad(
                dir,
                "metadata.yaml",
                "the folder has no metadata.yaml: it is not a ROS 2 bag (a rosbag2 folder holds metadata.yaml and its storage file; `ros2 bag reindex` rebuilds a lost one)",
            ))
        }
        Err(err) => {
            return Err(ScenarioError::Io {
                file: yaml_path,
                err,
            })
        }
    };
    let meta = atrium_formats::rosbag2::metadata::parse(&text, &yaml_path)?;
    let field = |k: &str| format!("rosbag2_bagfile_information.{k}");
    let version = u64::from(meta.version);
    if meta.storage_identifier != "mcap" {
        return Err(bad(
            &yaml_path,
            field("storage_identifier"),
            format!("{:?}: `atrium replay` and `score` read Atrium's bags, with MCAP storage (a real robot's bag of any storage runs as a log scenario, [log])", meta.storage_identifier),
        ));
    }
    let compression = meta.compression_mode.trim();
    if !(compression.is_empty() || compression.eq_ignore_ascii_case("none")) {
        return Err(bad(
            &yaml_path,
            field("compression_mode"),
            format!(
                "{compression:?}: compressed bag files are not read (MCAP chunk compression is)"
            ),
        ));
    }
    let file = match meta.relative_file_paths.as_slice() {
        [one] => one.as_str(),
        other => {
            return Err(bad(
                &yaml_path,
                field("relative_file_paths"),
                format!(
                    "{} storage files: Atrium reads bags of exactly one (split bags are not read)",
                    other.len()
                ),
            ))
        }
    };
    // rosbag2 resolves the name inside the bag folder, whatever folder it was written under.
    let name = Path::new(file).file_name().ok_or_else(|| {
        bad(
            &yaml_path,
            field("relative_file_paths"),
            format!("{file:?} names no file"),
        )
    })?;
    let storage = dir.join(name);
    if !storage.is_file() {
        return Err(bad(
            &yaml_path,
            field("relative_file_paths"),
            format!("the storage file {} does not exist", storage.display()),
        ));
    }
    let mut topics = Vec::new();
    for t in &meta.topics_with_message_count {
        let m = &t.topic_metadata;
        if m.serialization_format != "cdr" {
            return Err(bad(
                &yaml_path,
                format!("topic {}", m.name),
                format!(
                    "serialization format {:?}: Atrium reads CDR only",
                    m.serialization_format
                ),
            ));
        }
        check_type(&m.name, &m.msg_type)
            .map_err(|e| bad(&yaml_path, format!("topic {}", m.name), e))?;
        topics.push(BagTopic {
            name: m.name.clone(),
            msg_type: m.msg_type.clone(),
            count: t.message_count,
        });
    }
    Ok(BagInfo {
        dir: dir.to_path_buf(),
        version,
        storage,
        topics,
    })
}

/// The message type Atrium writes on `topic`, if it is one of its topics.
pub fn expected_type(topic: &str) -> Option<&'static str> {
    let info = |t: &str| t.ends_with(ros_topics::CAMERA_INFO_SUFFIX);
    Some(match topic {
        topics::ODOM => msgs::ODOMETRY,
        topics::ODOM_WHEELS => msgs::WHEEL_ODOMETRY,
        topics::GROUND_TRUTH => msgs::ODOMETRY,
        topics::SCORE => msgs::SCORING_INSTANT,
        topics::EVENTS => msgs::STRING,
        topics::TF | ros_topics::TF_STATIC => msgs::TF_MESSAGE,
        ros_topics::MAP => msgs::OCCUPANCY_GRID,
        ros_topics::ROBOT_DESCRIPTION => msgs::STRING,
        ros_topics::CLOCK => msgs::CLOCK,
        ros_topics::JOINT_STATES => msgs::JOINT_STATE,
        t if t.starts_with(ros_topics::RANGES_PREFIX) => msgs::LASER_RANGES,
        t if t.starts_with(topics::SCAN_PREFIX) => msgs::LASER_SCAN,
        t if (t.starts_with(topics::DEPTH_PREFIX)
            || t.starts_with(topics::IMAGE_PREFIX)
            || t.starts_with(topics::DISPARITY_PREFIX))
            && info(t) =>
        {
            msgs::CAMERA_INFO
        }
        t if t.starts_with(topics::DEPTH_PREFIX)
            || t.starts_with(topics::IMAGE_PREFIX)
            || t.starts_with(topics::DISPARITY_PREFIX) =>
        {
            msgs::IMAGE
        }
        t if t.starts_with(topics::WIFI_PREFIX) => msgs::WIFI_SCAN,
        t if t.starts_with(topics::LANDMARKS_PREFIX) => msgs::LANDMARKS,
        t if t.starts_with(topics::ESTIMATE_PREFIX) => msgs::POSE_COV_STAMPED,
        _ => return None,
    })
}

/// A topic's message type must be one Atrium reads, and the one it writes on an Atrium topic.
pub fn check_type(topic: &str, msg_type: &str) -> Result<(), String> {
    if !msgs::TOP_LEVEL.contains(&msg_type) {
        return Err(format!(
            "unknown message type {msg_type:?}: Atrium reads {}",
            msgs::TOP_LEVEL.join(", ")
        ));
    }
    // Bags before issue 42 carry the ground truth as a PoseWithCovarianceStamped.
    if topic == topics::GROUND_TRUTH && msg_type == msgs::POSE_COV_STAMPED {
        return Ok(());
    }
    match expected_type(topic) {
        Some(want) if want != msg_type => {
            Err(format!("has message type {msg_type:?}, expected {want:?}"))
        }
        _ => Ok(()),
    }
}

/// A channel of the bag's MCAP file: `ros2msg` schema of a known type, CDR messages.
pub fn check_channel(topic: &str, schema: &str, encoding: &str) -> Result<(), String> {
    if encoding != "cdr" {
        return Err(format!("message encoding {encoding:?}, expected \"cdr\""));
    }
    check_type(topic, schema)
}

/// The storage (MCAP) file of the bag folder `dir`, for readers of single topics (`score`'s
/// estimates).
pub fn storage_file(dir: &Path) -> Result<PathBuf, ScenarioError> {
    bag_info(dir).map(|i| i.storage)
}

// ---- CDR decoders ----

fn header(r: &mut CdrReader) -> Result<(u64, String), String> {
    let sec = r.i32()?;
    let nsec = r.u32()?;
    let frame = r.string()?;
    Ok((
        (i64::from(sec) * 1_000_000_000 + i64::from(nsec)).max(0) as u64,
        frame,
    ))
}

fn pose(r: &mut CdrReader) -> Result<(Pose2, [f64; 7]), String> {
    let v = r.f64_array::<7>()?;
    let q = fg::Quaternion {
        x: v[3],
        y: v[4],
        z: v[5],
        w: v[6],
    };
    Ok((Pose2::new(v[0], v[1], codec::yaw_of(&q)), v))
}

/// One `sensor_msgs/Image` as a Foxglove raw image (what the image decoders read).
fn image(data: &[u8]) -> Result<fg::RawImage, String> {
    let mut r = CdrReader::new(data)?;
    let (ns, frame_id) = header(&mut r)?;
    let height = r.u32()?;
    let width = r.u32()?;
    let encoding = r.string()?;
    if r.u8()? != 0 {
        return Err("big-endian image data is not read".into());
    }
    let step = r.u32()?;
    let pixels = r.bytes()?;
    Ok(fg::RawImage {
        timestamp: Some(codec::timestamp(ns)),
        frame_id,
        width,
        height,
        encoding,
        step,
        data: foxglove::bytes::Bytes::copy_from_slice(pixels),
    })
}

/// Intrinsics of a `sensor_msgs/CameraInfo` as channel-metadata keys (`fx`, `fy`, `cx`,
/// `cy`, and `baseline` from P[3] = −fx · baseline when P[3] is not 0).
fn camera_info(data: &[u8]) -> Result<BTreeMap<String, String>, String> {
    let mut r = CdrReader::new(data)?;
    header(&mut r)?;
    let _height = r.u32()?;
    let _width = r.u32()?;
    let _model = r.string()?;
    let _d = r.f64_seq()?;
    let k = r.f64_array::<9>()?;
    let _r = r.f64_array::<9>()?;
    let p = r.f64_array::<12>()?;
    let f = |v: f64| format!("{v:?}");
    let mut m = BTreeMap::from([
        ("fx".to_string(), f(k[0])),
        ("fy".into(), f(k[4])),
        ("cx".into(), f(k[2])),
        ("cy".into(), f(k[5])),
    ]);
    if p[3] != 0.0 && p[0] != 0.0 {
        m.insert("baseline".into(), f(-p[3] / p[0]));
    }
    Ok(m)
}

/// Channel metadata with `defaults` filled in where it has no value.
fn with_defaults(
    meta: &BTreeMap<String, String>,
    defaults: Option<&BTreeMap<String, String>>,
) -> BTreeMap<String, String> {
    let mut m = meta.clone();
    for (k, v) in defaults.into_iter().flatten() {
        m.entry(k.clone()).or_insert_with(|| v.clone());
    }
    m
}

/// Turns a bag's CDR messages into readings, for replay's stream.
pub struct Decoder {
    base_link: String,
    use_wheels: bool,
    use_score: bool,
    /// Each frame's parent and planar pose in it, from `/tf_static` and `/tf` (not map or odom).
    parents: HashMap<String, (String, Pose2)>,
    /// Exact ranges per laser topic suffix, with their log time.
    ranges: HashMap<String, (u64, Vec<f64>)>,
    /// Intrinsics per image topic from its CameraInfo.
    infos: HashMap<String, BTreeMap<String, String>>,
}

impl Decoder {
    /// `topics`: the topics of the bag (the exact side channels are used when present).
    pub fn new(base_link: String, topic_names: &[String]) -> Decoder {
        let has = |t: &str| topic_names.iter().any(|n| n == t);
        Decoder {
            base_link,
            use_wheels: has(topics::ODOM_WHEELS),
            use_score: has(topics::SCORE),
            parents: HashMap::new(),
            ranges: HashMap::new(),
            infos: HashMap::new(),
        }
    }

    /// The planar pose of `frame` in the base link, through the frame tree (None when it does
    /// not lead to the base link).
    fn in_base(&self, frame: &str) -> Option<Pose2> {
        let mut pose = Pose2::default();
        let mut at = frame;
        for _ in 0..=self.parents.len() {
            if at == self.base_link {
                return Some(pose);
            }
            let (parent, p) = self.parents.get(at)?;
            pose = p.compose(&pose);
            at = parent;
        }
        None
    }

    /// Decodes one message on `topic` (type `schema`, channel metadata `meta`) at log time
    /// `ns` (`stamp` seconds on the replay clock) into `readings`, the scoring instant or
    /// `events`. Errors say what is wrong with the message.
    #[allow(clippy::too_many_arguments)]
    pub fn handle(
        &mut self,
        topic: &str,
        schema: &str,
        meta: &BTreeMap<String, String>,
        ns: u64,
        stamp: f64,
        data: &[u8],
        readings: &mut Vec<Reading>,
        score: &mut Option<(f64, Pose2)>,
        events: &mut Vec<Event>,
    ) -> Result<(), String> {
        match schema {
            msgs::WHEEL_ODOMETRY if self.use_wheels => {
                let mut r = CdrReader::new(data)?;
                header(&mut r)?;
                let (x, y, theta) = (r.f64()?, r.f64()?, r.f64()?);
                readings.push(Reading::Odometry(WheelOdometry {
                    stamp,
                    pose: Pose2::new(x, y, theta),
                    left_ticks: r.i64()?,
                    right_ticks: r.i64()?,
                }));
            }
            msgs::ODOMETRY if !self.use_wheels && topic == topics::ODOM => {
                let mut r = CdrReader::new(data)?;
                header(&mut r)?;
                r.string()?;
                readings.push(Reading::Odometry(WheelOdometry {
                    stamp,
                    pose: pose(&mut r)?.0,
                    left_ticks: 0,
                    right_ticks: 0,
                }));
            }
            msgs::SCORING_INSTANT if self.use_score => {
                let mut r = CdrReader::new(data)?;
                header(&mut r)?;
                let v = r.f64_array::<4>()?;
                *score = Some((v[0], Pose2::new(v[1], v[2], v[3])));
            }
            msgs::POSE_COV_STAMPED if !self.use_score && topic == topics::GROUND_TRUTH => {
                let mut r = CdrReader::new(data)?;
                header(&mut r)?;
                *score = Some((stamp, pose(&mut r)?.0));
            }
            msgs::ODOMETRY if !self.use_score && topic == topics::GROUND_TRUTH => {
                let mut r = CdrReader::new(data)?;
                header(&mut r)?;
                r.string()?;
                *score = Some((stamp, pose(&mut r)?.0));
            }
            msgs::STRING if topic == topics::EVENTS => {
                let text = CdrReader::new(data)?.string()?;
                let v: serde_json::Value =
                    serde_json::from_str(&text).map_err(|e| e.to_string())?;
                events.append(&mut events_from_json(&serde_json::Value::Array(vec![v]))?);
            }
            msgs::TF_MESSAGE => {
                let mut r = CdrReader::new(data)?;
                let n = r.len(4 * 4 + 8 * 7)?;
                for _ in 0..n {
                    let (_, parent) = header(&mut r)?;
                    let child = r.string()?;
                    let (p, _) = pose(&mut r)?;
                    if parent != topics::MAP_FRAME && parent != topics::ODOM_FRAME {
                        self.parents.insert(child, (parent, p));
                    }
                }
            }
            msgs::LASER_RANGES => {
                let mut r = CdrReader::new(data)?;
                header(&mut r)?;
                let sensor = topic
                    .strip_prefix(ros_topics::RANGES_PREFIX)
                    .unwrap_or(topic);
                self.ranges.insert(sensor.to_string(), (ns, r.f64_seq()?));
            }
            msgs::LASER_SCAN => {
                let mut r = CdrReader::new(data)?;
                let (_, frame_id) = header(&mut r)?;
                let mut v = [0.0f32; 7];
                for x in &mut v {
                    *x = r.f32()?;
                }
                let [angle_min, angle_max, angle_increment, _, _, range_min, range_max] = v;
                let sensor = topic.strip_prefix(topics::SCAN_PREFIX).unwrap_or(topic);
                let short = r.f32_seq()?;
                let ranges = match self.ranges.remove(sensor) {
                    Some((at, exact)) if at == ns && exact.len() == short.len() => exact,
                    // REP 117: +Inf is a beam with no return, which Atrium reads as range_max.
                    _ => short
                        .iter()
                        .map(|&x| {
                            if x == f32::INFINITY {
                                f64::from(range_max)
                            } else {
                                f64::from(x)
                            }
                        })
                        .collect(),
                };
                // A bag from elsewhere: the message's own limits and increment.
                let f = |x: f32| format!("{:?}", f64::from(x));
                let defaults = BTreeMap::from([
                    ("angle_increment".to_string(), f(angle_increment)),
                    ("range_min".into(), f(range_min)),
                    ("range_max".into(), f(range_max)),
                ]);
                let meta = with_defaults(meta, Some(&defaults));
                let msg = fg::LaserScan {
                    timestamp: None,
                    frame_id,
                    pose: None,
                    start_angle: f64::from(angle_min),
                    end_angle: f64::from(angle_max),
                    ranges,
                    intensities: Vec::new(),
                };
                let mount = self.in_base(&msg.frame_id).unwrap_or_default();
                readings.push(Reading::Laser(codec::laser_from_message(
                    &msg, &meta, sensor, stamp, mount,
                )));
            }
            msgs::CAMERA_INFO => {
                let image_topic = topic
                    .strip_suffix(ros_topics::CAMERA_INFO_SUFFIX)
                    .unwrap_or(topic);
                self.infos
                    .insert(image_topic.to_string(), camera_info(data)?);
            }
            msgs::IMAGE => {
                let msg = image(data)?;
                let meta = with_defaults(meta, self.infos.get(topic));
                if let Some(sensor) = topic.strip_prefix(topics::DEPTH_PREFIX) {
                    let d = codec::depth_from_message(&msg, &meta, sensor, stamp)?;
                    readings.push(Reading::Depth(d));
                } else if let Some(sensor) = topic.strip_prefix(topics::IMAGE_PREFIX) {
                    let i = images::intensity_from_message(&msg, &meta, sensor, stamp)?;
                    readings.push(Reading::Intensity(i));
                } else if let Some(sensor) = topic.strip_prefix(topics::DISPARITY_PREFIX) {
                    let d = images::disparity_from_message(&msg, &meta, sensor, stamp)?;
                    readings.push(Reading::Disparity(d));
                }
            }
            msgs::WIFI_SCAN => {
                let mut r = CdrReader::new(data)?;
                header(&mut r)?;
                let sensor = r.string()?;
                let n = r.len(4 + 4 + 8)?;
                let mut list = Vec::with_capacity(n);
                for _ in 0..n {
                    list.push(WifiReading {
                        ap: r.string()?,
                        channel: r.u32()?,
                        rssi_dbm: r.f64()?,
                    });
                }
                readings.push(Reading::Wifi(WifiScan {
                    stamp,
                    sensor,
                    readings: list,
                }));
            }
            msgs::LANDMARKS => {
                let mut r = CdrReader::new(data)?;
                header(&mut r)?;
                let sensor = r.string()?;
                let mount = Pose2::new(r.f64()?, r.f64()?, r.f64()?);
                let n = r.len(24)?;
                let mut detections = Vec::with_capacity(n);
                for _ in 0..n {
                    let (range, bearing, id) = (r.f64()?, r.f64()?, r.i64()?);
                    detections.push(LandmarkDetection {
                        range,
                        bearing,
                        id: usize::try_from(id).ok(),
                    });
                }
                readings.push(Reading::Landmarks(LandmarkDetections {
                    stamp,
                    sensor,
                    mount,
                    detections,
                }));
            }
            _ => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What `atrium record --profile ros2` writes is read back by the formats crate's
    /// metadata reader (a YAML parser), as replay reads it.
    #[test]
    fn written_metadata_parses_back() {
        let topics = vec![
            crate::ros2::record::TopicStat {
                name: "/map".into(),
                msg_type: msgs::OCCUPANCY_GRID,
                count: 1,
            },
            crate::ros2::record::TopicStat {
                name: "/odom".into(),
                msg_type: msgs::ODOMETRY,
                count: 40,
            },
        ];
        let text =
            crate::ros2::record::metadata_yaml("b_0.mcap", &topics, 5_000_000, 90_000_000_000);
        let path = Path::new("metadata.yaml");
        let m = atrium_formats::rosbag2::metadata::parse(&text, path).unwrap();
        m.check(path).unwrap();
        assert_eq!(m.message_count, 41);
        assert_eq!(m.duration.nanoseconds, 89_995_000_000);
        assert_eq!(m.relative_file_paths, ["b_0.mcap"]);
        let odom = m.topic("/odom").unwrap();
        assert_eq!(odom.message_count, 40);
        assert_eq!(odom.topic_metadata.msg_type, msgs::ODOMETRY);
    }

    #[test]
    fn types_are_checked_per_topic() {
        assert!(check_type("/odom", msgs::ODOMETRY).is_ok());
        assert!(check_type("/scan/front", msgs::LASER_SCAN).is_ok());
        assert!(check_type("/depth/k/camera_info", msgs::CAMERA_INFO).is_ok());
        assert!(check_type("/depth/k", msgs::IMAGE).is_ok());
        let e = check_type("/odom", msgs::POSE_COV_STAMPED).unwrap_err();
        assert!(e.contains("expected \"nav_msgs/msg/Odometry\""), "{e}");
        let e = check_type("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray").unwrap_err();
        assert!(e.starts_with("unknown message type"), "{e}");
        assert!(check_channel("/odom", msgs::ODOMETRY, "protobuf").is_err());
    }
}
