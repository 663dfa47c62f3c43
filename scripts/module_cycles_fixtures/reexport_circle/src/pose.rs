pub struct Pose(pub f64);

pub fn footprint(p: &Pose) -> f64 {
    crate::shape::area(p)
}
