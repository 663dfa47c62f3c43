//! Real robot logs through the command line: log scenarios on every storage the readers accept
//! (rosbag2 MCAP and sqlite3, ROS 1 bz2 and lz4, CARMEN), the bundled maps and MIT reference
//! rebuilt by the commands `datasets/README.md` gives, and bad logs, references and maps
//! refused with exit 2, the file and field named and nothing written.

mod common;

use common::{atrium, datasets, tmpdir};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A log scenario in `dir` on `log` (absolute paths), the fr079 map and reference, MCL and
/// dead reckoning, cut to `duration_s`.
fn fr079_scenario(
    dir: &Path,
    name: &str,
    log: &str,
    extra_log_keys: &str,
    duration_s: f64,
) -> PathBuf {
    let text = format!(
        r#"name = "{name}"
map = "{map}"
seed = 3
duration_s = {duration_s}

[log]
path = "{log}"
reference = "{reference}"
relations = "{relations}"
{extra_log_keys}

[initial_belief]
mode = "tracking"
sigma = [0.1, 0.1, 0.05]

[[localizers]]
name = "mcl"
kind = "mcl"

[[localizers]]
name = "odometry"
kind = "dead_reckoning"
"#,
        map = datasets("fr079/fr079_map.yaml"),
        reference = datasets("fr079/fr079_reference.tum"),
        relations = datasets("fr079/fr079.relations"),
    );
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path
}

fn run_json(scenario: &Path) -> Value {
    let o = atrium(&["run", scenario.to_str().unwrap(), "--json"]);
    assert!(
        matches!(o.status.code(), Some(0 | 1)),
        "exit {:?}: {}",
        o.status.code(),
        stderr(&o)
    );
    serde_json::from_slice(&o.stdout).unwrap()
}

fn localizer<'a>(doc: &'a Value, name: &str) -> &'a Value {
    doc["localizers"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["name"] == name)
        .unwrap_or_else(|| panic!("no localizer {name}"))
}

/// The first 60 s of fr079 from each storage give the same scans and the same run: the
/// readers agree with each other, and MCL on the real log beats its own odometry.
#[test]
fn every_storage_gives_the_same_run() {
    let dir = tmpdir("real-storages");
    let logs = [
        ("ros2_mcap", datasets("fr079/fr079_ros2")),
        ("ros1_bz2", datasets("fr079/fr079.orig.bag")),
        ("ros1_lz4", datasets("fixtures/fr079_head_lz4.bag")),
        ("ros2_sqlite3", datasets("fixtures/fr079_head_sqlite3")),
    ];
    let mut medians = Vec::new();
    for (name, log) in &logs {
        let s = fr079_scenario(&dir, name, log, "", 55.0);
        let doc = run_json(&s);
        let info = &doc["log"];
        assert!(info["scans"].as_u64().unwrap() > 250, "{name}: {info}");
        let mcl = localizer(&doc, "mcl");
        let odo = localizer(&doc, "odometry");
        let rel = &mcl["relations"];
        for key in [
            "trans_mean_m",
            "trans_std_m",
            "rot_mean_deg",
            "rot_std_deg",
            "count",
        ] {
            assert!(
                rel[key].is_number(),
                "{name}: relations.{key} missing in {rel}"
            );
        }
        assert!(rel["count"].as_u64().unwrap() > 50, "{name}: {rel}");
        let m = mcl["position_error"]["median"].as_f64().unwrap();
        let o = odo["position_error"]["median"].as_f64().unwrap();
        assert!(
            m < 0.15 && m < 0.5 * o,
            "{name}: mcl median {m}, odometry {o}"
        );
        medians.push((name, m, info["scans"].as_u64().unwrap()));
    }
    for w in medians.windows(2) {
        assert_eq!(w[0].2, w[1].2, "scan counts differ: {medians:?}");
        assert!((w[0].1 - w[1].1).abs() < 1e-9, "runs differ: {medians:?}");
    }
}

/// `atrium map reference` and `atrium map build` rebuild the bundled MIT reference and both
/// bundled maps byte for byte: what is bundled is what the commands make.
#[test]
fn bundled_maps_and_reference_are_what_the_commands_make() {
    let dir = tmpdir("real-rebuild");
    let reference = dir.join("mit.tum");
    let o = atrium(&[
        "map",
        "reference",
        &datasets("mit-csail/mit-csail.clf.gz"),
        "--relations",
        &datasets("mit-csail/mit-csail.relations"),
        "-o",
        reference.to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let summary: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(summary["relations_used"], 1172);
    // Fitted to the relations, it agrees with them far better than the held-out half says
    // it is accurate: the held-out figure is the one the scenario states.
    let fit = summary["fit"]["trans_mean_m"].as_f64().unwrap();
    let held = summary["held_out"]["trans_mean_m"].as_f64().unwrap();
    assert!(fit < held && held < 0.1, "fit {fit}, held out {held}");
    assert_eq!(
        std::fs::read(&reference).unwrap(),
        std::fs::read(datasets("mit-csail/mit-csail_reference.tum")).unwrap()
    );
    for (log, reference, bundled) in [
        (
            "mit-csail/mit-csail.clf.gz",
            "mit-csail/mit-csail_reference.tum",
            "mit-csail/mit-csail_map",
        ),
        (
            "fr079/fr079_ros2",
            "fr079/fr079_reference.tum",
            "fr079/fr079_map",
        ),
    ] {
        let yaml = dir.join("m.yaml");
        let o = atrium(&[
            "map",
            "build",
            &datasets(log),
            "--reference",
            &datasets(reference),
            "-o",
            yaml.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        assert!(
            std::fs::read(dir.join("m.pgm")).unwrap()
                == std::fs::read(datasets(&format!("{bundled}.pgm"))).unwrap(),
            "{bundled}.pgm differs from what map build makes"
        );
        let y = std::fs::read_to_string(&yaml).unwrap();
        let b = std::fs::read_to_string(datasets(&format!("{bundled}.yaml"))).unwrap();
        assert_eq!(
            y.replace("m.pgm", "X"),
            b.replace(
                &format!(
                    "{}.pgm",
                    Path::new(bundled).file_name().unwrap().to_string_lossy()
                ),
                "X"
            )
        );
    }
}

/// `atrium score` on a log scenario: an estimate file in the log's stamps (the run's own
/// `--out` trajectory) scores as the live run did.
#[test]
fn score_on_a_log_scenario_matches_the_run() {
    let dir = tmpdir("real-score");
    let s = fr079_scenario(
        &dir,
        "score",
        &datasets("fixtures/fr079_head_lz4.bag"),
        "",
        55.0,
    );
    let out = dir.join("out");
    let o = atrium(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    let live: Value = serde_json::from_slice(&o.stdout).unwrap();
    let o = atrium(&[
        "score",
        s.to_str().unwrap(),
        out.join("mcl.tum").to_str().unwrap(),
        "--json",
    ]);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{}", stderr(&o));
    let scored: Value = serde_json::from_slice(&o.stdout).unwrap();
    let a = localizer(&live, "mcl");
    let b = &scored["localizers"][0];
    let med = |v: &Value| v["position_error"]["median"].as_f64().unwrap();
    assert!((med(a) - med(b)).abs() < 1e-3, "{} vs {}", med(a), med(b));
    let rel = |v: &Value| v["relations"]["trans_mean_m"].as_f64().unwrap();
    assert!((rel(a) - rel(b)).abs() < 1e-3, "{} vs {}", rel(a), rel(b));
}

/// 181 readings of `r` m, the FLASER line's poses and its stamp.
fn flaser(kind: &str, t: f64, x: f64, r: f64) -> String {
    let ranges = vec![format!("{r}"); 181].join(" ");
    format!("{kind} 181 {ranges} {x} 0 0 {x} 0 0 {t} host {t}\n")
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

/// A scenario on `log` with the fr079 map and `reference`.
fn scenario_on(dir: &Path, log: &str, reference: &str, log_keys: &str, map: &str) -> PathBuf {
    let text = format!(
        "name = \"bad\"\nmap = \"{map}\"\n\n[log]\npath = \"{log}\"\nreference = \"{reference}\"\n{log_keys}\n\n\
         [[localizers]]\nname = \"odometry\"\nkind = \"dead_reckoning\"\n"
    );
    let p = dir.join("bad.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// Runs `scenario` with `--out`; expects exit 2, every one of `needles` in the message, and
/// no output folder.
fn refused(dir: &Path, scenario: &Path, needles: &[&str]) {
    let out = dir.join("never");
    let o = atrium(&[
        "run",
        scenario.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out.exists(), "{} was written", out.display());
}

#[test]
fn bad_logs_references_and_maps_are_refused_naming_file_and_field() {
    let dir = tmpdir("real-bad");
    let map = datasets("fr079/fr079_map.yaml");
    let tum = write(
        &dir,
        "ref.tum",
        "0 0 0 0 0 0 0 1\n1 0.1 0 0 0 0 0 1\n2 0.2 0 0 0 0 0 1\n",
    );
    let good: String = (0..3)
        .map(|k| flaser("FLASER", k as f64, 0.1 * k as f64, 2.0))
        .collect();

    // No laser topic: odometry only.
    let log = write(
        &dir,
        "odom_only.log",
        "ODOM 0 0 0 0 0 0 0 h 0\nODOM 1 0 0 0 0 0 1 h 1\n",
    );
    refused(
        &dir,
        &scenario_on(&dir, &log, &tum, "", &map),
        &[
            "bad.toml",
            "log.scan_topic",
            "no sensor_msgs/msg/LaserScan topic",
        ],
    );

    // No odometry topic: a rear laser only.
    let rear: String = (0..3)
        .map(|k| flaser("RLASER", k as f64, 0.0, 2.0))
        .collect();
    let log = write(&dir, "rear_only.log", &rear);
    refused(
        &dir,
        &scenario_on(&dir, &log, &tum, "", &map),
        &["log.odom_topic", "no nav_msgs/msg/Odometry topic"],
    );

    // Two laser topics and no choice; then the choice works past that point.
    let both = format!("{good}{rear}");
    let log = write(&dir, "two_lasers.log", &both);
    refused(
        &dir,
        &scenario_on(&dir, &log, &tum, "", &map),
        &["log.scan_topic", "/rear_scan", "/scan", "name one"],
    );

    // A topic of the wrong type.
    let log = write(&dir, "good.log", &good);
    refused(
        &dir,
        &scenario_on(&dir, &log, &tum, "scan_topic = \"/odom\"", &map),
        &["log.scan_topic", "/odom", "not sensor_msgs/msg/LaserScan"],
    );
    refused(
        &dir,
        &scenario_on(&dir, &log, &tum, "odom_topic = \"/nowhere\"", &map),
        &["log.odom_topic", "/nowhere"],
    );

    // A reference that does not overlap the log.
    let late = write(&dir, "late.tum", "5000 0 0 0 0 0 0 1\n5001 0 0 0 0 0 0 1\n");
    refused(
        &dir,
        &scenario_on(&dir, &log, &late, "", &map),
        &["log.reference", "does not overlap"],
    );

    // Repeated and unsorted stamps.
    let repeated = format!(
        "{}{}",
        flaser("FLASER", 0.0, 0.0, 2.0),
        flaser("FLASER", 0.0, 0.1, 2.0)
    );
    let log2 = write(&dir, "repeated.log", &repeated);
    refused(
        &dir,
        &scenario_on(&dir, &log2, &tum, "", &map),
        &["repeated.log", "/scan", "repeats"],
    );
    let unsorted = format!(
        "{}{}",
        flaser("FLASER", 1.0, 0.0, 2.0),
        flaser("FLASER", 0.5, 0.1, 2.0)
    );
    let log2 = write(&dir, "unsorted.log", &unsorted);
    refused(
        &dir,
        &scenario_on(&dir, &log2, &tum, "", &map),
        &["unsorted.log", "comes before"],
    );

    // A map naming a missing image, and an impossible resolution.
    let bad_map = write(&dir, "missing.yaml", "image: nowhere.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n");
    refused(
        &dir,
        &scenario_on(&dir, &log, &tum, "", &bad_map),
        &["missing.yaml", "nowhere.pgm"],
    );
    let map_text = std::fs::read_to_string(&map)
        .unwrap()
        .replace("resolution: 0.05", "resolution: -1");
    std::fs::copy(datasets("fr079/fr079_map.pgm"), dir.join("fr079_map.pgm")).unwrap();
    let neg = write(
        &dir,
        "neg.yaml",
        &map_text.replace("\"fr079_map.pgm\"", "fr079_map.pgm"),
    );
    refused(
        &dir,
        &scenario_on(&dir, &log, &tum, "", &neg),
        &["neg.yaml", "resolution"],
    );

    // Truncated logs: a ROS 1 bag, a rosbag2 MCAP, a gzipped CARMEN log.
    let cut = |src: &str, dst: &Path| {
        let bytes = std::fs::read(src).unwrap();
        std::fs::write(dst, &bytes[..bytes.len() / 2]).unwrap();
    };
    let bag = dir.join("cut.bag");
    cut(&datasets("fixtures/fr079_head_lz4.bag"), &bag);
    refused(
        &dir,
        &scenario_on(&dir, bag.to_str().unwrap(), &tum, "", &map),
        &["cut.bag"],
    );
    let ros2 = dir.join("cut_ros2");
    std::fs::create_dir_all(&ros2).unwrap();
    std::fs::copy(
        datasets("fr079/fr079_ros2/metadata.yaml"),
        ros2.join("metadata.yaml"),
    )
    .unwrap();
    cut(
        &datasets("fr079/fr079_ros2/fr079_ros2.mcap"),
        &ros2.join("fr079_ros2.mcap"),
    );
    refused(
        &dir,
        &scenario_on(&dir, ros2.to_str().unwrap(), &tum, "", &map),
        &["fr079_ros2.mcap"],
    );
    let gz = dir.join("cut.clf.gz");
    cut(&datasets("mit-csail/mit-csail.clf.gz"), &gz);
    refused(
        &dir,
        &scenario_on(&dir, gz.to_str().unwrap(), &tum, "", &map),
        &["cut.clf.gz"],
    );
}

/// `atrium map build` refuses what it cannot use and writes nothing.
#[test]
fn map_build_refuses_bad_flags_without_writing() {
    let dir = tmpdir("real-mapbad");
    let yaml = dir.join("m.yaml");
    for (args, needle) in [
        (vec!["--resolution", "0"], "--resolution"),
        (vec!["--scan-topic", "/odom"], "--scan-topic"),
        (vec!["--max-range=-3"], "--max-range"),
    ] {
        let mut all = vec![
            "map".to_string(),
            "build".into(),
            datasets("fixtures/fr079_head_lz4.bag"),
            "--reference".into(),
            datasets("fr079/fr079_reference.tum"),
            "-o".into(),
            yaml.to_string_lossy().into_owned(),
        ];
        all.extend(args.iter().map(|s| s.to_string()));
        let refs: Vec<&str> = all.iter().map(|s| s.as_str()).collect();
        let o = atrium(&refs);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!yaml.exists() && !dir.join("m.pgm").exists());
    }
}

/// A sweep over a log scenario's `[log]` keys: a laser mount 0.5 m off makes MCL worse than
/// the log's own mount, cell by cell in the sweep's CSV.
#[test]
fn sweeps_take_log_axes() {
    let dir = tmpdir("real-sweep");
    let base = fr079_scenario(
        &dir,
        "base",
        &datasets("fixtures/fr079_head_lz4.bag"),
        "",
        55.0,
    );
    let sweep = dir.join("sweep.toml");
    std::fs::write(
        &sweep,
        format!(
            "base = \"{}\"\nseed = 2\ntrials = 1\n[axes]\n\"log.laser_mount\" = [[0.04, 0.0, 0.0], [0.54, 0.0, 0.0]]\n",
            base.display()
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let o = atrium(&[
        "sweep",
        sweep.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("results.csv")).unwrap();
    let median = |mount: &str| -> f64 {
        let line = csv
            .lines()
            .find(|l| l.contains(mount) && l.contains(",mcl,"))
            .unwrap_or_else(|| panic!("no mcl row for {mount} in {csv}"));
        // The mount is quoted (it has commas): take the fields after it.
        let after = line.split('"').nth(2).unwrap();
        let fields: Vec<&str> = after.split(',').collect();
        // ,cell,trial,seed,localizer,min_m,median_m
        fields[6].parse().unwrap()
    };
    let good = median("[0.04, 0.0, 0.0]");
    let off = median("[0.54, 0.0, 0.0]");
    assert!(
        off > 1.5 * good,
        "mount off by 0.5 m: {off}, right mount: {good}"
    );
}
