//! Mixture weights of the fused localizer (issue 9, beyond [004] §4): given
//! samples t with p_{k,t}, member k's likelihood of the true position at t, the weights w on
//! the simplex maximising Σ_t log Σ_k w_k p_{k,t}. The objective is concave, so this is a
//! convex program; it is solved with clarabel's interior point method on exponential cones:
//!
//!   minimise −(1/T) Σ_t u_t  over (w, u)
//!   subject to Σ_k w_k = 1 (zero cone), w ≥ 0 (non-negative cone),
//!              (u_t, 1, Σ_k p_{k,t} w_k) ∈ K_exp for every t, i.e. u_t ≤ log Σ_k p_{k,t} w_k.
//!
//! Each sample's likelihoods are first divided by their largest value: that adds a constant
//! to the objective (same optimum) and keeps the cone data near 1; with raw likelihoods of
//! 1e-20 the solver reports success at a wrong vertex (CRATE-NOTES, clarabel 0.11).
//! [`mixture_weights_em`] is the classic EM fixed point for the same problem, kept as the
//! reference the tests compare against.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};

/// Why mixture weights could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MixtureError {
    #[error("no samples with a positive likelihood")]
    Empty,
    #[error("sample {sample} has {got} likelihoods, expected {expected}")]
    Ragged {
        sample: usize,
        got: usize,
        expected: usize,
    },
    #[error("sample {sample}: likelihood {value} of component {component} is not finite and >= 0")]
    Invalid {
        sample: usize,
        component: usize,
        value: f64,
    },
    #[error("the convex solver failed: {0}")]
    Solver(String),
}

/// Checks the table and returns each usable sample scaled by its largest likelihood (samples
/// where every likelihood is 0 carry no information on w and are dropped).
fn scaled(p: &[Vec<f64>]) -> Result<(usize, Vec<Vec<f64>>), MixtureError> {
    let k = p.first().map(Vec::len).ok_or(MixtureError::Empty)?;
    if k == 0 {
        return Err(MixtureError::Empty);
    }
    let mut out = Vec::with_capacity(p.len());
    for (t, row) in p.iter().enumerate() {
        if row.len() != k {
            return Err(MixtureError::Ragged {
                sample: t,
                got: row.len(),
                expected: k,
            });
        }
        if let Some((c, v)) = row
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            return Err(MixtureError::Invalid {
                sample: t,
                component: c,
                value: *v,
            });
        }
        let max = row.iter().copied().fold(0.0, f64::max);
        if max > 0.0 {
            out.push(row.iter().map(|v| v / max).collect());
        }
    }
    if out.is_empty() {
        return Err(MixtureError::Empty);
    }
    Ok((k, out))
}

/// Maximum-likelihood mixture weights: `p[t][k]` is component k's likelihood of sample t.
/// Returns w (w ≥ 0, Σ w = 1) maximising Σ_t log Σ_k w_k p[t][k], by the exponential-cone
/// program of the module documentation. A single component gets weight 1 without solving.
pub fn mixture_weights(p: &[Vec<f64>]) -> Result<Vec<f64>, MixtureError> {
    let (k, q) = scaled(p)?;
    if k == 1 {
        return Ok(vec![1.0]);
    }
    let t_n = q.len();
    let n = k + t_n;
    let m = 1 + k + 3 * t_n;
    // A, column by column (CSC). Rows: 0 the simplex equality; 1..=k the non-negativity of
    // w; then per sample t the three rows of its exponential cone, at 1 + k + 3t.
    let mut colptr = Vec::with_capacity(n + 1);
    let mut rowval = Vec::with_capacity(k * (2 + t_n) + t_n);
    let mut nzval = Vec::with_capacity(rowval.capacity());
    for c in 0..k {
        colptr.push(rowval.len());
        rowval.push(0);
        nzval.push(1.0);
        rowval.push(1 + c);
        nzval.push(-1.0);
        for (t, row) in q.iter().enumerate() {
            if row[c] != 0.0 {
                rowval.push(1 + k + 3 * t + 2);
                nzval.push(-row[c]);
            }
        }
    }
    for t in 0..t_n {
        colptr.push(rowval.len());
        rowval.push(1 + k + 3 * t);
        nzval.push(-1.0);
    }
    colptr.push(rowval.len());
    let a = CscMatrix::new(m, n, colptr, rowval, nzval);
    let mut b = vec![0.0; m];
    b[0] = 1.0;
    for t in 0..t_n {
        b[1 + k + 3 * t + 1] = 1.0;
    }
    // The mean, not the sum, of the u_t: with the sum's cost vector (entries of 1 over a
    // thousand samples) clarabel 0.11 stalls (InsufficientProgress) on real training data
    // whose optimum lies on an edge of the simplex; the mean solves it in ~25 iterations.
    let mut q_obj = vec![0.0; n];
    q_obj[k..].fill(-1.0 / t_n as f64);
    let p_mat = CscMatrix::zeros((n, n));
    let mut cones = Vec::with_capacity(2 + t_n);
    cones.push(SupportedConeT::ZeroConeT(1));
    cones.push(SupportedConeT::NonnegativeConeT(k));
    cones.extend(std::iter::repeat_n(SupportedConeT::ExponentialConeT(), t_n));
    let settings = DefaultSettings {
        verbose: false,
        ..DefaultSettings::default()
    };
    let mut solver = DefaultSolver::new(&p_mat, &q_obj, &a, &b, &cones, settings)
        .map_err(|e| MixtureError::Solver(e.to_string()))?;
    solver.solve();
    let status = solver.solution.status;
    if !matches!(status, SolverStatus::Solved | SolverStatus::AlmostSolved) {
        return Err(MixtureError::Solver(format!("status {status:?}")));
    }
    // Interior-point iterates sit a hair inside the cone: clip and renormalise.
    let mut w: Vec<f64> = solver.solution.x[..k].iter().map(|v| v.max(0.0)).collect();
    let sum: f64 = w.iter().sum();
    if !(sum.is_finite() && sum > 0.0) {
        return Err(MixtureError::Solver(format!("degenerate weights {w:?}")));
    }
    for v in &mut w {
        *v /= sum;
    }
    Ok(w)
}

/// The same optimum by expectation–maximisation (Dempster, Laird & Rubin 1977: with fixed
/// components the M-step is w_k ← mean over t of the responsibilities), from uniform
/// weights, for `iterations` steps. Slow to converge near the boundary of the simplex.
pub fn mixture_weights_em(p: &[Vec<f64>], iterations: usize) -> Result<Vec<f64>, MixtureError> {
    let (k, q) = scaled(p)?;
    let mut w = vec![1.0 / k as f64; k];
    let mut next = vec![0.0; k];
    for _ in 0..iterations {
        next.fill(0.0);
        for row in &q {
            let mix: f64 = row.iter().zip(&w).map(|(p, w)| p * w).sum();
            if mix > 0.0 {
                for c in 0..k {
                    next[c] += w[c] * row[c] / mix;
                }
            }
        }
        let total: f64 = next.iter().sum();
        for c in 0..k {
            w[c] = next[c] / total;
        }
    }
    Ok(w)
}

/// Σ_t log Σ_k w_k p[t][k] (samples with all-zero likelihoods skipped, as the solvers do).
pub fn log_likelihood(p: &[Vec<f64>], w: &[f64]) -> f64 {
    p.iter()
        .map(|row| row.iter().zip(w).map(|(p, w)| p * w).sum::<f64>())
        .filter(|m| *m > 0.0)
        .map(f64::ln)
        .sum()
}

/// Log density at `p` of the Gaussian over (x, y) of an estimate, its xy covariance floored:
/// eigenvalues below `floor_m`² are raised to it, so that an overconfident member (a lost
/// laser filter reporting centimetres) still gives a finite, if tiny, density far from its
/// mean, and a member whose covariance is zero does not give an infinite one at its mean.
pub fn log_density_xy(
    mean: [f64; 2],
    cov: &nalgebra::Matrix3<f64>,
    floor_m: f64,
    p: [f64; 2],
) -> f64 {
    let (a, b, c) = (cov[(0, 0)], 0.5 * (cov[(0, 1)] + cov[(1, 0)]), cov[(1, 1)]);
    let f2 = floor_m * floor_m;
    // Eigen-decomposition of the symmetric 2 × 2 [[a, b], [b, c]].
    let half_tr = 0.5 * (a + c);
    let disc = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let (l1, l2) = (half_tr + disc, half_tr - disc);
    let (v1x, v1y) = if b.abs() > 1e-15 {
        let n = (l1 - c).hypot(b);
        ((l1 - c) / n, b / n)
    } else if a >= c {
        (1.0, 0.0)
    } else {
        (0.0, 1.0)
    };
    let (e1, e2) = (
        if l1.is_finite() {
            l1.max(f2)
        } else {
            f64::INFINITY
        },
        if l2.is_finite() {
            l2.max(f2)
        } else {
            f64::INFINITY
        },
    );
    let (dx, dy) = (p[0] - mean[0], p[1] - mean[1]);
    // Components along the eigenvectors (v1, v2 = v1 rotated by 90°).
    let u1 = dx * v1x + dy * v1y;
    let u2 = -dx * v1y + dy * v1x;
    -0.5 * (u1 * u1 / e1 + u2 * u2 / e2) - 0.5 * (e1 * e2).ln() - (2.0 * std::f64::consts::PI).ln()
}

/// The mixture of one area: a weight and a covariance floor (m) per component. The floor
/// calibrates a component that reports centimetres while it is metres off: learnt as the
/// component's RMS error over the area's training samples, so an overconfident member is as
/// wide as it is wrong there.
#[derive(Debug, Clone, PartialEq)]
pub struct MixtureGroup {
    pub weights: Vec<f64>,
    pub floors_m: Vec<f64>,
}

/// Mixture weights per area of the world: the group of the first polygon containing a point,
/// `default` elsewhere.
#[derive(Debug, Clone, PartialEq)]
pub struct RegionMixture {
    pub regions: Vec<(Vec<[f64; 2]>, MixtureGroup)>,
    pub default: MixtureGroup,
}

impl RegionMixture {
    pub fn group_at(&self, p: [f64; 2]) -> &MixtureGroup {
        self.regions
            .iter()
            .find(|(poly, _)| atrium_worlds::geometry::point_in_polygon(p, poly))
            .map_or(&self.default, |(_, g)| g)
    }

    /// Number of components; every group must have a weight and a floor for each.
    pub fn components(&self) -> usize {
        self.default.weights.len()
    }

    /// Whether every group has `k` weights and `k` positive, finite floors.
    pub fn is_consistent(&self, k: usize) -> bool {
        std::iter::once(&self.default)
            .chain(self.regions.iter().map(|(_, g)| g))
            .all(|g| {
                g.weights.len() == k
                    && g.floors_m.len() == k
                    && g.floors_m.iter().all(|f| f.is_finite() && *f > 0.0)
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn disjoint_supports_give_the_sample_fractions() {
        // Closed form: where only one component explains each sample, the optimum is the
        // fraction of samples each explains (here 1/4, 3/4, 0 for a never-best component).
        let mut p = Vec::new();
        for t in 0..40 {
            if t % 4 == 0 {
                p.push(vec![2.0, 0.0, 0.0]);
            } else {
                p.push(vec![0.0, 0.5, 0.0]);
            }
        }
        let w = mixture_weights(&p).unwrap();
        assert!((w[0] - 0.25).abs() < 1e-5, "{w:?}");
        assert!((w[1] - 0.75).abs() < 1e-5, "{w:?}");
        assert!(w[2].abs() < 1e-5, "{w:?}");
    }

    #[test]
    fn one_dominant_component_takes_all_the_weight() {
        // Component 1 has the higher likelihood at every sample: the objective increases
        // monotonically toward its vertex, so w = (0, 1, 0), even with likelihoods of 1e-20
        // (the scaling keeps the solver on the right vertex).
        let p: Vec<Vec<f64>> = (0..50)
            .map(|t| {
                let s = 1e-20 * (1.0 + (t % 7) as f64);
                vec![0.3 * s, s, 0.1 * s]
            })
            .collect();
        let w = mixture_weights(&p).unwrap();
        assert!((w[1] - 1.0).abs() < 1e-5, "{w:?}");
    }

    #[test]
    fn matches_em_on_overlapping_components() {
        // Two 1-D Gaussians at 0 and 3 (σ = 1) and a wide one; data from 0.3·N(0) + 0.7·N(3).
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let dens = |x: f64, mu: f64, s: f64| {
            (-0.5 * ((x - mu) / s).powi(2)).exp() / (s * (2.0 * std::f64::consts::PI).sqrt())
        };
        let mut p = Vec::new();
        for _ in 0..600 {
            let u: f64 = rng.random();
            let z: f64 = rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng);
            let x = if u < 0.3 { z } else { 3.0 + z };
            p.push(vec![
                dens(x, 0.0, 1.0),
                dens(x, 3.0, 1.0),
                dens(x, 1.5, 5.0),
            ]);
        }
        let w = mixture_weights(&p).unwrap();
        let em = mixture_weights_em(&p, 20_000).unwrap();
        for c in 0..3 {
            assert!((w[c] - em[c]).abs() < 2e-3, "{w:?} vs EM {em:?}");
        }
        // The solver's optimum is at least as good as EM's.
        assert!(log_likelihood(&p, &w) >= log_likelihood(&p, &em) - 1e-6);
        assert!(
            (w[0] - 0.3).abs() < 0.1 && (w[1] - 0.7).abs() < 0.1,
            "{w:?}"
        );
    }

    #[test]
    fn floored_density_is_hand_computed() {
        let cov = nalgebra::Matrix3::new(4.0, 0.0, 0.0, 0.0, 1e-8, 0.0, 0.0, 0.0, 1.0);
        // σx = 2, σy floored to 0.5: at (2, 0.5) from the mean, each axis is one σ away.
        let l = log_density_xy([1.0, 1.0], &cov, 0.5, [3.0, 1.5]);
        let expect = -1.0 - (2.0f64 * 0.5).ln() - (2.0 * std::f64::consts::PI).ln();
        assert!((l - expect).abs() < 1e-12, "{l} vs {expect}");
        // A rotated covariance: variance 5 along (1, 1)/√2, 1 across.
        let (s, d) = (3.0, 2.0);
        let cov = nalgebra::Matrix3::new(s, d, 0.0, d, s, 0.0, 0.0, 0.0, 1.0);
        let l = log_density_xy([0.0, 0.0], &cov, 0.1, [1.0, 1.0]);
        let expect = -0.5 * 2.0 / 5.0 - 0.5 * 5.0f64.ln() - (2.0 * std::f64::consts::PI).ln();
        assert!((l - expect).abs() < 1e-12, "{l} vs {expect}");
    }

    #[test]
    fn bad_tables_are_errors() {
        assert_eq!(mixture_weights(&[]), Err(MixtureError::Empty));
        assert_eq!(mixture_weights(&[vec![0.0, 0.0]]), Err(MixtureError::Empty));
        assert!(matches!(
            mixture_weights(&[vec![1.0, 2.0], vec![1.0]]),
            Err(MixtureError::Ragged { sample: 1, .. })
        ));
        assert!(matches!(
            mixture_weights(&[vec![1.0, f64::NAN]]),
            Err(MixtureError::Invalid { component: 1, .. })
        ));
        assert_eq!(mixture_weights(&[vec![0.2], vec![0.4]]), Ok(vec![1.0]));
    }
}
