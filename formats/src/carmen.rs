//! CARMEN logs (`.clf`, `.log`, plain or gzipped): text, one message per line, the first
//! word naming its kind; `#` starts a comment line. Read here:
//!
//! - `FLASER` / `RLASER` (front / rear laser, the old form): `num_readings r1 .. rn x y theta
//!   odom_x odom_y odom_theta timestamp [hostname logger_timestamp]`, readings spread evenly
//!   over 180 degrees from -90 (x y theta is the laser's pose, odom_* the robot's);
//! - `ROBOTLASER1`: `laser_type start_angle field_of_view angular_resolution maximum_range
//!   accuracy remission_mode num_readings r1 .. rn num_remissions [remissions] laser_pose_x
//!   laser_pose_y laser_pose_theta robot_pose_x robot_pose_y robot_pose_theta laser_tv laser_rv
//!   forward_safety_dist side_safty_dist turn_axis timestamp [hostname logger_timestamp]`;
//! - `ODOM`: `x y theta tv rv accel timestamp [hostname logger_timestamp]`;
//! - `PARAM name value ...`.
//!
//! Other CARMEN messages (an upper-case word: `SYNC`, `RAWLASER1`, `TRUEPOS`, ...) are skipped;
//! a line that does not start with such a word means the file is not a CARMEN log. Every
//! number is checked to parse and be finite (ranges also not negative); an error names the
//! line number and the field. Readings at the no-return marker ([`NO_RETURN_M`] or more, and
//! ROBOTLASER1's `maximum_range` or more) become `f32::INFINITY`. Messages are given in file
//! order: stamps that go backwards are the caller's to report.

use crate::FormatError;
use std::collections::BTreeMap;
use std::f64::consts::{FRAC_PI_2, PI};
use std::io::Read;
use std::path::{Path, PathBuf};

/// CARMEN's "no return" reading of SICK lasers is 81.91 m; anything at 81.9 m or beyond is it.
pub const NO_RETURN_M: f64 = 81.9;

/// The largest decompressed log read (4 GiB): more is a damaged or hostile gzip stream.
pub const MAX_LOG_BYTES: u64 = 4 << 30;

/// The message a scan came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScanKind {
    Flaser,
    Rlaser,
    RobotLaser1,
}

/// One laser scan.
#[derive(Debug, Clone, PartialEq)]
pub struct CarmenScan {
    pub kind: ScanKind,
    /// 1-based line number in the (decompressed) log.
    pub line: usize,
    /// The line's `timestamp` field, seconds.
    pub stamp: f64,
    pub angle_min: f64,
    pub angle_increment: f64,
    /// ROBOTLASER1's `maximum_range`; `None` for FLASER / RLASER.
    pub maximum_range: Option<f64>,
    /// Metres; no return is `f32::INFINITY`.
    pub ranges: Vec<f32>,
    /// The laser's pose and the robot's odometry pose (x, y, theta) at the scan.
    pub laser_pose: [f64; 3],
    pub robot_pose: [f64; 3],
}

/// One odometry pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdomPose {
    pub line: usize,
    pub stamp: f64,
    /// x, y, theta.
    pub pose: [f64; 3],
    /// Translational and rotational velocity (ODOM lines only).
    pub velocity: Option<[f64; 2]>,
}

/// Where the odometry poses came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OdometrySource {
    /// ODOM lines.
    Odom,
    /// The odometry pose of each FLASER line (logs without ODOM lines).
    Flaser,
    /// The robot pose of each ROBOTLASER1 line (logs without ODOM or FLASER lines).
    RobotLaser1,
    /// The log holds no odometry.
    None,
}

/// Where the front laser's mount came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MountSource {
    /// The first ROBOTLASER1 line's laser pose relative to its robot pose.
    RobotLaser1,
    /// The first FLASER line's laser pose relative to its odometry pose.
    FlaserPoses,
    /// The `robot_frontlaser_offset` (and `_side_offset`, `_angular_offset`) PARAMs.
    Param,
    /// None of these (or FLASER's two poses equal and no PARAM): taken as zero.
    Zero,
}

/// The front laser's pose in the robot frame (x, y, theta).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserMount {
    pub pose: [f64; 3],
    pub source: MountSource,
}

/// Where `range_max` came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RangeMaxSource {
    Param,
    RobotLaser1,
    Default,
}

/// A CARMEN log, read.
#[derive(Debug, Clone, PartialEq)]
pub struct CarmenLog {
    pub path: PathBuf,
    /// Front scans: the ROBOTLASER1 lines when the log has any, else the FLASER lines (many
    /// logs carry the same scans in both forms; they are not mixed).
    pub front_scans: Vec<CarmenScan>,
    /// RLASER lines.
    pub rear_scans: Vec<CarmenScan>,
    pub odometry: Vec<OdomPose>,
    pub odometry_source: OdometrySource,
    pub front_mount: LaserMount,
    /// The front laser's largest valid range, metres, and where it came from:
    /// `robot_front_laser_max`, else ROBOTLASER1's `maximum_range`, else [`NO_RETURN_M`].
    pub range_max: f64,
    pub range_max_source: RangeMaxSource,
    /// PARAM name -> value (the last given).
    pub params: BTreeMap<String, String>,
}

/// Reads the CARMEN log at `path`, gzipped or not (told by its first bytes).
pub fn read(path: &Path) -> Result<CarmenLog, FormatError> {
    let bytes = std::fs::read(path).map_err(|e| FormatError::io(path, e))?;
    let text = if is_gzip(&bytes) {
        gunzip(&bytes).map_err(|e| FormatError::field(path, "gzip", e))?
    } else {
        bytes
    };
    parse(&text, path)
}

/// Whether `bytes` start with the gzip magic.
pub fn is_gzip(bytes: &[u8]) -> bool {
    bytes.starts_with(&[0x1f, 0x8b])
}

fn gunzip(bytes: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(bytes)
        .take(MAX_LOG_BYTES + 1)
        .read_to_end(&mut out)
        .map_err(|e| format!("cannot be decompressed: {e} (the file is damaged or truncated)"))?;
    if out.len() as u64 > MAX_LOG_BYTES {
        return Err(format!("decompresses to more than {MAX_LOG_BYTES} bytes"));
    }
    Ok(out)
}

/// The most words a line may have: far above any laser's beam count (ROBOTLASER1 holds two
/// values per beam), far below what a damaged or hostile line can hold.
pub const MAX_WORDS: usize = 1 << 18;

/// A word quoted for a message, cut to its first 40 characters.
fn quote(w: &str) -> String {
    match w.char_indices().nth(40) {
        None => format!("{w:?}"),
        Some((cut, _)) => format!("{:?}... ({} bytes)", &w[..cut], w.len()),
    }
}

/// The words of one line, with its number, for field errors.
struct Fields<'a> {
    path: &'a Path,
    line: usize,
    kind: &'a str,
    words: Vec<&'a str>,
    pos: usize,
    /// The file ends inside this line (no newline after it): it may be cut short.
    unterminated: bool,
}

impl<'a> Fields<'a> {
    fn err(&self, field: impl std::fmt::Display, msg: impl Into<String>) -> FormatError {
        FormatError::field(
            self.path,
            format!("line {}: {} field {field}", self.line, self.kind),
            msg,
        )
    }

    fn word(&mut self, field: &dyn std::fmt::Display) -> Result<&'a str, FormatError> {
        let w = self.words.get(self.pos).copied().ok_or_else(|| {
            self.err(
                field,
                format!("missing: the line ends after {} words", self.words.len()),
            )
        })?;
        self.pos += 1;
        Ok(w)
    }

    /// A finite number.
    fn num(&mut self, field: &dyn std::fmt::Display) -> Result<f64, FormatError> {
        let w = self.word(field)?;
        match w.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.err(field, format!("{} is not finite", quote(w)))),
            Err(_) => Err(self.err(field, format!("{} is not a number", quote(w)))),
        }
    }

    fn count(&mut self, field: &str) -> Result<usize, FormatError> {
        let w = self.word(&field)?;
        let n: usize = w
            .parse()
            .map_err(|_| self.err(field, format!("{} is not a count", quote(w))))?;
        // Each value is one word: a count beyond the words left is damage, refused before
        // anything is allocated.
        let left = self.words.len() - self.pos;
        if n > left {
            return Err(self.err(
                field,
                format!("{n} values do not fit in the {left} words left on the line"),
            ));
        }
        Ok(n)
    }

    fn pose(&mut self, names: [&str; 3]) -> Result<[f64; 3], FormatError> {
        Ok([
            self.num(&names[0])?,
            self.num(&names[1])?,
            self.num(&names[2])?,
        ])
    }

    /// `n` ranges; readings at `no_return` or beyond become infinity.
    fn ranges(&mut self, n: usize, no_return: f64) -> Result<Vec<f32>, FormatError> {
        let mut v = Vec::with_capacity(n);
        for k in 0..n {
            let r = self.num(&format_args!("range[{k}]"))?;
            if r < 0.0 {
                return Err(self.err(format_args!("range[{k}]"), format!("{r} is negative")));
            }
            v.push(if r >= no_return {
                f32::INFINITY
            } else {
                r as f32
            });
        }
        Ok(v)
    }

    /// The timestamp, then at most `hostname logger_timestamp`.
    fn stamp_and_end(&mut self) -> Result<f64, FormatError> {
        let t = self.num(&"timestamp")?;
        let extra = self.words.len() - self.pos;
        // A cut inside the timestamp would still parse: a last line without its newline
        // must show it is whole by the two words that end every line CARMEN writes.
        if self.unterminated && extra < 2 {
            return Err(self.err(
                "timestamp",
                "the file ends inside this line (no newline, no hostname and logger_timestamp after the timestamp): the log is truncated",
            ));
        }
        if extra > 2 {
            return Err(self.err(
                "timestamp",
                format!("{extra} words follow it, at most 2 (hostname logger_timestamp) were expected: the line's counts do not match its values"),
            ));
        }
        Ok(t)
    }
}

fn old_laser(f: &mut Fields<'_>, kind: ScanKind) -> Result<CarmenScan, FormatError> {
    let n = f.count("num_readings")?;
    let ranges = f.ranges(n, NO_RETURN_M)?;
    let laser_pose = f.pose(["x", "y", "theta"])?;
    let robot_pose = f.pose(["odom_x", "odom_y", "odom_theta"])?;
    let stamp = f.stamp_and_end()?;
    // n readings over 180 degrees, the first at -90 and the last at +90.
    let angle_increment = if n > 1 { PI / (n - 1) as f64 } else { 0.0 };
    Ok(CarmenScan {
        kind,
        line: f.line,
        stamp,
        angle_min: -FRAC_PI_2,
        angle_increment,
        maximum_range: None,
        ranges,
        laser_pose,
        robot_pose,
    })
}

fn robot_laser(f: &mut Fields<'_>) -> Result<CarmenScan, FormatError> {
    let _laser_type = f.word(&"laser_type")?;
    let angle_min = f.num(&"start_angle")?;
    let _fov = f.num(&"field_of_view")?;
    let angle_increment = f.num(&"angular_resolution")?;
    let maximum_range = f.num(&"maximum_range")?;
    if maximum_range <= 0.0 {
        return Err(f.err("maximum_range", format!("{maximum_range} is not positive")));
    }
    let _accuracy = f.num(&"accuracy")?;
    let _remission_mode = f.word(&"remission_mode")?;
    let n = f.count("num_readings")?;
    let ranges = f.ranges(n, maximum_range.min(NO_RETURN_M))?;
    let m = f.count("num_remissions")?;
    for k in 0..m {
        f.num(&format_args!("remission[{k}]"))?;
    }
    let laser_pose = f.pose(["laser_pose_x", "laser_pose_y", "laser_pose_theta"])?;
    let robot_pose = f.pose(["robot_pose_x", "robot_pose_y", "robot_pose_theta"])?;
    for name in [
        "laser_tv",
        "laser_rv",
        "forward_safety_dist",
        "side_safty_dist",
        "turn_axis",
    ] {
        f.num(&name)?;
    }
    Ok(CarmenScan {
        kind: ScanKind::RobotLaser1,
        line: f.line,
        stamp: f.stamp_and_end()?,
        angle_min,
        angle_increment,
        maximum_range: Some(maximum_range),
        ranges,
        laser_pose,
        robot_pose,
    })
}

fn odom(f: &mut Fields<'_>) -> Result<OdomPose, FormatError> {
    let pose = f.pose(["x", "y", "theta"])?;
    let tv = f.num(&"tv")?;
    let rv = f.num(&"rv")?;
    let _accel = f.num(&"accel")?;
    Ok(OdomPose {
        line: f.line,
        stamp: f.stamp_and_end()?,
        pose,
        velocity: Some([tv, rv]),
    })
}

/// A CARMEN message name: upper-case letters, digits and underscores.
fn is_keyword(w: &str) -> bool {
    w.bytes().next().is_some_and(|b| b.is_ascii_uppercase())
        && w.bytes()
            .all(|b| b.is_ascii_uppercase() || b.is_ascii_digit() || b == b'_')
}

/// Parses a log's (decompressed) bytes; `path` names it in errors.
pub fn parse(text: &[u8], path: &Path) -> Result<CarmenLog, FormatError> {
    let mut flaser = Vec::new();
    let mut robot_laser1 = Vec::new();
    let mut rear = Vec::new();
    let mut odometry = Vec::new();
    let mut params = BTreeMap::new();
    let lines = text.split(|&b| b == b'\n').count();
    for (k, raw) in text.split(|&b| b == b'\n').enumerate() {
        let line = k + 1;
        // Hostnames may be in any encoding; numbers are ASCII either way.
        let s = String::from_utf8_lossy(raw);
        // At most one word past the limit is collected: a line of a hundred million words is
        // refused by its count, not gathered into gigabytes of word slices first.
        let words: Vec<&str> = s.split_ascii_whitespace().take(MAX_WORDS + 1).collect();
        if words.len() > MAX_WORDS {
            return Err(FormatError::field(
                path,
                format!("line {line}"),
                format!(
                    "more than {MAX_WORDS} words: no CARMEN message is that long (a laser of \
                     {MAX_WORDS} beams would be); the file is damaged"
                ),
            ));
        }
        let Some(&first) = words.first() else {
            continue;
        };
        if first.starts_with('#') {
            continue;
        }
        if !is_keyword(first) {
            return Err(FormatError::field(
                path,
                format!("line {line}"),
                format!(
                    "starts with {:?}, not a CARMEN message name: not a CARMEN log",
                    first.chars().take(20).collect::<String>()
                ),
            ));
        }
        let mut f = Fields {
            path,
            line,
            kind: first,
            words,
            pos: 1,
            unterminated: line == lines,
        };
        match first {
            "FLASER" => flaser.push(old_laser(&mut f, ScanKind::Flaser)?),
            "RLASER" => rear.push(old_laser(&mut f, ScanKind::Rlaser)?),
            "ROBOTLASER1" => robot_laser1.push(robot_laser(&mut f)?),
            "ODOM" => odometry.push(odom(&mut f)?),
            "PARAM" => {
                let name = f.word(&"name")?.to_string();
                let value = f.word(&"value")?.to_string();
                params.insert(name, value);
            }
            _ => {}
        }
    }
    if flaser.is_empty() && robot_laser1.is_empty() && rear.is_empty() && odometry.is_empty() {
        return Err(FormatError::field(
            path,
            "file",
            "holds no FLASER, RLASER, ROBOTLASER1 or ODOM line: not a CARMEN log, or an empty one",
        ));
    }
    let front_mount = front_mount(&robot_laser1, &flaser, &params, path)?;
    let (range_max, range_max_source) = range_max(&params, &robot_laser1, path)?;
    let (odometry, odometry_source) = if !odometry.is_empty() {
        (odometry, OdometrySource::Odom)
    } else if !flaser.is_empty() {
        (odometry_of(&flaser), OdometrySource::Flaser)
    } else if !robot_laser1.is_empty() {
        (odometry_of(&robot_laser1), OdometrySource::RobotLaser1)
    } else {
        (Vec::new(), OdometrySource::None)
    };
    Ok(CarmenLog {
        path: path.to_path_buf(),
        front_scans: if robot_laser1.is_empty() {
            flaser
        } else {
            robot_laser1
        },
        rear_scans: rear,
        odometry,
        odometry_source,
        front_mount,
        range_max,
        range_max_source,
        params,
    })
}

fn odometry_of(scans: &[CarmenScan]) -> Vec<OdomPose> {
    scans
        .iter()
        .map(|s| OdomPose {
            line: s.line,
            stamp: s.stamp,
            pose: s.robot_pose,
            velocity: None,
        })
        .collect()
}

/// `b` in the frame of `a`: (x, y, theta) of the laser relative to the robot.
pub fn relative_pose(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let (s, c) = a[2].sin_cos();
    let dt = b[2] - a[2];
    [c * dx + s * dy, -s * dx + c * dy, dt.sin().atan2(dt.cos())]
}

fn param_num(
    params: &BTreeMap<String, String>,
    name: &str,
    path: &Path,
) -> Result<Option<f64>, FormatError> {
    let Some(v) = params.get(name) else {
        return Ok(None);
    };
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(Some(x)),
        _ => Err(FormatError::field(
            path,
            format!("PARAM {name}"),
            format!("{v:?} is not a finite number"),
        )),
    }
}

fn front_mount(
    robot_laser1: &[CarmenScan],
    flaser: &[CarmenScan],
    params: &BTreeMap<String, String>,
    path: &Path,
) -> Result<LaserMount, FormatError> {
    if let Some(s) = robot_laser1.first() {
        return Ok(LaserMount {
            pose: relative_pose(s.robot_pose, s.laser_pose),
            source: MountSource::RobotLaser1,
        });
    }
    // Some loggers write the odometry pose twice (the MIT log does): equal poses say
    // nothing about the mount, so the PARAMs are asked next.
    if let Some(s) = flaser.first().filter(|s| s.laser_pose != s.robot_pose) {
        return Ok(LaserMount {
            pose: relative_pose(s.robot_pose, s.laser_pose),
            source: MountSource::FlaserPoses,
        });
    }
    if let Some(x) = param_num(params, "robot_frontlaser_offset", path)? {
        let y = param_num(params, "robot_frontlaser_side_offset", path)?.unwrap_or(0.0);
        let t = param_num(params, "robot_frontlaser_angular_offset", path)?.unwrap_or(0.0);
        return Ok(LaserMount {
            pose: [x, y, t],
            source: MountSource::Param,
        });
    }
    Ok(LaserMount {
        pose: [0.0; 3],
        source: MountSource::Zero,
    })
}

fn range_max(
    params: &BTreeMap<String, String>,
    robot_laser1: &[CarmenScan],
    path: &Path,
) -> Result<(f64, RangeMaxSource), FormatError> {
    if let Some(r) = param_num(params, "robot_front_laser_max", path)? {
        if r <= 0.0 {
            return Err(FormatError::field(
                path,
                "PARAM robot_front_laser_max",
                format!("{r} is not positive"),
            ));
        }
        return Ok((r, RangeMaxSource::Param));
    }
    if let Some(r) = robot_laser1.first().and_then(|s| s.maximum_range) {
        return Ok((r, RangeMaxSource::RobotLaser1));
    }
    Ok((NO_RETURN_M, RangeMaxSource::Default))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("t.clf")
    }

    /// Issue 45 class: a line of millions of words is refused by its count without being
    /// collected, and a huge word is quoted cut.
    #[test]
    fn huge_lines_and_words_are_refused_cheaply() {
        let many = format!("FLASER {}\n", "1 ".repeat(MAX_WORDS + 10));
        let e = parse(many.as_bytes(), p()).unwrap_err().to_string();
        assert!(
            e.contains("line 1") && e.contains("more than 262144 words"),
            "{e}"
        );
        let word = format!(
            "ODOM {} 0 0 0 0 0 1.0 host 1.0\n",
            "9".repeat(1_000_000) + "x"
        );
        let e = parse(word.as_bytes(), p()).unwrap_err().to_string();
        assert!(e.len() < 400 && e.contains("(1000001 bytes)"), "{e}");
    }

    fn mit() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets/mit-csail/mit-csail.clf.gz")
    }

    const SMALL: &str = "# a comment\n\
PARAM robot_front_laser_max 50.0\n\
PARAM robot_frontlaser_offset 0.2 nohost 0\n\
ODOM 1.0 2.0 0.5 0.3 0.0 0.0 100.25 host 0.1\n\
SYNC 3 4\n\
FLASER 3 1.5 81.91 2.0 1.1 2.0 0.5 1.0 2.0 0.5 100.5 host 0.2\n\
\n\
RLASER 2 1.0 1.0 1.0 2.0 3.1 1.0 2.0 0.5 100.6\n\
ODOM 1.1 2.0 0.5 0.3 0.0 0.0 100.75 host 0.3\n";

    #[test]
    fn a_small_log_is_read_line_by_line() {
        let log = parse(SMALL.as_bytes(), p()).unwrap();
        assert_eq!(log.front_scans.len(), 1);
        let s = &log.front_scans[0];
        assert_eq!((s.kind, s.line, s.stamp), (ScanKind::Flaser, 6, 100.5));
        assert_eq!(s.ranges, vec![1.5, f32::INFINITY, 2.0]);
        assert_eq!((s.angle_min, s.angle_increment), (-FRAC_PI_2, FRAC_PI_2));
        assert_eq!(log.rear_scans[0].stamp, 100.6);
        assert_eq!(log.odometry_source, OdometrySource::Odom);
        assert_eq!(log.odometry.len(), 2);
        assert_eq!(log.odometry[0].pose, [1.0, 2.0, 0.5]);
        assert_eq!(log.odometry[0].velocity, Some([0.3, 0.0]));
        assert_eq!(
            (log.range_max, log.range_max_source),
            (50.0, RangeMaxSource::Param)
        );
        // Laser at (1.1, 2.0) with the robot at (1.0, 2.0) heading 0.5: 0.1 m ahead, rotated.
        let m = log.front_mount;
        assert_eq!(m.source, MountSource::FlaserPoses);
        assert!((m.pose[0] - 0.1 * 0.5f64.cos()).abs() < 1e-12);
        assert!((m.pose[1] + 0.1 * 0.5f64.sin()).abs() < 1e-12);
        assert!(m.pose[2].abs() < 1e-12);
    }

    #[test]
    fn robot_laser1_gives_its_own_geometry_and_mount() {
        // 3 readings from -0.5 rad by 0.5 rad, maximum range 30: 30.0 is no return.
        let line = "ROBOTLASER1 0 -0.5 1.0 0.5 30.0 0.01 0 3 1.0 30.0 2.0 0 \
                    2.0 1.0 1.5707963267948966 2.0 0.5 1.5707963267948966 0 0 0.3 0.2 0 55.5 host 1";
        let log = parse(line.as_bytes(), p()).unwrap();
        let s = &log.front_scans[0];
        assert_eq!(
            (s.kind, s.angle_min, s.angle_increment),
            (ScanKind::RobotLaser1, -0.5, 0.5)
        );
        assert_eq!(s.ranges, vec![1.0, f32::INFINITY, 2.0]);
        assert_eq!(s.stamp, 55.5);
        assert_eq!(
            (log.range_max, log.range_max_source),
            (30.0, RangeMaxSource::RobotLaser1)
        );
        // The laser 0.5 m ahead of a robot heading +90 degrees.
        assert_eq!(log.front_mount.source, MountSource::RobotLaser1);
        assert!((log.front_mount.pose[0] - 0.5).abs() < 1e-12);
        assert!(log.front_mount.pose[1].abs() < 1e-12);
        assert_eq!(log.odometry_source, OdometrySource::RobotLaser1);
        // With remissions.
        let line = line.replace(" 2.0 0 ", " 2.0 3 0.1 0.2 0.3 ");
        assert_eq!(
            parse(line.as_bytes(), p()).unwrap().front_scans[0].stamp,
            55.5
        );
    }

    #[test]
    fn mount_falls_back_to_params_then_zero() {
        let flaser = "FLASER 2 1 1 0 0 0 0 0 0 10.0\n";
        let log = parse(flaser.as_bytes(), p()).unwrap();
        assert_eq!(log.front_mount.source, MountSource::Zero);
        assert_eq!(
            (log.range_max, log.range_max_source),
            (NO_RETURN_M, RangeMaxSource::Default)
        );
        assert_eq!(log.odometry_source, OdometrySource::Flaser);
        let with = format!("PARAM robot_frontlaser_offset 0.25\n{flaser}");
        let log = parse(with.as_bytes(), p()).unwrap();
        assert_eq!(log.front_mount.source, MountSource::Param);
        assert_eq!(log.front_mount.pose, [0.25, 0.0, 0.0]);
    }

    #[test]
    fn errors_name_the_line_and_the_field() {
        let cases = [
            (
                "FLASER 3 1.0 x 2.0 0 0 0 0 0 0 5.0\n",
                "line 1: FLASER field range[1]: \"x\" is not a number",
            ),
            (
                "FLASER 3 1.0 1.0 2.0 0 0 0 0 0 0 nan\n",
                "line 1: FLASER field timestamp: \"nan\" is not finite",
            ),
            (
                "FLASER 3 1.0 1.0 2.0 0 0 0 0 0 0\n",
                "line 1: FLASER field timestamp: missing",
            ),
            (
                "FLASER 1 1.0 0 0 0 0 0 0 3.25",
                "the file ends inside this line",
            ),
            ("FLASER 300 1.0 1.0", "num_readings: 300 values do not fit"),
            (
                "FLASER 2 1.0 -1.0 0 0 0 0 0 0 3\n",
                "range[1]: -1 is negative",
            ),
            ("FLASER 1 1.0 0 0 0 0 0 0 3 h 1 2 3", "4 words follow it"),
            ("\n\nODOM 1 2 3 4 5 inf 7\n", "line 3: ODOM field accel"),
            (
                "PARAM robot_front_laser_max abc\nODOM 1 2 3 4 5 6 7\n",
                "PARAM robot_front_laser_max: \"abc\" is not a finite number",
            ),
            (
                "hello world",
                "line 1: starts with \"hello\", not a CARMEN message name",
            ),
            ("# only a comment\nSYNC 1", "holds no FLASER"),
        ];
        for (text, want) in cases {
            let e = parse(text.as_bytes(), p()).unwrap_err().to_string();
            assert!(
                e.starts_with("t.clf: ") && e.contains(want),
                "{e}\nwanted {want}"
            );
        }
    }

    #[test]
    fn the_mit_log_is_read_from_gzip() {
        let log = read(&mit()).unwrap();
        assert_eq!(log.front_scans.len(), 1988);
        assert!(log.front_scans.iter().all(|s| s.ranges.len() == 361));
        let s = &log.front_scans[0];
        assert_eq!((s.line, s.stamp), (4, 1134864629.895182));
        assert_eq!(s.ranges[0], 1.40);
        assert_eq!(s.ranges[24], f32::INFINITY);
        assert!((s.angle_increment - PI / 360.0).abs() < 1e-15);
        assert_eq!(s.robot_pose, [576.536523, 0.106594, -2.255213]);
        assert_eq!(log.odometry_source, OdometrySource::Flaser);
        assert_eq!(log.odometry.len(), 1988);
        assert_eq!(log.front_mount.source, MountSource::Zero);
        assert!(log.rear_scans.is_empty() && log.params.is_empty());
        // The same text, not gzipped.
        let text = gunzip(&std::fs::read(mit()).unwrap()).unwrap();
        assert_eq!(parse(&text, &mit()).unwrap().front_scans, log.front_scans);
    }

    #[test]
    fn truncated_and_damaged_logs_never_panic() {
        let gz = std::fs::read(mit()).unwrap();
        let text = gunzip(&gz).unwrap();
        let full = parse(&text, p()).unwrap().front_scans.len();
        for cut in [0, 1, 2, 10, 1000, gz.len() / 2, gz.len() - 8, gz.len() - 1] {
            let dir = std::env::temp_dir().join(format!("atrium-carmen-{}.gz", std::process::id()));
            std::fs::write(&dir, &gz[..cut]).unwrap();
            let r = read(&dir);
            std::fs::remove_file(&dir).unwrap();
            assert!(r.is_err(), "gzip cut at {cut}");
        }
        // Plain text cut anywhere: an error on the cut line, or fewer (whole) scans.
        for cut in [5, 3000, text.len() / 3, text.len() / 2, text.len() - 50] {
            match parse(&text[..cut], p()) {
                Ok(log) => assert!(log.front_scans.len() < full),
                Err(e) => {
                    let e = e.to_string();
                    assert!(e.contains("line ") || e.contains("holds no FLASER"), "{e}");
                }
            }
        }
        for k in [0, 100, text.len() / 2, text.len() - 30] {
            let mut b = text.clone();
            for x in &mut b[k..k + 8] {
                *x ^= 0x55;
            }
            if let Ok(log) = parse(&b, p()) {
                assert!(log.front_scans.len() <= full);
            }
        }
    }
}
