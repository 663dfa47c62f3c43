//! The WiFi receiver: how often it scans and how it errs. Defaults follow ARCHITECTURE.md's
//! sensor table (scan noise 2 dB, cut-off −90 dBm, one scan every 1–2 s); the source is
//! [004] §2.3, whose robot scanned while driving.
//!
//! In a sensor file or a scenario:
//! ```toml
//! [wifi]
//! scan_period_s = 1.0
//! noise_db = 2.0
//! cutoff_dbm = -90.0
//! quantization_db = 1.0
//! antenna_height = 0.4
//! ```

use serde::{Deserialize, Serialize};

/// A WiFi scanner on the robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WifiSpec {
    /// Name carried by the scans. Default "wifi".
    pub name: String,
    /// Seconds between scans. Default 1.0.
    pub scan_period_s: f64,
    /// Standard deviation of the per-scan Gaussian noise, dB. Default 2.
    pub noise_db: f64,
    /// Sensitivity: an access point whose (quantized) RSSI falls below this is missing from
    /// the scan, dBm. Default −90.
    pub cutoff_dbm: f64,
    /// RSSI is reported in steps of this many dB (0: unquantized). Default 1.
    pub quantization_db: f64,
    /// Antenna height above the floor, m. Default 0.4.
    pub antenna_height: f64,
}

impl Default for WifiSpec {
    fn default() -> Self {
        Self {
            name: "wifi".into(),
            scan_period_s: 1.0,
            noise_db: 2.0,
            cutoff_dbm: -90.0,
            quantization_db: 1.0,
            antenna_height: 0.4,
        }
    }
}

impl WifiSpec {
    /// Reads a `[wifi]` table: missing keys keep [`WifiSpec::default`], unknown keys are
    /// errors. `field` prefixes every message, e.g. `"wifi.noise_db: must be >= 0 (got -1)"`.
    pub fn from_table(table: &toml::Table, field: &str) -> Result<WifiSpec, String> {
        let spec: WifiSpec = toml::Value::Table(table.clone())
            .try_into()
            .map_err(|e: toml::de::Error| format!("{field}: {}", e.message()))?;
        spec.validate().map_err(|msg| format!("{field}.{msg}"))?;
        Ok(spec)
    }

    /// Checks every number; the message starts with the key.
    pub fn validate(&self) -> Result<(), String> {
        if self.name.trim().is_empty() {
            return Err("name: must not be empty".into());
        }
        let p = self.scan_period_s;
        if !(p.is_finite() && (0.01..=60.0).contains(&p)) {
            return Err(format!(
                "scan_period_s: must be within [0.01, 60] s (got {p})"
            ));
        }
        let n = self.noise_db;
        if !(n.is_finite() && (0.0..=30.0).contains(&n)) {
            return Err(format!("noise_db: must be within [0, 30] dB (got {n})"));
        }
        let c = self.cutoff_dbm;
        if !(c.is_finite() && (-150.0..=0.0).contains(&c)) {
            return Err(format!(
                "cutoff_dbm: must be within [-150, 0] dBm (got {c})"
            ));
        }
        let q = self.quantization_db;
        if !(q.is_finite() && (0.0..=10.0).contains(&q)) {
            return Err(format!(
                "quantization_db: must be within [0, 10] dB (got {q})"
            ));
        }
        let h = self.antenna_height;
        if !(h.is_finite() && (0.0..=10.0).contains(&h)) {
            return Err(format!(
                "antenna_height: must be within [0, 10] m (got {h})"
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_overrides_defaults_and_errors_name_the_key() {
        let t: toml::Table = "noise_db = 3\nscan_period_s = 2.0".parse().unwrap();
        let s = WifiSpec::from_table(&t, "wifi").unwrap();
        assert_eq!(s.noise_db, 3.0);
        assert_eq!(s.scan_period_s, 2.0);
        assert_eq!(s.cutoff_dbm, -90.0);
        let t: toml::Table = "noise_db = -1.0".parse().unwrap();
        assert_eq!(
            WifiSpec::from_table(&t, "wifi").unwrap_err(),
            "wifi.noise_db: must be within [0, 30] dB (got -1)"
        );
        let t: toml::Table = "nois_db = 1.0".parse().unwrap();
        let e = WifiSpec::from_table(&t, "sensors.wifi").unwrap_err();
        assert!(
            e.starts_with("sensors.wifi: unknown field `nois_db`"),
            "{e}"
        );
    }
}
