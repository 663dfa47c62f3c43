//! Estimators. They see readings and maps exported from `worlds`, never the simulator.

pub mod dead_reckoning;
pub mod error;
pub mod kld;
pub mod likelihood_field;
pub mod localizer;
pub mod mcl;
pub mod motion;
pub mod resampling;

pub use dead_reckoning::{DeadReckoning, DriftModel};
pub use error::LocalizationError;
pub use kld::{kld_bound, BinSet};
pub use likelihood_field::{LikelihoodField, LikelihoodFieldParams};
pub use localizer::{Estimate, Localizer, OdometryDelta};
pub use mcl::{InitialBelief, Mcl, MclParams};
pub use motion::{OdometryIncrement, OdometryMotionModel};
pub use resampling::{low_variance_indices, low_variance_indices_with_offset};
