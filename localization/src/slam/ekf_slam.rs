//! Point-feature EKF-SLAM as written in Kozlov, MacDonald and Wünsche, "Covariance
//! Visualisations for Simultaneous Localisation and Mapping" ([003]
//! §2.1, eq. 1–11), with its covariance checks (§2.2, eq. 12–13) run after every update by a
//! [`CovarianceMonitor`].
//!
//! State x = [x_v; x_m]: the robot pose (x, y, θ) and n point features (f_kx, f_ky), in the
//! frame of the start pose the localizer is given (the paper takes the robot's initial pose as
//! the map origin; Atrium hands the known start so estimates are scored in the world frame).
//!
//! - Prediction (eq. 1–4) from wheel odometry: the increment is decomposed as (δrot1, δtrans,
//!   δrot2) (Thrun et al., Probabilistic Robotics §5.4) and applied to the pose only (eq. 2:
//!   features are static); P ← F P Fᵀ + Q touches only the pose rows, O(n).
//! - Observation (eq. 5–8): range and bearing from the detector's mount to a feature; S from the
//!   5 × 5 block of P that H touches.
//! - Update (eq. 9–11) with the gain W = P Hᵀ S⁻¹ and the Joseph form
//!   P ← (I − WH) P (I − WH)ᵀ + W R Wᵀ, evaluated in O(n²) without forming I − WH: with
//!   B = P Hᵀ and C = B − W (S − R), it is P − W Bᵀ − C Wᵀ + W R Wᵀ (exact for any gain, so a
//!   rounding error in W costs only second order, and symmetric by construction).
//! - Augmentation: a new feature from the inverse observation, with its cross-covariances.
//! - Association: known (detector ids) or gated nearest neighbour on the Mahalanobis distance
//!   νᵀ S⁻¹ ν (χ², 2 degrees of freedom).
//! - Fault injection (§4's faulty run: "incorrect update of the covariance of certain mapped
//!   features, causing the feature correlations to worsen over time"). In both modes P stays a
//!   valid covariance (the correct posterior plus a positive semi-definite term, or a convex
//!   combination of P and its block diagonal), so the filter runs on and only the monitor
//!   can tell. `fault_mode`:
//!   - `inflate` (default): the update never corrects the chosen features' own 2 × 2 blocks
//!     and adds `fault_q` · I to them at every update, so their marginal covariance grows
//!     linearly while every other entry is updated as usual. Their P_d (eq. 13) with every
//!     other feature grows at run scale, the symptom of Fig. 6–8 (the maximum ellipse grows
//!     even when no feature is new, the minimum keeps shrinking). Both halves are needed: with
//!     only the missing correction P_d stays flat; with only the added noise each re-sighting
//!     undoes it, so P_d swings with the loop around a bounded level.
//!   - `decorrelate`: after each Kalman update the chosen features' cross-covariances are
//!     multiplied by `fault_gamma` < 1. Each step makes their P_d grow, so the per-pair check
//!     flags them, but the filter then double-counts their observations and grows
//!     overconfident: at run scale every P_d ends about 10× *below* the correct filter's.
//!
//! Bad input never panics: non-finite odometry, a detection at zero or non-finite range, a
//! singular or non-finite innovation covariance are skipped and counted in [`SlamIssues`].

use crate::filter::motion::OdometryMotionModel;
use crate::localizer::{Capabilities, Estimate, Localizer, LocalizerError, OdometryDelta};
use crate::slam::covariance_monitor::{CovarianceMonitor, MonitorParams};
use atrium_robots::{normalize_angle, LandmarkDetections, Pose2, Reading};
use nalgebra::{DMatrix, Matrix3};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// How detections are matched to mapped features.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AssociationMode {
    /// Use the detector's ids when present, nearest neighbour otherwise.
    Auto,
    /// Require ids; an anonymous detection is reported and skipped.
    Known,
    /// Ignore ids: gated nearest neighbour on the Mahalanobis distance.
    NearestNeighbour,
}

/// How the covariance update of the fault-injected features is corrupted ([003] §4's faulty
/// run: "incorrect update of the covariance of certain mapped features"; see the module notes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultMode {
    /// The update leaves each faulty feature's own 2 × 2 block uncorrected and adds
    /// `fault_q` · I (m²) to it: their relative covariances grow over the run.
    Inflate,
    /// After every Kalman update the cross-covariances of the faulty features with the rest
    /// of the state are multiplied by `fault_gamma`: flagged per pair, but the filter grows
    /// overconfident and every relative covariance shrinks at run scale.
    Decorrelate,
}

/// Parameters of [`EkfSlam`] (scenario: `[[localizers]] kind = "ekf_slam"` plus these keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EkfSlamParams {
    /// Translation variance per metre driven, m²/m (a random walk, so independent of the
    /// odometry rate). Default 1e-4: 1 cm after 1 m.
    pub q_trans: f64,
    /// Heading variance per radian turned, rad²/rad. Default 4e-4: 0.02 rad after 1 rad,
    /// twice the 1 % wheelbase error of the default odometry.
    pub q_rot: f64,
    /// Heading variance per metre driven, rad²/m. Default 1e-3: 0.1 rad after 10 m, which
    /// covers the heading drift of the default odometry's 0.5 % wheel-radius mismatch
    /// (0.015 rad/m, a bias the filter can only treat as noise) over gaps of about 10 m
    /// without features.
    pub q_rot_per_m: f64,
    /// Observation noise the filter assumes (R = diag(σ_r², σ_b²)); when absent the scenario
    /// takes the detector's values.
    pub sigma_range: Option<f64>,
    pub sigma_bearing: Option<f64>,
    pub association: AssociationMode,
    /// Mahalanobis gate (χ², 2 dof) for accepting an association. Default 9.21 (99 %).
    pub gate: f64,
    /// A detection farther than this from every feature starts a new one; between `gate` and
    /// this it is ambiguous and dropped. Default 13.82 (99.9 %).
    pub new_feature_gate: f64,
    /// Initial pose standard deviations (x, y, θ). Default 0: the start defines the frame.
    pub initial_sigma: [f64; 3],
    /// At most this many features are mapped; later new ones are counted and dropped.
    pub max_features: usize,
    /// Fault injection: features (map order, from 0) whose covariance update is corrupted.
    pub fault_features: Vec<usize>,
    /// How their covariance update is corrupted.
    pub fault_mode: FaultMode,
    /// `decorrelate`: factor on their cross-covariances after every update, in (0, 1].
    pub fault_gamma: f64,
    /// `inflate`: variance (m²) added to each coordinate of a faulty feature per update
    /// (detection batch). Default 4e-6: at 5 Hz, the 3000 updates of 10 min add up to about
    /// 0.11 m of standard deviation.
    pub fault_q: f64,
    /// Covariance monitor: single-linkage threshold, m.
    pub cluster_distance: f64,
    /// Covariance monitor: relative tolerance of the non-growth check.
    pub monitor_rel_tol: f64,
    /// Times (s) at which to keep a snapshot of the state for pictures; the final state is
    /// always kept.
    pub frames_s: Vec<f64>,
}

impl Default for EkfSlamParams {
    fn default() -> Self {
        let m = MonitorParams::default();
        Self {
            q_trans: 1e-4,
            q_rot: 4e-4,
            q_rot_per_m: 1e-3,
            sigma_range: None,
            sigma_bearing: None,
            association: AssociationMode::Auto,
            gate: 9.21,
            new_feature_gate: 13.82,
            initial_sigma: [0.0; 3],
            max_features: 500,
            fault_features: Vec::new(),
            fault_mode: FaultMode::Inflate,
            fault_gamma: 0.9,
            fault_q: 4e-6,
            cluster_distance: m.cluster_distance,
            monitor_rel_tol: m.rel_tol,
            frames_s: Vec::new(),
        }
    }
}

impl EkfSlamParams {
    /// Checks every field; the message names it.
    pub fn validate(&self) -> Result<(), String> {
        let nonneg = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{name}: must be finite and >= 0 (got {v})"))
            }
        };
        nonneg("q_trans", self.q_trans)?;
        nonneg("q_rot", self.q_rot)?;
        nonneg("q_rot_per_m", self.q_rot_per_m)?;
        nonneg("fault_q", self.fault_q)?;
        // Zero observation noise is allowed: the filter must cope with the singular
        // innovation covariance it can produce (it reports and skips such updates).
        if let Some(s) = self.sigma_range {
            nonneg("sigma_range", s)?;
        }
        if let Some(s) = self.sigma_bearing {
            nonneg("sigma_bearing", s)?;
        }
        for (i, s) in self.initial_sigma.iter().enumerate() {
            nonneg(&format!("initial_sigma[{i}]"), *s)?;
        }
        if !(self.gate.is_finite() && self.gate > 0.0) {
            return Err(format!("gate: must be > 0 (got {})", self.gate));
        }
        if !(self.new_feature_gate.is_finite() && self.new_feature_gate >= self.gate) {
            return Err(format!(
                "new_feature_gate: must be >= gate = {} (got {})",
                self.gate, self.new_feature_gate
            ));
        }
        if self.max_features == 0 {
            return Err("max_features: must be at least 1".into());
        }
        crate::limits::check_count(
            "max_features",
            self.max_features,
            crate::limits::EKF_MAX_FEATURES,
            "EKF_MAX_FEATURES",
        )?;
        if self.frames_s.len() > crate::limits::EKF_MAX_FRAMES {
            return Err(format!(
                "frames_s: {} snapshots are more than the limit of {} (EKF_MAX_FRAMES)",
                self.frames_s.len(),
                crate::limits::EKF_MAX_FRAMES
            ));
        }
        if !(self.fault_gamma.is_finite() && self.fault_gamma > 0.0 && self.fault_gamma <= 1.0) {
            return Err(format!(
                "fault_gamma: must be in (0, 1] (got {})",
                self.fault_gamma
            ));
        }
        for (i, t) in self.frames_s.iter().enumerate() {
            nonneg(&format!("frames_s[{i}]"), *t)?;
        }
        MonitorParams {
            cluster_distance: self.cluster_distance,
            rel_tol: self.monitor_rel_tol,
            ..MonitorParams::default()
        }
        .validate()
    }
}

/// Bad input the filter met and skipped, counted by kind (the first message of each kind is
/// kept to say what happened).
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct SlamIssues {
    pub non_finite_odometry: usize,
    pub invalid_detection: usize,
    pub singular_innovation: usize,
    pub missing_id: usize,
    pub ambiguous_detection: usize,
    pub map_full: usize,
    pub messages: Vec<String>,
}

impl SlamIssues {
    pub fn total(&self) -> usize {
        self.non_finite_odometry
            + self.invalid_detection
            + self.singular_innovation
            + self.missing_id
            + self.ambiguous_detection
            + self.map_full
    }
}

/// The state at one instant, for pictures.
#[derive(Debug, Clone, PartialEq)]
pub struct SlamSnapshot {
    pub stamp: f64,
    /// Full state vector [x, y, θ, f0x, f0y, …].
    pub state: Vec<f64>,
    /// Full covariance, row-major, `state.len()` square.
    pub covariance: Vec<f64>,
    /// Detector id of each feature, when known.
    pub ids: Vec<Option<usize>>,
}

impl SlamSnapshot {
    pub fn dim(&self) -> usize {
        self.state.len()
    }
    pub fn features(&self) -> usize {
        (self.state.len() - 3) / 2
    }
    pub fn feature(&self, k: usize) -> [f64; 2] {
        [self.state[3 + 2 * k], self.state[4 + 2 * k]]
    }
    pub fn cov(&self, r: usize, c: usize) -> f64 {
        self.covariance[r * self.dim() + c]
    }
    /// The map-block accessor the monitor functions take.
    pub fn map_cov(&self) -> impl Fn(usize, usize) -> f64 + '_ {
        move |r, c| self.cov(3 + r, 3 + c)
    }
}

/// Range-bearing observation of a feature from the detector mount: the prediction h (eq. 6)
/// and its Jacobian with respect to (x, y, θ, f_x, f_y). `pose` is the robot pose, `mount` the
/// detector frame in the base frame, `f` the feature.
pub fn observe(pose: &[f64; 3], mount: &Pose2, f: [f64; 2]) -> ([f64; 2], [[f64; 5]; 2]) {
    let (s, c) = pose[2].sin_cos();
    let sx = pose[0] + c * mount.x - s * mount.y;
    let sy = pose[1] + s * mount.x + c * mount.y;
    let dsx_dth = -s * mount.x - c * mount.y;
    let dsy_dth = c * mount.x - s * mount.y;
    let (dx, dy) = (f[0] - sx, f[1] - sy);
    let q = dx * dx + dy * dy;
    let r = q.sqrt();
    let z = [r, normalize_angle(dy.atan2(dx) - pose[2] - mount.theta)];
    let h = [
        [
            -dx / r,
            -dy / r,
            (-dx * dsx_dth - dy * dsy_dth) / r,
            dx / r,
            dy / r,
        ],
        [
            dy / q,
            -dx / q,
            (dy * dsx_dth - dx * dsy_dth) / q - 1.0,
            -dy / q,
            dx / q,
        ],
    ];
    (z, h)
}

/// Inverse observation: the feature seen at (range, bearing) from the mount, with the
/// Jacobians with respect to the pose (2 × 3) and to (range, bearing) (2 × 2).
pub fn inverse_observe(
    pose: &[f64; 3],
    mount: &Pose2,
    z: [f64; 2],
) -> ([f64; 2], [[f64; 3]; 2], [[f64; 2]; 2]) {
    let (s, c) = pose[2].sin_cos();
    let sx = pose[0] + c * mount.x - s * mount.y;
    let sy = pose[1] + s * mount.x + c * mount.y;
    let dsx_dth = -s * mount.x - c * mount.y;
    let dsy_dth = c * mount.x - s * mount.y;
    let phi = pose[2] + mount.theta + z[1];
    let (sp, cp) = phi.sin_cos();
    let f = [sx + z[0] * cp, sy + z[0] * sp];
    let gx = [
        [1.0, 0.0, dsx_dth - z[0] * sp],
        [0.0, 1.0, dsy_dth + z[0] * cp],
    ];
    let gz = [[cp, -z[0] * sp], [sp, z[0] * cp]];
    (f, gx, gz)
}

/// The motion model f_v (eq. 1) on (δrot1, δtrans, δrot2) with its Jacobians with respect
/// to the pose (F) and to the control (V).
pub fn motion(pose: &[f64; 3], u: [f64; 3]) -> ([f64; 3], [[f64; 3]; 3], [[f64; 3]; 3]) {
    let [rot1, trans, rot2] = u;
    let th1 = pose[2] + rot1;
    let (s, c) = th1.sin_cos();
    let next = [
        pose[0] + trans * c,
        pose[1] + trans * s,
        normalize_angle(pose[2] + rot1 + rot2),
    ];
    let f = [
        [1.0, 0.0, -trans * s],
        [0.0, 1.0, trans * c],
        [0.0, 0.0, 1.0],
    ];
    let v = [[-trans * s, c, 0.0], [trans * c, s, 0.0], [1.0, 0.0, 1.0]];
    (next, f, v)
}

fn inv2(s: [[f64; 2]; 2]) -> Option<[[f64; 2]; 2]> {
    let det = s[0][0] * s[1][1] - s[0][1] * s[1][0];
    let scale = s[0][0].abs().max(s[1][1].abs());
    // Relative test: S is a covariance, so det ≤ s00·s11; a determinant this small relative
    // to it means S is singular to working precision.
    if !(det.is_finite() && scale.is_finite() && det > 1e-12 * scale * scale && scale > 0.0) {
        return None;
    }
    Some([
        [s[1][1] / det, -s[0][1] / det],
        [-s[1][0] / det, s[0][0] / det],
    ])
}

/// Outcome of one detection.
enum Outcome {
    Updated,
    Added,
    Skipped,
}

/// EKF-SLAM localizer with its covariance monitor.
pub struct EkfSlam {
    name: String,
    params: EkfSlamParams,
    r: [f64; 2],
    /// State mean and covariance (dimension 3 + 2n).
    x: Vec<f64>,
    p: DMatrix<f64>,
    ids: Vec<Option<usize>>,
    by_id: HashMap<usize, usize>,
    fault: Vec<bool>,
    monitor: CovarianceMonitor,
    issues: SlamIssues,
    stamp: f64,
    updates: u64,
    snapshots: Vec<SlamSnapshot>,
    next_frame: usize,
    /// Scratch rows (n × 2) of the update: B = P Hᵀ, the gain W and C = B − W (S − R).
    b: Vec<[f64; 2]>,
    w: Vec<[f64; 2]>,
    cbuf: Vec<[f64; 2]>,
    features_buf: Vec<[f64; 2]>,
}

/// At most this many issue messages are kept (the counts are complete).
const MAX_MESSAGES: usize = 20;

impl EkfSlam {
    /// `sigma_range` / `sigma_bearing` in `params` must be set (the scenario fills them from
    /// the detector when the file does not).
    pub fn new(name: &str, params: EkfSlamParams, start: Pose2) -> Result<Self, String> {
        params.validate()?;
        if !start.is_finite() {
            return Err(format!("start pose: must be finite (got {start:?})"));
        }
        let sr = params
            .sigma_range
            .ok_or("sigma_range: missing (and no landmark detector to take it from)")?;
        let sb = params
            .sigma_bearing
            .ok_or("sigma_bearing: missing (and no landmark detector to take it from)")?;
        let mut p = DMatrix::zeros(3, 3);
        for k in 0..3 {
            p[(k, k)] = params.initial_sigma[k].powi(2);
        }
        let monitor = CovarianceMonitor::new(MonitorParams {
            cluster_distance: params.cluster_distance,
            rel_tol: params.monitor_rel_tol,
            ..MonitorParams::default()
        });
        let mut frames = params.frames_s.clone();
        frames.sort_by(f64::total_cmp);
        let params = EkfSlamParams {
            frames_s: frames,
            ..params
        };
        Ok(Self {
            name: name.to_owned(),
            r: [sr * sr, sb * sb],
            x: vec![start.x, start.y, start.theta],
            p,
            ids: Vec::new(),
            by_id: HashMap::new(),
            fault: Vec::new(),
            monitor,
            issues: SlamIssues::default(),
            stamp: 0.0,
            updates: 0,
            snapshots: Vec::new(),
            next_frame: 0,
            b: Vec::new(),
            w: Vec::new(),
            cbuf: Vec::new(),
            features_buf: Vec::new(),
            params,
        })
    }

    pub fn params(&self) -> &EkfSlamParams {
        &self.params
    }

    /// Number of mapped features.
    pub fn feature_count(&self) -> usize {
        (self.x.len() - 3) / 2
    }

    /// Estimated position of feature `k` (map order).
    pub fn feature(&self, k: usize) -> [f64; 2] {
        [self.x[3 + 2 * k], self.x[4 + 2 * k]]
    }

    /// Detector id of feature `k`, when detections carried one.
    pub fn feature_id(&self, k: usize) -> Option<usize> {
        self.ids[k]
    }

    pub fn state(&self) -> &[f64] {
        &self.x
    }

    pub fn covariance(&self) -> &DMatrix<f64> {
        &self.p
    }

    pub fn monitor(&self) -> &CovarianceMonitor {
        &self.monitor
    }

    pub fn issues(&self) -> &SlamIssues {
        &self.issues
    }

    /// Measurement updates (detection batches) processed.
    pub fn updates(&self) -> u64 {
        self.updates
    }

    /// Snapshots at `frames_s` plus, last, the current state.
    pub fn snapshots(&self) -> Vec<SlamSnapshot> {
        let mut v = self.snapshots.clone();
        v.push(self.snapshot());
        v
    }

    pub fn snapshot(&self) -> SlamSnapshot {
        let n = self.x.len();
        let mut covariance = Vec::with_capacity(n * n);
        for r in 0..n {
            for c in 0..n {
                covariance.push(self.p[(r, c)]);
            }
        }
        SlamSnapshot {
            stamp: self.stamp,
            state: self.x.clone(),
            covariance,
            ids: self.ids.clone(),
        }
    }

    fn issue(&mut self, msg: String) {
        if self.issues.messages.len() < MAX_MESSAGES {
            self.issues.messages.push(msg);
        }
    }

    /// Prediction (eq. 3–4) with the odometry increment `from → to`.
    // Index loops mirror the matrix algebra (rows of F against columns of P).
    #[allow(clippy::needless_range_loop)]
    pub fn predict_odometry(&mut self, stamp: f64, from: &Pose2, to: &Pose2) {
        if !(from.is_finite() && to.is_finite() && stamp.is_finite()) {
            self.issues.non_finite_odometry += 1;
            self.issue(format!(
                "t = {stamp}: non-finite odometry ({from:?} -> {to:?}) skipped"
            ));
            return;
        }
        self.stamp = self.stamp.max(stamp);
        let inc = OdometryMotionModel::new([0.0; 4]).decompose(from, to);
        let u = [inc.rot1, inc.trans, inc.rot2];
        let pose = [self.x[0], self.x[1], self.x[2]];
        let (next, f, v) = motion(&pose, u);
        let at = inc.trans.abs();
        let m = [
            self.params.q_rot * inc.rot1.abs() + 0.5 * self.params.q_rot_per_m * at,
            self.params.q_trans * at,
            self.params.q_rot * inc.rot2.abs() + 0.5 * self.params.q_rot_per_m * at,
        ];
        self.x[..3].copy_from_slice(&next);
        let n = self.x.len();
        // P_vv ← F P_vv Fᵀ + V M Vᵀ; P_vm ← F P_vm (features are static, eq. 2).
        let mut pvv = [[0.0; 3]; 3];
        for (r, row) in pvv.iter_mut().enumerate() {
            for (c, cell) in row.iter_mut().enumerate() {
                let mut acc = 0.0;
                for a in 0..3 {
                    for b in 0..3 {
                        acc += f[r][a] * self.p[(a, b)] * f[c][b];
                    }
                    acc += v[r][a] * m[a] * v[c][a];
                }
                *cell = acc;
            }
        }
        for col in 3..n {
            let pc = [self.p[(0, col)], self.p[(1, col)], self.p[(2, col)]];
            for r in 0..3 {
                let val = f[r][0] * pc[0] + f[r][1] * pc[1] + f[r][2] * pc[2];
                self.p[(r, col)] = val;
                self.p[(col, r)] = val;
            }
        }
        for r in 0..3 {
            for c in 0..3 {
                // Average with the transpose: exact symmetry keeps later updates symmetric.
                self.p[(r, c)] = 0.5 * (pvv[r][c] + pvv[c][r]);
            }
        }
    }

    /// The 2 × 2 innovation covariance S (eq. 8) of feature `k` for Jacobian `h` (columns x,
    /// y, θ, f_x, f_y), from the 5 × 5 block of P it touches.
    fn innovation_cov(&self, k: usize, h: &[[f64; 5]; 2]) -> [[f64; 2]; 2] {
        let idx = [0, 1, 2, 3 + 2 * k, 4 + 2 * k];
        let mut s = [[0.0; 2]; 2];
        for a in 0..2 {
            for b in 0..2 {
                let mut acc = 0.0;
                for (u, &iu) in idx.iter().enumerate() {
                    for (v, &iv) in idx.iter().enumerate() {
                        acc += h[a][u] * self.p[(iu, iv)] * h[b][v];
                    }
                }
                s[a][b] = acc;
            }
        }
        s[0][0] += self.r[0];
        s[1][1] += self.r[1];
        let off = 0.5 * (s[0][1] + s[1][0]);
        s[0][1] = off;
        s[1][0] = off;
        s
    }

    /// Innovation (eq. 7), its covariance and Jacobian for feature `k`.
    fn innovation(
        &self,
        k: usize,
        mount: &Pose2,
        z: [f64; 2],
    ) -> ([f64; 2], [[f64; 2]; 2], [[f64; 5]; 2]) {
        let pose = [self.x[0], self.x[1], self.x[2]];
        let (zh, h) = observe(&pose, mount, self.feature(k));
        let nu = [z[0] - zh[0], normalize_angle(z[1] - zh[1])];
        (nu, self.innovation_cov(k, &h), h)
    }

    /// Kalman update (eq. 9–11) of feature `k`, Joseph form (see the module notes).
    fn update_feature(&mut self, k: usize, mount: &Pose2, z: [f64; 2]) -> bool {
        let (nu, s, h) = self.innovation(k, mount, z);
        let Some(si) = inv2(s) else {
            self.issues.singular_innovation += 1;
            self.issue(format!(
                "t = {}: singular innovation covariance {s:?} for feature {k}; update skipped",
                self.stamp
            ));
            return false;
        };
        let n = self.x.len();
        let idx = [0, 1, 2, 3 + 2 * k, 4 + 2 * k];
        self.b.resize(n, [0.0; 2]);
        self.w.resize(n, [0.0; 2]);
        self.cbuf.resize(n, [0.0; 2]);
        // B = P Hᵀ (n × 2), W = B S⁻¹ (eq. 11).
        for i in 0..n {
            let mut b = [0.0; 2];
            for (u, &iu) in idx.iter().enumerate() {
                let piu = self.p[(i, iu)];
                b[0] += piu * h[0][u];
                b[1] += piu * h[1][u];
            }
            self.b[i] = b;
            self.w[i] = [
                b[0] * si[0][0] + b[1] * si[1][0],
                b[0] * si[0][1] + b[1] * si[1][1],
            ];
        }
        // C = B − W (S − R), since H B = H P Hᵀ = S − R.
        let hph = [
            [s[0][0] - self.r[0], s[0][1]],
            [s[1][0], s[1][1] - self.r[1]],
        ];
        for i in 0..n {
            let w = self.w[i];
            self.cbuf[i] = [
                self.b[i][0] - (w[0] * hph[0][0] + w[1] * hph[1][0]),
                self.b[i][1] - (w[0] * hph[0][1] + w[1] * hph[1][1]),
            ];
        }
        // x ← x + W ν (eq. 9).
        for i in 0..n {
            self.x[i] += self.w[i][0] * nu[0] + self.w[i][1] * nu[1];
        }
        self.x[2] = normalize_angle(self.x[2]);
        // Joseph form: P − W Bᵀ − C Wᵀ + W R Wᵀ, upper triangle mirrored.
        for j in 0..n {
            let (bj, wj) = (self.b[j], self.w[j]);
            for i in 0..=j {
                let (wi, ci) = (self.w[i], self.cbuf[i]);
                let val = self.p[(i, j)]
                    - (wi[0] * bj[0] + wi[1] * bj[1])
                    - (ci[0] * wj[0] + ci[1] * wj[1])
                    + (wi[0] * self.r[0] * wj[0] + wi[1] * self.r[1] * wj[1]);
                self.p[(i, j)] = val;
                self.p[(j, i)] = val;
            }
        }
        self.uncorrect_faulty_blocks();
        self.inject_fault();
        true
    }

    /// First half of the `inflate` bug: the faulty features' own 2 × 2 blocks keep their prior
    /// value, i.e. the reduction W S Wᵀ the Joseph loop just subtracted there is added back
    /// (from the scratch rows B, W, C, still those of this update). The result is the correct
    /// posterior plus a positive semi-definite term on those blocks, so P stays valid.
    fn uncorrect_faulty_blocks(&mut self) {
        if self.params.fault_mode != FaultMode::Inflate {
            return;
        }
        for k in 0..self.fault.len() {
            if !self.fault[k] {
                continue;
            }
            let (a, b) = (3 + 2 * k, 4 + 2 * k);
            for (i, j) in [(a, a), (a, b), (b, b)] {
                let (wi, ci, bj, wj) = (self.w[i], self.cbuf[i], self.b[j], self.w[j]);
                let reduction = (wi[0] * bj[0] + wi[1] * bj[1]) + (ci[0] * wj[0] + ci[1] * wj[1])
                    - (wi[0] * self.r[0] * wj[0] + wi[1] * self.r[1] * wj[1]);
                self.p[(i, j)] += reduction;
                if i != j {
                    self.p[(j, i)] = self.p[(i, j)];
                }
            }
        }
    }

    /// Second half of the `inflate` bug, once per update (detection batch): each faulty
    /// feature's own block gains `fault_q` · I. Adding a positive semi-definite term keeps P a
    /// valid covariance, and a Kalman update with any valid P can only shrink P, so no pair
    /// without a faulty feature can grow: the fault stays confined to the pairs it touches.
    fn inflate_faulty(&mut self) {
        if self.params.fault_mode != FaultMode::Inflate || self.params.fault_q == 0.0 {
            return;
        }
        for k in 0..self.fault.len() {
            if self.fault[k] {
                let (a, b) = (3 + 2 * k, 4 + 2 * k);
                self.p[(a, a)] += self.params.fault_q;
                self.p[(b, b)] += self.params.fault_q;
            }
        }
    }

    /// The `decorrelate` bug: cross-covariances of the faulty features with everything else
    /// shrink by `fault_gamma` after each update.
    fn inject_fault(&mut self) {
        if self.params.fault_mode != FaultMode::Decorrelate
            || self.params.fault_features.is_empty()
            || self.params.fault_gamma == 1.0
        {
            return;
        }
        let g = self.params.fault_gamma;
        let n = self.x.len();
        for k in 0..self.fault.len() {
            if !self.fault[k] {
                continue;
            }
            let (a, b) = (3 + 2 * k, 4 + 2 * k);
            for other in (0..n).filter(|&o| o != a && o != b) {
                for row in [a, b] {
                    let v = self.p[(row, other)] * g;
                    self.p[(row, other)] = v;
                    self.p[(other, row)] = v;
                }
            }
        }
    }

    /// Augmentation: appends the feature seen at `z` with its covariance and
    /// cross-covariances.
    fn add_feature(&mut self, mount: &Pose2, z: [f64; 2], id: Option<usize>) -> bool {
        let k = self.feature_count();
        if k >= self.params.max_features {
            self.issues.map_full += 1;
            self.issue(format!(
                "t = {}: map full ({} features); new feature dropped",
                self.stamp, self.params.max_features
            ));
            return false;
        }
        let pose = [self.x[0], self.x[1], self.x[2]];
        let (f, gx, gz) = inverse_observe(&pose, mount, z);
        let n = self.x.len();
        // Rows of the new feature against the old state: G_x P_v,: (2 × n).
        let mut cross = vec![[0.0; 2]; n];
        for (j, cj) in cross.iter_mut().enumerate() {
            for (a, ca) in cj.iter_mut().enumerate() {
                *ca = gx[a][0] * self.p[(0, j)]
                    + gx[a][1] * self.p[(1, j)]
                    + gx[a][2] * self.p[(2, j)];
            }
        }
        let mut pff = [[0.0; 2]; 2];
        for a in 0..2 {
            for b in 0..2 {
                let mut acc = 0.0;
                for u in 0..3 {
                    acc += cross[u][a] * gx[b][u];
                }
                acc += gz[a][0] * self.r[0] * gz[b][0] + gz[a][1] * self.r[1] * gz[b][1];
                pff[a][b] = acc;
            }
        }
        let off = 0.5 * (pff[0][1] + pff[1][0]);
        pff[0][1] = off;
        pff[1][0] = off;
        // Growing P allocates, once per new feature: rare next to updates.
        let old = std::mem::replace(&mut self.p, DMatrix::zeros(0, 0));
        let mut p = old.resize(n + 2, n + 2, 0.0);
        for (j, cj) in cross.iter().enumerate() {
            for a in 0..2 {
                p[(n + a, j)] = cj[a];
                p[(j, n + a)] = cj[a];
            }
        }
        for a in 0..2 {
            for b in 0..2 {
                p[(n + a, n + b)] = pff[a][b];
            }
        }
        self.p = p;
        self.x.extend_from_slice(&f);
        self.ids.push(id);
        if let Some(id) = id {
            self.by_id.insert(id, k);
        }
        self.fault.push(self.params.fault_features.contains(&k));
        true
    }

    /// Gated nearest neighbour: the feature with the smallest Mahalanobis distance and that
    /// distance (None without features).
    fn nearest(&self, mount: &Pose2, z: [f64; 2]) -> Option<(usize, f64)> {
        let mut best: Option<(usize, f64)> = None;
        for k in 0..self.feature_count() {
            let (nu, s, _) = self.innovation(k, mount, z);
            let Some(si) = inv2(s) else { continue };
            let d2 = nu[0] * (si[0][0] * nu[0] + si[0][1] * nu[1])
                + nu[1] * (si[1][0] * nu[0] + si[1][1] * nu[1]);
            if best.is_none_or(|(_, b)| d2 < b) {
                best = Some((k, d2));
            }
        }
        best
    }

    fn process(&mut self, mount: &Pose2, z: [f64; 2], id: Option<usize>) -> Outcome {
        let use_id = match self.params.association {
            AssociationMode::NearestNeighbour => None,
            AssociationMode::Known | AssociationMode::Auto => id,
        };
        if self.params.association == AssociationMode::Known && use_id.is_none() {
            self.issues.missing_id += 1;
            self.issue(format!(
                "t = {}: detection without an id under known association; skipped",
                self.stamp
            ));
            return Outcome::Skipped;
        }
        if let Some(id) = use_id {
            return match self.by_id.get(&id) {
                Some(&k) => {
                    if self.update_feature(k, mount, z) {
                        Outcome::Updated
                    } else {
                        Outcome::Skipped
                    }
                }
                None => {
                    if self.add_feature(mount, z, Some(id)) {
                        Outcome::Added
                    } else {
                        Outcome::Skipped
                    }
                }
            };
        }
        match self.nearest(mount, z) {
            Some((k, d2)) if d2 <= self.params.gate => {
                if self.update_feature(k, mount, z) {
                    Outcome::Updated
                } else {
                    Outcome::Skipped
                }
            }
            Some((_, d2)) if d2 <= self.params.new_feature_gate => {
                self.issues.ambiguous_detection += 1;
                Outcome::Skipped
            }
            _ => {
                if self.add_feature(mount, z, None) {
                    Outcome::Added
                } else {
                    Outcome::Skipped
                }
            }
        }
    }

    /// One batch of detections: sequential updates and augmentations, then the covariance
    /// monitor (one check per batch, which is one "update" of the paper).
    pub fn update_detections(&mut self, d: &LandmarkDetections) {
        if d.stamp.is_finite() {
            self.stamp = self.stamp.max(d.stamp);
        }
        if !d.mount.is_finite() {
            self.issues.invalid_detection += d.detections.len();
            self.issue(format!(
                "t = {}: non-finite detector mount; batch skipped",
                d.stamp
            ));
            return;
        }
        let mut changed = false;
        for det in &d.detections {
            let z = [det.range, det.bearing];
            if !(z[0].is_finite() && z[1].is_finite() && z[0] > 1e-6) {
                self.issues.invalid_detection += 1;
                self.issue(format!(
                    "t = {}: detection at range {} bearing {} (zero or non-finite) skipped",
                    d.stamp, z[0], z[1]
                ));
                continue;
            }
            match self.process(&d.mount, z, det.id) {
                Outcome::Updated | Outcome::Added => changed = true,
                Outcome::Skipped => {}
            }
        }
        if !changed {
            return;
        }
        self.inflate_faulty();
        self.updates += 1;
        self.features_buf.clear();
        for k in 0..self.feature_count() {
            let f = self.feature(k);
            self.features_buf.push(f);
        }
        let p = &self.p;
        let cov = |r: usize, c: usize| p[(3 + r, 3 + c)];
        self.monitor.check(self.stamp, &self.features_buf, &cov);
        while let Some(&t) = self.params.frames_s.get(self.next_frame) {
            if self.stamp + 1e-9 < t {
                break;
            }
            let snap = self.snapshot();
            self.snapshots.push(snap);
            self.next_frame += 1;
        }
    }
}

impl Localizer for EkfSlam {
    fn name(&self) -> &str {
        &self.name
    }

    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError> {
        self.predict_odometry(delta.stamp, &delta.from, &delta.to);
        Ok(())
    }

    fn update(&mut self, reading: &Reading) -> Result<(), LocalizerError> {
        if let Reading::Landmarks(d) = reading {
            self.update_detections(d);
        }
        Ok(())
    }

    fn estimate(&self) -> Estimate {
        let mut covariance = Matrix3::zeros();
        for r in 0..3 {
            for c in 0..3 {
                covariance[(r, c)] = self.p[(r, c)];
            }
        }
        Estimate {
            stamp: self.stamp,
            pose: Pose2::new(self.x[0], self.x[1], self.x[2]),
            covariance,
        }
    }

    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        Some(self)
    }
}

impl Capabilities for EkfSlam {
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use atrium_robots::LandmarkDetection;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    fn params() -> EkfSlamParams {
        EkfSlamParams {
            sigma_range: Some(0.02),
            sigma_bearing: Some(0.01),
            ..Default::default()
        }
    }

    fn detections(stamp: f64, mount: Pose2, z: &[([f64; 2], Option<usize>)]) -> LandmarkDetections {
        LandmarkDetections {
            stamp,
            sensor: "d".into(),
            mount,
            detections: z
                .iter()
                .map(|(z, id)| LandmarkDetection {
                    range: z[0],
                    bearing: z[1],
                    id: *id,
                })
                .collect(),
        }
    }

    /// Central differences of `f` at `x` in each coordinate.
    fn numeric_jacobian<const N: usize, const M: usize>(
        f: impl Fn(&[f64; N]) -> [f64; M],
        x: &[f64; N],
    ) -> [[f64; N]; M] {
        let mut j = [[0.0; N]; M];
        let h = 1e-6;
        for k in 0..N {
            let (mut a, mut b) = (*x, *x);
            a[k] += h;
            b[k] -= h;
            let (fa, fb) = (f(&a), f(&b));
            for m in 0..M {
                j[m][k] = normalize_angle(fa[m] - fb[m]) / (2.0 * h);
            }
        }
        j
    }

    #[test]
    fn jacobians_match_finite_differences() {
        let mount = Pose2::new(0.16, 0.05, 0.2);
        // Observation: over (x, y, θ, fx, fy).
        let x0 = [1.0, -0.5, 0.7, 3.2, 1.1];
        let obs = |v: &[f64; 5]| observe(&[v[0], v[1], v[2]], &mount, [v[3], v[4]]).0;
        let num = numeric_jacobian(obs, &x0);
        let (_, h) = observe(&[x0[0], x0[1], x0[2]], &mount, [x0[3], x0[4]]);
        for m in 0..2 {
            for k in 0..5 {
                assert!(
                    (num[m][k] - h[m][k]).abs() < 1e-7,
                    "H[{m}][{k}] {} vs {}",
                    h[m][k],
                    num[m][k]
                );
            }
        }
        // Inverse observation: over (x, y, θ, r, b).
        let v0 = [1.0, -0.5, 0.7, 2.5, -0.4];
        let inv = |v: &[f64; 5]| inverse_observe(&[v[0], v[1], v[2]], &mount, [v[3], v[4]]).0;
        let num = numeric_jacobian(inv, &v0);
        let (_, gx, gz) = inverse_observe(&[v0[0], v0[1], v0[2]], &mount, [v0[3], v0[4]]);
        for m in 0..2 {
            for k in 0..3 {
                assert!((num[m][k] - gx[m][k]).abs() < 1e-7);
            }
            for k in 0..2 {
                assert!((num[m][3 + k] - gz[m][k]).abs() < 1e-7);
            }
        }
        // Motion: over (x, y, θ, rot1, trans, rot2).
        let m0 = [1.0, -0.5, 0.7, 0.1, 0.3, -0.2];
        let mot = |v: &[f64; 6]| motion(&[v[0], v[1], v[2]], [v[3], v[4], v[5]]).0;
        let num = numeric_jacobian(mot, &m0);
        let (_, f, vj) = motion(&[m0[0], m0[1], m0[2]], [m0[3], m0[4], m0[5]]);
        for m in 0..3 {
            for k in 0..3 {
                assert!((num[m][k] - f[m][k]).abs() < 1e-7);
                assert!((num[m][3 + k] - vj[m][k]).abs() < 1e-7);
            }
        }
        // The inverse observation inverts the observation.
        let (f, _, _) = inverse_observe(&[1.0, 2.0, 0.3], &mount, [2.0, 0.5]);
        let (z, _) = observe(&[1.0, 2.0, 0.3], &mount, f);
        assert!((z[0] - 2.0).abs() < 1e-12 && (z[1] - 0.5).abs() < 1e-12);
    }

    /// Robot at the origin with pose covariance diag(0.01, 0.01, 0) (θ known), no mount
    /// offset, feature straight ahead at (2, 0) with covariance diag(0.04, 0.04) and no
    /// cross-covariance. Range-only part by hand: H_r = [−1, 0, 0, 1, 0], so
    /// S_rr = 0.01 + 0.04 + σ_r² = 0.05 + 0.0004 = 0.0504; the bearing row
    /// H_b = [0, −0.5, −1, 0, 0.5] gives S_bb = 0.25·0.01 + 0.25·0.04 + σ_b² = 0.0125 + 1e-4
    /// and S_rb = 0. A range of 2.1 (ν_r = 0.1, ν_b = 0): W_r column = P H_rᵀ / S_rr, so the
    /// robot x moves by −0.01·0.1/0.0504 and the feature x by +0.04·0.1/0.0504.
    #[test]
    fn single_landmark_update_matches_hand_computation() {
        let mut p = params();
        p.initial_sigma = [0.1, 0.1, 0.0];
        let mut s = EkfSlam::new("s", p, Pose2::default()).unwrap();
        // Place the feature by hand with covariance diag(0.04, 0.04), uncorrelated.
        s.x.extend_from_slice(&[2.0, 0.0]);
        s.ids.push(Some(0));
        s.by_id.insert(0, 0);
        s.fault.push(false);
        s.p = s.p.clone().resize(5, 5, 0.0);
        s.p[(3, 3)] = 0.04;
        s.p[(4, 4)] = 0.04;
        s.update_detections(&detections(1.0, Pose2::default(), &[([2.1, 0.0], Some(0))]));
        let srr = 0.0504;
        assert!((s.x[0] - (-0.01 * 0.1 / srr)).abs() < 1e-12, "{}", s.x[0]);
        assert!((s.x[3] - (2.0 + 0.04 * 0.1 / srr)).abs() < 1e-12);
        assert!(s.x[1].abs() < 1e-15 && s.x[4].abs() < 1e-15 && s.x[2].abs() < 1e-15);
        // Covariance: P' = P − W S Wᵀ (eq. 10). Range block: P_xx' = 0.01 − 0.01²/S_rr,
        // P_fx' = 0.04 − 0.04²/S_rr, cross P_x,fx' = 0 + 0.01·0.04/S_rr.
        let p = &s.p;
        assert!((p[(0, 0)] - (0.01 - 1e-4 / srr)).abs() < 1e-12);
        assert!((p[(3, 3)] - (0.04 - 0.0016 / srr)).abs() < 1e-12);
        assert!((p[(0, 3)] - (0.0004 / srr)).abs() < 1e-12);
        // Bearing block: S_bb = 0.0125 + 1e-4; P_yy' = 0.01 − (0.5·0.01)²/S_bb.
        let sbb = 0.0125 + 1e-4;
        assert!((p[(1, 1)] - (0.01 - 0.005f64.powi(2) / sbb)).abs() < 1e-12);
        assert!((p[(4, 4)] - (0.04 - 0.02f64.powi(2) / sbb)).abs() < 1e-12);
    }

    /// A synthetic run without the physics: a robot on a circle among 12 landmarks, noisy
    /// odometry and detections. Returns the filter and the true landmarks.
    fn synthetic_run(
        steps: usize,
        fault: Vec<usize>,
        seed: u64,
    ) -> (EkfSlam, Vec<[f64; 2]>, Vec<f64>) {
        synthetic_run_with(steps, fault, FaultMode::Inflate, seed)
    }

    fn synthetic_run_with(
        steps: usize,
        fault: Vec<usize>,
        mode: FaultMode,
        seed: u64,
    ) -> (EkfSlam, Vec<[f64; 2]>, Vec<f64>) {
        let landmarks: Vec<[f64; 2]> = (0..12)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 12.0;
                let r = if k % 2 == 0 { 3.0 } else { 4.2 };
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let g = |rng: &mut ChaCha8Rng| -> f64 { StandardNormal.sample(rng) };
        let start = Pose2::new(2.0, 0.0, std::f64::consts::FRAC_PI_2);
        let p = EkfSlamParams {
            fault_features: fault,
            fault_mode: mode,
            fault_gamma: 0.9,
            ..params()
        };
        let (qt, qr, qm) = (p.q_trans, p.q_rot, p.q_rot_per_m);
        let mut s = EkfSlam::new("s", p, start).unwrap();
        let mut truth = start;
        let mut odom = Pose2::new(0.0, 0.0, 0.0);
        let mut nees = Vec::new();
        let dt = 0.1;
        let (v, w) = (0.4, 0.2);
        for step in 1..=steps {
            // True motion on the circle of radius 2 around the origin.
            let d = Pose2::new(v * dt, 0.0, w * dt);
            truth = truth.compose(&d);
            // Odometry with noise matching the filter's model (per-distance random walk).
            let noisy = Pose2::new(
                v * dt + (qt * v * dt).sqrt() * g(&mut rng),
                0.0,
                w * dt + (qr * w * dt + qm * v * dt).sqrt() * g(&mut rng),
            );
            let next = odom.compose(&noisy);
            s.predict_odometry(step as f64 * dt, &odom, &next);
            odom = next;
            if step % 2 == 0 {
                let mut z = Vec::new();
                for (id, l) in landmarks.iter().enumerate() {
                    let rel = truth.inverse().transform_point(*l);
                    let r = rel[0].hypot(rel[1]);
                    let b = rel[1].atan2(rel[0]);
                    if r < 5.0 && b.abs() < std::f64::consts::FRAC_PI_2 {
                        z.push(([r + 0.02 * g(&mut rng), b + 0.01 * g(&mut rng)], Some(id)));
                    }
                }
                s.update_detections(&detections(step as f64 * dt, Pose2::default(), &z));
                let e = s.estimate();
                let err = [e.pose.x - truth.x, e.pose.y - truth.y];
                let c = e.covariance;
                let det = c[(0, 0)] * c[(1, 1)] - c[(0, 1)] * c[(1, 0)];
                nees.push(
                    (c[(1, 1)] * err[0] * err[0] - 2.0 * c[(0, 1)] * err[0] * err[1]
                        + c[(0, 0)] * err[1] * err[1])
                        / det,
                );
            }
        }
        (s, landmarks, nees)
    }

    #[test]
    fn covariance_stays_symmetric_positive_definite_over_long_runs() {
        // 6000 steps of 0.1 s: ten minutes, about 19 laps.
        let (s, landmarks, _) = synthetic_run(6000, vec![], 3);
        let n = s.state().len();
        assert_eq!(s.feature_count(), 12);
        let p = s.covariance();
        for i in 0..n {
            for j in 0..n {
                assert_eq!(p[(i, j)], p[(j, i)], "P not symmetric at ({i}, {j})");
            }
        }
        assert!(p.clone().cholesky().is_some(), "P not positive definite");
        let eig = p.clone().symmetric_eigen();
        assert!(eig.eigenvalues.min() > 0.0);
        // The map is right: each feature within 10 cm of its landmark (ids are known).
        for k in 0..12 {
            let id = s.feature_id(k).unwrap();
            let f = s.feature(k);
            let e = (f[0] - landmarks[id][0]).hypot(f[1] - landmarks[id][1]);
            assert!(e < 0.1, "feature {k}: {e} m off");
        }
        assert_eq!(s.issues().total(), 0);
        assert_eq!(
            s.monitor().report().total_violations,
            0,
            "{}",
            s.monitor().report().describe()
        );
    }

    #[test]
    fn fault_injection_is_flagged_on_the_faulty_features_only() {
        for mode in [FaultMode::Inflate, FaultMode::Decorrelate] {
            fault_is_flagged_on_the_faulty_features_only(mode);
        }
    }

    fn fault_is_flagged_on_the_faulty_features_only(mode: FaultMode) {
        let (s, _, _) = synthetic_run_with(3000, vec![2, 5], mode, 4);
        let r = s.monitor().report();
        assert!(r.total_violations > 0);
        assert!(
            r.violating_pairs
                .iter()
                .all(|p| [2, 5].contains(&p.i) || [2, 5].contains(&p.j)),
            "{}",
            r.describe()
        );
        assert!(r.violating_features.contains(&2) && r.violating_features.contains(&5));
        let mut implicated = r.implicated_features.clone();
        implicated.sort_unstable();
        assert_eq!(implicated, vec![2, 5], "{}", r.describe());
        // Still a valid covariance: the fault is invisible without the monitor.
        assert!(s.covariance().clone().cholesky().is_some());
    }

    /// [003] §4's symptom at run scale: with `inflate` the faulty features' relative
    /// covariances end above where they were early on and above the correct filter's, each by
    /// most of the variance injected meanwhile, while pairs without a faulty feature end near
    /// the correct filter's. With
    /// `decorrelate` they end *below* the correct filter's (the overconfidence it causes).
    #[test]
    fn inflate_makes_faulty_pairs_grow_over_the_run() {
        let value = |s: &EkfSlam, i: usize, j: usize| s.monitor().last_value(i, j).unwrap();
        let (ok, _, _) = synthetic_run(3000, vec![], 4);
        let (early, _, _) = synthetic_run(500, vec![2, 5], 4);
        let (bad, _, _) = synthetic_run(3000, vec![2, 5], 4);
        let (dec, _, _) = synthetic_run_with(3000, vec![2, 5], FaultMode::Decorrelate, 4);
        // Between the two runs' ends the faulty blocks gained q · Δn on their diagonal; most
        // of that must show in P_d (the partner's shrinking variance offsets a little).
        let q = bad.params().fault_q;
        let added = q * (bad.updates() - early.updates()) as f64;
        for (i, j) in [(0, 2), (2, 7), (5, 9), (2, 5)] {
            let (e, b, o) = (value(&early, i, j), value(&bad, i, j), value(&ok, i, j));
            assert!(
                b - e > 0.5 * added,
                "pair ({i}, {j}): {e} after 500 steps, {b} after 3000 ({added} added)"
            );
            let total = q * bad.updates() as f64;
            assert!(
                b - o > 0.5 * total,
                "pair ({i}, {j}): {b} faulty vs {o} correct ({total} injected)"
            );
            assert!(value(&dec, i, j) < o, "pair ({i}, {j}) under decorrelate");
        }
        for (i, j) in [(0, 1), (3, 7), (8, 11)] {
            let r = value(&bad, i, j) / value(&ok, i, j);
            assert!(
                (0.5..2.0).contains(&r),
                "healthy pair ({i}, {j}): ratio {r}"
            );
        }
    }

    /// The `inflate` bug by hand: a faulty feature re-observed from a known pose keeps its
    /// covariance block except for `fault_q` · I per update, exactly; a healthy one shrinks.
    /// q is larger than any one update's reduction of the healthy feature's variance (at most
    /// half its initial ~4e-4 m²), so their P_d grows at every update.
    #[test]
    fn inflate_leaves_the_own_block_uncorrected_plus_noise() {
        let q = 1e-3;
        let mut s = EkfSlam::new(
            "s",
            EkfSlamParams {
                fault_features: vec![1],
                fault_q: q,
                ..params()
            },
            Pose2::default(),
        )
        .unwrap();
        let m = Pose2::default();
        let z = [([2.0, 0.3], Some(0)), ([2.5, -0.4], Some(1))];
        s.update_detections(&detections(0.1, m, &z));
        // Feature 1 was added in that batch and inflated once after it.
        let block = |s: &EkfSlam, k: usize| {
            let a = 3 + 2 * k;
            [s.p[(a, a)], s.p[(a, a + 1)], s.p[(a + 1, a + 1)]]
        };
        let (b1, b0) = (block(&s, 1), block(&s, 0));
        for n in 1..=5 {
            s.update_detections(&detections(0.1 + n as f64, m, &z));
            let now = block(&s, 1);
            let want = [b1[0] + n as f64 * q, b1[1], b1[2] + n as f64 * q];
            for c in 0..3 {
                assert!(
                    (now[c] - want[c]).abs() < 1e-15,
                    "update {n}: {now:?} vs {want:?}"
                );
            }
        }
        assert!(block(&s, 0)[0] < 0.5 * b0[0] && block(&s, 0)[2] < 0.5 * b0[2]);
        // Still a covariance (positive semi-definite: the pose, known and still, has none).
        let eig = s.covariance().clone().symmetric_eigen();
        assert!(eig.eigenvalues.min() > -1e-15, "{}", eig.eigenvalues);
        // And the monitor flags pair (0, 1) at each of those updates.
        assert_eq!(s.monitor().report().total_violations, 5);
    }

    #[test]
    fn position_nees_is_consistent_on_a_matched_model() {
        // With noise exactly as modelled, the (x, y) NEES averages 2 (its χ² dof); the EKF's
        // linearisation makes it slightly optimistic (averaged over 8 runs × 1500
        // updates). The samples are correlated in time, so the bound is wider than the
        // i.i.d. 95 % interval of such a mean.
        let mut all = Vec::new();
        for seed in 0..8 {
            all.extend(synthetic_run(3000, vec![], 100 + seed).2);
        }
        let mean = all.iter().sum::<f64>() / all.len() as f64;
        assert!((1.5..2.8).contains(&mean), "mean NEES {mean}");
    }

    #[test]
    fn nearest_neighbour_association_maps_each_landmark_once() {
        let landmarks: [[f64; 2]; 3] = [[2.0, 1.0], [2.0, -1.0], [4.0, 0.0]];
        let mut s = EkfSlam::new(
            "s",
            EkfSlamParams {
                association: AssociationMode::NearestNeighbour,
                ..params()
            },
            Pose2::default(),
        )
        .unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        for step in 0..50 {
            let z: Vec<([f64; 2], Option<usize>)> = landmarks
                .iter()
                .map(|l| {
                    let n1: f64 = StandardNormal.sample(&mut rng);
                    let n2: f64 = StandardNormal.sample(&mut rng);
                    (
                        [l[0].hypot(l[1]) + 0.02 * n1, l[1].atan2(l[0]) + 0.01 * n2],
                        Some(99),
                    )
                })
                .collect();
            s.update_detections(&detections(step as f64, Pose2::default(), &z));
        }
        assert_eq!(s.feature_count(), 3);
        for (k, l) in landmarks.iter().enumerate() {
            let f = s.feature(k);
            assert!((f[0] - l[0]).hypot(f[1] - l[1]) < 0.03);
            assert_eq!(s.feature_id(k), None);
        }
    }

    #[test]
    fn bad_input_is_reported_not_panicked_on() {
        // Zero observation noise and a perfectly known pose: the first sighting gives the
        // feature zero covariance, so the second has S = 0, which is singular.
        let mut s = EkfSlam::new(
            "s",
            EkfSlamParams {
                sigma_range: Some(0.0),
                sigma_bearing: Some(0.0),
                ..params()
            },
            Pose2::default(),
        )
        .unwrap();
        let m = Pose2::default();
        s.update_detections(&detections(0.1, m, &[([2.0, 0.1], Some(0))]));
        s.update_detections(&detections(0.2, m, &[([2.0, 0.1], Some(0))]));
        assert_eq!(s.issues().singular_innovation, 1);
        // A feature at zero range, and NaN ones.
        s.update_detections(&detections(0.3, m, &[([0.0, 0.3], Some(1))]));
        s.update_detections(&detections(0.4, m, &[([f64::NAN, 0.3], Some(1))]));
        assert_eq!(s.issues().invalid_detection, 2);
        assert_eq!(s.feature_count(), 1);
        // NaN odometry leaves the state alone.
        let before = s.state().to_vec();
        s.predict_odometry(0.5, &Pose2::default(), &Pose2::new(f64::NAN, 0.0, 0.0));
        assert_eq!(s.issues().non_finite_odometry, 1);
        assert_eq!(s.state(), &before[..]);
        assert!(s.state().iter().all(|v| v.is_finite()));
        assert!(s
            .issues()
            .messages
            .iter()
            .any(|m| m.contains("singular innovation")));
        // Known association without an id.
        let mut k = EkfSlam::new(
            "k",
            EkfSlamParams {
                association: AssociationMode::Known,
                ..params()
            },
            Pose2::default(),
        )
        .unwrap();
        k.update_detections(&detections(0.1, m, &[([2.0, 0.1], None)]));
        assert_eq!(k.issues().missing_id, 1);
        assert_eq!(k.feature_count(), 0);
        // Parameters: errors name the field.
        let e = EkfSlam::new(
            "e",
            EkfSlamParams {
                fault_gamma: 0.0,
                ..params()
            },
            Pose2::default(),
        );
        assert!(e.err().unwrap().starts_with("fault_gamma"));
        let e = EkfSlam::new(
            "e",
            EkfSlamParams {
                sigma_range: None,
                ..params()
            },
            Pose2::default(),
        );
        assert!(e.err().unwrap().starts_with("sigma_range"));
    }

    #[test]
    fn frames_are_snapshotted_at_the_requested_times() {
        let mut s = EkfSlam::new(
            "s",
            EkfSlamParams {
                frames_s: vec![0.25],
                ..params()
            },
            Pose2::default(),
        )
        .unwrap();
        for t in [0.1, 0.2, 0.3, 0.4] {
            s.update_detections(&detections(t, Pose2::default(), &[([2.0, 0.1], Some(0))]));
        }
        let snaps = s.snapshots();
        assert_eq!(snaps.len(), 2);
        assert!((snaps[0].stamp - 0.3).abs() < 1e-12 && (snaps[1].stamp - 0.4).abs() < 1e-12);
        assert_eq!(snaps[1].features(), 1);
        assert_eq!(snaps[1].cov(3, 4), s.covariance()[(3, 4)]);
    }

    #[test]
    fn map_and_snapshot_sizes_above_their_limits_are_refused() {
        use crate::limits::{EKF_MAX_FEATURES, EKF_MAX_FRAMES};
        let p = |features: usize, frames: usize| EkfSlamParams {
            max_features: features,
            frames_s: vec![1.0; frames],
            ..EkfSlamParams::default()
        };
        assert!(p(EKF_MAX_FEATURES, EKF_MAX_FRAMES).validate().is_ok());
        assert_eq!(
            p(1_000_000_000, 1).validate().unwrap_err(),
            "max_features: 1000000000 is more than the limit of 5000 (EKF_MAX_FEATURES)"
        );
        assert_eq!(
            p(500, EKF_MAX_FRAMES + 1).validate().unwrap_err(),
            "frames_s: 101 snapshots are more than the limit of 100 (EKF_MAX_FRAMES)"
        );
    }
}
