//! Cameras of a scenario: `[sensors.<name>]` tables with `kind = "camera"` (an intensity
//! camera), `kind = "stereo"` (a stereo rig: its left image and its disparity map),
//! `kind = "ceiling"` (an upward camera, [001]) or `kind = "omni"` (a panoramic camera,
//! [001]), and the top-level `lighting = "tube" | "bulb" | "natural"` they see (default
//! `tube`). A `[sensors.<name>]` table without `kind` is a laser; any other kind is an error.
//!
//! ```toml
//! lighting = "bulb"
//!
//! [sensors.front]
//! kind = "camera"
//! width = 160            # pixels (default 160 × 120)
//! height = 120
//! fov_deg = 60           # horizontal field of view (default 60°)
//! rate_hz = 2            # frames per second (default 2)
//! xyz = [0.1, 0.0, 1.0]  # camera frame in the robot's base frame, m (optical axis = +x)
//! rpy = [0.0, 0.0, 0.0]  # rad
//! gain = 1.0
//! noise_sigma = 0.01     # per pixel, [0, 1] scale
//! max_range = 30.0       # m
//!
//! [sensors.stereo]
//! kind = "stereo"        # every camera key above, plus:
//! baseline = 0.09        # m; the right camera sits this far to the left one's right
//! max_disparity = 32     # pixels searched
//! window_radius = 3      # SAD windows are (2r + 1)²
//! texture_threshold = 0.015
//! uniqueness = 0.9
//! lr_tolerance = 1.0
//!
//! [sensors.ceiling]
//! kind = "ceiling"       # a size × size image straight up; its mean is the brightness
//! size = 9               # pixels per side (default 9)
//! fov_deg = 40           # (default 40°)
//! z = 0.5                # lens height above the floor on the robot's axis, m (default 0.5)
//! rate_hz = 2
//! gain = 1.0
//! noise_sigma = 0.01     # per pixel
//!
//! [sensors.omni]
//! kind = "omni"          # a panorama: width columns over 360°, height rows over ±30°
//! width = 64             # (default 64; a multiple of an omni localizer's rotations)
//! height = 16            # (default 16)
//! z = 1.0                # mirror height above the floor on the robot's axis, m (default 1.0)
//! rate_hz = 2
//! gain = 1.0
//! noise_sigma = 0.01
//! ```
//!
//! Defaults are the paper's camera (`CameraSpec::paper`, `StereoSpec::paper`) and
//! `CeilingSensorSpec::new`, `OmniSensorSpec::new`.

use crate::error::ScenarioError;
use atrium_sim::camera::CameraSpec;
use atrium_sim::camera_stream::{
    CameraSensorSpec, CameraSensors, CeilingSensorSpec, OmniSensorSpec, StereoSensorSpec,
};
use atrium_sim::stereo::StereoSpec;
use atrium_worlds::lighting::LightingCondition;
use serde::Deserialize;
use std::path::Path;

/// The sensor kinds a `[sensors.<name>]` table may name.
pub const KINDS: [&str; 4] = ["camera", "stereo", "ceiling", "omni"];

/// Whether a `[sensors.<name>]` table belongs here: it has a `kind` (lasers have none), so
/// an unknown kind is reported by [`parse`] rather than as a stray laser key.
pub fn is_camera(table: &toml::Table) -> bool {
    table.contains_key("kind")
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CeilingTable {
    #[allow(dead_code)] // read through the generic table
    kind: String,
    size: Option<usize>,
    fov_deg: Option<f64>,
    z: Option<f64>,
    rate_hz: Option<f64>,
    gain: Option<f64>,
    noise_sigma: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct OmniTable {
    #[allow(dead_code)] // read through the generic table
    kind: String,
    width: Option<usize>,
    height: Option<usize>,
    z: Option<f64>,
    rate_hz: Option<f64>,
    gain: Option<f64>,
    noise_sigma: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraTable {
    kind: String,
    width: Option<usize>,
    height: Option<usize>,
    fov_deg: Option<f64>,
    rate_hz: Option<f64>,
    xyz: Option<[f64; 3]>,
    rpy: Option<[f64; 3]>,
    gain: Option<f64>,
    noise_sigma: Option<f64>,
    max_range: Option<f64>,
    baseline: Option<f64>,
    max_disparity: Option<usize>,
    window_radius: Option<usize>,
    texture_threshold: Option<f32>,
    uniqueness: Option<f32>,
    lr_tolerance: Option<f32>,
}

/// Default frame rate of scenario cameras, Hz.
pub const DEFAULT_RATE_HZ: f64 = 2.0;

/// Parses the `lighting` key and the camera tables (`(name, table)` in file order) of
/// `file`; errors name the file and the field.
pub fn parse(
    file: &Path,
    lighting: Option<&str>,
    tables: &[(String, toml::Table)],
) -> Result<CameraSensors, ScenarioError> {
    let mut out = CameraSensors::default();
    if let Some(l) = lighting {
        out.lighting = LightingCondition::parse(l).ok_or_else(|| {
            ScenarioError::field(
                file,
                "lighting",
                format!("unknown lighting condition {l:?} (expected tube, bulb or natural)"),
            )
        })?;
    }
    // Errors from the specs' own checks name `<field>.<key>`; split that off.
    let sim_err = |field: &str, e: atrium_sim::SimError| match e {
        atrium_sim::SimError::Config { field: f, msg } => ScenarioError::field(file, f, msg),
        other => ScenarioError::field(file, field, other.to_string()),
    };
    for (name, table) in tables {
        let field = format!("sensors.{name}");
        let kind = match table.get("kind").map(|k| k.as_str()) {
            Some(Some(k)) if KINDS.contains(&k) => k,
            Some(k) => {
                return Err(ScenarioError::field(
                    file,
                    format!("{field}.kind"),
                    format!(
                        "unknown sensor kind {} (known: camera, stereo, ceiling, omni; a laser table has no kind)",
                        k.map(|k| format!("{k:?}"))
                            .unwrap_or_else(|| table["kind"].to_string())
                    ),
                ))
            }
            None => continue,
        };
        let de = |e: toml::de::Error| ScenarioError::field(file, &field, e.message());
        if kind == "ceiling" {
            let t: CeilingTable = toml::Value::Table(table.clone()).try_into().map_err(de)?;
            let mut c = CeilingSensorSpec::new(name);
            c.size = t.size.unwrap_or(c.size);
            c.fov = t.fov_deg.map(f64::to_radians).unwrap_or(c.fov);
            c.z = t.z.unwrap_or(c.z);
            c.rate_hz = t.rate_hz.unwrap_or(DEFAULT_RATE_HZ);
            c.gain = t.gain.unwrap_or(c.gain);
            c.noise_sigma = t.noise_sigma.unwrap_or(c.noise_sigma);
            c.validate(&field).map_err(|e| sim_err(&field, e))?;
            out.ceiling.push(c);
            continue;
        }
        if kind == "omni" {
            let t: OmniTable = toml::Value::Table(table.clone()).try_into().map_err(de)?;
            let mut c = OmniSensorSpec::new(name);
            c.width = t.width.unwrap_or(c.width);
            c.height = t.height.unwrap_or(c.height);
            c.z = t.z.unwrap_or(c.z);
            c.rate_hz = t.rate_hz.unwrap_or(DEFAULT_RATE_HZ);
            c.gain = t.gain.unwrap_or(c.gain);
            c.noise_sigma = t.noise_sigma.unwrap_or(c.noise_sigma);
            c.validate(&field).map_err(|e| sim_err(&field, e))?;
            out.omni.push(c);
            continue;
        }
        let t: CameraTable = toml::Value::Table(table.clone()).try_into().map_err(de)?;
        let stereo = t.kind == "stereo";
        let mut camera = CameraSpec::paper(name);
        if let Some(v) = t.width {
            camera.width = v;
        }
        if let Some(v) = t.height {
            camera.height = v;
        }
        if let Some(v) = t.fov_deg {
            camera.hfov = v.to_radians();
        }
        if let Some(v) = t.xyz {
            camera.mount.xyz = v;
        }
        if let Some(v) = t.rpy {
            camera.mount.rpy = v;
        }
        if let Some(v) = t.gain {
            camera.gain = v;
        }
        if let Some(v) = t.noise_sigma {
            camera.noise_sigma = v;
        }
        if let Some(v) = t.max_range {
            camera.max_range = v;
        }
        // Checked before any image buffer is sized from it.
        if let Err(m) =
            atrium_robots::sensors::check_image_size("width", camera.width, camera.height)
        {
            let (key, why) = m.split_once(": ").unwrap_or(("width", &m));
            return Err(ScenarioError::field(file, format!("{field}.{key}"), why));
        }
        let rate_hz = t.rate_hz.unwrap_or(DEFAULT_RATE_HZ);
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(ScenarioError::field(
                file,
                format!("{field}.rate_hz"),
                format!("must be finite and > 0, got {rate_hz}"),
            ));
        }
        let sim_err = |e| sim_err(&field, e);
        if stereo {
            let mut s = StereoSpec::paper(name);
            s.camera = camera;
            if let Some(v) = t.baseline {
                s.baseline = v;
            }
            if let Some(v) = t.max_disparity {
                s.max_disparity = v;
            }
            if let Some(v) = t.window_radius {
                s.window_radius = v;
            }
            if let Some(v) = t.texture_threshold {
                s.texture_threshold = v;
            }
            if let Some(v) = t.uniqueness {
                s.uniqueness = v;
            }
            if let Some(v) = t.lr_tolerance {
                s.lr_tolerance = v;
            }
            s.validate(&field).map_err(sim_err)?;
            out.stereo.push(StereoSensorSpec { stereo: s, rate_hz });
        } else {
            let only_stereo = [
                ("baseline", t.baseline.is_some()),
                ("max_disparity", t.max_disparity.is_some()),
                ("window_radius", t.window_radius.is_some()),
                ("texture_threshold", t.texture_threshold.is_some()),
                ("uniqueness", t.uniqueness.is_some()),
                ("lr_tolerance", t.lr_tolerance.is_some()),
            ];
            if let Some((k, _)) = only_stereo.iter().find(|(_, set)| *set) {
                return Err(ScenarioError::field(
                    file,
                    format!("{field}.{k}"),
                    "only a stereo rig (kind = \"stereo\") has this key",
                ));
            }
            camera.validate(&field).map_err(sim_err)?;
            out.cameras.push(CameraSensorSpec { camera, rate_hz });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tables(text: &str) -> Vec<(String, toml::Table)> {
        let t: toml::Table = toml::from_str(text).unwrap();
        t.into_iter()
            .map(|(k, v)| (k, v.as_table().unwrap().clone()))
            .collect()
    }

    #[test]
    fn cameras_and_rigs_parse_with_paper_defaults() {
        let f = Path::new("s.toml");
        let t = tables(
            "[front]\nkind = \"camera\"\nwidth = 80\nheight = 60\nrate_hz = 5\n\
             [rig]\nkind = \"stereo\"\nbaseline = 0.12\n",
        );
        assert!(is_camera(&t[0].1) && is_camera(&t[1].1));
        let c = parse(f, Some("natural"), &t).unwrap();
        assert_eq!(c.lighting, LightingCondition::Natural);
        assert_eq!(c.cameras.len(), 1);
        assert_eq!(c.cameras[0].camera.width, 80);
        assert_eq!(c.cameras[0].rate_hz, 5.0);
        assert_eq!(c.stereo[0].stereo.baseline, 0.12);
        assert_eq!(c.stereo[0].stereo.camera.width, 160);
        assert_eq!(c.stereo[0].rate_hz, DEFAULT_RATE_HZ);
        assert_eq!(
            parse(f, None, &[]).unwrap().lighting,
            LightingCondition::Tube
        );
    }

    #[test]
    fn bad_camera_tables_name_the_field() {
        let f = Path::new("s.toml");
        let err = |lighting: Option<&str>, text: &str| {
            parse(f, lighting, &tables(text)).unwrap_err().to_string()
        };
        assert!(err(Some("disco"), "").contains("lighting"));
        let e = err(None, "[c]\nkind = \"camera\"\nwidth = 0\n");
        assert!(e.contains("sensors.c.width"), "{e}");
        let e = err(None, "[c]\nkind = \"camera\"\nbaseline = 0.1\n");
        assert!(e.contains("sensors.c.baseline"), "{e}");
        let e = err(None, "[c]\nkind = \"camera\"\nzoom = 2\n");
        assert!(e.contains("sensors.c") && e.contains("zoom"), "{e}");
        let e = err(None, "[c]\nkind = \"stereo\"\nuniqueness = 2.0\n");
        assert!(e.contains("sensors.c.uniqueness"), "{e}");
        let e = err(None, "[c]\nkind = \"camera\"\nrate_hz = -1\n");
        assert!(e.contains("sensors.c.rate_hz"), "{e}");
        let e = err(None, "[c]\nkind = \"lidar\"\n");
        assert!(
            e.contains("sensors.c.kind") && e.contains("unknown sensor kind \"lidar\""),
            "{e}"
        );
        let e = err(None, "[c]\nkind = 3\n");
        assert!(e.contains("sensors.c.kind"), "{e}");
        let e = err(None, "[c]\nkind = \"ceiling\"\nwidth = 9\n");
        assert!(e.contains("sensors.c") && e.contains("width"), "{e}");
        let e = err(None, "[c]\nkind = \"ceiling\"\nsize = 0\n");
        assert!(e.contains("sensors.c.size"), "{e}");
        let e = err(None, "[c]\nkind = \"omni\"\nwidth = 1\n");
        assert!(e.contains("sensors.c.width"), "{e}");
        let e = err(None, "[c]\nkind = \"omni\"\nz = 0\n");
        assert!(e.contains("sensors.c.z"), "{e}");
        let e = err(None, "[c]\nkind = \"omni\"\nrate_hz = 0\n");
        assert!(e.contains("sensors.c.rate_hz"), "{e}");
    }

    #[test]
    fn ceiling_and_omni_cameras_parse() {
        let f = Path::new("s.toml");
        let t = tables(
            "[up]\nkind = \"ceiling\"\nsize = 5\nz = 0.4\n\
             [pano]\nkind = \"omni\"\nwidth = 96\nrate_hz = 4\n",
        );
        let c = parse(f, Some("bulb"), &t).unwrap();
        assert_eq!(c.ceiling.len(), 1);
        assert_eq!((c.ceiling[0].size, c.ceiling[0].z), (5, 0.4));
        assert_eq!(c.ceiling[0].name, "up");
        assert_eq!(c.ceiling[0].rate_hz, DEFAULT_RATE_HZ);
        assert_eq!((c.omni[0].width, c.omni[0].height), (96, 16));
        assert_eq!(c.omni[0].rate_hz, 4.0);
        assert!(c.cameras.is_empty() && c.stereo.is_empty());
    }
}
