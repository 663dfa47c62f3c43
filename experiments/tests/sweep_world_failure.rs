//! Issue 17, parts 2 and 4: sweep axes over a generated world (`world.<parameter>`) and the
//! failure curves along numeric axes.

mod common;

use atrium_experiments::sweep::{csv, merge, run_sweep, Sweep, SweepSettings};
use atrium_localization::mcl::MclParams;
use atrium_scenarios::maps::SharedMaps;
use atrium_scenarios::scenario::Scenario;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn generated_office() -> PathBuf {
    root().join("scenarios/generated_office.toml")
}

/// A sweep file in `dir` over the bundled generated office (absolute base path).
fn sweep_file(dir: &Path, body: &str) -> PathBuf {
    let f = dir.join("s.toml");
    std::fs::write(
        &f,
        format!(
            "base = {:?}\nseed = 5\ntrials = 2\n{body}",
            generated_office()
        ),
    )
    .unwrap();
    f
}

fn settings(out: PathBuf, jobs: usize, shard: Option<(usize, usize)>) -> SweepSettings {
    SweepSettings {
        out,
        jobs: Some(jobs),
        shard,
        resume: false,
        progress: false,
    }
}

/// The rows of a CSV file with a header row, as maps from column name to field.
fn table(text: &str) -> Vec<std::collections::BTreeMap<String, String>> {
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            head.iter()
                .zip(l.split(','))
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect()
        })
        .collect()
}

#[test]
fn reduced_atrium_sweep_writes_failure_curves_over_generated_worlds() {
    let file = root().join("scenarios/sweeps/atrium_size_reduced.toml");
    let sweep = Sweep::load(&file).unwrap();
    assert_eq!(sweep.cells(), 3);

    // Every cell generates its own world: three different worlds, three hashes.
    let worlds: Vec<_> = (0..3)
        .map(|c| sweep.cell_scenario(c).unwrap().world)
        .collect();
    assert!(worlds[0] != worlds[1] && worlds[1] != worlds[2] && worlds[0] != worlds[2]);
    let atrium_height = |c: usize| {
        let r = worlds[c]
            .regions
            .iter()
            .find(|r| r.name == "atrium")
            .unwrap();
        let ys: Vec<f64> = r.polygon.iter().map(|p| p[1]).collect();
        ys.iter().copied().fold(f64::MIN, f64::max) - ys.iter().copied().fold(f64::MAX, f64::min)
    };
    for (c, w) in [(0, 8.0), (1, 12.0), (2, 16.0)] {
        assert!((atrium_height(c) - w).abs() < 1e-9, "cell {c}");
    }
    let hashes: std::collections::BTreeSet<&String> = sweep.world_hashes.values().collect();
    assert_eq!((sweep.world_hashes.len(), hashes.len()), (3, 3));

    let tmp = common::tmpdir("sweep-world-failure");
    let mut per_min = Vec::new();
    let mut curves_text = Vec::new();
    for jobs in [1, 2] {
        let out = tmp.join(format!("j{jobs}"));
        let o = run_sweep(&sweep, &settings(out.clone(), jobs, None)).unwrap();
        assert_eq!(o.ran, 6);
        per_min.push(6.0 / o.wall_s * 60.0);
        curves_text.push(std::fs::read_to_string(out.join("failure_curves.csv")).unwrap());
        let png = out.join("failure_world.atrium_width_duration_s=80.0.png");
        assert!(o.pictures.contains(&png), "{:?}", o.pictures);
    }
    eprintln!(
        "reduced atrium sweep: {:.0} trials/min on 1 job, {:.0} on 2",
        per_min[0], per_min[1]
    );
    assert_eq!(
        curves_text[0], curves_text[1],
        "independent of the thread count"
    );
    let out = tmp.join("j1");

    // results.csv: the failed-time fraction of every row lies in [0, 1].
    let results = csv::read_results(&out.join("results.csv")).unwrap();
    assert!(results.has_failure_column());
    for r in &results.rows {
        let f = csv::failed_time_frac(r).unwrap();
        assert!((0.0..=1.0).contains(&f), "{r:?}");
    }

    // results.csv: every trial's drive, the same on each localizer's row, and the very drive
    // a run of that trial's scenario and seed makes.
    let mut drives = std::collections::BTreeMap::new();
    for r in &results.rows {
        let d = (
            csv::distance_m(r).unwrap(),
            csv::route_completed(r).unwrap(),
        );
        assert!(d.0 > 1.0, "{r:?}");
        assert_eq!(*drives.entry((r.cell, r.trial)).or_insert(d), d, "{r:?}");
    }
    assert_eq!(drives.len(), 6);
    let (cell, trial) = (2, 1);
    let direct = sweep
        .registry
        .run(
            &sweep.cell_scenario(cell).unwrap(),
            atrium_scenarios::runner::RunOptions {
                seed: Some(atrium_experiments::sweep::run::trial_seed(
                    sweep.seed, cell, trial,
                )),
                ..Default::default()
            },
        )
        .unwrap();
    assert_eq!(
        drives[&(cell, trial)],
        (
            format!("{:.3}", direct.distance_m).parse().unwrap(),
            direct.route_completed
        )
    );
    // summary.md says per cell how far its trials drove.
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert_eq!(
        summary.matches("Distance driven per trial: ").count(),
        3,
        "{summary}"
    );

    // sweep.json: the settings and a world hash per cell.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("sweep.json")).unwrap()).unwrap();
    assert_eq!(json["failure"]["error_threshold_m"], 1.0);
    assert_eq!(json["world_hashes"].as_object().unwrap().len(), 3);

    // failure_curves.csv: both localizers at the three widths in increasing order, each
    // estimate inside its interval; duration_s (one value) is held fixed.
    let rows = table(&curves_text[0]);
    assert_eq!(rows.len(), 6);
    for loc in ["mcl", "odometry"] {
        let mine: Vec<_> = rows.iter().filter(|r| r["localizer"] == loc).collect();
        let values: Vec<&str> = mine.iter().map(|r| r["value"].as_str()).collect();
        assert_eq!(values, ["8.0", "12.0", "16.0"], "{loc}");
        for r in &mine {
            assert_eq!(r["axis"], "world.atrium_width");
            assert_eq!(r["fixed"], "duration_s=80.0");
            assert_eq!(r["trials"], "2");
            for stat in ["median", "p95", "time_failed", "lost"] {
                let col = if stat == "median" || stat == "p95" {
                    format!("{stat}_m")
                } else {
                    stat.to_string()
                };
                let v: f64 = r[&col].parse().unwrap();
                let lo: f64 = r[&format!("{stat}_lo")].parse().unwrap();
                let hi: f64 = r[&format!("{stat}_hi")].parse().unwrap();
                assert!(lo <= v + 1e-9 && v <= hi + 1e-9, "{loc} {stat}: {r:?}");
            }
        }
    }
    // Laser MCL tracks: far below dead reckoning's error at every width.
    let med = |loc: &str, v: &str| -> f64 {
        rows.iter()
            .find(|r| r["localizer"] == loc && r["value"] == v)
            .unwrap()["median_m"]
            .parse()
            .unwrap()
    };
    for v in ["8.0", "12.0", "16.0"] {
        assert!(
            med("mcl", v) < 0.2 && med("mcl", v) < med("odometry", v),
            "{v}"
        );
    }

    // summary.md names, per localizer, the first width at which its failed time exceeds
    // 50 %: the one the CSV says.
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("# Failure curves"), "{summary}");
    assert!(
        summary.contains("## Failure along world.atrium_width (duration_s = 80.0)"),
        "{summary}"
    );
    for loc in ["mcl", "odometry"] {
        let first = rows
            .iter()
            .filter(|r| r["localizer"] == loc)
            .find(|r| r["time_failed"].parse::<f64>().unwrap() > 0.5);
        let line = summary
            .lines()
            .find(|l| l.starts_with(&format!("- {loc}: time with error > 1 m ")))
            .unwrap_or_else(|| panic!("no line for {loc}:\n{summary}"));
        match first {
            Some(r) => assert!(
                line.contains(&format!(
                    "first exceeds 50 % at world.atrium_width = {}",
                    r["value"]
                )),
                "{line}"
            ),
            None => assert!(
                line.contains("time with error > 1 m never exceeds 50 %"),
                "{line}"
            ),
        }
        assert!(
            line.contains("; trials lost (final error > 2 m) "),
            "{line}"
        );
    }
    assert!(
        summary.contains("No failure curves along: duration_s (a single value)."),
        "{summary}"
    );

    // The picture, as PNG and SVG: one colour per localizer, the threshold labelled.
    assert!(out
        .join("failure_world.atrium_width_duration_s=80.0.png")
        .is_file());
    let svg = std::fs::read_to_string(out.join("failure_world.atrium_width_duration_s=80.0.svg"))
        .unwrap();
    for k in 0..2 {
        let c = atrium_scenarios::figure::colour::line_colour(k);
        let hex = format!("#{:02X}{:02X}{:02X}", c[0], c[1], c[2]);
        assert!(svg.contains(&hex), "colour {hex} missing");
    }
    assert!(svg.contains("failure threshold"), "threshold unlabelled");
}

#[test]
fn cells_share_derived_maps_only_when_their_worlds_are_equal() {
    let dir = common::tmpdir("sweep-world-maps");
    let f = sweep_file(
        &dir,
        "[axes]\n\"world.atrium_width\" = [12.0, 16.0]\nduration_s = [20.0, 30.0]\n",
    );
    let sweep = Sweep::load(&f).unwrap();
    // Cells in the order (width, duration) = (12, 20), (12, 30), (16, 20), (16, 30),
    // whatever order the axes are stored in.
    let cell = |w: f64, d: f64| {
        (0..4)
            .find(|&c| {
                let p = sweep.cell_params(c);
                let v = |path: &str| p.iter().find(|x| x.0 == path).unwrap().1.as_float();
                v("world.atrium_width") == Some(w) && v("duration_s") == Some(d)
            })
            .unwrap()
    };
    let cells = [
        cell(12.0, 20.0),
        cell(12.0, 30.0),
        cell(16.0, 20.0),
        cell(16.0, 30.0),
    ];
    let scenarios: Vec<Scenario> = cells
        .iter()
        .map(|&c| sweep.cell_scenario(c).unwrap())
        .collect();
    assert_eq!(scenarios[0].world, scenarios[1].world);
    assert_ne!(scenarios[0].world, scenarios[2].world);
    let hash = |k: usize| &sweep.world_hashes[&cells[k]];
    assert_eq!(hash(0), hash(1));
    assert_ne!(hash(0), hash(2));

    let params = MclParams::default();
    let mut maps: Vec<SharedMaps> = (0..4).map(|_| SharedMaps::default()).collect();
    let fields: Vec<_> = maps
        .iter_mut()
        .zip(&scenarios)
        .map(|(m, s)| m.mcl_map(s, &params).unwrap())
        .collect();
    assert!(Arc::ptr_eq(&fields[0], &fields[1]), "same world: one field");
    assert!(Arc::ptr_eq(&fields[2], &fields[3]), "same world: one field");
    assert!(
        !Arc::ptr_eq(&fields[0], &fields[2]),
        "other world: its own field"
    );
    let vector = |k: usize, m: &mut SharedMaps| m.vector_map(&scenarios[k]) as *const _;
    let (a, rest) = maps.split_at_mut(1);
    let (b, rest) = rest.split_at_mut(1);
    assert_eq!(vector(0, &mut a[0]), vector(1, &mut b[0]));
    assert_ne!(vector(0, &mut a[0]), vector(2, &mut rest[0]));
}

#[test]
fn scenario_world_params_generate_the_world_or_name_the_parameter() {
    let text = std::fs::read_to_string(generated_office()).unwrap();
    let file = generated_office();
    let plain = Scenario::from_toml_str(&text, &file).unwrap();
    assert!(plain.world_params.is_empty());
    // A table after the scenario's own: TOML's tables may come in any order.
    let with = |params: &str| {
        Scenario::from_toml_str(&format!("{text}\n[world_params]\n{params}\n"), &file)
    };
    let wide = with("atrium_width = 12.0").unwrap();
    assert_ne!(wide.world, plain.world);
    assert_eq!(wide.world_params["atrium_width"].as_float(), Some(12.0));
    // The same world the generator file makes with the parameter set.
    let mut g =
        atrium_worlds::GeneratorFile::load(&root().join("worlds/office_atrium_gen.toml")).unwrap();
    g.set("atrium_width", toml::Value::Float(12.0)).unwrap();
    let expected = g
        .generate(&atrium_worlds::GeneratorRegistry::with_builtins())
        .unwrap();
    assert_eq!(wide.world, expected);

    let e = with("atrium_wdth = 12.0").unwrap_err().to_string();
    assert!(
        e.contains("generated_office.toml: world_params.atrium_wdth: unknown parameter"),
        "{e}"
    );
    let e = with("atrium_width = 40.0").unwrap_err().to_string();
    assert!(
        e.contains("world_params.atrium_width: 40 m is wider than the floor")
            && !e.contains("--set"),
        "{e}"
    );
    // A world as written has no parameters.
    let corridor = root().join("scenarios/corridor_tracking.toml");
    let t = std::fs::read_to_string(&corridor).unwrap();
    let e = Scenario::from_toml_str(&format!("{t}\n[world_params]\nseed = 2\n"), &corridor)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("corridor_tracking.toml: world_params: is not a generator file"),
        "{e}"
    );
}

#[test]
fn bad_world_axes_are_refused_naming_the_axis_and_parameter() {
    let dir = common::tmpdir("sweep-world-bad");
    let err = |body: &str| {
        Sweep::load(&sweep_file(&dir, body))
            .unwrap_err()
            .to_string()
    };

    let e = err("[axes]\n\"world.atrium_wdth\" = [10.0]\n");
    assert!(
        e.contains("s.toml: axes.world.atrium_wdth: \"atrium_wdth\" is not a parameter of generator \"office_atrium\"")
            && e.contains("atrium_width")
            && e.contains("(line 5)"),
        "{e}"
    );
    let e = err("[axes]\n\"world.atrium_width\" = [8.0, 40.0]\n");
    assert!(
        e.contains("s.toml: axes.world.atrium_width: atrium_width: 40 m is wider than the floor")
            && e.contains("(value 40.0, line 5)")
            && !e.contains("--set"),
        "{e}"
    );
    let e = err("[axes]\n\"world.atrium_width\" = [\"wide\"]\n");
    assert!(
        e.contains("axes.world.atrium_width: atrium_width:") && e.contains("value \"wide\""),
        "{e}"
    );
    let e = err("[axes.world.atrium]\nwidth = [10.0]\n");
    assert!(
        e.contains("axes.world.atrium.width: \"atrium.width\" is not a generator parameter"),
        "{e}"
    );
    // A localizer learning from another scenario's world.
    let e = err(
        "[axes]\n\"world.atrium_width\" = [10.0]\n[[localizers]]\nname = \"wifi\"\n\
         kind = \"wifi\"\ntraining = \"wifi_survey.toml\"\n",
    );
    assert!(
        e.contains("axes.world.atrium_width: localizer \"wifi\" learns from another scenario"),
        "{e}"
    );

    // A base scenario whose world is a world file, not a generator file.
    let base = dir.join("base.toml");
    let corridor = root().join("scenarios/corridor_tracking.toml");
    let text = std::fs::read_to_string(&corridor)
        .unwrap()
        .replace("\"../", &format!("\"{}/", root().display()));
    std::fs::write(&base, text).unwrap();
    let f = dir.join("plain.toml");
    std::fs::write(
        &f,
        "base = \"base.toml\"\nseed = 1\ntrials = 1\n[axes]\n\"world.atrium_width\" = [10.0]\n",
    )
    .unwrap();
    let e = Sweep::load(&f).unwrap_err().to_string();
    assert!(
        e.contains("plain.toml: axes.world.atrium_width: atrium_width: the base scenario's world")
            && e.contains("is not a generator file")
            && e.contains("(line 5)"),
        "{e}"
    );
}

#[test]
fn shards_merge_to_the_same_failure_curves() {
    let dir = common::tmpdir("sweep-world-merge");
    let f = sweep_file(
        &dir,
        "[axes]\n\"world.atrium_width\" = [12.0, 16.0]\nduration_s = [10.0]\n\
         [failure]\nerror_threshold_m = 0.05\nbootstrap = 200\n",
    );
    let sweep = Sweep::load(&f).unwrap();
    let whole = dir.join("whole");
    run_sweep(&sweep, &settings(whole.clone(), 2, None)).unwrap();
    for i in 0..2 {
        run_sweep(
            &sweep,
            &settings(dir.join(format!("s{i}")), 1, Some((i, 2))),
        )
        .unwrap();
    }
    merge(&dir.join("merged"), &[dir.join("s0"), dir.join("s1")]).unwrap();
    let read = |d: &str, f: &str| std::fs::read_to_string(dir.join(d).join(f)).unwrap();
    assert_eq!(
        read("whole", "failure_curves.csv"),
        read("merged", "failure_curves.csv")
    );
    // The sweep file's threshold, recorded in sweep.json, reached the merge.
    assert!(read("merged", "summary.md").contains("time with error > 0.05 m"));
    assert!(dir
        .join("merged/failure_world.atrium_width_duration_s=10.0.png")
        .is_file());
    // Another threshold is another sweep: its hash differs.
    let g = sweep_file(
        &dir,
        "[axes]\n\"world.atrium_width\" = [12.0, 16.0]\nduration_s = [10.0]\n",
    );
    assert_ne!(Sweep::load(&g).unwrap().hash, sweep.hash);
}

#[test]
fn a_training_scenario_on_the_same_generator_file_surveys_each_cells_world() {
    // The atrium study's WiFi survey drives the study's generator file: a cell's
    // [world_params] reach the survey, so each width is surveyed in its own world.
    let study = Scenario::load(&root().join("scenarios/atrium_study.toml")).unwrap();
    let survey_file = root().join("scenarios/atrium_study_survey.toml");
    let atrium_height = |s: &Scenario| {
        let r = s.world.regions.iter().find(|r| r.name == "atrium").unwrap();
        let ys: Vec<f64> = r.polygon.iter().map(|p| p[1]).collect();
        ys.iter().copied().fold(f64::MIN, f64::max) - ys.iter().copied().fold(f64::MAX, f64::min)
    };
    assert_eq!(
        atrium_height(&study.load_training(&survey_file).unwrap()),
        20.0
    );
    for w in [10.0, 30.0] {
        let mut cell = study.clone();
        cell.world_params
            .insert("atrium_width".into(), toml::Value::Float(w));
        let survey = cell.load_training(&survey_file).unwrap();
        assert_eq!(atrium_height(&survey), w);
        assert_eq!(
            survey.world_params["atrium_length"],
            toml::Value::Float(40.0)
        );
    }
    // So the bundled study, whose base has a WiFi localizer, is a valid world sweep.
    let sweep = Sweep::load(&root().join("scenarios/sweeps/atrium_size.toml")).unwrap();
    assert_eq!(sweep.cells(), 7);
}
