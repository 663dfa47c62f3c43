//! `atrium inspect robot|world`: what Atrium derived from a description file.

use atrium_robots::model::{DriveKind, TrackSource};
use atrium_robots::{DepthCameraSpec, DriveSource, RobotInspection, RobotModel, RobotSensors};
use atrium_scenarios::robot_input::{self, RobotSources, SensorSource};
use atrium_scenarios::ScenarioError;
use atrium_worlds::{LaserBehaviour, World};
use serde_json::{json, Value};
use std::fmt::Write;
use std::path::{Path, PathBuf};

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

/// A robot as a scenario would load it, with its sensors and where they came from.
pub struct RobotReport {
    pub inspection: RobotInspection,
    pub urdf: PathBuf,
    pub sensors: RobotSensors,
    pub depth_cameras: Vec<DepthCameraSpec>,
    pub sources: RobotSources,
}

/// Loads the robot of `path`: a URDF, or a scenario file whose `robot` (a path or a `[robot]`
/// table with `wheel_radius` and `track`) names one.
pub fn load_robot(path: &Path) -> Result<RobotReport, ScenarioError> {
    let read = |p: &Path| {
        std::fs::read_to_string(p).map_err(|err| ScenarioError::Io {
            file: p.to_path_buf(),
            err,
        })
    };
    let (urdf, drive) = if path.extension().is_some_and(|e| e == "toml") {
        let doc: toml::Table =
            read(path)?
                .parse()
                .map_err(|e: toml::de::Error| ScenarioError::Parse {
                    file: path.to_path_buf(),
                    msg: e.to_string(),
                })?;
        let value = doc.get("robot").ok_or_else(|| {
            ScenarioError::field(path, "robot", "missing: this scenario names no robot")
        })?;
        let entry = robot_input::parse_robot_entry(path, value)?;
        let dir = path.parent().unwrap_or(Path::new("."));
        (dir.join(&entry.urdf), entry.drive)
    } else {
        (path.to_path_buf(), Default::default())
    };
    let text = read(&urdf)?;
    let mut inspection =
        RobotModel::inspect_urdf_str_with(&text, &urdf.display().to_string(), &drive)?;
    let (sensors, depth_cameras, mut sources) =
        robot_input::robot_sensors(&urdf, &mut inspection.model, false)?;
    sources.drive = inspection.drive_source;
    Ok(RobotReport {
        inspection,
        urdf,
        sensors,
        depth_cameras,
        sources,
    })
}

fn sensor_source(s: &SensorSource) -> Value {
    match s {
        SensorSource::SensorFile(p) => json!({"kind": "sensor_file", "file": p}),
        SensorSource::Gazebo(p) => json!({"kind": "urdf_gazebo", "file": p}),
        SensorSource::None(p) => json!({"kind": "none", "file": p}),
        SensorSource::Log => json!({"kind": "log"}),
    }
}

fn sensor_source_text(s: &SensorSource) -> String {
    match s {
        SensorSource::SensorFile(p) => format!("the sensor file {}", p.display()),
        SensorSource::Gazebo(p) => format!("<gazebo><sensor> blocks in {}", p.display()),
        SensorSource::None(p) => format!(
            "none: no sensor file beside {} and no <gazebo><sensor> blocks Atrium reads",
            p.display()
        ),
        SensorSource::Log => "the log".into(),
    }
}

fn drive_source(d: DriveSource) -> (&'static str, &'static str) {
    match d {
        DriveSource::Urdf => (
            "urdf",
            "the URDF's wheel joints and their collision (or visual) shapes",
        ),
        DriveSource::Override => (
            "robot_table",
            "the scenario's [robot] wheel_radius / track, over the URDF's wheels",
        ),
        DriveSource::OverrideMeshWheels => (
            "robot_table_mesh_wheels",
            "the scenario's [robot] wheel_radius and track, for wheels the URDF draws with \
             meshes only",
        ),
    }
}

/// The sensors of `r`, each with where it came from; the first laser is the one a localizer
/// that reads a single laser uses.
fn sensors_json(r: &RobotReport) -> Value {
    let source = sensor_source(&r.sources.sensors);
    let mut out: Vec<Value> = r
        .sensors
        .lasers
        .iter()
        .enumerate()
        .map(|(i, l)| {
            json!({"kind": "laser", "name": l.name, "mount": l.mount, "rate_hz": l.rate_hz,
                   "beams": l.beams, "fov": l.fov, "range_min": l.range_min,
                   "range_max": l.range_max, "sigma_hit": l.sigma_hit,
                   "default_laser": i == 0, "source": source})
        })
        .collect();
    out.extend(r.depth_cameras.iter().map(|c| {
        json!({"kind": "depth_camera", "name": c.name, "mount": c.mount, "rate_hz": c.rate_hz,
               "width": c.width, "height": c.height, "fov_h": c.fov_h, "fov_v": c.fov_v,
               "range_min": c.range_min, "range_max": c.range_max,
               "noise_base": c.noise_base, "source": source})
    }));
    if let Some(w) = &r.sensors.wifi {
        out.push(json!({"kind": "wifi", "name": w.name, "scan_period_s": w.scan_period_s, "source": source}));
    }
    Value::Array(out)
}

/// `atrium inspect robot --json` for a robot as a scenario loads it: [`robot_json`] plus its
/// sensors and the sources of sensors and drive geometry.
pub fn robot_report_json(r: &RobotReport) -> Value {
    let mut j = robot_json(&r.inspection);
    let o = j.as_object_mut().expect("robot_json is an object");
    o.insert("urdf".into(), json!(r.urdf));
    o.insert("sensors".into(), sensors_json(r));
    o.insert("sensor_source".into(), sensor_source(&r.sources.sensors));
    let odometry = match &r.sources.sensors {
        SensorSource::SensorFile(p) => json!({"kind": "sensor_file", "file": p}),
        _ => json!({"kind": "default"}),
    };
    o.insert("odometry_source".into(), odometry);
    o.insert(
        "drive_source".into(),
        json!(drive_source(r.sources.drive).0),
    );
    o.insert(
        "ignored_sensors".into(),
        json!(r
            .sources
            .ignored
            .iter()
            .map(|(n, t)| json!({"name": n, "type": t}))
            .collect::<Vec<_>>()),
    );
    o.insert("sensor_notes".into(), json!(r.sources.notes));
    j
}

/// `atrium inspect robot` as text: [`robot_text`] plus the sensors and their sources.
pub fn robot_report_text(r: &RobotReport) -> String {
    let mut s = robot_text(&r.inspection);
    let _ = writeln!(
        s,
        "\ndrive geometry    from {}",
        drive_source(r.sources.drive).1
    );
    let _ = writeln!(
        s,
        "sensors           from {}",
        sensor_source_text(&r.sources.sensors)
    );
    let _ = writeln!(
        s,
        "odometry          {}",
        match &r.sources.sensors {
            SensorSource::SensorFile(p) => format!("from {}", p.display()),
            _ => "defaults (no sensor file)".into(),
        }
    );
    for (i, l) in r.sensors.lasers.iter().enumerate() {
        let _ = writeln!(
            s,
            "laser             {} on {}: {} beams over {:.1}°, {:.2}–{:.2} m, {} Hz, σ {} m{}",
            l.name,
            l.mount,
            l.beams,
            l.fov.to_degrees(),
            l.range_min,
            l.range_max,
            l.rate_hz,
            l.sigma_hit,
            if i == 0 {
                " (the default laser: a localizer that reads one laser uses it)"
            } else {
                ""
            }
        );
    }
    for c in &r.depth_cameras {
        let _ = writeln!(
            s,
            "depth camera      {} on {}: {} × {} px, {:.1}° × {:.1}°, {:.2}–{:.2} m, {} Hz, σ {} m",
            c.name,
            c.mount,
            c.width,
            c.height,
            c.fov_h.to_degrees(),
            c.fov_v.to_degrees(),
            c.range_min,
            c.range_max,
            c.rate_hz,
            c.noise_base
        );
    }
    if r.sensors.wifi.is_some() {
        let _ = writeln!(s, "wifi              scanner from the sensor file");
    }
    for (name, kind) in &r.sources.ignored {
        let _ = writeln!(s, "not simulated     {name} (Gazebo sensor type {kind:?})");
    }
    for n in &r.sources.notes {
        let _ = writeln!(s, "note: {n}");
    }
    s
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
