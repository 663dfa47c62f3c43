//! `atrium replay`: a recording's readings fed to the localizers and scored against its
//! ground truth, through the same consumption loop as a live run (`runner::run_stream`), so a
//! replay of an Atrium recording gives exactly the live run's metrics.
//!
//! Files from elsewhere work when they use the same topics and schemas (see `dataset`):
//! without Atrium's exact side channels the odometry comes from `/odom`, the scoring instants
//! and ground truth from `/ground_truth`, a laser's mount from the `/tf` transform from the
//! base link to the scan's frame; such a file needs `--scenario` for the world and localizers.
//!
//! A recording is checked whole when it is opened, before any localizer is built: its
//! container ([`container`](atrium_formats::mcap::container): sizes, CRCs), channels defined before their
//! messages, log times in order, no message twice (same channel, log time and sequence
//! number; unnumbered messages when their bytes are the same too). Before the replay, the
//! scenario's world and robot must be the recording's (names, and content hashes of the
//! files when the recording has them), and every localizer must find messages on the
//! sensor topics it reads ([`Recording::check_sensor_topics`]).

use crate::record::{events_from_json, METADATA_NAME, SUMMARY_NAME};
use crate::topics;
use atrium_formats::mcap::container::{Place, Records};
use atrium_formats::mcap::foxglove::{self as codec, seconds_of};
use atrium_robots::{LandmarkDetections, Pose2, Reading, WheelOdometry, WifiScan};
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::runner::{ReadingStream, RunOptions, RunResult, StreamSummary, Tick};
use atrium_scenarios::scenario::{Event, LocalizerSpec, Scenario};
use atrium_scenarios::LocalizerRegistry;
use foxglove::messages as fg;
use foxglove::Decode;
use mcap::records::{MessageHeader, Record};
use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap, HashSet};
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Errors of a replay are bad input: they name the file and what is wrong with it.
pub type ReplayError = ScenarioError;

/// Choices for a replay beyond the file.
#[derive(Default)]
pub struct ReplayOptions<'a> {
    /// Take world, map, localizers and expectations from this scenario file instead of the
    /// recording's metadata (required for a file that has none).
    pub scenario: Option<PathBuf>,
    /// Run these localizers `(name, kind)` with default parameters instead of the
    /// scenario's.
    pub localizers: Vec<(String, String)>,
    pub progress: Option<&'a mut dyn FnMut(f64, f64)>,
    /// The localizer kinds to build (None: Atrium's built-in kinds).
    pub registry: Option<&'a LocalizerRegistry>,
}

#[derive(Debug, Clone)]
struct ChannelInfo {
    topic: String,
    schema: String,
    metadata: BTreeMap<String, String>,
}

/// The schema (name, message encoding) every known topic must have.
fn expected_schema(topic: &str) -> Option<(&'static str, &'static str)> {
    let pose = ("foxglove.PoseInFrame", "protobuf");
    Some(match topic {
        topics::ODOM | topics::GROUND_TRUTH => pose,
        topics::ODOM_WHEELS => ("atrium.WheelOdometry", "json"),
        topics::SCORE => ("atrium.ScoringInstant", "json"),
        topics::EVENTS => ("atrium.Event", "json"),
        topics::TF => ("foxglove.FrameTransforms", "protobuf"),
        topics::SCENE => ("foxglove.SceneUpdate", "protobuf"),
        t if t.starts_with(topics::SCAN_PREFIX) => ("foxglove.LaserScan", "protobuf"),
        t if t.starts_with(topics::DEPTH_PREFIX) => ("foxglove.RawImage", "protobuf"),
        t if t.starts_with(topics::IMAGE_PREFIX) => ("foxglove.RawImage", "protobuf"),
        t if t.starts_with(topics::DISPARITY_PREFIX) => ("foxglove.RawImage", "protobuf"),
        t if t.starts_with(topics::WIFI_PREFIX) => ("atrium.WifiScan", "json"),
        t if t.starts_with(topics::LANDMARKS_PREFIX) => ("atrium.LandmarkDetections", "json"),
        t if t.starts_with(topics::ESTIMATE_PREFIX) => pose,
        _ => return None,
    })
}

/// A topic a localizer reads: one sensor's (`prefix` + `sensor`) or any of a kind.
struct Need {
    what: &'static str,
    prefix: &'static str,
    sensor: Option<String>,
}

/// The sensor topics a built-in localizer kind reads, named as the kind's builder picks its
/// sensor (its parameter, else the scenario's first of the kind). Odometry, which every
/// replay needs, is checked for every file; choosers and fused mixtures read through their
/// members, which are localizers of the scenario themselves; `process` localizers subscribe
/// at run time and a user's kinds are unknown here, so neither is checked.
fn sensor_needs(spec: &LocalizerSpec, scenario: &Scenario) -> Vec<Need> {
    let param = |k: &str| {
        spec.params
            .get(k)
            .and_then(|v| v.as_str())
            .filter(|s| !s.is_empty())
            .map(str::to_string)
    };
    let need = |what, prefix, sensor| Need {
        what,
        prefix,
        sensor,
    };
    let cams = &scenario.cameras;
    match spec.kind.as_str() {
        "mcl" | "cgr_laser" => vec![need("laser scans", topics::SCAN_PREFIX, None)],
        "landmark_filter" => vec![need(
            "laser scans",
            topics::SCAN_PREFIX,
            param("laser").or_else(|| scenario.lasers.first().map(|l| l.name.clone())),
        )],
        "cgr_depth" => vec![need("depth images", topics::DEPTH_PREFIX, None)],
        "wifi" => vec![need("WiFi scans", topics::WIFI_PREFIX, None)],
        "ekf_slam" => vec![need("landmark detections", topics::LANDMARKS_PREFIX, None)],
        "ceiling_mcl" => vec![need(
            "ceiling camera images",
            topics::IMAGE_PREFIX,
            param("sensor").or_else(|| cams.ceiling.first().map(|c| c.name.clone())),
        )],
        "omni" => vec![need(
            "panoramic camera images",
            topics::IMAGE_PREFIX,
            param("sensor").or_else(|| cams.omni.first().map(|c| c.name.clone())),
        )],
        "appearance" => {
            let sensor = param("sensor").or_else(|| {
                cams.stereo
                    .first()
                    .map(|s| s.stereo.camera.name.clone())
                    .or_else(|| cams.cameras.first().map(|c| c.camera.name.clone()))
            });
            let stereo = sensor
                .as_ref()
                .is_some_and(|n| cams.stereo.iter().any(|s| &s.stereo.camera.name == n));
            let disparity = spec
                .params
                .get("disparity")
                .and_then(|v| v.as_bool())
                .unwrap_or(stereo);
            let mut v = vec![need("camera images", topics::IMAGE_PREFIX, sensor.clone())];
            if disparity {
                v.push(need("disparity maps", topics::DISPARITY_PREFIX, sensor));
            }
            v
        }
        _ => Vec::new(),
    }
}

fn bad(file: &Path, what: impl Into<String>, msg: impl Into<String>) -> ScenarioError {
    ScenarioError::field(file, what, msg)
}

/// Opens the ROS 2 bag folder `dir` (metadata.yaml and its MCAP file) as a recording (see
/// [`crate::ros2::read`]): the storage file read as a ROS 2 profile recording, and checked
/// against what metadata.yaml says of its topics.
fn open_bag(dir: &Path) -> Result<Recording, ScenarioError> {
    let info = crate::ros2::read::bag_info(dir)?;
    let bytes = std::fs::read(&info.storage).map_err(|err| ScenarioError::Io {
        file: info.storage.clone(),
        err,
    })?;
    let rec = Recording::from_bytes_profile(bytes, &info.storage, true)?;
    // metadata.yaml and the storage file must tell the same story.
    let in_file = rec.topics();
    for t in &info.topics {
        if let Some((_, schema)) = in_file.iter().find(|(n, _)| *n == t.name) {
            if *schema != t.msg_type {
                return Err(bad(
                    &info.storage,
                    format!("topic {}", t.name),
                    format!(
                        "message type {schema:?} in the storage file, {:?} in metadata.yaml",
                        t.msg_type
                    ),
                ));
            }
        }
    }
    Ok(rec)
}

/// A recording read into memory and checked: MCAP framing, sizes and CRCs (see
/// [`container`](atrium_formats::mcap::container)), schemas of the known topics, channels defined before
/// their messages, messages in log-time order and none twice, required topics, metadata.
pub struct Recording {
    pub path: PathBuf,
    bytes: Vec<u8>,
    /// Schema id -> (name, encoding, CRC of the schema's data).
    schemas: HashMap<u16, (String, String, u32)>,
    channels: HashMap<u16, ChannelInfo>,
    /// Messages per channel id.
    counts: HashMap<u16, u64>,
    /// The `atrium` metadata record (empty for a file from elsewhere).
    pub metadata: BTreeMap<String, String>,
    /// The `atrium.summary` metadata record, when the file has one.
    pub summary: BTreeMap<String, String>,
    /// The storage file of a ROS 2 bag (CDR messages, `crate::ros2`).
    pub(crate) ros2: bool,
}

/// What has been seen of one channel at its latest log time: duplicates are messages of the
/// same channel at the same log time with the same sequence number.
#[derive(Default)]
struct SeenAt {
    log_time: u64,
    sequences: HashSet<u32>,
    /// Sequence 0 means "not numbered" (many writers leave it so): such messages at one
    /// time are duplicates only when their bytes are identical, since a topic may carry
    /// several distinct messages at one instant (`/tf` from several broadcasters).
    unnumbered: HashSet<(usize, u64)>,
}

impl Recording {
    pub fn open(path: &Path) -> Result<Recording, ScenarioError> {
        let io = |err| ScenarioError::Io {
            file: path.to_path_buf(),
            err,
        };
        // A device or a pipe named as a recording would be read forever (`/dev/zero`).
        let meta = std::fs::metadata(path).map_err(io)?;
        if meta.is_dir() {
            // A ROS 2 bag folder (metadata.yaml and its MCAP file).
            return open_bag(path);
        }
        if !meta.is_file() {
            let what = if meta.is_dir() {
                "is a folder"
            } else {
                "is not a regular file"
            };
            return Err(bad(path, "file", format!("{what}, not an MCAP recording")));
        }
        let bytes = std::fs::read(path).map_err(io)?;
        Self::from_bytes(bytes, path)
    }

    pub fn from_bytes(bytes: Vec<u8>, path: &Path) -> Result<Recording, ScenarioError> {
        Self::from_bytes_profile(bytes, path, false)
    }

    /// [`Recording::from_bytes`] of a Foxglove-profile file, or (`ros2`) of a ROS 2 bag's
    /// storage file, whose channels are checked by `ros2::read::check_channel`.
    pub(crate) fn from_bytes_profile(
        bytes: Vec<u8>,
        path: &Path,
        ros2: bool,
    ) -> Result<Recording, ScenarioError> {
        let mut rec = Recording {
            ros2,
            path: path.to_path_buf(),
            bytes: Vec::new(),
            schemas: HashMap::new(),
            channels: HashMap::new(),
            counts: HashMap::new(),
            metadata: BTreeMap::new(),
            summary: BTreeMap::new(),
        };
        // One pass over every record, chunks unpacked: whatever replay will read later has
        // passed every check here, before a localizer is built.
        let mut seen: HashMap<u16, SeenAt> = HashMap::new();
        let mut last_time: Option<(u64, u16)> = None;
        for r in Records::new(&bytes, path)? {
            let (place, r) = r?;
            match r {
                Record::Message { header, data } => {
                    rec.check_message(place, &header, &data, &mut seen, &mut last_time)?;
                }
                other => rec.take_record(place, &other)?,
            }
        }
        rec.bytes = bytes;
        if let Some(v) = rec.metadata.get("physics_hz") {
            // Replay snaps log times to this clock: 0, negative or NaN would make every
            // stamp infinite or NaN.
            if !v.parse::<f64>().is_ok_and(|hz| hz.is_finite() && hz > 0.0) {
                return Err(bad(
                    path,
                    "metadata.physics_hz",
                    format!("{v:?} is not a rate in Hz (a finite number > 0)"),
                ));
            }
        }
        let has = |t: &str| rec.channels.values().any(|c| c.topic == t);
        if !(has(topics::ODOM_WHEELS) || has(topics::ODOM)) {
            return Err(bad(
                path,
                "topics",
                format!(
                    "lacks odometry: no {} or {} topic",
                    topics::ODOM_WHEELS,
                    topics::ODOM
                ),
            ));
        }
        if !(has(topics::SCORE) || has(topics::GROUND_TRUTH)) {
            return Err(bad(
                path,
                "topics",
                format!(
                    "lacks ground truth: no {} or {} topic",
                    topics::SCORE,
                    topics::GROUND_TRUTH
                ),
            ));
        }
        Ok(rec)
    }

    /// A message's channel is defined, its log time does not go back, and it is not a
    /// second copy of a message already seen.
    fn check_message(
        &mut self,
        place: Place,
        header: &MessageHeader,
        data: &[u8],
        seen: &mut HashMap<u16, SeenAt>,
        last_time: &mut Option<(u64, u16)>,
    ) -> Result<(), ScenarioError> {
        let id = header.channel_id;
        let Some(ch) = self.channels.get(&id) else {
            return Err(bad(
                &self.path,
                place.to_string(),
                format!("a message on channel {id}, which no channel record before it defines"),
            ));
        };
        let topic = format!("topic {}", ch.topic);
        let ns = header.log_time;
        if let Some((prev, prev_ch)) = *last_time {
            if ns < prev {
                let prev_topic = self.channels.get(&prev_ch).map_or("?", |c| &c.topic);
                return Err(bad(
                    &self.path,
                    topic,
                    format!(
                        "messages are not in log-time order ({ns} ns, {place}, after {prev} ns on {prev_topic}); replay reads files in time order"
                    ),
                ));
            }
        }
        *last_time = Some((ns, id));
        let at = seen.entry(id).or_default();
        if at.log_time != ns {
            at.log_time = ns;
            at.sequences.clear();
            at.unnumbered.clear();
        }
        let again = if header.sequence == 0 {
            let mut h = std::hash::DefaultHasher::new();
            data.hash(&mut h);
            !at.unnumbered.insert((data.len(), h.finish()))
        } else {
            !at.sequences.insert(header.sequence)
        };
        if again {
            let which = match header.sequence {
                0 => "unnumbered, with the same bytes".to_string(),
                s => format!("sequence {s}"),
            };
            return Err(bad(
                &self.path,
                topic,
                format!(
                    "the message at {} s (log time {ns} ns, {which}) is there twice (the second at the {place}): replay would feed the localizers the same reading twice; the file is damaged or was joined from overlapping recordings",
                    ns as f64 / 1e9
                ),
            ));
        }
        *self.counts.entry(id).or_default() += 1;
        Ok(())
    }

    fn take_record(&mut self, place: Place, r: &Record) -> Result<(), ScenarioError> {
        match r {
            Record::Schema { header, data } => {
                let new = (
                    header.name.clone(),
                    header.encoding.clone(),
                    crc32fast::hash(data),
                );
                match self.schemas.get(&header.id) {
                    // The summary section repeats the schemas of the data section.
                    Some(old) if *old == new => {}
                    Some(old) => {
                        return Err(bad(
                            &self.path,
                            place.to_string(),
                            format!(
                                "schema {} is defined twice, differently ({:?} and {:?})",
                                header.id, old.0, new.0
                            ),
                        ))
                    }
                    None => {
                        self.schemas.insert(header.id, new);
                    }
                }
            }
            Record::Channel(c) => {
                let schema = match c.schema_id {
                    0 => String::new(),
                    id => self.schemas.get(&id).map(|s| s.0.clone()).ok_or_else(|| {
                        bad(
                            &self.path,
                            format!("topic {}", c.topic),
                            format!("refers to schema {id}, which the file does not define"),
                        )
                    })?,
                };
                if self.ros2 {
                    crate::ros2::read::check_channel(&c.topic, &schema, &c.message_encoding)
                        .map_err(|m| bad(&self.path, format!("topic {}", c.topic), m))?;
                } else if let Some((name, encoding)) = expected_schema(&c.topic) {
                    if schema != name || c.message_encoding != encoding {
                        return Err(bad(
                            &self.path,
                            format!("topic {}", c.topic),
                            format!(
                                "has schema {:?} with {:?} messages, expected {name:?} with {encoding:?} messages",
                                schema, c.message_encoding
                            ),
                        ));
                    }
                }
                let info = ChannelInfo {
                    topic: c.topic.clone(),
                    schema,
                    metadata: c.metadata.clone(),
                };
                match self.channels.get(&c.id) {
                    Some(old)
                        if old.topic == info.topic
                            && old.schema == info.schema
                            && old.metadata == info.metadata => {}
                    Some(old) => {
                        return Err(bad(
                            &self.path,
                            place.to_string(),
                            format!(
                                "channel {} is defined twice, differently (topics {} and {})",
                                c.id, old.topic, info.topic
                            ),
                        ))
                    }
                    None => {
                        self.channels.insert(c.id, info);
                    }
                }
            }
            Record::Metadata(m) if m.name == METADATA_NAME => self.metadata = m.metadata.clone(),
            Record::Metadata(m) if m.name == SUMMARY_NAME => self.summary = m.metadata.clone(),
            _ => {}
        }
        Ok(())
    }

    /// Messages on `topic` (0 when the file has no such topic).
    pub fn message_count(&self, topic: &str) -> u64 {
        self.channels
            .iter()
            .filter(|(_, c)| c.topic == topic)
            .map(|(id, _)| self.counts.get(id).copied().unwrap_or(0))
            .sum()
    }

    /// The topics of the file with their schema names, sorted.
    pub fn topics(&self) -> Vec<(String, String)> {
        let mut v: Vec<_> = self
            .channels
            .values()
            .map(|c| (c.topic.clone(), c.schema.clone()))
            .collect();
        v.sort();
        v.dedup();
        v
    }

    fn meta_f64(&self, key: &str) -> Option<f64> {
        self.metadata.get(key).and_then(|v| v.parse().ok())
    }

    /// The scenario to replay under: `override_path`, else the recorded scenario text (its
    /// relative paths resolve against the recorded scenario file's folder). Either way its
    /// world and robot must be the ones the recording was made with (see
    /// [`Recording::check_same_world_and_robot`]).
    pub fn scenario(&self, override_path: Option<&Path>) -> Result<Scenario, ScenarioError> {
        let scenario = match override_path {
            Some(p) => Scenario::load(p)?,
            None => {
                let (Some(text), Some(file)) = (
                    self.metadata.get("scenario"),
                    self.metadata.get("scenario_file"),
                ) else {
                    return Err(bad(
                        &self.path,
                        "metadata",
                        "has no Atrium scenario metadata: name a scenario with --scenario FILE",
                    ));
                };
                Scenario::from_toml_str(text, Path::new(file)).map_err(|e| {
                    bad(
                        &self.path,
                        "metadata.scenario",
                        format!("the recorded scenario cannot be loaded here ({e}); name one with --scenario FILE"),
                    )
                })?
            }
        };
        self.check_same_world_and_robot(&scenario, override_path)?;
        Ok(scenario)
    }

    /// Refuses to replay under another world or robot than the recording's: the readings
    /// were taken in one building, and scoring them against another map gives numbers that
    /// look plausible and mean nothing. Compares the names, and the content hashes of the
    /// world and robot files when the recording has them (`record` stores them); a scenario
    /// given with `--scenario` (`given`) is named as the culprit, else the recording.
    pub fn check_same_world_and_robot(
        &self,
        scenario: &Scenario,
        given: Option<&Path>,
    ) -> Result<(), ScenarioError> {
        let sides = [
            ("world", &scenario.world.name, &scenario.world_file),
            ("robot", &scenario.robot.name, &scenario.robot_file),
        ];
        for (what, name, file) in sides {
            let Some(recorded) = self.metadata.get(what) else {
                continue; // a file from elsewhere: nothing to compare with
            };
            let recorded_file = self
                .metadata
                .get(&format!("{what}_file"))
                .map_or(String::new(), |f| format!(" from {f}"));
            let hash_then = self.metadata.get(&format!("{what}_hash"));
            let hash_now = match hash_then {
                Some(_) => Some(crate::record::content_hash(&std::fs::read(file).map_err(
                    |err| ScenarioError::Io {
                        file: file.clone(),
                        err,
                    },
                )?)),
                None => None,
            };
            let same_content = hash_then.zip(hash_now.as_ref()).is_none_or(|(a, b)| a == b);
            if recorded == name && same_content {
                continue;
            }
            let contents = match (hash_then, &hash_now) {
                (Some(a), Some(b)) if recorded == name => {
                    format!(" (content hash {a} then, {b} in {} now)", file.display())
                }
                _ => String::new(),
            };
            let consequence = if what == "world" {
                "replaying there would score the readings against another map"
            } else {
                "replaying with it would read the recorded odometry and sensors as another robot's"
            };
            return Err(match given {
                Some(s) => bad(
                    s,
                    what,
                    format!(
                        "{what} {name:?} ({}) is not the {what} the recording {} was made with, {what} {recorded:?}{recorded_file}{contents}: {consequence}; name a scenario with the recording's {what}",
                        file.display(),
                        self.path.display()
                    ),
                ),
                None => bad(
                    &self.path,
                    format!("metadata.{what}"),
                    format!(
                        "the recording was made with {what} {recorded:?}{recorded_file}, but the recorded scenario now loads {what} {name:?} ({}){contents}: the {what} changed since the recording was made; {consequence}",
                        file.display()
                    ),
                ),
            });
        }
        Ok(())
    }

    /// Refuses a replay whose localizers read a sensor the recording has no messages of:
    /// they would run on odometry alone and report dead reckoning's errors as theirs.
    pub fn check_sensor_topics(&self, scenario: &Scenario) -> Result<(), ScenarioError> {
        for spec in &scenario.localizers {
            for need in sensor_needs(spec, scenario) {
                let found = self.channels.iter().any(|(id, c)| {
                    let name_ok = match &need.sensor {
                        Some(s) => c.topic.strip_prefix(need.prefix) == Some(s.as_str()),
                        None => c.topic.starts_with(need.prefix),
                    };
                    name_ok && self.counts.get(id).is_some_and(|&n| n > 0)
                });
                if found {
                    continue;
                }
                let topic = match &need.sensor {
                    Some(s) => format!("{}{s}", need.prefix),
                    None => format!("a {}<sensor> topic", need.prefix),
                };
                let mut with: Vec<&str> = self
                    .channels
                    .iter()
                    .filter(|(id, _)| self.counts.get(id).is_some_and(|&n| n > 0))
                    .map(|(_, c)| c.topic.as_str())
                    .collect();
                with.sort_unstable();
                with.dedup();
                return Err(bad(
                    &self.path,
                    "topics",
                    format!(
                        "localizer {:?} (kind {}) needs {} on {topic}, but the recording has no messages there (topics with messages: {}); replay other localizers (--localizer NAME=KIND) or record the sensor",
                        spec.name,
                        spec.kind,
                        need.what,
                        with.join(", ")
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// A message record: header and (possibly decompressed) payload.
type RawMessage<'a> = (MessageHeader, Cow<'a, [u8]>);

/// Streams a recording's messages in file order, one instant (log time) at a time.
struct ReplayStream<'a> {
    rec: &'a Recording,
    channels: HashMap<u16, ChannelInfo>,
    records: Records<'a>,
    pending: Option<RawMessage<'a>>,
    physics_hz: Option<f64>,
    use_wheels: bool,
    use_score: bool,
    base_link: String,
    /// Planar poses of frames relative to the base link, from `/tf`.
    frames: HashMap<String, Pose2>,
    last_t: f64,
    last_gt: Option<Pose2>,
    distance: f64,
    decode_s: f64,
    /// The decoder of a ROS 2 bag's messages.
    ros2: Option<crate::ros2::read::Decoder>,
}

impl<'a> ReplayStream<'a> {
    fn new(rec: &'a Recording, base_link: String) -> Result<Self, ScenarioError> {
        let has = |t: &str| rec.channels.values().any(|c| c.topic == t);
        Ok(ReplayStream {
            channels: rec.channels.clone(),
            records: Records::new(&rec.bytes, &rec.path)?,
            pending: None,
            physics_hz: rec.meta_f64("physics_hz"),
            use_wheels: has(topics::ODOM_WHEELS),
            use_score: has(topics::SCORE),
            ros2: rec.ros2.then(|| {
                let names: Vec<String> = rec.channels.values().map(|c| c.topic.clone()).collect();
                crate::ros2::read::Decoder::new(base_link.clone(), &names)
            }),
            base_link,
            frames: HashMap::new(),
            last_t: 0.0,
            last_gt: None,
            distance: 0.0,
            decode_s: 0.0,
            rec,
        })
    }

    /// The next message record, taking schema and channel records on the way.
    fn pull(&mut self) -> Result<Option<RawMessage<'a>>, ScenarioError> {
        for r in self.records.by_ref() {
            let (_, r) = r?;
            match r {
                Record::Message { header, data } => return Ok(Some((header, data))),
                Record::Channel(c) if !self.channels.contains_key(&c.id) => {
                    self.channels.insert(
                        c.id,
                        ChannelInfo {
                            topic: c.topic.clone(),
                            schema: String::new(),
                            metadata: c.metadata.clone(),
                        },
                    );
                }
                _ => {}
            }
        }
        Ok(None)
    }

    fn handle(
        &mut self,
        header: &MessageHeader,
        data: &[u8],
        readings: &mut Vec<Reading>,
        score: &mut Option<(f64, Pose2)>,
        events: &mut Vec<Event>,
    ) -> Result<(), ScenarioError> {
        let Some(ch) = self.channels.get(&header.channel_id) else {
            return Err(bad(
                &self.rec.path,
                "file",
                format!(
                    "message on channel {} which the file never defines",
                    header.channel_id
                ),
            ));
        };
        let topic = ch.topic.as_str();
        let stamp = seconds_of(header.log_time, self.physics_hz);
        let fail = |e: &dyn std::fmt::Display| {
            bad(
                &self.rec.path,
                format!("topic {topic}"),
                format!("message at {stamp} s cannot be decoded: {e}"),
            )
        };
        if let Some(dec) = self.ros2.as_mut() {
            return dec
                .handle(
                    topic,
                    &ch.schema,
                    &ch.metadata,
                    header.log_time,
                    stamp,
                    data,
                    readings,
                    score,
                    events,
                )
                .map_err(|e| fail(&e));
        }
        match topic {
            topics::ODOM_WHEELS if self.use_wheels => {
                let o: WheelOdometry = serde_json::from_slice(data).map_err(|e| fail(&e))?;
                readings.push(Reading::Odometry(o));
            }
            topics::ODOM if !self.use_wheels => {
                let p = fg::PoseInFrame::decode(data).map_err(|e| fail(&e))?;
                readings.push(Reading::Odometry(WheelOdometry {
                    stamp,
                    pose: codec::pose2_of(p.pose.as_ref()),
                    left_ticks: 0,
                    right_ticks: 0,
                }));
            }
            topics::SCORE if self.use_score => {
                let v: serde_json::Value = serde_json::from_slice(data).map_err(|e| fail(&e))?;
                let num = |k: &str| {
                    v.get(k)
                        .and_then(serde_json::Value::as_f64)
                        .ok_or_else(|| fail(&format!("no number {k:?}")))
                };
                *score = Some((num("t")?, Pose2::new(num("x")?, num("y")?, num("theta")?)));
            }
            topics::GROUND_TRUTH if !self.use_score => {
                let p = fg::PoseInFrame::decode(data).map_err(|e| fail(&e))?;
                *score = Some((stamp, codec::pose2_of(p.pose.as_ref())));
            }
            topics::EVENTS => {
                let v: serde_json::Value = serde_json::from_slice(data).map_err(|e| fail(&e))?;
                let mut e =
                    events_from_json(&serde_json::Value::Array(vec![v])).map_err(|e| fail(&e))?;
                events.append(&mut e);
            }
            topics::TF => {
                let tf = fg::FrameTransforms::decode(data).map_err(|e| fail(&e))?;
                for t in tf.transforms {
                    if t.parent_frame_id == self.base_link {
                        let (x, y) = t.translation.as_ref().map_or((0.0, 0.0), |v| (v.x, v.y));
                        let th = t.rotation.as_ref().map_or(0.0, codec::yaw_of);
                        self.frames.insert(t.child_frame_id, Pose2::new(x, y, th));
                    }
                }
            }
            t if t.starts_with(topics::SCAN_PREFIX) => {
                let msg = fg::LaserScan::decode(data).map_err(|e| fail(&e))?;
                let mount = self.frames.get(&msg.frame_id).copied().unwrap_or_default();
                let sensor = &t[topics::SCAN_PREFIX.len()..];
                readings.push(Reading::Laser(codec::laser_from_message(
                    &msg,
                    &ch.metadata,
                    sensor,
                    stamp,
                    mount,
                )));
            }
            t if t.starts_with(topics::DEPTH_PREFIX) => {
                let msg = fg::RawImage::decode(data).map_err(|e| fail(&e))?;
                let sensor = &t[topics::DEPTH_PREFIX.len()..];
                let d = codec::depth_from_message(&msg, &ch.metadata, sensor, stamp)
                    .map_err(|e| fail(&e))?;
                readings.push(Reading::Depth(d));
            }
            t if t.starts_with(topics::IMAGE_PREFIX) => {
                let msg = fg::RawImage::decode(data).map_err(|e| fail(&e))?;
                let sensor = &t[topics::IMAGE_PREFIX.len()..];
                let i = atrium_formats::mcap::images::intensity_from_message(
                    &msg,
                    &ch.metadata,
                    sensor,
                    stamp,
                )
                .map_err(|e| fail(&e))?;
                readings.push(Reading::Intensity(i));
            }
            t if t.starts_with(topics::DISPARITY_PREFIX) => {
                let msg = fg::RawImage::decode(data).map_err(|e| fail(&e))?;
                let sensor = &t[topics::DISPARITY_PREFIX.len()..];
                let d = atrium_formats::mcap::images::disparity_from_message(
                    &msg,
                    &ch.metadata,
                    sensor,
                    stamp,
                )
                .map_err(|e| fail(&e))?;
                readings.push(Reading::Disparity(d));
            }
            t if t.starts_with(topics::WIFI_PREFIX) => {
                let w: WifiScan = serde_json::from_slice(data).map_err(|e| fail(&e))?;
                readings.push(Reading::Wifi(w));
            }
            t if t.starts_with(topics::LANDMARKS_PREFIX) => {
                let l: LandmarkDetections = serde_json::from_slice(data).map_err(|e| fail(&e))?;
                readings.push(Reading::Landmarks(l));
            }
            _ => {}
        }
        Ok(())
    }
}

impl ReadingStream for ReplayStream<'_> {
    fn next(&mut self, readings: &mut Vec<Reading>) -> Result<Option<Tick>, ScenarioError> {
        let t0 = Instant::now();
        readings.clear();
        let mut group: Option<u64> = None;
        let mut score = None;
        let mut events = Vec::new();
        loop {
            let (header, data) = match self.pending.take() {
                Some(m) => m,
                None => match self.pull()? {
                    Some(m) => m,
                    None => break,
                },
            };
            match group {
                None => group = Some(header.log_time),
                Some(g) if header.log_time > g => {
                    self.pending = Some((header, data));
                    break;
                }
                Some(g) if header.log_time < g => {
                    let topic = self
                        .channels
                        .get(&header.channel_id)
                        .map_or("?", |c| c.topic.as_str());
                    return Err(bad(
                        &self.rec.path,
                        format!("topic {topic}"),
                        format!(
                            "messages are not in log-time order ({} ns after {g} ns); replay reads files in time order",
                            header.log_time
                        ),
                    ));
                }
                _ => {}
            }
            self.handle(&header, &data, readings, &mut score, &mut events)?;
        }
        self.decode_s += t0.elapsed().as_secs_f64();
        let Some(ns) = group else {
            return Ok(None);
        };
        let t = match score {
            Some((t, _)) => t,
            None => seconds_of(ns, self.physics_hz),
        };
        self.last_t = t;
        let truth = score.map(|(_, p)| p);
        if let Some(p) = truth {
            if let Some(prev) = self.last_gt {
                self.distance += prev.distance(&p);
            }
            self.last_gt = Some(p);
        }
        Ok(Some(Tick {
            t,
            truth,
            score: truth.is_some(),
            events,
        }))
    }

    fn summary(&self) -> StreamSummary {
        let s = &self.rec.summary;
        let get = |k: &str| s.get(k).and_then(|v| v.parse::<f64>().ok());
        StreamSummary {
            sim_time_s: get("sim_time_s").unwrap_or(self.last_t),
            distance_m: get("distance_m").unwrap_or(self.distance),
            route_completed: s.get("route_completed").is_some_and(|v| v == "true"),
            physics_steps: s
                .get("physics_steps")
                .and_then(|v| v.parse().ok())
                .unwrap_or(0),
            source_s: self.decode_s,
        }
    }
}

/// What a replay produced.
pub struct Replayed {
    pub run: RunResult,
    pub scenario: Scenario,
    pub topics: Vec<(String, String)>,
}

/// Replays the recording at `path` (see the module docs).
pub fn replay(path: &Path, options: ReplayOptions) -> Result<Replayed, ScenarioError> {
    let rec = Recording::open(path)?;
    replay_recording(&rec, options)
}

pub fn replay_recording(
    rec: &Recording,
    options: ReplayOptions,
) -> Result<Replayed, ScenarioError> {
    // The names name output files: a path or a name given twice must not reach them.
    for (i, (name, _)) in options.localizers.iter().enumerate() {
        let field = format!("localizers[{i}]");
        atrium_scenarios::scenario::check_localizer_name(name)
            .map_err(|e| ScenarioError::field(&rec.path, &field, e))?;
        if options.localizers[..i].iter().any(|(n, _)| n == name) {
            return Err(ScenarioError::field(
                &rec.path,
                field,
                format!("the name {name:?} is given twice"),
            ));
        }
    }
    let mut scenario = rec.scenario(options.scenario.as_deref())?;
    if !options.localizers.is_empty() {
        scenario.localizers = options
            .localizers
            .iter()
            .map(|(name, kind)| LocalizerSpec {
                name: name.clone(),
                kind: kind.clone(),
                params: toml::Table::new(),
            })
            .collect();
        let names: Vec<&String> = options.localizers.iter().map(|(n, _)| n).collect();
        scenario.expect.retain(|k, _| names.iter().any(|n| *n == k));
    }
    replay_scenario(rec, scenario, options.registry, options.progress, None)
}

/// Replays `rec` under `scenario` as given (its localizers and expectations), with the
/// recording's seed and events. Take `scenario` from [`Recording::scenario`], which checks
/// that its world and robot are the recording's; its localizers' sensor topics are checked
/// here. `on_tick`, when given, sees every instant before the
/// localizers get its readings (`score` sets the clock of foreign estimates from it).
pub fn replay_scenario(
    rec: &Recording,
    scenario: Scenario,
    registry: Option<&LocalizerRegistry>,
    progress: Option<&mut dyn FnMut(f64, f64)>,
    on_tick: Option<&mut dyn FnMut(&Tick)>,
) -> Result<Replayed, ScenarioError> {
    let seed = match rec.metadata.get("seed") {
        Some(s) => s
            .parse()
            .map_err(|_| bad(&rec.path, "metadata.seed", format!("not a seed: {s:?}")))?,
        None => scenario.seed,
    };
    let events = match rec.metadata.get("events") {
        Some(text) => serde_json::from_str(text)
            .map_err(|e| e.to_string())
            .and_then(|v| events_from_json(&v))
            .map_err(|e| bad(&rec.path, "metadata.events", e))?,
        None => scenario.events.clone(),
    };
    rec.check_sensor_topics(&scenario)?;
    let base_link = rec
        .metadata
        .get("base_link")
        .cloned()
        .unwrap_or_else(|| scenario.robot.base_link.clone());
    let mut stream = Watched {
        inner: ReplayStream::new(rec, base_link)?,
        on_tick,
    };
    let builtins;
    let registry = match registry {
        Some(r) => r,
        None => {
            builtins = LocalizerRegistry::with_builtins();
            &builtins
        }
    };
    let run = registry.run_stream(
        &scenario,
        seed,
        &mut stream,
        &events,
        RunOptions {
            seed: Some(seed),
            progress,
            observer: None,
        },
    )?;
    Ok(Replayed {
        run,
        topics: rec.topics(),
        scenario,
    })
}

/// A replay stream whose instants are also shown to a callback.
struct Watched<'a, 'f> {
    inner: ReplayStream<'a>,
    on_tick: Option<&'f mut dyn FnMut(&Tick)>,
}

impl ReadingStream for Watched<'_, '_> {
    fn next(&mut self, readings: &mut Vec<Reading>) -> Result<Option<Tick>, ScenarioError> {
        let tick = self.inner.next(readings)?;
        if let (Some(t), Some(f)) = (&tick, self.on_tick.as_mut()) {
            f(t);
        }
        Ok(tick)
    }
    fn summary(&self) -> StreamSummary {
        self.inner.summary()
    }
    fn verify_node(&mut self, node: usize, pose: Pose2) {
        self.inner.verify_node(node, pose);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Recorder;
    use atrium_robots::{DepthImage, LandmarkDetection, LaserScan, Mount3, WifiReading};

    /// A stream of hand-built instants: what a sensor not yet simulated will produce.
    struct VecStream(std::vec::IntoIter<(Tick, Vec<Reading>)>);

    impl ReadingStream for VecStream {
        fn next(&mut self, out: &mut Vec<Reading>) -> Result<Option<Tick>, ScenarioError> {
            out.clear();
            Ok(self.0.next().map(|(t, r)| {
                out.extend(r);
                t
            }))
        }
        fn summary(&self) -> StreamSummary {
            StreamSummary::default()
        }
    }

    fn readings_at(k: u64) -> Vec<Reading> {
        let t = k as f64 / 200.0;
        vec![
            Reading::Odometry(WheelOdometry {
                stamp: t,
                pose: Pose2::new(2.0 + 0.001 * k as f64, 20.0, 0.1 / 3.0 * k as f64),
                left_ticks: 3 * k as i64,
                right_ticks: 5 * k as i64 - 7,
            }),
            Reading::Laser(LaserScan {
                stamp: t,
                sensor: "laser".into(),
                mount: Pose2::new(0.13, 0.0, 0.0),
                angle_min: -std::f64::consts::FRAC_PI_2,
                angle_increment: std::f64::consts::PI / 180.0,
                range_min: 0.0,
                range_max: 8.0,
                ranges: (0..181)
                    .map(|i| 1.0 / (1.0 + i as f64) + k as f64)
                    .collect(),
            }),
            Reading::Depth(DepthImage {
                stamp: t,
                sensor: "kinect".into(),
                mount: Mount3 {
                    xyz: [0.1, 0.02, 0.5],
                    rpy: [0.0, 0.2, 0.0],
                },
                width: 4,
                height: 3,
                fx: 140.0,
                fy: 141.0,
                cx: 1.5,
                cy: 1.0,
                depth: (0..12)
                    .map(|i| {
                        if i % 5 == 0 {
                            0.0
                        } else {
                            0.8 + i as f32 / 7.0
                        }
                    })
                    .collect(),
            }),
            Reading::Wifi(WifiScan {
                stamp: t,
                sensor: "wifi".into(),
                readings: vec![
                    WifiReading {
                        ap: "ap-atrium".into(),
                        channel: 6,
                        rssi_dbm: -61.0 - k as f64,
                    },
                    WifiReading {
                        ap: "ap-office".into(),
                        channel: 11,
                        rssi_dbm: -77.0,
                    },
                ],
            }),
            Reading::Landmarks(LandmarkDetections {
                stamp: t,
                sensor: "pillars".into(),
                mount: Pose2::new(0.1, 0.0, 0.0),
                detections: vec![
                    LandmarkDetection {
                        range: 3.25,
                        bearing: -0.4 / 3.0,
                        id: Some(4),
                    },
                    LandmarkDetection {
                        range: 7.5,
                        bearing: 1.0,
                        id: None,
                    },
                ],
            }),
        ]
    }

    #[test]
    fn a_write_failure_names_the_output_and_leaves_no_partial_file() {
        let path = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
        let scenario = Scenario::load(&path).unwrap();
        let dir = std::env::temp_dir().join(format!("atrium-write-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("run.mcap");
        let partial = dir.join("run.mcap.partial");
        std::fs::write(&partial, "left by a killed run").unwrap();
        let mut recorder = Recorder::create(&out, &scenario, 9).unwrap();
        // The stale partial file was replaced by the new recording.
        assert_ne!(std::fs::read(&partial).unwrap(), b"left by a killed run");
        let ticks: Vec<(Tick, Vec<Reading>)> = (1..=2u64)
            .map(|k| {
                let tick = Tick {
                    t: k as f64 / 200.0,
                    truth: Some(Pose2::new(2.0, 20.0, 0.0)),
                    score: true,
                    events: Vec::new(),
                };
                (tick, readings_at(k))
            })
            .collect();
        let run = LocalizerRegistry::with_builtins()
            .run_stream(
                &scenario,
                9,
                &mut VecStream(ticks.into_iter()),
                &[],
                RunOptions {
                    observer: Some(&mut recorder),
                    ..Default::default()
                },
            )
            .unwrap();
        // The final name is taken meanwhile by a folder with a file in it: renaming fails.
        std::fs::create_dir(&out).unwrap();
        std::fs::write(out.join("x"), "x").unwrap();
        let e = recorder.finish(&run).unwrap_err().to_string();
        assert!(
            e.contains(&format!("cannot write {}", out.display())),
            "{e}"
        );
        assert!(!e.contains("partial") && !e.contains("cannot read"), "{e}");
        assert!(!partial.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn every_reading_variant_round_trips_exactly() {
        let path = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
        let scenario = Scenario::load(&path).unwrap();
        let dir = std::env::temp_dir().join(format!("atrium-codec-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let out = dir.join("all.mcap");
        let ticks: Vec<(Tick, Vec<Reading>)> = (1..=4u64)
            .map(|k| {
                let t = k as f64 / 200.0;
                let tick = Tick {
                    t,
                    truth: Some(Pose2::new(2.0, 20.0, 0.01 * k as f64)),
                    score: k % 2 == 0,
                    events: Vec::new(),
                };
                (tick, readings_at(k))
            })
            .collect();
        let mut recorder = Recorder::create(&out, &scenario, 9).unwrap();
        let run = LocalizerRegistry::with_builtins()
            .run_stream(
                &scenario,
                9,
                &mut VecStream(ticks.clone().into_iter()),
                &[],
                RunOptions {
                    observer: Some(&mut recorder),
                    ..Default::default()
                },
            )
            .unwrap();
        recorder.finish(&run).unwrap();

        let rec = Recording::open(&out).unwrap();
        let topics: Vec<String> = rec.topics().into_iter().map(|(t, _)| t).collect();
        for t in [
            "/depth/kinect",
            "/wifi/wifi",
            "/landmarks/pillars",
            "/scan/laser",
        ] {
            assert!(topics.iter().any(|x| x == t), "{t} missing from {topics:?}");
        }
        let mut stream = ReplayStream::new(&rec, scenario.robot.base_link.clone()).unwrap();
        let mut got = Vec::new();
        let mut buf = Vec::new();
        while let Some(tick) = stream.next(&mut buf).unwrap() {
            got.push((tick.t, tick.truth, buf.clone()));
        }
        assert_eq!(got.len(), ticks.len());
        for ((t, truth, readings), (tick, want)) in got.iter().zip(&ticks) {
            assert_eq!(t.to_bits(), tick.t.to_bits());
            assert_eq!(readings, want);
            // Ground truth is recorded at the scoring instants only.
            assert_eq!(*truth, tick.truth.filter(|_| tick.score));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
