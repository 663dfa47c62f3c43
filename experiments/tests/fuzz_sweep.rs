//! Property-based fuzzing of the sweep file parser and of `results.csv` (issue 15): arbitrary,
//! token-soup and mutated sweep files never panic (they load, or fail with an error that names
//! a file), and any results file — whatever its values, axis paths and sweep name hold —
//! reads back exactly as written, while damaged ones read or fail cleanly. Inputs that fail
//! are to be kept below as explicit regression tests (runs of 20,000 cases per property found
//! none; `edge_cases` holds hand-picked ones).
//!
//! The valid sweep asks for 100,000 trials per cell, so a mutation that multiplies its cells
//! past ten is refused by the size limit before validation: each case costs milliseconds.

use atrium_experiments::sweep::csv::{self, Layout, Results, Row};
use atrium_experiments::sweep::Sweep;
use atrium_fuzz::{apply, config, mutation, toml_number_spans};
use proptest::prelude::*;
use proptest::sample::select;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// A folder with a small base scenario (the lab world, dead reckoning only).
fn dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("atrium-fuzz-sweep-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        let root = atrium_scenarios::bundled_scenarios_dir().join("..");
        let base = format!(
            "name = \"base\"\nduration_s = 1.0\nworld = {:?}\nrobot = {:?}\nseed = 3\n\
             [start]\npose = [1.0, 1.0, 0.0]\n[route]\nwaypoints = [[1.5, 1.0]]\n\
             [[localizers]]\nname = \"odometry\"\nkind = \"dead_reckoning\"\n",
            root.join("worlds/lab.toml"),
            root.join("robots/urdf/pioneer3dx.urdf"),
        );
        std::fs::write(d.join("base.toml"), base).unwrap();
        d
    })
}

/// A sweep using most of the format: dotted and nested axes, a localizer axis, strings,
/// the sweep's own localizer and expectations, an error map.
const BASE: &str = r#"base = "base.toml"
seed = 7
trials = 100000
[axes]
"odometry.radius_error" = [0.0, 0.01]
duration_s = [0.5]
[axes.controller]
max_speed = [0.4, 0.6]
[[localizers]]
name = "mine"
kind = "dead_reckoning"
[expect.mine]
median_max = 100.0
[error_map]
resolution = 1.0
"#;

const TOKENS: &[&str] = &[
    "[",
    "]",
    "[[",
    "]]",
    "{",
    "}",
    "=",
    ",",
    ".",
    "\"",
    "'",
    "\n",
    " ",
    "#",
    "\\",
    "\\n",
    "\"\"\"",
    "[axes]",
    "[axes.x]",
    "[axes.odometry]",
    "[[axes]]",
    "[[localizers]]",
    "[expect.odometry]",
    "[error_map]",
    "axes",
    "localizers",
    "base",
    "seed",
    "trials",
    "\"controller.max_speed\" = [1.0]",
    "controller = [{ max_speed = 1.0 }]",
    "\"localizers.mine.x\" = [1]",
    "\"a\\nb\" = [1]",
    "world = [\"nope.toml\"]",
    "world = [\"base.toml\"]",
    "base = \"/\"",
    "base = \"\"",
    "base = \"fuzz_sweep.rs\"",
    "name = \"odometry\"",
    "kind = \"nope\"",
    "kind = \"process\"",
    "[]",
    "[[]]",
    "{}",
    "0",
    "-1",
    "1e300",
    "nan",
    "inf",
    "-inf",
    "18446744073709551616",
    "1e-320",
    "true",
    "1979-05-27",
    "\u{0}",
    "\u{feff}",
    "é",
    "\u{10ffff}",
];

const NUMBERS: &[&str] = &[
    "0",
    "-0.0",
    "-1",
    "1",
    "2",
    "1e300",
    "-1e300",
    "1e-300",
    "nan",
    "inf",
    "-inf",
    "1e",
    "4294967296",
    "18446744073709551616",
    "-9223372036854775809",
    "10001",
    "1000000",
];

/// Loads `text` as a sweep file; a panic fails the property (proptest catches it), and an
/// error must name a file (the sweep, its base scenario, or a file they name).
fn load(text: &str) {
    let file = dir().join("fuzz.toml");
    if let Err(e) = Sweep::from_toml_str(text, &file) {
        let msg = e.to_string();
        let root = atrium_scenarios::bundled_scenarios_dir().join("..");
        let names_a_file = msg.contains(&*dir().to_string_lossy())
            || msg.contains(&*root.to_string_lossy())
            || msg.starts_with('/');
        assert!(names_a_file, "error names no file: {msg}");
    }
}

/// A results file of random content; `n_params` columns of parameters.
fn results(name: String, paths: Vec<String>, cells: Vec<Vec<String>>) -> Results {
    let rows = cells
        .into_iter()
        .enumerate()
        .map(|(k, mut fields)| {
            let params: Vec<String> = fields.drain(..paths.len().min(fields.len())).collect();
            let mut params = params;
            params.resize(paths.len(), String::new());
            Row {
                params,
                cell: k,
                trial: k % 3,
                seed: k as u64 * 7919,
                localizer: fields.pop().unwrap_or_default(),
                values: (0..9).map(|i| format!("{}", i as f64 * 0.5)).collect(),
            }
        })
        .collect();
    Results {
        hash: "0123456789abcdef".into(),
        name,
        layout: Some(Layout {
            cells: 9,
            trials: 3,
            shard: (1, 2),
        }),
        axis_paths: paths,
        rows,
        dropped_partial: false,
    }
}

/// Any character, control characters and CSV syntax favoured.
fn field() -> impl Strategy<Value = String> {
    prop::collection::vec(
        prop_oneof![
            select(&[",", "\"", "\n", "\r", "\r\n", " ", "#", "%", "=", "name=", "%0A"][..])
                .prop_map(String::from),
            "\\PC{0,3}",
            any::<char>().prop_map(String::from),
        ],
        0..6,
    )
    .prop_map(|parts| parts.concat())
}

/// Parameter paths an axis may name: real ones, tables, localizers, files, and nonsense.
const PATHS: &[&str] = &[
    "duration_s",
    "odometry.radius_error",
    "controller.max_speed",
    "controller",
    "start.pose",
    "route.waypoints",
    "route.jitter",
    "localizers.odometry.x",
    "localizers.mine.kind",
    "localizers.odometry.name",
    "localizers.none.x",
    "sensors.laser.range_max",
    "sensors.laser",
    "world",
    "robot",
    "seed",
    "expect.odometry.median_max",
    "expect.mine",
    "name",
    "eval_hz",
    "physics_hz",
    "map.resolution",
    "events",
    "initial_belief.mode",
    "a-b.c_d",
    "clutter",
];

/// A TOML value of any type, hostile numbers and strings favoured.
fn value() -> impl Strategy<Value = toml::Value> {
    let leaf = prop_oneof![
        select(NUMBERS).prop_map(|n| n
            .parse::<i64>()
            .map(toml::Value::Integer)
            .or_else(|_| n.parse::<f64>().map(toml::Value::Float))
            .unwrap_or_else(|_| toml::Value::String(n.into()))),
        any::<f64>().prop_map(toml::Value::Float),
        any::<i64>().prop_map(toml::Value::Integer),
        field().prop_map(toml::Value::String),
        select(&["base.toml", "../base.toml", "nope.toml", "", "fuzz.toml"][..])
            .prop_map(|s| toml::Value::String(s.into())),
        any::<bool>().prop_map(toml::Value::Boolean),
    ];
    leaf.prop_recursive(2, 8, 3, |inner| {
        prop_oneof![
            prop::collection::vec(inner.clone(), 0..4).prop_map(toml::Value::Array),
            prop::collection::btree_map(select(PATHS).prop_map(String::from), inner, 0..3)
                .prop_map(|m| toml::Value::Table(m.into_iter().collect())),
        ]
    })
}

/// A sweep file built from parts: 1–3 axes of 1–2 values each (at most 8 cells), maybe an
/// extra localizer with a parameter, maybe an expectation.
fn structured() -> impl Strategy<Value = String> {
    (
        prop::collection::vec((select(PATHS), prop::collection::vec(value(), 1..3)), 0..4),
        prop::option::of((select(PATHS), value())),
        prop::option::of((
            select(&["odometry", "mine", "x"][..]),
            select(PATHS),
            value(),
        )),
        select(&["1", "1", "1", "2", "0", "-1", "1000000"][..]),
    )
        .prop_map(|(axes, own, expect, trials)| {
            let mut t = toml::Table::new();
            t.insert("base".into(), toml::Value::String("base.toml".into()));
            t.insert("seed".into(), toml::Value::Integer(1));
            t.insert(
                "trials".into(),
                trials.parse::<i64>().map(toml::Value::Integer).unwrap(),
            );
            let mut a = toml::Table::new();
            for (path, values) in axes {
                a.insert(path.into(), toml::Value::Array(values));
            }
            t.insert("axes".into(), toml::Value::Table(a));
            if let Some((key, v)) = own {
                let mut l = toml::Table::new();
                l.insert("name".into(), toml::Value::String("mine".into()));
                l.insert("kind".into(), toml::Value::String("dead_reckoning".into()));
                l.insert(key.into(), v);
                t.insert(
                    "localizers".into(),
                    toml::Value::Array(vec![toml::Value::Table(l)]),
                );
            }
            if let Some((name, key, v)) = expect {
                let mut e = toml::Table::new();
                let mut inner = toml::Table::new();
                inner.insert(key.into(), v);
                e.insert(name.into(), toml::Value::Table(inner));
                t.insert("expect".into(), toml::Value::Table(e));
            }
            toml::to_string(&t).unwrap_or_default()
        })
}

proptest! {
    #![proptest_config(config(96))]

    #[test]
    fn structured_sweeps_load_or_fail_cleanly(text in structured()) {
        load(&text);
    }

    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,300}") {
        load(&text);
    }

    #[test]
    fn token_soup_in_the_axes_never_panics(tokens in prop::collection::vec(select(TOKENS), 0..30)) {
        load(&format!("base = \"base.toml\"\nseed = 1\ntrials = 100000\n[axes]\n{}", tokens.concat()));
    }

    #[test]
    fn mutated_sweeps_never_panic(mutations in prop::collection::vec(mutation(TOKENS, NUMBERS), 1..6)) {
        load(&apply(BASE, &mutations, toml_number_spans));
    }

    #[test]
    fn any_results_file_reads_back_as_written(
        name in field(),
        paths in prop::collection::vec(field(), 0..3),
        cells in prop::collection::vec(prop::collection::vec(field(), 0..5), 0..5),
    ) {
        let r = results(name, paths, cells);
        let text = r.to_text();
        let back = csv::parse_results(&text).map_err(|e| TestCaseError::fail(format!("{e:?}\n{text:?}")))?;
        prop_assert_eq!(&back.name, &r.name);
        prop_assert_eq!(&back.axis_paths, &r.axis_paths);
        prop_assert_eq!(&back.rows, &r.rows);
        prop_assert_eq!(back.layout, r.layout);
        prop_assert!(!back.dropped_partial);
        // Any prefix is the file of a killed sweep: whole records read, the torn one dropped.
        for cut in (0..text.len()).filter(|&c| text.is_char_boundary(c)).step_by(7) {
            if let Ok(p) = csv::parse_results(&text[..cut]) {
                prop_assert!(r.rows.starts_with(&p.rows));
            }
        }
    }

    #[test]
    fn damaged_results_files_read_or_fail_cleanly(
        mutations in prop::collection::vec(mutation(TOKENS, NUMBERS), 1..6),
    ) {
        let r = results("n".into(), vec!["a".into(), "b,c".into()], vec![
            vec!["1".into(), "x\ny".into(), "l".into()],
            vec!["\"q\"".into(), "2".into(), "m".into()],
        ]);
        let _ = csv::parse_results(&apply(&r.to_text(), &mutations, toml_number_spans));
    }
}

#[test]
fn base_loads() {
    let s = Sweep::from_toml_str(BASE, &dir().join("fuzz.toml")).unwrap();
    assert_eq!(s.cells(), 4);
    assert_eq!(s.axes.len(), 3);
}

/// Hand-picked inputs next to what the properties draw.
#[test]
fn edge_cases() {
    // A duplicated `[axes.controller]` header with a dotted key of the same path: the two
    // spellings are one parameter.
    let e = Sweep::from_toml_str(
        &BASE.replace(
            "[axes.controller]",
            "\"controller.max_speed\" = [0.5]\n[axes.controller]",
        ),
        &dir().join("fuzz.toml"),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("are the same parameter controller.max_speed"),
        "{e}"
    );
}
