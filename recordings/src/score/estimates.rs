//! Another stack's trajectory: read from a TUM file, a CSV file (`t,x,y,theta`) or an MCAP
//! pose topic, checked (time order, finite numbers), and looked up at any instant.

use super::cdr;
use crate::topics;
use atrium_formats::mcap::foxglove as codec;
use atrium_formats::tum;
use atrium_robots::{normalize_angle, Pose2};
use atrium_scenarios::error::ScenarioError;
use foxglove::messages as fg;
use foxglove::Decode;
use nalgebra::Matrix3;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Stamps closer than this to an instant are that instant (a stamp that went through
/// nanoseconds or a rounded text file is not bit-exact).
pub const SNAP_S: f64 = 1e-7;

/// The farthest an estimated position may lie from the map's origin, m: beyond it no map
/// reaches, and squared errors overflow.
pub const MAX_COORDINATE_M: f64 = 1e9;

/// Where the estimates came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    Tum,
    Csv,
    Mcap,
}

impl Format {
    pub fn as_str(self) -> &'static str {
        match self {
            Format::Tum => "tum",
            Format::Csv => "csv",
            Format::Mcap => "mcap",
        }
    }
}

/// A trajectory in strictly increasing time order.
#[derive(Debug, Clone)]
pub struct Estimates {
    pub path: PathBuf,
    pub format: Format,
    /// The MCAP topic read, with its schema.
    pub topic: Option<(String, String)>,
    pub stamps: Vec<f64>,
    pub poses: Vec<Pose2>,
    /// Covariances over (x, y, θ), when the source carries them.
    pub covariances: Option<Vec<Matrix3<f64>>>,
}

/// One pose as read, with where it was read (for messages).
struct Row {
    at: String,
    t: f64,
    pose: Pose2,
    cov: Option<Matrix3<f64>>,
}

fn bad(path: &Path, at: impl Into<String>, msg: impl Into<String>) -> ScenarioError {
    ScenarioError::field(path, at, msg)
}

impl Estimates {
    /// Reads `path`: a ROS 2 bag folder's MCAP file, MCAP when it starts with the MCAP magic
    /// bytes, else CSV for a `.csv`
    /// file or a first data line holding commas, else TUM. `topic` picks the MCAP topic
    /// (default: the only pose topic that is not `/ground_truth` or `/odom`).
    pub fn read(path: &Path, topic: Option<&str>) -> Result<Estimates, ScenarioError> {
        if crate::ros2::read::is_bag(path) {
            // A ROS 2 bag folder: its MCAP storage file (checked against metadata.yaml).
            let file = crate::ros2::read::storage_file(path)?;
            return Self::read(&file, topic);
        }
        let bytes = std::fs::read(path).map_err(|err| ScenarioError::Io {
            file: path.to_path_buf(),
            err,
        })?;
        Self::from_bytes(path, bytes, topic)
    }

    /// Reads a file's contents, as [`Estimates::read`] does once the file is read; `path`
    /// names it in errors and decides CSV by its extension. The entry point of the fuzz
    /// harness (`fuzz-targets/`).
    pub fn from_bytes(
        path: &Path,
        bytes: Vec<u8>,
        topic: Option<&str>,
    ) -> Result<Estimates, ScenarioError> {
        if bytes.starts_with(mcap::MAGIC) {
            return read_mcap(path, &bytes, topic);
        }
        if let Some(t) = topic {
            return Err(bad(
                path,
                "--topic",
                format!("{t:?} is given, but the file is not MCAP"),
            ));
        }
        let text = String::from_utf8(bytes).map_err(|_| {
            bad(
                path,
                "file",
                "neither MCAP nor text: expected a TUM file, a CSV t,x,y,theta or an MCAP file",
            )
        })?;
        let (format, rows) = if tum::looks_like_csv(path, &text) {
            (Format::Csv, tum::read_csv(path, &text)?)
        } else {
            (Format::Tum, tum::read_tum(path, &text)?)
        };
        let rows = rows
            .into_iter()
            .map(|r| Row {
                at: format!("line {}", r.line),
                t: r.t,
                pose: r.pose,
                cov: None,
            })
            .collect();
        Self::from_rows(path, format, None, rows)
    }

    fn from_rows(
        path: &Path,
        format: Format,
        topic: Option<(String, String)>,
        rows: Vec<Row>,
    ) -> Result<Estimates, ScenarioError> {
        if rows.is_empty() {
            return Err(bad(path, "file", "holds no poses"));
        }
        for (i, r) in rows.iter().enumerate() {
            let values = [
                ("time", r.t),
                ("x", r.pose.x),
                ("y", r.pose.y),
                ("heading", r.pose.theta),
            ];
            if let Some((what, v)) = values.iter().find(|(_, v)| !v.is_finite()) {
                return Err(bad(path, &r.at, format!("{what} is {v}: not a number")));
            }
            // Positions this far out are no place on any map (a unit or column mix-up), and
            // their errors would overflow the metrics to infinity.
            if let Some((what, v)) = values[1..3]
                .iter()
                .find(|(_, v)| v.abs() > MAX_COORDINATE_M)
            {
                return Err(bad(
                    path,
                    &r.at,
                    format!(
                        "{what} is {v} m: farther than {MAX_COORDINATE_M:e} m from the origin, \
                         no position on a map (wrong units or columns?)"
                    ),
                ));
            }
            if r.cov.is_some_and(|c| c.iter().any(|v| !v.is_finite())) {
                return Err(bad(path, &r.at, "the covariance holds a non-finite number"));
            }
            if let Some(c) = r.cov {
                if let Some((i, name)) = [(0, "x"), (1, "y"), (2, "theta")]
                    .into_iter()
                    .find(|&(i, _)| c[(i, i)] < 0.0)
                {
                    return Err(bad(
                        path,
                        &r.at,
                        format!(
                            "the covariance's variance of {name} is negative ({}): no \
                             covariance has that",
                            c[(i, i)]
                        ),
                    ));
                }
            }
            if i > 0 {
                let prev = &rows[i - 1];
                if r.t == prev.t {
                    return Err(bad(
                        path,
                        &r.at,
                        format!(
                            "stamp {} s repeats the stamp of {}: give one pose per instant",
                            r.t, prev.at
                        ),
                    ));
                }
                if r.t < prev.t {
                    return Err(bad(
                        path,
                        &r.at,
                        format!(
                            "stamp {} s comes before {} s of {}: the estimates must be in time \
                             order (sort them by time)",
                            r.t, prev.t, prev.at
                        ),
                    ));
                }
            }
        }
        let covariances = rows
            .iter()
            .all(|r| r.cov.is_some())
            .then(|| rows.iter().filter_map(|r| r.cov).collect());
        Ok(Estimates {
            path: path.to_path_buf(),
            format,
            topic,
            stamps: rows.iter().map(|r| r.t).collect(),
            poses: rows.iter().map(|r| r.pose).collect(),
            covariances,
        })
    }

    /// The time span [first, last] of the estimates, s.
    pub fn span(&self) -> [f64; 2] {
        [self.stamps[0], self.stamps[self.stamps.len() - 1]]
    }

    /// Whether `t` lies within the span (up to [`SNAP_S`]).
    pub fn covers(&self, t: f64) -> bool {
        let [a, b] = self.span();
        t >= a - SNAP_S && t <= b + SNAP_S
    }

    /// The pose at `t`: the estimate stamped `t` (within [`SNAP_S`]), else interpolated
    /// between the two around it (linearly in x, y and, the short way, in heading), else the
    /// first or last one held. The covariance likewise (zero when the source has none).
    pub fn at(&self, t: f64) -> (Pose2, Matrix3<f64>) {
        let n = self.stamps.len();
        let cov = |i: usize| {
            self.covariances
                .as_ref()
                .map_or_else(Matrix3::zeros, |c| c[i])
        };
        let i = self.stamps.partition_point(|&s| s < t);
        if i < n && self.stamps[i] - t <= SNAP_S {
            return (self.poses[i], cov(i));
        }
        if i > 0 && t - self.stamps[i - 1] <= SNAP_S {
            return (self.poses[i - 1], cov(i - 1));
        }
        if i == 0 {
            return (self.poses[0], cov(0));
        }
        if i == n {
            return (self.poses[n - 1], cov(n - 1));
        }
        let (t0, t1) = (self.stamps[i - 1], self.stamps[i]);
        let (p0, p1) = (self.poses[i - 1], self.poses[i]);
        let a = (t - t0) / (t1 - t0);
        let pose = Pose2::new(
            p0.x + a * (p1.x - p0.x),
            p0.y + a * (p1.y - p0.y),
            normalize_angle(p0.theta + a * normalize_angle(p1.theta - p0.theta)),
        );
        (pose, cov(i - 1) * (1.0 - a) + cov(i) * a)
    }

    /// The name scored by default: the topic's last part for MCAP, else the file stem, with
    /// characters a file name should not hold replaced by `_`.
    pub fn default_name(&self) -> String {
        let raw = match &self.topic {
            Some((t, _)) => t.rsplit('/').find(|s| !s.is_empty()).unwrap_or("estimates"),
            None => self
                .path
                .file_stem()
                .and_then(|s| s.to_str())
                .unwrap_or("estimates"),
        };
        let s: String = raw
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        if s.is_empty() || !s.starts_with(|c: char| c.is_ascii_alphanumeric()) {
            format!("estimates{s}")
        } else {
            s
        }
    }
}

const POSE_IN_FRAME: &str = "foxglove.PoseInFrame";

fn is_pose_schema(schema: &str, encoding: &str) -> bool {
    (schema == POSE_IN_FRAME && encoding == "protobuf")
        || (encoding == "cdr" && cdr::SCHEMAS.contains(&schema))
}

fn supported() -> String {
    format!(
        "{POSE_IN_FRAME} (protobuf), {} (cdr)",
        cdr::SCHEMAS.join(", ")
    )
}

/// An MCAP pose topic: `foxglove.PoseInFrame` (protobuf) or a ROS 2 pose message (cdr),
/// stamped with the message's own timestamp (the log time when it has none).
fn read_mcap(path: &Path, bytes: &[u8], topic: Option<&str>) -> Result<Estimates, ScenarioError> {
    if bytes.len() < 2 * mcap::MAGIC.len() || !bytes.ends_with(mcap::MAGIC) {
        return Err(bad(
            path,
            "file",
            "truncated MCAP file: it does not end with the footer's magic bytes",
        ));
    }
    // Topic -> (schema, encoding, rows) for every topic, rows for pose topics. The checked
    // reader: CRCs, record lengths and chunk sizes are verified before use.
    let mut seen: BTreeMap<String, (String, String, Vec<Row>)> = BTreeMap::new();
    for m in atrium_formats::mcap::container::Messages::new(bytes, path)? {
        let (_, ch, header, data) = m?;
        let schema = ch.schema.as_str();
        let entry = seen
            .entry(ch.topic.clone())
            .or_insert_with(|| (schema.to_string(), ch.message_encoding.clone(), Vec::new()));
        let wanted = match topic {
            Some(t) => t == ch.topic,
            None => ch.topic != topics::GROUND_TRUTH && ch.topic != topics::ODOM,
        };
        if !wanted || !is_pose_schema(schema, &ch.message_encoding) {
            continue;
        }
        let at = format!("topic {}, message {}", ch.topic, entry.2.len() + 1);
        let fail = |e: &dyn std::fmt::Display| bad(path, &at, format!("cannot be decoded: {e}"));
        let (t, pose, cov) = if schema == POSE_IN_FRAME {
            let p = fg::PoseInFrame::decode(&data[..]).map_err(|e| fail(&e))?;
            let ns = p.timestamp.map_or(header.log_time, |t| t.total_nanos());
            // A missing or zero-length orientation is no heading (it would read as 0).
            let q = p.pose.as_ref().and_then(|p| p.orientation.as_ref());
            let norm = q.map_or(0.0, |q| {
                (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt()
            });
            if norm.is_nan() || norm <= 1e-6 {
                return Err(bad(
                    path,
                    &at,
                    match q {
                        Some(q) => format!(
                            "orientation quaternion ({}, {}, {}, {}) is not a rotation (zero length)",
                            q.x, q.y, q.z, q.w
                        ),
                        None => "the pose has no orientation".to_string(),
                    },
                ));
            }
            (ns as f64 / 1e9, codec::pose2_of(p.pose.as_ref()), None)
        } else {
            let r = cdr::decode(schema, &data).map_err(|e| fail(&e))?;
            (r.stamp, r.pose, r.covariance)
        };
        entry.2.push(Row { at, t, pose, cov });
    }
    let poses: Vec<&String> = seen
        .iter()
        .filter(|(_, (s, e, _))| is_pose_schema(s, e))
        .map(|(t, _)| t)
        .collect();
    let list = |v: &[&String]| {
        if v.is_empty() {
            "none".to_string()
        } else {
            v.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
        }
    };
    let chosen = match topic {
        Some(t) => match seen.get(t) {
            None => {
                return Err(bad(
                    path,
                    "--topic",
                    format!(
                        "the file has no messages on topic {t:?} (pose topics: {})",
                        list(&poses)
                    ),
                ))
            }
            Some((s, e, _)) if !is_pose_schema(s, e) => {
                return Err(bad(
                    path,
                    format!("topic {t}"),
                    format!(
                        "has schema {s:?} with {e:?} messages; estimates need one of {}",
                        supported()
                    ),
                ))
            }
            Some(_) => t.to_string(),
        },
        None => {
            let candidates: Vec<&String> = poses
                .iter()
                .copied()
                .filter(|t| *t != topics::GROUND_TRUTH && *t != topics::ODOM)
                .collect();
            match candidates.as_slice() {
                [one] => one.to_string(),
                [] => {
                    return Err(bad(
                        path,
                        "topics",
                        format!(
                            "no pose topic besides {} and {} (estimates need one of {})",
                            topics::GROUND_TRUTH,
                            topics::ODOM,
                            supported()
                        ),
                    ))
                }
                many => {
                    return Err(bad(
                        path,
                        "topics",
                        format!(
                            "several pose topics ({}): choose one with --topic",
                            list(many)
                        ),
                    ))
                }
            }
        }
    };
    let (schema, _, rows) = seen.remove(&chosen).unwrap_or_default();
    Estimates::from_rows(path, Format::Mcap, Some((chosen, schema)), rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str, text: &[u8]) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("atrium-estimates-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn err(name: &str, text: &str) -> String {
        Estimates::read(&tmp(name, text.as_bytes()), None)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn tum_and_csv_with_and_without_header_read_the_same() {
        let (qz, qw) = (0.25f64).sin_cos();
        let tum = format!("# t x y z qx qy qz qw\n0.1 1 2 0 0 0 {qz} {qw}\n0.2 1.5 2 0 0 0 0 1\n");
        let a = Estimates::read(&tmp("a.tum", tum.as_bytes()), None).unwrap();
        let b = Estimates::read(&tmp("b.csv", b"0.1,1,2,0.5\n0.2,1.5,2,0\n"), None).unwrap();
        let c = Estimates::read(
            &tmp(
                "c.txt",
                b"time,yaw,x,y,extra\n0.1,0.5,1,2,9\n0.2,0,1.5,2,9\n",
            ),
            None,
        )
        .unwrap();
        assert_eq!(
            (a.format, b.format, c.format),
            (Format::Tum, Format::Csv, Format::Csv)
        );
        for e in [&a, &b, &c] {
            assert_eq!(e.stamps, vec![0.1, 0.2]);
            assert_eq!((e.poses[0].x, e.poses[0].y), (1.0, 2.0));
            assert!((e.poses[0].theta - 0.5).abs() < 1e-12);
            assert_eq!(e.poses[1].x, 1.5);
        }
        assert_eq!(a.default_name(), "a");
    }

    #[test]
    fn bad_files_name_the_line() {
        let e = err("u.csv", "t,x,y,theta\n0.1,0,0,0\n0.3,0,0,0\n0.2,0,0,0\n");
        assert!(
            e.contains("line 4") && e.contains("time order") && e.contains("line 3"),
            "{e}"
        );
        let e = err("d.csv", "0.1,0,0,0\n0.1,1,0,0\n");
        assert!(e.contains("line 2") && e.contains("repeats"), "{e}");
        let e = err("n.csv", "0.1,0,0,0\n0.2,NaN,0,0\n");
        assert!(e.contains("line 2") && e.contains("not a number"), "{e}");
        let e = err("f.tum", "0.1 0 0 0 0 0 1\n");
        assert!(e.contains("line 1") && e.contains("expected 8"), "{e}");
        let e = err("h.csv", "when,x,y,theta\n0.1,0,0,0\n");
        assert!(e.contains("line 1") && e.contains("\"t\""), "{e}");
        let e = err("empty.tum", "# nothing\n");
        assert!(e.contains("no poses"), "{e}");
        let e = err("w.tum", "0.1 0 zero 0 0 0 0 1\n");
        assert!(e.contains("line 1") && e.contains("\"zero\""), "{e}");
    }

    /// A channel's topic, schema, message encoding and (log time, message) list.
    type Channel<'a> = (&'a str, &'a str, &'a str, Vec<(u64, Vec<u8>)>);

    /// An MCAP file with these channels.
    fn write_mcap(name: &str, channels: &[Channel]) -> PathBuf {
        let mut buf = Vec::new();
        {
            let mut w = mcap::WriteOptions::new()
                .create(std::io::Cursor::new(&mut buf))
                .unwrap();
            for (topic, schema, encoding, msgs) in channels {
                let sid = w.add_schema(schema, "", b"").unwrap();
                let c = w
                    .add_channel(sid, topic, encoding, &BTreeMap::new())
                    .unwrap();
                for (k, (ns, data)) in msgs.iter().enumerate() {
                    let header = mcap::records::MessageHeader {
                        channel_id: c,
                        sequence: k as u32,
                        log_time: *ns,
                        publish_time: *ns,
                    };
                    w.write_to_known_channel(&header, data).unwrap();
                }
            }
            w.finish().unwrap();
        }
        tmp(name, &buf)
    }

    fn pose_in_frame(ns: u64, x: f64) -> (u64, Vec<u8>) {
        use foxglove::Encode;
        let mut b = Vec::new();
        codec::pose_in_frame(ns, "map", &Pose2::new(x, 1.0, 0.5))
            .encode(&mut b)
            .unwrap();
        (ns, b)
    }

    #[test]
    fn mcap_pose_topics_are_found_and_chosen() {
        let fg_msgs = |x0: f64| {
            (1..=3u64)
                .map(|k| pose_in_frame(k * 100_000_000, x0 + k as f64))
                .collect::<Vec<_>>()
        };
        let gt = ("/ground_truth", POSE_IN_FRAME, "protobuf", fg_msgs(0.0));
        let est = ("/estimate/mine", POSE_IN_FRAME, "protobuf", fg_msgs(10.0));
        let other = ("/estimate/other", POSE_IN_FRAME, "protobuf", fg_msgs(20.0));
        let p = write_mcap("one.mcap", &[gt.clone(), est.clone()]);
        let e = Estimates::read(&p, None).unwrap();
        assert_eq!(e.format, Format::Mcap);
        assert_eq!(e.topic.as_ref().unwrap().0, "/estimate/mine");
        assert_eq!(e.default_name(), "mine");
        // Nanosecond stamps come back as the seconds they were written from.
        assert_eq!(e.stamps, vec![0.1, 0.2, 0.3]);
        assert_eq!(e.poses[0].x, 11.0);
        assert!((e.poses[0].theta - 0.5).abs() < 1e-12);

        let p = write_mcap("two.mcap", &[gt.clone(), est, other]);
        let msg = Estimates::read(&p, None).unwrap_err().to_string();
        assert!(
            msg.contains("--topic") && msg.contains("/estimate/other"),
            "{msg}"
        );
        let e = Estimates::read(&p, Some("/estimate/other")).unwrap();
        assert_eq!(e.poses[2].x, 23.0);
        let msg = Estimates::read(&p, Some("/nope")).unwrap_err().to_string();
        assert!(msg.contains("no messages on topic"), "{msg}");
        let p = write_mcap("none.mcap", &[gt]);
        let msg = Estimates::read(&p, None).unwrap_err().to_string();
        assert!(msg.contains("no pose topic"), "{msg}");

        // ROS 2: AMCL's PoseWithCovarianceStamped in CDR, stamped by its header (not the log
        // time), with its covariance.
        let mut cov = [0.0; 36];
        cov[0] = 0.25;
        cov[7] = 0.25;
        cov[35] = 0.01;
        let schema = "geometry_msgs/msg/PoseWithCovarianceStamped";
        let amcl: Vec<(u64, Vec<u8>)> = (1..=3)
            .map(|k| {
                let p = Pose2::new(k as f64, 2.0, -0.25);
                let b = cdr::tests::encode(schema, 0, k * 100_000_000, "map", p, &cov, false);
                (5_000_000_000 + u64::from(k), b)
            })
            .collect();
        let p = write_mcap("ros.mcap", &[("/amcl_pose", schema, "cdr", amcl)]);
        let e = Estimates::read(&p, None).unwrap();
        assert_eq!(e.stamps, vec![0.1, 0.2, 0.3]);
        assert_eq!(e.topic.as_ref().unwrap().1, schema);
        assert_eq!(e.default_name(), "amcl_pose");
        let (pose, c) = e.at(0.15);
        assert_eq!((pose.x, pose.y), (1.5, 2.0));
        assert!((pose.theta + 0.25).abs() < 1e-12);
        assert_eq!((c[(0, 0)], c[(2, 2)]), (0.25, 0.01));

        // Out of order messages name the topic and message.
        let mut back = fg_msgs(0.0);
        back.swap(1, 2);
        let p = write_mcap("back.mcap", &[("/pose", POSE_IN_FRAME, "protobuf", back)]);
        let msg = Estimates::read(&p, None).unwrap_err().to_string();
        assert!(
            msg.contains("topic /pose, message 3") && msg.contains("time order"),
            "{msg}"
        );
    }

    /// Issue 45: an all-zero quaternion was read as heading 0, a negative variance made
    /// NEES silently null, and positions near 1e308 overflowed the metrics.
    #[test]
    fn zero_quaternions_negative_variances_and_huge_positions_are_refused() {
        use foxglove::Encode;
        let mut msg = codec::pose_in_frame(100_000_000, "map", &Pose2::new(1.0, 2.0, 0.0));
        if let Some(q) = msg.pose.as_mut().and_then(|p| p.orientation.as_mut()) {
            (q.x, q.y, q.z, q.w) = (0.0, 0.0, 0.0, 0.0);
        }
        let mut b = Vec::new();
        msg.encode(&mut b).unwrap();
        let p = write_mcap(
            "zero_q.mcap",
            &[("/pose", POSE_IN_FRAME, "protobuf", vec![(1, b)])],
        );
        let e = Estimates::read(&p, None).unwrap_err().to_string();
        assert!(
            e.contains("topic /pose, message 1") && e.contains("not a rotation"),
            "{e}"
        );

        let schema = "geometry_msgs/msg/PoseWithCovarianceStamped";
        let mut cov = [0.0; 36];
        cov[0] = 0.25;
        cov[7] = -0.25;
        cov[35] = 0.01;
        let b = cdr::tests::encode(
            schema,
            0,
            100_000_000,
            "map",
            Pose2::new(1.0, 2.0, 0.0),
            &cov,
            false,
        );
        let p = write_mcap(
            "neg_cov.mcap",
            &[("/amcl_pose", schema, "cdr", vec![(1, b)])],
        );
        let e = Estimates::read(&p, None).unwrap_err().to_string();
        assert!(e.contains("variance of y is negative"), "{e}");

        let e = err("huge.tum", "0.1 1e308 0 0 0 0 0 1\n");
        assert!(e.contains("line 1") && e.contains("farther than"), "{e}");
    }

    #[test]
    fn lookup_snaps_interpolates_and_holds() {
        let e = Estimates {
            path: "x".into(),
            format: Format::Csv,
            topic: None,
            stamps: vec![1.0, 2.0, 4.0],
            poses: vec![
                Pose2::new(0.0, 0.0, 3.0),
                Pose2::new(1.0, 2.0, -3.0),
                Pose2::new(3.0, 2.0, 0.0),
            ],
            covariances: None,
        };
        assert_eq!(e.at(2.0 + 1e-9).0, e.poses[1]);
        assert_eq!(e.at(0.0).0, e.poses[0]);
        assert_eq!(e.at(9.0).0, e.poses[2]);
        assert!(!e.covers(0.5) && e.covers(1.0) && e.covers(4.0) && !e.covers(4.1));
        let mid = e.at(1.5).0;
        assert_eq!((mid.x, mid.y), (0.5, 1.0));
        // Heading the short way across ±π: 3.0 to -3.0 passes π, not 0.
        assert!(
            (mid.theta.abs() - std::f64::consts::PI).abs() < 1e-9,
            "{mid:?}"
        );
        let q = e.at(3.0).0;
        assert_eq!((q.x, q.y), (2.0, 2.0));
        assert!((q.theta + 1.5).abs() < 1e-12);
    }
}
