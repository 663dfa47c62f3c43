//! `atrium bench sweep SWEEP [--trials N] [--json]` (issue 9, deliverable 6): trials per minute
//! of a sweep with one worker and with one per core, and the sweep machinery's own cost per
//! trial, measured as the wall time of the same sweep cut to a one-step scenario (scenario
//! parse, world and robot set-up, localizer construction on the shared maps, row write and
//! fsync, map write). Each run writes to a fresh temporary folder, removed afterwards.

use super::format::{Axis, Sweep};
use super::run::{run_sweep, SweepSettings};
use atrium_scenarios::error::ScenarioError;
use serde_json::{json, Value};
use std::path::Path;
use std::time::Instant;

fn timed_run(sweep: &Sweep, jobs: Option<usize>, tag: &str) -> Result<f64, ScenarioError> {
    let out = std::env::temp_dir().join(format!("atrium-bench-sweep-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let settings = SweepSettings {
        out: out.clone(),
        jobs,
        shard: None,
        resume: false,
        progress: false,
    };
    let started = Instant::now();
    let result = run_sweep(sweep, &settings);
    let wall = started.elapsed().as_secs_f64();
    let _ = std::fs::remove_dir_all(&out);
    result.map(|_| wall)
}

/// Measures `file`'s sweep (with `trials` per cell if given). Returns the JSON document.
pub fn run(file: &Path, trials: Option<usize>) -> Result<Value, ScenarioError> {
    let started = Instant::now();
    let mut sweep = Sweep::load(file)?;
    let load_s = started.elapsed().as_secs_f64();
    if let Some(n) = trials {
        if n == 0 {
            return Err(ScenarioError::field(file, "--trials", "must be at least 1"));
        }
        sweep.trials = n;
    }
    let total = sweep.total_trials();
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());

    // Overhead: the same cells, one physics step long (an added last axis wins over the
    // base and any duration axis).
    let mut zero = sweep.clone();
    zero.axes.push(Axis {
        path: "duration_s".into(),
        values: vec![toml::Value::Float(0.005)],
    });
    let zero_wall = timed_run(&zero, Some(1), "zero")?;
    let one = timed_run(&sweep, Some(1), "jobs1")?;
    let all = timed_run(&sweep, Some(cores), "jobsall")?;
    let per_min = |wall: f64| total as f64 * 60.0 / wall.max(1e-9);
    Ok(json!({
        "sweep": sweep.name,
        "cells": sweep.cells(),
        "trials_per_cell": sweep.trials,
        "trials": total,
        "load_and_validate_s": load_s,
        "jobs_1": { "wall_s": one, "trials_per_min": per_min(one) },
        "jobs_all": {
            "jobs": cores,
            "wall_s": all,
            "trials_per_min": per_min(all),
            "speedup": one / all.max(1e-9),
        },
        "overhead_per_trial_s": zero_wall / total.max(1) as f64,
        "machine": {
            "cores": cores,
            "os": std::env::consts::OS,
            "arch": std::env::consts::ARCH,
        },
    }))
}
