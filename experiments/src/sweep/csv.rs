//! `results.csv`: a header comment holding the sweep's hash, a column header, then one row per
//! trial and localizer. Rows are only ever appended as whole lines, so the only damage a
//! killed sweep can leave is a trailing partial line, which [`read_results`] drops.

use atrium_scenarios::error::ScenarioError;
use std::path::Path;

/// Columns after the parameter columns.
/// `wall_s` is last so tools comparing runs can drop it: it is the only column that varies.
pub const FIXED_COLUMNS: [&str; 13] = [
    "cell",
    "trial",
    "seed",
    "localizer",
    "min_m",
    "median_m",
    "rmse_m",
    "p95_m",
    "max_m",
    "final_m",
    "converged_after_s",
    "passed",
    "wall_s",
];

pub fn fixed_columns() -> &'static [&'static str] {
    &FIXED_COLUMNS
}

/// One row: a trial's result for one localizer. Numbers are kept as the text written, so
/// reading and writing a file round-trips exactly.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Row {
    pub params: Vec<String>,
    pub cell: usize,
    pub trial: usize,
    pub seed: u64,
    pub localizer: String,
    /// min, median, rmse, p95, max, final, converged_after_s, passed, wall_s.
    pub values: Vec<String>,
}

impl Row {
    /// The median position error, m (None when the localizer was never scored).
    pub fn median(&self) -> Option<f64> {
        self.values.get(1).and_then(|v| v.parse().ok())
    }

    /// The sort key of merged and finished files.
    pub fn key(&self) -> (usize, usize, &str) {
        (self.cell, self.trial, &self.localizer)
    }

    pub fn to_line(&self) -> String {
        let mut fields: Vec<String> = self.params.iter().map(|p| quote(p)).collect();
        fields.push(self.cell.to_string());
        fields.push(self.trial.to_string());
        fields.push(self.seed.to_string());
        fields.push(quote(&self.localizer));
        fields.extend(self.values.iter().map(|v| quote(v)));
        let mut line = fields.join(",");
        line.push('\n');
        line
    }

    fn parse(line: &str, n_params: usize) -> Result<Row, String> {
        let f = split(line)?;
        let n = fixed_columns().len();
        if f.len() != n_params + n {
            return Err(format!("expected {} fields, got {}", n_params + n, f.len()));
        }
        let num = |i: usize| f[i].parse::<u64>().map_err(|e| format!("{}: {e}", f[i]));
        Ok(Row {
            params: f[..n_params].to_vec(),
            cell: num(n_params)? as usize,
            trial: num(n_params + 1)? as usize,
            seed: num(n_params + 2)?,
            localizer: f[n_params + 3].clone(),
            values: f[n_params + 4..].to_vec(),
        })
    }
}

fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Splits one CSV line (RFC 4180 quoting, no embedded newlines).
fn split(line: &str) -> Result<Vec<String>, String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut chars = line.chars().peekable();
    let mut quoted = false;
    while let Some(c) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            (true, '"') => quoted = false,
            (false, '"') if cur.is_empty() => quoted = true,
            (false, ',') => out.push(std::mem::take(&mut cur)),
            (_, c) => cur.push(c),
        }
    }
    if quoted {
        return Err("unterminated quote".into());
    }
    out.push(cur);
    Ok(out)
}

/// The two header lines of a results file.
pub fn header(hash: &str, name: &str, axis_paths: &[String]) -> String {
    let cols: Vec<String> = axis_paths
        .iter()
        .map(|p| quote(p))
        .chain(fixed_columns().iter().map(|c| c.to_string()))
        .collect();
    format!(
        "# atrium-sweep hash={hash} name={name}\n{}\n",
        cols.join(",")
    )
}

/// A results file read back.
#[derive(Debug, Clone)]
pub struct Results {
    pub hash: String,
    pub name: String,
    pub axis_paths: Vec<String>,
    pub rows: Vec<Row>,
    /// Whether a trailing partial line (an interrupted write) was dropped.
    pub dropped_partial: bool,
}

impl Results {
    pub fn header(&self) -> String {
        header(&self.hash, &self.name, &self.axis_paths)
    }

    pub fn to_text(&self) -> String {
        let mut s = self.header();
        for r in &self.rows {
            s.push_str(&r.to_line());
        }
        s
    }
}

/// Reads a results file; a malformed file is bad input naming the file and line.
pub fn read_results(path: &Path) -> Result<Results, ScenarioError> {
    let text = std::fs::read_to_string(path).map_err(|err| ScenarioError::Io {
        file: path.to_path_buf(),
        err,
    })?;
    let bad = |line: usize, msg: String| ScenarioError::field(path, format!("line {line}"), msg);
    // Only newline-terminated lines are complete; a row is written in one write ending in
    // '\n', so anything after the last '\n' is the remains of an interrupted write.
    let complete = text.rfind('\n').map_or("", |i| &text[..=i]);
    let dropped_partial = complete.len() < text.len();
    let mut lines = complete.lines();
    let first = lines
        .next()
        .ok_or_else(|| bad(1, "empty file: not an atrium sweep results file".into()))?;
    let meta = first
        .strip_prefix("# atrium-sweep ")
        .ok_or_else(|| bad(1, "not an atrium sweep results file".into()))?;
    let mut hash = None;
    let mut name = String::new();
    for kv in meta.split(' ') {
        if let Some(h) = kv.strip_prefix("hash=") {
            hash = Some(h.to_string());
        } else if let Some(n) = kv.strip_prefix("name=") {
            name = n.to_string();
        }
    }
    let hash = hash.ok_or_else(|| bad(1, "no hash= in the header".into()))?;
    let cols = split(
        lines
            .next()
            .ok_or_else(|| bad(2, "no column header".into()))?,
    )
    .map_err(|e| bad(2, e))?;
    let n_fixed = fixed_columns().len();
    if cols.len() < n_fixed || cols[cols.len() - n_fixed..] != *fixed_columns() {
        return Err(bad(2, "unexpected columns".into()));
    }
    let axis_paths = cols[..cols.len() - n_fixed].to_vec();
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate() {
        rows.push(Row::parse(line, axis_paths.len()).map_err(|e| bad(i + 3, e))?);
    }
    Ok(Results {
        hash,
        name,
        axis_paths,
        rows,
        dropped_partial,
    })
}

/// Writes `text` to `path` atomically (temporary file, fsync, rename), so a reader or a
/// killed process never sees half a file.
pub fn write_atomic(path: &Path, text: &str) -> Result<(), ScenarioError> {
    use std::io::Write;
    let io = |err| ScenarioError::Io {
        file: path.to_path_buf(),
        err,
    };
    let tmp = path.with_extension("tmp");
    let mut f = std::fs::File::create(&tmp).map_err(io)?;
    f.write_all(text.as_bytes()).map_err(io)?;
    f.sync_all().map_err(io)?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_with_quoting() {
        let r = Row {
            params: vec!["\"a,b\"".into(), "4.5".into()],
            cell: 3,
            trial: 1,
            seed: 99,
            localizer: "mcl".into(),
            values: (0..9).map(|i| i.to_string()).collect(),
        };
        let line = r.to_line();
        assert_eq!(Row::parse(line.trim_end(), 2).unwrap(), r);
        assert_eq!(r.median(), Some(1.0));
    }
}
