pub fn area(p: &crate::Pose) -> f64 {
    p.0 * p.0
}
