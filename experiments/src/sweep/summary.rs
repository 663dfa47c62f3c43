//! `summary.md`: the paper-style table (004 §3, Table 1: min / median / max error per
//! sensor) per cell, over the per-trial median position errors.

use super::csv::Results;
use atrium_scenarios::metrics::ErrorStats;
use std::collections::BTreeMap;

/// (trials, min, median, max) of the per-trial median errors of one localizer in one cell.
pub type CellStats = (usize, f64, f64, f64);

/// Per cell and localizer: the statistics of the per-trial median error.
pub fn table(results: &Results) -> BTreeMap<usize, BTreeMap<String, CellStats>> {
    let mut medians: BTreeMap<usize, BTreeMap<String, Vec<f64>>> = BTreeMap::new();
    for r in &results.rows {
        if let Some(m) = r.median() {
            medians
                .entry(r.cell)
                .or_default()
                .entry(r.localizer.clone())
                .or_default()
                .push(m);
        }
    }
    medians
        .into_iter()
        .map(|(cell, locs)| {
            let locs = locs
                .into_iter()
                .filter_map(|(name, v)| {
                    let s = ErrorStats::of(v)?;
                    Some((name, (s.samples, s.min, s.median, s.max)))
                })
                .collect();
            (cell, locs)
        })
        .collect()
}

pub fn to_markdown(results: &Results) -> String {
    let mut params: BTreeMap<usize, &[String]> = BTreeMap::new();
    for r in &results.rows {
        params.entry(r.cell).or_insert(&r.params);
    }
    let mut s = format!(
        "# Sweep {} (hash {})\n\nPer cell: min / median / max over trials of each trial's median position error, m.\n",
        super::markdown::one_line(&results.name),
        results.hash
    );
    let drives = super::drive::per_cell(results);
    if let Some(w) = super::drive::unlike_drives(&drives) {
        s.push_str(&format!("\n**Note:** {}\n", super::markdown::one_line(&w)));
    }
    for (cell, locs) in table(results) {
        let p: Vec<String> = results
            .axis_paths
            .iter()
            .zip(params.get(&cell).copied().unwrap_or_default())
            .map(|(k, v)| super::markdown::one_line(&format!("{k} = {v}")))
            .collect();
        s.push_str(&format!("\n## Cell {cell}: {}\n\n", p.join(", ")));
        if let Some(d) = drives.get(&cell) {
            s.push_str(&super::drive::markdown_line(d));
        }
        s.push_str("| localizer | trials | min | median | max |\n|---|---:|---:|---:|---:|\n");
        for (name, (n, min, med, max)) in locs {
            s.push_str(&format!(
                "| {name} | {n} | {min:.4} | {med:.4} | {max:.4} |\n"
            ));
        }
    }
    s.push_str(&super::end_error::to_markdown(results));
    s
}
