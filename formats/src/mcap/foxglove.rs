//! Readings to MCAP messages and back: Foxglove well-known schemas (protobuf) for what the
//! ecosystem's tools display, and JSON-schema channels for what has no well-known schema
//! (WiFi scans, landmark detections, the raw odometry ticks, scoring instants, events).
//!
//! Exactness: replay must score exactly like the live run, so every value a localizer or the
//! scorer reads must survive the round trip bit for bit. Foxglove messages carry f64 ranges and
//! positions exactly, but a planar heading stored as a quaternion does not come back bit-exact
//! and a nanosecond timestamp does not give back `steps / physics_hz`. Hence: times are snapped
//! back to the physics clock (`physics_hz` in the file's metadata), headings a localizer reads
//! (odometry, ground truth at the scoring instants) also go to JSON channels whose numbers
//! are written shortest-round-trip and parsed correctly rounded (serde_json's
//! `float_roundtrip`), and per-sensor constants (mounts, angles, range limits, intrinsics)
//! go to channel metadata in Rust's round-trip float notation.

use atrium_robots::{DepthImage, LaserScan, Mount3, Pose2};
use foxglove::messages as fg;
use std::collections::BTreeMap;

/// Nanoseconds of a time in seconds (the MCAP log time; the clock starts at 0).
pub fn ns_of(t: f64) -> u64 {
    (t.max(0.0) * 1e9).round() as u64
}

/// Seconds of a log time, snapped to the physics clock when its rate is known: a live stamp
/// is `steps as f64 / physics_hz`, and this recomputes exactly that value.
pub fn seconds_of(ns: u64, physics_hz: Option<f64>) -> f64 {
    match physics_hz {
        Some(hz) => (ns as f64 * hz / 1e9).round() / hz,
        None => ns as f64 / 1e9,
    }
}

pub fn timestamp(ns: u64) -> fg::Timestamp {
    fg::Timestamp::new((ns / 1_000_000_000) as u32, (ns % 1_000_000_000) as u32)
}

/// A yaw as a quaternion about +z.
pub fn yaw_quaternion(theta: f64) -> fg::Quaternion {
    let (s, c) = (0.5 * theta).sin_cos();
    fg::Quaternion {
        x: 0.0,
        y: 0.0,
        z: s,
        w: c,
    }
}

/// The yaw of a quaternion (its rotation projected to the floor plane).
pub fn yaw_of(q: &fg::Quaternion) -> f64 {
    (2.0 * (q.w * q.z + q.x * q.y)).atan2(1.0 - 2.0 * (q.y * q.y + q.z * q.z))
}

pub fn pose_of(p: &Pose2) -> fg::Pose {
    fg::Pose {
        position: Some(fg::Vector3 {
            x: p.x,
            y: p.y,
            z: 0.0,
        }),
        orientation: Some(yaw_quaternion(p.theta)),
    }
}

/// The planar pose of a Foxglove pose (missing parts count as zero / identity).
pub fn pose2_of(p: Option<&fg::Pose>) -> Pose2 {
    let Some(p) = p else {
        return Pose2::default();
    };
    let (x, y) = p.position.as_ref().map_or((0.0, 0.0), |v| (v.x, v.y));
    let theta = p.orientation.as_ref().map_or(0.0, yaw_of);
    Pose2::new(x, y, theta)
}

pub fn pose_in_frame(ns: u64, frame: &str, p: &Pose2) -> fg::PoseInFrame {
    fg::PoseInFrame {
        timestamp: Some(timestamp(ns)),
        frame_id: frame.to_string(),
        pose: Some(pose_of(p)),
    }
}

/// A 3D transform from a mount (URDF xyz + roll, pitch, yaw).
pub fn frame_transform(ns: u64, parent: &str, child: &str, m: &Mount3) -> fg::FrameTransform {
    let q = m.to_isometry().rotation;
    fg::FrameTransform {
        timestamp: Some(timestamp(ns)),
        parent_frame_id: parent.to_string(),
        child_frame_id: child.to_string(),
        translation: Some(fg::Vector3 {
            x: m.xyz[0],
            y: m.xyz[1],
            z: m.xyz[2],
        }),
        rotation: Some(fg::Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        }),
    }
}

pub fn planar_transform(ns: u64, parent: &str, child: &str, p: &Pose2) -> fg::FrameTransform {
    fg::FrameTransform {
        timestamp: Some(timestamp(ns)),
        parent_frame_id: parent.to_string(),
        child_frame_id: child.to_string(),
        translation: Some(fg::Vector3 {
            x: p.x,
            y: p.y,
            z: 0.0,
        }),
        rotation: Some(yaw_quaternion(p.theta)),
    }
}

/// Float in Rust's shortest round-trip notation (`str::parse` gives the same bits back).
fn f(v: f64) -> String {
    format!("{v:?}")
}

fn parse_f(meta: &BTreeMap<String, String>, key: &str) -> Option<f64> {
    meta.get(key).and_then(|s| s.parse().ok())
}

/// Channel metadata of a laser: the per-sensor constants a `foxglove.LaserScan` lacks.
pub fn laser_metadata(scan: &LaserScan) -> BTreeMap<String, String> {
    BTreeMap::from([
        ("sensor".into(), scan.sensor.clone()),
        ("mount_x".into(), f(scan.mount.x)),
        ("mount_y".into(), f(scan.mount.y)),
        ("mount_theta".into(), f(scan.mount.theta)),
        ("angle_min".into(), f(scan.angle_min)),
        ("angle_increment".into(), f(scan.angle_increment)),
        ("range_min".into(), f(scan.range_min)),
        ("range_max".into(), f(scan.range_max)),
    ])
}

/// Fills `msg` (reused between scans, so steady-state encoding does not allocate) from `scan`.
/// Beams are evenly spread from `start_angle` to `end_angle` inclusive, as Foxglove draws them.
/// `origin` is the scan's origin in `frame` (identity when `frame` is the laser's own link).
pub fn fill_laser(msg: &mut fg::LaserScan, ns: u64, frame: &str, origin: &Pose2, scan: &LaserScan) {
    msg.timestamp = Some(timestamp(ns));
    if msg.frame_id != frame {
        msg.frame_id = frame.to_string();
    }
    msg.pose = Some(pose_of(origin));
    msg.start_angle = scan.angle_min;
    msg.end_angle = scan.beam_angle(scan.ranges.len().saturating_sub(1));
    msg.ranges.clear();
    msg.ranges.extend_from_slice(&scan.ranges);
    msg.intensities.clear();
}

/// Mount of a laser on replay: the channel metadata, else `fallback` (the /tf transform from
/// the base to the scan's frame, identity when there is none).
pub fn laser_from_message(
    msg: &fg::LaserScan,
    meta: &BTreeMap<String, String>,
    topic_sensor: &str,
    stamp: f64,
    fallback_mount: Pose2,
) -> LaserScan {
    let n = msg.ranges.len();
    let mount = match (
        parse_f(meta, "mount_x"),
        parse_f(meta, "mount_y"),
        parse_f(meta, "mount_theta"),
    ) {
        (Some(x), Some(y), Some(t)) => Pose2::new(x, y, t),
        _ => fallback_mount.compose(&pose2_of(msg.pose.as_ref())),
    };
    let angle_increment = parse_f(meta, "angle_increment").unwrap_or_else(|| {
        if n > 1 {
            (msg.end_angle - msg.start_angle) / (n - 1) as f64
        } else {
            0.0
        }
    });
    // A file from elsewhere may state no range limits: ROS drivers report "no return" as
    // inf or NaN, which become range_max; without a stated limit the scan's largest finite
    // range stands in for it.
    let range_max = parse_f(meta, "range_max").unwrap_or_else(|| {
        msg.ranges
            .iter()
            .copied()
            .filter(|r| r.is_finite())
            .fold(0.0, f64::max)
    });
    let ranges = msg
        .ranges
        .iter()
        .map(|&r| if r.is_finite() { r } else { range_max })
        .collect();
    LaserScan {
        stamp,
        sensor: meta
            .get("sensor")
            .cloned()
            .unwrap_or_else(|| topic_sensor.to_string()),
        mount,
        angle_min: parse_f(meta, "angle_min").unwrap_or(msg.start_angle),
        angle_increment,
        range_min: parse_f(meta, "range_min").unwrap_or(0.0),
        range_max,
        ranges,
    }
}

/// The encoding of depth images: 32-bit float metres, REP 118 (NaN where a pixel is invalid;
/// Atrium's readings use 0 there, so 0 and NaN map onto each other).
pub const DEPTH_ENCODING: &str = "32FC1";

pub fn depth_metadata(d: &DepthImage) -> BTreeMap<String, String> {
    BTreeMap::from([
        ("sensor".into(), d.sensor.clone()),
        ("unit".into(), "m (32FC1, NaN = invalid)".into()),
        (
            "mount_xyz".into(),
            format!(
                "{},{},{}",
                f(d.mount.xyz[0]),
                f(d.mount.xyz[1]),
                f(d.mount.xyz[2])
            ),
        ),
        (
            "mount_rpy".into(),
            format!(
                "{},{},{}",
                f(d.mount.rpy[0]),
                f(d.mount.rpy[1]),
                f(d.mount.rpy[2])
            ),
        ),
        ("fx".into(), f(d.fx)),
        ("fy".into(), f(d.fy)),
        ("cx".into(), f(d.cx)),
        ("cy".into(), f(d.cy)),
    ])
}

/// Fills `msg` and its reusable byte buffer `data` from `d`.
pub fn fill_depth(
    msg: &mut fg::RawImage,
    data: &mut Vec<u8>,
    ns: u64,
    frame: &str,
    d: &DepthImage,
) {
    data.clear();
    data.reserve(d.depth.len() * 4);
    for &z in &d.depth {
        let v = if z > 0.0 && z.is_finite() {
            z
        } else {
            f32::NAN
        };
        data.extend_from_slice(&v.to_le_bytes());
    }
    msg.timestamp = Some(timestamp(ns));
    if msg.frame_id != frame {
        msg.frame_id = frame.to_string();
    }
    msg.width = d.width as u32;
    msg.height = d.height as u32;
    msg.encoding = DEPTH_ENCODING.to_string();
    msg.step = (d.width * 4) as u32;
    // `Bytes` takes the buffer; it is handed back by the caller after encoding.
    msg.data = foxglove::bytes::Bytes::from(std::mem::take(data));
}

fn triple(meta: &BTreeMap<String, String>, key: &str) -> Option<[f64; 3]> {
    let v: Vec<f64> = meta
        .get(key)?
        .split(',')
        .map(|s| s.parse().ok())
        .collect::<Option<_>>()?;
    (v.len() == 3).then(|| [v[0], v[1], v[2]])
}

/// A depth reading from a `foxglove.RawImage` (32FC1 metres or 16UC1 millimetres) and its
/// channel metadata (mount, intrinsics); `Err` names what is missing or malformed.
pub fn depth_from_message(
    msg: &fg::RawImage,
    meta: &BTreeMap<String, String>,
    topic_sensor: &str,
    stamp: f64,
) -> Result<DepthImage, String> {
    let (w, h) = (msg.width as usize, msg.height as usize);
    let bpp = match msg.encoding.as_str() {
        "32FC1" => 4,
        "16UC1" => 2,
        other => {
            return Err(format!(
                "depth encoding {other:?} (expected 32FC1 or 16UC1)"
            ))
        }
    };
    let step = msg.step as usize;
    if !image_fits(w, h, step, bpp, msg.data.len()) {
        return Err(format!(
            "{}x{} image of {} bytes with step {step} is empty or too short",
            w,
            h,
            msg.data.len()
        ));
    }
    let mut depth = Vec::with_capacity(w * h);
    for v in 0..h {
        let row = &msg.data[v * step..v * step + w * bpp];
        for px in row.chunks_exact(bpp) {
            let z = if bpp == 4 {
                f32::from_le_bytes([px[0], px[1], px[2], px[3]])
            } else {
                f32::from(u16::from_le_bytes([px[0], px[1]])) / 1000.0
            };
            depth.push(if z.is_finite() && z > 0.0 { z } else { 0.0 });
        }
    }
    let need = |k: &str| parse_f(meta, k).ok_or_else(|| format!("channel metadata lacks {k:?}"));
    Ok(DepthImage {
        stamp,
        sensor: meta
            .get("sensor")
            .cloned()
            .unwrap_or_else(|| topic_sensor.to_string()),
        mount: Mount3 {
            xyz: triple(meta, "mount_xyz").ok_or("channel metadata lacks \"mount_xyz\"")?,
            rpy: triple(meta, "mount_rpy").ok_or("channel metadata lacks \"mount_rpy\"")?,
        },
        width: w,
        height: h,
        fx: need("fx")?,
        fy: need("fy")?,
        cx: need("cx")?,
        cy: need("cy")?,
        depth,
    })
}

/// JSON schemas of the channels that have no Foxglove well-known schema.
pub mod json_schemas {
    pub const WIFI_SCAN: &str = r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"atrium.WifiScan","description":"One WiFi scan: the access points heard (those below the sensitivity cut-off are absent).","type":"object","properties":{"stamp":{"type":"number","description":"s"},"sensor":{"type":"string"},"readings":{"type":"array","items":{"type":"object","properties":{"ap":{"type":"string","description":"access point name (BSSID)"},"channel":{"type":"integer"},"rssi_dbm":{"type":"number","description":"received signal strength, dBm"}},"required":["ap","channel","rssi_dbm"]}}},"required":["stamp","sensor","readings"]}"#;
    pub const LANDMARKS: &str = r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"atrium.LandmarkDetections","description":"Range-bearing detections of point features in the detector's frame.","type":"object","properties":{"stamp":{"type":"number"},"sensor":{"type":"string"},"mount":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"theta":{"type":"number"}}},"detections":{"type":"array","items":{"type":"object","properties":{"range":{"type":"number","description":"m"},"bearing":{"type":"number","description":"rad, counter-clockwise from the sensor's +x"},"id":{"type":["integer","null"]}},"required":["range","bearing"]}}},"required":["stamp","sensor","mount","detections"]}"#;
    pub const WHEEL_ODOMETRY: &str = r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"atrium.WheelOdometry","description":"Wheel odometry: the pose integrated from the encoders in the odom frame and the cumulative tick counts.","type":"object","properties":{"stamp":{"type":"number"},"pose":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"theta":{"type":"number"}}},"left_ticks":{"type":"integer"},"right_ticks":{"type":"integer"}},"required":["stamp","pose","left_ticks","right_ticks"]}"#;
    pub const SCORE: &str = r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"atrium.ScoringInstant","description":"An instant at which the localizers are scored, with the ground-truth pose of the base in the map frame.","type":"object","properties":{"t":{"type":"number","description":"s"},"x":{"type":"number"},"y":{"type":"number"},"theta":{"type":"number"}},"required":["t","x","y","theta"]}"#;
    pub const EVENT: &str = r#"{"$schema":"https://json-schema.org/draft/2020-12/schema","title":"atrium.Event","description":"A scenario event as it took effect (kidnap: the robot is moved, the localizers are not told).","type":"object","properties":{"kind":{"type":"string"},"at_s":{"type":"number"},"to":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"theta":{"type":"number"}}}},"required":["kind","at_s"]}"#;
}

/// A `w × h` image of `bpp` bytes a pixel, rows `step` bytes apart, is non-empty and lies
/// within `len` bytes. Width, height and step come from the file: checked arithmetic (u32
/// products overflow in release builds) before anything is sliced or allocated, and an empty
/// image would let a huge height loop over rows of nothing.
pub fn image_fits(w: usize, h: usize, step: usize, bpp: usize, len: usize) -> bool {
    let row = w.checked_mul(bpp);
    let need = row.and_then(|row| step.checked_mul(h.checked_sub(1)?)?.checked_add(row));
    w > 0 && h > 0 && matches!((row, need), (Some(row), Some(need)) if step >= row && len >= need)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_snap_back_to_the_physics_clock() {
        for steps in [0u64, 1, 7, 199, 12_345, 52_000, 3_600_000] {
            let t = steps as f64 / 200.0;
            assert_eq!(seconds_of(ns_of(t), Some(200.0)).to_bits(), t.to_bits());
        }
        assert_eq!(seconds_of(1_500_000_000, None), 1.5);
        let ts = timestamp(3_250_000_001);
        assert_eq!((ts.sec(), ts.nsec()), (3, 250_000_001));
    }

    #[test]
    fn yaw_survives_a_quaternion_to_rounding() {
        for th in [-3.0, -1.0, 0.0, 0.5, std::f64::consts::FRAC_PI_2, 3.1] {
            let back = yaw_of(&yaw_quaternion(th));
            assert!((back - th).abs() < 1e-12, "{th} -> {back}");
        }
    }

    #[test]
    fn laser_round_trip_is_exact_with_metadata() {
        let scan = LaserScan {
            stamp: 0.1,
            sensor: "front".into(),
            mount: Pose2::new(0.13, -0.01, 0.1),
            angle_min: -std::f64::consts::FRAC_PI_2,
            angle_increment: std::f64::consts::PI / 180.0,
            range_min: 0.05,
            range_max: 8.0,
            ranges: (0..181).map(|i| 0.5 + 0.01 * i as f64).collect(),
        };
        let mut msg = fg::LaserScan::default();
        fill_laser(&mut msg, ns_of(0.1), "laser", &Pose2::default(), &scan);
        assert_eq!(msg.end_angle, scan.beam_angle(180));
        let back = laser_from_message(&msg, &laser_metadata(&scan), "x", 0.1, Pose2::default());
        assert_eq!(back, scan);
        // Without metadata: the angles and limits are derived from the message.
        let mut foreign = msg.clone();
        foreign.ranges[3] = f64::INFINITY;
        let b = laser_from_message(&foreign, &BTreeMap::new(), "x", 0.1, Pose2::default());
        assert_eq!(b.sensor, "x");
        assert!((b.angle_increment - scan.angle_increment).abs() < 1e-15);
        assert_eq!(b.range_max, 0.5 + 0.01 * 180.0);
        assert_eq!(b.ranges[3], b.range_max);
        assert_eq!(b.range_min, 0.0);
    }

    #[test]
    fn depth_round_trip_maps_invalid_to_nan_and_back() {
        let d = DepthImage {
            stamp: 0.5,
            sensor: "kinect".into(),
            mount: Mount3 {
                xyz: [0.1, 0.0, 0.45],
                rpy: [0.0, 0.1, 0.0],
            },
            width: 3,
            height: 2,
            fx: 525.0,
            fy: 525.5,
            cx: 1.5,
            cy: 1.0,
            depth: vec![0.8, 0.0, 4.5, 1.234_567_8, 2.0, 0.0],
        };
        let mut msg = fg::RawImage::default();
        let mut buf = Vec::new();
        fill_depth(&mut msg, &mut buf, ns_of(0.5), "kinect", &d);
        assert_eq!((msg.width, msg.height, msg.step), (3, 2, 12));
        let px1 = f32::from_le_bytes(msg.data[4..8].try_into().unwrap());
        assert!(px1.is_nan());
        let back = depth_from_message(&msg, &depth_metadata(&d), "kinect", 0.5).unwrap();
        assert_eq!(back, d);
        // 16UC1 millimetres, the other ROS convention (0 = invalid).
        let mm = fg::RawImage {
            width: 2,
            height: 1,
            encoding: "16UC1".into(),
            step: 4,
            data: foxglove::bytes::Bytes::from(vec![0xE8, 0x03, 0, 0]),
            ..Default::default()
        };
        let b = depth_from_message(&mm, &depth_metadata(&d), "k", 0.0).unwrap();
        assert_eq!(b.depth, vec![1.0, 0.0]);
        let err = depth_from_message(&mm, &BTreeMap::new(), "k", 0.0).unwrap_err();
        assert!(err.contains("mount_xyz"), "{err}");
    }
}
