//! The Gaussian-process-learnt WiFi graph of [004] §2.3: for every access
//! point, a GP (squared-exponential kernel plus noise, hyperparameters by marginal likelihood,
//! see [`crate::maths::gp`]) learnt offline from (position, scan) samples collected while driving,
//! evaluated at the nodes of a regular graph (mean and variance per node), and bicubically
//! interpolated at run time (§2.3: "WiFi mean and variance at locations during run time are
//! estimated by bicubic interpolation across nodes of the graph").
//!
//! Missing readings: a scan that does not contain an access point says its RSSI was below
//! the receiver's cut-off. Such samples enter training at `missing_dbm` (default one
//! quantization step below the cut-off), so the graph learns where an access point fades
//! out instead of extrapolating its strong values there.
//!
//! The cost of a run-time lookup is 16 nodes per access point, whatever the number of
//! training samples.

use crate::error::LocalizationError;
use crate::limits::{
    check_count, Lattice, GP_MAX_BLOCKS, GP_MAX_BLOCK_SIZE, GP_MAX_ITERATIONS,
    WIFI_GRAPH_MAX_VALUES,
};
use crate::maths::gp::{
    bin_samples, bin_values, fit_hyperparameters, HyperOptions, LocalGp, LocalPosterior, SeKernel,
    SpatialIndex,
};
use atrium_robots::WifiScan;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// How a graph is learnt.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WifiGraphParams {
    /// Distance between graph nodes, m. Default 1.0.
    pub node_spacing: f64,
    /// Side of the bins samples are grouped into (see [`crate::maths::gp`]), m. Default 0.5.
    pub bin_m: f64,
    /// Nodes per side of a block sharing one local GP. Default 3.
    pub block: usize,
    /// Neighbours per 45° sector of a block's local GP. Default 32 (at most 256 in all).
    pub per_sector: usize,
    /// Radius of the neighbour search, m. Default 15.
    pub radius: f64,
    /// The receiver's sensitivity cut-off, dBm. Default −90.
    pub cutoff_dbm: f64,
    /// Value a missing reading is trained as, dBm. Default `cutoff_dbm − 1`.
    pub missing_dbm: Option<f64>,
    /// Hyperparameter fitting.
    pub hyper: HyperOptions,
}

impl Default for WifiGraphParams {
    fn default() -> Self {
        Self {
            node_spacing: 1.0,
            bin_m: 0.5,
            block: 3,
            per_sector: 32,
            radius: 15.0,
            cutoff_dbm: -90.0,
            missing_dbm: None,
            hyper: HyperOptions::default(),
        }
    }
}

impl WifiGraphParams {
    pub fn validate(&self) -> Result<(), String> {
        let pos = |name: &str, v: f64, max: f64| {
            if v.is_finite() && v > 0.0 && v <= max {
                Ok(())
            } else {
                Err(format!("{name} must be within (0, {max}], got {v}"))
            }
        };
        pos("node_spacing", self.node_spacing, 10.0)?;
        pos("bin_m", self.bin_m, 5.0)?;
        pos("radius", self.radius, 1000.0)?;
        if !(1..=20).contains(&self.block) {
            return Err(format!("block must be within [1, 20], got {}", self.block));
        }
        if !(1..=128).contains(&self.per_sector) {
            return Err(format!(
                "per_sector must be within [1, 128], got {}",
                self.per_sector
            ));
        }
        if !(self.cutoff_dbm.is_finite() && (-150.0..=0.0).contains(&self.cutoff_dbm)) {
            return Err(format!(
                "cutoff_dbm must be within [-150, 0], got {}",
                self.cutoff_dbm
            ));
        }
        if let Some(m) = self.missing_dbm {
            if !(m.is_finite() && m <= self.cutoff_dbm) {
                return Err(format!(
                    "missing_dbm must be finite and <= cutoff_dbm ({}), got {m}",
                    self.cutoff_dbm
                ));
            }
        }
        if self.hyper.blocks == 0 || self.hyper.block_size < 3 {
            return Err("hyper.blocks must be >= 1 and hyper.block_size >= 3".into());
        }
        check_count(
            "hyper.blocks",
            self.hyper.blocks,
            GP_MAX_BLOCKS,
            "GP_MAX_BLOCKS",
        )?;
        check_count(
            "hyper.block_size",
            self.hyper.block_size,
            GP_MAX_BLOCK_SIZE,
            "GP_MAX_BLOCK_SIZE",
        )?;
        check_count(
            "hyper.iterations",
            self.hyper.iterations,
            GP_MAX_ITERATIONS,
            "GP_MAX_ITERATIONS",
        )?;
        Ok(())
    }

    /// Checks the size of the graph learnt over the rectangle `lo`–`hi` for `access_points`
    /// access points against [`WIFI_GRAPH_MAX_VALUES`], before anything is learnt or
    /// allocated; the message gives the nodes it would need and the finest `node_spacing`
    /// that fits.
    pub fn check_graph_size(
        &self,
        lo: [f64; 2],
        hi: [f64; 2],
        access_points: usize,
    ) -> Result<(), String> {
        let aps = access_points.max(1) as u64;
        // The lattice has 3 nodes more than the extent needs on each axis (see `learn`).
        Lattice {
            field: "node_spacing",
            what: &format!("area ({aps} access points)"),
            unit: "nodes",
            extra: 3.0,
            limit: WIFI_GRAPH_MAX_VALUES / aps,
            limit_name: "WIFI_GRAPH_MAX_VALUES / access points",
        }
        .check(self.node_spacing, [hi[0] - lo[0], hi[1] - lo[1]])
    }

    fn missing(&self) -> f64 {
        self.missing_dbm.unwrap_or(self.cutoff_dbm - 1.0)
    }
}

/// One access point of the graph.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GraphAp {
    pub name: String,
    /// The fitted kernel; `noise_sd` is the spread of one reading around the mean.
    pub kernel: SeKernel,
    /// Constant prior mean (mean of the training values), dBm.
    pub prior_mean: f64,
    /// Training scans that heard it.
    pub heard: usize,
}

/// Catmull–Rom (Keys a = −½) weights of the 4 nodes around fractional position t ∈ [0, 1]:
/// a cubic that interpolates the nodes and reproduces quadratics exactly.
#[inline]
fn cubic_weights(t: f64) -> [f64; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ]
}

/// The 4 × 4 nodes and weights of a bicubic lookup at one position; compute it once per
/// particle and evaluate every access point with it.
#[derive(Debug, Clone, Copy)]
pub struct Stencil {
    /// Index of the first node (lower-left of the 4 × 4).
    base: usize,
    wx: [f64; 4],
    wy: [f64; 4],
}

/// Most access points [`WifiGraph::eval_aps`] evaluates at once.
pub const AP_CHUNK: usize = 16;

/// Smallest variance an interpolated node variance is clamped to (cubic interpolation can
/// overshoot below zero between a low and a high node), dB².
const MIN_VARIANCE: f64 = 1e-3;

const FORMAT: &str = "atrium-wifi-graph";
const VERSION: u32 = 1;

/// Mean and variance of every access point at the nodes of a regular graph.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WifiGraph {
    format: String,
    version: u32,
    /// Position of node (0, 0), m.
    pub origin: [f64; 2],
    pub spacing: f64,
    pub width: usize,
    pub height: usize,
    pub aps: Vec<GraphAp>,
    /// Training samples (scans) the graph was learnt from.
    pub samples: usize,
    /// The receiver cut-off the graph was trained with, dBm.
    pub cutoff_dbm: f64,
    /// Node-major: `mean[node * aps.len() + ap]`, dBm.
    mean: Vec<f64>,
    /// Posterior variance of the mean RSSI (without the reading noise), dB².
    var: Vec<f64>,
    /// Whether each node lies in free space (the others are interpolation support).
    pub free: Vec<bool>,
}

impl WifiGraph {
    /// Learns the graph from `(x, y, scan)` samples over the rectangle `lo`–`hi` (the world's
    /// bounds); `is_free` marks nodes in free space. Access points are those heard in any
    /// scan, sorted by name.
    pub fn learn(
        samples: &[([f64; 2], &WifiScan)],
        lo: [f64; 2],
        hi: [f64; 2],
        params: &WifiGraphParams,
        is_free: &dyn Fn([f64; 2]) -> bool,
    ) -> Result<WifiGraph, LocalizationError> {
        params
            .validate()
            .map_err(LocalizationError::InvalidParameter)?;
        if samples.is_empty() {
            return Err(LocalizationError::InvalidParameter(
                "WiFi graph: no training samples".into(),
            ));
        }
        if !(lo.iter().chain(&hi).all(|v| v.is_finite()) && hi[0] > lo[0] && hi[1] > lo[1]) {
            return Err(LocalizationError::InvalidParameter(format!(
                "WiFi graph: bad bounds {lo:?}–{hi:?}"
            )));
        }
        let mut names: Vec<String> = samples
            .iter()
            .flat_map(|(_, s)| s.readings.iter().map(|r| r.ap.clone()))
            .collect();
        names.sort();
        names.dedup();
        if names.is_empty() {
            return Err(LocalizationError::InvalidParameter(
                "WiFi graph: no access point was heard in any training scan".into(),
            ));
        }
        let n_ap = names.len();
        params
            .check_graph_size(lo, hi, n_ap)
            .map_err(LocalizationError::InvalidParameter)?;
        let missing = params.missing();
        // values[a][s]: the reading of AP a in sample s (missing → `missing`).
        let mut values = vec![vec![missing; samples.len()]; n_ap];
        let mut heard = vec![0usize; n_ap];
        for (s, (_, scan)) in samples.iter().enumerate() {
            for r in &scan.readings {
                if !r.rssi_dbm.is_finite() {
                    continue;
                }
                let a = names.binary_search(&r.ap).expect("name collected above");
                values[a][s] = r.rssi_dbm;
                heard[a] += 1;
            }
        }
        let positions: Vec<[f64; 2]> = samples.iter().map(|(p, _)| *p).collect();
        if let Some(p) = positions
            .iter()
            .find(|p| !(p[0].is_finite() && p[1].is_finite()))
        {
            return Err(LocalizationError::InvalidParameter(format!(
                "WiFi graph: a training position is not finite: {p:?}"
            )));
        }
        let bins = bin_samples(&positions, params.bin_m);
        let index = SpatialIndex::new(&bins.points, params.bin_m.max(0.5));

        // Per AP: binned values, prior mean, hyperparameters.
        let mut models = Vec::with_capacity(n_ap);
        let mut aps = Vec::with_capacity(n_ap);
        for (a, name) in names.iter().enumerate() {
            let bv = bin_values(&bins, &values[a]);
            let mean = values[a].iter().sum::<f64>() / values[a].len() as f64;
            let sd = (values[a].iter().map(|v| (v - mean).powi(2)).sum::<f64>()
                / values[a].len() as f64)
                .sqrt()
                .max(1.0);
            let init = SeKernel {
                length_scale: 3.0,
                signal_sd: sd,
                noise_sd: 2.0,
            };
            let hyper = HyperOptions {
                seed: params.hyper.seed ^ (a as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
                ..params.hyper
            };
            let kernel = fit_hyperparameters(&bins.points, &bv, &bins.counts, mean, init, &hyper);
            models.push((LocalGp { kernel, mean }, bv));
            aps.push(GraphAp {
                name: name.clone(),
                kernel,
                prior_mean: mean,
                heard: heard[a],
            });
        }

        // The lattice covers the bounds with one extra node on each side, so every position
        // inside has its full 4 × 4 stencil.
        let s = params.node_spacing;
        let origin = [lo[0] - s, lo[1] - s];
        let width = ((hi[0] - lo[0]) / s).ceil() as usize + 3;
        let height = ((hi[1] - lo[1]) / s).ceil() as usize + 3;
        let nodes = width * height;
        let mut mean = vec![0.0; nodes * n_ap];
        let mut var = vec![0.0; nodes * n_ap];
        let mut free = vec![false; nodes];
        let (mut nb, mut scratch) = (Vec::new(), Vec::new());
        let mut post = LocalPosterior::default();
        let b = params.block;
        for bj in (0..height).step_by(b) {
            for bi in (0..width).step_by(b) {
                let (i1, j1) = ((bi + b).min(width), (bj + b).min(height));
                let centre = [
                    origin[0] + 0.5 * (bi + i1 - 1) as f64 * s,
                    origin[1] + 0.5 * (bj + j1 - 1) as f64 * s,
                ];
                index.nearest_by_sector(
                    &bins.points,
                    centre,
                    params.per_sector,
                    params.radius,
                    &mut nb,
                    &mut scratch,
                );
                for (a, (gp, bv)) in models.iter().enumerate() {
                    gp.condition(&bins.points, bv, &bins.counts, &nb, &mut post);
                    for j in bj..j1 {
                        for i in bi..i1 {
                            let q = [origin[0] + i as f64 * s, origin[1] + j as f64 * s];
                            let (m, v) = post.predict(q);
                            let k = (j * width + i) * n_ap + a;
                            mean[k] = m;
                            var[k] = v;
                        }
                    }
                }
                for j in bj..j1 {
                    for i in bi..i1 {
                        free[j * width + i] =
                            is_free([origin[0] + i as f64 * s, origin[1] + j as f64 * s]);
                    }
                }
            }
        }
        Ok(WifiGraph {
            format: FORMAT.into(),
            version: VERSION,
            origin,
            spacing: s,
            width,
            height,
            aps,
            samples: samples.len(),
            cutoff_dbm: params.cutoff_dbm,
            mean,
            var,
            free,
        })
    }

    /// Builds a graph from node values directly (tests, synthetic maps): `mean` and `var`
    /// node-major as documented on the fields.
    #[allow(clippy::too_many_arguments)]
    pub fn from_nodes(
        origin: [f64; 2],
        spacing: f64,
        width: usize,
        height: usize,
        aps: Vec<GraphAp>,
        mean: Vec<f64>,
        var: Vec<f64>,
        cutoff_dbm: f64,
    ) -> Result<WifiGraph, LocalizationError> {
        let g = WifiGraph {
            format: FORMAT.into(),
            version: VERSION,
            origin,
            spacing,
            width,
            height,
            samples: 0,
            cutoff_dbm,
            free: vec![true; width * height],
            aps,
            mean,
            var,
        };
        g.check()
            .map_err(|e| LocalizationError::InvalidParameter(e.to_string()))?;
        Ok(g)
    }

    fn check(&self) -> Result<(), GraphFieldError> {
        if self.format != FORMAT || self.version != VERSION {
            return Err(GraphFieldError::new(
                "format",
                format!(
                    "expected {FORMAT:?} version {VERSION}, got {:?} version {}",
                    self.format, self.version
                ),
            ));
        }
        if !(self.spacing.is_finite() && self.spacing > 0.0) {
            return Err(GraphFieldError::new(
                "spacing",
                format!("must be > 0, got {}", self.spacing),
            ));
        }
        if self.width < 4 || self.height < 4 {
            return Err(GraphFieldError::new(
                "width, height",
                format!(
                    "need at least 4 × 4 nodes, got {} × {}",
                    self.width, self.height
                ),
            ));
        }
        if !(self.origin[0].is_finite() && self.origin[1].is_finite()) {
            return Err(GraphFieldError::new(
                "origin",
                format!("must be finite, got {:?}", self.origin),
            ));
        }
        if self.aps.is_empty() {
            return Err(GraphFieldError::new("aps", "no access point"));
        }
        let n = self.width.checked_mul(self.height);
        let want = n.and_then(|n| n.checked_mul(self.aps.len()));
        let (Some(n), Some(want)) = (n, want) else {
            return Err(GraphFieldError::new(
                "width, height",
                format!(
                    "{} × {} nodes × {} access points overflow",
                    self.width,
                    self.height,
                    self.aps.len()
                ),
            ));
        };
        if self.mean.len() != want || self.var.len() != want || self.free.len() != n {
            return Err(GraphFieldError::new(
                "mean, var, free",
                format!(
                    "expected {want}, {want} and {n} values, got {}, {} and {}",
                    self.mean.len(),
                    self.var.len(),
                    self.free.len()
                ),
            ));
        }
        if let Some(k) = self.mean.iter().position(|v| !v.is_finite()) {
            return Err(GraphFieldError::new(format!("mean[{k}]"), "not finite"));
        }
        if let Some(k) = self.var.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(GraphFieldError::new(
                format!("var[{k}]"),
                "must be finite and >= 0",
            ));
        }
        for (i, ap) in self.aps.iter().enumerate() {
            let k = ap.kernel;
            if ![k.length_scale, k.signal_sd, k.noise_sd, ap.prior_mean]
                .iter()
                .all(|v| v.is_finite())
                || k.noise_sd <= 0.0
            {
                return Err(GraphFieldError::new(
                    format!("aps[{i}]"),
                    "kernel and prior mean must be finite, noise_sd > 0",
                ));
            }
        }
        Ok(())
    }

    /// Index of the access point called `name`.
    pub fn ap_index(&self, name: &str) -> Option<usize> {
        self.aps.iter().position(|a| a.name == name)
    }

    /// The bicubic stencil at (x, y); positions off the graph are clamped onto it.
    #[inline]
    pub fn stencil(&self, x: f64, y: f64) -> Stencil {
        let axis = |v: f64, o: f64, n: usize| -> (usize, f64) {
            let g = ((v - o) / self.spacing).clamp(1.0, (n - 3) as f64 + 0.999_999);
            let i = g.floor();
            (i as usize, g - i)
        };
        let (i, tx) = axis(x, self.origin[0], self.width);
        let (j, ty) = axis(y, self.origin[1], self.height);
        Stencil {
            base: (j - 1) * self.width + (i - 1),
            wx: cubic_weights(tx),
            wy: cubic_weights(ty),
        }
    }

    /// Interpolated (mean dBm, variance dB² of the mean) of access point `ap` at a stencil.
    #[inline]
    pub fn eval(&self, st: &Stencil, ap: usize) -> (f64, f64) {
        let (mut m, mut v) = ([0.0], [0.0]);
        self.eval_aps(st, ap, &mut m, &mut v);
        (m[0], v[0])
    }

    /// [`WifiGraph::eval`] of the access points `first..first + mean.len()` (at most
    /// [`AP_CHUNK`]) at one stencil, into `mean` and `var`. Each access point's sums run in
    /// the same order whatever the chunk, so its value is the same bit for bit; the chunk
    /// shares the reads: a node's access points lie side by side, where one access point at a
    /// time strode across the sixteen nodes (a quarter of the WiFi filter's update).
    #[inline]
    pub fn eval_aps(&self, st: &Stencil, first: usize, mean: &mut [f64], var: &mut [f64]) {
        let n_ap = self.aps.len();
        let k = mean.len();
        assert!(k <= AP_CHUNK && var.len() == k && first + k <= n_ap);
        let (mut m, mut v) = ([0.0; AP_CHUNK], [0.0; AP_CHUNK]);
        for (r, wy) in st.wy.iter().enumerate() {
            let row = st.base + r * self.width;
            let (mut mr, mut vr) = ([0.0; AP_CHUNK], [0.0; AP_CHUNK]);
            for (c, wx) in st.wx.iter().enumerate() {
                let at = (row + c) * n_ap + first;
                let (node_mean, node_var) = (&self.mean[at..at + k], &self.var[at..at + k]);
                for a in 0..k {
                    mr[a] += wx * node_mean[a];
                    vr[a] += wx * node_var[a];
                }
            }
            for a in 0..k {
                m[a] += wy * mr[a];
                v[a] += wy * vr[a];
            }
        }
        mean.copy_from_slice(&m[..k]);
        for (out, v) in var.iter_mut().zip(&v[..k]) {
            *out = v.max(MIN_VARIANCE);
        }
    }

    /// Interpolated (mean, variance of the mean) of access point `ap` at (x, y).
    pub fn interpolate(&self, ap: usize, x: f64, y: f64) -> (f64, f64) {
        self.eval(&self.stencil(x, y), ap)
    }

    /// (mean, variance of the mean) of access point `ap` at node (i, j).
    pub fn node(&self, ap: usize, i: usize, j: usize) -> (f64, f64) {
        let k = (j * self.width + i) * self.aps.len() + ap;
        (self.mean[k], self.var[k])
    }

    /// Position of node (i, j).
    pub fn node_position(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.origin[0] + i as f64 * self.spacing,
            self.origin[1] + j as f64 * self.spacing,
        ]
    }

    /// A compact, lossless binary encoding (little-endian; every f64 bit for bit), read back
    /// by [`WifiGraph::from_bytes`]: the on-disk cache's form of a learnt graph.
    pub fn to_bytes(&self) -> Vec<u8> {
        let n = self.mean.len() + self.var.len();
        let mut out = Vec::with_capacity(128 + 8 * n + self.free.len() + 64 * self.aps.len());
        let u64s = |out: &mut Vec<u8>, v: u64| out.extend_from_slice(&v.to_le_bytes());
        let f64s = |out: &mut Vec<u8>, v: f64| out.extend_from_slice(&v.to_bits().to_le_bytes());
        u64s(&mut out, u64::from(self.version));
        f64s(&mut out, self.origin[0]);
        f64s(&mut out, self.origin[1]);
        f64s(&mut out, self.spacing);
        u64s(&mut out, self.width as u64);
        u64s(&mut out, self.height as u64);
        u64s(&mut out, self.samples as u64);
        f64s(&mut out, self.cutoff_dbm);
        u64s(&mut out, self.aps.len() as u64);
        for ap in &self.aps {
            u64s(&mut out, ap.name.len() as u64);
            out.extend_from_slice(ap.name.as_bytes());
            f64s(&mut out, ap.kernel.length_scale);
            f64s(&mut out, ap.kernel.signal_sd);
            f64s(&mut out, ap.kernel.noise_sd);
            f64s(&mut out, ap.prior_mean);
            u64s(&mut out, ap.heard as u64);
        }
        for v in [&self.mean, &self.var] {
            u64s(&mut out, v.len() as u64);
            for x in v.iter() {
                f64s(&mut out, *x);
            }
        }
        u64s(&mut out, self.free.len() as u64);
        out.extend(self.free.iter().map(|&f| u8::from(f)));
        out
    }

    /// Reads [`WifiGraph::to_bytes`]; `None` for bytes that are not a whole, valid graph.
    pub fn from_bytes(bytes: &[u8]) -> Option<WifiGraph> {
        let mut c = Cursor { bytes, at: 0 };
        let version = u32::try_from(c.u64()?).ok()?;
        let origin = [c.f64()?, c.f64()?];
        let spacing = c.f64()?;
        let width = c.usize()?;
        let height = c.usize()?;
        let samples = c.usize()?;
        let cutoff_dbm = c.f64()?;
        // Each access point takes at least 48 bytes: refuse counts the rest cannot hold.
        let n_ap = c.count(48)?;
        let mut aps = Vec::with_capacity(n_ap);
        for _ in 0..n_ap {
            let len = c.count(1)?;
            let name = String::from_utf8(c.take(len)?.to_vec()).ok()?;
            let kernel = SeKernel {
                length_scale: c.f64()?,
                signal_sd: c.f64()?,
                noise_sd: c.f64()?,
            };
            aps.push(GraphAp {
                name,
                kernel,
                prior_mean: c.f64()?,
                heard: c.usize()?,
            });
        }
        let mut arrays = Vec::with_capacity(2);
        for _ in 0..2 {
            let len = c.count(8)?;
            arrays.push((0..len).map(|_| c.f64()).collect::<Option<Vec<f64>>>()?);
        }
        let len = c.count(1)?;
        let raw = c.take(len)?;
        if raw.iter().any(|&b| b > 1) || c.at != bytes.len() {
            return None;
        }
        let free = raw.iter().map(|&b| b == 1).collect();
        let var = arrays.pop()?;
        let mean = arrays.pop()?;
        let g = WifiGraph {
            format: FORMAT.to_string(),
            version,
            origin,
            spacing,
            width,
            height,
            aps,
            samples,
            cutoff_dbm,
            mean,
            var,
            free,
        };
        g.check().ok()?;
        Some(g)
    }

    /// Writes the graph as JSON, to a temporary name first, renamed when complete.
    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        let text = serde_json::to_string(self).map_err(std::io::Error::other)?;
        let tmp = path.with_extension("json.partial");
        std::fs::write(&tmp, text)?;
        std::fs::rename(&tmp, path)
    }

    /// Reads a graph written by [`WifiGraph::save`] and checks it; errors name the field.
    pub fn load(path: &Path) -> Result<WifiGraph, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        let g: WifiGraph = serde_json::from_str(&text)
            .map_err(|e| format!("{}: not a WiFi graph: {e}", path.display()))?;
        g.check().map_err(|e| format!("{}: {e}", path.display()))?;
        Ok(g)
    }
}

/// A field of a WiFi graph (built or read from a file) that is not valid: its name (with the
/// index, `mean[3]`) and why.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct GraphFieldError {
    pub field: String,
    pub reason: String,
}

impl GraphFieldError {
    fn new(field: impl Into<String>, reason: impl Into<String>) -> GraphFieldError {
        GraphFieldError {
            field: field.into(),
            reason: reason.into(),
        }
    }
}

/// Little-endian reading for [`WifiGraph::from_bytes`]; `None` past the end.
struct Cursor<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Cursor<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }
    fn u64(&mut self) -> Option<u64> {
        Some(u64::from_le_bytes(self.take(8)?.try_into().ok()?))
    }
    fn f64(&mut self) -> Option<f64> {
        Some(f64::from_bits(self.u64()?))
    }
    fn usize(&mut self) -> Option<usize> {
        usize::try_from(self.u64()?).ok()
    }
    /// A count of items of at least `item` bytes each that the rest can hold.
    fn count(&mut self, item: usize) -> Option<usize> {
        let n = self.usize()?;
        (n.checked_mul(item)? <= self.bytes.len() - self.at).then_some(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use atrium_robots::WifiReading;

    fn ap(name: &str) -> GraphAp {
        GraphAp {
            name: name.into(),
            kernel: SeKernel {
                length_scale: 3.0,
                signal_sd: 5.0,
                noise_sd: 2.0,
            },
            prior_mean: -70.0,
            heard: 0,
        }
    }

    #[test]
    fn bicubic_interpolation_reproduces_a_smooth_field_between_nodes() {
        let f = |x: f64, y: f64| -60.0 + 8.0 * (0.3 * x).sin() * (0.2 * y).cos();
        let (w, h, s) = (30, 20, 0.5);
        let origin = [-2.0, -1.0];
        let mut mean = Vec::new();
        let mut var = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let (x, y) = (origin[0] + i as f64 * s, origin[1] + j as f64 * s);
                mean.push(f(x, y));
                var.push(4.0 + 0.1 * x + 0.05 * y * y); // a quadratic: reproduced exactly
            }
        }
        let g = WifiGraph::from_nodes(origin, s, w, h, vec![ap("a")], mean, var, -90.0).unwrap();
        let mut worst: f64 = 0.0;
        for k in 0..200 {
            let x = 0.0 + 0.0517 * k as f64 % 10.0;
            let y = 0.5 + (0.0311 * k as f64) % 6.0;
            let (m, v) = g.interpolate(0, x, y);
            worst = worst.max((m - f(x, y)).abs());
            assert!(
                (v - (4.0 + 0.1 * x + 0.05 * y * y)).abs() < 1e-9,
                "var at {x},{y}"
            );
        }
        // Catmull–Rom error ~ h³·|f'''|: 0.125 · 8 · 0.3³ ≈ 0.03 dB at most.
        assert!(worst < 0.03, "{worst}");
        // At a node, the node's value.
        let (m, _) = g.interpolate(0, origin[0] + 5.0 * s, origin[1] + 7.0 * s);
        assert!((m - g.node(0, 5, 7).0).abs() < 1e-9);
    }

    #[test]
    fn access_points_evaluated_together_are_each_evaluated_alone_bit_for_bit() {
        // 19 access points: a full chunk and a partial one. Node values span 1e-12..1e12 with
        // both signs, so sums whose order depended on the chunk would differ in the bits.
        let (w, h, n_ap) = (9, 7, 19);
        let mut mean = Vec::new();
        let mut var = Vec::new();
        for k in 0..w * h * n_ap {
            let e = ((k * 7) % 25) as i32 - 12;
            let sign = if k % 3 == 0 { -1.0 } else { 1.0 };
            mean.push(sign * (1.0 + (k % 11) as f64 / 7.0) * 10f64.powi(e));
            var.push((1.0 + (k % 5) as f64 / 3.0) * 10f64.powi(-e));
        }
        let aps = (0..n_ap).map(|a| ap(&format!("ap{a}"))).collect();
        let g = WifiGraph::from_nodes([0.0, 0.0], 0.5, w, h, aps, mean, var, -90.0).unwrap();
        let (mut m, mut v) = ([0.0; AP_CHUNK], [0.0; AP_CHUNK]);
        for (x, y) in [(1.13, 0.77), (2.0, 2.0), (-3.0, 9.0), (3.21, 1.49)] {
            let st = g.stencil(x, y);
            for first in (0..n_ap).step_by(AP_CHUNK) {
                let k = AP_CHUNK.min(n_ap - first);
                g.eval_aps(&st, first, &mut m[..k], &mut v[..k]);
                for j in 0..k {
                    let (m1, v1) = g.eval(&st, first + j);
                    assert_eq!(m[j].to_bits(), m1.to_bits(), "mean of ap {}", first + j);
                    assert_eq!(v[j].to_bits(), v1.to_bits(), "var of ap {}", first + j);
                }
            }
        }
    }

    fn scan(readings: &[(&str, f64)]) -> WifiScan {
        WifiScan {
            stamp: 0.0,
            sensor: "wifi".into(),
            readings: readings
                .iter()
                .map(|(a, r)| WifiReading {
                    ap: (*a).into(),
                    channel: 1,
                    rssi_dbm: *r,
                })
                .collect(),
        }
    }

    #[test]
    fn learnt_graph_follows_the_samples_and_round_trips_through_a_file() {
        // AP "a" strong at the west end, fading east; "b" only heard in the east half.
        let mut scans = Vec::new();
        for k in 0..200 {
            let x = 0.1 * k as f64;
            let mut r = vec![("a", (-45.0 - 2.0 * x).round())];
            if x > 10.0 {
                r.push(("b", -80.0));
            }
            scans.push(([x, 1.0 + 0.3 * ((k % 7) as f64 - 3.0) / 3.0], scan(&r)));
        }
        let samples: Vec<([f64; 2], &WifiScan)> = scans.iter().map(|(p, s)| (*p, s)).collect();
        let g = WifiGraph::learn(
            &samples,
            [0.0, 0.0],
            [20.0, 20.0],
            &WifiGraphParams::default(),
            &|_| true,
        )
        .unwrap();
        assert_eq!(g.aps.len(), 2);
        assert_eq!(g.aps[0].name, "a");
        assert_eq!(g.aps[1].heard, 99);
        let (m, v) = g.interpolate(0, 5.0, 1.0);
        assert!((m + 55.0).abs() < 1.0, "{m}");
        assert!(v < 1.0, "{v}");
        // "b" is missing in the west: its mean there is near the missing value −91.
        let (mb, _) = g.interpolate(1, 3.0, 1.0);
        assert!(mb < -88.0, "{mb}");
        // Far from any sample the variance grows back towards the prior.
        let far = g.interpolate(0, 5.0, 18.0).1;
        assert!(far > 5.0 * v, "{far}");
        let dir = std::env::temp_dir().join(format!("atrium-wifi-graph-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("g.json");
        g.save(&path).unwrap();
        let back = WifiGraph::load(&path).unwrap();
        assert!(back == g, "the loaded graph differs from the saved one");
        // The binary form is lossless, and anything but a whole graph is refused.
        let bytes = g.to_bytes();
        let back = WifiGraph::from_bytes(&bytes).unwrap();
        assert!(back == g, "the binary form differs");
        assert!(back
            .mean
            .iter()
            .zip(&g.mean)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        for cut in [0, 1, 8, bytes.len() / 2, bytes.len() - 1] {
            assert!(
                WifiGraph::from_bytes(&bytes[..cut]).is_none(),
                "cut at {cut}"
            );
        }
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(WifiGraph::from_bytes(&longer).is_none());
        std::fs::write(&path, "{\"format\": 3}").unwrap();
        assert!(WifiGraph::load(&path).unwrap_err().contains("g.json"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn graph_sizes_above_the_limit_are_refused_before_learning() {
        let p = |spacing: f64| WifiGraphParams {
            node_spacing: spacing,
            ..WifiGraphParams::default()
        };
        let (lo, hi) = ([0.0, 0.0], [60.0, 40.0]);
        let e = p(1e-6).check_graph_size(lo, hi, 10).unwrap_err();
        assert!(
            e.starts_with("node_spacing: 0.000001 m over the 60 m × 40 m area (10 access points)")
                && e.contains("nodes, more than the limit of 1000000"),
            "{e}"
        );
        // The spacing the message suggests fits; a little finer does not.
        let finest: f64 = e
            .rsplit_once("at least ")
            .unwrap()
            .1
            .trim_end_matches(" m")
            .parse()
            .unwrap();
        assert!(
            p(finest).check_graph_size(lo, hi, 10).is_ok(),
            "{e} {:?}",
            p(finest).check_graph_size(lo, hi, 10)
        );
        assert!(p(0.98 * finest).check_graph_size(lo, hi, 10).is_err());
        // Learning refuses it too, before allocating the lattice.
        let scan = WifiScan {
            stamp: 0.0,
            sensor: "wifi".into(),
            readings: vec![WifiReading {
                ap: "a".into(),
                channel: 6,
                rssi_dbm: -50.0,
            }],
        };
        let e = WifiGraph::learn(&[([1.0, 1.0], &scan)], lo, hi, &p(1e-6), &|_| true)
            .unwrap_err()
            .to_string();
        assert!(e.contains("WIFI_GRAPH_MAX_VALUES"), "{e}");
        let hyper = WifiGraphParams {
            hyper: HyperOptions {
                block_size: usize::MAX,
                ..HyperOptions::default()
            },
            ..WifiGraphParams::default()
        };
        assert!(hyper
            .validate()
            .unwrap_err()
            .contains("hyper.block_size: 18446744073709551615 is more than the limit of 1000"));
    }
}
