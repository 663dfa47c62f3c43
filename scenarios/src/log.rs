//! Scenarios on real robot logs: a `[log]` table names a recording of a real robot (a rosbag2
//! folder, a ROS 1 bag or a CARMEN log) instead of a simulated drive. Its laser scans and
//! wheel odometry go to the localizers in time order ([`LogStream`]), and every estimate is
//! scored against a reference trajectory (a TUM or CSV file, or a pose topic of the log) at
//! the reference's own stamps.
//!
//! Time: a log run's clock starts at the log's first scan (`t0`): stream instants, metrics
//! and reports count seconds from there, and files meant for other tools (TUM trajectories)
//! are written back in the log's own stamps (`RunResult::time_offset_s`).
//!
//! Checked when the scenario is loaded, each error naming the scenario file and the `log.*`
//! field, or the log file and its topic: the log opens and holds a laser and an odometry
//! topic (the one named, else the only one of its type), scans and odometry stamps strictly
//! increase, the scans keep one geometry, the laser's mount is known (`/tf_static` from the
//! odometry's child frame to the scans' frame, or `laser_mount`), and the reference overlaps
//! the log.

use crate::error::ScenarioError;
use crate::trajectory::pose_at;
use atrium_formats::relations::Relation;
use atrium_formats::robot_log::RobotLog;
use atrium_formats::ros_msgs::{yaw_of, LaserScanMsg, MessageKind, TransformMsg};
use atrium_robots::{LaserScan, LaserSpec, Pose2};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The `[log]` table as written.
#[derive(Debug, Clone, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct LogTable {
    /// A rosbag2 folder, a ROS 1 `.bag` or a CARMEN log (plain or gzip), relative to the
    /// scenario file.
    pub path: PathBuf,
    /// The `sensor_msgs/LaserScan` topic (default: the log's only one).
    #[serde(default)]
    pub scan_topic: Option<String>,
    /// The `nav_msgs/Odometry` topic (default: the log's only one).
    #[serde(default)]
    pub odom_topic: Option<String>,
    /// The reference trajectory: a TUM file, a CSV `t,x,y,theta` file, or a pose topic of
    /// the log (`PoseStamped`, `PoseWithCovarianceStamped` or `Odometry`).
    #[serde(default)]
    pub reference: Option<String>,
    /// Benchmark relations ([Kümmerle 2009]) scored per localizer.
    #[serde(default)]
    pub relations: Option<PathBuf>,
    /// The laser's pose on the robot, `[x, y, yaw]` (m, m, rad); overrides `/tf_static`.
    #[serde(default)]
    pub laser_mount: Option<[f64; 3]>,
    /// How far the reference is from the truth, m, when known from elsewhere; otherwise the
    /// reference's own relations error stands for it when relations are given.
    #[serde(default)]
    pub reference_accuracy_m: Option<f64>,
}

/// How good the reference is, and what says so.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct ReferenceAccuracy {
    /// Position accuracy, m: errors below it cannot be told from the reference's own.
    pub position_m: f64,
    /// Where the figure comes from.
    pub source: String,
}

/// A loaded log: its readings in time order and what the run needs to score them.
#[derive(Debug, Clone)]
pub struct RealLog {
    pub table: LogTable,
    /// The log's path, resolved against the scenario file.
    pub path: PathBuf,
    pub scan_topic: String,
    pub odom_topic: String,
    /// The log time of the run's t = 0 (the first scan), s.
    pub t0: f64,
    /// Scans, stamped in run time (`t - t0`), in the scenario's laser geometry.
    pub scans: Vec<LaserScan>,
    /// Wheel odometry poses in the odometry frame, run time.
    pub odometry: Vec<(f64, Pose2)>,
    /// The reference (base pose in the map frame), run time, strictly increasing.
    pub reference: Vec<(f64, Pose2)>,
    /// Where the reference came from (file or topic), for reports.
    pub reference_source: String,
    /// The reference's file, when it is one.
    pub reference_file: Option<PathBuf>,
    /// The relations' file.
    pub relations_file: Option<PathBuf>,
    /// Relations, with their stamps in run time.
    pub relations: Option<Vec<Relation>>,
    /// The laser as the scans describe it (beams, field of view, range limits), named after
    /// its topic and mounted on the link [`LOG_LASER_LINK`].
    pub laser: LaserSpec,
    /// The laser's pose in the base frame, and where it was read.
    pub mount: Pose2,
    pub mount_source: String,
    /// The direction of the middle of the scan in the laser's frame, rad (0 for a scan
    /// centred on the laser's +x, as Atrium's simulated lasers are).
    pub scan_centre: f64,
    pub reference_accuracy: Option<ReferenceAccuracy>,
    /// Scans the reference does not cover (no reference pose within half a scan period).
    pub unscored_scans: usize,
}

/// The link a log's laser hangs from in the robot a log scenario drives.
pub const LOG_LASER_LINK: &str = "laser";

/// The longest gap across which the reference is interpolated, s: a reference sampled at
/// every scan (a few Hz) is dense, and a longer gap is a stretch it does not cover.
pub const REFERENCE_MAX_GAP_S: f64 = 1.0;

/// The fastest a reference may move between two poses less than [`REFERENCE_MAX_GAP_S`]
/// apart, m/s. No ground robot drives at 100 m/s: a faster step is a jump (poses of another
/// frame or run spliced in, a unit error), which runs would be scored and calibrated against
/// as if the robot had made it.
pub const REFERENCE_MAX_SPEED_M_S: f64 = 100.0;

/// The largest `reference_accuracy_m`, m: every error of a run would hide below a reference
/// worse than this (and 1e300 filled the tables with 300-digit numbers).
pub const MAX_REFERENCE_ACCURACY_M: f64 = 100.0;

/// The farthest a reference or odometry position may lie from the origin, m (as `atrium
/// score`'s estimates): no map reaches there, and squared errors overflow to infinity.
pub const MAX_COORDINATE_M: f64 = 1e9;

/// A quaternion shorter than this is no rotation: its yaw would silently read as 0.
const MIN_QUATERNION_NORM: f64 = 1e-6;

/// Why a quaternion (x, y, z, w) is no rotation, if it is not one.
fn not_a_rotation(q: [f64; 4]) -> Option<String> {
    let norm = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    (!(norm.is_finite() && norm > MIN_QUATERNION_NORM)).then(|| {
        format!(
            "orientation quaternion ({}, {}, {}, {}) is not a rotation",
            q[0], q[1], q[2], q[3]
        )
    })
}

/// Checks reference poses (run time): finite, on a map, and no faster than
/// [`REFERENCE_MAX_SPEED_M_S`] between neighbours; `at` names pose `i` for the message.
fn check_reference(
    path: &Path,
    what: &str,
    poses: &[(f64, Pose2)],
    at: &dyn Fn(usize) -> String,
) -> Result<(), ScenarioError> {
    let bad = |i: usize, msg: String| ScenarioError::field(path, format!("{what}: {}", at(i)), msg);
    for (i, (_, p)) in poses.iter().enumerate() {
        if !p.is_finite() {
            return Err(bad(
                i,
                format!("the pose ({}, {}, {}) is not finite", p.x, p.y, p.theta),
            ));
        }
        if p.x.abs().max(p.y.abs()) > MAX_COORDINATE_M {
            return Err(bad(
                i,
                format!(
                    "the position ({:?}, {:?}) is farther than {MAX_COORDINATE_M:e} m from the \
                     origin: no position on a map (wrong units or columns?)",
                    p.x, p.y
                ),
            ));
        }
    }
    for (i, w) in poses.windows(2).enumerate() {
        let ((t0, a), (t1, b)) = (w[0], w[1]);
        let dt = t1 - t0;
        let d = (b.x - a.x).hypot(b.y - a.y);
        if dt > 0.0 && dt <= REFERENCE_MAX_GAP_S && d > REFERENCE_MAX_SPEED_M_S * dt {
            return Err(bad(
                i + 1,
                format!(
                    "the reference jumps {d:.3} m in {dt:.3} s from {} ({:.0} m/s, more than \
                     {REFERENCE_MAX_SPEED_M_S} m/s): no robot moves so; remove the jump or \
                     split the log",
                    at(i),
                    d / dt
                ),
            ));
        }
    }
    Ok(())
}

pub(crate) fn field(file: &Path, key: &str, msg: impl Into<String>) -> ScenarioError {
    ScenarioError::field(file, format!("log.{key}"), msg)
}

/// A sensor name from a topic: `/scan` is `scan`, `/robot/front_scan` is `robot_front_scan`.
pub fn sensor_name(topic: &str) -> String {
    let s: String = topic
        .trim_matches('/')
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.is_empty() {
        "scan".into()
    } else {
        s
    }
}

/// The topic of `kind` to read: the one named (checked to exist with that type), else the
/// log's only one.
pub(crate) fn pick_topic(
    file: &Path,
    log: &RobotLog,
    key: &str,
    named: Option<&str>,
    kind: MessageKind,
) -> Result<String, ScenarioError> {
    let of_kind: Vec<String> = log
        .topics()
        .iter()
        .filter(|t| MessageKind::from_type_name(&t.msg_type) == Some(kind))
        .map(|t| t.name.clone())
        .collect();
    let listing = || {
        log.topics()
            .iter()
            .map(|t| format!("{} ({})", t.name, t.msg_type))
            .collect::<Vec<_>>()
            .join(", ")
    };
    match named {
        Some(name) => match log.topics().iter().find(|t| t.name == name) {
            None => Err(field(
                file,
                key,
                format!(
                    "the log {} has no topic {name:?} (topics: {})",
                    log.path().display(),
                    listing()
                ),
            )),
            Some(t) if MessageKind::from_type_name(&t.msg_type) != Some(kind) => Err(field(
                file,
                key,
                format!(
                    "topic {name:?} of {} is {}, not {}",
                    log.path().display(),
                    t.msg_type,
                    kind.type_name()
                ),
            )),
            Some(_) => Ok(name.to_string()),
        },
        None => match of_kind.as_slice() {
            [one] => Ok(one.clone()),
            [] => Err(field(
                file,
                key,
                format!(
                    "the log {} has no {} topic (topics: {})",
                    log.path().display(),
                    kind.type_name(),
                    listing()
                ),
            )),
            many => Err(field(
                file,
                key,
                format!(
                    "the log {} has {} {} topics ({}): name one with {key} = \"...\"",
                    log.path().display(),
                    many.len(),
                    kind.type_name(),
                    many.join(", ")
                ),
            )),
        },
    }
}

/// Checks that `stamps` strictly increase; the error names the topic and the message index.
pub(crate) fn check_order(
    log_path: &Path,
    topic: &str,
    stamps: impl Iterator<Item = f64>,
) -> Result<(), ScenarioError> {
    let mut prev: Option<f64> = None;
    for (i, t) in stamps.enumerate() {
        if !t.is_finite() {
            return Err(ScenarioError::field(
                log_path,
                topic,
                format!("message {i} has the stamp {t}"),
            ));
        }
        if let Some(p) = prev {
            if t <= p {
                let what = if t == p { "repeats" } else { "comes before" };
                return Err(ScenarioError::field(
                    log_path,
                    topic,
                    format!(
                        "message {i} stamped {t:.6} s {what} the stamp {p:.6} s of message {}: \
                         stamps must strictly increase",
                        i - 1
                    ),
                ));
            }
        }
        prev = Some(t);
    }
    Ok(())
}

/// The planar pose of a transform.
fn planar(t: &TransformMsg) -> Pose2 {
    Pose2::new(t.translation[0], t.translation[1], yaw_of(t.rotation))
}

/// The pose of `child` in `parent` from a set of static transforms, following the chain of
/// parents up from `child` (at most 32 links).
fn static_pose(transforms: &[TransformMsg], parent: &str, child: &str) -> Option<Pose2> {
    let mut pose = Pose2::default();
    let mut frame = child.to_string();
    for _ in 0..32 {
        if frame == parent {
            return Some(pose);
        }
        let t = transforms.iter().find(|t| t.child_frame_id == frame)?;
        pose = planar(t).compose(&pose);
        frame = t.header.frame_id.clone();
    }
    None
}

/// A scan of the log in Atrium's reading: ranges that are not returns (NaN, infinite, at or
/// below `range_min`, above `range_max`) read `range_max`, as Atrium's simulated lasers and
/// ROS's amcl treat them.
pub fn scan_reading(msg: &LaserScanMsg, sensor: &str, mount: Pose2, t0: f64) -> LaserScan {
    let (lo, hi) = (msg.range_min, msg.range_max);
    LaserScan {
        stamp: msg.header.stamp - t0,
        sensor: sensor.to_string(),
        mount,
        angle_min: msg.angle_min,
        angle_increment: msg.angle_increment,
        range_min: lo,
        range_max: hi,
        ranges: msg
            .ranges
            .iter()
            .map(|&r| {
                let r = f64::from(r);
                if r.is_finite() && r > lo && r <= hi {
                    r
                } else {
                    hi
                }
            })
            .collect(),
    }
}

impl RealLog {
    /// Loads the log named by `table` for the scenario `file` (paths resolve against its
    /// folder); `duration_s` keeps only the log's first seconds.
    pub fn load(
        file: &Path,
        table: &LogTable,
        duration_s: Option<f64>,
    ) -> Result<RealLog, ScenarioError> {
        let dir = file.parent().unwrap_or(Path::new("."));
        let path = dir.join(&table.path);
        if !path.exists() {
            return Err(field(
                file,
                "path",
                format!("{} does not exist", path.display()),
            ));
        }
        let log = RobotLog::open(&path)?;
        let scan_topic = pick_topic(
            file,
            &log,
            "scan_topic",
            table.scan_topic.as_deref(),
            MessageKind::LaserScan,
        )?;
        let odom_topic = pick_topic(
            file,
            &log,
            "odom_topic",
            table.odom_topic.as_deref(),
            MessageKind::Odometry,
        )?;
        let scans = log.scans(&scan_topic)?;
        let odom = log.odometry(&odom_topic)?;
        if scans.is_empty() {
            return Err(field(
                file,
                "scan_topic",
                format!("{scan_topic} holds no scans"),
            ));
        }
        if odom.len() < 2 {
            return Err(field(
                file,
                "odom_topic",
                format!(
                    "{odom_topic} holds {} odometry messages: at least 2 are needed",
                    odom.len()
                ),
            ));
        }
        check_order(&path, &scan_topic, scans.iter().map(|s| s.header.stamp))?;
        check_order(&path, &odom_topic, odom.iter().map(|o| o.header.stamp))?;

        // One geometry for the whole log: the scenario's laser is the first scan's.
        let first = &scans[0];
        for (i, s) in scans.iter().enumerate() {
            let same = s.ranges.len() == first.ranges.len()
                && s.angle_min == first.angle_min
                && s.angle_increment == first.angle_increment;
            if !same {
                return Err(ScenarioError::field(
                    &path,
                    &scan_topic,
                    format!(
                        "scan {i} has {} beams from {} rad every {} rad, scan 0 had {} from {} \
                         every {}: one laser geometry per log",
                        s.ranges.len(),
                        s.angle_min,
                        s.angle_increment,
                        first.ranges.len(),
                        first.angle_min,
                        first.angle_increment
                    ),
                ));
            }
        }
        let geometry_ok = !first.ranges.is_empty()
            && first.angle_increment.is_finite()
            && first.angle_increment > 0.0
            && first.angle_min.is_finite()
            && first.range_max.is_finite()
            && first.range_min.is_finite()
            && first.range_min >= 0.0
            && first.range_max > first.range_min;
        if !geometry_ok {
            return Err(ScenarioError::field(
                &path,
                &scan_topic,
                format!(
                    "the scans' geometry is not usable: {} beams, angle_min {}, increment {}, \
                     range {}..{} m",
                    first.ranges.len(),
                    first.angle_min,
                    first.angle_increment,
                    first.range_min,
                    first.range_max
                ),
            ));
        }
        // Atrium's lasers are centred on their +x: a scan that is not is described by its
        // mount's yaw turned by the offset.
        let beams = first.ranges.len();
        let fov = first.angle_increment * (beams.max(2) - 1) as f64;
        let centre = first.angle_min + 0.5 * fov;

        let (mut mount, mount_source) = match table.laser_mount {
            Some(m) => {
                if !m.iter().all(|v| v.is_finite()) {
                    return Err(field(
                        file,
                        "laser_mount",
                        format!("must be finite, got {m:?}"),
                    ));
                }
                // A yaw past a turn is degrees (90 for a quarter turn) or garbage, and
                // 1e300 rad is no direction at all once reduced to one turn.
                if m[2].abs() > std::f64::consts::TAU {
                    return Err(field(
                        file,
                        "laser_mount",
                        format!(
                            "yaw {:?} is more than a turn: give it in radians, within ±2π",
                            m[2]
                        ),
                    ));
                }
                (
                    Pose2::new(m[0], m[1], m[2]),
                    "[log] laser_mount".to_string(),
                )
            }
            None => {
                let base = odom[0].child_frame_id.clone();
                let frame = first.header.frame_id.clone();
                if frame.is_empty() || frame == base {
                    (
                        Pose2::default(),
                        format!("the scans are in the base frame {base:?}"),
                    )
                } else {
                    let statics = log.static_transforms()?;
                    let pose = static_pose(&statics, &base, &frame).ok_or_else(|| {
                        field(
                            file,
                            "laser_mount",
                            format!(
                                "the log has no static transform from the odometry's frame \
                                 {base:?} to the scans' frame {frame:?}: give the laser's pose \
                                 on the robot as laser_mount = [x, y, yaw]"
                            ),
                        )
                    })?;
                    (pose, format!("/tf_static {base} -> {frame}"))
                }
            }
        };
        mount.theta = atrium_robots::normalize_angle(mount.theta);

        let t0 = first.header.stamp;
        let end = match duration_s {
            Some(d) => t0 + d,
            None => f64::INFINITY,
        };
        let sensor = sensor_name(&scan_topic);
        let scans: Vec<LaserScan> = scans
            .iter()
            .filter(|s| s.header.stamp <= end)
            .map(|s| scan_reading(s, &sensor, mount, t0))
            .collect();
        if let Some((i, why)) = odom
            .iter()
            .enumerate()
            .find_map(|(i, o)| not_a_rotation(o.orientation).map(|w| (i, w)))
        {
            return Err(ScenarioError::field(
                &path,
                &odom_topic,
                format!("message {i}: {why}"),
            ));
        }
        let odometry: Vec<(f64, Pose2)> = odom
            .iter()
            .filter(|o| o.header.stamp <= end + 1.0)
            .map(|o| {
                (
                    o.header.stamp - t0,
                    Pose2::new(o.position[0], o.position[1], yaw_of(o.orientation)),
                )
            })
            .collect();
        if let Some((t, p)) = odometry.iter().find(|(_, p)| !p.is_finite()) {
            return Err(ScenarioError::field(
                &path,
                &odom_topic,
                format!("the odometry pose at {:.6} s is not finite: {p:?}", t + t0),
            ));
        }
        if let Some((t, p)) = odometry
            .iter()
            .find(|(_, p)| p.x.abs().max(p.y.abs()) > MAX_COORDINATE_M)
        {
            return Err(ScenarioError::field(
                &path,
                &odom_topic,
                format!(
                    "the odometry position ({:?}, {:?}) at {:.6} s is farther than \
                     {MAX_COORDINATE_M:e} m from the origin (wrong units?)",
                    p.x,
                    p.y,
                    t + t0
                ),
            ));
        }
        let laser = LaserSpec {
            name: sensor.clone(),
            mount: LOG_LASER_LINK.to_string(),
            rate_hz: rate_of(scans.iter().map(|s| s.stamp)),
            beams,
            fov,
            range_min: first.range_min,
            range_max: first.range_max,
            ..LaserSpec::sick_lms200(&sensor, LOG_LASER_LINK)
        };

        let (reference, reference_source, reference_file) =
            match &table.reference {
                Some(r) => load_reference(file, dir, &log, r, t0)?,
                None => return Err(field(
                    file,
                    "reference",
                    "a log scenario needs a reference trajectory to score against: a TUM or CSV \
                     file, or a pose topic of the log",
                )),
            };
        let (span0, span1) = (scans[0].stamp, scans[scans.len() - 1].stamp);
        let covered = reference
            .iter()
            .filter(|(t, _)| *t >= span0 - 1e-6 && *t <= span1 + 1e-6)
            .count();
        if covered == 0 {
            return Err(field(
                file,
                "reference",
                format!(
                    "{reference_source} does not overlap the log: the reference spans \
                     {:.3}..{:.3} s, the log's scans {:.3}..{:.3} s (log time)",
                    reference[0].0 + t0,
                    reference[reference.len() - 1].0 + t0,
                    span0 + t0,
                    span1 + t0
                ),
            ));
        }
        // A cut run ends at `duration_s`: so does what it is scored against, calibrated
        // against and what its twin drives.
        let mut reference = reference;
        if let Some(d) = duration_s {
            reference.retain(|(t, _)| *t <= d);
        }
        let half_period = 0.5 / laser.rate_hz.max(1e-3);
        let unscored_scans = scans
            .iter()
            .filter(|s| {
                let i = reference.partition_point(|(t, _)| *t < s.stamp - half_period);
                !reference
                    .get(i)
                    .is_some_and(|(t, _)| (*t - s.stamp).abs() <= half_period)
            })
            .count();

        let relations_file = table.relations.as_ref().map(|p| dir.join(p));
        let relations = match &relations_file {
            None => None,
            Some(rel_path) => {
                let rels = atrium_formats::relations::read(rel_path)?;
                Some(
                    rels.into_iter()
                        .map(|r| Relation {
                            t1: r.t1 - t0,
                            t2: r.t2 - t0,
                            motion: r.motion,
                        })
                        .collect::<Vec<_>>(),
                )
            }
        };
        let reference_accuracy = match (table.reference_accuracy_m, &relations) {
            (Some(a), _) => {
                if !(a.is_finite() && (0.0..=MAX_REFERENCE_ACCURACY_M).contains(&a)) {
                    return Err(field(
                        file,
                        "reference_accuracy_m",
                        format!(
                            "must be a number from 0 to {MAX_REFERENCE_ACCURACY_M} m, got {a:?} \
                             (a reference that far off scores nothing)"
                        ),
                    ));
                }
                Some(ReferenceAccuracy {
                    position_m: a,
                    source: "[log] reference_accuracy_m".into(),
                })
            }
            (None, Some(rels)) => crate::relations::score(&reference, rels, REFERENCE_MAX_GAP_S)
                .map(|s| ReferenceAccuracy {
                    position_m: s.trans_mean_m,
                    source: format!(
                        "the reference's own relations error ({} relations: {:.3} m, {:.2} deg mean)",
                        s.count, s.trans_mean_m, s.rot_mean_deg
                    ),
                }),
            (None, None) => None,
        };

        Ok(RealLog {
            table: table.clone(),
            path,
            scan_topic,
            odom_topic,
            t0,
            scans,
            odometry,
            reference,
            reference_source,
            reference_file,
            relations_file,
            relations,
            laser,
            mount,
            mount_source,
            scan_centre: centre,
            reference_accuracy,
            unscored_scans,
        })
    }

    /// Every file the run reads: the log (a bag folder's files), the reference file and the
    /// relations, for the keys of caches and sweeps.
    pub fn input_files(&self) -> Vec<PathBuf> {
        let mut files = Vec::new();
        if self.path.is_dir() {
            if let Ok(dir) = std::fs::read_dir(&self.path) {
                let mut inside: Vec<PathBuf> =
                    dir.filter_map(|e| e.ok().map(|e| e.path())).collect();
                inside.sort();
                files.extend(inside.into_iter().filter(|p| p.is_file()));
            }
        } else {
            files.push(self.path.clone());
        }
        files.extend(self.reference_file.iter().cloned());
        files.extend(self.relations_file.iter().cloned());
        files
    }

    /// The pose the run starts from: the reference's at the first scan, or, when the
    /// reference starts later, its first pose taken back to the first scan by the odometry's
    /// motion in between.
    pub fn start_pose(&self) -> Pose2 {
        if let Some(p) = self.reference_at(0.0) {
            return p;
        }
        let (t, first) = self
            .reference
            .iter()
            .find(|(t, _)| *t >= 0.0)
            .copied()
            .unwrap_or(self.reference[0]);
        let back = self.odometry_at(t).between(&self.odometry_at(0.0));
        first.compose(&back)
    }

    /// The pose of the laser link of a robot whose simulated laser, centred on the link's
    /// +x, casts the log's beams: the mount turned to the middle of the scan.
    pub fn laser_mount_3(&self) -> Pose2 {
        Pose2::new(
            self.mount.x,
            self.mount.y,
            atrium_robots::normalize_angle(self.mount.theta + self.scan_centre),
        )
    }

    /// The odometry's median message rate, Hz.
    pub fn odometry_rate_hz(&self) -> f64 {
        rate_of(self.odometry.iter().map(|(t, _)| *t))
    }

    /// The run's length: from the first scan to the last, s.
    pub fn duration_s(&self) -> f64 {
        self.scans.last().map_or(0.0, |s| s.stamp)
    }

    /// The reference pose at run time `t`, when the reference covers it.
    pub fn reference_at(&self, t: f64) -> Option<Pose2> {
        pose_at(&self.reference, t, REFERENCE_MAX_GAP_S)
    }

    /// The odometry pose at run time `t`: interpolated between the messages around it, or the
    /// nearest end's pose held before the first and after the last.
    pub fn odometry_at(&self, t: f64) -> Pose2 {
        let o = &self.odometry;
        if t <= o[0].0 {
            return o[0].1;
        }
        if t >= o[o.len() - 1].0 {
            return o[o.len() - 1].1;
        }
        pose_at(o, t, f64::INFINITY).unwrap_or(o[o.len() - 1].1)
    }

    /// Path length of the reference within the run, m.
    pub fn reference_distance_m(&self) -> f64 {
        self.reference
            .windows(2)
            .map(|w| w[0].1.distance(&w[1].1))
            .sum()
    }
}

/// The rate of a stream from its stamps: the inverse of the median interval (a few long
/// pauses in a log do not change it).
fn rate_of(stamps: impl Iterator<Item = f64>) -> f64 {
    let t: Vec<f64> = stamps.collect();
    let mut dt: Vec<f64> = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    if dt.is_empty() {
        return 10.0;
    }
    dt.sort_by(f64::total_cmp);
    1.0 / dt[dt.len() / 2]
}

/// The reference as run-time poses: a pose topic of the log when `spec` names one, else a
/// TUM or CSV file relative to the scenario's folder.
type Reference = (Vec<(f64, Pose2)>, String, Option<PathBuf>);

fn load_reference(
    file: &Path,
    dir: &Path,
    log: &RobotLog,
    spec: &str,
    t0: f64,
) -> Result<Reference, ScenarioError> {
    let topic = log.topics().iter().find(|t| t.name == spec);
    let (poses, source, ref_file): Reference = match topic {
        Some(t) => {
            let kind = MessageKind::from_type_name(&t.msg_type);
            if !matches!(
                kind,
                Some(
                    MessageKind::PoseStamped
                        | MessageKind::PoseWithCovarianceStamped
                        | MessageKind::Odometry
                )
            ) {
                return Err(field(
                    file,
                    "reference",
                    format!(
                        "topic {spec:?} is {}, not a pose (PoseStamped, PoseWithCovarianceStamped \
                         or Odometry)",
                        t.msg_type
                    ),
                ));
            }
            let poses = log.poses(spec)?;
            check_order(log.path(), spec, poses.iter().map(|p| p.header.stamp))?;
            if let Some((i, why)) = poses
                .iter()
                .enumerate()
                .find_map(|(i, p)| not_a_rotation(p.orientation).map(|w| (i, w)))
            {
                return Err(ScenarioError::field(
                    log.path(),
                    spec,
                    format!("message {i}: {why}"),
                ));
            }
            let poses: Vec<(f64, Pose2)> = poses
                .iter()
                .map(|p| {
                    (
                        p.header.stamp - t0,
                        Pose2::new(p.position[0], p.position[1], yaw_of(p.orientation)),
                    )
                })
                .collect();
            check_reference(log.path(), spec, &poses, &|i| format!("message {i}"))?;
            (poses, format!("topic {spec} of the log"), None)
        }
        None => {
            let path = dir.join(spec);
            if !path.is_file() {
                return Err(field(
                    file,
                    "reference",
                    format!(
                        "{spec:?} is neither a pose topic of the log nor a file ({} does not \
                         exist)",
                        path.display()
                    ),
                ));
            }
            let rows = atrium_formats::tum::read_file(&path)?;
            check_order(&path, "reference", rows.iter().map(|r| r.t))?;
            let poses: Vec<(f64, Pose2)> = rows.iter().map(|r| (r.t - t0, r.pose)).collect();
            check_reference(&path, "reference", &poses, &|i| {
                format!("line {}", rows[i].line)
            })?;
            (poses, path.display().to_string(), Some(path.clone()))
        }
    };
    if poses.is_empty() {
        return Err(field(file, "reference", format!("{source} holds no poses")));
    }
    Ok((poses, source, ref_file))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_that_jump_or_leave_every_map_are_refused() {
        let p = Path::new("ref.tum");
        let at = |i: usize| format!("line {}", i + 1);
        let walk: Vec<(f64, Pose2)> = (0..5)
            .map(|k| (0.2 * k as f64, Pose2::new(0.1 * k as f64, 0.0, 0.0)))
            .collect();
        assert!(check_reference(p, "reference", &walk, &at).is_ok());
        // 500 m in 0.2 s: a spliced-in pose, not a drive.
        let mut jump = walk.clone();
        jump[3].1.x += 500.0;
        let e = check_reference(p, "reference", &jump, &at)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("ref.tum") && e.contains("line 4") && e.contains("jumps"),
            "{e}"
        );
        // The same distance across a gap longer than REFERENCE_MAX_GAP_S is not a step.
        let mut gap = jump.clone();
        for (t, _) in &mut gap[3..] {
            *t += 100.0;
        }
        gap[4].1.x += 500.0;
        assert!(check_reference(p, "reference", &gap, &at).is_ok());
        let mut far = walk.clone();
        far[2].1.y = 1e300;
        let e = check_reference(p, "reference", &far, &at)
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 3") && e.contains("farther than"), "{e}");
        let mut nan = walk;
        nan[1].1.theta = f64::NAN;
        let e = check_reference(p, "/pose", &nan, &|i| format!("message {i}"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("/pose: message 1") && e.contains("not finite"),
            "{e}"
        );
    }

    #[test]
    fn zero_and_nan_quaternions_are_no_rotation() {
        assert!(not_a_rotation([0.0, 0.0, 0.0, 1.0]).is_none());
        assert!(not_a_rotation([0.0, 0.0, 0.7, 0.7]).is_none());
        assert!(not_a_rotation([0.0; 4]).is_some());
        assert!(not_a_rotation([f64::NAN, 0.0, 0.0, 1.0]).is_some());
        assert!(not_a_rotation([0.0, 0.0, f64::INFINITY, 1.0]).is_some());
    }

    #[test]
    fn sensor_names_from_topics() {
        assert_eq!(sensor_name("/scan"), "scan");
        assert_eq!(sensor_name("/robot/front scan"), "robot_front_scan");
        assert_eq!(sensor_name("/"), "scan");
    }

    #[test]
    fn static_chains_compose() {
        let tf = |parent: &str, child: &str, x: f64, yaw: f64| TransformMsg {
            header: atrium_formats::ros_msgs::Header {
                stamp: 0.0,
                frame_id: parent.into(),
            },
            child_frame_id: child.into(),
            translation: [x, 0.0, 0.0],
            rotation: atrium_formats::ros_msgs::quaternion_of_yaw(yaw),
        };
        let statics = [
            tf("base_link", "plate", 0.1, std::f64::consts::FRAC_PI_2),
            tf("plate", "laser", 0.2, 0.0),
        ];
        let p = static_pose(&statics, "base_link", "laser").unwrap();
        assert!((p.x - 0.1).abs() < 1e-12 && (p.y - 0.2).abs() < 1e-12);
        assert!((p.theta - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!(static_pose(&statics, "base_link", "camera").is_none());
    }

    #[test]
    fn no_returns_read_range_max() {
        let msg = LaserScanMsg {
            range_min: 0.1,
            range_max: 80.0,
            angle_increment: 0.01,
            ranges: vec![0.05, 1.5, 81.9, f32::INFINITY, f32::NAN, 80.0],
            ..Default::default()
        };
        let s = scan_reading(&msg, "scan", Pose2::default(), 0.0);
        assert_eq!(s.ranges, vec![80.0, 1.5, 80.0, 80.0, 80.0, 80.0]);
    }

    #[test]
    fn rates_are_median_intervals() {
        let r = rate_of([0.0, 0.2, 0.4, 0.6, 5.0].into_iter());
        assert!((r - 5.0).abs() < 1e-9);
    }
}
