//! Property-based fuzzing of the world loader: arbitrary and mutated TOML never panics (it
//! loads or it is an error), and whatever loads is usable: it passes `validate`, every number
//! is finite and within the limits, and its maps can be made (or refused with an error).
//! Inputs that once failed are kept below as explicit regression tests.

use std::path::Path;

use atrium_fuzz::{apply, config, mutation, toml_number_spans, Mutation};
use atrium_worlds::{World, MAX_COORDINATE_M};
use proptest::prelude::*;
use proptest::sample::{select, Index};

/// A small world using every table the loader reads.
const BASE: &str = r#"name = "fuzz"
ceiling_height = 3.0
[materials.concrete]
laser = "opaque"
wifi_attenuation_db = 12.0
[materials.glass]
laser = "glass"
reflect_within_deg = 5.0
[materials.wood]
laser = "opaque"
[[walls]]
points = [[0.0, 0.0], [10.0, 0.0], [10.0, 8.0], [0.0, 8.0], [0.0, 0.0]]
thickness = 0.3
material = "concrete"
[[walls]]
points = [[5.0, 0.0], [5.0, 3.0]]
thickness = 0.05
height = 2.5
material = "glass"
[[pillars]]
center = [7.0, 5.0]
radius = 0.3
material = "concrete"
[[regions]]
name = "west"
kind = "room"
polygon = [[0.0, 0.0], [5.0, 0.0], [5.0, 8.0], [0.0, 8.0], [0.0, 0.0]]
[[regions]]
name = "east"
kind = "corridor"
polygon = [[5.0, 0.0], [10.0, 0.0], [10.0, 8.0], [5.0, 8.0]]
[[boxes]]
center = [2.0, 6.0]
size = [1.2, 0.6, 0.75]
yaw = 0.3
material = "wood"
[[access_points]]
name = "ap1"
position = [1.0, 1.0, 2.5]
tx_power_dbm = -40.0
path_loss_exponent = 2.5
channel = 6
[wifi]
shadowing_sigma_db = 4.0
seed = 7
[[lights]]
kind = "tube"
from = [1.0, 1.0, 2.9]
to = [3.0, 1.0, 2.9]
intensity = 4.0
[[lights]]
kind = "bulb"
from = [8.0, 6.0, 2.8]
[surfaces.floor]
albedo = 0.3
[surfaces.wood]
albedo = 0.5
contrast = 0.3
scale = 0.05
"#;

/// Snippets a mutation may splice in: TOML syntax, tables, keys and hostile numbers.
const TOKENS: &[&str] = &[
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    "=",
    ",",
    "\"",
    "'",
    "'''",
    "\"\"\"",
    "#",
    "\n",
    " ",
    ".",
    "\\",
    "\\u0000",
    "[[walls]]",
    "[[regions]]",
    "[[pillars]]",
    "[[boxes]]",
    "[[lights]]",
    "[[access_points]]",
    "[wifi]",
    "[materials.x]",
    "[surfaces.x]",
    "[walls]",
    "name = \"x\"",
    "kind = \"room\"",
    "material = \"concrete\"",
    "laser = \"glass\"",
    "points = []",
    "polygon = [[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]]",
    "center = [1.0]",
    "size = [1.0, 1.0]",
    "0",
    "-0.0",
    "1",
    "-1",
    "1e300",
    "-1e300",
    "1e-300",
    "5e-324",
    "1.7976931348623157e308",
    "nan",
    "inf",
    "-inf",
    "+inf",
    "1e",
    "0x10",
    "1_0",
    "true",
    "1979-05-27",
    "18446744073709551616",
    "-9223372036854775809",
    "\u{0}",
    "\u{feff}",
    "é",
];

/// Values a number in the text may be replaced by.
const NUMBERS: &[&str] = &[
    "0",
    "0.0",
    "-0.0",
    "-1.0",
    "1e300",
    "-1e300",
    "1e-300",
    "5e-324",
    "nan",
    "inf",
    "-inf",
    "1e4",
    "10000.000001",
    "-1e5",
    "3.0",
    "4294967296",
    "1",
    "true",
    "\"7\"",
    "[]",
    "[1.0]",
    "1e-9",
    "2e-9",
    "90.0",
    "90.1",
    "30.0",
    "233",
    "234",
];

/// What a loaded world must satisfy however hostile the text was.
fn check_usable(w: &World) {
    w.validate(Path::new("<fuzz>"))
        .unwrap_or_else(|e| panic!("loaded but does not validate: {e}"));
    let ok = |v: f64| v.is_finite() && v.abs() <= MAX_COORDINATE_M;
    assert!(ok(w.ceiling_height) && w.ceiling_height > 0.0);
    for wall in &w.walls {
        assert!(wall.a.iter().chain(&wall.b).all(|&v| ok(v)), "{wall:?}");
        assert!(ok(wall.thickness) && ok(wall.height), "{wall:?}");
    }
    for p in &w.pillars {
        assert!(p.center.iter().all(|&v| ok(v)) && ok(p.radius), "{p:?}");
    }
    for r in &w.regions {
        assert!(r.polygon.iter().flatten().all(|&v| ok(v)), "{r:?}");
        assert!(
            atrium_worlds::geometry::polygon_area(&r.polygon).abs() > 0.0,
            "{r:?}"
        );
    }
    for b in &w.boxes {
        assert!(b.center.iter().chain(&b.size).all(|&v| ok(v)), "{b:?}");
    }
    for ap in &w.access_points {
        assert!(ap.position.iter().all(|&v| ok(v)), "{ap:?}");
    }
    let (lo, hi) = w.bounds();
    assert!(lo.iter().chain(&hi).all(|v| v.is_finite()), "{lo:?} {hi:?}");
    for s in &w.vector_map(true).segments {
        assert!(s.a.iter().chain(&s.b).all(|v| v.is_finite()), "{s:?}");
    }
    // Maps: an error or a grid of the announced size, never an abort. Build only small ones.
    for res in [0.5, 0.05, 1e-300] {
        match w.grid_size(res) {
            Ok(size) if size.cells() <= 1_000_000 => {
                let g = w.try_occupancy_grid(res, false).unwrap();
                assert_eq!(g.cells.len() as u64, size.cells());
                assert!(g.to_pgm().len() as u64 > size.cells());
            }
            Ok(_) => {}
            Err(e) => assert!(!e.to_string().is_empty()),
        }
    }
    let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let _ = (w.clearance(c), w.region_at(c), w.furniture_at(c));
}

fn load(text: &str) {
    if let Ok(w) = World::from_toml_str(text, Path::new("fuzz.toml")) {
        check_usable(&w);
    }
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,400}") {
        load(&text);
    }

    #[test]
    fn token_soup_never_panics(tokens in prop::collection::vec(select(TOKENS), 0..80)) {
        load(&format!("name = \"x\"\nceiling_height = 3.0\n{}", tokens.concat()));
    }

    #[test]
    fn mutated_world_never_panics(mutations in prop::collection::vec(mutation(TOKENS, NUMBERS), 1..8)) {
        load(&apply(BASE, &mutations, toml_number_spans));
    }

    #[test]
    fn hostile_numbers_never_give_garbage(
        numbers in prop::collection::vec((any::<Index>(), select(NUMBERS)), 1..6)
    ) {
        let mutations: Vec<Mutation> =
            numbers.into_iter().map(|(i, v)| Mutation::Number(i, v.to_string())).collect();
        load(&apply(BASE, &mutations, toml_number_spans));
    }
}

#[test]
fn base_loads() {
    let w = World::from_toml_str(BASE, Path::new("fuzz.toml")).unwrap();
    check_usable(&w);
    assert!(
        toml_number_spans(BASE).len() > 60,
        "{}",
        toml_number_spans(BASE).len()
    );
}

/// Inputs the fuzzing above found (or that were found by hand while writing it).
#[test]
fn regressions() {
    let refused: Vec<String> = vec![
        // 1e300 coordinates loaded, and made infinite bounds and an empty 0 × 0 grid.
        BASE.replacen("[10.0, 8.0], [0.0, 8.0]", "[1e300, 8.0], [0.0, 8.0]", 1),
        BASE.replacen("center = [7.0, 5.0]", "center = [7.0, -1e300]", 1),
        BASE.replacen("center = [2.0, 6.0]", "center = [1e300, 6.0]", 1),
        BASE.replacen(
            "position = [1.0, 1.0, 2.5]",
            "position = [1e300, 1.0, 2.5]",
            1,
        ),
        BASE.replacen("[5.0, 3.0]]", "[5.0, 1e300]]", 1),
        // A bow-tie region: its signed area is zero.
        BASE.replacen(
            "[[5.0, 0.0], [10.0, 0.0], [10.0, 8.0], [5.0, 8.0]]",
            "[[5.0, 0.0], [10.0, 8.0], [10.0, 0.0], [5.0, 8.0]]",
            1,
        ),
        // A pillar of radius 5e-324 m.
        BASE.replacen("radius = 0.3", "radius = 5e-324", 1),
        // Deep nesting, which toml refuses by its own recursion limit.
        format!(
            "name = \"x\"\nceiling_height = 3.0\nfoo = {}1{}\n",
            "[".repeat(100_000),
            "]".repeat(100_000)
        ),
        format!(
            "name = \"x\"\nceiling_height = 3.0\n[{}b]\n",
            "a.".repeat(100_000)
        ),
    ];
    for text in &refused {
        load(text);
        assert!(
            World::from_toml_str(text, Path::new("fuzz.toml")).is_err(),
            "{}",
            &text[..200.min(text.len())]
        );
    }
    // Loads: numbers at the limits.
    let accepted = [
        BASE.replacen("[10.0, 8.0], [0.0, 8.0]", "[10000.0, 8.0], [0.0, 8.0]", 1),
        BASE.replacen("radius = 0.3", "radius = 0.001", 1),
    ];
    for text in &accepted {
        load(text);
        assert!(World::from_toml_str(text, Path::new("fuzz.toml")).is_ok());
    }
}
