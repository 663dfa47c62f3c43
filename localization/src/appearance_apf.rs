//! Appearance-based localization with the auxiliary particle filter that Porta, Verbeek and
//! Kröse use ([000] §VI, last paragraph: "the particle filter we use
//! [7], [10]" — Pitt and Shephard's auxiliary particle filter as Vlassis, Terwijn and Kröse
//! apply it to the nearest-neighbour sensor model).
//!
//! The sensor model of eq. 2 is a mixture over training poses, p(y | x) = Σ_j λ_j φ(x | x_j),
//! with φ Gaussian; the §VI fusion w_d p(y_d | x) + w_i p(y_i | x) is again such a mixture.
//! Because it is a Gaussian mixture *in pose space*, the filter can be fully adapted (Pitt and
//! Shephard §3.2): with the odometry prediction of particle i linearised as a Gaussian
//! N(x; m_i, Q), the posterior over (x_t, i, j) is
//!
//!   p(x_t, i, j | y_1..t) ∝ w_i λ_j N(x_j; m_i, Q + R) · N(x_t; μ_ij, S),
//!   S = (Q⁻¹ + R⁻¹)⁻¹,  μ_ij = S (Q⁻¹ m_i + R⁻¹ x_j),  R the covariance of φ.
//!
//! So one step draws the auxiliary variable k = (i, j) — a particle and a mixture component,
//! i.e. a training pose the sensor model proposes — with probability ∝ w_i λ_j N(x_j; m_i, Q+R)
//! (the motion model reweighting the sensor's proposals), then the new particle from
//! N(μ_ij, S): near that training pose, pulled towards where odometry says the particle went.
//! The new particles carry equal weights.
//!
//! Illumination changes make the sensor model propose wrong training poses (000 §II); with
//! nothing near the particles every N(x_j; m_i, Q + R) vanishes. The mixture therefore gets
//! one more component, an outlier ε spread uniformly over the map's area: its product with the
//! motion model is the motion model itself, so a particle with no plausible proposal simply
//! follows odometry instead of jumping to a wrong place.

use crate::appearance::{fuse, AppearanceMap, Component, PoseKernel};
use crate::cluster::PointEstimate;
use crate::em_pca::{EmPca, EmPcaParams, ProjectionScratch};
use crate::error::LocalizationError;
use crate::limits::check_positive;
use crate::localizer::OdometryDelta;
use crate::mcl::InitialBelief;
use crate::motion::OdometryMotionModel;
use crate::particle_filter::{core_in_field, FilterCore, ParticleFilter};
use crate::particles::{ReadingCounts, ReadingTally};
use crate::pca::{Pca, PcaMethod};
use crate::resampling::low_variance_indices;
use atrium_robots::{normalize_angle, DisparityImage, IntensityImage, Pose2, Reading};
use rand::seq::index::sample;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// How an appearance model is trained (000 §VII: N = 100 images chosen at random give the
/// d = 20 principal components; every training image is then projected).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AppearanceTraining {
    /// Number of principal components d. Default 20.
    pub d: usize,
    /// Training images (chosen at random) the components are computed from, N. Default 100.
    pub pca_samples: usize,
    /// Seed of that choice and of EM-PCA's initialisation.
    pub seed: u64,
}

impl Default for AppearanceTraining {
    fn default() -> Self {
        Self {
            d: 20,
            pca_samples: 100,
            seed: 0,
        }
    }
}

/// Intensity features: PCA (000 eq. 1) and the training map of projected images.
#[derive(Debug, Clone, PartialEq)]
pub struct IntensityFeatures {
    pub pca: Pca,
    pub map: AppearanceMap,
    pub width: usize,
    pub height: usize,
}

/// Disparity features: EM-PCA with missing values (000 §V) and the training map.
#[derive(Debug, Clone, PartialEq)]
pub struct DisparityFeatures {
    pub em: EmPca,
    pub map: AppearanceMap,
    pub width: usize,
    pub height: usize,
}

/// An appearance map: training poses with the features of their intensity images and,
/// optionally, of their sparse disparity maps.
#[derive(Debug, Clone, PartialEq)]
pub struct AppearanceModel {
    pub intensity: IntensityFeatures,
    pub disparity: Option<DisparityFeatures>,
}

fn size_error(what: &str, i: usize, got: usize, w: usize, h: usize) -> LocalizationError {
    LocalizationError::InvalidParameter(format!(
        "{what} {i} has {got} pixels, expected {w} × {h} = {}",
        w * h
    ))
}

impl AppearanceModel {
    /// Trains the model from images taken at `poses` (000 §II, §V, §VII). `intensity[k]` and
    /// `disparity[k]` (NaN = missing) were taken at `poses[k]`, all `width × height`.
    /// A disparity map with nothing matched gets zero features (it sits at the mean).
    pub fn train(
        poses: &[Pose2],
        width: usize,
        height: usize,
        intensity: &[&[f32]],
        disparity: Option<&[&[f32]]>,
        params: AppearanceTraining,
    ) -> Result<AppearanceModel, LocalizationError> {
        let n = poses.len();
        if n == 0 {
            return Err(LocalizationError::InvalidParameter(
                "appearance training: the training set is empty".into(),
            ));
        }
        if width == 0 || height == 0 {
            return Err(LocalizationError::InvalidParameter(format!(
                "appearance training: image size must be positive, got {width} × {height}"
            )));
        }
        if intensity.len() != n {
            return Err(LocalizationError::InvalidParameter(format!(
                "appearance training: {n} poses but {} intensity images",
                intensity.len()
            )));
        }
        let dim = width * height;
        for (i, img) in intensity.iter().enumerate() {
            if img.len() != dim {
                return Err(size_error(
                    "appearance training: intensity image",
                    i,
                    img.len(),
                    width,
                    height,
                ));
            }
            if let Some(p) = img.iter().position(|v| !v.is_finite()) {
                return Err(LocalizationError::InvalidParameter(format!(
                    "appearance training: intensity image {i} has a non-finite pixel at index {p}"
                )));
            }
        }
        if let Some(disp) = disparity {
            if disp.len() != n {
                return Err(LocalizationError::InvalidParameter(format!(
                    "appearance training: {n} poses but {} disparity maps",
                    disp.len()
                )));
            }
            for (i, m) in disp.iter().enumerate() {
                if m.len() != dim {
                    return Err(size_error(
                        "appearance training: disparity map",
                        i,
                        m.len(),
                        width,
                        height,
                    ));
                }
            }
        }
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
        let chosen = sample(&mut rng, n, params.pca_samples.min(n)).into_vec();
        let pick: Vec<&[f32]> = chosen.iter().map(|&i| intensity[i]).collect();
        let pca = Pca::fit(&pick, params.d, PcaMethod::Snapshot)?;
        let feats = intensity
            .iter()
            .map(|img| pca.project(img))
            .collect::<Result<Vec<_>, _>>()?;
        let imap = AppearanceMap::new(poses.to_vec(), feats)?;
        let disparity = match disparity {
            None => None,
            Some(disp) => {
                // Only maps with something observed can train EM-PCA.
                let pick: Vec<&[f32]> = chosen
                    .iter()
                    .map(|&i| disp[i])
                    .filter(|m| m.iter().any(|v| !v.is_nan()))
                    .collect();
                let em = EmPca::fit(
                    &pick,
                    params.d,
                    EmPcaParams {
                        seed: params.seed,
                        ..Default::default()
                    },
                )?;
                let mut scratch = ProjectionScratch::new(params.d);
                let mut feats = Vec::with_capacity(n);
                for m in disp {
                    let mut y = vec![0.0; params.d];
                    if m.iter().any(|v| !v.is_nan()) {
                        em.project_into(m, &mut scratch, &mut y)?;
                    }
                    feats.push(y);
                }
                Some(DisparityFeatures {
                    em,
                    map: AppearanceMap::new(poses.to_vec(), feats)?,
                    width,
                    height,
                })
            }
        };
        Ok(AppearanceModel {
            intensity: IntensityFeatures {
                pca,
                map: imap,
                width,
                height,
            },
            disparity,
        })
    }

    /// A model from its parts (kept from an earlier [`AppearanceModel::train`]), refused
    /// unless they fit together: each subspace of `width × height` pixels with as many
    /// components as its map has features, and one disparity entry per training pose.
    pub fn from_parts(
        intensity: IntensityFeatures,
        disparity: Option<DisparityFeatures>,
    ) -> Result<AppearanceModel, LocalizationError> {
        let check = |what: &str, dim: usize, d: usize, map: &AppearanceMap, w: usize, h: usize| {
            if w.checked_mul(h) != Some(dim) || d != map.d() {
                return Err(LocalizationError::InvalidParameter(format!(
                    "appearance model: {what} features of {dim} pixels and {d} components do \
                     not fit {w} × {h} images and a map of {} features",
                    map.d()
                )));
            }
            Ok(())
        };
        let i = &intensity;
        check(
            "intensity",
            i.pca.dim(),
            i.pca.d(),
            &i.map,
            i.width,
            i.height,
        )?;
        if let Some(dp) = &disparity {
            check(
                "disparity",
                dp.em.dim(),
                dp.em.d(),
                &dp.map,
                dp.width,
                dp.height,
            )?;
            if dp.map.len() != i.map.len() {
                return Err(LocalizationError::InvalidParameter(format!(
                    "appearance model: {} disparity entries for {} training poses",
                    dp.map.len(),
                    i.map.len()
                )));
            }
        }
        Ok(AppearanceModel {
            intensity,
            disparity,
        })
    }

    /// Bounding box (x0, y0, x1, y1) of the training positions.
    pub fn extent(&self) -> [f64; 4] {
        let m = &self.intensity.map;
        let mut b = [
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ];
        for i in 0..m.len() {
            let p = m.pose(i);
            b = [b[0].min(p.x), b[1].min(p.y), b[2].max(p.x), b[3].max(p.y)];
        }
        b
    }
}

/// Parameters of [`AppearanceApf`], as written in a scenario. Every field has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ApfParams {
    /// Particles. Default 500.
    pub particles: usize,
    /// J of eq. 2 when only intensity is used (000 §VII: 10). Default 10.
    pub j_intensity: usize,
    /// J per sensor when intensity and disparity are fused (000 §VII: 5 + 5). Default 5.
    pub j_each: usize,
    /// w_d of §VI (w_i = 1 − w_d). Default 0.5 ("equally reliable").
    pub w_d: f64,
    /// φ of eq. 2: standard deviation in x and y, m. Default 0.25 (half the 50 cm grid).
    pub sigma_xy: f64,
    /// φ of eq. 2: standard deviation of heading, degrees. Default 10 (the rotation step).
    pub sigma_theta_deg: f64,
    /// Odometry motion model α1–α4 (Thrun et al. Table 5.6). Default 0.05 each.
    pub alpha: [f64; 4],
    /// Floor of the motion noise per update, m and degrees: odometry is never exact.
    /// Default 0.02 m, 2°.
    pub min_motion_sd_xy: f64,
    pub min_motion_sd_theta_deg: f64,
    /// Outlier probability ε of the sensor model (uniform over the map). Default 0.05.
    pub outlier: f64,
    /// Only intensity images of this sensor are used (None: every intensity reading).
    pub intensity_sensor: Option<String>,
    /// Only disparity maps of this sensor are used (None: every disparity reading).
    pub disparity_sensor: Option<String>,
}

impl Default for ApfParams {
    fn default() -> Self {
        Self {
            particles: 500,
            j_intensity: 10,
            j_each: 5,
            w_d: 0.5,
            sigma_xy: 0.25,
            sigma_theta_deg: 10.0,
            alpha: [0.05; 4],
            min_motion_sd_xy: 0.02,
            min_motion_sd_theta_deg: 2.0,
            outlier: 0.05,
            intensity_sensor: None,
            disparity_sensor: None,
        }
    }
}

impl ApfParams {
    /// Checks every field; the message names it.
    pub fn validate(&self) -> Result<(), String> {
        use crate::limits::{check_count_min1, APF_MAX_J, APF_MAX_PARTICLES};
        check_count_min1(
            "particles",
            self.particles,
            APF_MAX_PARTICLES,
            "APF_MAX_PARTICLES",
        )?;
        check_count_min1("j_intensity", self.j_intensity, APF_MAX_J, "APF_MAX_J")?;
        check_count_min1("j_each", self.j_each, APF_MAX_J, "APF_MAX_J")?;
        if !(self.w_d.is_finite() && (0.0..=1.0).contains(&self.w_d)) {
            return Err(format!("w_d must be within [0, 1], got {}", self.w_d));
        }
        for (name, v) in [
            ("sigma_xy", self.sigma_xy),
            ("sigma_theta_deg", self.sigma_theta_deg),
            ("min_motion_sd_xy", self.min_motion_sd_xy),
            ("min_motion_sd_theta_deg", self.min_motion_sd_theta_deg),
        ] {
            check_positive(name, v)?;
        }
        crate::motion::validate_alpha(&self.alpha)?;
        if !(self.outlier > 0.0 && self.outlier < 1.0) {
            return Err(format!(
                "outlier must be within (0, 1), got {}",
                self.outlier
            ));
        }
        Ok(())
    }
}

/// An observation waiting for its partner of the same stereo frame (§VI fuses the intensity
/// and disparity models of one frame; they arrive as two readings).
#[derive(Debug, Clone)]
struct Pending {
    stamp: f64,
    components: Vec<Component>,
    full: bool,
}

impl Pending {
    fn new(cap: usize) -> Self {
        Self {
            stamp: f64::NEG_INFINITY,
            components: Vec::with_capacity(cap),
            full: false,
        }
    }
}

/// The auxiliary particle filter on an [`AppearanceModel`] (000 §VI).
#[derive(Clone)]
pub struct AppearanceApf {
    core: FilterCore,
    params: ApfParams,
    model: Arc<AppearanceModel>,
    kernel: PoseKernel,
    motion: OdometryMotionModel,
    /// log of the outlier component's density: ε / (area · 2π).
    log_outlier: f64,
    /// Weights of the auxiliary pairs (particle, component or outlier), M × (K + 1).
    pair_w: Vec<f64>,
    features: Vec<f64>,
    scratch: ProjectionScratch,
    intensity: Pending,
    disparity: Pending,
    fused: Vec<Component>,
    last_model: Vec<Component>,
    tally: ReadingTally,
}

impl ReadingCounts for AppearanceApf {
    fn tally(&self) -> &ReadingTally {
        &self.tally
    }
}

impl AppearanceApf {
    /// A filter on `model` starting from `init` (a global belief is uniform over the bounding
    /// box of the training positions, or over the given polygons).
    pub fn new(
        name: &str,
        params: ApfParams,
        model: Arc<AppearanceModel>,
        init: &InitialBelief,
        seed: u64,
    ) -> Result<AppearanceApf, LocalizationError> {
        params
            .validate()
            .map_err(|e| LocalizationError::InvalidParameter(format!("appearance apf: {e}")))?;
        let m = params.particles;
        let k_max = params.j_intensity.max(2 * params.j_each);
        let d = model.intensity.pca.d();
        let [x0, y0, x1, y1] = model.extent();
        let area = ((x1 - x0).max(0.0) + 2.0 * params.sigma_xy)
            * ((y1 - y0).max(0.0) + 2.0 * params.sigma_xy);
        let mut f = AppearanceApf {
            core: FilterCore::new(name, m, seed),
            kernel: PoseKernel {
                sigma_xy: params.sigma_xy,
                sigma_theta: params.sigma_theta_deg.to_radians(),
            },
            motion: OdometryMotionModel::new(params.alpha),
            log_outlier: params.outlier.ln() - (area * 2.0 * std::f64::consts::PI).ln(),
            pair_w: vec![0.0; m * (k_max + 1)],
            features: vec![0.0; d],
            scratch: ProjectionScratch::new(d),
            intensity: Pending::new(k_max),
            disparity: Pending::new(k_max),
            fused: Vec::with_capacity(k_max),
            last_model: Vec::with_capacity(k_max),
            tally: ReadingTally::default(),
            model,
            params,
        };
        f.core
            .start(m, init, [x0, y0, x1, y1], PointEstimate::WeightedMean)?;
        Ok(f)
    }

    pub fn model(&self) -> &AppearanceModel {
        &self.model
    }

    /// The sensor model (eq. 2, fused as §VI when disparity was used) of the last update, for
    /// the sensor-model error of 000 §VII.
    pub fn last_sensor_model(&self) -> &[Component] {
        &self.last_model
    }

    /// The nearest-neighbour components an intensity image proposes (eq. 2, J of them).
    pub fn intensity_model(
        &mut self,
        image: &IntensityImage,
        j: usize,
        out: &mut Vec<Component>,
    ) -> Result<(), LocalizationError> {
        let f = &self.model.intensity;
        if image.width != f.width
            || image.height != f.height
            || image.pixels.len() != f.width * f.height
        {
            return Err(LocalizationError::InvalidParameter(format!(
                "appearance apf: intensity image from `{}` is {} × {} ({} pixels), the map was trained on {} × {}",
                image.sensor,
                image.width,
                image.height,
                image.pixels.len(),
                f.width,
                f.height
            )));
        }
        f.pca.project_into(&image.pixels, &mut self.features)?;
        f.map.sensor_model(&self.features, j, out)
    }

    /// The components a disparity map proposes; `Ok(false)` when the map has no disparity
    /// features or the disparity map has nothing matched (no information, not an error).
    pub fn disparity_model(
        &mut self,
        map: &DisparityImage,
        j: usize,
        out: &mut Vec<Component>,
    ) -> Result<bool, LocalizationError> {
        let Some(f) = &self.model.disparity else {
            return Ok(false);
        };
        if map.width != f.width
            || map.height != f.height
            || map.disparity.len() != f.width * f.height
        {
            return Err(LocalizationError::InvalidParameter(format!(
                "appearance apf: disparity map from `{}` is {} × {} ({} values), the map was trained on {} × {}",
                map.sensor,
                map.width,
                map.height,
                map.disparity.len(),
                f.width,
                f.height
            )));
        }
        if map.disparity.iter().all(|v| v.is_nan()) {
            return Ok(false);
        }
        f.em.project_into(&map.disparity, &mut self.scratch, &mut self.features)?;
        f.map.sensor_model(&self.features, j, out)?;
        Ok(true)
    }

    /// One auxiliary-particle-filter step with the mixture sensor model `components`
    /// (weights λ summing to one), after the odometry received since the last step.
    pub fn step(&mut self, components: &[Component]) {
        let m = self.core.set.len();
        let k = components.len();
        // Odometry as a Gaussian N(m_i, Q): the noiseless composition and the variance
        // Table 5.6's α give to this increment, plus a floor.
        let p = std::mem::take(&mut self.core.carry.pending);
        let inc = self.motion.decompose(&Pose2::default(), &p);
        let q_xy = inc.sd_trans.powi(2)
            + (inc.trans * inc.sd_rot1).powi(2)
            + self.params.min_motion_sd_xy.powi(2);
        let q_th = inc.sd_rot1.powi(2)
            + inc.sd_rot2.powi(2)
            + self.params.min_motion_sd_theta_deg.to_radians().powi(2);
        for i in 0..m {
            let mi = self.core.set.pose(i).compose(&p);
            self.core.set.set_pose(i, mi);
        }
        let r_xy = self.kernel.sigma_xy.powi(2);
        let r_th = self.kernel.sigma_theta.powi(2);
        let (v_xy, v_th) = (q_xy + r_xy, q_th + r_th);
        let log_norm = -(2.0 * std::f64::consts::PI).ln() * 1.5 - v_xy.ln() - 0.5 * v_th.ln();
        let log_in = (1.0 - self.params.outlier).ln();
        let stride = k + 1;
        if self.pair_w.len() < m * stride {
            // Only a caller's own mixture larger than the J's the filter was built for.
            self.pair_w.resize(m * stride, 0.0);
        }
        let pairs = &mut self.pair_w[..m * stride];
        let mut max = f64::NEG_INFINITY;
        for i in 0..m {
            let lw = self.core.set.weights()[i].ln();
            let mi = self.core.set.pose(i);
            let row = &mut pairs[i * stride..(i + 1) * stride];
            for (slot, c) in row.iter_mut().zip(components) {
                let dx = c.pose.x - mi.x;
                let dy = c.pose.y - mi.y;
                let dt = normalize_angle(c.pose.theta - mi.theta);
                let l = lw + log_in + c.weight.max(1e-300).ln() + log_norm
                    - 0.5 * ((dx * dx + dy * dy) / v_xy + dt * dt / v_th);
                *slot = l;
                max = max.max(l);
            }
            // The outlier component: uniform density times the motion model, integrated.
            row[k] = lw + self.log_outlier;
            max = max.max(row[k]);
        }
        for v in pairs.iter_mut() {
            *v = (*v - max).exp();
        }
        if !low_variance_indices(
            pairs,
            &mut self.core.set.indices_mut()[..m],
            &mut self.core.rng,
        ) {
            // Cannot happen with the outlier term; keep the prediction if it does.
            self.core.set.make_uniform(m);
            self.core.refresh_estimate(PointEstimate::WeightedMean);
            return;
        }
        // Product of the two Gaussians: S = (Q⁻¹ + R⁻¹)⁻¹, μ = m + S R⁻¹ (x_j − m).
        let s_xy = 1.0 / (1.0 / q_xy + 1.0 / r_xy);
        let s_th = 1.0 / (1.0 / q_th + 1.0 / r_th);
        self.core
            .set
            .rebuild(m, &mut self.core.rng, |flat, src, rng| {
                let (i, j) = (flat / stride, flat % stride);
                let [mx, my, mt] = src.get(i);
                let (cx, cy, ct, sxy, sth) = if j < k {
                    let c = &components[j].pose;
                    let gx = s_xy / r_xy;
                    let gt = s_th / r_th;
                    (
                        mx + gx * (c.x - mx),
                        my + gx * (c.y - my),
                        mt + gt * normalize_angle(c.theta - mt),
                        s_xy.sqrt(),
                        s_th.sqrt(),
                    )
                } else {
                    (mx, my, mt, q_xy.sqrt(), q_th.sqrt())
                };
                let mut g = || -> f64 { StandardNormal.sample(rng) };
                [
                    cx + sxy * g(),
                    cy + sxy * g(),
                    normalize_angle(ct + sth * g()),
                ]
            });
        self.last_model.clear();
        self.last_model.extend_from_slice(components);
        self.tally.updates += 1;
        self.core.refresh_estimate(PointEstimate::WeightedMean);
    }

    /// Runs the step of an observation left waiting for its stereo partner, alone. A member
    /// of fusion weight 0 is no part of the sensor model, so it never steps alone either.
    fn flush_older_than(&mut self, stamp: f64) {
        if self.intensity.full && self.intensity.stamp < stamp {
            self.intensity.full = false;
            if self.params.w_d < 1.0 {
                let comps = std::mem::take(&mut self.intensity.components);
                self.step(&comps);
                self.intensity.components = comps;
            }
        }
        if self.disparity.full && self.disparity.stamp < stamp {
            self.disparity.full = false;
            if self.params.w_d > 0.0 {
                let comps = std::mem::take(&mut self.disparity.components);
                self.step(&comps);
                self.disparity.components = comps;
            }
        }
    }

    /// Takes one frame's components for one sensor; fuses with the partner when both are
    /// there (§VI), steps alone when the map has no disparity.
    fn observe(&mut self, stamp: f64, is_disparity: bool) {
        if self.model.disparity.is_none() {
            let comps = std::mem::take(&mut self.intensity.components);
            self.step(&comps);
            self.intensity.components = comps;
            return;
        }
        let (mine, other) = if is_disparity {
            (&mut self.disparity, &mut self.intensity)
        } else {
            (&mut self.intensity, &mut self.disparity)
        };
        mine.stamp = stamp;
        mine.full = true;
        if other.full && other.stamp == stamp {
            let mut fused = std::mem::take(&mut self.fused);
            // w_d was validated in [0, 1]: fuse cannot fail.
            let _ = fuse(
                &self.disparity.components,
                &self.intensity.components,
                self.params.w_d,
                &mut fused,
            );
            self.intensity.full = false;
            self.disparity.full = false;
            self.step(&fused);
            self.fused = fused;
        }
    }
}

fn sensor_matches(wanted: &Option<String>, got: &str) -> bool {
    wanted.as_deref().is_none_or(|w| w == got)
}

impl ParticleFilter for AppearanceApf {
    core_in_field!();

    /// Time moved past a frame whose partner never came: use it alone.
    fn before_odometry(&mut self, delta: &OdometryDelta) {
        self.flush_older_than(delta.stamp);
    }

    /// Intensity images (and disparity maps when the map has disparity features) of the
    /// configured sensors; a bad image is counted in [`ReadingCounts::rejected`], never a panic.
    fn take_reading(&mut self, reading: &Reading) {
        match reading {
            Reading::Intensity(img)
                if sensor_matches(&self.params.intensity_sensor, &img.sensor) =>
            {
                self.flush_older_than(img.stamp);
                let j = if self.model.disparity.is_some() {
                    self.params.j_each
                } else {
                    self.params.j_intensity
                };
                let mut comps = std::mem::take(&mut self.intensity.components);
                let r = self.intensity_model(img, j, &mut comps);
                self.intensity.components = comps;
                match r {
                    Ok(()) => {
                        self.core.carry.observed_at(img.stamp);
                        self.observe(img.stamp, false);
                    }
                    Err(e) => self.tally.record(e),
                }
            }
            Reading::Disparity(map)
                if self.model.disparity.is_some()
                    && sensor_matches(&self.params.disparity_sensor, &map.sensor) =>
            {
                self.flush_older_than(map.stamp);
                let mut comps = std::mem::take(&mut self.disparity.components);
                let r = self.disparity_model(map, self.params.j_each, &mut comps);
                self.disparity.components = comps;
                match r {
                    Ok(true) => {
                        self.core.carry.observed_at(map.stamp);
                        self.observe(map.stamp, true);
                    }
                    Ok(false) => {}
                    Err(e) => self.tally.record(e),
                }
            }
            _ => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::localizer::Localizer;
    use atrium_robots::Mount3;

    /// A synthetic world for the filter: the "image" at pose p is a smooth function of
    /// (x, y, θ) (8 × 4 pixels), so nearest neighbours in feature space are nearest in pose.
    fn render(p: &Pose2) -> Vec<f32> {
        (0..32)
            .map(|k| {
                let a = k as f64 * 0.7;
                let v = (p.x * a.cos() + p.y * a.sin() + 1.3 * (p.theta + a).cos()) * 0.8;
                (0.5 + 0.4 * v.sin()) as f32
            })
            .collect()
    }

    fn grid_model() -> AppearanceModel {
        let mut poses = Vec::new();
        for i in 0..9 {
            for j in 0..5 {
                for r in 0..12 {
                    poses.push(Pose2::new(
                        i as f64 * 0.5,
                        j as f64 * 0.5,
                        normalize_angle(r as f64 * 30f64.to_radians()),
                    ));
                }
            }
        }
        let imgs: Vec<Vec<f32>> = poses.iter().map(render).collect();
        let refs: Vec<&[f32]> = imgs.iter().map(|v| v.as_slice()).collect();
        AppearanceModel::train(
            &poses,
            8,
            4,
            &refs,
            None,
            AppearanceTraining {
                d: 12,
                pca_samples: 200,
                seed: 1,
            },
        )
        .unwrap()
    }

    fn image(p: &Pose2, stamp: f64) -> Reading {
        Reading::Intensity(IntensityImage {
            stamp,
            sensor: "cam".into(),
            mount: Mount3::default(),
            width: 8,
            height: 4,
            fx: 1.0,
            fy: 1.0,
            cx: 0.0,
            cy: 0.0,
            pixels: render(p),
        })
    }

    #[test]
    fn tracks_a_synthetic_path_from_a_global_belief() {
        let model = Arc::new(grid_model());
        let mut f = AppearanceApf::new(
            "apf",
            ApfParams {
                sigma_theta_deg: 20.0,
                ..Default::default()
            },
            model,
            &InitialBelief::Global { regions: vec![] },
            3,
        )
        .unwrap();
        let mut truth = Pose2::new(0.6, 0.4, 0.3);
        let mut odo = Pose2::new(10.0, -3.0, 1.0);
        let mut errs = Vec::new();
        for t in 0..40 {
            let step = Pose2::new(0.08, 0.0, if (t / 10) % 2 == 0 { 0.05 } else { -0.05 });
            truth = truth.compose(&step);
            let next = odo.compose(&step);
            f.predict(&OdometryDelta {
                stamp: t as f64,
                from: odo,
                to: next,
            })
            .unwrap();
            odo = next;
            f.update(&image(&truth, t as f64)).unwrap();
            errs.push(f.estimate().pose.distance(&truth));
        }
        assert_eq!(f.updates(), 40);
        // Converged within a few steps, then within the 0.5 m grid's resolution.
        let tail = &errs[5..];
        let worst = tail.iter().cloned().fold(0.0, f64::max);
        let mean = tail.iter().sum::<f64>() / tail.len() as f64;
        assert!(worst < 0.5 && mean < 0.35, "errors {errs:?}");
        assert!(f.last_sensor_model().len() == 10);
    }

    #[test]
    fn outlier_component_keeps_odometry_when_the_sensor_lies() {
        let model = Arc::new(grid_model());
        let start = Pose2::new(1.0, 1.0, 0.0);
        let mut f = AppearanceApf::new(
            "apf",
            ApfParams::default(),
            model,
            &InitialBelief::Tracking {
                pose: start,
                sigma: [0.05, 0.05, 0.02],
            },
            5,
        )
        .unwrap();
        // The image of a far place (as under a different light): the proposals are all
        // far from every particle, so the filter follows odometry.
        f.predict(&OdometryDelta {
            stamp: 1.0,
            from: Pose2::default(),
            to: Pose2::new(0.2, 0.0, 0.0),
        })
        .unwrap();
        f.update(&image(&Pose2::new(3.5, 2.0, 2.5), 1.0)).unwrap();
        let e = f.estimate().pose;
        assert!(e.distance(&Pose2::new(1.2, 1.0, 0.0)) < 0.1, "{e:?}");
    }

    #[test]
    fn bad_images_are_rejected_not_panicked_on() {
        let model = Arc::new(grid_model());
        let mut f = AppearanceApf::new(
            "apf",
            ApfParams::default(),
            model.clone(),
            &InitialBelief::Global { regions: vec![] },
            1,
        )
        .unwrap();
        let Reading::Intensity(mut img) = image(&Pose2::default(), 1.0) else {
            unreachable!()
        };
        img.pixels.pop();
        f.update(&Reading::Intensity(img.clone())).unwrap();
        assert_eq!(f.rejected(), 1);
        assert!(f.last_error().unwrap().to_string().contains("8 × 4"));
        img.pixels.push(f32::NAN);
        f.update(&Reading::Intensity(img)).unwrap();
        assert_eq!(f.rejected(), 2);
        assert!(f.last_error().unwrap().to_string().contains("non-finite"));
        assert_eq!(f.updates(), 0);
        // Bad parameters and an empty training set.
        let e = AppearanceApf::new(
            "apf",
            ApfParams {
                w_d: 2.0,
                ..Default::default()
            },
            model,
            &InitialBelief::Global { regions: vec![] },
            1,
        )
        .err()
        .unwrap();
        assert!(e.to_string().contains("w_d"), "{e}");
        let e = AppearanceModel::train(&[], 8, 4, &[], None, AppearanceTraining::default())
            .unwrap_err();
        assert!(e.to_string().contains("empty"), "{e}");
        let a = vec![0.5f32; 31];
        let e = AppearanceModel::train(
            &[Pose2::default()],
            8,
            4,
            &[&a],
            None,
            AppearanceTraining::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("image 0 has 31 pixels"), "{e}");
    }

    #[test]
    fn stereo_partners_are_fused_and_lonely_frames_flushed() {
        let mut poses = Vec::new();
        for i in 0..6 {
            for r in 0..8 {
                poses.push(Pose2::new(i as f64 * 0.5, 0.0, r as f64 * 0.78));
            }
        }
        let imgs: Vec<Vec<f32>> = poses.iter().map(render).collect();
        // "Disparity": the image with every third pixel missing.
        let disp: Vec<Vec<f32>> = imgs
            .iter()
            .map(|v| {
                v.iter()
                    .enumerate()
                    .map(|(k, x)| if k % 3 == 0 { f32::NAN } else { *x })
                    .collect()
            })
            .collect();
        let ri: Vec<&[f32]> = imgs.iter().map(|v| v.as_slice()).collect();
        let rd: Vec<&[f32]> = disp.iter().map(|v| v.as_slice()).collect();
        let model = AppearanceModel::train(
            &poses,
            8,
            4,
            &ri,
            Some(&rd),
            AppearanceTraining {
                d: 6,
                pca_samples: 40,
                seed: 2,
            },
        )
        .unwrap();
        let mut f = AppearanceApf::new(
            "apf",
            ApfParams::default(),
            Arc::new(model),
            &InitialBelief::Global { regions: vec![] },
            1,
        )
        .unwrap();
        let p = poses[17];
        f.update(&image(&p, 2.0)).unwrap();
        assert_eq!(f.updates(), 0, "waits for the disparity of the same frame");
        f.update(&Reading::Disparity(DisparityImage {
            stamp: 2.0,
            sensor: "stereo".into(),
            width: 8,
            height: 4,
            fx: 1.0,
            baseline: 0.1,
            disparity: disp[17].clone(),
        }))
        .unwrap();
        assert_eq!(f.updates(), 1);
        assert_eq!(f.last_sensor_model().len(), 10, "5 + 5 components");
        // An intensity image alone is used once time moves on.
        f.update(&image(&p, 3.0)).unwrap();
        assert_eq!(f.updates(), 1);
        f.predict(&OdometryDelta {
            stamp: 3.1,
            from: Pose2::default(),
            to: Pose2::default(),
        })
        .unwrap();
        assert_eq!(f.updates(), 2);
        assert_eq!(f.last_sensor_model().len(), 5);
    }

    #[test]
    fn counts_above_their_limits_name_field_and_limit() {
        use crate::limits::{APF_MAX_J, APF_MAX_PARTICLES};
        let p = |particles: usize, j: usize| ApfParams {
            particles,
            j_intensity: j,
            ..ApfParams::default()
        };
        assert!(p(APF_MAX_PARTICLES, APF_MAX_J).validate().is_ok());
        assert_eq!(
            p(APF_MAX_PARTICLES + 1, 10).validate().unwrap_err(),
            "particles: 200001 is more than the limit of 200000 (APF_MAX_PARTICLES)"
        );
        assert_eq!(
            p(500, APF_MAX_J + 1).validate().unwrap_err(),
            "j_intensity: 1001 is more than the limit of 1000 (APF_MAX_J)"
        );
    }
}
