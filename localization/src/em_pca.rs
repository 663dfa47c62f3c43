//! Principal components of data with missing values by Expectation-Maximization, exactly as
//! Porta, Verbeek and Kröse ([000] §V), for sparse disparity maps.
//!
//! Model (000 §V): y ~ N(0, I_d), z | y ~ N(Cᵀ y, σ² I_D), C the d × D projection matrix. The
//! E step factors q(y, z_h) = q(y) q(z_h): one covariance Σ_y = (I + σ⁻² C Cᵀ)⁻¹ shared by all
//! maps, means Y = σ⁻² Σ_y C Z with Z the data with its missing entries filled by their current
//! guesses, then the missing entries re-guessed as z_h = C_hᵀ y (variance σ²). The M step:
//! C = Z Yᵀ (N Σ_y + Y Yᵀ)⁻¹ and σ² = [N Tr{Cᵀ Σ_y C} + Σ_i ‖z_i − Cᵀ y_i‖² + D_h σ²_old] / (N D).
//! Iterate while the bound Ψ changes by more than 0.001 relative.
//!
//! Preprocessing (not in §V, where the model has no mean): the per-pixel mean of the observed
//! values is subtracted first, which is what probabilistic PCA's maximum-likelihood mean is
//! when nothing is missing, so that with complete data the subspace is the PCA subspace of
//! [`crate::pca::Pca`].
//!
//! Cost per iteration O(d D N) (four D × N × d products) and memory O(D N): no D × D matrix
//! is ever formed.

use crate::error::LocalizationError;
use crate::pca::check_training_set;
use nalgebra::{Cholesky, DMatrix, DVector};
use rand::seq::index::sample;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Fitting parameters. Defaults are the paper's (relative change 0.001).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmPcaParams {
    /// Stop when |Ψ_k − Ψ_{k−1}| / |Ψ_{k−1}| falls below this (000 §VII: 0.001).
    pub tolerance: f64,
    /// Give up after this many iterations (reported in `EmPca::converged`).
    pub max_iterations: usize,
    /// Seed for choosing the d initial maps.
    pub seed: u64,
}

impl Default for EmPcaParams {
    fn default() -> Self {
        Self {
            tolerance: 1e-3,
            max_iterations: 500,
            seed: 0,
        }
    }
}

/// A fitted EM-PCA model.
#[derive(Debug, Clone, PartialEq)]
pub struct EmPca {
    /// Per-pixel mean of the observed values (0 for a pixel never observed).
    pub mean: DVector<f64>,
    /// The d × D projection matrix C (column p: every component's weight on pixel p).
    pub c: DMatrix<f64>,
    /// Noise variance outside the principal subspace.
    pub sigma2: f64,
    /// EM iterations run.
    pub iterations: usize,
    /// Whether the relative change of Ψ fell below the tolerance.
    pub converged: bool,
    /// Ψ after every iteration (000 §V, the lower bound after the updates, up to a constant).
    pub psi: Vec<f64>,
    /// Fraction of the training entries that were missing.
    pub missing_fraction: f64,
    /// C Cᵀ, kept so that C_o C_oᵀ = C Cᵀ − C_h C_hᵀ costs O(D_h d²) for a new map.
    gram: DMatrix<f64>,
}

/// Reusable buffers for [`EmPca::project_into`], so that projecting in a loop allocates nothing.
#[derive(Debug, Clone)]
pub struct ProjectionScratch {
    m: DMatrix<f64>,
    v: DVector<f64>,
}

impl ProjectionScratch {
    pub fn new(d: usize) -> Self {
        Self {
            m: DMatrix::zeros(d, d),
            v: DVector::zeros(d),
        }
    }
}

fn is_missing(x: f32) -> bool {
    x.is_nan()
}

impl EmPca {
    /// Fits d components to `maps` (each of length D). A missing value is `f32::NAN`;
    /// infinite values are rejected, as are maps of different lengths, d ≥ N, and maps or
    /// data sets with nothing observed.
    pub fn fit(maps: &[&[f32]], d: usize, params: EmPcaParams) -> Result<EmPca, LocalizationError> {
        let dim = check_training_set("em-pca", maps, d)?;
        let n = maps.len();
        if !(params.tolerance.is_finite() && params.tolerance > 0.0) {
            return Err(LocalizationError::InvalidParameter(format!(
                "em-pca: tolerance must be finite and > 0, got {}",
                params.tolerance
            )));
        }
        if params.max_iterations == 0 {
            return Err(LocalizationError::InvalidParameter(
                "em-pca: max_iterations must be >= 1".into(),
            ));
        }
        // Per-pixel mean of observed values; validation on the way.
        let mut sum = vec![0.0f64; dim];
        let mut count = vec![0u32; dim];
        for (i, m) in maps.iter().enumerate() {
            let mut seen = 0usize;
            for (p, &x) in m.iter().enumerate() {
                if is_missing(x) {
                    continue;
                }
                if !x.is_finite() {
                    return Err(LocalizationError::InvalidParameter(format!(
                        "em-pca: map {i} has an infinite value at index {p} (missing values are NaN)"
                    )));
                }
                sum[p] += x as f64;
                count[p] += 1;
                seen += 1;
            }
            if seen == 0 {
                return Err(LocalizationError::InvalidParameter(format!(
                    "em-pca: map {i} has no observed value (all {dim} entries missing)"
                )));
            }
        }
        let mean = DVector::from_iterator(
            dim,
            sum.iter()
                .zip(&count)
                .map(|(s, &c)| if c > 0 { s / c as f64 } else { 0.0 }),
        );

        // Centred data; missing entries start at zero (000 §V: "zeros in the missing values").
        let mut z = DMatrix::<f64>::zeros(dim, n);
        let mut hidden: Vec<usize> = Vec::new();
        for (i, m) in maps.iter().enumerate() {
            let mut col = z.column_mut(i);
            for (p, &x) in m.iter().enumerate() {
                if is_missing(x) {
                    hidden.push(i * dim + p);
                } else {
                    col[p] = x as f64 - mean[p];
                }
            }
        }
        let d_h = hidden.len() as f64;
        let observed = (n * dim) as f64 - d_h;
        let scale2 = z.norm_squared() / observed;
        // σ² may not reach zero (exactly low-rank data): Σ_y would be singular.
        let floor = 1e-12 * scale2.max(f64::MIN_POSITIVE);

        // Initialisation: C from d randomly chosen maps, σ² the reconstruction error of the
        // observed values with that C (000 §V, last paragraph before "Once C and σ").
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
        let chosen = sample(&mut rng, n, d).into_vec();
        let mut ct = DMatrix::<f64>::zeros(dim, d);
        for (k, &i) in chosen.iter().enumerate() {
            ct.column_mut(k).copy_from(&z.column(i));
        }
        let mut gram = ct.tr_mul(&ct);
        let mut sigma2 = {
            let ginv = spd_inverse(&gram, 1e-9 * gram.trace().max(floor) / d as f64);
            let y0 = &ginv * ct.tr_mul(&z);
            let r = &ct * &y0;
            let mut err = (&z - &r).norm_squared();
            for &h in &hidden {
                err -= r[h] * r[h]; // missing entries (z = 0) do not count
            }
            (err.max(0.0) / observed).max(floor)
        };
        if sigma2 <= floor {
            // d maps already reconstruct everything: start from the data scale instead.
            sigma2 = scale2.max(floor);
        }

        let eye = DMatrix::<f64>::identity(d, d);
        let mut r = DMatrix::<f64>::zeros(dim, n);
        let mut c_rows = DMatrix::<f64>::zeros(d, dim);
        let mut cz = DMatrix::<f64>::zeros(d, n);
        let mut psi: Vec<f64> = Vec::new();
        let mut converged = false;
        let mut iterations = 0;
        while iterations < params.max_iterations {
            iterations += 1;
            // E step: shared Σ_y, then Y, then the missing entries.
            let sigma_y = spd_inverse(&(&eye + &gram / sigma2), 0.0);
            // C Z through one gemm on Cᵀ's transpose (d × D, small to copy): gemm goes to
            // matrixmultiply, tr_mul would be D-long dot products per entry.
            c_rows.copy_from(&ct.transpose());
            cz.gemm(1.0, &c_rows, &z, 0.0);
            let y = &sigma_y * &cz / sigma2;
            r.gemm(1.0, &ct, &y, 0.0);
            for &h in &hidden {
                z[h] = r[h];
            }
            let sigma2_old = sigma2;

            // M step.
            let yyt = &y * y.transpose();
            let a = &sigma_y * n as f64 + &yyt;
            let b = &z * y.transpose();
            ct = b * spd_inverse(&a, 0.0);
            gram = ct.tr_mul(&ct);
            r.gemm(1.0, &ct, &y, 0.0);
            let resid: f64 = z
                .as_slice()
                .iter()
                .zip(r.as_slice())
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            let tr = (&sigma_y * &gram).trace();
            sigma2 =
                ((n as f64 * tr + resid + d_h * sigma2_old) / (n as f64 * dim as f64)).max(floor);

            // Ψ after the updates (000 §V).
            let log_det = sigma_y
                .clone()
                .cholesky()
                .map(|c| 2.0 * c.l().diagonal().iter().map(|v| v.ln()).sum::<f64>())
                .unwrap_or(f64::NEG_INFINITY);
            let p = -0.5 * n as f64 * (dim as f64 * sigma2.ln() + sigma_y.trace() - log_det)
                - 0.5 * yyt.trace()
                + 0.5 * d_h * sigma2_old.ln();
            if let Some(&prev) = psi.last() {
                let rel = ((p - prev) / prev).abs();
                psi.push(p);
                if rel < params.tolerance {
                    converged = true;
                    break;
                }
            } else {
                psi.push(p);
            }
        }
        Ok(EmPca {
            mean,
            c: ct.transpose(),
            sigma2,
            iterations,
            converged,
            psi,
            missing_fraction: d_h / (n * dim) as f64,
            gram,
        })
    }

    /// A fitted model from its parts (kept from an earlier [`EmPca::fit`]); C Cᵀ is
    /// recomputed exactly as the fit computes it. Refused unless `c` is d × D with `mean` of
    /// D (both at least 1), the mean and C are finite, σ² is finite and > 0, and the missing
    /// fraction lies in [0, 1].
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        mean: DVector<f64>,
        c: DMatrix<f64>,
        sigma2: f64,
        iterations: usize,
        converged: bool,
        psi: Vec<f64>,
        missing_fraction: f64,
    ) -> Result<EmPca, LocalizationError> {
        let (d, dim) = c.shape();
        if d == 0 || dim == 0 || mean.len() != dim {
            return Err(LocalizationError::InvalidParameter(format!(
                "em-pca: C of {d} × {dim} and a mean of {} do not fit (d × D and D, d and D >= 1)",
                mean.len()
            )));
        }
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(mean.as_slice()) && finite(c.as_slice())) {
            return Err(LocalizationError::InvalidParameter(
                "em-pca: a mean or C entry is not finite".into(),
            ));
        }
        if !(sigma2.is_finite() && sigma2 > 0.0 && (0.0..=1.0).contains(&missing_fraction)) {
            return Err(LocalizationError::InvalidParameter(format!(
                "em-pca: sigma2 must be finite and > 0 and the missing fraction within [0, 1], \
                 got {sigma2} and {missing_fraction}"
            )));
        }
        // As `fit`: Cᵀ's Gram matrix, from Cᵀ itself so the sums run in the same order.
        let ct = c.transpose();
        let gram = ct.tr_mul(&ct);
        Ok(EmPca {
            mean,
            c,
            sigma2,
            iterations,
            converged,
            psi,
            missing_fraction,
            gram,
        })
    }

    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    pub fn d(&self) -> usize {
        self.c.nrows()
    }

    /// Features of a new map from its observed entries (000 §V):
    /// y = (σ² I + C_o C_oᵀ)⁻¹ C_o z_o, with missing entries NaN. C_o C_oᵀ is formed as
    /// C Cᵀ − C_h C_hᵀ when fewer than half the entries are missing, so a typical sparse map
    /// costs O(D d + D_h d²). Allocation-free given the scratch.
    pub fn project_into(
        &self,
        z: &[f32],
        scratch: &mut ProjectionScratch,
        out: &mut [f64],
    ) -> Result<(), LocalizationError> {
        let (dim, d) = (self.dim(), self.d());
        if z.len() != dim || out.len() != d {
            return Err(LocalizationError::InvalidParameter(format!(
                "em-pca projection: got a map of {} values and {} outputs, the model has D = {dim} and d = {d}",
                z.len(),
                out.len()
            )));
        }
        if scratch.m.nrows() != d {
            *scratch = ProjectionScratch::new(d);
        }
        let missing = z.iter().filter(|x| is_missing(**x)).count();
        if missing == dim {
            return Err(LocalizationError::InvalidParameter(
                "em-pca projection: every entry of the map is missing".into(),
            ));
        }
        if let Some(p) = z.iter().position(|x| x.is_infinite()) {
            return Err(LocalizationError::InvalidParameter(format!(
                "em-pca projection: infinite value at index {p}"
            )));
        }
        let from_hidden = 2 * missing < dim;
        let m = &mut scratch.m;
        if from_hidden {
            m.copy_from(&self.gram);
        } else {
            m.fill(0.0);
        }
        scratch.v.fill(0.0);
        for (p, &x) in z.iter().enumerate() {
            let col = self.c.column(p);
            let hidden = is_missing(x);
            if hidden {
                if from_hidden {
                    rank1(m, col.as_slice(), -1.0);
                }
            } else {
                if !from_hidden {
                    rank1(m, col.as_slice(), 1.0);
                }
                let c = x as f64 - self.mean[p];
                for (v, w) in scratch.v.iter_mut().zip(col.iter()) {
                    *v += w * c;
                }
            }
        }
        // Mirror the upper triangle rank1 filled, add σ².
        for j in 0..d {
            for i in 0..j {
                m[(j, i)] = m[(i, j)];
            }
            m[(j, j)] += self.sigma2;
        }
        let owned = std::mem::replace(m, DMatrix::zeros(0, 0));
        match Cholesky::new(owned) {
            Some(ch) => {
                ch.solve_mut(&mut scratch.v);
                *m = ch.unpack_dirty();
            }
            None => {
                *m = DMatrix::zeros(d, d);
                return Err(LocalizationError::InvalidParameter(
                    "em-pca projection: σ²I + C_o C_oᵀ is not positive definite".into(),
                ));
            }
        }
        out.copy_from_slice(scratch.v.as_slice());
        Ok(())
    }

    pub fn project(&self, z: &[f32]) -> Result<Vec<f64>, LocalizationError> {
        let mut s = ProjectionScratch::new(self.d());
        let mut out = vec![0.0; self.d()];
        self.project_into(z, &mut s, &mut out)?;
        Ok(out)
    }
}

/// m += s · c cᵀ on the upper triangle (column-major: m[(i, j)], i ≤ j).
#[inline]
fn rank1(m: &mut DMatrix<f64>, c: &[f64], s: f64) {
    let d = c.len();
    for j in 0..d {
        let cj = s * c[j];
        let col = &mut m.as_mut_slice()[j * d..j * d + j + 1];
        for (mi, ci) in col.iter_mut().zip(c) {
            *mi += ci * cj;
        }
    }
}

/// Inverse of a symmetric positive (semi)definite matrix by Cholesky, with a ridge added on
/// the diagonal only if the factorisation fails (duplicate initial maps).
fn spd_inverse(a: &DMatrix<f64>, ridge: f64) -> DMatrix<f64> {
    let n = a.nrows();
    let mut reg = ridge.max(0.0);
    let mut m = a.clone();
    for _ in 0..40 {
        if let Some(c) = Cholesky::new(m.clone()) {
            return c.inverse();
        }
        reg = if reg == 0.0 {
            1e-12 * (a.trace().abs() / n as f64).max(1e-300)
        } else {
            reg * 10.0
        };
        m = a + DMatrix::<f64>::identity(n, n) * reg;
    }
    DMatrix::identity(n, n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pca::tests::planted;
    use crate::pca::{principal_angles, Pca, PcaMethod};
    use rand::Rng;

    fn with_missing(data: &[Vec<f32>], fraction: f64, seed: u64) -> Vec<Vec<f32>> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        data.iter()
            .map(|v| {
                v.iter()
                    .map(|&x| {
                        if rng.random::<f64>() < fraction {
                            f32::NAN
                        } else {
                            x
                        }
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn without_missing_values_it_finds_the_pca_subspace() {
        // Five strong directions, three weak ones: a clear gap after the fifth eigenvalue.
        let scales = [10.0, 9.0, 8.0, 7.0, 6.0, 2.0, 1.5, 1.0];
        let (_, data) = planted(800, 60, &scales, 0.3, 11);
        let refs: Vec<&[f32]> = data.iter().map(|v| v.as_slice()).collect();
        let pca = Pca::fit(&refs, 5, PcaMethod::Svd).unwrap();
        let em = EmPca::fit(&refs, 5, EmPcaParams::default()).unwrap();
        assert!(em.converged, "{} iterations", em.iterations);
        let angles = principal_angles(&pca.components, &em.c);
        let worst = angles.last().unwrap().to_degrees();
        assert!(worst < 1.0, "principal angles {angles:?} (deg {worst})");
        assert_eq!(em.missing_fraction, 0.0);
    }

    #[test]
    fn with_20_percent_missing_it_recovers_a_planted_subspace_and_psi_never_decreases() {
        // Noise small enough that 80 samples pin the subspace down: with complete data the
        // sample subspace is within about sqrt(D σ² / (N s²)) ≈ 0.7° of the planted one.
        let (basis, data) = planted(1000, 80, &[9.0, 8.0, 7.0, 6.0, 5.0], 0.02, 5);
        let sparse = with_missing(&data, 0.2, 6);
        let refs: Vec<&[f32]> = sparse.iter().map(|v| v.as_slice()).collect();
        let em = EmPca::fit(&refs, 5, EmPcaParams::default()).unwrap();
        assert!(
            (em.missing_fraction - 0.2).abs() < 0.01,
            "{}",
            em.missing_fraction
        );
        let angles = principal_angles(&basis, &em.c);
        let worst = angles.last().unwrap().to_degrees();
        assert!(
            worst < 2.0,
            "principal angles to the planted basis: {worst} deg"
        );
        for w in em.psi.windows(2) {
            assert!(
                w[1] >= w[0] - 1e-9 * w[0].abs(),
                "Ψ decreased: {:?}",
                em.psi
            );
        }
        // σ² approaches the planted noise variance (4e-4) from above; the paper's loose
        // stopping rule (0.001 relative on Ψ) leaves it within a factor of 3.
        assert!(em.sigma2 > 3e-4 && em.sigma2 < 1.2e-3, "σ² = {}", em.sigma2);
        // A map's features from its observed entries match those from the complete map.
        let full = em.project(&data[3]).unwrap();
        let part = em.project(&sparse[3]).unwrap();
        let norm: f64 = full.iter().map(|v| v * v).sum::<f64>().sqrt();
        let diff: f64 = full
            .iter()
            .zip(&part)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        assert!(diff < 0.05 * norm, "{diff} vs {norm}");
    }

    #[test]
    fn projection_both_ways_agree() {
        // C_o C_oᵀ from the observed columns directly (more than half missing) and from
        // C Cᵀ − C_h C_hᵀ (fewer than half missing) give the same features.
        let (_, data) = planted(300, 40, &[4.0, 3.0, 2.0], 0.1, 8);
        let refs: Vec<&[f32]> = data.iter().map(|v| v.as_slice()).collect();
        let em = EmPca::fit(&refs, 3, EmPcaParams::default()).unwrap();
        let mut few = data[0].clone();
        for p in (0..300).step_by(7) {
            few[p] = f32::NAN;
        }
        let y = em.project(&few).unwrap();
        // Direct evaluation with nalgebra.
        let obs: Vec<usize> = (0..300).filter(|p| !few[*p].is_nan()).collect();
        let co = DMatrix::from_fn(3, obs.len(), |k, j| em.c[(k, obs[j])]);
        let zo = DVector::from_fn(obs.len(), |j, _| few[obs[j]] as f64 - em.mean[obs[j]]);
        let m = DMatrix::identity(3, 3) * em.sigma2 + &co * co.transpose();
        let want = m.try_inverse().unwrap() * (&co * zo);
        for k in 0..3 {
            assert!(
                (y[k] - want[k]).abs() < 1e-9 * (1.0 + want[k].abs()),
                "{y:?} {want}"
            );
        }
        let mut many = data[0].clone();
        for (p, v) in many.iter_mut().enumerate() {
            if p % 3 != 0 {
                *v = f32::NAN;
            }
        }
        let y = em.project(&many).unwrap();
        let obs: Vec<usize> = (0..300).step_by(3).collect();
        let co = DMatrix::from_fn(3, obs.len(), |k, j| em.c[(k, obs[j])]);
        let zo = DVector::from_fn(obs.len(), |j, _| many[obs[j]] as f64 - em.mean[obs[j]]);
        let m = DMatrix::identity(3, 3) * em.sigma2 + &co * co.transpose();
        let want = m.try_inverse().unwrap() * (&co * zo);
        for k in 0..3 {
            assert!(
                (y[k] - want[k]).abs() < 1e-9 * (1.0 + want[k].abs()),
                "{y:?} {want}"
            );
        }
    }

    #[test]
    fn from_parts_gives_the_fitted_model_and_refuses_misfits() {
        let (_, data) = planted(200, 40, &[5.0, 4.0, 3.0], 0.3, 5);
        let data = with_missing(&data, 0.2, 6);
        let refs: Vec<&[f32]> = data.iter().map(|v| v.as_slice()).collect();
        let em = EmPca::fit(&refs, 3, EmPcaParams::default()).unwrap();
        let parts = |em: &EmPca| {
            EmPca::from_parts(
                em.mean.clone(),
                em.c.clone(),
                em.sigma2,
                em.iterations,
                em.converged,
                em.psi.clone(),
                em.missing_fraction,
            )
        };
        let back = parts(&em).unwrap();
        // C Cᵀ too, bit for bit: projections of a new map agree exactly.
        assert_eq!(back, em);
        let bits = |v: &DMatrix<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.gram), bits(&em.gram));
        let mut short = em.clone();
        short.mean = DVector::zeros(em.dim() - 1);
        let mut nan = em.clone();
        nan.c[(0, 0)] = f64::NAN;
        let mut zero = em.clone();
        zero.sigma2 = 0.0;
        let mut fraction = em.clone();
        fraction.missing_fraction = 1.5;
        for bad in [short, nan, zero, fraction] {
            assert!(parts(&bad).is_err());
        }
    }

    #[test]
    fn pca_from_parts_gives_the_fitted_subspace_and_refuses_misfits() {
        let (_, data) = planted(200, 40, &[5.0, 4.0, 3.0], 0.3, 5);
        let refs: Vec<&[f32]> = data.iter().map(|v| v.as_slice()).collect();
        let pca = Pca::fit(&refs, 3, PcaMethod::Snapshot).unwrap();
        let parts =
            |p: &Pca| Pca::from_parts(p.mean.clone(), p.components.clone(), p.eigenvalues.clone());
        assert_eq!(parts(&pca).unwrap(), pca);
        let mut short = pca.clone();
        short.eigenvalues = DVector::zeros(2);
        let mut wide = pca.clone();
        wide.mean = DVector::zeros(pca.dim() + 1);
        let mut inf = pca.clone();
        inf.mean[3] = f64::INFINITY;
        for bad in [short, wide, inf] {
            assert!(parts(&bad).is_err());
        }
    }

    #[test]
    fn bad_input_is_rejected_with_a_message() {
        let a = vec![1.0f32; 10];
        let b = vec![2.0f32; 10];
        let nan = vec![f32::NAN; 10];
        let e = EmPca::fit(&[&a, &b], 2, EmPcaParams::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("1 <= d < N"), "{e}");
        let e = EmPca::fit(&[&a, &nan, &b], 1, EmPcaParams::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("map 1") && e.contains("all 10 entries missing"),
            "{e}"
        );
        let mut inf = a.clone();
        inf[2] = f32::INFINITY;
        let e = EmPca::fit(&[&a, &inf, &b], 1, EmPcaParams::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("index 2"), "{e}");
        let short = vec![1.0f32; 9];
        let e = EmPca::fit(&[&a, &short, &b], 1, EmPcaParams::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("different sizes"), "{e}");
        let mut c = a.clone();
        c[0] = 5.0;
        let em = EmPca::fit(&[&a, &b, &c], 1, EmPcaParams::default()).unwrap();
        assert!(em
            .project(&nan)
            .unwrap_err()
            .to_string()
            .contains("every entry"));
        assert!(em.project(&short).is_err());
    }
}
