//! The TOML world format, its loader and its validation.
//!
//! ```toml
//! name = "campus"
//! ceiling_height = 3.0
//! [materials.glass]
//! laser = "glass"               # or "opaque"
//! reflect_within_deg = 5.0      # glass only: reflects within this angle of normal incidence
//! [[walls]]                     # a polyline: each consecutive point pair becomes one Wall
//! points = [[0.0, 0.0], [60.0, 0.0]]
//! thickness = 0.3
//! height = 3.0                  # optional, default ceiling_height
//! material = "concrete"
//! [[pillars]]
//! center = [4.0, 10.6]
//! radius = 0.25
//! material = "concrete"
//! [[regions]]
//! name = "atrium"
//! kind = "atrium"               # corridor | glass_corridor | atrium | room
//! polygon = [[30.0, 2.85], [60.0, 2.85], [60.0, 40.0], [30.0, 40.0]]
//! ```
//!
//! WiFi (optional, see [`crate::wifi`]): `wifi_attenuation_db` on a material (default 0),
//! `[[access_points]]` (name, position, tx_power_dbm, path_loss_exponent, channel) and a
//! `[wifi]` table for the shadow fading.
//!
//! Furniture (optional, see [`crate::furniture`]): `[[boxes]]` with center, size (x, y,
//! height), yaw (default 0) and material; solid and seen by sensors, left out of the maps.
//!
//! Every table denies unknown keys, so a misspelt key is an error naming it. Errors name the
//! file, the field path (`walls[3].thickness`, indices from 0 in file order) and the line.
//!
//! Limits ([`crate::limits`]): every coordinate and length within ±[`MAX_COORDINATE_M`](crate::MAX_COORDINATE_M)
//! (10 km), every length at least [`MIN_SIZE_M`](crate::MIN_SIZE_M) (1 mm), region polygons simple and of at most [`MAX_POLYGON_POINTS`]
//! corners. Whether a world's occupancy grid fits at a resolution is
//! [`World::grid_size`](crate::World::grid_size).

use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

use crate::error::WorldError;
use crate::geometry::{polygon_area, polygon_self_intersection};
use crate::limits::{check_coordinates, check_length, MAX_POLYGON_POINTS};
use crate::wifi::{AccessPoint, WifiEnvironment};
use crate::world::{LaserBehaviour, Material, Pillar, Region, RegionKind, Wall, World};

/// Shorter than this, a wall segment or polygon edge is treated as zero length (metres).
const MIN_LENGTH: f64 = 1e-9;
/// Smaller than this, a region polygon is treated as having no area (m²).
const MIN_AREA: f64 = 1e-9;
/// Longest line of a TOML parse message: the parser quotes the offending source line, which
/// in a hostile file may be megabytes long.
const MAX_MESSAGE_LINE: usize = 200;

/// `msg` with every line longer than [`MAX_MESSAGE_LINE`] characters cut short.
fn clip_lines(msg: &str) -> String {
    msg.lines()
        .map(|line| match line.char_indices().nth(MAX_MESSAGE_LINE) {
            Some((cut, _)) => format!("{}…", &line[..cut]),
            None => line.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWorld {
    name: Spanned<String>,
    ceiling_height: Spanned<f64>,
    #[serde(default)]
    materials: BTreeMap<String, Spanned<toml::Value>>,
    #[serde(default)]
    walls: Vec<Spanned<toml::Value>>,
    #[serde(default)]
    pillars: Vec<Spanned<toml::Value>>,
    #[serde(default)]
    regions: Vec<Spanned<toml::Value>>,
    #[serde(default)]
    access_points: Vec<Spanned<toml::Value>>,
    #[serde(default)]
    wifi: Option<Spanned<toml::Value>>,
    #[serde(default)]
    boxes: Vec<Spanned<toml::Value>>,
    #[serde(default)]
    lights: Vec<Spanned<toml::Value>>,
    #[serde(default)]
    surfaces: BTreeMap<String, Spanned<toml::Value>>,
}

#[derive(Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "snake_case")]
enum LaserKind {
    Opaque,
    Glass,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMaterial {
    laser: LaserKind,
    reflect_within_deg: Option<f64>,
    wifi_attenuation_db: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWall {
    points: Vec<[f64; 2]>,
    thickness: f64,
    height: Option<f64>,
    material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPillar {
    center: [f64; 2],
    radius: f64,
    height: Option<f64>,
    material: String,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRegion {
    name: String,
    kind: RegionKind,
    polygon: Vec<[f64; 2]>,
}

/// Where errors point: the file and, when the text is known, the line of the offending item.
struct Ctx<'a> {
    file: &'a Path,
    text: Option<&'a str>,
}

impl Ctx<'_> {
    fn err(
        &self,
        field: impl Into<String>,
        at: Option<usize>,
        msg: impl Into<String>,
    ) -> WorldError {
        let field = field.into();
        let mut msg = msg.into();
        if let (Some(text), Some(offset)) = (self.text, at) {
            let line = 1 + text.as_bytes()[..offset.min(text.len())]
                .iter()
                .filter(|&&c| c == b'\n')
                .count();
            // Array and table entries carry the span of their whole table, which starts at its
            // header line; say so rather than suggest the key is on that line.
            let entry = field.contains(['.', '[']);
            let which = if entry { "entry at line" } else { "line" };
            msg.push_str(&format!(" ({which} {line})"));
        }
        WorldError::Field {
            file: self.file.to_path_buf(),
            field,
            msg,
        }
    }

    fn finite(&self, field: &str, at: Option<usize>, v: f64) -> Result<f64, WorldError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(field, at, format!("must be a finite number, got {v}")))
        }
    }

    /// A length: finite, > 0 and at most [`MAX_COORDINATE_M`](crate::MAX_COORDINATE_M).
    fn length(&self, field: &str, at: Option<usize>, v: f64) -> Result<f64, WorldError> {
        check_length(v).map_err(|msg| self.err(field, at, msg))
    }

    fn point(&self, field: &str, at: Option<usize>, p: [f64; 2]) -> Result<[f64; 2], WorldError> {
        check_coordinates(&p).map_err(|msg| self.err(field, at, msg))?;
        Ok(p)
    }

    /// `names` holds the names of `materials` (a set, so that checking every wall of a large
    /// world against many materials stays linear).
    fn material_ref(
        &self,
        field: &str,
        at: Option<usize>,
        name: &str,
        (names, materials): (&HashSet<&str>, &[Material]),
    ) -> Result<(), WorldError> {
        if names.contains(name) {
            return Ok(());
        }
        let known = if materials.is_empty() {
            "no [materials] are defined".to_string()
        } else {
            let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
            format!("known: {}", names.join(", "))
        };
        Err(self.err(field, at, format!("unknown material \"{name}\" ({known})")))
    }

    /// Deserialises one array-of-tables entry, prefixing serde's message with its path.
    fn typed<T: for<'de> Deserialize<'de>>(
        &self,
        path: &str,
        item: &Spanned<toml::Value>,
    ) -> Result<T, WorldError> {
        item.get_ref()
            .clone()
            .try_into::<T>()
            .map_err(|e| self.err(path, Some(item.span().start), e.message().to_string()))
    }

    fn polygon(
        &self,
        path: &str,
        at: Option<usize>,
        mut polygon: Vec<[f64; 2]>,
    ) -> Result<Vec<[f64; 2]>, WorldError> {
        for (k, &p) in polygon.iter().enumerate() {
            self.point(&format!("{path}[{k}]"), at, p)?;
        }
        // A closed ring (first == last) is a common way to write a polygon; store it open.
        if polygon.len() > 3 && polygon.first() == polygon.last() {
            polygon.pop();
        }
        if polygon.len() < 3 {
            return Err(self.err(
                path,
                at,
                format!("a polygon needs at least 3 points, got {}", polygon.len()),
            ));
        }
        if polygon.len() > MAX_POLYGON_POINTS {
            return Err(self.err(
                path,
                at,
                format!(
                    "a polygon may have at most {MAX_POLYGON_POINTS} points \
                     (MAX_POLYGON_POINTS), got {}",
                    polygon.len()
                ),
            ));
        }
        // Self-intersection first: a bow-tie's two lobes cancel in the signed area, and
        // "zero area" would not say why.
        if let Some((i, j)) = polygon_self_intersection(&polygon) {
            return Err(self.err(
                path,
                at,
                format!(
                    "polygon is self-intersecting: edges {i} and {j} cross or touch (edge k \
                     runs from point k to point k + 1); list the corners in order around the \
                     region"
                ),
            ));
        }
        let area = polygon_area(&polygon);
        if area.abs() < MIN_AREA {
            return Err(self.err(path, at, format!("polygon has zero area (got {area} m²)")));
        }
        Ok(polygon)
    }
}

/// The bundled campus world's TOML text (`worlds/campus.toml`).
pub const CAMPUS_TOML: &str = include_str!("../campus.toml");

impl World {
    /// The bundled campus world (see `worlds/campus.toml` for its layout and anchors).
    pub fn campus() -> Result<World, WorldError> {
        World::from_toml_str(CAMPUS_TOML, Path::new("worlds/campus.toml"))
    }

    /// Loads and validates a world file.
    pub fn load(path: &Path) -> Result<World, WorldError> {
        let text = std::fs::read_to_string(path).map_err(|err| WorldError::Io {
            file: path.to_path_buf(),
            err,
        })?;
        World::from_toml_str(&text, path)
    }

    /// Parses and validates a world from TOML text; `file` is used in error messages only.
    pub fn from_toml_str(text: &str, file: &Path) -> Result<World, WorldError> {
        let raw: RawWorld = toml::from_str(text).map_err(|e| WorldError::Parse {
            file: file.to_path_buf(),
            msg: clip_lines(e.to_string().trim_end()),
        })?;
        let ctx = Ctx {
            file,
            text: Some(text),
        };

        let name = raw.name.get_ref().trim().to_string();
        if name.is_empty() {
            return Err(ctx.err("name", Some(raw.name.span().start), "must not be empty"));
        }
        let ceiling_height = ctx.length(
            "ceiling_height",
            Some(raw.ceiling_height.span().start),
            *raw.ceiling_height.get_ref(),
        )?;

        let mut materials = Vec::with_capacity(raw.materials.len());
        for (mname, item) in &raw.materials {
            let path = format!("materials.{mname}");
            let at = Some(item.span().start);
            let m: RawMaterial = ctx.typed(&path, item)?;
            let field = format!("{path}.reflect_within_deg");
            let laser = match (m.laser, m.reflect_within_deg) {
                (LaserKind::Opaque, None) => LaserBehaviour::Opaque,
                (LaserKind::Opaque, Some(_)) => {
                    return Err(ctx.err(field, at, "only valid with laser = \"glass\""));
                }
                (LaserKind::Glass, None) => {
                    return Err(ctx.err(field, at, "required when laser = \"glass\""));
                }
                (LaserKind::Glass, Some(deg)) => {
                    let deg = ctx.finite(&field, at, deg)?;
                    if !(0.0..=90.0).contains(&deg) {
                        return Err(ctx.err(
                            field,
                            at,
                            format!("must be within [0, 90] degrees, got {deg}"),
                        ));
                    }
                    LaserBehaviour::Glass {
                        reflect_within_deg: deg,
                    }
                }
            };
            let wifi_attenuation_db = match m.wifi_attenuation_db {
                None => 0.0,
                Some(db) => crate::wifi::check_attenuation(db)
                    .map_err(|msg| ctx.err(format!("{path}.wifi_attenuation_db"), at, msg))?,
            };
            materials.push(Material {
                name: mname.clone(),
                laser,
                wifi_attenuation_db,
            });
        }

        let material_names: HashSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
        if raw.walls.is_empty() {
            return Err(ctx.err("walls", None, "at least one [[walls]] entry is required"));
        }
        let mut walls = Vec::new();
        for (i, item) in raw.walls.iter().enumerate() {
            let path = format!("walls[{i}]");
            let at = Some(item.span().start);
            let w: RawWall = ctx.typed(&path, item)?;
            if w.points.len() < 2 {
                return Err(ctx.err(
                    format!("{path}.points"),
                    at,
                    format!(
                        "a wall polyline needs at least 2 points, got {}",
                        w.points.len()
                    ),
                ));
            }
            for (k, &p) in w.points.iter().enumerate() {
                ctx.point(&format!("{path}.points[{k}]"), at, p)?;
            }
            let thickness = ctx.length(&format!("{path}.thickness"), at, w.thickness)?;
            let height = match w.height {
                Some(h) => ctx.length(&format!("{path}.height"), at, h)?,
                None => ceiling_height,
            };
            ctx.material_ref(
                &format!("{path}.material"),
                at,
                &w.material,
                (&material_names, &materials),
            )?;
            for (k, pair) in w.points.windows(2).enumerate() {
                let (a, b) = (pair[0], pair[1]);
                if (b[0] - a[0]).hypot(b[1] - a[1]) < MIN_LENGTH {
                    return Err(ctx.err(
                        format!("{path}.points[{}]", k + 1),
                        at,
                        format!(
                            "zero-length wall segment: same point as points[{k}] ([{}, {}])",
                            a[0], a[1]
                        ),
                    ));
                }
                walls.push(Wall {
                    a,
                    b,
                    thickness,
                    height,
                    material: w.material.clone(),
                });
            }
        }

        let mut pillars = Vec::with_capacity(raw.pillars.len());
        for (i, item) in raw.pillars.iter().enumerate() {
            let path = format!("pillars[{i}]");
            let at = Some(item.span().start);
            let p: RawPillar = ctx.typed(&path, item)?;
            let center = ctx.point(&format!("{path}.center"), at, p.center)?;
            let radius = ctx.length(&format!("{path}.radius"), at, p.radius)?;
            let height = match p.height {
                Some(h) => ctx.length(&format!("{path}.height"), at, h)?,
                None => ceiling_height,
            };
            ctx.material_ref(
                &format!("{path}.material"),
                at,
                &p.material,
                (&material_names, &materials),
            )?;
            pillars.push(Pillar {
                center,
                radius,
                height,
                material: p.material,
            });
        }

        let mut regions: Vec<Region> = Vec::with_capacity(raw.regions.len());
        let mut region_index: HashMap<String, usize> = HashMap::new();
        for (i, item) in raw.regions.iter().enumerate() {
            let path = format!("regions[{i}]");
            let at = Some(item.span().start);
            let r: RawRegion = ctx.typed(&path, item)?;
            let rname = r.name.trim().to_string();
            if rname.is_empty() {
                return Err(ctx.err(format!("{path}.name"), at, "must not be empty"));
            }
            if let Some(j) = region_index.insert(rname.clone(), i) {
                return Err(ctx.err(
                    format!("{path}.name"),
                    at,
                    format!("duplicate region name \"{rname}\" (also regions[{j}])"),
                ));
            }
            let polygon = ctx.polygon(&format!("{path}.polygon"), at, r.polygon)?;
            regions.push(Region {
                name: rname,
                kind: r.kind,
                polygon,
            });
        }

        let mut access_points: Vec<AccessPoint> = Vec::with_capacity(raw.access_points.len());
        let mut ap_index: HashMap<String, usize> = HashMap::new();
        for (i, item) in raw.access_points.iter().enumerate() {
            let path = format!("access_points[{i}]");
            let at = Some(item.span().start);
            let mut ap: AccessPoint = ctx.typed(&path, item)?;
            ap.name = ap.name.trim().to_string();
            ap.validate(ceiling_height)
                .map_err(|(key, msg)| ctx.err(format!("{path}.{key}"), at, msg))?;
            if let Some(j) = ap_index.insert(ap.name.clone(), i) {
                return Err(ctx.err(
                    format!("{path}.name"),
                    at,
                    format!(
                        "duplicate access point name \"{}\" (also access_points[{j}])",
                        ap.name
                    ),
                ));
            }
            access_points.push(ap);
        }
        let wifi = match &raw.wifi {
            None => WifiEnvironment::default(),
            Some(item) => {
                let at = Some(item.span().start);
                let env: WifiEnvironment = ctx.typed("wifi", item)?;
                env.validate()
                    .map_err(|(field, msg)| ctx.err(field, at, msg))?;
                env
            }
        };

        let mut boxes = Vec::with_capacity(raw.boxes.len());
        for (i, item) in raw.boxes.iter().enumerate() {
            let path = format!("boxes[{i}]");
            let at = Some(item.span().start);
            let b: crate::furniture::FurnitureBox = ctx.typed(&path, item)?;
            b.validate(ceiling_height)
                .map_err(|(key, msg)| ctx.err(format!("{path}.{key}"), at, msg))?;
            ctx.material_ref(
                &format!("{path}.material"),
                at,
                &b.material,
                (&material_names, &materials),
            )?;
            boxes.push(b);
        }

        let mut lighting = crate::lighting::Lighting::default();
        for (i, item) in raw.lights.iter().enumerate() {
            let path = format!("lights[{i}]");
            let at = Some(item.span().start);
            let l: crate::lighting::Light = ctx.typed(&path, item)?;
            l.validate(ceiling_height)
                .map_err(|(key, msg)| ctx.err(format!("{path}.{key}"), at, msg))?;
            lighting.lights.push(l);
        }
        for (sname, item) in &raw.surfaces {
            let path = format!("surfaces.{sname}");
            let at = Some(item.span().start);
            if sname != "floor" && sname != "ceiling" {
                ctx.material_ref(&path, at, sname, (&material_names, &materials))?;
            }
            let s: crate::lighting::Surface = ctx.typed(&path, item)?;
            s.validate()
                .map_err(|(key, msg)| ctx.err(format!("{path}.{key}"), at, msg))?;
            lighting.surfaces.insert(sname.clone(), s);
        }

        Ok(World {
            name,
            ceiling_height,
            materials,
            walls,
            pillars,
            regions,
            access_points,
            wifi,
            boxes,
            lighting,
        })
    }

    /// Checks a world built in code (generators, tests) by the same rules as the loader.
    /// Field paths index the expanded `walls` (one per segment). `origin` names the world in
    /// messages, e.g. the generator that made it.
    pub fn validate(&self, origin: &Path) -> Result<(), WorldError> {
        let ctx = Ctx {
            file: origin,
            text: None,
        };
        if self.name.trim().is_empty() {
            return Err(ctx.err("name", None, "must not be empty"));
        }
        ctx.length("ceiling_height", None, self.ceiling_height)?;
        let mut material_names: HashSet<&str> = HashSet::new();
        for (i, m) in self.materials.iter().enumerate() {
            if !material_names.insert(m.name.as_str()) {
                return Err(ctx.err(
                    format!("materials[{i}].name"),
                    None,
                    format!("duplicate material name \"{}\"", m.name),
                ));
            }
            crate::wifi::check_attenuation(m.wifi_attenuation_db).map_err(|msg| {
                ctx.err(
                    format!("materials.{}.wifi_attenuation_db", m.name),
                    None,
                    msg,
                )
            })?;
            if let LaserBehaviour::Glass { reflect_within_deg } = m.laser {
                let field = format!("materials.{}.reflect_within_deg", m.name);
                let deg = ctx.finite(&field, None, reflect_within_deg)?;
                if !(0.0..=90.0).contains(&deg) {
                    return Err(ctx.err(
                        field,
                        None,
                        format!("must be within [0, 90] degrees, got {deg}"),
                    ));
                }
            }
        }
        if self.walls.is_empty() {
            return Err(ctx.err("walls", None, "at least one wall is required"));
        }
        for (i, w) in self.walls.iter().enumerate() {
            let path = format!("walls[{i}]");
            ctx.point(&format!("{path}.a"), None, w.a)?;
            ctx.point(&format!("{path}.b"), None, w.b)?;
            if (w.b[0] - w.a[0]).hypot(w.b[1] - w.a[1]) < MIN_LENGTH {
                return Err(ctx.err(path, None, "zero-length wall: a == b"));
            }
            ctx.length(&format!("{path}.thickness"), None, w.thickness)?;
            ctx.length(&format!("{path}.height"), None, w.height)?;
            ctx.material_ref(
                &format!("{path}.material"),
                None,
                &w.material,
                (&material_names, &self.materials),
            )?;
        }
        for (i, p) in self.pillars.iter().enumerate() {
            let path = format!("pillars[{i}]");
            ctx.point(&format!("{path}.center"), None, p.center)?;
            ctx.length(&format!("{path}.radius"), None, p.radius)?;
            ctx.length(&format!("{path}.height"), None, p.height)?;
            ctx.material_ref(
                &format!("{path}.material"),
                None,
                &p.material,
                (&material_names, &self.materials),
            )?;
        }
        let mut ap_index: HashMap<&str, usize> = HashMap::new();
        for (i, ap) in self.access_points.iter().enumerate() {
            let path = format!("access_points[{i}]");
            ap.validate(self.ceiling_height)
                .map_err(|(key, msg)| ctx.err(format!("{path}.{key}"), None, msg))?;
            if let Some(j) = ap_index.insert(ap.name.as_str(), i) {
                return Err(ctx.err(
                    format!("{path}.name"),
                    None,
                    format!(
                        "duplicate access point name \"{}\" (also access_points[{j}])",
                        ap.name
                    ),
                ));
            }
        }
        self.wifi
            .validate()
            .map_err(|(field, msg)| ctx.err(field, None, msg))?;
        for (i, b) in self.boxes.iter().enumerate() {
            let path = format!("boxes[{i}]");
            b.validate(self.ceiling_height)
                .map_err(|(key, msg)| ctx.err(format!("{path}.{key}"), None, msg))?;
            ctx.material_ref(
                &format!("{path}.material"),
                None,
                &b.material,
                (&material_names, &self.materials),
            )?;
        }
        let mut region_index: HashMap<&str, usize> = HashMap::new();
        for (i, r) in self.regions.iter().enumerate() {
            let path = format!("regions[{i}]");
            if r.name.trim().is_empty() {
                return Err(ctx.err(format!("{path}.name"), None, "must not be empty"));
            }
            if let Some(j) = region_index.insert(r.name.as_str(), i) {
                return Err(ctx.err(
                    format!("{path}.name"),
                    None,
                    format!("duplicate region name \"{}\" (also regions[{j}])", r.name),
                ));
            }
            let polygon = ctx.polygon(&format!("{path}.polygon"), None, r.polygon.clone())?;
            if polygon.len() != r.polygon.len() {
                return Err(ctx.err(
                    format!("{path}.polygon"),
                    None,
                    "must not repeat its first point at the end",
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small valid world; each test breaks one tagged line.
    const BASE: &str = r#"name = "t"
ceiling_height = 3.0 # ceiling
[materials.concrete]
laser = "opaque"
[materials.drywall]
laser = "opaque"
[materials.glass]
laser = "glass"
reflect_within_deg = 5.0 # deg
[[walls]]
points = [[0.0, 0.0], [10.0, 0.0], [10.0, 8.0]] # w0 points
thickness = 0.3
material = "concrete"
[[walls]]
points = [[0.0, 8.0], [10.0, 8.0]]
thickness = 0.1
height = 2.5 # w1 height
material = "drywall"
[[walls]]
points = [[0.0, 0.0], [0.0, 8.0]]
thickness = 0.05
material = "glass" # w2 material
[[walls]]
points = [[5.0, 0.0], [5.0, 3.0]]
thickness = 0.1 # w3 thickness
material = "drywall"
[[pillars]]
center = [7.0, 5.0]
radius = 0.3 # p0 radius
material = "concrete"
[[regions]]
name = "west"
kind = "room"
polygon = [[0.0, 0.0], [5.0, 0.0], [5.0, 8.0], [0.0, 8.0], [0.0, 0.0]] # r0 polygon
[[regions]]
name = "east" # r1 name
kind = "corridor" # r1 kind
polygon = [[5.0, 0.0], [10.0, 0.0], [10.0, 8.0], [5.0, 8.0]]
"#;

    fn load(text: &str) -> Result<World, WorldError> {
        World::from_toml_str(text, Path::new("test.toml"))
    }

    /// The error message after replacing the tagged line containing `tag` by `line`.
    fn error_with(tag: &str, line: &str) -> String {
        let hits = BASE.lines().filter(|l| l.contains(tag)).count();
        assert_eq!(hits, 1, "tag {tag:?} must match one line");
        let text: String = BASE
            .lines()
            .map(|l| if l.contains(tag) { line } else { l })
            .collect::<Vec<_>>()
            .join("\n");
        match load(&text) {
            Ok(_) => panic!("expected an error after {tag:?} -> {line:?}"),
            Err(e) => e.to_string(),
        }
    }

    #[test]
    fn base_world_loads_and_expands_polylines() {
        let w = load(BASE).unwrap();
        assert_eq!(w.name, "t");
        assert_eq!(w.walls.len(), 5, "3-point polyline gives 2 walls");
        assert_eq!(w.walls[0].a, [0.0, 0.0]);
        assert_eq!(w.walls[0].b, [10.0, 0.0]);
        assert_eq!(w.walls[1].a, [10.0, 0.0]);
        assert_eq!(w.walls[1].b, [10.0, 8.0]);
        assert_eq!(w.walls[0].height, 3.0, "height defaults to the ceiling");
        assert_eq!(w.walls[2].height, 2.5);
        assert_eq!(w.pillars[0].height, 3.0);
        let names: Vec<&str> = w.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(names, ["concrete", "drywall", "glass"]);
        assert_eq!(
            w.material("glass").unwrap().laser,
            LaserBehaviour::Glass {
                reflect_within_deg: 5.0
            }
        );
        assert_eq!(w.regions[0].polygon.len(), 4, "closing point dropped");
        assert_eq!(w.regions[1].kind, RegionKind::Corridor);
        w.validate(Path::new("test.toml")).unwrap();
    }

    #[test]
    fn numbers_out_of_range() {
        assert_eq!(
            error_with("# w3 thickness", "thickness = -0.1"),
            "test.toml: walls[3].thickness: must be > 0, got -0.1 (entry at line 23)"
        );
        assert_eq!(
            error_with("# w3 thickness", "thickness = nan"),
            "test.toml: walls[3].thickness: must be a finite number, got NaN (entry at line 23)"
        );
        assert_eq!(
            error_with("# w1 height", "height = 0"),
            "test.toml: walls[1].height: must be > 0, got 0 (entry at line 14)"
        );
        assert_eq!(
            error_with("# w1 height", "height = -inf"),
            "test.toml: walls[1].height: must be a finite number, got -inf (entry at line 14)"
        );
        assert_eq!(
            error_with("# p0 radius", "radius = 0.0"),
            "test.toml: pillars[0].radius: must be > 0, got 0 (entry at line 27)"
        );
        assert_eq!(
            error_with("# ceiling", "ceiling_height = 0.0"),
            "test.toml: ceiling_height: must be > 0, got 0 (line 2)"
        );
        assert_eq!(
            error_with("# ceiling", "ceiling_height = nan"),
            "test.toml: ceiling_height: must be a finite number, got NaN (line 2)"
        );
        assert_eq!(
            error_with("# w0 points", "points = [[0.0, 0.0], [inf, 0.0]]"),
            "test.toml: walls[0].points[1]: coordinates must be finite numbers, got [inf, 0] \
             (entry at line 10)"
        );
        assert_eq!(
            error_with("# deg", "reflect_within_deg = 95.0"),
            "test.toml: materials.glass.reflect_within_deg: must be within [0, 90] degrees, \
             got 95 (entry at line 7)"
        );
    }

    #[test]
    fn wall_geometry_errors() {
        assert_eq!(
            error_with(
                "# w0 points",
                "points = [[0.0, 0.0], [10.0, 0.0], [10.0, 0.0]]"
            ),
            "test.toml: walls[0].points[2]: zero-length wall segment: same point as points[1] \
             ([10, 0]) (entry at line 10)"
        );
        assert_eq!(
            error_with("# w0 points", "points = [[0.0, 0.0]]"),
            "test.toml: walls[0].points: a wall polyline needs at least 2 points, got 1 \
             (entry at line 10)"
        );
        let no_walls: String = BASE.split("[[walls]]").next().unwrap().to_string();
        assert_eq!(
            load(&no_walls).unwrap_err().to_string(),
            "test.toml: walls: at least one [[walls]] entry is required"
        );
    }

    #[test]
    fn material_errors() {
        assert_eq!(
            error_with("# w2 material", "material = \"brick\""),
            "test.toml: walls[2].material: unknown material \"brick\" \
             (known: concrete, drywall, glass) (entry at line 19)"
        );
        assert_eq!(
            error_with("# deg", ""),
            "test.toml: materials.glass.reflect_within_deg: required when laser = \"glass\" \
             (entry at line 7)"
        );
        let e = load(&BASE.replace(
            "[materials.drywall]\nlaser = \"opaque\"",
            "[materials.drywall]\nlaser = \"opaque\"\nreflect_within_deg = 3.0",
        ))
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "test.toml: materials.drywall.reflect_within_deg: only valid with laser = \"glass\" \
             (entry at line 5)"
        );
        let e = load(&BASE.replace("laser = \"glass\"", "laser = \"mirror\"")).unwrap_err();
        let e = e.to_string();
        assert!(
            e.starts_with("test.toml: materials.glass: unknown variant `mirror`"),
            "{e}"
        );
        assert!(e.contains("`opaque`") && e.contains("`glass`"), "{e}");
    }

    #[test]
    fn region_errors() {
        assert_eq!(
            error_with("# r0 polygon", "polygon = [[0.0, 0.0], [5.0, 0.0]]"),
            "test.toml: regions[0].polygon: a polygon needs at least 3 points, got 2 (entry at line 31)"
        );
        assert_eq!(
            error_with(
                "# r0 polygon",
                "polygon = [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]"
            ),
            "test.toml: regions[0].polygon: polygon has zero area (got 0 m²) (entry at line 31)"
        );
        assert_eq!(
            error_with(
                "# r0 polygon",
                "polygon = [[0.0, 0.0], [4.0, 2.0], [4.0, 0.0], [0.0, 3.0]]"
            ),
            "test.toml: regions[0].polygon: polygon is self-intersecting: edges 0 and 2 cross \
             or touch (edge k runs from point k to point k + 1); list the corners in order \
             around the region (entry at line 31)"
        );
        assert_eq!(
            error_with(
                "# r0 polygon",
                "polygon = [[0.0, 0.0], [5.0, nan], [5.0, 8.0]]"
            ),
            "test.toml: regions[0].polygon[1]: coordinates must be finite numbers, got [5, NaN] \
             (entry at line 31)"
        );
        assert_eq!(
            error_with("# r1 name", "name = \"west\""),
            "test.toml: regions[1].name: duplicate region name \"west\" (also regions[0]) \
             (entry at line 35)"
        );
        let e = error_with("# r1 kind", "kind = \"lobby\"");
        assert!(
            e.starts_with("test.toml: regions[1]: unknown variant `lobby`"),
            "{e}"
        );
        assert!(
            e.contains("`glass_corridor`") && e.ends_with("(entry at line 35)"),
            "{e}"
        );
    }

    #[test]
    fn misspelt_and_mistyped_keys_are_named() {
        let e = error_with("# w3 thickness", "thicknes = 0.1");
        assert!(
            e.starts_with("test.toml: walls[3]: unknown field `thicknes`"),
            "{e}"
        );
        let e = error_with("# ceiling", "ceilng_height = 3.0");
        assert!(e.starts_with("test.toml: malformed TOML:"), "{e}");
        assert!(e.contains("ceilng_height"), "{e}");
        let e = error_with("# w3 thickness", "thickness = \"thick\"");
        assert!(
            e.starts_with("test.toml: walls[3]: invalid type: string \"thick\""),
            "{e}"
        );
        let e = error_with("# ceiling", "ceiling_height = = 3");
        assert!(
            e.starts_with("test.toml: malformed TOML:") && e.contains("line 2"),
            "{e}"
        );
    }

    #[test]
    fn load_reports_missing_file() {
        let e = World::load(Path::new("/nonexistent/dir/w.toml")).unwrap_err();
        assert!(matches!(e, WorldError::Io { .. }));
        assert!(e
            .to_string()
            .starts_with("/nonexistent/dir/w.toml: cannot read file"));
    }

    #[test]
    fn validate_checks_worlds_built_in_code() {
        let mut w = load(BASE).unwrap();
        w.walls[4].thickness = f64::NAN;
        assert_eq!(
            w.validate(Path::new("<gen>")).unwrap_err().to_string(),
            "<gen>: walls[4].thickness: must be a finite number, got NaN"
        );
        let mut w = load(BASE).unwrap();
        w.pillars[0].material = "wood".into();
        assert_eq!(
            w.validate(Path::new("<gen>")).unwrap_err().to_string(),
            "<gen>: pillars[0].material: unknown material \"wood\" \
             (known: concrete, drywall, glass)"
        );
        let mut w = load(BASE).unwrap();
        w.walls[0].b = w.walls[0].a;
        assert!(w.validate(Path::new("<gen>")).is_err());
    }

    #[test]
    fn bow_tie_region_is_reported_as_self_intersecting() {
        // Its two lobes cancel in the signed area: this used to say "zero area".
        let e = error_with(
            "# r0 polygon",
            "polygon = [[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]]",
        );
        assert!(
            e.starts_with(
                "test.toml: regions[0].polygon: polygon is self-intersecting: edges 0 and 2"
            ),
            "{e}"
        );
        assert!(!e.contains("zero area"), "{e}");
        // Built in code: the same.
        let mut w = load(BASE).unwrap();
        w.regions[1].polygon = vec![[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]];
        let e = w.validate(Path::new("<gen>")).unwrap_err().to_string();
        assert!(
            e.contains("regions[1].polygon: polygon is self-intersecting"),
            "{e}"
        );
    }

    #[test]
    fn absurd_coordinates_and_sizes_are_refused_naming_the_field() {
        let limit = "must be within ±10000 m (MAX_COORDINATE_M)";
        let cases: &[(&str, &str, &str)] = &[
            (
                "# w0 points",
                "points = [[0.0, 0.0], [1e300, 0.0]]",
                "walls[0].points[1]",
            ),
            (
                "# w0 points",
                "points = [[0.0, -1e5], [1.0, 0.0]]",
                "walls[0].points[0]",
            ),
            (
                "# r0 polygon",
                "polygon = [[0.0, 0.0], [1e300, 0.0], [1e300, 1e300]]",
                "regions[0].polygon[1]",
            ),
        ];
        for (tag, line, field) in cases {
            let e = error_with(tag, line);
            assert!(
                e.starts_with(&format!("test.toml: {field}: coordinates {limit}")),
                "{e}"
            );
        }
        let sizes: &[(&str, &str, &str)] = &[
            ("# w3 thickness", "thickness = 1e300", "walls[3].thickness"),
            ("# w1 height", "height = 2e4", "walls[1].height"),
            ("# p0 radius", "radius = 1e300", "pillars[0].radius"),
            ("# ceiling", "ceiling_height = 1e300", "ceiling_height"),
        ];
        let e = error_with("# p0 radius", "radius = 5e-324");
        assert_eq!(
            e,
            "test.toml: pillars[0].radius: must be at least 0.001 m (MIN_SIZE_M), got 5e-324 \
             (entry at line 27)"
        );
        for (tag, line, field) in sizes {
            let e = error_with(tag, line);
            assert!(
                e.starts_with(&format!(
                    "test.toml: {field}: must be at most 10000 m (MAX_COORDINATE_M)"
                )),
                "{e}"
            );
        }
        // Tables validated by their own types: pillars, boxes, access points, lights.
        let extra: &[(&str, &str)] = &[
            (
                "[[pillars]]\ncenter = [1e300, 5.0]\nradius = 0.3\nmaterial = \"concrete\"\n",
                "pillars[1].center: coordinates must be within",
            ),
            (
                "[[boxes]]\ncenter = [1.0, -1e300]\nsize = [1.0, 1.0, 1.0]\nmaterial = \"concrete\"\n",
                "boxes[0].center: coordinates must be within",
            ),
            (
                "[[boxes]]\ncenter = [1.0, 1.0]\nsize = [1e300, 1.0, 1.0]\nmaterial = \"concrete\"\n",
                "boxes[0].size: size[0] must be at most 10000 m",
            ),
            (
                "[[access_points]]\nname = \"a\"\nposition = [1e300, 1.0, 2.0]\ntx_power_dbm = -40.0\n\
                 path_loss_exponent = 2.5\nchannel = 1\n",
                "access_points[0].position: coordinates must be within",
            ),
            (
                "[[lights]]\nkind = \"bulb\"\nfrom = [1e300, 1.0, 2.0]\n",
                "lights[0].from: coordinates must be within",
            ),
            (
                "[[lights]]\nkind = \"tube\"\nfrom = [1.0, 1.0, 2.0]\nto = [1.0, 1e300, 2.0]\n",
                "lights[0].to: coordinates must be within",
            ),
        ];
        for (table, expected) in extra {
            let e = load(&format!("{BASE}{table}")).unwrap_err().to_string();
            assert!(e.starts_with(&format!("test.toml: {expected}")), "{e}");
            assert!(e.contains("MAX_COORDINATE_M"), "{e}");
        }
        // Built in code: the same limits.
        let mut w = load(BASE).unwrap();
        w.walls[2].b = [1e300, 8.0];
        let e = w.validate(Path::new("<gen>")).unwrap_err().to_string();
        assert!(
            e.starts_with("<gen>: walls[2].b: coordinates must be within"),
            "{e}"
        );
        // Up to the limit is fine.
        let far = BASE.replace("[5.0, 0.0], [5.0, 3.0]", "[5.0, 0.0], [5.0, -10000.0]");
        assert!(load(&far).is_ok());
    }

    #[test]
    fn polygon_corner_count_is_bounded() {
        // A circle of MAX_POLYGON_POINTS + 1 corners: simple, but too many to check cheaply.
        let n = MAX_POLYGON_POINTS + 1;
        let corners: Vec<String> = (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                format!("[{}, {}]", 5.0 + 2.0 * a.cos(), 4.0 + 2.0 * a.sin())
            })
            .collect();
        let e = error_with(
            "# r0 polygon",
            &format!("polygon = [{}]", corners.join(", ")),
        );
        assert!(
            e.starts_with("test.toml: regions[0].polygon: a polygon may have at most 1000 points"),
            "{e}"
        );
        let ok: Vec<String> = corners[..MAX_POLYGON_POINTS].to_vec();
        let text = BASE.replace(
            "polygon = [[0.0, 0.0], [5.0, 0.0], [5.0, 8.0], [0.0, 8.0], [0.0, 0.0]] # r0 polygon",
            &format!("polygon = [{}]", ok.join(", ")),
        );
        assert!(load(&text).is_ok());
    }

    #[test]
    fn parse_errors_do_not_echo_megabyte_lines() {
        let text = format!(
            "name = \"x\"\nceiling_height = 3.0\nfoo = {}1{}\n",
            "[".repeat(100_000),
            "]".repeat(100_000)
        );
        let e = load(&text).unwrap_err().to_string();
        assert!(e.starts_with("test.toml: malformed TOML:"), "{e}");
        assert!(e.len() < 2_000, "{} bytes", e.len());
        assert!(
            e.lines().all(|l| l.chars().count() <= MAX_MESSAGE_LINE + 1),
            "{e}"
        );
    }

    #[test]
    fn many_regions_and_materials_load() {
        // 20,000 regions and 20,000 materials with a wall each: the duplicate and material
        // look-ups (linear searches once, quadratic in all) are hash look-ups now.
        let n = 20_000;
        let mut text = String::from("name = \"big\"\nceiling_height = 3.0\n");
        for k in 0..n {
            text.push_str(&format!("[materials.m{k}]\nlaser = \"opaque\"\n"));
        }
        for k in 0..n {
            let (y, y2) = (0.25 * k as f64, 0.25 * k as f64 + 0.1);
            text.push_str(&format!(
                "[[walls]]\npoints = [[0.0, {y}], [1.0, {y}]]\nthickness = 0.1\nmaterial = \"m{k}\"\n\
                 [[regions]]\nname = \"r{k}\"\nkind = \"room\"\npolygon = [[0.0, {y}], [1.0, {y}], [1.0, {y2}]]\n"
            ));
        }
        let w = load(&text).unwrap();
        assert_eq!(
            (w.walls.len(), w.regions.len(), w.materials.len()),
            (n, n, n)
        );
        w.validate(Path::new("<big>")).unwrap();
        let dup = text.replacen("name = \"r7\"", "name = \"r3\"", 1);
        let e = load(&dup).unwrap_err().to_string();
        assert!(
            e.contains("regions[7].name: duplicate region name \"r3\" (also regions[3])"),
            "{e}"
        );
    }
}
