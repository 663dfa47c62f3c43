//! `atrium sweep merge OUT_DIR SHARD_DIR...`: joins the results of shards of one sweep.

use super::csv::{self, Results};
use super::run::canonical;
use super::summary;
use crate::error::ScenarioError;
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
    Ok(merged)
}
