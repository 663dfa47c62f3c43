//! What range readings are weighed by and matched with: the likelihood field and the beam
//! model of a laser scan (MCL's two measurement models), scan matching on the likelihood field
//! (MCL's poses drawn from a scan), and FSPF, which turns a depth image into the vertical
//! planes CGR matches. `simd.rs` holds the vector helpers of their hot loops.

pub mod beam_model;
pub mod fspf;
pub mod likelihood_field;
pub mod scan_match;
mod simd;
