//! Monte Carlo localization on the omnicam eigenimage map of [001]
//! (second part, its last paragraph: "the robot takes an omnicam image from its current
//! position, projects the image to an l-dimensional vector using P, and calculates the sum of
//! square differences for each point of the map to generate an energy function. This energy
//! function is related to the probability function of the location of the robot according
//! to the sensor measurement and serves as input to the Monte Carlo Localization
//! algorithm").
//!
//! 001 leaves the relation between energy and probability open; here it is the Gaussian one
//! the energy's form implies: the energy E(x) is a squared distance in feature space, so
//! p(z | x) ∝ exp(−E(x) / 2σ²), with E at a particle's pose from [`OmniMap::energy_at`]
//! (features interpolated between nodes and rotations, 001: "points between the samples are
//! obtained by interpolation"). The feature-space σ defaults to the map's own scale:
//! σ² = [`OmniMap::step_energy`] / 2, so a pose one grid step from a training pose is e⁻¹ as
//! likely. Because the features change in steps of the grid, the likelihood has a floor
//! (`outlier`, relative to the best particle) that keeps one odd panorama from wiping out the
//! right hypothesis.
//!
//! For a start anywhere in the map, a fraction `inject` of the particles at each resampling
//! is drawn from the energy function itself over all (node, rotation) pairs (the "sensor
//! resetting" / mixture proposal of Lenser and Veloso, Thrun et al.): 001's map gives that
//! proposal for free, since the energy at every node and rotation is one table lookup.

use crate::error::LocalizationError;
use crate::filter::cluster::PointEstimate;
use crate::filter::motion::OdometryMotionModel;
use crate::filter::particle_filter::{
    core_in_field, intensity_from, FilterCore, MeasurementModel, ParticleFilter,
};
use crate::filter::particles::{ReadingCounts, ReadingTally};
use crate::filter::resampling::{injection_count, Injection, ResamplePolicy};
use crate::limits::check_positive;
use crate::localizers::mcl::InitialBelief;
use crate::maps::omni_map::OmniMap;
use atrium_robots::{normalize_angle, IntensityImage, Pose2, Reading};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Parameters of [`OmniMcl`], as written in a scenario. Every field has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OmniMclParams {
    /// Particles. Default 2000.
    pub particles: usize,
    /// Odometry motion model α1–α4. Default 0.05 each.
    pub alpha: [f64; 4],
    /// Feature-space standard deviation of the energy likelihood; absent: from the map,
    /// σ² = step_energy / 2.
    pub sigma: Option<f64>,
    /// Likelihood floor relative to the best particle of the update. Default 0.01.
    pub outlier: f64,
    /// Fraction of the particles drawn from the energy function at each resampling.
    /// Default 0.02 (0 turns it off).
    pub inject: f64,
    /// Resample when the effective sample size falls below this fraction. Default 0.5.
    pub resample_ess: f64,
    /// Name of the panoramic camera whose intensity readings are used. Default "omni".
    pub sensor: String,
}

impl Default for OmniMclParams {
    fn default() -> Self {
        Self {
            particles: 2000,
            alpha: [0.05; 4],
            sigma: None,
            outlier: 0.01,
            inject: 0.02,
            resample_ess: 0.5,
            sensor: "omni".into(),
        }
    }
}

impl OmniMclParams {
    pub fn validate(&self) -> Result<(), String> {
        crate::filter::particles::validate_particle_count(self.particles)?;
        crate::filter::motion::validate_alpha(&self.alpha)?;
        if let Some(s) = self.sigma {
            check_positive("sigma", s)?;
        }
        if !(self.outlier > 0.0 && self.outlier < 1.0) {
            return Err(format!(
                "outlier must be within (0, 1), got {}",
                self.outlier
            ));
        }
        if !(0.0..1.0).contains(&self.inject) {
            return Err(format!("inject must be within [0, 1), got {}", self.inject));
        }
        if !(self.resample_ess > 0.0 && self.resample_ess <= 1.0) {
            return Err(format!(
                "resample_ess must be within (0, 1], got {}",
                self.resample_ess
            ));
        }
        Ok(())
    }
}

/// Particle filter on an [`OmniMap`] (001).
#[derive(Clone)]
pub struct OmniMcl {
    core: FilterCore,
    params: OmniMclParams,
    map: Arc<OmniMap>,
    /// 1 / 2σ².
    inv_two_sigma2: f64,
    motion: OdometryMotionModel,
    /// Below `resample_ess`, as the ceiling filter.
    policy: ResamplePolicy,
    /// Features of the current panorama.
    feat: Vec<f64>,
    /// Energy at every (node, rotation), then the cumulative proposal over them.
    table: Vec<f64>,
    tally: ReadingTally,
}

impl ReadingCounts for OmniMcl {
    fn tally(&self) -> &ReadingTally {
        &self.tally
    }
}

impl OmniMcl {
    /// A global belief is uniform over the map's node grid (or the given polygons).
    pub fn new(
        name: &str,
        params: OmniMclParams,
        map: Arc<OmniMap>,
        init: &InitialBelief,
        seed: u64,
    ) -> Result<OmniMcl, LocalizationError> {
        params
            .validate()
            .map_err(|e| LocalizationError::InvalidParameter(format!("omni mcl: {e}")))?;
        let sigma2 = match params.sigma {
            Some(s) => s * s,
            None => 0.5 * map.step_energy(),
        };
        if !(sigma2.is_finite() && sigma2 > 0.0) {
            return Err(LocalizationError::InvalidParameter(format!(
                "omni mcl: the map's neighbouring nodes look identical (step energy {}): give sigma",
                2.0 * sigma2
            )));
        }
        let m = params.particles;
        let (nx, ny) = map.nodes();
        let mut f = OmniMcl {
            core: FilterCore::new(name, m, seed),
            inv_two_sigma2: 0.5 / sigma2,
            motion: OdometryMotionModel::new(params.alpha),
            policy: ResamplePolicy::BelowEss(params.resample_ess),
            feat: vec![0.0; map.d()],
            table: Vec::with_capacity(nx * ny * map.rotations()),
            tally: ReadingTally::default(),
            params,
            map,
        };
        let extent = f.map.extent();
        f.core.start(m, init, extent, PointEstimate::WeightedMean)?;
        Ok(f)
    }

    /// The feature-space σ in use.
    pub fn sigma(&self) -> f64 {
        (0.5 / self.inv_two_sigma2).sqrt()
    }

    /// Motion update with the odometry since the last reading, then the panorama `image`
    /// (row-major, the map's width × height).
    pub fn observe(&mut self, image: &[f32]) -> Result<(), LocalizationError> {
        self.map.features_into(image, &mut self.feat)?;
        let feat = std::mem::take(&mut self.feat);
        self.filter_update(&feat);
        self.feat = feat;
        Ok(())
    }

    /// The energy function of the current panorama as a cumulative table over every
    /// (node, rotation), and its total; None when no energy is finite.
    fn proposal(&mut self, feat: &[f64]) -> Option<f64> {
        self.map.energy(feat, &mut self.table);
        let emin = self.table.iter().copied().fold(f64::INFINITY, f64::min);
        if !emin.is_finite() {
            return None;
        }
        let mut acc = 0.0;
        for e in &mut self.table {
            acc += (-(*e - emin) * self.inv_two_sigma2).exp();
            *e = acc;
        }
        Some(acc)
    }

    fn check(&self, img: &IntensityImage) -> Result<(), LocalizationError> {
        if img.width != self.map.width || img.height != self.map.height {
            return Err(LocalizationError::InvalidParameter(format!(
                "omni mcl: panorama from `{}` is {} × {}, the map was trained on {} × {}",
                img.sensor, img.width, img.height, self.map.width, self.map.height
            )));
        }
        Ok(())
    }
}

impl ParticleFilter for OmniMcl {
    core_in_field!();

    /// Intensity readings of the sensor named in the parameters; others are ignored, a bad
    /// one is counted in [`ReadingCounts::rejected`].
    fn take_reading(&mut self, reading: &Reading) {
        if let Some(img) = intensity_from(reading, &self.params.sensor) {
            let outcome = self.check(img).and_then(|()| self.observe(&img.pixels));
            self.tally.settle(outcome, img.stamp, &mut self.core.carry);
        }
    }

    fn reseed(&mut self, pose: Pose2, sigma: [f64; 3]) -> bool {
        let m = self.core.set.len();
        self.core
            .reseed(m, pose, sigma, PointEstimate::WeightedMean)
    }
}

/// A panorama's features weigh each particle by the map's energy at its pose, relative to the
/// best particle and with an outlier floor; resampling waits for the effective sample size to
/// fall (`resample_ess`) and injects particles drawn from the panorama's energy.
impl MeasurementModel for OmniMcl {
    type Observation = [f64];

    fn motion(&self) -> &OdometryMotionModel {
        &self.motion
    }

    fn reweight(&mut self, feat: &[f64]) -> bool {
        let m = self.core.set.len();
        let mut best = f64::NEG_INFINITY;
        for i in 0..m {
            let pose = self.core.set.pose(i);
            let l = match self.map.energy_at(feat, &pose) {
                Some(e) => -e * self.inv_two_sigma2,
                None => f64::NEG_INFINITY,
            };
            self.core.set.log_likelihoods_mut()[i] = l;
            best = best.max(l);
        }
        let eps = self.params.outlier;
        self.core.set.reweight(|_, l| {
            // Relative to the best particle: exp never underflows for all of them at once,
            // and the floor is a fraction of the best explanation.
            if best.is_finite() {
                eps + (1.0 - eps) * (l - best).exp()
            } else {
                1.0
            }
        });
        self.tally.updates += 1;
        true
    }

    fn resample_policy(&self) -> ResamplePolicy {
        self.policy
    }

    /// Low-variance resampling, then `inject` of the particles replaced by draws from
    /// exp(−E / 2σ²) over every (node, rotation), jittered uniformly within half a grid step
    /// and half a rotation step.
    fn resample(&mut self, feat: &[f64]) {
        let m = self.core.set.len();
        let k = injection_count(self.params.inject, m);
        let total = if k > 0 { self.proposal(feat) } else { None };
        let Some(total) = total else {
            self.core.set.resample_plain(m, &mut self.core.rng);
            return;
        };
        let (map, table) = (&self.map, &self.table);
        let r = map.rotations();
        let (nx, _) = map.nodes();
        let step = map.step();
        let half_turn = std::f64::consts::PI / r as f64;
        self.core
            .set
            .resample(m, Injection::Count(k), &mut self.core.rng, |rng| {
                let u = rng.random::<f64>() * total;
                let cell = table.partition_point(|c| *c <= u).min(table.len() - 1);
                let (node, rot) = (cell / r, cell % r);
                let [cx, cy] = map.node_position(node % nx, node / nx);
                Pose2::new(
                    cx + step * (rng.random::<f64>() - 0.5),
                    cy + step * (rng.random::<f64>() - 0.5),
                    normalize_angle(
                        map.heading(rot) + half_turn * (2.0 * rng.random::<f64>() - 1.0),
                    ),
                )
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::localizer::{Localizer, OdometryDelta};
    use crate::maps::omni_map::tests::panorama_of;
    use crate::maps::omni_map::{shift_columns, OmniMapParams};
    use atrium_robots::Mount3;

    /// A synthetic panorama of four posts seen from (x, y) with heading `theta`.
    fn panorama(x: f64, y: f64, theta: f64, w: usize, h: usize) -> Vec<f32> {
        let posts = [
            (5.0, 1.0, 0.9),
            (-1.0, 4.0, 0.5),
            (2.0, -3.0, 0.2),
            (4.0, 5.0, 0.7),
        ];
        panorama_of(&posts, x, y, theta, w, h)
    }

    fn map() -> Arc<OmniMap> {
        let (nx, ny) = (9, 7);
        let imgs: Vec<Vec<f32>> = (0..ny)
            .flat_map(|j| {
                (0..nx).map(move |i| panorama(i as f64 * 0.5, j as f64 * 0.5, 0.0, 64, 4))
            })
            .collect();
        let refs: Vec<&[f32]> = imgs.iter().map(|v| v.as_slice()).collect();
        Arc::new(
            OmniMap::build(
                [0.0, 0.0],
                0.5,
                nx,
                ny,
                64,
                4,
                &refs,
                OmniMapParams {
                    rotations: 32,
                    d: 12,
                    pca_locations: 12,
                    seed: 1,
                },
            )
            .unwrap(),
        )
    }

    fn reading(img: Vec<f32>, stamp: f64) -> Reading {
        Reading::Intensity(IntensityImage {
            stamp,
            sensor: "omni".into(),
            mount: Mount3::default(),
            width: 64,
            height: 4,
            fx: 64.0 / std::f64::consts::TAU,
            fy: 1.0,
            cx: 0.0,
            cy: 1.5,
            pixels: img,
        })
    }

    /// A straight drive, a turn and another leg, inside the 4 × 3 m map: poses every 10 cm.
    fn drive() -> Vec<Pose2> {
        let mut out = Vec::new();
        for k in 0..30 {
            out.push(Pose2::new(
                0.4 + 0.1 * k as f64,
                0.6 + 0.05 * k as f64,
                0.46,
            ));
        }
        for k in 0..10 {
            out.push(Pose2::new(3.3, 2.05, 0.46 + 0.15 * k as f64));
        }
        for k in 0..9 {
            let th: f64 = 0.46 + 1.5;
            out.push(Pose2::new(
                3.3 + 0.1 * k as f64 * th.cos(),
                2.05 + 0.1 * k as f64 * th.sin(),
                th,
            ));
        }
        out
    }

    fn run(init: InitialBelief, inject: f64) -> (Vec<f64>, Vec<f64>, OmniMcl) {
        let truth = drive();
        let mut f = OmniMcl::new(
            "omni",
            OmniMclParams {
                particles: 1500,
                inject,
                ..Default::default()
            },
            map(),
            &init,
            3,
        )
        .unwrap();
        let mut odo = Pose2::new(10.0, -3.0, 1.0);
        let (mut errs, mut headings) = (Vec::new(), Vec::new());
        for k in 1..truth.len() {
            let d = truth[k - 1].between(&truth[k]);
            let next = odo.compose(&Pose2::new(1.03 * d.x, d.y, d.theta));
            f.predict(&OdometryDelta {
                stamp: k as f64,
                from: odo,
                to: next,
            })
            .unwrap();
            odo = next;
            let t = truth[k];
            f.update(&reading(panorama(t.x, t.y, t.theta, 64, 4), k as f64))
                .unwrap();
            let e = f.estimate().pose;
            errs.push(e.distance(&t));
            headings.push(e.heading_error(&t).to_degrees());
        }
        (errs, headings, f)
    }

    #[test]
    fn tracks_a_drive_between_grid_nodes() {
        let (errs, headings, f) = run(
            InitialBelief::Tracking {
                pose: drive()[0],
                sigma: [0.2, 0.2, 0.1],
            },
            0.0,
        );
        assert_eq!(f.rejected(), 0);
        assert_eq!(f.updates(), errs.len());
        let mean = errs.iter().sum::<f64>() / errs.len() as f64;
        let max = errs.iter().cloned().fold(0.0, f64::max);
        let hmax = headings.iter().cloned().fold(0.0, f64::max);
        assert!(
            mean < 0.15 && max < 0.35 && hmax < 12.0,
            "{mean} {max} {hmax}"
        );
    }

    #[test]
    fn converges_from_a_global_start_with_injection() {
        let (errs, _, _) = run(InitialBelief::Global { regions: vec![] }, 0.05);
        assert!(errs[0] > 0.5, "starts spread: {}", errs[0]);
        let tail = &errs[errs.len() - 20..];
        let worst = tail.iter().cloned().fold(0.0, f64::max);
        assert!(worst < 0.35, "{errs:?}");
    }

    #[test]
    fn bad_readings_and_parameters_are_refused() {
        let mut f = OmniMcl::new(
            "omni",
            OmniMclParams::default(),
            map(),
            &InitialBelief::Global { regions: vec![] },
            1,
        )
        .unwrap();
        let Reading::Intensity(mut img) = reading(vec![0.5; 64 * 4], 1.0) else {
            unreachable!()
        };
        img.width = 32;
        img.pixels.truncate(32 * 4);
        f.update(&Reading::Intensity(img.clone())).unwrap();
        assert_eq!(f.rejected(), 1);
        assert!(f.last_error().unwrap().to_string().contains("32 × 4"));
        img.width = 64;
        img.pixels = vec![f32::NAN; 64 * 4];
        f.update(&Reading::Intensity(img.clone())).unwrap();
        assert_eq!(f.rejected(), 2);
        // Another camera's images are not for this filter.
        img.sensor = "front".into();
        f.update(&Reading::Intensity(img)).unwrap();
        assert_eq!((f.rejected(), f.updates()), (2, 0));
        for bad in [
            OmniMclParams {
                sigma: Some(0.0),
                ..Default::default()
            },
            OmniMclParams {
                inject: 1.0,
                ..Default::default()
            },
            OmniMclParams {
                particles: 0,
                ..Default::default()
            },
        ] {
            assert!(OmniMcl::new(
                "omni",
                bad,
                map(),
                &InitialBelief::Global { regions: vec![] },
                1
            )
            .is_err());
        }
        // A rotation of the robot is a column shift of the same panorama.
        let a = panorama(1.0, 1.0, 0.0, 64, 4);
        let mut s = vec![0.0; a.len()];
        shift_columns(&a, 64, 8, &mut s);
        let b = panorama(1.0, 1.0, std::f64::consts::FRAC_PI_4, 64, 4);
        assert!(s.iter().zip(&b).all(|(p, q)| (p - q).abs() < 1e-5));
    }
}
