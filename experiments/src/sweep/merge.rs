//! `atrium sweep merge OUT_DIR SHARD_DIR...`: joins the results of shards of one sweep, their
//! per-trial error maps (`maps/`), and redraws the heat maps and error maps of the whole.
//!
//! The shards must add up to the whole sweep: every trial of every cell in exactly one
//! folder, with a row for each localizer. Each `results.csv` records the sweep's size and its
//! shard (`cells=`, `trials=`, `shard=I/N` in its header), so a missing shard, a shard given
//! twice, or an interrupted one is refused, naming it, instead of being summarised as if it
//! were the whole sweep.

use super::csv::{self, Layout, Results};
use super::heatmap::AxisLabels;
use super::maps;
use super::run::canonical;
use super::summary;
use atrium_scenarios::error::ScenarioError;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// At most this many examples are named in a message.
const EXAMPLES: usize = 5;

/// `items` (at most [`EXAMPLES`] of them) joined, with how many more there are.
fn some<T: std::fmt::Display>(items: &[T]) -> String {
    let shown: Vec<String> = items.iter().take(EXAMPLES).map(|i| i.to_string()).collect();
    match items.len() > EXAMPLES {
        true => format!("{}, and {} more", shown.join(", "), items.len() - EXAMPLES),
        false => shown.join(", "),
    }
}

/// Cell ranges as text: `0-3, 7`.
fn ranges(cells: &BTreeSet<usize>) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut it = cells.iter().copied().peekable();
    while let Some(a) = it.next() {
        let mut b = a;
        while it.peek() == Some(&(b + 1)) {
            b = it.next().unwrap_or(b);
        }
        out.push(if a == b {
            a.to_string()
        } else {
            format!("{a}-{b}")
        });
    }
    some(&out)
}

/// One shard folder read back.
struct Shard {
    dir: PathBuf,
    results: Results,
    layout: Layout,
}

fn same_canonical(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => a == b,
    }
}

/// The layout of a shard folder: from its results.csv header, or (results written before
/// the header held it) from its sweep.json.
fn layout_of(dir: &Path, r: &Results) -> Result<Layout, ScenarioError> {
    if let Some(l) = r.layout {
        return Ok(l);
    }
    let p = dir.join("sweep.json");
    let bad = |msg: String| ScenarioError::field(&p, "shard", msg);
    let text = std::fs::read_to_string(&p).map_err(|err| ScenarioError::Io {
        file: p.clone(),
        err,
    })?;
    let doc: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    let count = |k: &str| {
        doc[k]
            .as_u64()
            .and_then(|v| usize::try_from(v).ok())
            .ok_or_else(|| {
                bad(format!(
                    "no {k}: cannot tell which trials this folder holds"
                ))
            })
    };
    let shard = match doc["shard"].as_str() {
        None => (0, 1),
        Some(s) => super::csv::parse_shard(s).map_err(bad)?,
    };
    Ok(Layout {
        cells: count("cells")?,
        trials: count("trials_per_cell")?,
        shard,
    })
}

/// Checks that `shards` hold every trial of the sweep exactly once, each with a row for
/// every localizer; the error names the missing or duplicated shards, cells and trials.
fn check_coverage(out: &Path, shards: &[Shard]) -> Result<(), ScenarioError> {
    let first = &shards[0];
    let (cells, trials) = (first.layout.cells, first.layout.trials);
    for s in shards {
        if (s.layout.cells, s.layout.trials) != (cells, trials) {
            return Err(ScenarioError::field(
                &s.dir.join("results.csv"),
                "cells",
                format!(
                    "{} cells × {} trials, but {} has {cells} × {trials}: not shards of one sweep",
                    s.layout.cells,
                    s.layout.trials,
                    first.dir.display()
                ),
            ));
        }
    }
    check_distinct(out, shards)?;
    let held = trials_held(out, shards, cells, trials)?;
    check_complete(out, shards, &held, cells, trials)
}

/// Which shard folder holds each trial (an index into the shards), and which localizers it
/// has rows for there.
type Held<'a> = BTreeMap<(usize, usize), (usize, BTreeSet<&'a str>)>;

fn refuse_shards(out: &Path, msg: String) -> ScenarioError {
    ScenarioError::field(out, "SHARD_DIR", msg)
}

fn shard_name(s: &Shard) -> String {
    format!(
        "{}/{} ({})",
        s.layout.shard.0,
        s.layout.shard.1,
        s.dir.display()
    )
}

/// Refuses the same shard folder (or overlapping shards) given twice.
fn check_distinct(out: &Path, shards: &[Shard]) -> Result<(), ScenarioError> {
    let refuse = |msg: String| refuse_shards(out, msg);
    for (a, sa) in shards.iter().enumerate() {
        for sb in &shards[a + 1..] {
            if same_canonical(&sa.dir, &sb.dir) {
                return Err(refuse(format!(
                    "{} is given twice: each shard folder once",
                    sa.dir.display()
                )));
            }
            if sa.layout.covers(&sb.layout) || sb.layout.covers(&sa.layout) {
                return Err(refuse(format!(
                    "shards {} and {} hold the same trials: give each shard once",
                    shard_name(sa),
                    shard_name(sb)
                )));
            }
        }
    }

    Ok(())
}

/// Where each trial's rows are; refuses rows outside the sweep or their shard, a trial in two
/// folders and two rows of one localizer for a trial.
fn trials_held<'a>(
    out: &Path,
    shards: &'a [Shard],
    cells: usize,
    trials: usize,
) -> Result<Held<'a>, ScenarioError> {
    let refuse = |msg: String| refuse_shards(out, msg);
    let mut held: Held = BTreeMap::new();
    for (k, s) in shards.iter().enumerate() {
        let csv = s.dir.join("results.csv");
        for r in &s.results.rows {
            if r.cell >= cells || r.trial >= trials {
                return Err(ScenarioError::field(
                    &csv,
                    "cell",
                    format!(
                        "a row for cell {} trial {}: the sweep has {cells} cells × {trials} trials",
                        r.cell, r.trial
                    ),
                ));
            }
            if !s.layout.holds(r.cell, r.trial) {
                return Err(ScenarioError::field(
                    &csv,
                    "shard",
                    format!(
                        "holds cell {} trial {}, which is not part of its shard {}/{}",
                        r.cell, r.trial, s.layout.shard.0, s.layout.shard.1
                    ),
                ));
            }
            let entry = held
                .entry((r.cell, r.trial))
                .or_insert_with(|| (k, BTreeSet::new()));
            if entry.0 != k {
                return Err(refuse(format!(
                    "cell {} trial {} is in both {} and {}: give each shard once",
                    r.cell,
                    r.trial,
                    shard_name(&shards[entry.0]),
                    shard_name(s)
                )));
            }
            if !entry.1.insert(r.localizer.as_str()) {
                return Err(ScenarioError::field(
                    &csv,
                    "rows",
                    format!(
                        "cell {} trial {} has two rows for localizer {:?}",
                        r.cell, r.trial, r.localizer
                    ),
                ));
            }
        }
    }

    Ok(held)
}

/// Refuses incomplete trials (an interrupted shard), then trials no folder holds, naming the
/// shards of the split that no folder holds at all.
fn check_complete(
    out: &Path,
    shards: &[Shard],
    held: &Held,
    cells: usize,
    trials: usize,
) -> Result<(), ScenarioError> {
    let refuse = |msg: String| refuse_shards(out, msg);
    let localizers: BTreeSet<&str> = shards
        .iter()
        .flat_map(|s| s.results.rows.iter().map(|r| r.localizer.as_str()))
        .collect();
    let partial: Vec<String> = held
        .iter()
        .filter(|(_, (_, l))| l.len() < localizers.len())
        .map(|((c, t), (k, _))| format!("cell {c} trial {t} in {}", shards[*k].dir.display()))
        .collect();
    if !partial.is_empty() {
        return Err(refuse(format!(
            "{} trials lack rows for some localizers ({}): finish those shards with --resume",
            partial.len(),
            some(&partial)
        )));
    }
    let missing: Vec<(usize, usize)> = (0..cells)
        .flat_map(|c| (0..trials).map(move |t| (c, t)))
        .filter(|k| !held.contains_key(k))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    let n = shards[0].layout.shard.1;
    let whole = Layout {
        cells,
        trials,
        shard: (0, 1),
    };
    // Name the shards of the given split that no folder holds at all, then the rest.
    let absent: Vec<String> = (0..n)
        .filter(|&i| {
            let l = Layout {
                shard: (i, n),
                ..whole
            };
            !shards
                .iter()
                .any(|s| s.layout.covers(&l) || l.covers(&s.layout))
        })
        .map(|i| format!("{i}/{n}"))
        .collect();
    let cells_missing: BTreeSet<usize> = missing.iter().map(|&(c, _)| c).collect();
    let what = match absent.is_empty() {
        true => String::new(),
        false => format!("shard {} not given; ", absent.join(", ")),
    };
    let trials_text: Vec<String> = missing
        .iter()
        .map(|(c, t)| format!("cell {c} trial {t}"))
        .collect();
    Err(refuse(format!(
        "the shards do not cover the sweep: {what}{} of {} trials missing (cells {}; {}). \
         Give every shard's folder (finish interrupted shards with --resume)",
        missing.len(),
        cells * trials,
        ranges(&cells_missing),
        some(&trials_text),
    )))
}

/// Merges `shards/*/results.csv` into `out/results.csv` (sorted by cell, trial, localizer)
/// and writes `out/summary.md`. All shards must come from the same sweep (same hash) and
/// together hold every trial exactly once.
pub fn merge(out: &Path, shards: &[impl AsRef<Path>]) -> Result<Results, ScenarioError> {
    if shards.is_empty() {
        return Err(ScenarioError::field(
            out,
            "SHARD_DIR",
            "give at least one shard folder",
        ));
    }
    let mut read: Vec<Shard> = Vec::new();
    for dir in shards {
        let dir = dir.as_ref();
        if same_canonical(dir, out) {
            return Err(ScenarioError::field(
                out,
                "OUT_DIR",
                "is one of the shard folders: the merge would overwrite its results; choose another folder",
            ));
        }
        let path = dir.join("results.csv");
        let results = csv::read_results(&path)?;
        if let Some(first) = read.first() {
            if first.results.hash != results.hash || first.results.axis_paths != results.axis_paths
            {
                return Err(ScenarioError::field(
                    &path,
                    "hash",
                    format!(
                        "results of a different sweep (hash {}, first shard {})",
                        results.hash, first.results.hash
                    ),
                ));
            }
        }
        if let Some(first) = read.iter().find(|s| !s.results.rows.is_empty()) {
            let (a, b) = (first.results.optional_columns(), results.optional_columns());
            if !results.rows.is_empty() && a != b {
                let names = |k: usize| match k {
                    0 => "none of the optional columns".to_string(),
                    k => csv::OPTIONAL_COLUMNS[..k].join(", "),
                };
                return Err(ScenarioError::field(
                    &path,
                    "columns",
                    format!(
                        "has {} and {} has {}: shards written by different atrium versions; \
                         rerun the older ones",
                        names(b),
                        first.dir.display(),
                        names(a)
                    ),
                ));
            }
        }
        let layout = layout_of(dir, &results)?;
        read.push(Shard {
            dir: dir.to_path_buf(),
            results,
            layout,
        });
    }
    check_coverage(out, &read)?;
    // A folder holding another sweep's results is not overwritten.
    let out_csv = out.join("results.csv");
    if out_csv.exists() {
        let existing = csv::read_results(&out_csv)?;
        if existing.hash != read[0].results.hash {
            return Err(ScenarioError::field(
                &out_csv,
                "hash",
                format!(
                    "holds results of a different sweep (hash {}, these shards {}): choose another OUT_DIR",
                    existing.hash, read[0].results.hash
                ),
            ));
        }
    }
    super::run::check_out(out)?;

    let first_layout = read[0].layout;
    let mut rows = Vec::new();
    let mut head = None;
    for s in read {
        rows.extend(s.results.rows);
        head.get_or_insert(Results {
            rows: Vec::new(),
            ..s.results
        });
    }
    let mut merged = head.expect("at least one shard");
    merged.rows = canonical(rows);
    merged.dropped_partial = false;
    merged.layout = Some(Layout {
        shard: (0, 1),
        ..first_layout
    });
    std::fs::create_dir_all(out).map_err(|err| ScenarioError::Write {
        file: out.to_path_buf(),
        err,
    })?;
    csv::write_atomic(&out_csv, &merged.to_text())?;

    // The axes' values and the cell count come from the first shard's sweep.json.
    let first = shards[0].as_ref().join("sweep.json");
    let (axes, cells) = read_axes(&first)?;
    let mut copied = 0;
    for dir in shards {
        copied += maps::copy_maps(dir.as_ref(), out)?;
    }
    let text = std::fs::read_to_string(&first).map_err(|err| ScenarioError::Io {
        file: first.clone(),
        err,
    })?;
    let mut doc: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| ScenarioError::field(&first, "sweep.json", e.to_string()))?;
    // The failure curves of the whole, with the settings and seed the shards ran with.
    let (settings, seed) = super::failure::recorded(&doc);
    let curves = super::failure::write_outputs(out, &merged, &axes, &settings, seed)?;
    csv::write_atomic(
        &out.join("summary.md"),
        &(summary::to_markdown(&merged) + &curves.markdown),
    )?;
    doc["shard"] = serde_json::Value::Null;
    csv::write_atomic(
        &out.join("sweep.json"),
        &serde_json::to_string_pretty(&doc).unwrap_or_default(),
    )?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sweep::csv::Row;

    fn shard(dir: &str, i: usize, n: usize, rows: &[(usize, usize, &str)]) -> Shard {
        Shard {
            dir: PathBuf::from(dir),
            layout: Layout {
                cells: 2,
                trials: 2,
                shard: (i, n),
            },
            results: Results {
                hash: "h".into(),
                name: "n".into(),
                layout: None,
                axis_paths: vec![],
                rows: rows
                    .iter()
                    .map(|&(cell, trial, l)| Row {
                        params: vec![],
                        cell,
                        trial,
                        seed: 0,
                        localizer: l.into(),
                        values: vec![String::new(); 9],
                    })
                    .collect(),
                dropped_partial: false,
            },
        }
    }

    fn err(shards: &[Shard]) -> String {
        check_coverage(Path::new("m"), shards)
            .unwrap_err()
            .to_string()
    }

    #[test]
    fn shards_must_cover_every_trial_once() {
        // Global index g = cell × 2 + trial; shard 0/2 holds g = 0, 2, shard 1/2 g = 1, 3.
        let s0 = || shard("a", 0, 2, &[(0, 0, "l"), (1, 0, "l")]);
        let s1 = || shard("b", 1, 2, &[(0, 1, "l"), (1, 1, "l")]);
        check_coverage(Path::new("m"), &[s0(), s1()]).unwrap();
        let e = err(&[s0()]);
        assert!(
            e.contains("shard 1/2 not given; 2 of 4 trials missing"),
            "{e}"
        );
        assert!(e.contains("cell 0 trial 1"), "{e}");
        let e = err(&[s0(), shard("c", 0, 2, &[(0, 0, "l"), (1, 0, "l")])]);
        assert!(
            e.contains("shards 0/2 (a) and 0/2 (c) hold the same trials"),
            "{e}"
        );
        let e = err(&[s0(), shard("a", 1, 2, &[(0, 1, "l")])]);
        assert!(e.contains("a is given twice"), "{e}");
        // An interrupted shard: one trial lacks a localizer's row, one is missing.
        let e = err(&[
            shard("a", 0, 2, &[(0, 0, "l"), (0, 0, "k"), (1, 0, "l")]),
            shard(
                "b",
                1,
                2,
                &[(0, 1, "l"), (0, 1, "k"), (1, 1, "l"), (1, 1, "k")],
            ),
        ]);
        assert!(
            e.contains("1 trials lack rows for some localizers (cell 1 trial 0 in a)"),
            "{e}"
        );
        let e = err(&[shard("a", 0, 2, &[(0, 0, "l")]), s1()]);
        assert!(
            e.contains("1 of 4 trials missing (cells 1; cell 1 trial 0)"),
            "{e}"
        );
        // A row outside its shard, and rows repeated within one folder.
        let e = err(&[shard("a", 0, 2, &[(0, 1, "l")]), s1()]);
        assert!(e.contains("not part of its shard 0/2"), "{e}");
        let e = err(&[
            shard("a", 0, 2, &[(0, 0, "l"), (0, 0, "l"), (1, 0, "l")]),
            s1(),
        ]);
        assert!(e.contains("two rows for localizer \"l\""), "{e}");
        // A whole sweep alone is complete; with a shard of it, that shard is twice.
        let whole = || {
            shard(
                "w",
                0,
                1,
                &[(0, 0, "l"), (0, 1, "l"), (1, 0, "l"), (1, 1, "l")],
            )
        };
        check_coverage(Path::new("m"), &[whole()]).unwrap();
        assert!(err(&[whole(), s1()]).contains("hold the same trials"));
    }

    #[test]
    fn cell_ranges_are_short() {
        let s: BTreeSet<usize> = [0, 1, 2, 5, 7, 8].into_iter().collect();
        assert_eq!(ranges(&s), "0-2, 5, 7-8");
    }
}
