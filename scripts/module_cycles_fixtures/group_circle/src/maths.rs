pub fn twice(x: f64) -> f64 {
    2.0 * x
}

#[cfg(test)]
mod tests {
    use crate::{maths::twice, model::{Model}};

    #[test]
    fn doubles_a_model() {
        assert_eq!(twice(Model.size()), 2.0);
    }
}
