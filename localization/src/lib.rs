//! Estimators. They see readings and maps exported from `worlds`, never the simulator.

pub mod localizer;

pub use localizer::{Estimate, Localizer, OdometryDelta};
