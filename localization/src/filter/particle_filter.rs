//! The particle filter recipe every particle filter of the crate follows, and the
//! [`Localizer`] and [`Capabilities`] glue they share, so that a filter writes only what is
//! its own: how it takes a reading and how a reading weighs its particles.
//!
//! The recipe, after Beluga's composable steps (a filter is its sensor model plus a choice of
//! steps and policies): [`MeasurementModel::filter_update`] runs
//! propagate → reweight → estimate → resample (when the [`ResamplePolicy`] says so). A filter
//! implements [`ParticleFilter`] (where its [`FilterCore`] is, which readings it takes) and
//! [`MeasurementModel`] (how an observation weighs the particles); the other steps have
//! defaults it may override where its method really differs (the WiFi filter's propagation
//! keeps particles inside the building, CGR's moves and refines each particle together,
//! MCL's and the omnicam filter's resampling inject particles drawn from the reading).
//!
//! Odometry is only accumulated (the motion model runs just before the next observation),
//! and the estimate is the one of the last sensor update carried forward by the odometry
//! received since.

use crate::error::LocalizationError;
use crate::filter::cluster::PointEstimate;
use crate::filter::initial_belief::InitialBelief;
use crate::filter::motion::OdometryMotionModel;
use crate::filter::observation_fit::FitTracker;
use crate::filter::particle_set::ParticleSet;
use crate::filter::particles::{CarriedEstimate, HeadingTrig};
use crate::filter::resampling::ResamplePolicy;
use crate::localizer::{Capabilities, Estimate, Localizer, LocalizerError, OdometryDelta};
use atrium_robots::{IntensityImage, Pose2, Reading};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// What every particle filter keeps besides its sensor model: its name, its random stream,
/// its particles and the estimate carried by odometry.
#[derive(Debug, Clone)]
pub struct FilterCore {
    pub(crate) name: String,
    pub(crate) rng: ChaCha8Rng,
    pub(crate) set: ParticleSet,
    pub(crate) carry: CarriedEstimate,
}

impl FilterCore {
    /// An empty set with room for `capacity` particles and a stream seeded with `seed`.
    pub fn new(name: &str, capacity: usize, seed: u64) -> FilterCore {
        FilterCore {
            name: name.to_owned(),
            rng: ChaCha8Rng::seed_from_u64(seed),
            set: ParticleSet::with_capacity(capacity),
            carry: CarriedEstimate::default(),
        }
    }

    /// Draws `n` particles from `init` (see [`ParticleSet::sample_initial_belief`]) and
    /// takes their estimate `kind`.
    pub fn start(
        &mut self,
        n: usize,
        init: &InitialBelief,
        extent: [f64; 4],
        kind: PointEstimate,
    ) -> Result<(), LocalizationError> {
        self.set
            .sample_initial_belief(n, init, extent, &mut self.rng)?;
        self.refresh_estimate(kind);
        Ok(())
    }

    /// Moves the particles by the odometry not yet applied (see [`ParticleSet::propagate`]).
    pub fn propagate(&mut self, motion: &OdometryMotionModel) {
        self.set
            .propagate(motion, &mut self.carry.pending, &mut self.rng);
    }

    /// Carries forward the estimate `kind` of the particles as they are now.
    pub fn refresh_estimate(&mut self, kind: PointEstimate) {
        self.refresh_estimate_with(kind, HeadingTrig::Compute);
    }

    /// [`FilterCore::refresh_estimate`] with the headings' sines and cosines from `trig`
    /// (see [`ParticleSet::estimate_with`]).
    pub fn refresh_estimate_with(&mut self, kind: PointEstimate, trig: HeadingTrig<'_>) {
        self.carry.set(self.set.estimate_with(kind, trig));
    }

    /// Redraws `n` particles around `pose` with standard deviations `sigma`, dropping the
    /// odometry not yet applied (`pose` is a current estimate), and takes their estimate
    /// `kind`. Returns false, leaving the filter alone, when the Gaussian is not valid.
    pub fn reseed(&mut self, n: usize, pose: Pose2, sigma: [f64; 3], kind: PointEstimate) -> bool {
        if !self.set.sample_gaussian(n, pose, sigma, &mut self.rng) {
            return false;
        }
        self.carry.pending = Pose2::default();
        self.refresh_estimate(kind);
        true
    }
}

/// [`ParticleFilter::core`] and [`ParticleFilter::core_mut`] for a filter that keeps its
/// [`FilterCore`] in a field named `core`, as every filter of the crate does: written once
/// here rather than twice in each filter.
macro_rules! core_in_field {
    () => {
        fn core(&self) -> &$crate::filter::particle_filter::FilterCore {
            &self.core
        }

        fn core_mut(&mut self) -> &mut $crate::filter::particle_filter::FilterCore {
            &mut self.core
        }
    };
}
pub(crate) use core_in_field;

/// A particle filter on a [`FilterCore`]; [`Localizer`] and [`Capabilities`] come with it.
pub trait ParticleFilter: Clone + Send + 'static {
    fn core(&self) -> &FilterCore;

    fn core_mut(&mut self) -> &mut FilterCore;

    /// The measurement update of [`Localizer::update`]: readings the filter does not use are
    /// ignored, and one it cannot use is skipped (or counted), never an error.
    fn take_reading(&mut self, reading: &Reading);

    /// Runs before an odometry step is accumulated.
    fn before_odometry(&mut self, _delta: &OdometryDelta) {}

    /// The tracker behind [`Capabilities::observation_fit`], if the filter measures a fit.
    fn fit_tracker(&self) -> Option<&FitTracker> {
        None
    }

    /// [`Capabilities::reset_to`]; a filter that cannot be re-seeded keeps this default.
    fn reseed(&mut self, _pose: Pose2, _sigma: [f64; 3]) -> bool {
        false
    }

    /// The particles and their weights as of the last sensor update (odometry received since
    /// is not applied to them; the estimate does apply it).
    fn particles(&self) -> impl Iterator<Item = (Pose2, f64)> + '_ {
        self.core().set.iter()
    }
}

/// The measurement model of a particle filter and its steps around it: what a filter supplies
/// to the one default update, [`MeasurementModel::filter_update`]. Only
/// [`MeasurementModel::reweight`] (and the motion model of the default propagation) must be
/// written; every other step has the default a plain MCL uses.
pub trait MeasurementModel: ParticleFilter {
    /// One observation as the filter's [`ParticleFilter::take_reading`] prepared it from a
    /// reading (a laser scan, a brightness, a panorama's features, a WiFi scan).
    type Observation: ?Sized;

    /// The motion model of the default [`MeasurementModel::propagate`].
    fn motion(&self) -> &OdometryMotionModel;

    /// Weighs the particles by `z` (through [`ParticleSet::reweight_log`] and its
    /// siblings). Returns false when `z` gave nothing to weigh by (too few points, no valid
    /// beam): the particles then only moved, and the update takes their estimate but does not
    /// resample.
    fn reweight(&mut self, z: &Self::Observation) -> bool;

    /// The point estimate the filter reports. Default: the weighted mean.
    fn point_estimate(&self) -> PointEstimate {
        PointEstimate::WeightedMean
    }

    /// When the filter resamples. Default: after every update.
    fn resample_policy(&self) -> ResamplePolicy {
        ResamplePolicy::EveryUpdate
    }

    /// Moves the particles by the odometry received since the last update. Default: the
    /// odometry motion model (see [`FilterCore::propagate`]).
    fn propagate(&mut self) {
        let motion = *self.motion();
        self.core_mut().propagate(&motion);
    }

    /// Takes the estimate of the particles as they are now. Default:
    /// [`MeasurementModel::point_estimate`], computed from the particles.
    fn refresh_estimate(&mut self) {
        let kind = self.point_estimate();
        self.core_mut().refresh_estimate(kind);
    }

    /// Resamples after `z` weighed the particles. Default: low-variance resampling at the
    /// current size, nothing injected.
    fn resample(&mut self, _z: &Self::Observation) {
        let core = self.core_mut();
        core.set.resample_plain(core.set.len(), &mut core.rng);
    }

    /// The default update: propagate → reweight → estimate → resample by
    /// [`MeasurementModel::resample_policy`]. The estimate is taken from the weighted set
    /// before resampling: resampling adds variance and injected particles, never information.
    fn filter_update(&mut self, z: &Self::Observation) {
        self.propagate();
        let weighed = self.reweight(z);
        self.refresh_estimate();
        if !weighed {
            return;
        }
        let set = &self.core().set;
        if self.resample_policy().due(set.ess(), set.len()) {
            self.resample(z);
        }
    }
}

impl<T: ParticleFilter> Localizer for T {
    fn name(&self) -> &str {
        &self.core().name
    }

    /// Accumulates odometry; the motion model runs just before the next sensor update.
    fn predict(&mut self, delta: &OdometryDelta) -> Result<(), LocalizerError> {
        self.before_odometry(delta);
        self.core_mut().carry.accumulate(delta);
        Ok(())
    }

    fn update(&mut self, reading: &Reading) -> Result<(), LocalizerError> {
        self.take_reading(reading);
        Ok(())
    }

    /// The estimate at the last sensor update, moved by the odometry received since, with
    /// its covariance carried through the same composition (first order).
    fn estimate(&self) -> Estimate {
        self.core().carry.estimate()
    }

    fn capabilities(&mut self) -> Option<&mut dyn Capabilities> {
        Some(self)
    }
}

impl<T: ParticleFilter> Capabilities for T {
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }

    fn observation_fit(&self) -> Option<f64> {
        self.fit_tracker().and_then(FitTracker::fit)
    }

    fn reset_to(&mut self, pose: Pose2, sigma: [f64; 3]) -> bool {
        self.reseed(pose, sigma)
    }

    fn clone_localizer(&self) -> Option<Box<dyn Localizer>> {
        Some(Box::new(self.clone()))
    }
}

/// The intensity image `reading` carries if it comes from `sensor`.
pub fn intensity_from<'a>(reading: &'a Reading, sensor: &str) -> Option<&'a IntensityImage> {
    match reading {
        Reading::Intensity(img) if img.sensor == sensor => Some(img),
        _ => None,
    }
}
