//! The world model.

use serde::{Deserialize, Serialize};

use crate::geometry::{distance, point_in_polygon, wall_corners, wall_signed_distance, P2};
use crate::wifi::{AccessPoint, WifiEnvironment};

/// What a laser beam does at a surface of this material.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum LaserBehaviour {
    /// Reflects every beam.
    Opaque,
    /// Transparent, except within `reflect_within_deg` degrees of normal incidence.
    Glass { reflect_within_deg: f64 },
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub name: String,
    pub laser: LaserBehaviour,
    /// What one crossing of a wall of this material costs a WiFi signal's direct path, dB.
    #[serde(default)]
    pub wifi_attenuation_db: f64,
}

/// A straight wall: the centre line from `a` to `b`, a thickness and a height.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Wall {
    pub a: [f64; 2],
    pub b: [f64; 2],
    pub thickness: f64,
    pub height: f64,
    pub material: String,
}

/// A vertical cylinder (columns, pillars; point features for SLAM later).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pillar {
    pub center: [f64; 2],
    pub radius: f64,
    pub height: f64,
    pub material: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RegionKind {
    Corridor,
    GlassCorridor,
    Atrium,
    Room,
}

/// A named area of the floor, used to break errors down by place.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Region {
    pub name: String,
    pub kind: RegionKind,
    /// Simple polygon, counter-clockwise or clockwise, not closed (first != last).
    pub polygon: Vec<[f64; 2]>,
}

/// A validated world. Build it with `World::load` / `World::from_toml_str` (see the loader),
/// which expand wall polylines into single [`Wall`]s.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct World {
    pub name: String,
    /// Floor at z = 0; ceiling height, m.
    pub ceiling_height: f64,
    /// Indexed by name; walls and pillars refer to them.
    pub materials: Vec<Material>,
    pub walls: Vec<Wall>,
    pub pillars: Vec<Pillar>,
    pub regions: Vec<Region>,
    /// WiFi access points (`[[access_points]]`, see [`crate::wifi`]).
    #[serde(default)]
    pub access_points: Vec<AccessPoint>,
    /// Shadow fading of the WiFi signals (`[wifi]`).
    #[serde(default)]
    pub wifi: WifiEnvironment,
    /// Furniture (`[[boxes]]`, see [`crate::furniture`]): solid and seen by sensors, but not
    /// part of the maps a localizer is given.
    #[serde(default)]
    pub boxes: Vec<crate::furniture::FurnitureBox>,
    /// Lights and surface looks for cameras (`[[lights]]`, `[surfaces.*]`, see
    /// [`crate::lighting`]).
    #[serde(default)]
    pub lighting: crate::lighting::Lighting,
}

impl World {
    /// The first furniture box whose footprint contains `p`. [`World::clearance`] and
    /// [`World::is_free`] describe the building (what the maps show) and leave furniture out.
    pub fn furniture_at(&self, p: P2) -> Option<usize> {
        self.boxes.iter().position(|b| b.signed_distance(p) <= 0.0)
    }

    /// The material called `name`.
    pub fn material(&self, name: &str) -> Option<&Material> {
        self.materials.iter().find(|m| m.name == name)
    }

    /// Whether `material` is see-through for a laser (except near normal incidence). Unknown
    /// names count as opaque: the loader never produces them.
    pub fn is_glass(&self, material: &str) -> bool {
        matches!(
            self.material(material).map(|m| m.laser),
            Some(LaserBehaviour::Glass { .. })
        )
    }

    /// Axis-aligned bounds `(min, max)` of every solid (wall footprints and pillars); both
    /// `[0, 0]` for a world without solids.
    pub fn bounds(&self) -> ([f64; 2], [f64; 2]) {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for w in &self.walls {
            for c in wall_corners(w.a, w.b, w.thickness) {
                for k in 0..2 {
                    lo[k] = lo[k].min(c[k]);
                    hi[k] = hi[k].max(c[k]);
                }
            }
        }
        for p in &self.pillars {
            for k in 0..2 {
                lo[k] = lo[k].min(p.center[k] - p.radius);
                hi[k] = hi[k].max(p.center[k] + p.radius);
            }
        }
        if lo[0] > hi[0] {
            return ([0.0; 2], [0.0; 2]);
        }
        (lo, hi)
    }

    /// The first region (in file order) whose polygon contains `p`.
    pub fn region_at(&self, p: [f64; 2]) -> Option<&Region> {
        self.regions
            .iter()
            .find(|r| point_in_polygon(p, &r.polygon))
    }

    /// Distance from `p` to the nearest solid (wall footprint or pillar, glass included since
    /// a robot cannot drive through it); `<= 0` inside one, infinite with no solids.
    pub fn clearance(&self, p: [f64; 2]) -> f64 {
        if !(p[0].is_finite() && p[1].is_finite()) {
            // NaN compares false, so `is_free` rejects a non-finite point.
            return f64::NAN;
        }
        let walls = self
            .walls
            .iter()
            .map(|w| wall_signed_distance(p, w.a, w.b, w.thickness));
        let pillars = self
            .pillars
            .iter()
            .map(|c| distance(p, c.center) - c.radius);
        walls.chain(pillars).fold(f64::INFINITY, f64::min)
    }

    /// Whether a disc of `radius` centred at `p` stays clear of every solid.
    pub fn is_free(&self, p: [f64; 2], radius: f64) -> bool {
        self.clearance(p) > radius
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn world() -> World {
        World {
            name: "w".into(),
            ceiling_height: 3.0,
            materials: vec![
                Material {
                    name: "concrete".into(),
                    laser: LaserBehaviour::Opaque,
                    wifi_attenuation_db: 0.0,
                },
                Material {
                    name: "glass".into(),
                    laser: LaserBehaviour::Glass {
                        reflect_within_deg: 5.0,
                    },
                    wifi_attenuation_db: 0.0,
                },
            ],
            // A 0.2 m wall x ∈ [0, 10] on y = 0 and a glass wall x = 10, y ∈ [0, 5].
            walls: vec![
                Wall {
                    a: [0.0, 0.0],
                    b: [10.0, 0.0],
                    thickness: 0.2,
                    height: 3.0,
                    material: "concrete".into(),
                },
                Wall {
                    a: [10.0, 0.0],
                    b: [10.0, 5.0],
                    thickness: 0.05,
                    height: 3.0,
                    material: "glass".into(),
                },
            ],
            pillars: vec![Pillar {
                center: [3.0, 4.0],
                radius: 0.5,
                height: 3.0,
                material: "concrete".into(),
            }],
            regions: vec![
                Region {
                    name: "a".into(),
                    kind: RegionKind::Room,
                    polygon: vec![[0.0, 0.0], [5.0, 0.0], [5.0, 5.0], [0.0, 5.0]],
                },
                Region {
                    name: "b".into(),
                    kind: RegionKind::Atrium,
                    polygon: vec![[0.0, 0.0], [10.0, 0.0], [10.0, 5.0], [0.0, 5.0]],
                },
            ],
            access_points: vec![],
            wifi: Default::default(),
            boxes: Vec::new(),
            lighting: Default::default(),
        }
    }

    #[test]
    fn materials_and_bounds() {
        let w = world();
        assert!(w.material("glass").is_some());
        assert!(w.material("wood").is_none());
        assert!(w.is_glass("glass") && !w.is_glass("concrete") && !w.is_glass("wood"));
        // x: concrete from 0 to glass's outer face 10.025; y: concrete's lower face to 5.
        assert_eq!(w.bounds(), ([0.0, -0.1], [10.025, 5.0]));
    }

    #[test]
    fn region_at_takes_the_first_match() {
        let w = world();
        assert_eq!(w.region_at([1.0, 1.0]).unwrap().name, "a");
        assert_eq!(w.region_at([7.0, 1.0]).unwrap().name, "b");
        assert!(w.region_at([11.0, 1.0]).is_none());
    }

    #[test]
    fn clearance_is_signed_distance_to_the_nearest_solid() {
        let w = world();
        // Above the concrete wall's upper face (y = 0.1), far from the rest.
        assert!((w.clearance([5.0, 1.1]) - 1.0).abs() < 1e-12);
        // Nearest is the pillar: |(3, 2.5) - (3, 4)| - 0.5 = 1.0 vs 2.4 to the wall.
        assert!((w.clearance([3.0, 2.5]) - 1.0).abs() < 1e-12);
        // Glass counts: 0.475 m from its west face at x = 9.975.
        assert!((w.clearance([9.5, 3.0]) - 0.475).abs() < 1e-12);
        // Inside the concrete wall and inside the pillar.
        assert!((w.clearance([5.0, 0.0]) + 0.1).abs() < 1e-12);
        assert!((w.clearance([3.0, 4.0]) + 0.5).abs() < 1e-12);
        assert!(w.is_free([5.0, 1.1], 0.9));
        assert!(!w.is_free([5.0, 1.1], 1.0));
        assert!(!w.is_free([5.0, 0.05], 0.0));
        assert!(w.clearance([f64::NAN, 1.0]).is_nan());
        assert!(!w.is_free([f64::NAN, 1.0], 0.0));
    }
}
