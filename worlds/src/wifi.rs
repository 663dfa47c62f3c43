//! WiFi in a world: access points and the radio environment (shadow fading) the RSSI model of
//! `sim` draws from. Source: [004] §2.3 (WiFi localization needs RSSI
//! that varies with place); the propagation model itself (log-distance path loss, wall
//! attenuation by material, log-normal shadowing) is the standard indoor model, see
//! `sim/src/wifi.rs`.
//!
//! ```toml
//! [[access_points]]
//! name = "ap_oc_w"               # unique; readings carry it
//! position = [3.0, 20.0, 2.9]    # x, y, z (m); z at most the ceiling height
//! tx_power_dbm = -40.0           # RSSI at 1 m, dBm
//! path_loss_exponent = 2.5       # n: RSSI falls by 10·n dB per decade of distance
//! channel = 1
//! [wifi]                         # optional, every key has a default
//! shadowing_sigma_db = 5.0
//! shadowing_decorrelation_m = 3.0
//! multipath_sigma_db = 0.0       # small-scale fading, fixed per spot, 6 cm correlation
//! seed = 1                       # the shadow field is fixed by the world, not by the run
//! ```
//!
//! Materials take an optional `wifi_attenuation_db` (default 0): what one crossing of a wall
//! of that material costs the direct path.

use serde::{Deserialize, Serialize};

/// A WiFi access point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AccessPoint {
    /// Unique name (stands for the BSSID); readings carry it.
    pub name: String,
    /// Antenna position in the world, m (z above the floor).
    pub position: [f64; 3],
    /// Received power at 1 m from the antenna, dBm.
    pub tx_power_dbm: f64,
    /// Log-distance path-loss exponent n.
    pub path_loss_exponent: f64,
    pub channel: u32,
}

/// The radio environment of a world: the spatially correlated shadow fading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WifiEnvironment {
    /// Standard deviation of the shadow fading, dB (0 disables it). Default 5.
    pub shadowing_sigma_db: f64,
    /// Length scale ℓ of its squared-exponential correlation exp(−d²/(2ℓ²)), m: 0.61 at
    /// d = ℓ, below 1e-9 at d = 20 m for the default 3 m.
    pub shadowing_decorrelation_m: f64,
    /// Standard deviation of the small-scale (multipath) fading, dB. Default 0 (off).
    pub multipath_sigma_db: f64,
    /// Its correlation length, m: about half a wavelength (6 cm at 2.4 GHz) by default, so
    /// it is fixed at a spot but cannot be learnt on a graph of metre-spaced nodes.
    pub multipath_decorrelation_m: f64,
    /// Seed of the shadow field. Part of the world, not of a run: every run in this world
    /// (training survey and localization alike) sees the same field.
    pub seed: u64,
}

impl Default for WifiEnvironment {
    fn default() -> Self {
        Self {
            shadowing_sigma_db: 5.0,
            shadowing_decorrelation_m: 3.0,
            multipath_sigma_db: 0.0,
            multipath_decorrelation_m: 0.06,
            seed: 1,
        }
    }
}

impl WifiEnvironment {
    /// Checks every number; the error names the key under `[wifi]`.
    pub fn validate(&self) -> Result<(), (String, String)> {
        let s = self.shadowing_sigma_db;
        if !(s.is_finite() && (0.0..=30.0).contains(&s)) {
            return Err((
                "wifi.shadowing_sigma_db".into(),
                format!("must be within [0, 30] dB, got {s}"),
            ));
        }
        let l = self.shadowing_decorrelation_m;
        if !(l.is_finite() && l > 0.0 && l <= 1000.0) {
            return Err((
                "wifi.shadowing_decorrelation_m".into(),
                format!("must be within (0, 1000] m, got {l}"),
            ));
        }
        let m = self.multipath_sigma_db;
        if !(m.is_finite() && (0.0..=30.0).contains(&m)) {
            return Err((
                "wifi.multipath_sigma_db".into(),
                format!("must be within [0, 30] dB, got {m}"),
            ));
        }
        let l = self.multipath_decorrelation_m;
        if !(l.is_finite() && l > 0.0 && l <= 10.0) {
            return Err((
                "wifi.multipath_decorrelation_m".into(),
                format!("must be within (0, 10] m, got {l}"),
            ));
        }
        Ok(())
    }
}

impl AccessPoint {
    /// Checks the numbers; `ceiling` bounds the height. The error is (key, message), the key
    /// relative to the access point's table.
    pub fn validate(&self, ceiling: f64) -> Result<(), (&'static str, String)> {
        if self.name.trim().is_empty() {
            return Err(("name", "must not be empty".into()));
        }
        let [x, y, z] = self.position;
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return Err((
                "position",
                format!("coordinates must be finite numbers, got [{x}, {y}, {z}]"),
            ));
        }
        crate::limits::check_coordinates(&self.position).map_err(|msg| ("position", msg))?;
        if !(0.0..=ceiling).contains(&z) {
            return Err((
                "position",
                format!("height z must be within [0, ceiling_height = {ceiling}] m, got {z}"),
            ));
        }
        let p = self.tx_power_dbm;
        if !(p.is_finite() && (-100.0..=30.0).contains(&p)) {
            return Err((
                "tx_power_dbm",
                format!("must be within [-100, 30] dBm, got {p}"),
            ));
        }
        let n = self.path_loss_exponent;
        if !(n.is_finite() && (1.0..=6.0).contains(&n)) {
            return Err((
                "path_loss_exponent",
                format!("must be within [1, 6], got {n}"),
            ));
        }
        if !(1..=233).contains(&self.channel) {
            return Err((
                "channel",
                format!(
                    "must be a WiFi channel number in [1, 233], got {}",
                    self.channel
                ),
            ));
        }
        Ok(())
    }
}

/// Checks a material's WiFi attenuation, dB per crossing.
pub fn check_attenuation(db: f64) -> Result<f64, String> {
    if db.is_finite() && (0.0..=100.0).contains(&db) {
        Ok(db)
    } else {
        Err(format!("must be within [0, 100] dB, got {db}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ap() -> AccessPoint {
        AccessPoint {
            name: "a".into(),
            position: [1.0, 2.0, 2.5],
            tx_power_dbm: -40.0,
            path_loss_exponent: 2.5,
            channel: 6,
        }
    }

    #[test]
    fn validation_names_the_key() {
        assert!(ap().validate(3.0).is_ok());
        let mut a = ap();
        a.position[2] = 3.5;
        assert_eq!(a.validate(3.0).unwrap_err().0, "position");
        let mut a = ap();
        a.path_loss_exponent = 0.5;
        assert_eq!(a.validate(3.0).unwrap_err().0, "path_loss_exponent");
        let mut a = ap();
        a.tx_power_dbm = f64::NAN;
        assert_eq!(a.validate(3.0).unwrap_err().0, "tx_power_dbm");
        let mut a = ap();
        a.channel = 0;
        assert_eq!(a.validate(3.0).unwrap_err().0, "channel");
        assert!(check_attenuation(12.0).is_ok() && check_attenuation(-1.0).is_err());
        let e = WifiEnvironment {
            shadowing_decorrelation_m: 0.0,
            ..Default::default()
        };
        assert_eq!(
            e.validate().unwrap_err().0,
            "wifi.shadowing_decorrelation_m"
        );
    }
}
