pub struct Beta;

pub fn beta_of(_: crate::a::Alpha) -> Beta {
    Beta
}
