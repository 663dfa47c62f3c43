//! The sweep file: base scenario, seed, trials per cell and parameter axes.
//!
//! ```toml
//! base = "../corridor_tracking.toml"   # relative to this file
//! seed = 7
//! trials = 20
//! [axes]
//! "sensors.laser.range_max" = [4.0, 8.0, 30.0]
//! "localizers.mcl.max_particles" = [500, 3000]   # a localizer addressed by name
//! duration_s = [60.0]
//! [error_map]                 # optional: per-location error maps (see `super::maps`)
//! resolution = 1.0            # cell size, m
//! [failure]                   # optional: failure curves (see `super::failure`)
//! error_threshold_m = 1.0
//! ```
//!
//! `world.<parameter>` axes vary the base scenario's generated world: the base scenario's
//! `world` must be a generator file (`generator = "..."`) and `<parameter>` one of its kind's
//! parameters. A cell sets them in its scenario's `[world_params]` table, which the scenario
//! loader applies to the generator file before generating; no file is written. Everything a
//! localizer derives from the world (grids, likelihood fields, appearance maps) is keyed by
//! the world's content (`atrium_scenarios::map_cache`), so it is built per cell and shared by
//! the cell's trials. Localizers that learn from another scenario file (`training = "<file>"`:
//! the WiFi survey, the data-driven chooser) learn on the cell's world when that file drives
//! the same generator file (it gets the cell's `[world_params]`, and its learnt graph or
//! training is memoised per cell); a training file on another world is refused with a world
//! axis, since it would learn a building the cell does not have.
//!
//! An axis's path may also be written as nested tables (`[axes.odometry] radius_error = [..]`);
//! every leaf array is one axis, and each parameter may have one axis only (two spellings of
//! one path, or a path inside another axis's table, are refused). Path keys are bare TOML keys
//! (letters, digits, `_`, `-`). Cells are the cartesian product of the axes, the last axis
//! varying fastest. A cell is applied by editing the base scenario's TOML table and parsing the
//! result with [`Scenario::from_toml_str`], so every scenario validation applies to it; its
//! errors are traced back to the line of the sweep file or base scenario that caused them
//! (see `super::origin`).

use super::inputs::{self, Collector, InputFile};
use super::origin::{field_keys, keys_at, line_of, parse_toml_message, within};
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::maps::SharedMaps;
use atrium_scenarios::scenario::Scenario;
use atrium_scenarios::LocalizerRegistry;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// One parameter axis: a dotted path into the scenario and the values it takes.
#[derive(Debug, Clone)]
pub struct Axis {
    pub path: String,
    pub values: Vec<toml::Value>,
}

/// A parsed and validated sweep.
#[derive(Debug, Clone)]
pub struct Sweep {
    pub file: PathBuf,
    pub name: String,
    pub base_file: PathBuf,
    pub base_text: String,
    pub seed: u64,
    pub trials: usize,
    pub axes: Vec<Axis>,
    /// Identifies the sweep: a hash of the sweep file's text and of the content of every file
    /// its trials read ([`Sweep::inputs`]). Results written under another hash belong to
    /// another sweep (or to changed inputs) and are never mixed with these.
    pub hash: String,
    /// The files the trials read (base scenario, worlds, robots, sensor files, training
    /// scenarios, error maps, ...) with their content hashes, by name relative to the sweep
    /// file's folder (see `super::inputs`).
    pub inputs: Vec<InputFile>,
    /// `[error_map] resolution`, m: every trial records a per-location error map.
    pub error_map: Option<f64>,
    /// `[failure]`: what counts as failing, for the failure curves (defaults without it).
    pub failure: super::failure::FailureSettings,
    /// Per cell, a hash of the world its trials run in, when the base scenario's world is
    /// generated (a generator file): part of [`Sweep::hash`], since a generated world
    /// depends on the generator's code as well as on the files. Empty otherwise.
    pub world_hashes: std::collections::BTreeMap<usize, String>,
    /// The sweep file's own `[[localizers]]`, added to the base scenario's in every cell.
    pub extra_localizers: Vec<toml::Table>,
    /// The sweep file's own `[expect.<localizer>]` tables.
    pub extra_expect: toml::Table,
    /// The maps (likelihood fields, grids) the validation built, per cell: kept alive so the
    /// trials share them instead of rebuilding (see `atrium_scenarios::map_cache`). `run_sweep` takes
    /// them and drops each cell's once its last trial is done.
    pub(crate) warm: WarmMaps,
    /// The localizer kinds the trials are built from.
    pub registry: LocalizerRegistry,
    /// The sweep file's text (errors give its lines).
    pub(crate) text: String,
    /// The base scenario's table, parsed once.
    pub(crate) base_doc: toml::Table,
    /// Per axis, its keys under `[axes]` as the file writes them (`["odometry",
    /// "radius_error"]` or `["odometry.radius_error"]`), to find its line.
    pub(crate) axis_keys: Vec<Vec<String>>,
    /// Whether the base scenario's world is a generator file (its cells' world hashes are
    /// recorded).
    pub(crate) generated_world: bool,
    /// World hashes collected while validating, by cell.
    pub(crate) hashes: std::sync::Arc<Mutex<std::collections::BTreeMap<usize, String>>>,
}

/// The first segment of a world axis: `world.<parameter>`.
pub const WORLD_AXIS: &str = "world";

/// The parameter a `world.<parameter>` axis sets (None for other axes; the bare `world`
/// axis, which names world files, is an ordinary one).
pub fn world_parameter(path: &str) -> Option<&str> {
    path.strip_prefix(WORLD_AXIS)?.strip_prefix('.')
}

/// Per-cell [`SharedMaps`] kept alive between validation and the trials.
#[derive(Clone, Default)]
pub struct WarmMaps(
    pub(crate) std::sync::Arc<std::sync::Mutex<std::collections::BTreeMap<usize, SharedMaps>>>,
);

impl std::fmt::Debug for WarmMaps {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let n = self.0.lock().map(|m| m.len()).unwrap_or(0);
        write!(f, "WarmMaps({n} cells)")
    }
}

impl WarmMaps {
    /// Takes the maps kept for `cell`, if any.
    pub(crate) fn take(&self, cell: usize) -> Option<SharedMaps> {
        self.0
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .remove(&cell)
    }
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ErrorMapFile {
    resolution: f64,
}

/// The most cells one sweep may have: each is validated (its localizers built) before any
/// trial runs, so a larger sweep would validate for minutes.
pub const MAX_CELLS: usize = 10_000;
/// The most trials one sweep may run (its `results.csv` holds a row per trial and localizer).
pub const MAX_TRIALS: usize = 1_000_000;

/// How often validation reports its progress (when it takes longer than this at all).
const PROGRESS_EVERY: Duration = Duration::from_secs(1);

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct SweepFile {
    base: PathBuf,
    seed: u64,
    trials: usize,
    #[serde(default)]
    axes: toml::Table,
    #[serde(default)]
    error_map: Option<ErrorMapFile>,
    #[serde(default)]
    failure: super::failure::FailureSettings,
    /// `[[localizers]]` added to the base scenario's (a user's own beside the bundled ones).
    #[serde(default)]
    localizers: Vec<toml::Table>,
    /// `[expect.<localizer>]` tables added to (or replacing) the base scenario's.
    #[serde(default)]
    expect: toml::Table,
}

/// A key as the sweep file could write it: bare when it is one, quoted otherwise.
fn spell_key(k: &str) -> String {
    if bare_key(k) {
        k.to_string()
    } else {
        format!("{k:?}")
    }
}

/// TOML's bare-key characters: the only ones a parameter path's keys are made of.
fn bare_key(k: &str) -> bool {
    !k.is_empty()
        && k.chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// How an axis is written: `axes."odometry.radius_error"` or `axes.odometry.radius_error`.
fn spelling(keys: &[String]) -> String {
    std::iter::once("axes".to_string())
        .chain(keys.iter().map(|k| spell_key(k)))
        .collect::<Vec<_>>()
        .join(".")
}

fn flatten_axes(
    file: &Path,
    keys: &mut Vec<String>,
    table: &toml::Table,
    out: &mut Vec<(Axis, Vec<String>)>,
) -> Result<(), ScenarioError> {
    for (k, v) in table {
        keys.push(k.clone());
        let path = keys.join(".");
        match v {
            toml::Value::Table(t) if t.is_empty() => {
                return Err(ScenarioError::field(
                    file,
                    spelling(keys),
                    "an empty table: name the axes under it, or remove it",
                ))
            }
            toml::Value::Table(t) => flatten_axes(file, keys, t, out)?,
            toml::Value::Array(values) => {
                if let Some(bad) = path.split('.').find(|s| !bare_key(s)) {
                    return Err(ScenarioError::field(
                        file,
                        spelling(keys),
                        format!(
                            "{bad:?} is not a parameter name: an axis path is keys of letters, \
                             digits, '_' and '-' joined by '.'"
                        ),
                    ));
                }
                if values.is_empty() {
                    return Err(ScenarioError::field(
                        file,
                        format!("axes.{path}"),
                        "empty axis: give at least one value",
                    ));
                }
                out.push((
                    Axis {
                        path,
                        values: values.clone(),
                    },
                    keys.clone(),
                ));
            }
            _ => {
                return Err(ScenarioError::field(
                    file,
                    format!("axes.{path}"),
                    "an axis must be a list of values",
                ))
            }
        }
        keys.pop();
    }
    Ok(())
}

/// Refuses two axes that set the same parameter (a dotted key and a nested table spelling
/// one path) or one inside the other (`controller` and `controller.max_speed`): a cell would
/// apply one and record both.
fn check_overlaps(file: &Path, axes: &[(Axis, Vec<String>)]) -> Result<(), ScenarioError> {
    let mut order: Vec<(Vec<&str>, usize)> = axes
        .iter()
        .enumerate()
        .map(|(i, (a, _))| (a.path.split('.').collect(), i))
        .collect();
    // Sorted by keys, a path is directly followed by any path inside it.
    order.sort();
    for w in order.windows(2) {
        let ((a, i), (b, j)) = (&w[0], &w[1]);
        if b.starts_with(a) {
            let (sa, sb) = (spelling(&axes[*i].1), spelling(&axes[*j].1));
            let msg = if a.len() == b.len() {
                format!(
                    "{sa} and {sb} are the same parameter {}: give each parameter one axis",
                    axes[*i].0.path
                )
            } else {
                format!(
                    "{sa} and {sb} overlap: {} lies inside {}; give each parameter one axis",
                    axes[*j].0.path, axes[*i].0.path
                )
            };
            return Err(ScenarioError::field(file, "axes", msg));
        }
    }
    Ok(())
}

/// Sets `path` (dotted) to `value` in a scenario table. `localizers.NAME.rest` addresses the
/// `[[localizers]]` entry named NAME; missing intermediate tables are created (a scenario
/// may override a sensor it does not mention), and the scenario parser decides whether the
/// result is meaningful.
fn set_path(doc: &mut toml::Table, path: &str, value: &toml::Value) -> Result<(), String> {
    let segs: Vec<&str> = path.split('.').collect();
    if segs.iter().any(|s| s.is_empty()) {
        return Err("empty segment in path".into());
    }
    let (mut table, rest): (&mut toml::Table, &[&str]) = if segs[0] == "localizers" {
        if segs.len() < 3 {
            return Err("use localizers.<name>.<parameter>".into());
        }
        let list = doc
            .get_mut("localizers")
            .and_then(|v| v.as_array_mut())
            .ok_or("the base scenario has no [[localizers]]")?;
        let names: Vec<String> = list
            .iter()
            .filter_map(|l| l.get("name").and_then(|n| n.as_str()).map(String::from))
            .collect();
        let entry = list
            .iter_mut()
            .find(|l| l.get("name").and_then(|n| n.as_str()) == Some(segs[1]))
            .and_then(|l| l.as_table_mut())
            .ok_or_else(|| {
                format!(
                    "no localizer named {:?} (known: {})",
                    segs[1],
                    names.join(", ")
                )
            })?;
        (entry, &segs[2..])
    } else {
        (doc, &segs[..])
    };
    for (i, seg) in rest.iter().enumerate() {
        if i + 1 == rest.len() {
            table.insert((*seg).to_string(), value.clone());
            return Ok(());
        }
        let next = table
            .entry((*seg).to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        table = next
            .as_table_mut()
            .ok_or_else(|| format!("{seg} is not a table in the base scenario"))?;
    }
    Ok(())
}

/// A field as scenario errors write it: `localizers[NAME].rest`, `a.b[3]`.
fn display_field(keys: &[String]) -> String {
    let mut s = String::new();
    for (i, k) in keys.iter().enumerate() {
        let index = i > 0 && !k.is_empty() && k.chars().all(|c| c.is_ascii_digit());
        if (i == 1 && keys[0] == "localizers") || index {
            s.push_str(&format!("[{k}]"));
        } else {
            if i > 0 {
                s.push('.');
            }
            s.push_str(k);
        }
    }
    s
}

/// An axis value as messages show it: its TOML text, cut short.
fn show(v: &toml::Value) -> String {
    const MAX: usize = 60;
    let s = v.to_string();
    match s.char_indices().nth(MAX) {
        Some((cut, _)) => format!("{}…", &s[..cut]),
        None => s,
    }
}

/// A choice of one value per axis (or of some axes): (axis index, value index) pairs.
type Choice = [(usize, usize)];

/// An error of a cell scenario in terms of the generated document: the keys it concerns and
/// its message without position.
#[derive(Debug, Clone, PartialEq)]
struct Located {
    keys: Vec<String>,
    /// The field as the error wrote it, if it named one.
    field: Option<String>,
    msg: String,
}

impl Sweep {
    /// Loads a sweep whose trials use Atrium's built-in localizer kinds.
    pub fn load(path: &Path) -> Result<Sweep, ScenarioError> {
        Self::load_with(path, LocalizerRegistry::with_builtins())
    }

    /// Loads a sweep whose trials build their localizers from `registry` (a user's kinds).
    pub fn load_with(path: &Path, registry: LocalizerRegistry) -> Result<Sweep, ScenarioError> {
        Self::load_reporting(path, registry, &|_, _| {})
    }

    /// [`Sweep::load_with`], calling `progress(done, total)` at most once a second while
    /// the cells are validated, when that takes more than a second.
    pub fn load_reporting(
        path: &Path,
        registry: LocalizerRegistry,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Sweep, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|err| ScenarioError::Io {
            file: path.to_path_buf(),
            err,
        })?;
        Self::parse(&text, path, registry, progress)
    }

    /// [`Sweep::from_toml_str_with`] with Atrium's built-in localizer kinds.
    pub fn from_toml_str(text: &str, file: &Path) -> Result<Sweep, ScenarioError> {
        Self::from_toml_str_with(text, file, LocalizerRegistry::with_builtins())
    }

    /// Parses a sweep and validates every axis value and every cell against the base
    /// scenario (including building the cell's localizers, which checks their parameters),
    /// so bad input is refused before any trial runs.
    pub fn from_toml_str_with(
        text: &str,
        file: &Path,
        registry: LocalizerRegistry,
    ) -> Result<Sweep, ScenarioError> {
        Self::parse(text, file, registry, &|_, _| {})
    }

    fn parse(
        text: &str,
        file: &Path,
        registry: LocalizerRegistry,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Sweep, ScenarioError> {
        let raw: SweepFile = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            file: file.to_path_buf(),
            msg: e.to_string(),
        })?;
        if raw.trials == 0 {
            return Err(ScenarioError::field(file, "trials", "must be at least 1"));
        }
        let mut flat = Vec::new();
        flatten_axes(file, &mut Vec::new(), &raw.axes, &mut flat)?;
        check_overlaps(file, &flat)?;
        let (axes, axis_keys): (Vec<Axis>, Vec<Vec<String>>) = flat.into_iter().unzip();
        Self::check_size(file, &axes, raw.trials)?;
        let dir = file.parent().unwrap_or(Path::new("."));
        let base_file = dir.join(&raw.base);
        let base_text = std::fs::read_to_string(&base_file).map_err(|err| ScenarioError::Io {
            file: base_file.clone(),
            err,
        })?;
        let base_doc: toml::Table =
            toml::from_str(&base_text).map_err(|e| ScenarioError::Parse {
                file: base_file.clone(),
                msg: e.to_string(),
            })?;
        let name = file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "sweep".into());
        let error_map = match raw.error_map {
            None => None,
            Some(e)
                if e.resolution.is_finite() && e.resolution >= 0.05 && e.resolution <= 100.0 =>
            {
                Some(e.resolution)
            }
            Some(e) => {
                return Err(ScenarioError::field(
                    file,
                    "error_map.resolution",
                    format!("must be between 0.05 and 100 m, got {}", e.resolution),
                ))
            }
        };
        raw.failure.validate().map_err(|(key, msg)| {
            let line = line_of(text, &["failure".to_string(), key.to_string()])
                .map_or(String::new(), |l| format!(" (line {l})"));
            ScenarioError::field(file, format!("failure.{key}"), msg + &line)
        })?;
        let mut sweep = Sweep {
            error_map,
            failure: raw.failure,
            world_hashes: Default::default(),
            generated_world: false,
            hashes: Default::default(),
            warm: WarmMaps::default(),
            // Validation builds every cell's localizers: record the paths they resolve.
            registry: registry.recording_paths(),
            extra_localizers: raw.localizers,
            extra_expect: raw.expect,
            file: file.to_path_buf(),
            name,
            hash: String::new(),
            inputs: Vec::new(),
            base_file,
            base_text,
            seed: raw.seed,
            trials: raw.trials,
            axes,
            text: text.to_string(),
            base_doc,
            axis_keys,
        };
        sweep.generated_world = sweep.check_world_axes()?;
        let collector = sweep.validate(progress)?;
        for p in sweep.registry.recorded_paths() {
            collector.add_file(&p);
        }
        collector.add_file(&sweep.base_file);
        sweep.registry = registry;
        sweep.inputs = inputs::hash_files(dir, &collector.files())?;
        sweep.hash = inputs::sweep_hash(text, &sweep.inputs);
        sweep.world_hashes =
            std::mem::take(&mut *sweep.hashes.lock().unwrap_or_else(|p| p.into_inner()));
        if !sweep.world_hashes.is_empty() {
            let mut parts: Vec<&[u8]> = vec![sweep.hash.as_bytes()];
            for h in sweep.world_hashes.values() {
                parts.push(h.as_bytes());
            }
            sweep.hash = inputs::fnv_hex(&parts);
        }
        Ok(sweep)
    }

    /// Number of cells (the product of the axis lengths; 1 with no axes).
    pub fn cells(&self) -> usize {
        self.axes.iter().map(|a| a.values.len()).product()
    }

    /// The cell and trial counts, refused (before anything is validated or run) when they
    /// overflow or pass [`MAX_CELLS`] / [`MAX_TRIALS`].
    fn check_size(file: &Path, axes: &[Axis], trials: usize) -> Result<(), ScenarioError> {
        let cells = axes
            .iter()
            .try_fold(1usize, |n, a| n.checked_mul(a.values.len()));
        let total = cells.and_then(|c| c.checked_mul(trials));
        match (cells, total) {
            (Some(c), Some(t)) if c <= MAX_CELLS && t <= MAX_TRIALS => Ok(()),
            _ => {
                let lens: Vec<String> = axes.iter().map(|a| a.values.len().to_string()).collect();
                Err(ScenarioError::field(
                    file,
                    "axes",
                    format!(
                        "{} cells × {trials} trials is more than the limits of {MAX_CELLS} cells \
                         and {MAX_TRIALS} trials per sweep (split it into several sweeps or shards)",
                        if lens.is_empty() { "1".to_string() } else { lens.join(" × ") },
                    ),
                ))
            }
        }
    }

    /// Total number of trials.
    pub fn total_trials(&self) -> usize {
        self.cells() * self.trials
    }

    /// Index into each axis's values for cell `cell` (last axis fastest).
    pub fn cell_indices(&self, cell: usize) -> Vec<usize> {
        let mut rem = cell;
        let mut idx = vec![0; self.axes.len()];
        for (i, a) in self.axes.iter().enumerate().rev() {
            idx[i] = rem % a.values.len();
            rem /= a.values.len();
        }
        idx
    }

    /// The (path, value) pairs of cell `cell`.
    pub fn cell_params(&self, cell: usize) -> Vec<(&str, &toml::Value)> {
        self.cell_indices(cell)
            .into_iter()
            .zip(&self.axes)
            .map(|(i, a)| (a.path.as_str(), &a.values[i]))
            .collect()
    }

    fn cell_choice(&self, cell: usize) -> Vec<(usize, usize)> {
        self.cell_indices(cell).into_iter().enumerate().collect()
    }

    /// The line of axis `a` in the sweep file.
    fn axis_line(&self, a: usize) -> Option<usize> {
        let keys = self.axis_keys.get(a)?;
        let mut path = vec!["axes".to_string()];
        path.extend(keys.iter().cloned());
        line_of(&self.text, &path)
    }

    /// `a = 1, b = "x"`: the axis values of `choice`.
    fn settings(&self, choice: &Choice) -> String {
        choice
            .iter()
            .map(|&(a, i)| format!("{} = {}", self.axes[a].path, show(&self.axes[a].values[i])))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// The cell's table: the base scenario's, with the sweep's own localizers and
    /// expectations, and the axis values of `choice`; and its text.
    fn cell_doc(&self, choice: &Choice) -> Result<String, ScenarioError> {
        let mut doc = self.base_doc.clone();
        if !self.extra_localizers.is_empty() {
            let list = doc
                .entry("localizers")
                .or_insert_with(|| toml::Value::Array(Vec::new()));
            if let toml::Value::Array(a) = list {
                a.extend(
                    self.extra_localizers
                        .iter()
                        .cloned()
                        .map(toml::Value::Table),
                );
            }
        }
        if !self.extra_expect.is_empty() {
            let expect = doc
                .entry("expect")
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            if let toml::Value::Table(t) = expect {
                for (k, v) in &self.extra_expect {
                    t.insert(k.clone(), v.clone());
                }
            }
        }
        for &(a, i) in choice {
            let axis = &self.axes[a];
            // `world.<parameter>` lands in `[world_params]` (the scenario's `world` is a
            // path, not a table).
            let path = match world_parameter(&axis.path) {
                Some(p) => format!("world_params.{p}"),
                None => axis.path.clone(),
            };
            set_path(&mut doc, &path, &axis.values[i]).map_err(|msg| {
                let line = self
                    .axis_line(a)
                    .map_or(String::new(), |l| format!(" (line {l})"));
                ScenarioError::field(&self.file, format!("axes.{}", axis.path), msg + &line)
            })?;
        }
        toml::to_string(&doc).map_err(|e| {
            ScenarioError::field(&self.file, "axes", format!("cannot write cell: {e}"))
        })
    }

    fn scenario_with(
        &self,
        choice: &Choice,
        cell: Option<usize>,
    ) -> Result<Scenario, ScenarioError> {
        let text = self.cell_doc(choice)?;
        // Parse as if the text were the base file, so its relative paths still resolve.
        Scenario::from_toml_str(&text, &self.base_file)
            .map_err(|e| self.explain(e, choice, cell, Some(&text)))
    }

    /// The scenario of cell `cell`.
    pub fn cell_scenario(&self, cell: usize) -> Result<Scenario, ScenarioError> {
        self.scenario_with(&self.cell_choice(cell), Some(cell))
    }

    /// `e` in terms of the keys of the cell document it concerns, when it is about the
    /// cell's own text (`text`: the generated text of a parse error's position).
    fn locate(&self, e: &ScenarioError, text: Option<&str>) -> Option<Located> {
        let mut loc = self.locate_raw(e, text)?;
        // `[world_params]` keys a world axis set are that axis's (`world.<parameter>`).
        if loc.keys.first().map(String::as_str) == Some("world_params") {
            let axis = loc.keys.get(1).map(|k| format!("{WORLD_AXIS}.{k}"));
            if axis.is_some_and(|p| self.axes.iter().any(|a| a.path == p)) {
                loc.keys[0] = WORLD_AXIS.to_string();
                loc.field = loc
                    .field
                    .as_ref()
                    .map(|f| f.replacen("world_params.", &format!("{WORLD_AXIS}."), 1));
            }
        }
        // An unnamed entry is written by index (`localizers[0].name`); axes and the sweep's
        // own tables name localizers, so take the name the entry had before any axis value.
        if loc.keys.first().map(String::as_str) == Some("localizers") {
            if let Some(i) = loc.keys.get(1).and_then(|k| k.parse::<usize>().ok()) {
                let base = self.base_doc.get("localizers").and_then(|l| l.as_array());
                let n_base = base.map_or(0, Vec::len);
                let entry = match i < n_base {
                    true => base.and_then(|b| b[i].as_table()),
                    false => self.extra_localizers.get(i - n_base),
                };
                if let Some(name) = entry.and_then(|t| t.get("name")).and_then(|n| n.as_str()) {
                    loc.keys[1] = name.to_string();
                }
            }
        }
        Some(loc)
    }

    fn locate_raw(&self, e: &ScenarioError, text: Option<&str>) -> Option<Located> {
        match e {
            ScenarioError::Parse { file, msg } if *file == self.base_file => {
                let text = text?;
                let (offset, msg) = parse_toml_message(msg, text);
                Some(Located {
                    keys: offset.map(|o| keys_at(text, o)).unwrap_or_default(),
                    field: None,
                    msg,
                })
            }
            ScenarioError::Field { file, field, msg } if *file == self.base_file => Some(Located {
                keys: field_keys(field),
                field: Some(field.clone()),
                msg: msg.clone(),
            }),
            _ => None,
        }
    }

    /// The base scenario with the sweep's own tables but no axis value, located as `locate`
    /// does, if it fails: tells an error of the base from one an axis value caused.
    fn base_alone_error(&self) -> Option<Located> {
        let text = self.cell_doc(&[]).ok()?;
        let e = match Scenario::from_toml_str(&text, &self.base_file) {
            Err(e) => e,
            Ok(s) => {
                let mut maps = SharedMaps::default();
                s.localizers
                    .iter()
                    .find_map(|spec| self.registry.build(spec, &s, &mut maps, 0).err())?
            }
        };
        self.locate(&e, Some(&text))
    }

    /// Whether `keys` (of the cell document) lie in the sweep file's own `[[localizers]]` or
    /// `[expect.<name>]` tables; then the keys under which the sweep file has them.
    fn sweep_own(&self, keys: &[String]) -> Option<Vec<String>> {
        let n_base = self
            .base_doc
            .get("localizers")
            .and_then(|l| l.as_array())
            .map_or(0, Vec::len);
        match (keys.first().map(String::as_str), keys.get(1)) {
            (Some("localizers"), Some(k)) => {
                let named = self
                    .extra_localizers
                    .iter()
                    .any(|l| l.get("name").and_then(|n| n.as_str()) == Some(k.as_str()));
                let index = k.parse::<usize>().ok().filter(|&i| i >= n_base);
                let mut own = keys.to_vec();
                match (named, index) {
                    (true, _) => Some(own),
                    (false, Some(i)) => {
                        own[1] = (i - n_base).to_string();
                        Some(own)
                    }
                    _ => None,
                }
            }
            (Some("expect"), Some(k)) if self.extra_expect.contains_key(k) => Some(keys.to_vec()),
            _ => None,
        }
    }

    /// Turns an error of the cell `choice` (text `text`) into one naming the file and line
    /// the user wrote: the axis whose value it concerns (sweep file), the sweep file's own
    /// localizers and expectations, or the base scenario; always with the axis values.
    fn explain(
        &self,
        e: ScenarioError,
        choice: &Choice,
        cell: Option<usize>,
        text: Option<&str>,
    ) -> ScenarioError {
        let values = self.settings(choice);
        let in_cell = match cell {
            Some(c) if choice.len() > 1 => format!("cell {c}: {values}"),
            _ => values.clone(),
        };
        let Some(loc) = self.locate(&e, text) else {
            // Another file's error (a world, robot, training scenario): it names its own
            // file; say which axis values led to it.
            return match (choice, cell) {
                ([], _) => e,
                ([(a, i)], _) => {
                    let line = self
                        .axis_line(*a)
                        .map_or(String::new(), |l| format!(", line {l}"));
                    ScenarioError::field(
                        &self.file,
                        format!("axes.{}", self.axes[*a].path),
                        format!("{e} (value {}{line})", show(&self.axes[*a].values[*i])),
                    )
                }
                (_, Some(c)) => ScenarioError::field(
                    &self.file,
                    format!("cell {c}"),
                    format!("{e} (with {values})"),
                ),
                (_, None) => ScenarioError::field(&self.file, values, e.to_string()),
            };
        };
        let field = loc
            .field
            .clone()
            .unwrap_or_else(|| display_field(&loc.keys));
        let axis_keys =
            |a: usize| -> Vec<String> { self.axes[a].path.split('.').map(String::from).collect() };
        // The axis whose value the error is at or inside; else the one axis inside the
        // table the error is about, unless the base scenario alone fails the same way.
        let at_axis = choice
            .iter()
            .find(|&&(a, _)| within(&loc.keys, &axis_keys(a)));
        let inside: Vec<&(usize, usize)> = choice
            .iter()
            .filter(|&&(a, _)| !loc.keys.is_empty() && within(&axis_keys(a), &loc.keys))
            .collect();
        let by_axis = at_axis.or_else(|| {
            (inside.len() == 1 && self.base_alone_error().as_ref() != Some(&loc)).then(|| inside[0])
        });
        if let Some(&(a, i)) = by_axis {
            let axis = &self.axes[a];
            let mut why = format!("value {}", show(&axis.values[i]));
            if let Some(l) = self.axis_line(a) {
                why.push_str(&format!(", line {l}"));
            }
            if choice.len() > 1 {
                why.push_str(&format!("; {in_cell}"));
            }
            // The field is worth naming when it is not the axis itself (nor already named
            // by the message).
            let named = loc.keys == axis_keys(a) || loc.msg.starts_with(&format!("{}:", axis.path));
            let msg = match named {
                true => loc.msg,
                false => format!("{field}: {}", loc.msg),
            };
            return ScenarioError::field(
                &self.file,
                format!("axes.{}", axis.path),
                format!("{msg} ({why})"),
            );
        }
        let with = |line: Option<usize>, from: &str| {
            let mut parts = Vec::new();
            if let Some(l) = line {
                parts.push(format!("line {l}"));
            }
            if !choice.is_empty() {
                parts.push(format!("with {in_cell}{from}"));
            }
            match parts.is_empty() {
                true => String::new(),
                false => format!(" ({})", parts.join("; ")),
            }
        };
        if let Some(own) = self.sweep_own(&loc.keys) {
            let line = line_of(&self.text, &own);
            return ScenarioError::field(
                &self.file,
                field,
                format!("{}{}", loc.msg, with(line, "")),
            );
        }
        let line = line_of(&self.base_text, &loc.keys);
        let from = format!(" of {}", self.file.display());
        ScenarioError::field(
            &self.base_file,
            field,
            format!("{}{}", loc.msg, with(line, &from)),
        )
    }

    /// Checks one combination of axis values; `cell` is the cell it is (if it is one), whose
    /// maps are then kept for the trials. The files it reads go to `collector`.
    fn check(
        &self,
        choice: &Choice,
        cell: Option<usize>,
        collector: &Collector,
    ) -> Result<(), ScenarioError> {
        let scenario = self.scenario_with(choice, cell)?;
        if let Some(res) = self.error_map {
            atrium_scenarios::error_maps::empty_for(&scenario, res).map_err(|msg| {
                let with = match choice {
                    [] => String::new(),
                    _ => format!(" (with {})", self.settings(choice)),
                };
                ScenarioError::field(&self.file, "error_map.resolution", msg + &with)
            })?;
        }
        // Kinds and expectation keys are checked when a run starts, localizer parameters when
        // a localizer is built; both here, so a misspelt key fails before any trial runs.
        self.registry
            .check(&scenario)
            .map_err(|e| self.explain(e, choice, cell, None))?;
        let mut maps = SharedMaps::default();
        for spec in &scenario.localizers {
            self.registry
                .build(spec, &scenario, &mut maps, 0)
                .map_err(|e| self.explain(e, choice, cell, None))?;
        }
        collector.add_scenario(&scenario);
        if let (Some(c), true) = (cell, self.generated_world) {
            let json = serde_json::to_string(&scenario.world).unwrap_or_default();
            self.hashes
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .insert(c, inputs::fnv_hex(&[json.as_bytes()]));
        }
        if let Some(c) = cell {
            self.warm
                .0
                .lock()
                .unwrap_or_else(|p| p.into_inner())
                .insert(c, maps);
        }
        Ok(())
    }

    /// Builds (or finds kept) maps for `cell`'s localizers and returns them: holding them
    /// keeps them shared by the cell's trials.
    pub(crate) fn warm_cell(
        &self,
        cell: usize,
        scenario: &Scenario,
    ) -> Result<SharedMaps, ScenarioError> {
        if let Some(m) = self.warm.take(cell) {
            return Ok(m);
        }
        let mut maps = SharedMaps::default();
        for spec in &scenario.localizers {
            self.registry.build(spec, scenario, &mut maps, 0)?;
        }
        Ok(maps)
    }

    /// Checks the `world.<parameter>` axes before any cell, so their errors name the axis and
    /// the parameter: the base scenario's world must be a generator file, the parameter one
    /// of its kind's, and every value must make a world (with the base scenario's own
    /// `[world_params]`). Localizers that learn from another scenario file are refused with a
    /// world axis: that file generates its own world, not the cell's. Returns whether the
    /// base scenario's world is generated.
    fn check_world_axes(&self) -> Result<bool, ScenarioError> {
        use atrium_worlds::generate::is_generator_text;
        use atrium_worlds::{GeneratorFile, GeneratorRegistry, WorldError};
        let dir = self.base_file.parent().unwrap_or(Path::new("."));
        let world_file = self
            .base_doc
            .get("world")
            .and_then(|w| w.as_str())
            .map(|w| dir.join(w));
        let text = world_file
            .as_ref()
            .and_then(|f| std::fs::read_to_string(f).ok());
        let generated = text.as_deref().is_some_and(is_generator_text);
        let registry = GeneratorRegistry::with_builtins();
        for (a, axis) in self.axes.iter().enumerate() {
            let Some(param) = world_parameter(&axis.path) else {
                continue;
            };
            let line = self
                .axis_line(a)
                .map_or(String::new(), |l| format!(", line {l}"));
            let at_line = self
                .axis_line(a)
                .map_or(String::new(), |l| format!(" (line {l})"));
            let refuse =
                |msg: String| ScenarioError::field(&self.file, format!("axes.{}", axis.path), msg);
            if param.contains('.') {
                return Err(refuse(format!(
                    "{param:?} is not a generator parameter: a generator's parameters are \
                     flat keys, write {WORLD_AXIS}.<parameter>{at_line}"
                )));
            }
            let (Some(world_file), Some(text)) = (&world_file, &text) else {
                return Err(refuse(format!(
                    "{param}: the base scenario {} names no readable world file{at_line}",
                    self.base_file.display()
                )));
            };
            if !generated {
                return Err(refuse(format!(
                    "{param}: the base scenario's world {} is not a generator file (no \
                     top-level `generator` key), so it has no parameters to sweep{at_line}",
                    world_file.display()
                )));
            }
            let mut generator =
                GeneratorFile::parse(text, world_file).map_err(|e| refuse(e.to_string()))?;
            if let Some(t) = self.base_doc.get("world_params").and_then(|t| t.as_table()) {
                for (k, v) in t {
                    generator
                        .set(k, v.clone())
                        .map_err(|e| refuse(e.to_string()))?;
                }
            }
            let Some(kind) = registry.get(&generator.generator) else {
                return Err(refuse(format!(
                    "{param}: the world {} names generator {:?}, which is not known \
                     (known: {}){at_line}",
                    world_file.display(),
                    generator.generator,
                    registry.names().join(", ")
                )));
            };
            let defaults = kind.defaults();
            if !defaults.contains_key(param) {
                let known: Vec<&str> = defaults.keys().map(String::as_str).collect();
                return Err(refuse(format!(
                    "{param:?} is not a parameter of generator {:?} (its parameters: {}){at_line}",
                    generator.generator,
                    known.join(", ")
                )));
            }
            for v in &axis.values {
                let mut g = generator.clone();
                let made = g.set(param, v.clone()).and_then(|_| g.generate(&registry));
                if let Err(e) = made {
                    let msg = match e {
                        // The generator's message of the parameter, without its "(from
                        // --set)": the value came from this axis.
                        WorldError::Field { field, msg, .. } if field == param => {
                            msg.trim_end_matches(" (from --set)").to_string()
                        }
                        other => other.to_string(),
                    };
                    return Err(refuse(format!("{param}: {msg} (value {}{line})", show(v))));
                }
            }
            let base = self.base_doc.get("localizers").and_then(|l| l.as_array());
            let tables = base
                .into_iter()
                .flatten()
                .filter_map(|l| l.as_table())
                .chain(&self.extra_localizers);
            for l in tables {
                if let Some(t) = l.get("training").and_then(|t| t.as_str()) {
                    // A training scenario on the same generator file learns on each cell's
                    // world (`Scenario::load_training`); on another world it would learn a
                    // building the cell does not have.
                    if training_world(&dir.join(t))
                        .is_some_and(|w| atrium_scenarios::scenario::same_file(&w, world_file))
                    {
                        continue;
                    }
                    let name = l.get("name").and_then(|n| n.as_str()).unwrap_or("?");
                    return Err(refuse(format!(
                        "localizer {name:?} learns from another scenario (training = {t:?}) \
                         whose world is not the base scenario's generator file {}, so its \
                         survey or training would not follow the world axis{at_line}",
                        world_file.display()
                    )));
                }
            }
        }
        Ok(generated)
    }

    /// Checks each axis value alone (so an error names the axis responsible), then every
    /// cell, on all cores; the error reported is the first in that order whatever the thread
    /// count. Returns the files the cells read.
    fn validate(
        &self,
        progress: &(dyn Fn(usize, usize) + Sync),
    ) -> Result<Collector, ScenarioError> {
        enum Check {
            Value(usize, usize),
            Cell(usize),
        }
        let single = self.axes.len() == 1;
        let mut checks: Vec<Check> = Vec::new();
        for (a, axis) in self.axes.iter().enumerate() {
            checks.extend((0..axis.values.len()).map(|i| Check::Value(a, i)));
        }
        // With one axis, value i is cell i, checked above.
        if !single {
            checks.extend((0..self.cells()).map(Check::Cell));
        }
        let collector = Collector::default();
        let total = checks.len();
        let done = AtomicUsize::new(0);
        let started = Instant::now();
        let last = Mutex::new(started);
        let reported = AtomicBool::new(false);
        let failed = checks.par_iter().find_map_first(|check| {
            let r = match *check {
                Check::Value(a, i) => self.check(&[(a, i)], single.then_some(i), &collector),
                Check::Cell(c) => self.check(&self.cell_choice(c), Some(c), &collector),
            };
            let n = done.fetch_add(1, Ordering::Relaxed) + 1;
            if started.elapsed() >= PROGRESS_EVERY {
                if let Ok(mut t) = last.try_lock() {
                    if t.elapsed() >= PROGRESS_EVERY {
                        *t = Instant::now();
                        reported.store(true, Ordering::Relaxed);
                        progress(n, total);
                    }
                }
            }
            r.err()
        });
        if let Some(e) = failed {
            return Err(e);
        }
        if reported.load(Ordering::Relaxed) {
            progress(total, total);
        }
        Ok(collector)
    }
}

/// The world file a training scenario at `path` names, resolved against its folder (`None`
/// when the file or its `world` key cannot be read).
fn training_world(path: &Path) -> Option<std::path::PathBuf> {
    let text = std::fs::read_to_string(path).ok()?;
    let doc: toml::Table = toml::from_str(&text).ok()?;
    let world = doc.get("world")?.as_str()?;
    Some(path.parent().unwrap_or(Path::new(".")).join(world))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_path_edits_nested_tables_and_named_localizers() {
        let mut doc: toml::Table =
            toml::from_str("duration_s = 5.0\n[[localizers]]\nname = \"mcl\"\nkind = \"mcl\"\n")
                .unwrap();
        set_path(&mut doc, "duration_s", &toml::Value::Float(2.0)).unwrap();
        set_path(
            &mut doc,
            "sensors.laser.range_max",
            &toml::Value::Float(4.0),
        )
        .unwrap();
        set_path(
            &mut doc,
            "localizers.mcl.max_particles",
            &toml::Value::Integer(10),
        )
        .unwrap();
        assert_eq!(doc["duration_s"].as_float(), Some(2.0));
        assert_eq!(doc["sensors"]["laser"]["range_max"].as_float(), Some(4.0));
        assert_eq!(doc["localizers"][0]["max_particles"].as_integer(), Some(10));
        let err = set_path(&mut doc, "localizers.nope.x", &toml::Value::Integer(1)).unwrap_err();
        assert!(err.contains("nope") && err.contains("mcl"), "{err}");
        assert!(set_path(&mut doc, "duration_s.x", &toml::Value::Integer(1)).is_err());
    }

    /// A folder with a small base scenario (the campus, dead reckoning only: cheap to
    /// validate) and the sweep file `sweep` beside it; returns the sweep file's path.
    pub(crate) fn sweep_file(tag: &str, sweep: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("atrium-sweep-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let root = atrium_scenarios::bundled_scenarios_dir().join("..");
        let base = format!(
            "name = \"base\"\nduration_s = 5.0\nworld = {:?}\nrobot = {:?}\nseed = 3\n\
             [start]\npose = [2.0, 20.0, 0.0]\n[route]\nwaypoints = [[8.0, 20.0]]\n\
             [[localizers]]\nname = \"odometry\"\nkind = \"dead_reckoning\"\n",
            root.join("worlds/campus.toml"),
            root.join("robots/urdf/pioneer3dx.urdf"),
        );
        std::fs::write(dir.join("base.toml"), base).unwrap();
        let f = dir.join("s.toml");
        std::fs::write(&f, sweep).unwrap();
        f
    }

    fn load_err(tag: &str, sweep: &str) -> String {
        Sweep::load(&sweep_file(tag, sweep))
            .unwrap_err()
            .to_string()
    }

    const HEAD: &str = "base = \"base.toml\"\nseed = 1\ntrials = 1\n";

    #[test]
    fn an_axis_named_twice_is_refused_naming_both_spellings() {
        let e = load_err(
            "twice",
            &format!(
                "{HEAD}[axes]\n\"controller.max_speed\" = [0.5]\n[axes.controller]\nmax_speed = [0.7]\n"
            ),
        );
        assert!(e.contains("s.toml: axes:"), "{e}");
        assert!(
            e.contains("are the same parameter controller.max_speed"),
            "{e}"
        );
        assert!(
            e.contains("axes.\"controller.max_speed\"")
                && e.contains("axes.controller.max_speed and"),
            "{e}"
        );
        let e = load_err(
            "inside",
            &format!(
                "{HEAD}[axes]\ncontroller = [{{ max_speed = 0.5 }}]\n\"controller.max_speed\" = [0.7]\n"
            ),
        );
        assert!(
            e.contains("axes.controller and axes.\"controller.max_speed\" overlap"),
            "{e}"
        );
        let e = load_err(
            "localizer-twice",
            &format!(
                "{HEAD}[axes]\n\"localizers.odometry.x\" = [1]\n[axes.localizers.odometry]\nx = [2]\n"
            ),
        );
        assert!(e.contains("same parameter localizers.odometry.x"), "{e}");
    }

    #[test]
    fn axis_paths_are_bare_keys_and_tables_name_axes() {
        for (bad, needle) in [
            ("\"odometry.\" = [1]", "\"\" is not a parameter name"),
            ("\"a\\nb\" = [1]", "is not a parameter name"),
            ("\"a,b\" = [1]", "\"a,b\" is not a parameter name"),
            ("\"a b\" = [1]", "axes.\"a b\""),
        ] {
            let e = load_err("keys", &format!("{HEAD}[axes]\n{bad}\n"));
            assert!(e.contains(needle), "{bad}: {e}");
        }
        let e = load_err("empty-table", &format!("{HEAD}[axes.odometry]\n"));
        assert!(e.contains("axes.odometry: an empty table"), "{e}");
    }

    #[test]
    fn cell_errors_name_the_users_file_and_line() {
        // A wrong type on line 6 of the sweep file: the parse of the generated cell text
        // must not leak its own line numbers.
        let e = load_err(
            "line-axis",
            &format!("{HEAD}\n[axes]\nduration_s = [\"x\"]\n"),
        );
        assert!(
            e.starts_with(&format!(
                "{}: axes.duration_s: invalid type: string \"x\"",
                sweep_file("line-axis", "").display()
            )),
            "{e}"
        );
        assert!(e.contains("line 6"), "{e}");
        assert!(!e.contains("TOML parse error") && !e.contains('|'), "{e}");

        // A value a scenario check refuses (not a parse error): its line.
        let e = load_err(
            "line-check",
            &format!("{HEAD}[axes]\n\"odometry.radius_error\" = [0.01]\n\n\"controller.max_speed\" = [0.5, 1e9]\n"),
        );
        assert!(
            e.contains("s.toml: axes.controller.max_speed: 1000000000 is above"),
            "{e}"
        );
        assert!(e.contains("value 1000000000.0, line 7"), "{e}");

        // The sweep file's own localizer: its file and line, not the base scenario's.
        let e = load_err(
            "line-own",
            &format!("{HEAD}[axes]\nduration_s = [1.0, 2.0]\n\n[[localizers]]\nname = \"x\"\nkind = \"dead_reckoning\"\nbogus = 3\n"),
        );
        assert!(
            e.contains("s.toml: localizers[x].bogus: dead_reckoning takes no parameters"),
            "{e}"
        );
        assert!(e.contains("(line 10; with duration_s = 1.0)"), "{e}");
        assert!(!e.contains("base.toml"), "{e}");

        // An expectation key of the sweep file.
        let e = load_err(
            "line-expect",
            &format!("{HEAD}[expect.odometry]\nmedian_maxx = 3\n"),
        );
        assert!(e.contains("s.toml: expect.odometry.median_maxx"), "{e}");
        assert!(e.contains("line 5"), "{e}");

        // A parameter an axis misspells inside a localizer's table.
        let e = load_err(
            "line-param",
            &format!("{HEAD}[axes]\n\"localizers.odometry.nonsense\" = [1]\n"),
        );
        assert!(e.contains("s.toml: axes.localizers.odometry.nonsense: dead_reckoning takes no parameters (value 1, line 5)"), "{e}");

        // A key of a nested-table spelling: the line of the key itself.
        let e = load_err(
            "line-table",
            &format!("{HEAD}[axes]\nduration_s = [1.0]\n[axes.controller]\nmax_sped = [1.0]\n"),
        );
        assert!(
            e.contains("s.toml: axes.controller.max_sped: unknown key"),
            "{e}"
        );
        assert!(e.contains("(value 1.0, line 7)"), "{e}");
    }

    #[test]
    fn base_scenario_errors_name_the_base_file_and_its_line() {
        let f = sweep_file(
            "line-base",
            &format!("{HEAD}[axes]\nduration_s = [1.0, 2.0]\n"),
        );
        let base = f.parent().unwrap().join("base.toml");
        let text = std::fs::read_to_string(&base).unwrap();
        std::fs::write(
            &base,
            text.replace("seed = 3\n", "seed = 3\neval_hz = \"fast\"\n"),
        )
        .unwrap();
        let e = Sweep::load(&f).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}: eval_hz: invalid type", base.display())),
            "{e}"
        );
        assert!(
            e.contains(&format!("line 6; with duration_s = 1.0 of {}", f.display())),
            "{e}"
        );
    }

    #[test]
    fn validation_reports_progress_only_when_slow_and_collects_inputs() {
        let f = sweep_file(
            "inputs",
            &format!("{HEAD}[axes]\nduration_s = [1.0, 2.0]\n"),
        );
        let calls = AtomicUsize::new(0);
        let s = Sweep::load_reporting(&f, LocalizerRegistry::with_builtins(), &|_, _| {
            calls.fetch_add(1, Ordering::Relaxed);
        })
        .unwrap();
        assert_eq!(calls.load(Ordering::Relaxed), 0);
        let names: Vec<&str> = s.inputs.iter().map(|i| i.file.as_str()).collect();
        assert!(names.contains(&"base.toml"), "{names:?}");
        for end in [
            "worlds/campus.toml",
            "robots/urdf/pioneer3dx.urdf",
            "pioneer3dx.sensors.toml",
        ] {
            assert!(
                names.iter().any(|n| n.ends_with(end)),
                "{end} not in {names:?}"
            );
        }
    }
}
