//! Camera images in recordings (issue 8): intensity as `foxglove.RawImage` `mono8` on
//! `/image/<camera>` and stereo disparity as `foxglove.RawImage` `32FC1` (pixels, NaN =
//! missing) on `/disparity/<rig>`, with the intrinsics (and the baseline) in the channel
//! metadata, read back into the same readings.
//!
//! Every `/image/<camera>` channel carries `fx`, `fy`, `cx`, `cy`, `mount_xyz`, `mount_rpy`
//! and `projection`:
//! - `projection = "pinhole"` (intensity cameras, stereo left images, the upward ceiling
//!   camera of [001]): pixel (u, v) looks along (1, −(u − cx)/fx, −(v − cy)/fy) in the
//!   mount frame (x forward / the optical axis, y left, z up). A ceiling camera's mount has
//!   `rpy = [0, −π/2, 0]`: its optical axis points straight up.
//! - `projection = "cylindrical"` (the panoramic omni camera of [001]): column u looks at
//!   azimuth (u − cx) / fx counter-clockwise from the mount's +x (the robot's heading), row v
//!   at elevation (cy − v) / fy. A panorama is recognised by `cx = 0` and
//!   `fx = width / 2π` (its `width` columns span exactly 360°, so turning the robot by
//!   2π k / width shifts the columns by k); `fy` is pixels per radian of elevation and `cy`
//!   the row at elevation 0 (the simulator's panoramas span ±30°: `fy = (height − 1) / (π/3)`,
//!   `cy = (height − 1) / 2`).
//!
//! The readings themselves carry only the four numbers (`IntensityImage` has no projection
//! field): `projection` is for readers of the file, and is derived from them when recording.

use super::foxglove::{image_fits, timestamp};
use atrium_robots::{DisparityImage, IntensityImage, Mount3};
use foxglove::messages as fg;
use std::collections::BTreeMap;

pub const INTENSITY_ENCODING: &str = "mono8";
pub const DISPARITY_ENCODING: &str = "32FC1";

fn f(v: f64) -> String {
    format!("{v}")
}

fn parse_meta_f64(meta: &BTreeMap<String, String>, key: &str) -> Option<f64> {
    meta.get(key)?.parse().ok().filter(|v: &f64| v.is_finite())
}

fn triple_meta(meta: &BTreeMap<String, String>, key: &str) -> Option<[f64; 3]> {
    let v: Vec<f64> = meta
        .get(key)?
        .split(',')
        .map(|s| s.parse().ok())
        .collect::<Option<_>>()?;
    (v.len() == 3).then(|| [v[0], v[1], v[2]])
}

/// The sensor name and its mount (`mount_xyz`, `mount_rpy` as `x,y,z`), as for depth images.
fn mount_metadata(sensor: &str, m: &Mount3) -> BTreeMap<String, String> {
    let t = |v: [f64; 3]| format!("{},{},{}", f(v[0]), f(v[1]), f(v[2]));
    BTreeMap::from([
        ("sensor".into(), sensor.to_string()),
        ("mount_xyz".into(), t(m.xyz)),
        ("mount_rpy".into(), t(m.rpy)),
    ])
}

/// Whether an image's intrinsics are those of a 360° panorama (`cx = 0`, `fx = width / 2π`);
/// a pinhole image has its principal point in the middle, never at column 0.
pub fn is_panorama(i: &IntensityImage) -> bool {
    let w = i.width as f64;
    i.cx == 0.0 && (i.fx * std::f64::consts::TAU - w).abs() <= 1e-9 * w
}

pub fn intensity_metadata(i: &IntensityImage) -> BTreeMap<String, String> {
    let mut m = mount_metadata(&i.sensor, &i.mount);
    let projection = if is_panorama(i) {
        "cylindrical"
    } else {
        "pinhole"
    };
    m.insert("projection".into(), projection.into());
    m.insert("unit".into(), "grey level /255 (mono8)".into());
    m.insert("fx".into(), f(i.fx));
    m.insert("fy".into(), f(i.fy));
    m.insert("cx".into(), f(i.cx));
    m.insert("cy".into(), f(i.cy));
    m
}

pub fn disparity_metadata(d: &DisparityImage) -> BTreeMap<String, String> {
    BTreeMap::from([
        ("sensor".into(), d.sensor.clone()),
        ("unit".into(), "pixels (32FC1, NaN = missing)".into()),
        ("fx".into(), f(d.fx)),
        ("baseline".into(), f(d.baseline)),
    ])
}

fn finish(msg: &mut fg::RawImage, data: &mut Vec<u8>, ns: u64, frame: &str, w: usize, h: usize) {
    msg.timestamp = Some(timestamp(ns));
    if msg.frame_id != frame {
        msg.frame_id = frame.to_string();
    }
    msg.width = w as u32;
    msg.height = h as u32;
    // `Bytes` takes the buffer; the caller takes it back after encoding.
    msg.data = foxglove::bytes::Bytes::from(std::mem::take(data));
}

/// Fills `msg` from an intensity image: pixel values in [0, 1] to bytes (the simulator
/// quantises to k/255, so this is exact).
pub fn fill_intensity(
    msg: &mut fg::RawImage,
    data: &mut Vec<u8>,
    ns: u64,
    frame: &str,
    i: &IntensityImage,
) {
    data.clear();
    data.extend(
        i.pixels
            .iter()
            .map(|p| (p.clamp(0.0, 1.0) * 255.0).round() as u8),
    );
    msg.encoding = INTENSITY_ENCODING.to_string();
    msg.step = i.width as u32;
    finish(msg, data, ns, frame, i.width, i.height);
}

/// Fills `msg` from a disparity map (NaN stays NaN: missing).
pub fn fill_disparity(
    msg: &mut fg::RawImage,
    data: &mut Vec<u8>,
    ns: u64,
    frame: &str,
    d: &DisparityImage,
) {
    data.clear();
    data.reserve(d.disparity.len() * 4);
    for v in &d.disparity {
        data.extend_from_slice(&v.to_le_bytes());
    }
    msg.encoding = DISPARITY_ENCODING.to_string();
    msg.step = (d.width * 4) as u32;
    finish(msg, data, ns, frame, d.width, d.height);
}

fn rows<'a>(msg: &'a fg::RawImage, bpp: usize, what: &str) -> Result<Vec<&'a [u8]>, String> {
    let (w, h) = (msg.width as usize, msg.height as usize);
    let step = msg.step as usize;
    if !image_fits(w, h, step, bpp, msg.data.len()) {
        return Err(format!(
            "{what}: {w}x{h} image of {} bytes with step {step} is empty or too short",
            msg.data.len()
        ));
    }
    Ok((0..h)
        .map(|v| &msg.data[v * step..v * step + w * bpp])
        .collect())
}

/// An intensity reading from a `mono8` `foxglove.RawImage` and its channel metadata.
pub fn intensity_from_message(
    msg: &fg::RawImage,
    meta: &BTreeMap<String, String>,
    topic_sensor: &str,
    stamp: f64,
) -> Result<IntensityImage, String> {
    if msg.encoding != INTENSITY_ENCODING {
        return Err(format!(
            "intensity encoding {:?} (expected mono8)",
            msg.encoding
        ));
    }
    // After `rows` has checked that the pixels are there: the size is the file's to claim.
    let rows = rows(msg, 1, "intensity")?;
    let mut pixels = Vec::with_capacity(msg.width as usize * msg.height as usize);
    for row in rows {
        pixels.extend(row.iter().map(|&b| b as f32 / 255.0));
    }
    let need =
        |k: &str| parse_meta_f64(meta, k).ok_or_else(|| format!("channel metadata lacks {k:?}"));
    Ok(IntensityImage {
        stamp,
        sensor: meta
            .get("sensor")
            .cloned()
            .unwrap_or_else(|| topic_sensor.to_string()),
        mount: Mount3 {
            xyz: triple_meta(meta, "mount_xyz").ok_or("channel metadata lacks \"mount_xyz\"")?,
            rpy: triple_meta(meta, "mount_rpy").ok_or("channel metadata lacks \"mount_rpy\"")?,
        },
        width: msg.width as usize,
        height: msg.height as usize,
        fx: need("fx")?,
        fy: need("fy")?,
        cx: need("cx")?,
        cy: need("cy")?,
        pixels,
    })
}

/// A disparity reading from a `32FC1` `foxglove.RawImage` and its channel metadata.
pub fn disparity_from_message(
    msg: &fg::RawImage,
    meta: &BTreeMap<String, String>,
    topic_sensor: &str,
    stamp: f64,
) -> Result<DisparityImage, String> {
    if msg.encoding != DISPARITY_ENCODING {
        return Err(format!(
            "disparity encoding {:?} (expected 32FC1)",
            msg.encoding
        ));
    }
    let rows = rows(msg, 4, "disparity")?;
    let mut disparity = Vec::with_capacity(msg.width as usize * msg.height as usize);
    for row in rows {
        disparity.extend(
            row.chunks_exact(4)
                .map(|p| f32::from_le_bytes([p[0], p[1], p[2], p[3]])),
        );
    }
    let need =
        |k: &str| parse_meta_f64(meta, k).ok_or_else(|| format!("channel metadata lacks {k:?}"));
    Ok(DisparityImage {
        stamp,
        sensor: meta
            .get("sensor")
            .cloned()
            .unwrap_or_else(|| topic_sensor.to_string()),
        width: msg.width as usize,
        height: msg.height as usize,
        fx: need("fx")?,
        baseline: need("baseline")?,
        disparity,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn images_round_trip_exactly() {
        let i = IntensityImage {
            stamp: 1.5,
            sensor: "stereo".into(),
            mount: Mount3 {
                xyz: [0.1, 0.0, 1.0],
                rpy: [0.0, 0.1, 0.0],
            },
            width: 3,
            height: 2,
            fx: 138.5,
            fy: 138.5,
            cx: 1.0,
            cy: 0.5,
            pixels: [0u8, 1, 77, 128, 254, 255]
                .map(|k| k as f32 / 255.0)
                .to_vec(),
        };
        let mut msg = fg::RawImage::default();
        let mut buf = Vec::new();
        fill_intensity(&mut msg, &mut buf, 1_500_000_000, "stereo", &i);
        let meta = intensity_metadata(&i);
        assert_eq!(meta["projection"], "pinhole");
        let back = intensity_from_message(&msg, &meta, "x", 1.5).unwrap();
        assert_eq!(back, i);
        // A panorama ([001]'s omnicam): its intrinsics survive and name the cylinder.
        let pano = IntensityImage {
            sensor: "omni".into(),
            width: 8,
            height: 3,
            fx: 8.0 / std::f64::consts::TAU,
            fy: 2.0 / (std::f64::consts::PI / 3.0),
            cx: 0.0,
            cy: 1.0,
            pixels: (0..24).map(|k| (k * 10) as f32 / 255.0).collect(),
            ..i.clone()
        };
        let meta = intensity_metadata(&pano);
        assert_eq!(meta["projection"], "cylindrical");
        fill_intensity(&mut msg, &mut buf, 0, "omni", &pano);
        assert_eq!(
            (msg.width, msg.height, msg.step, msg.data.len()),
            (8, 3, 8, 24)
        );
        let back = intensity_from_message(&msg, &meta, "x", 1.5).unwrap();
        assert_eq!(back, pano);
        let d = DisparityImage {
            stamp: 1.5,
            sensor: "stereo".into(),
            width: 2,
            height: 2,
            fx: 138.5,
            baseline: 0.09,
            disparity: vec![f32::NAN, 3.25, 0.0, 31.5],
        };
        let mut msg = fg::RawImage::default();
        fill_disparity(&mut msg, &mut buf, 0, "stereo", &d);
        let back = disparity_from_message(&msg, &disparity_metadata(&d), "x", 1.5).unwrap();
        assert!(back.disparity[0].is_nan());
        assert_eq!(back.disparity[1..], d.disparity[1..]);
        assert_eq!(back.baseline, 0.09);
        // Wrong encodings and short buffers are refused with a message.
        let e = intensity_from_message(&msg, &BTreeMap::new(), "x", 0.0).unwrap_err();
        assert!(e.contains("mono8"), "{e}");
        msg.data = foxglove::bytes::Bytes::from(vec![0u8; 3]);
        let e = disparity_from_message(&msg, &disparity_metadata(&d), "x", 0.0).unwrap_err();
        assert!(e.contains("too short"), "{e}");
    }
}
