//! Sensors read from `<gazebo><sensor>` blocks of public descriptions (ROSbot, Jackal), and
//! drive geometry given beside a URDF whose wheels only meshes describe (MP-400).

// The LMS1xx block states its angles to six digits (1.570796), and the tests check them as read.
#![allow(clippy::approx_constant)]
use atrium_robots::{read_gazebo_sensors, DriveOverride, DriveSource, RobotModel};
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

fn text(name: &str) -> String {
    std::fs::read_to_string(fixture(name)).unwrap()
}

fn sensors_of(t: &str) -> Result<atrium_robots::GazeboSensors, String> {
    let model = RobotModel::from_urdf_str(t, "robot.urdf").map_err(|e| e.to_string())?;
    read_gazebo_sensors(t, "robot.urdf", &model).map_err(|e| e.to_string())
}

#[test]
fn rosbot_lidar_range_finders_and_depth_camera_are_read() {
    let s = sensors_of(&text("rosbot_gz.urdf")).unwrap();
    let names: Vec<&str> = s.lasers.iter().map(|l| l.name.as_str()).collect();
    // The RPLIDAR (800 beams) leads, so localizers that read one laser use it; the range
    // finders follow in file order.
    assert_eq!(
        names,
        [
            "slamtec_rplidar_sensor",
            "fl_range",
            "fr_range",
            "rl_range",
            "rr_range"
        ]
    );
    let lidar = &s.lasers[0];
    assert_eq!(lidar.beams, 800);
    assert!((lidar.fov - std::f64::consts::TAU).abs() < 1e-12);
    assert_eq!((lidar.range_min, lidar.range_max), (0.2, 10.0));
    assert_eq!((lidar.rate_hz, lidar.sigma_hit), (10.0, 0.05));
    assert_eq!(lidar.mount, "laser");
    assert_eq!((lidar.p_short, lidar.p_max, lidar.p_rand), (0.0, 0.0, 0.0));
    let fl = &s.lasers[1];
    assert_eq!((fl.beams, fl.range_max, fl.rate_hz), (1, 0.9, 5.0));
    assert_eq!(fl.mount, "fl_range");
    assert!(s
        .notes
        .iter()
        .any(|n| n.contains("fl_range") && n.contains("mean 0.1")));
    assert_eq!(s.depth_cameras.len(), 1);
    let cam = &s.depth_cameras[0];
    assert_eq!(cam.name, "camera_orbbec_astra_depth");
    assert_eq!((cam.width, cam.height, cam.rate_hz), (640, 480, 30.0));
    assert_eq!(
        (cam.range_min, cam.range_max, cam.noise_base),
        (0.6, 8.0, 0.05)
    );
    assert!((cam.fov_h - 60f64.to_radians()).abs() < 1e-12);
    // 4:3 at 60° across: 2 atan(tan 30° · 3/4) = 46.8° down.
    assert!(
        (cam.fov_v.to_degrees() - 46.83).abs() < 0.01,
        "{}",
        cam.fov_v
    );
    assert_eq!(
        s.ignored,
        vec![(
            "camera_orbbec_astra_color".to_string(),
            "camera".to_string()
        )]
    );
    assert!(s.frames.is_empty());
}

#[test]
fn jackal_classic_ray_block_is_a_laser_and_gpu_ray_reads_alike() {
    let t = text("jackal_lms1xx.urdf");
    let s = sensors_of(&t).unwrap();
    assert_eq!(s.lasers.len(), 1);
    let l = &s.lasers[0];
    assert_eq!(
        (l.name.as_str(), l.mount.as_str()),
        ("front_laser", "front_laser")
    );
    assert_eq!(
        (l.beams, l.rate_hz, l.range_min, l.range_max),
        (720, 40.0, 0.1, 30.0)
    );
    assert!((l.fov - 2.0 * 1.570796).abs() < 1e-12);
    let gpu = sensors_of(&t.replace("type=\"ray\"", "type=\"gpu_ray\"")).unwrap();
    assert_eq!(gpu.lasers, s.lasers);
    // New Gazebo's <lidar> element under gpu_lidar.
    let lidar = t
        .replace("type=\"ray\"", "type=\"gpu_lidar\"")
        .replace("<ray>", "<lidar>")
        .replace("</ray>", "</lidar>");
    assert_eq!(sensors_of(&lidar).unwrap().lasers, s.lasers);
}

#[test]
fn an_off_centre_scan_or_a_sensor_pose_gets_its_own_frame() {
    let t = text("jackal_lms1xx.urdf")
        .replace(
            "<min_angle>-1.570796</min_angle>",
            "<min_angle>0</min_angle>",
        )
        .replace(
            "<max_angle>1.570796</max_angle>",
            "<max_angle>3.141592</max_angle>",
        )
        .replace("<pose>0 0 0 0 0 0</pose>", "<pose>0.1 0 0 0 0 0</pose>");
    let s = sensors_of(&t).unwrap();
    assert_eq!(s.lasers[0].mount, "front_laser_frame");
    let f = &s.frames[0];
    let model = RobotModel::from_urdf_str(&t, "j").unwrap();
    let link = model.mount("front_laser").unwrap().pose;
    let d = link.inverse() * f.pose;
    assert!((d.translation.vector.x - 0.1).abs() < 1e-9);
    // The scan's centre (π/2 left) becomes the frame's +x.
    assert!((d.rotation.euler_angles().2 - 0.5 * 3.141592).abs() < 1e-6);
}

#[test]
fn unreadable_blocks_are_refused_naming_file_sensor_and_field() {
    let t = text("jackal_lms1xx.urdf");
    let cases = [
        (
            "<samples>720</samples>",
            "",
            "ray.scan.horizontal.samples: missing",
        ),
        (
            "<samples>720</samples>",
            "<samples>nan</samples>",
            "samples: must be finite",
        ),
        (
            "<max_angle>1.570796</max_angle>",
            "<max_angle>-2</max_angle>",
            "ray.scan.horizontal.max_angle: must be >= min_angle",
        ),
        (
            "<max>30.0</max>",
            "<max>0.05</max>",
            "ray.range.max: must be greater",
        ),
        (
            "<min>0.10</min>",
            "<min>NaN</min>",
            "ray.range.min: must be finite",
        ),
        ("<update_rate>40</update_rate>", "", "update_rate: missing"),
        (
            "<stddev>0.001</stddev>",
            "<stddev>-1</stddev>",
            "ray.noise.stddev",
        ),
        (
            "<gazebo reference=\"front_laser\">",
            "<gazebo reference=\"nowhere\">",
            "\"nowhere\" is not a link",
        ),
    ];
    for (from, to, want) in cases {
        let e = sensors_of(&t.replace(from, to)).unwrap_err();
        assert!(
            e.starts_with("robot.urdf: gazebo[")
                && e.contains("sensor[front_laser]")
                && e.contains(want),
            "{from} -> {to}: {e}"
        );
    }
}

#[test]
fn mp400_is_refused_pointing_to_the_robot_keys_and_loads_with_them() {
    let t = text("mp_400.urdf");
    let e = RobotModel::from_urdf_str(&t, "mp_400.urdf")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("[robot] table") && e.contains("wheel_radius") && e.contains("track"),
        "{e}"
    );
    assert!(
        e.contains("mp_400_wheel_left_link (fixed joint, mesh"),
        "{e}"
    );
    let ovr = DriveOverride {
        wheel_radius: Some(0.075),
        track: Some(0.52),
    };
    let i = RobotModel::inspect_urdf_str_with(&t, "mp_400.urdf", &ovr).unwrap();
    let m = &i.model;
    assert_eq!(i.drive_source, DriveSource::OverrideMeshWheels);
    assert_eq!(m.left_wheel.link, "mp_400_wheel_left_link");
    assert_eq!(m.right_wheel.link, "mp_400_wheel_right_link");
    assert_eq!((m.wheel_radius, m.wheel_separation), (0.075, 0.52));
    assert!(m.left_wheel.axis.y.abs() > 0.99);
    // The wheels stand on the floor: axle 0.074 m above base_link, radius 0.075 m.
    assert!((m.base_height - 0.001).abs() < 1e-9, "{}", m.base_height);
    // A track that matches the casters' spacing still takes the drive wheels: caster meshes
    // are never drive wheels.
    let wrong = DriveOverride {
        wheel_radius: Some(0.075),
        track: Some(0.31),
    };
    let m2 = RobotModel::from_urdf_str_with(&t, "mp_400.urdf", &wrong).unwrap();
    assert_eq!(m2.left_wheel.link, "mp_400_wheel_left_link");
    assert_eq!(m2.wheel_separation, 0.31);
}

#[test]
fn the_override_replaces_urdf_geometry_and_is_validated() {
    let t = text("jackal_lms1xx.urdf");
    let plain = RobotModel::from_urdf_str(&t, "j").unwrap();
    let ovr = DriveOverride {
        wheel_radius: Some(0.1),
        track: Some(0.4),
    };
    let i = RobotModel::inspect_urdf_str_with(&t, "j", &ovr).unwrap();
    assert_eq!(i.drive_source, DriveSource::Override);
    assert_eq!((i.model.wheel_radius, i.model.wheel_separation), (0.1, 0.4));
    assert!(i.model.driven_wheels().iter().all(|w| w.radius == 0.1));
    // The skid steer keeps its effective-track ratio.
    let ratio = |m: &RobotModel| m.drive().wheel_separation / m.wheel_separation;
    assert!((ratio(&i.model) - ratio(&plain)).abs() < 1e-12);
    for (r, tr, field) in [
        (f64::NAN, 0.4, "robot.wheel_radius"),
        (-0.1, 0.4, "robot.wheel_radius"),
        (0.1, f64::INFINITY, "robot.track"),
        (0.1, 0.0, "robot.track"),
    ] {
        let e = DriveOverride {
            wheel_radius: Some(r),
            track: Some(tr),
        }
        .validate(Path::new("s.toml"))
        .unwrap_err()
        .to_string();
        assert!(e.starts_with(&format!("s.toml: {field}:")), "{e}");
    }
}
