//! Property-based fuzzing of the text readers `atrium score`, `map` and the log scenarios rely
//! on (issue 45, "beyond the list"): TUM and CSV trajectories, CARMEN logs, ROS map YAML and
//! rosbag2 metadata, each a valid text damaged by deletions, duplications, inserted tokens and
//! hostile numbers. Every input must give `Ok` or a clean error naming the file: never a
//! panic, and what a reader accepts must hold only finite numbers.

use atrium_formats::{carmen, ros_map, rosbag2, tum};
use proptest::prelude::*;
use proptest::sample::{select, Index};
use std::path::Path;

#[derive(Debug, Clone)]
enum Edit {
    Delete(Index, usize),
    Insert(Index, &'static str),
    Duplicate(Index, usize),
}

const TOKENS: &[&str] = &[
    " ",
    "\n",
    "\r\n",
    ",",
    "#",
    "-",
    ".",
    "e",
    "1e308",
    "-1e308",
    "1e400",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "0",
    "-0",
    "18446744073709551616",
    "-9223372036854775809",
    "5e-324",
    "é",
    "\u{0}",
    "\t",
    ":",
    "[",
    "]",
    "{",
    "}",
    "'",
    "\"",
    "*a",
    "&a ",
    "!!binary ",
    "~",
    "null",
    "FLASER ",
    "ODOM ",
    "ROBOTLASER1 ",
    "PARAM ",
    "RLASER ",
    "1000000000 ",
    "t,x,y,theta\n",
    "image: ",
    "resolution: ",
    "origin: ",
    "negate: ",
    "mode: ",
    "rosbag2_bagfile_information:",
];

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (any::<Index>(), 1usize..20).prop_map(|(i, n)| Edit::Delete(i, n)),
        (any::<Index>(), select(TOKENS)).prop_map(|(i, t)| Edit::Insert(i, t)),
        (any::<Index>(), 1usize..200).prop_map(|(i, n)| Edit::Duplicate(i, n)),
    ]
}

fn apply(base: &str, edits: &[Edit]) -> String {
    let mut b = base.as_bytes().to_vec();
    for e in edits {
        match e {
            Edit::Delete(i, n) => {
                if !b.is_empty() {
                    let at = i.index(b.len());
                    let end = (at + n).min(b.len());
                    b.drain(at..end);
                }
            }
            Edit::Insert(i, t) => {
                let at = i.index(b.len() + 1);
                b.splice(at..at, t.bytes());
            }
            Edit::Duplicate(i, n) => {
                if !b.is_empty() {
                    let at = i.index(b.len());
                    let end = (at + n).min(b.len());
                    let piece = b[at..end].to_vec();
                    b.splice(at..at, piece);
                }
            }
        }
    }
    String::from_utf8_lossy(&b).into_owned()
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: std::env::var("FUZZ_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(400),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

const TUM: &str = "# t x y z qx qy qz qw\n0.1 1 2 0 0 0 0.2474 0.9689\n0.2 1.5 2 0 0 0 0 1\n\
0.3 1.75 2.25 0 0 0 -0.1 0.995\n";
const CSV: &str = "t,x,y,theta\n0.1,1,2,0.5\n0.2,1.5,2,0\n0.3,1.75,2.25,-0.2\n";
const CARMEN: &str = "# a comment\n\
PARAM robot_front_laser_max 50.0\n\
PARAM robot_frontlaser_offset 0.2 nohost 0\n\
ODOM 1.0 2.0 0.5 0.3 0.0 0.0 100.25 host 0.1\n\
FLASER 3 1.5 81.91 2.0 1.1 2.0 0.5 1.0 2.0 0.5 100.5 host 0.2\n\
ROBOTLASER1 0 -1.5708 3.1416 1.5708 50.0 0.01 0 3 1.0 2.0 3.0 0 1.0 2.0 0.5 1.1 2.0 0.5 0.0 0.0 0.0 0.0 0.0 100.7 host 0.4\n\
ODOM 1.1 2.0 0.5 0.3 0.0 0.0 100.75 host 0.3\n";
const MAP_YAML: &str = "image: map.pgm\nresolution: 0.05\norigin: [-10.0, -5.5, 0.0]\n\
negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n";

fn finite_rows(rows: &[tum::Row]) -> bool {
    rows.iter().all(|r| {
        r.t.is_finite() && r.pose.x.is_finite() && r.pose.y.is_finite() && r.pose.theta.is_finite()
    })
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn tum_and_csv(edits in proptest::collection::vec(edit(), 1..6)) {
        let p = Path::new("fuzz.tum");
        let text = apply(TUM, &edits);
        match tum::read_tum(p, &text) {
            Ok(rows) => prop_assert!(finite_rows(&rows)),
            Err(e) => prop_assert!(e.to_string().contains("fuzz.tum"), "{e}"),
        }
        let p = Path::new("fuzz.csv");
        let text = apply(CSV, &edits);
        match tum::read_csv(p, &text) {
            Ok(rows) => prop_assert!(finite_rows(&rows)),
            Err(e) => prop_assert!(e.to_string().contains("fuzz.csv"), "{e}"),
        }
    }

    #[test]
    fn carmen_logs(edits in proptest::collection::vec(edit(), 1..6)) {
        let p = Path::new("fuzz.clf");
        let text = apply(CARMEN, &edits);
        match carmen::parse(text.as_bytes(), p) {
            Ok(log) => {
                for s in log.front_scans.iter().chain(&log.rear_scans) {
                    prop_assert!(s.stamp.is_finite());
                    prop_assert!(s.ranges.iter().all(|r| !r.is_nan() && *r >= 0.0));
                }
                prop_assert!(log.odometry.iter().all(|o| o.pose.iter().all(|v| v.is_finite())));
            }
            Err(e) => prop_assert!(e.to_string().contains("fuzz.clf"), "{e}"),
        }
    }

    #[test]
    fn map_yaml(edits in proptest::collection::vec(edit(), 1..6)) {
        let p = Path::new("fuzz.yaml");
        let text = apply(MAP_YAML, &edits);
        match ros_map::parse_yaml(&text, p) {
            Ok(m) => {
                prop_assert!(m.resolution > 0.0 && m.resolution.is_finite());
                prop_assert!(m.origin.iter().all(|v| v.is_finite()));
                prop_assert!(m.free_thresh < m.occupied_thresh);
            }
            Err(e) => prop_assert!(e.to_string().contains("fuzz.yaml"), "{e}"),
        }
    }

    #[test]
    fn rosbag2_metadata(edits in proptest::collection::vec(edit(), 1..6)) {
        let base = std::fs::read_to_string(
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../datasets/fixtures/fr079_head_sqlite3/metadata.yaml"),
        )
        .unwrap();
        let p = Path::new("fuzz/metadata.yaml");
        let text = apply(&base, &edits);
        if let Err(e) = rosbag2::metadata::parse(&text, p) {
            prop_assert!(e.to_string().contains("metadata.yaml"), "{e}");
        }
    }
}
