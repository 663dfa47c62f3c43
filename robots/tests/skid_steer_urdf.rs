//! Robots people own: four- and six-wheel skid steers, and differential drives whose URDFs
//! carry quirks seen in published files (a fixed joint with an all-zero `<axis>`, visual-only
//! links, caster wheels on continuous joints), plus the drives that cannot be determined.

use atrium_robots::diff_drive::DEFAULT_EFFECTIVE_TRACK_RATIO;
use atrium_robots::model::{DriveKind, TrackSource};
use atrium_robots::{RobotInspection, RobotModel};
use std::path::Path;

const ROLL: &str = r#"rpy="1.5707963267948966 0 0""#;

/// A wheel link and its continuous joint at (x, y, z) with a cylinder of radius `r`.
fn wheel(name: &str, x: f64, y: f64, z: f64, r: f64) -> String {
    format!(
        r#"<link name="{name}"><inertial><mass value="1"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><origin {ROLL}/><geometry><cylinder radius="{r}" length="0.05"/></geometry></collision></link>
  <joint name="{name}_joint" type="continuous"><parent link="base"/><child link="{name}"/><origin xyz="{x} {y} {z}"/><axis xyz="0 1 0"/></joint>"#
    )
}

/// A robot with a 20 kg chassis box and the given parts.
fn robot(parts: &[String]) -> String {
    format!(
        r#"<robot name="t">
  <link name="base"><inertial><mass value="20"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><origin xyz="0 0 0.15"/><geometry><box size="0.8 0.4 0.15"/></geometry></collision></link>
{}
</robot>"#,
        parts.join("\n")
    )
}

fn four_wheels(rear_left_radius: f64) -> Vec<String> {
    vec![
        wheel("fl", 0.25, 0.28, 0.1, 0.1),
        wheel("rl", -0.25, 0.28, 0.1, rear_left_radius),
        wheel("fr", 0.25, -0.28, 0.1, 0.1),
        wheel("rr", -0.25, -0.28, 0.1, 0.1),
    ]
}

fn inspect(text: &str) -> RobotInspection {
    RobotModel::inspect_urdf_str(text, "t.urdf").unwrap()
}

fn error(text: &str) -> String {
    match RobotModel::from_urdf_str(text, "t.urdf") {
        Ok(m) => panic!("expected a refusal, loaded {:?}", m.drive_kind),
        Err(e) => e.to_string(),
    }
}

fn sides(m: &RobotModel) -> (Vec<String>, Vec<String>) {
    match &m.drive_kind {
        DriveKind::SkidSteer(s) => (
            s.left.iter().map(|w| w.joint.clone()).collect(),
            s.right.iter().map(|w| w.joint.clone()).collect(),
        ),
        DriveKind::Differential => panic!("not a skid steer"),
    }
}

#[test]
fn the_bundled_skid4_is_a_husky_like_skid_steer() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("urdf/skid4.urdf");
    let i = RobotModel::inspect_urdf(&path).unwrap();
    let m = &i.model;
    assert_eq!(
        sides(m),
        (
            vec![
                "front_left_wheel_joint".into(),
                "rear_left_wheel_joint".into()
            ],
            vec![
                "front_right_wheel_joint".into(),
                "rear_right_wheel_joint".into()
            ]
        )
    );
    // Husky figures: 0.1651 m wheels (here 0.165), 0.571 m track, about 50 kg.
    assert!((m.wheel_radius - 0.165).abs() < 1e-9);
    assert!((m.wheel_separation - 0.5708).abs() < 1e-9);
    assert!((m.mass() - 49.9).abs() < 1e-9, "{}", m.mass());
    let DriveKind::SkidSteer(s) = &m.drive_kind else {
        unreachable!()
    };
    assert_eq!(s.effective_track_source, TrackSource::Urdf);
    assert!((s.effective_track / m.wheel_separation - 1.875).abs() < 1e-9);
    assert!(m.casters.is_empty());
    assert!(m.mount("laser").is_some() && m.mount("imu_link").is_some());
    // The fixed IMU joint's all-zero axis is accepted silently (the URDF spec ignores it).
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    assert!(i.excluded_joints.is_empty(), "{:?}", i.excluded_joints);
}

#[test]
fn four_wheels_of_equal_radius_make_a_skid_steer_with_the_default_effective_track() {
    let m = RobotModel::from_urdf_str(&robot(&four_wheels(0.1)), "t.urdf").unwrap();
    assert_eq!(
        sides(&m),
        (
            vec!["fl_joint".into(), "rl_joint".into()],
            vec!["fr_joint".into(), "rr_joint".into()]
        )
    );
    assert!((m.wheel_separation - 0.56).abs() < 1e-12);
    let DriveKind::SkidSteer(s) = &m.drive_kind else {
        unreachable!()
    };
    assert_eq!(s.effective_track_source, TrackSource::DefaultRatio);
    assert!((s.effective_track - DEFAULT_EFFECTIVE_TRACK_RATIO * 0.56).abs() < 1e-12);
    assert!((m.drive().wheel_separation - s.effective_track).abs() < 1e-12);
    assert!((m.mass() - 24.0).abs() < 1e-12);
}

#[test]
fn six_wheels_make_a_skid_steer_with_three_per_side() {
    let mut parts = four_wheels(0.1);
    parts.push(wheel("ml", 0.0, 0.28, 0.1, 0.1));
    parts.push(wheel("mr", 0.0, -0.28, 0.1, 0.1));
    let m = RobotModel::from_urdf_str(&robot(&parts), "t.urdf").unwrap();
    let (left, right) = sides(&m);
    assert_eq!(left, ["fl_joint", "ml_joint", "rl_joint"]);
    assert_eq!(right, ["fr_joint", "mr_joint", "rr_joint"]);
}

#[test]
fn three_driven_wheels_on_one_side_are_refused_naming_the_joints() {
    let mut parts = four_wheels(0.1);
    parts.push(wheel("ml", 0.0, 0.28, 0.1, 0.1));
    let err = error(&robot(&parts));
    assert!(
        err.starts_with("t.urdf: cannot determine the drive"),
        "{err}"
    );
    for e in [
        "3 driven wheels on the left",
        "fl_joint",
        "ml_joint",
        "rl_joint",
        "2 on the right",
        "fr_joint",
        "rr_joint",
    ] {
        assert!(err.contains(e), "{e}: {err}");
    }
}

#[test]
fn mixed_wheel_radii_on_one_side_are_refused_naming_the_joints() {
    let err = error(&robot(&four_wheels(0.12)));
    assert!(
        err.starts_with("t.urdf: cannot determine the drive"),
        "{err}"
    );
    for e in [
        "the left side",
        "fl_joint r = 0.1 m",
        "rl_joint r = 0.12 m",
        "share a radius",
    ] {
        assert!(err.contains(e), "{e}: {err}");
    }
    // Within the tolerance (0.5 %): a tyre measured to a tenth of a millimetre loads.
    assert!(RobotModel::from_urdf_str(&robot(&four_wheels(0.1002)), "t.urdf").is_ok());
}

/// A differential drive (wheels at y = ±0.2) with the given extra parts.
fn diff(extra: &[String]) -> String {
    let mut parts = vec![
        wheel("left_wheel", 0.0, 0.2, 0.1, 0.1),
        wheel("right_wheel", 0.0, -0.2, 0.1, 0.1),
    ];
    parts.extend_from_slice(extra);
    robot(&parts)
}

#[test]
fn a_fixed_joint_with_an_all_zero_axis_is_accepted_but_a_moving_one_is_not() {
    let imu = |kind: &str| {
        format!(
            r#"<link name="imu"/><joint name="imu_joint" type="{kind}"><parent link="base"/><child link="imu"/><origin xyz="0 0 0.2"/><axis xyz="0 0 0"/>{}</joint>"#,
            if kind == "revolute" {
                r#"<limit lower="0" upper="1" effort="1" velocity="1"/>"#
            } else {
                ""
            }
        )
    };
    let m = RobotModel::from_urdf_str(&diff(&[imu("fixed")]), "t.urdf").unwrap();
    assert_eq!(m.drive_kind, DriveKind::Differential);
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    let err = error(&diff(&[imu("revolute")]));
    assert!(
        err.contains("joint[imu_joint].axis.xyz") && err.contains("zero vector"),
        "{err}"
    );
}

#[test]
fn visual_only_links_load() {
    // Wheels described by <visual> alone (no collision, no inertial), and a visual-only
    // decoration on top.
    let visual_wheel = |name: &str, y: f64| {
        format!(
            r#"<link name="{name}"><visual><origin {ROLL}/><geometry><cylinder radius="0.1" length="0.05"/></geometry></visual></link>
  <joint name="{name}_joint" type="continuous"><parent link="base"/><child link="{name}"/><origin xyz="0 {y} 0.1"/><axis xyz="0 1 0"/></joint>"#
        )
    };
    let deco = r#"<link name="top_plate"><visual><geometry><box size="0.5 0.3 0.01"/></geometry></visual></link>
  <joint name="top_plate_joint" type="fixed"><parent link="base"/><child link="top_plate"/><origin xyz="0 0 0.3"/></joint>
  <link name="logo"><visual><geometry><mesh filename="package://t/logo.dae"/></geometry></visual></link>
  <joint name="logo_joint" type="fixed"><parent link="base"/><child link="logo"/><origin xyz="0.3 0 0.2"/></joint>"#;
    let text = robot(&[
        visual_wheel("wl", 0.2),
        visual_wheel("wr", -0.2),
        deco.to_string(),
    ]);
    let m = RobotModel::from_urdf_str(&text, "t.urdf").unwrap();
    assert_eq!(m.left_wheel.joint, "wl_joint");
    assert!((m.wheel_radius - 0.1).abs() < 1e-12);
    // No wheel mass given: 2 % of the 20 kg chassis each.
    assert!((m.left_wheel.mass - 0.4).abs() < 1e-12);
    let said = |s: &str| m.warnings.iter().any(|w| w.contains(s));
    assert!(said("\"top_plate\" has no <collision>"), "{:?}", m.warnings);
    assert!(said("\"logo\" has only mesh geometry"), "{:?}", m.warnings);
    assert!(m.mount("top_plate").is_some() && m.mount("logo").is_some());
}

#[test]
fn continuous_caster_joints_are_casters() {
    // A caster by name on a continuous lateral joint, and an unnamed small wheel on the
    // centre line behind the axle on another continuous joint.
    let named = wheel("caster_front", 0.3, 0.0, 0.04, 0.04);
    let unnamed = wheel("tail", -0.3, 0.0, 0.04, 0.04);
    let i = inspect(&diff(&[named, unnamed]));
    assert_eq!(i.model.drive_kind, DriveKind::Differential);
    assert_eq!(i.model.left_wheel.joint, "left_wheel_joint");
    let reason = |joint: &str| {
        i.excluded_joints
            .iter()
            .find(|e| e.joint == joint)
            .unwrap_or_else(|| panic!("{joint}: {:?}", i.excluded_joints))
            .reason
            .clone()
    };
    assert!(reason("caster_front_joint").contains("name contains \"caster\""));
    let r = reason("tail_joint");
    assert!(r.contains("centre line") && r.contains("continuous"), "{r}");
    // Both carry weight as frictionless support spheres.
    let mut links: Vec<&str> = i.model.casters.iter().map(|c| c.link.as_str()).collect();
    links.sort();
    assert_eq!(links, ["caster_front", "tail"]);
    assert!(i
        .model
        .warnings
        .iter()
        .all(|w| !w.contains("held at position 0")));
}
