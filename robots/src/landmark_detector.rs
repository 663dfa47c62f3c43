//! The range-bearing point-feature detector that feeds EKF-SLAM (Kozlov, MacDonald, Wünsche,
//! "Covariance Visualisations for SLAM", [003] §2.1, observation
//! model eq. 5: z = h(x) + w with w Gaussian). What it detects (pillar centres) is decided by
//! the simulator; this is only the sensor's description.

use crate::sensors::check_mounted_sensor;
use serde::{Deserialize, Serialize};

/// Whether detections carry the feature's identity.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Association {
    /// Every detection names its feature (`LandmarkDetection::id`).
    Known,
    /// Detections are anonymous: the estimator must associate them itself.
    Unknown,
}

/// A range-bearing detector of point features (pillar centres).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LandmarkDetectorSpec {
    pub name: String,
    /// URDF link the detector frame is attached to (its height decides what it sees).
    pub mount: String,
    pub rate_hz: f64,
    /// Features closer than this to the sensor are not reported, m (> 0: a detection at zero
    /// range has no bearing).
    pub range_min: f64,
    pub range_max: f64,
    /// Total field of view, rad, centred on the sensor's +x.
    pub fov: f64,
    /// Standard deviation of the range noise, m.
    pub sigma_range: f64,
    /// Standard deviation of the bearing noise, rad.
    pub sigma_bearing: f64,
    pub association: Association,
}

impl Default for LandmarkDetectorSpec {
    /// Laser-derived pillar detection on a SICK LMS200-like scanner: 180°, 5 Hz, 6 m, 2 cm
    /// and 0.5° noise (the centre of a fitted arc is noisier than one beam).
    fn default() -> Self {
        Self {
            name: "landmarks".into(),
            mount: "laser".into(),
            rate_hz: 5.0,
            range_min: 0.1,
            range_max: 6.0,
            fov: std::f64::consts::PI,
            sigma_range: 0.02,
            sigma_bearing: 0.5f64.to_radians(),
            association: Association::Known,
        }
    }
}

impl LandmarkDetectorSpec {
    /// Checks every field; the error names it, e.g. `"range_min: must be > 0 (got 0)"`.
    pub fn validate(&self) -> Result<(), String> {
        check_mounted_sensor(
            &self.name,
            &self.mount,
            self.rate_hz,
            &[
                ("rate_hz", self.rate_hz),
                ("range_min", self.range_min),
                ("range_max", self.range_max),
                ("fov", self.fov),
                ("sigma_range", self.sigma_range),
                ("sigma_bearing", self.sigma_bearing),
            ],
        )?;
        if self.range_min <= 0.0 {
            return Err(format!(
                "range_min: must be > 0 (got {}): a feature at zero range has no bearing",
                self.range_min
            ));
        }
        if self.range_max <= self.range_min {
            return Err(format!(
                "range_max: must be greater than range_min = {} (got {})",
                self.range_min, self.range_max
            ));
        }
        if !(self.fov > 0.0 && self.fov <= std::f64::consts::TAU) {
            return Err(format!("fov: must be in (0, 2π] rad (got {})", self.fov));
        }
        // Zero noise would make the innovation covariance singular for a perfectly known
        // robot; the estimator needs R > 0.
        if self.sigma_range <= 0.0 {
            return Err(format!(
                "sigma_range: must be > 0 (got {})",
                self.sigma_range
            ));
        }
        if self.sigma_bearing <= 0.0 {
            return Err(format!(
                "sigma_bearing: must be > 0 (got {})",
                self.sigma_bearing
            ));
        }
        Ok(())
    }

    /// Reads a detector from a TOML table; missing fields keep [`Default`]. `field` prefixes
    /// every error (`"landmark_detector.fov: must be in (0, 2π] rad (got 7)"`); unknown keys
    /// are errors.
    pub fn from_table(table: &toml::Table, field: &str) -> Result<LandmarkDetectorSpec, String> {
        let spec: LandmarkDetectorSpec = toml::Value::Table(table.clone())
            .try_into()
            .map_err(|e: toml::de::Error| format!("{field}: {}", e.message()))?;
        spec.validate().map_err(|msg| format!("{field}.{msg}"))?;
        Ok(spec)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_overrides_defaults_and_errors_name_the_field() {
        let t: toml::Table = "rate_hz = 10\nassociation = \"unknown\"\nfov = 3.0"
            .parse()
            .unwrap();
        let s = LandmarkDetectorSpec::from_table(&t, "landmark_detector").unwrap();
        assert_eq!(s.rate_hz, 10.0);
        assert_eq!(s.association, Association::Unknown);
        assert_eq!(s.fov, 3.0);
        assert_eq!(s.range_max, LandmarkDetectorSpec::default().range_max);

        let t: toml::Table = "range_min = 0.0".parse().unwrap();
        let e = LandmarkDetectorSpec::from_table(&t, "landmark_detector").unwrap_err();
        assert!(
            e.starts_with("landmark_detector.range_min: must be > 0"),
            "{e}"
        );
        let t: toml::Table = "sigma_bearing = nan".parse().unwrap();
        let e = LandmarkDetectorSpec::from_table(&t, "landmark_detector").unwrap_err();
        assert!(e.contains("sigma_bearing: must be finite"), "{e}");
        let t: toml::Table = "colour = 1".parse().unwrap();
        let e = LandmarkDetectorSpec::from_table(&t, "landmark_detector").unwrap_err();
        assert!(e.contains("colour"), "{e}");
        let t: toml::Table = "association = \"psychic\"".parse().unwrap();
        assert!(LandmarkDetectorSpec::from_table(&t, "d").is_err());
    }
}
