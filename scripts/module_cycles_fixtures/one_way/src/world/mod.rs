mod wall;
pub use self::wall::Wall;

pub struct World {
    pub limits: super::Limits,
}
