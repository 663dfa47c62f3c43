use super::World;
use crate::Limits;

pub struct Wall;

pub fn fits(_: &World, _: &Limits) -> bool {
    true
}
