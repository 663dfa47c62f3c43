//! Property-based fuzzing of the scenario loader: arbitrary and mutated TOML never panics (it
//! loads or it is an error naming the file), and whatever loads is usable: every number the
//! run uses is finite and within its limit, every place lies in the world, and the registry's
//! check (localizer tables, `[expect]`) either accepts it or refuses it cleanly.
//! Inputs that once failed are kept below as explicit regression tests.

use atrium_fuzz::{apply, config, mutation, toml_number_spans, Mutation, HOSTILE_NUMBERS};
use atrium_scenarios::scenario::{InitialBelief, MAX_DURATION_S};
use atrium_scenarios::{LocalizerRegistry, Scenario};
use proptest::prelude::*;
use proptest::sample::{select, Index};
use std::path::{Path, PathBuf};

/// A small scenario in the lab using most tables the loader reads; its localizers are cheap
/// to build, so the registry check runs for every case.
const BASE: &str = r#"name = "fuzz"
description = "fuzzed"
world = "../worlds/lab.toml"
robot = "../robots/urdf/pioneer3dx.urdf"
seed = 1
duration_s = 20.0
physics_hz = 200.0
eval_hz = 10.0

[start]
pose = [2.0, 2.0, 0.0]

[route]
waypoints = [[8.5, 2.0], [8.5, 5.0]]
jitter = 0.2

[controller]
max_speed = 0.5
max_turn_rate = 1.0

[odometry]
radius_error = 0.005
rate_hz = 50.0

[sensors.laser]
beams = 91
rate_hz = 10.0

[initial_belief]
mode = "tracking"
sigma = [0.1, 0.1, 0.05]

[metrics]
converge_threshold_m = 0.3
converge_hold_s = 2.0

[[events]]
kind = "kidnap"
at_s = 5.0
to = [3.0, 5.0, 1.0]

[[localizers]]
name = "odometry"
kind = "dead_reckoning"

[[localizers]]
name = "odo2"
kind = "dead_reckoning"

[expect.odometry]
median_max = 100.0
"#;

/// Snippets a mutation may splice in: TOML syntax, tables, keys and hostile values.
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
    "#",
    "\n",
    " ",
    ".",
    "\\",
    "[start]",
    "[route]",
    "[controller]",
    "[odometry]",
    "[sensors.x]",
    "[[localizers]]",
    "[[events]]",
    "[expect.odometry]",
    "[initial_belief]",
    "[metrics]",
    "[map]",
    "[wifi]",
    "name = \"../x\"",
    "kind = \"mcl\"",
    "kind = \"process\"",
    "kind = \"kidnap\"",
    "mode = \"global\"",
    "regions = []",
    "waypoints = []",
    "pose = [1.0]",
    "to = []",
    "world = \"/nonexistent.toml\"",
    "robot = \"../worlds/lab.toml\"",
    "seed = -1",
    "duration_s = 1e12",
    "max_speed = 1e9",
    "beams = 100000000",
    "sigma = [1e300, 0, 0]",
    "median_max = nan",
    "lighting = \"disco\"",
    "\u{0}",
    "\u{feff}",
    "é",
];

/// Values a number in the text may be replaced by: the hostile ones plus values at the limits.
const NUMBERS: &[&str] = &[
    "0",
    "0.0",
    "-0.0",
    "-1.0",
    "1",
    "1e300",
    "-1e300",
    "1e-300",
    "5e-324",
    "nan",
    "inf",
    "-inf",
    "4294967296",
    "18446744073709551616",
    "-9223372036854775809",
    "1e-9",
    "86400",
    "86400.5",
    "100",
    "100.5",
    "10",
    "10.5",
    "5000",
    "5001",
    "200",
    "201",
    "12.0",
    "-3.0",
];

/// A scenario file path beside the bundled ones, so the relative paths resolve.
fn file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz_probe.toml")
}

/// What a loaded scenario must satisfy however hostile the text was.
fn check_usable(s: &Scenario) {
    let (lo, hi) = s.world.bounds();
    let inside = |p: [f64; 2]| (lo[0]..=hi[0]).contains(&p[0]) && (lo[1]..=hi[1]).contains(&p[1]);
    assert!(s.duration_s.is_finite() && s.duration_s > 0.0 && s.duration_s <= MAX_DURATION_S);
    assert!(s.physics_hz.is_finite() && s.eval_hz.is_finite() && s.eval_hz > 0.0);
    assert!(inside([s.start.x, s.start.y]), "{:?}", s.start);
    assert!(
        s.start.theta.abs() <= std::f64::consts::PI + 1e-12,
        "{:?}",
        s.start
    );
    assert!(s.waypoints.iter().all(|w| inside(*w)), "{:?}", s.waypoints);
    assert!(s.route_jitter.is_finite() && s.route_jitter >= 0.0);
    assert!(s.route_speeds.iter().all(|v| v.is_finite() && *v > 0.0));
    assert!(s.controller.max_speed.is_finite() && s.controller.max_speed <= 10.0);
    for l in &s.lasers {
        assert!(l.rate_hz <= s.physics_hz, "{l:?}");
    }
    if let InitialBelief::Tracking { sigma } = &s.initial_belief {
        assert!(
            sigma.iter().all(|v| v.is_finite() && *v >= 0.0),
            "{sigma:?}"
        );
    }
    for e in &s.events {
        assert!(e.at_s().is_finite() && e.at_s() < s.duration_s);
    }
    // Localizer tables and `[expect]`: accepted or refused, never a panic.
    if let Err(e) = LocalizerRegistry::with_builtins().check(s) {
        assert!(!e.to_string().is_empty());
    }
}

fn load(text: &str) {
    match Scenario::from_toml_str(text, &file()) {
        Ok(s) => check_usable(&s),
        // Every error starts with the file it is about (the scenario, or a file it names).
        Err(e) => assert!(e.to_string().contains(": "), "{e}"),
    }
}

proptest! {
    #![proptest_config(config(192))]

    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,300}") {
        load(&text);
    }

    #[test]
    fn mutated_scenario_never_panics(mutations in prop::collection::vec(mutation(TOKENS, NUMBERS), 1..6)) {
        load(&apply(BASE, &mutations, toml_number_spans));
    }

    #[test]
    fn hostile_numbers_never_give_garbage(
        numbers in prop::collection::vec((any::<Index>(), select(HOSTILE_NUMBERS)), 1..5)
    ) {
        let mutations: Vec<Mutation> =
            numbers.into_iter().map(|(i, v)| Mutation::Number(i, v.to_string())).collect();
        load(&apply(BASE, &mutations, toml_number_spans));
    }
}

#[test]
fn base_loads() {
    let s = Scenario::from_toml_str(BASE, &file()).unwrap();
    check_usable(&s);
    LocalizerRegistry::with_builtins().check(&s).unwrap();
    assert!(toml_number_spans(BASE).len() > 20);
}

/// Inputs found by hand or by the fuzzing above.
#[test]
fn regressions() {
    let refused = [
        BASE.replacen("pose = [2.0, 2.0, 0.0]", "pose = [2.0, 2.0, 1e39]", 1),
        BASE.replacen("pose = [2.0, 2.0, 0.0]", "pose = [2e3, 2.0, 0.0]", 1),
        BASE.replacen("rate_hz = 10.0", "rate_hz = 1000.0", 1),
        BASE.replacen("duration_s = 20.0", "duration_s = 1e12", 1),
        BASE.replacen("max_speed = 0.5", "max_speed = 1e9", 1),
        BASE.replacen("to = [3.0, 5.0, 1.0]", "to = [3.0, 5.0, nan]", 1),
        BASE.replacen("name = \"odo2\"", "name = \"../../x\"", 1),
    ];
    for text in &refused {
        load(text);
        assert!(Scenario::from_toml_str(text, &file()).is_err(), "{text}");
    }
}
