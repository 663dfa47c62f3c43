//! The cluster path of docs/cluster.md, run on one machine exactly as documented: the array
//! job script (`scripts/slurm_sweep.sh`) once per array task, with the environment Slurm
//! gives a task, from different folders and with the sweep's path typed differently, one
//! task requeued; then the merge script. The merged rows equal a one-machine run's.

#![cfg(unix)]

#[allow(dead_code)] // this test uses only `tmpdir`
mod common;

use common::tmpdir;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn ok(o: &Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "exit {:?}: {err}", o.status.code());
    err
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

/// `script` run by bash (as sbatch would) in `cwd`, with `atrium` on the PATH through `bin`.
fn job(script: &str, cwd: &Path, bin: &Path, env: &[(&str, String)]) -> Output {
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut c = Command::new("bash");
    c.arg(repo().join("scripts").join(script))
        .current_dir(cwd)
        .env("PATH", path)
        .env_remove("OUT")
        .env_remove("ATRIUM_CACHE_DIR");
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().unwrap()
}

#[test]
fn the_documented_scripts_are_in_the_docs_verbatim() {
    let doc = std::fs::read_to_string(repo().join("docs/cluster.md")).unwrap();
    for script in ["slurm_sweep.sh", "slurm_merge.sh"] {
        let text = std::fs::read_to_string(repo().join("scripts").join(script)).unwrap();
        assert!(
            text.starts_with("#!/bin/bash\n"),
            "{script}: sbatch needs a #! line"
        );
        assert!(
            doc.contains(&format!("```bash\n{text}```")),
            "docs/cluster.md does not show scripts/{script} as it is"
        );
    }
    let sweep = std::fs::read_to_string(repo().join("scripts/slurm_sweep.sh")).unwrap();
    for needle in [
        "--resume",
        "--jobs \"${SLURM_CPUS_PER_TASK",
        "ATRIUM_CACHE_DIR",
        "command -v atrium",
    ] {
        assert!(sweep.contains(needle), "the array script lacks {needle}");
    }
}

#[test]
fn array_then_merge_equals_a_one_machine_run() {
    let d = tmpdir("cluster");
    let shared = d.join("shared/sweeps");
    std::fs::create_dir_all(&shared).unwrap();
    // A sweep holding an absolute path (its base): the case whose hash depended on how the
    // sweep file's path was typed.
    let base = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let sweep = shared.join("tiny.toml");
    std::fs::write(
        &sweep,
        format!(
            "base = {:?}\nseed = 3\ntrials = 2\n[axes]\nduration_s = [2.0]\n\
             \"localizers.mcl.max_particles\" = [1000, 2000]\n",
            base.to_str().unwrap()
        ),
    )
    .unwrap();
    // `atrium` on the PATH, as on a cluster's nodes.
    let bin = d.join("bin");
    std::fs::create_dir_all(&bin).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_atrium"), bin.join("atrium")).unwrap();
    let cache = d.join("cache");
    let task = |i: usize, cwd: &Path, sweep_arg: String| {
        job(
            "slurm_sweep.sh",
            cwd,
            &bin,
            &[
                ("SLURM_ARRAY_TASK_ID", i.to_string()),
                ("SLURM_ARRAY_TASK_COUNT", "3".into()),
                ("SLURM_CPUS_PER_TASK", "1".into()),
                ("SWEEP", sweep_arg),
                ("ATRIUM_CACHE_DIR", cache.to_string_lossy().into_owned()),
            ],
        )
    };
    // Task 0 from the sweep's folder by a relative name, the others by absolute paths from
    // elsewhere.
    ok(&task(0, &shared, "tiny.toml".into()));
    ok(&task(1, &d, sweep.to_string_lossy().into_owned()));
    ok(&task(
        2,
        Path::new("/"),
        sweep.to_string_lossy().into_owned(),
    ));
    // A requeued task finds its finished shard (4 trials in 3 shards: shard 1 holds one)
    // and runs nothing again.
    let again = ok(&task(1, &d, sweep.to_string_lossy().into_owned()));
    assert!(
        again.contains("ran 0 trials (1 already recorded)"),
        "{again}"
    );
    let out = shared.join("sweep-tiny");
    let header = |i: usize| rows(&out.join(format!("shard-{i}")))[0].clone();
    let hash = |h: String| h.split_whitespace().nth(2).unwrap_or_default().to_string();
    assert_eq!(
        hash(header(0)),
        hash(header(2)),
        "{} / {}",
        header(0),
        header(2)
    );
    let merged = job(
        "slurm_merge.sh",
        &d,
        &bin,
        &[("SWEEP", sweep.to_string_lossy().into_owned())],
    );
    let msg = ok(&merged);
    assert!(msg.contains("merged 8 rows from 3 shards"), "{msg}");
    // The same sweep on one machine, in one process.
    let single = d.join("single");
    ok(&Command::new(env!("CARGO_BIN_EXE_atrium"))
        .args([
            "sweep",
            sweep.to_str().unwrap(),
            "--out",
            single.to_str().unwrap(),
        ])
        .env("ATRIUM_CACHE_DIR", &cache)
        .output()
        .unwrap());
    let (a, b) = (rows(&single), rows(&out.join("merged")));
    assert_eq!(a.len(), 2 + 8);
    assert_eq!(a[1..], b[1..], "merged rows differ from a one-machine run");
    assert_eq!(hash(a[0].clone()), hash(b[0].clone()));
    let _ = std::fs::remove_dir_all(&d);
}

/// Without `atrium` on the PATH the script says so and exits 2 before doing anything.
#[test]
fn the_array_script_names_a_missing_atrium() {
    let d = tmpdir("cluster-nopath");
    let o = Command::new("bash")
        .arg(repo().join("scripts/slurm_sweep.sh"))
        .current_dir(&d)
        .env("PATH", "/usr/bin:/bin")
        .env("SWEEP", d.join("x.toml"))
        .env("SLURM_ARRAY_TASK_ID", "0")
        .env("SLURM_ARRAY_TASK_COUNT", "1")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("atrium is not on PATH"));
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0);
}
