//! Benchmark relations of [Kümmerle 2009]: one relative pose per line,
//! `t1 t2 x y z roll pitch yaw`, the motion of the robot from its pose at `t1` to its pose at
//! `t2`, expressed in its frame at `t1` (metres, radians). A localizer's trajectory is scored
//! by comparing its own motion between the two stamps with each relation, which needs no
//! global reference frame.
//!
//! Checked: eight finite numbers per line (`#` comments and blank lines skipped), `t1 != t2`,
//! and a planar motion (`z`, `roll`, `pitch` within 1e-6 of zero: the benchmark's relations
//! are 2-D; a 3-D one is refused rather than projected silently).

use crate::FormatError;
use atrium_robots::Pose2;
use std::path::Path;

/// One relation: the motion from the pose at `t1` to the pose at `t2`, in the frame at `t1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Relation {
    pub t1: f64,
    pub t2: f64,
    pub motion: Pose2,
}

/// Reads a relations file's text (`path` names it in errors).
pub fn parse(path: &Path, text: &str) -> Result<Vec<Relation>, FormatError> {
    const NAMES: [&str; 8] = ["t1", "t2", "x", "y", "z", "roll", "pitch", "yaw"];
    let mut out = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let at = format!("line {}", k + 1);
        let fields: Vec<&str> = line.split_whitespace().take(9).collect();
        if fields.len() != 8 {
            return Err(FormatError::field(
                path,
                &at,
                format!(
                    "{} fields, expected 8 (t1 t2 x y z roll pitch yaw)",
                    if fields.len() > 8 {
                        "more than 8".to_string()
                    } else {
                        fields.len().to_string()
                    }
                ),
            ));
        }
        let mut v = [0.0; 8];
        for (i, (s, name)) in fields.iter().zip(NAMES).enumerate() {
            v[i] = s
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| {
                    FormatError::field(path, &at, format!("{name} {s:?} is not a finite number"))
                })?;
        }
        if v[0] == v[1] {
            return Err(FormatError::field(
                path,
                &at,
                format!(
                    "t1 and t2 are both {} s: a relation joins two instants",
                    v[0]
                ),
            ));
        }
        for (i, name) in [(4, "z"), (5, "roll"), (6, "pitch")] {
            if v[i].abs() > 1e-6 {
                return Err(FormatError::field(
                    path,
                    &at,
                    format!("{name} is {}: only planar relations are read", v[i]),
                ));
            }
        }
        out.push(Relation {
            t1: v[0],
            t2: v[1],
            motion: Pose2::new(v[2], v[3], v[7]),
        });
    }
    if out.is_empty() {
        return Err(FormatError::field(path, "file", "holds no relations"));
    }
    Ok(out)
}

/// Reads a relations file.
pub fn read(path: &Path) -> Result<Vec<Relation>, FormatError> {
    let text = std::fs::read_to_string(path).map_err(|e| FormatError::io(path, e))?;
    parse(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_benchmark_layout() {
        let text = "# fr079\n1216.630413 1217.490267 0.407950 -0.016330 0 0 0 -0.069620\n\n";
        let r = parse(Path::new("r"), text).unwrap();
        assert_eq!(r.len(), 1);
        assert_eq!((r[0].t1, r[0].t2), (1216.630413, 1217.490267));
        assert_eq!(
            (r[0].motion.x, r[0].motion.y, r[0].motion.theta),
            (0.40795, -0.01633, -0.06962)
        );
    }

    #[test]
    fn bad_lines_are_named() {
        let e = |t: &str| parse(Path::new("r"), t).unwrap_err().to_string();
        assert!(e("1 2 3\n").contains("line 1: 3 fields"));
        assert!(e("1 2 0 0 0 0 0 x\n").contains("yaw \"x\""));
        assert!(e("1 1 0 0 0 0 0 0\n").contains("both 1 s"));
        assert!(e("1 2 0 0 0.5 0 0 0\n").contains("z is 0.5"));
        assert!(e("# nothing\n").contains("no relations"));
        assert!(e("1 2 nan 0 0 0 0 0\n").contains("finite"));
    }

    #[test]
    fn the_bundled_files_read_whole() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets");
        let fr = read(&dir.join("fr079/fr079.relations")).unwrap();
        let mit = read(&dir.join("mit-csail/mit-csail.relations")).unwrap();
        assert_eq!((fr.len(), mit.len()), (1685, 1172));
    }
}
