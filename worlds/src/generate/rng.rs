//! The generators' random numbers: one ChaCha8 stream per purpose (rooms, doors, glass,
//! clutter), so that changing one parameter, say `clutter_density`, leaves the rooms and doors
//! of the same seed where they were: a sweep over one parameter varies that parameter only.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub(crate) struct Stream(ChaCha8Rng);

impl Stream {
    /// The stream for `purpose` of world `seed`.
    pub(crate) fn new(seed: u64, purpose: &str) -> Self {
        // FNV-1a of the purpose, mixed into the seed; ChaCha's key schedule does the rest.
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        for b in purpose.bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        Stream(ChaCha8Rng::seed_from_u64(seed ^ h))
    }

    /// Uniform in [0, 1).
    pub(crate) fn unit(&mut self) -> f64 {
        self.0.random::<f64>()
    }

    /// Uniform in [lo, hi).
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// Uniform index in 0..n (n > 0).
    pub(crate) fn index(&mut self, n: usize) -> usize {
        self.0.random_range(0..n)
    }

    pub(crate) fn shuffle<T>(&mut self, v: &mut [T]) {
        for i in (1..v.len()).rev() {
            let j = self.index(i + 1);
            v.swap(i, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_repeat_per_seed_and_purpose_and_differ_otherwise() {
        let draw = |seed, purpose| {
            let mut s = Stream::new(seed, purpose);
            (0..4).map(|_| s.unit()).collect::<Vec<f64>>()
        };
        assert_eq!(draw(1, "doors"), draw(1, "doors"));
        assert_ne!(draw(1, "doors"), draw(1, "clutter"));
        assert_ne!(draw(1, "doors"), draw(2, "doors"));
        let mut s = Stream::new(3, "x");
        for _ in 0..1000 {
            assert!((0.0..1.0).contains(&s.unit()));
            assert!(s.index(7) < 7);
        }
    }
}
