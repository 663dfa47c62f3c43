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

/// A folder holding a copy of the campus world and of the Pioneer's URDF and sensor file
/// (so a test may edit them), a 1-second dead-reckoning base scenario using them, and the
/// sweep `sweep_name` with `axes`. Returns the sweep file's path.
fn own_inputs(dir: &Path, sweep_name: &str, axes: &str) -> std::path::PathBuf {
    let root = atrium_scenarios::bundled_scenarios_dir().join("..");
    std::fs::copy(root.join("worlds/campus.toml"), dir.join("world.toml")).unwrap();
    std::fs::copy(
        root.join("robots/urdf/pioneer3dx.urdf"),
        dir.join("robot.urdf"),
    )
    .unwrap();
    std::fs::copy(
        root.join("robots/urdf/pioneer3dx.sensors.toml"),
        dir.join("robot.sensors.toml"),
    )
    .unwrap();
    std::fs::write(
        dir.join("base.toml"),
        "name = \"base\"\nduration_s = 1.0\nworld = \"world.toml\"\nrobot = \"robot.urdf\"\n\
         seed = 3\n[start]\npose = [2.0, 20.0, 0.0]\n[route]\nwaypoints = [[8.0, 20.0]]\n\
         [[localizers]]\nname = \"odometry\"\nkind = \"dead_reckoning\"\n",
    )
    .unwrap();
    let f = dir.join(sweep_name);
    std::fs::write(
        &f,
        format!("base = \"base.toml\"\nseed = 5\ntrials = 2\n[axes]\n{axes}\n"),
    )
    .unwrap();
    f
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

#[test]
fn newlines_commas_and_quotes_in_values_and_names_survive_every_step() {
    let d = tmpdir("odd");
    // A world axis naming files with a comma, quotes and a newline, in a sweep whose own
    // name holds them too.
    let odd_world = "wor,ld \"a\"\nb.toml";
    let f = own_inputs(
        &d,
        "odd, \"name\"\nx.toml",
        &format!("world = [\"world.toml\", {odd_world:?}]\n\"odometry.radius_error\" = [0.0]"),
    );
    std::fs::copy(d.join("world.toml"), d.join(odd_world)).unwrap();
    let out = |n: &str| s(&d.join(n));
    ok(&atrium(&["sweep", &s(&f), "--out", &out("whole")]));
    let whole = d.join("whole");
    let results = atrium_experiments::sweep::csv::read_results(&whole.join("results.csv")).unwrap();
    assert_eq!(results.name, "odd, \"name\"\nx");
    assert_eq!(results.axis_paths, ["odometry.radius_error", "world"]);
    let worlds: std::collections::BTreeSet<&str> =
        results.rows.iter().map(|r| r.params[1].as_str()).collect();
    assert_eq!(
        worlds,
        ["world.toml", odd_world].into_iter().collect(),
        "values read back as written"
    );
    assert_eq!(results.rows.len(), 4);
    let summary = std::fs::read_to_string(whole.join("summary.md")).unwrap();
    assert!(summary.contains("# Sweep odd, \"name\"\\nx"), "{summary}");
    assert!(
        summary.contains("world = wor,ld \"a\"\\nb.toml"),
        "{summary}"
    );
    let reference = rows(&whole);

    // Resume after a kill that tore the last record inside its quoted newline.
    let csv = whole.join("results.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let torn = text.rfind("b.toml").unwrap();
    std::fs::write(&csv, &text[..torn]).unwrap();
    let o = atrium(&["sweep", &s(&f), "--resume", "--out", &out("whole")]);
    ok(&o);
    assert!(
        String::from_utf8_lossy(&o.stderr).contains("ran 1 trials (3 already recorded)"),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(rows(&whole), reference);

    // Shards and their merge.
    for i in 0..2 {
        ok(&atrium(&[
            "sweep",
            &s(&f),
            "--shard",
            &format!("{i}/2"),
            "--out",
            &out(&format!("s{i}")),
        ]));
    }
    ok(&atrium(&[
        "sweep",
        "merge",
        &out("m"),
        &out("s0"),
        &out("s1"),
    ]));
    assert_eq!(rows(&d.join("m")), reference);
}

#[test]
fn merge_refuses_missing_duplicated_and_unfinished_shards() {
    let d = tmpdir("merge");
    let f = own_inputs(&d, "m.toml", "duration_s = [0.5, 1.0]");
    let out = |n: &str| s(&d.join(n));
    for i in 0..2 {
        ok(&atrium(&[
            "sweep",
            &s(&f),
            "--shard",
            &format!("{i}/2"),
            "--out",
            &out(&format!("s{i}")),
        ]));
    }
    // One shard of two.
    bad(
        &["sweep", "merge", &out("m"), &out("s0")],
        "the shards do not cover the sweep: shard 1/2 not given; 2 of 4 trials missing",
    );
    // The same shard twice, by one folder or a copy of it.
    bad(
        &["sweep", "merge", &out("m"), &out("s0"), &out("s0")],
        "s0 is given twice",
    );
    let copy = d.join("s0-copy");
    std::fs::create_dir_all(&copy).unwrap();
    for f in ["results.csv", "sweep.json"] {
        std::fs::copy(d.join("s0").join(f), copy.join(f)).unwrap();
    }
    bad(
        &["sweep", "merge", &out("m"), &out("s0"), &s(&copy)],
        "hold the same trials",
    );
    bad(
        &[
            "sweep",
            "merge",
            &out("m"),
            &out("s0"),
            &out("s1"),
            &s(&copy),
        ],
        "hold the same trials",
    );
    // Into one of the shards.
    bad(
        &["sweep", "merge", &out("s0"), &out("s0"), &out("s1")],
        "is one of the shard folders",
    );
    assert!(!d.join("m").exists(), "a refused merge wrote its folder");
    // An interrupted shard: its last trial's row is gone.
    let csv = d.join("s1/results.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines: Vec<&str> = text.lines().collect();
    lines.pop();
    std::fs::write(&csv, lines.join("\n") + "\n").unwrap();
    bad(
        &["sweep", "merge", &out("m"), &out("s0"), &out("s1")],
        "1 of 4 trials missing (cells 1; cell 1 trial 1)",
    );
    // Resumed as shard 0/2, shard 1's folder is refused; as shard 1/2 it is finished.
    bad(
        &[
            "sweep",
            &s(&f),
            "--resume",
            "--shard",
            "0/2",
            "--out",
            &out("s1"),
        ],
        "holds shard 1/2",
    );
    ok(&atrium(&[
        "sweep",
        &s(&f),
        "--resume",
        "--shard",
        "1/2",
        "--out",
        &out("s1"),
    ]));
    ok(&atrium(&[
        "sweep",
        "merge",
        &out("m"),
        &out("s0"),
        &out("s1"),
    ]));
    let merged = std::fs::read_to_string(d.join("m/results.csv")).unwrap();
    assert!(merged.starts_with("# atrium-sweep hash="));
    assert!(merged
        .lines()
        .next()
        .unwrap()
        .contains("cells=2 trials=2 shard=0/1"));
}

#[test]
fn resume_refuses_changed_inputs_naming_them() {
    let d = tmpdir("inputs");
    let f = own_inputs(&d, "r.toml", "duration_s = [0.5]");
    let out = s(&d.join("o"));
    ok(&atrium(&["sweep", &s(&f), "--out", &out]));
    // Unchanged: resume has nothing to do.
    let o = atrium(&["sweep", &s(&f), "--resume", "--out", &out]);
    ok(&o);
    assert!(String::from_utf8_lossy(&o.stderr).contains("ran 0 trials (2 already recorded)"));
    for (file, edit) in [
        ("world.toml", "\n# moved a wall\n"),
        ("robot.sensors.toml", "\n# another laser\n"),
    ] {
        let p = d.join(file);
        let before = std::fs::read_to_string(&p).unwrap();
        std::fs::write(&p, format!("{before}{edit}")).unwrap();
        bad(
            &["sweep", &s(&f), "--resume", "--out", &out],
            &format!("the inputs changed since ({file} changed)"),
        );
        std::fs::write(&p, before).unwrap();
    }
    // An edited sweep file is named too.
    let text = std::fs::read_to_string(&f).unwrap();
    std::fs::write(&f, text.replace("seed = 5", "seed = 6")).unwrap();
    bad(
        &["sweep", &s(&f), "--resume", "--out", &out],
        "r.toml changed",
    );
    std::fs::write(&f, text).unwrap();
    ok(&atrium(&["sweep", &s(&f), "--resume", "--out", &out]));
}

#[test]
fn an_unwritable_out_is_refused_before_validation_and_nothing_is_written() {
    let d = tmpdir("out");
    // The axis value is bad too: the --out error coming first shows it is checked before.
    let f = own_inputs(&d, "w.toml", "duration_s = [-1.0]");
    let file = d.join("a-file");
    std::fs::write(&file, "x").unwrap();
    bad(
        &["sweep", &s(&f), "--out", &s(&file)],
        &format!("{}: --out: is a file, not a folder", file.display()),
    );
    bad(
        &["sweep", &s(&f), "--out", &s(&file.join("sub"))],
        &format!("--out: {} is a file, not a folder", file.display()),
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
    bad(
        &["sweep", &s(&f), "--out", &s(&d.join("fresh"))],
        "axes.duration_s",
    );
    assert!(
        !d.join("fresh").exists(),
        "a refused sweep created its --out"
    );
}

/// `path`'s results.csv rewritten as the atrium before the distance columns wrote it: no
/// `distance_m` and `route_completed`, in the header and in every row.
fn strip_distance_columns(path: &Path) {
    let csv = path.join("results.csv");
    let text = std::fs::read_to_string(&csv).unwrap();
    let old: Vec<String> = text
        .lines()
        .map(|l| match l.starts_with('#') {
            true => l.to_string(),
            false => {
                // The tiny sweep's fields hold no commas: drop the two before wall_s.
                let mut f: Vec<&str> = l.split(',').collect();
                let n = f.len();
                f.drain(n - 3..n - 1);
                f.join(",")
            }
        })
        .collect();
    assert!(
        old[1].ends_with(",passed,failed_time_frac,wall_s"),
        "{}",
        old[1]
    );
    std::fs::write(&csv, old.join("\n") + "\n").unwrap();
}

#[test]
fn older_results_are_refused_and_unlike_drives_are_named() {
    let d = tmpdir("drives");
    let out = |n: &str| d.join(n).to_str().unwrap().to_string();
    // Trials of 1 s and 2 s drive unlike distances: the run and summary.md say so.
    let sweep = tiny_sweep(&d, "duration_s = [1.0, 2.0]");
    let o = atrium(&["sweep", &sweep, "--out", &out("a")]);
    ok(&o);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("note: the cells drove unlike drives"), "{err}");
    let summary = std::fs::read_to_string(d.join("a/summary.md")).unwrap();
    assert!(
        summary.contains("**Note:** the cells drove unlike drives"),
        "{summary}"
    );
    assert_eq!(summary.matches("Distance driven per trial: ").count(), 2);
    // Cells that drive alike get no note.
    let o = atrium(&["sweep", &tiny_sweep(&d, AXES), "--out", &out("b")]);
    ok(&o);
    assert!(!String::from_utf8_lossy(&o.stderr).contains("unlike drives"));

    // An older atrium's folder is neither resumed nor merged with a current one.
    for shard in ["0/2", "1/2"] {
        let name = format!("s{}", &shard[..1]);
        ok(&atrium(&[
            "sweep",
            &sweep,
            "--shard",
            shard,
            "--out",
            &out(&name),
        ]));
    }
    strip_distance_columns(&d.join("s1"));
    bad(
        &[
            "sweep",
            &sweep,
            "--shard",
            "1/2",
            "--resume",
            "--out",
            &out("s1"),
        ],
        "written by an older atrium (no distance_m column)",
    );
    bad(
        &["sweep", "merge", &out("m"), &out("s0"), &out("s1")],
        "shards written by different atrium versions",
    );
    assert!(!d.join("m").exists(), "a refused merge wrote its folder");
}
