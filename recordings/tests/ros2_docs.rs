//! A ROS 2 bag as nav2 and friends replay it (issue 42), and the walk-through `docs/ros2.md`:
//! every row of its table of topics, types, frames and QoS, and every promise below the table,
//! is checked on a bag recorded from `scenarios/corridor_tracking.toml`; `/tf_static` follows
//! the URDF's tree; the `atrium_msgs` definitions inside the bag are the package's `.msg`
//! files; `--tf-ground-truth` puts `map -> odom` back. With `ATRIUM_ROSBAGS_PYTHON` naming a
//! Python that has the `rosbags` package (CI sets it), the same bag is also read by the
//! independent checker `scripts/check_rosbag.py --doc docs/ros2.md`.

mod common;

use atrium_formats::cdr::CdrReader;
use atrium_formats::rosbag2::schemas;
use atrium_recordings::ros2::{self, Ros2Options};
use atrium_scenarios::{LocalizerRegistry, RunOptions, Scenario};
use common::tmpdir;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn scenario(secs: f64) -> Scenario {
    let path = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut table: toml::Table = text.parse().unwrap();
    table.insert("duration_s".into(), toml::Value::Float(secs));
    Scenario::from_toml_str(&toml::to_string(&table).unwrap(), &path).unwrap()
}

/// One message of the bag: log time and CDR bytes.
struct Msg {
    ns: u64,
    data: Vec<u8>,
}

struct Topic {
    schema: String,
    schema_text: String,
    qos: String,
    msgs: Vec<Msg>,
}

struct Bag {
    dir: PathBuf,
    topics: BTreeMap<String, Topic>,
}

fn read_bag(dir: &Path) -> Bag {
    let file = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "mcap"))
        .unwrap();
    let bytes = std::fs::read(file).unwrap();
    let mut topics: BTreeMap<String, Topic> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let t = topics.entry(m.channel.topic.clone()).or_insert_with(|| {
            let s = m.channel.schema.as_ref().unwrap();
            Topic {
                schema: s.name.clone(),
                schema_text: String::from_utf8(s.data.to_vec()).unwrap(),
                qos: m.channel.metadata["offered_qos_profiles"].clone(),
                msgs: Vec::new(),
            }
        });
        t.msgs.push(Msg {
            ns: m.log_time,
            data: m.data.to_vec(),
        });
    }
    Bag {
        dir: dir.to_path_buf(),
        topics,
    }
}

/// The bag of the walk-through, recorded once for all tests of this file.
fn bag() -> &'static Bag {
    static BAG: OnceLock<Bag> = OnceLock::new();
    BAG.get_or_init(|| {
        let dir = tmpdir("ros2-docs").join("run");
        ros2::record_ros2(
            &LocalizerRegistry::with_builtins(),
            &scenario(6.0),
            &dir,
            RunOptions::default(),
        )
        .unwrap();
        read_bag(&dir)
    })
}

fn header(r: &mut CdrReader) -> (u64, String) {
    let sec = r.i32().unwrap();
    let nsec = r.u32().unwrap();
    (
        sec as u64 * 1_000_000_000 + u64::from(nsec),
        r.string().unwrap(),
    )
}

/// (stamp, frame, child frame) of each message of a type with a header; for a TFMessage one
/// entry per transform.
fn frames(topic: &Topic) -> Vec<(u64, String, Option<String>)> {
    let mut out = Vec::new();
    for m in &topic.msgs {
        let mut r = CdrReader::new(&m.data).unwrap();
        match topic.schema.as_str() {
            schemas::TF_MESSAGE => {
                let n = r.len(1).unwrap();
                for _ in 0..n {
                    let (ns, parent) = header(&mut r);
                    let child = r.string().unwrap();
                    r.f64_array::<7>().unwrap();
                    out.push((ns, parent, Some(child)));
                }
            }
            schemas::ODOMETRY => {
                let (ns, f) = header(&mut r);
                out.push((ns, f, Some(r.string().unwrap())));
            }
            schemas::STRING | schemas::CLOCK => {}
            _ => {
                let (ns, f) = header(&mut r);
                out.push((ns, f, None));
            }
        }
    }
    out
}

/// The rows of the table under "## What this walk-through relies on" in docs/ros2.md:
/// (topic, type, frame, child frame, durability).
fn doc_rows() -> Vec<[String; 5]> {
    let text = std::fs::read_to_string(repo().join("docs/ros2.md")).unwrap();
    let section = text
        .split("## What this walk-through relies on")
        .nth(1)
        .expect("docs/ros2.md has its table section");
    let rows: Vec<[String; 5]> = section
        .lines()
        .filter(|l| l.starts_with("| `/"))
        .map(|l| {
            let cells: Vec<String> = l
                .trim_matches('|')
                .split('|')
                .map(|c| c.trim().trim_matches('`').to_string())
                .collect();
            assert_eq!(cells.len(), 5, "{l}");
            [
                cells[0].clone(),
                cells[1].clone(),
                cells[2].clone(),
                cells[3].clone(),
                cells[4].clone(),
            ]
        })
        .collect();
    assert!(rows.len() >= 8, "{rows:?}");
    rows
}

#[test]
fn every_topic_frame_and_qos_the_walk_through_names_is_in_the_bag() {
    let bag = bag();
    for [topic, ty, frame, child, durability] in doc_rows() {
        let t = bag
            .topics
            .get(&topic)
            .unwrap_or_else(|| panic!("{topic} missing: {:?}", bag.topics.keys()));
        assert_eq!(t.schema, ty, "{topic}");
        let want = match durability.as_str() {
            "transient local" => "durability: 1",
            "volatile" => "durability: 2",
            other => panic!("{topic}: durability {other:?} in the doc"),
        };
        assert!(t.qos.contains(want), "{topic}: {}", t.qos);
        let f = frames(t);
        if ty == schemas::TF_MESSAGE {
            assert!(
                f.iter()
                    .any(|(_, p, c)| *p == frame && c.as_deref() == Some(child.as_str())),
                "{topic} has no {frame} -> {child}: {f:?}"
            );
        } else if !frame.is_empty() {
            assert!(!f.is_empty(), "{topic}");
            for (_, p, c) in &f {
                assert_eq!(*p, frame, "{topic}");
                if !child.is_empty() {
                    assert_eq!(c.as_deref(), Some(child.as_str()), "{topic}");
                }
            }
        }
        // Header stamps are the log times (what `ros2 bag play --clock` publishes).
        if ty != schemas::TF_MESSAGE {
            let stamps: Vec<u64> = f.iter().map(|x| x.0).collect();
            if !stamps.is_empty() {
                let logs: Vec<u64> = t.msgs.iter().map(|m| m.ns).collect();
                assert_eq!(stamps, logs, "{topic}");
            }
        }
    }
}

#[test]
fn tf_carries_odom_to_base_only_and_the_flag_puts_map_to_odom_back() {
    let tf = frames(&bag().topics["/tf"]);
    assert!(!tf.is_empty());
    assert!(
        tf.iter()
            .all(|(_, p, c)| p == "odom" && c.as_deref() == Some("base_footprint")),
        "{:?}",
        &tf[..3]
    );
    let dir = tmpdir("ros2-tf-gt").join("run");
    ros2::record_ros2_with(
        &LocalizerRegistry::with_builtins(),
        &scenario(1.0),
        &dir,
        RunOptions::default(),
        Ros2Options {
            tf_ground_truth: true,
        },
    )
    .unwrap();
    let with = read_bag(&dir);
    let tf = frames(&with.topics["/tf"]);
    assert!(tf
        .iter()
        .any(|(_, p, c)| p == "map" && c.as_deref() == Some("odom")));
    let _ = std::fs::remove_dir_all(dir.parent().unwrap());
}

#[test]
fn odom_has_twist_and_covariances_from_the_odometry_model() {
    let odom = &bag().topics["/odom"];
    let mut moving = 0;
    let mut last_var = [0.0; 3];
    for (k, m) in odom.msgs.iter().enumerate() {
        let mut r = CdrReader::new(&m.data).unwrap();
        header(&mut r);
        r.string().unwrap();
        r.f64_array::<7>().unwrap();
        let pc = r.f64_array::<36>().unwrap();
        let tw = r.f64_array::<6>().unwrap();
        let tc = r.f64_array::<36>().unwrap();
        if tw[0].abs() > 0.05 {
            moving += 1;
        }
        if k > 0 {
            for (i, idx) in [0usize, 7, 35].into_iter().enumerate() {
                assert!(
                    pc[idx] >= 0.0 && tc[idx] > 0.0,
                    "message {k}: {pc:?} {tc:?}"
                );
                last_var[i] = pc[idx];
            }
            // Symmetric, and z, roll, pitch exactly known.
            assert_eq!(pc[1], pc[6]);
            assert_eq!(pc[14], 0.0);
        }
    }
    assert!(
        moving > odom.msgs.len() / 2,
        "{moving} of {}",
        odom.msgs.len()
    );
    assert!(last_var.iter().all(|&v| v > 0.0), "{last_var:?}");
    // The twist is the motion between readings: it integrates to the pose.
    let poses: Vec<[f64; 7]> = odom
        .msgs
        .iter()
        .map(|m| {
            let mut r = CdrReader::new(&m.data).unwrap();
            header(&mut r);
            r.string().unwrap();
            r.f64_array::<7>().unwrap()
        })
        .collect();
    let last = poses.last().unwrap();
    assert!(last[0].hypot(last[1]) > 0.5, "the robot drove: {last:?}");
}

#[test]
fn ground_truth_is_odometry_in_map_and_not_on_tf() {
    let gt = &bag().topics["/ground_truth"];
    assert_eq!(gt.schema, schemas::ODOMETRY);
    let f = frames(gt);
    assert!(f
        .iter()
        .all(|(_, p, c)| p == "map" && c.as_deref() == Some("base_footprint")));
    // Covariances zero (exact); the twist is the motion between scoring instants.
    let mut r = CdrReader::new(&gt.msgs[gt.msgs.len() / 2].data).unwrap();
    header(&mut r);
    r.string().unwrap();
    r.f64_array::<7>().unwrap();
    assert_eq!(r.f64_array::<36>().unwrap(), [0.0; 36]);
    let tw = r.f64_array::<6>().unwrap();
    assert!(tw[0] > 0.05, "{tw:?}");
}

#[test]
fn tf_static_is_the_urdf_tree_and_joint_states_carries_the_wheels() {
    let b = bag();
    let urdf = std::fs::read_to_string(repo().join("robots/urdf/pioneer3dx.urdf")).unwrap();
    let joints = atrium_robots::RobotModel::joint_tree(&urdf, "pioneer3dx").unwrap();
    let statics: BTreeSet<(String, String)> = frames(&b.topics["/tf_static"])
        .into_iter()
        .map(|(_, p, c)| (p, c.unwrap()))
        .collect();
    let fixed: BTreeSet<(String, String)> = joints
        .iter()
        .filter(|j| j.fixed)
        .map(|j| (j.parent.clone(), j.child.clone()))
        .collect();
    assert!(fixed.len() >= 3, "{fixed:?}");
    assert_eq!(statics, fixed, "tf_static vs the URDF's fixed joints");
    // Every child frame has exactly one parent, and no moving joint's child is static.
    let children: Vec<&String> = statics.iter().map(|x| &x.1).collect();
    let unique: BTreeSet<&String> = children.iter().copied().collect();
    assert_eq!(children.len(), unique.len());
    let js = &b.topics["/joint_states"];
    let mut r = CdrReader::new(&js.msgs.last().unwrap().data).unwrap();
    header(&mut r);
    let n = r.len(4).unwrap();
    let names: Vec<String> = (0..n).map(|_| r.string().unwrap()).collect();
    let position = r.f64_seq().unwrap();
    let velocity = r.f64_seq().unwrap();
    let moving: BTreeSet<String> = joints
        .iter()
        .filter(|j| !j.fixed)
        .map(|j| j.name.clone())
        .collect();
    assert_eq!(
        names.iter().cloned().collect::<BTreeSet<_>>(),
        moving,
        "joint_states names every moving joint"
    );
    assert_eq!((position.len(), velocity.len()), (n, n));
    for w in ["left_wheel_joint", "right_wheel_joint"] {
        let i = names.iter().position(|x| x == w).unwrap();
        // The wheels turned forward about their own axes over the drive.
        assert!(position[i].abs() > 1.0, "{w}: {}", position[i]);
    }
}

#[test]
fn laser_scans_follow_rep_117_with_their_timing() {
    let scans = &bag().topics["/scan/laser"];
    let mut inf = 0;
    let mut total = 0;
    for m in &scans.msgs {
        let mut r = CdrReader::new(&m.data).unwrap();
        header(&mut r);
        let mut v = [0f32; 7];
        for x in &mut v {
            *x = r.f32().unwrap();
        }
        let [_, _, inc, time_inc, scan_time, rmin, rmax] = v;
        assert_eq!(scan_time, 0.1f32, "1 / 10 Hz");
        assert!((time_inc - 0.1 * inc / std::f32::consts::TAU).abs() < 1e-9);
        assert!(rmin > 0.0 && rmin < rmax && rmax == 8.0);
        for x in r.f32_seq().unwrap() {
            total += 1;
            if x == f32::INFINITY {
                inf += 1;
            } else {
                assert!(x.is_finite() && x < rmax, "{x}");
            }
        }
    }
    assert!(inf > 0 && inf < total, "{inf} of {total} beams +Inf");
}

#[test]
fn map_marks_outside_the_building_unknown() {
    let map = &bag().topics["/map"];
    let mut r = CdrReader::new(&map.msgs[0].data).unwrap();
    header(&mut r);
    r.i32().unwrap();
    r.u32().unwrap();
    let res = f64::from(r.f32().unwrap());
    let w = r.u32().unwrap() as usize;
    let h = r.u32().unwrap() as usize;
    let origin = r.f64_array::<7>().unwrap();
    let cells = r.bytes().unwrap().to_vec();
    assert_eq!(cells.len(), w * h);
    let count = |v: i8| cells.iter().filter(|&&c| c as i8 == v).count();
    assert!(count(-1) > 0 && count(0) > 0 && count(100) > 0);
    assert_eq!(count(-1) + count(0) + count(100), cells.len());
    // The corners are outside; the start (2, 20) is inside and free.
    assert_eq!(cells[0] as i8, -1);
    let i = ((2.0 - origin[0]) / res) as usize;
    let j = ((20.0 - origin[1]) / res) as usize;
    assert_eq!(cells[j * w + i] as i8, 0);
}

#[test]
fn atrium_msgs_definitions_in_the_bag_are_the_package_files() {
    let dir = repo().join("ros/atrium_msgs/msg");
    let mut checked = BTreeSet::new();
    for t in bag().topics.values() {
        for (name, def) in schemas::schema_sections(&t.schema, &t.schema_text) {
            let Some(short) = name
                .strip_prefix("atrium_msgs/msg/")
                .or_else(|| name.strip_prefix("atrium_msgs/"))
            else {
                continue;
            };
            let file = std::fs::read_to_string(dir.join(format!("{short}.msg"))).unwrap();
            assert_eq!(
                def,
                schemas::msg_without_comments(&file),
                "{name} in {}",
                t.schema
            );
            checked.insert(short.to_string());
        }
    }
    for want in ["WheelOdometry", "ScoringInstant", "LaserRanges"] {
        assert!(checked.contains(want), "{checked:?}");
    }
}

#[test]
fn the_independent_rosbags_reader_agrees_where_available() {
    let Ok(python) = std::env::var("ATRIUM_ROSBAGS_PYTHON") else {
        eprintln!("ATRIUM_ROSBAGS_PYTHON not set: the rosbags check runs in CI (.ci/run)");
        return;
    };
    let b = bag();
    let out = std::process::Command::new(python)
        .arg(repo().join("scripts/check_rosbag.py"))
        .arg(&b.dir)
        .arg("--doc")
        .arg(repo().join("docs/ros2.md"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
