//! What cameras see: light sources and the look of each surface ([000] §VII: tube
//! lights, bulbs, daylight through windows; [000] §III: textureless areas give no
//! disparity).
//!
//! ```toml
//! [[lights]]
//! kind = "tube"                  # tube | bulb | window
//! from = [1.0, 1.0, 2.9]         # tube: one end; bulb: the bulb; window: one lower corner
//! to = [3.0, 1.0, 2.9]           # tube: other end; window: the diagonally opposite corner
//! intensity = 4.0                # optional; relative radiant power (default by kind)
//!
//! [surfaces.painted]             # a material's look (also `floor` and `ceiling`)
//! albedo = 0.7                   # mean reflectance in [0, 1]
//! contrast = 0.05                # relative amplitude of the texture in [0, 1]
//! scale = 0.05                   # feature size of the texture, m
//! ```
//!
//! A named lighting condition switches a kind of light on: `tube` the tubes, `bulb` the bulbs,
//! `natural` the windows (with daylight), so the condition changes both the overall level and
//! where the light comes from.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LightKind {
    /// A fluorescent tube along a segment (on under the `tube` condition).
    Tube,
    /// A point bulb (on under `bulb`).
    Bulb,
    /// Daylight through a vertical rectangular window (on under `natural`).
    Window,
}

impl LightKind {
    pub fn default_intensity(self) -> f64 {
        match self {
            LightKind::Tube => 8.0,
            LightKind::Bulb => 5.0,
            LightKind::Window => 20.0,
        }
    }
}

/// A named lighting condition of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LightingCondition {
    Tube,
    Bulb,
    Natural,
}

impl LightingCondition {
    pub const ALL: [LightingCondition; 3] = [Self::Tube, Self::Bulb, Self::Natural];

    /// The kind of light this condition switches on.
    pub fn lights(self) -> LightKind {
        match self {
            Self::Tube => LightKind::Tube,
            Self::Bulb => LightKind::Bulb,
            Self::Natural => LightKind::Window,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Tube => "tube",
            Self::Bulb => "bulb",
            Self::Natural => "natural",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == s)
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Light {
    pub kind: LightKind,
    pub from: [f64; 3],
    #[serde(default)]
    pub to: Option<[f64; 3]>,
    #[serde(default)]
    pub intensity: Option<f64>,
}

impl Light {
    pub fn intensity(&self) -> f64 {
        self.intensity
            .unwrap_or_else(|| self.kind.default_intensity())
    }

    /// Checks the numbers; the error is (key, message).
    pub fn validate(&self, ceiling_height: f64) -> Result<(), (&'static str, String)> {
        let finite = |p: &[f64; 3]| p.iter().all(|v| v.is_finite());
        if !finite(&self.from) {
            return Err(("from", format!("must be finite, got {:?}", self.from)));
        }
        crate::limits::check_coordinates(&self.from).map_err(|msg| ("from", msg))?;
        if !(0.0..=ceiling_height).contains(&self.from[2]) {
            return Err((
                "from",
                format!(
                    "height {} is outside [0, ceiling_height = {ceiling_height}]",
                    self.from[2]
                ),
            ));
        }
        match (self.kind, self.to) {
            (LightKind::Bulb, Some(_)) => {
                return Err(("to", "a bulb is a point: only `from` is allowed".into()))
            }
            (LightKind::Tube | LightKind::Window, None) => {
                return Err(("to", "required for tubes and windows".into()))
            }
            (_, Some(to)) => {
                if !finite(&to) {
                    return Err(("to", format!("must be finite, got {to:?}")));
                }
                crate::limits::check_coordinates(&to).map_err(|msg| ("to", msg))?;
                let len = ((to[0] - self.from[0]).powi(2) + (to[1] - self.from[1]).powi(2)).sqrt();
                if len < 1e-6 {
                    return Err(("to", "must differ from `from` in x or y".into()));
                }
                if self.kind == LightKind::Window && (to[2] - self.from[2]).abs() < 1e-6 {
                    return Err((
                        "to",
                        "a window needs a height: to[2] must differ from from[2]".into(),
                    ));
                }
            }
            (LightKind::Bulb, None) => {}
        }
        if let Some(i) = self.intensity {
            if !(i.is_finite() && i > 0.0) {
                return Err(("intensity", format!("must be finite and > 0, got {i}")));
            }
        }
        Ok(())
    }
}

/// The look of a material: mean albedo and a procedural texture.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Surface {
    pub albedo: f64,
    #[serde(default = "default_contrast")]
    pub contrast: f64,
    #[serde(default = "default_scale")]
    pub scale: f64,
}

fn default_contrast() -> f64 {
    0.4
}
fn default_scale() -> f64 {
    0.08
}

impl Default for Surface {
    /// A moderately textured mid-grey surface, for materials the world says nothing about.
    fn default() -> Self {
        Self {
            albedo: 0.5,
            contrast: default_contrast(),
            scale: default_scale(),
        }
    }
}

impl Surface {
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !(self.albedo.is_finite() && (0.0..=1.0).contains(&self.albedo)) {
            return Err((
                "albedo",
                format!("must be within [0, 1], got {}", self.albedo),
            ));
        }
        if !(self.contrast.is_finite() && (0.0..=1.0).contains(&self.contrast)) {
            return Err((
                "contrast",
                format!("must be within [0, 1], got {}", self.contrast),
            ));
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err((
                "scale",
                format!("must be finite and > 0, got {}", self.scale),
            ));
        }
        Ok(())
    }
}

/// Lights and surface looks of a world (`[[lights]]`, `[surfaces.*]`); empty by default, in
/// which case cameras see default surfaces under ambient light only.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Lighting {
    #[serde(default)]
    pub lights: Vec<Light>,
    /// By material name, plus `floor` and `ceiling`.
    #[serde(default)]
    pub surfaces: BTreeMap<String, Surface>,
}

impl Lighting {
    /// The look of a material (or `floor` / `ceiling`): the world's, else the default.
    pub fn surface(&self, name: &str) -> Surface {
        self.surfaces.get(name).copied().unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conditions_parse_and_switch_kinds() {
        for c in LightingCondition::ALL {
            assert_eq!(LightingCondition::parse(c.name()), Some(c));
        }
        assert_eq!(LightingCondition::parse("moonlight"), None);
        assert_eq!(LightingCondition::Natural.lights(), LightKind::Window);
    }

    #[test]
    fn lights_are_validated() {
        let tube = Light {
            kind: LightKind::Tube,
            from: [0.0, 0.0, 2.9],
            to: Some([1.0, 0.0, 2.9]),
            intensity: None,
        };
        assert!(tube.validate(3.0).is_ok());
        assert_eq!(tube.intensity(), 8.0);
        let mut t = tube.clone();
        t.to = None;
        assert_eq!(t.validate(3.0).unwrap_err().0, "to");
        let mut t = tube.clone();
        t.from[2] = 3.5;
        assert!(t.validate(3.0).unwrap_err().1.contains("outside"));
        let mut t = tube.clone();
        t.intensity = Some(f64::NAN);
        assert_eq!(t.validate(3.0).unwrap_err().0, "intensity");
        let w = Light {
            kind: LightKind::Window,
            from: [0.0, 0.0, 1.0],
            to: Some([2.0, 0.0, 1.0]),
            intensity: None,
        };
        assert!(w.validate(3.0).unwrap_err().1.contains("height"));
        let s = Surface {
            albedo: 1.5,
            ..Surface::default()
        };
        assert_eq!(s.validate().unwrap_err().0, "albedo");
    }
}
