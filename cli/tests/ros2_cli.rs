//! `atrium record --profile ros2` writes a bag folder that `atrium replay` replays to the
//! recorded run's report; Foxglove stays the default profile; bad bags exit 2 naming what is
//! wrong.

mod common;

use common::{atrium, tmpdir};
use std::path::Path;

/// corridor_tracking cut to `secs`, written into `dir` with absolute world and robot paths.
fn short_scenario(dir: &Path, secs: f64) -> std::path::PathBuf {
    let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenarios");
    let text = std::fs::read_to_string(bundled.join("corridor_tracking.toml")).unwrap();
    let mut table: toml::Table = text.parse().unwrap();
    table.insert("duration_s".into(), toml::Value::Float(secs));
    // A short run meets no accuracy expectations: exit 0 means recorded.
    table.remove("expect");
    for key in ["world", "robot"] {
        let rel = table[key].as_str().unwrap().to_string();
        let abs = bundled.join(rel).canonicalize().unwrap();
        table.insert(key.into(), toml::Value::String(abs.display().to_string()));
    }
    let path = dir.join("short.toml");
    std::fs::write(&path, toml::to_string(&table).unwrap()).unwrap();
    path
}

fn metrics(stdout: &[u8]) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(stdout).unwrap();
    let o = v.as_object_mut().unwrap();
    for k in ["timing", "recording"] {
        o.remove(k);
    }
    v
}

#[test]
fn record_ros2_then_replay_gives_the_recorded_report() {
    let dir = tmpdir("cli-ros2");
    let scenario = short_scenario(&dir, 4.0);
    let bag = dir.join("run");
    let o = atrium(&[
        "record",
        scenario.to_str().unwrap(),
        "-o",
        bag.to_str().unwrap(),
        "--profile",
        "ros2",
        "--json",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(bag.join("metadata.yaml").is_file() && bag.join("run_0.mcap").is_file());
    let recorded = metrics(&o.stdout);
    let o = atrium(&["replay", bag.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(metrics(&o.stdout), recorded);

    // The default profile is still one Foxglove MCAP file.
    let file = dir.join("run.mcap");
    let o = atrium(&[
        "record",
        scenario.to_str().unwrap(),
        "-o",
        file.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(std::fs::read(&file).unwrap().starts_with(mcap::MAGIC));

    let o = atrium(&[
        "record",
        scenario.to_str().unwrap(),
        "-o",
        "x",
        "--profile",
        "ros1",
    ]);
    assert_eq!(o.status.code(), Some(2));
    // --tf-ground-truth is for bags (a Foxglove recording always has map -> odom).
    let o = atrium(&[
        "record",
        scenario.to_str().unwrap(),
        "-o",
        dir.join("gt.mcap").to_str().unwrap(),
        "--tf-ground-truth",
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--tf-ground-truth") && err.contains("--profile ros2"),
        "{err}"
    );
    let gt = dir.join("gt");
    let o = atrium(&[
        "record",
        scenario.to_str().unwrap(),
        "-o",
        gt.to_str().unwrap(),
        "--profile",
        "ros2",
        "--tf-ground-truth",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mcap_bytes = std::fs::read(gt.join("gt_0.mcap")).unwrap();
    let map_to_odom = mcap::MessageStream::new(&mcap_bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .filter(|m| m.channel.topic == "/tf")
        .any(|m| m.data.windows(4).any(|w| w == b"map\0"));
    assert!(map_to_odom, "the bag's /tf has no map -> odom");

    // A folder without metadata.yaml, and a bag with an unknown type: exit 2, named.
    let empty = dir.join("empty");
    std::fs::create_dir(&empty).unwrap();
    let o = atrium(&["replay", empty.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("no metadata.yaml"), "{err}");
    let yaml = std::fs::read_to_string(bag.join("metadata.yaml")).unwrap();
    std::fs::write(
        bag.join("metadata.yaml"),
        yaml.replacen(
            "sensor_msgs/msg/LaserScan",
            "sensor_msgs/msg/PointCloud2",
            1,
        ),
    )
    .unwrap();
    let o = atrium(&["replay", bag.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("topic /scan/") && err.contains("\"sensor_msgs/msg/PointCloud2\""),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
