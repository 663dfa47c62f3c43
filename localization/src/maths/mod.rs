//! Estimation maths not tied to one sensor: Gaussian-process regression in the plane (the
//! WiFi graph's model, `gp.rs`) and the mixture weights that fuse several localizers
//! (`mixture.rs`, the choosers').

pub mod gp;
pub mod mixture;
