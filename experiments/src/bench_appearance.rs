//! `atrium bench empca`: EM-PCA with missing values (000 §V) at the paper's size, on seeded
//! random low-rank data, plus the cost of extracting the features of one new map.

use atrium_localization::em_pca::{EmPca, EmPcaParams, ProjectionScratch};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::{json, Value};
use std::time::Instant;

/// Problem size. Defaults are 000 §VII: d = 20 components of N = 100 maps of D = 19200 pixels
/// (160 × 120), about 20 % missing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EmPcaBench {
    pub d: usize,
    pub n: usize,
    pub dim: usize,
    pub missing: f64,
    pub seed: u64,
}

impl Default for EmPcaBench {
    fn default() -> Self {
        Self {
            d: 20,
            n: 100,
            dim: 19200,
            missing: 0.2,
            seed: 1,
        }
    }
}

impl EmPcaBench {
    pub fn validate(&self) -> Result<(), String> {
        if self.d == 0 || self.d >= self.n {
            return Err(format!(
                "--d must satisfy 1 <= d < N (--n), got d = {}, N = {}",
                self.d, self.n
            ));
        }
        if self.dim < self.d {
            return Err(format!(
                "--dim must be at least --d, got dim = {}, d = {}",
                self.dim, self.d
            ));
        }
        if !(self.missing.is_finite() && (0.0..0.95).contains(&self.missing)) {
            return Err(format!(
                "--missing must be a fraction in [0, 0.95), got {}",
                self.missing
            ));
        }
        Ok(())
    }
}

/// Rank-`d` maps Z = A S + noise with A (D × d) and S (d × N) uniform in [−1, 1], noise
/// uniform with standard deviation about 0.03 (σ² ≈ 8e-4), then `missing` of the entries
/// blanked at random (NaN).
pub fn low_rank_maps(b: &EmPcaBench) -> Vec<Vec<f32>> {
    let mut rng = ChaCha8Rng::seed_from_u64(b.seed);
    let a: Vec<f32> = (0..b.dim * b.d)
        .map(|_| rng.random_range(-1.0f32..1.0))
        .collect();
    (0..b.n)
        .map(|_| {
            let s: Vec<f32> = (0..b.d).map(|_| rng.random_range(-1.0f32..1.0)).collect();
            (0..b.dim)
                .map(|p| {
                    if rng.random::<f64>() < b.missing {
                        return f32::NAN;
                    }
                    let row = &a[p * b.d..(p + 1) * b.d];
                    let v: f32 = row.iter().zip(&s).map(|(x, y)| x * y).sum();
                    v + 0.05 * rng.random_range(-1.0f32..1.0)
                })
                .collect()
        })
        .collect()
}

pub fn empca(b: &EmPcaBench) -> Result<Value, String> {
    b.validate()?;
    let maps = low_rank_maps(b);
    let refs: Vec<&[f32]> = maps.iter().map(|m| m.as_slice()).collect();
    let started = Instant::now();
    let em = EmPca::fit(&refs, b.d, EmPcaParams::default()).map_err(|e| e.to_string())?;
    let seconds = started.elapsed().as_secs_f64();

    // Feature extraction of one new map (000 §V, the paper: < 0.1 s), averaged.
    let mut scratch = ProjectionScratch::new(b.d);
    let mut out = vec![0.0; b.d];
    let reps = 200;
    let started = Instant::now();
    for i in 0..reps {
        em.project_into(&maps[i % maps.len()], &mut scratch, &mut out)
            .map_err(|e| e.to_string())?;
    }
    let project_s = started.elapsed().as_secs_f64() / reps as f64;
    Ok(json!({
        "d": b.d,
        "n": b.n,
        "dim": b.dim,
        "missing": em.missing_fraction,
        "seconds": seconds,
        "iterations": em.iterations,
        "converged": em.converged,
        "sigma2": em.sigma2,
        "psi": em.psi,
        "project_seconds": project_s,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_bench_runs_and_finds_the_noise_level() {
        let b = EmPcaBench {
            d: 5,
            n: 30,
            dim: 400,
            missing: 0.2,
            seed: 3,
        };
        let v = empca(&b).unwrap();
        assert!(v["iterations"].as_u64().unwrap() >= 2);
        // Uniform noise of half-width 0.05: variance 0.05² / 3 ≈ 8.3e-4. σ² approaches it
        // from above; the paper's stopping rule (0.001 relative on Ψ) stops within ~10×.
        let s2 = v["sigma2"].as_f64().unwrap();
        assert!(s2 > 4e-4 && s2 < 1e-2, "{s2}");
        let bad = EmPcaBench { d: 30, ..b };
        assert!(empca(&bad).unwrap_err().contains("--d"));
        let bad = EmPcaBench {
            missing: f64::NAN,
            ..b
        };
        assert!(empca(&bad).unwrap_err().contains("--missing"));
    }
}
