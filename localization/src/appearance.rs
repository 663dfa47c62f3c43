//! Appearance-based localization ([000] §II and §VI): a map of features of training
//! images taken at known poses, the nearest-neighbour sensor model of eq. 2 and the
//! disjunctive fusion of intensity and disparity sensor models.
//!
//! eq. 2: p(y | x) = Σ_{j=1..J} λ_j φ(x | x_j), with x_j the poses of the J training points
//! whose features are nearest to y, λ_j weights favouring closer neighbours and φ a Gaussian.
//! §VI: p(y_d, y_i | x) = w_d p(y_d | x) + w_i p(y_i | x), w_i = 1 − w_d.

use crate::error::LocalizationError;
use atrium_robots::{normalize_angle, Pose2};

/// Training poses and their feature vectors (all of one length d).
#[derive(Debug, Clone, PartialEq)]
pub struct AppearanceMap {
    poses: Vec<Pose2>,
    /// Row-major N × d.
    features: Vec<f64>,
    d: usize,
}

/// One term of the sensor model: a training pose and its weight λ_j.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Component {
    pub index: usize,
    pub pose: Pose2,
    pub weight: f64,
    /// Feature-space distance ‖y − y_j‖.
    pub distance: f64,
}

impl AppearanceMap {
    pub fn new(poses: Vec<Pose2>, features: Vec<Vec<f64>>) -> Result<Self, LocalizationError> {
        if poses.is_empty() || poses.len() != features.len() {
            return Err(LocalizationError::InvalidParameter(format!(
                "appearance map: need one feature vector per training pose, got {} poses and {} vectors",
                poses.len(),
                features.len()
            )));
        }
        let d = features[0].len();
        let mut flat = Vec::with_capacity(d * features.len());
        for (i, f) in features.iter().enumerate() {
            if f.len() != d || d == 0 {
                return Err(LocalizationError::InvalidParameter(format!(
                    "appearance map: feature vector {i} has {} values, vector 0 has {d}",
                    f.len()
                )));
            }
            if f.iter().any(|v| !v.is_finite()) || !poses[i].is_finite() {
                return Err(LocalizationError::InvalidParameter(format!(
                    "appearance map: training point {i} has a non-finite pose or feature"
                )));
            }
            flat.extend_from_slice(f);
        }
        Ok(Self {
            poses,
            features: flat,
            d,
        })
    }

    pub fn len(&self) -> usize {
        self.poses.len()
    }

    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    pub fn d(&self) -> usize {
        self.d
    }

    /// Every training point's features, row-major (N × d).
    pub fn features(&self) -> &[f64] {
        &self.features
    }

    pub fn pose(&self, i: usize) -> Pose2 {
        self.poses[i]
    }

    /// The same features at other poses (one per training point, finite). Used to build the
    /// random-pose baseline: a map of the same size whose answers carry no information about
    /// where the robot is, against which every appearance claim must be checked.
    pub fn with_poses(&self, poses: Vec<Pose2>) -> Result<Self, LocalizationError> {
        if poses.len() != self.poses.len() || poses.iter().any(|p| !p.is_finite()) {
            return Err(LocalizationError::InvalidParameter(format!(
                "appearance map: need {} finite poses, got {}",
                self.poses.len(),
                poses.len()
            )));
        }
        Ok(Self {
            poses,
            features: self.features.clone(),
            d: self.d,
        })
    }

    /// The J training points nearest to `y` in feature space, nearest first, with weights
    /// λ_j ∝ exp(−(δ_j² − δ_1²) / (2 δ_1²)) (δ the feature distances): the nearest neighbour
    /// weighs most, and neighbours much farther than it hardly count. Written into `out`
    /// (cleared first; no allocation once `out` has capacity J).
    pub fn sensor_model(
        &self,
        y: &[f64],
        j: usize,
        out: &mut Vec<Component>,
    ) -> Result<(), LocalizationError> {
        if y.len() != self.d {
            return Err(LocalizationError::InvalidParameter(format!(
                "appearance sensor model: features of length {}, the map has d = {}",
                y.len(),
                self.d
            )));
        }
        if y.iter().any(|v| !v.is_finite()) {
            return Err(LocalizationError::InvalidParameter(
                "appearance sensor model: non-finite feature".into(),
            ));
        }
        let j = j.clamp(1, self.len());
        out.clear();
        // Insertion into a sorted list of J: J is small (5–10) next to N (thousands).
        for (i, f) in self.features.chunks_exact(self.d).enumerate() {
            let d2: f64 = f.iter().zip(y).map(|(a, b)| (a - b) * (a - b)).sum();
            if out.len() == j && d2 >= out[j - 1].distance {
                continue;
            }
            let pos = out.partition_point(|c| c.distance <= d2);
            if out.len() == j {
                out.pop();
            }
            out.insert(
                pos,
                Component {
                    index: i,
                    pose: self.poses[i],
                    weight: 0.0,
                    distance: d2,
                },
            );
        }
        let d1 = out[0].distance.max(1e-300);
        let mut total = 0.0;
        for c in out.iter_mut() {
            let w = (-(c.distance - d1) / (2.0 * d1)).exp();
            c.distance = c.distance.sqrt();
            c.weight = w;
            total += w;
        }
        for c in out.iter_mut() {
            c.weight /= total;
        }
        Ok(())
    }
}

/// φ of eq. 2: a Gaussian around a training pose, independent in x, y and heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseKernel {
    pub sigma_xy: f64,
    pub sigma_theta: f64,
}

impl Default for PoseKernel {
    /// Half the paper's 50 cm grid and its 10° rotation step.
    fn default() -> Self {
        Self {
            sigma_xy: 0.25,
            sigma_theta: 10f64.to_radians(),
        }
    }
}

impl PoseKernel {
    pub fn density(&self, x: &Pose2, at: &Pose2) -> f64 {
        let dx = x.x - at.x;
        let dy = x.y - at.y;
        let dt = normalize_angle(x.theta - at.theta);
        let s2 = self.sigma_xy * self.sigma_xy;
        let t2 = self.sigma_theta * self.sigma_theta;
        (-(dx * dx + dy * dy) / (2.0 * s2) - dt * dt / (2.0 * t2)).exp()
            / ((2.0 * std::f64::consts::PI).powf(1.5) * s2 * self.sigma_theta)
    }

    /// eq. 2: Σ λ_j φ(x | x_j).
    pub fn likelihood(&self, x: &Pose2, components: &[Component]) -> f64 {
        components
            .iter()
            .map(|c| c.weight * self.density(x, &c.pose))
            .sum()
    }
}

/// §VI disjunctive fusion: the mixture w_d · (disparity model) + w_i · (intensity model), as
/// one list of components with their weights scaled. `w_d` in [0, 1]; w_i = 1 − w_d. A member
/// of weight 0 is not in the mixture at all (w_d = 1 is disparity alone), so it proposes
/// no training pose and counts in no sensor-model error.
pub fn fuse(
    disparity: &[Component],
    intensity: &[Component],
    w_d: f64,
    out: &mut Vec<Component>,
) -> Result<(), LocalizationError> {
    if !(w_d.is_finite() && (0.0..=1.0).contains(&w_d)) {
        return Err(LocalizationError::InvalidParameter(format!(
            "appearance fusion: w_d must be within [0, 1], got {w_d}"
        )));
    }
    out.clear();
    for (member, w) in [(disparity, w_d), (intensity, 1.0 - w_d)] {
        if w > 0.0 {
            out.extend(member.iter().map(|c| Component {
                weight: c.weight * w,
                ..*c
            }));
        }
    }
    Ok(())
}

/// The error of a sensor model at the true pose r (000 §VII): e = min_n ‖r − n‖ over the
/// poses n of its components, with r = (x, y, φ) in centimetres and degrees as in the paper.
/// Returns (e, position error of that n in cm, heading error of that n in degrees).
pub fn sensor_model_error(truth: &Pose2, components: &[Component]) -> Option<(f64, f64, f64)> {
    components
        .iter()
        .map(|c| {
            let p = 100.0 * (c.pose.x - truth.x).hypot(c.pose.y - truth.y);
            let h = normalize_angle(c.pose.theta - truth.theta)
                .abs()
                .to_degrees();
            ((p * p + h * h).sqrt(), p, h)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> AppearanceMap {
        let poses: Vec<Pose2> = (0..10).map(|i| Pose2::new(i as f64, 0.0, 0.0)).collect();
        let feats: Vec<Vec<f64>> = (0..10).map(|i| vec![i as f64, 0.0]).collect();
        AppearanceMap::new(poses, feats).unwrap()
    }

    #[test]
    fn nearest_neighbours_are_found_and_weighted() {
        let m = map();
        let mut out = Vec::new();
        m.sensor_model(&[3.2, 0.0], 3, &mut out).unwrap();
        let idx: Vec<usize> = out.iter().map(|c| c.index).collect();
        assert_eq!(idx, vec![3, 4, 2]);
        assert!((out[0].distance - 0.2).abs() < 1e-12);
        assert!(out[0].weight > out[1].weight && out[1].weight > out[2].weight);
        let total: f64 = out.iter().map(|c| c.weight).sum();
        assert!((total - 1.0).abs() < 1e-12);
        // The likelihood peaks at the nearest neighbour's pose.
        let k = PoseKernel::default();
        let at3 = k.likelihood(&Pose2::new(3.0, 0.0, 0.0), &out);
        let at7 = k.likelihood(&Pose2::new(7.0, 0.0, 0.0), &out);
        assert!(at3 > 100.0 * at7);
        assert!(m.sensor_model(&[1.0], 3, &mut out).is_err());
        assert!(m.sensor_model(&[f64::NAN, 0.0], 3, &mut out).is_err());
    }

    #[test]
    fn with_poses_moves_the_answers_not_the_matches() {
        let m = map();
        let moved: Vec<Pose2> = (0..10).map(|i| Pose2::new(0.0, i as f64, 0.0)).collect();
        let r = m.with_poses(moved).unwrap();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        m.sensor_model(&[3.2, 0.0], 3, &mut a).unwrap();
        r.sensor_model(&[3.2, 0.0], 3, &mut b).unwrap();
        assert_eq!(
            a.iter().map(|c| c.index).collect::<Vec<_>>(),
            b.iter().map(|c| c.index).collect::<Vec<_>>()
        );
        assert_eq!(b[0].pose, Pose2::new(0.0, 3.0, 0.0));
        assert!(m.with_poses(vec![Pose2::default(); 9]).is_err());
        let mut bad = vec![Pose2::default(); 10];
        bad[4].x = f64::NAN;
        assert!(m.with_poses(bad).is_err());
    }

    #[test]
    fn fusion_keeps_both_hypotheses_and_error_is_the_closest() {
        let m = map();
        let (mut a, mut b, mut f) = (Vec::new(), Vec::new(), Vec::new());
        m.sensor_model(&[1.0, 0.0], 2, &mut a).unwrap();
        m.sensor_model(&[8.0, 0.0], 2, &mut b).unwrap();
        fuse(&a, &b, 0.5, &mut f).unwrap();
        assert_eq!(f.len(), 4);
        let total: f64 = f.iter().map(|c| c.weight).sum();
        assert!((total - 1.0).abs() < 1e-12);
        let k = PoseKernel::default();
        // Disjunctive: both places keep probability.
        assert!(k.likelihood(&Pose2::new(1.0, 0.0, 0.0), &f) > 0.1);
        assert!(k.likelihood(&Pose2::new(8.0, 0.0, 0.0), &f) > 0.1);
        let (e, p, h) = sensor_model_error(&Pose2::new(7.9, 0.0, 0.1), &f).unwrap();
        assert!((p - 10.0).abs() < 1e-9, "{p}");
        assert!((h - 0.1f64.to_degrees()).abs() < 1e-9);
        assert!((e - (p * p + h * h).sqrt()).abs() < 1e-9);
        assert!(fuse(&a, &b, 1.5, &mut f).is_err());
        // w_d = 1 is disparity alone: the intensity member's poses are gone, not weighted 0.
        fuse(&a, &b, 1.0, &mut f).unwrap();
        assert_eq!(f, a);
        fuse(&a, &b, 0.0, &mut f).unwrap();
        assert_eq!(f, b);
    }
}
