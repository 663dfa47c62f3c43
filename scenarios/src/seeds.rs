//! One random stream per purpose, derived from the scenario seed, so that adding a localizer
//! or a sensor never changes the draws of another and runs are identical across machines.

/// SplitMix64 finaliser: a portable, well-mixed 64-bit hash step.
fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// The seed of the stream named `purpose` (e.g. "sim", "localizer/mcl") under `seed`.
pub fn derive_seed(seed: u64, purpose: &str) -> u64 {
    // FNV-1a over the purpose, then mixed with the seed.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in purpose.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    splitmix64(seed ^ splitmix64(h))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_differ_by_purpose_and_seed_and_are_stable() {
        assert_ne!(derive_seed(1, "sim"), derive_seed(1, "localizer/mcl"));
        assert_ne!(derive_seed(1, "sim"), derive_seed(2, "sim"));
        assert_eq!(derive_seed(7, "sim"), derive_seed(7, "sim"));
        // Pinned value: a change here changes every recorded run.
        assert_eq!(
            derive_seed(0, ""),
            splitmix64(splitmix64(0xcbf2_9ce4_8422_2325))
        );
    }
}
