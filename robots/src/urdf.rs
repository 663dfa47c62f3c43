//! URDF loading into a [`RobotModel`].
//!
//! urdf-rs gives the typed tree; roxmltree reads the raw XML first, because urdf-rs silently
//! defaults what a loader must notice (an omitted `<axis>` becomes 1 0 0, a missing mass 0),
//! drops unparsable numbers from vectors, and reports errors without naming the element.
//!
//! Hostile input is refused with an error, never a panic, an abort or silent garbage: numbers
//! must be finite and within the limits below (`MAX_LENGTH_M`, `MAX_MASS_KG`, wheel size and
//! separation, XML depth, ...), and every refusal names the file, the link or joint, the field
//! and the limit. Loading is linear in the size of the file.

use crate::diff_drive::DEFAULT_EFFECTIVE_TRACK_RATIO;
use crate::error::RobotError;
use crate::model::UrdfJoint;
use crate::model::{
    Caster, DriveKind, DriveOverride, DriveSource, ExcludedJoint, LinkMount, RobotInspection,
    RobotModel, Shape, ShapeInstance, SkidSteer, TrackSource, Wheel,
};
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
/// A lateral-axis wheel closer to the centre line than this fraction of the widest wheel's
/// |y| is a caster wheel on a continuous joint: it cannot steer by a speed difference.
const CENTRE_LINE_FRACTION: f64 = 0.25;
/// A skid steer has 2 or 3 driven wheels per side (Husky, Jackal, Pioneer 3-AT: 2; six-wheel
/// rovers: 3). More is a tracked vehicle, which Atrium does not model.
const MAX_WHEELS_PER_SIDE: usize = 3;
/// The driven wheels of one skid-steer side must share a radius within this fraction: the
/// side turns at one speed, so a 1 % larger wheel would have to slip 1 % all the time.
const SIDE_RADIUS_TOLERANCE: f64 = 0.005;
/// Largest `effective_track_ratio` a `<skid_steer>` element may state (Clearpath's Husky
/// uses 1.875; beyond 4 the robot would hardly turn at all).
const MAX_EFFECTIVE_TRACK_RATIO: f64 = 4.0;

// ---- Limits on what a URDF may state. Each refusal names the file, the link or joint, the
// ---- field and the limit. They are far outside any real indoor robot, so they only catch
// ---- typos and garbage (1e300, a unit mix-up) before it turns into inf, NaN or a misleading
// ---- error much later (a "start pose collides" for a 50 m wheel).

/// Largest length or coordinate (m): geometry sizes, every `<origin xyz>` component, and how
/// far any link or shape may lie from the base link. Atrium simulates indoor mobile robots (the
/// largest, wheelchairs and AGVs, are 1 to 2 m); 50 m admits anything that fits in a building
/// and keeps the f32 physics precise to a few micrometres over the robot.
pub const MAX_LENGTH_M: f64 = 50.0;
/// Largest |roll|, |pitch|, |yaw| of an `<origin rpy>` (rad). Real files stay within ±2π;
/// beyond 100 rad a value is garbage (1e300) or degrees (180, 360), and beyond about 1e16 rad
/// f64 cannot even resolve a whole turn.
pub const MAX_ANGLE_RAD: f64 = 100.0;
/// Largest mass of one link and of the whole chassis (kg). Heavier than any indoor robot (a
/// loaded AGV is a few tonnes); keeps the 2 % default wheel mass and the solver's mass ratios
/// within what f32 physics handles.
pub const MAX_MASS_KG: f64 = 10_000.0;
/// Smallest mass (kg) of the chassis (every link but the drive wheels) and of a drive wheel
/// whose mass the URDF states: the physics computes in f32 and needs mass to move, and a gram
/// is below any real robot's wheel (TurtleBot3's weigh 28 g). Single links (sensor frames) may
/// be lighter.
pub const MIN_MASS_KG: f64 = 1e-3;
/// Largest |inertia tensor entry| (kg·m²): the heaviest link spread over the largest length,
/// `MAX_MASS_KG · MAX_LENGTH_M²`.
pub const MAX_INERTIA: f64 = MAX_MASS_KG * MAX_LENGTH_M * MAX_LENGTH_M;
/// A `quat_xyzw` must have a norm within [1/this, this]: urdf-rs normalises it by squaring the
/// components, which silently turns a zero, tiny (1e-200) or huge (1e200) quaternion into the
/// identity rotation.
pub const QUAT_NORM_RANGE: f64 = 1e3;
/// Largest drive-wheel radius (m): a wheel taller than 2 m would not pass a standard door
/// (2.0 to 2.1 m high), so it cannot drive through an indoor world. Also refused: a radius
/// larger than the wheel separation ([`MAX_WHEEL_RADIUS_PER_SEPARATION`]).
pub const MAX_WHEEL_RADIUS_M: f64 = 1.0;
/// Largest drive-wheel radius as a fraction of the wheel separation. Real differential drives
/// have 0.2 to 0.55 (TurtleBot3 0.21, Pioneer 3-DX 0.30, wheelchairs about 0.3 to 0.5); a wheel
/// wider in radius than the track is a robot of two giant wheels, i.e. a wrong unit or size.
pub const MAX_WHEEL_RADIUS_PER_SEPARATION: f64 = 1.0;
/// Smallest drive-wheel radius (m): motor speeds are v / r, and below 5 mm the physics' contact
/// margins (millimetres) are as large as the wheel.
pub const MIN_WHEEL_RADIUS_M: f64 = 0.005;
/// Smallest wheel separation (m): the turn rate is (v_r − v_l) / separation; the smallest real
/// differential drives are several centimetres across (e-puck: 5.3 cm). The wheels must also
/// not overlap (separation > mean wheel width).
pub const MIN_WHEEL_SEPARATION_M: f64 = 0.01;
/// Deepest XML element nesting accepted. A URDF nests about 6 deep (robot, link, collision,
/// geometry, box; a few more inside `<gazebo>` blocks); the XML parsers recurse once per level,
/// and 100,000 nested elements overflow the stack (an abort, not an error).
pub const MAX_XML_DEPTH: usize = 64;

pub(crate) fn load_file(path: &Path) -> Result<RobotModel, RobotError> {
    load_file_with_report(path).map(|(model, _)| model)
}

pub(crate) fn load_file_with_report(
    path: &Path,
) -> Result<(RobotModel, Vec<ExcludedJoint>), RobotError> {
    let text = std::fs::read_to_string(path).map_err(|err| RobotError::Io {
        source_name: path.display().to_string(),
        err,
    })?;
    load_str_with_report(
        &text,
        &path.display().to_string(),
        &DriveOverride::default(),
    )
    .map(|(m, e, _)| (m, e))
}

pub(crate) fn load_str(text: &str, source: &str) -> Result<RobotModel, RobotError> {
    load_str_with_report(text, source, &DriveOverride::default()).map(|(model, _, _)| model)
}

/// [`load_str`] with drive geometry `ovr` given beside the URDF, plus every revolving joint
/// that is not a drive wheel (with the reason) and where the drive geometry came from.
pub(crate) fn load_str_with_report(
    text: &str,
    source: &str,
    ovr: &DriveOverride,
) -> Result<(RobotModel, Vec<ExcludedJoint>, DriveSource), RobotError> {
    check_depth(text, source)?;
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
    let (mut nodes, mut geometry) = placed_links(&robot, source)?;
    let mesh_wheels = mesh_wheels(&mut nodes, &mut geometry, ovr);
    let (mut model, excluded) = build(&nodes, &geometry, &mesh_wheels, &robot, &facts, source)?;
    ovr.apply(&mut model);
    let drive_source = match (ovr.is_empty(), mesh_wheels.is_empty()) {
        (true, _) => DriveSource::Urdf,
        (false, true) => DriveSource::Override,
        (false, false) => DriveSource::OverrideMeshWheels,
    };
    Ok((model, excluded, drive_source))
}

/// Refuses XML nested deeper than [`MAX_XML_DEPTH`] before any parser sees it (roxmltree and
/// urdf-rs both recurse once per level). A linear byte scan that knows comments, CDATA,
/// processing instructions, declarations and quoted attribute values; whatever else is
/// malformed is left for roxmltree to report.
fn check_depth(text: &str, source: &str) -> Result<(), RobotError> {
    let b = text.as_bytes();
    // Index just past the first `pat` at or after `from` (the end of the text if none).
    let past = |from: usize, pat: &[u8]| {
        b[from..]
            .windows(pat.len())
            .position(|w| w == pat)
            .map_or(b.len(), |k| from + k + pat.len())
    };
    let mut depth = 0usize;
    let mut i = 0;
    while let Some(k) = b[i..].iter().position(|&c| c == b'<') {
        let start = i + k;
        let rest = &b[start..];
        i = if rest.starts_with(b"<!--") {
            past(start + 4, b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            past(start + 9, b"]]>")
        } else if rest.starts_with(b"<?") {
            past(start + 2, b"?>")
        } else if rest.starts_with(b"<!") {
            past(start + 2, b">")
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            past(start + 2, b">")
        } else {
            // A start tag: its end is the first `>` outside a quoted attribute value.
            let mut j = start + 1;
            let mut quote = None;
            while j < b.len() {
                let c = b[j];
                match quote {
                    Some(q) if c == q => quote = None,
                    Some(_) => {}
                    None if c == b'"' || c == b'\'' => quote = Some(c),
                    None if c == b'>' => break,
                    None => {}
                }
                j += 1;
            }
            if !(j < b.len() && b[j - 1] == b'/') {
                depth += 1;
                if depth > MAX_XML_DEPTH {
                    let line = 1 + b[..start].iter().filter(|&&c| c == b'\n').count();
                    let name: String = text[start + 1..]
                        .chars()
                        .take_while(|c| !c.is_whitespace() && !matches!(c, '>' | '/' | '<'))
                        .take(64)
                        .collect();
                    return Err(RobotError::Xml {
                        source_name: source.into(),
                        msg: format!(
                            "line {line}: element <{name}> is nested more than {MAX_XML_DEPTH} \
                             elements deep (the limit; a URDF nests about 6 deep)"
                        ),
                    });
                }
            }
            j + 1
        };
        if i >= b.len() {
            break;
        }
    }
    Ok(())
}

/// A number for a message: plain for everyday magnitudes, in exponent form for huge or tiny
/// ones (`1e300`, not three hundred digits).
fn num(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-6..1e16).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
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
    /// Atrium's `<skid_steer effective_track=".."/>` or `effective_track_ratio=".."`.
    skid_steer: Option<EffectiveTrack>,
}

/// A skid steer's effective track as the URDF states it.
#[derive(Clone, Copy)]
enum EffectiveTrack {
    Metres(f64),
    Ratio(f64),
}

/// Reads Atrium's `<skid_steer>` element (a direct child of `<robot>`, ignored by other URDF
/// tools): exactly one of `effective_track` (m) or `effective_track_ratio` (× the geometric
/// track).
fn skid_steer_element(node: roxmltree::Node, source: &str) -> Result<EffectiveTrack, RobotError> {
    match (
        node.attribute("effective_track"),
        node.attribute("effective_track_ratio"),
    ) {
        (Some(_), None) => {
            let field = "skid_steer.effective_track";
            Ok(EffectiveTrack::Metres(length_attr(
                node,
                "effective_track",
                field,
                source,
            )?))
        }
        (None, Some(_)) => {
            let field = "skid_steer.effective_track_ratio";
            let k = numbers_attr(node, "effective_track_ratio", 1, field, source)?[0];
            if !(k > 0.0 && k <= MAX_EFFECTIVE_TRACK_RATIO) {
                return Err(field_err(
                    source,
                    field,
                    format!(
                        "must be > 0 and at most {MAX_EFFECTIVE_TRACK_RATIO}                          (MAX_EFFECTIVE_TRACK_RATIO), got {}",
                        num(k)
                    ),
                ));
            }
            Ok(EffectiveTrack::Ratio(k))
        }
        _ => Err(field_err(
            source,
            "skid_steer",
            "give exactly one of effective_track (m) or effective_track_ratio",
        )),
    }
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

/// A length (m): > 0 and at most [`MAX_LENGTH_M`].
fn check_length(v: f64, field: &str, source: &str) -> Result<f64, RobotError> {
    if v <= 0.0 {
        return Err(field_err(
            source,
            field,
            format!("must be > 0 (got {})", num(v)),
        ));
    }
    if v > MAX_LENGTH_M {
        return Err(field_err(
            source,
            field,
            format!(
                "{} m exceeds the limit of {MAX_LENGTH_M} m for any robot length or \
                 coordinate (MAX_LENGTH_M)",
                num(v)
            ),
        ));
    }
    Ok(v)
}

fn length_attr(
    node: roxmltree::Node,
    attr: &str,
    field: &str,
    source: &str,
) -> Result<f64, RobotError> {
    let v = numbers_attr(node, attr, 1, field, source)?[0];
    check_length(v, field, source)
}

/// Each number's magnitude is at most `limit`.
fn check_magnitudes(
    values: &[f64],
    limit: f64,
    unit: &str,
    name: &str,
    field: &str,
    source: &str,
) -> Result<(), RobotError> {
    match values.iter().find(|v| v.abs() > limit) {
        Some(v) => Err(field_err(
            source,
            field,
            format!(
                "{} exceeds the limit of ±{limit} {unit} ({name}) (got {values:?})",
                num(*v)
            ),
        )),
        None => Ok(()),
    }
}

fn check_origin(parent: roxmltree::Node, prefix: &str, source: &str) -> Result<(), RobotError> {
    let Some(origin) = child(parent, "origin") else {
        return Ok(());
    };
    for (attr, n) in [("xyz", 3), ("rpy", 3), ("quat_xyzw", 4)] {
        if origin.attribute(attr).is_none() {
            continue;
        }
        let field = format!("{prefix}.origin.{attr}");
        let v = numbers_attr(origin, attr, n, &field, source)?;
        match attr {
            "xyz" => check_magnitudes(&v, MAX_LENGTH_M, "m", "MAX_LENGTH_M", &field, source)?,
            "rpy" => check_magnitudes(&v, MAX_ANGLE_RAD, "rad", "MAX_ANGLE_RAD", &field, source)?,
            _ => {
                let norm = v.iter().fold(0.0f64, |a, &b| a.hypot(b));
                if !(1.0 / QUAT_NORM_RANGE..=QUAT_NORM_RANGE).contains(&norm) {
                    return Err(field_err(
                        source,
                        field,
                        format!(
                            "a rotation quaternion's norm must be within [{}, {}] \
                             (QUAT_NORM_RANGE), got {} for {v:?}",
                            1.0 / QUAT_NORM_RANGE,
                            QUAT_NORM_RANGE,
                            num(norm)
                        ),
                    ));
                }
            }
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
            check_magnitudes(
                &size,
                MAX_LENGTH_M,
                "m",
                "MAX_LENGTH_M",
                &field("size"),
                source,
            )?;
        }
        "cylinder" | "capsule" => {
            length_attr(*shape, "radius", &field("radius"), source)?;
            length_attr(*shape, "length", &field("length"), source)?;
        }
        "sphere" => {
            length_attr(*shape, "radius", &field("radius"), source)?;
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
            return Err(field_err(
                source,
                field,
                format!("must be >= 0 (got {})", num(m)),
            ));
        }
        if m > MAX_MASS_KG {
            return Err(field_err(
                source,
                field,
                format!(
                    "{} kg exceeds the limit of {MAX_MASS_KG} kg for a link (MAX_MASS_KG)",
                    num(m)
                ),
            ));
        }
        let inertia = child(inertial, "inertia")
            .ok_or_else(|| field_err(source, format!("{prefix}.inertia"), "missing"))?;
        for attr in ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"] {
            let field = format!("{prefix}.inertia.{attr}");
            let v = numbers_attr(inertia, attr, 1, &field, source)?[0];
            let diagonal = matches!(attr, "ixx" | "iyy" | "izz");
            if diagonal && v < 0.0 {
                return Err(field_err(
                    source,
                    field,
                    format!("a moment of inertia must be >= 0 (got {})", num(v)),
                ));
            }
            if v.abs() > MAX_INERTIA {
                return Err(field_err(
                    source,
                    field,
                    format!(
                        "{} kg·m² exceeds the limit of ±{MAX_INERTIA} kg·m² (MAX_INERTIA = \
                         MAX_MASS_KG · MAX_LENGTH_M²)",
                        num(v)
                    ),
                ));
            }
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
            // The URDF specification: fixed and floating joints do not use the axis, so an
            // all-zero one (exporters write it) is ignored there.
            if xyz.iter().all(|&v| v == 0.0) && !matches!(kind, "fixed" | "floating") {
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
        if kind == "skid_steer" {
            if facts.skid_steer.is_some() {
                return Err(invalid(source, "<skid_steer> is given twice"));
            }
            facts.skid_steer = Some(skid_steer_element(node, source)?);
            continue;
        }
        if kind != "link" && kind != "joint" {
            continue;
        }
        // Only on error: `text_pos_at` scans the text from its start, so calling it for every
        // element made loading quadratic in the number of links.
        let line = || doc.text_pos_at(node.range().start).row;
        let name = node
            .attribute("name")
            .filter(|n| !n.trim().is_empty())
            .ok_or_else(|| {
                field_err(source, format!("{kind} at line {}", line()), "has no name")
            })?;
        let seen = if kind == "link" {
            &mut links
        } else {
            &mut joints
        };
        if !seen.insert(name) {
            return Err(invalid(
                source,
                format!(
                    "{kind} name {name:?} is used twice (again at line {})",
                    line()
                ),
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

/// Every joint of the URDF `text` as its tree states it (parent, child, origin), in file order,
/// for the frames a ROS system publishes: `robot_state_publisher` sends the fixed joints on
/// `/tf_static` and the moving ones from `/joint_states`.
pub(crate) fn joint_tree(text: &str, source: &str) -> Result<Vec<UrdfJoint>, RobotError> {
    check_depth(text, source)?;
    let robot = urdf_rs::read_from_string(text).map_err(|e| RobotError::Invalid {
        source_name: source.into(),
        msg: format!("URDF: {e}"),
    })?;
    Ok(robot
        .joints
        .iter()
        .map(|j| UrdfJoint {
            name: j.name.clone(),
            parent: j.parent.link.clone(),
            child: j.child.link.clone(),
            origin: origin_pose(&j.origin),
            fixed: matches!(j.joint_type, JointType::Fixed),
            kind: joint_kind(j),
            axis: j.axis.xyz.0,
        })
        .collect())
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
    /// For each primitive, its field path in the URDF (`link[l].collision[0].geometry.cylinder`).
    fields: Vec<String>,
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
    let kind = if out.from_visual {
        "visual"
    } else {
        "collision"
    };
    for (k, (origin, geometry)) in elements.into_iter().enumerate() {
        let shape_name = match geometry {
            Geometry::Box { .. } => "box",
            Geometry::Cylinder { .. } => "cylinder",
            Geometry::Sphere { .. } => "sphere",
            Geometry::Capsule { .. } => "capsule",
            Geometry::Mesh { .. } => "mesh",
        };
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
        out.fields.push(format!(
            "link[{}].{kind}[{k}].geometry.{shape_name}",
            link.name
        ));
    }
    out
}

/// Farthest any point of a placed primitive lies from the base origin (an upper bound).
fn reach(p: &ShapeInstance) -> f64 {
    let half_diagonal = match p.shape {
        Shape::Sphere { radius } => radius,
        Shape::Cylinder { radius, length } => radius.hypot(0.5 * length),
        Shape::Box { size } => 0.5 * size[0].hypot(size[1]).hypot(size[2]),
    };
    p.pose.translation.vector.norm() + half_diagonal
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
            // Scaled by its largest component first: normalising 1e-200 or 1e200 directly
            // under- or overflows the squared norm (the XML check refused the zero vector).
            let raw = Vector3::from(j.axis.xyz.0);
            let axis = if raw.amax() > 0.0 {
                joint_pose.rotation * (raw / raw.amax()).normalize()
            } else {
                joint_pose.rotation * Vector3::x()
            };
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

/// Every link placed in the base frame, with its usable geometry.
fn placed_links<'a>(
    robot: &'a urdf_rs::Robot,
    source: &str,
) -> Result<(Vec<Node<'a>>, Vec<LinkGeometry>), RobotError> {
    let nodes = kinematic_tree(robot, source)?;
    let geometry: Vec<LinkGeometry> = nodes
        .iter()
        .map(|n| link_geometry(n.link, &n.pose))
        .collect();
    check_reach(&nodes, &geometry, source)?;
    Ok((nodes, geometry))
}

/// Wheels only meshes describe, made from a complete [`DriveOverride`]: among the links whose
/// name (or joint's name) says "wheel", that have no cylinder or sphere and are no caster (by
/// name or mesh file), the left/right pair at the same x whose lateral distance is nearest the
/// given track gets a cylinder of the given radius about ±y at its link origin, and counts as
/// driven whatever its joint type (the MP-400 declares its drive joints `fixed`). Returns the
/// indices of those links.
fn mesh_wheels(
    nodes: &mut [Node],
    geometry: &mut [LinkGeometry],
    ovr: &DriveOverride,
) -> Vec<usize> {
    let (Some(radius), Some(track)) = (ovr.wheel_radius, ovr.track) else {
        return Vec::new();
    };
    let wheel_like = |i: usize| {
        let n = &nodes[i];
        let joint = n.joint.map(|j| j.name.as_str()).unwrap_or_default();
        let named = |s: &str| s.to_ascii_lowercase().contains("wheel");
        (named(&n.link.name) || named(joint))
            && !is_caster_name(&n.link.name)
            && !is_caster_name(joint)
            && !geometry[i].meshes.iter().any(|m| is_caster_name(m))
            && !geometry[i]
                .prims
                .iter()
                .any(|p| !matches!(p.shape, Shape::Box { .. }))
    };
    let candidates: Vec<usize> = (1..nodes.len()).filter(|&i| wheel_like(i)).collect();
    let at = |i: usize| nodes[i].pose.translation.vector;
    let mut best: Option<(f64, usize, usize)> = None;
    for &l in candidates.iter().filter(|&&i| at(i).y > 0.0) {
        for &r in candidates.iter().filter(|&&i| at(i).y < 0.0) {
            if (at(l).x - at(r).x).abs() > 0.01 {
                continue;
            }
            let miss = ((at(l).y - at(r).y) - track).abs();
            if best.is_none_or(|b| miss < b.0) {
                best = Some((miss, l, r));
            }
        }
    }
    let Some((_, l, r)) = best else {
        return Vec::new();
    };
    // A tyre is typically 0.4–0.7 of its radius wide; its width only shapes the contact.
    let width = 0.5 * radius;
    for i in [l, r] {
        let centre = nodes[i].pose.translation.vector;
        let sign = if centre.y > 0.0 { 1.0 } else { -1.0 };
        let axis = nodes[i].axis;
        if axis.y.abs() <= LATERAL {
            nodes[i].axis = Vector3::new(0.0, sign, 0.0);
        }
        let rotation =
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2);
        geometry[i].prims.push(ShapeInstance {
            link: nodes[i].link.name.clone(),
            shape: Shape::Cylinder {
                radius,
                length: width,
            },
            pose: Isometry3::from_parts(Translation3::from(centre), rotation),
        });
        geometry[i].fields.push(format!(
            "robot.wheel_radius (link {:?} is drawn with meshes only)",
            nodes[i].link.name
        ));
    }
    vec![l, r]
}

fn build(
    nodes: &[Node],
    geometry: &[LinkGeometry],
    mesh_wheels: &[usize],
    robot: &urdf_rs::Robot,
    facts: &XmlFacts,
    source: &str,
) -> Result<(RobotModel, Vec<ExcludedJoint>), RobotError> {
    let mut warnings = Vec::new();
    let mut excluded = Vec::new();

    // A swivel (revolving joint about a vertical axis) above a wheel makes it a caster wheel.
    // The nearest swivel at or above each link, in one pass (parents come before children).
    let mut swivel: Vec<Option<usize>> = vec![None; nodes.len()];
    for i in 1..nodes.len() {
        let j = nodes[i].joint.expect("non-root nodes have a joint");
        swivel[i] = if is_revolving(j) && nodes[i].axis.z.abs() > VERTICAL {
            Some(i)
        } else {
            swivel[nodes[i].parent.expect("non-root nodes have a parent")]
        };
    }

    // ---- drive wheels: (node, (radius, width, primitive, primitive index))
    type Candidate<'g> = (usize, (f64, f64, &'g ShapeInstance, usize));
    let mut wheels: Vec<Candidate> = Vec::new();
    let mut skipped: Vec<String> = Vec::new();
    for (i, node) in nodes.iter().enumerate() {
        let Some(j) = node.joint else { continue };
        if !is_revolving(j) && !mesh_wheels.contains(&i) {
            continue;
        }
        let mut exclude = |reason: String, lateral: bool| {
            if lateral {
                skipped.push(format!("joint {:?}: {reason}", j.name));
            }
            excluded.push(ExcludedJoint {
                joint: j.name.clone(),
                link: node.link.name.clone(),
                reason,
            });
        };
        let a = node.axis;
        if a.y.abs() <= LATERAL {
            exclude(
                format!(
                    "its axis ({:.3}, {:.3}, {:.3} in the base frame) is not lateral: a drive \
                     wheel turns about ±y (|y| > {LATERAL})",
                    a.x, a.y, a.z
                ),
                false,
            );
            continue;
        }
        let mut caster = Vec::new();
        if is_caster_name(&j.name) || is_caster_name(&node.link.name) {
            let whose = if is_caster_name(&j.name) {
                "joint"
            } else {
                "link"
            };
            caster.push(format!("its {whose} name contains \"caster\""));
        }
        if let Some(s) = swivel[i] {
            let swivel_joint = nodes[s].joint.map(|j| j.name.as_str()).unwrap_or_default();
            caster.push(format!(
                "it hangs below the swivel joint {swivel_joint:?} (a revolving joint with a \
                 vertical axis)"
            ));
        }
        if !caster.is_empty() {
            exclude(
                format!(
                    "{}: a caster wheel, not a drive wheel",
                    caster.join(" and ")
                ),
                true,
            );
            continue;
        }
        let round = geometry[i]
            .prims
            .iter()
            .enumerate()
            .filter_map(|(k, p)| match p.shape {
                Shape::Cylinder { radius, length } => Some((radius, length, p, k)),
                Shape::Sphere { radius } => Some((radius, 2.0 * radius, p, k)),
                Shape::Box { .. } => None,
            })
            .max_by(|a, b| a.0.total_cmp(&b.0));
        match round {
            Some(w) => wheels.push((i, w)),
            None => exclude(
                format!(
                    "it has a lateral axis but its link {:?} has no cylinder or sphere {}",
                    node.link.name,
                    if geometry[i].meshes.is_empty() {
                        "geometry".to_string()
                    } else {
                        format!("(only mesh {})", geometry[i].meshes.join(", "))
                    }
                ),
                true,
            ),
        }
    }
    let describe = |(i, (_, _, p, _)): &Candidate| {
        format!(
            "{} (link {}, y = {:.3} m)",
            nodes[*i].joint.map(|j| j.name.as_str()).unwrap_or_default(),
            nodes[*i].link.name,
            p.pose.translation.vector.y
        )
    };
    // A lateral wheel on the centre line cannot steer by speed difference: it is a caster
    // wheel on a continuous joint (a quirk of published URDFs that do not name it "caster").
    let widest = wheels
        .iter()
        .map(|(_, (_, _, p, _))| p.pose.translation.vector.y.abs())
        .fold(0.0f64, f64::max);
    let mut centre_casters = HashSet::new();
    wheels.retain(|(i, (_, _, p, _))| {
        let y = p.pose.translation.vector.y;
        if y.abs() >= CENTRE_LINE_FRACTION * widest {
            return true;
        }
        centre_casters.insert(*i);
        let j = nodes[*i].joint.expect("non-root nodes have a joint");
        excluded.push(ExcludedJoint {
            joint: j.name.clone(),
            link: nodes[*i].link.name.clone(),
            reason: format!(
                "it sits on the centre line (y = {y:.3} m, within {:.0} % of the widest wheel's \
                 {widest:.3} m): a caster wheel on a {} joint, not a drive wheel",
                100.0 * CENTRE_LINE_FRACTION,
                joint_kind(j)
            ),
        });
        false
    });
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
        msg.push_str(&override_hint(nodes, geometry));
        return Err(invalid(source, msg));
    }
    // ---- sides: left y > 0, right y < 0, each front to back
    let (mut left_c, mut right_c): (Vec<Candidate>, Vec<Candidate>) = wheels
        .iter()
        .copied()
        .partition(|(_, (_, _, p, _))| p.pose.translation.vector.y > 0.0);
    for side in [&mut left_c, &mut right_c] {
        side.sort_by(|a, b| {
            let x = |c: &Candidate| c.1 .2.pose.translation.vector.x;
            x(b).total_cmp(&x(a))
        });
    }
    let side_list = |side: &[Candidate]| side.iter().map(describe).collect::<Vec<_>>().join(", ");
    if left_c.is_empty() || right_c.is_empty() {
        return Err(invalid(
            source,
            format!(
                "the drive wheels must be one left (y > 0) and one right (y < 0) of the base \
                 link {:?} (or, for a skid steer, two or three on each side); found {}",
                nodes[0].link.name,
                listed.join(", ")
            ),
        ));
    }
    if left_c.len() != right_c.len() {
        return Err(invalid(
            source,
            format!(
                "cannot determine the drive: {} driven wheel{} on the left ({}) but {} on the \
                 right ({}); a differential drive has one wheel per side and a skid steer the \
                 same number (two or three) on each side",
                left_c.len(),
                if left_c.len() == 1 { "" } else { "s" },
                side_list(&left_c),
                right_c.len(),
                side_list(&right_c)
            ),
        ));
    }
    if left_c.len() > MAX_WHEELS_PER_SIDE {
        return Err(invalid(
            source,
            format!(
                "found {} lateral wheel joints: {}; Atrium supports a differential drive (one \
                 wheel per side) or a skid steer of 2 to {MAX_WHEELS_PER_SIDE} wheels per side",
                wheels.len(),
                listed.join(", ")
            ),
        ));
    }
    for (name, side) in [("left", &left_c), ("right", &right_c)] {
        let radii = || side.iter().map(|c| c.1 .0);
        let (lo, hi) = (
            radii().fold(f64::MAX, f64::min),
            radii().fold(0.0, f64::max),
        );
        if hi - lo > SIDE_RADIUS_TOLERANCE * hi {
            let each: Vec<String> = side
                .iter()
                .map(|c| {
                    format!(
                        "{} r = {} m",
                        nodes[c.0]
                            .joint
                            .map(|j| j.name.as_str())
                            .unwrap_or_default(),
                        num(c.1 .0)
                    )
                })
                .collect();
            return Err(invalid(
                source,
                format!(
                    "cannot determine the drive: the {name} side's driven wheels have different \
                     radii ({}); a skid steer turns a side's wheels at one speed, so they must \
                     share a radius (within {} %)",
                    each.join(", "),
                    100.0 * SIDE_RADIUS_TOLERANCE
                ),
            ));
        }
        for pair in side.windows(2) {
            let (a, b) = (&pair[0].1, &pair[1].1);
            let dx = a.2.pose.translation.vector.x - b.2.pose.translation.vector.x;
            if dx < a.0 + b.0 {
                let joint =
                    |c: &Candidate| nodes[c.0].joint.map(|j| j.name.clone()).unwrap_or_default();
                return Err(invalid(
                    source,
                    format!(
                        "the {name} side's wheels of joints {:?} and {:?} overlap: their centres \
                         are {dx:.3} m apart along x but their radii add up to {:.3} m",
                        joint(&pair[0]),
                        joint(&pair[1]),
                        a.0 + b.0
                    ),
                ));
            }
        }
    }
    let mut make =
        |&(i, (radius, width, p, k)): &Candidate| -> Result<(Wheel, String), RobotError> {
            let node = &nodes[i];
            let field = &geometry[i].fields[k];
            let joint = node.joint.map(|j| j.name.as_str()).unwrap_or_default();
            if let Shape::Cylinder { .. } = p.shape {
                let cyl_axis = p.pose.rotation * Vector3::z();
                if cyl_axis.dot(&node.axis).abs() <= LATERAL {
                    return Err(field_err(
                        source,
                        field.clone(),
                        format!(
                            "the wheel cylinder's axis ({:.3}, {:.3}, {:.3} in the base frame) is \
                             not along its joint's axis ({:.3}, {:.3}, {:.3})",
                            cyl_axis.x,
                            cyl_axis.y,
                            cyl_axis.z,
                            node.axis.x,
                            node.axis.y,
                            node.axis.z
                        ),
                    ));
                }
            }
            if radius > MAX_WHEEL_RADIUS_M {
                return Err(field_err(
                    source,
                    format!("{field}.radius"),
                    format!(
                        "the drive wheel of joint {joint:?} has radius {} m, above the limit \
                     of {MAX_WHEEL_RADIUS_M} m (MAX_WHEEL_RADIUS_M: a wheel taller than a 2 m \
                     door cannot drive through an indoor world)",
                        num(radius)
                    ),
                ));
            }
            if radius < MIN_WHEEL_RADIUS_M {
                return Err(field_err(
                    source,
                    format!("{field}.radius"),
                    format!(
                        "the drive wheel of joint {joint:?} has radius {} m, below the limit \
                     of {MIN_WHEEL_RADIUS_M} m (MIN_WHEEL_RADIUS_M)",
                        num(radius)
                    ),
                ));
            }
            Ok((
                Wheel {
                    joint: joint.to_string(),
                    link: node.link.name.clone(),
                    center: p.pose.translation.vector,
                    axis: node.axis,
                    radius,
                    width,
                    mass: node.link.inertial.mass.value,
                },
                field.clone(),
            ))
        };
    let mut left_made = left_c
        .iter()
        .map(&mut make)
        .collect::<Result<Vec<_>, _>>()?;
    let mut right_made = right_c
        .iter()
        .map(&mut make)
        .collect::<Result<Vec<_>, _>>()?;
    let skid = left_made.len() > 1;
    // ---- wheel separation (the geometric track of a skid steer: between the sides' mean
    // ---- lateral positions) and wheel size relative to it
    let mean_y = |side: &[(Wheel, String)]| {
        side.iter().map(|(w, _)| w.center.y).sum::<f64>() / side.len() as f64
    };
    let wheel_separation = (mean_y(&left_made) - mean_y(&right_made)).abs();
    let origins = format!(
        "joint[{}].origin.xyz, joint[{}].origin.xyz",
        left_made[0].0.joint, right_made[0].0.joint
    );
    if wheel_separation.is_nan() || wheel_separation < MIN_WHEEL_SEPARATION_M {
        return Err(field_err(
            source,
            origins,
            format!(
                "the drive wheels are {} m apart (the wheel separation); it must be at least \
                 {MIN_WHEEL_SEPARATION_M} m (MIN_WHEEL_SEPARATION_M)",
                num(wheel_separation)
            ),
        ));
    }
    let mean_width = 0.5 * (left_made[0].0.width + right_made[0].0.width);
    if wheel_separation <= mean_width {
        return Err(field_err(
            source,
            origins,
            format!(
                "the drive wheels overlap: their centres are {wheel_separation} m apart (the \
                 wheel separation) but they are {mean_width} m wide"
            ),
        ));
    }
    for (w, field) in left_made.iter().chain(&right_made) {
        if w.radius > MAX_WHEEL_RADIUS_PER_SEPARATION * wheel_separation {
            return Err(field_err(
                source,
                format!("{field}.radius"),
                format!(
                    "the drive wheel of joint {:?} has radius {} m, larger than \
                     {MAX_WHEEL_RADIUS_PER_SEPARATION} × the wheel separation of {} m \
                     (MAX_WHEEL_RADIUS_PER_SEPARATION)",
                    w.joint,
                    num(w.radius),
                    num(wheel_separation)
                ),
            ));
        }
    }
    let wheel_links: Vec<String> = left_made
        .iter()
        .chain(&right_made)
        .map(|(w, _)| w.link.clone())
        .collect();

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
    if chassis_mass < MIN_MASS_KG {
        return Err(invalid(
            source,
            format!(
                "the chassis mass (sum of <inertial><mass> of every link except the drive \
                 wheels) is {} kg, below the limit of {MIN_MASS_KG} kg (MIN_MASS_KG)",
                num(chassis_mass)
            ),
        ));
    }
    if chassis_mass > MAX_MASS_KG {
        return Err(invalid(
            source,
            format!(
                "the chassis mass (sum of <inertial><mass> of every link except the drive \
                 wheels) is {} kg, above the limit of {MAX_MASS_KG} kg (MAX_MASS_KG)",
                num(chassis_mass)
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
    for (w, _) in left_made.iter_mut().chain(right_made.iter_mut()) {
        if w.mass > 0.0 && w.mass < MIN_MASS_KG {
            return Err(field_err(
                source,
                format!("link[{}].inertial.mass.value", w.link),
                format!(
                    "the drive wheel of joint {:?} weighs {} kg, below the limit of \
                     {MIN_MASS_KG} kg (MIN_MASS_KG); leave the mass out to get 2 % of the \
                     chassis mass",
                    w.joint,
                    num(w.mass)
                ),
            ));
        }
        if w.mass <= 0.0 {
            w.mass = DEFAULT_WHEEL_MASS_FRACTION * chassis_mass;
            warnings.push(format!(
                "wheel link {:?} has no mass; using 2 % of the chassis mass ({:.4} kg)",
                w.link, w.mass
            ));
        }
    }
    let left_wheels: Vec<Wheel> = left_made.into_iter().map(|(w, _)| w).collect();
    let right_wheels: Vec<Wheel> = right_made.into_iter().map(|(w, _)| w).collect();
    let (left_wheel, right_wheel) = (left_wheels[0].clone(), right_wheels[0].clone());
    let all: Vec<&Wheel> = left_wheels.iter().chain(&right_wheels).collect();
    let n_wheels = all.len() as f64;

    let wheel_radius = all.iter().map(|w| w.radius).sum::<f64>() / n_wheels;
    let lifts: Vec<f64> = all.iter().map(|w| w.radius - w.center.z).collect();
    let (lift_lo, lift_hi) = (
        lifts.iter().copied().fold(f64::MAX, f64::min),
        lifts.iter().copied().fold(f64::MIN, f64::max),
    );
    if lift_hi - lift_lo > 1e-3 {
        let each: Vec<String> = all
            .iter()
            .zip(&lifts)
            .map(|(w, l)| format!("{} {l:.4} m", w.joint))
            .collect();
        warnings.push(format!(
            "the wheels do not reach the same floor height ({} below the base origin); using \
             their mean",
            each.join(", ")
        ));
    }
    let base_height = lifts.iter().sum::<f64>() / n_wheels;
    let floor_z = -base_height;
    let axle_z = all.iter().map(|w| w.center.z).sum::<f64>() / n_wheels;
    let drive_kind = if skid {
        let (effective_track, effective_track_source) = match facts.skid_steer {
            Some(EffectiveTrack::Metres(t)) => (t, TrackSource::Urdf),
            Some(EffectiveTrack::Ratio(k)) => (k * wheel_separation, TrackSource::Urdf),
            None => (
                DEFAULT_EFFECTIVE_TRACK_RATIO * wheel_separation,
                TrackSource::DefaultRatio,
            ),
        };
        if effective_track < wheel_separation {
            warnings.push(format!(
                "<skid_steer> gives an effective track of {effective_track:.4} m, less than the \
                 geometric track of {wheel_separation:.4} m; skid steers turn as if wider"
            ));
        }
        DriveKind::SkidSteer(SkidSteer {
            left: left_wheels,
            right: right_wheels,
            effective_track,
            effective_track_source,
        })
    } else {
        if facts.skid_steer.is_some() {
            warnings.push(
                "<skid_steer> is ignored: this robot is a differential drive (one driven wheel \
                 per side)"
                    .to_string(),
            );
        }
        DriveKind::Differential
    };

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
        } else if centre_casters.contains(&i)
            || is_caster_name(&node.link.name)
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
    // Every caster's links, grouped in one pass (by the caster's topmost link, in tree order).
    let mut caster_links: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
    for (i, o) in owner.iter().enumerate() {
        if let Owner::Caster(root) = o {
            caster_links.entry(*root).or_default().push(i);
        }
    }
    for (root, members) in caster_links {
        let lowest = members
            .iter()
            .flat_map(|&i| geometry[i].prims.iter())
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

    check_not_mecanum(robot, &drive_kind, &left_wheel, &right_wheel, source)?;

    let model = RobotModel {
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
        drive_kind,
    };
    Ok((model, excluded))
}

/// The end of the "too few drive wheels" refusal: the scenario keys that give the drive
/// geometry a URDF leaves to meshes or fixed joints, naming such wheel links when there are any.
fn override_hint(nodes: &[Node], geometry: &[LinkGeometry]) -> String {
    let drawn: Vec<String> = nodes
        .iter()
        .zip(geometry)
        .skip(1)
        .filter(|(n, g)| {
            let joint = n.joint.map(|j| j.name.as_str()).unwrap_or_default();
            let wheel = n.link.name.to_ascii_lowercase().contains("wheel")
                || joint.to_ascii_lowercase().contains("wheel");
            let round = g
                .prims
                .iter()
                .any(|p| !matches!(p.shape, Shape::Box { .. }));
            let fixed = n
                .joint
                .is_some_and(|j| matches!(j.joint_type, JointType::Fixed));
            wheel && !is_caster_name(&n.link.name) && (!round || fixed)
        })
        .map(|(n, g)| {
            let joint = n.joint.map(joint_kind).unwrap_or_default();
            if g.meshes.is_empty() {
                format!("{} ({joint} joint)", n.link.name)
            } else {
                format!(
                    "{} ({joint} joint, mesh {})",
                    n.link.name,
                    g.meshes.join(", ")
                )
            }
        })
        .collect();
    let links = if drawn.is_empty() {
        String::new()
    } else {
        format!(" (wheel links here: {})", drawn.join("; "))
    };
    format!(
        ". If the wheels are drawn with meshes only or sit on fixed joints{links}, give the drive \
         geometry in the scenario: a [robot] table with urdf = \"<this file>\", wheel_radius = \
         <m> and track = <m> (the distance between the left and right wheels)"
    )
}

/// Refuses a robot whose driven wheels are mecanum or omni wheels (by the wheel link's or
/// joint's name, or the file name of a mesh it is drawn with, or rollers: revolving joints
/// hung below the wheel): Atrium drives differential and skid-steer bases, and such a base
/// run as a skid steer would move in ways the real one never does (issue 42).
fn check_not_mecanum(
    robot: &urdf_rs::Robot,
    drive_kind: &DriveKind,
    left: &Wheel,
    right: &Wheel,
    source: &str,
) -> Result<(), RobotError> {
    let wheels: Vec<&Wheel> = match drive_kind {
        DriveKind::SkidSteer(s) => s.left.iter().chain(&s.right).collect(),
        DriveKind::Differential => vec![left, right],
    };
    let kind_of = |text: &str| {
        let t = text.to_ascii_lowercase();
        if t.contains("mecanum") {
            Some("a mecanum")
        } else if t.contains("omni") {
            Some("an omni")
        } else {
            None
        }
    };
    for w in wheels {
        let mut found = kind_of(&w.link)
            .or_else(|| kind_of(&w.joint))
            .map(|k| (k, format!("its name ({:?})", w.link)));
        if found.is_none() {
            if let Some(link) = robot.links.iter().find(|l| l.name == w.link) {
                let meshes = link
                    .visual
                    .iter()
                    .map(|v| &v.geometry)
                    .chain(link.collision.iter().map(|c| &c.geometry));
                for g in meshes {
                    if let Geometry::Mesh { filename, .. } = g {
                        if let Some(k) = kind_of(filename) {
                            found = Some((k, format!("its mesh {filename:?}")));
                        }
                    }
                }
            }
        }
        if found.is_none() {
            let rollers = robot
                .joints
                .iter()
                .filter(|j| j.parent.link == w.link && is_revolving(j))
                .count();
            if rollers >= 3 {
                found = Some((
                    "a mecanum or omni",
                    format!("the {rollers} rollers jointed to it"),
                ));
            }
        }
        if let Some((kind, why)) = found {
            return Err(invalid(
                source,
                format!(
                    "the driven wheel {:?} (joint {:?}) is {kind} wheel, by {why}: Atrium simulates differential-drive and skid-steer robots, and would drive this one as a skid steer, which it is not; describe it with plain wheels to run it as such",
                    w.link, w.joint
                ),
            ));
        }
    }
    Ok(())
}

/// Refuses links and shapes that, though each `<origin>` and size is within
/// [`MAX_LENGTH_M`], end up farther than that from the base link (long chains add up).
fn check_reach(nodes: &[Node], geometry: &[LinkGeometry], source: &str) -> Result<(), RobotError> {
    let base = &nodes[0].link.name;
    for (node, g) in nodes.iter().zip(geometry) {
        let d = node.pose.translation.vector.norm();
        if let Some(j) = node.joint.filter(|_| d > MAX_LENGTH_M) {
            return Err(field_err(
                source,
                format!("joint[{}].origin.xyz", j.name),
                format!(
                    "places link {:?} {d:.1} m from the base link {base:?}; a robot must fit \
                     within {MAX_LENGTH_M} m of its base link (MAX_LENGTH_M)",
                    node.link.name
                ),
            ));
        }
        for (p, field) in g.prims.iter().zip(&g.fields) {
            let r = reach(p);
            if r > MAX_LENGTH_M {
                return Err(field_err(
                    source,
                    field.clone(),
                    format!(
                        "reaches {r:.1} m from the base link {base:?}; a robot must fit within \
                         {MAX_LENGTH_M} m of its base link (MAX_LENGTH_M)"
                    ),
                ));
            }
        }
    }
    Ok(())
}

impl RobotModel {
    /// Loads a plain (non-xacro) URDF file.
    pub fn from_urdf(path: &Path) -> Result<Self, RobotError> {
        load_file(path)
    }

    /// Every joint of URDF `text` with its parent, child and origin, in file order (the tree
    /// `robot_state_publisher` builds from the same text). `source` names it in errors.
    pub fn joint_tree(text: &str, source: &str) -> Result<Vec<UrdfJoint>, RobotError> {
        joint_tree(text, source)
    }

    /// Parses URDF text; `source` names it in error messages.
    pub fn from_urdf_str(text: &str, source: &str) -> Result<Self, RobotError> {
        load_str(text, source)
    }

    /// [`RobotModel::from_urdf`], plus why each revolving joint that is not a drive wheel was
    /// left out of the drive.
    pub fn inspect_urdf(path: &Path) -> Result<RobotInspection, RobotError> {
        let (model, excluded_joints) = load_file_with_report(path)?;
        Ok(RobotInspection {
            model,
            excluded_joints,
            drive_source: DriveSource::Urdf,
        })
    }

    /// [`RobotModel::inspect_urdf`] on URDF text; `source` names it in error messages.
    pub fn inspect_urdf_str(text: &str, source: &str) -> Result<RobotInspection, RobotError> {
        Self::inspect_urdf_str_with(text, source, &DriveOverride::default())
    }

    /// [`RobotModel::inspect_urdf_str`] with drive geometry given beside the URDF (a
    /// scenario's `[robot] wheel_radius` and `track`): over the URDF's wheels, or making the
    /// wheels a URDF draws with meshes only (see [`DriveOverride`]).
    pub fn inspect_urdf_str_with(
        text: &str,
        source: &str,
        ovr: &DriveOverride,
    ) -> Result<RobotInspection, RobotError> {
        let (model, excluded_joints, drive_source) = load_str_with_report(text, source, ovr)?;
        Ok(RobotInspection {
            model,
            excluded_joints,
            drive_source,
        })
    }

    /// [`RobotModel::from_urdf_str`] with drive geometry given beside the URDF (see
    /// [`RobotModel::inspect_urdf_str_with`]).
    pub fn from_urdf_str_with(
        text: &str,
        source: &str,
        ovr: &DriveOverride,
    ) -> Result<Self, RobotError> {
        load_str_with_report(text, source, ovr).map(|(m, _, _)| m)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn mecanum_and_omni_wheels_are_refused_not_run_as_skid_steer() {
        let text =
            std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/urdf/pioneer3dx.urdf"))
                .unwrap();
        assert!(load_str(&text, "p3dx").is_ok());
        let e = load_str(
            &text.replace("\"left_wheel\"", "\"left_mecanum_wheel\""),
            "m",
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("\"left_mecanum_wheel\"") && e.contains("is a mecanum wheel"),
            "{e}"
        );
        let e = load_str(
            &text.replace("\"right_wheel\"", "\"right_omni_wheel\""),
            "o",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("is an omni wheel"), "{e}");
    }

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

    /// Two more wheels of radius `r2` at x = `x2` (jl2 left, jr2 right).
    fn rear_pair(x2: f64, r2: f64) -> String {
        let cyl = format!(
            r#"<collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="{r2}" length="0.02"/></geometry></collision>"#
        );
        format!(
            r#"<link name="wl2">{cyl}</link><link name="wr2">{cyl}</link>
  <joint name="jl2" type="continuous"><parent link="base"/><child link="wl2"/><origin xyz="{x2} 0.2 0.05"/><axis xyz="0 1 0"/></joint>
  <joint name="jr2" type="continuous"><parent link="base"/><child link="wr2"/><origin xyz="{x2} -0.2 0.05"/><axis xyz="0 1 0"/></joint>"#
        )
    }

    #[test]
    fn four_lateral_wheels_load_as_a_skid_steer() {
        let m = load_str(&robot(&rear_pair(-0.3, 0.05)), "t.urdf").unwrap();
        let DriveKind::SkidSteer(s) = &m.drive_kind else {
            panic!("{:?}", m.drive_kind)
        };
        let joints = |side: &[Wheel]| side.iter().map(|w| w.joint.clone()).collect::<Vec<_>>();
        // Front to back on each side; the front wheels are the model's left and right wheel.
        assert_eq!(joints(&s.left), ["jl", "jl2"]);
        assert_eq!(joints(&s.right), ["jr", "jr2"]);
        assert_eq!(m.left_wheel.joint, "jl");
        assert!((m.wheel_separation - 0.4).abs() < 1e-12);
        assert_eq!(s.effective_track_source, TrackSource::DefaultRatio);
        assert!((s.effective_track - DEFAULT_EFFECTIVE_TRACK_RATIO * 0.4).abs() < 1e-12);
        // The robot's software turns with the effective track.
        assert!((m.drive().wheel_separation - s.effective_track).abs() < 1e-12);
        // Four 0.1 kg wheels (2 % of the 5 kg chassis each).
        assert!((m.mass() - 5.4).abs() < 1e-12, "{}", m.mass());
        assert!(m.casters.is_empty());
    }

    #[test]
    fn the_urdf_may_state_the_effective_track() {
        let text = |el: &str| robot(&format!("{}{el}", rear_pair(-0.3, 0.05)));
        let track = |el: &str| match load_str(&text(el), "t.urdf").unwrap().drive_kind {
            DriveKind::SkidSteer(s) => (s.effective_track, s.effective_track_source),
            other => panic!("{other:?}"),
        };
        let (t, src) = track(r#"<skid_steer effective_track_ratio="1.875"/>"#);
        assert!((t - 0.75).abs() < 1e-12 && src == TrackSource::Urdf, "{t}");
        let (t, _) = track(r#"<skid_steer effective_track="0.7"/>"#);
        assert!((t - 0.7).abs() < 1e-12, "{t}");
        for (el, expected) in [
            (
                r#"<skid_steer effective_track_ratio="9"/>"#,
                "MAX_EFFECTIVE_TRACK_RATIO",
            ),
            (
                r#"<skid_steer effective_track="-1"/>"#,
                "skid_steer.effective_track",
            ),
            (r#"<skid_steer/>"#, "exactly one of"),
        ] {
            let err = load_str(&text(el), "t.urdf").unwrap_err().to_string();
            assert!(
                err.starts_with("t.urdf: ") && err.contains(expected),
                "{err}"
            );
        }
        // On a differential drive the element is reported as ignored.
        let m = load_str(
            &robot(r#"<skid_steer effective_track_ratio="1.5"/>"#),
            "t.urdf",
        )
        .unwrap();
        assert_eq!(m.drive_kind, DriveKind::Differential);
        assert!(m
            .warnings
            .iter()
            .any(|w| w.contains("<skid_steer> is ignored")));
    }

    #[test]
    fn an_undeterminable_drive_is_refused_naming_the_joints() {
        // Three driven wheels on the left, two on the right.
        let third = r#"<link name="wl3"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.05" length="0.02"/></geometry></collision></link>
  <joint name="jl3" type="continuous"><parent link="base"/><child link="wl3"/><origin xyz="0.3 0.2 0.05"/><axis xyz="0 1 0"/></joint>"#;
        let err = load_str(
            &robot(&format!("{}{third}", rear_pair(-0.3, 0.05))),
            "t.urdf",
        )
        .unwrap_err()
        .to_string();
        for e in [
            "3 driven wheels on the left",
            "jl3",
            "jl2",
            "jl ",
            "2 on the right",
            "jr2",
        ] {
            assert!(err.contains(e), "{e}: {err}");
        }
        // Mixed radii on one side.
        let err = load_str(&robot(&rear_pair(-0.3, 0.06)), "t.urdf")
            .unwrap_err()
            .to_string();
        for e in [
            "left side",
            "different radii",
            "jl r = 0.05 m",
            "jl2 r = 0.06 m",
        ] {
            assert!(err.contains(e), "{e}: {err}");
        }
        // Wheels of a side that overlap.
        let err = load_str(&robot(&rear_pair(-0.05, 0.05)), "t.urdf")
            .unwrap_err()
            .to_string();
        assert!(err.contains("\"jl\" and \"jl2\" overlap"), "{err}");
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

    /// `robot("")` with the first occurrence of each `from` replaced by its `to`; the message
    /// of the error it must give.
    fn error_after(edits: &[(&str, &str)]) -> String {
        let mut text = robot("");
        for (from, to) in edits {
            assert!(text.contains(from), "{from}");
            text = text.replacen(from, to, 1);
        }
        match load_str(&text, "t.urdf") {
            Ok(m) => panic!("expected an error after {edits:?}, loaded {m:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn absurd_numbers_are_refused_naming_link_field_and_limit() {
        let inertia = r#"ixx="1" ixy="0""#;
        let wheel = r#"radius="0.05" length="0.02""#;
        let cases: &[(&str, &str, &[&str])] = &[
            // Inertia: negative, NaN, infinite, absurd.
            (
                inertia,
                r#"ixx="-1" ixy="0""#,
                &["link[base].inertial.inertia.ixx", ">= 0"],
            ),
            (
                inertia,
                r#"ixx="NaN" ixy="0""#,
                &["link[base].inertial.inertia.ixx", "finite"],
            ),
            (
                inertia,
                r#"ixx="inf" ixy="0""#,
                &["link[base].inertial.inertia.ixx", "finite"],
            ),
            (
                inertia,
                r#"ixx="1" ixy="-1e300""#,
                &["link[base].inertial.inertia.ixy", "MAX_INERTIA"],
            ),
            // Mass: NaN, infinite, absurd (negative is in `bad_numbers_name_link_and_field`).
            (
                r#"<mass value="5"/>"#,
                r#"<mass value="NaN"/>"#,
                &["link[base].inertial.mass.value", "finite"],
            ),
            (
                r#"<mass value="5"/>"#,
                r#"<mass value="-inf"/>"#,
                &["link[base].inertial.mass.value", "finite"],
            ),
            (
                r#"<mass value="5"/>"#,
                r#"<mass value="1e300"/>"#,
                &["link[base].inertial.mass.value", "10000 kg", "MAX_MASS_KG"],
            ),
            // Geometry sizes, wheel radii, joint origins.
            (
                r#"<box size="0.4 0.3 0.1"/>"#,
                r#"<box size="1e300 0.3 0.1"/>"#,
                &[
                    "link[base].collision[0].geometry.box.size",
                    "50 m",
                    "MAX_LENGTH_M",
                ],
            ),
            (
                wheel,
                r#"radius="1e300" length="0.02""#,
                &[
                    "link[wl].collision[0].geometry.cylinder.radius",
                    "50 m",
                    "MAX_LENGTH_M",
                ],
            ),
            (
                r#"<origin xyz="0 0.2 0.05"/>"#,
                r#"<origin xyz="0 1e300 0.05"/>"#,
                &["joint[jl].origin.xyz", "50 m", "MAX_LENGTH_M"],
            ),
            (
                r#"<origin xyz="0 0.2 0.05"/>"#,
                r#"<origin xyz="0 0.2 0.05" rpy="1e300 0 0"/>"#,
                &["joint[jl].origin.rpy", "100 rad", "MAX_ANGLE_RAD"],
            ),
            (
                r#"<origin xyz="0 0 0.1"/>"#,
                r#"<origin xyz="0 0 -1e300"/>"#,
                &["link[base].collision[0].origin.xyz", "MAX_LENGTH_M"],
            ),
        ];
        for (from, to, expected) in cases {
            let err = error_after(&[(from, to)]);
            assert!(err.starts_with("t.urdf: "), "{err}");
            for e in *expected {
                assert!(err.contains(e), "{to}: expected {e:?} in {err}");
            }
        }
    }

    #[test]
    fn zero_quaternion_is_refused() {
        let text = robot("")
            .replacen(
                "<robot name=\"t\">",
                "<robot name=\"t\" version=\"1.1\">",
                1,
            )
            .replacen(
                r#"<origin xyz="0 0.2 0.05"/>"#,
                r#"<origin xyz="0 0.2 0.05" quat_xyzw="0 0 0 0"/>"#,
                1,
            );
        let err = load_str(&text, "t.urdf").unwrap_err().to_string();
        assert!(
            err.contains("joint[jl].origin.quat_xyzw") && err.contains("QUAT_NORM_RANGE"),
            "{err}"
        );
    }

    #[test]
    fn tiny_axis_is_normalised_without_underflow() {
        // |axis|² = 1e-400 underflows to 0: a naive normalisation gives NaN and loses the wheel.
        let text = robot("").replacen(r#"<axis xyz="0 1 0"/>"#, r#"<axis xyz="0 1e-200 0"/>"#, 1);
        let m = load_str(&text, "t.urdf").unwrap();
        assert!(
            (m.left_wheel.axis - Vector3::y()).norm() < 1e-12,
            "{:?}",
            m.left_wheel.axis
        );
    }

    #[test]
    fn wheel_separation_must_be_real() {
        // Zero in all but name: 2e-300 m between the wheels.
        let err = error_after(&[
            (r#"xyz="0 0.2 0.05""#, r#"xyz="0 1e-300 0.05""#),
            (r#"xyz="0 -0.2 0.05""#, r#"xyz="0 -1e-300 0.05""#),
        ]);
        for e in [
            "joint[jl].origin.xyz, joint[jr].origin.xyz",
            "wheel separation",
            "MIN_WHEEL_SEPARATION_M",
        ] {
            assert!(err.contains(e), "{e}: {err}");
        }
        // 1.5 cm apart, 2 cm wide: the wheels overlap.
        let err = error_after(&[
            (r#"xyz="0 0.2 0.05""#, r#"xyz="0 0.0075 0.05""#),
            (r#"xyz="0 -0.2 0.05""#, r#"xyz="0 -0.0075 0.05""#),
        ]);
        assert!(err.contains("overlap") && err.contains("0.015"), "{err}");
    }

    #[test]
    fn huge_and_tiny_wheels_are_refused_at_load() {
        let both = |r: &str| {
            let to = format!(r#"radius="{r}" length="0.02""#);
            let text = robot("").replace(r#"radius="0.05" length="0.02""#, &to);
            load_str(&text, "t.urdf").unwrap_err().to_string()
        };
        // 3 m: within MAX_LENGTH_M, but a wheel 6 m tall.
        let err = both("3");
        for e in [
            "link[wl].collision[0].geometry.cylinder.radius",
            "drive wheel of joint \"jl\"",
            "radius 3 m",
            "MAX_WHEEL_RADIUS_M",
        ] {
            assert!(err.contains(e), "{e}: {err}");
        }
        // 0.5 m wheels 0.4 m apart.
        let err = both("0.5");
        assert!(err.contains("MAX_WHEEL_RADIUS_PER_SEPARATION"), "{err}");
        assert!(err.contains("separation of 0.4"), "{err}");
        let err = both("0.001");
        assert!(err.contains("MIN_WHEEL_RADIUS_M"), "{err}");
    }

    #[test]
    fn links_beyond_the_robot_size_limit_are_refused() {
        // Each joint origin is within MAX_LENGTH_M, but the chain reaches 120 m.
        let extra = r#"<link name="a"/><link name="b"/><link name="c"/>
  <joint name="ja" type="fixed"><parent link="base"/><child link="a"/><origin xyz="40 0 0"/></joint>
  <joint name="jb" type="fixed"><parent link="a"/><child link="b"/><origin xyz="40 0 0"/></joint>
  <joint name="jc" type="fixed"><parent link="b"/><child link="c"/><origin xyz="40 0 0"/></joint>"#;
        let err = load_str(&robot(extra), "t.urdf").unwrap_err().to_string();
        assert!(
            err.contains("joint[jb].origin.xyz") && err.contains("places link \"b\" 80.0 m"),
            "{err}"
        );
        assert!(err.contains("MAX_LENGTH_M"), "{err}");
        // A 40 m box 30 m out.
        let extra = r#"<link name="far"><collision><geometry><box size="40 1 1"/></geometry></collision></link>
  <joint name="jf" type="fixed"><parent link="base"/><child link="far"/><origin xyz="30 0 0"/></joint>"#;
        let err = load_str(&robot(extra), "t.urdf").unwrap_err().to_string();
        assert!(
            err.contains("link[far].collision[0].geometry.box") && err.contains("reaches"),
            "{err}"
        );
    }

    #[test]
    fn excluded_wheel_joints_say_why() {
        let extra = r#"<link name="fork"/>
  <link name="roller"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.03" length="0.02"/></geometry></collision></link>
  <joint name="swivel" type="continuous"><parent link="base"/><child link="fork"/><origin xyz="-0.2 0 0.04"/><axis xyz="0 0 1"/></joint>
  <joint name="roll" type="continuous"><parent link="fork"/><child link="roller"/><origin xyz="-0.02 0 -0.01"/><axis xyz="0 1 0"/></joint>
  <link name="front_caster_wheel"><collision><origin rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.02" length="0.01"/></geometry></collision></link>
  <joint name="jc" type="continuous"><parent link="base"/><child link="front_caster_wheel"/><origin xyz="0.2 0 0.02"/><axis xyz="0 1 0"/></joint>
  <link name="flap"><collision><geometry><box size="0.1 0.1 0.01"/></geometry></collision></link>
  <joint name="jflap" type="revolute"><parent link="base"/><child link="flap"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/><limit lower="0" upper="1" effort="1" velocity="1"/></joint>"#;
        let r = RobotModel::from_urdf_str(&robot(extra), "t.urdf").unwrap();
        let i = RobotModel::inspect_urdf_str(&robot(extra), "t.urdf").unwrap();
        assert_eq!(i.model, r, "the same model either way");
        let reason = |joint: &str| {
            let found: Vec<&ExcludedJoint> = i
                .excluded_joints
                .iter()
                .filter(|e| e.joint == joint)
                .collect();
            assert_eq!(found.len(), 1, "{joint}: {:?}", i.excluded_joints);
            found[0].reason.clone()
        };
        assert!(
            reason("swivel").contains("not lateral"),
            "{}",
            reason("swivel")
        );
        assert!(
            reason("roll").contains("below the swivel joint \"swivel\""),
            "{}",
            reason("roll")
        );
        assert!(
            reason("jc").contains("link name contains \"caster\""),
            "{}",
            reason("jc")
        );
        assert!(
            reason("jflap").contains("no cylinder or sphere geometry"),
            "{}",
            reason("jflap")
        );
        assert_eq!(i.excluded_joints.len(), 4, "drive wheels are not listed");
        let roll = i
            .excluded_joints
            .iter()
            .find(|e| e.joint == "roll")
            .unwrap();
        assert_eq!(roll.link, "roller");
    }
}
