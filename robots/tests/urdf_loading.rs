//! URDF loading against real published robots (tests/fixtures, see its README for sources and
//! licences), the bundled Pioneer 3-DX, and the errors a user meets.

use atrium_robots::{RobotError, RobotModel};
use nalgebra::Vector3;
use std::path::{Path, PathBuf};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

fn bundled(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("urdf")
        .join(name)
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

fn assert_vec(v: &Vector3<f64>, expected: [f64; 3], tol: f64) {
    let e = Vector3::from(expected);
    assert!((v - e).norm() <= tol, "{v:?} != {e:?}");
}

#[test]
fn fixtures_give_published_wheel_radius_and_separation() {
    for (file, radius, separation) in [
        ("turtlebot3_burger.urdf", 0.033, 0.160),
        ("turtlebot3_waffle.urdf", 0.033, 0.288),
        ("kobuki_standalone.urdf", 0.035, 0.230),
    ] {
        let m = RobotModel::from_urdf(&fixture(file)).unwrap();
        assert!(
            close(m.wheel_radius, radius, 1e-3),
            "{file}: {}",
            m.wheel_radius
        );
        assert!(
            close(m.wheel_separation, separation, 1e-3),
            "{file}: {}",
            m.wheel_separation
        );
        assert!(m.left_wheel.center.y > 0.0, "{file}");
        assert!(m.right_wheel.center.y < 0.0, "{file}");
        assert_eq!(m.left_wheel.joint, "wheel_left_joint", "{file}");
        assert_eq!(m.right_wheel.joint, "wheel_right_joint", "{file}");
        assert_eq!(m.base_link, "base_footprint", "{file}");
        // The fixtures have a collision primitive wherever they have a mesh.
        assert!(m.warnings.is_empty(), "{file}: {:?}", m.warnings);
        // Every link is a mount, the root at the identity.
        let root = m.mount("base_footprint").unwrap();
        assert_eq!(root.pose, nalgebra::Isometry3::identity());
    }
}

#[test]
fn turtlebot3_burger_in_detail() {
    let m = RobotModel::from_urdf(&fixture("turtlebot3_burger.urdf")).unwrap();
    // Wheel joints have rpy = (-1.57, 0, 0) and axis 0 0 1: Rx(-1.57)·ẑ = (0, sin 1.57, cos 1.57).
    assert_vec(
        &m.left_wheel.axis,
        [0.0, 1.57f64.sin(), 1.57f64.cos()],
        1e-12,
    );
    // base_link is 0.010 above the footprint and the wheel joints 0.023 above base_link.
    assert_vec(&m.left_wheel.center, [0.0, 0.08, 0.033], 1e-12);
    assert_vec(&m.right_wheel.center, [0.0, -0.08, 0.033], 1e-12);
    assert!(close(m.left_wheel.width, 0.018, 1e-12));
    assert!(close(m.left_wheel.mass, 2.849894e-2, 1e-12));
    // Radius 0.033 minus centre height 0.033: the footprint is on the floor.
    assert!(m.base_height.abs() < 1e-12, "{}", m.base_height);
    // Every link but the wheels: base_link, caster, LDS.
    assert!(close(m.chassis_mass, 0.825_735_04 + 0.005 + 0.114, 1e-12));
    assert!(close(m.mass(), m.chassis_mass + 2.0 * 2.849894e-2, 1e-12));
    // Chassis: base_link's box and the LDS cylinder; the caster box is a caster.
    let links: Vec<&str> = m.chassis_shapes.iter().map(|s| s.link.as_str()).collect();
    assert_eq!(links, ["base_link", "base_scan"]);
    // The caster is the small box under the back, 0.009 m thick once rolled by -1.57 rad:
    // its support sphere is the inscribed one (r = 0.0045) standing on the floor.
    assert_eq!(m.casters.len(), 1);
    let c = &m.casters[0];
    assert_eq!(c.link, "caster_back_link");
    assert!(close(c.radius, 0.0045, 1e-12));
    assert_vec(&c.center, [-0.081, 0.0, 0.0045], 1e-5);
    let (xyz, rpy) = m.mount("base_scan").unwrap().xyz_rpy();
    assert!(close(xyz[0], -0.032, 1e-12) && close(xyz[1], 0.0, 1e-12));
    assert!(close(xyz[2], 0.182, 1e-12));
    assert!(rpy.iter().all(|a| a.abs() < 1e-12));
    let (_, rpy) = m.mount("caster_back_link").unwrap().xyz_rpy();
    assert!(close(rpy[0], -1.57, 1e-12), "{rpy:?}");
}

#[test]
fn waffle_and_kobuki_casters() {
    let m = RobotModel::from_urdf(&fixture("turtlebot3_waffle.urdf")).unwrap();
    let mut ys: Vec<(String, f64, f64)> = m
        .casters
        .iter()
        .map(|c| (c.link.clone(), c.center.x, c.center.y))
        .collect();
    ys.sort_by(|a, b| a.0.cmp(&b.0));
    assert_eq!(ys.len(), 2);
    assert_eq!(ys[0].0, "caster_back_left_link");
    assert!(close(ys[0].1, -0.177, 1e-9) && close(ys[0].2, 0.064, 1e-5));
    assert!(close(ys[1].1, -0.177, 1e-9) && close(ys[1].2, -0.064, 1e-5));

    let k = RobotModel::from_urdf(&fixture("kobuki_standalone.urdf")).unwrap();
    // Wheel centre 0.0102 + 0.025 above the footprint with radius 0.035: the footprint is
    // 0.2 mm below the floor.
    assert!(close(k.base_height, -0.0002, 1e-12), "{}", k.base_height);
    assert_eq!(k.casters.len(), 2);
    for (c, x) in k.casters.iter().zip([0.115, -0.135]) {
        // Fixed caster cylinders lying on their side: spheres of the wheel radius on the floor.
        assert!(close(c.radius, 0.017, 1e-12));
        assert_vec(&c.center, [x, 0.0, 0.0002 + 0.017], 1e-9);
    }
    // 2.4 kg base, two 0.01 kg casters, the gyro and three cliff sensors.
    assert!(close(k.chassis_mass, 2.4 + 0.02 + 0.001 + 0.0003, 1e-12));
    assert!(close(k.left_wheel.mass, 0.01, 1e-12));
}

#[test]
fn pioneer3dx_bundled_model() {
    let m = RobotModel::from_urdf(&bundled("pioneer3dx.urdf")).unwrap();
    assert_eq!(m.name, "pioneer3dx");
    assert_eq!(m.base_link, "base_footprint");
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    assert!(close(m.wheel_radius, 0.0975, 1e-12));
    assert!(close(m.wheel_separation, 0.33, 1e-12));
    assert!(close(m.left_wheel.width, 0.0475, 1e-12));
    assert!(m.left_wheel.center.y > 0.0 && m.right_wheel.center.y < 0.0);
    assert_vec(&m.left_wheel.axis, [0.0, 1.0, 0.0], 1e-12);
    // base_footprint is on the floor under the axle (REP-120), so the base origin's height
    // above the floor is zero; the chassis frame base_link is at axle height above it.
    assert!(m.base_height.abs() < 1e-12, "{}", m.base_height);
    let base_link = m.mount("base_link").unwrap().xyz_rpy().0;
    assert!(close(base_link[2], 0.0975, 1e-12) && base_link[2] > m.base_height);
    // Laser at the front, scan plane 0.30 m above the floor.
    let (laser, _) = m.mount("laser").unwrap().xyz_rpy();
    assert!(
        close(laser[0], 0.16, 1e-12) && close(laser[2], 0.30, 1e-12),
        "{laser:?}"
    );
    // One caster: the swivel group, supported under its trailing 0.0375 m wheel.
    assert_eq!(m.casters.len(), 1);
    let c = &m.casters[0];
    assert_eq!(c.link, "caster_swivel");
    assert!(close(c.radius, 0.0375, 1e-12));
    assert_vec(&c.center, [-0.225, 0.0, 0.0375], 1e-12);
    // 9 kg robot plus the 4.5 kg LMS200; the drive wheels are 0.5 kg each.
    assert!(close(m.mass(), 13.5, 1e-9));
    assert!(close(m.chassis_mass, 12.5, 1e-9));
    let links: Vec<&str> = m.chassis_shapes.iter().map(|s| s.link.as_str()).collect();
    assert_eq!(links, ["base_link", "laser"]);
    // Body: 0.455 long, top plate at 0.237 m, 6 cm clearance.
    let body = &m.chassis_shapes[0];
    assert_eq!(
        body.shape,
        atrium_robots::Shape::Box {
            size: [0.455, 0.26, 0.177]
        }
    );
    assert_vec(&body.pose.translation.vector, [-0.045, 0.0, 0.1485], 1e-12);
    let width = 2.0 * (m.left_wheel.center.y + 0.5 * m.left_wheel.width);
    assert!(close(width, 0.381, 0.005), "overall width {width}");
}

#[test]
fn xacro_file_is_refused_with_advice() {
    let text = r#"<?xml version="1.0"?>
<robot name="r" xmlns:xacro="http://ros.org/wiki/xacro">
  <xacro:property name="wheel_radius" value="0.05"/>
  <link name="base_link"/>
</robot>"#;
    let err = RobotModel::from_urdf_str(text, "r.urdf.xacro").unwrap_err();
    assert!(matches!(err, RobotError::Xacro { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(
        msg.starts_with("r.urdf.xacro: this is a xacro file"),
        "{msg}"
    );
    assert!(msg.contains("<xacro:property> element at line 3"), "{msg}");
    // Undeclared prefix: not well-formed XML, but still recognisably xacro.
    let undeclared = "<robot name=\"r\">\n<xacro:include filename=\"a.xacro\"/>\n</robot>";
    let err = RobotModel::from_urdf_str(undeclared, "r.xacro").unwrap_err();
    assert!(matches!(err, RobotError::Xacro { .. }), "{err:?}");
}

#[test]
fn one_wheel_is_an_error_naming_what_was_found() {
    let text = r#"<robot name="uni">
  <link name="base_link"><inertial><mass value="3"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="wheel"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.1" length="0.03"/></geometry></collision></link>
  <joint name="wheel_joint" type="continuous"><parent link="base_link"/><child link="wheel"/><origin xyz="0 0.2 0"/><axis xyz="0 1 0"/></joint>
</robot>"#;
    let msg = RobotModel::from_urdf_str(text, "uni.urdf")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("drive wheel"), "{msg}");
    assert!(msg.contains("found 1 drive wheel: wheel_joint"), "{msg}");
    assert!(msg.starts_with("uni.urdf: "), "{msg}");
}

#[test]
fn malformed_xml_reports_line_and_column() {
    let text = "<robot name=\"r\">\n  <link name=\"a\">\n</robot>";
    let err = RobotModel::from_urdf_str(text, "bad.urdf").unwrap_err();
    assert!(matches!(err, RobotError::Xml { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(
        msg.starts_with("bad.urdf: malformed XML: line 3, column"),
        "{msg}"
    );
}

#[test]
fn missing_file_names_the_path() {
    let path = fixture("no_such_robot.urdf");
    let err = RobotModel::from_urdf(&path).unwrap_err();
    assert!(matches!(err, RobotError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("no_such_robot.urdf"), "{err}");
}

#[test]
fn mesh_only_chassis_link_is_reported() {
    let text = r#"<robot name="m">
  <link name="base_link">
    <visual><geometry><mesh filename="package://m_description/meshes/body.stl"/></geometry></visual>
    <collision><geometry><mesh filename="package://m_description/meshes/body.stl"/></geometry></collision>
    <inertial><mass value="4"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
  </link>
  <link name="l"><inertial><mass value="0.2"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><origin rpy="-1.5707963267948966 0 0"/><geometry><cylinder radius="0.06" length="0.02"/></geometry></collision></link>
  <link name="r"><inertial><mass value="0.2"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><origin rpy="-1.5707963267948966 0 0"/><geometry><cylinder radius="0.06" length="0.02"/></geometry></collision></link>
  <joint name="jl" type="continuous"><parent link="base_link"/><child link="l"/><origin xyz="0 0.15 0.06"/><axis xyz="0 1 0"/></joint>
  <joint name="jr" type="continuous"><parent link="base_link"/><child link="r"/><origin xyz="0 -0.15 0.06"/><axis xyz="0 1 0"/></joint>
</robot>"#;
    let m = RobotModel::from_urdf_str(text, "m.urdf").unwrap();
    assert!(m.chassis_shapes.is_empty());
    assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
    assert!(
        m.warnings[0].contains("\"base_link\" has only mesh geometry"),
        "{:?}",
        m.warnings
    );
    assert!(m.warnings[0].contains("package://m_description/meshes/body.stl"));
    assert!(close(m.wheel_radius, 0.06, 1e-12) && close(m.wheel_separation, 0.3, 1e-12));
    assert!(close(m.chassis_mass, 4.0, 1e-12) && close(m.left_wheel.mass, 0.2, 1e-12));
}

#[test]
fn visual_only_wheels_are_used_as_a_fallback() {
    // Same robot with the wheel cylinders given only as visuals.
    let text = r#"<robot name="v">
  <link name="base_link"><inertial><mass value="4"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><box size="0.3 0.2 0.1"/></geometry></collision></link>
  <link name="l"><visual><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.06" length="0.02"/></geometry></visual></link>
  <link name="r"><visual><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.06" length="0.02"/></geometry></visual></link>
  <joint name="jl" type="continuous"><parent link="base_link"/><child link="l"/><origin xyz="0 0.15 0.06"/><axis xyz="0 1 0"/></joint>
  <joint name="jr" type="continuous"><parent link="base_link"/><child link="r"/><origin xyz="0 -0.15 0.06"/><axis xyz="0 1 0"/></joint>
</robot>"#;
    let m = RobotModel::from_urdf_str(text, "v.urdf").unwrap();
    assert!(close(m.wheel_radius, 0.06, 1e-12));
    // No wheel masses: 2 % of the 4 kg chassis each.
    assert!(close(m.left_wheel.mass, 0.08, 1e-12));
    assert!(close(m.mass(), 4.16, 1e-12));
}
