//! Monte Carlo localization (Dellaert et al. 1999; Thrun et al., *Probabilistic Robotics*,
//! Table 8.2 and, for random-particle injection, Augmented MCL, Table 8.3) with the odometry
//! motion model, the likelihood-field laser model, low-variance resampling and KLD-sampling.

use crate::error::LocalizationError;
use crate::filter::cluster::PointEstimate;
use crate::filter::initial_belief::{check_gaussian, gaussian_pose};
use crate::filter::kld::KldSampling;
use crate::filter::motion::OdometryMotionModel;
use crate::filter::observation_fit::FitTracker;
use crate::filter::particle_filter::{core_in_field, FilterCore, MeasurementModel, ParticleFilter};
use crate::filter::particles::Headings;
use crate::filter::resampling::ResamplePolicy;
use crate::limits::{
    check_count, check_count_min1, check_grid, check_positive, MAX_BEAMS, MAX_GLOBAL_PARTICLES,
    MCL_MAX_GRID_CELLS,
};
use crate::sensor_models::beam_model::{beam_probability, cast_rays, BeamModelParams};
use crate::sensor_models::likelihood_field::{
    validate_grid, LikelihoodField, LikelihoodFieldParams,
};
use crate::sensor_models::scan_match::{refine, CoarseDistance, ScanMatchParams};
use atrium_robots::{normalize_angle, LaserScan, Pose2, Reading};
use atrium_worlds::geometry::point_in_polygon;
use atrium_worlds::{Cell, OccupancyGrid};
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Range the likelihood table is first built for; rebuilt in place at the first scan whose
/// `range_max` differs.
const NOMINAL_RANGE_MAX: f64 = 8.0;

/// MCL parameters, as written in a scenario file. Every field has a default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MclParams {
    /// Lower bound of the KLD-adapted particle count. Default 500.
    pub min_particles: usize,
    /// Upper bound of the KLD-adapted particle count (and the global-localization count).
    /// Default 5000.
    pub max_particles: usize,
    /// Odometry motion model α1–α4 (see [`OdometryMotionModel`]). Default 0.05 each.
    pub alpha: [f64; 4],
    /// KLD-sampling error bound ε. Default 0.05.
    pub kld_epsilon: f64,
    /// KLD-sampling confidence 1 − δ. Default δ = 0.01.
    pub kld_delta: f64,
    /// KLD histogram bin size (x m, y m, θ rad). Default (0.2, 0.2, 10°).
    pub kld_bin: [f64; 3],
    /// Likelihood-field hit standard deviation, metres. Default 0.2 (as ROS amcl). Measured on
    /// the test room: 0.08 loses global localization in 8 of 30 seeds (the basin around the
    /// true pose is too narrow for 5000 particles to land in), 0.15 in 2, 0.2 in none, while
    /// the mean tracking error only goes from 5.0 to 5.5 cm.
    pub sigma_hit: f64,
    /// Weight of the hit Gaussian. Default 0.95.
    pub z_hit: f64,
    /// Weight of the uniform random-reading density 1/range_max. Default 0.05.
    pub z_rand: f64,
    /// Beams used per scan, evenly spread over the valid ones. Default 60.
    pub max_beams: usize,
    /// Resolution of the likelihood field, metres; the map is resampled to it if it differs.
    /// Default 0.02 (see docs/design/0005-likelihood-field.md: coarser cells bias the estimate along corridors).
    pub grid_resolution: f64,
    /// Distance cap of the likelihood field, metres. Default 2.0.
    pub max_dist: f64,
    /// Augmented-MCL long-term likelihood average rate (0.001 is usual when enabled). Default
    /// 0, with alpha_fast 0: no random-particle injection, as in ROS amcl. Injection is what
    /// recovers from a kidnapping, but where the map misses what the laser sees (glass,
    /// clutter) the average likelihood drops without the robot being lost, and injected
    /// particles then pull the estimate away (measured: 50 m errors in the glass corridor).
    pub alpha_slow: f64,
    /// Augmented-MCL short-term likelihood average rate (0.1 is usual when enabled). Default 0.
    pub alpha_fast: f64,
    /// Skip the sensor update until the robot has moved this far (m) since the last one.
    /// Default 0: update on every scan.
    pub update_min_d: f64,
    /// Skip the sensor update until the robot has turned this much (rad). Default 0.
    pub update_min_a: f64,
    /// The reported estimate: `"heaviest_cluster"` (default, as ROS amcl: the weighted mean of
    /// the cluster of 0.5 m × 10° bins with the most weight) or `"weighted_mean"` of the whole
    /// set, which lands between the modes of a split cloud ([004] §3's open-area errors).
    pub estimate: PointEstimate,
    /// The laser model: `"likelihood_field"` (default; [Thrun 2005] §6.4) or `"beam"`
    /// ([Thrun 2005] §6.3: every beam ray-cast on the map, max-range readings included;
    /// about ten times slower per beam, see `beam_model`).
    pub sensor_model: SensorModel,
    /// Beam model: weight of unexpected short readings. Default 0.1 (ROS amcl's).
    pub z_short: f64,
    /// Beam model: weight of max-range failures. Default 0.05 (ROS amcl's).
    pub z_max: f64,
    /// Beam model: rate of the short-reading exponential, 1/m. Default 0.1 (ROS amcl's).
    pub lambda_short: f64,
    /// Resample only when the effective sample size falls below this fraction of the
    /// particles; between resamplings the weights carry the evidence of every scan. Default 0:
    /// after every update, as ROS amcl. Resampling every scan makes the weight of each of
    /// several hypotheses a random walk, and a globally localizing filter can lose the true
    /// one before the robot sees what tells them apart ([Thrun 2005] §4.3.4).
    pub resample_ess: f64,
    /// Global belief only: seed the filter from its first scan instead of uniformly. This
    /// many poses are drawn uniformly over the belief, the max_particles whose scan endpoints
    /// lie closest to the walls are kept and each is brought into its local optimum by scan
    /// matching (`scan_match`), and the first update weighs those. Uniform particles almost
    /// never fall within the degree and decimetre of the true pose that a sharp field
    /// (sigma_hit 0.1 m, 60 beams) rewards, so an aliased place that a particle happens to
    /// fit wins ([Thrun 2001]; measured on `global_localization`, docs/design/0007). The kept poses
    /// are weighed by the likelihood alone, not divided by how densely the matcher gathers
    /// them: each local optimum stands for a hypothesis. Default 0: uniform particles.
    pub global_samples: usize,
    /// With recovery (alpha_slow, alpha_fast): draw half of the particles Augmented MCL
    /// injects from the current scan, the other half uniformly. At an update that injects,
    /// this many poses are drawn uniformly over the map's free space, the best hundredth by
    /// truncated endpoint cost is refined by scan matching as `global_samples` does, and each
    /// scan-drawn particle takes one of them: sensor resetting, the dual proposal of
    /// [Thrun 2001]. A uniform particle almost never lands in the decimetre and degree a sharp
    /// field rewards, so after a kidnapping recovery waits for luck; the uniform half covers
    /// a scan that matches look-alike places better than the true one (measured on
    /// `kidnapped`, docs/design/0007). Default 0: uniform injection only.
    pub inject_from_scan: usize,
    /// Likelihood field only: beam skipping, as ROS amcl's `do_beamskip` [amcl]. A beam
    /// whose endpoint lies within this distance (metres) of a wall for fewer than
    /// `beam_skip_threshold` of the particles is left out of the update: where nearly every
    /// particle finds it unexplained, it sees something the map does not hold (a table's legs
    /// under a footprint the map fills, a door jamb's corner), and its z_rand floor against
    /// the few particles that happen to put it on a wall swings the estimate (measured on
    /// `corridor_tracking` seed 2: one beam through a door moved it 5 cm along the corridor,
    /// docs/design/0008). Default 0: every beam is used.
    pub beam_skip_distance: f64,
    /// Fraction of the particles below which a beam is skipped. Default 0.3 (amcl's).
    pub beam_skip_threshold: f64,
    /// When more than this fraction of a scan's beams would be skipped, none is: the
    /// particles disagree with the scan as a whole (global localization, a kidnapping), and
    /// skipping would hide it. Default 0.9 (amcl's).
    pub beam_skip_error_threshold: f64,
}

/// Which laser model an MCL filter weighs particles with.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SensorModel {
    #[default]
    LikelihoodField,
    Beam,
}

impl Default for MclParams {
    fn default() -> Self {
        Self {
            min_particles: 500,
            max_particles: 5000,
            alpha: [0.05; 4],
            kld_epsilon: 0.05,
            kld_delta: 0.01,
            kld_bin: [0.2, 0.2, 10f64.to_radians()],
            sigma_hit: 0.2,
            z_hit: 0.95,
            z_rand: 0.05,
            max_beams: 60,
            grid_resolution: 0.02,
            max_dist: 2.0,
            alpha_slow: 0.0,
            alpha_fast: 0.0,
            update_min_d: 0.0,
            update_min_a: 0.0,
            estimate: PointEstimate::default(),
            sensor_model: SensorModel::default(),
            z_short: 0.1,
            z_max: 0.05,
            lambda_short: 0.1,
            resample_ess: 0.0,
            global_samples: 0,
            inject_from_scan: 0,
            beam_skip_distance: 0.0,
            beam_skip_threshold: 0.3,
            beam_skip_error_threshold: 0.9,
        }
    }
}

impl MclParams {
    /// The beam model's parameters (z_hit, z_rand and sigma_hit are the field's).
    pub fn beam_params(&self) -> BeamModelParams {
        BeamModelParams {
            z_hit: self.z_hit,
            z_short: self.z_short,
            z_max: self.z_max,
            z_rand: self.z_rand,
            sigma_hit: self.sigma_hit,
            lambda_short: self.lambda_short,
        }
    }

    /// When the filter resamples.
    pub fn resample_policy(&self) -> ResamplePolicy {
        ResamplePolicy::from_resample_ess(self.resample_ess)
    }

    /// Checks every field; the error names the field and the offending value.
    pub fn validate(&self) -> Result<(), String> {
        let non_negative = |name: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{name} must be finite and >= 0, got {v}"))
            }
        };
        if self.min_particles == 0 {
            return Err("min_particles must be >= 1, got 0".into());
        }
        if self.max_particles < self.min_particles {
            return Err(format!(
                "max_particles ({}) must be >= min_particles ({})",
                self.max_particles, self.min_particles
            ));
        }
        check_count_min1(
            "max_particles",
            self.max_particles,
            MAX_GLOBAL_PARTICLES,
            "MAX_GLOBAL_PARTICLES",
        )?;
        check_count(
            "global_samples",
            self.global_samples,
            MAX_GLOBAL_PARTICLES,
            "MAX_GLOBAL_PARTICLES",
        )?;
        check_count(
            "inject_from_scan",
            self.inject_from_scan,
            MAX_GLOBAL_PARTICLES,
            "MAX_GLOBAL_PARTICLES",
        )?;
        for (i, a) in self.alpha.iter().enumerate() {
            non_negative(&format!("alpha[{i}]"), *a)?;
        }
        check_positive("kld_epsilon", self.kld_epsilon)?;
        if !(self.kld_delta > 0.0 && self.kld_delta < 1.0) {
            return Err(format!(
                "kld_delta must be in (0, 1), got {}",
                self.kld_delta
            ));
        }
        for (i, b) in self.kld_bin.iter().enumerate() {
            check_positive(&format!("kld_bin[{i}]"), *b)?;
        }
        check_positive("sigma_hit", self.sigma_hit)?;
        non_negative("z_hit", self.z_hit)?;
        // z_rand is the floor of every beam's likelihood (and the value off the map): with 0
        // one unexplained beam would veto a particle outright.
        check_positive("z_rand", self.z_rand)?;
        check_count_min1("max_beams", self.max_beams, MAX_BEAMS, "MAX_BEAMS")?;
        check_positive("grid_resolution", self.grid_resolution)?;
        check_positive("max_dist", self.max_dist)?;
        non_negative("alpha_slow", self.alpha_slow)?;
        non_negative("alpha_fast", self.alpha_fast)?;
        if self.alpha_slow > 1.0 || self.alpha_fast > 1.0 {
            return Err(format!(
                "alpha_slow ({}) and alpha_fast ({}) must be <= 1",
                self.alpha_slow, self.alpha_fast
            ));
        }
        if self.recovery_enabled() && self.alpha_slow >= self.alpha_fast {
            return Err(format!(
                "alpha_slow ({}) must be < alpha_fast ({}) (both 0 disables recovery)",
                self.alpha_slow, self.alpha_fast
            ));
        }
        non_negative("update_min_d", self.update_min_d)?;
        non_negative("update_min_a", self.update_min_a)?;
        if !(self.resample_ess.is_finite() && (0.0..=1.0).contains(&self.resample_ess)) {
            return Err(format!(
                "resample_ess must be a fraction in [0, 1], got {}",
                self.resample_ess
            ));
        }
        non_negative("beam_skip_distance", self.beam_skip_distance)?;
        for (name, v) in [
            ("beam_skip_threshold", self.beam_skip_threshold),
            ("beam_skip_error_threshold", self.beam_skip_error_threshold),
        ] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return Err(format!("{name} must be a fraction in [0, 1], got {v}"));
            }
        }
        self.beam_params().validate()?;
        Ok(())
    }

    /// Checks the size of the likelihood field this filter builds over a map `extent` metres
    /// wide and high (at `grid_resolution`) against [`MCL_MAX_GRID_CELLS`], before anything
    /// is built; the message gives the cells it would need and the finest resolution that fits.
    pub fn check_field_size(&self, extent: [f64; 2]) -> Result<(), String> {
        check_grid(
            "grid_resolution",
            self.grid_resolution,
            extent,
            "map",
            MCL_MAX_GRID_CELLS,
            "MCL_MAX_GRID_CELLS",
        )
    }

    fn recovery_enabled(&self) -> bool {
        self.alpha_slow > 0.0 || self.alpha_fast > 0.0
    }
}

/// Where the robot may be at the start (defined with the steps every filter shares).
pub use crate::filter::initial_belief::InitialBelief;

/// Monte Carlo localization on an occupancy grid with a laser.
#[derive(Debug, Clone)]
pub struct Mcl {
    /// Up to max_particles particles; the carried estimate is the one at the last sensor
    /// update (before resampling).
    core: FilterCore,
    params: MclParams,
    /// Shared with every filter built from the same [`MclMap`]; copied on write only if a
    /// scan's range_max differs from the one the table was built for.
    field: Arc<LikelihoodField>,
    motion: OdometryMotionModel,
    /// The KLD-adapted size and the bins it counts.
    kld: KldSampling,
    /// Selected beam endpoints in the robot base frame.
    beams: Beams,
    /// The sensor update's scratch.
    beam_scratch: BeamScratch,
    /// Free cells of the field grid, for random injection.
    free_cells: Arc<Vec<u32>>,
    grid_origin: [f64; 2],
    grid_resolution: f64,
    grid_width: usize,
    updated_once: bool,
    /// The belief's free cells while the first scan has yet to seed a global belief (see
    /// `global_samples`).
    seed_from_scan: Option<Arc<Vec<u32>>>,
    /// The field on 0.1 m cells, built at the first draw from a scan.
    coarse: Option<Arc<CoarseDistance>>,
    w_slow: f64,
    w_fast: f64,
    /// Sensing mismatch (004 §4.2) per beam, on its own time-based averages (w_slow and
    /// w_fast above exist only with recovery enabled and run per update).
    fit: FitTracker,
}

/// What an MCL filter derives from its map: the likelihood field (a distance transform and a
/// log-likelihood table) and the free cells for random particles. It is a pure function of
/// the occupancy grid and the field parameters, and costs far more than running a short
/// trial, so a sweep builds it once and shares it between filters ([`Mcl::with_map`]).
#[derive(Debug, Clone)]
pub struct MclMap {
    field: Arc<LikelihoodField>,
    free_cells: Arc<Vec<u32>>,
    origin: [f64; 2],
    resolution: f64,
    width: usize,
    height: usize,
    /// The MclParams fields the map depends on: z_hit, z_rand, sigma_hit, max_dist,
    /// grid_resolution.
    built_for: [f64; 5],
}

fn field_key(p: &MclParams) -> [f64; 5] {
    [
        p.z_hit,
        p.z_rand,
        p.sigma_hit,
        p.max_dist,
        p.grid_resolution,
    ]
}

impl MclMap {
    /// Builds the field of `grid` (resampled to `params.grid_resolution` if it differs) for
    /// scans of `range_max` metres (a filter seeing another range_max rebuilds its own copy
    /// of the table at the first such scan).
    pub fn new(
        grid: &OccupancyGrid,
        params: &MclParams,
        range_max: f64,
    ) -> Result<MclMap, LocalizationError> {
        Self::with_field(grid, params, range_max, LikelihoodField::new)
    }

    /// As [`MclMap::new`], with the likelihood field made by `field`, called with the grid it
    /// is for (resampled if need be) and its parameters: a caller that kept the field of an
    /// earlier build (an on-disk cache) makes it from the kept parts
    /// ([`LikelihoodField::from_tables`]) instead of computing it; it must be what
    /// [`LikelihoodField::new`] makes. A field of another frame, size or parameters is
    /// refused.
    pub fn with_field(
        grid: &OccupancyGrid,
        params: &MclParams,
        range_max: f64,
        field: impl FnOnce(
            &OccupancyGrid,
            LikelihoodFieldParams,
        ) -> Result<LikelihoodField, LocalizationError>,
    ) -> Result<MclMap, LocalizationError> {
        params
            .validate()
            .map_err(LocalizationError::InvalidParameter)?;
        validate_grid(grid)?;
        let extent = [
            grid.width as f64 * grid.resolution,
            grid.height as f64 * grid.resolution,
        ];
        params
            .check_field_size(extent)
            .map_err(LocalizationError::InvalidParameter)?;
        let resampled;
        let grid =
            if (grid.resolution - params.grid_resolution).abs() > 1e-9 * params.grid_resolution {
                resampled = resample_grid(grid, params.grid_resolution);
                &resampled
            } else {
                grid
            };
        let field_params = LikelihoodFieldParams {
            z_hit: params.z_hit,
            z_rand: params.z_rand,
            sigma_hit: params.sigma_hit,
            max_dist: params.max_dist,
            range_max,
        };
        field_params
            .validate()
            .map_err(LocalizationError::InvalidParameter)?;
        let field = field(grid, field_params)?;
        let fits = field.origin() == grid.origin
            && field.resolution() == grid.resolution
            && field.size() == (grid.width, grid.height)
            && *field.params() == field_params;
        if !fits {
            return Err(LocalizationError::InvalidParameter(
                "the likelihood field given for the MclMap is of another grid or parameters"
                    .to_owned(),
            ));
        }
        let free_cells: Vec<u32> = grid
            .cells
            .iter()
            .enumerate()
            .filter(|(_, c)| **c == Cell::Free)
            .map(|(k, _)| k as u32)
            .collect();
        Ok(MclMap {
            field: Arc::new(field),
            free_cells: Arc::new(free_cells),
            origin: grid.origin,
            resolution: grid.resolution,
            width: grid.width,
            height: grid.height,
            built_for: field_key(params),
        })
    }

    /// The likelihood field (its distances, parameters and table).
    pub fn field(&self) -> &LikelihoodField {
        &self.field
    }
}

impl Mcl {
    pub fn new(
        name: &str,
        params: MclParams,
        grid: &OccupancyGrid,
        init: InitialBelief,
        seed: u64,
    ) -> Result<Mcl, LocalizationError> {
        let map = MclMap::new(grid, &params, NOMINAL_RANGE_MAX)?;
        Self::with_map(name, params, &map, init, seed)
    }

    /// A filter on a prepared (possibly shared) map; `map` must have been built for the same
    /// field parameters (z_hit, z_rand, sigma_hit, max_dist, grid_resolution) as `params`.
    pub fn with_map(
        name: &str,
        params: MclParams,
        map: &MclMap,
        init: InitialBelief,
        seed: u64,
    ) -> Result<Mcl, LocalizationError> {
        params
            .validate()
            .map_err(LocalizationError::InvalidParameter)?;
        if map.built_for != field_key(&params) {
            return Err(LocalizationError::InvalidParameter(
                "the MclMap was built for other likelihood-field parameters".to_owned(),
            ));
        }
        let m = params.max_particles;
        let capacity = match init {
            InitialBelief::Global { .. } | InitialBelief::Tracking { .. } => m,
        };
        let mut mcl = Mcl {
            core: FilterCore::new(name, capacity, seed),
            motion: OdometryMotionModel::new(params.alpha),
            kld: KldSampling::new(
                params.min_particles,
                m,
                params.kld_epsilon,
                params.kld_delta,
                params.kld_bin,
            ),
            beams: Beams::with_capacity(params.max_beams),
            beam_scratch: BeamScratch {
                row: Vec::with_capacity(capacity),
                headings: Headings::with_capacity(capacity),
                dirs: Vec::with_capacity(params.max_beams),
                ranges: Vec::with_capacity(params.max_beams),
            },
            free_cells: map.free_cells.clone(),
            grid_origin: map.origin,
            grid_resolution: map.resolution,
            grid_width: map.width,
            updated_once: false,
            seed_from_scan: None,
            coarse: None,
            w_slow: 0.0,
            w_fast: 0.0,
            fit: Default::default(),
            field: map.field.clone(),
            params,
        };
        mcl.initialise((map.width, map.height), &init)?;
        Ok(mcl)
    }

    /// Draws the initial set with KLD-sampling proper (Fox 2003): particles are drawn one at
    /// a time until their number reaches the bound for the bins they occupy.
    fn initialise(
        &mut self,
        grid_size: (usize, usize),
        init: &InitialBelief,
    ) -> Result<(), LocalizationError> {
        let mut region_cells: Vec<u32> = Vec::new();
        match init {
            InitialBelief::Tracking { pose, sigma } => check_gaussian(pose, sigma)?,
            InitialBelief::Global { regions } => {
                for (r, poly) in regions.iter().enumerate() {
                    if poly.len() < 3 {
                        return Err(LocalizationError::belief(
                            "regions",
                            format!("polygon {r} has {} vertices, needs at least 3", poly.len()),
                        ));
                    }
                    if poly.iter().any(|p| !(p[0].is_finite() && p[1].is_finite())) {
                        return Err(LocalizationError::belief(
                            "regions",
                            format!("polygon {r} has a non-finite vertex"),
                        ));
                    }
                }
                if regions.is_empty() {
                    region_cells.clone_from(&self.free_cells);
                } else {
                    region_cells = self
                        .free_cells
                        .iter()
                        .copied()
                        .filter(|&k| {
                            let c = self.cell_centre(k);
                            regions.iter().any(|poly| point_in_polygon(c, poly))
                        })
                        .collect();
                }
                if region_cells.is_empty() {
                    return Err(LocalizationError::belief(
                        "regions",
                        if regions.is_empty() {
                            format!(
                                "the map ({} × {}) has no Free cell",
                                grid_size.0, grid_size.1
                            )
                        } else {
                            "no Free cell of the map lies inside the polygons".to_owned()
                        },
                    ));
                }
            }
        }
        let (origin, res, width) = (self.grid_origin, self.grid_resolution, self.grid_width);
        self.core
            .set
            .sample_kld(&mut self.kld, &mut self.core.rng, |rng| match init {
                InitialBelief::Tracking { pose, sigma } => gaussian_pose(pose, sigma, rng),
                InitialBelief::Global { .. } => random_pose(&region_cells, origin, res, width, rng),
            });
        if matches!(init, InitialBelief::Global { .. }) && self.params.global_samples > 0 {
            self.seed_from_scan = Some(Arc::new(region_cells));
        }
        self.core.refresh_estimate(self.params.estimate);
        Ok(())
    }

    fn cell_centre(&self, k: u32) -> [f64; 2] {
        let k = k as usize;
        let (i, j) = (k % self.grid_width, k / self.grid_width);
        [
            self.grid_origin[0] + (i as f64 + 0.5) * self.grid_resolution,
            self.grid_origin[1] + (j as f64 + 0.5) * self.grid_resolution,
        ]
    }

    pub fn params(&self) -> &MclParams {
        &self.params
    }

    pub fn particle_count(&self) -> usize {
        self.core.set.len()
    }

    /// Probability of replacing a particle by a random one at the next resampling
    /// (Augmented MCL): max(0, 1 − w_fast / w_slow).
    pub fn injection_probability(&self) -> f64 {
        if !self.params.recovery_enabled() || self.w_slow <= 0.0 {
            0.0
        } else {
            (1.0 - self.w_fast / self.w_slow).max(0.0)
        }
    }

    /// Replaces the particles by max_particles poses drawn from `scan` (see
    /// `global_samples`). False, leaving the particles alone, for a scan without a valid beam.
    fn seed_global_from_scan(&mut self, scan: &LaserScan, cells: &[u32]) -> bool {
        let mut endpoints = Beams::with_capacity(self.params.max_beams);
        if endpoints.select_endpoints(scan, self.params.max_beams) == 0 {
            return false;
        }
        let coarse = self.coarse_distance();
        let draw = PoseDraw {
            cells,
            origin: self.grid_origin,
            resolution: self.grid_resolution,
            width: self.grid_width,
        };
        let poses: Vec<Pose2> = scan_candidates(
            &coarse,
            &endpoints,
            &draw,
            self.params.global_samples,
            self.params.max_particles,
            &mut self.core.rng,
        )
        .into_iter()
        .map(|p| refine_on_scan(&self.field, &endpoints, p))
        .collect();
        for (i, q) in poses.iter().enumerate() {
            self.core.set.set_pose(i, *q);
        }
        self.core.set.make_uniform(poses.len());
        true
    }

    /// The field on 0.1 m cells, for ranking poses drawn from a scan (see
    /// [`CoarseDistance`]); built once and shared by copies of the filter.
    fn coarse_distance(&mut self) -> Arc<CoarseDistance> {
        let res = self.grid_resolution;
        let field = &self.field;
        self.coarse
            .get_or_insert_with(|| {
                Arc::new(CoarseDistance::new(
                    field,
                    (0.1 / res).round().max(1.0) as usize,
                ))
            })
            .clone()
    }

    /// The sensor model's log-likelihood of `scan` at each of `poses` of the robot, with the
    /// beams an update would use: what the filter weighs a pose by, for diagnostics.
    pub fn scan_log_likelihoods(&self, scan: &LaserScan, poses: &[Pose2]) -> Vec<f64> {
        let mut field = std::borrow::Cow::Borrowed(self.field.as_ref());
        if needs_range(&field, scan.range_max) {
            field.to_mut().set_range_max(scan.range_max);
        }
        let mut beams = Beams::with_capacity(self.params.max_beams);
        let mut out = vec![0.0; poses.len()];
        if beams.select(scan, &self.params) > 0 {
            let x: Vec<f64> = poses.iter().map(|p| p.x).collect();
            let y: Vec<f64> = poses.iter().map(|p| p.y).collect();
            let th: Vec<f64> = poses.iter().map(|p| p.theta).collect();
            let model = ScanModel::new(&field, &self.params, &beams, scan);
            model.log_likelihoods(&x, &y, &th, &mut out, &mut BeamScratch::default());
        }
        out
    }
}

/// Uniform poses over the given cells of a grid (see [`random_pose`]).
struct PoseDraw<'a> {
    cells: &'a [u32],
    origin: [f64; 2],
    resolution: f64,
    width: usize,
}

impl PoseDraw<'_> {
    fn random<R: Rng + ?Sized>(&self, rng: &mut R) -> Pose2 {
        random_pose(self.cells, self.origin, self.resolution, self.width, rng)
    }
}

/// Poses drawn from a scan (`endpoints`, in the robot frame): `samples` uniform poses, the
/// `keep` whose endpoints have the least truncated cost on `coarse`, to be refined by
/// [`refine_on_scan`]. What `global_samples` seeds a belief with and `inject_from_scan`
/// injects ([Thrun 2001]'s dual proposal).
fn scan_candidates<R: Rng + ?Sized>(
    coarse: &CoarseDistance,
    endpoints: &Beams,
    draw: &PoseDraw,
    samples: usize,
    keep: usize,
    rng: &mut R,
) -> Vec<Pose2> {
    let params = ScanMatchParams::default();
    let poses: Vec<Pose2> = (0..samples).map(|_| draw.random(rng)).collect();
    let mut costs = vec![0.0; samples];
    coarse.truncated_costs(
        &endpoints.x,
        &endpoints.y,
        &poses,
        params.truncation,
        &mut costs,
    );
    let mut candidates: Vec<(f64, Pose2)> = costs.into_iter().zip(poses).collect();
    let keep = keep.min(candidates.len());
    if keep < candidates.len() {
        candidates.select_nth_unstable_by(keep, |a, b| a.0.total_cmp(&b.0));
        candidates.truncate(keep);
    }
    candidates.into_iter().map(|(_, p)| p).collect()
}

/// A candidate pose refined by scan matching the endpoints on `field`.
fn refine_on_scan(field: &LikelihoodField, endpoints: &Beams, pose: Pose2) -> Pose2 {
    refine(
        field,
        &endpoints.x,
        &endpoints.y,
        pose,
        &ScanMatchParams::default(),
    )
    .0
}

/// Whether the field's table must be rebuilt for scans of `range_max` (the same test as
/// [`LikelihoodField::set_range_max`]'s, so a shared table is copied only when it will
/// really change).
fn needs_range(field: &LikelihoodField, range_max: f64) -> bool {
    range_max != field.params().range_max && range_max.is_finite() && range_max > 0.0
}

/// The beams of one scan an update weighs, selected by [`Beams::select`]. Likelihood field:
/// endpoints in the base frame; beam model: angles in the laser frame and ranges.
#[derive(Debug, Clone)]
struct Beams {
    x: Vec<f64>,
    y: Vec<f64>,
}

impl Beams {
    fn with_capacity(n: usize) -> Beams {
        Beams {
            x: Vec::with_capacity(n),
            y: Vec::with_capacity(n),
        }
    }

    /// Picks up to max_beams beams, evenly spread over the usable ones; returns how many.
    /// Likelihood field: see [`Beams::select_endpoints`]. Beam model: every beam with a
    /// reading, max-range ones included (they say "nothing within range here"), as angles
    /// and ranges.
    fn select(&mut self, scan: &LaserScan, params: &MclParams) -> usize {
        match params.sensor_model {
            SensorModel::LikelihoodField => self.select_endpoints(scan, params.max_beams),
            SensorModel::Beam => {
                self.x.clear();
                self.y.clear();
                let (bx, by) = (&mut self.x, &mut self.y);
                let usable = |r: f64| r.is_finite() && r >= scan.range_min;
                evenly_spread(&scan.ranges, usable, params.max_beams, |i| {
                    bx.push(scan.beam_angle(i));
                    by.push(scan.ranges[i].min(scan.range_max));
                });
                self.x.len()
            }
        }
    }

    /// The endpoints (base frame) of up to `max` valid beams, evenly spread over them (a
    /// max-range reading has no endpoint); returns how many.
    fn select_endpoints(&mut self, scan: &LaserScan, max: usize) -> usize {
        self.x.clear();
        self.y.clear();
        let (bx, by) = (&mut self.x, &mut self.y);
        let valid = |r: f64| r.is_finite() && r >= scan.range_min && r < scan.range_max;
        evenly_spread(&scan.ranges, valid, max, |i| {
            let (a, r) = (scan.beam_angle(i), scan.ranges[i]);
            let p = scan.mount.transform_point([r * a.cos(), r * a.sin()]);
            bx.push(p[0]);
            by.push(p[1]);
        });
        self.x.len()
    }
}

/// The sensor update's buffers, kept between updates: the particles' headings' sines and
/// cosines, and (for beam skipping) one beam's log-likelihoods from every particle.
#[derive(Debug, Clone, Default)]
struct BeamScratch {
    row: Vec<f64>,
    headings: Headings,
    /// The beam model's ray directions (cos, sin) and predicted ranges for one particle.
    dirs: Vec<(f64, f64)>,
    ranges: Vec<f64>,
}

/// The laser model of one scan: the selected beams and the map they are weighed on.
struct ScanModel<'a> {
    field: &'a LikelihoodField,
    params: &'a MclParams,
    beams: &'a Beams,
    mount: Pose2,
    range_max: f64,
}

impl<'a> ScanModel<'a> {
    fn new(
        field: &'a LikelihoodField,
        params: &'a MclParams,
        beams: &'a Beams,
        scan: &LaserScan,
    ) -> ScanModel<'a> {
        ScanModel {
            field,
            params,
            beams,
            mount: scan.mount,
            range_max: scan.range_max,
        }
    }

    /// Fills `out` with the log-likelihood of the scan at each robot pose (x, y, θ); returns
    /// how many beams it used.
    fn log_likelihoods(
        &self,
        x: &[f64],
        y: &[f64],
        th: &[f64],
        out: &mut [f64],
        scratch: &mut BeamScratch,
    ) -> usize {
        let (field, mount, range_max) = (self.field, self.mount, self.range_max);
        let (bx, by) = (&self.beams.x[..], &self.beams.y[..]);
        let p = self.params;
        match p.sensor_model {
            SensorModel::LikelihoodField if p.beam_skip_distance > 0.0 => {
                // One beam at a time, so that its row stays in cache: the row is added to
                // the sums when enough particles explain the beam, in beam order as the plain
                // sum adds them.
                let n = x.len();
                let BeamScratch { row, headings, .. } = scratch;
                row.resize(n, 0.0);
                let poses = headings.poses(x, y, th);
                let hit = field.log_likelihood_at_distance(p.beam_skip_distance);
                let min_explained = p.beam_skip_threshold * n as f64;
                out.fill(0.0);
                let mut n_kept = 0;
                for (&u, &v) in bx.iter().zip(by) {
                    field.beam_log_likelihoods((u, v), poses, row);
                    let explained = row.iter().filter(|l| **l >= hit).count();
                    if explained as f64 >= min_explained {
                        n_kept += 1;
                        for (o, l) in out.iter_mut().zip(row.iter()) {
                            *o += l;
                        }
                    }
                }
                let skipped = (bx.len() - n_kept) as f64;
                if skipped > p.beam_skip_error_threshold * bx.len() as f64 {
                    // Most beams unexplained: the cloud is lost, not the beams cluttered.
                    field.scan_log_likelihoods(bx, by, poses, out);
                    bx.len()
                } else {
                    n_kept
                }
            }
            SensorModel::LikelihoodField => {
                let poses = scratch.headings.poses(x, y, th);
                field.scan_log_likelihoods(bx, by, poses, out);
                bx.len()
            }
            SensorModel::Beam => {
                let bp = p.beam_params();
                let BeamScratch { dirs, ranges, .. } = scratch;
                ranges.resize(bx.len(), 0.0);
                for (i, l) in out.iter_mut().enumerate() {
                    let o = Pose2::new(x[i], y[i], th[i]).compose(&mount);
                    dirs.clear();
                    dirs.extend(bx.iter().map(|&a| {
                        let (s, c) = (o.theta + a).sin_cos();
                        (c, s)
                    }));
                    // A particle's rays together, so that their lookups overlap.
                    cast_rays(field, (o.x, o.y), dirs, range_max, ranges);
                    *l = 0.0;
                    for (&z, &z_star) in by.iter().zip(ranges.iter()) {
                        *l += beam_probability(z, z_star, range_max, &bp).ln();
                    }
                }
                bx.len()
            }
        }
    }
}

/// Calls `take` with the indices of up to `max` of the `ranges` that are `usable`, evenly
/// spread over the usable ones (the first always among them), in order.
fn evenly_spread(
    ranges: &[f64],
    usable: impl Fn(f64) -> bool,
    max: usize,
    mut take: impl FnMut(usize),
) {
    let n_usable = ranges.iter().filter(|r| usable(**r)).count();
    let m = max.min(n_usable);
    let (mut taken, mut next, mut v) = (0usize, 0usize, 0usize);
    for (i, &r) in ranges.iter().enumerate() {
        if taken == m {
            break;
        }
        if !usable(r) {
            continue;
        }
        if v == next {
            take(i);
            taken += 1;
            next = taken * n_usable / m;
        }
        v += 1;
    }
}

/// Uniform over the given cells of a grid (`origin`, `res`, `width`), each cell uniformly,
/// uniform heading: a cell index, then x, y and θ fractions.
fn random_pose<R: Rng + ?Sized>(
    cells: &[u32],
    origin: [f64; 2],
    res: f64,
    width: usize,
    rng: &mut R,
) -> Pose2 {
    let k = cells[rng.random_range(0..cells.len())] as usize;
    let (i, j) = (k % width, k / width);
    let u: f64 = rng.random();
    let v: f64 = rng.random();
    let t: f64 = rng.random();
    Pose2::new(
        origin[0] + (i as f64 + u) * res,
        origin[1] + (j as f64 + v) * res,
        normalize_angle((2.0 * t - 1.0) * std::f64::consts::PI),
    )
}

impl ParticleFilter for Mcl {
    core_in_field!();

    /// Laser scans only; odometry readings are ignored because odometry arrives through
    /// `predict` (using both would count it twice).
    fn take_reading(&mut self, reading: &Reading) {
        let Reading::Laser(scan) = reading else {
            return;
        };
        self.core.carry.observed_at(scan.stamp);
        let pending = self.core.carry.pending;
        let moved = pending.x.hypot(pending.y) >= self.params.update_min_d
            || pending.theta.abs() >= self.params.update_min_a;
        if self.updated_once && !moved {
            return;
        }
        self.updated_once = true;
        self.filter_update(scan);
    }

    fn fit_tracker(&self) -> Option<&FitTracker> {
        Some(&self.fit)
    }

    /// Redraws the current number of particles (at least `min_particles`) around `pose`.
    fn reseed(&mut self, pose: Pose2, sigma: [f64; 3]) -> bool {
        let n = self.core.set.len().max(self.params.min_particles);
        self.core.reseed(n, pose, sigma, self.params.estimate)
    }
}

/// A laser scan weighs each particle by the likelihood field or the beam model over the
/// selected beams; resampling is KLD-sized with Augmented MCL's injection.
impl MeasurementModel for Mcl {
    type Observation = LaserScan;

    fn motion(&self) -> &OdometryMotionModel {
        &self.motion
    }

    fn reweight(&mut self, scan: &LaserScan) -> bool {
        if needs_range(&self.field, scan.range_max) {
            Arc::make_mut(&mut self.field).set_range_max(scan.range_max);
        }
        if let Some(cells) = self.seed_from_scan.take() {
            if !self.seed_global_from_scan(scan, &cells) {
                self.seed_from_scan = Some(cells);
            }
        }
        // Cleared so that the estimate reuses only headings computed for these particles.
        self.beam_scratch.headings.clear();
        if self.beams.select(scan, &self.params) == 0 {
            return false;
        }
        let model = ScanModel::new(&self.field, &self.params, &self.beams, scan);
        let (scratch, mut nb) = (&mut self.beam_scratch, 0);
        self.core.set.reweight_log_columns(|x, y, th, out| {
            nb = model.log_likelihoods(x, y, th, out, scratch);
        });
        let n = self.core.set.len();
        let inv_nb = 1.0 / nb as f64;
        let mut per_beam = 0.0;
        for &l in self.core.set.log_likelihoods() {
            per_beam += (l * inv_nb).exp();
        }
        self.fit
            .record(self.core.carry.stamp, (per_beam / n as f64).ln());
        // Augmented MCL bookkeeping (Table 8.3) on the per-beam geometric mean likelihood:
        // the raw product swings by orders of magnitude with the number of valid beams in a
        // scan, which would read as a sudden loss of track.
        if self.params.recovery_enabled() {
            let w_avg = per_beam / n as f64;
            if self.w_slow == 0.0 {
                self.w_slow = w_avg;
                self.w_fast = w_avg;
            } else {
                self.w_slow += self.params.alpha_slow * (w_avg - self.w_slow);
                self.w_fast += self.params.alpha_fast * (w_avg - self.w_fast);
            }
        }
        true
    }

    fn point_estimate(&self) -> PointEstimate {
        self.params.estimate
    }

    fn resample_policy(&self) -> ResamplePolicy {
        self.params.resample_policy()
    }

    /// The estimate of [`MeasurementModel::point_estimate`]; the particles have not moved
    /// since the sensor model took their headings' sines and cosines, so it reuses them.
    fn refresh_estimate(&mut self) {
        let trig = self.beam_scratch.headings.trig(self.core.set.len());
        self.core.refresh_estimate_with(self.params.estimate, trig);
    }

    /// KLD-sized low-variance resampling with random injection (see
    /// [`ParticleSet::resample_kld`]), injected poses uniform or drawn from `scan` (see
    /// `inject_from_scan`).
    fn resample(&mut self, scan: &LaserScan) {
        let p_inj = if self.free_cells.is_empty() {
            0.0
        } else {
            self.injection_probability()
        };
        let mut endpoints = Beams::with_capacity(0);
        let from_scan = self.params.inject_from_scan > 0
            && p_inj > 0.0
            && endpoints.select_endpoints(scan, self.params.max_beams) > 0;
        let coarse = from_scan.then(|| self.coarse_distance());
        let draw = PoseDraw {
            cells: &self.free_cells,
            origin: self.grid_origin,
            resolution: self.grid_resolution,
            width: self.grid_width,
        };
        let (field, samples) = (&*self.field, self.params.inject_from_scan);
        // Ranked only when the first particle is injected (most updates inject none), and
        // each candidate refined only when first drawn: an update that injects a few
        // particles draws a few of the `keep` candidates. `refine` draws no random numbers,
        // so the particles are those refining every candidate up front gives.
        let mut matched: Vec<(Pose2, bool)> = Vec::new();
        self.core
            .set
            .resample_kld(&mut self.kld, p_inj, &mut self.core.rng, |rng| {
                // Half stay uniform: where the scan is aliased (a corridor like others) the
                // matched poses may all sit in the look-alikes.
                let Some(coarse) = coarse.as_ref().filter(|_| rng.random::<bool>()) else {
                    return draw.random(rng);
                };
                if matched.is_empty() {
                    let keep = (samples / 100).max(1);
                    matched = scan_candidates(coarse, &endpoints, &draw, samples, keep, rng)
                        .into_iter()
                        .map(|p| (p, false))
                        .collect();
                }
                let j = rng.random_range(0..matched.len());
                let (pose, refined) = &mut matched[j];
                if !*refined {
                    *pose = refine_on_scan(field, &endpoints, *pose);
                    *refined = true;
                }
                *pose
            });
    }
}

/// The grid at another resolution over the same origin. A target cell is Occupied if it
/// overlaps any Occupied source cell (thin walls survive coarsening), otherwise it takes the
/// state of the source cell under its centre.
fn resample_grid(grid: &OccupancyGrid, res: f64) -> OccupancyGrid {
    let extent = [
        grid.width as f64 * grid.resolution,
        grid.height as f64 * grid.resolution,
    ];
    let w = ((extent[0] / res).ceil() as usize).max(1);
    let h = ((extent[1] / res).ceil() as usize).max(1);
    let mut cells = vec![Cell::Unknown; w * h];
    for j in 0..h {
        for i in 0..w {
            let si = (((i as f64 + 0.5) * res) / grid.resolution) as usize;
            let sj = (((j as f64 + 0.5) * res) / grid.resolution) as usize;
            if si < grid.width && sj < grid.height {
                cells[j * w + i] = grid.cells[sj * grid.width + si];
            }
        }
    }
    // A small inset keeps a source cell's far edge from marking the next target cell when the
    // edges coincide.
    let eps = 1e-9 * res;
    for sj in 0..grid.height {
        for si in 0..grid.width {
            if grid.cells[sj * grid.width + si] != Cell::Occupied {
                continue;
            }
            let x0 = si as f64 * grid.resolution;
            let y0 = sj as f64 * grid.resolution;
            let i0 = ((x0 + eps) / res).floor() as usize;
            let i1 = (((x0 + grid.resolution - eps) / res).floor() as usize).min(w - 1);
            let j0 = ((y0 + eps) / res).floor() as usize;
            let j1 = (((y0 + grid.resolution - eps) / res).floor() as usize).min(h - 1);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    cells[j * w + i] = Cell::Occupied;
                }
            }
        }
    }
    OccupancyGrid {
        origin: grid.origin,
        resolution: res,
        width: w,
        height: h,
        cells,
    }
}

#[cfg(test)]
mod tests;
