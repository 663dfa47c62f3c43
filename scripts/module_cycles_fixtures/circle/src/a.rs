use crate::b::Beta;

pub struct Alpha;

pub fn alpha_of(_: Beta) -> Alpha {
    Alpha
}
