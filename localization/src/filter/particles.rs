//! Pieces every particle filter here shares besides the set itself (`particle_set.rs`): the
//! weighted estimate of struct-of-arrays columns, weight normalisation, the odometry a filter
//! has received but not yet applied and the estimate carried forward by it, and the tally of
//! the readings a filter used and refused.

use crate::error::LocalizationError;
use crate::localizer::{Estimate, OdometryDelta};
use atrium_robots::{normalize_angle, Pose2};
use nalgebra::{Matrix3, Vector3};

/// Weighted mean (circular mean for θ) and weighted covariance over (x, y, θ) of the first
/// `w.len()` particles; the weights must sum to one.
pub fn weighted_mean_covariance(
    x: &[f64],
    y: &[f64],
    th: &[f64],
    w: &[f64],
) -> (Pose2, Matrix3<f64>) {
    weighted_mean_covariance_of(x, y, th, w, HeadingTrig::Compute, |_| true)
}

/// Where an estimate gets the sines and cosines of the particles' headings: computed from
/// θ, or given by a sensor model that computed them with the same `sin_cos` for the same
/// headings (so the estimate is the same bit for bit, without a second `sin_cos` per
/// particle).
#[derive(Debug, Clone, Copy, Default)]
pub enum HeadingTrig<'a> {
    #[default]
    Compute,
    Given {
        sin: &'a [f64],
        cos: &'a [f64],
    },
}

impl HeadingTrig<'_> {
    /// (sin θᵢ, cos θᵢ) of particle `i` of `th`.
    #[inline]
    fn sin_cos(&self, th: &[f64], i: usize) -> (f64, f64) {
        match self {
            HeadingTrig::Compute => th[i].sin_cos(),
            HeadingTrig::Given { sin, cos } => (sin[i], cos[i]),
        }
    }
}

/// [`weighted_mean_covariance`] of the particles `keep` selects, their weights renormalised
/// (the estimate of one cluster). An empty selection gives the origin with zero covariance.
pub fn weighted_mean_covariance_of(
    x: &[f64],
    y: &[f64],
    th: &[f64],
    w: &[f64],
    trig: HeadingTrig<'_>,
    keep: impl Fn(usize) -> bool,
) -> (Pose2, Matrix3<f64>) {
    let (mut sw, mut mx, mut my, mut ms, mut mc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (i, &wi) in w.iter().enumerate() {
        if !keep(i) {
            continue;
        }
        sw += wi;
        mx += wi * x[i];
        my += wi * y[i];
        let (s, c) = trig.sin_cos(th, i);
        ms += wi * s;
        mc += wi * c;
    }
    if sw.is_nan() || sw <= 0.0 {
        return (Pose2::default(), Matrix3::zeros());
    }
    let (mx, my) = (mx / sw, my / sw);
    let mt = ms.atan2(mc);
    let mut cov = Matrix3::zeros();
    for (i, &wi) in w.iter().enumerate() {
        if !keep(i) {
            continue;
        }
        let d = Vector3::new(x[i] - mx, y[i] - my, normalize_angle(th[i] - mt));
        cov += (wi / sw) * d * d.transpose();
    }
    (Pose2::new(mx, my, mt), cov)
}

/// Checks a particle filter's `particles` count: at least 1 and at most
/// [`MAX_PARTICLES`](crate::limits::MAX_PARTICLES).
pub fn validate_particle_count(particles: usize) -> Result<(), String> {
    use crate::limits::{check_count_min1, MAX_PARTICLES};
    check_count_min1("particles", particles, MAX_PARTICLES, "MAX_PARTICLES")
}

/// Adds one odometry step to the motion not yet applied to the particles, and advances the
/// filter's clock. Non-finite odometry is ignored (a broken encoder reading must not poison
/// the particle set).
pub fn accumulate_odometry(pending: &mut Pose2, stamp: &mut f64, delta: &OdometryDelta) {
    if !delta.from.is_finite() || !delta.to.is_finite() {
        return;
    }
    *pending = pending.compose(&delta.from.between(&delta.to));
    *stamp = stamp.max(delta.stamp);
}

/// The estimate `mean` (with `covariance`) of the last sensor update, moved by the odometry
/// `pending` received since; the covariance is carried through the composition to first
/// order. Filters apply odometry lazily, just before the next observation, so without this
/// an estimate read between observations would lag the robot.
pub fn carried_by_odometry(
    mean: &Pose2,
    covariance: &Matrix3<f64>,
    pending: &Pose2,
    stamp: f64,
) -> Estimate {
    let p = pending;
    let (s, c) = mean.theta.sin_cos();
    let j = Matrix3::new(
        1.0,
        0.0,
        -s * p.x - c * p.y,
        0.0,
        1.0,
        c * p.x - s * p.y,
        0.0,
        0.0,
        1.0,
    );
    Estimate {
        stamp,
        pose: mean.compose(p),
        covariance: j * covariance * j.transpose(),
    }
}

/// Divides the weights by their sum; degenerate weights (sum zero, NaN or infinite) become
/// uniform, so a filter whose observation explained nothing keeps its particles.
pub fn normalize_weights(w: &mut [f64]) {
    let sum: f64 = w.iter().sum();
    if !(sum.is_finite() && sum > 0.0) {
        w.fill(1.0 / w.len().max(1) as f64);
    } else {
        for v in w.iter_mut() {
            *v /= sum;
        }
    }
}

/// Normalised weights from log-likelihoods, computed in log space (the raw product of many
/// densities under- or overflows): w_i ∝ exp(logw_i − max_j logw_j). Degenerate
/// log-likelihoods (all −∞ or NaN) give uniform weights. The sum is inverted once and
/// multiplied in (MCL's arithmetic since its first version: its seeded runs depend on it).
pub fn weights_from_log_likelihoods(logw: &[f64], w: &mut [f64]) {
    let max = logw.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut sum = 0.0;
    for (wi, &l) in w.iter_mut().zip(logw) {
        *wi = (l - max).exp();
        sum += *wi;
    }
    if !(sum.is_finite() && sum > 0.0) {
        w.fill(1.0 / w.len().max(1) as f64);
        return;
    }
    let inv = 1.0 / sum;
    for wi in w.iter_mut() {
        *wi *= inv;
    }
}

/// Effective sample size 1 / Σ w² of normalised weights.
pub fn effective_sample_size(w: &[f64]) -> f64 {
    1.0 / w.iter().map(|v| v * v).sum::<f64>()
}

/// What a particle filter's `predict` and `estimate` amount to: the odometry received but
/// not yet applied to the particles (filters apply it lazily, just before the next
/// observation), the filter's clock, and the estimate of its last sensor update.
#[derive(Debug, Clone, Copy, Default)]
pub struct CarriedEstimate {
    /// Odometry accumulated since it was last applied, in the robot frame.
    pub pending: Pose2,
    pub stamp: f64,
    pub mean: Pose2,
    pub covariance: Matrix3<f64>,
}

impl CarriedEstimate {
    /// [`accumulate_odometry`].
    pub fn accumulate(&mut self, delta: &OdometryDelta) {
        accumulate_odometry(&mut self.pending, &mut self.stamp, delta);
    }

    /// Advances the clock to a reading's stamp.
    pub fn observed_at(&mut self, stamp: f64) {
        self.stamp = self.stamp.max(stamp);
    }

    /// Sets the estimate of the last sensor update.
    pub fn set(&mut self, (mean, covariance): (Pose2, Matrix3<f64>)) {
        self.mean = mean;
        self.covariance = covariance;
    }

    /// [`carried_by_odometry`]: the last estimate moved by the pending odometry.
    pub fn estimate(&self) -> Estimate {
        carried_by_odometry(&self.mean, &self.covariance, &self.pending, self.stamp)
    }
}

/// What a filter did with the readings it was given: the sensor updates it applied, and the
/// readings it refused (wrong size, non-finite values) with the last reason. A bad reading is
/// counted, never a panic nor an error that stops a run.
#[derive(Debug, Clone, Default)]
pub struct ReadingTally {
    pub updates: usize,
    pub rejected: usize,
    pub last_error: Option<LocalizationError>,
}

impl ReadingTally {
    pub fn record(&mut self, e: LocalizationError) {
        self.rejected += 1;
        self.last_error = Some(e);
    }

    /// The outcome of a reading stamped `stamp`: the filter's clock advances to it when it
    /// was used; a refused one is counted and leaves the clock alone.
    pub fn settle(
        &mut self,
        outcome: Result<(), LocalizationError>,
        stamp: f64,
        carry: &mut CarriedEstimate,
    ) {
        match outcome {
            Ok(()) => carry.observed_at(stamp),
            Err(e) => self.record(e),
        }
    }
}

/// The counts of a filter that keeps a [`ReadingTally`] (the camera filters, whose readings
/// can be malformed): one accessor to implement, the rest follow.
pub trait ReadingCounts {
    fn tally(&self) -> &ReadingTally;

    /// Sensor updates applied so far.
    fn updates(&self) -> usize {
        self.tally().updates
    }

    /// Readings refused so far.
    fn rejected(&self) -> usize {
        self.tally().rejected
    }

    /// Why the last refused reading was refused.
    fn last_error(&self) -> Option<&LocalizationError> {
        self.tally().last_error.as_ref()
    }
}

/// Poses as columns, with their headings' sines and cosines: computed once for all the beams
/// of a scan.
#[derive(Debug, Clone, Copy)]
pub struct Poses<'a> {
    pub x: &'a [f64],
    pub y: &'a [f64],
    pub sin: &'a [f64],
    pub cos: &'a [f64],
}

impl<'a> Poses<'a> {
    /// The first `n` poses (all four columns cut to `n`: panics if one is shorter).
    pub fn first(self, n: usize) -> Poses<'a> {
        Poses {
            x: &self.x[..n],
            y: &self.y[..n],
            sin: &self.sin[..n],
            cos: &self.cos[..n],
        }
    }
}

/// The sines and cosines of headings, kept between scans so that filling them allocates
/// nothing once the columns have grown.
#[derive(Debug, Clone, Default)]
pub struct Headings {
    sin: Vec<f64>,
    cos: Vec<f64>,
}

impl Headings {
    /// Room for `n` headings: no allocation until there are more.
    pub fn with_capacity(n: usize) -> Headings {
        Headings {
            sin: Vec::with_capacity(n),
            cos: Vec::with_capacity(n),
        }
    }

    /// Forgets the headings, so that [`Headings::trig`] gives none until
    /// [`Headings::poses`] computes them again.
    pub fn clear(&mut self) {
        self.sin.clear();
        self.cos.clear();
    }

    /// The sines and cosines [`Headings::poses`] computed last, if it computed `n` of them
    /// since the last [`Headings::clear`]; otherwise they are to be computed.
    pub fn trig(&self, n: usize) -> HeadingTrig<'_> {
        if self.sin.len() == n && n > 0 {
            HeadingTrig::Given {
                sin: &self.sin,
                cos: &self.cos,
            }
        } else {
            HeadingTrig::Compute
        }
    }

    /// The poses (`x`, `y`, `th`) with the sines and cosines of `th`.
    pub fn poses<'a>(&'a mut self, x: &'a [f64], y: &'a [f64], th: &[f64]) -> Poses<'a> {
        self.sin.clear();
        self.cos.clear();
        for t in th {
            let (s, c) = t.sin_cos();
            self.sin.push(s);
            self.cos.push(c);
        }
        Poses {
            x,
            y,
            sin: &self.sin,
            cos: &self.cos,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headings_are_given_only_for_the_poses_computed_since_the_last_clear() {
        let th = [0.3, -2.0, 3.1];
        let mut h = Headings::default();
        assert!(matches!(h.trig(0), HeadingTrig::Compute));
        h.poses(&[0.0; 3], &[0.0; 3], &th);
        let HeadingTrig::Given { sin, cos } = h.trig(3) else {
            panic!("computed for 3 poses");
        };
        for (k, t) in th.iter().enumerate() {
            assert_eq!((sin[k], cos[k]), t.sin_cos());
        }
        // Another count of particles, or a clear, and the estimate must compute its own.
        assert!(matches!(h.trig(2), HeadingTrig::Compute));
        h.clear();
        assert!(matches!(h.trig(3), HeadingTrig::Compute));
    }

    /// Log-likelihoods far below what exp can represent still give the right ratios; a set
    /// where every particle is impossible keeps uniform weights.
    #[test]
    fn weights_from_log_likelihoods_are_computed_in_log_space() {
        let mut w = [0.0; 2];
        weights_from_log_likelihoods(&[-2000.0, -2000.0 + 3f64.ln()], &mut w);
        assert!(
            (w[0] - 0.25).abs() < 1e-12 && (w[1] - 0.75).abs() < 1e-12,
            "{w:?}"
        );
        weights_from_log_likelihoods(&[f64::NEG_INFINITY; 2], &mut w);
        assert_eq!(w, [0.5, 0.5]);
    }

    #[test]
    fn effective_sample_size_by_hand() {
        // Uniform over 4: 4; all on one: 1; (0.5, 0.5, 0, 0): 2.
        assert!((effective_sample_size(&[0.25; 4]) - 4.0).abs() < 1e-12);
        assert_eq!(effective_sample_size(&[0.0, 1.0, 0.0]), 1.0);
        assert!((effective_sample_size(&[0.5, 0.5, 0.0, 0.0]) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn weights_normalise_and_degenerate_ones_become_uniform() {
        let mut w = [1.0, 3.0];
        normalize_weights(&mut w);
        assert_eq!(w, [0.25, 0.75]);
        assert!((effective_sample_size(&w) - 1.6).abs() < 1e-12);
        let mut w = [0.0, 0.0, 0.0, f64::NAN];
        normalize_weights(&mut w);
        assert_eq!(w, [0.25; 4]);
    }

    #[test]
    fn mean_is_circular_and_covariance_hand_computed() {
        let pi = std::f64::consts::PI;
        let (m, cov) = weighted_mean_covariance(
            &[0.0, 2.0],
            &[1.0, 1.0],
            &[pi - 0.1, -pi + 0.1],
            &[0.5, 0.5],
        );
        assert!((m.x - 1.0).abs() < 1e-12 && (m.y - 1.0).abs() < 1e-12);
        // Headings straddle ±π: the mean is π, not 0.
        assert!((m.theta.abs() - pi).abs() < 1e-12);
        assert!((cov[(0, 0)] - 1.0).abs() < 1e-12);
        assert!((cov[(2, 2)] - 0.01).abs() < 1e-12);
    }

    #[test]
    fn odometry_accumulates_and_nan_is_ignored() {
        let (mut pending, mut stamp) = (Pose2::default(), 0.0);
        let step = |t: f64, from: Pose2, to: Pose2| OdometryDelta { stamp: t, from, to };
        let a = Pose2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2);
        accumulate_odometry(&mut pending, &mut stamp, &step(0.1, Pose2::default(), a));
        accumulate_odometry(
            &mut pending,
            &mut stamp,
            &step(0.2, a, Pose2::new(1.0, 1.0, a.theta)),
        );
        accumulate_odometry(
            &mut pending,
            &mut stamp,
            &step(0.3, a, Pose2::new(f64::NAN, 0.0, 0.0)),
        );
        // Forward 1 m, turn left, forward 1 m: (1, 1) facing +y; the NaN step changed nothing.
        assert!(
            (pending.x - 1.0).abs() < 1e-12 && (pending.y - 1.0).abs() < 1e-12,
            "{pending:?}"
        );
        assert_eq!(stamp, 0.2);
    }

    #[test]
    fn carrying_composes_the_pending_odometry() {
        let mean = Pose2::new(1.0, 0.0, std::f64::consts::FRAC_PI_2);
        let e = carried_by_odometry(&mean, &Matrix3::identity(), &Pose2::new(1.0, 0.0, 0.0), 3.0);
        assert!((e.pose.x - 1.0).abs() < 1e-12 && (e.pose.y - 1.0).abs() < 1e-12);
        assert_eq!(e.stamp, 3.0);
        // Heading uncertainty now moves x: d x / d θ = -1 for a 1 m step facing +y.
        assert!((e.covariance[(0, 0)] - 2.0).abs() < 1e-12);
    }

    #[test]
    fn particle_counts_name_the_limit() {
        assert!(validate_particle_count(crate::limits::MAX_PARTICLES).is_ok());
        assert_eq!(
            validate_particle_count(usize::MAX).unwrap_err(),
            format!(
                "particles: {} is more than the limit of 1000000 (MAX_PARTICLES)",
                usize::MAX
            )
        );
        assert!(validate_particle_count(0)
            .unwrap_err()
            .starts_with("particles"));
    }
}
