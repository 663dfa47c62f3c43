//! Estimators: the localizers Atrium runs against the simulator's ground truth. They see
//! readings ([`atrium_robots::Reading`]) and maps exported from `atrium_worlds`, never the
//! simulator. Every localizer implements [`Localizer`] (`localizer.rs`): odometry in through
//! [`Localizer::predict`], readings through [`Localizer::update`], a pose and covariance out
//! through [`Localizer::estimate`]; [`Capabilities`] adds what some can do besides (re-seeding,
//! an observation fit, cloning).
//!
//! # Where things are
//!
//! | folder | what it holds |
//! |---|---|
//! | [`filter`] | the particle filter core: the recipe ([`MeasurementModel`], [`ParticleFilter`], [`FilterCore`]), the particle set and its steps (propagation, resampling and its policies, KLD-sampling, the point estimate), the initial belief, the observation fit |
//! | [`localizers`] | the localizers: the particle filters on the recipe (MCL, CGR, ceiling MCL, omnicam MCL, WiFi MCL), dead reckoning, the landmark filter |
//! | [`sensor_models`] | what a laser or a depth camera is weighed by: the likelihood field, the beam model, scan matching, FSPF's planes |
//! | [`maps`] | the maps the filters weigh against that are not a world's own: the line map of CGR, the omnicam eigenimage map, the WiFi graph, the building's free space, per-location error maps |
//! | [`slam`] | SLAM and mapping: EKF SLAM and its covariance monitor; the pose graph and occupancy mapping that build a map from a robot log |
//! | [`maths`] | Gaussian processes (the WiFi graph's) and mixture weights (the choosers') |
//!
//! At the root: the [`Localizer`] interface (`localizer.rs`), the crate's errors (`error.rs`)
//! and size limits (`limits.rs`), the appearance localizer of [000] (`appearance.rs` its
//! map and sensor model, `appearance_apf.rs` the filter, `pca.rs` and `em_pca.rs` its
//! eigenimages) and the choosers, which run several localizers and pick or fuse one
//! (`chooser.rs`, `shared_member.rs`).
//!
//! # The filter recipe
//!
//! Every particle filter runs one update, [`MeasurementModel::filter_update`]:
//! propagate (odometry motion model) → reweight (the filter's measurement model) → estimate
//! (weighted mean or heaviest cluster) → resample when its [`ResamplePolicy`] says so. A filter
//! writes two things: [`ParticleFilter`] (where its [`FilterCore`] is and which readings it
//! takes) and [`MeasurementModel::reweight`] (how an observation weighs the particles, through
//! the [`ParticleSet`]'s reweighting steps). The other steps are extension points with
//! defaults: [`MeasurementModel::propagate`] (the WiFi filter keeps particles in the
//! building; CGR moves each particle inside its refinement), [`MeasurementModel::resample`]
//! (MCL's KLD-sized resampling with injection, the omnicam filter's injection from its
//! energy function), [`MeasurementModel::refresh_estimate`],
//! [`MeasurementModel::resample_policy`]. The appearance filter's auxiliary resampling draws
//! particles from the product of weights and reading components in one step, so it writes
//! its own [`ParticleFilter::take_reading`] on the same [`FilterCore`].
//!
//! A new particle filter: a struct with a [`FilterCore`] field `core`, `impl ParticleFilter`
//! (with `core_in_field!()`) whose `take_reading` picks its readings and calls
//! `filter_update`, and `impl MeasurementModel`; [`Localizer`] and [`Capabilities`] follow.
//! Module paths of the former flat layout (`atrium_localization::mcl`, `::particle_set`, ...)
//! are re-exported below so that callers keep their paths.

pub mod filter;
pub mod localizers;
pub mod maps;
pub mod maths;
pub mod sensor_models;
pub mod slam;

pub mod appearance;
pub mod appearance_apf;
pub mod chooser;
pub mod em_pca;
pub mod error;
pub mod limits;
pub mod localizer;
pub mod pca;
pub mod shared_member;

// The module paths of the flat layout, kept for callers (and the files at the root).
pub use filter::{
    cluster, initial_belief, kld, lattice, motion, observation_fit, particle_filter, particle_set,
    particles, resampling,
};
pub use localizers::{ceiling_mcl, cgr, dead_reckoning, landmark_filter, mcl, omni_mcl, wifi_mcl};
pub use maps::{error_map, free_space, line_map, omni_map, wifi_graph};
pub use maths::{gp, mixture};
pub use sensor_models::{beam_model, fspf, likelihood_field, scan_match};
pub use slam::{covariance_monitor, ekf_slam, occupancy_mapping, pose_graph};

pub use cgr::{Cgr, CgrParams};
pub use chooser::{Chooser, ReseedParams, Strategy};
pub use dead_reckoning::{DeadReckoning, DriftModel};
pub use error::LocalizationError;
pub use fspf::{FspfParams, PlaneFilter, PlaneFiltered};
pub use kld::{kld_bound, BinSet};
pub use landmark_filter::{
    LandmarkFilter, LandmarkFilterParams, LandmarkSignature, NodeModel, RecursiveLandmarkModel,
    TrainingScan,
};
pub use likelihood_field::{LikelihoodField, LikelihoodFieldParams};
pub use line_map::LineMap;
pub use localizer::{Capabilities, Estimate, Localizer, LocalizerError, OdometryDelta};
pub use mcl::{InitialBelief, Mcl, MclMap, MclParams};
pub use motion::{OdometryIncrement, OdometryMotionModel};
pub use occupancy_mapping::{MappingParams, OccupancyMapper};
pub use particle_filter::{FilterCore, MeasurementModel, ParticleFilter};
pub use particle_set::ParticleSet;
pub use particles::{ReadingCounts, ReadingTally};
pub use pose_graph::{PoseGraph, PoseGraphError};
pub use resampling::{
    low_variance_indices, low_variance_indices_with_offset, Injection, ResamplePolicy,
};
pub use shared_member::SharedMember;
