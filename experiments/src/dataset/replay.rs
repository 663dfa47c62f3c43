//! `atrium replay`: a recording's readings fed to the localizers and scored against its
//! ground truth, through the same consumption loop as a live run (`runner::run_stream`), so a
//! replay of an Atrium recording gives exactly the live run's metrics.
//!
//! Files from elsewhere work when they use the same topics and schemas (see `dataset`):
//! without Atrium's exact side channels the odometry comes from `/odom`, the scoring instants
//! and ground truth from `/ground_truth`, a laser's mount from the `/tf` transform from the
//! base link to the scan's frame; such a file needs `--scenario` for the world and localizers.

use super::codec::{self, seconds_of};
use super::record::{events_from_json, METADATA_NAME, SUMMARY_NAME};
use super::topics;
use atrium_robots::{LandmarkDetections, Pose2, Reading, WheelOdometry, WifiScan};
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::runner::{ReadingStream, RunOptions, RunResult, StreamSummary, Tick};
use atrium_scenarios::scenario::{Event, LocalizerSpec, Scenario};
use atrium_scenarios::LocalizerRegistry;
use foxglove::messages as fg;
use foxglove::Decode;
use mcap::records::{MessageHeader, Record};
use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
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

fn bad(file: &Path, what: impl Into<String>, msg: impl Into<String>) -> ScenarioError {
    ScenarioError::field(file, what, msg)
}

/// A recording read into memory and checked: MCAP framing, schemas of the known topics,
/// required topics, metadata.
pub struct Recording {
    pub path: PathBuf,
    bytes: Vec<u8>,
    schemas: HashMap<u16, (String, String)>,
    channels: HashMap<u16, ChannelInfo>,
    /// The `atrium` metadata record (empty for a file from elsewhere).
    pub metadata: BTreeMap<String, String>,
    /// The `atrium.summary` metadata record, when the file has one.
    pub summary: BTreeMap<String, String>,
}

impl Recording {
    pub fn open(path: &Path) -> Result<Recording, ScenarioError> {
        let bytes = std::fs::read(path).map_err(|err| ScenarioError::Io {
            file: path.to_path_buf(),
            err,
        })?;
        Self::from_bytes(bytes, path)
    }

    pub fn from_bytes(bytes: Vec<u8>, path: &Path) -> Result<Recording, ScenarioError> {
        if !bytes.starts_with(mcap::MAGIC) {
            return Err(bad(
                path,
                "file",
                "not an MCAP file (it does not start with the MCAP magic bytes)",
            ));
        }
        if bytes.len() < 2 * mcap::MAGIC.len() || !bytes.ends_with(mcap::MAGIC) {
            return Err(bad(
                path,
                "file",
                "truncated MCAP file: it does not end with the footer's magic bytes (was the recording interrupted?)",
            ));
        }
        let mut rec = Recording {
            path: path.to_path_buf(),
            bytes: Vec::new(),
            schemas: HashMap::new(),
            channels: HashMap::new(),
            metadata: BTreeMap::new(),
            summary: BTreeMap::new(),
        };
        // Top-level records only (chunks stay compressed): schemas and channels repeated in
        // the summary section, and the metadata records.
        let reader = mcap::read::LinearReader::new(&bytes)
            .map_err(|e| bad(path, "file", format!("corrupt MCAP: {e}")))?;
        for r in reader {
            let r = r.map_err(|e| bad(path, "file", format!("corrupt MCAP: {e}")))?;
            rec.take_record(&r)?;
        }
        if rec.channels.is_empty() {
            // No summary section: the channel records live in the chunks.
            let flat = mcap::read::ChunkFlattener::new(&bytes)
                .map_err(|e| bad(path, "file", format!("corrupt MCAP: {e}")))?;
            for r in flat {
                let r = r.map_err(|e| bad(path, "file", format!("corrupt MCAP: {e}")))?;
                if !matches!(r, Record::Message { .. }) {
                    rec.take_record(&r)?;
                }
            }
        }
        rec.bytes = bytes;
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

    fn take_record(&mut self, r: &Record) -> Result<(), ScenarioError> {
        match r {
            Record::Schema { header, .. } => {
                self.schemas
                    .insert(header.id, (header.name.clone(), header.encoding.clone()));
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
                if let Some((name, encoding)) = expected_schema(&c.topic) {
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
                self.channels.insert(
                    c.id,
                    ChannelInfo {
                        topic: c.topic.clone(),
                        schema,
                        metadata: c.metadata.clone(),
                    },
                );
            }
            Record::Metadata(m) if m.name == METADATA_NAME => self.metadata = m.metadata.clone(),
            Record::Metadata(m) if m.name == SUMMARY_NAME => self.summary = m.metadata.clone(),
            _ => {}
        }
        Ok(())
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
    /// relative paths resolve against the recorded scenario file's folder).
    pub fn scenario(&self, override_path: Option<&Path>) -> Result<Scenario, ScenarioError> {
        if let Some(p) = override_path {
            return Scenario::load(p);
        }
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
        })
    }
}

/// A message record: header and (possibly decompressed) payload.
type RawMessage<'a> = (MessageHeader, Cow<'a, [u8]>);

/// Streams a recording's messages in file order, one instant (log time) at a time.
struct ReplayStream<'a> {
    rec: &'a Recording,
    channels: HashMap<u16, ChannelInfo>,
    records: mcap::read::ChunkFlattener<'a>,
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
}

impl<'a> ReplayStream<'a> {
    fn new(rec: &'a Recording, base_link: String) -> Result<Self, ScenarioError> {
        let has = |t: &str| rec.channels.values().any(|c| c.topic == t);
        Ok(ReplayStream {
            channels: rec.channels.clone(),
            records: mcap::read::ChunkFlattener::new(&rec.bytes)
                .map_err(|e| bad(&rec.path, "file", format!("corrupt MCAP: {e}")))?,
            pending: None,
            physics_hz: rec.meta_f64("physics_hz"),
            use_wheels: has(topics::ODOM_WHEELS),
            use_score: has(topics::SCORE),
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
            let r = r.map_err(|e| bad(&self.rec.path, "file", format!("corrupt MCAP: {e}")))?;
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
                let i = super::images::intensity_from_message(&msg, &ch.metadata, sensor, stamp)
                    .map_err(|e| fail(&e))?;
                readings.push(Reading::Intensity(i));
            }
            t if t.starts_with(topics::DISPARITY_PREFIX) => {
                let msg = fg::RawImage::decode(data).map_err(|e| fail(&e))?;
                let sensor = &t[topics::DISPARITY_PREFIX.len()..];
                let d = super::images::disparity_from_message(&msg, &ch.metadata, sensor, stamp)
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
/// recording's seed and events. `on_tick`, when given, sees every instant before the
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
    use crate::dataset::Recorder;
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
