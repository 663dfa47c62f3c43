//! URDF loading into a [`RobotModel`].
//!
//! urdf-rs gives the typed tree; roxmltree reads the raw XML first, because urdf-rs silently
//! defaults what a loader must notice (an omitted `<axis>` becomes 1 0 0, a missing mass 0),
//! drops unparsable numbers from vectors, and reports errors without naming the element.

use crate::error::RobotError;
use crate::model::{Caster, LinkMount, RobotModel, Shape, ShapeInstance, Wheel};
use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};
use urdf_rs::{Geometry, JointType};

/// A joint axis counts as lateral (a drive-wheel axle) above this |axis·ŷ|.
const LATERAL: f64 = 0.9;
/// A joint axis counts as vertical (a caster swivel) above this |axis·ẑ|.
const VERTICAL: f64 = 0.9;
/// Wheel mass as a fraction of the chassis mass when the URDF gives none.
const DEFAULT_WHEEL_MASS_FRACTION: f64 = 0.02;
/// A caster whose lowest point is farther than this from the floor gets a warning.
const CASTER_GAP_WARN: f64 = 0.005;

pub(crate) fn load_file(path: &Path) -> Result<RobotModel, RobotError> {
    let text = std::fs::read_to_string(path).map_err(|err| RobotError::Io {
        source_name: path.display().to_string(),
        err,
    })?;
    load_str(&text, &path.display().to_string())
}

pub(crate) fn load_str(text: &str, source: &str) -> Result<RobotModel, RobotError> {
    let doc = match roxmltree::Document::parse(text) {
        Ok(doc) => doc,
        Err(err) => {
            // An undeclared `xacro:` prefix is a parse error, but the useful answer is "xacro".
            if let Some(line) = text.lines().position(|l| l.contains("<xacro:")) {
                return Err(RobotError::Xacro {
                    source_name: source.into(),
                    hint: format!("<xacro:...> element at line {}", line + 1),
                });
            }
            let pos = err.pos();
            return Err(RobotError::Xml {
                source_name: source.into(),
                msg: format!("line {}, column {}: {err}", pos.row, pos.col),
            });
        }
    };
    detect_xacro(&doc, source)?;
    let facts = check_xml(&doc, source)?;
    let robot = urdf_rs::read_from_string(text).map_err(|e| RobotError::Invalid {
        source_name: source.into(),
        msg: format!("URDF: {e}"),
    })?;
    build(&robot, &facts, source)
}

fn invalid(source: &str, msg: impl Into<String>) -> RobotError {
    RobotError::Invalid {
        source_name: source.into(),
        msg: msg.into(),
    }
}

fn field_err(source: &str, field: impl Into<String>, msg: impl Into<String>) -> RobotError {
    RobotError::Field {
        file: PathBuf::from(source),
        field: field.into(),
        msg: msg.into(),
    }
}

// ---------------------------------------------------------------------------------------------
// Raw XML checks
// ---------------------------------------------------------------------------------------------

/// What the raw XML says that urdf-rs's typed result hides.
#[derive(Default)]
struct XmlFacts {
    /// Movable joints with no `<axis>` element (urdf-rs reports 1 0 0 for them).
    joints_without_axis: HashSet<String>,
}

/// Rejects xacro sources. A bare `xmlns:xacro` declaration is not enough: real plain URDFs
/// (TurtleBot3) keep the declaration after expansion, so only xacro elements and `${...}` /
/// `$(...)` substitutions outside comments count.
fn detect_xacro(doc: &roxmltree::Document, source: &str) -> Result<(), RobotError> {
    let line = |node: roxmltree::Node| doc.text_pos_at(node.range().start).row;
    let declared = doc
        .root_element()
        .namespaces()
        .any(|ns| ns.uri().contains("xacro"));
    let declared_note = if declared {
        "; the file declares xmlns:xacro"
    } else {
        ""
    };
    for node in doc.descendants() {
        let hint = if node.is_element() {
            if node
                .tag_name()
                .namespace()
                .is_some_and(|ns| ns.contains("xacro"))
            {
                Some(format!(
                    "<xacro:{}> element at line {}",
                    node.tag_name().name(),
                    line(node)
                ))
            } else {
                node.attributes()
                    .find(|a| is_substitution(a.value()))
                    .map(|a| {
                        format!(
                            "attribute {}=\"{}\" of <{}> at line {} uses a xacro substitution",
                            a.name(),
                            a.value(),
                            node.tag_name().name(),
                            line(node)
                        )
                    })
            }
        } else if node.is_text() && node.text().is_some_and(is_substitution) {
            Some(format!(
                "text at line {} uses a xacro substitution",
                line(node)
            ))
        } else {
            None
        };
        if let Some(hint) = hint {
            return Err(RobotError::Xacro {
                source_name: source.into(),
                hint: format!("{hint}{declared_note}"),
            });
        }
    }
    Ok(())
}

fn is_substitution(s: &str) -> bool {
    s.contains("${") || s.contains("$(")
}

fn child<'a, 'i>(node: roxmltree::Node<'a, 'i>, name: &str) -> Option<roxmltree::Node<'a, 'i>> {
    node.children()
        .find(|c| c.is_element() && c.tag_name().name() == name)
}

/// Parses exactly `n` finite numbers from an attribute value.
fn parse_numbers(value: &str, n: usize) -> Result<Vec<f64>, String> {
    let mut out = Vec::with_capacity(n);
    for token in value.split_whitespace() {
        let v: f64 = token
            .parse()
            .map_err(|_| format!("{token:?} is not a number (in \"{value}\")"))?;
        if !v.is_finite() {
            return Err(format!("must be finite (got \"{value}\")"));
        }
        out.push(v);
    }
    if out.len() != n {
        return Err(format!("expected {n} numbers, got \"{value}\""));
    }
    Ok(out)
}

/// Reads a required attribute of `n` numbers; `field` names it in errors.
fn numbers_attr(
    node: roxmltree::Node,
    attr: &str,
    n: usize,
    field: &str,
    source: &str,
) -> Result<Vec<f64>, RobotError> {
    let value = node
        .attribute(attr)
        .ok_or_else(|| field_err(source, field, "missing"))?;
    parse_numbers(value, n).map_err(|msg| field_err(source, field, msg))
}

fn positive_attr(
    node: roxmltree::Node,
    attr: &str,
    field: &str,
    source: &str,
) -> Result<f64, RobotError> {
    let v = numbers_attr(node, attr, 1, field, source)?[0];
    if v <= 0.0 {
        return Err(field_err(source, field, format!("must be > 0 (got {v})")));
    }
    Ok(v)
}

fn check_origin(parent: roxmltree::Node, prefix: &str, source: &str) -> Result<(), RobotError> {
    let Some(origin) = child(parent, "origin") else {
        return Ok(());
    };
    for (attr, n) in [("xyz", 3), ("rpy", 3), ("quat_xyzw", 4)] {
        if origin.attribute(attr).is_some() {
            numbers_attr(origin, attr, n, &format!("{prefix}.origin.{attr}"), source)?;
        }
    }
    Ok(())
}

fn check_geometry(parent: roxmltree::Node, prefix: &str, source: &str) -> Result<(), RobotError> {
    let geometry = child(parent, "geometry")
        .ok_or_else(|| field_err(source, format!("{prefix}.geometry"), "missing"))?;
    let shapes: Vec<_> = geometry.children().filter(|c| c.is_element()).collect();
    let [shape] = shapes.as_slice() else {
        return Err(field_err(
            source,
            format!("{prefix}.geometry"),
            format!(
                "must hold exactly one of box, cylinder, sphere, capsule, mesh (found {})",
                shapes.len()
            ),
        ));
    };
    let name = shape.tag_name().name();
    let field = |attr: &str| format!("{prefix}.geometry.{name}.{attr}");
    match name {
        "box" => {
            let size = numbers_attr(*shape, "size", 3, &field("size"), source)?;
            if size.iter().any(|&s| s <= 0.0) {
                return Err(field_err(
                    source,
                    field("size"),
                    format!("every side must be > 0 (got {size:?})"),
                ));
            }
        }
        "cylinder" | "capsule" => {
            positive_attr(*shape, "radius", &field("radius"), source)?;
            positive_attr(*shape, "length", &field("length"), source)?;
        }
        "sphere" => {
            positive_attr(*shape, "radius", &field("radius"), source)?;
        }
        "mesh" => {
            if shape
                .attribute("filename")
                .is_none_or(|f| f.trim().is_empty())
            {
                return Err(field_err(source, field("filename"), "missing"));
            }
            if shape.attribute("scale").is_some() {
                numbers_attr(*shape, "scale", 3, &field("scale"), source)?;
            }
        }
        other => {
            return Err(field_err(
                source,
                format!("{prefix}.geometry"),
                format!(
                    "unknown shape <{other}> (expected box, cylinder, sphere, capsule or mesh)"
                ),
            ))
        }
    }
    Ok(())
}

fn check_link(link: roxmltree::Node, name: &str, source: &str) -> Result<(), RobotError> {
    for kind in ["visual", "collision"] {
        let elements = link
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == kind);
        for (i, element) in elements.enumerate() {
            let prefix = format!("link[{name}].{kind}[{i}]");
            check_origin(element, &prefix, source)?;
            check_geometry(element, &prefix, source)?;
        }
    }
    if let Some(inertial) = child(link, "inertial") {
        let prefix = format!("link[{name}].inertial");
        check_origin(inertial, &prefix, source)?;
        let mass = child(inertial, "mass")
            .ok_or_else(|| field_err(source, format!("{prefix}.mass"), "missing"))?;
        let field = format!("{prefix}.mass.value");
        let m = numbers_attr(mass, "value", 1, &field, source)?[0];
        if m < 0.0 {
            return Err(field_err(source, field, format!("must be >= 0 (got {m})")));
        }
        let inertia = child(inertial, "inertia")
            .ok_or_else(|| field_err(source, format!("{prefix}.inertia"), "missing"))?;
        for attr in ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"] {
            numbers_attr(
                inertia,
                attr,
                1,
                &format!("{prefix}.inertia.{attr}"),
                source,
            )?;
        }
    }
    Ok(())
}

fn check_joint(joint: roxmltree::Node, name: &str, source: &str) -> Result<bool, RobotError> {
    let prefix = format!("joint[{name}]");
    let kind = joint
        .attribute("type")
        .ok_or_else(|| field_err(source, format!("{prefix}.type"), "missing"))?;
    const TYPES: [&str; 7] = [
        "revolute",
        "continuous",
        "prismatic",
        "fixed",
        "floating",
        "planar",
        "spherical",
    ];
    if !TYPES.contains(&kind) {
        return Err(field_err(
            source,
            format!("{prefix}.type"),
            format!(
                "unknown joint type {kind:?} (expected one of {})",
                TYPES.join(", ")
            ),
        ));
    }
    for end in ["parent", "child"] {
        let ok = child(joint, end)
            .and_then(|e| e.attribute("link"))
            .is_some_and(|l| !l.trim().is_empty());
        if !ok {
            return Err(field_err(source, format!("{prefix}.{end}.link"), "missing"));
        }
    }
    check_origin(joint, &prefix, source)?;
    match child(joint, "axis") {
        Some(axis) => {
            let field = format!("{prefix}.axis.xyz");
            let xyz = numbers_attr(axis, "xyz", 3, &field, source)?;
            if xyz.iter().all(|&v| v == 0.0) {
                return Err(field_err(source, field, "must not be the zero vector"));
            }
            Ok(true)
        }
        None => Ok(false),
    }
}

/// Validates every number the loader relies on, so that errors name the link or joint and
/// the field, and so that nothing urdf-rs defaults goes unnoticed.
fn check_xml(doc: &roxmltree::Document, source: &str) -> Result<XmlFacts, RobotError> {
    let root = doc.root_element();
    if root.tag_name().name() != "robot" {
        return Err(invalid(
            source,
            format!(
                "the root element is <{}>; a URDF's root element is <robot>",
                root.tag_name().name()
            ),
        ));
    }
    let mut facts = XmlFacts::default();
    let mut links = HashSet::new();
    let mut joints = HashSet::new();
    for node in root.children().filter(|c| c.is_element()) {
        let kind = node.tag_name().name();
        if kind != "link" && kind != "joint" {
            continue;
        }
        let line = doc.text_pos_at(node.range().start).row;
        let name = node
            .attribute("name")
            .filter(|n| !n.trim().is_empty())
            .ok_or_else(|| field_err(source, format!("{kind} at line {line}"), "has no name"))?;
        let seen = if kind == "link" {
            &mut links
        } else {
            &mut joints
        };
        if !seen.insert(name.to_string()) {
            return Err(invalid(
                source,
                format!("{kind} name {name:?} is used twice (again at line {line})"),
            ));
        }
        if kind == "link" {
            check_link(node, name, source)?;
        } else if !check_joint(node, name, source)? {
            let kind = node.attribute("type").unwrap_or_default();
            if matches!(kind, "revolute" | "continuous" | "prismatic") {
                facts.joints_without_axis.insert(name.to_string());
            }
        }
    }
    Ok(facts)
}

// ---------------------------------------------------------------------------------------------
// Kinematic tree and geometry
// ---------------------------------------------------------------------------------------------

/// URDF orientation: fixed-axis roll about x, then pitch about y, then yaw about z,
/// R = Rz(yaw)·Ry(pitch)·Rx(roll).
fn rpy_rotation(rpy: [f64; 3]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), rpy[2])
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), rpy[1])
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), rpy[0])
}

fn origin_pose(p: &urdf_rs::Pose) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::new(p.xyz[0], p.xyz[1], p.xyz[2]),
        rpy_rotation(p.rpy.0),
    )
}

/// One link placed in the base frame at zero joint positions.
struct Node<'a> {
    link: &'a urdf_rs::Link,
    pose: Isometry3<f64>,
    /// The joint whose child this link is (None for the root).
    joint: Option<&'a urdf_rs::Joint>,
    /// That joint's unit axis in the base frame.
    axis: Vector3<f64>,
    parent: Option<usize>,
}

/// A link's usable geometry in the base frame.
#[derive(Default)]
struct LinkGeometry {
    prims: Vec<ShapeInstance>,
    meshes: Vec<String>,
    from_visual: bool,
    capsules: usize,
}

/// Collision geometry when the link has any; visual geometry only as a fallback, because
/// some published URDFs describe wheels and bodies with visuals alone.
fn link_geometry(link: &urdf_rs::Link, pose: &Isometry3<f64>) -> LinkGeometry {
    let mut out = LinkGeometry::default();
    let elements: Vec<(&urdf_rs::Pose, &Geometry)> = if link.collision.is_empty() {
        out.from_visual = !link.visual.is_empty();
        link.visual
            .iter()
            .map(|v| (&v.origin, &v.geometry))
            .collect()
    } else {
        link.collision
            .iter()
            .map(|c| (&c.origin, &c.geometry))
            .collect()
    };
    for (origin, geometry) in elements {
        let shape = match geometry {
            Geometry::Box { size } => Shape::Box { size: size.0 },
            Geometry::Cylinder { radius, length } => Shape::Cylinder {
                radius: *radius,
                length: *length,
            },
            Geometry::Sphere { radius } => Shape::Sphere { radius: *radius },
            // A capsule's URDF length is that of its cylindrical part; the cylinder spanning
            // both caps keeps the same footprint and height.
            Geometry::Capsule { radius, length } => {
                out.capsules += 1;
                Shape::Cylinder {
                    radius: *radius,
                    length: length + 2.0 * radius,
                }
            }
            Geometry::Mesh { filename, .. } => {
                out.meshes.push(filename.clone());
                continue;
            }
        };
        out.prims.push(ShapeInstance {
            link: link.name.clone(),
            shape,
            pose: pose * origin_pose(origin),
        });
    }
    out
}

/// Height of the lowest point of a placed primitive, in the base frame.
fn lowest_z(p: &ShapeInstance) -> f64 {
    let c = p.pose.translation.vector.z;
    match p.shape {
        Shape::Sphere { radius } => c - radius,
        Shape::Cylinder { radius, length } => {
            let a = (p.pose.rotation * Vector3::z()).z.abs().min(1.0);
            c - (a * 0.5 * length + radius * (1.0 - a * a).sqrt())
        }
        Shape::Box { size } => {
            let r = p.pose.rotation.to_rotation_matrix();
            let m = r.matrix();
            c - (0..3).map(|i| m[(2, i)].abs() * 0.5 * size[i]).sum::<f64>()
        }
    }
}

/// Radius of the sphere that stands in for a caster primitive: a rolling cylinder rolls on
/// its rim; anything else is replaced by the largest sphere that fits inside it.
fn support_radius(p: &ShapeInstance) -> f64 {
    match p.shape {
        Shape::Sphere { radius } => radius,
        Shape::Cylinder { radius, length } => {
            let a = (p.pose.rotation * Vector3::z()).z.abs();
            if a < 0.5 {
                radius
            } else {
                radius.min(0.5 * length)
            }
        }
        Shape::Box { size } => 0.5 * size.iter().copied().fold(f64::INFINITY, f64::min),
    }
}

fn is_caster_name(name: &str) -> bool {
    name.to_ascii_lowercase().contains("caster")
}

fn is_revolving(j: &urdf_rs::Joint) -> bool {
    matches!(j.joint_type, JointType::Continuous | JointType::Revolute)
}

fn joint_kind(j: &urdf_rs::Joint) -> &'static str {
    match j.joint_type {
        JointType::Revolute => "revolute",
        JointType::Continuous => "continuous",
        JointType::Prismatic => "prismatic",
        JointType::Fixed => "fixed",
        JointType::Floating => "floating",
        JointType::Planar => "planar",
        JointType::Spherical => "spherical",
    }
}

/// Orders the links from the root and places each in the base frame.
fn kinematic_tree<'a>(
    robot: &'a urdf_rs::Robot,
    source: &str,
) -> Result<Vec<Node<'a>>, RobotError> {
    let links: HashMap<&str, &urdf_rs::Link> =
        robot.links.iter().map(|l| (l.name.as_str(), l)).collect();
    let mut parent_joint: HashMap<&str, &urdf_rs::Joint> = HashMap::new();
    let mut children: HashMap<&str, Vec<&urdf_rs::Joint>> = HashMap::new();
    for j in &robot.joints {
        for (end, name) in [("parent", &j.parent.link), ("child", &j.child.link)] {
            if !links.contains_key(name.as_str()) {
                return Err(field_err(
                    source,
                    format!("joint[{}].{end}.link", j.name),
                    format!("no link is named {name:?}"),
                ));
            }
        }
        if let Some(other) = parent_joint.insert(j.child.link.as_str(), j) {
            return Err(invalid(
                source,
                format!(
                    "link {:?} is the child of two joints ({:?} and {:?}); a URDF is a tree",
                    j.child.link, other.name, j.name
                ),
            ));
        }
        children.entry(j.parent.link.as_str()).or_default().push(j);
    }
    let roots: Vec<&str> = robot
        .links
        .iter()
        .map(|l| l.name.as_str())
        .filter(|n| !parent_joint.contains_key(n))
        .collect();
    let root = match roots.as_slice() {
        [root] => *root,
        [] => {
            return Err(invalid(
                source,
                if robot.links.is_empty() {
                    "the URDF has no links".to_string()
                } else {
                    "every link is the child of a joint: the joints form a cycle".to_string()
                },
            ))
        }
        many => {
            return Err(invalid(
                source,
                format!(
                    "{} root links ({}); every link but one must be the child of a joint",
                    many.len(),
                    many.join(", ")
                ),
            ))
        }
    };
    let mut nodes = vec![Node {
        link: links[root],
        pose: Isometry3::identity(),
        joint: None,
        axis: Vector3::zeros(),
        parent: None,
    }];
    let mut next = 0;
    while next < nodes.len() {
        let name = nodes[next].link.name.as_str();
        let parent_pose = nodes[next].pose;
        for j in children.get(name).map(Vec::as_slice).unwrap_or_default() {
            let joint_pose = parent_pose * origin_pose(&j.origin);
            let axis = joint_pose.rotation * Vector3::from(j.axis.xyz.0).normalize();
            nodes.push(Node {
                link: links[j.child.link.as_str()],
                pose: joint_pose,
                joint: Some(j),
                axis,
                parent: Some(next),
            });
        }
        next += 1;
    }
    if nodes.len() != robot.links.len() {
        let reached: HashSet<&str> = nodes.iter().map(|n| n.link.name.as_str()).collect();
        let lost: Vec<&str> = robot
            .links
            .iter()
            .map(|l| l.name.as_str())
            .filter(|n| !reached.contains(n))
            .collect();
        return Err(invalid(
            source,
            format!(
                "links not connected to the root {root:?} (their joints form a cycle): {}",
                lost.join(", ")
            ),
        ));
    }
    Ok(nodes)
}

/// Which part of the robot a link moves with.
#[derive(Clone, Copy, PartialEq)]
enum Owner {
    Chassis,
    Wheel,
    /// Index of the caster's topmost link.
    Caster(usize),
}

fn build(robot: &urdf_rs::Robot, facts: &XmlFacts, source: &str) -> Result<RobotModel, RobotError> {
    let nodes = kinematic_tree(robot, source)?;
    let geometry: Vec<LinkGeometry> = nodes
        .iter()
        .map(|n| link_geometry(n.link, &n.pose))
        .collect();
    let mut warnings = Vec::new();

    // A swivel (revolving joint about a vertical axis) above a wheel makes it a caster wheel.
    let under_swivel = |mut i: usize| {
        while let Some(p) = nodes[i].parent {
            let j = nodes[i].joint.expect("non-root nodes have a joint");
            if is_revolving(j) && nodes[i].axis.z.abs() > VERTICAL {
                return true;
            }
            i = p;
        }
        false
    };

    // ---- drive wheels
    let mut wheels: Vec<(usize, (f64, f64, &ShapeInstance))> = Vec::new();
    let mut skipped: Vec<String> = Vec::new();
    for (i, node) in nodes.iter().enumerate() {
        let Some(j) = node.joint else { continue };
        if !is_revolving(j) || node.axis.y.abs() <= LATERAL {
            continue;
        }
        if is_caster_name(&j.name) || is_caster_name(&node.link.name) || under_swivel(i) {
            continue;
        }
        let round = geometry[i]
            .prims
            .iter()
            .filter_map(|p| match p.shape {
                Shape::Cylinder { radius, length } => Some((radius, length, p)),
                Shape::Sphere { radius } => Some((radius, 2.0 * radius, p)),
                Shape::Box { .. } => None,
            })
            .max_by(|a, b| a.0.total_cmp(&b.0));
        match round {
            Some(w) => wheels.push((i, w)),
            None => skipped.push(format!(
                "joint {:?} has a lateral axis but its link {:?} has no cylinder or sphere {}",
                j.name,
                node.link.name,
                if geometry[i].meshes.is_empty() {
                    "geometry".to_string()
                } else {
                    format!("(only mesh {})", geometry[i].meshes.join(", "))
                }
            )),
        }
    }
    let describe = |(i, (_, _, p)): &(usize, (f64, f64, &ShapeInstance))| {
        format!(
            "{} (link {}, y = {:.3} m)",
            nodes[*i].joint.map(|j| j.name.as_str()).unwrap_or_default(),
            nodes[*i].link.name,
            p.pose.translation.vector.y
        )
    };
    let listed: Vec<String> = wheels.iter().map(describe).collect();
    if wheels.len() < 2 {
        let mut msg = format!(
            "found {} drive wheel{}{}{}; a differential drive needs two continuous or revolute \
             joints with a lateral (±y) axis whose child link has a cylinder or sphere collision, \
             one left (y > 0) and one right (y < 0)",
            wheels.len(),
            if wheels.len() == 1 { "" } else { "s" },
            if wheels.is_empty() { "" } else { ": " },
            listed.join(", ")
        );
        if !skipped.is_empty() {
            msg.push_str(&format!("; skipped: {}", skipped.join("; ")));
        }
        return Err(invalid(source, msg));
    }
    if wheels.len() > 2 {
        return Err(invalid(
            source,
            format!(
                "found {} lateral wheel joints: {}; Atrium supports exactly two drive wheels \
                 (differential drive), not skid steer",
                wheels.len(),
                listed.join(", ")
            ),
        ));
    }
    let mut made = Vec::with_capacity(2);
    for &(i, (radius, width, p)) in &wheels {
        let node = &nodes[i];
        if let Shape::Cylinder { .. } = p.shape {
            let cyl_axis = p.pose.rotation * Vector3::z();
            if cyl_axis.dot(&node.axis).abs() <= LATERAL {
                return Err(field_err(
                    source,
                    format!("link[{}].collision", node.link.name),
                    format!(
                        "the wheel cylinder's axis ({:.3}, {:.3}, {:.3} in the base frame) is \
                             not along its joint's axis ({:.3}, {:.3}, {:.3})",
                        cyl_axis.x, cyl_axis.y, cyl_axis.z, node.axis.x, node.axis.y, node.axis.z
                    ),
                ));
            }
        }
        made.push(Wheel {
            joint: node.joint.map(|j| j.name.clone()).unwrap_or_default(),
            link: node.link.name.clone(),
            center: p.pose.translation.vector,
            axis: node.axis,
            radius,
            width,
            mass: node.link.inertial.mass.value,
        });
    }
    let (mut left_wheel, mut right_wheel) = {
        let b = made.pop().expect("two wheels");
        let a = made.pop().expect("two wheels");
        if a.center.y >= b.center.y {
            (a, b)
        } else {
            (b, a)
        }
    };
    if left_wheel.center.y <= 0.0 || right_wheel.center.y >= 0.0 {
        return Err(invalid(
            source,
            format!(
                "the two drive wheels must be one left (y > 0) and one right (y < 0) of the base \
                 link {:?}; found {}",
                nodes[0].link.name,
                listed.join(", ")
            ),
        ));
    }
    let wheel_links = [left_wheel.link.clone(), right_wheel.link.clone()];

    // ---- mass
    let chassis_mass: f64 = nodes
        .iter()
        .filter(|n| !wheel_links.contains(&n.link.name))
        .map(|n| n.link.inertial.mass.value)
        .sum();
    if !(chassis_mass > 0.0 && chassis_mass.is_finite()) {
        return Err(invalid(
            source,
            format!(
                "the chassis mass (sum of <inertial><mass> of every link except the drive \
                 wheels) is {chassis_mass} kg; it must be > 0"
            ),
        ));
    }
    // Centre of mass of the chassis from the URDF inertials (not from collision volumes:
    // a heavy sensor on a light frame moves it, and with a single rear caster that decides
    // whether the robot tips forward when it brakes).
    let chassis_com = nodes
        .iter()
        .filter(|n| !wheel_links.contains(&n.link.name))
        .map(|n| {
            let origin = origin_pose(&n.link.inertial.origin);
            let c = n.pose * origin * nalgebra::Point3::origin();
            c.coords * n.link.inertial.mass.value
        })
        .fold(Vector3::zeros(), |a, b| a + b)
        / chassis_mass;
    for w in [&mut left_wheel, &mut right_wheel] {
        if w.mass <= 0.0 {
            w.mass = DEFAULT_WHEEL_MASS_FRACTION * chassis_mass;
            warnings.push(format!(
                "wheel link {:?} has no mass; using 2 % of the chassis mass ({:.4} kg)",
                w.link, w.mass
            ));
        }
    }

    let wheel_radius = 0.5 * (left_wheel.radius + right_wheel.radius);
    let wheel_separation = (left_wheel.center.y - right_wheel.center.y).abs();
    let lift_left = left_wheel.radius - left_wheel.center.z;
    let lift_right = right_wheel.radius - right_wheel.center.z;
    if (lift_left - lift_right).abs() > 1e-3 {
        warnings.push(format!(
            "the wheels do not reach the same floor height (left {lift_left:.4} m, right \
             {lift_right:.4} m below the base origin); using their mean"
        ));
    }
    let base_height = 0.5 * (lift_left + lift_right);
    let floor_z = -base_height;
    let axle_z = 0.5 * (left_wheel.center.z + right_wheel.center.z);

    // ---- who moves with whom
    let mut owner = vec![Owner::Chassis; nodes.len()];
    for i in 1..nodes.len() {
        let node = &nodes[i];
        let parent = owner[node.parent.expect("non-root nodes have a parent")];
        let j = node.joint.expect("non-root nodes have a joint");
        owner[i] = if parent != Owner::Chassis {
            parent
        } else if wheel_links.contains(&node.link.name) {
            Owner::Wheel
        } else if is_caster_name(&node.link.name)
            || is_caster_name(&j.name)
            || (is_revolving(j) && node.axis.z.abs() > VERTICAL)
            || geometry[i].prims.iter().any(|p| {
                matches!(p.shape, Shape::Sphere { .. }) && p.pose.translation.vector.z < axle_z
            })
        {
            Owner::Caster(i)
        } else {
            Owner::Chassis
        };
        if owner[i] == Owner::Chassis && !matches!(j.joint_type, JointType::Fixed) {
            warnings.push(format!(
                "joint {:?} ({}) is neither a drive wheel nor a caster; it is held at position 0 \
                 and link {:?} moves with the chassis",
                j.name,
                joint_kind(j),
                node.link.name
            ));
        }
        if facts.joints_without_axis.contains(&j.name) && owner[i] != Owner::Wheel {
            warnings.push(format!(
                "joint {:?} ({}) has no <axis>; the URDF default 1 0 0 is used",
                j.name,
                joint_kind(j)
            ));
        }
    }

    // ---- geometry warnings, chassis shapes
    let mut chassis_shapes = Vec::new();
    for (i, g) in geometry.iter().enumerate() {
        if owner[i] == Owner::Wheel {
            continue;
        }
        let name = &nodes[i].link.name;
        if g.prims.is_empty() && !g.meshes.is_empty() {
            warnings.push(format!(
                "link {name:?} has only mesh geometry ({}); meshes are not loaded, so it \
                 contributes no collision shape",
                g.meshes.join(", ")
            ));
        } else if !g.meshes.is_empty() {
            warnings.push(format!(
                "link {name:?}: mesh geometry ignored ({}); its primitives are used",
                g.meshes.join(", ")
            ));
        }
        if g.from_visual && !g.prims.is_empty() {
            warnings.push(format!(
                "link {name:?} has no <collision>; its <visual> primitives are used instead"
            ));
        }
        if g.capsules > 0 {
            warnings.push(format!(
                "link {name:?}: capsule approximated by a cylinder spanning both caps"
            ));
        }
        if owner[i] == Owner::Chassis {
            chassis_shapes.extend(g.prims.iter().cloned());
        }
    }

    // ---- casters: one support sphere per caster, under its lowest primitive
    let mut casters = Vec::new();
    for (root, _) in owner
        .iter()
        .enumerate()
        .filter(|(i, o)| **o == Owner::Caster(*i))
    {
        let lowest = (0..nodes.len())
            .filter(|&i| owner[i] == Owner::Caster(root))
            .flat_map(|i| geometry[i].prims.iter())
            .map(|p| (lowest_z(p), p))
            .min_by(|a, b| a.0.total_cmp(&b.0));
        let name = &nodes[root].link.name;
        let Some((bottom, p)) = lowest else {
            warnings.push(format!(
                "caster {name:?} has no primitive geometry; no support sphere is made for it"
            ));
            continue;
        };
        let radius = support_radius(p);
        let gap = bottom - floor_z;
        if gap.abs() > CASTER_GAP_WARN {
            warnings.push(format!(
                "caster {name:?}: its lowest point is {gap:.4} m {} the floor; its support \
                 sphere is placed on the floor",
                if gap > 0.0 { "above" } else { "below" }
            ));
        }
        let c = p.pose.translation.vector;
        casters.push(Caster {
            link: name.clone(),
            center: Vector3::new(c.x, c.y, floor_z + radius),
            radius,
        });
    }

    let mounts = nodes
        .iter()
        .map(|n| LinkMount {
            name: n.link.name.clone(),
            pose: n.pose,
        })
        .collect();

    Ok(RobotModel {
        name: robot.name.clone(),
        base_link: nodes[0].link.name.clone(),
        chassis_shapes,
        chassis_mass,
        chassis_com,
        left_wheel,
        right_wheel,
        casters,
        mounts,
        wheel_radius,
        wheel_separation,
        base_height,
        warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    /// A minimal two-wheel robot; `extra` is spliced in before `</robot>`.
    fn robot(extra: &str) -> String {
        format!(
            r#"<robot name="t">
  <link name="base"><inertial><mass value="5"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><box size="0.4 0.3 0.1"/></geometry></collision></link>
  <link name="wl"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.05" length="0.02"/></geometry></collision></link>
  <link name="wr"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.05" length="0.02"/></geometry></collision></link>
  <joint name="jl" type="continuous"><parent link="base"/><child link="wl"/><origin xyz="0 0.2 0.05"/><axis xyz="0 1 0"/></joint>
  <joint name="jr" type="continuous"><parent link="base"/><child link="wr"/><origin xyz="0 -0.2 0.05"/><axis xyz="0 1 0"/></joint>
{extra}
</robot>"#
        )
    }

    #[test]
    fn rpy_matches_hand_computed_matrix() {
        // Rz(y)·Ry(p)·Rx(r) for r = 0.1, p = 0.2, y = 0.3, first row and last row by hand:
        // R[0][0] = cy·cp, R[0][1] = cy·sp·sr − sy·cr, R[2][0] = −sp, R[2][2] = cp·cr.
        let (r, p, y) = (0.1f64, 0.2f64, 0.3f64);
        let m = rpy_rotation([r, p, y]).to_rotation_matrix();
        let m = m.matrix();
        assert!((m[(0, 0)] - y.cos() * p.cos()).abs() < 1e-12);
        assert!((m[(0, 1)] - (y.cos() * p.sin() * r.sin() - y.sin() * r.cos())).abs() < 1e-12);
        assert!((m[(2, 0)] + p.sin()).abs() < 1e-12);
        assert!((m[(2, 2)] - p.cos() * r.cos()).abs() < 1e-12);
    }

    #[test]
    fn xyz_rpy_inverts_an_origin() {
        let pose = origin_pose(&urdf_rs::Pose {
            xyz: urdf_rs::Vec3([0.1, -0.2, 0.3]),
            rpy: urdf_rs::Vec3([0.4, -0.5, 0.6]),
        });
        let (xyz, rpy) = LinkMount {
            name: "x".into(),
            pose,
        }
        .xyz_rpy();
        for (a, b) in xyz.iter().zip([0.1, -0.2, 0.3]) {
            assert!((a - b).abs() < 1e-12);
        }
        for (a, b) in rpy.iter().zip([0.4, -0.5, 0.6]) {
            assert!((a - b).abs() < 1e-12, "{rpy:?}");
        }
    }

    #[test]
    fn lowest_point_of_rotated_primitives() {
        let place = |shape, rpy, z| ShapeInstance {
            link: "l".into(),
            shape,
            pose: Isometry3::from_parts(Translation3::new(0.0, 0.0, z), rpy_rotation(rpy)),
        };
        // Cylinder lying on its side: its radius is what reaches down.
        let c = place(
            Shape::Cylinder {
                radius: 0.1,
                length: 0.5,
            },
            [FRAC_PI_2, 0.0, 0.0],
            1.0,
        );
        assert!((lowest_z(&c) - 0.9).abs() < 1e-12);
        assert!((support_radius(&c) - 0.1).abs() < 1e-12);
        // Box rolled by 90°: its y side becomes vertical.
        let b = place(
            Shape::Box {
                size: [0.3, 0.2, 0.1],
            },
            [FRAC_PI_2, 0.0, 0.0],
            1.0,
        );
        assert!((lowest_z(&b) - 0.9).abs() < 1e-12);
        assert!((support_radius(&b) - 0.05).abs() < 1e-12);
    }

    #[test]
    fn simple_robot_derives_drive_parameters() {
        let m = load_str(&robot(""), "t.urdf").unwrap();
        assert_eq!(m.base_link, "base");
        assert!((m.wheel_radius - 0.05).abs() < 1e-12);
        assert!((m.wheel_separation - 0.4).abs() < 1e-12);
        // Wheel centre 0.05 above the base origin, radius 0.05: the origin is on the floor.
        assert!(m.base_height.abs() < 1e-12);
        assert_eq!(m.left_wheel.link, "wl");
        assert!((m.left_wheel.axis - Vector3::y()).norm() < 1e-12);
        assert!((m.left_wheel.width - 0.02).abs() < 1e-12);
        // No wheel mass in the URDF: 2 % of the 5 kg chassis.
        assert!((m.left_wheel.mass - 0.1).abs() < 1e-12);
        assert!(m.warnings.iter().any(|w| w.contains("no mass")));
        assert_eq!(m.chassis_shapes.len(), 1);
        assert!(m.casters.is_empty());
        assert_eq!(m.mounts.len(), 3);
    }

    #[test]
    fn sphere_below_the_axle_is_a_caster() {
        let m = load_str(
            &robot(
                r#"<link name="ball"><collision><geometry><sphere radius="0.02"/></geometry></collision></link>
  <joint name="jb" type="fixed"><parent link="base"/><child link="ball"/><origin xyz="-0.15 0 0.03"/></joint>"#,
            ),
            "t.urdf",
        )
        .unwrap();
        assert_eq!(m.casters.len(), 1);
        let c = &m.casters[0];
        assert_eq!(c.link, "ball");
        assert!((c.radius - 0.02).abs() < 1e-12);
        assert!((c.center - Vector3::new(-0.15, 0.0, 0.02)).norm() < 1e-12);
        assert_eq!(m.chassis_shapes.len(), 1, "the caster is not chassis");
    }

    #[test]
    fn skid_steer_is_rejected_naming_every_wheel() {
        let extra = r#"<link name="wl2"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.05" length="0.02"/></geometry></collision></link>
  <link name="wr2"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.05" length="0.02"/></geometry></collision></link>
  <joint name="jl2" type="continuous"><parent link="base"/><child link="wl2"/><origin xyz="0.3 0.2 0.05"/><axis xyz="0 1 0"/></joint>
  <joint name="jr2" type="continuous"><parent link="base"/><child link="wr2"/><origin xyz="0.3 -0.2 0.05"/><axis xyz="0 1 0"/></joint>"#;
        let err = load_str(&robot(extra), "t.urdf").unwrap_err().to_string();
        for name in ["jl", "jr", "jl2", "jr2", "exactly two drive wheels"] {
            assert!(err.contains(name), "{err}");
        }
    }

    #[test]
    fn swivel_caster_wheel_is_not_a_drive_wheel() {
        let extra = r#"<link name="fork"/>
  <link name="roller"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.03" length="0.02"/></geometry></collision></link>
  <joint name="swivel" type="continuous"><parent link="base"/><child link="fork"/><origin xyz="-0.2 0 0.04"/><axis xyz="0 0 1"/></joint>
  <joint name="roll" type="continuous"><parent link="fork"/><child link="roller"/><origin xyz="-0.02 0 -0.01"/><axis xyz="0 1 0"/></joint>"#;
        let m = load_str(&robot(extra), "t.urdf").unwrap();
        assert_eq!(m.casters.len(), 1);
        let c = &m.casters[0];
        assert_eq!(c.link, "fork");
        assert!((c.radius - 0.03).abs() < 1e-12);
        assert!((c.center - Vector3::new(-0.22, 0.0, 0.03)).norm() < 1e-12);
    }

    #[test]
    fn bad_numbers_name_link_and_field() {
        let cases = [
            (
                r#"radius="0.05" length="0.02""#,
                r#"radius="NaN" length="0.02""#,
                "link[wl].collision[0].geometry.cylinder.radius",
            ),
            (
                r#"radius="0.05" length="0.02""#,
                r#"radius="-0.05" length="0.02""#,
                "must be > 0",
            ),
            (
                r#"radius="0.05" length="0.02""#,
                r#"radius="0.05" length="0""#,
                "link[wl].collision[0].geometry.cylinder.length",
            ),
            (
                r#"<mass value="5"/>"#,
                r#"<mass value="-5"/>"#,
                "link[base].inertial.mass.value",
            ),
            (
                r#"<origin xyz="0 0.2 0.05"/>"#,
                r#"<origin xyz="0 0.2 x"/>"#,
                "joint[jl].origin.xyz",
            ),
            (
                r#"<axis xyz="0 1 0"/></joint>"#,
                r#"<axis xyz="0 0 0"/></joint>"#,
                "joint[jl].axis.xyz",
            ),
        ];
        for (from, to, expected) in cases {
            let text = robot("").replacen(from, to, 1);
            assert_ne!(text, robot(""), "{from}");
            let err = load_str(&text, "t.urdf").unwrap_err().to_string();
            assert!(err.starts_with("t.urdf: "), "{err}");
            assert!(err.contains(expected), "{expected}: {err}");
        }
    }

    #[test]
    fn tree_errors() {
        let dangling = robot(
            r#"<joint name="jx" type="fixed"><parent link="base"/><child link="nowhere"/></joint>"#,
        );
        let err = load_str(&dangling, "t.urdf").unwrap_err().to_string();
        assert!(
            err.contains("joint[jx].child.link") && err.contains("nowhere"),
            "{err}"
        );
        let two_roots = robot(r#"<link name="loose"/>"#);
        let err = load_str(&two_roots, "t.urdf").unwrap_err().to_string();
        assert!(
            err.contains("2 root links") && err.contains("loose"),
            "{err}"
        );
        let not_robot = "<model name=\"x\"/>";
        let err = load_str(not_robot, "t.urdf").unwrap_err().to_string();
        assert!(err.contains("<model>"), "{err}");
    }

    #[test]
    fn massless_chassis_is_rejected() {
        let text = robot("").replacen(r#"<mass value="5"/>"#, r#"<mass value="0"/>"#, 1);
        let err = load_str(&text, "t.urdf").unwrap_err().to_string();
        assert!(
            err.starts_with("t.urdf: ") && err.contains("chassis mass"),
            "{err}"
        );
    }

    #[test]
    fn wheels_on_one_side_are_rejected() {
        let text = robot("").replacen(r#"xyz="0 -0.2 0.05""#, r#"xyz="0 0.1 0.05""#, 1);
        let err = load_str(&text, "t.urdf").unwrap_err().to_string();
        assert!(err.contains("one left (y > 0) and one right"), "{err}");
    }

    #[test]
    fn xacro_substitution_is_detected_but_a_bare_declaration_is_not() {
        let declared = robot("").replacen(
            "<robot name=\"t\">",
            "<robot name=\"t\" xmlns:xacro=\"http://ros.org/wiki/xacro\">",
            1,
        );
        assert!(load_str(&declared, "t.urdf").is_ok());
        let substituted = robot("").replacen("0 0.2 0.05", "0 ${track/2} 0.05", 1);
        let err = load_str(&substituted, "t.urdf").unwrap_err();
        assert!(matches!(err, RobotError::Xacro { .. }), "{err}");
        assert!(err.to_string().contains("line 6"), "{err}");
    }
}
