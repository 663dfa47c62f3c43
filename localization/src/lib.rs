//! Estimators. They see readings and maps exported from `worlds`, never the simulator.

pub mod appearance;
pub mod appearance_apf;
pub mod beam_model;
pub mod ceiling_mcl;
pub mod cgr;
pub mod chooser;
pub mod cluster;
pub mod covariance_monitor;
pub mod dead_reckoning;
pub mod ekf_slam;
pub mod em_pca;
pub mod error;
pub mod error_map;
pub mod free_space;
pub mod fspf;
pub mod gp;
pub mod initial_belief;
pub mod kld;
pub mod landmark_filter;
pub mod lattice;
pub mod likelihood_field;
pub mod limits;
pub mod line_map;
pub mod localizer;
pub mod mcl;
pub mod mixture;
pub mod motion;
pub mod observation_fit;
pub mod occupancy_mapping;
pub mod omni_map;
pub mod omni_mcl;
pub mod particle_filter;
pub mod particle_set;
pub mod particles;
pub mod pca;
pub mod pose_graph;
pub mod resampling;
pub mod scan_match;
pub mod shared_member;
mod simd;
pub mod wifi_graph;
pub mod wifi_mcl;

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
pub use particle_filter::{FilterCore, ParticleFilter};
pub use particle_set::ParticleSet;
pub use particles::{ReadingCounts, ReadingTally};
pub use pose_graph::{PoseGraph, PoseGraphError};
pub use resampling::{
    low_variance_indices, low_variance_indices_with_offset, Injection, ResamplePolicy,
};
pub use shared_member::SharedMember;
