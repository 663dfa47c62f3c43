use super::Settings;

pub fn step(_: &Settings) -> u32 {
    1
}
