//! The SDF export checked against the SDFormat 1.9 specification.
//!
//! No SDF tooling (libsdformat, `gz sdf -k`) is available to a Rust test, so [`check`] is a
//! validator for the subset Atrium writes: for every element it knows, the children the 1.9
//! spec allows under it (with how often: at most once or any number), its attributes (which
//! are required), and the type of its value; taken from the spec files of sdformat's `sdf/1.9`
//! (root, world, physics, scene, light, frame, model, link, collision, visual, geometry, the
//! box / cylinder / plane shapes, material, pose). A child the spec does not allow under its
//! parent is an error, and so is one the spec allows but this checker does not describe: the
//! export may only grow together with this table. Names must be unique within their scope and
//! not use what SDF reserves (`::`, `__name__`).

use atrium_formats::sdf::to_sdf;
use atrium_formats::sdf::{
    GLASS_TRANSPARENCY, GLASS_VISIBILITY_FLAGS, LASER_RETRO_GLASS, LASER_RETRO_OPAQUE,
    LIDAR_MASK_WITHOUT_GLASS,
};
use atrium_worlds::World;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The type of an element's text.
#[derive(Clone, Copy, Debug)]
enum Value {
    /// No text (only children).
    None,
    Bool,
    /// A double > 0.
    Positive,
    /// A double in [0, 1].
    Unit,
    /// An `unsigned int` (32 bits).
    UInt,
    Vector3,
    /// Three doubles > 0 (box size).
    Size3,
    /// Two doubles > 0 (plane size).
    Size2,
    /// Four doubles in [0, 1].
    Color,
    /// x y z roll pitch yaw.
    Pose,
}

/// One element of the spec: its allowed children (`name?` at most once, `name*` any number,
/// `name!` exactly once), its attributes (`name!` required) and its value.
struct Spec {
    children: &'static [&'static str],
    attributes: &'static [&'static str],
    value: Value,
}

const fn spec(
    children: &'static [&'static str],
    attributes: &'static [&'static str],
    value: Value,
) -> Spec {
    Spec {
        children,
        attributes,
        value,
    }
}

/// The spec of `name` under `parent` (some names mean different things under different
/// parents: a box's `size` has three numbers, a plane's two).
fn spec_of(parent: &str, name: &str) -> Option<Spec> {
    use Value::*;
    let leaf = |v| Some(spec(&[], &[], v));
    match (parent, name) {
        // root.sdf: the version attribute is required; world, model, actor, light.
        ("", "sdf") => Some(spec(
            &["world*", "model?", "actor?", "light?"],
            &["version!"],
            None,
        )),
        // world.sdf
        ("sdf", "world") => Some(spec(
            &[
                "audio?",
                "wind?",
                "include*",
                "gravity?",
                "magnetic_field?",
                "atmosphere?",
                "gui?",
                "physics*",
                "scene?",
                "light*",
                "frame*",
                "model*",
                "actor*",
                "plugin*",
                "road*",
                "spherical_coordinates?",
                "state*",
                "population*",
            ],
            &["name!"],
            None,
        )),
        ("world", "gravity") => leaf(Vector3),
        // physics.sdf
        ("world", "physics") => Some(spec(
            &[
                "max_step_size?",
                "real_time_factor?",
                "real_time_update_rate?",
                "max_contacts?",
                "dart?",
                "simbody?",
                "bullet?",
                "ode?",
            ],
            &["name", "default", "type!"],
            None,
        )),
        ("physics", "max_step_size") | ("physics", "real_time_factor") => leaf(Positive),
        // scene.sdf
        ("world", "scene") => Some(spec(
            &[
                "ambient?",
                "background?",
                "sky?",
                "shadows?",
                "fog?",
                "grid?",
                "origin_visual?",
            ],
            &[],
            None,
        )),
        ("scene", "ambient") | ("scene", "background") => leaf(Color),
        ("scene", "shadows") => leaf(Bool),
        // light.sdf
        ("world", "light") => Some(spec(
            &[
                "cast_shadows?",
                "intensity?",
                "pose?",
                "diffuse?",
                "specular?",
                "attenuation?",
                "direction?",
                "spot?",
            ],
            &["name!", "type!"],
            None,
        )),
        ("light", "cast_shadows") => leaf(Bool),
        ("light", "diffuse") | ("light", "specular") => leaf(Color),
        ("light", "direction") => leaf(Vector3),
        ("light", "attenuation") => Some(spec(
            &["range?", "linear?", "constant?", "quadratic?"],
            &[],
            None,
        )),
        ("attenuation", "range") => leaf(Positive),
        ("attenuation", "linear") | ("attenuation", "constant") | ("attenuation", "quadratic") => {
            leaf(Unit)
        }
        // frame.sdf
        ("world", "frame") => Some(spec(&["pose?"], &["name!", "attached_to"], None)),
        // pose.sdf (1.9: relative_to, rotation_format, degrees)
        (_, "pose") => Some(spec(
            &[],
            &["relative_to", "rotation_format", "degrees"],
            Pose,
        )),
        // model.sdf
        ("world", "model") => Some(spec(
            &[
                "static?",
                "self_collide?",
                "allow_auto_disable?",
                "include*",
                "model*",
                "enable_wind?",
                "frame*",
                "pose?",
                "link*",
                "joint*",
                "plugin*",
                "gripper*",
            ],
            &["name!", "canonical_link", "placement_frame"],
            None,
        )),
        ("model", "static") => leaf(Bool),
        // link.sdf
        ("model", "link") => Some(spec(
            &[
                "gravity?",
                "enable_wind?",
                "self_collide?",
                "kinematic?",
                "must_be_base_link?",
                "velocity_decay?",
                "pose?",
                "inertial?",
                "collision*",
                "visual*",
                "sensor*",
                "projector*",
                "audio_sink*",
                "audio_source*",
                "battery*",
                "light*",
                "particle_emitter*",
            ],
            &["name!"],
            None,
        )),
        // collision.sdf (1.9: no material_density yet, that is 1.11)
        ("link", "collision") => Some(spec(
            &[
                "laser_retro?",
                "max_contacts?",
                "pose?",
                "geometry!",
                "surface?",
            ],
            &["name!"],
            None,
        )),
        ("collision", "laser_retro") | ("visual", "laser_retro") => leaf(Positive),
        // visual.sdf
        ("link", "visual") => Some(spec(
            &[
                "cast_shadows?",
                "laser_retro?",
                "transparency?",
                "visibility_flags?",
                "meta?",
                "pose?",
                "material?",
                "geometry!",
                "plugin*",
            ],
            &["name!"],
            None,
        )),
        ("visual", "cast_shadows") => leaf(Bool),
        ("visual", "transparency") => leaf(Unit),
        ("visual", "visibility_flags") => leaf(UInt),
        // geometry.sdf (1.9: no cone yet, that is 1.11); exactly one shape.
        ("collision", "geometry") | ("visual", "geometry") => Some(spec(
            &[
                "empty?",
                "box?",
                "capsule?",
                "cylinder?",
                "ellipsoid?",
                "heightmap?",
                "image?",
                "mesh?",
                "plane?",
                "polyline*",
                "sphere?",
            ],
            &[],
            None,
        )),
        ("geometry", "box") => Some(spec(&["size!"], &[], None)),
        ("box", "size") => leaf(Size3),
        ("geometry", "cylinder") => Some(spec(&["radius!", "length!"], &[], None)),
        ("cylinder", "radius") | ("cylinder", "length") => leaf(Positive),
        ("geometry", "plane") => Some(spec(&["normal!", "size!"], &[], None)),
        ("plane", "normal") => leaf(Vector3),
        ("plane", "size") => leaf(Size2),
        // material.sdf
        ("visual", "material") => Some(spec(
            &[
                "script?",
                "shader?",
                "lighting?",
                "ambient?",
                "diffuse?",
                "specular?",
                "emissive?",
                "pbr?",
            ],
            &[],
            None,
        )),
        ("material", "ambient")
        | ("material", "diffuse")
        | ("material", "specular")
        | ("material", "emissive") => leaf(Color),
        _ => Option::None,
    }
}

fn numbers(text: &str, n: usize) -> Result<Vec<f64>, String> {
    let v: Vec<f64> = text
        .split_whitespace()
        .map(|t| {
            t.parse::<f64>()
                .map_err(|_| format!("{t:?} is not a number"))
        })
        .collect::<Result<_, _>>()?;
    if v.len() != n || v.iter().any(|x| !x.is_finite()) {
        return Err(format!("{text:?}: expected {n} finite numbers"));
    }
    Ok(v)
}

fn check_value(value: Value, text: &str) -> Result<(), String> {
    let t = text.trim();
    let positive = |v: Vec<f64>| {
        if v.iter().all(|x| *x > 0.0) {
            Ok(())
        } else {
            Err(format!("{t:?}: must be > 0"))
        }
    };
    let unit = |v: Vec<f64>| {
        if v.iter().all(|x| (0.0..=1.0).contains(x)) {
            Ok(())
        } else {
            Err(format!("{t:?}: must be in [0, 1]"))
        }
    };
    match value {
        Value::None if t.is_empty() => Ok(()),
        Value::None => Err(format!("unexpected text {t:?}")),
        Value::Bool => match t {
            "true" | "false" | "0" | "1" => Ok(()),
            _ => Err(format!("{t:?} is not a bool")),
        },
        Value::Positive => positive(numbers(t, 1)?),
        Value::Unit => unit(numbers(t, 1)?),
        Value::UInt => t
            .parse::<u32>()
            .map(|_| ())
            .map_err(|_| format!("{t:?} is not an unsigned int")),
        Value::Vector3 => numbers(t, 3).map(|_| ()),
        Value::Size3 => positive(numbers(t, 3)?),
        Value::Size2 => positive(numbers(t, 2)?),
        Value::Color => unit(numbers(t, 4)?),
        Value::Pose => numbers(t, 6).map(|_| ()),
    }
}

/// Checks `xml` against the SDFormat 1.9 subset above; the error names the element's path.
fn check(xml: &str) -> Result<(), String> {
    let doc = roxmltree::Document::parse(xml).map_err(|e| format!("not XML: {e}"))?;
    let root = doc.root_element();
    if root.attribute("version") != Some("1.9") {
        return Err(format!(
            "/sdf: version must be \"1.9\", got {:?}",
            root.attribute("version")
        ));
    }
    check_element(root, "", "")
}

fn check_element(node: roxmltree::Node, parent: &str, path: &str) -> Result<(), String> {
    let name = node.tag_name().name();
    let path = format!("{path}/{name}");
    if node.tag_name().namespace().is_some() {
        return Err(format!("{path}: SDF elements have no namespace"));
    }
    let spec = spec_of(parent, name).ok_or_else(|| {
        if parent.is_empty() {
            format!("{path}: the root must be <sdf>")
        } else {
            format!("{path}: <{name}> is not allowed under <{parent}> (or not described here)")
        }
    })?;
    for a in node.attributes() {
        if !spec
            .attributes
            .iter()
            .any(|s| s.trim_end_matches('!') == a.name())
        {
            return Err(format!("{path}: unknown attribute {:?}", a.name()));
        }
    }
    for s in spec.attributes.iter().filter(|s| s.ends_with('!')) {
        let a = s.trim_end_matches('!');
        match node.attribute(a) {
            Some(v) if !v.is_empty() => {}
            _ => return Err(format!("{path}: attribute {a:?} is required")),
        }
    }
    if let Some(n) = node.attribute("name") {
        if n.contains("::") || (n.len() >= 4 && n.starts_with("__") && n.ends_with("__")) {
            return Err(format!("{path}: name {n:?} is reserved in SDF"));
        }
    }
    let text: String = node
        .children()
        .filter(|c| c.is_text())
        .map(|c| c.text().unwrap_or(""))
        .collect();
    check_value(spec.value, &text).map_err(|e| format!("{path}: {e}"))?;

    let mut counts: HashMap<&str, usize> = HashMap::new();
    let mut names: HashMap<String, &str> = HashMap::new();
    for child in node.children().filter(|c| c.is_element()) {
        let cname = child.tag_name().name();
        *counts.entry(cname).or_default() += 1;
        if let Some(n) = child.attribute("name") {
            // Frames, models, links, joints, lights share one scope; collisions and visuals
            // are unique within their link.
            if let Some(other) = names.insert(n.to_string(), cname) {
                return Err(format!(
                    "{path}: name {n:?} used by both a <{other}> and a <{cname}>"
                ));
            }
        }
        check_element(child, name, &path)?;
    }
    for allowed in spec.children {
        let (child, rule) = allowed.split_at(allowed.len() - 1);
        let n = counts.get(child).copied().unwrap_or(0);
        match rule {
            "?" if n > 1 => return Err(format!("{path}: <{child}> at most once, found {n}")),
            "!" if n != 1 => return Err(format!("{path}: <{child}> exactly once, found {n}")),
            _ => {}
        }
    }
    if name == "geometry" && node.children().filter(|c| c.is_element()).count() != 1 {
        return Err(format!("{path}: exactly one shape"));
    }
    Ok(())
}

fn bundled_worlds() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds");
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml") && !p.ends_with("Cargo.toml"))
        .collect();
    v.sort();
    v
}

fn models<'a>(doc: &'a roxmltree::Document) -> Vec<roxmltree::Node<'a, 'a>> {
    doc.descendants()
        .filter(|n| n.has_tag_name("model"))
        .collect()
}

fn child<'a>(n: roxmltree::Node<'a, 'a>, path: &[&str]) -> Option<roxmltree::Node<'a, 'a>> {
    let mut n = n;
    for p in path {
        n = n.children().find(|c| c.has_tag_name(*p))?;
    }
    Some(n)
}

fn nums(n: Option<roxmltree::Node>) -> Vec<f64> {
    n.and_then(|n| n.text())
        .unwrap()
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect()
}

#[test]
fn every_bundled_world_exports_valid_sdf_with_one_model_per_solid() {
    let worlds = bundled_worlds();
    assert!(worlds.len() >= 3, "bundled worlds: {worlds:?}");
    let mut glass_walls = 0;
    let mut exported = 0;
    for path in worlds {
        // Generator parameter files (`generator = "..."`) sit beside the worlds; they are
        // exported once expanded, which `World::load` may or may not do for them.
        let text = std::fs::read_to_string(&path).unwrap();
        let generator = text
            .parse::<toml::Table>()
            .is_ok_and(|t| t.contains_key("generator"));
        let world = match World::load(&path) {
            Ok(w) => w,
            Err(_) if generator => continue,
            Err(e) => panic!("{}: {e}", path.display()),
        };
        exported += 1;
        let xml = to_sdf(&world);
        check(&xml).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        // Deterministic: the same bytes again.
        assert_eq!(xml, to_sdf(&world), "{}", path.display());

        let doc = roxmltree::Document::parse(&xml).unwrap();
        let ms = models(&doc);
        let named = |prefix: &str| {
            ms.iter()
                .filter(|m| m.attribute("name").unwrap().starts_with(prefix))
                .copied()
                .collect::<Vec<_>>()
        };
        let (walls, pillars, boxes) = (named("wall_"), named("pillar_"), named("box_"));
        assert_eq!(walls.len(), world.walls.len(), "{}", path.display());
        assert_eq!(pillars.len(), world.pillars.len(), "{}", path.display());
        assert_eq!(boxes.len(), world.boxes.len(), "{}", path.display());
        assert_eq!(
            ms.len(),
            world.walls.len() + world.pillars.len() + world.boxes.len() + 2,
            "walls, pillars, boxes, ground plane and ceiling in {}",
            path.display()
        );
        assert!(named("ground_plane").len() == 1 && named("ceiling").len() == 1);
        let frames = doc
            .descendants()
            .filter(|n| n.has_tag_name("frame"))
            .count();
        assert_eq!(frames, world.access_points.len(), "{}", path.display());

        for (i, w) in world.walls.iter().enumerate() {
            let m = walls[i];
            assert!(m
                .attribute("name")
                .unwrap()
                .starts_with(&format!("wall_{i}_")));
            let size = nums(child(m, &["link", "collision", "geometry", "box", "size"]));
            let len = (w.b[0] - w.a[0]).hypot(w.b[1] - w.a[1]);
            assert!(
                (size[0] - len).abs() < 1e-9
                    && (size[1] - w.thickness).abs() < 1e-12
                    && (size[2] - w.height).abs() < 1e-12,
                "wall {i}: {size:?}"
            );
            let pose = nums(child(m, &["pose"]));
            assert!((pose[2] - 0.5 * w.height).abs() < 1e-12);
            // The box's end at +x/2 along its yaw is the wall's end b.
            let end = [
                pose[0] + 0.5 * len * pose[5].cos(),
                pose[1] + 0.5 * len * pose[5].sin(),
            ];
            assert!(
                (end[0] - w.b[0]).abs() < 1e-9 && (end[1] - w.b[1]).abs() < 1e-9,
                "wall {i}: {pose:?}"
            );
            let visual = child(m, &["link", "visual"]).unwrap();
            let transparency = child(visual, &["transparency"]).map(|t| nums(Some(t))[0]);
            let retro = |p: &[&str]| nums(child(m, p))[0];
            let retro_c = retro(&["link", "collision", "laser_retro"]);
            let retro_v = retro(&["link", "visual", "laser_retro"]);
            assert_eq!(retro_c, retro_v);
            if world.is_glass(&w.material) {
                glass_walls += 1;
                assert_eq!(transparency, Some(GLASS_TRANSPARENCY), "wall {i}");
                assert!(
                    transparency.unwrap() > 0.0,
                    "wall {i}: glass must be see-through"
                );
                let flags: u32 = child(visual, &["visibility_flags"])
                    .unwrap()
                    .text()
                    .unwrap()
                    .parse()
                    .unwrap();
                assert_eq!(flags, GLASS_VISIBILITY_FLAGS);
                // The documented lidar mask hides glass and nothing else.
                assert_eq!(flags & LIDAR_MASK_WITHOUT_GLASS, 0);
                let alpha = nums(child(visual, &["material", "diffuse"]))[3];
                assert!((alpha - (1.0 - GLASS_TRANSPARENCY)).abs() < 1e-12);
                assert_eq!(retro_c, LASER_RETRO_GLASS);
            } else {
                assert_eq!(transparency, None, "wall {i}: opaque");
                assert!(child(visual, &["visibility_flags"]).is_none());
                assert_eq!(retro_c, LASER_RETRO_OPAQUE);
            }
        }
        for (i, p) in world.pillars.iter().enumerate() {
            let g = child(pillars[i], &["link", "collision", "geometry", "cylinder"]).unwrap();
            assert_eq!(nums(child(g, &["radius"]))[0], p.radius);
            assert_eq!(nums(child(g, &["length"]))[0], p.height);
        }
        for (i, b) in world.boxes.iter().enumerate() {
            let size = nums(child(
                boxes[i],
                &["link", "visual", "geometry", "box", "size"],
            ));
            assert_eq!(size, b.size.to_vec());
            let pose = nums(child(boxes[i], &["pose"]));
            assert_eq!(
                pose,
                vec![b.center[0], b.center[1], 0.5 * b.size[2], 0.0, 0.0, b.yaw]
            );
        }
    }
    assert!(exported >= 3, "bundled worlds exported: {exported}");
    assert!(glass_walls > 0, "no bundled world has glass walls to check");
}

/// The campus export with `edit` applied to its text (which must change it).
fn mutated(from: &str, to: &str) -> String {
    let xml = to_sdf(&World::campus().unwrap());
    assert!(xml.contains(from), "{from:?} not in the export");
    xml.replacen(from, to, 1)
}

#[test]
fn the_checker_rejects_what_sdf_1_9_does_not_allow() {
    let campus = World::campus().unwrap();
    assert_eq!(check(&to_sdf(&campus)), Ok(()));
    let wall_0 = format!("<model name=\"wall_0_{}\"", campus.walls[0].material);
    let cases = [
        // An element SDF does not know.
        (
            mutated(
                "<transparency>",
                "<refraction_index>1.5</refraction_index><transparency>",
            ),
            "refraction_index",
        ),
        // A known element under the wrong parent (transparency is for visuals only).
        (
            mutated(
                "<laser_retro>5</laser_retro>",
                "<transparency>0.7</transparency>",
            ),
            "transparency",
        ),
        // An element of a later version (collision material_density is SDF 1.11).
        (
            mutated(
                "<laser_retro>",
                "<material_density>1</material_density><laser_retro>",
            ),
            "material_density",
        ),
        (mutated("version=\"1.9\"", "version=\"1.8\""), "version"),
        (
            mutated("<model name=\"wall_0_", "<model nam=\"wall_0_"),
            "nam",
        ),
        (
            mutated(&wall_0, "<model name=\"ceiling\""),
            "\"ceiling\" used by both",
        ),
        (
            mutated("<model name=\"wall_0_", "<model name=\"a::"),
            "reserved",
        ),
        (
            mutated("<static>true</static>", "<static>yes</static>"),
            "bool",
        ),
        (mutated("<transparency>0.7", "<transparency>1.7"), "[0, 1]"),
        (
            mutated("<visibility_flags>65536", "<visibility_flags>-1"),
            "unsigned",
        ),
        (
            mutated(
                "</size></box>",
                "</size></box><box><size>1 1 1</size></box>",
            ),
            "<box> at most once",
        ),
        (
            mutated("</size></box>", "</size><sz/></box>"),
            "<sz> is not allowed",
        ),
        (mutated("<pose>", "<pose>0 "), "6 finite numbers"),
        (
            mutated("<sdf version", "<sdf xmlns=\"urn:x\" version"),
            "namespace",
        ),
    ];
    for (xml, needle) in cases {
        let e = check(&xml).expect_err(needle);
        assert!(e.contains(needle), "{needle:?} not in {e:?}");
    }
}

#[test]
fn names_and_text_are_escaped() {
    let toml = r#"
name = "a<b> & \"c\" 'd' --"
ceiling_height = 2.5
[materials."glass & co"]
laser = "glass"
reflect_within_deg = 5.0
[materials.wood]
laser = "opaque"
[[walls]]
points = [[0.0, 0.0], [0.0, 4.0]]
thickness = 0.1
material = "glass & co"
[[boxes]]
center = [2.0, 2.0]
size = [1.0, 0.5, 0.7]
yaw = 0.5
material = "wood"
[[access_points]]
name = "ap::one"
position = [1.0, 1.0, 2.0]
tx_power_dbm = -40.0
path_loss_exponent = 2.5
channel = 6
"#;
    let world = World::from_toml_str(toml, Path::new("escape.toml")).unwrap();
    let xml = to_sdf(&world);
    check(&xml).unwrap();
    let doc = roxmltree::Document::parse(&xml).unwrap();
    let w = doc.descendants().find(|n| n.has_tag_name("world")).unwrap();
    assert_eq!(w.attribute("name"), Some(world.name.as_str()));
    let names: Vec<&str> = models(&doc)
        .iter()
        .map(|m| m.attribute("name").unwrap())
        .collect();
    assert_eq!(
        names,
        ["ground_plane", "ceiling", "wall_0_glass___co", "box_0_wood"]
    );
    // A wall along +y turns by 90°; the world without pillars still gets a finite floor.
    let wall = models(&doc)[2];
    let pose = nums(child(wall, &["pose"]));
    assert!(
        (pose[5] - std::f64::consts::FRAC_PI_2).abs() < 1e-12,
        "{pose:?}"
    );
    assert_eq!(&pose[..3], &[0.0, 2.0, 1.25]);
    let frame = doc.descendants().find(|n| n.has_tag_name("frame")).unwrap();
    assert_eq!(frame.attribute("name"), Some("wifi_ap_0_ap__one"));
}
