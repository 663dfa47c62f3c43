//! The localizers, each behind [`crate::Localizer`]. Particle filters on the recipe of
//! [`crate::filter`]: `mcl.rs` (MCL on an occupancy grid: likelihood field or beam model,
//! KLD-sampling, Augmented MCL), `cgr.rs` (Corrective Gradient Refinement on a vector map,
//! laser or depth camera), `ceiling_mcl.rs` (ceiling brightness), `omni_mcl.rs` (omnicam
//! eigenimages), `wifi_mcl.rs` (WiFi signal strengths on a WiFi graph). Others:
//! `dead_reckoning.rs` (odometry alone, the baseline every claim is checked against) and
//! `landmark_filter.rs` (node-based odometry reset at recognised landmarks).

pub mod ceiling_mcl;
pub mod cgr;
pub mod dead_reckoning;
pub mod landmark_filter;
pub mod mcl;
pub mod omni_mcl;
pub mod wifi_mcl;
