//! `atrium inspect robot|world`: what Atrium derived from a description file.

use atrium_robots::model::{DriveKind, TrackSource};
use atrium_robots::RobotInspection;
use atrium_worlds::{LaserBehaviour, World};
use serde_json::{json, Value};
use std::fmt::Write;

fn v3(v: &nalgebra::Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// "differential" or "skid_steer".
fn drive_name(r: &atrium_robots::RobotModel) -> &'static str {
    match r.drive_kind {
        DriveKind::Differential => "differential",
        DriveKind::SkidSteer(_) => "skid_steer",
    }
}

/// The drive joints of each side, front to back.
fn side_joints(r: &atrium_robots::RobotModel) -> (Vec<&str>, Vec<&str>) {
    match &r.drive_kind {
        DriveKind::Differential => (vec![&r.left_wheel.joint], vec![&r.right_wheel.joint]),
        DriveKind::SkidSteer(s) => (
            s.left.iter().map(|w| w.joint.as_str()).collect(),
            s.right.iter().map(|w| w.joint.as_str()).collect(),
        ),
    }
}

fn track_source(s: &TrackSource) -> &'static str {
    match s {
        TrackSource::DefaultRatio => "default_ratio",
        TrackSource::Urdf => "urdf",
    }
}

/// `atrium inspect robot --json`: the model, and why each revolving joint that does not
/// drive was left out.
pub fn robot_json(i: &RobotInspection) -> Value {
    let r = &i.model;
    let wheel = |w: &atrium_robots::Wheel| {
        json!({"joint": w.joint, "link": w.link, "center": v3(&w.center), "axis": v3(&w.axis),
               "radius": w.radius, "width": w.width, "mass": w.mass})
    };
    let (left, right) = side_joints(r);
    let skid_steer = match &r.drive_kind {
        DriveKind::Differential => Value::Null,
        DriveKind::SkidSteer(s) => json!({
            "left_wheels": s.left.iter().map(wheel).collect::<Vec<_>>(),
            "right_wheels": s.right.iter().map(wheel).collect::<Vec<_>>(),
            "geometric_track": r.wheel_separation,
            "effective_track": s.effective_track,
            "effective_track_ratio": s.effective_track / r.wheel_separation,
            "effective_track_source": track_source(&s.effective_track_source),
        }),
    };
    json!({
        "drive": drive_name(r),
        "left_drive_joints": left,
        "right_drive_joints": right,
        "skid_steer": skid_steer,
        "name": r.name,
        "base_link": r.base_link,
        "wheel_radius": r.wheel_radius,
        "wheel_separation": r.wheel_separation,
        "drive_joints": r.driven_wheels().iter().map(|w| w.joint.as_str()).collect::<Vec<_>>(),
        "left_wheel": wheel(&r.left_wheel),
        "right_wheel": wheel(&r.right_wheel),
        "casters": r.casters.iter().map(|c| json!({"link": c.link, "center": v3(&c.center), "radius": c.radius})).collect::<Vec<_>>(),
        "caster_joints": caster_joints(i),
        "mass": r.mass(),
        "base_height": r.base_height,
        "links": r.mounts.iter().map(|m| {
            let (xyz, rpy) = m.xyz_rpy();
            json!({"name": m.name, "xyz": xyz, "rpy": rpy})
        }).collect::<Vec<_>>(),
        "excluded_joints": i.excluded_joints.iter().map(|e| json!({"joint": e.joint, "link": e.link, "reason": e.reason})).collect::<Vec<_>>(),
        "warnings": r.warnings,
    })
}

/// The excluded joints that belong to a caster: the loader called their wheel a caster, or
/// their link carries a caster's support sphere (a swivel fork).
fn caster_joints(i: &RobotInspection) -> Vec<&str> {
    i.excluded_joints
        .iter()
        .filter(|e| e.reason.contains("caster") || i.model.casters.iter().any(|c| c.link == e.link))
        .map(|e| e.joint.as_str())
        .collect()
}

pub fn robot_text(i: &RobotInspection) -> String {
    let r = &i.model;
    let mut s = String::new();
    let _ = writeln!(s, "robot {} (base link {})", r.name, r.base_link);
    let (left, right) = side_joints(r);
    match &r.drive_kind {
        DriveKind::Differential => {
            let _ = writeln!(s, "drive             differential");
        }
        DriveKind::SkidSteer(k) => {
            let _ = writeln!(
                s,
                "drive             skid steer, {} wheels per side driven together",
                k.left.len()
            );
        }
    }
    let _ = writeln!(s, "wheel_radius      {:.4} m", r.wheel_radius);
    let _ = writeln!(s, "wheel_separation  {:.4} m", r.wheel_separation);
    if let DriveKind::SkidSteer(k) = &r.drive_kind {
        let _ = writeln!(
            s,
            "effective track   {:.4} m ({:.3} x the geometric track; {})",
            k.effective_track,
            k.effective_track / r.wheel_separation,
            match k.effective_track_source {
                TrackSource::DefaultRatio => "the default ratio",
                TrackSource::Urdf => "from the URDF's <skid_steer>",
            }
        );
    }
    let _ = writeln!(
        s,
        "drive joints      left {}; right {}",
        left.join(", "),
        right.join(", ")
    );
    let casters = caster_joints(i);
    if !casters.is_empty() {
        let _ = writeln!(s, "caster joints     {}", casters.join(", "));
    }
    let _ = writeln!(s, "mass              {:.2} kg", r.mass());
    for c in &r.casters {
        let _ = writeln!(
            s,
            "caster            {} (support sphere r = {:.4} m)",
            c.link, c.radius
        );
    }
    let _ = writeln!(s, "\nlink mounts in the base frame (xyz m, rpy rad)");
    for m in &r.mounts {
        let (xyz, rpy) = m.xyz_rpy();
        let _ = writeln!(
            s,
            "  {:<28} xyz [{:>7.4} {:>7.4} {:>7.4}]  rpy [{:>7.4} {:>7.4} {:>7.4}]",
            m.name, xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2]
        );
    }
    for e in &i.excluded_joints {
        let _ = writeln!(
            s,
            "not a drive joint {} (link {}): {}",
            e.joint, e.link, e.reason
        );
    }
    for w in &r.warnings {
        let _ = writeln!(s, "warning: {w}");
    }
    s
}

fn kind_name<T: serde::Serialize>(k: &T) -> String {
    serde_json::to_value(k)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default()
}

pub fn world_json(w: &World) -> Value {
    let (min, max) = w.bounds();
    let glass = w
        .walls
        .iter()
        .filter(|wall| {
            w.material(&wall.material)
                .is_some_and(|m| matches!(m.laser, LaserBehaviour::Glass { .. }))
        })
        .count();
    json!({
        "name": w.name,
        "bounds": {"min": min, "max": max},
        "ceiling_height": w.ceiling_height,
        "materials": w.materials.iter().map(|m| json!({"name": m.name, "laser": m.laser})).collect::<Vec<_>>(),
        "walls": w.walls.len(),
        "glass_walls": glass,
        "pillars": w.pillars.len(),
        "regions": w.regions.iter().map(|r| json!({
            "name": r.name,
            "kind": kind_name(&r.kind),
            "area_m2": atrium_worlds::geometry::polygon_area(&r.polygon).abs(),
        })).collect::<Vec<_>>(),
    })
}

pub fn world_text(w: &World) -> String {
    let j = world_json(w);
    let mut s = String::new();
    let (min, max) = w.bounds();
    let _ = writeln!(
        s,
        "world {}: {:.1} × {:.1} m, ceiling {:.2} m",
        w.name,
        max[0] - min[0],
        max[1] - min[1],
        w.ceiling_height
    );
    let _ = writeln!(
        s,
        "{} walls ({} glass), {} pillars, {} materials",
        j["walls"],
        j["glass_walls"],
        j["pillars"],
        w.materials.len()
    );
    let _ = writeln!(s, "\nregions");
    for r in j["regions"].as_array().into_iter().flatten() {
        let _ = writeln!(
            s,
            "  {:<24} {:<15} {:>8.1} m²",
            r["name"].as_str().unwrap_or(""),
            r["kind"].as_str().unwrap_or(""),
            r["area_m2"].as_f64().unwrap_or(0.0)
        );
    }
    s
}
