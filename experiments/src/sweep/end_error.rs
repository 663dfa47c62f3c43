//! The open-area table of [004] §3: per localizer, the minimum, maximum
//! and median of the END error over a sweep's trials ("the robot was then driven back to the
//! starting location, and the error in localization noted"). The end error of a trial is the
//! `final_m` column of `results.csv` (the position error at the run's last scoring instant).
//! `summary.md` carries this table for every cell, after the table of per-trial medians.

use super::csv::{fixed_columns, Results, Row};
use atrium_scenarios::metrics::ErrorStats;
use std::collections::BTreeMap;

/// Min / median / max of the end errors of one localizer in one cell, m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EndErrorStats {
    /// Trials with a recorded end error.
    pub trials: usize,
    pub min: f64,
    pub median: f64,
    pub max: f64,
}

/// A row's end error (`final_m`), m; None when the localizer was never scored.
pub fn final_error(row: &Row) -> Option<f64> {
    // `values` holds the fixed columns after cell, trial, seed and localizer.
    let i = fixed_columns().iter().position(|c| *c == "final_m")? - 4;
    row.values.get(i).and_then(|v| v.parse().ok())
}

/// Per cell, per localizer (in name order): the end-error statistics over the trials.
pub fn table(results: &Results) -> BTreeMap<usize, BTreeMap<String, EndErrorStats>> {
    let mut errors: BTreeMap<usize, BTreeMap<String, Vec<f64>>> = BTreeMap::new();
    for r in &results.rows {
        if let Some(e) = final_error(r) {
            errors
                .entry(r.cell)
                .or_default()
                .entry(r.localizer.clone())
                .or_default()
                .push(e);
        }
    }
    errors
        .into_iter()
        .map(|(cell, locs)| {
            let locs = locs
                .into_iter()
                .filter_map(|(name, v)| {
                    let s = ErrorStats::of(v)?;
                    let s = EndErrorStats {
                        trials: s.samples,
                        min: s.min,
                        median: s.median,
                        max: s.max,
                    };
                    Some((name, s))
                })
                .collect();
            (cell, locs)
        })
        .collect()
}

/// The table as Markdown, laid out as in the paper: one column per localizer, rows min / max
/// / median end error, one table per cell.
pub fn to_markdown(results: &Results) -> String {
    let mut params: BTreeMap<usize, &[String]> = BTreeMap::new();
    for r in &results.rows {
        params.entry(r.cell).or_insert(&r.params);
    }
    let mut s = String::from(
        "\n# End error\n\nPer cell: min / max / median over trials of each trial's END position \
         error (`final_m`), m (004 §3, the open-area table).\n",
    );
    for (cell, locs) in table(results) {
        let p: Vec<String> = results
            .axis_paths
            .iter()
            .zip(params.get(&cell).copied().unwrap_or_default())
            .map(|(k, v)| super::markdown::one_line(&format!("{k} = {v}")))
            .collect();
        s.push_str(&format!(
            "\n## End error, cell {cell}: {}\n\n",
            p.join(", ")
        ));
        let names: Vec<&String> = locs.keys().collect();
        s.push_str("| end error (m) |");
        for n in &names {
            s.push_str(&format!(" {n} |"));
        }
        s.push_str("\n|---|");
        s.push_str(&"---:|".repeat(names.len()));
        s.push('\n');
        type Pick = fn(&EndErrorStats) -> f64;
        let rows: [(&str, Pick); 3] = [
            ("min", |e| e.min),
            ("max", |e| e.max),
            ("median", |e| e.median),
        ];
        for (label, pick) in rows {
            s.push_str(&format!("| {label} |"));
            for n in &names {
                s.push_str(&format!(" {:.2} |", pick(&locs[*n])));
            }
            s.push('\n');
        }
        s.push_str("| trials |");
        for n in &names {
            s.push_str(&format!(" {} |", locs[*n].trials));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(trial: usize, loc: &str, final_m: &str) -> Row {
        // min, median, rmse, p95, max, final, converged_after_s, passed, wall_s
        let mut values: Vec<String> = ["0", "9", "0", "0", "0"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        values.extend([final_m, "", "true", "0.1"].iter().map(|s| s.to_string()));
        Row {
            params: vec![],
            cell: 0,
            trial,
            seed: trial as u64,
            localizer: loc.into(),
            values,
        }
    }

    #[test]
    fn end_error_table_uses_the_final_column() {
        let results = Results {
            hash: "h".into(),
            name: "n".into(),
            layout: None,
            axis_paths: vec![],
            rows: vec![
                row(0, "laser", "0.01"),
                row(1, "laser", "14.5"),
                row(2, "laser", "2.0"),
                row(0, "wifi", "0.5"),
                row(1, "wifi", "1.5"),
                row(2, "wifi", ""), // never scored: left out
            ],
            dropped_partial: false,
        };
        let t = table(&results);
        let l = t[&0]["laser"];
        assert_eq!((l.trials, l.min, l.median, l.max), (3, 0.01, 2.0, 14.5));
        let w = t[&0]["wifi"];
        assert_eq!((w.trials, w.min, w.median, w.max), (2, 0.5, 1.0, 1.5));
        let md = to_markdown(&results);
        assert!(md.contains("| end error (m) | laser | wifi |"), "{md}");
        assert!(md.contains("| min | 0.01 | 0.50 |"), "{md}");
        assert!(md.contains("| max | 14.50 | 1.50 |"), "{md}");
        assert!(md.contains("| median | 2.00 | 1.00 |"), "{md}");
    }
}
