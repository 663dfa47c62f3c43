//! `atrium record`: a live run written to MCAP as it happens (a [`RunObserver`] of the
//! runner), zstd-compressed chunks, log times from the simulation clock.
//!
//! The file is written as `<output>.partial` beside the output and renamed once complete, so
//! the final name never holds half a recording. The partial name is visible and tied to the
//! output on purpose: a run that is killed (SIGKILL, or SIGINT / SIGTERM, which the standard
//! library cannot catch and for which no signal crate is available offline here) leaves it
//! where the user sees what it is, and the next `record` to the same output replaces it. A
//! run that fails with an error removes it. The output is checked before the run starts
//! (its folder exists, it is no folder and not read-only, the partial file can be created),
//! so a bad `-o` costs nothing; every write error names the final output.

use crate::topics;
use atrium_formats::mcap::foxglove::{self as codec, json_schemas, ns_of};
use atrium_formats::mcap::scene::{people_update, robot_transforms, scene_update};
use atrium_localization::Estimate;
use atrium_robots::{Pose2, Reading};
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::runner::{PeopleFrame, RunObserver, RunOptions, RunResult, SimStream, Tick};
use atrium_scenarios::scenario::{Event, Scenario};
use atrium_scenarios::LocalizerRegistry;
use foxglove::messages as fg;
use foxglove::Encode;
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

/// The name of the header metadata record.
pub const METADATA_NAME: &str = "atrium";
/// The name of the metadata record written when the run has ended.
pub const SUMMARY_NAME: &str = "atrium.summary";

fn event_json(e: &Event) -> serde_json::Value {
    match e {
        Event::Kidnap { at_s, to } => serde_json::json!({
            "kind": "kidnap",
            "at_s": at_s,
            "to": {"x": to.x, "y": to.y, "theta": to.theta},
        }),
    }
}

/// Parses the events of [`event_json`] back (the `events` metadata key).
pub fn events_from_json(v: &serde_json::Value) -> Result<Vec<Event>, String> {
    let list = v.as_array().ok_or("events: not a list")?;
    list.iter()
        .enumerate()
        .map(|(i, e)| {
            let num = |p: &str| {
                e.pointer(p)
                    .and_then(serde_json::Value::as_f64)
                    .ok_or_else(|| format!("events[{i}]{}: missing number", p.replace('/', ".")))
            };
            match e.get("kind").and_then(|k| k.as_str()) {
                Some("kidnap") => Ok(Event::Kidnap {
                    at_s: num("/at_s")?,
                    to: Pose2::new(num("/to/x")?, num("/to/y")?, num("/to/theta")?),
                }),
                other => Err(format!("events[{i}].kind: unknown event {other:?}")),
            }
        })
        .collect()
}

struct Schemas {
    laser: u16,
    image: u16,
    pose: u16,
    tf: u16,
    scene: u16,
    wifi: u16,
    landmarks: u16,
    odometry: u16,
    score: u16,
    event: u16,
}

/// Writes one run to an MCAP file. Create it, pass it to the runner as its observer, then
/// [`Recorder::finish`] with the run's result; dropped unfinished, it removes its temporary
/// file and the final name is never created.
pub struct Recorder {
    writer: Option<mcap::Writer<BufWriter<File>>>,
    tmp: PathBuf,
    /// Removes `tmp` if the process is interrupted; dropped after the rename or removal.
    _unfinished: atrium_scenarios::output::Unfinished,
    path: PathBuf,
    schemas: Schemas,
    channels: HashMap<String, u16>,
    sequence: HashMap<u16, u32>,
    buf: Vec<u8>,
    image_buf: Vec<u8>,
    laser_msg: fg::LaserScan,
    image_msg: fg::RawImage,
    /// Laser name -> (frame, scan origin in that frame) from the scenario's sensor specs.
    laser_frames: HashMap<String, (String, Pose2)>,
    base_link: String,
    localizer_names: Vec<String>,
    world: atrium_worlds::World,
    robot: atrium_robots::RobotModel,
    started: bool,
    messages: u64,
    /// When the next `/people` update is due, ns.
    next_people_ns: u64,
}

/// `/people` updates per second of sim time: smooth enough to watch, a small share of the
/// file.
const PEOPLE_HZ: u64 = 10;

/// A failure to write the recording, named by its final path (never the partial one: that
/// is an implementation detail, and never "read": nothing is read here).
fn write_err(path: &Path, e: impl std::fmt::Display) -> ScenarioError {
    ScenarioError::field(
        path,
        "output",
        format!("cannot write {}: {e}", path.display()),
    )
}

/// The partial file a recording to `path` is written under until complete.
pub fn partial_path(path: &Path) -> Option<PathBuf> {
    let mut name = path.file_name()?.to_os_string();
    name.push(".partial");
    Some(path.with_file_name(name))
}

/// Checks that `path` can be the output of a recording, before any run: its folder exists,
/// it is not a folder itself, and it is not a read-only file (the rename at the end would
/// silently replace a file the user protected). Whether the folder is writable is found out
/// by creating the partial file, which [`Recorder::create`] does right after.
pub fn check_output(path: &Path) -> Result<(), ScenarioError> {
    let fail = |why: String| write_err(path, why);
    if path.file_name().is_none() {
        return Err(fail("it names no file".into()));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    match std::fs::metadata(dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(fail(format!("{} is not a folder", dir.display()))),
        Err(e) => return Err(fail(format!("folder {}: {e}", dir.display()))),
    }
    if let Ok(m) = std::fs::metadata(path) {
        if m.is_dir() {
            return Err(fail("it is a folder".into()));
        }
        if m.permissions().readonly() {
            return Err(fail("the file is read-only".into()));
        }
    }
    atrium_formats::output_path::check_replaceable(path).map_err(|e| fail(e.to_string()))?;
    Ok(())
}

/// A stable hash of a file a recording depends on (64-bit FNV-1a of its bytes, in hex):
/// replay compares it with the file it is given to notice another world or robot under the
/// same name. It catches accidents (an edited or different file), not forgeries.
pub fn content_hash(bytes: &[u8]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    format!("fnv1a64:{h:016x}")
}

impl Recorder {
    /// Checks the output ([`check_output`]), opens `<path>.partial` for writing (replacing
    /// one an earlier killed run left) and puts the scenario text, seed, Atrium version and
    /// the world and robot files' content hashes in the file's `atrium` metadata record.
    pub fn create(path: &Path, scenario: &Scenario, seed: u64) -> Result<Recorder, ScenarioError> {
        check_output(path)?;
        let tmp = partial_path(path).ok_or_else(|| write_err(path, "it names no file"))?;
        let hash_of = |file: &Path| {
            std::fs::read(file)
                .map(|b| content_hash(&b))
                .map_err(|err| ScenarioError::Io {
                    file: file.to_path_buf(),
                    err,
                })
        };
        let world_hash = hash_of(&scenario.world_file)?;
        let robot_hash = hash_of(&scenario.robot_file)?;
        let unfinished = atrium_scenarios::output::Unfinished::register(&tmp);
        // Truncates a partial file an earlier run left (only a SIGKILL or a power cut can).
        let file = File::create(&tmp).map_err(|e| write_err(path, e))?;
        let created = mcap::WriteOptions::new()
            .compression(Some(mcap::Compression::Zstd))
            .profile("")
            .library(format!("atrium {}", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::with_capacity(1 << 20, file))
            .map_err(|e| write_err(path, e));
        let mut writer = match created {
            Ok(w) => w,
            Err(e) => {
                let _ = std::fs::remove_file(&tmp);
                return Err(e);
            }
        };
        // From here on a failure drops `writer` unfinished; remove the partial file then.
        let made = Self::start(&mut writer, path, scenario, seed, world_hash, robot_hash);
        let schemas = match made {
            Ok(s) => s,
            Err(e) => {
                drop(writer);
                let _ = std::fs::remove_file(&tmp);
                return Err(e);
            }
        };
        let laser_frames = scenario
            .lasers
            .iter()
            .map(|l| (l.name.clone(), (l.mount.clone(), Pose2::default())))
            .collect();
        Ok(Recorder {
            writer: Some(writer),
            path: path.to_path_buf(),
            tmp,
            _unfinished: unfinished,
            schemas,
            channels: HashMap::new(),
            sequence: HashMap::new(),
            buf: Vec::with_capacity(1 << 16),
            image_buf: Vec::new(),
            laser_msg: fg::LaserScan::default(),
            image_msg: fg::RawImage::default(),
            laser_frames,
            base_link: scenario.robot.base_link.clone(),
            localizer_names: scenario.localizers.iter().map(|l| l.name.clone()).collect(),
            world: scenario.world.clone(),
            robot: scenario.robot.clone(),
            started: false,
            messages: 0,
            next_people_ns: 0,
        })
    }

    /// The schemas and the `atrium` metadata record, at the start of a new file.
    fn start(
        writer: &mut mcap::Writer<BufWriter<File>>,
        path: &Path,
        scenario: &Scenario,
        seed: u64,
        world_hash: String,
        robot_hash: String,
    ) -> Result<Schemas, ScenarioError> {
        let mut add = |name: &str, encoding: &str, data: &[u8]| {
            writer
                .add_schema(name, encoding, data)
                .map_err(|e| write_err(path, e))
        };
        let fox = |s: Option<foxglove::Schema>| s.expect("well-known schemas have a schema");
        let (l, i, p, t, s) = (
            fox(fg::LaserScan::get_schema()),
            fox(fg::RawImage::get_schema()),
            fox(fg::PoseInFrame::get_schema()),
            fox(fg::FrameTransforms::get_schema()),
            fox(fg::SceneUpdate::get_schema()),
        );
        let schemas = Schemas {
            laser: add(&l.name, &l.encoding, &l.data)?,
            image: add(&i.name, &i.encoding, &i.data)?,
            pose: add(&p.name, &p.encoding, &p.data)?,
            tf: add(&t.name, &t.encoding, &t.data)?,
            scene: add(&s.name, &s.encoding, &s.data)?,
            wifi: add(
                "atrium.WifiScan",
                "jsonschema",
                json_schemas::WIFI_SCAN.as_bytes(),
            )?,
            landmarks: add(
                "atrium.LandmarkDetections",
                "jsonschema",
                json_schemas::LANDMARKS.as_bytes(),
            )?,
            odometry: add(
                "atrium.WheelOdometry",
                "jsonschema",
                json_schemas::WHEEL_ODOMETRY.as_bytes(),
            )?,
            score: add(
                "atrium.ScoringInstant",
                "jsonschema",
                json_schemas::SCORE.as_bytes(),
            )?,
            event: add("atrium.Event", "jsonschema", json_schemas::EVENT.as_bytes())?,
        };

        let absolute = |p: &Path| {
            std::fs::canonicalize(p)
                .unwrap_or_else(|_| p.to_path_buf())
                .to_string_lossy()
                .into_owned()
        };
        let scenario_file = absolute(&scenario.file);
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
            ("seed".into(), seed.to_string()),
            ("scenario_name".into(), scenario.name.clone()),
            ("scenario_file".into(), scenario_file),
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
        writer
            .write_metadata(&mcap::records::Metadata {
                name: METADATA_NAME.into(),
                metadata,
            })
            .map_err(|e| write_err(path, e))?;
        Ok(schemas)
    }

    /// Messages written so far.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    fn writer(&mut self) -> &mut mcap::Writer<BufWriter<File>> {
        self.writer.as_mut().expect("the writer lives until finish")
    }

    fn channel(
        &mut self,
        topic: &str,
        schema: u16,
        metadata: impl FnOnce() -> BTreeMap<String, String>,
    ) -> Result<u16, ScenarioError> {
        if let Some(&id) = self.channels.get(topic) {
            return Ok(id);
        }
        let encoding = if schema == self.schemas.wifi
            || schema == self.schemas.landmarks
            || schema == self.schemas.odometry
            || schema == self.schemas.score
            || schema == self.schemas.event
        {
            "json"
        } else {
            "protobuf"
        };
        let meta = metadata();
        let path = self.path.clone();
        let id = self
            .writer()
            .add_channel(schema, topic, encoding, &meta)
            .map_err(|e| write_err(&path, e))?;
        self.channels.insert(topic.to_string(), id);
        Ok(id)
    }

    /// Writes `self.buf` on `channel` at `ns`.
    fn put(&mut self, channel: u16, ns: u64) -> Result<(), ScenarioError> {
        let seq = self.sequence.entry(channel).or_insert(0);
        *seq += 1;
        let header = mcap::records::MessageHeader {
            channel_id: channel,
            sequence: *seq,
            log_time: ns,
            publish_time: ns,
        };
        let writer = self.writer.as_mut().expect("the writer lives until finish");
        writer
            .write_to_known_channel(&header, &self.buf)
            .map_err(|e| write_err(&self.path, e))?;
        self.messages += 1;
        Ok(())
    }

    fn put_proto(&mut self, channel: u16, ns: u64, msg: &impl Encode) -> Result<(), ScenarioError> {
        self.buf.clear();
        msg.encode(&mut self.buf)
            .map_err(|e| write_err(&self.path, format!("encoding: {e}")))?;
        self.put(channel, ns)
    }

    fn put_json(
        &mut self,
        channel: u16,
        ns: u64,
        v: &impl serde::Serialize,
    ) -> Result<(), ScenarioError> {
        self.buf.clear();
        serde_json::to_writer(&mut self.buf, v).map_err(|e| write_err(&self.path, e))?;
        self.put(channel, ns)
    }

    fn write_static(&mut self, ns: u64) -> Result<(), ScenarioError> {
        let scene = scene_update(&self.world, topics::MAP_FRAME, ns);
        let ch = self.channel(topics::SCENE, self.schemas.scene, BTreeMap::new)?;
        self.put_proto(ch, ns, &scene)?;
        let tf = fg::FrameTransforms {
            transforms: robot_transforms(&self.robot, ns),
        };
        let ch = self.channel(topics::TF, self.schemas.tf, BTreeMap::new)?;
        self.put_proto(ch, ns, &tf)
    }

    fn write_reading(
        &mut self,
        r: &Reading,
        ns: u64,
        truth: Option<Pose2>,
    ) -> Result<(), ScenarioError> {
        match r {
            Reading::Odometry(o) => {
                let ch = self.channel(topics::ODOM, self.schemas.pose, BTreeMap::new)?;
                self.put_proto(
                    ch,
                    ns,
                    &codec::pose_in_frame(ns, topics::ODOM_FRAME, &o.pose),
                )?;
                let ch = self.channel(topics::ODOM_WHEELS, self.schemas.odometry, BTreeMap::new)?;
                self.put_json(ch, ns, o)?;
                // The odometry and ground-truth frames: odom -> base from the wheels, and
                // map -> odom such that map -> base is the true pose.
                let mut transforms = vec![codec::planar_transform(
                    ns,
                    topics::ODOM_FRAME,
                    &self.base_link,
                    &o.pose,
                )];
                if let Some(gt) = truth {
                    let map_to_odom = gt.compose(&o.pose.inverse());
                    transforms.push(codec::planar_transform(
                        ns,
                        topics::MAP_FRAME,
                        topics::ODOM_FRAME,
                        &map_to_odom,
                    ));
                }
                let ch = self.channel(topics::TF, self.schemas.tf, BTreeMap::new)?;
                self.put_proto(ch, ns, &fg::FrameTransforms { transforms })?;
            }
            Reading::Laser(scan) => {
                let topic = format!("{}{}", topics::SCAN_PREFIX, scan.sensor);
                let ch =
                    self.channel(&topic, self.schemas.laser, || codec::laser_metadata(scan))?;
                let (frame, origin) = self
                    .laser_frames
                    .get(&scan.sensor)
                    .cloned()
                    .unwrap_or_else(|| (self.base_link.clone(), scan.mount));
                let mut msg = std::mem::take(&mut self.laser_msg);
                codec::fill_laser(&mut msg, ns, &frame, &origin, scan);
                let res = self.put_proto(ch, ns, &msg);
                self.laser_msg = msg;
                res?;
            }
            Reading::Depth(d) => {
                let topic = format!("{}{}", topics::DEPTH_PREFIX, d.sensor);
                if !self.channels.contains_key(&topic) {
                    // The camera's frame, once, before its first image.
                    let tf = fg::FrameTransforms {
                        transforms: vec![codec::frame_transform(
                            ns,
                            &self.base_link,
                            &d.sensor,
                            &d.mount,
                        )],
                    };
                    let ch = self.channel(topics::TF, self.schemas.tf, BTreeMap::new)?;
                    self.put_proto(ch, ns, &tf)?;
                }
                let ch = self.channel(&topic, self.schemas.image, || codec::depth_metadata(d))?;
                let mut msg = std::mem::take(&mut self.image_msg);
                let mut data = std::mem::take(&mut self.image_buf);
                codec::fill_depth(&mut msg, &mut data, ns, &d.sensor, d);
                let res = self.put_proto(ch, ns, &msg);
                // Take the pixel buffer back for the next image when no one else holds it.
                let bytes = std::mem::take(&mut msg.data);
                self.image_buf = Vec::from(bytes);
                self.image_msg = msg;
                res?;
            }
            Reading::Intensity(i) => {
                let topic = format!("{}{}", topics::IMAGE_PREFIX, i.sensor);
                if !self.channels.contains_key(&topic) {
                    // The camera's frame, once, before its first image.
                    let tf = fg::FrameTransforms {
                        transforms: vec![codec::frame_transform(
                            ns,
                            &self.base_link,
                            &i.sensor,
                            &i.mount,
                        )],
                    };
                    let ch = self.channel(topics::TF, self.schemas.tf, BTreeMap::new)?;
                    self.put_proto(ch, ns, &tf)?;
                }
                let ch = self.channel(&topic, self.schemas.image, || {
                    atrium_formats::mcap::images::intensity_metadata(i)
                })?;
                let mut msg = std::mem::take(&mut self.image_msg);
                let mut data = std::mem::take(&mut self.image_buf);
                atrium_formats::mcap::images::fill_intensity(&mut msg, &mut data, ns, &i.sensor, i);
                let res = self.put_proto(ch, ns, &msg);
                self.image_buf = Vec::from(std::mem::take(&mut msg.data));
                self.image_msg = msg;
                res?;
            }
            Reading::Disparity(d) => {
                let topic = format!("{}{}", topics::DISPARITY_PREFIX, d.sensor);
                let ch = self.channel(&topic, self.schemas.image, || {
                    atrium_formats::mcap::images::disparity_metadata(d)
                })?;
                let mut msg = std::mem::take(&mut self.image_msg);
                let mut data = std::mem::take(&mut self.image_buf);
                atrium_formats::mcap::images::fill_disparity(&mut msg, &mut data, ns, &d.sensor, d);
                let res = self.put_proto(ch, ns, &msg);
                self.image_buf = Vec::from(std::mem::take(&mut msg.data));
                self.image_msg = msg;
                res?;
            }
            Reading::Wifi(w) => {
                let topic = format!("{}{}", topics::WIFI_PREFIX, w.sensor);
                let ch = self.channel(&topic, self.schemas.wifi, BTreeMap::new)?;
                self.put_json(ch, ns, w)?;
            }
            Reading::Landmarks(l) => {
                let topic = format!("{}{}", topics::LANDMARKS_PREFIX, l.sensor);
                let ch = self.channel(&topic, self.schemas.landmarks, BTreeMap::new)?;
                self.put_json(ch, ns, l)?;
            }
            // `Reading` is non-exhaustive: a sensor added later without an encoder here is
            // left out of the recording rather than failing the run.
            #[allow(unreachable_patterns)]
            _ => {}
        }
        Ok(())
    }

    /// Writes the run's totals and metrics, completes the file and renames it to its final
    /// name. Returns the final size in bytes.
    pub fn finish(mut self, run: &RunResult) -> Result<u64, ScenarioError> {
        let (tmp, path) = (self.tmp.clone(), self.path.clone());
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
        let done = (|| -> Result<u64, ScenarioError> {
            writer
                .write_metadata(&mcap::records::Metadata {
                    name: SUMMARY_NAME.into(),
                    metadata: summary,
                })
                .map_err(|e| write_err(&path, e))?;
            writer.finish().map_err(|e| write_err(&path, e))?;
            let file = writer
                .into_inner()
                .into_inner()
                .map_err(|e| write_err(&path, e.error()))?;
            file.sync_all().map_err(|e| write_err(&path, e))?;
            let len = file.metadata().map_err(|e| write_err(&path, e))?.len();
            std::fs::rename(&tmp, &path).map_err(|e| write_err(&path, e))?;
            Ok(len)
        })();
        if done.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        done
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if let Some(w) = self.writer.take() {
            // Unfinished (an error during the run): no file under any name.
            drop(w);
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

impl RunObserver for Recorder {
    fn instant(
        &mut self,
        tick: &Tick,
        readings: &[Reading],
        estimates: Option<&[Estimate]>,
    ) -> Result<(), ScenarioError> {
        let ns = ns_of(tick.t);
        if !self.started {
            self.started = true;
            self.write_static(ns)?;
        }
        for e in &tick.events {
            let ch = self.channel(topics::EVENTS, self.schemas.event, BTreeMap::new)?;
            self.put_json(ch, ns, &event_json(e))?;
        }
        for r in readings {
            self.write_reading(r, ns, tick.truth)?;
        }
        if let (true, Some(gt)) = (tick.score, tick.truth) {
            let ch = self.channel(topics::GROUND_TRUTH, self.schemas.pose, BTreeMap::new)?;
            self.put_proto(ch, ns, &codec::pose_in_frame(ns, topics::MAP_FRAME, &gt))?;
            let ch = self.channel(topics::SCORE, self.schemas.score, BTreeMap::new)?;
            self.put_json(
                ch,
                ns,
                &serde_json::json!({"t": tick.t, "x": gt.x, "y": gt.y, "theta": gt.theta}),
            )?;
            for (i, est) in estimates.unwrap_or_default().iter().enumerate() {
                let Some(name) = self.localizer_names.get(i).cloned() else {
                    break;
                };
                let topic = format!("{}{}", topics::ESTIMATE_PREFIX, name);
                let ch = self.channel(&topic, self.schemas.pose, BTreeMap::new)?;
                self.put_proto(
                    ch,
                    ns,
                    &codec::pose_in_frame(ns, topics::MAP_FRAME, &est.pose),
                )?;
            }
        }
        Ok(())
    }

    fn people(&mut self, tick: &Tick, people: &PeopleFrame<'_>) -> Result<(), ScenarioError> {
        let ns = ns_of(tick.t);
        if ns < self.next_people_ns {
            return Ok(());
        }
        self.next_people_ns = ns + 1_000_000_000 / PEOPLE_HZ;
        let update = people_update(
            people.positions,
            people.radius,
            people.height,
            topics::MAP_FRAME,
            ns,
        );
        let ch = self.channel(topics::PEOPLE, self.schemas.scene, BTreeMap::new)?;
        self.put_proto(ch, ns, &update)
    }
}

/// What a recording run produced.
#[derive(Debug, Clone)]
pub struct Recorded {
    pub run: RunResult,
    pub path: PathBuf,
    pub bytes: u64,
    pub messages: u64,
}

/// Runs `scenario` live, its localizers built from `registry`, and records it to `path` (see
/// the module docs).
pub fn record(
    registry: &LocalizerRegistry,
    scenario: &Scenario,
    path: &Path,
    options: RunOptions,
) -> Result<Recorded, ScenarioError> {
    let seed = options.seed.unwrap_or(scenario.seed);
    let mut recorder = Recorder::create(path, scenario, seed)?;
    let run = run_observed(registry, scenario, seed, options, &mut recorder)?;
    let messages = recorder.messages();
    let bytes = recorder.finish(&run)?;
    Ok(Recorded {
        run,
        path: path.to_path_buf(),
        bytes,
        messages,
    })
}

/// Runs `scenario` live with `seed`, every instant shown to `observer` (a recorder of either
/// profile).
pub(crate) fn run_observed(
    registry: &LocalizerRegistry,
    scenario: &Scenario,
    seed: u64,
    mut options: RunOptions,
    observer: &mut dyn RunObserver,
) -> Result<RunResult, ScenarioError> {
    let mut stream = SimStream::new(scenario, seed)?;
    registry.run_stream(
        scenario,
        seed,
        &mut stream,
        &scenario.events,
        RunOptions {
            seed: Some(seed),
            // A shorter reborrow, so the recorder need not outlive the caller's closure.
            progress: options
                .progress
                .as_deref_mut()
                .map(|p| p as &mut dyn FnMut(f64, f64)),
            observer: Some(observer),
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("atrium-record-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn a_bad_output_is_refused_before_anything_is_written() {
        let dir = tmp("check");
        let err = |p: &Path| check_output(p).unwrap_err().to_string();
        let missing = dir.join("nope/run.mcap");
        let e = err(&missing);
        assert!(
            e.contains(&format!("cannot write {}", missing.display())) && e.contains("nope"),
            "{e}"
        );
        let e = err(&dir);
        assert!(e.ends_with("it is a folder"), "{e}");
        let locked = dir.join("locked.mcap");
        std::fs::write(&locked, b"keep").unwrap();
        let mut perm = std::fs::metadata(&locked).unwrap().permissions();
        perm.set_readonly(true);
        std::fs::set_permissions(&locked, perm).unwrap();
        let e = err(&locked);
        assert!(e.ends_with("the file is read-only"), "{e}");
        let e = err(&dir.join("a_file.mcap/..").join("x.mcap"));
        assert!(e.contains("cannot write"), "{e}");
        assert!(check_output(&dir.join("fresh.mcap")).is_ok());
        // Nothing was created on the way.
        let names: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("locked.mcap")]);
        let mut perm = std::fs::metadata(&locked).unwrap().permissions();
        #[allow(clippy::permissions_set_readonly_false)] // a test file, removed right after
        perm.set_readonly(false);
        std::fs::set_permissions(&locked, perm).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn partial_names_and_hashes_are_stable() {
        assert_eq!(
            partial_path(Path::new("out/run.mcap")).unwrap(),
            Path::new("out/run.mcap.partial")
        );
        assert!(partial_path(Path::new("/")).is_none());
        // FNV-1a test vectors.
        assert_eq!(content_hash(b""), "fnv1a64:cbf29ce484222325");
        assert_eq!(content_hash(b"a"), "fnv1a64:af63dc4c8601ec8c");
        assert_ne!(content_hash(b"campus"), content_hash(b"campus "));
    }
}
