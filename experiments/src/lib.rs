//! What Atrium builds on its harness (`atrium-scenarios`): multi-run experiments (the node
//! table of [002], the illumination experiment of [000], the end-error table of [004]),
//! parameter sweeps, seed checks, benchmarks and inspection (recordings, replay and scoring
//! are in `atrium-recordings`, file formats in `atrium-formats`). Every entry point that runs localizers takes a
//! [`LocalizerRegistry`], so a user's kinds run here as Atrium's own do.

pub mod appearance_lab;
pub mod bench;
pub mod bench_appearance;
pub mod inspect;
pub mod node_experiment;
pub mod seed_check;
pub mod sweep;

pub use sweep::end_error;

pub use atrium_scenarios::LocalizerRegistry;
