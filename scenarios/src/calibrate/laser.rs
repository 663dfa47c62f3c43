//! The laser's measurement model fitted to a real log: the beam mixture of [Thrun 2005] §6.3
//! (a Gaussian hit around the range the map predicts, short readings from unmodelled
//! obstacles, max-range failures, uniform random readings) learned by EM as in §6.3.2,
//! Table 6.2 (`learn_intrinsic_parameters`), from scans taken at reference poses on the map.
//!
//! Two departures from the book, both so the simulated laser can reproduce what it is fitted
//! to: the hit's standard deviation grows linearly with the expected range
//! (σ(z*) = `sigma_hit` + `sigma_hit_per_m`·z*, as `LaserSpec` reads it), and the short
//! component is the exponential truncated at z* that the simulation draws from, so its rate
//! is the truncated maximum-likelihood one rather than the book's untruncated ratio.
//!
//! The expected range z* is cast on the occupancy grid to the face of the first occupied
//! cell, as the simulation's walls made from the same grid are met; the fitted noise is thus
//! the spread of real readings about the map's walls, which is what a simulated laser on that
//! map has to add. Where the map does not know (Unknown cells, outside the grid) a beam says
//! nothing about the sensor and is left out.

use atrium_robots::Pose2;
use atrium_worlds::{Cell, OccupancyGrid};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

/// Bootstrap resamples behind [`LaserFitUncertainty`].
pub const BOOTSTRAP_RESAMPLES: usize = 50;
/// Seed of the bootstrap's draws: the same log gives the same uncertainties.
pub const BOOTSTRAP_SEED: u64 = 0x01a5_ef17;

/// At most about this many beams go into the EM: adjacent beams of a scan (and successive
/// scans) see nearly the same wall, so thinning costs little information and keeps a long
/// log's fit, 51 EM runs with the bootstrap, to seconds.
const BEAM_BUDGET: usize = 250_000;
/// Thinning takes every k-th beam up to this stride before it skips scans: scans are the
/// bootstrap's unit, so keeping many of them keeps its resamples varied.
const MAX_BEAM_STRIDE: usize = 4;
/// Fewer beams than this cannot pin down four weights and three shape parameters.
const MIN_BEAMS: usize = 100;
/// The hit's σ at range 0 is kept above this, m: with every hit exact the likelihood would
/// grow without bound as σ → 0.
const SIGMA_FLOOR: f64 = 1e-4;
/// Bounds of the short rate, 1/m: outside them the truncated exponential is a step or flat.
const LAMBDA_MIN: f64 = 1e-3;
const LAMBDA_MAX: f64 = 1e3;
/// A z* shorter than this (the laser against a wall cell) leaves nothing to fit, m.
const MIN_EXPECTED_RANGE: f64 = 1e-3;
const EM_MAX_ITERATIONS: usize = 500;
/// Inner steps per M-step for σ(z*) and λ_short, which have no closed form: EM only needs
/// each M-step to improve the likelihood (generalized EM), and warm starts make a few enough.
const INNER_STEPS: usize = 3;

/// Edges of the expected-range bins of [`LaserFit::no_return_by_range`], m; `range_max`
/// closes the last bin.
const RANGE_BIN_EDGES: [f64; 5] = [0.0, 2.0, 4.0, 8.0, 16.0];
/// Edges of the incidence-angle bins of [`LaserFit::no_return_by_incidence`], degrees.
const INCIDENCE_BIN_EDGES_DEG: [f64; 7] = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0];

/// One scan of a log with the laser's pose on the map.
#[derive(Debug, Clone, Copy)]
pub struct ScanAtPose<'a> {
    /// The laser's pose in the map frame (the base's reference pose composed with the mount).
    pub pose: Pose2,
    /// Direction of beam 0 in the laser frame, rad.
    pub angle_min: f64,
    /// Angle between successive beams, rad.
    pub angle_increment: f64,
    /// Ranges, m, as `LaserScan::ranges` holds them: beams with no return read `range_max`
    /// or more.
    pub ranges: &'a [f64],
}

/// The no-return rate of the beams in one bin.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RateBin {
    pub lo: f64,
    pub hi: f64,
    /// Fraction of the bin's beams that read `range_max` or more; NaN when it holds none.
    pub rate: f64,
    pub beams: usize,
}

/// Standard errors of [`LaserFit`]'s scalars: the spread of the fit over
/// [`BOOTSTRAP_RESAMPLES`] resamples of the scans (whole scans, since a scan's beams err
/// together: a person in view shortens many of them at once). A parameter held at a bound
/// (`lambda_short` at 0.001 /m, `sigma_hit_per_m` at 0) in every resample shows 0: the bound
/// holds it, not the data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LaserFitUncertainty {
    pub sigma_hit: f64,
    pub sigma_hit_per_m: f64,
    pub p_short: f64,
    pub lambda_short: f64,
    pub p_max: f64,
    pub p_rand: f64,
    pub hit_bias: f64,
    pub resamples: usize,
    pub seed: u64,
}

/// The fitted mixture, in `LaserSpec`'s terms (the hit's weight is what the others leave).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LaserFit {
    /// σ of the hit at range 0, m.
    pub sigma_hit: f64,
    /// Growth of the hit's σ with the expected range, m per m.
    pub sigma_hit_per_m: f64,
    /// Weight of short readings, and their exponential's rate, 1/m.
    pub p_short: f64,
    pub lambda_short: f64,
    /// Fraction of beams with no return (read as `range_max`) where the map predicts a wall
    /// within range.
    pub p_max: f64,
    /// Weight of uniform random readings over [0, `range_max`).
    pub p_rand: f64,
    /// Mean of z − z* over the hits (responsibility-weighted), m. The model (and the
    /// simulation) centre hits on z*; an offset here is a map or mount error the σ above has
    /// absorbed (σ² grows by its square).
    pub hit_bias: f64,
    /// No-return rate per expected-range bin (0–2, 2–4, 4–8, 8–16, 16–`range_max` m, cut at
    /// `range_max`).
    pub no_return_by_range: Vec<RateBin>,
    /// No-return rate per incidence-angle bin (the angle between the beam and the wall's
    /// normal, 0–90° in steps of 15°).
    pub no_return_by_incidence: Vec<RateBin>,
    pub uncertainty: LaserFitUncertainty,
    /// Scans and beams that went into the fit after thinning.
    pub scans_used: usize,
    pub beams_used: usize,
}

/// Where a beam meets the map's walls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridHit {
    /// Distance from the ray's origin to the face of the first occupied cell, m.
    pub range: f64,
    /// That cell, (i, j) as [`OccupancyGrid::index`] takes them.
    pub cell: (usize, usize),
    /// The unit normal of the face the ray entered through, pointing back at the ray.
    pub face_normal: [f64; 2],
}

/// Casts a ray on the grid by Amanatides–Woo traversal (every cell the ray crosses, in
/// order) and returns the first occupied cell within `max_range`. `None` when the ray meets
/// an Unknown cell or leaves the grid first (the map cannot say what is there), when nothing
/// is within `max_range`, or when the origin itself is not in a free cell.
pub fn cast_ray(
    grid: &OccupancyGrid,
    origin: [f64; 2],
    angle: f64,
    max_range: f64,
) -> Option<GridHit> {
    let (i0, j0) = grid.world_to_cell(origin)?;
    if grid.cells.get(grid.index(i0, j0)) != Some(&Cell::Free) {
        return None;
    }
    let (s, c) = angle.sin_cos();
    let res = grid.resolution;
    let (w, h) = (grid.width as i64, grid.height as i64);
    let (mut i, mut j) = (i0 as i64, j0 as i64);
    let step_i: i64 = if c >= 0.0 { 1 } else { -1 };
    let step_j: i64 = if s >= 0.0 { 1 } else { -1 };
    // Distance along the ray to the next grid line of each family, and between them.
    let first_line = |cell: i64, step: i64, o: f64, p: f64, d: f64| {
        if d == 0.0 {
            return f64::INFINITY;
        }
        let line = o + (cell + i64::from(step > 0)) as f64 * res;
        (line - p) / d
    };
    let mut t_i = first_line(i, step_i, grid.origin[0], origin[0], c);
    let mut t_j = first_line(j, step_j, grid.origin[1], origin[1], s);
    let dt_i = if c == 0.0 {
        f64::INFINITY
    } else {
        res / c.abs()
    };
    let dt_j = if s == 0.0 {
        f64::INFINITY
    } else {
        res / s.abs()
    };
    loop {
        let (t, normal) = if t_i < t_j {
            i += step_i;
            let t = t_i;
            t_i += dt_i;
            (t, [-step_i as f64, 0.0])
        } else {
            j += step_j;
            let t = t_j;
            t_j += dt_j;
            (t, [0.0, -step_j as f64])
        };
        if t > max_range || !t.is_finite() || i < 0 || j < 0 || i >= w || j >= h {
            return None;
        }
        let (iu, ju) = (i as usize, j as usize);
        match grid.cells[grid.index(iu, ju)] {
            Cell::Free => {}
            Cell::Unknown => return None,
            Cell::Occupied => {
                return Some(GridHit {
                    range: t.max(0.0),
                    cell: (iu, ju),
                    face_normal: normal,
                })
            }
        }
    }
}

/// The wall's normal at an occupied cell from the line through the occupied cells within two
/// cells of it (principal axis of their spread); `None` where they make no line (a corner, a
/// filled block, a lone cell).
fn wall_normal(grid: &OccupancyGrid, (ci, cj): (usize, usize)) -> Option<[f64; 2]> {
    let mut pts: [(f64, f64); 25] = [(0.0, 0.0); 25];
    let mut n = 0;
    for dj in -2i64..=2 {
        for di in -2i64..=2 {
            let (i, j) = (ci as i64 + di, cj as i64 + dj);
            if i < 0 || j < 0 || i >= grid.width as i64 || j >= grid.height as i64 {
                continue;
            }
            if grid.cells[grid.index(i as usize, j as usize)] == Cell::Occupied {
                pts[n] = (di as f64, dj as f64);
                n += 1;
            }
        }
    }
    if n < 3 {
        return None;
    }
    let pts = &pts[..n];
    let nf = n as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / nf;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / nf;
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for (x, y) in pts {
        sxx += (x - mx) * (x - mx);
        syy += (y - my) * (y - my);
        sxy += (x - mx) * (y - my);
    }
    let half_diff = 0.5 * (sxx - syy);
    let root = (half_diff * half_diff + sxy * sxy).sqrt();
    let mean = 0.5 * (sxx + syy);
    let (major, minor) = (mean + root, mean - root);
    // A line's cells spread far more along it than across it; half as much across is a
    // blob or a corner, whose "normal" would be a guess.
    if major <= 0.0 || minor > 0.5 * major {
        return None;
    }
    let along = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    Some([-along.sin(), along.cos()])
}

/// The angle between a beam along `angle` and the wall it meets, from the wall's normal
/// ([`wall_normal`], else the face the beam entered), degrees in [0, 90].
fn incidence_deg(grid: &OccupancyGrid, hit: &GridHit, angle: f64) -> f64 {
    let n = wall_normal(grid, hit.cell).unwrap_or(hit.face_normal);
    let (s, c) = angle.sin_cos();
    (c * n[0] + s * n[1]).abs().min(1.0).acos().to_degrees()
}

/// One beam that takes part in the fit.
#[derive(Debug, Clone, Copy)]
struct Beam {
    /// Index of its scan among the scans used (the bootstrap's unit).
    scan: usize,
    z: f64,
    z_star: f64,
    no_return: bool,
}

/// The mixture's parameters while EM runs.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Mixture {
    p_hit: f64,
    p_short: f64,
    p_max: f64,
    p_rand: f64,
    sigma0: f64,
    sigma_per_m: f64,
    lambda: f64,
    hit_bias: f64,
}

impl Mixture {
    fn close_to(&self, o: &Mixture) -> bool {
        let p = [
            self.p_hit - o.p_hit,
            self.p_short - o.p_short,
            self.p_max - o.p_max,
            self.p_rand - o.p_rand,
        ];
        p.iter().all(|d| d.abs() < 1e-7)
            && (self.sigma0 - o.sigma0).abs() < 1e-7
            && (self.sigma_per_m - o.sigma_per_m).abs() < 1e-8
            && (self.lambda - o.lambda).abs() < 1e-5 * self.lambda
    }
}

const INV_SQRT_2PI: f64 = 0.398_942_280_401_432_7;

/// EM for the mixture over `beams`, each weighted by its scan's entry in `scan_weight` (1
/// for the fit, the draw counts for a bootstrap resample), from `start`. `resp` is scratch
/// for the responsibilities of the hit and short components.
fn em(
    beams: &[Beam],
    scan_weight: &[f64],
    range_max: f64,
    start: Mixture,
    resp: &mut Vec<[f64; 2]>,
) -> Mixture {
    resp.clear();
    resp.resize(beams.len(), [0.0, 0.0]);
    let mut m = start;
    let p_rand_density = 1.0 / range_max;
    for _ in 0..EM_MAX_ITERATIONS {
        // E-step. A reading at range_max is the max component's alone: the book's hit,
        // short and random densities all vanish there (Table 6.2 with its indicator).
        let (mut w_all, mut w_max, mut w_hit, mut w_short, mut w_rand) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (b, r) in beams.iter().zip(resp.iter_mut()) {
            let w = scan_weight[b.scan];
            w_all += w;
            if b.no_return {
                w_max += w;
                *r = [0.0, 0.0];
                continue;
            }
            if w == 0.0 {
                *r = [0.0, 0.0];
                continue;
            }
            let sigma = m.sigma0 + m.sigma_per_m * b.z_star;
            let e = (b.z - b.z_star) / sigma;
            let hit = m.p_hit * INV_SQRT_2PI / sigma * (-0.5 * e * e).exp();
            let short = if b.z <= b.z_star {
                m.p_short * m.lambda * (-m.lambda * b.z).exp() / -(-m.lambda * b.z_star).exp_m1()
            } else {
                0.0
            };
            let rand = m.p_rand * p_rand_density;
            let total = hit + short + rand;
            *r = if total > 0.0 && total.is_finite() {
                [hit / total, short / total]
            } else {
                // Nothing explains it (a weight fitted to 0): the random component takes it.
                [0.0, 0.0]
            };
            w_hit += w * r[0];
            w_short += w * r[1];
            w_rand += w * (1.0 - r[0] - r[1]);
        }
        if w_all <= 0.0 {
            return m;
        }
        // M-step: the weights are the responsibilities' shares (Table 6.2).
        let mut next = Mixture {
            p_hit: w_hit / w_all,
            p_short: w_short / w_all,
            p_max: w_max / w_all,
            p_rand: w_rand / w_all,
            ..m
        };
        if w_hit > 0.0 {
            (next.sigma0, next.sigma_per_m) =
                fit_sigma(beams, scan_weight, resp, m.sigma0, m.sigma_per_m);
            let bias: f64 = beams
                .iter()
                .zip(resp.iter())
                .map(|(b, r)| scan_weight[b.scan] * r[0] * (b.z - b.z_star))
                .sum();
            next.hit_bias = bias / w_hit;
        }
        if w_short > 0.0 {
            next.lambda = fit_lambda(beams, scan_weight, resp, m.lambda);
        }
        let done = next.close_to(&m);
        m = next;
        if done {
            break;
        }
    }
    m
}

/// The hit's σ(z*) = a + b·z* by weighted maximum likelihood (weights: scan weight times the
/// hit responsibility), a few Fisher-scoring steps from (a, b). Scoring a variance model is
/// iteratively reweighted least squares of the squared residuals against σ(z*)², weighted by
/// 1/σ⁴; steps are halved until a stays above the floor and b non-negative.
fn fit_sigma(
    beams: &[Beam],
    scan_weight: &[f64],
    resp: &[[f64; 2]],
    a0: f64,
    b0: f64,
) -> (f64, f64) {
    let (mut a, mut b) = (a0, b0);
    for _ in 0..INNER_STEPS {
        let (mut s0, mut s1, mut i00, mut i01, mut i11) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let (mut we_sum, mut we_r2) = (0.0, 0.0);
        for (bm, r) in beams.iter().zip(resp) {
            let we = scan_weight[bm.scan] * r[0];
            if we == 0.0 {
                continue;
            }
            let sigma = a + b * bm.z_star;
            let r2 = (bm.z - bm.z_star) * (bm.z - bm.z_star);
            let s2 = sigma * sigma;
            let g = we * (r2 - s2) / (s2 * sigma);
            let h = 2.0 * we / s2;
            s0 += g;
            s1 += g * bm.z_star;
            i00 += h;
            i01 += h * bm.z_star;
            i11 += h * bm.z_star * bm.z_star;
            we_sum += we;
            we_r2 += we * r2;
        }
        if we_sum <= 0.0 {
            break;
        }
        let det = i00 * i11 - i01 * i01;
        // All hits at one z*: the growth is not identifiable, so σ is one constant.
        let (da, db) = if det > 1e-12 * i00 * i11 {
            ((i11 * s0 - i01 * s1) / det, (i00 * s1 - i01 * s0) / det)
        } else {
            (s0 / i00, -b)
        };
        let mut t = 1.0;
        while t > 1e-6 && !(a + t * da >= SIGMA_FLOOR && b + t * db >= 0.0) {
            t *= 0.5;
        }
        if t > 1e-6 {
            (a, b) = (a + t * da, b + t * db);
        } else {
            // Pinned at the boundary: the best constant σ.
            (a, b) = ((we_r2 / we_sum).sqrt().max(SIGMA_FLOOR), 0.0);
        }
    }
    (a, b)
}

/// The short exponential's rate λ by weighted maximum likelihood of the exponential
/// truncated at each beam's z* (a few Newton steps from `lambda0`; its log-likelihood is
/// concave in λ, the truncated exponential being an exponential family).
fn fit_lambda(beams: &[Beam], scan_weight: &[f64], resp: &[[f64; 2]], lambda0: f64) -> f64 {
    let mut lambda = lambda0.clamp(LAMBDA_MIN, LAMBDA_MAX);
    for _ in 0..INNER_STEPS {
        let (mut d1, mut d2) = (0.0, 0.0);
        for (bm, r) in beams.iter().zip(resp) {
            let we = scan_weight[bm.scan] * r[1];
            if we == 0.0 {
                continue;
            }
            let x = lambda * bm.z_star;
            // d/dλ of −ln(1 − e^{−λz*}) and its derivative, written to survive large λz*.
            let sh = (0.5 * x).sinh();
            d1 += we * (1.0 / lambda - bm.z - bm.z_star / x.exp_m1());
            d2 += we * (-1.0 / (lambda * lambda) + bm.z_star * bm.z_star / (4.0 * sh * sh));
        }
        let next = if d2 < 0.0 { lambda - d1 / d2 } else { f64::NAN };
        lambda = if next.is_finite() && next > 0.0 {
            next
        } else if d1 > 0.0 {
            2.0 * lambda
        } else {
            0.5 * lambda
        }
        .clamp(LAMBDA_MIN, LAMBDA_MAX);
    }
    lambda
}

fn check_grid(grid: &OccupancyGrid) -> Result<(), String> {
    if !(grid.resolution.is_finite() && grid.resolution > 0.0) {
        return Err(format!(
            "the grid's resolution must be finite and > 0 (got {})",
            grid.resolution
        ));
    }
    if !(grid.origin[0].is_finite() && grid.origin[1].is_finite()) {
        return Err(format!(
            "the grid's origin must be finite (got {:?})",
            grid.origin
        ));
    }
    if grid.width == 0 || grid.height == 0 || grid.cells.len() != grid.width * grid.height {
        return Err(format!(
            "the grid holds {} cells for {} × {}",
            grid.cells.len(),
            grid.width,
            grid.height
        ));
    }
    if !grid.cells.contains(&Cell::Occupied) {
        return Err("the grid has no occupied cell: no wall to fit against".into());
    }
    Ok(())
}

fn check_scan(k: usize, s: &ScanAtPose) -> Result<(), String> {
    if !s.pose.is_finite() {
        return Err(format!(
            "scan {k}: the laser pose is not finite ({:?})",
            s.pose
        ));
    }
    if !(s.angle_min.is_finite() && s.angle_increment.is_finite()) {
        return Err(format!(
            "scan {k}: angle_min {} and angle_increment {} must be finite",
            s.angle_min, s.angle_increment
        ));
    }
    if let Some((i, r)) = s
        .ranges
        .iter()
        .enumerate()
        .find(|(_, r)| r.is_nan() || **r < 0.0)
    {
        return Err(format!(
            "scan {k}: beam {i} reads {r} (ranges must be >= 0; no return reads range_max)"
        ));
    }
    Ok(())
}

/// No-return rates of `(bin value, no return)` pairs over bins with the given edges.
fn rate_bins(edges: &[f64], items: impl Iterator<Item = (f64, bool)>) -> Vec<RateBin> {
    let mut counts = vec![(0usize, 0usize); edges.len() - 1];
    for (v, no_return) in items {
        // The top edge belongs to the last bin (z* = range_max, incidence 90°).
        let k = edges[1..]
            .partition_point(|e| *e <= v)
            .min(counts.len() - 1);
        counts[k].0 += 1;
        counts[k].1 += usize::from(no_return);
    }
    counts
        .iter()
        .zip(edges.windows(2))
        .map(|(&(beams, none), e)| RateBin {
            lo: e[0],
            hi: e[1],
            rate: if beams == 0 {
                f64::NAN
            } else {
                none as f64 / beams as f64
            },
            beams,
        })
        .collect()
}

/// Sample standard deviation of `f` over the resampled fits.
fn spread(fits: &[Mixture], f: impl Fn(&Mixture) -> f64) -> f64 {
    // Every resample at one value (a bound) has no spread; the mean's rounding would make one.
    if fits.iter().all(|m| f(m) == f(&fits[0])) {
        return 0.0;
    }
    let n = fits.len() as f64;
    let mean = fits.iter().map(&f).sum::<f64>() / n;
    (fits.iter().map(|m| (f(m) - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt()
}

/// Fits the laser's mixture to `scans` taken at known poses on `grid` ([Thrun 2005] §6.3.2,
/// Table 6.2, with σ growing with range; see the module's notes). Long logs are thinned to
/// about 250,000 beams (every 4th beam of every k-th scan). Errors name the problem: no scans,
/// a scan with a non-finite pose or a NaN range, an unusable grid or `range_max`, too few
/// beams that meet a known wall within `range_max`.
pub fn fit_laser(
    grid: &OccupancyGrid,
    scans: &[ScanAtPose],
    range_max: f64,
) -> Result<LaserFit, String> {
    if scans.is_empty() {
        return Err("no scans to fit the laser to".into());
    }
    if !(range_max.is_finite() && range_max > 0.0) {
        return Err(format!(
            "range_max must be finite and > 0 (got {range_max})"
        ));
    }
    check_grid(grid)?;
    for (k, s) in scans.iter().enumerate() {
        check_scan(k, s)?;
    }

    let total: usize = scans.iter().map(|s| s.ranges.len()).sum();
    let thin = total.div_ceil(BEAM_BUDGET).max(1);
    let beam_stride = thin.min(MAX_BEAM_STRIDE);
    let scan_stride = thin.div_ceil(beam_stride);

    let mut beams: Vec<Beam> = Vec::new();
    let mut by_range: Vec<(f64, bool)> = Vec::new();
    let mut by_incidence: Vec<(f64, bool)> = Vec::new();
    let mut scans_used = 0;
    for s in scans.iter().step_by(scan_stride) {
        let before = beams.len();
        for (i, &z) in s.ranges.iter().enumerate().step_by(beam_stride) {
            let angle = s.pose.theta + s.angle_min + i as f64 * s.angle_increment;
            let Some(hit) = cast_ray(grid, [s.pose.x, s.pose.y], angle, range_max) else {
                continue;
            };
            let no_return = z >= range_max;
            by_range.push((hit.range, no_return));
            by_incidence.push((incidence_deg(grid, &hit, angle), no_return));
            if hit.range >= MIN_EXPECTED_RANGE {
                beams.push(Beam {
                    scan: scans_used,
                    z: z.min(range_max),
                    z_star: hit.range,
                    no_return,
                });
            }
        }
        if beams.len() > before {
            scans_used += 1;
        }
    }
    if beams.len() < MIN_BEAMS {
        return Err(format!(
            "only {} beams (of {total}, every {beam_stride}th beam of every {scan_stride}th \
             scan) meet a wall the map knows within range_max = {range_max} m; at least \
             {MIN_BEAMS} are needed (are the poses in the map's frame, on free cells?)",
            beams.len()
        ));
    }

    // Without returns the hit's σ and the short and random weights have nothing to be fitted
    // to: EM would report its starting values as a fit (a log of no-returns only, or ranges
    // in other units than range_max).
    let returns = beams.iter().filter(|b| !b.no_return).count();
    if returns < MIN_BEAMS {
        return Err(format!(
            "only {returns} of the {} beams that meet a wall the map knows return a range \
             below range_max = {range_max} m; at least {MIN_BEAMS} are needed to fit the \
             laser (do the scans hold ranges in metres, is range_max the laser's?)",
            beams.len()
        ));
    }
    // Start the hit from a robust spread of the residuals (MAD), the rest from small
    // weights: EM only finds the optimum near where it starts.
    let mut residuals: Vec<f64> = beams
        .iter()
        .filter(|b| !b.no_return)
        .map(|b| (b.z - b.z_star).abs())
        .collect();
    let mad = if residuals.is_empty() {
        0.05
    } else {
        let mid = residuals.len() / 2;
        *residuals.select_nth_unstable_by(mid, f64::total_cmp).1
    };
    let start = Mixture {
        p_hit: 0.85,
        p_short: 0.05,
        p_max: 0.05,
        p_rand: 0.05,
        sigma0: (1.4826 * mad).max(SIGMA_FLOOR),
        sigma_per_m: 0.0,
        lambda: 1.0,
        hit_bias: 0.0,
    };
    let mut resp = Vec::new();
    let ones = vec![1.0; scans_used];
    let fit = em(&beams, &ones, range_max, start, &mut resp);

    let mut rng = ChaCha8Rng::seed_from_u64(BOOTSTRAP_SEED);
    let mut weights = vec![0.0; scans_used];
    let mut fits = Vec::with_capacity(BOOTSTRAP_RESAMPLES);
    for _ in 0..BOOTSTRAP_RESAMPLES {
        weights.iter_mut().for_each(|w| *w = 0.0);
        for _ in 0..scans_used {
            weights[rng.random_range(0..scans_used)] += 1.0;
        }
        fits.push(em(&beams, &weights, range_max, fit, &mut resp));
    }

    let mut range_edges: Vec<f64> = RANGE_BIN_EDGES
        .iter()
        .copied()
        .filter(|e| *e < range_max)
        .collect();
    range_edges.push(range_max);
    Ok(LaserFit {
        sigma_hit: fit.sigma0,
        sigma_hit_per_m: fit.sigma_per_m,
        p_short: fit.p_short,
        lambda_short: fit.lambda,
        p_max: fit.p_max,
        p_rand: fit.p_rand,
        hit_bias: fit.hit_bias,
        no_return_by_range: rate_bins(&range_edges, by_range.into_iter()),
        no_return_by_incidence: rate_bins(&INCIDENCE_BIN_EDGES_DEG, by_incidence.into_iter()),
        uncertainty: LaserFitUncertainty {
            sigma_hit: spread(&fits, |m| m.sigma0),
            sigma_hit_per_m: spread(&fits, |m| m.sigma_per_m),
            p_short: spread(&fits, |m| m.p_short),
            lambda_short: spread(&fits, |m| m.lambda),
            p_max: spread(&fits, |m| m.p_max),
            p_rand: spread(&fits, |m| m.p_rand),
            hit_bias: spread(&fits, |m| m.hit_bias),
            resamples: BOOTSTRAP_RESAMPLES,
            seed: BOOTSTRAP_SEED,
        },
        scans_used,
        beams_used: beams.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid of `w` × `h` cells of 5 cm from `origin`, every cell `fill`.
    fn grid(w: usize, h: usize, origin: [f64; 2], fill: Cell) -> OccupancyGrid {
        OccupancyGrid {
            origin,
            resolution: 0.05,
            width: w,
            height: h,
            cells: vec![fill; w * h],
        }
    }

    fn set(g: &mut OccupancyGrid, is: std::ops::Range<usize>, js: std::ops::Range<usize>, c: Cell) {
        for j in js {
            for i in is.clone() {
                let k = g.index(i, j);
                g.cells[k] = c;
            }
        }
    }

    /// A 12 m square room (inner faces at ±5.9 m) with 10 cm walls, a 1 m pillar at
    /// (2.5, 2.5) and nothing known outside.
    fn room() -> OccupancyGrid {
        let mut g = grid(260, 260, [-6.5, -6.5], Cell::Unknown);
        set(&mut g, 10..250, 10..250, Cell::Occupied);
        set(&mut g, 12..248, 12..248, Cell::Free);
        set(&mut g, 170..190, 170..190, Cell::Occupied);
        g
    }

    #[test]
    fn rays_meet_the_face_of_the_first_wall_cell() {
        // 2 m × 2 m of 5 cm cells from (0, 0); a wall in column 30 (x in [1.5, 1.55)).
        let mut g = grid(40, 40, [0.0, 0.0], Cell::Free);
        set(&mut g, 30..31, 0..40, Cell::Occupied);
        let hit = cast_ray(&g, [0.55, 1.05], 0.0, 8.0).unwrap();
        assert!((hit.range - 0.95).abs() < 1e-9, "{hit:?}");
        assert_eq!((hit.cell, hit.face_normal), ((30, 21), [-1.0, 0.0]));
        // 60° off the wall's normal the beam goes twice as far: 0.95 / cos 60° = 1.9 m.
        let a = 60f64.to_radians();
        let hit = cast_ray(&g, [0.55, 0.05], a, 8.0).unwrap();
        assert!((hit.range - 1.9).abs() < 1e-9, "{hit:?}");
        assert!((incidence_deg(&g, &hit, a) - 60.0).abs() < 1e-9);
        // Beyond max_range, or off the grid's far side: nothing.
        assert_eq!(cast_ray(&g, [0.55, 1.05], 0.0, 0.9), None);
        assert_eq!(cast_ray(&g, [0.55, 1.05], std::f64::consts::PI, 8.0), None);
        // Straight up the free column it leaves the grid: nothing.
        assert_eq!(
            cast_ray(&g, [0.55, 1.05], std::f64::consts::FRAC_PI_2, 8.0),
            None
        );
        // An Unknown cell before the wall stops the beam: the map does not know.
        set(&mut g, 20..21, 20..22, Cell::Unknown);
        assert_eq!(cast_ray(&g, [0.55, 1.05], 0.0, 8.0), None);
        // A laser inside a wall cell, or off the grid, casts nothing.
        assert_eq!(cast_ray(&g, [1.52, 0.5], std::f64::consts::PI, 8.0), None);
        assert_eq!(cast_ray(&g, [-1.0, 0.5], 0.0, 8.0), None);
        // Horizontal wall along y = 1.5 (row 30): the normal is ±y.
        let mut g = grid(40, 40, [0.0, 0.0], Cell::Free);
        set(&mut g, 0..40, 30..32, Cell::Occupied);
        let a = 20f64.to_radians();
        let hit = cast_ray(&g, [0.5, 0.5], std::f64::consts::FRAC_PI_2 - a, 8.0).unwrap();
        assert!((hit.range - 1.0 / a.cos()).abs() < 1e-9, "{hit:?}");
        let n = wall_normal(&g, hit.cell).unwrap();
        assert!(
            n[0].abs() < 1e-12 && (n[1].abs() - 1.0).abs() < 1e-12,
            "{n:?}"
        );
        assert!((incidence_deg(&g, &hit, std::f64::consts::FRAC_PI_2 - a) - 20.0).abs() < 1e-9);
    }

    /// Draws a reading as the simulated laser does (sim's `apply_noise`).
    fn draw(m: &Mixture, zt: f64, range_max: f64, rng: &mut ChaCha8Rng) -> f64 {
        let u: f64 = rng.random();
        let r = if u < m.p_short {
            let v: f64 = rng.random();
            -(1.0 - v * -(-m.lambda * zt).exp_m1()).ln() / m.lambda
        } else if u < m.p_short + m.p_max {
            range_max
        } else if u < m.p_short + m.p_max + m.p_rand {
            rng.random_range(0.0..range_max)
        } else {
            // Box–Muller: a normal draw without a distribution crate.
            let (u1, u2): (f64, f64) = (rng.random(), rng.random());
            let n = (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
            zt + (m.sigma0 + m.sigma_per_m * zt) * n
        };
        r.clamp(0.0, range_max)
    }

    #[test]
    fn em_recovers_a_known_mixture_in_a_square_room() {
        let g = room();
        let range_max = 20.0;
        let truth = Mixture {
            p_hit: 0.90,
            p_short: 0.05,
            p_max: 0.03,
            p_rand: 0.02,
            sigma0: 0.01,
            sigma_per_m: 0.005,
            lambda: 1.0,
            hit_bias: 0.0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let beams = 360;
        let inc = std::f64::consts::TAU / beams as f64;
        let mut poses = Vec::new();
        while poses.len() < 200 {
            let p = Pose2::new(
                rng.random_range(-5.5..5.5),
                rng.random_range(-5.5..5.5),
                rng.random_range(-3.0..3.0),
            );
            if g.at([p.x, p.y]) == Cell::Free {
                poses.push(p);
            }
        }
        let ranges: Vec<Vec<f64>> = poses
            .iter()
            .map(|p| {
                (0..beams)
                    .map(|i| {
                        let a = p.theta - std::f64::consts::PI + i as f64 * inc;
                        let zt = cast_ray(&g, [p.x, p.y], a, range_max).unwrap().range;
                        draw(&truth, zt, range_max, &mut rng)
                    })
                    .collect()
            })
            .collect();
        let scans: Vec<ScanAtPose> = poses
            .iter()
            .zip(&ranges)
            .map(|(p, r)| ScanAtPose {
                pose: *p,
                angle_min: -std::f64::consts::PI,
                angle_increment: inc,
                ranges: r,
            })
            .collect();
        let fit = fit_laser(&g, &scans, range_max).unwrap();
        let u = &fit.uncertainty;
        println!("{fit:#?}");
        assert_eq!((fit.scans_used, fit.beams_used), (200, 72_000));
        // Tolerances: a few bootstrap standard errors at this sample size (72,000 beams).
        let close = |name: &str, got: f64, want: f64, tol: f64, se: f64| {
            assert!(
                (got - want).abs() <= tol,
                "{name}: fitted {got}, true {want}, tolerance {tol}"
            );
            assert!(se > 0.0 && se < tol, "{name}: standard error {se} vs {tol}");
        };
        close("sigma_hit", fit.sigma_hit, 0.01, 0.001, u.sigma_hit);
        close(
            "sigma_hit_per_m",
            fit.sigma_hit_per_m,
            0.005,
            0.0003,
            u.sigma_hit_per_m,
        );
        close("p_short", fit.p_short, 0.05, 0.005, u.p_short);
        close("lambda_short", fit.lambda_short, 1.0, 0.1, u.lambda_short);
        close("p_max", fit.p_max, 0.03, 0.003, u.p_max);
        close("p_rand", fit.p_rand, 0.02, 0.003, u.p_rand);
        assert!(fit.hit_bias.abs() < 0.0005, "{}", fit.hit_bias);
        // Every beam meets a wall within 20 m, and only the max component reads 20 m, so
        // every bin's no-return rate is p_max.
        let ranges: Vec<(f64, f64)> = fit
            .no_return_by_range
            .iter()
            .map(|b| (b.lo, b.hi))
            .collect();
        assert_eq!(
            ranges,
            [
                (0.0, 2.0),
                (2.0, 4.0),
                (4.0, 8.0),
                (8.0, 16.0),
                (16.0, 20.0)
            ]
        );
        for bin in fit
            .no_return_by_range
            .iter()
            .chain(&fit.no_return_by_incidence)
        {
            if bin.beams > 2000 {
                assert!((bin.rate - 0.03).abs() < 0.01, "{bin:?}");
            }
        }
        let binned: usize = fit.no_return_by_incidence.iter().map(|b| b.beams).sum();
        assert_eq!(binned, 72_000);
        assert_eq!(fit.no_return_by_range[4].beams, 0);
        assert!(fit.no_return_by_range[4].rate.is_nan());
        // Same input, same fit (the bootstrap is seeded); Debug, as NaN != NaN.
        let again = fit_laser(&g, &scans, range_max).unwrap();
        assert_eq!(format!("{again:?}"), format!("{fit:?}"));
    }

    #[test]
    fn bad_input_is_named_not_a_panic() {
        let g = room();
        let ranges = vec![3.0; 360];
        let scan = |pose| ScanAtPose {
            pose,
            angle_min: 0.0,
            angle_increment: 0.01,
            ranges: &ranges,
        };
        let e = fit_laser(&g, &[], 20.0).unwrap_err();
        assert!(e.contains("no scans"), "{e}");
        let good = scan(Pose2::new(0.0, 0.0, 0.0));
        let nan = scan(Pose2::new(f64::NAN, 0.0, 0.0));
        let e = fit_laser(&g, &[good, nan], 20.0).unwrap_err();
        assert!(e.starts_with("scan 1: the laser pose is not finite"), "{e}");
        let e = fit_laser(&g, &[good], f64::NAN).unwrap_err();
        assert!(e.contains("range_max"), "{e}");
        let bad_ranges = [1.0, f64::NAN];
        let e = fit_laser(
            &g,
            &[ScanAtPose {
                ranges: &bad_ranges,
                ..good
            }],
            20.0,
        )
        .unwrap_err();
        assert!(e.contains("scan 0: beam 1 reads NaN"), "{e}");
        // Poses off the map: no beam meets a known wall.
        let e = fit_laser(&g, &[scan(Pose2::new(100.0, 0.0, 0.0))], 20.0).unwrap_err();
        assert!(e.contains("only 0 beams"), "{e}");
        let mut broken = g.clone();
        broken.cells.pop();
        let e = fit_laser(&broken, &[good], 20.0).unwrap_err();
        assert!(e.contains("cells"), "{e}");
        let blank = grid(10, 10, [0.0, 0.0], Cell::Free);
        let e = fit_laser(&blank, &[good], 20.0).unwrap_err();
        assert!(e.contains("no occupied cell"), "{e}");
        // Every beam a no-return: nothing to fit the hit to.
        let far = vec![20.0; 360];
        let none = ScanAtPose {
            ranges: &far,
            ..good
        };
        let e = fit_laser(&g, &[none], 20.0).unwrap_err();
        assert!(e.contains("only 0 of the"), "{e}");
    }

    /// The fit on Freiburg 079's real log and map, printed (`cargo test --release -p
    /// atrium-scenarios fr079_fit_report -- --ignored --nocapture`). A second fit takes the
    /// reference pose itself as the laser's: the residuals' dependence on the beam's angle
    /// says which of the two the reference and map were made with.
    #[test]
    #[ignore = "reads the 1,061 s fr079 log; run by hand for the numbers"]
    fn fr079_fit_report() {
        use crate::log::{LogTable, RealLog};
        use std::path::Path;
        use std::time::Instant;

        let started = Instant::now();
        let file = Path::new("../scenarios/fr079_real.toml");
        let text = std::fs::read_to_string(file).unwrap();
        let mut scenario: toml::Table = text.parse().unwrap();
        let table: LogTable = scenario.remove("log").unwrap().try_into().unwrap();
        let log = RealLog::load(file, &table, None).unwrap();
        let grid = atrium_formats::ros_map::read_map(Path::new("../datasets/fr079/fr079_map.yaml"))
            .unwrap();
        println!(
            "fr079: {} scans of {} beams, range {}..{} m, mount {:?} ({}); loaded in {:.2?}",
            log.scans.len(),
            log.laser.beams,
            log.laser.range_min,
            log.laser.range_max,
            log.mount,
            log.mount_source,
            started.elapsed()
        );
        for (label, mount) in [
            ("laser = reference ⊕ mount", true),
            ("laser = reference", false),
        ] {
            let scans: Vec<ScanAtPose> = log
                .scans
                .iter()
                .filter_map(|s| {
                    let base = log.reference_at(s.stamp)?;
                    Some(ScanAtPose {
                        pose: if mount { base.compose(&s.mount) } else { base },
                        angle_min: s.angle_min,
                        angle_increment: s.angle_increment,
                        ranges: &s.ranges,
                    })
                })
                .collect();
            let t = Instant::now();
            let fit = fit_laser(&grid, &scans, log.laser.range_max).unwrap();
            let took = t.elapsed();
            println!("\n{label}: {} scans with a reference pose", scans.len());
            println!("{}", serde_json::to_string_pretty(&fit).unwrap());
            println!("fit in {took:.2?} (one core)");
        }
    }
}
