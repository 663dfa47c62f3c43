//! Gaussian-process regression in the plane with a squared-exponential kernel, for the WiFi
//! graph of [004] §2.3 (RSSI mean and variance learnt from samples
//! collected while driving; the GP formulation follows Rasmussen & Williams, *Gaussian
//! Processes for Machine Learning*, 2006, Algorithm 2.1 and eq. 2.30).
//!
//! Model: y_i = m + f(x_i) + ε_i, f ~ GP(0, σ_f² exp(−|x − x'|²/(2ℓ²))), ε_i ~ N(0, σ_n²/c_i)
//! where c_i ≥ 1 is the number of raw samples a data point stands for (see [`bin_samples`]);
//! with c_i = 1 this is the textbook model. The constant prior mean m is the data's mean.
//!
//! Scale: the exact GP costs O(n³); the WiFi graph must learn from over 100,000 samples per
//! access point. [`LocalGp`] is the approximation used there, in two steps:
//!
//! 1. **Binning.** Samples are grouped into square bins of side `bin_m` (0.25 m by default);
//!    a bin becomes one data point at its samples' mean position with their mean value and
//!    noise variance σ_n²/c. This is exact when a bin's samples share one position; otherwise
//!    it moves each sample by at most the bin's diagonal (0.35 m, about a tenth of the
//!    fitted length scales of 3–6 m), which changes the kernel by at most a few percent.
//! 2. **Local conditioning.** The posterior at a point conditions only on its K nearest bins
//!    (K = 64 by default) instead of all of them. Under the SE kernel, distant data are
//!    screened by the near data, so their weights are negligible.
//!
//! Hyperparameters (ℓ, σ_f, σ_n) maximise the log marginal likelihood (R&W eq. 2.30) of a
//! block-diagonal approximation: B blocks of the M nearest bins around B seeded random
//! centres, each block's exact likelihood summed (the blocks keep the short-range structure
//! that identifies ℓ and σ_n), by Nelder–Mead in log space.
//! The test `local_gp_matches_the_exact_gp` checks the whole approximation against the exact
//! GP on 1,200 samples: mean within 0.5 dB and variance within 10 %.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Squared-exponential kernel plus noise.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SeKernel {
    /// ℓ, m.
    pub length_scale: f64,
    /// σ_f, same unit as the values (dB).
    pub signal_sd: f64,
    /// σ_n of one raw sample.
    pub noise_sd: f64,
}

impl SeKernel {
    #[inline]
    pub fn k(&self, d2: f64) -> f64 {
        self.signal_sd
            * self.signal_sd
            * (-0.5 * d2 / (self.length_scale * self.length_scale)).exp()
    }

    fn noise_var(&self) -> f64 {
        self.noise_sd * self.noise_sd
    }
}

#[inline]
fn d2(a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
    dx * dx + dy * dy
}

/// In-place Cholesky of the symmetric positive-definite n×n row-major `a` (lower triangle
/// read and overwritten with L; the upper triangle is left as it was). False if not SPD.
///
/// Row by row (left-looking): L_jj = √(a_jj − Σ_k L_jk²), L_ij = (a_ij − Σ_k L_ik L_jk) / L_jj,
/// each sum over k = 0..j in increasing order. The dot products of four rows i are computed
/// together (four independent dependency chains instead of one), each in that same order,
/// so the result is bit-identical to the textbook loop.
fn cholesky(a: &mut [f64], n: usize) -> bool {
    assert!(a.len() >= n * n);
    for j in 0..n {
        let (head, tail) = a[..n * n].split_at_mut((j + 1) * n);
        let row_j = &mut head[j * n..];
        let mut s = row_j[j];
        for &x in &row_j[..j] {
            s -= x * x;
        }
        // Also false for NaN.
        if s.is_nan() || s <= 0.0 {
            return false;
        }
        let d = s.sqrt();
        row_j[j] = d;
        let lj = &row_j[..j];
        let mut quads = tail.chunks_exact_mut(4 * n);
        for quad in &mut quads {
            let (r0, rest) = quad.split_at_mut(n);
            let (r1, rest) = rest.split_at_mut(n);
            let (r2, r3) = rest.split_at_mut(n);
            let (mut s0, mut s1, mut s2, mut s3) = (r0[j], r1[j], r2[j], r3[j]);
            for ((((&x, &y0), &y1), &y2), &y3) in lj
                .iter()
                .zip(&r0[..j])
                .zip(&r1[..j])
                .zip(&r2[..j])
                .zip(&r3[..j])
            {
                s0 -= y0 * x;
                s1 -= y1 * x;
                s2 -= y2 * x;
                s3 -= y3 * x;
            }
            (r0[j], r1[j], r2[j], r3[j]) = (s0 / d, s1 / d, s2 / d, s3 / d);
        }
        for r in quads.into_remainder().chunks_exact_mut(n) {
            let mut s = r[j];
            for (&y, &x) in r[..j].iter().zip(lj) {
                s -= y * x;
            }
            r[j] = s / d;
        }
    }
    true
}

/// Solves L z = b in place (L lower, from [`cholesky`]).
fn forward(l: &[f64], n: usize, b: &mut [f64]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * n + k] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
}

/// Solves Lᵀ z = b in place.
fn backward(l: &[f64], n: usize, b: &mut [f64]) {
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k * n + i] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
}

/// K + diag(σ_n²/c) over `idx` into `a` (n×n).
fn gram(kernel: &SeKernel, points: &[[f64; 2]], counts: &[f64], idx: &[usize], a: &mut Vec<f64>) {
    let n = idx.len();
    a.clear();
    a.resize(n * n, 0.0);
    let nv = kernel.noise_var();
    for (r, &i) in idx.iter().enumerate() {
        for (c, &j) in idx.iter().enumerate().take(r) {
            let v = kernel.k(d2(points[i], points[j]));
            a[r * n + c] = v;
            a[c * n + r] = v;
        }
        a[r * n + r] = kernel.k(0.0) + nv / counts[i];
    }
}

/// The exact GP posterior (R&W Algorithm 2.1).
#[derive(Debug, Clone)]
pub struct ExactGp {
    kernel: SeKernel,
    mean: f64,
    points: Vec<[f64; 2]>,
    l: Vec<f64>,
    alpha: Vec<f64>,
}

impl ExactGp {
    /// Conditions on every point; `counts` as in the module docs (1 for raw samples). None
    /// if the Gram matrix is not positive definite.
    pub fn fit(
        points: &[[f64; 2]],
        values: &[f64],
        counts: &[f64],
        kernel: SeKernel,
        mean: f64,
    ) -> Option<ExactGp> {
        let n = points.len();
        let idx: Vec<usize> = (0..n).collect();
        let mut l = Vec::new();
        gram(&kernel, points, counts, &idx, &mut l);
        if !cholesky(&mut l, n) {
            return None;
        }
        let mut alpha: Vec<f64> = values.iter().map(|v| v - mean).collect();
        forward(&l, n, &mut alpha);
        backward(&l, n, &mut alpha);
        Some(ExactGp {
            kernel,
            mean,
            points: points.to_vec(),
            l,
            alpha,
        })
    }

    /// Posterior mean and variance of f (without the noise) at `q`.
    pub fn predict(&self, q: [f64; 2]) -> (f64, f64) {
        let n = self.points.len();
        let mut v: Vec<f64> = self
            .points
            .iter()
            .map(|p| self.kernel.k(d2(*p, q)))
            .collect();
        let mu = self.mean + v.iter().zip(&self.alpha).map(|(a, b)| a * b).sum::<f64>();
        forward(&self.l, n, &mut v);
        let var = self.kernel.k(0.0) - v.iter().map(|x| x * x).sum::<f64>();
        (mu, var.max(0.0))
    }
}

/// log p(y | X, θ) of the points `idx` (R&W eq. 2.30), or None if not positive definite.
/// `a` and `b` are scratch buffers.
#[allow(clippy::too_many_arguments)]
fn log_marginal_likelihood(
    kernel: &SeKernel,
    points: &[[f64; 2]],
    values: &[f64],
    counts: &[f64],
    mean: f64,
    idx: &[usize],
    a: &mut Vec<f64>,
    b: &mut Vec<f64>,
) -> Option<f64> {
    let n = idx.len();
    gram(kernel, points, counts, idx, a);
    if !cholesky(a, n) {
        return None;
    }
    b.clear();
    b.extend(idx.iter().map(|&i| values[i] - mean));
    forward(a, n, b);
    let quad: f64 = b.iter().map(|x| x * x).sum();
    let logdet: f64 = (0..n).map(|i| a[i * n + i].ln()).sum();
    Some(-0.5 * quad - logdet - 0.5 * n as f64 * (2.0 * std::f64::consts::PI).ln())
}

/// How hyperparameters are fitted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct HyperOptions {
    /// Number of blocks B. Default 4.
    pub blocks: usize,
    /// Points per block M. Default 150.
    pub block_size: usize,
    /// Nelder–Mead iterations. Default 120.
    pub iterations: usize,
    /// Seed of the block centres.
    pub seed: u64,
}

impl Default for HyperOptions {
    fn default() -> Self {
        Self {
            blocks: 4,
            block_size: 150,
            iterations: 120,
            seed: 0,
        }
    }
}

/// Bounds of the search, so a degenerate data set cannot drive the kernel to 0 or ∞.
const LENGTH_RANGE: (f64, f64) = (0.3, 50.0);
const SIGNAL_RANGE: (f64, f64) = (0.1, 60.0);
const NOISE_RANGE: (f64, f64) = (0.2, 30.0);

fn kernel_from(theta: [f64; 3]) -> SeKernel {
    let c = |v: f64, r: (f64, f64)| v.exp().clamp(r.0, r.1);
    SeKernel {
        length_scale: c(theta[0], LENGTH_RANGE),
        signal_sd: c(theta[1], SIGNAL_RANGE),
        noise_sd: c(theta[2], NOISE_RANGE),
    }
}

/// Maximises the block log marginal likelihood (see the module docs) starting from `init`.
/// With no more points than one block holds, the blocks are the whole data set (exact).
pub fn fit_hyperparameters(
    points: &[[f64; 2]],
    values: &[f64],
    counts: &[f64],
    mean: f64,
    init: SeKernel,
    opts: &HyperOptions,
) -> SeKernel {
    let n = points.len();
    if n < 3 {
        return init;
    }
    let blocks: Vec<Vec<usize>> = if n <= opts.block_size.max(1) {
        vec![(0..n).collect()]
    } else {
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
        let index = SpatialIndex::new(points, 1.0);
        let mut scratch = Vec::new();
        (0..opts.blocks.max(1))
            .map(|_| {
                let c = points[rng.random_range(0..n)];
                let mut out = Vec::new();
                index.nearest(points, c, opts.block_size, &mut out, &mut scratch);
                out
            })
            .collect()
    };
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let mut cost = |theta: [f64; 3]| -> f64 {
        let k = kernel_from(theta);
        let mut total = 0.0;
        for blk in &blocks {
            match log_marginal_likelihood(&k, points, values, counts, mean, blk, &mut a, &mut b) {
                Some(l) => total -= l,
                None => return f64::INFINITY,
            }
        }
        total
    };
    let start = [
        init.length_scale.ln(),
        init.signal_sd.ln(),
        init.noise_sd.ln(),
    ];
    let best = nelder_mead(&mut cost, start, 0.5, opts.iterations);
    kernel_from(best)
}

/// Nelder–Mead simplex minimisation in 3 dimensions (standard coefficients 1, 2, ½, ½).
fn nelder_mead(
    f: &mut dyn FnMut([f64; 3]) -> f64,
    x0: [f64; 3],
    step: f64,
    iters: usize,
) -> [f64; 3] {
    let mut simplex: Vec<([f64; 3], f64)> = Vec::with_capacity(4);
    simplex.push((x0, f(x0)));
    for k in 0..3 {
        let mut x = x0;
        x[k] += step;
        simplex.push((x, f(x)));
    }
    let lerp = |a: [f64; 3], b: [f64; 3], t: f64| -> [f64; 3] {
        [
            a[0] + t * (b[0] - a[0]),
            a[1] + t * (b[1] - a[1]),
            a[2] + t * (b[2] - a[2]),
        ]
    };
    for _ in 0..iters {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        if (simplex[3].1 - simplex[0].1).abs() < 1e-6 * (1.0 + simplex[0].1.abs()) {
            break;
        }
        let mut c = [0.0; 3];
        for (x, _) in &simplex[..3] {
            for k in 0..3 {
                c[k] += x[k] / 3.0;
            }
        }
        let worst = simplex[3];
        let xr = lerp(c, worst.0, -1.0);
        let fr = f(xr);
        if fr < simplex[0].1 {
            let xe = lerp(c, worst.0, -2.0);
            let fe = f(xe);
            simplex[3] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[2].1 {
            simplex[3] = (xr, fr);
        } else {
            let xc = lerp(c, worst.0, 0.5);
            let fc = f(xc);
            if fc < worst.1 {
                simplex[3] = (xc, fc);
            } else {
                let best = simplex[0].0;
                for s in simplex.iter_mut().skip(1) {
                    let x = lerp(best, s.0, 0.5);
                    *s = (x, f(x));
                }
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex[0].0
}

/// Samples grouped into square bins: position (mean of the members), count, and for each
/// raw sample the bin it went to.
#[derive(Debug, Clone, PartialEq)]
pub struct Bins {
    pub points: Vec<[f64; 2]>,
    pub counts: Vec<f64>,
    pub assignment: Vec<usize>,
}

/// Groups samples into bins of side `bin_m` (bins in order of first appearance, so the
/// result does not depend on hashing).
pub fn bin_samples(points: &[[f64; 2]], bin_m: f64) -> Bins {
    let mut map: std::collections::HashMap<(i64, i64), usize> = std::collections::HashMap::new();
    let mut sums: Vec<[f64; 2]> = Vec::new();
    let mut counts: Vec<f64> = Vec::new();
    let mut assignment = Vec::with_capacity(points.len());
    for p in points {
        let key = ((p[0] / bin_m).floor() as i64, (p[1] / bin_m).floor() as i64);
        let b = *map.entry(key).or_insert_with(|| {
            sums.push([0.0; 2]);
            counts.push(0.0);
            sums.len() - 1
        });
        sums[b][0] += p[0];
        sums[b][1] += p[1];
        counts[b] += 1.0;
        assignment.push(b);
    }
    let points = sums
        .iter()
        .zip(&counts)
        .map(|(s, c)| [s[0] / c, s[1] / c])
        .collect();
    Bins {
        points,
        counts,
        assignment,
    }
}

/// Mean value per bin of one series of raw values.
pub fn bin_values(bins: &Bins, values: &[f64]) -> Vec<f64> {
    let mut sums = vec![0.0; bins.counts.len()];
    for (&b, v) in bins.assignment.iter().zip(values) {
        sums[b] += v;
    }
    sums.iter().zip(&bins.counts).map(|(s, c)| s / c).collect()
}

/// A uniform grid over points for nearest-neighbour queries.
#[derive(Debug, Clone)]
pub struct SpatialIndex {
    origin: [f64; 2],
    cell: f64,
    width: usize,
    height: usize,
    /// Point indices sorted by cell; `starts[c]..starts[c + 1]` are cell c's.
    order: Vec<usize>,
    starts: Vec<usize>,
}

impl SpatialIndex {
    pub fn new(points: &[[f64; 2]], cell: f64) -> SpatialIndex {
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for p in points {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if points.is_empty() {
            lo = [0.0; 2];
            hi = [0.0; 2];
        }
        let width = (((hi[0] - lo[0]) / cell).floor() as usize) + 1;
        let height = (((hi[1] - lo[1]) / cell).floor() as usize) + 1;
        let cell_of = |p: &[f64; 2]| {
            let i = (((p[0] - lo[0]) / cell) as usize).min(width - 1);
            let j = (((p[1] - lo[1]) / cell) as usize).min(height - 1);
            j * width + i
        };
        let mut counts = vec![0usize; width * height + 1];
        for p in points {
            counts[cell_of(p) + 1] += 1;
        }
        for c in 1..counts.len() {
            counts[c] += counts[c - 1];
        }
        let starts = counts.clone();
        let mut fill = counts;
        let mut order = vec![0; points.len()];
        for (i, p) in points.iter().enumerate() {
            let c = cell_of(p);
            order[fill[c]] = i;
            fill[c] += 1;
        }
        SpatialIndex {
            origin: lo,
            cell,
            width,
            height,
            order,
            starts,
        }
    }

    /// The `k` points nearest to `q` (fewer if there are fewer), nearest first, into `out`.
    /// Rings of cells are scanned outwards until the k-th distance is certainly final.
    pub fn nearest(
        &self,
        points: &[[f64; 2]],
        q: [f64; 2],
        k: usize,
        out: &mut Vec<usize>,
        scratch: &mut Vec<(f64, usize)>,
    ) {
        out.clear();
        scratch.clear();
        if points.is_empty() || k == 0 {
            return;
        }
        let qi = ((q[0] - self.origin[0]) / self.cell).floor() as i64;
        let qj = ((q[1] - self.origin[1]) / self.cell).floor() as i64;
        let (w, h) = (self.width as i64, self.height as i64);
        // The farthest ring that can hold a cell of the grid.
        let max_ring = [qi, w - 1 - qi, qj, h - 1 - qj]
            .iter()
            .map(|v| v.unsigned_abs() as i64)
            .max()
            .unwrap_or(0)
            + 1;
        let mut ring = 0i64;
        loop {
            for j in qj - ring..=qj + ring {
                if j < 0 || j >= h {
                    continue;
                }
                let edge_row = j == qj - ring || j == qj + ring;
                let mut i = qi - ring;
                while i <= qi + ring {
                    if i >= 0 && i < w {
                        let c = (j * w + i) as usize;
                        for &p in &self.order[self.starts[c]..self.starts[c + 1]] {
                            scratch.push((d2(points[p], q), p));
                        }
                    }
                    // Inner rows only touch the ring's two side cells.
                    i += if edge_row || ring == 0 { 1 } else { 2 * ring };
                }
            }
            // Every point outside the scanned square is farther than `ring` cells.
            let safe = ring as f64 * self.cell;
            if scratch.len() >= k {
                let kth = if scratch.len() > k {
                    scratch.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
                    scratch[k - 1].0
                } else {
                    scratch.iter().map(|s| s.0).fold(0.0, f64::max)
                };
                if kth <= safe * safe {
                    break;
                }
            }
            if ring > max_ring {
                break;
            }
            ring += 1;
        }
        scratch.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        out.extend(scratch.iter().take(k).map(|s| s.1));
    }
}

impl SpatialIndex {
    /// Octant search (as in kriging): up to `per_sector` nearest points in each of 8
    /// 45° sectors around `q`, within `radius`, into `out` (sector by sector, nearest first).
    /// Plain k-nearest would take every neighbour from the one route lane nearest to `q`
    /// and ignore the lane on its other side; sectors keep data on every side.
    pub fn nearest_by_sector(
        &self,
        points: &[[f64; 2]],
        q: [f64; 2],
        per_sector: usize,
        radius: f64,
        out: &mut Vec<usize>,
        scratch: &mut Vec<(f64, usize)>,
    ) {
        out.clear();
        scratch.clear();
        if points.is_empty() || per_sector == 0 {
            return;
        }
        let r2 = radius * radius;
        let lo_i = (((q[0] - radius - self.origin[0]) / self.cell).floor() as i64).max(0);
        let hi_i = (((q[0] + radius - self.origin[0]) / self.cell).floor() as i64)
            .min(self.width as i64 - 1);
        let lo_j = (((q[1] - radius - self.origin[1]) / self.cell).floor() as i64).max(0);
        let hi_j = (((q[1] + radius - self.origin[1]) / self.cell).floor() as i64)
            .min(self.height as i64 - 1);
        for j in lo_j..=hi_j {
            for i in lo_i..=hi_i {
                let c = (j as usize) * self.width + i as usize;
                for &p in &self.order[self.starts[c]..self.starts[c + 1]] {
                    let d = d2(points[p], q);
                    if d <= r2 {
                        scratch.push((d, p));
                    }
                }
            }
        }
        // Sector 0..8 packed into the sort key's order: sort by (sector, distance, index).
        let sector = |p: usize| -> usize {
            let a = (points[p][1] - q[1]).atan2(points[p][0] - q[0]);
            (((a + std::f64::consts::PI) / std::f64::consts::FRAC_PI_4) as usize).min(7)
        };
        scratch.sort_by(|a, b| {
            sector(a.1)
                .cmp(&sector(b.1))
                .then(a.0.total_cmp(&b.0))
                .then(a.1.cmp(&b.1))
        });
        let mut k = 0;
        while k < scratch.len() {
            let s = sector(scratch[k].1);
            let mut taken = 0;
            while k < scratch.len() && sector(scratch[k].1) == s {
                if taken < per_sector {
                    out.push(scratch[k].1);
                    taken += 1;
                }
                k += 1;
            }
        }
    }
}

/// The local GP of the module docs: a kernel and prior mean. [`LocalGp::condition`] factors
/// the system of one neighbour set once; the result then predicts at every graph node of a
/// block (so one factorisation serves several nodes, and one neighbour search serves every
/// access point whose samples share positions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LocalGp {
    pub kernel: SeKernel,
    pub mean: f64,
}

/// A local GP conditioned on one neighbour set; its buffers are reused by the next
/// [`LocalGp::condition`], so conditioning again does not allocate once they have grown.
#[derive(Debug, Default, Clone)]
pub struct LocalPosterior {
    kernel: Option<SeKernel>,
    mean: f64,
    n: usize,
    pts: Vec<[f64; 2]>,
    l: Vec<f64>,
    /// L⁻¹(y − m).
    r: Vec<f64>,
    v: Vec<f64>,
}

impl LocalGp {
    /// Conditions on the data points `idx` (bins: positions, mean values, counts) into
    /// `post`. With an empty or non-SPD set the posterior is the prior.
    pub fn condition(
        &self,
        points: &[[f64; 2]],
        values: &[f64],
        counts: &[f64],
        idx: &[usize],
        post: &mut LocalPosterior,
    ) {
        post.kernel = Some(self.kernel);
        post.mean = self.mean;
        post.n = 0;
        let n = idx.len();
        if n == 0 {
            return;
        }
        gram(&self.kernel, points, counts, idx, &mut post.l);
        if !cholesky(&mut post.l, n) {
            return;
        }
        post.pts.clear();
        post.pts.extend(idx.iter().map(|&i| points[i]));
        post.r.clear();
        post.r.extend(idx.iter().map(|&i| values[i] - self.mean));
        forward(&post.l, n, &mut post.r);
        post.n = n;
    }
}

impl LocalPosterior {
    /// Posterior mean and variance of f at `q`:
    /// μ = m + (L⁻¹k*)·(L⁻¹r), σ² = k** − |L⁻¹k*|².
    pub fn predict(&mut self, q: [f64; 2]) -> (f64, f64) {
        let Some(kernel) = self.kernel else {
            return (f64::NAN, f64::NAN);
        };
        let prior = kernel.k(0.0);
        if self.n == 0 {
            return (self.mean, prior);
        }
        self.v.clear();
        self.v.extend(self.pts.iter().map(|p| kernel.k(d2(*p, q))));
        forward(&self.l, self.n, &mut self.v);
        let mu = self.mean + self.v.iter().zip(&self.r).map(|(a, b)| a * b).sum::<f64>();
        let var = prior - self.v.iter().map(|x| x * x).sum::<f64>();
        (mu, var.max(0.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The textbook loop [`cholesky`] must reproduce bit for bit.
    fn cholesky_reference(a: &mut [f64], n: usize) -> bool {
        for j in 0..n {
            let mut s = a[j * n + j];
            for k in 0..j {
                s -= a[j * n + k] * a[j * n + k];
            }
            if s.is_nan() || s <= 0.0 {
                return false;
            }
            let d = s.sqrt();
            a[j * n + j] = d;
            for i in j + 1..n {
                let mut s = a[i * n + j];
                for k in 0..j {
                    s -= a[i * n + k] * a[j * n + k];
                }
                a[i * n + j] = s / d;
            }
        }
        true
    }

    #[test]
    fn cholesky_is_bit_identical_to_the_textbook_loop() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for n in [1usize, 2, 3, 4, 5, 7, 8, 9, 33, 150] {
            let pts: Vec<[f64; 2]> = (0..n)
                .map(|_| [rng.random_range(0.0..20.0), rng.random_range(0.0..20.0)])
                .collect();
            let counts: Vec<f64> = (0..n).map(|_| rng.random_range(1.0..5.0)).collect();
            let idx: Vec<usize> = (0..n).collect();
            let kernel = SeKernel {
                length_scale: 3.0,
                signal_sd: 8.0,
                noise_sd: 2.0,
            };
            let mut a = Vec::new();
            gram(&kernel, &pts, &counts, &idx, &mut a);
            let mut b = a.clone();
            assert!(cholesky(&mut a, n));
            assert!(cholesky_reference(&mut b, n));
            assert!(
                a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
                "n = {n}"
            );
        }
        // Not positive definite: both refuse.
        let mut a = vec![1.0, 2.0, 2.0, 1.0];
        assert!(!cholesky(&mut a, 2));
    }

    /// A smooth "RSSI-like" field: a log-distance peak plus ripples, dB.
    fn field(p: [f64; 2]) -> f64 {
        let d = ((p[0] - 3.0).powi(2) + (p[1] - 4.0).powi(2) + 4.0).sqrt();
        -40.0 - 25.0 * d.log10() + 3.0 * (0.4 * p[0]).sin() * (0.3 * p[1]).cos()
    }

    /// Samples along a lawnmower route over 20 × 12 m with Gaussian noise.
    fn route_samples(n: usize, noise: f64, seed: u64) -> (Vec<[f64; 2]>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut pts = Vec::with_capacity(n);
        let mut vals = Vec::with_capacity(n);
        let lanes = 5;
        for k in 0..n {
            let s = k as f64 / n as f64 * lanes as f64;
            let lane = s.floor();
            let u = s - lane;
            let x = if lane as i64 % 2 == 0 {
                20.0 * u
            } else {
                20.0 * (1.0 - u)
            };
            let y = 1.0 + lane * 2.5;
            let p = [
                x + 0.05 * rng.random::<f64>(),
                y + 0.05 * rng.random::<f64>(),
            ];
            let z: f64 = rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng);
            pts.push(p);
            vals.push(field(p) + noise * z);
        }
        (pts, vals)
    }

    const BLOCK_PER_SECTOR: usize = 32;

    #[test]
    fn posterior_variance_shrinks_near_samples() {
        let k = SeKernel {
            length_scale: 2.0,
            signal_sd: 5.0,
            noise_sd: 1.0,
        };
        let pts = vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
        let gp = ExactGp::fit(&pts, &[-50.0, -52.0, -51.0], &[1.0; 3], k, -60.0).unwrap();
        let (_, at) = gp.predict([0.2, 0.2]);
        let (_, near) = gp.predict([2.0, 2.0]);
        let (m_far, far) = gp.predict([30.0, 30.0]);
        assert!(at < 0.5 * 25.0, "{at}");
        assert!(at < near && near < far, "{at} {near} {far}");
        assert!((far - 25.0).abs() < 1e-9 && (m_far + 60.0).abs() < 1e-9);
        // One point, by hand: var = σ_f² − σ_f⁴/(σ_f² + σ_n²) at the point itself.
        let one = ExactGp::fit(&[[0.0, 0.0]], &[-50.0], &[1.0], k, -60.0).unwrap();
        let (m, v) = one.predict([0.0, 0.0]);
        assert!((v - (25.0 - 625.0 / 26.0)).abs() < 1e-9, "{v}");
        assert!((m - (-60.0 + 25.0 / 26.0 * 10.0)).abs() < 1e-9, "{m}");
        // Four co-located samples in one bin shrink it like four samples.
        let four = ExactGp::fit(&[[0.0, 0.0]], &[-50.0], &[4.0], k, -60.0).unwrap();
        assert!((four.predict([0.0, 0.0]).1 - (25.0 - 625.0 / 25.25)).abs() < 1e-9);
    }

    #[test]
    fn nearest_neighbours_match_brute_force() {
        let (pts, _) = route_samples(800, 0.0, 3);
        let index = SpatialIndex::new(&pts, 1.0);
        let (mut out, mut scratch) = (Vec::new(), Vec::new());
        for q in [[0.0, 0.0], [10.0, 6.0], [-5.0, 30.0], [19.9, 11.0]] {
            index.nearest(&pts, q, 37, &mut out, &mut scratch);
            let mut brute: Vec<(f64, usize)> = pts
                .iter()
                .enumerate()
                .map(|(i, p)| (d2(*p, q), i))
                .collect();
            brute.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let want: Vec<usize> = brute.iter().take(37).map(|b| b.1).collect();
            assert_eq!(out, want, "query {q:?}");
        }
    }

    #[test]
    fn hyperparameters_recover_the_generating_noise() {
        let (pts, vals) = route_samples(1500, 2.0, 7);
        let mean = vals.iter().sum::<f64>() / vals.len() as f64;
        let init = SeKernel {
            length_scale: 3.0,
            signal_sd: 5.0,
            noise_sd: 5.0,
        };
        let k = fit_hyperparameters(
            &pts,
            &vals,
            &vec![1.0; pts.len()],
            mean,
            init,
            &HyperOptions::default(),
        );
        assert!((k.noise_sd - 2.0).abs() < 0.4, "{k:?}");
        assert!(k.length_scale > 1.0 && k.length_scale < 20.0, "{k:?}");
    }

    /// The approximation of the module docs against the exact GP on 1,200 samples.
    #[test]
    fn local_gp_matches_the_exact_gp() {
        let (pts, vals) = route_samples(1200, 2.0, 11);
        let mean = vals.iter().sum::<f64>() / vals.len() as f64;
        let kernel = SeKernel {
            length_scale: 3.0,
            signal_sd: 6.0,
            noise_sd: 2.0,
        };
        let exact = ExactGp::fit(&pts, &vals, &vec![1.0; pts.len()], kernel, mean).unwrap();
        let bins = bin_samples(&pts, 0.5);
        assert!(bins.points.len() < pts.len());
        let bvals = bin_values(&bins, &vals);
        let index = SpatialIndex::new(&bins.points, 1.0);
        let local = LocalGp { kernel, mean };
        let (mut nb, mut scratch) = (Vec::new(), Vec::new());
        let mut post = LocalPosterior::default();
        let mut worst = (0.0f64, 0.0f64);
        // Graph nodes every metre over the area, between and on the lanes, and a metre
        // beyond, in blocks of 3 × 3 as the WiFi graph evaluates them.
        for bj in 0..5 {
            for bi in 0..8 {
                let c = [-1.0 + 3.0 * bi as f64 + 1.0, -1.0 + 3.0 * bj as f64 + 1.0];
                index.nearest_by_sector(
                    &bins.points,
                    c,
                    BLOCK_PER_SECTOR,
                    15.0,
                    &mut nb,
                    &mut scratch,
                );
                local.condition(&bins.points, &bvals, &bins.counts, &nb, &mut post);
                for j in 0..3 {
                    for i in 0..3 {
                        let q = [c[0] - 1.0 + i as f64, c[1] - 1.0 + j as f64];
                        if q[0] > 21.0 || q[1] < 0.0 || q[1] > 12.0 {
                            // Up to a metre beyond the data (x in [0, 20], y in [1, 11]).
                            continue;
                        }
                        let (me, ve) = exact.predict(q);
                        let (ml, vl) = post.predict(q);
                        worst.0 = worst.0.max((me - ml).abs());
                        worst.1 = worst.1.max((ve - vl).abs() / ve);
                    }
                }
            }
        }
        eprintln!(
            "local vs exact: mean {:.3} dB, variance {:.1} %",
            worst.0,
            100.0 * worst.1
        );
        assert!(worst.0 < 0.5, "mean differs by {} dB", worst.0);
        assert!(worst.1 < 0.10, "variance differs by {} %", 100.0 * worst.1);
    }
}
