//! Running a sweep: trials in parallel on a rayon pool, one atomically appended row batch per
//! finished trial, resumable, and sliceable into shards for batch schedulers.

use super::csv::{self, Layout, Results, Row};
use super::failure;
use super::format::Sweep;
use super::heatmap::{self, AxisLabels};
use super::inputs::{self, InputFile};
use super::maps;
use super::summary;
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::maps::SharedMaps;
use atrium_scenarios::runner::RunOptions;
use atrium_scenarios::seeds::derive_seed;
use rayon::prelude::*;
use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// How to run a sweep (everything that is not part of the sweep file).
#[derive(Debug, Clone)]
pub struct SweepSettings {
    pub out: PathBuf,
    /// Worker threads (None: rayon's default, one per core).
    pub jobs: Option<usize>,
    /// (I, N): run only the trials whose global index % N == I.
    pub shard: Option<(usize, usize)>,
    /// Skip trials already in `out/results.csv` instead of refusing to touch it.
    pub resume: bool,
    /// Show a progress bar (the caller decides: on a terminal only).
    pub progress: bool,
}

/// The most worker threads `--jobs` may ask for: trials are CPU-bound, so more threads than
/// cores only cost memory (each holds a simulation).
pub const MAX_JOBS: usize = 1024;

/// What a sweep run did.
#[derive(Debug, Clone)]
pub struct SweepOutcome {
    /// Trials of this shard run now.
    pub ran: usize,
    /// Trials of this shard found already recorded (resume).
    pub skipped: usize,
    pub results_csv: PathBuf,
    pub summary_md: PathBuf,
    /// Heat maps and error-map files written.
    pub pictures: Vec<PathBuf>,
    /// Pictures left out, and why (a heat map too large to draw).
    pub notes: Vec<String>,
    pub wall_s: f64,
}

/// The seed of trial `trial` of cell `cell`: a function of the sweep seed and the trial's
/// position only, which is what makes results independent of threads and shards.
pub fn trial_seed(sweep_seed: u64, cell: usize, trial: usize) -> u64 {
    derive_seed(sweep_seed, &format!("trial/{cell}/{trial}"))
}

/// An axis value as results.csv and the pictures show it (strings without quotes).
fn label(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// The sweep's axes with their value labels, for the heat maps.
pub fn axis_labels(sweep: &Sweep) -> Vec<AxisLabels> {
    sweep
        .axes
        .iter()
        .map(|a| AxisLabels {
            path: a.path.clone(),
            values: a.values.iter().map(label).collect(),
        })
        .collect()
}

/// Writes the heat maps of `results` and, when `error_maps` gives the trials to sum (and
/// whether the sweep has a single cell), the error-map CSV and pictures. Returns the files,
/// and notes on the pictures left out.
pub fn write_pictures(
    out: &Path,
    results: &Results,
    axes: &[AxisLabels],
    error_maps: Option<(&[(usize, usize)], bool)>,
) -> Result<(Vec<PathBuf>, Vec<String>), ScenarioError> {
    let mut written = Vec::new();
    let pics = heatmap::heatmaps(results, axes)
        .map_err(|msg| ScenarioError::field(out, "heatmap", msg))?;
    for (stem, fig) in pics.pictures {
        written.extend(
            fig.write(out, &stem)
                .map_err(|e| ScenarioError::figure(out, e))?,
        );
    }
    if let Some((trials, single)) = error_maps {
        let combined = maps::combine(out, trials)?;
        written.extend(maps::write_outputs(out, &results.name, &combined, single)?);
    }
    Ok((written, pics.skipped))
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map(|x| x.to_string()).unwrap_or_default()
}

/// Runs one trial and returns its rows (one per localizer, in scenario order). With
/// `[error_map]`, the trial's map is written to `out/maps/` before the rows are returned.
fn run_trial(
    sweep: &Sweep,
    scenario: &atrium_scenarios::scenario::Scenario,
    cell: usize,
    trial: usize,
    out: &Path,
) -> Result<Vec<Row>, ScenarioError> {
    let seed = trial_seed(sweep.seed, cell, trial);
    let started = Instant::now();
    let result = sweep.registry.run(
        scenario,
        RunOptions {
            seed: Some(seed),
            ..Default::default()
        },
    )?;
    let wall = started.elapsed().as_secs_f64();
    if let Some(res) = sweep.error_map {
        let mut map = atrium_scenarios::error_maps::empty_for(scenario, res)
            .map_err(|msg| ScenarioError::field(&sweep.file, "error_map.resolution", msg))?;
        atrium_scenarios::error_maps::accumulate(&mut map, &result);
        maps::write_trial_map(out, cell, trial, &map)?;
    }
    let params: Vec<String> = sweep
        .cell_params(cell)
        .iter()
        .map(|(_, v)| label(v))
        .collect();
    Ok(result
        .localizers
        .iter()
        .map(|l| {
            let m = l.metrics.as_ref();
            let p = m.map(|m| &m.position_error);
            Row {
                params: params.clone(),
                cell,
                trial,
                seed,
                localizer: l.name.clone(),
                values: vec![
                    fmt_opt(p.map(|p| p.min)),
                    fmt_opt(p.map(|p| p.median)),
                    fmt_opt(p.map(|p| p.rmse)),
                    fmt_opt(p.map(|p| p.p95)),
                    fmt_opt(p.map(|p| p.max)),
                    fmt_opt(m.map(|m| m.final_position_error)),
                    fmt_opt(m.and_then(|m| m.converged_after_s)),
                    l.passed.to_string(),
                    fmt_opt(failure::time_above(
                        &l.samples,
                        sweep.failure.error_threshold_m,
                    )),
                    format!("{:.3}", result.distance_m),
                    result.route_completed.to_string(),
                    format!("{wall:.3}"),
                ],
            }
        })
        .collect())
}

/// Sorts rows by (cell, trial, localizer) and drops repeats of a key (the first wins).
pub fn canonical(mut rows: Vec<Row>) -> Vec<Row> {
    rows.sort_by(|a, b| a.key().cmp(&b.key()));
    rows.dedup_by(|a, b| a.key() == b.key());
    rows
}

/// Refuses an output folder that cannot be written, before anything runs (and without
/// writing anything): `out` is a folder, or can be created as one (its nearest existing
/// ancestor is a folder), and a file can be created there.
pub fn check_out(out: &Path) -> Result<(), ScenarioError> {
    let refuse = |msg: String| ScenarioError::field(out, "--out", msg);
    let mut existing = out;
    while !existing.exists() {
        match existing.parent() {
            Some(p) if !p.as_os_str().is_empty() => existing = p,
            _ => {
                existing = Path::new(".");
                break;
            }
        }
    }
    if !existing.is_dir() {
        return Err(refuse(match existing == out {
            true => "is a file, not a folder: choose another --out".into(),
            false => format!("{} is a file, not a folder", existing.display()),
        }));
    }
    let probe = existing.join(format!(".atrium-write-probe.{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(refuse(format!(
            "cannot write in {}: {e}",
            existing.display()
        ))),
    }
}

/// Checks what can be checked of `settings` before the sweep `file` is even validated:
/// `--jobs` within 1..=[`MAX_JOBS`] and a writable `--out`.
pub fn check_settings(file: &Path, settings: &SweepSettings) -> Result<(), ScenarioError> {
    if let Some(n) = settings.jobs {
        if !(1..=MAX_JOBS).contains(&n) {
            return Err(ScenarioError::field(
                file,
                "--jobs",
                format!("must be between 1 and {MAX_JOBS} worker threads, got {n}"),
            ));
        }
    }
    check_out(&settings.out)
}

/// The inputs recorded in a results folder's `sweep.json` (none when it has none), and its
/// world hashes by cell (empty when it has none).
fn recorded_inputs(
    out: &Path,
) -> Option<(
    String,
    Vec<InputFile>,
    std::collections::BTreeMap<usize, String>,
)> {
    let text = std::fs::read_to_string(out.join("sweep.json")).ok()?;
    let doc: serde_json::Value = serde_json::from_str(&text).ok()?;
    let inputs = serde_json::from_value(doc.get("inputs")?.clone()).ok()?;
    let worlds = doc
        .get("world_hashes")
        .and_then(|w| serde_json::from_value(w.clone()).ok())
        .unwrap_or_default();
    Some((
        doc.get("sweep_text_hash")?.as_str()?.to_string(),
        inputs,
        worlds,
    ))
}

/// Runs `sweep` into `settings.out`: `results.csv` (rows appended per finished trial, each
/// batch one write + fsync, then sorted once the shard is complete) and `summary.md`.
pub fn run_sweep(sweep: &Sweep, settings: &SweepSettings) -> Result<SweepOutcome, ScenarioError> {
    let started = Instant::now();
    check_settings(&sweep.file, settings)?;
    let out = &settings.out;
    let csv_path = out.join("results.csv");
    let layout = Layout {
        cells: sweep.cells(),
        trials: sweep.trials,
        shard: settings.shard.unwrap_or((0, 1)),
    };
    let sweep_text_hash = inputs::fnv_hex(&[sweep.text.as_bytes()]);
    let done = prepare_results(sweep, settings, &layout, &sweep_text_hash)?;
    write_sweep_json(sweep, settings, &sweep_text_hash)?;

    let mine: Vec<(usize, usize)> = (0..sweep.total_trials())
        .map(|g| (g / sweep.trials, g % sweep.trials))
        .filter(|&(c, t)| layout.holds(c, t))
        .collect();
    let todo: Vec<(usize, usize)> = mine.iter().copied().filter(|k| !done.contains(k)).collect();
    let skipped = mine.len() - todo.len();
    run_trials(sweep, settings, &todo, &csv_path)?;
    let (summary_md, pictures, notes) = finish_outputs(sweep, out, &csv_path, &mine)?;
    Ok(SweepOutcome {
        ran: todo.len(),
        skipped,
        results_csv: csv_path,
        summary_md,
        pictures,
        notes,
        wall_s: started.elapsed().as_secs_f64(),
    })
}

/// An I/O error on `file` as the error of writing it.
fn write_err(file: &Path) -> impl Fn(std::io::Error) -> ScenarioError {
    let file = file.to_path_buf();
    move |err| ScenarioError::Write {
        file: file.clone(),
        err,
    }
}

/// Makes `out/results.csv` ready for this run and returns the trials it already holds whole:
/// a new file holds only the header; an existing one must hold this sweep (resumed, of a shard
/// this run covers, with the current columns) and is cut back to its whole trials.
fn prepare_results(
    sweep: &Sweep,
    settings: &SweepSettings,
    layout: &Layout,
    sweep_text_hash: &str,
) -> Result<BTreeSet<(usize, usize)>, ScenarioError> {
    let out = &settings.out;
    let csv_path = out.join("results.csv");
    let axis_paths: Vec<String> = sweep.axes.iter().map(|a| a.path.clone()).collect();
    // Localizer count per trial: a trial is recorded only when all its rows are.
    let per_trial = sweep.cell_scenario(0)?.localizers.len();
    if !csv_path.exists() {
        std::fs::create_dir_all(out).map_err(write_err(out))?;
        csv::write_atomic(
            &csv_path,
            &csv::header_with(
                &sweep.hash,
                &sweep.name,
                Some(layout),
                &axis_paths,
                csv::CURRENT_OPTIONAL,
            ),
        )?;
        return Ok(BTreeSet::new());
    }
    let existing = csv::read_results(&csv_path)?;
    check_resumable(
        sweep,
        settings,
        layout,
        sweep_text_hash,
        &csv_path,
        &existing,
    )?;
    // Keep only whole trials; the partial line and any trial missing rows are redone.
    let mut count: std::collections::BTreeMap<(usize, usize), usize> = Default::default();
    for r in &existing.rows {
        *count.entry((r.cell, r.trial)).or_default() += 1;
    }
    // With error maps a trial also needs its map file (written before its rows, so only
    // a deleted file can be missing).
    let done: BTreeSet<(usize, usize)> = count
        .into_iter()
        .filter(|&(_, n)| n >= per_trial)
        .map(|(k, _)| k)
        .filter(|&(c, t)| sweep.error_map.is_none() || maps::trial_map_path(out, c, t).is_file())
        .collect();
    let kept = Results {
        rows: existing
            .rows
            .into_iter()
            .filter(|r| done.contains(&(r.cell, r.trial)))
            .collect(),
        layout: Some(*layout),
        ..existing
    };
    // Without rows, `to_text` would write the header without the optional columns.
    let text = match kept.rows.is_empty() {
        true => csv::header_with(
            &kept.hash,
            &kept.name,
            Some(layout),
            &axis_paths,
            csv::CURRENT_OPTIONAL,
        ),
        false => kept.to_text(),
    };
    csv::write_atomic(&csv_path, &text)?;
    Ok(done)
}

/// Refuses to continue `existing` (the results at `csv_path`) unless it holds this very sweep,
/// `--resume` was given, this run's shard covers it and its rows have the current columns.
fn check_resumable(
    sweep: &Sweep,
    settings: &SweepSettings,
    layout: &Layout,
    sweep_text_hash: &str,
    csv_path: &Path,
    existing: &Results,
) -> Result<(), ScenarioError> {
    if existing.hash != sweep.hash {
        let why = what_changed(sweep, &settings.out, sweep_text_hash);
        return Err(ScenarioError::field(
            csv_path,
            "hash",
            format!(
                "results of a different sweep (hash {}, this sweep {}){why}: choose another --out",
                existing.hash, sweep.hash
            ),
        ));
    }
    if !settings.resume {
        return Err(ScenarioError::field(
            csv_path,
            "results",
            "already holds results of this sweep: pass --resume to continue it, or choose another --out",
        ));
    }
    // The folder must end up holding exactly this run's shard: resuming shard 0/2 as 1/2
    // would mix two shards under one header.
    if let Some(old) = existing.layout {
        if !layout.covers(&old) {
            return Err(ScenarioError::field(
                csv_path,
                "shard",
                format!(
                    "holds shard {}/{}; this run is shard {}/{}, which does not include it: \
                     resume it as the same shard (or as the whole sweep), or choose another --out",
                    old.shard.0, old.shard.1, layout.shard.0, layout.shard.1
                ),
            ));
        }
    }
    // Rows without the current optional columns (written before they existed) cannot be
    // continued with rows that have them.
    let held = existing.optional_columns();
    if !existing.rows.is_empty() && held < csv::CURRENT_OPTIONAL {
        return Err(ScenarioError::field(
            csv_path,
            "columns",
            format!(
                "written by an older atrium (no {} column): rerun this sweep into another --out",
                csv::OPTIONAL_COLUMNS[held]
            ),
        ));
    }
    Ok(())
}

/// Why the results in `out` belong to another sweep, as far as its `sweep.json` tells: the
/// changed inputs and cells whose generated world changed (empty when nothing is known).
fn what_changed(sweep: &Sweep, out: &Path, sweep_text_hash: &str) -> String {
    let Some((text_hash, old, old_worlds)) = recorded_inputs(out) else {
        return String::new();
    };
    let mut changes = inputs::describe_changes(&old, &sweep.inputs);
    if text_hash != sweep_text_hash {
        changes.insert(0, format!("{} changed", sweep.file.display()));
    }
    // Same files, other worlds: the generator itself changed.
    let cells: Vec<String> = sweep
        .world_hashes
        .iter()
        .filter(|(c, h)| old_worlds.get(c).is_some_and(|o| o != *h))
        .map(|(c, _)| c.to_string())
        .collect();
    if !cells.is_empty() {
        changes.push(format!(
            "the generated worlds of cells {} changed",
            cells.join(", ")
        ));
    }
    match changes.is_empty() {
        true => String::new(),
        false => format!(": the inputs changed since ({})", changes.join(", ")),
    }
}

/// Writes `out/sweep.json`: what was swept, its inputs' hashes and the generated worlds'.
fn write_sweep_json(
    sweep: &Sweep,
    settings: &SweepSettings,
    sweep_text_hash: &str,
) -> Result<(), ScenarioError> {
    let sweep_json = serde_json::json!({
        "sweep": sweep.file,
        "base": sweep.base_file,
        "hash": sweep.hash,
        "sweep_text_hash": sweep_text_hash,
        "inputs": sweep.inputs,
        "seed": sweep.seed,
        "trials_per_cell": sweep.trials,
        "cells": sweep.cells(),
        "axes": sweep.axes.iter().map(|a| serde_json::json!({
            "path": a.path,
            "values": a.values.iter().map(|v| v.to_string()).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
        "shard": settings.shard.map(|(i, n)| format!("{i}/{n}")),
        "failure": sweep.failure,
        // Per cell, a hash of its generated world (present when the world is generated).
        "world_hashes": sweep.world_hashes,
    });
    csv::write_atomic(
        &settings.out.join("sweep.json"),
        &serde_json::to_string_pretty(&sweep_json).unwrap_or_default(),
    )
}

/// The cells of the trials to run, each built when its first trial starts, shared by its
/// trials, and dropped after its last: memory holds the cells in progress, not the whole sweep.
struct CellCache<'a> {
    sweep: &'a Sweep,
    out: &'a Path,
    /// Per cell, its scenario and maps once built, and how many of its trials are left.
    held: std::collections::BTreeMap<usize, (Slot, AtomicUsize)>,
}

type Slot = Mutex<Option<std::sync::Arc<CellRun>>>;

impl<'a> CellCache<'a> {
    fn new(sweep: &'a Sweep, out: &'a Path, todo: &[(usize, usize)]) -> Self {
        let mut held: std::collections::BTreeMap<usize, (Slot, AtomicUsize)> = Default::default();
        for &(c, _) in todo {
            held.entry(c)
                .or_insert_with(|| (Mutex::new(None), AtomicUsize::new(0)))
                .1
                .fetch_add(1, Ordering::Relaxed);
        }
        CellCache { sweep, out, held }
    }

    /// The scenario and maps of `cell`, built on first use.
    fn get(&self, cell: usize) -> Result<std::sync::Arc<CellRun>, ScenarioError> {
        let slot = &self.held[&cell].0;
        if let Some(run) = slot.lock().unwrap_or_else(|p| p.into_inner()).as_ref() {
            return Ok(run.clone());
        }
        // Built without holding the lock: a build that waits on rayon work (a localizer's
        // parallel training) may run another trial of this cell on this very thread, which
        // would deadlock on it. Two first trials may both build; the first kept wins.
        let scenario = self.sweep.cell_scenario(cell)?;
        let maps = self.sweep.warm_cell(cell, &scenario)?;
        let mut slot = slot.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(run) = slot.as_ref() {
            return Ok(run.clone());
        }
        // Under the lock, so one thread writes the cell's world.
        if self.sweep.error_map.is_some() {
            maps::write_world(self.out, cell, &scenario.world)?;
        }
        Ok(slot.insert(std::sync::Arc::new((scenario, maps))).clone())
    }

    /// Counts one finished trial of `cell`; after its last, frees the cell's scenario and maps.
    fn trial_done(&self, cell: usize) {
        let (slot, left) = &self.held[&cell];
        if left.fetch_sub(1, Ordering::AcqRel) == 1 {
            slot.lock().unwrap_or_else(|p| p.into_inner()).take();
        }
    }
}

/// Runs the trials `todo` in parallel (on `settings.jobs` threads), appending each trial's rows
/// to `csv_path` as one write + fsync.
fn run_trials(
    sweep: &Sweep,
    settings: &SweepSettings,
    todo: &[(usize, usize)],
    csv_path: &Path,
) -> Result<(), ScenarioError> {
    let out = &settings.out;
    let cells = CellCache::new(sweep, out, todo);
    let file = std::fs::OpenOptions::new()
        .append(true)
        .open(csv_path)
        .map_err(write_err(csv_path))?;
    let file = Mutex::new(file);
    let bar = settings.progress.then(|| progress_bar(sweep, todo.len()));
    let work = || {
        todo.par_iter().try_for_each(|&(cell, trial)| {
            let run = cells.get(cell)?;
            let rows = run_trial(sweep, &run.0, cell, trial, out)?;
            drop(run);
            let batch: String = rows.iter().map(Row::to_line).collect();
            // One write of whole lines, then fsync, under the lock: rows of concurrent
            // trials never interleave and a kill leaves at most a partial last line.
            let mut f = file.lock().unwrap_or_else(|p| p.into_inner());
            f.write_all(batch.as_bytes())
                .and_then(|_| f.sync_data())
                .map_err(write_err(csv_path))?;
            drop(f);
            cells.trial_done(cell);
            if let Some(b) = &bar {
                b.inc(1);
            }
            Ok::<(), ScenarioError>(())
        })
    };
    match settings.jobs {
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .map_err(|e| ScenarioError::field(&sweep.file, "--jobs", e.to_string()))?
            .install(work)?,
        None => work()?,
    }
    drop(file);
    if let Some(b) = &bar {
        b.finish_and_clear();
    }
    Ok(())
}

fn progress_bar(sweep: &Sweep, trials: usize) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(trials as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} trials (eta {eta})")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    bar.set_message(sweep.name.clone());
    bar
}

/// Once the shard is complete: rewrites `csv_path` in canonical order (so its content does
/// not depend on which thread finished first), then writes `summary.md`, the failure curves
/// and the pictures of the trials `mine`. Returns the summary's path, the pictures and notes.
fn finish_outputs(
    sweep: &Sweep,
    out: &Path,
    csv_path: &Path,
    mine: &[(usize, usize)],
) -> Result<(PathBuf, Vec<PathBuf>, Vec<String>), ScenarioError> {
    let results = csv::read_results(csv_path)?;
    let results = Results {
        rows: canonical(results.rows),
        ..results
    };
    csv::write_atomic(csv_path, &results.to_text())?;
    let summary_md = out.join("summary.md");
    let axes = axis_labels(sweep);
    let curves = failure::write_outputs(out, &results, &axes, &sweep.failure, sweep.seed)?;
    csv::write_atomic(
        &summary_md,
        &(summary::to_markdown(&results) + &curves.markdown),
    )?;
    let (mut pictures, mut notes) = write_pictures(
        out,
        &results,
        &axes,
        sweep.error_map.map(|_| (mine, sweep.cells() == 1)),
    )?;
    pictures.extend(curves.files);
    notes.extend(curves.notes);
    notes.extend(super::drive::unlike_drives(&super::drive::per_cell(
        &results,
    )));
    Ok((summary_md, pictures, notes))
}

/// A cell's scenario and the maps its trials share.
type CellRun = (atrium_scenarios::scenario::Scenario, SharedMaps);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trial_seeds_are_distinct_and_pinned_to_position() {
        assert_ne!(trial_seed(1, 0, 1), trial_seed(1, 1, 0));
        assert_eq!(trial_seed(1, 2, 3), derive_seed(1, "trial/2/3"));
    }
}
