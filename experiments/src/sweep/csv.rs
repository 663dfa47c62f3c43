//! `results.csv`: a header comment holding the sweep's hash, its size and the shard the
//! folder holds, a column header, then one row per trial and localizer. Fields are quoted as
//! RFC 4180 says (a value may hold commas, quotes and newlines) and [`read_results`] parses
//! them back, so every file written here is one its reader accepts. Rows are only ever
//! appended as whole records, so the only damage a killed sweep can leave is a trailing
//! partial record, which [`read_results`] drops.

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

/// Columns a sweep writes between `passed` and `wall_s`, in this order, each added by a
/// later atrium than the one before it: a file holds the first [`Results::optional_columns`]
/// of them (none, `failed_time_frac` alone, or all), as its column header says, and every row
/// of it holds the same.
/// - `failed_time_frac`: the fraction of the trial's scored instants with position error
///   above the sweep's `[failure] error_threshold_m` (see `super::failure`);
/// - `distance_m`: how far the robot drove in the trial (the same on each localizer's row);
/// - `route_completed`: whether it reached the route's last waypoint before the trial ended.
///
/// The last two tell trials that end on the clock after different distances apart: errors
/// depend on how far and where the robot drove, so a cell whose robot drove less (stopped by
/// people, say) scores other errors for that alone (see `super::drive`).
pub const OPTIONAL_COLUMNS: [&str; 3] = ["failed_time_frac", "distance_m", "route_completed"];

/// The optional columns this atrium writes (all of them).
pub const CURRENT_OPTIONAL: usize = OPTIONAL_COLUMNS.len();

/// The first of [`OPTIONAL_COLUMNS`].
pub const FAILURE_COLUMN: &str = OPTIONAL_COLUMNS[0];

/// The fixed columns of a file holding the first `optional` of [`OPTIONAL_COLUMNS`].
pub fn columns(optional: usize) -> Vec<&'static str> {
    let (head, wall) = FIXED_COLUMNS.split_at(FIXED_COLUMNS.len() - 1);
    let mut c = head.to_vec();
    c.extend(&OPTIONAL_COLUMNS[..optional.min(OPTIONAL_COLUMNS.len())]);
    c.extend(wall);
    c
}

/// Values per row (the fixed columns after cell, trial, seed and localizer) of a file
/// without any of [`OPTIONAL_COLUMNS`].
pub const VALUES_WITHOUT_OPTIONAL: usize = FIXED_COLUMNS.len() - 4;

/// A row's value of optional column `k` (an index into [`OPTIONAL_COLUMNS`]), if its file
/// has that column.
fn optional_value(row: &Row, k: usize) -> Option<&str> {
    let present = row.values.len().checked_sub(VALUES_WITHOUT_OPTIONAL)?;
    (k < present).then(|| row.values[VALUES_WITHOUT_OPTIONAL - 1 + k].as_str())
}

/// A row's [`FAILURE_COLUMN`] value; `None` in a file without it or when never scored.
pub fn failed_time_frac(row: &Row) -> Option<f64> {
    optional_value(row, 0).and_then(|v| v.parse().ok())
}

/// How far the robot drove in the row's trial, m; `None` in a file without the column.
pub fn distance_m(row: &Row) -> Option<f64> {
    optional_value(row, 1).and_then(|v| v.parse().ok())
}

/// Whether the row's trial completed its route; `None` in a file without the column.
pub fn route_completed(row: &Row) -> Option<bool> {
    optional_value(row, 2).and_then(|v| v.parse().ok())
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
    /// min, median, rmse, p95, max, final, converged_after_s, passed, the file's
    /// [`OPTIONAL_COLUMNS`], wall_s.
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

    fn from_fields(f: Vec<String>, n_params: usize, n: usize) -> Result<Row, String> {
        if f.len() != n_params + n {
            return Err(format!("expected {} fields, got {}", n_params + n, f.len()));
        }
        let num = |i: usize| {
            f[i].parse::<u64>()
                .map_err(|e| format!("{} {:?}: {e}", FIXED_COLUMNS[i - n_params], f[i]))
        };
        let index = |i: usize| {
            num(i).and_then(|v| {
                usize::try_from(v).map_err(|e| format!("{}: {v}: {e}", FIXED_COLUMNS[i - n_params]))
            })
        };
        Ok(Row {
            cell: index(n_params)?,
            trial: index(n_params + 1)?,
            seed: num(n_params + 2)?,
            localizer: f[n_params + 3].clone(),
            values: f[n_params + 4..].to_vec(),
            params: f[..n_params].to_vec(),
        })
    }
}

/// A field as RFC 4180 writes it: quoted when it holds a comma, quote or line break (or
/// starts with a space, which some readers trim).
pub(crate) fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) || s.starts_with(' ') || s.ends_with(' ') {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// One record of `text` from byte `at`: its fields and the offset after its terminating
/// newline, or `None` when the text ends before the record does (an interrupted write).
fn record(text: &str, at: usize) -> Result<Option<(Vec<String>, usize)>, String> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quoted = false;
    // Whether the current field was quoted: after its closing quote only `,` or a line end
    // may follow.
    let mut closed = false;
    let mut chars = text[at..].char_indices().peekable();
    while let Some((i, c)) = chars.next() {
        match (quoted, c) {
            (true, '"') if chars.peek().map(|p| p.1) == Some('"') => {
                cur.push('"');
                chars.next();
            }
            (true, '"') => {
                quoted = false;
                closed = true;
            }
            (true, c) => cur.push(c),
            (false, '"') if cur.is_empty() && !closed => quoted = true,
            (false, ',') => {
                out.push(std::mem::take(&mut cur));
                closed = false;
            }
            (false, '\r') if chars.peek().map(|p| p.1) == Some('\n') => {}
            (false, '\n') => {
                out.push(cur);
                return Ok(Some((out, at + i + 1)));
            }
            (false, c) if closed => {
                return Err(format!(
                    "{c:?} after a closing quote (quote the whole field)"
                ))
            }
            (false, c) => cur.push(c),
        }
    }
    Ok(None)
}

/// Escapes a sweep name for the header comment line: `%`, and every control character
/// (newlines above all) as `%XX`, so the name stays on its line whatever it holds.
fn escape_name(name: &str) -> String {
    let mut s = String::with_capacity(name.len());
    for c in name.chars() {
        if c == '%' || c.is_control() {
            let mut buf = [0u8; 4];
            for b in c.encode_utf8(&mut buf).bytes() {
                s.push_str(&format!("%{b:02X}"));
            }
        } else {
            s.push(c);
        }
    }
    s
}

fn unescape_name(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = || std::str::from_utf8(b.get(i + 1..i + 3)?).ok();
        match (b[i], hex().and_then(|h| u8::from_str_radix(h, 16).ok())) {
            (b'%', Some(v)) => {
                out.push(v);
                i += 3;
            }
            (c, _) => {
                out.push(c);
                i += 1;
            }
        }
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// What a results folder covers: the sweep's size and the shard (`I/N`: the trials whose
/// global index `cell × trials + trial` is `I` mod `N`) it was run as. `sweep merge` checks
/// with it that the shards given cover every trial exactly once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    pub cells: usize,
    pub trials: usize,
    pub shard: (usize, usize),
}

impl Layout {
    /// Whether trial `trial` of cell `cell` belongs to this shard.
    pub fn holds(&self, cell: usize, trial: usize) -> bool {
        let (i, n) = self.shard;
        (cell * self.trials + trial) % n == i
    }

    /// Whether every trial of `other`'s shard is one of this shard's (the whole sweep covers
    /// every shard; `1/2` covers `1/4` and `3/4`).
    pub fn covers(&self, other: &Layout) -> bool {
        let ((i, n), (j, m)) = (self.shard, other.shard);
        self.cells == other.cells && self.trials == other.trials && m % n == 0 && j % n == i
    }
}

/// The two header lines of a results file without any of [`OPTIONAL_COLUMNS`].
pub fn header(hash: &str, name: &str, layout: Option<&Layout>, axis_paths: &[String]) -> String {
    header_with(hash, name, layout, axis_paths, 0)
}

/// The two header lines of a results file holding the first `optional` of
/// [`OPTIONAL_COLUMNS`].
pub fn header_with(
    hash: &str,
    name: &str,
    layout: Option<&Layout>,
    axis_paths: &[String],
    optional: usize,
) -> String {
    let cols: Vec<String> = axis_paths
        .iter()
        .map(|p| quote(p))
        .chain(columns(optional).iter().map(|c| c.to_string()))
        .collect();
    // The name goes last and takes the rest of the line, so it may hold spaces.
    let size = layout.map_or(String::new(), |l| {
        format!(
            " cells={} trials={} shard={}/{}",
            l.cells, l.trials, l.shard.0, l.shard.1
        )
    });
    format!(
        "# atrium-sweep hash={hash}{size} name={}\n{}\n",
        escape_name(name),
        cols.join(",")
    )
}

/// A results file read back.
#[derive(Debug, Clone)]
pub struct Results {
    pub hash: String,
    pub name: String,
    /// The sweep's size and the shard the file holds (`None` in files written before it was
    /// recorded).
    pub layout: Option<Layout>,
    pub axis_paths: Vec<String>,
    pub rows: Vec<Row>,
    /// Whether a trailing partial line (an interrupted write) was dropped.
    pub dropped_partial: bool,
}

impl Results {
    /// The header lines, with the optional columns the rows hold (rows hold the values as
    /// read or made, so the file written says what they hold). A file without rows gets the
    /// header without them: a caller about to append rows with them writes [`header_with`]
    /// itself.
    pub fn header(&self) -> String {
        header_with(
            &self.hash,
            &self.name,
            self.layout.as_ref(),
            &self.axis_paths,
            self.optional_columns(),
        )
    }

    /// How many of [`OPTIONAL_COLUMNS`] the rows hold (0 without rows).
    pub fn optional_columns(&self) -> usize {
        self.rows.first().map_or(0, |r| {
            r.values
                .len()
                .saturating_sub(VALUES_WITHOUT_OPTIONAL)
                .min(OPTIONAL_COLUMNS.len())
        })
    }

    /// Whether the rows hold [`FAILURE_COLUMN`].
    pub fn has_failure_column(&self) -> bool {
        self.optional_columns() >= 1
    }

    pub fn to_text(&self) -> String {
        let mut s = self.header();
        for r in &self.rows {
            s.push_str(&r.to_line());
        }
        s
    }
}

/// Parses the comment line `# atrium-sweep hash=... [cells=C trials=T shard=I/N] name=...`.
fn parse_meta(first: &str) -> Result<(String, String, Option<Layout>), String> {
    let meta = first
        .strip_prefix("# atrium-sweep ")
        .ok_or("not an atrium sweep results file")?;
    let (fields, name) = match meta.find("name=") {
        Some(i) => (&meta[..i], unescape_name(&meta[i + "name=".len()..])),
        None => (meta, String::new()),
    };
    let mut hash = None;
    let (mut cells, mut trials, mut shard) = (None, None, None);
    for kv in fields.split(' ').filter(|s| !s.is_empty()) {
        let (k, v) = kv
            .split_once('=')
            .ok_or(format!("{kv:?}: expected key=value"))?;
        let count = || v.parse::<usize>().map_err(|e| format!("{k}={v}: {e}"));
        match k {
            "hash" => hash = Some(v.to_string()),
            "cells" => cells = Some(count()?),
            "trials" => trials = Some(count()?),
            "shard" => shard = Some(parse_shard(v).map_err(|e| format!("shard={v}: {e}"))?),
            _ => {}
        }
    }
    let hash = hash.ok_or("no hash= in the header")?;
    let layout = match (cells, trials, shard) {
        (Some(cells), Some(trials), Some(shard)) => Some(Layout {
            cells,
            trials,
            shard,
        }),
        (None, None, None) => None,
        _ => return Err("cells=, trials= and shard= go together".into()),
    };
    Ok((hash, name, layout))
}

/// Parses a results file's text; errors are (line, message).
pub fn parse_results(text: &str) -> Result<Results, (usize, String)> {
    let first_end = text.find('\n').ok_or((
        1,
        "not an atrium sweep results file (no complete header line)".to_string(),
    ))?;
    let (hash, name, layout) = parse_meta(&text[..first_end]).map_err(|m| (1, m))?;
    let mut at = first_end + 1;
    let mut line = 2;
    let lines_in = |a: usize, b: usize| text[a..b].matches('\n').count();
    let (cols, next) = record(text, at)
        .map_err(|m| (line, m))?
        .ok_or((2, "no column header".to_string()))?;
    line += lines_in(at, next);
    at = next;
    let ends_with =
        |fixed: &[&str]| cols.len() >= fixed.len() && cols[cols.len() - fixed.len()..] == *fixed;
    // The longest set of optional columns the header ends with (an axis path may itself be
    // named like a fixed column, so the longer reading wins).
    let n_fixed = (0..=OPTIONAL_COLUMNS.len())
        .rev()
        .map(columns)
        .find(|c| ends_with(c))
        .map(|c| c.len())
        .ok_or((2, "unexpected columns".to_string()))?;
    let axis_paths = cols[..cols.len() - n_fixed].to_vec();
    let mut rows = Vec::new();
    let mut dropped_partial = false;
    while at < text.len() {
        match record(text, at).map_err(|m| (line, m))? {
            Some((fields, next)) => {
                rows.push(
                    Row::from_fields(fields, axis_paths.len(), n_fixed).map_err(|m| (line, m))?,
                );
                line += lines_in(at, next);
                at = next;
            }
            // A record is written in one write ending in its newline, so a record the text
            // ends inside is the remains of an interrupted write.
            None => {
                dropped_partial = true;
                break;
            }
        }
    }
    Ok(Results {
        hash,
        name,
        layout,
        axis_paths,
        rows,
        dropped_partial,
    })
}

/// Reads a results file; a malformed file is bad input naming the file and line.
pub fn read_results(path: &Path) -> Result<Results, ScenarioError> {
    let text = std::fs::read_to_string(path).map_err(|err| ScenarioError::Io {
        file: path.to_path_buf(),
        err,
    })?;
    parse_results(&text)
        .map_err(|(line, msg)| ScenarioError::field(path, format!("line {line}"), msg))
}

/// Writes `text` to `path` atomically (temporary file, fsync, rename), so a reader or a
/// killed process never sees half a file.
pub fn write_atomic(path: &Path, text: &str) -> Result<(), ScenarioError> {
    atrium_scenarios::output::write_atomic(path, text.as_bytes()).map_err(|err| {
        ScenarioError::Write {
            file: path.to_path_buf(),
            err,
        }
    })
}

/// Parses `I/N` with 0 <= I < N.
pub fn parse_shard(s: &str) -> Result<(usize, usize), String> {
    let (i, n) = s
        .split_once('/')
        .ok_or_else(|| format!("--shard {s:?}: expected I/N, e.g. 0/4"))?;
    let i: usize = i
        .trim()
        .parse()
        .map_err(|_| format!("--shard {s:?}: I must be a non-negative integer"))?;
    let n: usize = n
        .trim()
        .parse()
        .map_err(|_| format!("--shard {s:?}: N must be a positive integer"))?;
    if n == 0 || i >= n {
        return Err(format!("--shard {s:?}: index {i} out of range 0..{n}"));
    }
    Ok((i, n))
}

#[cfg(test)]
mod tests {
    use super::*;

    const NASTY: &[&str] = &[
        "",
        "plain",
        "a,b",
        "\"quoted\"",
        "\"",
        "line\nbreak",
        "cr\r\nlf",
        "\r",
        "trailing\n",
        " padded ",
        "# not a comment",
        "é ü \u{feff} \u{10ffff}",
        "x\"y,z\nw",
        "name=evil hash=0",
    ];

    fn row(params: Vec<String>, localizer: &str) -> Row {
        Row {
            params,
            cell: 3,
            trial: 1,
            seed: 99,
            localizer: localizer.into(),
            values: (0..9).map(|i| i.to_string()).collect(),
        }
    }

    /// A file with axis `a` holding `row` alone.
    fn one_row(row: Row) -> Results {
        Results {
            hash: "h".into(),
            name: "n".into(),
            layout: None,
            axis_paths: vec!["a".into()],
            rows: vec![row],
            dropped_partial: false,
        }
    }

    #[test]
    fn shard_parsing() {
        assert_eq!(parse_shard("1/4"), Ok((1, 4)));
        assert!(parse_shard("4/4").unwrap_err().contains("out of range"));
        assert!(parse_shard("0/0").is_err());
        assert!(parse_shard("x").is_err());
    }

    #[test]
    fn rows_round_trip_with_quoting() {
        let r = row(vec!["\"a,b\"".into(), "4.5".into()], "mcl");
        let line = r.to_line();
        let (fields, end) = record(&line, 0).unwrap().unwrap();
        assert_eq!(end, line.len());
        assert_eq!(Row::from_fields(fields, 2, FIXED_COLUMNS.len()).unwrap(), r);
        assert_eq!(r.median(), Some(1.0));
    }

    #[test]
    fn any_value_path_and_name_round_trip_through_the_file() {
        for (k, nasty) in NASTY.iter().enumerate() {
            let results = Results {
                hash: "00ff".into(),
                name: format!("sweep {nasty} %41 % 100%"),
                layout: Some(Layout {
                    cells: 4,
                    trials: 2,
                    shard: (1, 3),
                }),
                axis_paths: vec![format!("p{nasty}"), "q".into()],
                rows: NASTY
                    .iter()
                    .map(|v| row(vec![v.to_string(), nasty.to_string()], "l"))
                    .collect(),
                dropped_partial: false,
            };
            let text = results.to_text();
            assert_eq!(text.lines().next().unwrap().len(), text.find('\n').unwrap());
            let back = parse_results(&text).unwrap_or_else(|e| panic!("case {k}: {e:?}\n{text}"));
            assert_eq!(back.name, results.name);
            assert_eq!(back.hash, results.hash);
            assert_eq!(back.layout, results.layout);
            assert_eq!(back.axis_paths, results.axis_paths);
            assert_eq!(back.rows, results.rows);
            assert!(!back.dropped_partial);
            assert_eq!(back.to_text(), text);
        }
    }

    #[test]
    fn a_torn_last_record_is_dropped_even_inside_a_quoted_newline() {
        let results = Results {
            hash: "h".into(),
            name: "n".into(),
            layout: None,
            axis_paths: vec!["a".into()],
            rows: vec![row(vec!["x\ny".into()], "l"), row(vec!["z\nw".into()], "m")],
            dropped_partial: false,
        };
        let text = results.to_text();
        let second = text.rfind("\"z").unwrap();
        for cut in second..text.len() {
            let back = parse_results(&text[..cut]).unwrap();
            assert_eq!(back.rows, results.rows[..1], "cut at {cut}");
            assert_eq!(back.dropped_partial, cut > second, "cut at {cut}");
        }
        assert_eq!(parse_results(&text).unwrap().rows, results.rows);
    }

    #[test]
    fn malformed_files_name_the_line() {
        let h = header("h", "n", None, &["a".into()]);
        let bad =
            format!("{h}1,0,0,0,l,1,2,3,4,5,6,7,true,0.1\n1,0,x,0,l,1,2,3,4,5,6,7,true,0.1\n");
        assert_eq!(parse_results(&bad).unwrap_err().0, 4);
        let bad = format!("{h}\"a\"b,0,0,0,l,1,2,3,4,5,6,7,true,0.1\n");
        assert_eq!(parse_results(&bad).unwrap_err().0, 3);
        assert!(parse_results("# atrium-sweep name=x\n").is_err());
        assert!(parse_results("# atrium-sweep hash=1 cells=3 name=x\na\n").is_err());
        assert!(parse_results("").is_err());
    }

    #[test]
    fn files_with_and_without_the_failure_column_round_trip() {
        let mut with = row(vec!["1".into()], "l");
        with.values.insert(8, "0.25".into());
        let results = one_row(with.clone());
        let text = results.to_text();
        assert!(text.contains(",passed,failed_time_frac,wall_s\n"), "{text}");
        let back = parse_results(&text).unwrap();
        assert_eq!(back.rows, vec![with.clone()]);
        assert_eq!(failed_time_frac(&back.rows[0]), Some(0.25));
        assert_eq!(back.to_text(), text);
        // Without it: read as before, no fraction.
        let old = Results {
            rows: vec![row(vec!["1".into()], "l")],
            ..results.clone()
        };
        let back = parse_results(&old.to_text()).unwrap();
        assert!(!back.has_failure_column());
        assert_eq!(failed_time_frac(&back.rows[0]), None);
        // A row of the other layout is refused.
        let h = header_with("h", "n", None, &["a".into()], 1);
        let short = format!("{h}1,0,0,0,l,1,2,3,4,5,6,7,true,0.1\n");
        assert_eq!(parse_results(&short).unwrap_err().0, 3);
    }

    #[test]
    fn files_with_the_distance_columns_round_trip_and_older_ones_lack_them() {
        let mut with = row(vec!["1".into()], "l");
        for (k, v) in ["0.25", "41.5", "false"].into_iter().enumerate() {
            with.values.insert(8 + k, v.into());
        }
        let results = one_row(with.clone());
        let text = results.to_text();
        assert!(
            text.contains(",passed,failed_time_frac,distance_m,route_completed,wall_s\n"),
            "{text}"
        );
        let back = parse_results(&text).unwrap();
        assert_eq!(back.optional_columns(), CURRENT_OPTIONAL);
        assert_eq!(back.rows, vec![with]);
        let r = &back.rows[0];
        assert_eq!(failed_time_frac(r), Some(0.25));
        assert_eq!(distance_m(r), Some(41.5));
        assert_eq!(route_completed(r), Some(false));
        assert_eq!(back.to_text(), text);
        // A file of the previous version (the failure column only) has no distance.
        let mut older = row(vec!["1".into()], "l");
        older.values.insert(8, "0.25".into());
        let back = parse_results(&one_row(older).to_text()).unwrap();
        assert_eq!(back.optional_columns(), 1);
        assert_eq!(failed_time_frac(&back.rows[0]), Some(0.25));
        assert_eq!(distance_m(&back.rows[0]), None);
        assert_eq!(route_completed(&back.rows[0]), None);
        // A row of the older layout under the current header is refused.
        let h = header_with("h", "n", None, &["a".into()], CURRENT_OPTIONAL);
        let short = format!("{h}1,0,0,0,l,1,2,3,4,5,6,7,true,0.1,0.2\n");
        assert_eq!(parse_results(&short).unwrap_err().0, 3);
    }

    #[test]
    fn layouts_cover_their_sub_shards() {
        let l = |i, n| Layout {
            cells: 3,
            trials: 2,
            shard: (i, n),
        };
        assert!(l(0, 1).covers(&l(1, 2)));
        assert!(l(1, 2).covers(&l(3, 4)));
        assert!(!l(1, 2).covers(&l(0, 4)));
        assert!(!l(0, 2).covers(&l(0, 1)));
        assert!(l(1, 2).holds(0, 1) && !l(1, 2).holds(1, 0));
    }
}
