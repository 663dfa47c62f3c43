//! Monte Carlo localization with ceiling brightness ([001], first
//! part, after Dellaert et al.'s museum robot): the map is the brightness of the ceiling over
//! the floor, sampled from training readings of an upward-looking camera; a reading is one
//! brightness value; each particle is weighted by how well the map's brightness above it
//! explains the reading. "Updated by odometry ... a less clustered distribution. Then a new
//! measurement of the brightness of the ceiling is taken ... a more clustered distribution."
//!
//! One number per reading says little at once (many places share a brightness); the
//! sequence of readings along the robot's path is what localizes it, so the filter keeps its
//! diversity: it resamples only when the effective sample size falls below a fraction of the
//! particles, and the likelihood has an outlier floor so that one odd reading cannot wipe out
//! the right hypothesis.

use crate::error::LocalizationError;
use crate::filter::cluster::PointEstimate;
use crate::filter::motion::OdometryMotionModel;
use crate::filter::particle_filter::{
    core_in_field, intensity_from, FilterCore, MeasurementModel, ParticleFilter,
};
use crate::filter::particles::{ReadingCounts, ReadingTally};
use crate::filter::resampling::ResamplePolicy;
use crate::limits::check_positive;
use crate::localizers::mcl::InitialBelief;
use atrium_robots::{IntensityImage, Reading};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Ceiling brightness on a regular grid of nodes (x0 + i·step, y0 + j·step), bilinear
/// between nodes; NaN marks a node without training data.
#[derive(Debug, Clone, PartialEq)]
pub struct CeilingMap {
    origin: [f64; 2],
    step: f64,
    nx: usize,
    ny: usize,
    values: Vec<f64>,
}

impl CeilingMap {
    /// `values[j * nx + i]` is the brightness at node (i, j).
    pub fn new(
        origin: [f64; 2],
        step: f64,
        nx: usize,
        ny: usize,
        values: Vec<f64>,
    ) -> Result<CeilingMap, LocalizationError> {
        let bad = |f: &str, r: String| {
            LocalizationError::InvalidParameter(format!("ceiling map: {f}: {r}"))
        };
        if !(origin.iter().all(|v| v.is_finite())) {
            return Err(bad("origin", format!("must be finite, got {origin:?}")));
        }
        if !(step.is_finite() && step > 0.0) {
            return Err(bad("step", format!("must be finite and > 0, got {step}")));
        }
        if nx < 2 || ny < 2 {
            return Err(bad(
                "size",
                format!("need at least 2 × 2 nodes, got {nx} × {ny}"),
            ));
        }
        if Some(values.len()) != nx.checked_mul(ny) {
            return Err(bad(
                "values",
                format!("{} values for {nx} × {ny} nodes", values.len()),
            ));
        }
        if values.iter().any(|v| v.is_infinite()) {
            return Err(bad("values", "infinite brightness".into()));
        }
        if values.iter().all(|v| v.is_nan()) {
            return Err(bad(
                "values",
                "the map is empty (no node has a brightness)".into(),
            ));
        }
        Ok(CeilingMap {
            origin,
            step,
            nx,
            ny,
            values,
        })
    }

    /// A map from training readings `(x, y, brightness)`: each reading goes to its nearest
    /// node, a node's value is the mean of its readings (NaN when it has none).
    pub fn from_samples(
        samples: &[[f64; 3]],
        origin: [f64; 2],
        step: f64,
        nx: usize,
        ny: usize,
    ) -> Result<CeilingMap, LocalizationError> {
        if samples.is_empty() {
            return Err(LocalizationError::InvalidParameter(
                "ceiling map: no training readings".into(),
            ));
        }
        if !(step.is_finite() && step > 0.0) {
            return Err(LocalizationError::InvalidParameter(format!(
                "ceiling map: step: must be finite and > 0, got {step}"
            )));
        }
        let mut sum = vec![0.0; nx * ny];
        let mut count = vec![0u32; nx * ny];
        for (k, s) in samples.iter().enumerate() {
            if s.iter().any(|v| !v.is_finite()) {
                return Err(LocalizationError::InvalidParameter(format!(
                    "ceiling map: training reading {k} is not finite: {s:?}"
                )));
            }
            let i = ((s[0] - origin[0]) / step).round();
            let j = ((s[1] - origin[1]) / step).round();
            if i < 0.0 || j < 0.0 || i >= nx as f64 || j >= ny as f64 {
                continue;
            }
            let c = j as usize * nx + i as usize;
            sum[c] += s[2];
            count[c] += 1;
        }
        let values = sum
            .iter()
            .zip(&count)
            .map(|(s, &c)| if c > 0 { s / c as f64 } else { f64::NAN })
            .collect();
        CeilingMap::new(origin, step, nx, ny, values)
    }

    /// Position of node (0, 0).
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }

    /// Node spacing, m.
    pub fn step(&self) -> f64 {
        self.step
    }

    /// Grid nodes along x and y.
    pub fn nodes(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Every node's brightness, `values()[j * nx + i]` (NaN: no training data); with
    /// [`CeilingMap::origin`], [`CeilingMap::step`] and [`CeilingMap::nodes`] what
    /// [`CeilingMap::new`] takes back.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// (x0, y0, x1, y1) of the node grid.
    pub fn extent(&self) -> [f64; 4] {
        [
            self.origin[0],
            self.origin[1],
            self.origin[0] + (self.nx - 1) as f64 * self.step,
            self.origin[1] + (self.ny - 1) as f64 * self.step,
        ]
    }

    /// The least and greatest brightness of the nodes that have one: how much the ceiling
    /// varies over the map (a flat ceiling cannot tell places apart).
    pub fn range(&self) -> (f64, f64) {
        self.values
            .iter()
            .filter(|v| !v.is_nan())
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(*v), hi.max(*v))
            })
    }

    /// Bilinear brightness at (x, y) over the nodes that have one; `None` outside the grid or
    /// where all four surrounding nodes are unknown.
    #[inline]
    pub fn brightness(&self, x: f64, y: f64) -> Option<f64> {
        let u = (x - self.origin[0]) / self.step;
        let v = (y - self.origin[1]) / self.step;
        if !(u >= 0.0 && v >= 0.0 && u <= (self.nx - 1) as f64 && v <= (self.ny - 1) as f64) {
            return None;
        }
        let i = (u.floor() as usize).min(self.nx - 2);
        let j = (v.floor() as usize).min(self.ny - 2);
        let (fu, fv) = (u - i as f64, v - j as f64);
        let corners = [
            (i, j, (1.0 - fu) * (1.0 - fv)),
            (i + 1, j, fu * (1.0 - fv)),
            (i, j + 1, (1.0 - fu) * fv),
            (i + 1, j + 1, fu * fv),
        ];
        let (mut s, mut w) = (0.0, 0.0);
        for (a, b, c) in corners {
            let val = self.values[b * self.nx + a];
            if !val.is_nan() {
                s += c * val;
                w += c;
            }
        }
        (w > 1e-9).then(|| s / w)
    }
}

/// Parameters of [`CeilingMcl`], as written in a scenario. Every field has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CeilingMclParams {
    /// Particles. Default 2000.
    pub particles: usize,
    /// Odometry motion model α1–α4. Default 0.05 each.
    pub alpha: [f64; 4],
    /// Standard deviation of a reading around the map's brightness (sensor noise plus map
    /// interpolation error). Default 0.03.
    pub sigma: f64,
    /// Probability that a reading is an outlier (uniform over `range`). Default 0.05.
    pub outlier: f64,
    /// Span of possible readings, for the outlier density. Default 2.0.
    pub range: f64,
    /// Resample when the effective sample size falls below this fraction of the particles.
    /// Default 0.5.
    pub resample_ess: f64,
    /// Name of the upward camera whose intensity readings are used. Default "ceiling".
    pub sensor: String,
}

impl Default for CeilingMclParams {
    fn default() -> Self {
        Self {
            particles: 2000,
            alpha: [0.05; 4],
            sigma: 0.03,
            outlier: 0.05,
            range: 2.0,
            resample_ess: 0.5,
            sensor: "ceiling".into(),
        }
    }
}

impl CeilingMclParams {
    pub fn validate(&self) -> Result<(), String> {
        crate::filter::particles::validate_particle_count(self.particles)?;
        crate::filter::motion::validate_alpha(&self.alpha)?;
        for (name, v) in [("sigma", self.sigma), ("range", self.range)] {
            check_positive(name, v)?;
        }
        if !(self.outlier > 0.0 && self.outlier < 1.0) {
            return Err(format!(
                "outlier must be within (0, 1), got {}",
                self.outlier
            ));
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

/// The brightness a reading reports: the mean of the upward camera's pixels (a 1 × 1 image is
/// the reading itself). Errors on an empty image or a non-finite pixel.
pub fn reading_brightness(image: &IntensityImage) -> Result<f64, LocalizationError> {
    if image.pixels.is_empty() || image.pixels.len() != image.width * image.height {
        return Err(LocalizationError::InvalidParameter(format!(
            "ceiling mcl: image from `{}` has {} pixels for {} × {}",
            image.sensor,
            image.pixels.len(),
            image.width,
            image.height
        )));
    }
    if let Some(p) = image.pixels.iter().position(|v| !v.is_finite()) {
        return Err(LocalizationError::InvalidParameter(format!(
            "ceiling mcl: image from `{}` has a non-finite pixel at index {p}",
            image.sensor
        )));
    }
    Ok(image.pixels.iter().map(|v| *v as f64).sum::<f64>() / image.pixels.len() as f64)
}

/// Particle filter on a [`CeilingMap`] (001).
#[derive(Clone)]
pub struct CeilingMcl {
    core: FilterCore,
    params: CeilingMclParams,
    map: Arc<CeilingMap>,
    motion: OdometryMotionModel,
    /// Below `resample_ess`: one brightness says little, so diversity is kept.
    policy: ResamplePolicy,
    tally: ReadingTally,
}

impl ReadingCounts for CeilingMcl {
    fn tally(&self) -> &ReadingTally {
        &self.tally
    }
}

impl CeilingMcl {
    /// A global belief is uniform over the map's node grid (or the given polygons).
    pub fn new(
        name: &str,
        params: CeilingMclParams,
        map: Arc<CeilingMap>,
        init: &InitialBelief,
        seed: u64,
    ) -> Result<CeilingMcl, LocalizationError> {
        params
            .validate()
            .map_err(|e| LocalizationError::InvalidParameter(format!("ceiling mcl: {e}")))?;
        let m = params.particles;
        let mut f = CeilingMcl {
            core: FilterCore::new(name, m, seed),
            motion: OdometryMotionModel::new(params.alpha),
            policy: ResamplePolicy::BelowEss(params.resample_ess),
            tally: ReadingTally::default(),
            params,
            map,
        };
        let extent = f.map.extent();
        f.core.start(m, init, extent, PointEstimate::WeightedMean)?;
        Ok(f)
    }

    /// p(z | x) = (1 − ε) N(z; m(x), σ²) + ε / range; where the map knows nothing, 1 / range.
    #[inline]
    pub fn likelihood(&self, z: f64, x: f64, y: f64) -> f64 {
        brightness_likelihood(&self.params, &self.map, z, x, y)
    }

    /// Motion update with the odometry since the last reading, then the brightness `z`.
    pub fn observe(&mut self, z: f64) -> Result<(), LocalizationError> {
        if !z.is_finite() {
            return Err(LocalizationError::InvalidParameter(format!(
                "ceiling mcl: brightness must be finite, got {z}"
            )));
        }
        self.filter_update(&z);
        Ok(())
    }
}

/// [`CeilingMcl::likelihood`] of brightness `z` at (x, y).
#[inline]
fn brightness_likelihood(p: &CeilingMclParams, map: &CeilingMap, z: f64, x: f64, y: f64) -> f64 {
    match map.brightness(x, y) {
        Some(m) => {
            let d = (z - m) / p.sigma;
            (1.0 - p.outlier) * (-0.5 * d * d).exp()
                / (p.sigma * (2.0 * std::f64::consts::PI).sqrt())
                + p.outlier / p.range
        }
        None => 1.0 / p.range,
    }
}

impl ParticleFilter for CeilingMcl {
    core_in_field!();

    /// Intensity readings of the sensor named in the parameters; others are ignored, a bad
    /// one is counted in [`ReadingCounts::rejected`].
    fn take_reading(&mut self, reading: &Reading) {
        if let Some(img) = intensity_from(reading, &self.params.sensor) {
            let outcome = reading_brightness(img).and_then(|z| self.observe(z));
            self.tally.settle(outcome, img.stamp, &mut self.core.carry);
        }
    }
}

/// A brightness weighs each particle by the map's brightness above it; resampling waits for
/// the effective sample size to fall (`resample_ess`).
impl MeasurementModel for CeilingMcl {
    type Observation = f64;

    fn motion(&self) -> &OdometryMotionModel {
        &self.motion
    }

    fn reweight(&mut self, &z: &f64) -> bool {
        let (params, map) = (&self.params, &self.map);
        self.core
            .set
            .reweight(|p, _| brightness_likelihood(params, map, z, p.x, p.y));
        self.tally.updates += 1;
        true
    }

    fn resample_policy(&self) -> ResamplePolicy {
        self.policy
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::localizer::{Localizer, OdometryDelta};
    use atrium_robots::{Mount3, Pose2};
    use rand::Rng;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    /// Three lamps of different strength over a 6 × 4 m room.
    fn lamp(x: f64, y: f64) -> f64 {
        let l = |cx: f64, cy: f64, s: f64| s / (1.0 + 2.0 * ((x - cx).powi(2) + (y - cy).powi(2)));
        0.1 + l(1.5, 1.0, 0.9) + l(4.5, 3.0, 0.5) + l(5.0, 0.8, 0.3)
    }

    fn map() -> CeilingMap {
        let mut s = Vec::new();
        for j in 0..9 {
            for i in 0..13 {
                let (x, y) = (i as f64 * 0.5, j as f64 * 0.5);
                s.push([x, y, lamp(x, y)]);
            }
        }
        CeilingMap::from_samples(&s, [0.0, 0.0], 0.5, 13, 9).unwrap()
    }

    fn reading(z: f32, stamp: f64) -> Reading {
        Reading::Intensity(IntensityImage {
            stamp,
            sensor: "ceiling".into(),
            mount: Mount3::default(),
            width: 1,
            height: 1,
            fx: 1.0,
            fy: 1.0,
            cx: 0.0,
            cy: 0.0,
            pixels: vec![z],
        })
    }

    #[test]
    fn map_interpolates_and_handles_holes() {
        let m = map();
        assert!((m.brightness(1.5, 1.0).unwrap() - lamp(1.5, 1.0)).abs() < 1e-12);
        let mid = m.brightness(1.25, 1.0).unwrap();
        assert!((mid - 0.5 * (lamp(1.0, 1.0) + lamp(1.5, 1.0))).abs() < 1e-12);
        assert!(m.brightness(-0.1, 1.0).is_none());
        assert!(m.brightness(6.0, 4.0).is_some());
        let holes = CeilingMap::new(
            [0.0, 0.0],
            1.0,
            2,
            2,
            vec![1.0, f64::NAN, f64::NAN, f64::NAN],
        )
        .unwrap();
        assert_eq!(holes.brightness(0.5, 0.5), Some(1.0));
        assert!(CeilingMap::new([0.0, 0.0], 1.0, 2, 2, vec![f64::NAN; 4])
            .unwrap_err()
            .to_string()
            .contains("empty"));
        assert!(CeilingMap::from_samples(&[], [0.0, 0.0], 1.0, 2, 2).is_err());
        assert!(
            CeilingMap::from_samples(&[[0.0, f64::NAN, 1.0]], [0.0, 0.0], 1.0, 2, 2)
                .unwrap_err()
                .to_string()
                .contains("reading 0")
        );
    }

    #[test]
    fn a_map_comes_back_from_its_parts() {
        let m = map();
        let (nx, ny) = m.nodes();
        let back = CeilingMap::new(m.origin(), m.step(), nx, ny, m.values().to_vec()).unwrap();
        assert_eq!(back, m);
        // A node count past usize is refused, not wrapped onto the values' length.
        let e = CeilingMap::new([0.0, 0.0], 1.0, usize::MAX / 2 + 1, 2, vec![1.0; 0]);
        assert!(e.unwrap_err().to_string().contains("0 values for"));
    }

    #[test]
    fn converges_from_a_global_belief_along_a_path() {
        let map = Arc::new(map());
        let mut f = CeilingMcl::new(
            "ceiling",
            CeilingMclParams {
                sigma: 0.02,
                particles: 20_000,
                ..Default::default()
            },
            map,
            &InitialBelief::Global { regions: vec![] },
            7,
        )
        .unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        // A drive around the room: 5 cm steps, turning in place at the corners.
        let corners: [[f64; 2]; 5] = [[0.5, 0.5], [5.5, 0.5], [5.5, 3.5], [1.0, 3.5], [1.0, 2.0]];
        let mut path = Vec::new();
        for w in corners.windows(2) {
            let th = (w[1][1] - w[0][1]).atan2(w[1][0] - w[0][0]);
            let n = ((w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) / 0.05) as usize;
            for k in 0..n {
                let t = k as f64 / n as f64;
                path.push(Pose2::new(
                    w[0][0] + t * (w[1][0] - w[0][0]),
                    w[0][1] + t * (w[1][1] - w[0][1]),
                    th,
                ));
            }
        }
        let mut truth = path[0];
        let mut odo = Pose2::default();
        for (t, next_truth) in path.iter().enumerate().skip(1) {
            let step = truth.between(next_truth);
            truth = *next_truth;
            let next = odo.compose(&step);
            f.predict(&OdometryDelta {
                stamp: t as f64,
                from: odo,
                to: next,
            })
            .unwrap();
            odo = next;
            let z = lamp(truth.x, truth.y) + 0.01 * rng.sample::<f64, _>(StandardNormal);
            f.update(&reading(z as f32, t as f64)).unwrap();
        }
        let e = f.estimate().pose;
        assert!(e.distance(&truth) < 0.3, "{e:?} vs {truth:?}");
        assert_eq!(f.updates(), path.len() - 1);
    }

    #[test]
    fn bad_readings_are_counted() {
        let mut f = CeilingMcl::new(
            "c",
            CeilingMclParams::default(),
            Arc::new(map()),
            &InitialBelief::Global { regions: vec![] },
            1,
        )
        .unwrap();
        f.update(&reading(f32::NAN, 1.0)).unwrap();
        assert_eq!(f.rejected(), 1);
        assert!(f.last_error().unwrap().to_string().contains("non-finite"));
        let Reading::Intensity(mut img) = reading(0.5, 1.0) else {
            unreachable!()
        };
        img.width = 2;
        f.update(&Reading::Intensity(img.clone())).unwrap();
        assert_eq!(f.rejected(), 2);
        img.sensor = "other".into();
        f.update(&Reading::Intensity(img)).unwrap();
        assert_eq!(f.rejected(), 2, "other sensors are ignored");
        assert_eq!(f.updates(), 0);
        let e = CeilingMcl::new(
            "c",
            CeilingMclParams {
                sigma: 0.0,
                ..Default::default()
            },
            Arc::new(map()),
            &InitialBelief::Global { regions: vec![] },
            1,
        )
        .err()
        .unwrap();
        assert!(e.to_string().contains("sigma"), "{e}");
    }
}
