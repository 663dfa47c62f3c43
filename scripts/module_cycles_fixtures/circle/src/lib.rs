//! Two sibling files that import each other: a circle.
pub mod a;
pub mod b;
