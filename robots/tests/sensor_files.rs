//! Sensor files: the bundled Pioneer 3-DX file, round trips, and every validation error.

use atrium_robots::{LaserSpec, OdometrySpec, RobotError, RobotModel, RobotSensors};
use std::path::{Path, PathBuf};

fn bundled(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("urdf")
        .join(name)
}

const BASE: &str = r#"
[odometry]
ticks_per_rev = 500
radius_error = 0.005
separation_error = 0.01
rate_hz = 50

[[laser]]
name = "laser"
preset = "sick_lms200"
mount = "laser"
rate_hz = 10
"#;

fn parse(text: &str) -> Result<RobotSensors, RobotError> {
    RobotSensors::from_toml_str(text, Path::new("robot.sensors.toml"))
}

#[test]
fn pioneer_sensor_file_sits_beside_its_urdf_and_matches_the_robot() {
    let urdf = bundled("pioneer3dx.urdf");
    let path = RobotSensors::path_beside(&urdf);
    assert_eq!(path, bundled("pioneer3dx.sensors.toml"));
    let sensors = RobotSensors::load(&path).unwrap();
    assert_eq!(
        sensors.odometry,
        OdometrySpec {
            ticks_per_rev: 500,
            radius_error: 0.005,
            separation_error: 0.01,
            // Fitted by `atrium calibrate` to the bundled real logs (see the file).
            slip_sigma: 0.04,
            slip_correlation_m: 0.05,
            rate_hz: 50.0,
            ..Default::default()
        }
    );
    assert_eq!(
        sensors.lasers,
        vec![LaserSpec::sick_lms200("laser", "laser")]
    );
    let model = RobotModel::from_urdf(&urdf).unwrap();
    sensors.check_mounts(&model).unwrap();

    let mut wrong = sensors.clone();
    wrong.lasers[0].mount = "lidar".into();
    let msg = wrong.check_mounts(&model).unwrap_err().to_string();
    assert!(msg.contains("\"lidar\" is not a link"), "{msg}");
    assert!(msg.contains("pioneer3dx"), "{msg}");
}

#[test]
fn overrides_apply_on_top_of_the_preset() {
    let text = BASE.replace(
        "rate_hz = 10\n",
        "rate_hz = 10\nbeams = 361\nrange_max = 30.5\n",
    );
    let s = parse(&text).unwrap();
    let l = &s.lasers[0];
    assert_eq!(l.beams, 361);
    assert_eq!(l.range_max, 30.5);
    // Untouched fields keep the preset's values.
    assert_eq!(l.fov, std::f64::consts::PI);
    assert_eq!(l.sigma_hit, LaserSpec::sick_lms200("a", "b").sigma_hit);
}

#[test]
fn round_trip_through_text() {
    let mut s = parse(BASE).unwrap();
    let mut hokuyo = LaserSpec::hokuyo_urg04lx("rear", "base_link");
    hokuyo.beams = 100;
    hokuyo.p_rand = 0.1;
    s.lasers.push(hokuyo);
    s.odometry.radius_error = -0.0123456789;
    let text = s.to_toml_string().unwrap();
    let back = parse(&text).unwrap();
    assert_eq!(back, s, "{text}");
    // A file without [odometry] or lasers is the default odometry alone.
    let empty = parse("").unwrap();
    assert_eq!(empty.odometry, OdometrySpec::default());
    assert!(empty.lasers.is_empty());
}

#[test]
fn every_validation_error_names_its_field() {
    let laser = |extra: &str| BASE.replace("rate_hz = 10\n", &format!("rate_hz = 10\n{extra}\n"));
    let odometry = |from: &str, to: &str| {
        let t = BASE.replacen(from, to, 1);
        assert_ne!(t, BASE, "{from}");
        t
    };
    let cases: Vec<(String, &str)> = vec![
        (laser("beams = 0"), "laser[0].beams: must be at least 1 (got 0)"),
        (laser("beams = -3"), "laser[0].beams: must be at least 1 (got -3)"),
        (laser("beams = 1.5"), "laser[0].beams: expected an integer"),
        (
            BASE.replace("rate_hz = 10", "rate_hz = 0"),
            "laser[0].rate_hz: must be > 0",
        ),
        (laser("fov = 0.0"), "laser[0].fov: must be in (0, 2π]"),
        (laser("fov = 7.0"), "laser[0].fov: must be in (0, 2π]"),
        (laser("fov = nan"), "laser[0].fov: must be finite"),
        (laser("range_max = inf"), "laser[0].range_max: must be finite"),
        (laser("range_min = -0.1"), "laser[0].range_min: must be >= 0"),
        (laser("range_max = 0.01"), "laser[0].range_max: must be greater than range_min"),
        (laser("sigma_hit = -0.01"), "laser[0].sigma_hit: must be >= 0"),
        (laser("lambda_short = 0"), "laser[0].lambda_short: must be > 0"),
        (laser("p_short = 1.5"), "laser[0].p_short: must be a probability in [0, 1]"),
        (laser("p_max = -0.1"), "laser[0].p_max: must be a probability in [0, 1]"),
        (laser("p_rand = 2"), "laser[0].p_rand: must be a probability in [0, 1]"),
        (
            laser("p_short = 0.5\np_max = 0.3\np_rand = 0.3"),
            "p_short + p_max + p_rand must be <= 1",
        ),
        (laser("fov = \"wide\""), "laser[0].fov: expected a number, got a string"),
        (laser("beems = 3"), "laser[0].beems: unknown key"),
        (
            BASE.replace("sick_lms200", "velodyne"),
            "laser[0].preset: unknown preset \"velodyne\"",
        ),
        (
            BASE.replace("preset = \"sick_lms200\"\n", ""),
            "laser[0]: no preset given, so every field is needed; missing: beams, fov",
        ),
        (BASE.replace("mount = \"laser\"\n", ""), "laser[0].mount: missing"),
        (BASE.replace("name = \"laser\"\n", ""), "laser[0].name: missing"),
        (
            format!("{BASE}\n[[laser]]\nname = \"laser\"\npreset = \"hokuyo_urg04lx\"\nmount = \"laser\"\n"),
            "laser[1].name: \"laser\" is already the name of another laser",
        ),
        (
            odometry("ticks_per_rev = 500", "ticks_per_rev = 0"),
            "odometry.ticks_per_rev: must be at least 1 (got 0)",
        ),
        (
            odometry("radius_error = 0.005", "radius_error = 0.5"),
            "odometry.radius_error: must be within (-0.5, 0.5)",
        ),
        (
            odometry("separation_error = 0.01", "separation_error = -0.7"),
            "odometry.separation_error: must be within (-0.5, 0.5)",
        ),
        (
            odometry("rate_hz = 50", "rate_hz = -50"),
            "odometry.rate_hz: must be > 0",
        ),
        (
            odometry("rate_hz = 50", "rate_hz = 50\nticks = 3"),
            "odometry.ticks: unknown key",
        ),
        (format!("{BASE}\ncamera = 1\n"), "camera: unknown key"),
        ("[[laser]\n".to_string(), "robot.sensors.toml: TOML: "),
    ];
    for (text, expected) in cases {
        let err = parse(&text).expect_err(expected).to_string();
        assert!(err.starts_with("robot.sensors.toml: "), "{err}");
        assert!(err.contains(expected), "expected {expected:?} in {err:?}");
    }
}

#[test]
fn from_table_prefixes_the_callers_field_path() {
    let table: toml::Table =
        "name = \"laser\"\nmount = \"laser\"\npreset = \"sick_lms200\"\nbeams = 0"
            .parse()
            .unwrap();
    let err = LaserSpec::from_table(&table, "sensors.laser").unwrap_err();
    assert_eq!(err, "sensors.laser.beams: must be at least 1 (got 0)");

    // Without a preset every field must be present; the serialized spec is such a table.
    let full = toml::Table::try_from(LaserSpec::hokuyo_urg04lx("h", "m")).unwrap();
    assert_eq!(
        LaserSpec::from_table(&full, "sensors.h").unwrap(),
        LaserSpec::hokuyo_urg04lx("h", "m")
    );
}

#[test]
fn validate_checks_struct_values_directly() {
    assert!(LaserSpec::sick_lms200("a", "b").validate().is_ok());
    assert!(LaserSpec::hokuyo_urg04lx("a", "b").validate().is_ok());
    assert!(OdometrySpec::default().validate().is_ok());
    let mut l = LaserSpec::sick_lms200("a", "b");
    l.beams = 0;
    assert_eq!(
        l.validate().unwrap_err(),
        "beams: must be at least 1 (got 0)"
    );
    l.beams = 1;
    l.fov = std::f64::consts::TAU;
    assert!(l.validate().is_ok(), "a full circle is allowed");
    l.sigma_hit = f64::NAN;
    assert!(l
        .validate()
        .unwrap_err()
        .starts_with("sigma_hit: must be finite"));
    let o = OdometrySpec {
        ticks_per_rev: 0,
        ..OdometrySpec::default()
    };
    assert_eq!(
        o.validate().unwrap_err(),
        "ticks_per_rev: must be at least 1 (got 0)"
    );
    let o = OdometrySpec {
        radius_error: f64::INFINITY,
        ..OdometrySpec::default()
    };
    assert!(o
        .validate()
        .unwrap_err()
        .starts_with("radius_error: must be finite"));
}

#[test]
fn missing_sensor_file_names_the_path() {
    let err = RobotSensors::load(Path::new("/nonexistent/x.sensors.toml")).unwrap_err();
    assert!(matches!(err, RobotError::Io { .. }));
    assert!(err
        .to_string()
        .starts_with("/nonexistent/x.sensors.toml: cannot read file"));
}
