//! A parent calling its child while the child uses `super::` items of the parent: a circle.
pub mod parent;
