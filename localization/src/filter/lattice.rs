//! The integer lattice cell of a coordinate, for the histograms of particle clouds (KLD
//! sampling's bins, the estimate's clusters), which take a few per particle per update.

/// `q.floor() as i64`, for every f64 (NaN 0, saturating at the ends as `as` does), without
/// the library call that `floor` is on a target without a rounding instruction (x86-64's
/// baseline): truncation, then one step down where it rounded a negative value up.
#[inline]
pub fn floor_i64(q: f64) -> i64 {
    let t = q as i64;
    if (t as f64) > q {
        t.saturating_sub(1)
    } else {
        t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn floor_i64_is_floor_then_as_for_every_input() {
        let mut cases = vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            0.0,
            -0.0,
            -0.5,
            0.5,
            -1.0,
            1e300,
            -1e300,
            9.2e18,
            -9.2e18,
            i64::MAX as f64,
            i64::MIN as f64,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            4503599627370495.5,
            -4503599627370495.5,
        ];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..100_000 {
            cases.push(rng.random_range(-1e3..1e3));
            // Integers and their neighbours, where truncation and floor meet.
            let n = rng.random_range(-1_000_000i64..1_000_000) as f64;
            cases.extend([n, n.next_up(), n.next_down()]);
            cases.push(f64::from_bits(rng.random::<u64>()));
        }
        for q in cases {
            assert_eq!(floor_i64(q), q.floor() as i64, "{q:e}");
        }
    }
}
