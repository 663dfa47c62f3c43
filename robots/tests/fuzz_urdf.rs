//! Property-based fuzzing of the URDF loader: arbitrary and mutated text never panics (it
//! loads or it is an error), and whatever loads is usable (finite, positive, within limits).
//! Inputs that once failed are kept below as explicit regression tests.

use atrium_fuzz::{apply, config, mutation, xml_number_spans, Mutation};
use atrium_robots::urdf_limits::{MAX_LENGTH_M, MAX_MASS_KG, MIN_WHEEL_SEPARATION_M};
use atrium_robots::{RobotModel, Shape};
use proptest::prelude::*;
use proptest::sample::{select, Index};

/// A small robot using most of what the loader reads: inertials, collision and visual
/// geometry of every kind, a swivel caster, a fixed sensor link, a mesh.
const BASE: &str = r#"<?xml version="1.0"?>
<robot name="fuzz">
  <link name="base_link">
    <inertial><origin xyz="-0.05 0 0.1" rpy="0 0 0"/><mass value="8"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>
    <visual><geometry><mesh filename="package://fuzz/body.stl" scale="1 1 1"/></geometry></visual>
    <collision><origin xyz="0 0 0.12" rpy="0 0 0"/><geometry><box size="0.4 0.3 0.15"/></geometry></collision>
  </link>
  <link name="left_wheel">
    <inertial><mass value="0.4"/><inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" izz="0.001"/></inertial>
    <collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.08" length="0.03"/></geometry></collision>
  </link>
  <link name="right_wheel">
    <visual><origin rpy="-1.5707963267948966 0 0"/><geometry><capsule radius="0.08" length="0.01"/></geometry></visual>
  </link>
  <joint name="left_wheel_joint" type="continuous"><parent link="base_link"/><child link="left_wheel"/><origin xyz="0 0.17 0.08" rpy="0 0 0"/><axis xyz="0 1 0"/></joint>
  <joint name="right_wheel_joint" type="revolute"><parent link="base_link"/><child link="right_wheel"/><origin xyz="0 -0.17 0.08"/><axis xyz="0 1 0"/><limit lower="-1e9" upper="1e9" effort="1" velocity="1"/></joint>
  <link name="swivel"/>
  <link name="caster"><collision><geometry><sphere radius="0.03"/></geometry></collision></link>
  <joint name="swivel_joint" type="continuous"><parent link="base_link"/><child link="swivel"/><origin xyz="-0.15 0 0.05"/><axis xyz="0 0 1"/></joint>
  <joint name="caster_joint" type="fixed"><parent link="swivel"/><child link="caster"/><origin xyz="-0.02 0 -0.02"/></joint>
  <link name="laser"><collision><geometry><cylinder radius="0.03" length="0.05"/></geometry></collision></link>
  <joint name="laser_joint" type="fixed"><parent link="base_link"/><child link="laser"/><origin xyz="0.12 0 0.25" rpy="0 0 3.14159"/></joint>
</robot>
"#;

/// Snippets a mutation may splice in: XML syntax, URDF elements, and hostile numbers.
const TOKENS: &[&str] = &[
    "<", ">", "/>", "</", "\"", "'", "=", " ", "\n", "&", "&amp;", "&#0;", "&#x110000;", "<!--",
    "-->", "<![CDATA[", "]]>", "<?xml?>", "<!DOCTYPE r [<!ENTITY a \"aaaa\">]>", "&a;",
    "<link name=\"base_link\"/>", "<link name=\"x\"/>", "<link/>",
    "<joint name=\"j\" type=\"fixed\"><parent link=\"base_link\"/><child link=\"x\"/></joint>",
    "<joint name=\"k\" type=\"continuous\"><parent link=\"x\"/><child link=\"base_link\"/><axis xyz=\"0 1 0\"/></joint>",
    "<geometry/>", "<geometry><sphere radius=\"1\"/><box size=\"1 1 1\"/></geometry>",
    "<inertial/>", "<mass/>", "<axis/>", "<origin/>", "<collision/>", "<visual/>",
    "<xacro:property/>", "${x}", "$(find p)", "package://", "xmlns:xacro=\"xacro\"",
    "version=\"1.1\"", "version=\"1.2\"", "quat_xyzw=\"0 0 0 0\"", "quat_xyzw=\"1e200 0 0 1\"",
    "0", "-0", "1", "-1", "1e300", "-1e300", "1e-300", "5e-324", "1.7976931348623157e308",
    "NaN", "nan", "inf", "-inf", "infinity", "1e", "0x10", "1_0", "+1", ".", "-", "1 2",
    "1 2 3 4", "\u{0}", "\u{feff}", "é", "\u{10ffff}", "caster", "wheel",
];

/// Values a numeric attribute may be replaced by.
const NUMBERS: &[&str] = &[
    "0",
    "-0",
    "-1",
    "1e300",
    "-1e300",
    "1e-300",
    "5e-324",
    "1.7976931348623157e308",
    "NaN",
    "inf",
    "-inf",
    "1e-200",
    "3",
    "-0.2",
    "50",
    "50.000001",
    "1e5",
    "",
    " ",
    "1 1",
    "abc",
    "0 0 0",
    "1e-200 1e-200 0",
    "0 1e-320 0",
    "1 2 3 4",
];

/// What a loaded model must satisfy however hostile the text was.
fn check_usable(m: &RobotModel) {
    let finite3 = |v: &nalgebra::Vector3<f64>| v.iter().all(|x| x.is_finite());
    assert!(m.wheel_radius.is_finite() && m.wheel_radius > 0.0, "{m:?}");
    assert!(m.wheel_separation >= MIN_WHEEL_SEPARATION_M, "{m:?}");
    assert!(m.wheel_separation <= 2.0 * MAX_LENGTH_M, "{m:?}");
    assert!(
        m.chassis_mass > 0.0 && m.chassis_mass <= MAX_MASS_KG,
        "{m:?}"
    );
    assert!(
        finite3(&m.chassis_com) && m.base_height.is_finite(),
        "{m:?}"
    );
    for w in [&m.left_wheel, &m.right_wheel] {
        assert!(finite3(&w.center) && finite3(&w.axis), "{w:?}");
        assert!((w.axis.norm() - 1.0).abs() < 1e-9, "{w:?}");
        assert!(w.radius > 0.0 && w.width > 0.0 && w.mass > 0.0, "{w:?}");
        assert!(w.mass.is_finite(), "{w:?}");
    }
    assert!(m.left_wheel.center.y > 0.0 && m.right_wheel.center.y < 0.0);
    for c in &m.casters {
        assert!(
            finite3(&c.center) && c.radius > 0.0 && c.radius.is_finite(),
            "{c:?}"
        );
    }
    for s in &m.chassis_shapes {
        let dims: Vec<f64> = match s.shape {
            Shape::Box { size } => size.to_vec(),
            Shape::Cylinder { radius, length } => vec![radius, length],
            Shape::Sphere { radius } => vec![radius],
        };
        assert!(dims.iter().all(|d| d.is_finite() && *d > 0.0), "{s:?}");
    }
    for mount in &m.mounts {
        let p = &mount.pose;
        assert!(finite3(&p.translation.vector), "{mount:?}");
        assert!(p.rotation.coords.iter().all(|x| x.is_finite()), "{mount:?}");
    }
}

/// Loads `text`; a panic fails the property (proptest catches it), an error is fine.
fn load(text: &str) {
    if let Ok(m) = RobotModel::from_urdf_str(text, "fuzz.urdf") {
        check_usable(&m);
    }
    let _ = RobotModel::inspect_urdf_str(text, "fuzz.urdf");
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,400}") {
        load(&text);
    }

    #[test]
    fn token_soup_never_panics(tokens in prop::collection::vec(select(TOKENS), 0..80)) {
        load(&format!("<robot name=\"r\">{}</robot>", tokens.concat()));
        load(&tokens.concat());
    }

    #[test]
    fn mutated_urdf_never_panics(mutations in prop::collection::vec(mutation(TOKENS, NUMBERS), 1..8)) {
        load(&apply(BASE, &mutations, xml_number_spans));
    }

    #[test]
    fn hostile_numbers_never_give_garbage(
        numbers in prop::collection::vec((any::<Index>(), select(NUMBERS)), 1..6)
    ) {
        let mutations: Vec<Mutation> =
            numbers.into_iter().map(|(i, v)| Mutation::Number(i, v.to_string())).collect();
        load(&apply(BASE, &mutations, xml_number_spans));
    }
}

#[test]
fn base_loads() {
    let m = RobotModel::from_urdf_str(BASE, "fuzz.urdf").unwrap();
    check_usable(&m);
    assert_eq!(m.casters.len(), 1);
    assert!(xml_number_spans(BASE).len() > 60);
}

/// Inputs the fuzzing above found (or that were found by hand while writing it).
#[test]
fn regressions() {
    let cases: Vec<String> = vec![
        // The axis' squared norm underflows: a NaN axis lost the left wheel.
        BASE.replacen(r#"<axis xyz="0 1 0"/>"#, r#"<axis xyz="0 1e-200 0"/>"#, 1),
        // A 1e300 wheel radius gave an infinite wheel.
        BASE.replacen(r#"radius="0.08""#, r#"radius="1e300""#, 1),
        // Wheels 2e-300 m apart.
        BASE.replacen("0 0.17 0.08", "0 1e-300 0.08", 1)
            .replacen("0 -0.17 0.08", "0 -1e-300 0.08", 1),
        // A 5e-324 kg chassis: its default wheel mass (2 %) underflowed to 0 kg.
        BASE.replacen(r#"<mass value="8"/>"#, r#"<mass value="5e-324"/>"#, 1),
        // 100,000 nested elements: a stack overflow.
        format!("<robot name=\"r\">{}{}</robot>", "<a>".repeat(100_000), "</a>".repeat(100_000)),
        // Unclosed quote and comment, DTD, stray bytes.
        "<robot name=\"r><link name='a'/></robot>".into(),
        "<robot name=\"r\"><!-- <link name=\"a\"> </robot>".into(),
        "<!DOCTYPE r [<!ENTITY a \"aaaa\">]><robot name=\"&a;\"/>".into(),
        "<robot name=\"r\"><link name=\"a\"/><joint name=\"j\" type=\"fixed\"><parent link=\"a\"/><child link=\"a\"/></joint></robot>".into(),
        "\u{feff}<robot name=\"\u{0}\"/>".into(),
    ];
    for text in &cases {
        load(text);
    }
    for text in &cases[1..5] {
        assert!(
            RobotModel::from_urdf_str(text, "r.urdf").is_err(),
            "{}",
            &text[..80.min(text.len())]
        );
    }
    assert!(RobotModel::from_urdf_str(&cases[0], "r.urdf").is_ok());
}
