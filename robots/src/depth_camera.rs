//! Depth cameras (Kinect-like structured-light sensors): intrinsics, range, the axial noise
//! model and what makes a pixel invalid. A scenario opts in per camera with
//! `[depth_cameras.<name>]` (see `scenarios/src/scenario.rs`); the simulator casts one 3D ray
//! per pixel (`sim/src/depth.rs`) and produces a [`crate::DepthImage`].
//!
//! Source: [004] §2.2 (depth image of size w × h with fields of view
//! f_h, f_v); the noise model σ(z) = 0.0012 + 0.0019 (z − 0.4)² m is the Kinect's measured
//! axial noise (Nguyen, Izadi & Lovell, 3DIMPVT 2012), as the project's ARCHITECTURE.md asks.

use crate::sensors::{check_mounted_sensor, require_all_fields};
use serde::{Deserialize, Serialize};

/// Every field of [`DepthCameraSpec`], as named in TOML.
const FIELDS: [&str; 15] = [
    "name",
    "mount",
    "rate_hz",
    "width",
    "height",
    "fov_h",
    "fov_v",
    "range_min",
    "range_max",
    "decimation",
    "noise_base",
    "noise_quadratic",
    "noise_offset",
    "quantization",
    "max_incidence_deg",
];

const PRESETS: [&str; 1] = ["kinect"];

/// A pinhole depth camera whose optical axis is its mount link's +x (REP-103 body frame).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DepthCameraSpec {
    pub name: String,
    /// URDF link the camera frame is attached to (x forward along the optical axis).
    pub mount: String,
    pub rate_hz: f64,
    /// Sensor resolution in pixels, before decimation.
    pub width: usize,
    pub height: usize,
    /// Full horizontal and vertical fields of view, radians; each below π.
    pub fov_h: f64,
    pub fov_v: f64,
    /// Depths (along the optical axis) outside [range_min, range_max] read 0 (invalid), m.
    pub range_min: f64,
    pub range_max: f64,
    /// Keep every `decimation`-th pixel in both directions (1 = full resolution): the image
    /// is `width / decimation` × `height / decimation` with the same fields of view. Ray
    /// casting cost falls with its square.
    pub decimation: usize,
    /// Axial noise σ(z) = noise_base + noise_quadratic · (z − noise_offset)², m.
    pub noise_base: f64,
    pub noise_quadratic: f64,
    pub noise_offset: f64,
    /// Depth quantization step, m (the OpenNI driver reports whole millimetres); 0 = none.
    pub quantization: f64,
    /// A surface seen at more than this angle between ray and surface normal returns no
    /// depth (the projected pattern is too stretched to match), degrees.
    pub max_incidence_deg: f64,
}

fn type_name(v: &toml::Value) -> &'static str {
    match v {
        toml::Value::String(_) => "a string",
        toml::Value::Integer(_) => "an integer",
        toml::Value::Float(_) => "a float",
        toml::Value::Boolean(_) => "a boolean",
        toml::Value::Datetime(_) => "a date",
        toml::Value::Array(_) => "an array",
        toml::Value::Table(_) => "a table",
    }
}

impl DepthCameraSpec {
    /// Microsoft Kinect (v1)-like: 640 × 480 pixels, 57° × 43°, 0.8–4.5 m, 30 Hz.
    pub fn kinect(name: &str, mount: &str) -> Self {
        Self {
            name: name.into(),
            mount: mount.into(),
            rate_hz: 30.0,
            width: 640,
            height: 480,
            fov_h: 57f64.to_radians(),
            fov_v: 43f64.to_radians(),
            range_min: 0.8,
            range_max: 4.5,
            decimation: 1,
            noise_base: 0.0012,
            noise_quadratic: 0.0019,
            noise_offset: 0.4,
            quantization: 0.001,
            max_incidence_deg: 75.0,
        }
    }

    pub fn preset(preset: &str, name: &str, mount: &str) -> Option<Self> {
        match preset {
            "kinect" => Some(Self::kinect(name, mount)),
            _ => None,
        }
    }

    /// Reads a camera from a TOML table: `preset` plus any field overriding it, or every
    /// field without a preset; `name` and `mount` are always required. `field` (e.g.
    /// `depth_cameras.kinect`) prefixes every error:
    /// `"depth_cameras.kinect.width: must be at least 1 (got 0)"`. Unknown keys are errors.
    pub fn from_table(table: &toml::Table, field: &str) -> Result<DepthCameraSpec, String> {
        if let Some(k) = table
            .keys()
            .find(|k| k.as_str() != "preset" && !FIELDS.contains(&k.as_str()))
        {
            return Err(format!(
                "{field}.{k}: unknown key (expected preset or one of {})",
                FIELDS.join(", ")
            ));
        }
        let string = |key: &str| -> Result<Option<String>, String> {
            match table.get(key) {
                None => Ok(None),
                Some(toml::Value::String(s)) if s.trim().is_empty() => {
                    Err(format!("{field}.{key}: must not be empty"))
                }
                Some(toml::Value::String(s)) => Ok(Some(s.clone())),
                Some(v) => Err(format!(
                    "{field}.{key}: expected a string, got {}",
                    type_name(v)
                )),
            }
        };
        let name = string("name")?.ok_or_else(|| format!("{field}.name: missing"))?;
        let mount = string("mount")?.ok_or_else(|| {
            format!("{field}.mount: missing (the URDF link the camera frame is attached to)")
        })?;
        let mut spec = match string("preset")? {
            Some(p) => Self::preset(&p, &name, &mount).ok_or_else(|| {
                format!(
                    "{field}.preset: unknown preset {p:?} (known: {})",
                    PRESETS.join(", ")
                )
            })?,
            None => {
                require_all_fields(table, &FIELDS, field, &PRESETS)?;
                Self::kinect(&name, &mount)
            }
        };
        for (key, slot) in [
            ("width", &mut spec.width),
            ("height", &mut spec.height),
            ("decimation", &mut spec.decimation),
        ] {
            match table.get(key) {
                None => {}
                Some(toml::Value::Integer(i)) if *i < 0 => {
                    return Err(format!("{field}.{key}: must be at least 1 (got {i})"))
                }
                Some(toml::Value::Integer(i)) => *slot = *i as usize,
                Some(v) => {
                    return Err(format!(
                        "{field}.{key}: expected an integer, got {}",
                        type_name(v)
                    ))
                }
            }
        }
        for (key, slot) in [
            ("rate_hz", &mut spec.rate_hz),
            ("fov_h", &mut spec.fov_h),
            ("fov_v", &mut spec.fov_v),
            ("range_min", &mut spec.range_min),
            ("range_max", &mut spec.range_max),
            ("noise_base", &mut spec.noise_base),
            ("noise_quadratic", &mut spec.noise_quadratic),
            ("noise_offset", &mut spec.noise_offset),
            ("quantization", &mut spec.quantization),
            ("max_incidence_deg", &mut spec.max_incidence_deg),
        ] {
            match table.get(key) {
                None => {}
                Some(toml::Value::Float(f)) => *slot = *f,
                Some(toml::Value::Integer(i)) => *slot = *i as f64,
                Some(v) => {
                    return Err(format!(
                        "{field}.{key}: expected a number, got {}",
                        type_name(v)
                    ))
                }
            }
        }
        spec.validate().map_err(|msg| format!("{field}.{msg}"))?;
        Ok(spec)
    }

    /// Checks every field; the error starts with the field's name, e.g.
    /// `"fov_h: must be in (0°, 180°) (got 180°)"`.
    pub fn validate(&self) -> Result<(), String> {
        check_mounted_sensor(
            &self.name,
            &self.mount,
            self.rate_hz,
            &[
                ("rate_hz", self.rate_hz),
                ("fov_h", self.fov_h),
                ("fov_v", self.fov_v),
                ("range_min", self.range_min),
                ("range_max", self.range_max),
                ("noise_base", self.noise_base),
                ("noise_quadratic", self.noise_quadratic),
                ("noise_offset", self.noise_offset),
                ("quantization", self.quantization),
                ("max_incidence_deg", self.max_incidence_deg),
            ],
        )?;
        if self.width == 0 {
            return Err("width: must be at least 1 pixel (got 0)".into());
        }
        if self.height == 0 {
            return Err("height: must be at least 1 pixel (got 0)".into());
        }
        crate::sensors::check_image_size("width", self.width, self.height)?;
        if self.decimation == 0 {
            return Err("decimation: must be at least 1 (got 0)".into());
        }
        if self.decimation > self.width.min(self.height) {
            return Err(format!(
                "decimation: {} leaves no pixel of a {} × {} image",
                self.decimation, self.width, self.height
            ));
        }
        // A pinhole camera cannot see 180° or more: tan(fov / 2) is infinite.
        for (name, fov) in [("fov_h", self.fov_h), ("fov_v", self.fov_v)] {
            if !(fov > 0.0 && fov < std::f64::consts::PI) {
                return Err(format!(
                    "{name}: must be in (0°, 180°) for a pinhole camera (got {:.1}°)",
                    fov.to_degrees()
                ));
            }
        }
        if self.range_min < 0.0 {
            return Err(format!("range_min: must be >= 0 (got {})", self.range_min));
        }
        if self.range_max <= self.range_min {
            return Err(format!(
                "range_max: must be greater than range_min = {} (got {})",
                self.range_min, self.range_max
            ));
        }
        for (name, v) in [
            ("noise_base", self.noise_base),
            ("noise_quadratic", self.noise_quadratic),
            ("quantization", self.quantization),
        ] {
            if v < 0.0 {
                return Err(format!("{name}: must be >= 0 (got {v})"));
            }
        }
        if !(self.max_incidence_deg > 0.0 && self.max_incidence_deg <= 90.0) {
            return Err(format!(
                "max_incidence_deg: must be in (0, 90] (got {})",
                self.max_incidence_deg
            ));
        }
        Ok(())
    }

    /// Width of the produced image (after decimation), pixels.
    pub fn image_width(&self) -> usize {
        self.width / self.decimation.max(1)
    }

    /// Height of the produced image (after decimation), pixels.
    pub fn image_height(&self) -> usize {
        self.height / self.decimation.max(1)
    }

    /// Pinhole intrinsics (fx, fy, cx, cy) of the produced image: the fields of view span the
    /// outer edges of the first and last pixels.
    pub fn intrinsics(&self) -> (f64, f64, f64, f64) {
        let (w, h) = (self.image_width() as f64, self.image_height() as f64);
        let fx = 0.5 * w / (0.5 * self.fov_h).tan();
        let fy = 0.5 * h / (0.5 * self.fov_v).tan();
        (fx, fy, 0.5 * (w - 1.0), 0.5 * (h - 1.0))
    }

    /// Axial noise standard deviation at depth `z`, m.
    pub fn sigma(&self, z: f64) -> f64 {
        let d = z - self.noise_offset;
        self.noise_base + self.noise_quadratic * d * d
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> toml::Table {
        text.parse().unwrap()
    }

    #[test]
    fn kinect_preset_and_intrinsics() {
        let k = DepthCameraSpec::kinect("k", "camera");
        k.validate().unwrap();
        assert_eq!((k.image_width(), k.image_height()), (640, 480));
        let (fx, fy, cx, cy) = k.intrinsics();
        // 320 / tan(28.5°) = 589.4; 240 / tan(21.5°) = 609.3.
        assert!((fx - 589.37).abs() < 0.05, "{fx}");
        assert!((fy - 609.28).abs() < 0.05, "{fy}");
        assert_eq!((cx, cy), (319.5, 239.5));
        // σ(0.4) = 1.2 mm, σ(4.4) = 0.0012 + 0.0019 · 16 = 0.0316.
        assert!((k.sigma(0.4) - 0.0012).abs() < 1e-12);
        assert!((k.sigma(4.4) - 0.0316).abs() < 1e-12);
        let mut d = k.clone();
        d.decimation = 4;
        assert_eq!((d.image_width(), d.image_height()), (160, 120));
        assert!((d.intrinsics().0 - fx / 4.0).abs() < 1e-9);
    }

    #[test]
    fn tables_override_the_preset_and_bad_values_are_named() {
        let spec = DepthCameraSpec::from_table(
            &table("preset = \"kinect\"\nname = \"k\"\nmount = \"camera\"\ndecimation = 4"),
            "depth_cameras.k",
        )
        .unwrap();
        assert_eq!(spec.decimation, 4);
        let err = |text: &str| {
            DepthCameraSpec::from_table(
                &table(&format!(
                    "preset = \"kinect\"\nname = \"k\"\nmount = \"camera\"\n{text}"
                )),
                "depth_cameras.k",
            )
            .unwrap_err()
        };
        assert_eq!(
            err("width = 0"),
            "depth_cameras.k.width: must be at least 1 pixel (got 0)"
        );
        assert_eq!(
            err("height = 0"),
            "depth_cameras.k.height: must be at least 1 pixel (got 0)"
        );
        assert_eq!(
            err("fov_h = 3.141592653589793"),
            "depth_cameras.k.fov_h: must be in (0°, 180°) for a pinhole camera (got 180.0°)"
        );
        assert!(err("fov_v = 4.0").starts_with("depth_cameras.k.fov_v: must be in (0°, 180°)"));
        assert!(err("range_max = 0.5").starts_with("depth_cameras.k.range_max"));
        assert!(err("decimation = 0").starts_with("depth_cameras.k.decimation"));
        assert!(err("colour = 1").starts_with("depth_cameras.k.colour: unknown key"));
        assert!(err("width = \"wide\"").contains("expected an integer"));
        let e = DepthCameraSpec::from_table(
            &table("name = \"k\"\nmount = \"camera\""),
            "depth_cameras.k",
        )
        .unwrap_err();
        assert!(e.contains("no preset given") && e.contains("width"), "{e}");
    }
}
