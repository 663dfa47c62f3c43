//! A circle made through a `use` group and a file's inline tests.
pub mod maths;
pub mod model;
