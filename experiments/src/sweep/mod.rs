//! Parameter sweeps (issue 9, deliverable 1 and the CSV/summary part of 2): a sweep TOML
//! names a base scenario, parameter axes and trials per cell; `atrium sweep` runs every trial
//! in parallel with seeds derived from the trial's index (so results do not depend on the
//! thread count or the sharding), appends one row batch per trial to `results.csv`, and
//! writes `summary.md`. Source of the experiment design: [004] §3. Axes may vary a generated
//! world (`world.<parameter>`, see `format`), and numeric axes get failure curves
//! (`failure`, issue 17).

pub mod bench;
pub mod csv;
pub mod drive;
pub mod end_error;
pub mod failure;
pub mod format;
pub mod heatmap;
pub mod inputs;
pub mod maps;
pub mod markdown;
pub mod merge;
pub mod origin;
pub mod over_seeds;
pub mod run;
pub mod summary;

pub use csv::parse_shard;
pub use format::{Axis, Sweep};
pub use merge::merge;
pub use run::{run_sweep, SweepOutcome, SweepSettings};
