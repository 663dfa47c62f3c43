//! The particle filter core: the one update every particle filter runs
//! ([`particle_filter::MeasurementModel::filter_update`]: propagate → reweight → estimate →
//! resample by policy), the [`particle_filter::FilterCore`] a filter keeps, the
//! [`particle_set::ParticleSet`] and its steps, and the policies a filter chooses among.
//!
//! - `particle_filter.rs`: the recipe ([`particle_filter::MeasurementModel`],
//!   [`particle_filter::ParticleFilter`]) and the `Localizer` glue it brings;
//! - `particle_set.rs`: the set (struct-of-arrays) and its steps: sampling, propagation,
//!   reweighting, resampling, the estimate;
//! - `motion.rs` the odometry motion model; `resampling.rs` low-variance resampling, the
//!   [`resampling::ResamplePolicy`] and injection; `kld.rs` KLD-sampling;
//!   `cluster.rs` the point estimate (weighted mean or heaviest cluster) and `lattice.rs` its
//!   histogram cells; `initial_belief.rs` tracking and global beliefs;
//!   `observation_fit.rs` how well the readings fit the belief; `particles.rs` the pieces
//!   besides the set (weights, the estimate carried by odometry, the reading tally).

pub mod cluster;
pub mod initial_belief;
pub mod kld;
pub mod lattice;
pub mod motion;
pub mod observation_fit;
pub mod particle_filter;
pub mod particle_set;
pub mod particles;
pub mod resampling;
