//! The robot log readers on the bundled real logs: fr079 as a ROS 1 bag (bz2 chunks), its
//! first minute as a ROS 1 bag with lz4 chunks and as a rosbag2 folder with sqlite3 storage
//! (both written by the Python `rosbags` package), the whole log as a rosbag2 folder with
//! MCAP storage, and the MIT CSAIL CARMEN log (gzipped).

use atrium_formats::robot_log::{LogKind, RobotLog, TopicInfo};
use atrium_formats::ros_msgs::{yaw_of, LaserScanMsg, MessageKind, OdometryMsg};
use std::path::{Path, PathBuf};

fn data(rel: &str) -> PathBuf {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../datasets")).join(rel)
}

const ROS1: &str = "fr079/fr079.orig.bag";
const ROS1_LZ4: &str = "fixtures/fr079_head_lz4.bag";
const MCAP: &str = "fr079/fr079_ros2";
const SQLITE: &str = "fixtures/fr079_head_sqlite3";
const MIT: &str = "mit-csail/mit-csail.clf.gz";

fn open(rel: &str) -> RobotLog {
    RobotLog::open(&data(rel)).unwrap()
}

fn topic(name: &str, ty: &str, count: u64) -> TopicInfo {
    TopicInfo {
        name: name.into(),
        msg_type: ty.into(),
        count,
    }
}

fn fr079_topics(scans: u64, odom: u64) -> Vec<TopicInfo> {
    vec![
        topic("/odom", "nav_msgs/msg/Odometry", odom),
        topic("/scan", "sensor_msgs/msg/LaserScan", scans),
        topic("/tf", "tf2_msgs/msg/TFMessage", odom),
        topic("/tf_static", "tf2_msgs/msg/TFMessage", 1),
    ]
}

#[test]
fn topic_lists_and_counts() {
    let whole = fr079_topics(4934, 8951);
    let head = fr079_topics(279, 504);
    for (rel, kind, want) in [
        (ROS1, LogKind::Ros1, &whole),
        (MCAP, LogKind::Rosbag2, &whole),
        (ROS1_LZ4, LogKind::Ros1, &head),
        (SQLITE, LogKind::Rosbag2, &head),
    ] {
        let log = open(rel);
        assert_eq!(log.kind(), kind, "{rel}");
        assert_eq!(log.topics(), &want[..], "{rel}");
        let scans = log.topics_of_type(MessageKind::LaserScan);
        assert_eq!(scans.len(), 1);
        assert_eq!(scans[0].name, "/scan");
    }
    let mit = open(MIT);
    assert_eq!(mit.kind(), LogKind::Carmen);
    assert_eq!(
        mit.topics(),
        &[
            topic("/odom", "nav_msgs/msg/Odometry", 1988),
            topic("/scan", "sensor_msgs/msg/LaserScan", 1988),
            topic("/tf_static", "tf2_msgs/msg/TFMessage", 1),
        ]
    );
    // The metadata file itself opens its folder.
    let log = RobotLog::open(&data(MCAP).join("metadata.yaml")).unwrap();
    assert_eq!(log.topics(), &whole[..]);
}

fn check_first_scan(s: &LaserScanMsg) {
    assert_eq!(s.header.frame_id, "laser");
    assert_eq!(s.ranges.len(), 360);
    assert_eq!(s.angle_min, f64::from(-std::f32::consts::FRAC_PI_2));
    assert_eq!(s.angle_increment, f64::from(0.008_750_955_f32));
    assert_eq!((s.range_min, s.range_max), (f64::from(0.1f32), 80.0));
    assert!(
        (s.header.stamp - 1211.52).abs() < 0.01,
        "{}",
        s.header.stamp
    );
    assert_eq!(s.ranges.iter().cloned().fold(0f32, f32::max), 12.43);
    assert!(s.ranges.iter().all(|r| r.is_finite() && *r >= 0.0));
}

fn check_first_odometry(o: &OdometryMsg) {
    assert_eq!(
        (o.header.frame_id.as_str(), o.child_frame_id.as_str()),
        ("odom", "base_link")
    );
    assert_eq!((o.position[0], o.position[1]), (-3.034287, 8.291214));
    assert_eq!(o.orientation[2], -0.999946812959906);
    assert_eq!(o.orientation[3], 0.010313643940275164);
    let yaw = yaw_of(o.orientation);
    assert!(
        (yaw - (-std::f64::consts::PI + 0.020627)).abs() < 1e-5,
        "{yaw}"
    );
}

#[test]
fn all_four_fr079_readings_agree_over_the_first_minute() {
    let logs: Vec<(&str, RobotLog)> = [ROS1, ROS1_LZ4, MCAP, SQLITE]
        .into_iter()
        .map(|r| (r, open(r)))
        .collect();
    let scans: Vec<Vec<LaserScanMsg>> = logs
        .iter()
        .map(|(_, l)| l.scans("/scan").unwrap())
        .collect();
    let odom: Vec<Vec<OdometryMsg>> = logs
        .iter()
        .map(|(_, l)| l.odometry("/odom").unwrap())
        .collect();
    assert_eq!((scans[0].len(), scans[2].len()), (4934, 4934));
    assert_eq!((scans[1].len(), scans[3].len()), (279, 279));
    assert_eq!(
        (odom[0].len(), odom[2].len(), odom[1].len(), odom[3].len()),
        (8951, 8951, 504, 504)
    );
    check_first_scan(&scans[0][0]);
    check_first_odometry(&odom[0][0]);
    // No-return readings are logged as 81.91 m, beyond range_max: none in the first scan,
    // 36,881 in 2,932 of the 4,934 scans.
    let over: Vec<usize> = scans[0]
        .iter()
        .map(|s| {
            s.ranges
                .iter()
                .filter(|&&r| f64::from(r) > s.range_max)
                .count()
        })
        .collect();
    assert_eq!(over.iter().sum::<usize>(), 36_881);
    assert_eq!(over.iter().filter(|&&c| c > 0).count(), 2_932);
    // Header stamps never go backwards in fr079, in either stream.
    assert!(scans[0]
        .windows(2)
        .all(|w| w[0].header.stamp <= w[1].header.stamp));
    assert!(odom[0]
        .windows(2)
        .all(|w| w[0].header.stamp <= w[1].header.stamp));
    let n = scans[1].len();
    let m = odom[1].len();
    for k in 1..4 {
        // Identical values and stamps, bit for bit.
        assert_eq!(&scans[k][..n], &scans[0][..n], "{}", logs[k].0);
        assert_eq!(&odom[k][..m], &odom[0][..m], "{}", logs[k].0);
    }
    assert_eq!(scans[2], scans[0]);
    assert_eq!(odom[2], odom[0]);
    // Odometry as poses.
    let poses = logs[3].1.poses("/odom").unwrap();
    assert_eq!(poses.len(), 504);
    assert_eq!(poses[0].position, odom[0][0].position);
    assert_eq!(poses[0].covariance, Some(odom[0][0].pose_covariance));
}

#[test]
fn tf_static_holds_the_laser_mount() {
    for rel in [ROS1, ROS1_LZ4, MCAP, SQLITE] {
        let t = open(rel).static_transforms().unwrap();
        assert_eq!(t.len(), 1, "{rel}");
        assert_eq!(t[0].header.frame_id, "base_link");
        assert_eq!(t[0].child_frame_id, "laser");
        assert_eq!(t[0].translation, [0.04, 0.0, 0.0], "{rel}");
    }
    let tf = open(SQLITE).transforms("/tf").unwrap();
    assert_eq!(tf.len(), 504);
    let mit = open(MIT).static_transforms().unwrap();
    assert_eq!(
        (mit[0].child_frame_id.as_str(), mit[0].translation),
        ("laser", [0.0; 3])
    );
}

#[test]
fn the_mit_carmen_log() {
    let log = open(MIT);
    let scans = log.scans("/scan").unwrap();
    assert_eq!(scans.len(), 1988);
    assert!(scans.iter().all(|s| s.ranges.len() == 361));
    let no_return: usize = scans
        .iter()
        .map(|s| s.ranges.iter().filter(|r| r.is_infinite()).count())
        .sum();
    assert_eq!(no_return, 23_711);
    assert_eq!(
        scans[0].ranges.iter().filter(|r| r.is_infinite()).count(),
        75
    );
    let s = &scans[0];
    assert_eq!(s.header.stamp, 1134864629.895182);
    assert_eq!(
        (s.angle_min, s.range_max),
        (-std::f64::consts::FRAC_PI_2, 81.9)
    );
    assert!((s.angle_max - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    let odom = log.odometry("/odom").unwrap();
    assert_eq!(odom.len(), 1988);
    assert_eq!(
        (odom[0].position[0], odom[0].position[1]),
        (576.536523, 0.106594)
    );
    assert!((yaw_of(odom[0].orientation) - -2.255213).abs() < 1e-12);
    let c = log.carmen().unwrap();
    assert_eq!(
        c.front_mount.source,
        atrium_formats::carmen::MountSource::Zero
    );
}

#[test]
fn wrong_topics_and_paths_are_errors_naming_them() {
    let log = open(SQLITE);
    let e = log.scans("/odom").unwrap_err().to_string();
    assert!(
        e.contains("topic /odom: is of type nav_msgs/msg/Odometry, not sensor_msgs/msg/LaserScan"),
        "{e}"
    );
    let e = log.poses("/scan").unwrap_err().to_string();
    assert!(
        e.contains("is of type sensor_msgs/msg/LaserScan, not geometry_msgs/msg/PoseStamped or"),
        "{e}"
    );
    let e = open(ROS1).odometry("/nope").unwrap_err().to_string();
    assert!(
        e.contains("topic /nope: the log has no such topic (it has /odom, /scan, /tf, /tf_static)"),
        "{e}"
    );
    let e = open(MIT).scans("/rear_scan").unwrap_err().to_string();
    assert!(e.contains("no such topic"), "{e}");

    let missing = data("no/such/log.bag");
    let e = RobotLog::open(&missing).unwrap_err().to_string();
    assert!(
        e.contains("no/such/log.bag") && e.contains("cannot read"),
        "{e}"
    );
    // A folder without metadata.yaml, a bare MCAP file, a file of no log kind.
    let e = RobotLog::open(&data("fr079")).unwrap_err().to_string();
    assert!(e.contains("holds no metadata.yaml"), "{e}");
    let e = RobotLog::open(&data(MCAP).join("fr079_ros2.mcap"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("an MCAP file: open the rosbag2 folder"), "{e}");
    let e = RobotLog::open(&data("fr079/fr079_reference.tum"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("fr079_reference.tum: line 2: starts with \"1211.720330\"")
            && e.contains("not a CARMEN log"),
        "{e}"
    );
}

/// A scratch copy of a log (a file or a folder) whose `file` is replaced by `bytes`.
fn damaged_copy(rel: &str, file: Option<&str>, bytes: &[u8], tag: &str) -> PathBuf {
    let src = data(rel);
    let dir = std::env::temp_dir().join(format!("atrium-robot-log-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    match file {
        None => {
            let p = dir.join(src.file_name().unwrap());
            std::fs::write(&p, bytes).unwrap();
            p
        }
        Some(name) => {
            let bag = dir.join("bag");
            std::fs::create_dir_all(&bag).unwrap();
            for e in std::fs::read_dir(&src).unwrap() {
                let e = e.unwrap();
                std::fs::copy(e.path(), bag.join(e.file_name())).unwrap();
            }
            std::fs::write(bag.join(name), bytes).unwrap();
            bag
        }
    }
}

/// Everything a caller reads, or the first error.
fn read_all(path: &Path) -> Result<(usize, usize), atrium_formats::FormatError> {
    let log = RobotLog::open(path)?;
    let scans = log.scans("/scan")?.len();
    let odom = log.odometry("/odom")?.len();
    log.static_transforms()?;
    Ok((scans, odom))
}

#[test]
fn truncated_and_flipped_real_files_never_panic_nor_read_short() {
    let cases: [(&str, Option<&str>); 5] = [
        (ROS1, None),
        (ROS1_LZ4, None),
        (MCAP, Some("fr079_ros2.mcap")),
        (SQLITE, Some("fr079_head_sqlite3.db3")),
        (MIT, None),
    ];
    for (rel, file) in cases {
        let src = match file {
            Some(f) => data(rel).join(f),
            None => data(rel),
        };
        let good = std::fs::read(&src).unwrap();
        let whole = read_all(&data(rel)).unwrap();
        let len = good.len();
        for cut in [0, 1, 16, 600, 4200, len / 7, len / 2, len - 1000, len - 1] {
            let p = damaged_copy(rel, file, &good[..cut], "cut");
            match read_all(&p) {
                Err(e) => assert!(
                    e.to_string().contains(p.to_str().unwrap()),
                    "{rel} cut at {cut}: {e}"
                ),
                // Only bytes nothing needs were cut (SQLite's last page's unused tail).
                Ok(n) => assert_eq!(n, whole, "{rel} cut at {cut}"),
            }
        }
        for k in [len / 5, len / 3, len / 2, 4 * len / 5] {
            let mut b = good.clone();
            for x in &mut b[k..k + 32] {
                *x ^= 0x3c;
            }
            let p = damaged_copy(rel, file, &b, "flip");
            // SQLite has no checksums and a CARMEN log none at all: a flip may read, but
            // never as fewer messages than the log holds without an error.
            if let Ok(n) = read_all(&p) {
                assert_eq!(n, whole, "{rel} flipped at {k}");
            }
        }
        let _ = std::fs::remove_dir_all(
            std::env::temp_dir().join(format!("atrium-robot-log-{}-cut", std::process::id())),
        );
        let _ = std::fs::remove_dir_all(
            std::env::temp_dir().join(format!("atrium-robot-log-{}-flip", std::process::id())),
        );
    }
}

/// The whole ROS 1 bag (bz2 chunks) reads: every scan, odometry and /tf message and the
/// static mount. How long it takes is measured by `atrium bench ros1_bag`, not here.
#[test]
fn the_whole_ros1_bag_reads() {
    let log = open(ROS1);
    let scans = log.scans("/scan").unwrap();
    let odom = log.odometry("/odom").unwrap();
    let tf = log.transforms("/tf").unwrap();
    let mount = log.static_transforms().unwrap();
    assert_eq!(
        (scans.len(), odom.len(), tf.len(), mount.len()),
        (4934, 8951, 8951, 1)
    );
}
