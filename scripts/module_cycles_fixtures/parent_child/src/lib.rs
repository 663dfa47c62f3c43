//! A parent using its child's function through a bare path while the child uses the parent: a circle.
pub mod sweep;
