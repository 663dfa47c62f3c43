pub struct Model;

impl Model {
    pub fn size(&self) -> f64 {
        super::maths::twice(0.5)
    }
}
