//! Principal component analysis of a set of images (000 §II, eq. 1; 001 "eigenimages").
//!
//! Two ways to the same subspace: the singular value decomposition of the centred D × N data
//! matrix (the numerically most accurate, 000 §I), and the snapshot trick of Turk and Pentland
//! (001): when N ≪ D, diagonalise the small N × N Gram matrix XᵀX instead of the D × D
//! covariance XXᵀ, and map its eigenvectors back with u = X v / ‖X v‖.

use crate::error::LocalizationError;
use crate::limits::MAX_PCA_SAMPLES;
use nalgebra::{DMatrix, DVector, SymmetricEigen};

/// How the principal components are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PcaMethod {
    /// Thin SVD of the centred data matrix (O(D N²)).
    Svd,
    /// Eigenvectors of the N × N Gram matrix (the snapshot trick, 001), O(D N² + N³).
    Snapshot,
}

/// A d-dimensional principal subspace of D-dimensional vectors.
#[derive(Debug, Clone, PartialEq)]
pub struct Pca {
    /// Mean of the training vectors (D).
    pub mean: DVector<f64>,
    /// d × D projection matrix C of 000 eq. 1: its rows are the unit eigenvectors (the
    /// eigenimages of 001), largest eigenvalue first.
    pub components: DMatrix<f64>,
    /// Eigenvalues of the sample covariance (variance along each row of `components`).
    pub eigenvalues: DVector<f64>,
}

/// Checks the training set: N ≥ 2 vectors of one length D ≥ 1, finite values, 1 ≤ d < N.
pub(crate) fn check_training_set(
    what: &str,
    vectors: &[&[f32]],
    d: usize,
) -> Result<usize, LocalizationError> {
    let n = vectors.len();
    if n < 2 {
        return Err(LocalizationError::InvalidParameter(format!(
            "{what}: need at least 2 training vectors, got {n}"
        )));
    }
    let dim = vectors[0].len();
    if dim == 0 {
        return Err(LocalizationError::InvalidParameter(format!(
            "{what}: training vector 0 is empty"
        )));
    }
    if let Some((i, v)) = vectors.iter().enumerate().find(|(_, v)| v.len() != dim) {
        return Err(LocalizationError::InvalidParameter(format!(
            "{what}: training vector {i} has {} values, vector 0 has {dim} (images of different sizes)",
            v.len()
        )));
    }
    if d == 0 || d >= n {
        return Err(LocalizationError::InvalidParameter(format!(
            "{what}: the number of components d must satisfy 1 <= d < N, got d = {d}, N = {n}"
        )));
    }
    if d > dim {
        return Err(LocalizationError::InvalidParameter(format!(
            "{what}: d = {d} exceeds the vector length D = {dim}"
        )));
    }
    Ok(dim)
}

impl Pca {
    /// Fits the first `d` principal components of `vectors` (each of length D; no missing
    /// values: NaN or infinite entries are rejected with the vector and index named).
    pub fn fit(vectors: &[&[f32]], d: usize, method: PcaMethod) -> Result<Pca, LocalizationError> {
        let dim = check_training_set("pca", vectors, d)?;
        // Both methods cost N² memory and N³ time (the Gram matrix, or the SVD's V).
        if vectors.len() > MAX_PCA_SAMPLES {
            return Err(LocalizationError::InvalidParameter(format!(
                "pca: {} training vectors are more than the limit of {MAX_PCA_SAMPLES} \
                 (MAX_PCA_SAMPLES)",
                vectors.len()
            )));
        }
        for (i, v) in vectors.iter().enumerate() {
            if let Some(p) = v.iter().position(|x| !x.is_finite()) {
                return Err(LocalizationError::InvalidParameter(format!(
                    "pca: training vector {i} has a non-finite value ({}) at index {p}; PCA takes no missing values (use EmPca)",
                    v[p]
                )));
            }
        }
        let n = vectors.len();
        let mut mean = DVector::<f64>::zeros(dim);
        for v in vectors {
            for (m, &x) in mean.iter_mut().zip(v.iter()) {
                *m += x as f64;
            }
        }
        mean /= n as f64;
        let mut x = DMatrix::<f64>::zeros(dim, n);
        for (j, v) in vectors.iter().enumerate() {
            for (r, (&val, m)) in v.iter().zip(mean.iter()).enumerate() {
                x[(r, j)] = val as f64 - m;
            }
        }
        let (components, eigenvalues) = match method {
            PcaMethod::Svd => svd_components(x, d, n),
            PcaMethod::Snapshot => snapshot_components(&x, d, n),
        };
        Ok(Pca {
            mean,
            components,
            eigenvalues,
        })
    }

    /// A subspace from its parts (kept from an earlier [`Pca::fit`]), refused unless the
    /// shapes agree (`components` d × D, `mean` D, `eigenvalues` d) and every value is finite.
    pub fn from_parts(
        mean: DVector<f64>,
        components: DMatrix<f64>,
        eigenvalues: DVector<f64>,
    ) -> Result<Pca, LocalizationError> {
        let (d, dim) = components.shape();
        if d == 0 || dim == 0 || mean.len() != dim || eigenvalues.len() != d {
            return Err(LocalizationError::InvalidParameter(format!(
                "pca: components of {d} × {dim}, a mean of {} and {} eigenvalues do not fit \
                 (d × D, D and d, d and D >= 1)",
                mean.len(),
                eigenvalues.len()
            )));
        }
        let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
        if !(finite(mean.as_slice())
            && finite(components.as_slice())
            && finite(eigenvalues.as_slice()))
        {
            return Err(LocalizationError::InvalidParameter(
                "pca: a mean, component or eigenvalue is not finite".into(),
            ));
        }
        Ok(Pca {
            mean,
            components,
            eigenvalues,
        })
    }

    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    pub fn d(&self) -> usize {
        self.components.nrows()
    }

    /// Features y = C (z − mean) of one vector (000 eq. 1), written into `out` (length d).
    /// Fails (never panics) on a vector of the wrong length or with non-finite values.
    pub fn project_into(&self, z: &[f32], out: &mut [f64]) -> Result<(), LocalizationError> {
        if z.len() != self.dim() || out.len() != self.d() {
            return Err(LocalizationError::InvalidParameter(format!(
                "pca projection: got a vector of {} values and {} outputs, the model has D = {} and d = {}",
                z.len(),
                out.len(),
                self.dim(),
                self.d()
            )));
        }
        if let Some(p) = z.iter().position(|x| !x.is_finite()) {
            return Err(LocalizationError::InvalidParameter(format!(
                "pca projection: non-finite value at index {p}"
            )));
        }
        out.fill(0.0);
        // C is d × D column-major: column p holds every component's weight on pixel p, so
        // one pass over the pixels reads C contiguously.
        for (p, (&v, m)) in z.iter().zip(self.mean.iter()).enumerate() {
            let c = v as f64 - m;
            let col = self.components.column(p);
            for (o, w) in out.iter_mut().zip(col.iter()) {
                *o += w * c;
            }
        }
        Ok(())
    }

    pub fn project(&self, z: &[f32]) -> Result<Vec<f64>, LocalizationError> {
        let mut out = vec![0.0; self.d()];
        self.project_into(z, &mut out)?;
        Ok(out)
    }
}

fn svd_components(x: DMatrix<f64>, d: usize, n: usize) -> (DMatrix<f64>, DVector<f64>) {
    let svd = x.svd(true, false);
    let u = svd.u.expect("svd computed with u");
    // nalgebra does not promise sorted singular values: order them ourselves.
    let mut order: Vec<usize> = (0..svd.singular_values.len()).collect();
    order.sort_by(|&a, &b| svd.singular_values[b].total_cmp(&svd.singular_values[a]));
    let mut comps = DMatrix::<f64>::zeros(d, u.nrows());
    let mut eig = DVector::<f64>::zeros(d);
    for (k, &j) in order.iter().take(d).enumerate() {
        let s = svd.singular_values[j];
        eig[k] = s * s / (n as f64 - 1.0);
        comps.row_mut(k).copy_from(&u.column(j).transpose());
    }
    (comps, eig)
}

fn snapshot_components(x: &DMatrix<f64>, d: usize, n: usize) -> (DMatrix<f64>, DVector<f64>) {
    let gram = x.tr_mul(x);
    let eig = SymmetricEigen::new(gram);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let mut comps = DMatrix::<f64>::zeros(d, x.nrows());
    let mut vals = DVector::<f64>::zeros(d);
    for (k, &j) in order.iter().take(d).enumerate() {
        // X v is an eigenvector of X Xᵀ with the same eigenvalue; ‖X v‖² = λ.
        let u = x * eig.eigenvectors.column(j);
        let norm = u.norm();
        if norm > 0.0 {
            comps.row_mut(k).copy_from(&(u / norm).transpose());
        }
        vals[k] = eig.eigenvalues[j].max(0.0) / (n as f64 - 1.0);
    }
    (comps, vals)
}

/// Principal angles (radians, ascending) between the row spaces of two k × D matrices, whose
/// rows need not be orthonormal: the arc-cosines of the singular values of Q₁ᵀQ₂ with Q the
/// orthonormal bases (Björck and Golub).
pub fn principal_angles(a: &DMatrix<f64>, b: &DMatrix<f64>) -> Vec<f64> {
    let qa = a.transpose().qr().q();
    let qb = b.transpose().qr().q();
    let m = qa.tr_mul(&qb);
    let mut s: Vec<f64> = m
        .svd(false, false)
        .singular_values
        .iter()
        .map(|c| c.clamp(-1.0, 1.0).acos())
        .collect();
    s.sort_by(f64::total_cmp);
    s
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    /// N vectors z = Bᵀ s + noise with a planted k-dimensional basis B (k × D) whose
    /// directions have standard deviations `scales`, plus isotropic noise `noise`.
    pub(crate) fn planted(
        dim: usize,
        n: usize,
        scales: &[f64],
        noise: f64,
        seed: u64,
    ) -> (DMatrix<f64>, Vec<Vec<f32>>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let k = scales.len();
        let basis = DMatrix::<f64>::from_fn(k, dim, |_, _| StandardNormal.sample(&mut rng));
        let basis = basis.transpose().qr().q().transpose();
        let mut data = Vec::with_capacity(n);
        for _ in 0..n {
            let s: Vec<f64> = scales
                .iter()
                .map(|sc| {
                    let g: f64 = StandardNormal.sample(&mut rng);
                    sc * g
                })
                .collect();
            let mut z = vec![0f32; dim];
            for (p, zp) in z.iter_mut().enumerate() {
                let mut v: f64 = (0..k).map(|j| basis[(j, p)] * s[j]).sum();
                v += noise * rng.sample::<f64, _>(StandardNormal);
                *zp = v as f32;
            }
            data.push(z);
        }
        (basis, data)
    }

    #[test]
    fn svd_and_snapshot_give_the_same_subspace() {
        let scales: Vec<f64> = (0..8).map(|i| 10.0 - i as f64).collect();
        let (basis, data) = planted(500, 40, &scales, 0.05, 3);
        let refs: Vec<&[f32]> = data.iter().map(|v| v.as_slice()).collect();
        let a = Pca::fit(&refs, 6, PcaMethod::Svd).unwrap();
        let b = Pca::fit(&refs, 6, PcaMethod::Snapshot).unwrap();
        let angles = principal_angles(&a.components, &b.components);
        assert!(angles.iter().all(|t| t.to_degrees() < 1e-3), "{angles:?}");
        for k in 0..6 {
            assert!(
                (a.eigenvalues[k] - b.eigenvalues[k]).abs() < 1e-6 * a.eigenvalues[0],
                "eigenvalue {k}: {} vs {}",
                a.eigenvalues[k],
                b.eigenvalues[k]
            );
            // Each component individually agrees up to sign.
            let dot = a.components.row(k).dot(&b.components.row(k)).abs();
            assert!(dot > 1.0 - 1e-6, "component {k}: |cos| = {dot}");
        }
        // And both lie in the planted 8-dimensional span (which 6 of its directions they
        // pick depends on the sample when scales are close).
        let angles = principal_angles(&a.components, &basis);
        assert!(angles.iter().all(|t| t.to_degrees() < 2.0), "{angles:?}");
    }

    #[test]
    fn projection_of_a_training_vector_reconstructs_it() {
        let (_, data) = planted(200, 30, &[5.0, 3.0, 2.0], 0.0, 9);
        let refs: Vec<&[f32]> = data.iter().map(|v| v.as_slice()).collect();
        let pca = Pca::fit(&refs, 3, PcaMethod::Snapshot).unwrap();
        let y = pca.project(&data[4]).unwrap();
        let rec = pca.components.tr_mul(&DVector::from_vec(y)) + &pca.mean;
        for (p, &v) in data[4].iter().enumerate() {
            assert!((rec[p] - v as f64).abs() < 1e-4, "pixel {p}");
        }
    }

    #[test]
    fn bad_input_is_named() {
        let a = vec![0.0f32; 10];
        let b = vec![1.0f32; 9];
        let e = Pca::fit(&[&a, &b], 1, PcaMethod::Svd)
            .unwrap_err()
            .to_string();
        assert!(e.contains("different sizes"), "{e}");
        let e = Pca::fit(&[&a, &a], 2, PcaMethod::Svd)
            .unwrap_err()
            .to_string();
        assert!(e.contains("1 <= d < N"), "{e}");
        let mut c = a.clone();
        c[3] = f32::NAN;
        let e = Pca::fit(&[&a, &c, &a], 1, PcaMethod::Svd)
            .unwrap_err()
            .to_string();
        assert!(e.contains("vector 1") && e.contains("index 3"), "{e}");
        let pca = Pca::fit(
            &[&a, &c.iter().map(|_| 1.0).collect::<Vec<_>>(), &a],
            1,
            PcaMethod::Svd,
        )
        .unwrap();
        assert!(pca.project(&b).is_err());
        assert!(pca.project(&c).is_err());
    }

    #[test]
    fn more_training_vectors_than_the_limit_are_refused_before_fitting() {
        let n = crate::limits::MAX_PCA_SAMPLES + 1;
        let data: Vec<Vec<f32>> = (0..n).map(|i| vec![i as f32, 1.0]).collect();
        let refs: Vec<&[f32]> = data.iter().map(|v| v.as_slice()).collect();
        let e = Pca::fit(&refs, 1, PcaMethod::Snapshot)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("2001 training vectors are more than the limit of 2000 (MAX_PCA_SAMPLES)"),
            "{e}"
        );
        assert!(Pca::fit(&refs[..n - 1], 1, PcaMethod::Snapshot).is_ok());
    }
}
