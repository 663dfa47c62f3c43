//! Datasets: MCAP recording read back with the `mcap` crate (schemas, counts, metadata),
//! replay equals live, bad files refused cleanly by the CLI (exit 2), `replay --out` TUM
//! files, and the exported occupancy map against the world's free space.

mod common;

use atrium_recordings::{self as dataset, replay::Recording, ReplayOptions};
use atrium_scenarios::{output, report, run_scenario, RunOptions, Scenario};
use common::{atrium, tmpdir};
use std::collections::BTreeMap;
use std::path::Path;

/// A bundled scenario with its duration cut to `duration_s` (kept beside the bundled file so
/// its relative paths resolve).
fn bundled_short(name: &str, duration_s: f64) -> Scenario {
    let path = atrium_scenarios::bundled_scenarios_dir().join(format!("{name}.toml"));
    let text = std::fs::read_to_string(&path).unwrap();
    let mut table: toml::Table = text.parse().unwrap();
    table.insert("duration_s".into(), toml::Value::Float(duration_s));
    Scenario::from_toml_str(&toml::to_string(&table).unwrap(), &path).unwrap()
}

/// The report without its wall-clock part.
fn results(r: &atrium_scenarios::RunResult) -> serde_json::Value {
    let mut v = report::to_json(r);
    v.as_object_mut().unwrap().remove("timing");
    v
}

#[test]
fn recording_reads_back_with_expected_schemas_counts_and_metadata() {
    let dir = tmpdir("roundtrip");
    let scenario = bundled_short("corridor_tracking", 10.0);
    let out = dir.join("corridor.mcap");
    let rec = dataset::record(
        &atrium_scenarios::LocalizerRegistry::with_builtins(),
        &scenario,
        &out,
        RunOptions::default(),
    )
    .unwrap();
    assert!(out.exists());
    // No temporary left behind.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);

    let bytes = std::fs::read(&out).unwrap();
    let mut counts: BTreeMap<String, (String, String, usize)> = BTreeMap::new();
    let mut last_time = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        assert!(m.log_time >= last_time, "log times must not go back");
        last_time = m.log_time;
        let schema = m.channel.schema.as_ref().map(|s| s.name.clone()).unwrap();
        let e = counts.entry(m.channel.topic.clone()).or_insert((
            schema,
            m.channel.message_encoding.clone(),
            0,
        ));
        e.2 += 1;
    }
    // 10 s at 200 Hz: odometry at 50 Hz, laser at 10 Hz, scoring at eval_hz = 10 Hz.
    let want: &[(&str, &str, &str, usize)] = &[
        ("/odom", "foxglove.PoseInFrame", "protobuf", 500),
        ("/odom/wheels", "atrium.WheelOdometry", "json", 500),
        ("/scan/laser", "foxglove.LaserScan", "protobuf", 100),
        ("/ground_truth", "foxglove.PoseInFrame", "protobuf", 100),
        ("/atrium/score", "atrium.ScoringInstant", "json", 100),
        ("/estimate/mcl", "foxglove.PoseInFrame", "protobuf", 100),
        (
            "/estimate/odometry",
            "foxglove.PoseInFrame",
            "protobuf",
            100,
        ),
        ("/scene", "foxglove.SceneUpdate", "protobuf", 1),
        // The URDF's links once, then odom and map frames at every odometry reading.
        ("/tf", "foxglove.FrameTransforms", "protobuf", 501),
    ];
    for (topic, schema, encoding, n) in want {
        let got = counts
            .get(*topic)
            .unwrap_or_else(|| panic!("{topic} missing: {counts:?}"));
        assert_eq!(
            (got.0.as_str(), got.1.as_str(), got.2),
            (*schema, *encoding, *n),
            "{topic}"
        );
    }
    // Sensors the robot's sensor file adds (WiFi, depth, landmarks) have their own schemas.
    for (topic, (schema, encoding, n)) in &counts {
        if want.iter().any(|w| w.0 == topic) {
            continue;
        }
        let expected = [
            ("/wifi/", "atrium.WifiScan", "json"),
            ("/depth/", "foxglove.RawImage", "protobuf"),
            ("/landmarks/", "atrium.LandmarkDetections", "json"),
            ("/scan/", "foxglove.LaserScan", "protobuf"),
        ]
        .into_iter()
        .find(|(prefix, _, _)| topic.starts_with(prefix))
        .unwrap_or_else(|| panic!("unexpected topic {topic}"));
        assert_eq!(
            (schema.as_str(), encoding.as_str()),
            (expected.1, expected.2)
        );
        assert!(*n > 0);
    }
    let total: usize = counts.values().map(|c| c.2).sum();
    assert_eq!(total as u64, rec.messages);

    // Chunks are zstd-compressed; metadata holds scenario text, seed and version.
    let mut chunks = 0;
    let mut meta = BTreeMap::new();
    for r in mcap::read::LinearReader::new(&bytes).unwrap() {
        match r.unwrap() {
            mcap::records::Record::Chunk { header, .. } => {
                assert_eq!(header.compression, "zstd");
                chunks += 1;
            }
            mcap::records::Record::Metadata(m) => {
                meta.insert(m.name.clone(), m.metadata);
            }
            _ => {}
        }
    }
    assert!(chunks > 0);
    let a = &meta["atrium"];
    assert_eq!(a["scenario"], scenario.text);
    assert_eq!(a["seed"], "1");
    assert_eq!(a["atrium_version"], env!("CARGO_PKG_VERSION"));
    let summary = &meta["atrium.summary"];
    assert_eq!(summary["physics_steps"], "2000");

    // Decoded, a scan carries the live ranges exactly.
    let scan = mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| m.unwrap())
        .find(|m| m.channel.topic == "/scan/laser")
        .unwrap();
    use foxglove::Decode;
    let msg = foxglove::messages::LaserScan::decode(&scan.data[..]).unwrap();
    assert_eq!(msg.ranges.len(), scenario.lasers[0].beams);
    assert_eq!(msg.frame_id, scenario.lasers[0].mount);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn replay_equals_live_with_the_same_seed() {
    // The kidnapped scenario (an event, two localizers, random injection) cut to 30 s: the
    // kidnapping at 8 s and the recovery (12.2 s later) are inside, so the run passes.
    let scenario = bundled_short("kidnapped", 30.0);
    let live = run_scenario(&scenario, RunOptions::default()).unwrap();
    let dir = tmpdir("replay");
    let out = dir.join("kidnapped.mcap");
    let rec = dataset::record(
        &atrium_scenarios::LocalizerRegistry::with_builtins(),
        &scenario,
        &out,
        RunOptions::default(),
    )
    .unwrap();
    // Recording does not change the run.
    assert_eq!(results(&rec.run), results(&live));

    let replayed = dataset::replay(&out, ReplayOptions::default()).unwrap();
    assert_eq!(results(&replayed.run), results(&live));
    assert_eq!(replayed.run.events, live.events);
    assert_eq!(replayed.run.ground_truth, live.ground_truth);
    for (a, b) in replayed.run.localizers.iter().zip(&live.localizers) {
        assert_eq!(a.samples, b.samples, "{}", a.name);
        assert_eq!(a.trajectory, b.trajectory, "{}", a.name);
    }
    assert!(live.localizers[0].samples.len() == 300);

    // The CLI: replay --json matches, and --out writes TUM trajectories.
    let tum = dir.join("out");
    let o = atrium(&[
        "replay",
        out.to_str().unwrap(),
        "--json",
        "--out",
        tum.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let mut doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let d = doc.as_object_mut().unwrap();
    d.remove("timing");
    d.remove("recording");
    assert_eq!(doc, results(&live));
    let gt = std::fs::read_to_string(tum.join("ground_truth.tum")).unwrap();
    assert_eq!(gt.lines().count(), 300);
    assert!(gt.lines().all(|l| l.split_whitespace().count() == 8));
    assert!(tum.join("mcl.tum").exists() && tum.join("odometry.tum").exists());

    // A localizer named on the command line instead of the scenario's.
    let o = atrium(&[
        "replay",
        out.to_str().unwrap(),
        "--json",
        "--localizer",
        "dr=dead_reckoning",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let locs = doc["localizers"].as_array().unwrap();
    assert_eq!(locs.len(), 1);
    assert_eq!(locs[0]["name"], "dr");
    // Dead reckoning sees the same odometry as the scenario's `odometry` localizer.
    let live_dr = &results(&live)["localizers"][1]["position_error"];
    assert_eq!(&locs[0]["position_error"], live_dr);
    let _ = std::fs::remove_dir_all(&dir);
}

fn write_mcap(path: &Path, topic: &str, schema: &str, encoding: &str) {
    let f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut w = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        .create(f)
        .unwrap();
    let s = w.add_schema(schema, "protobuf", b"").unwrap();
    let c = w.add_channel(s, topic, encoding, &BTreeMap::new()).unwrap();
    w.write_to_known_channel(
        &mcap::records::MessageHeader {
            channel_id: c,
            sequence: 1,
            log_time: 5,
            publish_time: 5,
        },
        b"\x08\x01",
    )
    .unwrap();
    w.finish().unwrap();
}

#[test]
fn bad_files_are_refused_cleanly_with_exit_2() {
    let dir = tmpdir("bad");
    let check = |path: &Path, needle: &str| {
        let o = atrium(&["replay", path.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(2), "{}: {err}", path.display());
        assert!(err.contains(needle), "{needle:?} not in {err:?}");
        assert!(
            err.contains(path.file_name().unwrap().to_str().unwrap()),
            "{err}"
        );
        assert!(!err.contains("panicked"), "{err}");
        // The library says the same without a process.
        assert!(Recording::open(path).is_err());
    };

    let text = dir.join("notes.mcap");
    std::fs::write(&text, "not a recording\n").unwrap();
    check(&text, "not an MCAP file");
    check(&dir.join("missing.mcap"), "cannot read file");

    let scenario = bundled_short("corridor_tracking", 2.0);
    let good = dir.join("good.mcap");
    dataset::record(
        &atrium_scenarios::LocalizerRegistry::with_builtins(),
        &scenario,
        &good,
        RunOptions::default(),
    )
    .unwrap();
    let bytes = std::fs::read(&good).unwrap();
    for (name, len) in [
        ("half.mcap", bytes.len() / 2),
        ("cut.mcap", bytes.len() - 3),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, &bytes[..len]).unwrap();
        check(&p, "truncated");
    }

    let wrong = dir.join("wrong_schema.mcap");
    write_mcap(&wrong, "/scan/laser", "foxglove.PointCloud", "protobuf");
    check(&wrong, "/scan/laser");
    let o = atrium(&["replay", wrong.to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("foxglove.LaserScan"));

    let no_topics = dir.join("no_topics.mcap");
    write_mcap(&no_topics, "/camera", "foxglove.RawImage", "protobuf");
    check(&no_topics, "lacks odometry");

    // `record` to a folder that does not exist: bad input, nothing written.
    let o = atrium(&[
        "record",
        atrium_scenarios::default_scenario().to_str().unwrap(),
        "-o",
        dir.join("nope/x.mcap").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Offsets of the top-level records of an MCAP file with `opcode`.
fn records_with(bytes: &[u8], opcode: u8) -> Vec<usize> {
    let mut at = mcap::MAGIC.len();
    let mut found = Vec::new();
    while at + 9 <= bytes.len() - mcap::MAGIC.len() {
        if bytes[at] == opcode {
            found.push(at);
        }
        let len = u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap());
        at += 9 + len as usize;
    }
    found
}

/// `atrium replay ARGS...`: exit status and stderr.
fn replay_err(args: &[&str]) -> (Option<i32>, String) {
    let mut all = vec!["replay"];
    all.extend_from_slice(args);
    let o = atrium(&all);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!err.contains("panicked"), "{err}");
    (o.status.code(), err)
}

fn record_short(name: &str, duration_s: f64, out: &Path) {
    dataset::record(
        &atrium_scenarios::LocalizerRegistry::with_builtins(),
        &bundled_short(name, duration_s),
        out,
        RunOptions::default(),
    )
    .unwrap();
}

/// Damage the official reader's CRC checks reject is refused, naming the chunk by its byte
/// offset; a chunk claiming an absurd size is refused before anything is allocated.
#[test]
fn damaged_recordings_are_refused_naming_the_chunk() {
    let dir = tmpdir("damaged");
    let good = dir.join("good.mcap");
    record_short("corridor_tracking", 2.0, &good);
    let bytes = std::fs::read(&good).unwrap();
    let chunk = records_with(&bytes, 0x06)[0];
    // Chunk body: start and end time (16), uncompressed size (8), CRC (4), compression.
    let (size_at, crc_at) = (chunk + 9 + 16, chunk + 9 + 24);
    let damaged = |name: &str, change: &dyn Fn(&mut Vec<u8>)| {
        let mut b = bytes.clone();
        change(&mut b);
        let p = dir.join(name);
        std::fs::write(&p, &b).unwrap();
        (p, b)
    };

    let (p, b) = damaged("crc.mcap", &|b| b[crc_at] ^= 0x10);
    let (code, err) = replay_err(&[p.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains(&format!("crc.mcap: chunk at byte {chunk}: CRC mismatch")),
        "{err}"
    );
    // What the bug was: the `mcap` crate's default reader takes this file without a word.
    assert!(mcap::MessageStream::new(&b).unwrap().all(|m| m.is_ok()));

    let (p, _) = damaged("huge.mcap", &|b| {
        b[size_at..size_at + 8].copy_from_slice(&(1u64 << 40).to_le_bytes())
    });
    let (code, err) = replay_err(&[p.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains(&format!("chunk at byte {chunk}: claims an uncompressed size of 1099511627776 bytes, more than the limit of 268435456 bytes")),
        "{err}"
    );

    // A flipped bit in the compressed records, and one in the metadata (outside any chunk).
    let (p, _) = damaged("data.mcap", &|b| b[crc_at + 40] ^= 0x01);
    let (code, err) = replay_err(&[p.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains(&format!("chunk at byte {chunk}")), "{err}");
    let meta = records_with(&bytes, 0x0C)[0];
    let (p, _) = damaged("meta.mcap", &|b| b[meta + 30] ^= 0x01);
    let (code, err) = replay_err(&[p.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("data section CRC mismatch"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `src` rewritten by `edit`, which sees every message and returns those to write.
fn rewrite(
    src: &Path,
    dst: &Path,
    edit: impl Fn(mcap::Message<'static>) -> Vec<mcap::Message<'static>>,
) {
    let bytes = std::fs::read(src).unwrap();
    let f = std::io::BufWriter::new(std::fs::File::create(dst).unwrap());
    let mut w = mcap::WriteOptions::new().create(f).unwrap();
    for r in mcap::read::LinearReader::new(&bytes).unwrap() {
        if let mcap::records::Record::Metadata(m) = r.unwrap() {
            w.write_metadata(&m).unwrap();
        }
    }
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        for m in edit(m.unwrap()) {
            w.write(&m).unwrap();
        }
    }
    w.finish().unwrap();
}

/// Replay refuses what would give a plausible-looking wrong answer: localizers without the
/// sensor they read, a message twice, another world or robot than the recording's.
#[test]
fn replay_refuses_missing_sensors_duplicates_and_another_world() {
    let dir = tmpdir("replay_checks");
    let good = dir.join("good.mcap");
    record_short("corridor_tracking", 2.0, &good);
    let good_s = good.to_str().unwrap();

    let no_laser = dir.join("no_laser.mcap");
    rewrite(&good, &no_laser, |m| {
        if m.channel.topic.starts_with("/scan/") {
            vec![]
        } else {
            vec![m]
        }
    });
    let (code, err) = replay_err(&[no_laser.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("no_laser.mcap: topics: localizer \"mcl\" (kind mcl) needs laser scans on a /scan/<sensor> topic, but the recording has no messages there"),
        "{err}"
    );
    // Dead reckoning needs nothing the file lacks.
    let (code, err) = replay_err(&[
        no_laser.to_str().unwrap(),
        "--localizer",
        "dr=dead_reckoning",
    ]);
    assert_eq!(code, Some(0), "{err}");

    let twice = dir.join("twice.mcap");
    rewrite(&good, &twice, |m| {
        if m.channel.topic == "/odom/wheels" && m.sequence == 7 {
            vec![m.clone(), m]
        } else {
            vec![m]
        }
    });
    let (code, err) = replay_err(&[twice.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("twice.mcap: topic /odom/wheels: the message at 0.14 s (log time 140000000 ns, sequence 7) is there twice"),
        "{err}"
    );

    // Another world.
    let slam = atrium_scenarios::bundled_scenarios_dir().join("slam_paper.toml");
    let (code, err) = replay_err(&[good_s, "--scenario", slam.to_str().unwrap()]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("slam_paper.toml: world: world \"slam_lab\"")
            && err.contains("is not the world the recording")
            && err.contains("was made with, world \"campus\""),
        "{err}"
    );
    // The same world's name on an edited copy of its file, and another robot.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    let campus = std::fs::read_to_string(root.join("worlds/campus.toml")).unwrap();
    std::fs::write(
        dir.join("campus.toml"),
        campus.replacen("height = ", "height = 0.5 + ", 0) + "\n# edited\n",
    )
    .unwrap();
    let corridor = std::fs::read_to_string(
        atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml"),
    )
    .unwrap();
    let robots = root.join("robots/urdf");
    let edited = corridor
        .replace("../worlds/campus.toml", "campus.toml")
        .replace("../robots/urdf/", &format!("{}/", robots.display()));
    std::fs::write(dir.join("edited_world.toml"), &edited).unwrap();
    let (code, err) = replay_err(&[
        good_s,
        "--scenario",
        dir.join("edited_world.toml").to_str().unwrap(),
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("world \"campus\"") && err.contains("content hash fnv1a64:"),
        "{err}"
    );
    let wheelchair = corridor
        .replace("../worlds/", &format!("{}/", root.join("worlds").display()))
        .replace(
            "../robots/urdf/pioneer3dx.urdf",
            &robots.join("wheelchair.urdf").display().to_string(),
        );
    std::fs::write(dir.join("wheelchair.toml"), &wheelchair).unwrap();
    let (code, err) = replay_err(&[
        good_s,
        "--scenario",
        dir.join("wheelchair.toml").to_str().unwrap(),
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("robot \"wheelchair\"") && err.contains("was made with, robot \"pioneer3dx\""),
        "{err}"
    );
    // The recording's own scenario named explicitly is fine.
    let own = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let (code, err) = replay_err(&[
        good_s,
        "--scenario",
        own.to_str().unwrap(),
        "--localizer",
        "dr=dead_reckoning",
    ]);
    assert_eq!(code, Some(0), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A bad `-o` is refused before the run with nothing written; a partial file a killed run
/// left is replaced and gone after a new recording to the same output.
#[test]
fn record_checks_its_output_first_and_replaces_a_stale_partial_file() {
    let dir = tmpdir("record_output");
    let base = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile/base.toml");
    let record = |out: &Path| {
        let o = atrium(&[
            "record",
            base.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(!err.contains("panicked"), "{err}");
        (o.status.code(), err)
    };
    let missing = dir.join("nope/run.mcap");
    let (code, err) = record(&missing);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains(&format!("cannot write {}", missing.display())),
        "{err}"
    );
    let (code, err) = record(&dir);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("it is a folder"), "{err}");
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);

    let out = dir.join("run.mcap");
    let partial = dir.join("run.mcap.partial");
    std::fs::write(&partial, "left by a killed run").unwrap();
    let (code, err) = record(&out);
    assert_eq!(code, Some(0), "{err}");
    assert!(out.exists() && !partial.exists());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}

/// An unfinished recording (an error or a kill mid-run) never leaves a file under the final
/// name: the run fails at the kidnapping (into a wall) after the file was opened. A partial
/// file an earlier killed run left is gone too.
#[test]
fn a_failed_recording_leaves_no_file() {
    let mut scenario = bundled_short("kidnapped", 10.0);
    // Into the middle of a wall: the loader refuses that, so change the event after loading.
    let wall = &scenario.world.walls[0];
    let inside = [0.5 * (wall.a[0] + wall.b[0]), 0.5 * (wall.a[1] + wall.b[1])];
    assert!(!scenario.world.is_free(inside, 0.0));
    let atrium_scenarios::scenario::Event::Kidnap { to, .. } = &mut scenario.events[0];
    *to = atrium_robots::Pose2::new(inside[0], inside[1], 0.0);
    let dir = tmpdir("failed");
    let out = dir.join("x.mcap");
    std::fs::write(dir.join("x.mcap.partial"), "left by a killed run").unwrap();
    assert!(dataset::record(
        &atrium_scenarios::LocalizerRegistry::with_builtins(),
        &scenario,
        &out,
        RunOptions::default()
    )
    .is_err());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn exported_occupancy_map_matches_the_free_space() {
    let world = atrium_worlds::World::campus().unwrap();
    let dir = tmpdir("map");
    for include_glass in [false, true] {
        let yaml = dir.join(format!("campus_{include_glass}.yaml"));
        let res = 0.1;
        output::export_map(&world, "ros", &yaml, include_glass, res).unwrap();
        let pgm = std::fs::read(yaml.with_extension("pgm")).unwrap();
        let header: Vec<&str> = std::str::from_utf8(&pgm[..20])
            .unwrap_or_else(|e| std::str::from_utf8(&pgm[..e.valid_up_to()]).unwrap())
            .split_whitespace()
            .take(4)
            .collect();
        let (w, h): (usize, usize) = (header[1].parse().unwrap(), header[2].parse().unwrap());
        let pixels = &pgm[pgm.len() - w * h..];
        let y = std::fs::read_to_string(&yaml).unwrap();
        let origin: Vec<f64> = y
            .lines()
            .find(|l| l.starts_with("origin:"))
            .unwrap()
            .trim_start_matches("origin:")
            .trim()
            .trim_matches(|c| c == '[' || c == ']')
            .split(',')
            .map(|v| v.trim().parse().unwrap())
            .collect();
        // The world as the map sees it: furniture is never in a localizer's map, glass only
        // when asked for.
        let mut seen = world.clone();
        seen.boxes.clear();
        if !include_glass {
            seen.walls.retain(|wall| !world.is_glass(&wall.material));
        }
        let half_diag = res * std::f64::consts::FRAC_1_SQRT_2;
        let (mut free, mut occupied, mut unknown) = (0, 0, 0);
        for row in 0..h {
            for i in 0..w {
                // PGM rows run top (largest y) to bottom.
                let j = h - 1 - row;
                let c = [
                    origin[0] + (i as f64 + 0.5) * res,
                    origin[1] + (j as f64 + 0.5) * res,
                ];
                let v = pixels[row * w + i];
                assert!(v == 254 || v == 0 || v == 205);
                let clearance = seen.clearance(c);
                if clearance > half_diag {
                    // Free space: inside the building free (254), outside it unknown (205).
                    assert!(v == 254 || v == 205, "cell {c:?} is free space: {v}");
                    if v == 254 {
                        free += 1;
                    } else {
                        unknown += 1;
                    }
                } else if clearance < 0.0 {
                    assert_eq!(v, 0, "cell {c:?} lies in a solid");
                    occupied += 1;
                }
            }
        }
        assert!(
            free > 10_000 && occupied > 1_000 && unknown > 1_000,
            "{free} {occupied} {unknown}"
        );
        // The map's corner is outside the building; the corridor at (2, 20) inside it.
        assert_eq!(pixels[0], 205);
        let (i, j) = (
            ((2.0 - origin[0]) / res) as usize,
            ((20.0 - origin[1]) / res) as usize,
        );
        assert_eq!(pixels[(h - 1 - j) * w + i], 254);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A tiny recording from elsewhere: wheel odometry and scoring instants at 0.1, 0.2 and 0.3 s
/// (uncompressed, so the same code always writes the same bytes), with `metadata` as the
/// `atrium` metadata record and `more` writing extra channels and messages.
fn tiny(
    metadata: Option<BTreeMap<String, String>>,
    twice: bool,
    more: impl Fn(&mut mcap::Writer<&mut std::io::Cursor<Vec<u8>>>),
) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    let mut w = mcap::WriteOptions::new()
        .compression(None)
        .library("atrium hostile corpus")
        .create(&mut out)
        .unwrap();
    if let Some(m) = metadata {
        w.write_metadata(&mcap::records::Metadata {
            name: "atrium".into(),
            metadata: m,
        })
        .unwrap();
    }
    let odom_schema = w
        .add_schema("atrium.WheelOdometry", "jsonschema", b"{}")
        .unwrap();
    let score_schema = w
        .add_schema("atrium.ScoringInstant", "jsonschema", b"{}")
        .unwrap();
    let odom = w
        .add_channel(odom_schema, "/odom/wheels", "json", &BTreeMap::new())
        .unwrap();
    let score = w
        .add_channel(score_schema, "/atrium/score", "json", &BTreeMap::new())
        .unwrap();
    for k in 1..=3u32 {
        let t = f64::from(k) / 10.0;
        let ns = u64::from(k) * 100_000_000;
        let header = |channel_id| mcap::records::MessageHeader {
            channel_id,
            sequence: k,
            log_time: ns,
            publish_time: ns,
        };
        let o = format!(
            r#"{{"stamp":{t},"pose":{{"x":{},"y":20.0,"theta":0.0}},"left_ticks":{k},"right_ticks":{k}}}"#,
            2.0 + t / 10.0
        );
        w.write_to_known_channel(&header(odom), o.as_bytes())
            .unwrap();
        if twice && k == 2 {
            w.write_to_known_channel(&header(odom), o.as_bytes())
                .unwrap();
        }
        let s = format!(r#"{{"t":{t},"x":2.0,"y":20.0,"theta":0.0}}"#);
        w.write_to_known_channel(&header(score), s.as_bytes())
            .unwrap();
        if k == 1 {
            more(&mut w);
        }
    }
    w.finish().unwrap();
    drop(w);
    out.into_inner()
}

/// The MCAP files of the hostile corpus (`tests/hostile/mcap_*.mcap`, run by
/// `cases_mcap.toml`). A test checks that the committed files are exactly these;
/// `ATRIUM_WRITE_HOSTILE_MCAP=1 cargo test --release -p atrium-cli --test dataset corpus`
/// rewrites them.
fn hostile_mcap_files() -> Vec<(&'static str, Vec<u8>)> {
    let valid = tiny(None, false, |_| {});
    let chunk = records_with(&valid, 0x06)[0];
    let header = records_with(&valid, 0x01)[0];
    let with = |change: &dyn Fn(&mut Vec<u8>)| {
        let mut b = valid.clone();
        change(&mut b);
        b
    };
    let image = tiny(None, false, |w| {
        let s = w.add_schema("foxglove.RawImage", "protobuf", b"").unwrap();
        let c = w
            .add_channel(s, "/depth/kinect", "protobuf", &BTreeMap::new())
            .unwrap();
        let msg = foxglove::messages::RawImage {
            width: 65535,
            height: 65535,
            step: 65535 * 4,
            encoding: "32FC1".into(),
            data: foxglove::bytes::Bytes::from(vec![0u8; 4]),
            ..Default::default()
        };
        let mut data = Vec::new();
        foxglove::Encode::encode(&msg, &mut data).unwrap();
        let h = mcap::records::MessageHeader {
            channel_id: c,
            sequence: 1,
            log_time: 100_000_000,
            publish_time: 100_000_000,
        };
        w.write_to_known_channel(&h, &data).unwrap();
    });
    let lab = BTreeMap::from([
        ("world".to_string(), "lab".to_string()),
        ("robot".to_string(), "pioneer3dx".to_string()),
    ]);
    vec![
        // The chunk's stored CRC, one bit off.
        ("mcap_chunk_crc.mcap", with(&|b| b[chunk + 9 + 24] ^= 0x04)),
        // The chunk claims 2^61 bytes uncompressed.
        (
            "mcap_huge_chunk.mcap",
            with(&|b| {
                b[chunk + 9 + 16..chunk + 9 + 24].copy_from_slice(&(1u64 << 61).to_le_bytes())
            }),
        ),
        // The header record claims 2^60 bytes.
        (
            "mcap_huge_record.mcap",
            with(&|b| b[header + 1..header + 9].copy_from_slice(&(1u64 << 60).to_le_bytes())),
        ),
        // The header's profile string claims 0x7f7f7f7f bytes.
        (
            "mcap_huge_string.mcap",
            with(&|b| b[header + 9..header + 13].fill(0x7f)),
        ),
        // A letter of the header's library string changed: only the data section CRC tells.
        ("mcap_data_crc.mcap", with(&|b| b[header + 13 + 4] ^= 0x20)),
        ("mcap_truncated.mcap", valid[..valid.len() / 2].to_vec()),
        ("mcap_duplicate.mcap", tiny(None, true, |_| {})),
        ("mcap_no_laser.mcap", valid.clone()),
        ("mcap_other_world.mcap", tiny(Some(lab), false, |_| {})),
        ("mcap_huge_image.mcap", image),
    ]
}

#[test]
fn hostile_mcap_corpus_is_what_its_generator_writes() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile");
    let write = std::env::var_os("ATRIUM_WRITE_HOSTILE_MCAP").is_some();
    for (name, bytes) in hostile_mcap_files() {
        let path = dir.join(name);
        assert!(bytes.len() < 4096, "{name}: {} bytes", bytes.len());
        if write {
            std::fs::write(&path, &bytes).unwrap();
        }
        let committed = std::fs::read(&path).unwrap_or_default();
        assert!(
            committed == bytes,
            "{} differs from its generator: rewrite with ATRIUM_WRITE_HOSTILE_MCAP=1",
            path.display()
        );
    }
    // The valid base of the corpus replays (dead reckoning, base.toml's localizer).
    let (code, err) = replay_err(&[
        dir.join("mcap_no_laser.mcap").to_str().unwrap(),
        "--scenario",
        dir.join("base.toml").to_str().unwrap(),
    ]);
    assert_eq!(code, Some(0), "{err}");
}
