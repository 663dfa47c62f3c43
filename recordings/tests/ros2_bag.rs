//! ROS 2 recordings (`dataset::ros2`): a bag replays to exactly the live run's metrics, every
//! reading variant survives the round trip, `score` reads a bag's estimates, and bad bags are
//! refused naming what is wrong (no metadata.yaml, an unknown message type on a topic).

mod common;

use atrium_localization::{Estimate, Localizer, LocalizerError, OdometryDelta};
use atrium_recordings::replay::{replay_scenario, Recording};
use atrium_recordings::ros2::{self, Ros2Recorder};
use atrium_recordings::{self as dataset, ReplayOptions};
use atrium_robots::{
    DepthImage, DisparityImage, IntensityImage, LandmarkDetection, LandmarkDetections, LaserScan,
    Mount3, Pose2, Reading, WheelOdometry, WifiReading, WifiScan,
};
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::runner::{ReadingStream, StreamSummary, Tick};
use atrium_scenarios::scenario::LocalizerSpec;
use atrium_scenarios::{
    report, run_scenario, BuildContext, LocalizerRegistry, RunOptions, Scenario,
};
use common::tmpdir;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

fn bundled_short(name: &str, duration_s: f64) -> Scenario {
    let path = atrium_scenarios::bundled_scenarios_dir().join(format!("{name}.toml"));
    let text = std::fs::read_to_string(&path).unwrap();
    let mut table: toml::Table = text.parse().unwrap();
    table.insert("duration_s".into(), toml::Value::Float(duration_s));
    Scenario::from_toml_str(&toml::to_string(&table).unwrap(), &path).unwrap()
}

fn results(r: &atrium_scenarios::RunResult) -> serde_json::Value {
    let mut v = report::to_json(r);
    v.as_object_mut().unwrap().remove("timing");
    v
}

fn record(scenario: &Scenario, dir: &Path) -> dataset::Recorded {
    ros2::record_ros2(
        &LocalizerRegistry::with_builtins(),
        scenario,
        dir,
        RunOptions::default(),
    )
    .unwrap()
}

#[test]
fn a_bag_replays_to_exactly_the_live_run() {
    // An event (kidnapping at 8 s), two localizers with random injection; and the depth
    // camera scenario (laser, depth images, WiFi) for the image path.
    for (name, secs) in [("kidnapped", 12.0), ("cgr_corridor", 6.0)] {
        let scenario = bundled_short(name, secs);
        let live = run_scenario(&scenario, RunOptions::default()).unwrap();
        let dir = tmpdir(&format!("ros2-replay-{name}"));
        let bag = dir.join("bag");
        let rec = record(&scenario, &bag);
        assert_eq!(
            results(&rec.run),
            results(&live),
            "{name}: recording changed the run"
        );
        // The folder holds the bag only; no partial folder is left beside it.
        let mut names: Vec<String> = std::fs::read_dir(&bag)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["bag_0.mcap", "metadata.yaml"]);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);

        let replayed = dataset::replay(&bag, ReplayOptions::default()).unwrap();
        assert_eq!(results(&replayed.run), results(&live), "{name}");
        assert_eq!(replayed.run.events, live.events);
        assert_eq!(replayed.run.ground_truth, live.ground_truth);
        for (a, b) in replayed.run.localizers.iter().zip(&live.localizers) {
            assert_eq!(a.samples, b.samples, "{name}: {}", a.name);
            assert_eq!(a.trajectory, b.trajectory, "{name}: {}", a.name);
        }
        if name == "kidnapped" {
            assert!(!live.events.is_empty());
            // `score` reads the bag as the recording and one of its estimate topics as the
            // estimates: stamped at the scoring instants, with x, y exact, so the position
            // errors are the live run's.
            // (odometry: mcl's expectations name a baseline a score does not run)
            let l = live
                .localizers
                .iter()
                .find(|l| l.name == "odometry")
                .unwrap();
            let scored = atrium_recordings::score::score(
                &bag,
                &bag,
                atrium_recordings::score::ScoreOptions {
                    topic: Some(format!("/estimate/{}", l.name)),
                    ..Default::default()
                },
            )
            .unwrap();
            assert_eq!(scored.coverage.covered_fraction, 1.0);
            let errors = |s: &[atrium_scenarios::metrics::Sample]| -> Vec<f64> {
                s.iter().map(|x| x.position_error).collect()
            };
            assert_eq!(
                errors(&scored.run.localizers[0].samples),
                errors(&l.samples)
            );
        } else {
            let topics: Vec<String> = replayed.topics.iter().map(|t| t.0.clone()).collect();
            for t in [
                "/depth/kinect",
                "/depth/kinect/camera_info",
                "/map",
                "/tf_static",
            ] {
                assert!(topics.iter().any(|x| x == t), "{t} missing: {topics:?}");
            }
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

#[test]
fn a_bag_replays_from_standard_topics_alone_close_to_the_live_run() {
    // Without Atrium's exact side channels (a bag from elsewhere), replay reads /odom,
    // /ground_truth and the float32 ranges: the same run up to float32 rounding.
    let scenario = bundled_short("corridor_tracking", 8.0);
    let dir = tmpdir("ros2-standard");
    let bag = dir.join("bag");
    let rec = record(&scenario, &bag);
    let stripped = dir.join("stripped");
    strip_topics(
        &bag,
        &stripped,
        &["/odom/wheels", "/atrium/score", "/atrium/ranges/"],
    );
    let r = Recording::open(&stripped).unwrap();
    assert_eq!(r.message_count("/odom/wheels"), 0);
    let replayed = dataset::replay(&stripped, ReplayOptions::default()).unwrap();
    assert_eq!(replayed.run.ground_truth.len(), rec.run.ground_truth.len());
    for ((ta, a), (tb, b)) in replayed.run.ground_truth.iter().zip(&rec.run.ground_truth) {
        assert_eq!(ta, tb);
        assert!(a.distance(b) < 1e-9 && (a.theta - b.theta).abs() < 1e-9);
    }
    let (a, b) = (&replayed.run.localizers[0], &rec.run.localizers[0]);
    let med = |samples: &[atrium_scenarios::metrics::Sample]| {
        let mut e: Vec<f64> = samples.iter().map(|s| s.position_error).collect();
        e.sort_by(f64::total_cmp);
        e[e.len() / 2]
    };
    let (ma, mb) = (med(&a.samples), med(&b.samples));
    assert!((ma - mb).abs() < 0.02, "{ma} vs {mb}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Copies the bag at `from` to `to` without the topics starting with any of `drop`
/// (metadata.yaml rewritten to match).
fn strip_topics(from: &Path, to: &Path, drop: &[&str]) {
    std::fs::create_dir_all(to).unwrap();
    let bytes = std::fs::read(from.join("bag_0.mcap")).unwrap();
    let file = std::fs::File::create(to.join("bag_0.mcap")).unwrap();
    let mut w = mcap::WriteOptions::new()
        .profile("ros2")
        .create(std::io::BufWriter::new(file))
        .unwrap();
    let mut ids = std::collections::HashMap::new();
    let mut kept = Vec::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if drop.iter().any(|d| m.channel.topic.starts_with(d)) {
            continue;
        }
        let id = *ids.entry(m.channel.topic.clone()).or_insert_with(|| {
            let s = m.channel.schema.as_ref().unwrap();
            let sid = w.add_schema(&s.name, &s.encoding, &s.data).unwrap();
            kept.push((m.channel.topic.clone(), s.name.clone()));
            w.add_channel(sid, &m.channel.topic, "cdr", &m.channel.metadata)
                .unwrap()
        });
        w.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: id,
                sequence: m.sequence,
                log_time: m.log_time,
                publish_time: m.publish_time,
            },
            &m.data,
        )
        .unwrap();
    }
    for name in ["atrium", "atrium.summary"] {
        // The metadata records, copied so replay finds the scenario.
        let md = read_metadata(&bytes, name);
        w.write_metadata(&mcap::records::Metadata {
            name: name.into(),
            metadata: md,
        })
        .unwrap();
    }
    w.finish().unwrap();
    let yaml = std::fs::read_to_string(from.join("metadata.yaml")).unwrap();
    let mut out = String::new();
    let mut skip = false;
    for line in yaml.lines() {
        if line.starts_with("    - topic_metadata:") {
            skip = false;
        }
        if let Some(name) = line.trim().strip_prefix("name: ") {
            if drop.iter().any(|d| name.starts_with(d)) {
                skip = true;
                // Remove the `- topic_metadata:` line already written.
                let cut = out.trim_end_matches('\n').rfind('\n').unwrap();
                out.truncate(cut + 1);
                continue;
            }
        }
        if skip && line.starts_with("      ") {
            continue;
        }
        skip = false;
        out.push_str(line);
        out.push('\n');
    }
    std::fs::write(to.join("metadata.yaml"), out).unwrap();
    assert!(!kept.is_empty());
}

fn read_metadata(bytes: &[u8], name: &str) -> std::collections::BTreeMap<String, String> {
    for r in mcap::read::LinearReader::new(bytes).unwrap() {
        if let mcap::records::Record::Metadata(m) = r.unwrap() {
            if m.name == name {
                return m.metadata;
            }
        }
    }
    panic!("no metadata {name}");
}

/// A stream of hand-built instants with every reading variant.
struct VecStream(std::vec::IntoIter<(Tick, Vec<Reading>)>);

impl ReadingStream for VecStream {
    fn next(&mut self, out: &mut Vec<Reading>) -> Result<Option<Tick>, ScenarioError> {
        out.clear();
        Ok(self.0.next().map(|(t, r)| {
            out.extend(r);
            t
        }))
    }
    fn summary(&self) -> StreamSummary {
        StreamSummary::default()
    }
}

fn readings_at(k: u64) -> Vec<Reading> {
    let t = k as f64 / 200.0;
    let mount = Mount3 {
        xyz: [0.1, 0.02, 0.5],
        rpy: [0.0, 0.2, 0.0],
    };
    vec![
        Reading::Odometry(WheelOdometry {
            stamp: t,
            pose: Pose2::new(2.0 + 0.001 * k as f64, 20.0, 0.1 / 3.0 * k as f64),
            left_ticks: 3 * k as i64,
            right_ticks: 5 * k as i64 - 7,
        }),
        Reading::Laser(LaserScan {
            stamp: t,
            sensor: "laser".into(),
            mount: Pose2::new(0.13, 0.0, 0.0),
            angle_min: -std::f64::consts::FRAC_PI_2,
            angle_increment: std::f64::consts::PI / 180.0,
            range_min: 0.0,
            range_max: 8.0,
            ranges: (0..181)
                .map(|i| 1.0 / (1.0 + i as f64) + k as f64)
                .collect(),
        }),
        Reading::Depth(DepthImage {
            stamp: t,
            sensor: "kinect".into(),
            mount,
            width: 4,
            height: 3,
            fx: 140.0,
            fy: 141.0,
            cx: 1.5,
            cy: 1.0,
            depth: (0..12)
                .map(|i| {
                    if i % 5 == 0 {
                        0.0
                    } else {
                        0.8 + i as f32 / 7.0
                    }
                })
                .collect(),
        }),
        Reading::Intensity(IntensityImage {
            stamp: t,
            sensor: "stereo".into(),
            mount,
            width: 5,
            height: 2,
            fx: 100.0 / 3.0,
            fy: 100.0 / 3.0,
            cx: 2.0,
            cy: 0.5,
            pixels: (0..10)
                .map(|i| ((i * 25 + k as usize) % 256) as f32 / 255.0)
                .collect(),
        }),
        Reading::Disparity(DisparityImage {
            stamp: t,
            sensor: "stereo".into(),
            width: 5,
            height: 2,
            fx: 100.0 / 3.0,
            baseline: 0.09,
            disparity: (0..10)
                .map(|i| if i % 3 == 0 { f32::NAN } else { i as f32 * 0.7 })
                .collect(),
        }),
        Reading::Wifi(WifiScan {
            stamp: t,
            sensor: "wifi".into(),
            readings: vec![
                WifiReading {
                    ap: "ap-atrium".into(),
                    channel: 6,
                    rssi_dbm: -61.0 - k as f64,
                },
                WifiReading {
                    ap: "ap-office".into(),
                    channel: 11,
                    rssi_dbm: -77.0,
                },
            ],
        }),
        Reading::Landmarks(LandmarkDetections {
            stamp: t,
            sensor: "pillars".into(),
            mount: Pose2::new(0.1, 0.0, 0.0),
            detections: vec![
                LandmarkDetection {
                    range: 3.25,
                    bearing: -0.4 / 3.0,
                    id: Some(4),
                },
                LandmarkDetection {
                    range: 7.5,
                    bearing: 1.0,
                    id: None,
                },
            ],
        }),
    ]
}

/// A localizer that keeps every reading it is given.
struct Probe(Arc<Mutex<Vec<Reading>>>);

impl Localizer for Probe {
    fn name(&self) -> &str {
        "probe"
    }
    fn predict(&mut self, _: &OdometryDelta) -> Result<(), LocalizerError> {
        Ok(())
    }
    fn update(&mut self, r: &Reading) -> Result<(), LocalizerError> {
        self.0.lock().unwrap().push(r.clone());
        Ok(())
    }
    fn estimate(&self) -> Estimate {
        Estimate {
            stamp: 0.0,
            pose: Pose2::new(1.0, 2.0, 0.5),
            covariance: nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(0.04, 0.09, 0.01)),
        }
    }
}

fn probe_registry(seen: &Arc<Mutex<Vec<Reading>>>) -> LocalizerRegistry {
    let mut reg = LocalizerRegistry::empty();
    let seen = seen.clone();
    reg.register("probe", move |_: &mut BuildContext| {
        Ok(Box::new(Probe(seen.clone())) as Box<dyn Localizer>)
    })
    .unwrap();
    reg
}

/// Records four hand-built instants with every reading variant to a bag in `dir`; returns the
/// bag, the scenario and what the probe saw live.
fn hand_built_bag(dir: &Path) -> (PathBuf, Scenario, Vec<Reading>) {
    let path = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let mut scenario = Scenario::load(&path).unwrap();
    scenario.localizers = vec![LocalizerSpec {
        name: "probe".into(),
        kind: "probe".into(),
        params: toml::Table::new(),
    }];
    scenario.expect = toml::Table::new();
    let ticks: Vec<(Tick, Vec<Reading>)> = (1..=4u64)
        .map(|k| {
            let tick = Tick {
                t: k as f64 / 200.0,
                truth: Some(Pose2::new(2.0, 20.0, 0.01 * k as f64)),
                score: k % 2 == 0,
                events: Vec::new(),
            };
            (tick, readings_at(k))
        })
        .collect();
    let bag = dir.join("all");
    let seen = Arc::new(Mutex::new(Vec::new()));
    let mut recorder = Ros2Recorder::create(&bag, &scenario, 9).unwrap();
    let run = probe_registry(&seen)
        .run_stream(
            &scenario,
            9,
            &mut VecStream(ticks.into_iter()),
            &[],
            RunOptions {
                observer: Some(&mut recorder),
                ..Default::default()
            },
        )
        .unwrap();
    recorder.finish(&run).unwrap();
    let live = seen.lock().unwrap().clone();
    (bag, scenario, live)
}

#[test]
fn every_reading_variant_round_trips_exactly() {
    let dir = tmpdir("ros2-variants");
    let (bag, scenario, live) = hand_built_bag(&dir);
    assert!(live.len() >= 4 * 6, "{}", live.len());
    let rec = Recording::open(&bag).unwrap();
    for t in [
        "/scan/laser",
        "/atrium/ranges/laser",
        "/depth/kinect",
        "/image/stereo",
        "/image/stereo/camera_info",
        "/disparity/stereo",
        "/wifi/wifi",
        "/landmarks/pillars",
        "/estimate/probe",
    ] {
        assert!(
            rec.message_count(t) > 0,
            "{t} missing from {:?}",
            rec.topics()
        );
    }
    let seen = Arc::new(Mutex::new(Vec::new()));
    let replayed =
        replay_scenario(&rec, scenario, Some(&probe_registry(&seen)), None, None).unwrap();
    let got = seen.lock().unwrap().clone();
    // NaN disparities compare unequal: compare the printed values (NaN prints as NaN).
    assert_eq!(format!("{got:?}"), format!("{live:?}"));
    assert_eq!(replayed.run.ground_truth.len(), 2);

    let _ = std::fs::remove_dir_all(&dir);
}

fn replay_err(path: &Path) -> String {
    match dataset::replay(path, ReplayOptions::default()) {
        Ok(_) => panic!("{} replayed", path.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_bags_are_refused_naming_the_problem() {
    let dir = tmpdir("ros2-refusals");
    let (bag, _, _) = hand_built_bag(&dir);

    // No metadata.yaml.
    let bare = dir.join("bare");
    std::fs::create_dir(&bare).unwrap();
    std::fs::copy(bag.join("all_0.mcap"), bare.join("all_0.mcap")).unwrap();
    let e = replay_err(&bare);
    assert!(e.contains("no metadata.yaml") && e.contains("bare"), "{e}");

    // metadata.yaml names an unknown type for a topic.
    let yaml = std::fs::read_to_string(bag.join("metadata.yaml")).unwrap();
    let odd = dir.join("odd");
    std::fs::create_dir(&odd).unwrap();
    std::fs::copy(bag.join("all_0.mcap"), odd.join("all_0.mcap")).unwrap();
    std::fs::write(
        odd.join("metadata.yaml"),
        yaml.replacen("atrium_msgs/msg/WifiScan", "acme_msgs/msg/WifiScan", 1),
    )
    .unwrap();
    let e = replay_err(&odd);
    assert!(
        e.contains("topic /wifi/wifi")
            && e.contains("unknown message type \"acme_msgs/msg/WifiScan\""),
        "{e}"
    );

    // The storage file holds a topic of an unknown type that metadata.yaml does not list.
    let extra = dir.join("extra");
    std::fs::create_dir(&extra).unwrap();
    std::fs::write(extra.join("metadata.yaml"), &yaml).unwrap();
    let bytes = std::fs::read(bag.join("all_0.mcap")).unwrap();
    let file = std::fs::File::create(extra.join("all_0.mcap")).unwrap();
    let mut w = mcap::WriteOptions::new()
        .profile("ros2")
        .create(std::io::BufWriter::new(file))
        .unwrap();
    let sid = w
        .add_schema("diagnostic_msgs/msg/DiagnosticArray", "ros2msg", b"")
        .unwrap();
    let ch = w
        .add_channel(sid, "/diagnostics", "cdr", &Default::default())
        .unwrap();
    w.write_to_known_channel(
        &mcap::records::MessageHeader {
            channel_id: ch,
            sequence: 1,
            log_time: 1,
            publish_time: 1,
        },
        &[0, 1, 0, 0],
    )
    .unwrap();
    w.finish().unwrap();
    let e = replay_err(&extra);
    assert!(
        e.contains("topic /diagnostics") && e.contains("unknown message type"),
        "{e}"
    );

    // A topic with a known type other than the one Atrium writes there.
    let swapped = dir.join("swapped");
    std::fs::create_dir(&swapped).unwrap();
    std::fs::copy(bag.join("all_0.mcap"), swapped.join("all_0.mcap")).unwrap();
    let y = yaml.replacen(
        "name: /odom\n        type: nav_msgs/msg/Odometry",
        "name: /odom\n        type: geometry_msgs/msg/PoseWithCovarianceStamped",
        1,
    );
    assert_ne!(y, yaml);
    std::fs::write(swapped.join("metadata.yaml"), y).unwrap();
    let e = replay_err(&swapped);
    assert!(
        e.contains("topic /odom") && e.contains("expected \"nav_msgs/msg/Odometry\""),
        "{e}"
    );

    // The storage file named in metadata.yaml is missing.
    let lost = dir.join("lost");
    std::fs::create_dir(&lost).unwrap();
    std::fs::write(lost.join("metadata.yaml"), &yaml).unwrap();
    let e = replay_err(&lost);
    assert!(
        e.contains("does not exist") && e.contains("all_0.mcap"),
        "{e}"
    );

    // A truncated storage file goes through the checked MCAP reader.
    let cut = dir.join("cut");
    std::fs::create_dir(&cut).unwrap();
    std::fs::write(cut.join("metadata.yaml"), &yaml).unwrap();
    std::fs::write(cut.join("all_0.mcap"), &bytes[..bytes.len() / 2]).unwrap();
    let e = replay_err(&cut);
    assert!(e.contains("all_0.mcap"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn recording_into_a_folder_of_other_files_is_refused_and_a_bag_is_replaced() {
    let dir = tmpdir("ros2-output");
    let scenario = bundled_short("corridor_tracking", 1.0);
    let other = dir.join("photos");
    std::fs::create_dir(&other).unwrap();
    std::fs::write(other.join("cat.jpg"), b"meow").unwrap();
    let e = ros2::record_ros2(
        &LocalizerRegistry::with_builtins(),
        &scenario,
        &other,
        RunOptions::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("holds other things than a bag"), "{e}");
    assert_eq!(std::fs::read(other.join("cat.jpg")).unwrap(), b"meow");
    let file = dir.join("file");
    std::fs::write(&file, b"x").unwrap();
    let e = ros2::record::check_output(&file).unwrap_err().to_string();
    assert!(e.contains("is a file"), "{e}");
    // A bag there already is replaced, and nothing else is left beside it.
    let bag = dir.join("bag");
    record(&scenario, &bag);
    let first = std::fs::read(bag.join("metadata.yaml")).unwrap();
    record(&bundled_short("corridor_tracking", 2.0), &bag);
    assert_ne!(std::fs::read(bag.join("metadata.yaml")).unwrap(), first);
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["bag", "file", "photos"]);
    let _ = std::fs::remove_dir_all(&dir);
}
