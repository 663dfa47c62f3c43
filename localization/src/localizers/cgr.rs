//! Corrective Gradient Refinement (CGR): [004] §2.1 (after Biswas, Coltin
//! & Veloso, IROS 2011), on the world's vector map, for a laser rangefinder and, through FSPF
//! (§2.2, Algorithm 1), for a depth camera. Per observation:
//!
//! 1. every particle of Bel(x_{t−1}) goes through the odometry motion model: proposal q⁰;
//! 2. each sample is refined in `refinements` (r) iterations along the gradient of the
//!    observation log-likelihood: q¹ … qʳ;
//! 3. an acceptance test chooses, per particle, between its refined sample (qʳ) and its
//!    unrefined one (q⁰);
//! 4. the chosen samples are weighted by the observation likelihood and resampled
//!    (low-variance) into Bel(x_t).
//!
//! Observation model: the observed points (laser endpoints, or FSPF points of vertical planes
//! projected to the floor) are matched to their nearest map segment (point-to-line
//! correspondences; for depth points only segments whose normal agrees with the point's plane
//! normal); each residual d scores log(exp(−d²/2σ²) + ε_out), ε_out = exp(−k²/2) for
//! `outlier_sigmas` = k, so that unmapped clutter (furniture, people) costs a bounded amount.
//! Its gradient with respect to (x, y, θ) is analytic.
//!
//! Two choices the paper leaves open, made here:
//! - the refinement step is the gradient scaled per coordinate by the inverse diagonal of the
//!   Gauss–Newton curvature (a Jacobi preconditioner: metres and radians need different step
//!   sizes), times `step`, damped so that a direction no point constrains does not move;
//! - the acceptance test is a Metropolis–Hastings test on the unnormalised posterior:
//!   accept qʳ with probability min(1, p(y|qʳ) π(qʳ) / (p(y|q⁰) π(q⁰))), π being the motion
//!   model as a Gaussian around the odometry prediction whose standard deviations are at
//!   least `accept_sigma_xy` / `accept_sigma_theta` (slip the odometry model cannot see). A
//!   refinement that pulls a sample somewhere the motion cannot explain is refused.

use crate::error::LocalizationError;
use crate::filter::cluster::PointEstimate;
use crate::filter::initial_belief::check_gaussian;
use crate::filter::motion::{apply_increment, OdometryMotionModel};
use crate::filter::observation_fit::{per_unit_log_mean, FitTracker};
use crate::filter::particle_filter::{core_in_field, FilterCore, MeasurementModel, ParticleFilter};
use crate::filter::resampling::ResamplePolicy;
use crate::maps::line_map::{Correspondence, LineMap};
use crate::sensor_models::fspf::{vertical_planes_on_floor, FspfParams, PlaneFilter};
use atrium_robots::{normalize_angle, DepthImage, LaserScan, Pose2, Reading};
use atrium_worlds::VectorMap;
use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::limits::{
    check_count, check_count_min1, check_positive, MAX_BEAMS, MAX_PARTICLES, MAX_REFINEMENTS,
};

/// CGR parameters, as written in a scenario file. Every field has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CgrParams {
    /// Number of particles (fixed). Default 500.
    pub particles: usize,
    /// Odometry motion model α1–α4 (see [`OdometryMotionModel`]). Default 0.05 each.
    pub alpha: [f64; 4],
    /// r: gradient refinement iterations per sample. Default 3.
    pub refinements: usize,
    /// Fraction of the preconditioned gradient step taken per iteration, (0, 1]. Default 0.5.
    pub step: f64,
    /// Standard deviation of a point's distance to its map line, m. Default 0.05.
    pub sigma: f64,
    /// Residuals beyond this many σ count as outliers (bounded cost). Default 3.
    pub outlier_sigmas: f64,
    /// Farthest a point may be from a map segment to correspond to it, m. Default 0.5.
    pub max_correspondence: f64,
    /// Points used per observation, evenly spread over the available ones. Default 60.
    pub max_points: usize,
    /// Fewest points an observation must have to be used; with fewer, the particles only
    /// move (as when nothing is seen). Default 10. The point-to-line likelihood has no term
    /// for beams that return nothing, so a handful of stray returns in an open area (the
    /// SICK preset's short and random readings: 1.5 per scan on average, up to 8, in the
    /// atrium's interior) would otherwise decide the weights by chance alignments with walls
    /// for particles at the fringe of a wide cloud, and pull the cloud toward walls the
    /// laser does not see. Must be within [3, max_points].
    pub min_points: usize,
    /// Floor of the motion model's position standard deviation in the acceptance test, m.
    /// Default 0.02.
    pub accept_sigma_xy: f64,
    /// Floor of the motion model's heading standard deviation in the acceptance test, rad.
    /// Default 0.02.
    pub accept_sigma_theta: f64,
    /// Cell size of the correspondence grid, m. Default 0.1.
    pub map_resolution: f64,
    /// Depth only: FSPF parameters (Table 1 defaults). Scale `eta` with the camera's
    /// decimation.
    pub fspf: FspfParams,
    /// Depth only: a plane is vertical when |normal_z| <= this in the base frame. Default 0.2
    /// (about 11.5° from vertical).
    pub max_normal_z: f64,
    /// Depth only: a point may correspond to a map segment whose normal is within this angle
    /// of its plane's normal, degrees. Default 30.
    pub normal_tolerance_deg: f64,
    /// The reported estimate: `"heaviest_cluster"` (default, as ROS amcl: the weighted mean of
    /// the cluster of 0.5 m × 10° bins with the most weight) or `"weighted_mean"` of the whole
    /// set, which lands between the modes of a split cloud ([004] §3's open-area errors).
    pub estimate: PointEstimate,
    /// Resample only when the effective sample size falls below this fraction of the
    /// particles; 0 (default) resamples after every update with observations, as [004]
    /// §2.1 does. As MCL's `resample_ess`.
    pub resample_ess: f64,
}

impl Default for CgrParams {
    fn default() -> Self {
        Self {
            particles: 500,
            alpha: [0.05; 4],
            refinements: 3,
            step: 0.5,
            sigma: 0.05,
            outlier_sigmas: 3.0,
            max_correspondence: 0.5,
            max_points: 60,
            min_points: 10,
            accept_sigma_xy: 0.02,
            accept_sigma_theta: 0.02,
            map_resolution: 0.1,
            fspf: FspfParams::default(),
            max_normal_z: 0.2,
            normal_tolerance_deg: 30.0,
            estimate: PointEstimate::default(),
            resample_ess: 0.0,
        }
    }
}

impl CgrParams {
    /// When the filter resamples.
    pub fn resample_policy(&self) -> ResamplePolicy {
        ResamplePolicy::from_resample_ess(self.resample_ess)
    }

    /// Checks every field; the message names the field and the value.
    pub fn validate(&self) -> Result<(), String> {
        check_count_min1("particles", self.particles, MAX_PARTICLES, "MAX_PARTICLES")?;
        crate::filter::motion::validate_alpha(&self.alpha)?;
        check_count(
            "refinements",
            self.refinements,
            MAX_REFINEMENTS,
            "MAX_REFINEMENTS",
        )?;
        if !(self.step > 0.0 && self.step <= 1.0) {
            return Err(format!("step must be in (0, 1], got {}", self.step));
        }
        check_positive("sigma", self.sigma)?;
        check_positive("outlier_sigmas", self.outlier_sigmas)?;
        check_positive("max_correspondence", self.max_correspondence)?;
        if self.max_points < 3 {
            return Err(format!("max_points must be >= 3, got {}", self.max_points));
        }
        check_count("max_points", self.max_points, MAX_BEAMS, "MAX_BEAMS")?;
        if !(3..=self.max_points).contains(&self.min_points) {
            return Err(format!(
                "min_points must be within [3, max_points = {}], got {}",
                self.max_points, self.min_points
            ));
        }
        check_positive("accept_sigma_xy", self.accept_sigma_xy)?;
        check_positive("accept_sigma_theta", self.accept_sigma_theta)?;
        check_positive("map_resolution", self.map_resolution)?;
        self.fspf.validate().map_err(|m| format!("fspf.{m}"))?;
        if !(self.max_normal_z.is_finite() && (0.0..1.0).contains(&self.max_normal_z)) {
            return Err(format!(
                "max_normal_z must be in [0, 1), got {}",
                self.max_normal_z
            ));
        }
        if !(self.normal_tolerance_deg > 0.0 && self.normal_tolerance_deg <= 90.0) {
            return Err(format!(
                "normal_tolerance_deg must be in (0, 90], got {}",
                self.normal_tolerance_deg
            ));
        }
        if !(self.resample_ess.is_finite() && (0.0..=1.0).contains(&self.resample_ess)) {
            return Err(format!(
                "resample_ess must be a fraction in [0, 1], got {}",
                self.resample_ess
            ));
        }
        Ok(())
    }
}

/// What a CGR localizer observes.
#[derive(Debug, Clone)]
enum Source {
    Laser,
    Depth {
        fspf: Box<PlaneFilter>,
        /// Vertical-plane points on the floor and their normals, base frame.
        points: Vec<[f64; 2]>,
        normals: Vec<[f64; 2]>,
        min_cos: f64,
    },
}

/// The gradient of a pose's observation log-likelihood and its Gauss–Newton diagonal; the
/// log-likelihood itself is left in per-point [`Terms`] until it is asked for.
#[derive(Debug, Clone, Copy, Default)]
struct Eval {
    grad: [f64; 3],
    hdiag: [f64; 3],
}

/// Marks a point without a corresponding segment in [`Terms`] (a Gaussian factor is >= 0).
const NO_CORRESPONDENCE: f64 = -1.0;

/// The Gaussian factor g = exp(−d²/2σ²) of each observed point at the last evaluated pose, or
/// [`NO_CORRESPONDENCE`]. The refinement only needs the gradient; the logarithms of the
/// log-likelihood, one per point, are taken from here only for the poses that the acceptance
/// test compares (q⁰ and qʳ), not for the intermediate refinement iterates. Summed in point
/// order with the operations the single pass used, the result is bit for bit the same.
/// `matched` is the evaluation's scratch: the points with a segment, in point order.
#[derive(Debug, Clone, Default)]
struct Terms {
    g: Vec<f64>,
    matched: Vec<Matched>,
}

impl Terms {
    fn with_capacity(n: usize) -> Terms {
        Terms {
            g: Vec::with_capacity(n),
            matched: Vec::with_capacity(n),
        }
    }
}

/// An observed point with a corresponding segment, at the evaluated pose.
#[derive(Debug, Clone, Copy)]
struct Matched {
    /// Index of the point in the observation.
    point: usize,
    corr: Correspondence,
}

/// A CGR particle filter on a vector map.
#[derive(Debug, Clone)]
pub struct Cgr {
    /// `particles` particles, resampled (by `resample_ess`) after updates with observations.
    core: FilterCore,
    params: CgrParams,
    map: LineMap,
    motion: OdometryMotionModel,
    source: Source,
    /// Observed points in the base frame and (depth) their unit normals.
    obs: Vec<[f64; 2]>,
    obs_normals: Vec<[f64; 2]>,
    /// Scratch of [`Cgr::evaluate`], one factor per observed point.
    terms: Terms,
    /// Refined samples accepted / offered, over the whole run.
    accepted: u64,
    offered: u64,
    /// Sensing mismatch (004 §4.2) of the updates, per observed point.
    fit: FitTracker,
}

impl Cgr {
    /// A CGR localizer fed by laser scans (every `Reading::Laser`).
    pub fn laser(
        name: &str,
        params: CgrParams,
        map: &VectorMap,
        start: Pose2,
        sigma: [f64; 3],
        seed: u64,
    ) -> Result<Cgr, LocalizationError> {
        Self::new(name, params, map, start, sigma, seed, false)
    }

    /// A CGR localizer fed by depth images (every `Reading::Depth`) through FSPF.
    pub fn depth(
        name: &str,
        params: CgrParams,
        map: &VectorMap,
        start: Pose2,
        sigma: [f64; 3],
        seed: u64,
    ) -> Result<Cgr, LocalizationError> {
        Self::new(name, params, map, start, sigma, seed, true)
    }

    fn new(
        name: &str,
        params: CgrParams,
        map: &VectorMap,
        start: Pose2,
        sigma: [f64; 3],
        seed: u64,
        depth: bool,
    ) -> Result<Cgr, LocalizationError> {
        params
            .validate()
            .map_err(LocalizationError::InvalidParameter)?;
        check_gaussian(&start, &sigma)?;
        let line_map = LineMap::new(map, params.map_resolution, params.max_correspondence)?;
        let source = if depth {
            Source::Depth {
                // The plane filter draws from its own stream, so FSPF's sampling never shifts
                // the particle filter's.
                fspf: Box::new(PlaneFilter::new(params.fspf, seed ^ 0x5f5f_5f5f_5f5f_5f5f)?),
                points: Vec::with_capacity(params.fspf.n_max + params.fspf.l),
                normals: Vec::with_capacity(params.fspf.n_max + params.fspf.l),
                min_cos: params.normal_tolerance_deg.to_radians().cos(),
            }
        } else {
            Source::Laser
        };
        let m = params.particles;
        let mut core = FilterCore::new(name, m, seed);
        // Validated above.
        core.reseed(m, start, sigma, params.estimate);
        Ok(Cgr {
            core,
            motion: OdometryMotionModel::new(params.alpha),
            map: line_map,
            source,
            obs: Vec::with_capacity(params.max_points),
            obs_normals: Vec::with_capacity(params.max_points),
            terms: Terms::with_capacity(params.max_points),
            accepted: 0,
            offered: 0,
            fit: FitTracker::default(),
            params,
        })
    }

    pub fn params(&self) -> &CgrParams {
        &self.params
    }

    /// Fraction of refined samples the acceptance test kept, over the run so far.
    pub fn acceptance_rate(&self) -> f64 {
        if self.offered == 0 {
            0.0
        } else {
            self.accepted as f64 / self.offered as f64
        }
    }

    /// Sets the observation to `points` (base frame) and, for depth, their normals; used by
    /// tests and by callers that extract points themselves.
    pub fn set_observation(&mut self, points: &[[f64; 2]], normals: Option<&[[f64; 2]]>) {
        self.obs.clear();
        self.obs_normals.clear();
        self.obs.extend_from_slice(points);
        if let Some(n) = normals {
            self.obs_normals.extend_from_slice(n);
        }
    }

    /// The observation log-likelihood of `pose` for the current observation.
    pub fn log_likelihood(&self, pose: &Pose2) -> f64 {
        let mut terms = Terms::default();
        self.match_points(pose.x, pose.y, pose.theta, &mut terms);
        self.log_likelihood_of(&terms)
    }

    /// `r` refinement iterations of `pose` on the current observation (step 2 alone).
    pub fn refine(&self, pose: &Pose2, r: usize) -> Pose2 {
        let (mut x, mut y, mut th) = (pose.x, pose.y, pose.theta);
        let mut terms = Terms::default();
        let mut e = self.evaluate(x, y, th, &mut terms);
        for k in 0..r {
            let d = self.refinement_step(&e);
            x += d[0];
            y += d[1];
            th = normalize_angle(th + d[2]);
            if k + 1 < r {
                e = self.evaluate(x, y, th, &mut terms);
            }
        }
        Pose2::new(x, y, th)
    }

    /// Gradient and Gauss–Newton diagonal of the current observation's log-likelihood at
    /// (x, y, θ); each point's Gaussian factor goes to `terms` for
    /// [`Cgr::log_likelihood_of`]. Allocation-free once `terms` has grown to the observation.
    fn evaluate(&self, px: f64, py: f64, th: f64, terms: &mut Terms) -> Eval {
        let (s, c) = self.match_points(px, py, th, terms);
        self.gradient(s, c, terms)
    }

    /// The first two of an evaluation's three passes: each observed point's segment and
    /// Gaussian factor at (x, y, θ), into `terms`; all the log-likelihood needs, and all a
    /// pose whose gradient would go unused (the last refinement iterate) is given. Returns
    /// sin θ and cos θ for [`Cgr::gradient`].
    fn match_points(&self, px: f64, py: f64, th: f64, terms: &mut Terms) -> (f64, f64) {
        let sigma2 = self.params.sigma * self.params.sigma;
        let (s, c) = th.sin_cos();
        let min_cos = match &self.source {
            Source::Depth { min_cos, .. } => *min_cos,
            Source::Laser => 0.0,
        };
        let with_normals = self.obs_normals.len() == self.obs.len();
        let Terms {
            g: factors,
            matched,
        } = terms;
        factors.clear();
        matched.clear();
        // Three passes over the points (with the gradient's), each with no chain from one
        // point to the next but the sums of the last: the processor overlaps the points'
        // lookups, divisions and library calls, where one pass per point waited for each in
        // turn (the work and its order per value are unchanged, so the results are too, bit
        // for bit).
        // Every point starts without a segment; the matched ones get their factor below.
        factors.resize(self.obs.len(), NO_CORRESPONDENCE);
        let mut offer = |i: usize, corr: Option<Correspondence>| {
            if let Some(corr) = corr {
                matched.push(Matched { point: i, corr });
            }
        };
        // One loop per source, so the laser's has no normal to test.
        if with_normals {
            for (i, (q, n)) in self.obs.iter().zip(&self.obs_normals).enumerate() {
                let p = [px + c * q[0] - s * q[1], py + s * q[0] + c * q[1]];
                let n = [c * n[0] - s * n[1], s * n[0] + c * n[1]];
                offer(i, self.map.correspondence(p, Some((n, min_cos))));
            }
        } else {
            for (i, q) in self.obs.iter().enumerate() {
                let p = [px + c * q[0] - s * q[1], py + s * q[0] + c * q[1]];
                offer(i, self.map.correspondence(p, None));
            }
        }
        for m in matched.iter() {
            let d = m.corr.distance;
            factors[m.point] = (-0.5 * d * d / sigma2).exp();
        }
        (s, c)
    }

    /// The third pass: gradient and Gauss–Newton diagonal from the points matched by
    /// [`Cgr::match_points`] at a pose of heading sin θ = `s`, cos θ = `c`.
    fn gradient(&self, s: f64, c: f64, terms: &Terms) -> Eval {
        let sigma2 = self.params.sigma * self.params.sigma;
        let eps_out = self.outlier_floor();
        let lines = self.map.lines();
        let mut e = Eval::default();
        for m in terms.matched.iter() {
            let q = self.obs[m.point];
            let g = terms.g[m.point];
            // Residual vector from the closest point of the segment to p, and its length.
            let (r, d) = (m.corr.residual, m.corr.distance);
            // d/dpose of ½d²: r·∂p; the mixture weights it by g / (g + ε_out).
            let omega = g / (g + eps_out) / sigma2;
            let dp_dth = [-s * q[0] - c * q[1], c * q[0] - s * q[1]];
            e.grad[0] -= omega * r[0];
            e.grad[1] -= omega * r[1];
            e.grad[2] -= omega * (r[0] * dp_dth[0] + r[1] * dp_dth[1]);
            let u = if d > 1e-9 {
                [r[0] / d, r[1] / d]
            } else {
                lines[m.corr.line].normal
            };
            let j_th = u[0] * dp_dth[0] + u[1] * dp_dth[1];
            e.hdiag[0] += omega * u[0] * u[0];
            e.hdiag[1] += omega * u[1] * u[1];
            e.hdiag[2] += omega * j_th * j_th;
        }
        e
    }

    /// ε_out = exp(−k²/2), the outlier floor of the per-point mixture.
    fn outlier_floor(&self) -> f64 {
        let k = self.params.outlier_sigmas;
        (-0.5 * k * k).exp()
    }

    /// The observation log-likelihood from the factors of an evaluation: per point
    /// log(g + ε_out) − log(1 + ε_out), or log ε_out − log(1 + ε_out) without a segment.
    fn log_likelihood_of(&self, terms: &Terms) -> f64 {
        let eps_out = self.outlier_floor();
        let norm = (1.0 + eps_out).ln();
        let outlier = eps_out.ln() - norm;
        let mut loglik = 0.0;
        for &g in &terms.g {
            if g == NO_CORRESPONDENCE {
                loglik += outlier;
            } else {
                loglik += (g + eps_out).ln() - norm;
            }
        }
        loglik
    }

    /// One refinement step from an evaluation: the gradient preconditioned by the damped
    /// Gauss–Newton diagonal, times `step`, clamped to half the correspondence distance
    /// (and 0.1 rad) so a step never jumps to other walls.
    fn refinement_step(&self, e: &Eval) -> [f64; 3] {
        let sigma2 = self.params.sigma * self.params.sigma;
        // Damping: as if 5 % of the points constrained every coordinate with a 1 m lever.
        let damping = 0.05 * self.obs.len().max(1) as f64 / sigma2;
        let lim = 0.5 * self.params.max_correspondence;
        let mut d: [f64; 3] =
            std::array::from_fn(|k| self.params.step * e.grad[k] / (e.hdiag[k] + damping));
        d[0] = d[0].clamp(-lim, lim);
        d[1] = d[1].clamp(-lim, lim);
        d[2] = d[2].clamp(-0.1, 0.1);
        d
    }

    /// Laser endpoints in the base frame: up to max_points valid beams, evenly spread.
    fn observe_laser(&mut self, scan: &LaserScan) {
        self.obs.clear();
        self.obs_normals.clear();
        let valid = |r: f64| r.is_finite() && r >= scan.range_min && r < scan.range_max;
        let n_valid = scan.ranges.iter().filter(|r| valid(**r)).count();
        if n_valid == 0 {
            return;
        }
        let m = self.params.max_points.min(n_valid);
        let (mut taken, mut next, mut v) = (0usize, 0usize, 0usize);
        for (i, &r) in scan.ranges.iter().enumerate() {
            if !valid(r) {
                continue;
            }
            if v == next {
                let a = scan.beam_angle(i);
                self.obs
                    .push(scan.mount.transform_point([r * a.cos(), r * a.sin()]));
                taken += 1;
                if taken == m {
                    break;
                }
                next = taken * n_valid / m;
            }
            v += 1;
        }
    }

    /// FSPF on the image, vertical planes projected to the floor, then up to max_points of
    /// them evenly spread (FSPF's output order is already random).
    fn observe_depth(&mut self, img: &DepthImage) -> Result<(), LocalizationError> {
        self.obs.clear();
        self.obs_normals.clear();
        let max_normal_z = self.params.max_normal_z;
        let Source::Depth {
            fspf,
            points,
            normals,
            ..
        } = &mut self.source
        else {
            return Ok(());
        };
        let mount = img.mount.to_isometry();
        let filtered = fspf.filter(img)?;
        vertical_planes_on_floor(&filtered, &mount, max_normal_z, points, normals);
        let n = points.len();
        let m = self.params.max_points.min(n);
        for k in 0..m {
            let i = k * n / m;
            self.obs.push(points[i]);
            self.obs_normals.push(normals[i]);
        }
        Ok(())
    }

    /// Steps 1–3 of CGR on the current observation and the importance weights of step 4
    /// (its resampling is the recipe's, by `resample_ess`). False when the observation has
    /// too few points: the particles then only moved.
    fn cgr_update(&mut self) -> bool {
        let p = std::mem::take(&mut self.core.carry.pending);
        let moved = p.x != 0.0 || p.y != 0.0 || p.theta != 0.0;
        let inc = self.motion.decompose(&Pose2::default(), &p);
        // The motion model as a Gaussian in the frame of each particle's odometry prediction,
        // for the acceptance test.
        let sd_along = inc.sd_trans.max(self.params.accept_sigma_xy);
        let sd_lateral = (inc.trans.abs() * inc.sd_rot1).max(self.params.accept_sigma_xy);
        let sd_theta = inc
            .sd_rot1
            .hypot(inc.sd_rot2)
            .max(self.params.accept_sigma_theta);
        let motion_log = |mu: &Pose2, q: &Pose2| {
            let rel = mu.between(q);
            -0.5 * ((rel.x / sd_along).powi(2)
                + (rel.y / sd_lateral).powi(2)
                + (rel.theta / sd_theta).powi(2))
        };
        let have_obs = self.obs.len() >= self.params.min_points;
        let r = self.params.refinements;
        let mut terms = std::mem::take(&mut self.terms);
        // CGR keeps its own step 1: its motion draws interleave with the acceptance test's.
        for i in 0..self.core.set.len() {
            let prev = self.core.set.pose(i);
            // Step 1: q⁰ from the motion model.
            let q0 = if moved {
                let (x, y, th) =
                    apply_increment(prev.x, prev.y, prev.theta, &inc, &mut self.core.rng);
                Pose2::new(x, y, th)
            } else {
                prev
            };
            if !have_obs {
                self.core.set.set_pose(i, q0);
                continue;
            }
            // Step 2: r refinement iterations.
            let mut e = self.evaluate(q0.x, q0.y, q0.theta, &mut terms);
            let ll0 = self.log_likelihood_of(&terms);
            let (mut cx, mut cy, mut ct) = (q0.x, q0.y, q0.theta);
            let mut refined = false;
            for k in 0..r {
                let d = self.refinement_step(&e);
                if d[0].abs() < 1e-6 && d[1].abs() < 1e-6 && d[2].abs() < 1e-7 {
                    break;
                }
                cx += d[0];
                cy += d[1];
                ct = normalize_angle(ct + d[2]);
                // qʳ needs only its likelihood, for the acceptance test: no gradient.
                let (s, c) = self.match_points(cx, cy, ct, &mut terms);
                if k + 1 < r {
                    e = self.gradient(s, c, &terms);
                }
                refined = true;
            }
            let llr = if refined {
                self.log_likelihood_of(&terms)
            } else {
                ll0
            };
            let qr = Pose2::new(cx, cy, ct);
            // Step 3: acceptance test between qʳ and q⁰.
            let mu = if moved { prev.compose(&p) } else { prev };
            let log_alpha = (llr + motion_log(&mu, &qr)) - (ll0 + motion_log(&mu, &q0));
            self.offered += 1;
            let u: f64 = self.core.rng.random();
            let (chosen, ll) = if log_alpha >= 0.0 || u.ln() < log_alpha {
                self.accepted += 1;
                (qr, llr)
            } else {
                (q0, ll0)
            };
            self.core.set.set_pose(i, chosen);
            self.core.set.log_likelihoods_mut()[i] = ll;
        }
        self.terms = terms;
        if !have_obs {
            // Nothing (or too little) to match: for the mismatch measure, as if every point
            // were an outlier, so a sensor that sees nothing does not look well matched.
            let eps_out = self.outlier_floor();
            self.fit
                .record_blind(self.core.carry.stamp, eps_out.ln() - (1.0 + eps_out).ln());
            return false;
        }
        // Step 4: importance weights (normalised in log space).
        self.fit.record(
            self.core.carry.stamp,
            per_unit_log_mean(self.core.set.log_likelihoods(), self.obs.len()),
        );
        self.core.set.weigh_by_log_likelihoods();
        true
    }
}

impl ParticleFilter for Cgr {
    core_in_field!();

    /// Laser scans for a laser CGR, depth images for a depth CGR; everything else is
    /// ignored. A depth image FSPF cannot use (η larger than the image, malformed
    /// intrinsics) is skipped: the parameters were checked against the camera when the
    /// localizer was built.
    fn take_reading(&mut self, reading: &Reading) {
        match (reading, &self.source) {
            (Reading::Laser(scan), Source::Laser) => {
                self.core.carry.observed_at(scan.stamp);
                self.observe_laser(scan);
            }
            (Reading::Depth(img), Source::Depth { .. }) => {
                self.core.carry.observed_at(img.stamp);
                if self.observe_depth(img).is_err() {
                    return;
                }
            }
            _ => return,
        }
        self.filter_update(&());
    }

    fn fit_tracker(&self) -> Option<&FitTracker> {
        Some(&self.fit)
    }

    fn reseed(&mut self, pose: Pose2, sigma: [f64; 3]) -> bool {
        self.core
            .reseed(self.core.set.len(), pose, sigma, self.params.estimate)
    }
}

/// CGR's observation is the points [`Cgr::observe_laser`] or [`Cgr::observe_depth`] loaded
/// into the filter, where the matching reads them.
impl MeasurementModel for Cgr {
    type Observation = ();

    fn motion(&self) -> &OdometryMotionModel {
        &self.motion
    }

    /// Nothing here: CGR moves each particle in [`MeasurementModel::reweight`] (step 1), its
    /// motion draws interleaved with the acceptance test's; and with an observation too
    /// small to use, the particles still move there (the estimate then follows them instead
    /// of freezing wherever the sensor last saw something, open areas in 004 §3).
    fn propagate(&mut self) {}

    fn reweight(&mut self, _: &()) -> bool {
        self.cgr_update()
    }

    fn point_estimate(&self) -> PointEstimate {
        self.params.estimate
    }

    fn resample_policy(&self) -> ResamplePolicy {
        self.params.resample_policy()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::localizer::{Localizer, OdometryDelta};
    use atrium_worlds::Segment;

    /// A 10 × 4 m room with a 1 m notch in the north wall at x ∈ [6, 7] (so that x is
    /// observable), as a vector map.
    fn room() -> VectorMap {
        let s = |a: [f64; 2], b: [f64; 2]| Segment { a, b };
        VectorMap {
            segments: vec![
                s([0.0, 0.0], [10.0, 0.0]),
                s([10.0, 0.0], [10.0, 4.0]),
                s([10.0, 4.0], [7.0, 4.0]),
                s([7.0, 4.0], [7.0, 5.0]),
                s([7.0, 5.0], [6.0, 5.0]),
                s([6.0, 5.0], [6.0, 4.0]),
                s([6.0, 4.0], [0.0, 4.0]),
                s([0.0, 4.0], [0.0, 0.0]),
            ],
        }
    }

    /// Exact laser endpoints from `pose`: 181 beams over 360°, ray-cast on the map.
    fn scan_points(map: &VectorMap, pose: Pose2) -> Vec<[f64; 2]> {
        let mut pts = Vec::new();
        for i in 0..181 {
            let a = -std::f64::consts::PI + i as f64 * std::f64::consts::TAU / 181.0;
            let dir = [(pose.theta + a).cos(), (pose.theta + a).sin()];
            let mut best = f64::INFINITY;
            for s in &map.segments {
                if let Some(t) = atrium_worlds::geometry::ray_segment_intersection(
                    [pose.x, pose.y],
                    dir,
                    s.a,
                    s.b,
                ) {
                    best = best.min(t);
                }
            }
            if best < 8.0 {
                pts.push([best * a.cos(), best * a.sin()]);
            }
        }
        pts
    }

    fn cgr(map: &VectorMap, params: CgrParams, start: Pose2) -> Cgr {
        Cgr::laser("cgr", params, map, start, [0.0; 3], 1).unwrap()
    }

    #[test]
    fn refinement_moves_a_perturbed_pose_toward_the_truth() {
        let map = room();
        let truth = Pose2::new(5.0, 2.0, 0.3);
        let mut c = cgr(&map, CgrParams::default(), truth);
        let pts = scan_points(&map, truth);
        c.set_observation(&pts, None);
        for off in [
            Pose2::new(0.1, 0.0, 0.0),
            Pose2::new(0.0, -0.12, 0.0),
            Pose2::new(0.0, 0.0, 0.04),
            Pose2::new(-0.08, 0.08, -0.03),
        ] {
            let start = Pose2::new(truth.x + off.x, truth.y + off.y, truth.theta + off.theta);
            let err = |p: &Pose2| p.distance(&truth) + p.heading_error(&truth);
            let mut p = start;
            let mut last = err(&p);
            for _ in 0..6 {
                p = c.refine(&p, 1);
                let now = err(&p);
                assert!(now <= last + 1e-9, "{off:?}: error grew {last} -> {now}");
                last = now;
            }
            assert!(
                last < 0.2 * err(&start),
                "{off:?}: {} -> {last} after 6 iterations",
                err(&start)
            );
            assert!(c.log_likelihood(&p) > c.log_likelihood(&start));
        }
    }

    #[test]
    fn tracks_a_straight_drive_from_noisy_odometry() {
        let map = room();
        let params = CgrParams {
            particles: 100,
            alpha: [0.05; 4],
            ..Default::default()
        };
        let mut truth = Pose2::new(1.0, 2.0, 0.0);
        let mut c = cgr(&map, params, truth);
        let mut odo = truth;
        for k in 0..80 {
            let step = Pose2::new(0.1, 0.0, if k < 40 { 0.0 } else { 0.01 });
            let next = truth.compose(&step);
            // Odometry believes 3 % less distance and a slight left drift.
            let next_odo = odo.compose(&Pose2::new(0.097, 0.001, step.theta + 0.002));
            c.predict(&OdometryDelta {
                stamp: k as f64,
                from: odo,
                to: next_odo,
            })
            .unwrap();
            truth = next;
            odo = next_odo;
            // The exact endpoints, straight into the observation (the scan path is the
            // scenario tests' job).
            let pts = scan_points(&map, truth);
            c.set_observation(&pts, None);
            c.filter_update(&());
        }
        let est = c.estimate().pose;
        assert!(est.distance(&truth) < 0.03, "{est:?} vs {truth:?}");
        assert!(est.heading_error(&truth) < 0.01);
        assert!(
            odo.distance(&truth) > 0.2,
            "odometry alone drifted {}",
            odo.distance(&truth)
        );
        assert!(c.acceptance_rate() > 0.3, "{}", c.acceptance_rate());
    }

    #[test]
    fn bad_parameters_are_named() {
        let map = room();
        let bad = |p: CgrParams| {
            Cgr::laser("c", p, &map, Pose2::default(), [0.1; 3], 0)
                .unwrap_err()
                .to_string()
        };
        assert!(bad(CgrParams {
            particles: 0,
            ..Default::default()
        })
        .contains("particles"));
        assert!(bad(CgrParams {
            step: 0.0,
            ..Default::default()
        })
        .contains("step"));
        assert!(bad(CgrParams {
            fspf: FspfParams {
                l: 1,
                ..Default::default()
            },
            ..Default::default()
        })
        .contains("fspf.l"));
        for min_points in [2, 61] {
            assert!(bad(CgrParams {
                min_points,
                ..Default::default()
            })
            .contains("min_points"));
        }
        let e = Cgr::laser(
            "c",
            CgrParams::default(),
            &map,
            Pose2::default(),
            [-1.0; 3],
            0,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("sigma"), "{e}");
    }

    #[test]
    fn counts_above_their_limits_name_field_and_limit() {
        use crate::limits::{MAX_BEAMS, MAX_PARTICLES, MAX_REFINEMENTS};
        let check = |f: fn(&mut CgrParams)| {
            let mut p = CgrParams::default();
            f(&mut p);
            p.validate()
        };
        assert!(check(|p| p.particles = MAX_PARTICLES).is_ok());
        assert_eq!(
            check(|p| p.particles = MAX_PARTICLES + 1).unwrap_err(),
            "particles: 1000001 is more than the limit of 1000000 (MAX_PARTICLES)"
        );
        assert!(check(|p| p.max_points = MAX_BEAMS).is_ok());
        assert_eq!(
            check(|p| p.max_points = 1_000_000_000_000).unwrap_err(),
            "max_points: 1000000000000 is more than the limit of 100000 (MAX_BEAMS)"
        );
        assert!(check(|p| p.refinements = MAX_REFINEMENTS).is_ok());
        assert!(check(|p| p.refinements = MAX_REFINEMENTS + 1)
            .unwrap_err()
            .contains("MAX_REFINEMENTS"));
        assert_eq!(
            check(|p| p.fspf.n_max = usize::MAX).unwrap_err(),
            format!(
                "fspf.n_max: {} is more than the limit of 100000 (FSPF_MAX_POINTS)",
                usize::MAX
            )
        );
    }
}
