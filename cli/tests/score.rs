//! `atrium score`: a trajectory written by `atrium run --out` scored against the recording of
//! the same run gives the live run's figures (TUM, CSV and MCAP estimates), and bad estimates
//! are refused with exit 2 naming the problem, or scored with a stated warning.

mod common;

use common::{atrium, tmpdir};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn json_of(o: &Output) -> Value {
    assert!(
        matches!(o.status.code(), Some(0 | 1)),
        "exit {:?}: {}",
        o.status.code(),
        stderr(o)
    );
    serde_json::from_slice(&o.stdout).unwrap()
}

/// `atrium run short.toml --out DIR --json` and `atrium record short.toml -o R.mcap` in
/// `dir`: the run's JSON, the recording.
fn run_and_record(dir: &Path) -> (Value, PathBuf) {
    let s = data("short.toml");
    let out = dir.join("run");
    let run = json_of(&atrium(&[
        "run",
        s.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--json",
    ]));
    let rec = dir.join("short.mcap");
    let o = atrium(&["record", s.to_str().unwrap(), "-o", rec.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    (run, rec)
}

fn score(args: &[&str]) -> Output {
    let mut all = vec!["score"];
    all.extend_from_slice(args);
    atrium(&all)
}

fn localizer<'a>(doc: &'a Value, name: &str) -> &'a Value {
    doc["localizers"]
        .as_array()
        .unwrap()
        .iter()
        .find(|l| l["name"] == name)
        .unwrap_or_else(|| panic!("no localizer {name}"))
}

/// Position figures equal to the bit (positions round-trip through every input format), the
/// heading figures to 1e-12 (a heading goes through a quaternion).
fn assert_same_figures(live: &Value, scored: &Value, what: &str) {
    for k in ["min", "median", "mean", "rmse", "p95", "max", "samples"] {
        assert_eq!(
            live["position_error"][k], scored["position_error"][k],
            "{what}: position_error.{k}"
        );
        let (a, b) = (
            live["heading_error"][k].as_f64().unwrap(),
            scored["heading_error"][k].as_f64().unwrap(),
        );
        assert!((a - b).abs() < 1e-12, "{what}: heading_error.{k} {a} {b}");
    }
    for k in ["per_region", "per_region_kind"] {
        let (a, b) = (live[k].as_object().unwrap(), scored[k].as_object().unwrap());
        assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
        for (region, stats) in a {
            assert_eq!(stats["median"], b[region]["median"], "{what}: {k}.{region}");
            assert_eq!(stats["max"], b[region]["max"], "{what}: {k}.{region}");
        }
    }
    for k in ["final_position_error", "converged_after_s"] {
        assert_eq!(live[k], scored[k], "{what}: {k}");
    }
    assert_eq!(live["expectations"], scored["expectations"], "{what}");
}

#[test]
fn scoring_run_trajectories_gives_the_live_run_figures() {
    let dir = tmpdir("score");
    let (run, rec) = run_and_record(&dir);
    let rec_s = rec.to_str().unwrap();
    let tum = dir.join("run/mcl.tum");

    // TUM, named after the file stem: the scenario's [expect.mcl] applies.
    let doc = json_of(&score(&[rec_s, tum.to_str().unwrap(), "--json"]));
    let locs = doc["localizers"].as_array().unwrap();
    assert_eq!(locs.len(), 1);
    assert_eq!(locs[0]["kind"], "foreign_trajectory");
    let live = localizer(&run, "mcl");
    assert!(!live["expectations"].as_array().unwrap().is_empty());
    assert_same_figures(live, &locs[0], "mcl.tum");
    assert_eq!(doc["passed"], run["passed"]);
    let c = &doc["score"]["coverage"];
    assert_eq!(c["covered_fraction"], 1.0);
    assert_eq!(c["scoring_instants"], live["position_error"]["samples"]);
    assert_eq!(doc["score"]["format"], "tum");
    assert!(doc["score"]["warnings"].as_array().unwrap().is_empty());

    // Another localizer's file under --name, with --out writing a run's files.
    let out = dir.join("scored");
    let doc = json_of(&score(&[
        rec_s,
        dir.join("run/odometry.tum").to_str().unwrap(),
        "--name",
        "dr",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]));
    assert_same_figures(localizer(&run, "odometry"), localizer(&doc, "dr"), "dr");
    for f in [
        "ground_truth.tum",
        "dr.tum",
        "metrics.json",
        "trajectory_dr.svg",
        "trajectory_dr.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    assert_eq!(
        std::fs::read_to_string(out.join("ground_truth.tum")).unwrap(),
        std::fs::read_to_string(dir.join("run/ground_truth.tum")).unwrap()
    );

    // CSV with a header, theta from the TUM quaternion.
    let mut csv = String::from("t,x,y,theta\n");
    for l in std::fs::read_to_string(&tum).unwrap().lines() {
        let f: Vec<&str> = l.split(' ').collect();
        let (qz, qw): (f64, f64) = (f[6].parse().unwrap(), f[7].parse().unwrap());
        csv += &format!("{},{},{},{}\n", f[0], f[1], f[2], 2.0 * qz.atan2(qw));
    }
    let csv_path = dir.join("mine.csv");
    std::fs::write(&csv_path, csv).unwrap();
    let doc = json_of(&score(&[
        rec_s,
        csv_path.to_str().unwrap(),
        "--name",
        "mcl",
        "--json",
    ]));
    assert_eq!(doc["score"]["format"], "csv");
    assert_same_figures(live, localizer(&doc, "mcl"), "csv");

    // MCAP: the recording's own /estimate/mcl topic (foxglove.PoseInFrame).
    let o = score(&[rec_s, rec_s]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--topic"), "{}", stderr(&o));
    let doc = json_of(&score(&[
        rec_s,
        rec_s,
        "--topic",
        "/estimate/mcl",
        "--json",
    ]));
    assert_eq!(doc["score"]["topic"], "/estimate/mcl");
    assert_same_figures(live, localizer(&doc, "mcl"), "mcap");

    // The text report: the same tables as `atrium run`.
    let o = score(&[rec_s, tum.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "covers 124 of 124",
        "position error (m)",
        "per region",
        "[pass] mcl",
    ] {
        assert!(text.contains(needle), "{needle:?} not in {text}");
    }

    // --out into the estimates' own folder would overwrite them.
    let o = score(&[
        rec_s,
        tum.to_str().unwrap(),
        "--out",
        dir.join("run").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("overwrite"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_estimates_are_refused_or_warned_about() {
    let dir = tmpdir("score-bad");
    let (run, rec) = run_and_record(&dir);
    let rec_s = rec.to_str().unwrap();
    let lines: Vec<String> = std::fs::read_to_string(dir.join("run/mcl.tum"))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    let n = lines.len();
    let write = |name: &str, lines: &[String]| {
        let p = dir.join(name);
        std::fs::write(&p, lines.join("\n") + "\n").unwrap();
        p
    };
    let shifted = |dt: f64| -> Vec<String> {
        lines
            .iter()
            .map(|l| {
                let (t, rest) = l.split_once(' ').unwrap();
                format!("{:.6} {rest}", t.parse::<f64>().unwrap() + dt)
            })
            .collect()
    };
    let refused = |path: &Path, needles: &[&str]| {
        let o = score(&[rec_s, path.to_str().unwrap()]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{}: {err}", path.display());
        assert!(!err.contains("panicked"), "{err}");
        assert!(
            err.contains(path.file_name().unwrap().to_str().unwrap()),
            "{err}"
        );
        for needle in needles {
            assert!(err.contains(needle), "{needle:?} not in {err:?}");
        }
    };

    // Two lines swapped: the later one is named.
    let mut unordered = lines.clone();
    unordered.swap(9, 10);
    let p = write("unordered.tum", &unordered);
    refused(&p, &["line 11", "line 10", "time order"]);
    let mut twice = lines.clone();
    twice.insert(5, lines[5].clone());
    refused(&write("twice.tum", &twice), &["line 7", "repeats"]);

    // Stamps from the wall clock, and from a clock offset by a few seconds.
    let p = write("unix.tum", &shifted(1.7e9));
    refused(
        &p,
        &[
            "clocks do not match",
            "Unix epoch",
            "recording spans [0.100,",
        ],
    );
    let p = write("offset.tum", &shifted(4.0));
    refused(&p, &["clocks do not match", "offset"]);

    // The middle half of the run: scored with a warning saying how much is covered.
    let part = write("part.tum", &lines[n / 4..3 * n / 4]);
    let o = score(&[rec_s, part.to_str().unwrap(), "--name", "mcl", "--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.contains("warning") && err.contains("cover"), "{err}");
    let doc: Value = serde_json::from_slice(&o.stdout).unwrap();
    let c = &doc["score"]["coverage"];
    assert_eq!(c["covered_instants"], (3 * n / 4 - n / 4) as u64);
    assert_eq!(
        c["before_first"].as_u64().unwrap() + c["after_last"].as_u64().unwrap(),
        (n - (3 * n / 4 - n / 4)) as u64
    );
    assert_eq!(doc["score"]["warnings"].as_array().unwrap().len(), 1);
    // Every scoring instant is still scored (first / last estimate held).
    assert_eq!(
        localizer(&doc, "mcl")["position_error"]["samples"],
        localizer(&run, "mcl")["position_error"]["samples"]
    );

    // Not a number, a short line, and --name that cannot be a file name.
    let mut nan = lines.clone();
    nan[3] = "0.4 NaN 20 0 0 0 0 1".into();
    refused(&write("nan.tum", &nan), &["line 4", "not a number"]);
    let mut short = lines.clone();
    short[2] = "0.3 2 20".into();
    refused(&write("short_line.tum", &short), &["line 3", "expected 8"]);
    let o = score(&[rec_s, part.to_str().unwrap(), "--name", "../x"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--name"), "{}", stderr(&o));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 45: estimates that are wrong are refused naming the line or argument; legal but
/// suspicious ones (headings in degrees, a trajectory much longer than the recording) are
/// scored with a warning.
#[test]
fn hostile_estimates_round_three() {
    let dir = tmpdir("score-45");
    let (_, rec) = run_and_record(&dir);
    let rec_s = rec.to_str().unwrap();
    let lines: Vec<String> = std::fs::read_to_string(dir.join("run/mcl.tum"))
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    let write = |name: &str, lines: &[String]| {
        let p = dir.join(name);
        std::fs::write(&p, lines.join("\n") + "\n").unwrap();
        p
    };
    // Coordinates near 1e308 and 1e200 overflowed rmse and mean to null / inf.
    for (name, v) in [("huge308.tum", "1.7e308"), ("huge200.tum", "-1e200")] {
        let mut huge = lines.clone();
        let f: Vec<&str> = huge[3].split(' ').collect();
        huge[3] = format!("{} {v} {} 0 0 0 0 1", f[0], f[2]);
        let p = write(name, &huge);
        let o = score(&[rec_s, p.to_str().unwrap(), "--json"]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains(name) && err.contains("line 4") && err.contains("farther than"),
            "{err}"
        );
    }
    // Arguments swapped: the first is said not to be a recording.
    let good = write("good.tum", &lines);
    let o = score(&[good.to_str().unwrap(), rec_s]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("good.tum") && err.contains("is not a recording") && err.contains("swapped"),
        "{err}"
    );
    // A CSV with theta in degrees: scored, with a warning.
    let mut csv = vec!["t,x,y,theta".to_string()];
    for l in &lines {
        let f: Vec<f64> = l.split(' ').map(|v| v.parse().unwrap()).collect();
        let yaw =
            (2.0 * (f[7] * f[6] + f[4] * f[5])).atan2(1.0 - 2.0 * (f[5] * f[5] + f[6] * f[6]));
        csv.push(format!(
            "{},{},{},{}",
            f[0],
            f[1],
            f[2],
            90.0 + yaw.to_degrees()
        ));
    }
    let p = write("degrees.csv", &csv);
    let o = score(&[rec_s, p.to_str().unwrap(), "--name", "mcl"]);
    let err = stderr(&o);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{err}");
    assert!(
        err.contains("warning") && err.contains("beyond ±2π"),
        "{err}"
    );
    // A trajectory twice as long as the recording (of another run): a warning.
    let span = {
        let t = |l: &String| l.split(' ').next().unwrap().parse::<f64>().unwrap();
        t(&lines[lines.len() - 1]) - t(&lines[0])
    };
    let mut long = lines.clone();
    for l in &lines {
        let (t, rest) = l.split_once(' ').unwrap();
        long.push(format!(
            "{:.6} {rest}",
            t.parse::<f64>().unwrap() + span + 0.5
        ));
    }
    let p = write("long.tum", &long);
    let o = score(&[rec_s, p.to_str().unwrap(), "--name", "mcl"]);
    let err = stderr(&o);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{err}");
    assert!(err.contains("lie outside the recording"), "{err}");
    // The trajectory itself: no such warning.
    let o = score(&[rec_s, good.to_str().unwrap(), "--name", "mcl"]);
    let err = stderr(&o);
    assert!(!err.contains("warning"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}
