//! `atrium sweep`: results independent of threads and shards, resume redoes only missing
//! trials, bad input exits 2 naming the axis or file.

mod common;

use common::{atrium, tmpdir};
use std::path::Path;
use std::process::Output;

/// A 2-cell × 2-trial sweep over a 2-second corridor scenario, written into `dir`.
fn tiny_sweep(dir: &Path, axes: &str) -> String {
    let base = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let text = format!(
        "base = {:?}\nseed = 3\ntrials = 2\n[axes]\n{axes}\n",
        base.to_str().unwrap()
    );
    let f = dir.join("tiny.toml");
    std::fs::write(&f, text).unwrap();
    f.to_str().unwrap().to_string()
}

const AXES: &str = "duration_s = [2.0]\n\"localizers.mcl.max_particles\" = [1000, 2000]";

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// The rows of a results.csv without the wall-time column (the only one that varies).
fn rows(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("results.csv"))
        .unwrap()
        .lines()
        .map(|l| match l.starts_with('#') {
            true => l.to_string(),
            false => l.rsplit_once(',').unwrap().0.to_string(),
        })
        .collect()
}

#[test]
fn threads_shards_and_resume_give_identical_rows() {
    let d = tmpdir("same");
    let sweep = tiny_sweep(&d, AXES);
    let out = |n: &str| d.join(n).to_str().unwrap().to_string();
    ok(&atrium(&[
        "sweep",
        &sweep,
        "--jobs",
        "1",
        "--out",
        &out("j1"),
    ]));
    ok(&atrium(&[
        "sweep",
        &sweep,
        "--jobs",
        "2",
        "--out",
        &out("j2"),
    ]));
    let reference = rows(&d.join("j1"));
    // header comment, column header, 2 cells × 2 trials × 2 localizers
    assert_eq!(reference.len(), 2 + 8);
    assert_eq!(reference, rows(&d.join("j2")));
    assert!(std::fs::read_to_string(d.join("j1/summary.md"))
        .unwrap()
        .contains("| mcl | 2 |"));

    ok(&atrium(&[
        "sweep",
        &sweep,
        "--shard",
        "0/2",
        "--out",
        &out("s0"),
    ]));
    ok(&atrium(&[
        "sweep",
        &sweep,
        "--shard",
        "1/2",
        "--out",
        &out("s1"),
    ]));
    assert_eq!(rows(&d.join("s0")).len(), 2 + 4);
    ok(&atrium(&[
        "sweep",
        "merge",
        &out("m"),
        &out("s0"),
        &out("s1"),
    ]));
    assert_eq!(reference, rows(&d.join("m")));

    // Simulate a kill: drop the last trial's rows and leave a torn partial line.
    let csv = d.join("j1/results.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let mut cut = lines[..lines.len() - 2].join("\n");
    cut.push_str("\n1.0,12");
    std::fs::write(&csv, cut).unwrap();
    let o = atrium(&["sweep", &sweep, "--resume", "--out", &out("j1")]);
    ok(&o);
    let msg = String::from_utf8_lossy(&o.stderr);
    assert!(msg.contains("ran 1 trials (3 already recorded)"), "{msg}");
    assert_eq!(reference, rows(&d.join("j1")));
    // Without --resume an existing result folder is refused.
    assert_eq!(
        atrium(&["sweep", &sweep, "--out", &out("j1")])
            .status
            .code(),
        Some(2)
    );
}

fn bad(args: &[&str], needle: &str) {
    let o = atrium(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains(needle), "expected {needle:?} in {err}");
}

#[test]
fn bad_input_exits_2_naming_the_problem() {
    let d = tmpdir("bad");
    let o = |n: &str| d.join(n).to_str().unwrap().to_string();
    let s = tiny_sweep(&d, "bogus_field = [1.0]");
    bad(&["sweep", &s, "--out", &o("x")], "axes.bogus_field");
    let s = tiny_sweep(&d, "duration_s = []");
    bad(&["sweep", &s, "--out", &o("x")], "axes.duration_s");
    let s = tiny_sweep(&d, "\"localizers.nope.max_particles\" = [10]");
    bad(
        &["sweep", &s, "--out", &o("x")],
        "no localizer named \"nope\"",
    );
    let s = tiny_sweep(&d, "\"localizers.mcl.max_partcles\" = [10]");
    bad(&["sweep", &s, "--out", &o("x")], "max_partcles");
    let s = tiny_sweep(&d, "\"odometry.radius_eror\" = [0.01]");
    bad(&["sweep", &s, "--out", &o("x")], "radius_eror");
    let s = tiny_sweep(&d, "duration_s = [-1.0]");
    bad(&["sweep", &s, "--out", &o("x")], "duration_s");
    let s = tiny_sweep(&d, "duration_s = [1.0]");
    bad(
        &["sweep", &s, "--shard", "2/2", "--out", &o("x")],
        "out of range",
    );

    // A results folder from another sweep is refused, for a run and for a merge.
    ok(&atrium(&["sweep", &s, "--out", &o("a")]));
    let s2 = tiny_sweep(&d, "duration_s = [1.5]");
    bad(
        &["sweep", &s2, "--resume", "--out", &o("a")],
        "different sweep",
    );
    ok(&atrium(&["sweep", &s2, "--out", &o("b")]));
    bad(
        &["sweep", "merge", &o("m"), &o("a"), &o("b")],
        "different sweep",
    );
}
