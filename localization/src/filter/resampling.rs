//! Low-variance (systematic) resampling: Thrun et al., *Probabilistic Robotics*, §4.3.4,
//! Table 4.4. One random number per resampling, so the copies of particle i are
//! ⌊M·wᵢ⌋ or ⌈M·wᵢ⌉, with no more variance than the weights force.

use rand::Rng;

/// Fills `out` with the indices of the particles chosen for the new set (as many as
/// `out.len()`), given weights that need not sum to one. `offset` ∈ [0, 1) is the fraction of
/// one step at which the comb starts (Table 4.4's r = offset / M).
///
/// Returns `false` and leaves `out` untouched if the weights are empty or their sum is not a
/// positive finite number.
pub fn low_variance_indices_with_offset(weights: &[f64], out: &mut [usize], offset: f64) -> bool {
    let total: f64 = weights.iter().sum();
    if weights.is_empty() || !(total.is_finite() && total > 0.0) {
        return false;
    }
    let m = out.len();
    if m == 0 {
        return true;
    }
    let step = total / m as f64;
    let r = offset.clamp(0.0, 1.0) * step;
    let last = weights.len() - 1;
    let mut i = 0usize;
    let mut c = weights[0];
    for (k, slot) in out.iter_mut().enumerate() {
        let u = r + k as f64 * step;
        // `>=` (Table 4.4 has `>`) so that a zero-weight particle is never picked when the
        // comb starts exactly at 0; `i < last` guards against rounding in the running sum.
        while u >= c && i < last {
            i += 1;
            c += weights[i];
        }
        *slot = i;
    }
    true
}

/// [`low_variance_indices_with_offset`] with the offset drawn from `rng`.
pub fn low_variance_indices<R: Rng + ?Sized>(
    weights: &[f64],
    out: &mut [usize],
    rng: &mut R,
) -> bool {
    let offset: f64 = rng.random();
    low_variance_indices_with_offset(weights, out, offset)
}

/// When a filter resamples after a sensor update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ResamplePolicy {
    /// After every update (MCL, CGR, the WiFi filter: each update carries enough evidence
    /// that weights are worth little afterwards).
    EveryUpdate,
    /// When the effective sample size falls below this fraction of the particles: a filter
    /// whose single readings say little (a ceiling brightness) keeps its diversity until the
    /// weights really degenerate (Thrun et al., *Probabilistic Robotics*, §4.3.4, on
    /// resampling too often).
    BelowEss(f64),
}

impl ResamplePolicy {
    /// The policy of a `resample_ess` parameter: below that fraction of the particles, or
    /// after every update when it is 0.
    pub fn from_resample_ess(fraction: f64) -> ResamplePolicy {
        if fraction > 0.0 {
            ResamplePolicy::BelowEss(fraction)
        } else {
            ResamplePolicy::EveryUpdate
        }
    }

    /// Whether a set of `n` particles with effective sample size `ess` is due.
    pub fn due(&self, ess: f64, n: usize) -> bool {
        match *self {
            ResamplePolicy::EveryUpdate => true,
            ResamplePolicy::BelowEss(fraction) => ess < fraction * n as f64,
        }
    }
}

/// Particles a resampling replaces by draws from a proposal other than the set itself
/// (random particles, or a sensor's own proposal): the recovery of a filter that lost track.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Injection {
    None,
    /// Each new particle independently with this probability (Augmented MCL, Thrun et al.
    /// Table 8.3; one uniform draw per particle).
    Probability(f64),
    /// This many, at slots chosen at random after resampling (after resampling the
    /// particles are interchangeable).
    Count(usize),
}

/// The number of particles a fraction of `m` injects: the nearest whole number.
pub fn injection_count(fraction: f64, m: usize) -> usize {
    (fraction * m as f64).round() as usize
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn counts(idx: &[usize], n: usize) -> Vec<usize> {
        let mut c = vec![0; n];
        for &i in idx {
            c[i] += 1;
        }
        c
    }

    #[test]
    fn copies_in_proportion_to_weights_for_any_offset() {
        let w = [0.5, 0.25, 0.25];
        let mut out = [0usize; 4];
        for offset in [0.0, 0.1, 0.5, 0.99, 0.999_999] {
            assert!(low_variance_indices_with_offset(&w, &mut out, offset));
            assert_eq!(counts(&out, 3), vec![2, 1, 1], "offset {offset}");
        }
        // Unnormalised weights give the same result.
        assert!(low_variance_indices_with_offset(
            &[2.0, 1.0, 1.0],
            &mut out,
            0.3
        ));
        assert_eq!(counts(&out, 3), vec![2, 1, 1]);
        // Eight draws, weights 0.5 / 0.25 / 0.125 / 0.125: exactly 4 / 2 / 1 / 1.
        let mut out = [0usize; 8];
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..20 {
            assert!(low_variance_indices(
                &[0.5, 0.25, 0.125, 0.125],
                &mut out,
                &mut rng
            ));
            assert_eq!(counts(&out, 4), vec![4, 2, 1, 1]);
        }
    }

    #[test]
    fn counts_are_floor_or_ceil_of_expected_copies() {
        let w = [0.1, 0.0, 0.37, 0.2, 0.33];
        let mut out = [0usize; 10];
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for _ in 0..100 {
            low_variance_indices(&w, &mut out, &mut rng);
            let c = counts(&out, 5);
            for (ci, wi) in c.iter().zip(w) {
                let e = wi * 10.0;
                assert!(*ci as f64 >= e.floor() && *ci as f64 <= e.ceil(), "{c:?}");
            }
            // Sorted output: the comb walks the weights once.
            assert!(out.windows(2).all(|p| p[0] <= p[1]));
        }
    }

    #[test]
    fn degenerate_weights_are_refused() {
        let mut out = [7usize; 3];
        assert!(!low_variance_indices_with_offset(&[], &mut out, 0.5));
        assert!(!low_variance_indices_with_offset(
            &[0.0, 0.0],
            &mut out,
            0.5
        ));
        assert!(!low_variance_indices_with_offset(
            &[f64::NAN, 1.0],
            &mut out,
            0.5
        ));
        assert_eq!(out, [7, 7, 7]);
    }

    #[test]
    fn policies_and_injection_counts_by_hand() {
        assert!(ResamplePolicy::EveryUpdate.due(1000.0, 1000));
        // ESS 499 of 1000 is below half; 500 is not (strictly below).
        assert!(ResamplePolicy::BelowEss(0.5).due(499.0, 1000));
        assert!(!ResamplePolicy::BelowEss(0.5).due(500.0, 1000));
        assert_eq!(injection_count(0.02, 2000), 40);
        assert_eq!(injection_count(0.02, 30), 1); // 0.6 rounds up
        assert_eq!(injection_count(0.02, 20), 0); // 0.4 rounds down
        assert_eq!(injection_count(0.0, 5000), 0);
    }
}
