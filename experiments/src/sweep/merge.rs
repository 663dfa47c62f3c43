//! `atrium sweep merge OUT_DIR SHARD_DIR...`: joins the results of shards of one sweep, their
//! per-trial error maps (`maps/`), and redraws the heat maps and error maps of the whole.

use super::csv::{self, Results};
use super::heatmap::AxisLabels;
use super::maps;
use super::run::canonical;
use super::summary;
use atrium_scenarios::error::ScenarioError;
use std::path::Path;

/// Merges `shards/*/results.csv` into `out/results.csv` (sorted by cell, trial, localizer)
/// and writes `out/summary.md`. All shards must come from the same sweep (same hash).
pub fn merge(out: &Path, shards: &[impl AsRef<Path>]) -> Result<Results, ScenarioError> {
    let mut merged: Option<Results> = None;
    for dir in shards {
        let path = dir.as_ref().join("results.csv");
        let r = csv::read_results(&path)?;
        match &mut merged {
            None => merged = Some(r),
            Some(m) => {
                if m.hash != r.hash || m.axis_paths != r.axis_paths {
                    return Err(ScenarioError::field(
                        &path,
                        "hash",
                        format!(
                            "results of a different sweep (hash {}, first shard {})",
                            r.hash, m.hash
                        ),
                    ));
                }
                m.rows.extend(r.rows);
            }
        }
    }
    let mut merged = merged
        .ok_or_else(|| ScenarioError::field(out, "SHARD_DIR", "give at least one shard folder"))?;
    merged.rows = canonical(std::mem::take(&mut merged.rows));
    merged.dropped_partial = false;
    std::fs::create_dir_all(out).map_err(|err| ScenarioError::Io {
        file: out.to_path_buf(),
        err,
    })?;
    csv::write_atomic(&out.join("results.csv"), &merged.to_text())?;
    csv::write_atomic(&out.join("summary.md"), &summary::to_markdown(&merged))?;

    // The axes' values and the cell count come from the first shard's sweep.json.
    let first = shards.first().map(|d| d.as_ref().join("sweep.json"));
    let (axes, cells) = match &first {
        Some(p) => read_axes(p)?,
        None => (Vec::new(), 1),
    };
    let mut copied = 0;
    for dir in shards {
        copied += maps::copy_maps(dir.as_ref(), out)?;
    }
    if let Some(p) = &first {
        let text = std::fs::read_to_string(p).map_err(|err| ScenarioError::Io {
            file: p.clone(),
            err,
        })?;
        let mut doc: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| ScenarioError::field(p, "sweep.json", e.to_string()))?;
        doc["shard"] = serde_json::Value::Null;
        csv::write_atomic(
            &out.join("sweep.json"),
            &serde_json::to_string_pretty(&doc).unwrap_or_default(),
        )?;
    }
    let trials: Vec<(usize, usize)> = merged.rows.iter().map(|r| (r.cell, r.trial)).collect();
    super::run::write_pictures(
        out,
        &merged,
        &axes,
        (copied > 0).then_some((trials.as_slice(), cells == 1)),
    )?;
    Ok(merged)
}

/// The axes (path and value labels, strings unquoted as in results.csv) and the cell count
/// recorded in a shard's sweep.json.
fn read_axes(path: &Path) -> Result<(Vec<AxisLabels>, usize), ScenarioError> {
    let bad = |msg: String| ScenarioError::field(path, "axes", msg);
    let text = std::fs::read_to_string(path).map_err(|err| ScenarioError::Io {
        file: path.to_path_buf(),
        err,
    })?;
    let doc: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    let cells = doc["cells"].as_u64().unwrap_or(1) as usize;
    let mut axes = Vec::new();
    for a in doc["axes"]
        .as_array()
        .ok_or_else(|| bad("missing".into()))?
    {
        let path = a["path"]
            .as_str()
            .ok_or_else(|| bad("axis without path".into()))?;
        let values = a["values"]
            .as_array()
            .ok_or_else(|| bad(format!("{path}: no values")))?
            .iter()
            .map(|v| {
                let s = v.as_str().unwrap_or_default();
                // Values are stored as TOML text: a string keeps its quotes there.
                match toml::from_str::<toml::Table>(&format!("v = {s}")) {
                    Ok(t) => match &t["v"] {
                        toml::Value::String(x) => x.clone(),
                        other => other.to_string(),
                    },
                    Err(_) => s.to_string(),
                }
            })
            .collect();
        axes.push(AxisLabels {
            path: path.to_string(),
            values,
        });
    }
    Ok((axes, cells))
}
