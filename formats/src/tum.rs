//! Trajectories as text: the TUM format (`timestamp x y z qx qy qz qw`, one pose per line,
//! `#` comments), read by `evo` and the TUM RGB-D benchmark tools, and CSV `t,x,y,theta`
//! (with or without a header naming the columns, then in any order).
//!
//! Writing: numbers in the shortest notation that reads back to the same `f64` (plain
//! decimals, no exponent), so `atrium score` of a trajectory written here scores exactly like
//! the run that wrote it.
//!
//! Reading checks every line before trusting it (a line's field count before its fields are
//! collected, so a huge file on one line costs no memory; numbers; a quaternion that is not a
//! rotation) and names the line of the first error. Time order is the caller's to check: it
//! knows what a repeated stamp means to it.

use crate::FormatError;
use atrium_robots::Pose2;
use std::fmt::Write;
use std::path::Path;

/// One pose read from a text trajectory.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// 1-based line number, for messages.
    pub line: usize,
    pub t: f64,
    pub pose: Pose2,
}

/// The planar yaw of a quaternion (its rotation projected to the floor plane).
pub fn yaw_of_quaternion(x: f64, y: f64, z: f64, w: f64) -> f64 {
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// `s` quoted for a message, cut to its first 60 characters: a field or header of hundreds of
/// megabytes (one line of a hostile file) must not be copied into the error, twice over.
fn quote(s: &str) -> String {
    const KEEP: usize = 60;
    match s.char_indices().nth(KEEP) {
        None => format!("{s:?}"),
        Some((cut, _)) => format!("{:?}... ({} bytes)", &s[..cut], s.len()),
    }
}

fn parse_num(path: &Path, line: usize, what: &str, s: &str) -> Result<f64, FormatError> {
    let v = s.trim().parse::<f64>().map_err(|_| {
        FormatError::field(
            path,
            format!("line {line}"),
            format!("{what} {} is not a number", quote(s.trim())),
        )
    })?;
    if !v.is_finite() {
        return Err(FormatError::field(
            path,
            format!("line {line}"),
            format!("{what} is {v}: not a number"),
        ));
    }
    Ok(v)
}

/// Reads a TUM trajectory's text (`path` names it in errors).
pub fn read_tum(path: &Path, text: &str) -> Result<Vec<Row>, FormatError> {
    const NAMES: [&str; 8] = ["timestamp", "x", "y", "z", "qx", "qy", "qz", "qw"];
    let mut rows = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let n = k + 1;
        // At most one field past the eight is looked at: a line of a million fields is
        // refused by its count without being collected.
        let f: Vec<&str> = line.split_whitespace().take(9).collect();
        if f.len() != 8 {
            let count = if f.len() > 8 {
                "more than 8".to_string()
            } else {
                f.len().to_string()
            };
            return Err(FormatError::field(
                path,
                format!("line {n}"),
                format!("{count} fields, expected 8 (TUM: timestamp x y z qx qy qz qw)"),
            ));
        }
        let mut v = [0.0; 8];
        for (i, (s, name)) in f.iter().zip(NAMES).enumerate() {
            v[i] = parse_num(path, n, name, s)?;
        }
        let norm = (v[4] * v[4] + v[5] * v[5] + v[6] * v[6] + v[7] * v[7]).sqrt();
        if norm.is_nan() || norm <= 1e-6 {
            return Err(FormatError::field(
                path,
                format!("line {n}"),
                format!(
                    "quaternion ({}, {}, {}, {}) is not a rotation (zero length)",
                    v[4], v[5], v[6], v[7]
                ),
            ));
        }
        rows.push(Row {
            line: n,
            t: v[0],
            pose: Pose2::new(v[1], v[2], yaw_of_quaternion(v[4], v[5], v[6], v[7])),
        });
    }
    Ok(rows)
}

/// Reads a CSV trajectory's text: `t,x,y,theta` (radians), with or without a header naming
/// the columns (then in any order, other columns ignored).
pub fn read_csv(path: &Path, text: &str) -> Result<Vec<Row>, FormatError> {
    let mut rows = Vec::new();
    let mut columns = [0usize, 1, 2, 3];
    let mut first = true;
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let n = k + 1;
        let at = format!("line {n}");
        // A header or a row has a few dozen columns at most: more is not a trajectory.
        const MAX_COLUMNS: usize = 256;
        let f: Vec<&str> = line
            .split(',')
            .map(str::trim)
            .take(MAX_COLUMNS + 1)
            .collect();
        if f.len() > MAX_COLUMNS {
            return Err(FormatError::field(
                path,
                &at,
                format!("more than {MAX_COLUMNS} columns: not a t,x,y,theta trajectory"),
            ));
        }
        if std::mem::take(&mut first) && f.iter().any(|s| s.parse::<f64>().is_err()) {
            let aliases: [&[&str]; 4] = [
                &["t", "time", "timestamp", "stamp", "t_s", "time_s"],
                &["x", "x_m"],
                &["y", "y_m"],
                &["theta", "yaw", "heading", "theta_rad", "yaw_rad"],
            ];
            for (c, names) in columns.iter_mut().zip(aliases) {
                *c = f
                    .iter()
                    .position(|h| names.contains(&h.to_ascii_lowercase().as_str()))
                    .ok_or_else(|| {
                        let degrees = f.iter().any(|h| {
                            let h = h.to_ascii_lowercase();
                            h.contains("deg")
                        });
                        let hint = if degrees && names[0] == "theta" {
                            " (a heading in degrees is not read: give theta in radians)"
                        } else {
                            ""
                        };
                        FormatError::field(
                            path,
                            &at,
                            format!(
                                "header {} has no {:?} column (expected t,x,y,theta){hint}",
                                quote(line),
                                names[0]
                            ),
                        )
                    })?;
            }
            continue;
        }
        let need = columns.iter().max().copied().unwrap_or(3) + 1;
        if f.len() < need {
            return Err(FormatError::field(
                path,
                &at,
                format!("{} fields, expected at least {need} (t,x,y,theta)", f.len()),
            ));
        }
        let names = ["t", "x", "y", "theta"];
        let mut v = [0.0; 4];
        for i in 0..4 {
            v[i] = parse_num(path, n, names[i], f[columns[i]])?;
        }
        rows.push(Row {
            line: n,
            t: v[0],
            pose: Pose2::new(v[1], v[2], v[3]),
        });
    }
    Ok(rows)
}

/// Whether a trajectory file is CSV rather than TUM: a `.csv` name, or a first data line
/// holding commas.
pub fn looks_like_csv(path: &Path, text: &str) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
        || text
            .lines()
            .map(str::trim)
            .find(|l| !l.is_empty() && !l.starts_with('#'))
            .is_some_and(|l| l.contains(','))
}

/// Reads a TUM or CSV trajectory file (see [`looks_like_csv`]).
pub fn read_file(path: &Path) -> Result<Vec<Row>, FormatError> {
    let text = std::fs::read_to_string(path).map_err(|e| FormatError::io(path, e))?;
    if looks_like_csv(path, &text) {
        read_csv(path, &text)
    } else {
        read_tum(path, &text)
    }
}

pub fn to_tum(poses: &[(f64, Pose2)]) -> String {
    let mut s = String::with_capacity(poses.len() * 64);
    for (t, p) in poses {
        let (qz, qw) = (0.5 * p.theta).sin_cos();
        let _ = writeln!(s, "{t} {} {} 0 0 0 {qz} {qw}", p.x, p.y);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tum_and_csv_read_the_same_poses() {
        let p = Path::new("t");
        let tum = read_tum(
            p,
            "# c\n1.5 1 2 0 0 0 0.7071067811865476 0.7071067811865476\n",
        )
        .unwrap();
        let csv = read_csv(p, "theta,t,x,y\n1.5707963267948966,1.5,1,2\n").unwrap();
        assert_eq!(tum.len(), 1);
        assert_eq!(tum[0].line, 2);
        assert_eq!((tum[0].t, tum[0].pose.x, tum[0].pose.y), (1.5, 1.0, 2.0));
        assert!((tum[0].pose.theta - csv[0].pose.theta).abs() < 1e-12);
        assert!(looks_like_csv(Path::new("a.txt"), "1,2,3,4"));
        assert!(!looks_like_csv(Path::new("a.txt"), "1 2 3 4 0 0 0 1"));
    }

    #[test]
    fn bad_lines_are_named() {
        let p = Path::new("t");
        let err = |r: Result<Vec<Row>, FormatError>| r.unwrap_err().to_string();
        assert!(err(read_tum(p, "1 2 3\n")).contains("line 1: 3 fields"));
        assert!(err(read_tum(p, "\n1 2 3 4 5 6 7 8 9 10\n")).contains("line 2: more than 8"));
        assert!(err(read_tum(p, "1 2 x 0 0 0 0 1\n")).contains("y \"x\" is not a number"));
        assert!(err(read_tum(p, "1 2 3 0 0 0 0 0\n")).contains("not a rotation"));
        assert!(err(read_tum(p, "1 nan 3 0 0 0 0 1\n")).contains("x is NaN: not a number"));
        assert!(err(read_csv(p, "t,x,y,theta_deg\n1,2,3,90\n")).contains("degrees"));
        // A line of many fields is refused by its count.
        let long = "1 ".repeat(100_000);
        assert!(err(read_tum(p, &long)).contains("more than 8"));
    }

    /// Issue 45: a huge field is quoted cut, not copied into the message whole.
    #[test]
    fn a_huge_field_is_quoted_cut() {
        let line = format!("0.1 {} 0 0 0 0 0 1", "x".repeat(10_000_000));
        let e = read_tum(Path::new("big.tum"), &line)
            .unwrap_err()
            .to_string();
        assert!(e.len() < 300, "{} bytes", e.len());
        assert!(
            e.contains("... (10000000 bytes)") && e.contains("line 1"),
            "{e}"
        );
        let header = format!("t,x,y,{}\n0,1,2,3\n", "h".repeat(10_000_000));
        let e = read_csv(Path::new("big.csv"), &header)
            .unwrap_err()
            .to_string();
        assert!(e.len() < 400, "{} bytes", e.len());
    }

    #[test]
    fn quarter_turn_quaternion() {
        let s = to_tum(&[(1.5, Pose2::new(1.0, 2.0, std::f64::consts::FRAC_PI_2))]);
        let f: Vec<f64> = s.split_whitespace().map(|v| v.parse().unwrap()).collect();
        assert_eq!(f.len(), 8);
        assert_eq!(&f[..3], &[1.5, 1.0, 2.0]);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((f[6] - h).abs() < 1e-8 && (f[7] - h).abs() < 1e-8);
    }

    #[test]
    fn times_and_positions_read_back_bit_exact() {
        let poses = [
            (0.1, Pose2::new(0.1 + 0.2, -1e-9, 3.0)),
            (259.995, Pose2::new(27.123456789012345, 1e-300, -3.1)),
            (2.0, Pose2::new(-0.0, 1e15, 0.0)),
        ];
        for (line, (t, p)) in to_tum(&poses).lines().zip(&poses) {
            assert!(!line.contains('e'), "{line}");
            let f: Vec<f64> = line.split(' ').map(|v| v.parse().unwrap()).collect();
            assert_eq!(
                [f[0], f[1], f[2]].map(f64::to_bits),
                [*t, p.x, p.y].map(f64::to_bits)
            );
        }
    }
}
