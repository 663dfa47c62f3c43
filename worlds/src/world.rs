//! The world model.

use serde::{Deserialize, Serialize};

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
}
