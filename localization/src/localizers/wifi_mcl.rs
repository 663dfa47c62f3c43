//! WiFi localization with the GP-learnt WiFi graph ([004] §2.3, eq. 1–2):
//! a particle filter with the odometry motion model (Thrun et al. Table 5.6) whose
//! observation likelihood comes from the graph's bicubically interpolated mean and variance.
//!
//! Observation likelihood of a scan at a particle's position x, per access point a of the
//! graph (independent given x):
//! - heard with RSSI z: N(z; μ_a(x), σ_a²(x) + σ_n,a²), μ and σ² interpolated from the graph,
//!   σ_n,a the fitted reading noise;
//! - missing from the scan: the probability that the reading fell below the cut-off,
//!   Φ((c − μ_a(x)) / √(σ_a²(x) + σ_n,a²)); a place where the access point is strong is
//!   thereby evidence against, not silently ignored;
//! - each term mixed with a small outlier probability (`outlier`), so one odd reading cannot
//!   veto a particle.
//!
//! The product is tempered by `exponent` ≤ 1: readings of one scan share the graph's
//! spatially correlated errors, which the independence assumption would count many times
//! over. Readings of access points the graph does not know are counted
//! ([`WifiMcl::unknown_readings`]) and otherwise unused: nothing was learnt about them.
//!
//! A particle's likelihood costs one 4 × 4 stencil plus 16 node reads per access point,
//! independent of the number of training samples.

use crate::error::LocalizationError;
use crate::filter::cluster::PointEstimate;
use crate::filter::motion::OdometryMotionModel;
use crate::filter::observation_fit::{per_unit_log_mean, FitTracker};
use crate::filter::particle_filter::{core_in_field, FilterCore, MeasurementModel, ParticleFilter};
use crate::filter::resampling::Injection;
use crate::localizers::mcl::InitialBelief;
use crate::maps::free_space::FreeSpace;
use crate::maps::wifi_graph::{WifiGraph, AP_CHUNK};
use atrium_robots::{Pose2, Reading, WifiScan};
use atrium_worlds::geometry::point_in_polygon;
use atrium_worlds::{Cell, OccupancyGrid};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Parameters of the WiFi particle filter, as written in a scenario. Every field has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WifiMclParams {
    /// Particles while tracking. Default 2000.
    pub particles: usize,
    /// Particles of a global initial belief, reduced to `particles` at the first resampling.
    /// Default 30000.
    pub global_particles: usize,
    /// Odometry motion model α1–α4. Default 0.05 each.
    pub alpha: [f64; 4],
    /// Probability that one reading is an outlier. Default 0.02.
    pub outlier: f64,
    /// Exponent of the scan likelihood (1: independent readings). Default 0.5.
    pub exponent: f64,
    /// Receiver cut-off, dBm; None takes the graph's. Default None.
    pub cutoff_dbm: Option<f64>,
    /// Fraction of particles replaced by uniformly random ones at each resampling (recovery
    /// from a wrong global fix). Default 0.
    pub random_fraction: f64,
    /// Keep the particles in the building's free space, as the graph-constrained WiFi
    /// localizer of 004 §2.3 does ([`crate::maps::free_space`]): a particle whose motion ends in a
    /// wall or outside the building is weighted down by [`OFF_MAP_WEIGHT`] and put back where
    /// it came from (and see `walls`). Default true; false is the unconstrained filter (for
    /// comparison).
    pub constrain_to_map: bool,
    /// With `constrain_to_map`, also weight down (but do not move) a particle whose motion
    /// crossed an inner wall, so that the cloud keeps to corridors and doors like the robot.
    /// Default false. It keeps the cloud out of rooms beside a corridor (wifi_edges: max
    /// 27 m without, 5.4 m with), but a cloud that went into a room through a door can be
    /// shut in there, and on wifi_atrium's seed it moves the atrium maximum from 2.43 to
    /// 2.56 m (over its 2.5 m bound; seeds 1–6: 1.59–2.35 m with, 1.57–2.21 m without).
    pub walls: bool,
    /// Keep the particles where the graph was learnt — 004 §2.3 localizes on the WiFi graph,
    /// the places its survey covered. A particle where the graph's variance, summed over
    /// access points, exceeds this fraction of the prior's (σ_f²) is weighted down like one
    /// off the map: far from every survey scan the GP reverts to its prior, whose wide
    /// variance fits any scan moderately well, so an unsurveyed room can out-score the true
    /// position whenever its readings are a few dB off the learnt means, and draw the cloud
    /// in. Within (0, 1]; 1 (the default) turns the constraint off. 0.3 on the
    /// campus_error_map sweep (20 drives): the worst per-drive median error 34.6 m → 1.07 m,
    /// the worst error 55.6 m → 8.9 m. Not yet the default: with it, choosers_campus's
    /// data-driven chooser loses track (see docs/design/0010-wifi-graph.md).
    pub max_untrained: f64,
}

/// Likelihood factor of a particle whose last motion crossed a wall or left the building:
/// practically zero (p(x | map) = 0 there), but finite, so that when every particle did (the
/// map disagrees with the motion everywhere) the weights are unchanged rather than undefined.
pub const OFF_MAP_WEIGHT: f64 = 1e-6;

impl Default for WifiMclParams {
    fn default() -> Self {
        Self {
            particles: 2000,
            global_particles: 30000,
            alpha: [0.05; 4],
            outlier: 0.02,
            exponent: 0.5,
            cutoff_dbm: None,
            random_fraction: 0.0,
            constrain_to_map: true,
            walls: false,
            max_untrained: 1.0,
        }
    }
}

impl WifiMclParams {
    pub fn validate(&self) -> Result<(), String> {
        crate::filter::particles::validate_particle_count(self.particles)?;
        crate::limits::check_count_min1(
            "global_particles",
            self.global_particles,
            crate::limits::MAX_GLOBAL_PARTICLES,
            "MAX_GLOBAL_PARTICLES",
        )?;
        crate::filter::motion::validate_alpha(&self.alpha)?;
        if !(self.outlier > 0.0 && self.outlier < 1.0) {
            return Err(format!(
                "outlier must be within (0, 1), got {}",
                self.outlier
            ));
        }
        if !(self.exponent > 0.0 && self.exponent <= 1.0) {
            return Err(format!(
                "exponent must be within (0, 1], got {}",
                self.exponent
            ));
        }
        if let Some(c) = self.cutoff_dbm {
            if !(c.is_finite() && (-150.0..=0.0).contains(&c)) {
                return Err(format!("cutoff_dbm must be within [-150, 0], got {c}"));
            }
        }
        if !(self.max_untrained > 0.0 && self.max_untrained <= 1.0) {
            return Err(format!(
                "max_untrained must be within (0, 1], got {}",
                self.max_untrained
            ));
        }
        if !(0.0..1.0).contains(&self.random_fraction) {
            return Err(format!(
                "random_fraction must be within [0, 1), got {}",
                self.random_fraction
            ));
        }
        Ok(())
    }
}

/// Standard normal CDF via erfc (W. J. Cody's rational Chebyshev fit as in Numerical
/// Recipes `erfcc`: fractional error below 1.2e-7 everywhere).
fn normal_cdf(z: f64) -> f64 {
    let x = -z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * x.abs());
    let y = t
        * (-x * x - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87
                                        + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    let erfc = if x >= 0.0 { y } else { 2.0 - y };
    0.5 * erfc
}

/// Particle filter on a [`WifiGraph`].
#[derive(Clone)]
pub struct WifiMcl {
    core: FilterCore,
    params: WifiMclParams,
    graph: Arc<WifiGraph>,
    cutoff: f64,
    motion: OdometryMotionModel,
    /// Per graph access point: the reading of the current scan, NaN when missing.
    z: Vec<f64>,
    /// Free positions to draw random particles from (cell centres on a ≤ 0.25 m lattice).
    free: Vec<[f64; 2]>,
    free_step: f64,
    unknown: usize,
    /// Sensing mismatch (004 §4.2) of the scans, per access point of the graph.
    fit: FitTracker,
    /// The building's free space (the constraint of `constrain_to_map`).
    space: FreeSpace,
    /// Per particle: its last motion crossed a wall or left the building.
    off_map: Vec<bool>,
    /// Σ_a σ_f,a²: the graph's variance summed over access points where nothing was learnt.
    prior_variance: f64,
}

impl WifiMcl {
    /// `grid` supplies the free space for a global belief and random particles.
    pub fn new(
        name: &str,
        params: WifiMclParams,
        graph: Arc<WifiGraph>,
        grid: &OccupancyGrid,
        init: InitialBelief,
        seed: u64,
    ) -> Result<WifiMcl, LocalizationError> {
        params
            .validate()
            .map_err(LocalizationError::InvalidParameter)?;
        let space = FreeSpace::from_grid(grid);
        // Free space on a lattice of about 0.25 m: enough for uniform draws, and small. With
        // the map constraint, only the building's inside (the grid's margin is outside).
        let (free, free_step) = if params.constrain_to_map {
            (space.anchors().to_vec(), space.anchor_spacing())
        } else {
            let stride = ((0.25 / grid.resolution).round() as usize).max(1);
            let mut free = Vec::new();
            for j in (0..grid.height).step_by(stride) {
                for i in (0..grid.width).step_by(stride) {
                    if grid.cells[j * grid.width + i] == Cell::Free {
                        free.push([
                            grid.origin[0] + (i as f64 + 0.5) * grid.resolution,
                            grid.origin[1] + (j as f64 + 0.5) * grid.resolution,
                        ]);
                    }
                }
            }
            (free, stride as f64 * grid.resolution)
        };
        let cap = params.particles.max(params.global_particles);
        let cutoff = params.cutoff_dbm.unwrap_or(graph.cutoff_dbm);
        let n_ap = graph.aps.len();
        let mut f = WifiMcl {
            // Room for the larger of the tracking and the global counts.
            core: FilterCore::new(name, cap, seed),
            motion: OdometryMotionModel::new(params.alpha),
            cutoff,
            z: vec![f64::NAN; n_ap],
            free,
            free_step,
            unknown: 0,
            fit: FitTracker::default(),
            space,
            off_map: vec![false; cap],
            prior_variance: graph.aps.iter().map(|a| a.kernel.signal_sd.powi(2)).sum(),
            graph,
            params,
        };
        f.initialise(&init)?;
        Ok(f)
    }

    fn initialise(&mut self, init: &InitialBelief) -> Result<(), LocalizationError> {
        match init {
            InitialBelief::Tracking { .. } => {
                let n = self.params.particles;
                // A tracking belief needs no extent.
                self.core
                    .set
                    .sample_initial_belief(n, init, [0.0; 4], &mut self.core.rng)?;
            }
            InitialBelief::Global { regions } => {
                if !regions.is_empty() {
                    self.free
                        .retain(|p| regions.iter().any(|poly| point_in_polygon(*p, poly)));
                }
                if self.free.is_empty() {
                    return Err(LocalizationError::InvalidInitialBelief {
                        field: "regions",
                        reason: "no free space of the map lies inside the polygons".into(),
                    });
                }
                let n = self.params.global_particles;
                let draw = RandomPoses {
                    free: &self.free,
                    step: self.free_step,
                    space: self.params.constrain_to_map.then_some(&self.space),
                };
                self.core.set.sample(n, &mut self.core.rng, |rng| {
                    Ok::<_, LocalizationError>(draw.draw(rng))
                })?;
            }
        }
        self.core.refresh_estimate(PointEstimate::WeightedMean);
        Ok(())
    }

    pub fn particle_count(&self) -> usize {
        self.core.set.len()
    }

    /// Readings (over all scans so far) of access points the graph does not know.
    pub fn unknown_readings(&self) -> usize {
        self.unknown
    }

    /// Loads a scan into `z` (per graph AP, NaN when missing). Returns the readings used.
    fn load_scan(&mut self, scan: &WifiScan) -> usize {
        self.z.fill(f64::NAN);
        let mut used = 0;
        for r in &scan.readings {
            match self.graph.ap_index(&r.ap) {
                Some(a) if r.rssi_dbm.is_finite() => {
                    self.z[a] = r.rssi_dbm;
                    used += 1;
                }
                Some(_) => {}
                None => self.unknown += 1,
            }
        }
        used
    }

    /// Log-likelihood of the loaded scan at (x, y) (before tempering).
    #[inline]
    pub fn log_likelihood_at(&self, x: f64, y: f64) -> f64 {
        self.log_likelihood_and_untrained(x, y).0
    }

    /// [`WifiMcl::log_likelihood_at`] and the untrained fraction at (x, y): the graph's
    /// variance summed over access points over the prior's (0 on the survey, 1 far from it).
    fn log_likelihood_and_untrained(&self, x: f64, y: f64) -> (f64, f64) {
        let st = self.graph.stencil(x, y);
        let eps = self.params.outlier;
        // Outlier densities: a uniform reading over a 100 dB span; a missing reading anyway.
        let (out_heard, out_missing) = (eps / 100.0, eps);
        let (mut l, mut var_sum) = (0.0, 0.0);
        let (mut means, mut vars) = ([0.0; AP_CHUNK], [0.0; AP_CHUNK]);
        for (chunk, zs) in self.z.chunks(AP_CHUNK).enumerate() {
            let first = chunk * AP_CHUNK;
            let (means, vars) = (&mut means[..zs.len()], &mut vars[..zs.len()]);
            self.graph.eval_aps(&st, first, means, vars);
            for (j, &z) in zs.iter().enumerate() {
                let (mu, var) = (means[j], vars[j]);
                var_sum += var;
                let noise = self.graph.aps[first + j].kernel.noise_sd;
                let s2 = var + noise * noise;
                let p = if z.is_nan() {
                    let s = s2.sqrt();
                    (1.0 - eps) * normal_cdf((self.cutoff - mu) / s) + out_missing
                } else {
                    let d = z - mu;
                    (1.0 - eps) * (-0.5 * d * d / s2).exp()
                        / (2.0 * std::f64::consts::PI * s2).sqrt()
                        + out_heard
                };
                l += p.ln();
            }
        }
        (l, var_sum / self.prior_variance.max(f64::MIN_POSITIVE))
    }
}

/// Random particles of the WiFi filter: a free position, jittered uniformly within half the
/// lattice step, uniform heading (x, y jitter, then θ). With the map constraint, an anchor
/// whose jittered neighbourhood is in a wall keeps the anchor itself (it is inside).
struct RandomPoses<'a> {
    free: &'a [[f64; 2]],
    step: f64,
    space: Option<&'a FreeSpace>,
}

impl RandomPoses<'_> {
    fn draw<R: Rng + ?Sized>(&self, rng: &mut R) -> Pose2 {
        let p = self.free[rng.random_range(0..self.free.len())];
        let h = 0.5 * self.step;
        let u: f64 = rng.random_range(-h..h);
        let v: f64 = rng.random_range(-h..h);
        let t: f64 = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        let (x, y) = (p[0] + u, p[1] + v);
        if self.space.is_some_and(|s| !s.contains(x, y)) {
            return Pose2::new(p[0], p[1], t);
        }
        Pose2::new(x, y, t)
    }
}

impl ParticleFilter for WifiMcl {
    core_in_field!();

    /// WiFi scans only (odometry arrives through `predict`).
    fn take_reading(&mut self, reading: &Reading) {
        if let Reading::Wifi(scan) = reading {
            self.core.carry.observed_at(scan.stamp);
            self.filter_update(scan);
        }
    }

    fn fit_tracker(&self) -> Option<&FitTracker> {
        Some(&self.fit)
    }

    /// Redraws the tracking-size set (`particles`) around `pose`.
    fn reseed(&mut self, pose: Pose2, sigma: [f64; 3]) -> bool {
        let n = self.params.particles;
        let ok = self
            .core
            .reseed(n, pose, sigma, PointEstimate::WeightedMean);
        if ok {
            self.off_map[..n].fill(false);
        }
        ok
    }
}

/// A WiFi scan weighs each particle by the graph's RSSI distributions at its position,
/// tempered by `exponent`, and down by `OFF_MAP_WEIGHT` if its last motion left the map.
impl MeasurementModel for WifiMcl {
    type Observation = WifiScan;

    fn motion(&self) -> &OdometryMotionModel {
        &self.motion
    }

    /// The odometry motion model, constrained to the building's free space
    /// (`constrain_to_map`); a particle that crossed a wall is marked for the next weighing.
    fn propagate(&mut self) {
        let constrain = self.params.constrain_to_map && !self.space.is_empty();
        let (space, walls, off_map) = (&self.space, self.params.walls, &mut self.off_map);
        self.core.set.propagate_constrained(
            &self.motion,
            &mut self.core.carry.pending,
            &mut self.core.rng,
            |i, [x0, y0], [mut x, mut y, th]| {
                // 004 §2.3: the robot is constrained to the graph. A particle that went
                // through a wall (with `walls`) is weighted down at the next scan; one that
                // ended in a wall or out of the building is also put back inside (out there
                // the graph is clamped, the likelihood flat, and nothing would ever pull it
                // back): where it came from, or, if that was not inside either, the nearest
                // free position. (The nearest free position of a particle in a wall can be
                // on the wall's far side: a leak through which clouds wandered into rooms.)
                if constrain && walls && !space.path_clear([x0, y0], [x, y]) {
                    off_map[i] = true;
                }
                if constrain && !space.contains(x, y) {
                    off_map[i] = true;
                    if space.contains(x0, y0) {
                        (x, y) = (x0, y0);
                    } else if let Some(q) = space.project(x, y) {
                        (x, y) = (q[0], q[1]);
                    }
                }
                [x, y, th]
            },
        );
    }

    fn reweight(&mut self, scan: &WifiScan) -> bool {
        self.load_scan(scan);
        let n = self.core.set.len();
        let limit = self.params.max_untrained;
        for i in 0..n {
            let p = self.core.set.pose(i);
            let (l, untrained) = self.log_likelihood_and_untrained(p.x, p.y);
            self.core.set.log_likelihoods_mut()[i] = self.params.exponent * l;
            // Off the graph counts as off the map (applied below, after the fit).
            if limit < 1.0 && untrained > limit {
                self.off_map[i] = true;
            }
        }
        self.fit.record(
            self.core.carry.stamp,
            per_unit_log_mean(self.core.set.log_likelihoods(), self.z.len()),
        );
        // The map's verdict on the last motion (after the fit: that measures the scan alone).
        let off_map_log = OFF_MAP_WEIGHT.ln();
        let logw = self.core.set.log_likelihoods_mut();
        for (l, off) in logw.iter_mut().zip(&mut self.off_map[..n]) {
            if *off {
                *l += off_map_log;
                *off = false;
            }
        }
        self.core.set.weigh_by_log_likelihoods();
        true
    }

    /// Low-variance resampling back to the tracking size (`particles`; a global belief
    /// starts larger), each new particle a random one with probability `random_fraction`.
    fn resample(&mut self, _scan: &WifiScan) {
        let draw = RandomPoses {
            free: &self.free,
            step: self.free_step,
            space: self.params.constrain_to_map.then_some(&self.space),
        };
        let inject = match self.params.random_fraction {
            p if p > 0.0 => Injection::Probability(p),
            _ => Injection::None,
        };
        self.core
            .set
            .resample(self.params.particles, inject, &mut self.core.rng, |rng| {
                draw.draw(rng)
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::localizer::{Localizer, OdometryDelta};
    use crate::maps::wifi_graph::GraphAp;
    use crate::maths::gp::SeKernel;
    use atrium_robots::WifiReading;

    /// Four APs at the corners of a 20 × 20 m room, log-distance means on a 1 m graph.
    fn graph() -> (Arc<WifiGraph>, Vec<[f64; 2]>) {
        let aps_at = vec![[0.0, 0.0], [20.0, 0.0], [0.0, 20.0], [20.0, 20.0]];
        let (w, h) = (25, 25);
        let origin = [-2.0, -2.0];
        let mut mean = Vec::new();
        let mut var = Vec::new();
        for j in 0..h {
            for i in 0..w {
                let p = [origin[0] + i as f64, origin[1] + j as f64];
                for a in &aps_at {
                    mean.push(rssi(*a, p));
                    var.push(0.5);
                }
            }
        }
        let aps = (0..4)
            .map(|k| GraphAp {
                name: format!("ap{k}"),
                kernel: SeKernel {
                    length_scale: 3.0,
                    signal_sd: 5.0,
                    noise_sd: 2.0,
                },
                prior_mean: -70.0,
                heard: 0,
            })
            .collect();
        let g = WifiGraph::from_nodes(origin, 1.0, w, h, aps, mean, var, -90.0).unwrap();
        (Arc::new(g), aps_at)
    }

    fn rssi(ap: [f64; 2], p: [f64; 2]) -> f64 {
        let d = ((ap[0] - p[0]).powi(2) + (ap[1] - p[1]).powi(2) + 4.0).sqrt();
        -40.0 - 30.0 * d.log10()
    }

    fn scan(aps: &[[f64; 2]], p: [f64; 2], drop: Option<usize>) -> Reading {
        Reading::Wifi(WifiScan {
            stamp: 1.0,
            sensor: "wifi".into(),
            readings: aps
                .iter()
                .enumerate()
                .filter(|(k, _)| Some(*k) != drop)
                .map(|(k, a)| WifiReading {
                    ap: format!("ap{k}"),
                    channel: 1,
                    rssi_dbm: rssi(*a, p).round(),
                })
                .collect(),
        })
    }

    fn room_grid() -> OccupancyGrid {
        OccupancyGrid {
            origin: [0.0, 0.0],
            resolution: 0.1,
            width: 200,
            height: 200,
            cells: vec![Cell::Free; 40000],
        }
    }

    /// The 20 × 20 m room of `graph()` with a 0.2 m wall around it (centre lines 0 and 20) and
    /// a 1 m free margin outside, 0.05 m cells: the margin is outside the building.
    fn walled_grid() -> OccupancyGrid {
        let (res, origin, side) = (0.05, [-1.2, -1.2], 448);
        let mut cells = vec![Cell::Free; side * side];
        for j in 0..side {
            for i in 0..side {
                let x = origin[0] + (i as f64 + 0.5) * res;
                let y = origin[1] + (j as f64 + 0.5) * res;
                let on = |v: f64, w: f64| (v - w).abs() <= 0.1;
                let within = |v: f64| (-0.1..=20.1).contains(&v);
                if within(x)
                    && within(y)
                    && (on(x, 0.0) || on(x, 20.0) || on(y, 0.0) || on(y, 20.0))
                {
                    cells[j * side + i] = Cell::Occupied;
                }
            }
        }
        OccupancyGrid {
            origin,
            resolution: res,
            width: side,
            height: side,
            cells,
        }
    }

    fn drive(f: &mut WifiMcl, from: Pose2, to: Pose2, stamp: f64) {
        f.predict(&OdometryDelta { stamp, from, to }).unwrap();
    }

    #[test]
    fn a_particle_set_pushed_out_of_the_building_comes_back() {
        let (g, aps) = graph();
        let init = InitialBelief::Tracking {
            pose: Pose2::new(10.0, 18.5, std::f64::consts::FRAC_PI_2),
            sigma: [0.3, 0.3, 0.02],
        };
        let run = |constrain: bool| {
            let params = WifiMclParams {
                constrain_to_map: constrain,
                ..WifiMclParams::default()
            };
            let mut f =
                WifiMcl::new("wifi", params, g.clone(), &walled_grid(), init.clone(), 5).unwrap();
            // Odometry claims 4 m north: through the north wall (y = 20) and beyond the grid.
            let a = Pose2::new(0.0, 0.0, 0.0);
            drive(&mut f, a, Pose2::new(4.0, 0.0, 0.0), 1.0);
            f.update(&scan(&aps, [10.0, 19.0], None)).unwrap();
            f
        };
        let f = run(true);
        let outside = f.particles().filter(|(p, _)| p.y >= 19.9).count();
        assert_eq!(outside, 0, "every particle is back inside");
        let e = f.estimate().pose;
        assert!(e.y < 19.9 && (e.x - 10.0).abs() < 1.0, "{e:?}");
        // Without the constraint the whole set stays outside, where the graph is clamped.
        let e0 = run(false).estimate().pose;
        assert!(e0.y > 21.5, "{e0:?}");
    }

    #[test]
    fn particles_that_leave_the_building_are_killed() {
        let (g, aps) = graph();
        let mut f = WifiMcl::new(
            "wifi",
            WifiMclParams {
                alpha: [0.0; 4],
                ..WifiMclParams::default()
            },
            g,
            &walled_grid(),
            InitialBelief::Tracking {
                pose: Pose2::new(10.0, 10.0, std::f64::consts::FRAC_PI_2),
                sigma: [0.0; 3],
            },
            2,
        )
        .unwrap();
        // Half the set 0.5 m south of the north wall, half in the middle, all heading north;
        // the WiFi scan alone prefers the wall-side half (it was taken at y = 18).
        for i in 0..f.core.set.len() {
            if i % 2 == 0 {
                let p = f.core.set.pose(i);
                f.core.set.set_pose(i, Pose2::new(p.x, 19.5, p.theta));
            }
        }
        drive(&mut f, Pose2::default(), Pose2::new(1.0, 0.0, 0.0), 1.0);
        f.update(&scan(&aps, [10.0, 18.0], None)).unwrap();
        // The wall-side half went through the outer wall and is gone after resampling; the
        // other half moved freely to y = 11.
        assert!(
            f.particles().all(|(p, _)| (p.y - 11.0).abs() < 1e-9),
            "{:?}",
            f.estimate()
        );
        // ... although the scan alone favoured where the killed half ended (by e^3 or more).
        let (near, far) = (
            f.log_likelihood_at(10.0, 19.8),
            f.log_likelihood_at(10.0, 11.0),
        );
        assert!(near > far + 3.0, "{near} {far}");
    }

    #[test]
    fn global_belief_collapses_onto_the_scan_position() {
        let (g, aps) = graph();
        let mut f = WifiMcl::new(
            "wifi",
            WifiMclParams::default(),
            g,
            &room_grid(),
            InitialBelief::Global { regions: vec![] },
            3,
        )
        .unwrap();
        assert_eq!(f.particle_count(), 30000);
        let truth = [6.0, 13.0];
        for _ in 0..3 {
            f.update(&scan(&aps, truth, None)).unwrap();
        }
        let e = f.estimate().pose;
        assert_eq!(f.particle_count(), 2000);
        assert!((e.x - truth[0]).hypot(e.y - truth[1]) < 1.0, "{e:?}");
    }

    /// `graph()` with its east half (x > 10) never surveyed: there every node holds the GP
    /// prior (mean −70 dBm, variance σ_f² = 25 dB²).
    fn half_surveyed_graph() -> Arc<WifiGraph> {
        let (g, _) = graph();
        let (w, h, n_ap) = (g.width, g.height, g.aps.len());
        let (mut mean, mut var) = (Vec::new(), Vec::new());
        for j in 0..h {
            for i in 0..w {
                let east = g.node_position(i, j)[0] > 10.0;
                for a in 0..n_ap {
                    let (m, v) = g.node(a, i, j);
                    mean.push(if east { -70.0 } else { m });
                    var.push(if east { 25.0 } else { v });
                }
            }
        }
        let aps = g.aps.clone();
        Arc::new(WifiGraph::from_nodes(g.origin, 1.0, w, h, aps, mean, var, -90.0).unwrap())
    }

    /// Scans 6 dB stronger than the survey learnt at the robot's spot fit the unsurveyed
    /// half's wide prior better than any surveyed place; `max_untrained` keeps the cloud on
    /// the surveyed half.
    #[test]
    fn max_untrained_keeps_the_cloud_where_the_survey_was() {
        let (_, aps) = graph();
        let truth = [4.0, 10.0];
        let strong = |r: Reading| match r {
            Reading::Wifi(mut s) => {
                for x in &mut s.readings {
                    x.rssi_dbm += 6.0;
                }
                Reading::Wifi(s)
            }
            other => other,
        };
        // (estimate's x, untrained fraction there)
        let settle = |max_untrained: f64| {
            let params = WifiMclParams {
                max_untrained,
                ..WifiMclParams::default()
            };
            let mut f = WifiMcl::new(
                "wifi",
                params,
                half_surveyed_graph(),
                &room_grid(),
                InitialBelief::Global { regions: vec![] },
                5,
            )
            .unwrap();
            for _ in 0..3 {
                f.update(&strong(scan(&aps, truth, None))).unwrap();
            }
            let e = f.estimate().pose;
            (e.x, f.log_likelihood_and_untrained(e.x, e.y).1)
        };
        let (off, on) = (settle(1.0), settle(0.3));
        assert!(
            off.0 > 12.0 && off.1 > 0.9,
            "without the constraint: {off:?}"
        );
        // With it the cloud stays where the graph is at most 30 % prior: on the survey, or in
        // the one-node band where the graph blends into the prior.
        assert!(on.0 < 11.0 && on.1 <= 0.3, "with it: {on:?}");
        for bad in [0.0, 1.5, f64::NAN] {
            let p = WifiMclParams {
                max_untrained: bad,
                ..WifiMclParams::default()
            };
            assert!(p.validate().unwrap_err().contains("max_untrained"));
        }
    }

    #[test]
    fn a_missing_strong_access_point_is_evidence_against() {
        let (g, aps) = graph();
        let mut f = WifiMcl::new(
            "wifi",
            WifiMclParams::default(),
            g,
            &room_grid(),
            InitialBelief::Tracking {
                pose: Pose2::new(10.0, 10.0, 0.0),
                sigma: [0.0; 3],
            },
            1,
        )
        .unwrap();
        // Near ap0 (−53 dBm expected) a scan without ap0 is far less likely than one with it.
        let p = [1.0, 1.0];
        let Reading::Wifi(with) = scan(&aps, p, None) else {
            unreachable!()
        };
        let Reading::Wifi(without) = scan(&aps, p, Some(0)) else {
            unreachable!()
        };
        f.load_scan(&with);
        let l_with = f.log_likelihood_at(p[0], p[1]);
        f.load_scan(&without);
        let l_without = f.log_likelihood_at(p[0], p[1]);
        assert!(l_without < l_with - 2.0, "{l_with} {l_without}");
        // Far from ap0 (in the opposite corner, ~−80 dBm) missing it costs less.
        let q = [19.0, 19.0];
        let l_far_without = f.log_likelihood_at(q[0], q[1]);
        assert!(l_far_without.is_finite());
        // Unknown APs are counted.
        let mut odd = with.clone();
        odd.readings[0].ap = "stranger".into();
        f.load_scan(&odd);
        assert_eq!(f.unknown_readings(), 1);
    }

    #[test]
    fn normal_cdf_matches_known_values() {
        for (z, p) in [
            (0.0, 0.5),
            (1.0, 0.841_344_746),
            (-2.0, 0.022_750_132),
            (3.0, 0.998_650_102),
        ] {
            assert!((normal_cdf(z) - p).abs() < 1e-7, "{z}");
        }
    }

    #[test]
    fn global_particles_above_the_limit_are_refused() {
        let p = |n: usize| WifiMclParams {
            global_particles: n,
            ..WifiMclParams::default()
        };
        assert!(p(crate::limits::MAX_GLOBAL_PARTICLES).validate().is_ok());
        assert_eq!(
            p(crate::limits::MAX_GLOBAL_PARTICLES + 1)
                .validate()
                .unwrap_err(),
            "global_particles: 10000001 is more than the limit of 10000000 (MAX_GLOBAL_PARTICLES)"
        );
    }
}
