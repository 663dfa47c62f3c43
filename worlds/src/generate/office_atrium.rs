//! `office_atrium`: an office wing (one straight corridor with rooms on both sides) opening
//! into an atrium hall with pillars, some corridor and atrium walls of glass, unmapped
//! furniture clutter, ceiling WiFi access points and lights.
//!
//! ```text
//!   y=floor_width +----+------+-----+----+
//!                 | n1 |  n2  | n3  | n4 |----------------------+ y = yc + atrium_width/2
//!                 |    |      |     |    |    atrium             |
//!   yc+cw/2       +-d--+--d---+---d-+-d--+    o      o      o    |
//!                 | corridor_1 ... corridor_4  ->                |   (o: pillars)
//!   yc-cw/2       +--d-+----d-+-d---+--d-+    o      o      o    |
//!                 | s1 |  s2  | s3  | s4 |                       |
//!                 |    |      |     |    |-----------------------+ y = yc - atrium_width/2
//!   y=0           +----+------+-----+----+
//!                 x=0             x=corridor_length    x=corridor_length+atrium_length
//! ```
//!
//! Every dimension is between wall centre lines (as regions are drawn), so a corridor of
//! `corridor_width` 2 m has 1.9 m clear between its drywall faces. The corridor runs along
//! y = yc = floor_width / 2; rooms fill the wing from the corridor to the outer walls, so
//! room depth is (floor_width − corridor_width) / 2. The atrium is centred on the corridor
//! axis and may be narrower than the wing (the building's outline then steps in).
//!
//! | parameter | default | meaning |
//! |---|---|---|
//! | `name` | `"generated_office"` | the world's name |
//! | `seed` | 1 | room widths, doors, glass panels, clutter; also the WiFi shadow-field seed |
//! | `ceiling_height` | 3.0 | m, in [2, 20] |
//! | `floor_width` | 20.0 | m, width (y) of the office wing; at least corridor_width + 4 |
//! | `corridor_length` | 30.0 | m, from the west wall to the atrium, in [2, 1000] |
//! | `corridor_width` | 2.0 | m, in [1, 100] |
//! | `room_count` | 5 | rooms per side of the corridor (0: none, no doors) |
//! | `room_width_jitter` | 0.2 | relative spread of room widths, in [0, 0.5] (asymmetry helps global localization) |
//! | `door_width` | 1.0 | m, gaps in the corridor walls, one per room, in [0.6, 10] |
//! | `atrium_length` | 20.0 | m, along x, in [2, 1000] |
//! | `atrium_width` | 16.0 | m, along y, from corridor_width to floor_width |
//! | `pillar_spacing` | 6.0 | m, pillar grid in the atrium, symmetric about its centre lines (none on them); 0: no pillars |
//! | `pillar_radius` | 0.3 | m, in (0, 2] |
//! | `glass_fraction` | 0.3 | share of the length of corridor and atrium walls made of glass, in [0, 1] |
//! | `clutter_density` | 2.0 | furniture boxes per 100 m² of room and atrium floor (corridors and the atrium's aisle on the corridor axis stay clear); 0: none |
//! | `ap_spacing` | 10.0 | m, square grid of ceiling access points, one row on the corridor axis; 0: none |
//!
//! Glass is chosen in units (a corridor section alongside one room pair, both walls; or a
//! 4 m stretch of an atrium wall), whole units in a seeded order until the next one would
//! overshoot, which is glazed in part: the glass length is `glass_fraction` of the candidate
//! length up to panel rounding (1 cm). A corridor section with at least half its wall length
//! in glass is labelled `glass_corridor`.
//!
//! Regions: `corridor_<i>` (kind `corridor` or `glass_corridor`, i from 1 at the west end),
//! `atrium`, and `room_n<i>` / `room_s<i>` (north and south of the corridor). The furniture
//! is `[[boxes]]`: solid and seen by sensors but not in the maps a localizer is given.

use serde::{Deserialize, Serialize};
use std::fmt::Write;

use super::kind::{ParamError, WorldGenerator};
use super::rng::Stream;

/// The parameters of the `office_atrium` generator (see the module documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct GeneratorParams {
    pub name: String,
    pub seed: u64,
    pub ceiling_height: f64,
    pub floor_width: f64,
    pub corridor_length: f64,
    pub corridor_width: f64,
    pub room_count: u32,
    pub room_width_jitter: f64,
    pub door_width: f64,
    pub atrium_length: f64,
    pub atrium_width: f64,
    pub pillar_spacing: f64,
    pub pillar_radius: f64,
    pub glass_fraction: f64,
    pub clutter_density: f64,
    pub ap_spacing: f64,
}

impl Default for GeneratorParams {
    fn default() -> Self {
        Self {
            name: "generated_office".into(),
            seed: 1,
            ceiling_height: 3.0,
            floor_width: 20.0,
            corridor_length: 30.0,
            corridor_width: 2.0,
            room_count: 5,
            room_width_jitter: 0.2,
            door_width: 1.0,
            atrium_length: 20.0,
            atrium_width: 16.0,
            pillar_spacing: 6.0,
            pillar_radius: 0.3,
            glass_fraction: 0.3,
            clutter_density: 2.0,
            ap_spacing: 10.0,
        }
    }
}

/// The `office_atrium` kind for a [`GeneratorRegistry`](crate::GeneratorRegistry).
pub struct OfficeAtrium;

impl WorldGenerator for OfficeAtrium {
    fn defaults(&self) -> toml::Table {
        toml::Table::try_from(GeneratorParams::default()).expect("plain struct")
    }

    fn generate_toml(&self, params: &toml::Table) -> Result<String, ParamError> {
        generate(&typed(params)?)
    }
}

/// `params` as [`GeneratorParams`]; a value of the wrong type is reported under its own key
/// (serde's error for the whole table would not say which).
fn typed(params: &toml::Table) -> Result<GeneratorParams, ParamError> {
    toml::Value::Table(params.clone())
        .try_into::<GeneratorParams>()
        .map_err(|e| {
            params
                .iter()
                .find_map(|(key, value)| {
                    let mut one = toml::Table::new();
                    one.insert(key.clone(), value.clone());
                    toml::Value::Table(one)
                        .try_into::<GeneratorParams>()
                        .err()
                        .map(|e| ParamError::new(key.clone(), e.message().to_string()))
                })
                .unwrap_or_else(|| ParamError::new("generator", e.message().to_string()))
        })
}

// Wall thicknesses (m): outer concrete, interior drywall, glass (as in the bundled campus).
const T_OUTER: f64 = 0.3;
const T_INNER: f64 = 0.1;
const T_GLASS: f64 = 0.05;
/// Closest a door comes to a room partition, m.
const DOOR_MARGIN: f64 = 0.4;
const MIN_ROOM_DEPTH: f64 = 2.0;
/// Largest length along x or y (m): well inside the loader's 10 km coordinate limit.
const MAX_EXTENT: f64 = 1000.0;
const MAX_ROOMS: u32 = 500;
const MAX_PILLARS: usize = 10_000;
const MAX_APS: usize = 1000;
const MAX_CLUTTER: usize = 5000;
/// Length of one atrium-wall glass unit, m.
const ATRIUM_UNIT: f64 = 4.0;
/// Corridor sections when there are no rooms to define them, m.
const BARE_SECTION: f64 = 6.0;
/// Pillars keep this far (plus their radius) from the atrium's wall centre lines, m.
const PILLAR_MARGIN: f64 = 1.0;
/// Share of the floor that clutter may cover at most: beyond it a room is a store room and
/// rejection sampling fails more often than not.
const MAX_CLUTTER_COVER: f64 = 0.3;
/// Gap kept between clutter and walls, other clutter and pillars, m.
const CLUTTER_GAP: f64 = 0.3;
const CLUTTER_TRIES: usize = 200;

/// Furniture: (what, length, depth, height) in m.
const FURNITURE: [(&str, f64, f64, f64); 6] = [
    ("desk", 1.6, 0.8, 0.75),
    ("cabinet", 0.9, 0.45, 1.8),
    ("chair", 0.5, 0.5, 0.9),
    ("shelf", 1.2, 0.4, 1.9),
    ("plant", 0.5, 0.5, 1.2),
    ("bench", 1.8, 0.5, 0.45),
];

fn mean_footprint() -> f64 {
    FURNITURE.iter().map(|f| f.1 * f.2).sum::<f64>() / FURNITURE.len() as f64
}

fn finite(name: &str, v: f64) -> Result<f64, ParamError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ParamError::new(
            name,
            format!("must be a finite number, got {v}"),
        ))
    }
}

/// Finite and within [lo, hi] (metres unless said otherwise); "> 0" is said first for a
/// negative or zero size, the commonest mistake.
fn within(name: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<f64, ParamError> {
    let v = finite(name, v)?;
    if lo > 0.0 && v <= 0.0 {
        return Err(ParamError::new(name, format!("must be > 0, got {v}")));
    }
    if !(lo..=hi).contains(&v) {
        return Err(ParamError::new(
            name,
            format!("must be within [{lo}, {hi}]{unit}, got {v}"),
        ));
    }
    Ok(v)
}

/// Checks every parameter, naming the one that cannot make a world.
pub fn validate(p: &GeneratorParams) -> Result<(), ParamError> {
    if p.name.trim().is_empty() {
        return Err(ParamError::new("name", "must not be empty"));
    }
    // The name goes into the world file's header comment and its `name` line: a line break
    // or control character there broke the file, reported as a bug in the generator.
    if let Some(c) = p.name.chars().find(|c| c.is_control()) {
        return Err(ParamError::new(
            "name",
            format!(
                "must be one line of text without control characters, got {:?} (holds {c:?})",
                p.name
            ),
        ));
    }
    if p.name.len() > 200 {
        return Err(ParamError::new(
            "name",
            format!("must be at most 200 bytes, got {}", p.name.len()),
        ));
    }
    within("ceiling_height", p.ceiling_height, 2.0, 20.0, " m")?;
    let cw = within("corridor_width", p.corridor_width, 1.0, 100.0, " m")?;
    within("corridor_length", p.corridor_length, 2.0, MAX_EXTENT, " m")?;
    let w = within("floor_width", p.floor_width, 1.0, MAX_EXTENT, " m")?;
    if w < cw + 2.0 * MIN_ROOM_DEPTH {
        return Err(ParamError::new(
            "floor_width",
            format!(
                "{w} m is too narrow for the corridor (corridor_width = {cw} m) and rooms at \
                 least {MIN_ROOM_DEPTH} m deep on both sides: needs at least {} m",
                cw + 2.0 * MIN_ROOM_DEPTH
            ),
        ));
    }
    within("atrium_length", p.atrium_length, 2.0, MAX_EXTENT, " m")?;
    let aw = within("atrium_width", p.atrium_width, 1.0, MAX_EXTENT, " m")?;
    if aw > w {
        return Err(ParamError::new(
            "atrium_width",
            format!("{aw} m is wider than the floor (floor_width = {w} m)"),
        ));
    }
    if aw < cw {
        return Err(ParamError::new(
            "atrium_width",
            format!(
                "{aw} m is narrower than the corridor that opens into it (corridor_width = \
                 {cw} m)"
            ),
        ));
    }
    let jitter = finite("room_width_jitter", p.room_width_jitter)?;
    if !(0.0..=0.5).contains(&jitter) {
        return Err(ParamError::new(
            "room_width_jitter",
            format!("must be within [0, 0.5], got {jitter}"),
        ));
    }
    let dw = within("door_width", p.door_width, 0.6, 10.0, " m")?;
    if p.room_count > MAX_ROOMS {
        return Err(ParamError::new(
            "room_count",
            format!("must be at most {MAX_ROOMS} per side, got {}", p.room_count),
        ));
    }
    if p.room_count > 0 {
        let base = p.corridor_length / f64::from(p.room_count);
        // The narrowest a room can come out after jitter and rescaling to the corridor.
        let narrowest = base * (1.0 - jitter) / (1.0 + jitter);
        let need = dw + 2.0 * DOOR_MARGIN;
        if narrowest < need {
            return Err(ParamError::new(
                "room_count",
                format!(
                    "{} rooms per side along {} m of corridor can be as narrow as {:.2} m \
                     (room_width_jitter = {jitter}), too narrow for a door (door_width = {dw} \
                     m, plus {DOOR_MARGIN} m each side = {need} m); use fewer rooms",
                    p.room_count, p.corridor_length, narrowest
                ),
            ));
        }
    }
    let r = within("pillar_radius", p.pillar_radius, 0.01, 2.0, " m")?;
    let s = finite("pillar_spacing", p.pillar_spacing)?;
    if s < 0.0 {
        return Err(ParamError::new(
            "pillar_spacing",
            format!("must be >= 0 (0: no pillars), got {s}"),
        ));
    }
    if s > 0.0 && s < 2.0 * r + 1.0 {
        return Err(ParamError::new(
            "pillar_spacing",
            format!(
                "must be 0 (no pillars) or at least 2 × pillar_radius + 1 m = {} m so a \
                 robot fits between pillars, got {s}",
                2.0 * r + 1.0
            ),
        ));
    }
    let g = finite("glass_fraction", p.glass_fraction)?;
    if !(0.0..=1.0).contains(&g) {
        return Err(ParamError::new(
            "glass_fraction",
            format!("must be within [0, 1], got {g}"),
        ));
    }
    let c = finite("clutter_density", p.clutter_density)?;
    if c < 0.0 {
        return Err(ParamError::new(
            "clutter_density",
            format!("must be >= 0 (boxes per 100 m²), got {c}"),
        ));
    }
    let cover = c * mean_footprint() / 100.0;
    if cover > MAX_CLUTTER_COVER {
        return Err(ParamError::new(
            "clutter_density",
            format!(
                "{c} boxes per 100 m² would cover about {:.0} % of the room and atrium floor, \
                 more than the {:.0} % that leaves it passable; use at most {:.1}",
                100.0 * cover,
                100.0 * MAX_CLUTTER_COVER,
                100.0 * MAX_CLUTTER_COVER / mean_footprint()
            ),
        ));
    }
    let a = finite("ap_spacing", p.ap_spacing)?;
    if a < 0.0 || (a > 0.0 && a < 2.0) {
        return Err(ParamError::new(
            "ap_spacing",
            format!("must be 0 (no access points) or at least 2 m, got {a}"),
        ));
    }
    Ok(())
}

/// A stretch of corridor or atrium wall that may be glazed: from `a` to `b`, glass over
/// the first `glass` metres, extended by `extend` metres past `b` (closing a corner).
struct Piece {
    a: [f64; 2],
    b: [f64; 2],
    material: &'static str,
    thickness: f64,
    glass: f64,
    extend: f64,
    note: String,
}

impl Piece {
    fn len(&self) -> f64 {
        (self.b[0] - self.a[0]).hypot(self.b[1] - self.a[1])
    }
}

struct WallOut {
    a: [f64; 2],
    b: [f64; 2],
    thickness: f64,
    material: &'static str,
    note: String,
}

/// A rectangle `[x0, x1] × [y0, y1]`.
#[derive(Clone, Copy)]
struct Rect {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
}

impl Rect {
    fn area(&self) -> f64 {
        (self.x1 - self.x0) * (self.y1 - self.y0)
    }

    fn polygon(&self) -> [[f64; 2]; 4] {
        [
            [self.x0, self.y0],
            [self.x1, self.y0],
            [self.x1, self.y1],
            [self.x0, self.y1],
        ]
    }

    /// Gap between two rectangles (0 when they touch or overlap).
    fn gap(&self, o: &Rect) -> f64 {
        let dx = (o.x0 - self.x1).max(self.x0 - o.x1).max(0.0);
        let dy = (o.y0 - self.y1).max(self.y0 - o.y1).max(0.0);
        dx.hypot(dy)
    }

    fn distance_to(&self, p: [f64; 2]) -> f64 {
        let dx = (self.x0 - p[0]).max(p[0] - self.x1).max(0.0);
        let dy = (self.y0 - p[1]).max(p[1] - self.y1).max(0.0);
        dx.hypot(dy)
    }
}

/// A number for the TOML text: rounded to the micrometre (generated coordinates are sums
/// whose last bits are noise) and always written as a float.
fn num(v: f64) -> String {
    let r = (v * 1e6).round() / 1e6;
    let r = if r == 0.0 { 0.0 } else { r };
    format!("{r:?}")
}

fn point(p: [f64; 2]) -> String {
    format!("[{}, {}]", num(p[0]), num(p[1]))
}

/// Generates the explicit world TOML text for `p`; refuses parameters that cannot make a
/// world, naming the parameter. Pure and deterministic: the same parameters give the same
/// text on every machine.
pub fn generate(p: &GeneratorParams) -> Result<String, ParamError> {
    validate(p)?;
    let floor = Floor::new(p);
    let (mut pieces, units, corridor_units) = glass_candidates(&floor);
    let glass_section = glaze(p, &mut pieces, &units, corridor_units);
    let walls = walls(&floor, &pieces);
    let pillars = pillars(p, &floor)?;
    let (rooms, atrium) = rooms(&floor);
    let boxes = clutter(p, &floor, &rooms, &atrium, &pillars)?;
    let aps = access_points(p, &floor)?;
    let plan = Plan {
        floor,
        walls,
        glass_section,
        pillars,
        rooms,
        atrium,
        boxes,
        aps,
    };
    Ok(world_text(p, &plan))
}

/// The floor's dimensions (on wall centre lines, see the module documentation) and where its
/// room partitions and doors are.
struct Floor {
    /// Wing width (y), corridor length and atrium length (x).
    w: f64,
    lc: f64,
    la: f64,
    /// The corridor axis, and the corridor's south and north wall lines.
    yc: f64,
    ys: f64,
    yn: f64,
    /// The atrium's south and north wall lines, and the building's east end.
    ya0: f64,
    ya1: f64,
    xe: f64,
    dw: f64,
    n_rooms: usize,
    /// Section boundaries along the corridor, from 0 to `lc`: room partitions, or equal
    /// sections when there are no rooms.
    xs: Vec<f64>,
    /// doors[side][i]: the west end of room i's door; side 0 south, 1 north.
    doors: [Vec<f64>; 2],
}

impl Floor {
    fn new(p: &GeneratorParams) -> Floor {
        let w = p.floor_width;
        let lc = p.corridor_length;
        let la = p.atrium_length;
        let cw = p.corridor_width;
        let yc = 0.5 * w;
        let (ys, yn) = (yc - 0.5 * cw, yc + 0.5 * cw);
        let (ya0, ya1) = (yc - 0.5 * p.atrium_width, yc + 0.5 * p.atrium_width);
        let xe = lc + la;
        let dw = p.door_width;

        // Room partitions (shared by both sides, so rooms face each other) and doors.
        let n_rooms = p.room_count as usize;
        let mut xs = vec![0.0];
        if n_rooms > 0 {
            let mut rng = Stream::new(p.seed, "rooms");
            let widths: Vec<f64> = (0..n_rooms)
                .map(|_| 1.0 + p.room_width_jitter * (2.0 * rng.unit() - 1.0))
                .collect();
            let scale = lc / widths.iter().sum::<f64>();
            let mut x = 0.0;
            for wi in &widths[..n_rooms - 1] {
                x += wi * scale;
                xs.push(x);
            }
        } else {
            let n = (lc / BARE_SECTION).ceil().max(1.0) as usize;
            xs.extend((1..n).map(|k| lc * k as f64 / n as f64));
        }
        xs.push(lc);
        let mut doors: [Vec<f64>; 2] = [Vec::new(), Vec::new()];
        if n_rooms > 0 {
            let mut rng = Stream::new(p.seed, "doors");
            for side in &mut doors {
                for i in 0..n_rooms {
                    side.push(rng.range(xs[i] + DOOR_MARGIN, xs[i + 1] - DOOR_MARGIN - dw));
                }
            }
        }
        Floor {
            w,
            lc,
            la,
            yc,
            ys,
            yn,
            ya0,
            ya1,
            xe,
            dw,
            n_rooms,
            xs,
            doors,
        }
    }

    fn sections(&self) -> usize {
        self.xs.len() - 1
    }
}

/// Everything the world file lists, placed.
struct Plan {
    floor: Floor,
    walls: Vec<WallOut>,
    /// Per corridor section, whether it is mostly glass.
    glass_section: Vec<bool>,
    pillars: Vec<[f64; 2]>,
    rooms: Vec<Room>,
    atrium: Rect,
    /// Furniture boxes and their kinds (indices into [`FURNITURE`]).
    boxes: Vec<(Rect, usize)>,
    aps: Vec<[f64; 2]>,
}

/// A room: its name, its floor, and its door (x0, x1, y of the corridor wall).
type Room = (String, Rect, [f64; 3]);

/// The corridor and atrium wall pieces that may be glazed, grouped in glass units (indices
/// into the pieces), and how many of the units (the first) are corridor sections.
fn glass_candidates(f: &Floor) -> (Vec<Piece>, Vec<Vec<usize>>, usize) {
    let Floor {
        lc,
        ys,
        yn,
        ya0,
        ya1,
        xe,
        dw,
        n_rooms,
        ..
    } = *f;
    let (xs, doors, sections) = (&f.xs, &f.doors, f.sections());
    // Glass candidates, in units.
    let mut pieces: Vec<Piece> = Vec::new();
    let mut units: Vec<Vec<usize>> = Vec::new();
    for i in 0..sections {
        let mut unit = Vec::new();
        // The last section's walls run to the atrium's west wall centre line plus half its
        // thickness, so the corner at the corridor mouth is solid.
        let x1 = if i + 1 == sections {
            lc + 0.5 * T_INNER
        } else {
            xs[i + 1]
        };
        for (side, y) in [(0, ys), (1, yn)] {
            let spans: Vec<(f64, f64)> = if n_rooms > 0 {
                let d = doors[side][i];
                vec![(xs[i], d), (d + dw, x1)]
            } else {
                vec![(xs[i], x1)]
            };
            for (a, b) in spans {
                unit.push(pieces.len());
                pieces.push(Piece {
                    a: [a, y],
                    b: [b, y],
                    material: "drywall",
                    thickness: T_INNER,
                    glass: 0.0,
                    extend: 0.0,
                    note: format!("corridor_{} {} wall", i + 1, ["south", "north"][side]),
                });
            }
        }
        units.push(unit);
    }
    let corridor_units = units.len();
    // Atrium walls: outer sides (concrete, each extended past its end to close the corner)
    // and the two interior stretches of its west wall beside the corridor mouth.
    // (from, to, material, thickness, extension past `to`, what)
    type Side = ([f64; 2], [f64; 2], &'static str, f64, f64, &'static str);
    let atrium_sides: Vec<Side> = vec![
        (
            [lc, ya0],
            [xe, ya0],
            "concrete",
            T_OUTER,
            0.5 * T_OUTER,
            "atrium south",
        ),
        (
            [xe, ya0],
            [xe, ya1],
            "concrete",
            T_OUTER,
            0.5 * T_OUTER,
            "atrium east",
        ),
        (
            [xe, ya1],
            [lc, ya1],
            "concrete",
            T_OUTER,
            0.5 * T_OUTER,
            "atrium north",
        ),
        (
            [lc, yn],
            [lc, ya1],
            "drywall",
            T_INNER,
            0.0,
            "atrium west (north of the corridor)",
        ),
        (
            [lc, ya0],
            [lc, ys],
            "drywall",
            T_INNER,
            0.0,
            "atrium west (south of the corridor)",
        ),
    ];
    for (a, b, material, thickness, extend, note) in atrium_sides {
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        if len < 1e-6 {
            continue; // atrium as wide as the corridor: no west wall beside the mouth
        }
        let n = (len / ATRIUM_UNIT).ceil().max(1.0) as usize;
        for k in 0..n {
            let t0 = k as f64 / n as f64;
            let t1 = (k + 1) as f64 / n as f64;
            let at = |t: f64| [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])];
            units.push(vec![pieces.len()]);
            pieces.push(Piece {
                a: at(t0),
                b: at(t1),
                material,
                thickness,
                glass: 0.0,
                extend: if k + 1 == n { extend } else { 0.0 },
                note: note.to_string(),
            });
        }
    }
    (pieces, units, corridor_units)
}

/// Glazes whole units in a seeded order, the first that would overshoot in part; returns per
/// corridor section whether at least half its wall length is glass.
fn glaze(
    p: &GeneratorParams,
    pieces: &mut [Piece],
    units: &[Vec<usize>],
    corridor_units: usize,
) -> Vec<bool> {
    let total: f64 = pieces.iter().map(Piece::len).sum();
    let mut remaining = p.glass_fraction * total;
    let mut order: Vec<usize> = (0..units.len()).collect();
    Stream::new(p.seed, "glass").shuffle(&mut order);
    'units: for &u in &order {
        for &k in &units[u] {
            if remaining < 0.01 {
                break 'units;
            }
            let len = pieces[k].len();
            // Leftovers under a centimetre are not worth a panel: round to whole pieces.
            let g = if remaining >= len - 0.01 {
                len
            } else {
                remaining
            };
            pieces[k].glass = g;
            remaining -= g;
        }
    }
    let unit_glass = |u: usize| -> (f64, f64) {
        units[u].iter().fold((0.0, 0.0), |(g, l), &k| {
            (g + pieces[k].glass, l + pieces[k].len())
        })
    };
    let glass_section: Vec<bool> = (0..corridor_units)
        .map(|u| {
            let (g, l) = unit_glass(u);
            g >= 0.5 * l
        })
        .collect();
    glass_section
}

/// Every wall: the wing's outline, the corridor and atrium pieces (glass where glazed) and the
/// room partitions.
fn walls(f: &Floor, pieces: &[Piece]) -> Vec<WallOut> {
    let Floor {
        w,
        lc,
        ys,
        yn,
        ya0,
        ya1,
        n_rooms,
        ..
    } = *f;
    let xs = &f.xs;
    let mut walls: Vec<WallOut> = Vec::new();
    // Office wing outline (concrete), each side extended past its end over the corner.
    let e = 0.5 * T_OUTER;
    let outer: Vec<([f64; 2], [f64; 2], &str)> = vec![
        ([0.0, w], [0.0, 0.0], "west outer wall"),
        ([0.0, 0.0], [lc, 0.0], "south outer wall"),
        (
            [lc, 0.0],
            [lc, ya0],
            "east outer wall of the wing (south of the atrium)",
        ),
        (
            [lc, ya1],
            [lc, w],
            "east outer wall of the wing (north of the atrium)",
        ),
        ([lc, w], [0.0, w], "north outer wall"),
    ];
    for (a, b, note) in outer {
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        if len < 1e-6 {
            continue; // atrium as wide as the wing
        }
        let d = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        walls.push(WallOut {
            a,
            b: [b[0] + e * d[0], b[1] + e * d[1]],
            thickness: T_OUTER,
            material: "concrete",
            note: note.to_string(),
        });
    }
    for pc in pieces {
        let len = pc.len();
        let d = [(pc.b[0] - pc.a[0]) / len, (pc.b[1] - pc.a[1]) / len];
        let at = |t: f64| [pc.a[0] + t * d[0], pc.a[1] + t * d[1]];
        let end = len + pc.extend;
        if pc.glass > 0.0 {
            // Glass over [0, glass]; an extension past the end belongs to whichever
            // material ends the piece.
            let g_end = if pc.glass >= len { end } else { pc.glass };
            walls.push(WallOut {
                a: pc.a,
                b: at(g_end),
                thickness: T_GLASS,
                material: "glass",
                note: format!("{} (glass)", pc.note),
            });
            if g_end < end {
                walls.push(WallOut {
                    a: at(g_end),
                    b: at(end),
                    thickness: pc.thickness,
                    material: pc.material,
                    note: pc.note.clone(),
                });
            }
        } else {
            walls.push(WallOut {
                a: pc.a,
                b: at(end),
                thickness: pc.thickness,
                material: pc.material,
                note: pc.note.clone(),
            });
        }
    }
    // Room partitions, from the corridor walls to the outer walls.
    if n_rooms > 0 {
        for &x in &xs[1..n_rooms] {
            walls.push(WallOut {
                a: [x, yn],
                b: [x, w],
                thickness: T_INNER,
                material: "drywall",
                note: "partition".into(),
            });
            walls.push(WallOut {
                a: [x, ys],
                b: [x, 0.0],
                thickness: T_INNER,
                material: "drywall",
                note: "partition".into(),
            });
        }
    }
    walls
}

/// Pillars: a grid symmetric about the atrium's centre lines, none on them (the corridor
/// axis stays an open aisle).
fn pillars(p: &GeneratorParams, f: &Floor) -> Result<Vec<[f64; 2]>, ParamError> {
    let Floor { lc, la, yc, .. } = *f;
    let mut pillars: Vec<[f64; 2]> = Vec::new();
    if p.pillar_spacing > 0.0 {
        let s = p.pillar_spacing;
        let m = PILLAR_MARGIN + p.pillar_radius;
        let offsets = |half: f64| -> Vec<f64> {
            let mut v = Vec::new();
            let mut k = 0.0;
            while (k + 0.5) * s <= half - m {
                v.push((k + 0.5) * s);
                k += 1.0;
            }
            v
        };
        let xo = offsets(0.5 * la);
        let yo = offsets(0.5 * p.atrium_width);
        let count = 4 * xo.len() * yo.len();
        if count > MAX_PILLARS {
            return Err(ParamError::new(
                "pillar_spacing",
                format!(
                    "{s} m would place {count} pillars, more than {MAX_PILLARS}; use a larger \
                     spacing"
                ),
            ));
        }
        let xm = lc + 0.5 * la;
        for dx in xo.iter().rev().map(|d| -d).chain(xo.iter().copied()) {
            for dy in yo.iter().rev().map(|d| -d).chain(yo.iter().copied()) {
                pillars.push([xm + dx, yc + dy]);
            }
        }
    }
    Ok(pillars)
}

/// The rooms and the atrium.
fn rooms(f: &Floor) -> (Vec<Room>, Rect) {
    let Floor {
        w,
        ys,
        yn,
        ya0,
        ya1,
        xe,
        lc,
        dw,
        n_rooms,
        ..
    } = *f;
    let (xs, doors) = (&f.xs, &f.doors);
    let mut rooms: Vec<Room> = Vec::new();
    if n_rooms > 0 {
        for i in 0..n_rooms {
            let (x0, x1) = (xs[i], xs[i + 1]);
            let dn = doors[1][i];
            let ds = doors[0][i];
            rooms.push((
                format!("room_n{}", i + 1),
                Rect {
                    x0,
                    y0: yn,
                    x1,
                    y1: w,
                },
                [dn, dn + dw, yn],
            ));
            rooms.push((
                format!("room_s{}", i + 1),
                Rect {
                    x0,
                    y0: 0.0,
                    x1,
                    y1: ys,
                },
                [ds, ds + dw, ys],
            ));
        }
    }
    let atrium = Rect {
        x0: lc,
        y0: ya0,
        x1: xe,
        y1: ya1,
    };
    (rooms, atrium)
}

/// Clutter: furniture in the rooms and the atrium, clear of walls, doorways, the atrium
/// aisle on the corridor axis, pillars and each other.
fn clutter(
    p: &GeneratorParams,
    f: &Floor,
    rooms: &[Room],
    atrium: &Rect,
    pillars: &[[f64; 2]],
) -> Result<Vec<(Rect, usize)>, ParamError> {
    let Floor { ys, yn, lc, xe, .. } = *f;
    let mut areas: Vec<(Rect, Vec<Rect>)> = Vec::new(); // where, keep-out zones
    for (_, r, door) in rooms {
        let keep = if door[2] == yn {
            Rect {
                x0: door[0] - 0.5,
                y0: yn,
                x1: door[1] + 0.5,
                y1: yn + 1.5,
            }
        } else {
            Rect {
                x0: door[0] - 0.5,
                y0: ys - 1.5,
                x1: door[1] + 0.5,
                y1: ys,
            }
        };
        areas.push((*r, vec![keep]));
    }
    areas.push((
        *atrium,
        vec![Rect {
            x0: lc,
            y0: ys - 0.75,
            x1: xe,
            y1: yn + 0.75,
        }],
    ));
    let clutter_area: f64 = areas.iter().map(|(r, _)| r.area()).sum();
    let n_clutter = (p.clutter_density * clutter_area / 100.0).round() as usize;
    if n_clutter > MAX_CLUTTER {
        return Err(ParamError::new(
            "clutter_density",
            format!(
                "{} boxes per 100 m² of {clutter_area:.0} m² is {n_clutter} boxes, more than \
                 {MAX_CLUTTER}; use a lower density",
                p.clutter_density
            ),
        ));
    }
    let mut boxes: Vec<(Rect, usize)> = Vec::new();
    let mut rng = Stream::new(p.seed, "clutter");
    let inset = 0.5 * T_OUTER + CLUTTER_GAP;
    for placed in 0..n_clutter {
        let mut ok = None;
        for _ in 0..CLUTTER_TRIES {
            let mut pick = rng.unit() * clutter_area;
            let mut which = areas.len() - 1;
            for (k, (r, _)) in areas.iter().enumerate() {
                if pick < r.area() {
                    which = k;
                    break;
                }
                pick -= r.area();
            }
            let kind = rng.index(FURNITURE.len());
            let (_, mut sx, mut sy, _) = FURNITURE[kind];
            if rng.unit() < 0.5 {
                std::mem::swap(&mut sx, &mut sy);
            }
            let (area, keep) = &areas[which];
            let (lo_x, hi_x) = (area.x0 + inset + 0.5 * sx, area.x1 - inset - 0.5 * sx);
            let (lo_y, hi_y) = (area.y0 + inset + 0.5 * sy, area.y1 - inset - 0.5 * sy);
            let (cx, cy) = (rng.range(0.0, 1.0), rng.range(0.0, 1.0));
            if lo_x > hi_x || lo_y > hi_y {
                continue;
            }
            let (cx, cy) = (lo_x + cx * (hi_x - lo_x), lo_y + cy * (hi_y - lo_y));
            let b = Rect {
                x0: cx - 0.5 * sx,
                y0: cy - 0.5 * sy,
                x1: cx + 0.5 * sx,
                y1: cy + 0.5 * sy,
            };
            let clear = keep.iter().all(|k| b.gap(k) > 0.0)
                && pillars
                    .iter()
                    .all(|&c| b.distance_to(c) > p.pillar_radius + CLUTTER_GAP)
                && boxes.iter().all(|(o, _)| b.gap(o) > CLUTTER_GAP);
            if clear {
                ok = Some((b, kind));
                break;
            }
        }
        let Some(b) = ok else {
            return Err(ParamError::new(
                "clutter_density",
                format!(
                    "the floor is full: placed {placed} of {n_clutter} boxes \
                     ({} per 100 m²) before finding no free spot in {CLUTTER_TRIES} \
                     tries; use a lower density",
                    p.clutter_density
                ),
            ));
        };
        boxes.push(b);
    }
    Ok(boxes)
}

/// Access points: a square grid, one row on the corridor axis, inside the outline.
fn access_points(p: &GeneratorParams, f: &Floor) -> Result<Vec<[f64; 2]>, ParamError> {
    let Floor {
        w,
        lc,
        yc,
        ya0,
        ya1,
        xe,
        ..
    } = *f;
    let mut aps: Vec<[f64; 2]> = Vec::new();
    if p.ap_spacing > 0.0 {
        let s = p.ap_spacing;
        let inside = 0.5;
        let nx = ((xe - inside) / s - 0.5).floor().max(-1.0) as i64 + 1;
        let nj = ((0.5 * w) / s).floor() as i64;
        let estimate = (nx.max(0) as usize) * (2 * nj as usize + 1);
        if estimate > MAX_APS {
            return Err(ParamError::new(
                "ap_spacing",
                format!(
                    "{s} m would place about {estimate} access points, more than {MAX_APS}; \
                     use a larger spacing"
                ),
            ));
        }
        for i in 0..nx {
            let x = (i as f64 + 0.5) * s;
            if x > xe - inside {
                break;
            }
            let (y_lo, y_hi) = if x <= lc {
                (inside, w - inside)
            } else {
                (ya0 + inside, ya1 - inside)
            };
            for j in -nj..=nj {
                let y = yc + j as f64 * s;
                if (y_lo..=y_hi).contains(&y) {
                    aps.push([x, y]);
                }
            }
        }
    }
    Ok(aps)
}

/// The world file's text.
fn world_text(p: &GeneratorParams, plan: &Plan) -> String {
    let Floor {
        w,
        lc,
        ys,
        yn,
        ya0,
        ya1,
        xe,
        yc,
        ..
    } = plan.floor;
    let Plan {
        walls,
        glass_section,
        pillars,
        rooms,
        atrium,
        boxes,
        aps,
        ..
    } = plan;
    let (xs, sections) = (&plan.floor.xs, plan.floor.sections());
    let mut t = String::new();
    let params = toml::Table::try_from(p).expect("plain struct");
    let _ = writeln!(
        t,
        "# Generated by the office_atrium world generator (atrium-worlds); regenerate rather \
         than edit.\n# Parameters: {}\n#\n# Office wing x 0..{}, y 0..{}; corridor y {}..{}; \
         atrium x {}..{}, y {}..{}. Dimensions on wall centre lines.\n",
        params
            .iter()
            .map(|(k, v)| format!("{k} = {v}"))
            .collect::<Vec<_>>()
            .join(", "),
        num(lc),
        num(w),
        num(ys),
        num(yn),
        num(lc),
        num(xe),
        num(ya0),
        num(ya1)
    );
    let _ = writeln!(
        t,
        "name = {}",
        toml::Value::String(p.name.trim().to_string())
    );
    let _ = writeln!(t, "ceiling_height = {}\n", num(p.ceiling_height));
    // TOML integers are signed: the top bit of a seed does not reach the shadow field.
    let _ = writeln!(t, "[wifi]\nseed = {}\n", p.seed & (i64::MAX as u64));
    t.push_str(
        "[materials.concrete]\nlaser = \"opaque\"\nwifi_attenuation_db = 12.0\n\n\
         [materials.drywall]\nlaser = \"opaque\"\nwifi_attenuation_db = 4.0\n\n\
         [materials.glass]\nlaser = \"glass\"\nreflect_within_deg = 5.0\nwifi_attenuation_db = 2.5\n\n\
         [materials.wood]\nlaser = \"opaque\"\n\n",
    );
    for wl in walls {
        let _ = writeln!(
            t,
            "[[walls]] # {}\npoints = [{}, {}]\nthickness = {}\nmaterial = \"{}\"\n",
            wl.note,
            point(wl.a),
            point(wl.b),
            num(wl.thickness),
            wl.material
        );
    }
    for c in pillars {
        let _ = writeln!(
            t,
            "[[pillars]]\ncenter = {}\nradius = {}\nmaterial = \"concrete\"\n",
            point(*c),
            num(p.pillar_radius)
        );
    }
    // Regions: corridors first (region_at takes the first match, and corridor edges touch
    // the rooms and the atrium).
    for i in 0..sections {
        let r = Rect {
            x0: xs[i],
            y0: ys,
            x1: xs[i + 1],
            y1: yn,
        };
        let kind = if glass_section[i] {
            "glass_corridor"
        } else {
            "corridor"
        };
        region(&mut t, &format!("corridor_{}", i + 1), kind, &r);
    }
    region(&mut t, "atrium", "atrium", atrium);
    for (name, r, _) in rooms {
        region(&mut t, name, "room", r);
    }
    for (b, kind) in boxes {
        let (what, _, _, h) = FURNITURE[*kind];
        let _ = writeln!(
            t,
            "[[boxes]] # {what}\ncenter = {}\nsize = [{}, {}, {}]\nmaterial = \"wood\"\n",
            point([0.5 * (b.x0 + b.x1), 0.5 * (b.y0 + b.y1)]),
            num(b.x1 - b.x0),
            num(b.y1 - b.y0),
            num(h)
        );
    }
    let z_ap = p.ceiling_height - 0.1;
    for (k, a) in aps.iter().enumerate() {
        let _ = writeln!(
            t,
            "[[access_points]]\nname = \"ap_{:03}\"\nposition = [{}, {}, {}]\n\
             tx_power_dbm = -40.0\npath_loss_exponent = 2.5\nchannel = {}\n",
            k + 1,
            num(a[0]),
            num(a[1]),
            num(z_ap),
            [1, 6, 11][k % 3]
        );
    }
    lights(&mut t, p, rooms, atrium, yc);
    t
}

fn region(t: &mut String, name: &str, kind: &str, r: &Rect) {
    let poly: Vec<String> = r.polygon().iter().map(|&c| point(c)).collect();
    let _ = writeln!(
        t,
        "[[regions]]\nname = \"{name}\"\nkind = \"{kind}\"\npolygon = [{}]\n",
        poly.join(", ")
    );
}

/// Tubes along the corridor axis and over the atrium, a bulb in each room: what the camera
/// sensors need to see anything. At most a few hundred over the atrium.
fn lights(
    t: &mut String,
    p: &GeneratorParams,
    rooms: &[(String, Rect, [f64; 3])],
    atrium: &Rect,
    yc: f64,
) {
    let z = p.ceiling_height - 0.05;
    let lc = p.corridor_length;
    let tube = |t: &mut String, x: f64, y: f64| {
        let _ = writeln!(
            t,
            "[[lights]]\nkind = \"tube\"\nfrom = [{}, {}, {}]\nto = [{}, {}, {}]\n",
            num(x - 0.6),
            num(y),
            num(z),
            num(x + 0.6),
            num(y),
            num(z)
        );
    };
    let n = (lc / 4.0).floor().max(1.0) as usize;
    for k in 0..n {
        tube(t, (k as f64 + 0.5) * lc / n as f64, yc);
    }
    let step = 6.0f64.max((atrium.area() / 400.0).sqrt());
    let nx = ((atrium.x1 - atrium.x0) / step).floor().max(1.0) as usize;
    let ny = ((atrium.y1 - atrium.y0) / step).floor().max(1.0) as usize;
    for i in 0..nx {
        for j in 0..ny {
            let x = atrium.x0 + (i as f64 + 0.5) * (atrium.x1 - atrium.x0) / nx as f64;
            let y = atrium.y0 + (j as f64 + 0.5) * (atrium.y1 - atrium.y0) / ny as f64;
            tube(t, x, y);
        }
    }
    for (_, r, _) in rooms {
        let _ = writeln!(
            t,
            "[[lights]]\nkind = \"bulb\"\nfrom = [{}, {}, {}]\n",
            num(0.5 * (r.x0 + r.x1)),
            num(0.5 * (r.y0 + r.y1)),
            num(z)
        );
    }
}
