//! The world as an SDFormat 1.9 world (`atrium export world WORLD --format sdf`), so the same
//! building can be run in Gazebo (gz-sim, or Gazebo Classic 11 via its SDF converter) and the
//! two simulators compared.
//!
//! What is written, all in one `<world>`:
//! - a sun (directional light), a `<physics>` block (1 ms steps, real time), gravity, and a
//!   scene without shadows (an indoor floor under a ceiling would otherwise be in shadow);
//! - `ground_plane`: the floor, a plane (infinite for collisions, the world's extent plus a
//!   margin for the visual);
//! - `ceiling`: a visual-only plane facing down at `ceiling_height` (depth and ceiling cameras
//!   see it; nothing collides with it; a one-sided plane does not hide the building from a GUI
//!   camera above it);
//! - one static model per wall (`wall_<i>_<material>`: a box along the centre line, thickness
//!   wide, height tall, no end caps, exactly the footprint Atrium uses), per pillar
//!   (`pillar_<i>_<material>`: a cylinder) and per furniture box (`box_<i>_<material>`: a box
//!   turned by its yaw);
//! - one `<frame>` per WiFi access point (`wifi_ap_<i>_<name>`) at the antenna, so a user can
//!   find them; Gazebo has no WiFi model.
//!
//! Glass: the visual is see-through (`<transparency>` [`GLASS_TRANSPARENCY`], a tinted
//! material whose alpha agrees), and both the collision and the visual carry a low
//! `<laser_retro>` ([`LASER_RETRO_GLASS`] against [`LASER_RETRO_OPAQUE`]): Gazebo Classic's
//! CPU ray sensor reports a collision's `laser_retro` as intensity, gz-sim's `gpu_lidar`
//! renders the visual's. Neither simulator lets a beam pass a surface depending on the angle
//! of incidence, which is Atrium's glass model, and `gpu_lidar` renders depth regardless of
//! transparency: to let a lidar see through glass in gz-sim, glass visuals carry only the
//! [`GLASS_VISIBILITY_FLAGS`] bit in `<visibility_flags>`, so a `gpu_lidar` whose
//! `<lidar><visibility_mask>` is [`LIDAR_MASK_WITHOUT_GLASS`] ignores them (a visual is seen
//! when `mask & flags != 0`; the lidar `<visibility_mask>` element is SDF 1.9, sdformat
//! pull request 1015), while cameras with the default all-ones mask still see the glass.
//!
//! Regions and lights are not written: SDF has no notion of the first, and Atrium's lights
//! depend on the run's lighting condition.
//!
//! The output depends only on the world (no time stamps, no hash-map order), so exporting the
//! same world twice gives identical bytes.

use atrium_worlds::{LaserBehaviour, World};
use std::fmt::Write;

/// The SDFormat version written in `<sdf version=...>`.
pub const SDF_VERSION: &str = "1.9";

/// `<transparency>` of glass visuals (0 opaque, 1 invisible).
pub const GLASS_TRANSPARENCY: f64 = 0.7;

/// `<laser_retro>` (reflective intensity, arbitrary units: only the ratio matters) of opaque
/// materials.
pub const LASER_RETRO_OPAQUE: f64 = 100.0;

/// `<laser_retro>` of glass: it returns little of a beam (Atrium: nothing, except near normal
/// incidence).
pub const LASER_RETRO_GLASS: f64 = 5.0;

/// `<visibility_flags>` of glass visuals: one bit of their own (bit 16, inside the
/// `0x0FFFFFFF` that gz-rendering's ordinary visuals use, clear of its GUI and selection bits).
pub const GLASS_VISIBILITY_FLAGS: u32 = 0x0001_0000;

/// The `gpu_lidar` `<visibility_mask>` that hides glass and shows everything else.
pub const LIDAR_MASK_WITHOUT_GLASS: u32 = !GLASS_VISIBILITY_FLAGS;

/// Margin around the solids' extent for the floor and ceiling visuals, m.
const PLANE_MARGIN_M: f64 = 10.0;

/// The world as an SDFormat 1.9 document (see the module documentation for what is written).
pub fn to_sdf(world: &World) -> String {
    let mut s = String::new();
    s.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    s.push_str(&format!(
        "<!-- Written by atrium from world {}. Glass visuals carry visibility_flags {}: \
         a gpu_lidar with <visibility_mask>{}</visibility_mask> sees through glass. -->\n",
        escape(&comment_safe(&world.name)),
        GLASS_VISIBILITY_FLAGS,
        LIDAR_MASK_WITHOUT_GLASS
    ));
    let _ = writeln!(s, "<sdf version=\"{SDF_VERSION}\">");
    let _ = writeln!(s, "  <world name=\"{}\">", escape(&world.name));
    s.push_str(concat!(
        "    <physics name=\"1ms\" type=\"ode\">\n",
        "      <max_step_size>0.001</max_step_size>\n",
        "      <real_time_factor>1</real_time_factor>\n",
        "    </physics>\n",
        "    <gravity>0 0 -9.81</gravity>\n",
        "    <scene>\n",
        "      <ambient>0.4 0.4 0.4 1</ambient>\n",
        "      <background>0.7 0.7 0.7 1</background>\n",
        "      <shadows>false</shadows>\n",
        "    </scene>\n",
        "    <light name=\"sun\" type=\"directional\">\n",
        "      <cast_shadows>false</cast_shadows>\n",
    ));
    let _ = writeln!(
        s,
        "      <pose>0 0 {} 0 0 0</pose>",
        num(world.ceiling_height + PLANE_MARGIN_M)
    );
    s.push_str(concat!(
        "      <diffuse>0.8 0.8 0.8 1</diffuse>\n",
        "      <specular>0.2 0.2 0.2 1</specular>\n",
        "      <attenuation>\n",
        "        <range>1000</range>\n",
        "        <constant>0.9</constant>\n",
        "        <linear>0.01</linear>\n",
        "        <quadratic>0.001</quadratic>\n",
        "      </attenuation>\n",
        "      <direction>-0.5 0.1 -0.9</direction>\n",
        "    </light>\n",
    ));

    let (lo, hi) = extent(world);
    let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let size = [
        hi[0] - lo[0] + 2.0 * PLANE_MARGIN_M,
        hi[1] - lo[1] + 2.0 * PLANE_MARGIN_M,
    ];
    let floor_look = Look::surface(world, "floor");
    let plane = |normal_z: i32| {
        format!(
            "<plane><normal>0 0 {normal_z}</normal><size>{} {}</size></plane>",
            num(size[0]),
            num(size[1])
        )
    };
    model(
        &mut s,
        "ground_plane",
        [centre[0], centre[1], 0.0],
        0.0,
        &plane(1),
        &floor_look,
        true,
    );
    let ceiling_look = Look::surface(world, "ceiling");
    model(
        &mut s,
        "ceiling",
        [centre[0], centre[1], world.ceiling_height],
        0.0,
        &plane(-1),
        &ceiling_look,
        false,
    );

    for (i, w) in world.walls.iter().enumerate() {
        let d = [w.b[0] - w.a[0], w.b[1] - w.a[1]];
        let length = d[0].hypot(d[1]);
        let geometry = format!(
            "<box><size>{} {} {}</size></box>",
            num(length),
            num(w.thickness),
            num(w.height)
        );
        model(
            &mut s,
            &format!("wall_{i}_{}", name_part(&w.material)),
            [
                0.5 * (w.a[0] + w.b[0]),
                0.5 * (w.a[1] + w.b[1]),
                0.5 * w.height,
            ],
            d[1].atan2(d[0]),
            &geometry,
            &Look::material(world, &w.material),
            true,
        );
    }
    for (i, p) in world.pillars.iter().enumerate() {
        let geometry = format!(
            "<cylinder><radius>{}</radius><length>{}</length></cylinder>",
            num(p.radius),
            num(p.height)
        );
        model(
            &mut s,
            &format!("pillar_{i}_{}", name_part(&p.material)),
            [p.center[0], p.center[1], 0.5 * p.height],
            0.0,
            &geometry,
            &Look::material(world, &p.material),
            true,
        );
    }
    for (i, b) in world.boxes.iter().enumerate() {
        let geometry = format!(
            "<box><size>{} {} {}</size></box>",
            num(b.size[0]),
            num(b.size[1]),
            num(b.size[2])
        );
        model(
            &mut s,
            &format!("box_{i}_{}", name_part(&b.material)),
            [b.center[0], b.center[1], 0.5 * b.size[2]],
            b.yaw,
            &geometry,
            &Look::material(world, &b.material),
            true,
        );
    }
    for (i, ap) in world.access_points.iter().enumerate() {
        let _ = writeln!(
            s,
            "    <frame name=\"wifi_ap_{i}_{}\">\n      <pose>{} {} {} 0 0 0</pose>\n    </frame>",
            escape(&name_part(&ap.name)),
            num(ap.position[0]),
            num(ap.position[1]),
            num(ap.position[2])
        );
    }
    s.push_str("  </world>\n</sdf>\n");
    s
}

/// How a surface looks and what a laser makes of it.
struct Look {
    /// Grey level of the diffuse colour, from the surface's camera albedo.
    albedo: f64,
    glass: bool,
}

impl Look {
    fn material(world: &World, material: &str) -> Look {
        Look {
            albedo: world.lighting.surface(material).albedo,
            glass: matches!(
                world.material(material).map(|m| m.laser),
                Some(LaserBehaviour::Glass { .. })
            ),
        }
    }

    fn surface(world: &World, name: &str) -> Look {
        Look {
            albedo: world.lighting.surface(name).albedo,
            glass: false,
        }
    }
}

/// Writes one static model with a single link holding `geometry` as visual and, when
/// `collide`, as collision.
fn model(
    s: &mut String,
    name: &str,
    position: [f64; 3],
    yaw: f64,
    geometry: &str,
    look: &Look,
    collide: bool,
) {
    let retro = if look.glass {
        LASER_RETRO_GLASS
    } else {
        LASER_RETRO_OPAQUE
    };
    let name = escape(name);
    let _ = writeln!(s, "    <model name=\"{name}\">");
    s.push_str("      <static>true</static>\n");
    let _ = writeln!(
        s,
        "      <pose>{} {} {} 0 0 {}</pose>",
        num(position[0]),
        num(position[1]),
        num(position[2]),
        num(yaw)
    );
    s.push_str("      <link name=\"link\">\n");
    if collide {
        s.push_str("        <collision name=\"collision\">\n");
        let _ = writeln!(s, "          <laser_retro>{}</laser_retro>", num(retro));
        let _ = writeln!(s, "          <geometry>{geometry}</geometry>");
        s.push_str("        </collision>\n");
    }
    s.push_str("        <visual name=\"visual\">\n");
    if collide {
        let _ = writeln!(s, "          <laser_retro>{}</laser_retro>", num(retro));
    } else {
        // Nothing to collide with and nothing to cast a shadow over the building.
        s.push_str("          <cast_shadows>false</cast_shadows>\n");
    }
    let g = num(look.albedo.clamp(0.0, 1.0));
    if look.glass {
        // Rounded: 1 - 0.7 is 0.30000000000000004 in binary.
        let alpha = num(((1.0 - GLASS_TRANSPARENCY) * 1e9).round() / 1e9);
        let _ = writeln!(
            s,
            "          <transparency>{}</transparency>",
            num(GLASS_TRANSPARENCY)
        );
        let _ = writeln!(
            s,
            "          <visibility_flags>{GLASS_VISIBILITY_FLAGS}</visibility_flags>"
        );
        // A faint blue-green tint, as float glass looks edge-on.
        let _ = writeln!(
            s,
            "          <material>\n            <ambient>0.6 0.8 0.8 {alpha}</ambient>\n            \
             <diffuse>0.6 0.8 0.8 {alpha}</diffuse>\n            \
             <specular>0.9 0.9 0.9 {alpha}</specular>\n          </material>"
        );
    } else {
        let _ = writeln!(
            s,
            "          <material>\n            <ambient>{g} {g} {g} 1</ambient>\n            \
             <diffuse>{g} {g} {g} 1</diffuse>\n            \
             <specular>0.1 0.1 0.1 1</specular>\n          </material>"
        );
    }
    let _ = writeln!(s, "          <geometry>{geometry}</geometry>");
    s.push_str("        </visual>\n      </link>\n    </model>\n");
}

/// Axis-aligned extent of walls, pillars and furniture; a 1 m square at the origin without
/// any.
fn extent(world: &World) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let mut add = |p: [f64; 2]| {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    };
    if !(world.walls.is_empty() && world.pillars.is_empty()) {
        // `bounds` is [0, 0] for a world without walls and pillars: only use it with some.
        let (a, b) = world.bounds();
        add(a);
        add(b);
    }
    for b in &world.boxes {
        b.corners().into_iter().for_each(&mut add);
    }
    if !(lo[0] <= hi[0] && lo[1] <= hi[1]) {
        return ([-0.5; 2], [0.5; 2]);
    }
    (lo, hi)
}

/// A number as SDF reads it: shortest round-trip decimal, and never `-0`.
fn num(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v}")
    }
}

/// `text` safe in an XML attribute or element.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // XML 1.0 forbids most control characters even as references.
            c if (c as u32) < 0x20 && !matches!(c, '\t' | '\n' | '\r') => out.push('_'),
            c => out.push(c),
        }
    }
    out
}

/// `text` safe inside an XML comment (no `--`, no trailing `-`).
fn comment_safe(text: &str) -> String {
    text.replace('-', "\u{2010}")
}

/// A user-given name as part of an SDF entity name: SDF reserves `::` as the scope separator
/// and names starting and ending with `__`, so everything but ASCII letters, digits, `_`, `-`
/// and `.` becomes `_`.
fn name_part(text: &str) -> String {
    let s: String = text
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect();
    if s.is_empty() {
        "unnamed".into()
    } else {
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escaping_and_names() {
        assert_eq!(escape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&apos;");
        assert_eq!(escape("x\u{1}y"), "x_y");
        assert_eq!(name_part("m::x y"), "m__x_y");
        assert_eq!(name_part(""), "unnamed");
        assert_eq!(num(-0.0), "0");
        assert_eq!(num(0.25), "0.25");
        assert!(!comment_safe("a--b-").contains('-'));
    }
}
