//! One way only: the parent declares its children and re-exports their items, the children use
//! the parent (`super::`) and each other in one direction; the parent's own tests use `super::*`.
pub mod world;
pub use world::{Wall, World};

pub struct Limits;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_exist() {
        let _ = Limits;
    }
}
