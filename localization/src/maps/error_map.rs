//! Per-location error maps ([004] §3, Figure 2): the mean
//! localization error of each localizer in every cell of a grid over the floor, accumulated
//! over many runs. The data-driven sensor choice of 004 §4.3 looks the map up at the current
//! estimate; sweeps write it as CSV and PNG.
//!
//! The map is plain data: sums and counts per (localizer, cell), so maps from shards or trials
//! merge exactly by adding.

use crate::limits::{check_grid, fmt_count, MAX_LOOKUP_RADIUS_CELLS};
use std::fmt::Write as _;

pub use crate::limits::ERROR_MAP_MAX_VALUES;

/// Mean error per localizer and grid cell. Cell (i, j) covers
/// `[origin + i·res, origin + (i+1)·res) × [origin + j·res, ...)`.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorMap {
    pub origin: [f64; 2],
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    /// Localizer names, in the order their layers are stored.
    pub localizers: Vec<String>,
    /// `sum[l * width * height + j * width + i]`: summed position error (m).
    sum: Vec<f64>,
    count: Vec<u32>,
}

/// Errors reading an error-map CSV.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("error map line {line}: {message}")]
pub struct ErrorMapParseError {
    pub line: usize,
    pub message: String,
}

impl ErrorMap {
    /// An empty map covering `[min, max]` with square cells of `resolution` metres. Refused,
    /// before anything is allocated, when the cells × layers exceed [`ERROR_MAP_MAX_VALUES`].
    pub fn new(
        min: [f64; 2],
        max: [f64; 2],
        resolution: f64,
        localizers: Vec<String>,
    ) -> Result<Self, String> {
        if !(resolution.is_finite() && resolution > 0.0) {
            return Err(format!(
                "resolution must be finite and > 0, got {resolution}"
            ));
        }
        if !(min.iter().chain(max.iter()).all(|v| v.is_finite())
            && max[0] > min[0]
            && max[1] > min[1])
        {
            return Err(format!("empty or non-finite bounds {min:?}..{max:?}"));
        }
        Self::check_size(min, max, resolution, localizers.len())?;
        let extent = [max[0] - min[0], max[1] - min[1]];
        let width = ((extent[0] / resolution).ceil() as usize).max(1);
        let height = ((extent[1] / resolution).ceil() as usize).max(1);
        let n = width * height * localizers.len();
        Ok(ErrorMap {
            origin: min,
            resolution,
            width,
            height,
            localizers,
            sum: vec![0.0; n],
            count: vec![0; n],
        })
    }

    /// Checks the size of a map [`ErrorMap::new`] would build, without building it: its cells
    /// × `layers` against [`ERROR_MAP_MAX_VALUES`]. The message starts with `resolution` and
    /// gives the cells it would need and the finest resolution that fits.
    pub fn check_size(
        min: [f64; 2],
        max: [f64; 2],
        resolution: f64,
        layers: usize,
    ) -> Result<(), String> {
        let layers = layers.max(1) as u64;
        check_grid(
            "resolution",
            resolution,
            [max[0] - min[0], max[1] - min[1]],
            &format!(
                "area ({layers} layer{})",
                if layers == 1 { "" } else { "s" }
            ),
            ERROR_MAP_MAX_VALUES / layers,
            "ERROR_MAP_MAX_VALUES / layers",
        )
    }

    /// The cell containing `p`, if it is on the map.
    pub fn cell(&self, p: [f64; 2]) -> Option<(usize, usize)> {
        let fx = (p[0] - self.origin[0]) / self.resolution;
        let fy = (p[1] - self.origin[1]) / self.resolution;
        if !(fx >= 0.0 && fy >= 0.0) {
            return None;
        }
        let (i, j) = (fx as usize, fy as usize);
        (i < self.width && j < self.height).then_some((i, j))
    }

    /// Centre of cell (i, j).
    pub fn cell_centre(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.origin[0] + (i as f64 + 0.5) * self.resolution,
            self.origin[1] + (j as f64 + 0.5) * self.resolution,
        ]
    }

    pub fn localizer_index(&self, name: &str) -> Option<usize> {
        self.localizers.iter().position(|l| l == name)
    }

    fn index(&self, layer: usize, i: usize, j: usize) -> usize {
        layer * self.width * self.height + j * self.width + i
    }

    /// Records one error of localizer `layer` with the robot truly at `truth`. Points off the
    /// map and non-finite errors are ignored (returns false).
    pub fn add(&mut self, layer: usize, truth: [f64; 2], error: f64) -> bool {
        let Some((i, j)) = self.cell(truth) else {
            return false;
        };
        if !error.is_finite() || layer >= self.localizers.len() {
            return false;
        }
        let k = self.index(layer, i, j);
        if self.count[k] == u32::MAX {
            return false;
        }
        self.sum[k] += error;
        self.count[k] += 1;
        true
    }

    /// Mean error and sample count of `layer` in cell (i, j); None where nothing was recorded.
    pub fn mean(&self, layer: usize, i: usize, j: usize) -> Option<(f64, u32)> {
        let k = self.index(layer, i, j);
        (self.count[k] > 0).then(|| (self.sum[k] / self.count[k] as f64, self.count[k]))
    }

    /// Mean error of `layer` at point `p`; None off the map or in an unvisited cell.
    pub fn mean_at(&self, layer: usize, p: [f64; 2]) -> Option<f64> {
        let (i, j) = self.cell(p)?;
        self.mean(layer, i, j).map(|(m, _)| m)
    }

    /// Like [`ErrorMap::mean_at`], but falls back to the nearest visited cell of that layer
    /// within `radius_cells` (Chebyshev rings), so an estimate a little off the driven path
    /// still finds the map.
    pub fn mean_near(&self, layer: usize, p: [f64; 2], radius_cells: usize) -> Option<f64> {
        let fx = ((p[0] - self.origin[0]) / self.resolution).floor();
        let fy = ((p[1] - self.origin[1]) / self.resolution).floor();
        if !(fx.is_finite() && fy.is_finite()) {
            return None;
        }
        // Rings wider than the map (or than the limit) add nothing; i64 cannot overflow then.
        let span = self.width.max(self.height) as f64;
        let radius = radius_cells.min(MAX_LOOKUP_RADIUS_CELLS) as f64;
        if fx < -radius - 1.0 || fy < -radius - 1.0 || fx > span + radius || fy > span + radius {
            return None;
        }
        let (fx, fy) = (fx as i64, fy as i64);
        let visit = |i: i64, j: i64, best: &mut Option<(f64, f64)>| {
            if i < 0 || j < 0 || i as usize >= self.width || j as usize >= self.height {
                return;
            }
            if let Some((m, n)) = self.mean(layer, i as usize, j as usize) {
                // Pool the ring: sample-weighted mean of its visited cells.
                let n = n as f64;
                *best = Some(match *best {
                    None => (m * n, n),
                    Some((s, c)) => (s + m * n, c + n),
                });
            }
        };
        for r in 0..=radius as i64 {
            let mut best: Option<(f64, f64)> = None;
            if r == 0 {
                visit(fx, fy, &mut best);
            }
            // The ring's cells only: its top and bottom rows, then its sides.
            for d in -r..=r {
                if r > 0 {
                    visit(fx + d, fy - r, &mut best);
                    visit(fx + d, fy + r, &mut best);
                }
            }
            for d in (1 - r)..r {
                visit(fx - r, fy + d, &mut best);
                visit(fx + r, fy + d, &mut best);
            }
            if let Some((s, c)) = best {
                return Some(s / c);
            }
        }
        None
    }

    /// For each cell, the layer with the lowest mean error (None where no layer was recorded).
    pub fn best_layer(&self, i: usize, j: usize) -> Option<usize> {
        (0..self.localizers.len())
            .filter_map(|l| self.mean(l, i, j).map(|(m, _)| (l, m)))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(l, _)| l)
    }

    /// Adds another map's sums and counts (same grid and localizers).
    pub fn merge(&mut self, other: &ErrorMap) -> Result<(), String> {
        if other.origin != self.origin
            || other.resolution != self.resolution
            || other.width != self.width
            || other.height != self.height
            || other.localizers != self.localizers
        {
            return Err("error maps differ in grid or localizers".into());
        }
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            *a += b;
        }
        // 4 billion samples in one cell cannot come from runs; saturate rather than wrap.
        for (a, b) in self.count.iter_mut().zip(&other.count) {
            *a = a.saturating_add(*b);
        }
        Ok(())
    }

    /// CSV with a header line describing the grid, then one row per visited (localizer, cell):
    /// `localizer,i,j,x,y,mean_error,samples,sum`. Keeping the sum makes the file re-loadable
    /// and mergeable without loss.
    pub fn to_csv(&self) -> String {
        let mut s = format!(
            "# atrium error map: origin_x={} origin_y={} resolution={} width={} height={}\n\
             localizer,i,j,x,y,mean_error,samples,sum\n",
            self.origin[0], self.origin[1], self.resolution, self.width, self.height
        );
        for (l, name) in self.localizers.iter().enumerate() {
            for j in 0..self.height {
                for i in 0..self.width {
                    let k = self.index(l, i, j);
                    if self.count[k] == 0 {
                        continue;
                    }
                    let c = self.cell_centre(i, j);
                    let _ = writeln!(
                        s,
                        "{name},{i},{j},{},{},{},{},{}",
                        c[0],
                        c[1],
                        self.sum[k] / self.count[k] as f64,
                        self.count[k],
                        self.sum[k]
                    );
                }
            }
        }
        s
    }

    /// Parses [`ErrorMap::to_csv`] output. Localizers appear in the order first seen; rows of
    /// the same localizer and cell add up (merged shards). Refused, with the line and the
    /// field: a header that is not finite (origin), not positive (resolution), not a whole
    /// number of cells, or a grid whose cells × layers exceed [`ERROR_MAP_MAX_VALUES`] (checked
    /// before anything is allocated); rows outside the declared grid, with a malformed or
    /// non-finite number, or whose counts overflow.
    pub fn from_csv(text: &str) -> Result<ErrorMap, ErrorMapParseError> {
        let mut lines = text.lines().enumerate();
        let (_, head) = lines.next().ok_or_else(|| parse_error(1, "empty file"))?;
        let grid = CsvGrid::parse(head)?;
        match lines.next() {
            Some((_, "localizer,i,j,x,y,mean_error,samples,sum")) => {}
            _ => {
                return Err(parse_error(
                    2,
                    "missing column header localizer,i,j,x,y,mean_error,samples,sum",
                ))
            }
        }
        let mut rows: Vec<CsvRow> = Vec::new();
        let mut names: Vec<String> = Vec::new();
        for (n, line) in lines {
            if !line.trim().is_empty() {
                rows.push(grid.row(n + 1, line, &mut names)?);
            }
        }
        grid.accumulate(names, rows)
    }
}

fn parse_error(line: usize, message: impl Into<String>) -> ErrorMapParseError {
    ErrorMapParseError {
        line,
        message: message.into(),
    }
}

/// The grid an error map's CSV header declares, checked against [`ERROR_MAP_MAX_VALUES`].
struct CsvGrid {
    origin: [f64; 2],
    resolution: f64,
    width: usize,
    height: usize,
    /// width × height, as f64 for the size checks.
    area: f64,
}

/// One row of an error map's CSV: its line, layer, cell, samples and error sum.
struct CsvRow {
    line: usize,
    layer: usize,
    cell: usize,
    samples: u32,
    sum: f64,
}

impl CsvGrid {
    /// The header line `# atrium error map: origin_x=… origin_y=… resolution=… width=…
    /// height=…`; errors are at line 1.
    fn parse(head: &str) -> Result<CsvGrid, ErrorMapParseError> {
        let err = |message: String| parse_error(1, message);
        let head = head
            .strip_prefix("# atrium error map:")
            .ok_or_else(|| err("missing '# atrium error map:' header".into()))?;
        let value = |key: &str| -> Result<&str, ErrorMapParseError> {
            head.split_whitespace()
                .find_map(|kv| kv.strip_prefix(key).and_then(|v| v.strip_prefix('=')))
                .ok_or_else(|| err(format!("{key}: missing from the header")))
        };
        let finite = |key: &str| -> Result<f64, ErrorMapParseError> {
            let v = value(key)?;
            match v.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                Ok(x) => Err(err(format!("{key}: must be finite, got {x}"))),
                Err(e) => Err(err(format!("{key}: {v:?} is not a number ({e})"))),
            }
        };
        let cells = |key: &str| -> Result<u64, ErrorMapParseError> {
            let v = value(key)?;
            match v.parse::<u64>() {
                Ok(n) if n >= 1 => Ok(n),
                _ => Err(err(format!(
                    "{key}: must be a whole number of cells >= 1, got {v:?}"
                ))),
            }
        };
        let origin = [finite("origin_x")?, finite("origin_y")?];
        let resolution = finite("resolution")?;
        if resolution <= 0.0 {
            return Err(err(format!("resolution: must be > 0, got {resolution}")));
        }
        let (width, height) = (cells("width")?, cells("height")?);
        let far = [
            origin[0] + width as f64 * resolution,
            origin[1] + height as f64 * resolution,
        ];
        if !(far[0].is_finite() && far[1].is_finite()) {
            return Err(err(format!(
                "resolution: {width} × {height} cells of {resolution} m from {origin:?} \
                 reach beyond the finite numbers"
            )));
        }
        let area = width as f64 * height as f64;
        if area > ERROR_MAP_MAX_VALUES as f64 {
            return Err(err(format!(
                "width: {width} × {height} is {} cells, more than the limit of \
                 {ERROR_MAP_MAX_VALUES} (ERROR_MAP_MAX_VALUES)",
                fmt_count(area)
            )));
        }
        Ok(CsvGrid {
            origin,
            resolution,
            width: width as usize,
            height: height as usize,
            area,
        })
    }

    /// Row `line_no`: its fields checked, its localizer found in `names` or added to them
    /// (a new layer is checked against the limit before it is allocated).
    fn row(
        &self,
        line_no: usize,
        line: &str,
        names: &mut Vec<String>,
    ) -> Result<CsvRow, ErrorMapParseError> {
        let (width, height, area) = (self.width, self.height, self.area);
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 8 {
            return Err(parse_error(
                line_no,
                format!("expected 8 fields, got {}", f.len()),
            ));
        }
        let bad = |what: &str, msg: String| parse_error(line_no, format!("{what}: {msg}"));
        if f[0].trim().is_empty() {
            return Err(bad("localizer", "must not be empty".into()));
        }
        let index = |s: &str, what: &str, size: usize| match s.parse::<usize>() {
            Ok(v) if v < size => Ok(v),
            Ok(v) => Err(bad(
                what,
                format!("{v} lies outside the declared grid of {width} × {height} cells"),
            )),
            Err(e) => Err(bad(what, format!("{s:?} is not a cell index ({e})"))),
        };
        let (i, j) = (index(f[1], "i", width)?, index(f[2], "j", height)?);
        for (k, what) in [(3, "x"), (4, "y"), (5, "mean_error")] {
            match f[k].parse::<f64>() {
                Ok(v) if v.is_finite() => {}
                _ => {
                    return Err(bad(
                        what,
                        format!("must be a finite number, got {:?}", f[k]),
                    ))
                }
            }
        }
        let samples: u32 = f[6].parse().map_err(|e| {
            bad(
                "samples",
                format!("{:?} is not a count of at most {} ({e})", f[6], u32::MAX),
            )
        })?;
        // Only visited cells are written: a row without samples has no mean.
        if samples == 0 {
            return Err(bad("samples", "must be at least 1, got 0".into()));
        }
        let sum: f64 = match f[7].parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 => v,
            _ => {
                return Err(bad(
                    "sum",
                    format!("must be a finite number >= 0, got {:?}", f[7]),
                ))
            }
        };
        let layer = match names.iter().position(|x| x == f[0]) {
            Some(l) => l,
            None => {
                // Each new layer adds a whole grid: checked before it is allocated.
                let values = area * (names.len() + 1) as f64;
                if values > ERROR_MAP_MAX_VALUES as f64 {
                    return Err(bad(
                        "localizer",
                        format!(
                            "layer {} ({:?}) makes {width} × {height} cells × {} layers = \
                             {} values, more than the limit of {ERROR_MAP_MAX_VALUES} \
                             (ERROR_MAP_MAX_VALUES)",
                            names.len() + 1,
                            f[0],
                            names.len() + 1,
                            fmt_count(values)
                        ),
                    ));
                }
                names.push(f[0].to_string());
                names.len() - 1
            }
        };
        Ok(CsvRow {
            line: line_no,
            layer,
            cell: j * width + i,
            samples,
            sum,
        })
    }

    /// The map of `names` layers with `rows` added up (rows of the same localizer and cell
    /// are merged shards), refusing sums that overflow.
    fn accumulate(
        self,
        names: Vec<String>,
        rows: Vec<CsvRow>,
    ) -> Result<ErrorMap, ErrorMapParseError> {
        let (width, height) = (self.width, self.height);
        let n = width * height * names.len();
        let mut map = ErrorMap {
            origin: self.origin,
            resolution: self.resolution,
            width,
            height,
            sum: vec![0.0; n],
            count: vec![0; n],
            localizers: names,
        };
        for row in rows {
            let k = row.layer * width * height + row.cell;
            map.sum[k] += row.sum;
            map.count[k] = map.count[k].checked_add(row.samples).ok_or_else(|| {
                parse_error(
                    row.line,
                    format!(
                        "samples: the rows of this localizer and cell add up to more than {}",
                        u32::MAX
                    ),
                )
            })?;
            if !map.sum[k].is_finite() {
                return Err(parse_error(
                    row.line,
                    "sum: the rows of this localizer and cell add up to more than the finite \
                     numbers",
                ));
            }
        }
        Ok(map)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> ErrorMap {
        ErrorMap::new(
            [0.0, 0.0],
            [4.0, 2.0],
            1.0,
            vec!["laser".into(), "wifi".into()],
        )
        .unwrap()
    }

    #[test]
    fn means_per_cell_and_best_layer() {
        let mut m = map();
        assert_eq!((m.width, m.height), (4, 2));
        assert!(m.add(0, [0.5, 0.5], 0.1));
        assert!(m.add(0, [0.9, 0.2], 0.3));
        assert!(m.add(1, [0.5, 0.5], 1.0));
        assert!(m.add(1, [3.5, 1.5], 0.8));
        assert!(!m.add(0, [4.5, 0.5], 0.1), "off the map");
        assert!(!m.add(0, [0.5, 0.5], f64::NAN));
        assert_eq!(m.mean(0, 0, 0), Some((0.2, 2)));
        assert!((m.mean_at(0, [0.1, 0.1]).unwrap() - 0.2).abs() < 1e-12);
        assert_eq!(m.best_layer(0, 0), Some(0));
        assert_eq!(m.best_layer(3, 1), Some(1));
        assert_eq!(m.best_layer(2, 0), None);
    }

    #[test]
    fn nearest_visited_cell_is_found_within_radius() {
        let mut m = map();
        m.add(1, [3.5, 1.5], 0.8);
        assert_eq!(m.mean_at(1, [1.5, 1.5]), None);
        assert_eq!(m.mean_near(1, [1.5, 1.5], 1), None);
        assert_eq!(m.mean_near(1, [1.5, 1.5], 2), Some(0.8));
    }

    #[test]
    fn csv_round_trip_and_merge_add_up() {
        let mut m = map();
        m.add(0, [0.5, 0.5], 0.1);
        m.add(1, [2.5, 1.5], 2.0);
        let back = ErrorMap::from_csv(&m.to_csv()).unwrap();
        assert_eq!(back, m);
        let mut twice = back.clone();
        twice.merge(&m).unwrap();
        assert_eq!(twice.mean(1, 2, 1), Some((2.0, 2)));
        let other = ErrorMap::new([0.0, 0.0], [4.0, 2.0], 0.5, vec!["laser".into()]).unwrap();
        assert!(twice.merge(&other).is_err());
    }

    #[test]
    fn bad_input_is_rejected() {
        assert!(ErrorMap::new([0.0, 0.0], [1.0, 1.0], 0.0, vec![]).is_err());
        assert!(ErrorMap::new([0.0, 0.0], [0.0, 1.0], 1.0, vec![]).is_err());
        assert!(ErrorMap::from_csv("").is_err());
        assert!(ErrorMap::from_csv("hello\n").is_err());
        let text = map().to_csv() + "laser,9,0,0,0,1,1,1\n";
        let e = ErrorMap::from_csv(&text).unwrap_err();
        assert_eq!(e.line, 3);
    }

    fn csv(header: &str, rows: &str) -> Result<ErrorMap, ErrorMapParseError> {
        ErrorMap::from_csv(&format!(
            "# atrium error map: {header}\nlocalizer,i,j,x,y,mean_error,samples,sum\n{rows}"
        ))
    }

    const GRID: &str = "origin_x=0 origin_y=0 resolution=1 width=4 height=2";

    #[test]
    fn hostile_headers_are_refused_with_line_and_field() {
        let e = |header: &str| csv(header, "").unwrap_err();
        let nan = e("origin_x=NaN origin_y=0 resolution=1 width=4 height=2");
        assert_eq!(nan.line, 1);
        assert_eq!(nan.message, "origin_x: must be finite, got NaN");
        let inf = e("origin_x=0 origin_y=0 resolution=inf width=4 height=2");
        assert_eq!(inf.message, "resolution: must be finite, got inf");
        let zero = e("origin_x=0 origin_y=0 resolution=0 width=4 height=2");
        assert_eq!(zero.message, "resolution: must be > 0, got 0");
        assert!(e("origin_x=0 origin_y=0 resolution=1 width=4.5 height=2")
            .message
            .starts_with("width: must be a whole number of cells"));
        assert!(e("origin_x=0 origin_y=0 resolution=1 width=0 height=2")
            .message
            .starts_with("width: must be a whole number of cells"));
        assert!(
            e("origin_x=0 origin_y=0 resolution=1e306 width=1000 height=2")
                .message
                .contains("beyond the finite numbers")
        );
        assert_eq!(
            e("origin_x=0 origin_y=0 resolution=1 width=1000000000 height=1000000000").message,
            "width: 1000000000 × 1000000000 is 1e18 cells, more than the limit of 50000000 \
             (ERROR_MAP_MAX_VALUES)"
        );
        assert!(e("origin_x=0 resolution=1 width=4 height=2")
            .message
            .starts_with("origin_y: missing"));
        // At the limit the header is accepted (no layer is allocated without rows).
        let at = csv(
            &format!("origin_x=0 origin_y=0 resolution=1 width={ERROR_MAP_MAX_VALUES} height=1"),
            "",
        )
        .unwrap();
        assert_eq!(
            (at.width, at.localizers.len()),
            (ERROR_MAP_MAX_VALUES as usize, 0)
        );
        assert!(csv(
            &format!(
                "origin_x=0 origin_y=0 resolution=1 width={} height=1",
                ERROR_MAP_MAX_VALUES + 1
            ),
            "",
        )
        .is_err());
    }

    #[test]
    fn hostile_rows_are_refused_with_line_and_field() {
        let e = |rows: &str| csv(GRID, rows).unwrap_err();
        let out = e("a,0,0,0.5,0.5,1,1,1\na,4,0,4.5,0.5,1,1,1\n");
        assert_eq!(out.line, 4);
        assert_eq!(
            out.message,
            "i: 4 lies outside the declared grid of 4 × 2 cells"
        );
        assert!(e("a,0,-1,0,0,1,1,1\n")
            .message
            .starts_with("j: \"-1\" is not a cell index"));
        assert!(e("a,0,0,NaN,0,1,1,1\n")
            .message
            .starts_with("x: must be a finite number"));
        assert!(e("a,0,0,0,0,inf,1,1\n")
            .message
            .starts_with("mean_error: must be a finite number"));
        assert!(e("a,0,0,0,0,1,99999999999,1\n")
            .message
            .starts_with("samples:"));
        assert!(e("a,0,0,0,0,1,1,-1\n")
            .message
            .starts_with("sum: must be a finite number >= 0"));
        assert!(e(",0,0,0,0,1,1,1\n")
            .message
            .starts_with("localizer: must not be empty"));
        assert_eq!(
            e("a,0,0,0,0,1,0,5\n").message,
            "samples: must be at least 1, got 0"
        );
        let twice = e("a,0,0,0,0,1,4294967295,1\na,0,0,0,0,1,1,1\n");
        assert_eq!(
            (twice.line, twice.message.starts_with("samples:")),
            (4, true)
        );
        // Rows of one cell add up (merged shards).
        let m = csv(GRID, "a,1,1,0,0,1,2,3\na,1,1,0,0,1,1,1\n").unwrap();
        assert_eq!(m.mean(0, 1, 1), Some((4.0 / 3.0, 3)));
        // Every layer is a whole grid: the one that passes the limit is refused by name.
        let wide = format!(
            "origin_x=0 origin_y=0 resolution=1 width={} height=1",
            ERROR_MAP_MAX_VALUES / 2 + 1
        );
        let layers = csv(&wide, "a,0,0,0,0,1,1,1\nb,0,0,0,0,1,1,1\n").unwrap_err();
        assert_eq!(layers.line, 4);
        assert!(
            layers.message.starts_with("localizer: layer 2 (\"b\")")
                && layers.message.contains("ERROR_MAP_MAX_VALUES"),
            "{}",
            layers.message
        );
    }

    #[test]
    fn a_new_map_over_the_limit_is_refused_before_allocating() {
        let e = ErrorMap::new([0.0, 0.0], [60.0, 40.0], 1e-6, vec!["a".into(), "b".into()])
            .unwrap_err();
        assert!(
            e.starts_with("resolution: 0.000001 m over the 60 m × 40 m area (2 layers) is")
                && e.contains("more than the limit of 25000000"),
            "{e}"
        );
        assert!(ErrorMap::new([0.0, 0.0], [1.0, 1.0], f64::INFINITY, vec![]).is_err());
    }

    #[test]
    fn lookups_far_off_the_map_or_with_huge_radii_end_at_once() {
        let mut m = map();
        m.add(0, [0.5, 0.5], 0.4);
        assert_eq!(m.mean_near(0, [1e300, 0.5], usize::MAX), None);
        assert_eq!(m.mean_near(0, [f64::NAN, 0.5], 3), None);
        assert_eq!(m.mean_near(0, [-50.0, 0.5], usize::MAX), Some(0.4));
        assert_eq!(m.mean_near(1, [0.5, 0.5], usize::MAX), None);
    }
}
