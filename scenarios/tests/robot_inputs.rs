//! Robots as they come: sensors from a URDF's Gazebo blocks when there is no sensor file, a
//! localizer whose sensor the robot lacks refused at load, and `[robot] wheel_radius` and
//! `track` for a robot whose wheels only meshes describe.

use atrium_scenarios::robot_input::SensorSource;
use atrium_scenarios::{Scenario, ScenarioError};
use std::path::{Path, PathBuf};

fn repo(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(rel)
}

/// A corridor run on the campus with `robot` (a TOML value) and `localizers` (TOML text).
fn scenario(robot: &str, localizers: &str) -> Result<Scenario, ScenarioError> {
    let text = format!(
        r#"name = "robot_inputs"
world = "{}"
{robot}
duration_s = 5.0

[start]
pose = [2.0, 20.0, 0.0]

[route]
waypoints = [[6.0, 20.0]]

{localizers}
"#,
        repo("worlds/campus.toml").display()
    );
    Scenario::from_toml_str(&text, &repo("scenarios/robot_inputs.toml"))
}

fn fixture(name: &str) -> String {
    repo("robots/tests/fixtures")
        .join(name)
        .display()
        .to_string()
}

const MCL: &str = "[[localizers]]\nname = \"amcl\"\nkind = \"mcl\"\n";

#[test]
fn a_robot_without_a_sensor_file_gets_its_gazebo_lasers() {
    let s = scenario(&format!("robot = \"{}\"", fixture("rosbot_gz.urdf")), MCL).unwrap();
    assert!(matches!(s.robot_sources.sensors, SensorSource::Gazebo(_)));
    assert_eq!(s.lasers[0].name, "slamtec_rplidar_sensor");
    assert_eq!(s.lasers.len(), 5);
    assert_eq!(s.depth_cameras.len(), 1);
    // A scenario table named like a robot's sensor overrides only what it gives.
    let s = scenario(
        &format!("robot = \"{}\"", fixture("rosbot_gz.urdf")),
        &format!(
            "{MCL}\n[sensors.slamtec_rplidar_sensor]\nbeams = 400\n\n\
             [depth_cameras.camera_orbbec_astra_depth]\ndecimation = 8\n"
        ),
    )
    .unwrap();
    assert_eq!((s.lasers[0].beams, s.lasers[0].range_max), (400, 10.0));
    assert_eq!(s.depth_cameras[0].decimation, 8);
    assert_eq!(s.depth_cameras[0].range_max, 8.0);
}

#[test]
fn a_localizer_whose_sensor_the_robot_lacks_is_refused_at_load() {
    // The Jackal without its laser block: no sensor file, no Gazebo laser.
    let dir = std::env::temp_dir().join(format!("atrium-robot-inputs-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bare = dir.join("jackal.urdf");
    let text = std::fs::read_to_string(fixture("jackal_lms1xx.urdf")).unwrap();
    let start = text.find("<gazebo reference=\"front_laser\">").unwrap();
    let end = start + text[start..].find("</gazebo>").unwrap() + "</gazebo>".len();
    std::fs::write(&bare, format!("{}{}", &text[..start], &text[end..])).unwrap();
    let e = scenario(&format!("robot = \"{}\"", bare.display()), MCL)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("robot_inputs.toml: localizers[amcl].kind:")
            && e.contains("localizer \"amcl\" (mcl) needs a laser")
            && e.contains("robot \"jackal\" has none")
            && e.contains("jackal.sensors.toml"),
        "{e}"
    );
    let e = scenario(
        &format!("robot = \"{}\"", bare.display()),
        "[[localizers]]\nname = \"d\"\nkind = \"cgr_depth\"\n",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("(cgr_depth) needs a depth camera"), "{e}");
    // Dead reckoning needs nothing; the laser block makes mcl loadable.
    scenario(
        &format!("robot = \"{}\"", bare.display()),
        "[[localizers]]\nname = \"odo\"\nkind = \"dead_reckoning\"\n",
    )
    .unwrap();
    scenario(
        &format!("robot = \"{}\"", fixture("jackal_lms1xx.urdf")),
        MCL,
    )
    .unwrap();
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_robot_table_gives_a_mesh_wheeled_robot_its_drive() {
    let odo = "[[localizers]]\nname = \"odo\"\nkind = \"dead_reckoning\"\n";
    let e = scenario(&format!("robot = \"{}\"", fixture("mp_400.urdf")), odo)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("[robot] table") && e.contains("wheel_radius"),
        "{e}"
    );
    let table = |extra: &str| format!("[robot]\nurdf = \"{}\"\n{extra}", fixture("mp_400.urdf"));
    // TOML needs the [robot] table after the top-level keys: give the localizers first.
    let s = scenario(
        "",
        &format!("{odo}\n{}", table("wheel_radius = 0.075\ntrack = 0.52")),
    )
    .unwrap();
    assert_eq!(
        (s.robot.wheel_radius, s.robot.wheel_separation),
        (0.075, 0.52)
    );
    for (extra, field) in [
        ("wheel_radius = -0.075\ntrack = 0.52", "robot.wheel_radius"),
        ("wheel_radius = nan\ntrack = 0.52", "robot.wheel_radius"),
        ("wheel_radius = 0.075\ntrack = inf", "robot.track"),
        ("wheel_radius = 0.075\ntrack = \"wide\"", "robot.track"),
        (
            "wheel_radius = 0.075\ntrack = 0.52\nwidth = 1",
            "robot.width",
        ),
    ] {
        let e = scenario("", &format!("{odo}\n{}", table(extra)))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("robot_inputs.toml: {field}:")),
            "{extra}: {e}"
        );
    }
    let e = scenario("", &format!("{odo}\n[robot]\nwheel_radius = 0.075\n"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("robot.urdf: missing"), "{e}");
}

#[test]
fn every_bundled_scenario_has_the_sensors_its_localizers_need() {
    let mut checked = 0;
    for entry in std::fs::read_dir(repo("scenarios")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            if let Err(e) = Scenario::load(&path) {
                assert!(!e.to_string().contains(") needs "), "{e}");
            }
            checked += 1;
        }
    }
    assert!(checked > 10, "{checked}");
}
