mod child;

pub struct Settings;

pub fn run() -> u32 {
    self::child::step(&Settings)
}
