//! Per-location error maps ([004] §3, Figure 2): the mean
//! localization error of each localizer in every cell of a grid over the floor, accumulated
//! over many runs. The data-driven sensor choice of 004 §4.3 looks the map up at the current
//! estimate; sweeps write it as CSV and PNG.
//!
//! The map is plain data: sums and counts per (localizer, cell), so maps from shards or trials
//! merge exactly by adding.

use std::fmt::Write as _;

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
    /// An empty map covering `[min, max]` with square cells of `resolution` metres.
    pub fn new(
        min: [f64; 2],
        max: [f64; 2],
        resolution: f64,
        localizers: Vec<String>,
    ) -> Result<Self, String> {
        if !(resolution.is_finite() && resolution > 0.0) {
            return Err(format!("resolution must be positive, got {resolution}"));
        }
        if !(min.iter().chain(max.iter()).all(|v| v.is_finite())
            && max[0] > min[0]
            && max[1] > min[1])
        {
            return Err(format!("empty or non-finite bounds {min:?}..{max:?}"));
        }
        let width = ((max[0] - min[0]) / resolution).ceil() as usize;
        let height = ((max[1] - min[1]) / resolution).ceil() as usize;
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
        let fx = ((p[0] - self.origin[0]) / self.resolution).floor() as i64;
        let fy = ((p[1] - self.origin[1]) / self.resolution).floor() as i64;
        for r in 0..=radius_cells as i64 {
            let mut best: Option<(f64, u32)> = None;
            for dj in -r..=r {
                for di in -r..=r {
                    if di.abs().max(dj.abs()) != r {
                        continue;
                    }
                    let (i, j) = (fx + di, fy + dj);
                    if i < 0 || j < 0 || i as usize >= self.width || j as usize >= self.height {
                        continue;
                    }
                    if let Some((m, n)) = self.mean(layer, i as usize, j as usize) {
                        // Pool the ring: sample-weighted mean of its visited cells.
                        best = Some(match best {
                            None => (m * n as f64, n),
                            Some((s, c)) => (s + m * n as f64, c + n),
                        });
                    }
                }
            }
            if let Some((s, c)) = best {
                return Some(s / c as f64);
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
        for (a, b) in self.count.iter_mut().zip(&other.count) {
            *a += b;
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

    /// Parses [`ErrorMap::to_csv`] output. Localizers appear in the order first seen.
    pub fn from_csv(text: &str) -> Result<ErrorMap, ErrorMapParseError> {
        let err = |line: usize, message: String| ErrorMapParseError { line, message };
        let mut lines = text.lines().enumerate();
        let (_, head) = lines.next().ok_or_else(|| err(1, "empty file".into()))?;
        let head = head
            .strip_prefix("# atrium error map:")
            .ok_or_else(|| err(1, "missing '# atrium error map:' header".into()))?;
        let field = |key: &str| -> Result<f64, ErrorMapParseError> {
            head.split_whitespace()
                .find_map(|kv| kv.strip_prefix(key).and_then(|v| v.strip_prefix('=')))
                .ok_or_else(|| err(1, format!("header lacks {key}")))?
                .parse::<f64>()
                .map_err(|e| err(1, format!("{key}: {e}")))
        };
        let origin = [field("origin_x")?, field("origin_y")?];
        let resolution = field("resolution")?;
        let (width, height) = (field("width")?, field("height")?);
        if !(resolution > 0.0 && width >= 1.0 && height >= 1.0 && width * height <= 1e8) {
            return Err(err(1, "impossible grid size".into()));
        }
        let (width, height) = (width as usize, height as usize);
        match lines.next() {
            Some((_, "localizer,i,j,x,y,mean_error,samples,sum")) => {}
            _ => return Err(err(2, "missing column header".into())),
        }
        let mut rows = Vec::new();
        let mut names: Vec<String> = Vec::new();
        for (n, line) in lines {
            if line.trim().is_empty() {
                continue;
            }
            let f: Vec<&str> = line.split(',').collect();
            if f.len() != 8 {
                return Err(err(n + 1, format!("expected 8 fields, got {}", f.len())));
            }
            let parse_u = |s: &str, what: &str| {
                s.parse::<usize>()
                    .map_err(|e| err(n + 1, format!("{what}: {e}")))
            };
            let (i, j) = (parse_u(f[1], "i")?, parse_u(f[2], "j")?);
            let samples = parse_u(f[6], "samples")? as u32;
            let sum: f64 = f[7].parse().map_err(|e| err(n + 1, format!("sum: {e}")))?;
            if i >= width || j >= height || !sum.is_finite() || sum < 0.0 {
                return Err(err(n + 1, "cell or sum out of range".into()));
            }
            if !names.iter().any(|x| x == f[0]) {
                names.push(f[0].to_string());
            }
            rows.push((f[0].to_string(), i, j, samples, sum));
        }
        let mut map = ErrorMap {
            origin,
            resolution,
            width,
            height,
            sum: vec![0.0; width * height * names.len()],
            count: vec![0; width * height * names.len()],
            localizers: names,
        };
        for (name, i, j, samples, sum) in rows {
            let l = map.localizer_index(&name).expect("name collected above");
            let k = map.index(l, i, j);
            map.sum[k] += sum;
            map.count[k] += samples;
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
}
