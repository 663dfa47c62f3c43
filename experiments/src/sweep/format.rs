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
//! ```
//!
//! An axis's path may also be written as nested tables (`[axes.odometry] radius_error = [..]`);
//! every leaf array is one axis. Cells are the cartesian product of the axes, the last axis
//! varying fastest. A cell is applied by editing the base scenario's TOML table and parsing the
//! result with [`Scenario::from_toml_str`], so every scenario validation applies to it.

use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::maps::SharedMaps;
use atrium_scenarios::scenario::Scenario;
use atrium_scenarios::LocalizerRegistry;
use std::path::{Path, PathBuf};

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
    /// Identifies the sweep: a hash of the sweep file's and base scenario's text. Results
    /// written under another hash belong to another sweep and are never mixed with these.
    pub hash: String,
    /// `[error_map] resolution`, m: every trial records a per-location error map.
    pub error_map: Option<f64>,
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
    /// `[[localizers]]` added to the base scenario's (a user's own beside the bundled ones).
    #[serde(default)]
    localizers: Vec<toml::Table>,
    /// `[expect.<localizer>]` tables added to (or replacing) the base scenario's.
    #[serde(default)]
    expect: toml::Table,
}

/// FNV-1a 64 over `parts` with a separator, printed as hex: stable across machines and
/// Rust versions (unlike `DefaultHasher`).
fn fnv_hex(parts: &[&str]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for p in parts {
        for b in p.bytes().chain(std::iter::once(0u8)) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    format!("{h:016x}")
}

fn flatten_axes(
    file: &Path,
    prefix: &str,
    table: &toml::Table,
    out: &mut Vec<Axis>,
) -> Result<(), ScenarioError> {
    for (k, v) in table {
        let path = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(t) => flatten_axes(file, &path, t, out)?,
            toml::Value::Array(values) => {
                if values.is_empty() {
                    return Err(ScenarioError::field(
                        file,
                        format!("axes.{path}"),
                        "empty axis: give at least one value",
                    ));
                }
                out.push(Axis {
                    path,
                    values: values.clone(),
                });
            }
            _ => {
                return Err(ScenarioError::field(
                    file,
                    format!("axes.{path}"),
                    "an axis must be a list of values",
                ))
            }
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

impl Sweep {
    /// Loads a sweep whose trials use Atrium's built-in localizer kinds.
    pub fn load(path: &Path) -> Result<Sweep, ScenarioError> {
        Self::load_with(path, LocalizerRegistry::with_builtins())
    }

    /// Loads a sweep whose trials build their localizers from `registry` (a user's kinds).
    pub fn load_with(path: &Path, registry: LocalizerRegistry) -> Result<Sweep, ScenarioError> {
        let text = std::fs::read_to_string(path).map_err(|err| ScenarioError::Io {
            file: path.to_path_buf(),
            err,
        })?;
        Self::from_toml_str_with(&text, path, registry)
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
        let raw: SweepFile = toml::from_str(text).map_err(|e| ScenarioError::Parse {
            file: file.to_path_buf(),
            msg: e.to_string(),
        })?;
        if raw.trials == 0 {
            return Err(ScenarioError::field(file, "trials", "must be at least 1"));
        }
        let dir = file.parent().unwrap_or(Path::new("."));
        let base_file = dir.join(&raw.base);
        let base_text = std::fs::read_to_string(&base_file).map_err(|err| ScenarioError::Io {
            file: base_file.clone(),
            err,
        })?;
        let mut axes = Vec::new();
        flatten_axes(file, "", &raw.axes, &mut axes)?;
        Self::check_size(file, &axes, raw.trials)?;
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
        let sweep = Sweep {
            error_map,
            warm: WarmMaps::default(),
            registry,
            extra_localizers: raw.localizers,
            extra_expect: raw.expect,
            file: file.to_path_buf(),
            name,
            hash: fnv_hex(&[text, &base_text]),
            base_file,
            base_text,
            seed: raw.seed,
            trials: raw.trials,
            axes,
        };
        sweep.validate()?;
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

    fn scenario_with(&self, params: &[(&str, &toml::Value)]) -> Result<Scenario, ScenarioError> {
        let mut doc: toml::Table =
            toml::from_str(&self.base_text).map_err(|e| ScenarioError::Parse {
                file: self.base_file.clone(),
                msg: e.to_string(),
            })?;
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
        for (path, value) in params {
            set_path(&mut doc, path, value)
                .map_err(|msg| ScenarioError::field(&self.file, format!("axes.{path}"), msg))?;
        }
        let text = toml::to_string(&doc).map_err(|e| {
            ScenarioError::field(&self.file, "axes", format!("cannot write cell: {e}"))
        })?;
        // Parse as if the text were the base file, so its relative paths still resolve.
        Scenario::from_toml_str(&text, &self.base_file)
    }

    /// The scenario of cell `cell`.
    pub fn cell_scenario(&self, cell: usize) -> Result<Scenario, ScenarioError> {
        self.scenario_with(&self.cell_params(cell))
    }

    /// Checks one combination of axis values; `cell` is the cell it is (if it is one), whose
    /// maps are then kept for the trials.
    fn check(
        &self,
        params: &[(&str, &toml::Value)],
        what: String,
        cell: Option<usize>,
    ) -> Result<(), ScenarioError> {
        let wrap = |e: ScenarioError| ScenarioError::field(&self.file, &what, e.to_string());
        let scenario = self.scenario_with(params).map_err(wrap)?;
        if let Some(res) = self.error_map {
            atrium_scenarios::error_maps::empty_for(&scenario, res)
                .map_err(|msg| ScenarioError::field(&self.file, "error_map.resolution", msg))
                .map_err(wrap)?;
        }
        // Localizer parameters are checked when a localizer is built, not when the scenario
        // is parsed; build them here so a misspelt parameter fails before any trial runs.
        let mut maps = SharedMaps::default();
        for spec in &scenario.localizers {
            self.registry
                .build(spec, &scenario, &mut maps, 0)
                .map_err(wrap)?;
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

    fn validate(&self) -> Result<(), ScenarioError> {
        // Each axis alone first, so an error names the axis responsible.
        let single = self.axes.len() == 1;
        for a in &self.axes {
            for (i, v) in a.values.iter().enumerate() {
                // With one axis, value i is cell i.
                let cell = single.then_some(i);
                self.check(
                    &[(a.path.as_str(), v)],
                    format!("axes.{} = {v}", a.path),
                    cell,
                )?;
            }
        }
        if self.axes.len() > 1 || self.axes.is_empty() {
            for cell in 0..self.cells() {
                let params = self.cell_params(cell);
                self.check(&params, format!("cell {cell}"), Some(cell))?;
            }
        }
        Ok(())
    }
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

    #[test]
    fn hash_depends_on_every_part() {
        assert_ne!(fnv_hex(&["ab", "c"]), fnv_hex(&["a", "bc"]));
        assert_eq!(fnv_hex(&["x"]), fnv_hex(&["x"]));
    }
}
