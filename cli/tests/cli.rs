//! The `atrium` binary as users' scripts see it: exit codes, messages naming file and field,
//! stable JSON, output files.

mod common;

use common::{atrium, tmpdir};
use std::path::{Path, PathBuf};
use std::process::Output;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Writes a variant of the short scenario with one text replaced, in a temporary folder (its
/// world and robot paths made absolute).
fn variant(tag: &str, from: &str, to: &str) -> PathBuf {
    let text = std::fs::read_to_string(data("short.toml")).unwrap();
    assert!(text.contains(from), "{from:?} not in short.toml");
    let root = repo("").canonicalize().unwrap();
    let text = text
        .replace("../../../", &format!("{}/", root.display()))
        .replace(from, to);
    let p = tmpdir(tag).join(format!("{tag}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

fn without_timing(mut v: serde_json::Value) -> serde_json::Value {
    v.as_object_mut().unwrap().remove("timing");
    v
}

#[test]
fn same_seed_gives_identical_json_apart_from_timing() {
    let s = data("short.toml");
    let a = atrium(&["run", s.to_str().unwrap(), "--json"]);
    let b = atrium(&["run", s.to_str().unwrap(), "--json"]);
    assert!(
        a.status.code() == Some(0) || a.status.code() == Some(1),
        "{}",
        stderr(&a)
    );
    let ja: serde_json::Value = serde_json::from_slice(&a.stdout).unwrap();
    let jb: serde_json::Value = serde_json::from_slice(&b.stdout).unwrap();
    assert!(ja["timing"]["real_time_factor"].as_f64().unwrap() > 0.0);
    assert_eq!(without_timing(ja.clone()), without_timing(jb));
    // The documented fields are there.
    let mcl = &ja["localizers"][0];
    assert_eq!(mcl["name"], "mcl");
    for k in ["min", "median", "rmse", "p95", "max"] {
        assert!(
            mcl["position_error"][k].as_f64().is_some(),
            "position_error.{k}"
        );
    }
    assert!(mcl["per_region"]["office_corridor"]["median"]
        .as_f64()
        .is_some());
    assert!(mcl.get("converged_after_s").is_some());
    assert!(mcl["expectations"].as_array().is_some());
    // A different seed gives a different run.
    let c = atrium(&["run", s.to_str().unwrap(), "--json", "--seed", "99"]);
    let jc: serde_json::Value = serde_json::from_slice(&c.stdout).unwrap();
    assert_eq!(jc["seed"], 99);
    assert_ne!(without_timing(ja), without_timing(jc));
}

#[test]
fn out_writes_trajectories_metrics_and_pictures() {
    let dir = tmpdir("out");
    let s = data("short.toml");
    let o = atrium(&["run", s.to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    assert!(
        o.status.code() == Some(0) || o.status.code() == Some(1),
        "{}",
        stderr(&o)
    );
    for f in [
        "ground_truth.tum",
        "mcl.tum",
        "odometry.tum",
        "metrics.json",
        "trajectory_mcl.svg",
        "trajectory_mcl.png",
    ] {
        let p = dir.join(f);
        assert!(
            p.is_file() && std::fs::metadata(&p).unwrap().len() > 0,
            "{f} missing"
        );
    }
    let tum = std::fs::read_to_string(dir.join("mcl.tum")).unwrap();
    let first: Vec<f64> = tum
        .lines()
        .next()
        .unwrap()
        .split(' ')
        .map(|x| x.parse().unwrap())
        .collect();
    assert_eq!(first.len(), 8);
    let png = std::fs::read(dir.join("trajectory_mcl.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // Wide enough to read (IHDR width, big-endian, at byte 16).
    assert!(u32::from_be_bytes([png[16], png[17], png[18], png[19]]) >= 1600);
    // The picture names scenario, localizer and seed, its axes and colour bar have units.
    let svg = std::fs::read_to_string(dir.join("trajectory_mcl.svg")).unwrap();
    for text in [
        "short: mcl (mcl), seed",
        "x (m)",
        "y (m)",
        "position error (m)",
        "ground truth",
        "mcl estimate",
    ] {
        assert!(svg.contains(text), "{text:?} not in the SVG");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn failed_expectation_exits_1() {
    let p = variant("strict", "median_max = 0.2", "median_max = 0.0000001");
    let o = atrium(&["run", p.to_str().unwrap()]);
    let _ = std::fs::remove_file(&p);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("FAIL"));
}

fn assert_bad_input(o: &Output, needles: &[&str]) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {err}");
    assert!(!err.contains("panicked"), "{err}");
    for n in needles {
        assert!(err.contains(n), "{n:?} not in: {err}");
    }
}

#[test]
fn bad_scenarios_exit_2_naming_file_and_field() {
    let cases = [
        ("nan", "duration_s = 15.0", "duration_s = nan", "duration_s"),
        (
            "negative",
            "duration_s = 15.0",
            "duration_s = -1.0",
            "duration_s",
        ),
        (
            "inwall",
            "pose = [2.0, 20.0, 0.0]",
            "pose = [2.0, 18.95, 0.0]",
            "start.pose",
        ),
        (
            "waypoint",
            "waypoints = [[8.0, 20.0]]",
            "waypoints = [[8.0, 18.95]]",
            "route.waypoints[0]",
        ),
        ("unknownkey", "seed = 3", "seed = 3\nsede = 4", "sede"),
        (
            "badparam",
            "max_particles = 1000",
            "max_particles = -5",
            "localizers[mcl]",
        ),
        (
            "kind",
            "kind = \"mcl\"",
            "kind = \"mlc\"",
            "localizers[mcl].kind",
        ),
        (
            "expect",
            "median_max = 0.2",
            "median_maxx = 0.2",
            "expect.mcl.median_maxx",
        ),
        ("noworld", "campus.toml", "nowhere.toml", "nowhere.toml"),
        (
            "clutter_on_route",
            "seed = 3",
            "seed = 3\nclutter = [{ center = [8.0, 20.2], size = [0.8, 0.8, 0.75], material = \"wood\" }]",
            "route.waypoints[0]",
        ),
        (
            "clutter_material",
            "seed = 3",
            "seed = 3\nclutter = [{ center = [5.0, 20.0], size = [0.8, 0.8, 0.75], material = \"marble\" }]",
            "clutter[0].material",
        ),
        (
            "clutter_size",
            "seed = 3",
            "seed = 3\nclutter = [{ center = [5.0, 20.0], size = [0.8, nan, 0.75], material = \"wood\" }]",
            "clutter[0].size",
        ),
        (
            "clutter_key",
            "seed = 3",
            "seed = 3\nclutter = [{ centre = [5.0, 20.0], size = [0.8, 0.8, 0.75], material = \"wood\" }]",
            "clutter[0]",
        ),
    ];
    for (tag, from, to, field) in cases {
        let p = variant(tag, from, to);
        let o = atrium(&["run", p.to_str().unwrap()]);
        let _ = std::fs::remove_file(&p);
        let name = p.file_name().unwrap().to_string_lossy().into_owned();
        let needle = if tag == "noworld" {
            "nowhere.toml"
        } else {
            name.as_str()
        };
        assert_bad_input(&o, &[needle, field]);
    }
    let o = atrium(&["run", "/no/such/scenario.toml"]);
    assert_bad_input(&o, &["/no/such/scenario.toml"]);
}

#[test]
fn inspect_robot_reports_fixture_geometry() {
    let urdf = repo("robots/tests/fixtures/turtlebot3_burger.urdf");
    let o = atrium(&["inspect", "robot", urdf.to_str().unwrap(), "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!((j["wheel_radius"].as_f64().unwrap() - 0.033).abs() < 1e-3);
    assert!((j["wheel_separation"].as_f64().unwrap() - 0.160).abs() < 1e-3);
    assert_eq!(j["drive_joints"].as_array().unwrap().len(), 2);
    assert!(j["links"]
        .as_array()
        .unwrap()
        .iter()
        .any(|l| l["name"] == "base_scan"));
    let text = atrium(&[
        "inspect",
        "robot",
        repo("robots/urdf/pioneer3dx.urdf").to_str().unwrap(),
    ]);
    assert_eq!(text.status.code(), Some(0));
    assert!(String::from_utf8_lossy(&text.stdout).contains("wheel_separation"));
}

#[test]
fn inspect_robot_lists_sensors_and_drive_sources() {
    let urdf = repo("robots/tests/fixtures/rosbot_gz.urdf");
    let o = atrium(&["inspect", "robot", urdf.to_str().unwrap(), "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["sensor_source"]["kind"], "urdf_gazebo");
    assert_eq!(j["drive_source"], "urdf");
    let sensors = j["sensors"].as_array().unwrap();
    assert_eq!(sensors.len(), 6);
    assert_eq!(sensors[0]["name"], "slamtec_rplidar_sensor");
    assert_eq!(sensors[0]["default_laser"], true);
    assert_eq!(sensors[5]["kind"], "depth_camera");
    assert_eq!(j["ignored_sensors"][0]["type"], "camera");
    let text = atrium(&[
        "inspect",
        "robot",
        repo("robots/urdf/pioneer3dx.urdf").to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&text.stdout).to_string();
    assert!(
        text.contains("sensors           from the sensor file"),
        "{text}"
    );
    // A scenario file: its [robot] keys make the MP-400's mesh wheels.
    let dir = tmpdir("inspect-mp400");
    let scenario = dir.join("mp400.toml");
    std::fs::write(
        &scenario,
        format!(
            "[robot]\nurdf = \"{}\"\nwheel_radius = 0.075\ntrack = 0.52\n",
            repo("robots/tests/fixtures/mp_400.urdf").display()
        ),
    )
    .unwrap();
    let o = atrium(&["inspect", "robot", scenario.to_str().unwrap(), "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["drive_source"], "robot_table_mesh_wheels");
    assert_eq!(j["wheel_radius"], 0.075);
    assert_bad_input(
        &atrium(&[
            "inspect",
            "robot",
            repo("robots/tests/fixtures/mp_400.urdf").to_str().unwrap(),
        ]),
        &["mp_400.urdf", "wheel_radius", "track"],
    );
}

#[test]
fn bad_robot_and_world_files_exit_2() {
    let dir = tmpdir("bad");
    let xacro = dir.join("r.urdf.xacro");
    std::fs::write(&xacro, r#"<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="r"><xacro:property name="a" value="1"/></robot>"#).unwrap();
    assert_bad_input(
        &atrium(&["inspect", "robot", xacro.to_str().unwrap()]),
        &["r.urdf.xacro", "xacro"],
    );
    let broken = dir.join("broken.urdf");
    std::fs::write(&broken, "<robot name=\"x\"><link name=\"a\">").unwrap();
    assert_bad_input(
        &atrium(&["inspect", "robot", broken.to_str().unwrap()]),
        &["broken.urdf"],
    );
    assert_bad_input(
        &atrium(&["inspect", "robot", "/no/such.urdf"]),
        &["/no/such.urdf"],
    );
    let world = dir.join("w.toml");
    std::fs::write(
        &world,
        "name = \"w\"\nceiling_height = 3.0\n[materials.concrete]\nlaser = \"opaque\"\n[[walls]]\npoints = [[0.0, 0.0], [1.0, 0.0]]\nthickness = -0.2\nmaterial = \"concrete\"\n",
    )
    .unwrap();
    assert_bad_input(
        &atrium(&["inspect", "world", world.to_str().unwrap()]),
        &["w.toml", "walls[0].thickness"],
    );
    let ok = atrium(&[
        "inspect",
        "world",
        repo("worlds/campus.toml").to_str().unwrap(),
        "--json",
    ]);
    assert_eq!(ok.status.code(), Some(0), "{}", stderr(&ok));
    let j: serde_json::Value = serde_json::from_slice(&ok.stdout).unwrap();
    assert!(j["regions"]
        .as_array()
        .unwrap()
        .iter()
        .any(|r| r["kind"] == "atrium"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn export_map_writes_ros_and_vector_maps_with_glass_optional() {
    let dir = tmpdir("export");
    let world = repo("worlds/campus.toml");
    let yaml = dir.join("campus.yaml");
    let o = atrium(&[
        "export",
        "map",
        world.to_str().unwrap(),
        "--format",
        "ros",
        "-o",
        yaml.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let y = std::fs::read_to_string(&yaml).unwrap();
    for key in [
        "image:",
        "resolution:",
        "origin:",
        "negate:",
        "occupied_thresh:",
        "free_thresh:",
    ] {
        assert!(y.contains(key), "{key} missing in {y}");
    }
    let pgm = std::fs::read(dir.join("campus.pgm")).unwrap();
    assert_eq!(&pgm[..2], b"P5");
    let count = |with_glass: bool| {
        let out = dir.join(format!("v{with_glass}.txt"));
        let mut args = vec![
            "export",
            "map",
            world.to_str().unwrap(),
            "--format",
            "vector",
            "-o",
            out.to_str().unwrap(),
        ];
        if with_glass {
            args.push("--include-glass");
        }
        assert_eq!(atrium(&args).status.code(), Some(0));
        let text = std::fs::read_to_string(&out).unwrap();
        assert!(text.lines().all(|l| l.split(',').count() == 4), "{text}");
        text.lines().count()
    };
    assert!(count(true) > count(false), "glass walls must add segments");
    let bad = atrium(&[
        "export",
        "map",
        world.to_str().unwrap(),
        "--format",
        "ros",
        "--resolution",
        "0",
        "-o",
        yaml.to_str().unwrap(),
    ]);
    assert_bad_input(&bad, &["resolution"]);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn check_runs_every_seed_and_exits_by_the_pass_count() {
    // MCL's 0.2 m median holds on every seed: exit 0, with one row per expectation.
    let o = atrium(&[
        "check",
        data("short.toml").to_str().unwrap(),
        "--seeds",
        "1..3",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["passed_seeds"], 3);
    assert_eq!(v["seeds"], serde_json::json!([1, 2, 3]));
    assert_eq!(v["expectations"][0]["held"], 3);
    for o in v["outcomes"].as_array().unwrap() {
        assert!(o["distance_m"].as_f64().unwrap() > 0.5, "{o}");
        assert!(o["route_completed"].is_boolean(), "{o}");
    }
    // A bound nothing meets fails on every seed: exit 1, each seed's failure listed.
    let tight = variant("check_tight", "median_max = 0.2", "median_max = 0.0001");
    let o = atrium(&["check", tight.to_str().unwrap(), "--seeds", "1,2"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("passed on 0 of 2 seeds (needs 2): FAIL"),
        "{text}"
    );
    assert!(
        text.contains("seed 2 failed: mcl: position_error.median"),
        "{text}"
    );
    assert!(text.contains("distance driven: "), "{text}");
    // A claim dead reckoning meets too is no claim: the baseline check fails it.
    let weak = variant(
        "check_weak",
        "median_max = 0.2",
        "median_max = 5.0\nbaselines = [\"odometry\"]",
    );
    let o = atrium(&["check", weak.to_str().unwrap(), "--seeds", "1"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("claims also met by odometry"));
    // Bad seed ranges are bad input.
    for bad in ["5..1", "0..100000", "x"] {
        let o = atrium(&[
            "check",
            data("short.toml").to_str().unwrap(),
            "--seeds",
            bad,
        ]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains("--seeds"), "{}", stderr(&o));
    }
}
