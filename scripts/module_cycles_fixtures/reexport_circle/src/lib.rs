//! `lib.rs` re-exports `Pose` from `pose.rs`; `pose.rs` uses `shape.rs`, which names
//! `crate::Pose`: the edge goes to `pose.rs`, where `Pose` is defined, and makes a circle.
mod pose;
mod shape;
pub use pose::Pose;
