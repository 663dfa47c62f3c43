//! KLD-sampling (Fox, "Adapting the Sample Size in Particle Filters Through KLD-Sampling",
//! IJRR 2003): the number of particles that keeps the Kullback–Leibler divergence
//! between the sample-based and the true posterior below ε with probability 1 − δ, given the
//! number k of histogram bins the particles occupy.

use crate::filter::lattice::floor_i64;
use atrium_robots::normalize_angle;

/// Standard normal quantile (inverse CDF), Acklam's rational approximation: relative error
/// below 1.15e-9 on (0, 1), far below what rounding the bound up to an integer can notice.
/// NaN outside (0, 1).
pub fn normal_quantile(p: f64) -> f64 {
    if !(p > 0.0 && p < 1.0) {
        return f64::NAN;
    }
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    const P_LOW: f64 = 0.02425;
    if p < P_LOW {
        let q = (-2.0 * p.ln()).sqrt();
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    } else if p <= 1.0 - P_LOW {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    } else {
        let q = (-2.0 * (1.0 - p).ln()).sqrt();
        -(((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    }
}

/// Fox 2003, the Wilson–Hilferty approximation of the χ² quantile, with z the upper 1 − δ quantile of the standard normal:
/// n = (k−1)/(2ε) · (1 − 2/(9(k−1)) + sqrt(2/(9(k−1))) · z)³, rounded up; 1 for k ≤ 1.
pub fn kld_bound_with_quantile(k: usize, epsilon: f64, z: f64) -> usize {
    if k <= 1 {
        return 1;
    }
    let km1 = (k - 1) as f64;
    let a = 2.0 / (9.0 * km1);
    let b = 1.0 - a + a.sqrt() * z;
    (km1 / (2.0 * epsilon) * b * b * b).ceil() as usize
}

/// [`kld_bound_with_quantile`] with z = z_{1−δ}.
pub fn kld_bound(k: usize, epsilon: f64, delta: f64) -> usize {
    kld_bound_with_quantile(k, epsilon, normal_quantile(1.0 - delta))
}

/// KLD-adaptive sample size (Fox 2003): the bound for the number of bins a set occupies,
/// kept within [min, max], with the bins of the set being drawn.
#[derive(Debug, Clone)]
pub struct KldSampling {
    /// The bins occupied by the particles drawn since the last clear.
    pub bins: BinSet,
    epsilon: f64,
    /// z_{1−δ}, computed once.
    z: f64,
    min: usize,
    max: usize,
}

impl KldSampling {
    /// Sizes within [min, max] for error bound `epsilon`, confidence 1 − `delta`, bins of
    /// `bin` (m, m, rad); room for `max` bins.
    pub fn new(min: usize, max: usize, epsilon: f64, delta: f64, bin: [f64; 3]) -> KldSampling {
        KldSampling {
            bins: BinSet::new(max, bin),
            epsilon,
            z: normal_quantile(1.0 - delta),
            min,
            max,
        }
    }

    /// The unclamped bound for `k` occupied bins.
    pub fn bound(&self, k: usize) -> usize {
        kld_bound_with_quantile(k, self.epsilon, self.z)
    }

    /// Whether sequential sampling may stop after `n` draws (Fox 2003, Table 1's loop
    /// condition, with the lower bound `min`).
    pub fn enough(&self, n: usize) -> bool {
        n >= self.min && n >= self.bound(self.bins.len())
    }

    /// The size for the bins counted so far, within [min, max].
    pub fn target(&self) -> usize {
        self.bound(self.bins.len()).clamp(self.min, self.max)
    }

    pub fn max(&self) -> usize {
        self.max
    }
}

/// The set of occupied (x, y, θ) bins, as an open-addressing hash set of packed bin keys with
/// a fixed capacity: inserting never allocates, and clearing is O(1) (a generation counter).
#[derive(Debug, Clone)]
pub struct BinSet {
    keys: Vec<u64>,
    generation: Vec<u32>,
    current: u32,
    mask: usize,
    len: usize,
    inv_bin: [f64; 3],
}

impl BinSet {
    /// Room for `capacity` distinct bins (the table is kept at most half full); `bin` is the
    /// bin size (m, m, rad).
    pub fn new(capacity: usize, bin: [f64; 3]) -> Self {
        let slots = (2 * capacity.max(1)).next_power_of_two();
        Self {
            keys: vec![0; slots],
            generation: vec![0; slots],
            current: 1,
            mask: slots - 1,
            len: 0,
            inv_bin: bin.map(|b| 1.0 / b),
        }
    }

    pub fn clear(&mut self) {
        self.len = 0;
        if self.current == u32::MAX {
            self.generation.fill(0);
            self.current = 1;
        } else {
            self.current += 1;
        }
    }

    /// Number of distinct bins inserted since the last `clear`.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The packed key of the bin holding a pose: 21 bits per axis (±10⁶ bins of 0.2 m is
    /// ±200 km, far beyond any indoor map).
    #[inline]
    pub fn key(&self, x: f64, y: f64, theta: f64) -> u64 {
        let pack = |v: f64| ((floor_i64(v) + (1 << 20)) as u64) & 0x1F_FFFF;
        pack(x * self.inv_bin[0])
            | pack(y * self.inv_bin[1]) << 21
            | pack(normalize_angle(theta) * self.inv_bin[2]) << 42
    }

    /// Inserts the bin of a pose; `true` if the bin was empty. When the set is full (more
    /// distinct bins than its capacity), further new bins are counted but not stored, so
    /// `len` keeps growing and the caller's bound saturates at its maximum anyway.
    #[inline]
    pub fn insert(&mut self, x: f64, y: f64, theta: f64) -> bool {
        let key = self.key(x, y, theta);
        if 2 * self.len >= self.keys.len() {
            self.len += 1;
            return true;
        }
        // Fibonacci hashing: the high bits of key · 2⁶⁴/φ spread neighbouring bins.
        let mut slot = (key.wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 32) as usize & self.mask;
        loop {
            if self.generation[slot] != self.current {
                self.generation[slot] = self.current;
                self.keys[slot] = key;
                self.len += 1;
                return true;
            }
            if self.keys[slot] == key {
                return false;
            }
            slot = (slot + 1) & self.mask;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_tables() {
        assert!((normal_quantile(0.99) - 2.326_347_874_040_841).abs() < 1e-8);
        assert!((normal_quantile(0.95) - 1.644_853_626_951_472_2).abs() < 1e-8);
        assert!((normal_quantile(0.5)).abs() < 1e-15);
        assert!((normal_quantile(0.001) + 3.090_232_306_167_813_5).abs() < 1e-8);
        assert!(normal_quantile(1.0).is_nan() && normal_quantile(0.0).is_nan());
    }

    #[test]
    fn bound_matches_hand_computed_values() {
        // ε = 0.05, δ = 0.01, z = 2.326348.
        // k = 2:   a = 2/9 = 0.222222, 1 − a + √a·z = 0.777778 + 1.096660 = 1.874438,
        //          cubed 6.585773, × 1/(2·0.05) = 65.858 → 66.
        // k = 10:  a = 2/81 = 0.024691, 0.975309 + 0.365551 = 1.340860, cubed 2.410734,
        //          × 9/0.1 = 216.966 → 217.
        // k = 100: a = 2/891 = 0.002245, 0.997755 + 0.110219 = 1.107974, cubed 1.360157,
        //          × 99/0.1 = 1346.55 → 1347.
        assert_eq!(kld_bound(2, 0.05, 0.01), 66);
        assert_eq!(kld_bound(10, 0.05, 0.01), 217);
        assert_eq!(kld_bound(100, 0.05, 0.01), 1347);
        // ε = 0.1, δ = 0.05 (z = 1.644854): k = 10 → 84.51 → 85.
        assert_eq!(kld_bound(10, 0.1, 0.05), 85);
        assert_eq!(kld_bound(1, 0.05, 0.01), 1);
        assert_eq!(kld_bound(0, 0.05, 0.01), 1);
    }

    #[test]
    fn bin_set_counts_distinct_bins_and_clears() {
        let mut s = BinSet::new(16, [0.2, 0.2, 0.1745]);
        assert!(s.insert(0.05, 0.05, 0.0));
        assert!(!s.insert(0.15, 0.19, 0.1)); // same bin
        assert!(s.insert(0.25, 0.05, 0.0)); // next x bin
        assert!(s.insert(-0.05, 0.05, 0.0)); // negative side
        assert!(s.insert(0.05, 0.05, 0.2)); // next heading bin
        assert!(s.insert(0.05, 0.05, -3.1));
        assert!(!s.insert(0.05, 0.05, -3.1 + std::f64::consts::TAU)); // same angle wrapped
        assert_eq!(s.len(), 5);
        s.clear();
        assert_eq!(s.len(), 0);
        assert!(s.insert(0.05, 0.05, 0.0));
        // Saturation: more distinct bins than capacity keeps counting.
        let mut s = BinSet::new(4, [1.0, 1.0, 1.0]);
        for i in 0..20 {
            s.insert(i as f64, 0.0, 0.0);
        }
        assert_eq!(s.len(), 20);
    }

    #[test]
    fn kld_sampling_sizes_from_the_bins_within_bounds() {
        let mut k = KldSampling::new(50, 1000, 0.05, 0.01, [1.0, 1.0, 1.0]);
        k.bins.insert(0.5, 0.5, 0.0);
        // One bin: bound 1, clamped up to min.
        assert_eq!(k.target(), 50);
        assert!(!k.enough(49) && k.enough(50));
        for i in 1..10 {
            k.bins.insert(i as f64 + 0.5, 0.5, 0.0);
        }
        // Ten bins: 217 (hand-computed in bound_matches_hand_computed_values).
        assert_eq!(k.target(), 217);
        assert!(!k.enough(216) && k.enough(217));
        for i in 10..200 {
            k.bins.insert(i as f64 + 0.5, 0.5, 0.0);
        }
        assert_eq!(k.target(), 1000);
    }
}
