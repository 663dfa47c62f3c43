//! The particle set every particle filter of the crate keeps, and the steps of a filter on it,
//! after Beluga's composable particle-filter steps: a filter is its sensor model plus a
//! choice of these steps and of their policies ([`ResamplePolicy`], [`Injection`], fixed or
//! [`KldSampling`] size, [`PointEstimate`]).
//!
//! The set is struct-of-arrays (x, y, θ, weight, per-particle log-likelihood) with its
//! scratch buffers (resampling indices, the columns resampling copies into, the clustering's
//! scratch), all allocated once at the largest size the filter may reach: no step allocates.
//! Steps that draw random numbers draw them in a fixed, documented order, so that a seeded
//! run is reproducible.

use crate::error::LocalizationError;
use crate::filter::cluster::{point_estimate, ClusterScratch, PointEstimate};
use crate::filter::initial_belief::{
    gaussian_is_valid, gaussian_pose, InitialBelief, UniformInRegions,
};
use crate::filter::kld::{BinSet, KldSampling};
use crate::filter::motion::{apply_increment, OdometryMotionModel};
use crate::filter::particles::{
    effective_sample_size, normalize_weights, weights_from_log_likelihoods, HeadingTrig,
};
use crate::filter::resampling::{low_variance_indices, Injection};
use atrium_robots::Pose2;
use nalgebra::Matrix3;
use rand::Rng;

/// Read access to the columns of the set being replaced, for [`ParticleSet::rebuild`].
#[derive(Debug, Clone, Copy)]
pub struct Columns<'a> {
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub th: &'a [f64],
}

impl Columns<'_> {
    #[inline]
    pub fn get(&self, i: usize) -> [f64; 3] {
        [self.x[i], self.y[i], self.th[i]]
    }
}

/// A weighted particle set over (x, y, θ) with room for `capacity` particles.
#[derive(Debug, Clone, Default)]
pub struct ParticleSet {
    /// Live particles; the columns below hold `capacity`.
    n: usize,
    x: Vec<f64>,
    y: Vec<f64>,
    th: Vec<f64>,
    w: Vec<f64>,
    /// Per-particle log-likelihood of the current observation.
    logw: Vec<f64>,
    /// Resampling targets, swapped with x / y / θ.
    x2: Vec<f64>,
    y2: Vec<f64>,
    th2: Vec<f64>,
    idx: Vec<usize>,
    /// The weights are all 1/n (just drawn or resampled): a log-space reweighting then needs
    /// no prior term, and adding the same constant to every log-weight would only cost
    /// rounding.
    uniform: bool,
    cluster: ClusterScratch,
}

impl ParticleSet {
    /// An empty set with buffers for `capacity` particles.
    pub fn with_capacity(capacity: usize) -> ParticleSet {
        ParticleSet {
            n: 0,
            x: vec![0.0; capacity],
            y: vec![0.0; capacity],
            th: vec![0.0; capacity],
            w: vec![0.0; capacity],
            logw: vec![0.0; capacity],
            x2: vec![0.0; capacity],
            y2: vec![0.0; capacity],
            th2: vec![0.0; capacity],
            idx: vec![0; capacity],
            uniform: true,
            cluster: ClusterScratch::with_capacity(capacity),
        }
    }

    pub fn len(&self) -> usize {
        self.n
    }

    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    pub fn capacity(&self) -> usize {
        self.x.len()
    }

    pub fn x(&self) -> &[f64] {
        &self.x[..self.n]
    }

    pub fn y(&self) -> &[f64] {
        &self.y[..self.n]
    }

    pub fn th(&self) -> &[f64] {
        &self.th[..self.n]
    }

    pub fn weights(&self) -> &[f64] {
        &self.w[..self.n]
    }

    #[inline]
    pub fn pose(&self, i: usize) -> Pose2 {
        Pose2::new(self.x[i], self.y[i], self.th[i])
    }

    #[inline]
    pub fn set_pose(&mut self, i: usize, p: Pose2) {
        (self.x[i], self.y[i], self.th[i]) = (p.x, p.y, p.theta);
    }

    /// The live particles and their weights.
    pub fn iter(&self) -> impl Iterator<Item = (Pose2, f64)> + '_ {
        (0..self.n).map(|i| (self.pose(i), self.w[i]))
    }

    /// The live x, y, θ columns, to move particles in place.
    pub fn columns_mut(&mut self) -> [&mut [f64]; 3] {
        let n = self.n;
        [&mut self.x[..n], &mut self.y[..n], &mut self.th[..n]]
    }

    /// The live per-particle log-likelihoods, for a sensor model to fill before
    /// [`ParticleSet::weigh_by_log_likelihoods`].
    pub fn log_likelihoods_mut(&mut self) -> &mut [f64] {
        &mut self.logw[..self.n]
    }

    pub fn log_likelihoods(&self) -> &[f64] {
        &self.logw[..self.n]
    }

    /// The resampling index buffer (capacity long), for a filter that draws its own indices
    /// (the appearance filter's auxiliary pairs) before [`ParticleSet::rebuild`].
    pub fn indices_mut(&mut self) -> &mut [usize] {
        &mut self.idx
    }

    /// Makes the first `n` particles live with equal weights.
    pub fn make_uniform(&mut self, n: usize) {
        self.n = n;
        self.w[..n].fill(1.0 / n as f64);
        self.uniform = true;
    }

    // ---- Sampling an initial belief ----------------------------------------------------

    /// Draws `n` particles from `draw` (in particle order), with equal weights.
    pub fn sample<R: Rng + ?Sized, E>(
        &mut self,
        n: usize,
        rng: &mut R,
        mut draw: impl FnMut(&mut R) -> Result<Pose2, E>,
    ) -> Result<(), E> {
        for i in 0..n {
            let p = draw(rng)?;
            self.set_pose(i, p);
        }
        self.make_uniform(n);
        Ok(())
    }

    /// Redraws `n` particles from a Gaussian around `pose` (the re-seeding of a lost filter
    /// by a sensor chooser, `chooser.rs`). Returns false, leaving the set alone, when `pose`
    /// or `sigma` is not finite (or sigma < 0).
    pub fn sample_gaussian<R: Rng + ?Sized>(
        &mut self,
        n: usize,
        pose: Pose2,
        sigma: [f64; 3],
        rng: &mut R,
    ) -> bool {
        if !gaussian_is_valid(&pose, &sigma) {
            return false;
        }
        let _ = self.sample(n, rng, |rng| Ok::<_, ()>(gaussian_pose(&pose, &sigma, rng)));
        true
    }

    /// Draws `n` particles from `init`: Gaussian around its pose, or uniform over its
    /// polygons (or over `extent`, x0, y0, x1, y1, when it has none) with uniform heading.
    pub fn sample_initial_belief<R: Rng + ?Sized>(
        &mut self,
        n: usize,
        init: &InitialBelief,
        extent: [f64; 4],
        rng: &mut R,
    ) -> Result<(), LocalizationError> {
        match init {
            InitialBelief::Tracking { pose, sigma } => {
                if !self.sample_gaussian(n, *pose, *sigma, rng) {
                    return Err(LocalizationError::InvalidInitialBelief {
                        field: "pose",
                        reason: format!("pose and sigma must be finite, got {pose:?} {sigma:?}"),
                    });
                }
                Ok(())
            }
            InitialBelief::Global { regions } => {
                let uniform = UniformInRegions::new(regions, extent)?;
                self.sample(n, rng, |rng| uniform.sample(rng))
            }
        }
    }

    /// KLD-sampling proper (Fox 2003): particles are drawn from `draw` one at a time until
    /// their number reaches the bound for the bins they occupy (at most `kld.max()`).
    pub fn sample_kld<R: Rng + ?Sized>(
        &mut self,
        kld: &mut KldSampling,
        rng: &mut R,
        mut draw: impl FnMut(&mut R) -> Pose2,
    ) {
        kld.bins.clear();
        let max = kld.max().min(self.capacity());
        let mut n = 0;
        while n < max {
            let p = draw(rng);
            self.set_pose(n, p);
            kld.bins.insert(p.x, p.y, p.theta);
            n += 1;
            if kld.enough(n) {
                break;
            }
        }
        self.make_uniform(n);
    }

    // ---- Propagation ---------------------------------------------------------------------

    /// Moves every particle by the odometry accumulated in `pending` (Thrun et al.,
    /// *Probabilistic Robotics*, Table 5.6: three normal draws per particle, in particle
    /// order) and clears it. Standing still, nothing happens: particles would otherwise
    /// spread while the robot waits.
    pub fn propagate<R: Rng + ?Sized>(
        &mut self,
        model: &OdometryMotionModel,
        pending: &mut Pose2,
        rng: &mut R,
    ) {
        self.propagate_constrained(model, pending, rng, |_, _, to| to);
    }

    /// [`ParticleSet::propagate`] with a motion constraint: `constrain(i, from, to)` gets the
    /// particle's index, its (x, y) before the motion and its sampled pose after it, and
    /// returns where it is kept (the WiFi filter's free space puts a particle that left the
    /// building back inside).
    pub fn propagate_constrained<R: Rng + ?Sized>(
        &mut self,
        model: &OdometryMotionModel,
        pending: &mut Pose2,
        rng: &mut R,
        mut constrain: impl FnMut(usize, [f64; 2], [f64; 3]) -> [f64; 3],
    ) {
        let p = *pending;
        if p.x == 0.0 && p.y == 0.0 && p.theta == 0.0 {
            return;
        }
        let inc = model.decompose(&Pose2::default(), &p);
        for i in 0..self.n {
            let (x0, y0) = (self.x[i], self.y[i]);
            let (x, y, th) = apply_increment(x0, y0, self.th[i], &inc, rng);
            [self.x[i], self.y[i], self.th[i]] = constrain(i, [x0, y0], [x, y, th]);
        }
        *pending = Pose2::default();
    }

    // ---- Reweighting -------------------------------------------------------------------

    /// Sets the log-likelihood of every particle from its pose, then weighs by them.
    #[inline]
    pub fn reweight_log(&mut self, mut loglik: impl FnMut(f64, f64, f64) -> f64) {
        for i in 0..self.n {
            self.logw[i] = loglik(self.x[i], self.y[i], self.th[i]);
        }
        self.weigh_by_log_likelihoods();
    }

    /// [`ParticleSet::reweight_log`] for a sensor model that computes every particle's
    /// log-likelihood at once: `loglik(x, y, θ, out)` gets the live columns and fills `out`.
    #[inline]
    pub fn reweight_log_columns(
        &mut self,
        loglik: impl FnOnce(&[f64], &[f64], &[f64], &mut [f64]),
    ) {
        let n = self.n;
        loglik(
            &self.x[..n],
            &self.y[..n],
            &self.th[..n],
            &mut self.logw[..n],
        );
        self.weigh_by_log_likelihoods();
    }

    /// Weights ∝ prior weight × exp(log-likelihood), normalised in log space (the raw
    /// product of many densities under- or overflows). Degenerate log-likelihoods (every
    /// particle impossible) give uniform weights.
    pub fn weigh_by_log_likelihoods(&mut self) {
        let n = self.n;
        if !self.uniform {
            for (l, w) in self.logw[..n].iter_mut().zip(&self.w[..n]) {
                *l += w.ln();
            }
        }
        weights_from_log_likelihoods(&self.logw[..n], &mut self.w[..n]);
        self.uniform = false;
    }

    /// Multiplies every weight by `likelihood(pose, stored log-likelihood)` and normalises:
    /// for sensor models whose likelihood is a mixture computed as a density, not a log
    /// (the stored log-likelihood is whatever the sensor model left in
    /// [`ParticleSet::log_likelihoods_mut`]).
    #[inline]
    pub fn reweight(&mut self, mut likelihood: impl FnMut(Pose2, f64) -> f64) {
        let n = self.n;
        for i in 0..n {
            self.w[i] *= likelihood(self.pose(i), self.logw[i]);
        }
        normalize_weights(&mut self.w[..n]);
        self.uniform = false;
    }

    /// Effective sample size 1 / Σ w² of the (normalised) weights.
    pub fn ess(&self) -> f64 {
        effective_sample_size(self.weights())
    }

    // ---- Resampling ----------------------------------------------------------------------

    /// Low-variance resampling to `m` particles (at most the capacity) with `injection`,
    /// whose particles come from `draw`. Random numbers: one for the comb, then, with
    /// [`Injection::Probability`], one per new particle and `draw`'s for each injected one;
    /// with [`Injection::Count`] k, per injected particle its slot then `draw`'s.
    pub fn resample<R: Rng + ?Sized>(
        &mut self,
        m: usize,
        injection: Injection,
        rng: &mut R,
        mut draw: impl FnMut(&mut R) -> Pose2,
    ) {
        let m = m.min(self.capacity());
        let p = match injection {
            Injection::Probability(p) => p,
            _ => 0.0,
        };
        self.fill_injected(m, p, rng, &mut draw, None);
        self.commit_scratch(m);
        if let Injection::Count(k) = injection {
            for _ in 0..k.min(m) {
                let i = rng.random_range(0..m);
                let q = draw(rng);
                self.set_pose(i, q);
            }
        }
    }

    /// Low-variance resampling to `m` particles without injection (one random number).
    pub fn resample_plain<R: Rng + ?Sized>(&mut self, m: usize, rng: &mut R) {
        self.resample(m, Injection::None, rng, |_| {
            unreachable!("nothing is injected")
        });
    }

    /// KLD-sized low-variance resampling with injection probability `p_inject`. The set is
    /// first resampled at its current size and the bins it occupies counted (injected
    /// particles included); if the bound for that many bins asks for another size, it is
    /// resampled again at that size. Fox's sequential draw cannot be combined with a
    /// systematic comb, whose step needs the count in advance; this sizes the set from the
    /// spread of the same posterior.
    pub fn resample_kld<R: Rng + ?Sized>(
        &mut self,
        kld: &mut KldSampling,
        p_inject: f64,
        rng: &mut R,
        mut draw: impl FnMut(&mut R) -> Pose2,
    ) {
        let n = self.n;
        self.fill_injected(n, p_inject, rng, &mut draw, Some(&mut kld.bins));
        let target = kld.target().min(self.capacity());
        if target != n {
            self.fill_injected(target, p_inject, rng, &mut draw, Some(&mut kld.bins));
        }
        self.commit_scratch(target);
    }

    /// Resamples into the scratch columns at size `m`, each new particle replaced by a draw
    /// with probability `p_inject`, counting the bins of the new set when given them.
    fn fill_injected<R: Rng + ?Sized>(
        &mut self,
        m: usize,
        p_inject: f64,
        rng: &mut R,
        draw: &mut impl FnMut(&mut R) -> Pose2,
        mut bins: Option<&mut BinSet>,
    ) {
        let n = self.n;
        if !low_variance_indices(&self.w[..n], &mut self.idx[..m], rng) {
            // All weights vanished (the sensor models' floors prevent it; kept for safety):
            // an even spread over the current particles.
            for (k, slot) in self.idx[..m].iter_mut().enumerate() {
                *slot = k * n / m;
            }
        }
        if let Some(b) = bins.as_deref_mut() {
            b.clear();
        }
        self.fill_scratch(m, rng, |i, src, rng| {
            let q = if p_inject > 0.0 && rng.random::<f64>() < p_inject {
                let p = draw(rng);
                [p.x, p.y, p.theta]
            } else {
                src.get(i)
            };
            if let Some(b) = bins.as_deref_mut() {
                b.insert(q[0], q[1], q[2]);
            }
            q
        });
    }

    /// Replaces the set by `m` new particles with equal weights: the k-th is
    /// `make(indices_mut()[k], old columns, rng)`. The general resampling step, for a filter
    /// that draws its own indices (the appearance filter's auxiliary pairs).
    pub fn rebuild<R: Rng + ?Sized>(
        &mut self,
        m: usize,
        rng: &mut R,
        make: impl FnMut(usize, Columns, &mut R) -> [f64; 3],
    ) {
        self.fill_scratch(m, rng, make);
        self.commit_scratch(m);
    }

    fn fill_scratch<R: Rng + ?Sized>(
        &mut self,
        m: usize,
        rng: &mut R,
        mut make: impl FnMut(usize, Columns, &mut R) -> [f64; 3],
    ) {
        let src = Columns {
            x: &self.x,
            y: &self.y,
            th: &self.th,
        };
        for k in 0..m {
            [self.x2[k], self.y2[k], self.th2[k]] = make(self.idx[k], src, rng);
        }
    }

    fn commit_scratch(&mut self, m: usize) {
        std::mem::swap(&mut self.x, &mut self.x2);
        std::mem::swap(&mut self.y, &mut self.y2);
        std::mem::swap(&mut self.th, &mut self.th2);
        self.make_uniform(m);
    }

    // ---- Estimate ------------------------------------------------------------------------

    /// The point estimate `kind` asks for (the weighted mean, or the heaviest cluster's) and
    /// its covariance.
    pub fn estimate(&mut self, kind: PointEstimate) -> (Pose2, Matrix3<f64>) {
        self.estimate_with(kind, HeadingTrig::Compute)
    }

    /// [`ParticleSet::estimate`] with the headings' sines and cosines from `trig`, which
    /// must hold those of the live particles.
    pub fn estimate_with(
        &mut self,
        kind: PointEstimate,
        trig: HeadingTrig<'_>,
    ) -> (Pose2, Matrix3<f64>) {
        let n = self.n;
        let (mean, covariance, _) = point_estimate(
            kind,
            &self.x[..n],
            &self.y[..n],
            &self.th[..n],
            &self.w[..n],
            trig,
            &mut self.cluster,
        );
        (mean, covariance)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::resampling::ResamplePolicy;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn set_of(poses: &[[f64; 3]]) -> ParticleSet {
        let mut s = ParticleSet::with_capacity(poses.len());
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let mut it = poses.iter();
        s.sample(poses.len(), &mut rng, |_| {
            let p = it.next().unwrap();
            Ok::<_, ()>(Pose2::new(p[0], p[1], p[2]))
        })
        .unwrap();
        s
    }

    #[test]
    fn log_reweighting_uses_prior_weights_once_they_are_not_uniform() {
        let mut s = set_of(&[[0.0; 3], [1.0, 0.0, 0.0]]);
        // Uniform prior: weights ∝ e^l, here 1 : 3.
        s.reweight_log(|x, _, _| if x > 0.5 { 3f64.ln() - 1000.0 } else { -1000.0 });
        assert!((s.weights()[0] - 0.25).abs() < 1e-12, "{:?}", s.weights());
        // Second update without resampling: 0.25·1 : 0.75·3 = 1 : 9.
        s.reweight_log(|x, _, _| if x > 0.5 { 3f64.ln() } else { 0.0 });
        assert!((s.weights()[0] - 0.1).abs() < 1e-12, "{:?}", s.weights());
        // ESS of (0.1, 0.9) = 1 / 0.82.
        assert!((s.ess() - 1.0 / 0.82).abs() < 1e-12);
        assert!(!ResamplePolicy::BelowEss(0.5).due(s.ess(), 2));
        assert!(ResamplePolicy::BelowEss(0.7).due(s.ess(), 2));
    }

    #[test]
    fn resampling_copies_whole_particles_and_injects_as_asked() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut s = set_of(&[[0.0, 10.0, 0.1], [1.0, 11.0, 0.2], [2.0, 12.0, 0.3]]);
        s.reweight(|p, _| if p.x == 1.0 { 1.0 } else { 0.0 });
        s.resample(3, Injection::None, &mut rng, |_| unreachable!());
        assert_eq!(s.len(), 3);
        assert!(s
            .iter()
            .all(|(p, w)| p == Pose2::new(1.0, 11.0, 0.2) && w == 1.0 / 3.0));
        // Shrinking keeps whole particles too; more than the capacity is capped.
        s.resample_plain(2, &mut rng);
        assert_eq!(s.len(), 2);
        s.resample_plain(7, &mut rng);
        assert_eq!(s.len(), 3);
        // Every new particle injected.
        let far = Pose2::new(50.0, 50.0, 0.0);
        s.resample(3, Injection::Probability(1.0), &mut rng, |_| far);
        assert!(s.iter().all(|(p, _)| p == far));
        // Two injected into a set of three identical particles: one or two slots (a slot
        // may be drawn twice).
        let mut s = set_of(&[[0.0; 3]; 3]);
        s.resample(3, Injection::Count(2), &mut rng, |_| far);
        let injected = s.iter().filter(|(p, _)| *p == far).count();
        assert!((1..=2).contains(&injected), "{injected}");
    }

    #[test]
    fn kld_resampling_shrinks_a_tight_set_and_sampling_stops_at_the_bound() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut kld = KldSampling::new(10, 200, 0.05, 0.01, [0.2, 0.2, 0.2]);
        let mut s = ParticleSet::with_capacity(200);
        // All in one bin: the bound is 1, so sampling stops at min.
        s.sample_kld(&mut kld, &mut rng, |_| Pose2::new(0.05, 0.05, 0.05));
        assert_eq!(s.len(), 10);
        // Spread over 200 bins: the bound exceeds max, so sampling stops at max.
        let mut k = 0;
        s.sample_kld(&mut kld, &mut rng, |_| {
            k += 1;
            Pose2::new(k as f64, 0.0, 0.0)
        });
        assert_eq!(s.len(), 200);
        // Resampled onto one particle: one bin, back to min.
        s.reweight(|p, _| if p.x == 8.0 { 1.0 } else { 0.0 });
        s.resample_kld(&mut kld, 0.0, &mut rng, |_| unreachable!());
        assert_eq!(s.len(), 10);
        assert!(s.iter().all(|(p, _)| p.x == 8.0));
    }

    #[test]
    fn propagation_stands_still_without_odometry_and_obeys_the_constraint() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let model = OdometryMotionModel::new([0.0; 4]);
        let mut s = set_of(&[[0.0; 3], [1.0, 0.0, 0.0]]);
        let mut pending = Pose2::default();
        s.propagate(&model, &mut pending, &mut rng);
        assert_eq!(s.x(), &[0.0, 1.0]);
        pending = Pose2::new(2.0, 0.0, 0.0);
        // Keep x below 2.5: the second particle (to 3.0) stays where it was.
        s.propagate_constrained(&model, &mut pending, &mut rng, |_, from, to| {
            if to[0] > 2.5 {
                [from[0], from[1], to[2]]
            } else {
                to
            }
        });
        assert_eq!(s.x(), &[2.0, 1.0]);
        assert_eq!(pending, Pose2::default());
    }

    #[test]
    fn estimates_are_the_weighted_mean_or_the_heaviest_cluster() {
        let mut s = set_of(&[[0.0; 3], [0.0; 3], [10.0, 0.0, 0.0]]);
        let (mean, _) = s.estimate(PointEstimate::WeightedMean);
        assert!((mean.x - 10.0 / 3.0).abs() < 1e-12);
        let (heavy, cov) = s.estimate(PointEstimate::HeaviestCluster);
        assert_eq!(heavy.x, 0.0);
        assert_eq!(cov[(0, 0)], 0.0);
    }
}
