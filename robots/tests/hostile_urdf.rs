//! Hostile URDF input: no aborts, no hangs, no silent garbage. Every refusal is an error that
//! names the file, the link or joint, the field and the limit.

use atrium_robots::urdf_limits::{MAX_WHEEL_RADIUS_M, MAX_XML_DEPTH};
use atrium_robots::{RobotError, RobotModel};
use std::fmt::Write;
use std::path::Path;

fn bundled(name: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("urdf")
        .join(name);
    std::fs::read_to_string(path).unwrap()
}

/// A two-wheeled base with a mast of `n` links hanging off it by fixed joints, each 0.1 mm
/// above its parent, with 1 g and a 1 cm cube each.
fn chain(n: usize) -> String {
    let mut s = String::from(
        r#"<robot name="chain">
  <link name="base"><inertial><mass value="5"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><box size="0.4 0.3 0.1"/></geometry></collision></link>
  <link name="wl"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.05" length="0.02"/></geometry></collision></link>
  <link name="wr"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.05" length="0.02"/></geometry></collision></link>
  <joint name="jl" type="continuous"><parent link="base"/><child link="wl"/><origin xyz="0 0.2 0.05"/><axis xyz="0 1 0"/></joint>
  <joint name="jr" type="continuous"><parent link="base"/><child link="wr"/><origin xyz="0 -0.2 0.05"/><axis xyz="0 1 0"/></joint>
"#,
    );
    let mut parent = "base".to_string();
    for i in 0..n {
        let name = format!("c{i}");
        writeln!(
            s,
            r#"  <link name="{name}"><inertial><mass value="0.001"/><inertia ixx="1e-7" ixy="0" ixz="0" iyy="1e-7" iyz="0" izz="1e-7"/></inertial><collision><geometry><box size="0.01 0.01 0.01"/></geometry></collision></link>
  <joint name="j{name}" type="fixed"><parent link="{parent}"/><child link="{name}"/><origin xyz="0 0 0.0001"/></joint>"#
        )
        .unwrap();
        parent = name;
    }
    s.push_str("</robot>\n");
    s
}

/// Loading was quadratic in the number of links (a line-number lookup that scans the text
/// from its start, per link): 10,000 links took seconds. It is linear now; this checks the
/// result, and prints the time (run with `--nocapture` to see it).
#[test]
fn ten_thousand_link_chain_loads() {
    const N: usize = 10_000;
    let text = chain(N);
    let t = std::time::Instant::now();
    let m = RobotModel::from_urdf_str(&text, "chain.urdf").unwrap();
    eprintln!(
        "{N}-link chain ({} KB) loaded in {:?}",
        text.len() / 1024,
        t.elapsed()
    );
    assert_eq!(m.mounts.len(), N + 3);
    let top = m.mount(&format!("c{}", N - 1)).unwrap();
    assert!((top.pose.translation.vector.z - N as f64 * 1e-4).abs() < 1e-9);
    assert!((m.chassis_mass - (5.0 + N as f64 * 0.001)).abs() < 1e-9);
    assert_eq!(m.chassis_shapes.len(), N + 1);
    assert!((m.wheel_separation - 0.4).abs() < 1e-12);
    assert!(m.casters.is_empty());
}

/// 100,000 nested elements overflowed the XML parser's stack: an abort, not an error.
#[test]
fn deeply_nested_xml_is_an_error_not_a_stack_overflow() {
    let n = 100_000;
    let text = format!(
        "<robot name=\"r\">\n<link name=\"a\">{}{}</link></robot>",
        "<x>".repeat(n),
        "</x>".repeat(n)
    );
    let err = RobotModel::from_urdf_str(&text, "deep.urdf").unwrap_err();
    assert!(matches!(err, RobotError::Xml { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(
        msg.starts_with("deep.urdf: malformed XML: line 2: element <x>"),
        "{msg}"
    );
    assert!(msg.contains(&format!("more than {MAX_XML_DEPTH}")), "{msg}");
    // Depth up to the limit is fine as far as nesting goes (the URDF has no wheels).
    let ok_depth = MAX_XML_DEPTH - 3;
    let text = format!(
        "<robot name=\"r\"><link name=\"a\"><!-- <a><b><c> --><x a='>'>{}{}</x></link></robot>",
        "<y>".repeat(ok_depth - 1),
        "</y>".repeat(ok_depth - 1)
    );
    let msg = RobotModel::from_urdf_str(&text, "ok.urdf")
        .unwrap_err()
        .to_string();
    assert!(msg.contains("found 0 drive wheels"), "{msg}");
}

/// A 5 m wheel used to load and then show up as a start pose inside a wall (it reaches up
/// through the ceiling and out across the corridor).
#[test]
fn huge_wheel_is_refused_at_load_not_as_a_spawn_collision() {
    let text = bundled("pioneer3dx.urdf").replace(
        r#"<cylinder radius="0.0975" length="0.0475"/>"#,
        r#"<cylinder radius="5" length="0.0475"/>"#,
    );
    let msg = RobotModel::from_urdf_str(&text, "pioneer3dx.urdf")
        .unwrap_err()
        .to_string();
    assert!(msg.starts_with("pioneer3dx.urdf: link["), "{msg}");
    assert!(msg.contains("geometry.cylinder.radius"), "{msg}");
    assert!(msg.contains("drive wheel of joint"), "{msg}");
    assert!(
        msg.contains(&format!("limit of {MAX_WHEEL_RADIUS_M} m")),
        "{msg}"
    );
}

#[test]
fn pioneer_caster_wheel_exclusion_is_explained() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("urdf/pioneer3dx.urdf");
    let i = RobotModel::inspect_urdf(&path).unwrap();
    assert_eq!(i.model, RobotModel::from_urdf(&path).unwrap());
    let caster = i
        .excluded_joints
        .iter()
        .find(|e| e.joint == "caster_wheel_joint")
        .unwrap();
    assert_eq!(caster.link, "caster_wheel");
    assert!(
        caster.reason.contains("caster") && caster.reason.contains("caster_swivel_joint"),
        "{}",
        caster.reason
    );
    let swivel = i
        .excluded_joints
        .iter()
        .find(|e| e.joint == "caster_swivel_joint")
        .unwrap();
    assert!(swivel.reason.contains("not lateral"), "{}", swivel.reason);
    assert!(i
        .excluded_joints
        .iter()
        .all(|e| !e.joint.contains("wheel_joint") || e.joint.starts_with("caster")));
}
