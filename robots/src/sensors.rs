//! Sensor specifications: what a sensor is, where it is mounted and how it errs. A robot's
//! sensor file (`<robot>.sensors.toml` beside its URDF) lists them; a scenario may override.

use crate::error::RobotError;
use crate::model::RobotModel;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Every field of [`LaserSpec`], as named in TOML.
const LASER_FIELDS: [&str; 13] = [
    "name",
    "mount",
    "rate_hz",
    "beams",
    "fov",
    "range_min",
    "range_max",
    "sigma_hit",
    "sigma_hit_per_m",
    "p_short",
    "lambda_short",
    "p_max",
    "p_rand",
];

/// Fields of [`LaserSpec`] a table without a preset may still leave out: they came after
/// sensor files were written that give every other field, and their defaults keep those
/// files' lasers as they were.
const LASER_OPTIONAL_FIELDS: [&str; 1] = ["sigma_hit_per_m"];

/// Every field of [`OdometrySpec`], as named in TOML.
const ODOMETRY_FIELDS: [&str; 7] = [
    "ticks_per_rev",
    "radius_error",
    "separation_error",
    "slip_sigma",
    "slip_correlation_m",
    "scale_error",
    "rate_hz",
];

const PRESETS: [&str; 2] = ["sick_lms200", "hokuyo_urg04lx"];

/// Beams of a laser: real ones have at most a few thousand (the Hokuyo URG-04LX 683, the SICK
/// LMS200 181), so 100,000 is generous; every beam is a ray cast per scan and a range kept.
pub const MAX_LASER_BEAMS: usize = 100_000;

/// Pixels of one camera image (width × height after decimation): a Kinect has 307,200, so
/// 16 million is generous; every pixel is a ray cast per frame and an f32 kept. Sensor tables
/// check their sizes with [`check_image_size`].
pub const MAX_IMAGE_PIXELS: u64 = 16_000_000;

/// Checks an image size against [`MAX_IMAGE_PIXELS`] (the product in u128, so it cannot
/// overflow); the message starts with `field` (e.g. `width`).
pub fn check_image_size(field: &str, width: usize, height: usize) -> Result<(), String> {
    let pixels = width as u128 * height as u128;
    if pixels > MAX_IMAGE_PIXELS as u128 {
        return Err(format!(
            "{field}: a {width} × {height} image is {pixels} pixels, more than the limit of \
             {MAX_IMAGE_PIXELS} (MAX_IMAGE_PIXELS)"
        ));
    }
    Ok(())
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

/// A number field; TOML integers are accepted because `rate_hz = 10` is natural to write.
fn number(table: &toml::Table, key: &str, field: &str) -> Result<Option<f64>, String> {
    match table.get(key) {
        None => Ok(None),
        Some(toml::Value::Float(f)) => Ok(Some(*f)),
        Some(toml::Value::Integer(i)) => Ok(Some(*i as f64)),
        Some(v) => Err(format!(
            "{field}.{key}: expected a number, got {}",
            type_name(v)
        )),
    }
}

/// An integer field that must be at least 1 and fit `T`.
fn count<T: TryFrom<i64>>(
    table: &toml::Table,
    key: &str,
    field: &str,
) -> Result<Option<T>, String> {
    match table.get(key) {
        None => Ok(None),
        Some(toml::Value::Integer(i)) if *i < 1 => {
            Err(format!("{field}.{key}: must be at least 1 (got {i})"))
        }
        Some(toml::Value::Integer(i)) => T::try_from(*i)
            .map(Some)
            .map_err(|_| format!("{field}.{key}: {i} is too large")),
        Some(v) => Err(format!(
            "{field}.{key}: expected an integer, got {}",
            type_name(v)
        )),
    }
}

fn string(table: &toml::Table, key: &str, field: &str) -> Result<Option<String>, String> {
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
}

fn reject_unknown(table: &toml::Table, known: &[&str], field: &str) -> Result<(), String> {
    match table.keys().find(|k| !known.contains(&k.as_str())) {
        Some(k) => Err(format!(
            "{field}.{k}: unknown key (expected one of {})",
            known.join(", ")
        )),
        None => Ok(()),
    }
}

fn finite(value: f64, name: &str) -> Result<(), String> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(format!("{name}: must be finite (got {value})"))
    }
}

/// Checks every mounted sensor spec shares, in this order: the listed numbers are finite, the
/// name and mount link are not empty, the rate is positive. Errors start with the field name.
pub(crate) fn check_mounted_sensor(
    name: &str,
    mount: &str,
    rate_hz: f64,
    numbers: &[(&str, f64)],
) -> Result<(), String> {
    for (field, v) in numbers {
        finite(*v, field)?;
    }
    if name.trim().is_empty() {
        return Err("name: must not be empty".into());
    }
    if mount.trim().is_empty() {
        return Err("mount: must not be empty".into());
    }
    if rate_hz <= 0.0 {
        return Err(format!("rate_hz: must be > 0 (got {rate_hz})"));
    }
    Ok(())
}

/// A spec table without a `preset` must give every field; the error lists the missing ones.
pub(crate) fn require_all_fields(
    table: &toml::Table,
    fields: &[&str],
    field: &str,
    presets: &[&str],
) -> Result<(), String> {
    let missing: Vec<&str> = fields
        .iter()
        .copied()
        .filter(|k| !table.contains_key(*k))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    Err(format!(
        "{field}: no preset given, so every field is needed; missing: {} \
         (or set preset = one of {})",
        missing.join(", "),
        presets.join(", ")
    ))
}

fn probability(value: f64, name: &str) -> Result<(), String> {
    if (0.0..=1.0).contains(&value) {
        Ok(())
    } else {
        Err(format!(
            "{name}: must be a probability in [0, 1] (got {value})"
        ))
    }
}

/// A planar laser rangefinder with the beam model's error terms (Thrun et al., ch. 6.3).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LaserSpec {
    pub name: String,
    /// URDF link the laser frame is attached to.
    pub mount: String,
    pub rate_hz: f64,
    pub beams: usize,
    /// Total field of view, radians, centred on the laser's +x.
    pub fov: f64,
    pub range_min: f64,
    pub range_max: f64,
    /// Standard deviation of the Gaussian range noise at range 0, m.
    pub sigma_hit: f64,
    /// Growth of the Gaussian range noise's standard deviation with the true range r
    /// (m per m): σ(r) = `sigma_hit` + `sigma_hit_per_m`·r, as real lasers spread more on
    /// far walls. Default 0 (σ the same at every range).
    #[serde(default)]
    pub sigma_hit_per_m: f64,
    /// Probability that a beam returns short (unmodelled obstacle), exponential with `lambda_short`.
    pub p_short: f64,
    pub lambda_short: f64,
    /// Probability that a beam fails and reads `range_max`.
    pub p_max: f64,
    /// Probability of a uniformly random reading.
    pub p_rand: f64,
}

impl LaserSpec {
    /// SICK LMS200-like: 181 beams over 180°, 8 m indoor range.
    pub fn sick_lms200(name: &str, mount: &str) -> Self {
        Self {
            name: name.into(),
            mount: mount.into(),
            rate_hz: 10.0,
            beams: 181,
            fov: std::f64::consts::PI,
            range_min: 0.05,
            range_max: 8.0,
            sigma_hit: 0.01,
            sigma_hit_per_m: 0.0,
            p_short: 0.01,
            lambda_short: 1.0,
            p_max: 0.005,
            p_rand: 0.005,
        }
    }

    /// Hokuyo URG-04LX-like: 683 beams over 240°, 5.6 m range.
    pub fn hokuyo_urg04lx(name: &str, mount: &str) -> Self {
        Self {
            name: name.into(),
            mount: mount.into(),
            rate_hz: 10.0,
            beams: 683,
            fov: 240f64.to_radians(),
            range_min: 0.02,
            range_max: 5.6,
            sigma_hit: 0.015,
            sigma_hit_per_m: 0.0,
            p_short: 0.01,
            lambda_short: 1.0,
            p_max: 0.01,
            p_rand: 0.005,
        }
    }

    pub fn preset(preset: &str, name: &str, mount: &str) -> Option<Self> {
        match preset {
            "sick_lms200" => Some(Self::sick_lms200(name, mount)),
            "hokuyo_urg04lx" => Some(Self::hokuyo_urg04lx(name, mount)),
            _ => None,
        }
    }

    /// Reads a laser from a TOML table: `preset` (required unless every field is given) plus
    /// any [`LaserSpec`] field, which overrides the preset; `name` and `mount` are always
    /// required. `field` is the table's path (e.g. `sensors.laser`) and prefixes every error:
    /// `"sensors.laser.beams: must be at least 1 (got 0)"`. Unknown keys are errors.
    pub fn from_table(table: &toml::Table, field: &str) -> Result<LaserSpec, String> {
        let mut known = LASER_FIELDS.to_vec();
        known.push("preset");
        reject_unknown(table, &known, field)?;
        let name = string(table, "name", field)?.ok_or_else(|| format!("{field}.name: missing"))?;
        let mount = string(table, "mount", field)?.ok_or_else(|| {
            format!("{field}.mount: missing (the URDF link the laser frame is attached to)")
        })?;
        let mut spec = match string(table, "preset", field)? {
            Some(preset) => Self::preset(&preset, &name, &mount).ok_or_else(|| {
                format!(
                    "{field}.preset: unknown preset {preset:?} (known: {})",
                    PRESETS.join(", ")
                )
            })?,
            None => {
                let required: Vec<&str> = LASER_FIELDS
                    .into_iter()
                    .filter(|k| !LASER_OPTIONAL_FIELDS.contains(k))
                    .collect();
                require_all_fields(table, &required, field, &PRESETS)?;
                // Every required field is overwritten below; an optional one left out keeps
                // this preset's value, which is its default.
                Self::sick_lms200(&name, &mount)
            }
        };
        if let Some(beams) = count(table, "beams", field)? {
            spec.beams = beams;
        }
        let numbers: [(&str, &mut f64); 10] = [
            ("rate_hz", &mut spec.rate_hz),
            ("fov", &mut spec.fov),
            ("range_min", &mut spec.range_min),
            ("range_max", &mut spec.range_max),
            ("sigma_hit", &mut spec.sigma_hit),
            ("sigma_hit_per_m", &mut spec.sigma_hit_per_m),
            ("p_short", &mut spec.p_short),
            ("lambda_short", &mut spec.lambda_short),
            ("p_max", &mut spec.p_max),
            ("p_rand", &mut spec.p_rand),
        ];
        for (key, slot) in numbers {
            if let Some(v) = number(table, key, field)? {
                *slot = v;
            }
        }
        spec.validate().map_err(|msg| format!("{field}.{msg}"))?;
        Ok(spec)
    }

    /// Checks every number; the error names the field, e.g. `"beams: must be at least 1 (got 0)"`.
    pub fn validate(&self) -> Result<(), String> {
        check_mounted_sensor(
            &self.name,
            &self.mount,
            self.rate_hz,
            &[
                ("rate_hz", self.rate_hz),
                ("fov", self.fov),
                ("range_min", self.range_min),
                ("range_max", self.range_max),
                ("sigma_hit", self.sigma_hit),
                ("sigma_hit_per_m", self.sigma_hit_per_m),
                ("p_short", self.p_short),
                ("lambda_short", self.lambda_short),
                ("p_max", self.p_max),
                ("p_rand", self.p_rand),
            ],
        )?;
        if self.beams < 1 {
            return Err(format!("beams: must be at least 1 (got {})", self.beams));
        }
        if self.beams > MAX_LASER_BEAMS {
            return Err(format!(
                "beams: {} is more than the limit of {MAX_LASER_BEAMS} (MAX_LASER_BEAMS)",
                self.beams
            ));
        }
        if !(self.fov > 0.0 && self.fov <= std::f64::consts::TAU) {
            return Err(format!("fov: must be in (0, 2π] rad (got {})", self.fov));
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
        if self.sigma_hit < 0.0 {
            return Err(format!("sigma_hit: must be >= 0 (got {})", self.sigma_hit));
        }
        if self.sigma_hit_per_m < 0.0 {
            return Err(format!(
                "sigma_hit_per_m: must be >= 0 (got {})",
                self.sigma_hit_per_m
            ));
        }
        if self.lambda_short <= 0.0 {
            return Err(format!(
                "lambda_short: must be > 0 (got {})",
                self.lambda_short
            ));
        }
        probability(self.p_short, "p_short")?;
        probability(self.p_max, "p_max")?;
        probability(self.p_rand, "p_rand")?;
        let sum = self.p_short + self.p_max + self.p_rand;
        if sum > 1.0 {
            return Err(format!(
                "p_rand: p_short + p_max + p_rand must be <= 1 (got {sum})"
            ));
        }
        Ok(())
    }

    pub fn angle_min(&self) -> f64 {
        -0.5 * self.fov
    }

    pub fn angle_increment(&self) -> f64 {
        if self.beams > 1 {
            self.fov / (self.beams - 1) as f64
        } else {
            0.0
        }
    }
}

/// Wheel encoders and the systematic errors of the odometry computed from them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OdometrySpec {
    pub ticks_per_rev: u32,
    /// Relative mismatch between the believed radii of the two wheels: odometry uses
    /// r·(1 + e/2) for the left wheel and r·(1 − e/2) for the right.
    pub radius_error: f64,
    /// Relative error of the believed wheel separation: odometry uses b·(1 + e).
    pub separation_error: f64,
    /// Common-mode (scale) error of the believed wheel radii: both are multiplied by
    /// (1 + s), on top of `radius_error`'s split, so a straight drive over-reads its distance
    /// by that factor (and a turn its angle) — Borenstein & Feng's scale error E_s beside E_d
    /// (`radius_error`) and E_b (`separation_error`) [Borenstein 1996]. Positive for a tyre
    /// that rolls on less than its nominal radius (a pneumatic tyre flattened under load).
    /// Default 0.
    #[serde(default)]
    pub scale_error: f64,
    /// Random slip per wheel: the standard deviation of each wheel's random scale error
    /// (dimensionless; 0.02 reads a wheel's travel 2 % off, one σ). Each wheel's error is a
    /// Gauss–Markov process over the distance that wheel rolls, drawn from the run's seed,
    /// so the drift differs from stretch to stretch and from seed to seed, on top of the
    /// systematic errors above. Default 0 (no random error).
    #[serde(default)]
    pub slip_sigma: f64,
    /// The distance a wheel rolls over which its slip error decorrelates (the process's
    /// correlation length), m: short for gravel-like jitter, long for slowly changing floors
    /// and loads. Default 2.
    #[serde(default = "default_slip_correlation_m")]
    pub slip_correlation_m: f64,
    /// Odometry publication rate, Hz.
    pub rate_hz: f64,
}

fn default_slip_correlation_m() -> f64 {
    2.0
}

impl OdometrySpec {
    /// Reads odometry from a TOML table; missing fields keep [`OdometrySpec::default`].
    /// `field` prefixes every error, e.g. `"odometry.ticks_per_rev: must be at least 1 (got 0)"`.
    pub fn from_table(table: &toml::Table, field: &str) -> Result<OdometrySpec, String> {
        reject_unknown(table, &ODOMETRY_FIELDS, field)?;
        let mut spec = OdometrySpec::default();
        if let Some(t) = count(table, "ticks_per_rev", field)? {
            spec.ticks_per_rev = t;
        }
        for (key, slot) in [
            ("radius_error", &mut spec.radius_error),
            ("separation_error", &mut spec.separation_error),
            ("scale_error", &mut spec.scale_error),
            ("slip_sigma", &mut spec.slip_sigma),
            ("slip_correlation_m", &mut spec.slip_correlation_m),
            ("rate_hz", &mut spec.rate_hz),
        ] {
            if let Some(v) = number(table, key, field)? {
                *slot = v;
            }
        }
        spec.validate().map_err(|msg| format!("{field}.{msg}"))?;
        Ok(spec)
    }

    /// Checks every number; the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        finite(self.radius_error, "radius_error")?;
        finite(self.separation_error, "separation_error")?;
        finite(self.scale_error, "scale_error")?;
        finite(self.slip_sigma, "slip_sigma")?;
        finite(self.slip_correlation_m, "slip_correlation_m")?;
        finite(self.rate_hz, "rate_hz")?;
        if !(0.0..0.5).contains(&self.slip_sigma) {
            return Err(format!(
                "slip_sigma: must be within [0, 0.5) (got {})",
                self.slip_sigma
            ));
        }
        if self.slip_correlation_m <= 0.0 {
            return Err(format!(
                "slip_correlation_m: must be > 0 m (got {})",
                self.slip_correlation_m
            ));
        }
        if self.ticks_per_rev < 1 {
            return Err(format!(
                "ticks_per_rev: must be at least 1 (got {})",
                self.ticks_per_rev
            ));
        }
        // Half the radius or half the track wrong is no longer a calibration error.
        if self.radius_error.abs() >= 0.5 {
            return Err(format!(
                "radius_error: must be within (-0.5, 0.5) (got {})",
                self.radius_error
            ));
        }
        if self.separation_error.abs() >= 0.5 {
            return Err(format!(
                "separation_error: must be within (-0.5, 0.5) (got {})",
                self.separation_error
            ));
        }
        // A believed radius of zero or less (s ≤ −1) or twice the truth is no calibration.
        if self.scale_error.abs() >= 1.0 {
            return Err(format!(
                "scale_error: must be within (-1, 1) (got {})",
                self.scale_error
            ));
        }
        if self.rate_hz <= 0.0 {
            return Err(format!("rate_hz: must be > 0 (got {})", self.rate_hz));
        }
        Ok(())
    }
}

impl Default for OdometrySpec {
    fn default() -> Self {
        Self {
            ticks_per_rev: 500,
            radius_error: 0.005,
            separation_error: 0.01,
            scale_error: 0.0,
            slip_sigma: 0.0,
            slip_correlation_m: default_slip_correlation_m(),
            rate_hz: 50.0,
        }
    }
}

/// The contents of a robot's sensor file.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RobotSensors {
    pub odometry: OdometrySpec,
    pub lasers: Vec<LaserSpec>,
    /// The WiFi scanner (`[wifi]`), if the robot has one.
    pub wifi: Option<crate::wifi::WifiSpec>,
}

/// The sensor file's layout, for writing it back.
#[derive(Serialize)]
struct SensorFile<'a> {
    odometry: &'a OdometrySpec,
    laser: &'a [LaserSpec],
    #[serde(skip_serializing_if = "Option::is_none")]
    wifi: &'a Option<crate::wifi::WifiSpec>,
}

impl RobotSensors {
    /// The sensor file that belongs to a URDF: `<stem>.sensors.toml` in the same directory.
    pub fn path_beside(urdf: &Path) -> PathBuf {
        let stem = urdf.file_stem().unwrap_or_default().to_string_lossy();
        urdf.with_file_name(format!("{stem}.sensors.toml"))
    }

    /// Reads and validates a sensor file.
    pub fn load(path: &Path) -> Result<RobotSensors, RobotError> {
        let text = std::fs::read_to_string(path).map_err(|err| RobotError::Io {
            source_name: path.display().to_string(),
            err,
        })?;
        Self::from_toml_str(&text, path)
    }

    /// Parses sensor-file text: an optional `[odometry]` table (missing fields take
    /// [`OdometrySpec::default`]) and any number of `[[laser]]` tables (see
    /// [`LaserSpec::from_table`]). `path` names the file in errors.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<RobotSensors, RobotError> {
        let invalid = |msg: String| RobotError::Invalid {
            source_name: path.display().to_string(),
            msg,
        };
        let table: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| invalid(format!("TOML: {e}")))?;
        if let Some(key) = table
            .keys()
            .find(|k| *k != "odometry" && *k != "laser" && *k != "wifi")
        {
            return Err(RobotError::Field {
                file: path.to_path_buf(),
                field: key.clone(),
                msg: "unknown key (expected odometry, laser, wifi)".into(),
            });
        }
        let odometry = match table.get("odometry") {
            None => OdometrySpec::default(),
            Some(toml::Value::Table(t)) => {
                OdometrySpec::from_table(t, "odometry").map_err(invalid)?
            }
            Some(v) => {
                return Err(invalid(format!(
                    "odometry: expected a table ([odometry]), got {}",
                    type_name(v)
                )))
            }
        };
        let mut lasers: Vec<LaserSpec> = Vec::new();
        match table.get("laser") {
            None => {}
            Some(toml::Value::Array(items)) => {
                for (i, item) in items.iter().enumerate() {
                    let field = format!("laser[{i}]");
                    let toml::Value::Table(t) = item else {
                        return Err(invalid(format!(
                            "{field}: expected a table ([[laser]]), got {}",
                            type_name(item)
                        )));
                    };
                    let spec = LaserSpec::from_table(t, &field).map_err(invalid)?;
                    if lasers.iter().any(|l| l.name == spec.name) {
                        return Err(invalid(format!(
                            "{field}.name: {:?} is already the name of another laser",
                            spec.name
                        )));
                    }
                    lasers.push(spec);
                }
            }
            Some(v) => {
                return Err(invalid(format!(
                    "laser: expected an array of tables ([[laser]]), got {}",
                    type_name(v)
                )))
            }
        }
        let wifi = match table.get("wifi") {
            None => None,
            Some(toml::Value::Table(t)) => {
                Some(crate::wifi::WifiSpec::from_table(t, "wifi").map_err(invalid)?)
            }
            Some(v) => {
                return Err(invalid(format!(
                    "wifi: expected a table ([wifi]), got {}",
                    type_name(v)
                )))
            }
        };
        Ok(RobotSensors {
            odometry,
            lasers,
            wifi,
        })
    }

    /// The sensor file text for these sensors (every field explicit, no presets), which
    /// [`RobotSensors::from_toml_str`] reads back to an equal value.
    pub fn to_toml_string(&self) -> Result<String, toml::ser::Error> {
        toml::to_string(&SensorFile {
            odometry: &self.odometry,
            laser: &self.lasers,
            wifi: &self.wifi,
        })
    }

    /// Checks that every sensor is mounted on a link of `model`.
    pub fn check_mounts(&self, model: &RobotModel) -> Result<(), RobotError> {
        for laser in &self.lasers {
            if model.mount(&laser.mount).is_none() {
                let links: Vec<&str> = model.mounts.iter().map(|m| m.name.as_str()).collect();
                return Err(RobotError::Invalid {
                    source_name: format!("sensors of robot {:?}", model.name),
                    msg: format!(
                        "laser {:?}: mount {:?} is not a link of the robot (links: {})",
                        laser.name,
                        laser.mount,
                        links.join(", ")
                    ),
                });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn laser(extra: &str) -> Result<LaserSpec, String> {
        let table: toml::Table =
            format!("name = \"laser\"\nmount = \"laser\"\npreset = \"sick_lms200\"\n{extra}")
                .parse()
                .unwrap();
        LaserSpec::from_table(&table, "sensors.laser")
    }

    #[test]
    fn beams_above_the_limit_are_refused_with_field_and_limit() {
        assert_eq!(
            laser("beams = 100000000").unwrap_err(),
            "sensors.laser.beams: 100000000 is more than the limit of 100000 (MAX_LASER_BEAMS)"
        );
        assert!(laser("beams = 1000000000000")
            .unwrap_err()
            .contains("MAX_LASER_BEAMS"));
        assert_eq!(laser("beams = 100000").unwrap().beams, MAX_LASER_BEAMS);
    }

    #[test]
    fn range_growth_of_the_hit_noise_is_read_checked_and_optional() {
        assert_eq!(laser("").unwrap().sigma_hit_per_m, 0.0);
        assert_eq!(
            laser("sigma_hit_per_m = 0.004").unwrap().sigma_hit_per_m,
            0.004
        );
        assert_eq!(
            laser("sigma_hit_per_m = -0.1").unwrap_err(),
            "sensors.laser.sigma_hit_per_m: must be >= 0 (got -0.1)"
        );
        assert_eq!(
            laser("sigma_hit_per_m = nan").unwrap_err(),
            "sensors.laser.sigma_hit_per_m: must be finite (got NaN)"
        );
        // A table without a preset that gives every other field (as sensor files written
        // before the field existed do) still reads, with no growth.
        let full: toml::Table = "name = \"l\"\nmount = \"l\"\nrate_hz = 10\nbeams = 181\n\
                                 fov = 3.14\nrange_min = 0.05\nrange_max = 8.0\n\
                                 sigma_hit = 0.01\np_short = 0.01\nlambda_short = 1.0\n\
                                 p_max = 0.005\np_rand = 0.005\n"
            .parse()
            .unwrap();
        let spec = LaserSpec::from_table(&full, "laser[0]").unwrap();
        assert_eq!(spec.sigma_hit_per_m, 0.0);
        // Written back and read again, the field survives.
        let mut spec = LaserSpec::sick_lms200("l", "l");
        spec.sigma_hit_per_m = 0.003;
        let table = toml::Table::try_from(&spec).unwrap();
        assert_eq!(LaserSpec::from_table(&table, "laser[0]").unwrap(), spec);
    }

    #[test]
    fn image_sizes_are_checked_without_overflow() {
        assert!(check_image_size("width", 4000, 4000).is_ok());
        assert_eq!(
            check_image_size("width", 4001, 4000).unwrap_err(),
            "width: a 4001 × 4000 image is 16004000 pixels, more than the limit of 16000000 \
             (MAX_IMAGE_PIXELS)"
        );
        assert!(check_image_size("height", usize::MAX, usize::MAX).is_err());
    }
}
