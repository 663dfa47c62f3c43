//! The `score_estimates` fuzz target's entry point (`fuzz-targets/`, docs/fuzzing.md), run
//! deterministically in CI: every seed and every input the fuzzer once broke
//! (`fuzz-targets/regressions/score_estimates/`), then a few hundred byte-level mutations of
//! the seeds. Each must give estimates that are finite, on a map and in time order, or an
//! error naming the file.

use atrium_recordings::score::Estimates;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

fn inputs() -> Vec<(PathBuf, Vec<u8>)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../fuzz-targets");
    let mut out = Vec::new();
    for dir in ["seeds", "regressions"] {
        let Ok(entries) = std::fs::read_dir(root.join(dir).join("score_estimates")) else {
            continue;
        };
        for e in entries {
            let p = e.unwrap().path();
            out.push((p.clone(), std::fs::read(&p).unwrap()));
        }
    }
    out.sort();
    out
}

/// `fuzz_targets/score_estimates.rs`.
fn read(data: &[u8]) -> Result<Option<Estimates>, String> {
    let Some((&pick, bytes)) = data.split_first() else {
        return Ok(None);
    };
    let path = Path::new(if pick & 1 == 0 {
        "estimates.txt"
    } else {
        "estimates.csv"
    });
    match Estimates::from_bytes(path, bytes.to_vec(), None) {
        Ok(e) => {
            let finite = e
                .poses
                .iter()
                .all(|p| p.x.is_finite() && p.y.is_finite() && p.theta.is_finite());
            let ordered = e.stamps.windows(2).all(|w| w[0] < w[1]);
            if !(finite && ordered && !e.stamps.is_empty()) {
                return Err(format!("accepted garbage: {e:?}"));
            }
            let [a, b] = e.span();
            for k in 0..=8 {
                let (p, _) = e.at(a + (b - a) * k as f64 / 8.0);
                if !(p.x.is_finite() && p.y.is_finite() && p.theta.is_finite()) {
                    return Err(format!("interpolated {p:?}"));
                }
            }
            Ok(Some(e))
        }
        Err(err) if err.to_string().contains("estimates.") => Ok(None),
        Err(err) => Err(format!("the error does not name the file: {err}")),
    }
}

#[test]
fn seeds_are_read_and_regressions_refused_cleanly() {
    let all = inputs();
    assert!(all.len() >= 4, "the seeds are missing");
    for (p, data) in all {
        let r = read(&data).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        if p.to_string_lossy().contains("/seeds/") {
            assert!(r.is_some(), "{}: a seed is refused", p.display());
        }
    }
}

fn mutated() -> impl Strategy<Value = Vec<u8>> {
    let seeds: Vec<Vec<u8>> = inputs()
        .into_iter()
        .filter(|(p, _)| p.to_string_lossy().contains("/seeds/"))
        .map(|(_, d)| d)
        .collect();
    (
        prop::sample::select(seeds),
        prop::collection::vec((any::<prop::sample::Index>(), 0u8..8, 0u8..3), 1..6),
    )
        .prop_map(|(mut b, edits)| {
            for (i, bit, kind) in edits {
                if b.len() < 2 {
                    break;
                }
                // Never the first byte, which only picks the name.
                let at = 1 + i.index(b.len() - 1);
                match kind {
                    0 => b[at] ^= 1 << bit,
                    1 => b[at] = [b'\n', b' ', b',', b'-', b'e', b'9', 0, 0xff][bit as usize],
                    _ => b.truncate(at),
                }
            }
            b
        })
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(256),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn damaged_estimates(data in mutated()) {
        let r = read(&data);
        prop_assert!(r.is_ok(), "{:?}", r.err());
    }
}
