//! The sensing-mismatch measure of [004] §4.2: how well the observation
//! likelihood P(l|s) overlaps the belief Bel(l), estimated as in Augmented MCL (Thrun et al.,
//! Probabilistic Robotics Table 8.3) by the mean unnormalised importance weight of an update,
//! tracked by a short-term and a long-term average; their ratio w_fast / w_slow is the fit.
//!
//! Two changes make the figure comparable across filters with different sensors and rates
//! (the paper warns it is not comparable as a raw likelihood, §4.2):
//! - the weight of a particle is the per-unit geometric mean of its likelihood (per laser
//!   point, per access point): the raw product swings by orders of magnitude with the number
//!   of points in a reading, and its scale depends on the sensor;
//! - the averages are taken in log space and their rates are set in seconds, not updates: a
//!   1 Hz WiFi filter and a 10 Hz laser filter then forget at the same pace, and the ratio
//!   exp(L_fast − L_slow) is free of each sensor's likelihood scale.

/// Short- and long-term averages of the per-unit log mean likelihood of a filter's updates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitTracker {
    /// Time constants of the two averages, s.
    pub tau_fast_s: f64,
    pub tau_slow_s: f64,
    fast: f64,
    slow: f64,
    last_stamp: f64,
    started: bool,
}

impl Default for FitTracker {
    fn default() -> Self {
        Self::new(2.0, 60.0)
    }
}

impl FitTracker {
    pub fn new(tau_fast_s: f64, tau_slow_s: f64) -> Self {
        Self {
            tau_fast_s,
            tau_slow_s,
            fast: 0.0,
            slow: 0.0,
            last_stamp: 0.0,
            started: false,
        }
    }

    /// Records the per-unit log mean likelihood `log_mean` of an update at `stamp`.
    /// Non-finite values are ignored.
    pub fn record(&mut self, stamp: f64, log_mean: f64) {
        if !log_mean.is_finite() {
            return;
        }
        if !self.started {
            self.fast = log_mean;
            self.slow = log_mean;
            self.last_stamp = stamp;
            self.started = true;
            return;
        }
        // An update at the same instant still counts, as a small step (readings of one tick).
        let dt = (stamp - self.last_stamp).max(1e-3);
        self.last_stamp = stamp.max(self.last_stamp);
        let a_fast = 1.0 - (-dt / self.tau_fast_s).exp();
        let a_slow = 1.0 - (-dt / self.tau_slow_s).exp();
        self.fast += a_fast * (log_mean - self.fast);
        self.slow += a_slow * (log_mean - self.slow);
    }

    /// Records an update in which the sensor saw too little to match (`log_mean` the
    /// all-outlier level). Only the fast average follows it: the slow one is the long-term
    /// level of informative updates, so a sensor blind for a minute keeps reporting a poor
    /// fit instead of getting used to being blind (with both averages following, the ratio
    /// returned to 1 after τ_slow and a blind laser looked as good as a tracking WiFi).
    pub fn record_blind(&mut self, stamp: f64, log_mean: f64) {
        if !self.started || !log_mean.is_finite() {
            return;
        }
        let dt = (stamp - self.last_stamp).max(1e-3);
        self.last_stamp = stamp.max(self.last_stamp);
        self.fast += (1.0 - (-dt / self.tau_fast_s).exp()) * (log_mean - self.fast);
    }

    /// w_fast / w_slow; None before the first update.
    pub fn fit(&self) -> Option<f64> {
        self.started.then(|| (self.fast - self.slow).exp())
    }
}

/// log((1/N) Σ_i exp(logw_i / units)): the log of the mean over particles of each particle's
/// per-unit geometric mean likelihood. `units` is clamped to at least 1. Allocation-free.
pub fn per_unit_log_mean(logw: &[f64], units: usize) -> f64 {
    if logw.is_empty() {
        return f64::NAN;
    }
    let inv = 1.0 / units.max(1) as f64;
    let max = logw
        .iter()
        .map(|l| l * inv)
        .fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return max;
    }
    let sum: f64 = logw.iter().map(|l| (l * inv - max).exp()).sum();
    max + (sum / logw.len() as f64).ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn per_unit_log_mean_is_hand_computed() {
        // Two particles, 2 units: per-unit likelihoods e^-1 and e^-3; mean (e^-1 + e^-3) / 2.
        let v = per_unit_log_mean(&[-2.0, -6.0], 2);
        let expect = ((-1.0f64).exp() + (-3.0f64).exp()) / 2.0;
        assert!((v - expect.ln()).abs() < 1e-12);
        // Huge magnitudes do not underflow.
        assert!((per_unit_log_mean(&[-1e5, -1e5], 1) + 1e5).abs() < 1e-9);
    }

    #[test]
    fn fit_drops_when_the_fit_gets_worse_and_is_scale_free() {
        for offset in [0.0, -40.0] {
            let mut t = FitTracker::default();
            for k in 0..600 {
                t.record(k as f64 * 0.1, offset - 0.5);
            }
            assert!((t.fit().unwrap() - 1.0).abs() < 1e-9);
            for k in 600..620 {
                t.record(k as f64 * 0.1, offset - 2.5);
            }
            // 2 s at τ_fast = 2 s: L_fast moved 1 − e^-1 of the way; L_slow by 1 − e^-(2/60).
            let f = t.fit().unwrap().ln();
            let expect = -2.0 * ((1.0 - (-1.0f64).exp()) - (1.0 - (-2.0f64 / 60.0).exp()));
            assert!((f - expect).abs() < 0.02, "{f} vs {expect}");
        }
        assert_eq!(FitTracker::default().fit(), None);
    }

    #[test]
    fn a_blind_sensor_keeps_a_poor_fit() {
        let mut t = FitTracker::default();
        for k in 0..600 {
            t.record(k as f64 * 0.1, -0.5);
        }
        for k in 600..1800 {
            t.record_blind(k as f64 * 0.1, -5.0);
        }
        // Two minutes blind: fast is at the blind level, slow still at the informative one.
        assert!((t.fit().unwrap().ln() + 4.5).abs() < 1e-6);
    }
}
