//! The odometry motion model: Thrun, Burgard, Fox, *Probabilistic Robotics* (2005), §5.4,
//! Table 5.6 `sample_motion_model_odometry`.

use atrium_robots::{normalize_angle, Pose2};
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

/// Below this translation (metres) the direction of travel, and so δrot1, is numerically
/// meaningless (encoder quantization, slip while turning in place); the whole rotation is
/// then attributed to δrot2 so that noise is not scaled by a spurious rotation. 1 cm as in
/// ROS amcl.
pub const MIN_TRANSLATION: f64 = 0.01;

/// Odometry motion model with Thrun's α1–α4:
/// α1 rotation noise from rotation (rad²/rad²), α2 rotation noise from translation (rad²/m²),
/// α3 translation noise from translation (m²/m²), α4 translation noise from rotation (m²/rad²).
///
/// The book's Table 5.6 passes `α1 δrot1² + α2 δtrans²` to `sample(b²)` (Table 5.4, where the
/// argument is a variance); we use it as the variance, i.e. the standard deviation is its square
/// root, matching the density of Table 5.5 and ROS amcl.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryMotionModel {
    pub alpha: [f64; 4],
}

/// An odometry increment decomposed once (rot1, trans, rot2) so that many particles can be
/// propagated with it without repeating the trigonometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryIncrement {
    /// Direction of travel in the frame of the start pose (radians).
    pub direction: f64,
    pub rot1: f64,
    /// Signed: negative when the robot drove backwards.
    pub trans: f64,
    pub rot2: f64,
    pub sd_rot1: f64,
    pub sd_trans: f64,
    pub sd_rot2: f64,
}

/// Checks the odometry noise coefficients α1–α4 a filter's parameters name `alpha`: each
/// finite and non-negative.
pub fn validate_alpha(alpha: &[f64; 4]) -> Result<(), String> {
    for (i, a) in alpha.iter().enumerate() {
        if !(a.is_finite() && *a >= 0.0) {
            return Err(format!("alpha[{i}] must be finite and >= 0, got {a}"));
        }
    }
    Ok(())
}

impl OdometryMotionModel {
    pub const fn new(alpha: [f64; 4]) -> Self {
        Self { alpha }
    }

    /// Decomposes the odometry increment `from → to` (two poses in the odometry frame).
    ///
    /// Backwards motion: Table 5.6 would give δrot1 ≈ ±π and δrot2 ≈ ∓π, whose α1 noise is
    /// enormous although the robot barely turned. When the direction of travel points
    /// backwards we use δrot1 − π with a negative δtrans instead; the noiseless result is the
    /// same pose.
    pub fn decompose(&self, from: &Pose2, to: &Pose2) -> OdometryIncrement {
        let rel = from.between(to);
        let dist = rel.x.hypot(rel.y);
        let dtheta = rel.theta;
        let mut direction = rel.y.atan2(rel.x);
        let mut trans = dist;
        if direction.abs() > std::f64::consts::FRAC_PI_2 {
            direction = normalize_angle(direction - std::f64::consts::PI);
            trans = -dist;
        }
        let rot1 = if dist < MIN_TRANSLATION {
            0.0
        } else {
            direction
        };
        let rot2 = normalize_angle(dtheta - rot1);
        let [a1, a2, a3, a4] = self.alpha;
        let t2 = trans * trans;
        OdometryIncrement {
            direction,
            rot1,
            trans,
            rot2,
            sd_rot1: (a1 * rot1 * rot1 + a2 * t2).sqrt(),
            sd_trans: (a3 * t2 + a4 * (rot1 * rot1 + rot2 * rot2)).sqrt(),
            sd_rot2: (a1 * rot2 * rot2 + a2 * t2).sqrt(),
        }
    }

    /// One sample of the pose after the increment, starting from `pose`.
    #[inline]
    pub fn sample_increment<R: Rng + ?Sized>(
        &self,
        pose: &Pose2,
        inc: &OdometryIncrement,
        rng: &mut R,
    ) -> Pose2 {
        let (x, y, theta) = apply_increment(pose.x, pose.y, pose.theta, inc, rng);
        Pose2 { x, y, theta }
    }

    /// Table 5.6: a sample of the pose reached from `pose` when odometry went from
    /// `delta_from` to `delta_to`.
    pub fn sample<R: Rng + ?Sized>(
        &self,
        pose: &Pose2,
        delta_from: &Pose2,
        delta_to: &Pose2,
        rng: &mut R,
    ) -> Pose2 {
        let inc = self.decompose(delta_from, delta_to);
        self.sample_increment(pose, &inc, rng)
    }
}

/// The body of Table 5.6 on raw coordinates (used on struct-of-arrays particles).
#[inline]
pub(crate) fn apply_increment<R: Rng + ?Sized>(
    x: f64,
    y: f64,
    theta: f64,
    inc: &OdometryIncrement,
    rng: &mut R,
) -> (f64, f64, f64) {
    let e1 = noise(inc.sd_rot1, rng);
    let et = noise(inc.sd_trans, rng);
    let e2 = noise(inc.sd_rot2, rng);
    let rot1 = inc.rot1 - e1;
    let trans = inc.trans - et;
    let rot2 = inc.rot2 - e2;
    // The travel direction carries the rot1 noise; when rot1 was zeroed for a tiny
    // translation the exact direction is still used so the noiseless motion is exact.
    let heading = theta + inc.direction - e1;
    let (s, c) = heading.sin_cos();
    (
        x + trans * c,
        y + trans * s,
        normalize_angle(theta + rot1 + rot2),
    )
}

#[inline]
fn noise<R: Rng + ?Sized>(sd: f64, rng: &mut R) -> f64 {
    if sd > 0.0 {
        let z: f64 = StandardNormal.sample(rng);
        sd * z
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn close(a: &Pose2, b: &Pose2, tol: f64) -> bool {
        (a.x - b.x).abs() < tol && (a.y - b.y).abs() < tol && a.heading_error(b) < tol
    }

    #[test]
    fn zero_alphas_reproduce_the_odometry_delta() {
        let m = OdometryMotionModel::new([0.0; 4]);
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let pose = Pose2::new(2.0, -1.0, 0.7);
        let cases = [
            (Pose2::new(0.0, 0.0, 0.0), Pose2::new(1.0, 0.5, 0.3)),
            // backwards
            (
                Pose2::new(5.0, 5.0, FRAC_PI_2),
                Pose2::new(5.1, 4.2, FRAC_PI_2 + 0.1),
            ),
            // in place
            (Pose2::new(1.0, 1.0, 3.0), Pose2::new(1.0, 1.0, -3.0)),
            // tiny sideways slip while turning
            (Pose2::new(1.0, 1.0, 0.0), Pose2::new(1.0, 1.004, 0.5)),
            // across the ±π seam
            (
                Pose2::new(0.0, 0.0, PI - 0.1),
                Pose2::new(-0.3, 0.05, -PI + 0.2),
            ),
        ];
        for (from, to) in cases {
            let expected = pose.compose(&from.between(&to));
            let got = m.sample(&pose, &from, &to, &mut rng);
            assert!(
                close(&got, &expected, 1e-12),
                "{from:?}->{to:?}: {got:?} vs {expected:?}"
            );
        }
    }

    #[test]
    fn decomposition_of_backwards_and_in_place_motion() {
        let m = OdometryMotionModel::new([0.1; 4]);
        let back = m.decompose(&Pose2::new(0.0, 0.0, 0.0), &Pose2::new(-0.5, 0.0, 0.0));
        assert!((back.trans + 0.5).abs() < 1e-12);
        assert!(back.rot1.abs() < 1e-12 && back.rot2.abs() < 1e-12);
        let turn = m.decompose(&Pose2::new(0.0, 0.0, 0.0), &Pose2::new(0.0, 0.0, 1.0));
        assert_eq!(turn.rot1, 0.0);
        assert!((turn.rot2 - 1.0).abs() < 1e-12);
        // sd_rot2 = sqrt(α1 · 1²) and no rotation noise on rot1.
        assert!((turn.sd_rot2 - 0.1f64.sqrt()).abs() < 1e-12);
        assert_eq!(turn.sd_rot1, 0.0);
    }

    /// Mean and variance of (x, y, θ) over many samples.
    fn stats(m: &OdometryMotionModel, from: &Pose2, to: &Pose2, n: usize) -> ([f64; 3], [f64; 3]) {
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let start = Pose2::default();
        let mut sum = [0.0; 3];
        let mut sq = [0.0; 3];
        for _ in 0..n {
            let p = m.sample(&start, from, to, &mut rng);
            for (k, v) in [p.x, p.y, p.theta].into_iter().enumerate() {
                sum[k] += v;
                sq[k] += v * v;
            }
        }
        let nf = n as f64;
        let mean = sum.map(|s| s / nf);
        let var = [0, 1, 2].map(|k| sq[k] / nf - mean[k] * mean[k]);
        (mean, var)
    }

    #[test]
    fn noisy_samples_centre_on_the_delta_and_spread_with_alpha() {
        let from = Pose2::default();
        let to = Pose2::new(1.0, 0.0, 0.2);
        let n = 40_000;
        let small = OdometryMotionModel::new([0.01; 4]);
        let large = OdometryMotionModel::new([0.04; 4]);
        let (m_s, v_s) = stats(&small, &from, &to, n);
        let (m_l, v_l) = stats(&large, &from, &to, n);
        // Small noise: mean within a few standard errors of the delta.
        assert!((m_s[0] - 1.0).abs() < 0.01, "{m_s:?}");
        assert!(m_s[1].abs() < 0.01, "{m_s:?}");
        assert!((m_s[2] - 0.2).abs() < 0.01, "{m_s:?}");
        // Pure translation direction: var(x) ≈ var of trans = α3·1 + α4·(0 + 0.04).
        assert!((v_s[0] - (0.01 + 0.01 * 0.04)).abs() < 0.001, "{v_s:?}");
        // Heading variance = var(rot1) + var(rot2) = 2·α2·1 + α1·0.04.
        let th = 0.01 * 2.0 + 0.01 * 0.04;
        assert!((v_s[2] - th).abs() < 0.1 * th, "{v_s:?}");
        // Four times the alphas, four times the variance (within sampling error).
        for k in 0..3 {
            let ratio = v_l[k] / v_s[k];
            assert!((ratio - 4.0).abs() < 0.4, "axis {k}: ratio {ratio}");
        }
        assert!((m_l[0] - 1.0).abs() < 0.03 && (m_l[2] - 0.2).abs() < 0.01);
    }
}
