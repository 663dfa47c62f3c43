//! The recursive Bayesian landmark filter of Theodoridis et al.,
//! [002]: node-based odometry (Table I) whose pose is
//! reset to a node when the laser recognises the landmark there (passive localisation,
//! Algorithm 1).
//!
//! - Signatures (§III-B, §IV-B): a 180-sample scan becomes a 6-bin histogram of its ranges
//!   ([`LandmarkSignature`]).
//! - Recursive update (eq. 1–4, [`RecursiveLandmarkModel`]): the prior comes from the current
//!   observation, the conditional is the node's model learnt from its training observations,
//!   the posterior is normalised by the evidence and fed back as the next prior (eq. 2).
//! - Covariance signature γ (eq. 6, [`covariance`], [`covariance_error`]) with a threshold γ_n
//!   per node learnt in a training run ([`train`]).
//! - Passive localisation (Algorithm 1, [`LandmarkFilter`]): inside radius ρ of the next node
//!   and with γ < γ_n, the pose is set to the node; the first steps after each node are not
//!   trusted (§IV-B filters the first 30 time steps of 100 ms).
//!
//! - Beyond the paper ([`align`]): at verification the current scan is aligned with the node's
//!   training scan (the r_t and x_t of the node's feature triplet, eq. 5), and the pose is
//!   reset to the node's training pose corrected by the measured offset (x, y and θ), not
//!   only to the node's x, y (`scan_alignment`, on by default; off is the paper's reset).
//!
//! Where the paper leaves a choice open, the choice and its reason are stated at the item.

pub mod align;

use crate::error::LocalizationError;
use crate::localizer::{Capabilities, Estimate, Localizer, LocalizerError, OdometryDelta};
use align::{AlignParams, ScanPoints};
use atrium_robots::node_route::Leg;
use atrium_robots::{normalize_angle, LaserScan, Pose2, Reading};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};

/// Histogram bins of a signature (002 §IV-B: "a six-bin histogram for each model").
pub const BINS: usize = 6;

/// A normalised 6-bin histogram.
pub type Histogram = [f64; BINS];

/// The landmark signature of one scan: the histogram of its ranges over [0, max_range] in six
/// equal bins (002 §IV-B), normalised to sum 1.
///
/// Every bin starts with one pseudo-count (Laplace smoothing, a uniform Dirichlet prior): the
/// recursive update multiplies histograms, and one empty bin would otherwise zero a bin of
/// the posterior for good. Readings at or beyond `max_range` (nothing returned) fall in the
/// last bin; non-finite readings are skipped.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LandmarkSignature(pub Histogram);

impl LandmarkSignature {
    pub fn from_ranges(ranges: &[f64], max_range: f64) -> LandmarkSignature {
        let mut h = [1.0; BINS];
        let width = max_range / BINS as f64;
        for &r in ranges {
            if !r.is_finite() {
                continue;
            }
            let bin = ((r.max(0.0) / width) as usize).min(BINS - 1);
            h[bin] += 1.0;
        }
        LandmarkSignature(normalised(h))
    }

    pub fn bins(&self) -> &Histogram {
        &self.0
    }
}

fn normalised(mut h: Histogram) -> Histogram {
    let s: f64 = h.iter().sum();
    if s > 0.0 && s.is_finite() {
        for v in &mut h {
            *v /= s;
        }
    } else {
        h = [1.0 / BINS as f64; BINS];
    }
    h
}

/// Eq. 6 of 002: Cov_f[p, q] = Σ_i (p_i − p̄)(q_i − q̄) / S over the S = 6 bins.
pub fn covariance(p: &Histogram, q: &Histogram) -> f64 {
    let pm = p.iter().sum::<f64>() / BINS as f64;
    let qm = q.iter().sum::<f64>() / BINS as f64;
    p.iter()
        .zip(q)
        .map(|(a, b)| (a - pm) * (b - qm))
        .sum::<f64>()
        / BINS as f64
}

/// The covariance error γ between a posterior `p` and a node's signature `s`, built from the
/// covariance of eq. 6: γ = Cov[p, p] − 2·Cov[p, s] + Cov[s, s] (= Cov[p − s, p − s]).
///
/// The paper thresholds a "covariance error" that "diminishes" as the robot approaches the
/// landmark (§III-B, §IV-B, Fig. 4c) but prints only the cross-covariance; the cross term
/// alone grows with similarity and depends on how peaked the histograms are, so Atrium uses
/// the expansion above, which is zero exactly when the posterior equals the signature and
/// grows with every difference between them.
pub fn covariance_error(p: &Histogram, s: &Histogram) -> f64 {
    (covariance(p, p) - 2.0 * covariance(p, s) + covariance(s, s)).max(0.0)
}

/// The recursive Bayesian model of one node (002 eq. 1–4).
///
/// States x_z are the six bins. At every scan:
/// - prior (eq. 2): the current observation h_t, combined with the posterior fed back from the
///   previous scan: prior_t ∝ h_t^w · post_{t−1}^(1−w), with `observation_weight` w. The paper
///   says both "the prior is the current landmark observation" and "the prior is updated
///   recursively with the posterior"; a weighted geometric combination is both, and w < 1
///   lets past scans smooth the laser noise without the posterior forgetting where the
///   robot is now (w = 1 would drop the feedback, w → 0 would freeze the first scan). The
///   feedback carries the conditional along, so the posterior leans on it as c^(1/w): the
///   default w = 0.8 keeps that lean mild, so that a different landmark stays different;
/// - posterior (eq. 1): post_t(x) = prior_t(x) · c(x) / Σ_x prior_t(x) · c(x), with c the
///   conditional (the node's training observations, eq. 3) and the sum the evidence (eq. 4).
///
/// With the same observation h repeated, the posterior converges to ∝ h · c^(1/w); the node's
/// signature ([`RecursiveLandmarkModel::signature`]) is that limit for h = c: the posterior the
/// recursion settles on when the robot sees exactly what it saw at the node in training.
#[derive(Debug, Clone, PartialEq)]
pub struct RecursiveLandmarkModel {
    conditional: Histogram,
    signature: Histogram,
    weight: f64,
    posterior: Histogram,
    steps: usize,
}

impl RecursiveLandmarkModel {
    /// `conditional` must be a positive histogram; `observation_weight` in (0, 1].
    pub fn new(conditional: Histogram, observation_weight: f64) -> RecursiveLandmarkModel {
        let conditional = normalised(conditional);
        let power = 1.0 + 1.0 / observation_weight;
        let signature = normalised(conditional.map(|c| c.powf(power)));
        RecursiveLandmarkModel {
            conditional,
            signature,
            weight: observation_weight,
            posterior: [1.0 / BINS as f64; BINS],
            steps: 0,
        }
    }

    /// Forgets every observation: the posterior is uniform again.
    pub fn reset(&mut self) {
        self.posterior = [1.0 / BINS as f64; BINS];
        self.steps = 0;
    }

    /// One recursion step with an observed signature; returns the new posterior.
    pub fn update(&mut self, observation: &Histogram) -> &Histogram {
        let w = self.weight;
        let mut post = [0.0; BINS];
        for i in 0..BINS {
            let prior = observation[i].powf(w) * self.posterior[i].powf(1.0 - w);
            post[i] = prior * self.conditional[i];
        }
        // normalised() divides by the evidence of eq. 4.
        self.posterior = normalised(post);
        self.steps += 1;
        &self.posterior
    }

    pub fn posterior(&self) -> &Histogram {
        &self.posterior
    }

    pub fn conditional(&self) -> &Histogram {
        &self.conditional
    }

    pub fn signature(&self) -> &Histogram {
        &self.signature
    }

    /// Observations since the last reset.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// γ of the current posterior against the node's signature.
    pub fn gamma(&self) -> f64 {
        covariance_error(&self.posterior, &self.signature)
    }

    /// γ once the recursion has settled on an observation seen over and over (the posterior
    /// ∝ h · c^(1/w)): what a robot standing still at that spot ends up with.
    pub fn settled_gamma(&self, observation: &Histogram) -> f64 {
        let p = 1.0 / self.weight;
        let mut post = [0.0; BINS];
        for i in 0..BINS {
            post[i] = observation[i] * self.conditional[i].powf(p);
        }
        covariance_error(&normalised(post), &self.signature)
    }
}

/// Parameters of the landmark filter (`[[localizers]] kind = "landmark_filter"`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct LandmarkFilterParams {
    /// ρ, m: a node can be verified only within this radius of it (002 §III-C, §IV-A: 250 mm).
    pub rho: f64,
    /// Scans after each node during which no node is verified (002 §IV-B: the first 30 time
    /// steps, one per 100 ms scan).
    pub warmup_steps: usize,
    /// w of [`RecursiveLandmarkModel`], in (0, 1].
    pub observation_weight: f64,
    /// γ_n = margin × the largest γ seen inside ρ of node n in the training run (after the
    /// warm-up); a margin > 1 leaves room for the run's own laser noise.
    pub gamma_margin: f64,
    /// Upper edge of the histogram, m; 0 means the laser's own maximum range.
    pub histogram_range: f64,
    /// The laser whose scans are used; empty means the robot's first laser.
    pub laser: String,
    /// Radius around a node from which the training scans build its model (conditional and
    /// γ_n), m; 0 means ρ/2. Smaller than ρ on purpose: ρ bounds where the odometry pose
    /// must be for the test to be made, the model radius where the landmark must really be
    /// seen from. A node verified at the rim of ρ leaves the pose off by ρ, and that offset
    /// is carried into the next leg (Table I resets x, y to the node); recognising the node
    /// only near its centre keeps the offsets from adding up from node to node. With
    /// `scan_alignment` the offset is measured instead of inherited, and the model radius
    /// should cover where the robot really arrives (the bundled scenario uses ρ).
    pub model_radius: f64,
    /// Beyond 002: at verification, align the scan with the node's training scan and reset
    /// the pose to the training pose corrected by the measured offset (x, y, θ) — see
    /// [`align`]. When false, or when the alignment is poor, the reset is Table I's
    /// (x, y = x_n, y_n, heading kept).
    pub scan_alignment: bool,
    /// Training runs (the paper's "training run", repeated with this many seeds so that γ_n
    /// and the conditional average over the laser's noise rather than one draw of it).
    pub training_runs: usize,
    /// Heading offsets of the survey around each node, rad: the survey scans are taken at
    /// the leg's heading and at ± this, because a robot arrives with a heading error of a
    /// few degrees and a 180° scan turned by that shifts ranges between histogram bins.
    pub survey_heading: f64,
    /// How γ_n is learnt ([`GammaRule`]).
    pub gamma_rule: GammaRule,
}

/// How [`train`] sets a node's threshold γ_n.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GammaRule {
    /// 002 §IV-B, Fig. 4c: γ falls as the robot approaches the node, and γ_n "verifies whether
    /// a landmark is relatively close": γ_n is the γ the recursion has when the teach run
    /// crosses the ρ circle on its approach (the largest over the teach runs, times
    /// `gamma_margin`). The landmark then fires where the robot truly is about ρ from the
    /// node, whatever its odometry says, so a reset leaves an error of about ρ (Table II)
    /// that does not add up from node to node.
    Rim,
    /// `gamma_margin` × the largest γ seen anywhere within the model radius (teach runs and
    /// the survey, every heading): fires wherever the odometry gate opens. Loose on purpose
    /// for `scan_alignment`, which measures the offset instead of inheriting it; with the
    /// paper's reset it lets the landmark fire 0.4–0.9 m out, and every reset then adds about
    /// −ρ along the leg to the pose error (measured in issue 16).
    Disk,
}

impl Default for LandmarkFilterParams {
    fn default() -> Self {
        Self {
            rho: 0.25,
            warmup_steps: 30,
            observation_weight: 0.8,
            gamma_margin: 1.5,
            histogram_range: 0.0,
            laser: String::new(),
            model_radius: 0.0,
            scan_alignment: true,
            training_runs: 3,
            survey_heading: 0.07,
            gamma_rule: GammaRule::Disk,
        }
    }
}

impl LandmarkFilterParams {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.rho.is_finite() && self.rho > 0.0) {
            return Err(format!(
                "rho: the node radius must be a positive number of metres, got {}",
                self.rho
            ));
        }
        if !(self.observation_weight.is_finite()
            && self.observation_weight > 0.0
            && self.observation_weight <= 1.0)
        {
            return Err(format!(
                "observation_weight: must lie in (0, 1], got {}",
                self.observation_weight
            ));
        }
        if !(self.gamma_margin.is_finite() && self.gamma_margin >= 1.0) {
            return Err(format!(
                "gamma_margin: must be >= 1, got {}",
                self.gamma_margin
            ));
        }
        if !(self.model_radius.is_finite()
            && self.model_radius >= 0.0
            && self.model_radius <= self.rho)
        {
            return Err(format!(
                "model_radius: must lie in [0, rho] (0: rho / 2), got {}",
                self.model_radius
            ));
        }
        if self.training_runs == 0 {
            return Err("training_runs: must be at least 1".into());
        }
        crate::limits::check_count(
            "training_runs",
            self.training_runs,
            crate::limits::MAX_TRAINING_RUNS,
            "MAX_TRAINING_RUNS",
        )?;
        if !(self.survey_heading.is_finite() && (0.0..0.5).contains(&self.survey_heading)) {
            return Err(format!(
                "survey_heading: must lie in [0, 0.5) rad, got {}",
                self.survey_heading
            ));
        }
        if !(self.histogram_range.is_finite() && self.histogram_range >= 0.0) {
            return Err(format!(
                "histogram_range: must be >= 0 (0: the laser's range), got {}",
                self.histogram_range
            ));
        }
        Ok(())
    }

    /// The model radius in metres (`model_radius`, or ρ/2 when 0).
    pub fn model_radius(&self) -> f64 {
        if self.model_radius > 0.0 {
            self.model_radius
        } else {
            0.5 * self.rho
        }
    }

    fn max_range(&self, laser_max: f64) -> f64 {
        if self.histogram_range > 0.0 {
            self.histogram_range
        } else {
            laser_max
        }
    }
}

/// One scan of the training run: the robot's true pose when it was taken, the node the robot
/// was heading for, and the ranges.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainingScan {
    pub pose: Pose2,
    pub target: usize,
    pub ranges: Vec<f64>,
    pub range_max: f64,
    pub geometry: ScanGeometry,
}

/// Where a scan's beams point: what the alignment needs besides the ranges.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanGeometry {
    /// The laser frame in the robot's base frame.
    pub mount: Pose2,
    pub angle_min: f64,
    pub angle_increment: f64,
    pub range_min: f64,
}

impl Default for ScanGeometry {
    /// A 180-beam scan over 180° (002 §III-B) at the base's origin.
    fn default() -> Self {
        Self {
            mount: Pose2::new(0.0, 0.0, 0.0),
            angle_min: -std::f64::consts::FRAC_PI_2,
            angle_increment: std::f64::consts::PI / 179.0,
            range_min: 0.0,
        }
    }
}

impl ScanGeometry {
    pub fn of(scan: &LaserScan) -> ScanGeometry {
        ScanGeometry {
            mount: scan.mount,
            angle_min: scan.angle_min,
            angle_increment: scan.angle_increment,
            range_min: scan.range_min,
        }
    }
}

/// The node's own training scan and the robot pose it was taken from (r_t and x_t of the
/// feature triplet, 002 eq. 5), for [`align`].
#[derive(Debug, Clone, PartialEq)]
pub struct NodeReference {
    pub pose: Pose2,
    pub mount: Pose2,
    pub points: ScanPoints,
}

/// What the training run taught about one node (the feature set of 002 eq. 5 and 7).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NodeModel {
    pub node: [f64; 2],
    /// Conditional p(z_{1:n−1} | x_z): the mean signature of the training scans within the
    /// model radius.
    pub conditional: Histogram,
    /// γ_n: verify when γ falls below this.
    pub gamma_n: f64,
    /// Largest γ within the model radius (teach run after the warm-up, and survey).
    pub gamma_inside_max: f64,
    /// Smallest γ farther than 2ρ from the node after the warm-up, in training (None when the
    /// leg never was): γ_n below it means the landmark alone tells the node apart.
    pub gamma_outside_min: Option<f64>,
    /// Training scans within the model radius (teach run and survey).
    pub scans_inside: usize,
    /// The training scan taken closest to the node, for the alignment at verification.
    #[serde(skip)]
    pub reference: Option<NodeReference>,
}

/// Learns every node's model from a training run (002 §III-A, §IV-B).
///
/// `scans` is the teach run in time order; `survey` holds extra scans taken inside ρ of the
/// nodes (for instance on a small grid around each node at the approach heading), so that
/// the model covers the whole disk a robot may cross and not only the teach run's line.
/// - The conditional: the mean signature of every scan within the model radius
///   ([`LandmarkFilterParams::model_radius`], ρ/2 by default) of the node taken while heading
///   for it (teach run and survey).
/// - γ_n = `gamma_margin` × the largest γ seen within the model radius: replaying the teach
///   run through the recursion exactly as the filter will (reset at each node, warm-up),
///   and, for the survey scans, the γ the recursion settles on at each spot. When that would
///   reach the smallest γ seen farther than 2ρ from the node on the same leg (the landmark
///   would then be "recognised" away from it), γ_n is the geometric mean of the two instead:
///   the threshold halfway, on the log scale γ lives on, between near and far.
/// - The reference for the alignment at verification: the training scan taken closest to the
///   node while heading for it.
pub fn train(
    nodes: &[[f64; 2]],
    scans: &[TrainingScan],
    survey: &[TrainingScan],
    params: &LandmarkFilterParams,
) -> Result<Vec<NodeModel>, LocalizationError> {
    params
        .validate()
        .map_err(LocalizationError::InvalidParameter)?;
    if nodes.is_empty() {
        return Err(LocalizationError::InvalidParameter(
            "route.nodes: the node list is empty".into(),
        ));
    }
    let near = |s: &TrainingScan, n: usize, r: f64| {
        (s.pose.x - nodes[n][0]).hypot(s.pose.y - nodes[n][1]) <= r
    };
    let r_model = params.model_radius();
    let mut models = Vec::with_capacity(nodes.len());
    for (n, node) in nodes.iter().enumerate() {
        let mut sum = [0.0; BINS];
        let mut count = 0;
        for s in scans
            .iter()
            .chain(survey)
            .filter(|s| s.target == n && near(s, n, r_model))
        {
            let h = LandmarkSignature::from_ranges(&s.ranges, params.max_range(s.range_max));
            for (a, b) in sum.iter_mut().zip(h.bins()) {
                *a += b;
            }
            count += 1;
        }
        if count == 0 {
            return Err(LocalizationError::InvalidParameter(format!(
                "training: no scan was taken within the model radius {} m (rho = {} m) of node \
                 {n} ({:?}); the training run did not reach it",
                r_model, params.rho, node
            )));
        }
        let mut model = RecursiveLandmarkModel::new(normalised(sum), params.observation_weight);
        // Replay the scans heading for node n, leg by leg, as the filter will see them.
        let mut inside_max: Option<f64> = None;
        let mut outside_min: Option<f64> = None;
        // γ at the first scan of each approach inside ρ (GammaRule::Rim).
        let mut rim_max: Option<f64> = None;
        let mut rim_seen = false;
        let mut prev_target = usize::MAX;
        for s in scans {
            if s.target != prev_target {
                model.reset();
                prev_target = s.target;
                rim_seen = false;
            }
            if s.target != n {
                continue;
            }
            let h = LandmarkSignature::from_ranges(&s.ranges, params.max_range(s.range_max));
            model.update(h.bins());
            if model.steps() <= params.warmup_steps {
                continue;
            }
            let g = model.gamma();
            if !rim_seen && near(s, n, params.rho) {
                rim_seen = true;
                rim_max = Some(rim_max.map_or(g, |m| m.max(g)));
            }
            if near(s, n, r_model) {
                inside_max = Some(inside_max.map_or(g, |m| m.max(g)));
            } else if !near(s, n, 2.0 * params.rho) {
                outside_min = Some(outside_min.map_or(g, |m| m.min(g)));
            }
        }
        for s in survey
            .iter()
            .filter(|s| s.target == n && near(s, n, r_model))
        {
            let h = LandmarkSignature::from_ranges(&s.ranges, params.max_range(s.range_max));
            let g = model.settled_gamma(h.bins());
            inside_max = Some(inside_max.map_or(g, |m| m.max(g)));
        }
        let inside_max = inside_max.ok_or_else(|| {
            LocalizationError::InvalidParameter(format!(
                "training: the leg to node {n} ({node:?}) reaches the node only within the first \
                 {} scans (warmup_steps); lengthen the leg or lower warmup_steps",
                params.warmup_steps
            ))
        })?;
        let mut gamma_n = params.gamma_margin * inside_max;
        if let Some(out) = outside_min {
            if out > inside_max && inside_max > 0.0 && gamma_n >= out {
                gamma_n = (inside_max * out).sqrt();
            }
        }
        if params.gamma_rule == GammaRule::Rim {
            gamma_n = params.gamma_margin
                * rim_max.ok_or_else(|| {
                    LocalizationError::InvalidParameter(format!(
                        "training: no teach run crossed the rho circle of node {n} ({node:?}) \
                         after the first {} scans (warmup_steps); gamma_rule = \"rim\" needs \
                         one",
                        params.warmup_steps
                    ))
                })?;
        }
        let reference = scans
            .iter()
            .chain(survey)
            .filter(|s| s.target == n)
            .min_by(|a, b| {
                let da = (a.pose.x - node[0]).hypot(a.pose.y - node[1]);
                let db = (b.pose.x - node[0]).hypot(b.pose.y - node[1]);
                da.total_cmp(&db)
            })
            .map(|s| NodeReference {
                pose: s.pose,
                mount: s.geometry.mount,
                points: ScanPoints::from_ranges(
                    &s.ranges,
                    s.geometry.angle_min,
                    s.geometry.angle_increment,
                    s.geometry.range_min,
                    s.range_max,
                ),
            });
        models.push(NodeModel {
            node: *node,
            conditional: *model.conditional(),
            gamma_n,
            gamma_inside_max: inside_max,
            gamma_outside_min: outside_min,
            scans_inside: count,
            reference,
        });
    }
    Ok(models)
}

/// Position standard deviation right after an aligned reset, m: the alignment of two scans of
/// a static scene is good to millimetres in simulation; 5 cm leaves room for a real scene
/// that changed a little since training.
const ALIGNED_SIGMA: f64 = 0.05;

/// What the filter did at a node.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NodeEvent {
    pub node: usize,
    pub stamp: f64,
    /// True: verified by the landmark (Algorithm 1); false: reached by odometry alone.
    pub verified: bool,
    /// γ at that moment (NaN when no scan had been seen on the leg).
    pub gamma: f64,
    /// The filter's pose right after the reset.
    pub pose: Pose2,
    /// Whether the reset came from aligning the scan with the node's training scan (false:
    /// Table I's x, y = x_n, y_n).
    pub aligned: bool,
}

/// Node-based odometry with landmark verification (002 Table I and Algorithm 1) as a
/// [`Localizer`]: the pose is the odometry carried along the node list, and its x, y are set to
/// a node when the node is verified (or, failing that, reached by odometry: Table I update()).
/// Table I resets x and y only; with `scan_alignment` (beyond the paper) a verified node
/// resets x, y and θ to the node's training pose corrected by the scan alignment.
#[derive(Debug, Clone)]
pub struct LandmarkFilter {
    name: String,
    params: LandmarkFilterParams,
    gamma_d: f64,
    models: Vec<NodeModel>,
    recursion: Vec<RecursiveLandmarkModel>,
    pose: Pose2,
    stamp: f64,
    next: usize,
    leg: Option<Leg>,
    gamma: f64,
    /// Distance and rotation since the last node, for the covariance.
    since_node: (f64, f64),
    /// Distance and rotation since the heading was last fixed (the start, or an aligned
    /// reset: Table I's reset leaves the heading to odometry).
    since_heading_fix: (f64, f64),
    /// Position uncertainty right after the last reset, m: ρ for Table I's reset, a few
    /// centimetres for an aligned one.
    fix_sigma: f64,
    pending: Option<usize>,
    events: Vec<NodeEvent>,
}

impl LandmarkFilter {
    /// `gamma_d` must be the node controller's (so the filter and the controller agree on
    /// when odometry reached a node); `start` is the start pose of the route.
    pub fn new(
        name: &str,
        params: LandmarkFilterParams,
        models: Vec<NodeModel>,
        start: Pose2,
        gamma_d: f64,
    ) -> Result<LandmarkFilter, LocalizationError> {
        params
            .validate()
            .map_err(LocalizationError::InvalidParameter)?;
        if models.is_empty() {
            return Err(LocalizationError::InvalidParameter(
                "route.nodes: the node list is empty".into(),
            ));
        }
        if !(gamma_d.is_finite() && gamma_d > 0.0) {
            return Err(LocalizationError::InvalidParameter(format!(
                "gamma_d must be > 0, got {gamma_d}"
            )));
        }
        if !start.is_finite() {
            return Err(LocalizationError::InvalidParameter(format!(
                "start pose must be finite, got {start:?}"
            )));
        }
        let recursion = models
            .iter()
            .map(|m| RecursiveLandmarkModel::new(m.conditional, params.observation_weight))
            .collect();
        let leg = Some(Leg {
            from: [start.x, start.y],
            node: models[0].node,
        });
        Ok(LandmarkFilter {
            name: name.to_owned(),
            fix_sigma: params.rho,
            params,
            gamma_d,
            models,
            recursion,
            pose: start,
            stamp: 0.0,
            next: 0,
            leg,
            gamma: f64::NAN,
            since_node: (0.0, 0.0),
            since_heading_fix: (0.0, 0.0),
            pending: None,
            events: Vec::new(),
        })
    }

    pub fn models(&self) -> &[NodeModel] {
        &self.models
    }

    pub fn events(&self) -> &[NodeEvent] {
        &self.events
    }

    /// Index of the node being approached (the node count when the route is done).
    pub fn next_node(&self) -> usize {
        self.next
    }

    /// γ after the latest scan (NaN before the first scan of a leg).
    pub fn gamma(&self) -> f64 {
        self.gamma
    }

    /// The pose the scan says the robot has, from its alignment with the node's training
    /// scan (None when alignment is off, the node has no reference or the match is poor).
    fn aligned_pose(&self, scan: &LaserScan) -> Option<Pose2> {
        if !self.params.scan_alignment {
            return None;
        }
        let reference = self.models[self.next].reference.as_ref()?;
        let current = ScanPoints::from_ranges(
            &scan.ranges,
            scan.angle_min,
            scan.angle_increment,
            scan.range_min,
            scan.range_max,
        );
        let laser_ref = reference.pose.compose(&reference.mount);
        // Start from where odometry believes the laser is, relative to the reference laser.
        let initial = laser_ref.between(&self.pose.compose(&scan.mount));
        let a = align::align(
            &reference.points,
            &current,
            initial,
            &AlignParams::default(),
        )?;
        let pose = laser_ref
            .compose(&a.transform)
            .compose(&scan.mount.inverse());
        // A match that puts the robot farther than 4ρ from the node is taken for a false one:
        // the landmark was just recognised, so the robot is near the node.
        let node = self.models[self.next].node;
        ((pose.x - node[0]).hypot(pose.y - node[1]) <= 4.0 * self.params.rho).then_some(pose)
    }

    /// Table I update(): x = x_n, y = y_n, next node; with a scan-aligned pose, that pose.
    fn arrive(&mut self, verified: bool, aligned: Option<Pose2>) {
        let node = self.models[self.next].node;
        match aligned {
            Some(p) => self.pose = Pose2::new(p.x, p.y, normalize_angle(p.theta)),
            None => {
                self.pose.x = node[0];
                self.pose.y = node[1];
            }
        }
        self.events.push(NodeEvent {
            node: self.next,
            stamp: self.stamp,
            verified,
            gamma: self.gamma,
            pose: self.pose,
            aligned: aligned.is_some(),
        });
        if verified {
            self.pending = Some(self.next);
        }
        self.since_node = (0.0, 0.0);
        if aligned.is_some() {
            self.since_heading_fix = (0.0, 0.0);
            self.fix_sigma = ALIGNED_SIGMA;
        } else {
            self.fix_sigma = self.params.rho;
        }
        self.recursion[self.next].reset();
        self.next += 1;
        self.gamma = f64::NAN;
        self.leg = self.models.get(self.next).map(|m| Leg {
            from: node,
            node: m.node,
        });
    }
}

impl Localizer for LandmarkFilter {
    fn name(&self) -> &str {
        &self.name
    }

    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError> {
        if !delta.from.is_finite() || !delta.to.is_finite() {
            return Ok(());
        }
        let step = delta.from.between(&delta.to);
        self.pose = self.pose.compose(&step);
        self.since_node.0 += step.x.hypot(step.y);
        self.since_node.1 += normalize_angle(step.theta).abs();
        self.since_heading_fix.0 += step.x.hypot(step.y);
        self.since_heading_fix.1 += normalize_angle(step.theta).abs();
        self.stamp = delta.stamp;
        if let Some(leg) = self.leg {
            if leg.reached(&self.pose, self.gamma_d) {
                self.arrive(false, None);
            }
        }
        Ok(())
    }

    fn update(&mut self, reading: &Reading) -> Result<(), LocalizerError> {
        let Reading::Laser(scan) = reading else {
            return Ok(());
        };
        if !self.params.laser.is_empty() && scan.sensor != self.params.laser {
            return Ok(());
        }
        let Some(leg) = self.leg else {
            return Ok(());
        };
        self.stamp = scan.stamp;
        let h = LandmarkSignature::from_ranges(&scan.ranges, self.params.max_range(scan.range_max));
        let model = &mut self.recursion[self.next];
        model.update(h.bins());
        self.gamma = model.gamma();
        // Algorithm 1 line 12: the node is within ρ of the pose, and γ < γ_n — once the first
        // noisy steps are over (§IV-B).
        if model.steps() > self.params.warmup_steps
            && leg.current(&self.pose) <= self.params.rho
            && self.gamma < self.models[self.next].gamma_n
        {
            let aligned = self.aligned_pose(scan);
            self.arrive(true, aligned);
        }
        Ok(())
    }

    /// Covariance: Table I's reset fixes the position to within ρ (the verification radius)
    /// and leaves the heading to odometry; an aligned reset fixes both to within
    /// [`ALIGNED_SIGMA`] and a negligible angle. Odometry drift then grows with the distance
    /// and rotation since (the same rates as [`crate::DriftModel`]'s defaults).
    fn estimate(&self) -> Estimate {
        let d = crate::DriftModel::default();
        let s_xy = self.fix_sigma + d.k_d * self.since_node.0;
        let s_th = d.k_theta * self.since_heading_fix.0 + d.k_r * self.since_heading_fix.1;
        Estimate {
            stamp: self.stamp,
            pose: self.pose,
            covariance: Matrix3::from_diagonal(&Vector3::new(
                s_xy * s_xy,
                s_xy * s_xy,
                s_th * s_th,
            )),
        }
    }

    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        Some(self)
    }
}

impl Capabilities for LandmarkFilter {
    fn take_node_verification(&mut self) -> Option<usize> {
        self.pending.take()
    }

    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}

#[cfg(test)]
mod tests;
