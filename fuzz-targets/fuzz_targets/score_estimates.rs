//! `atrium score`'s estimate reader: TUM, CSV (`t,x,y,theta`) and MCAP pose topics, then
//! the lookups the metrics make. Accepted estimates must be finite, on a map and in time
//! order; a refusal must name the file.
#![no_main]

use atrium_recordings::score::Estimates;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    // The first byte picks the name: `.csv` forces CSV, `.txt` leaves it to the content.
    let Some((&pick, bytes)) = data.split_first() else {
        return;
    };
    let path = Path::new(if pick & 1 == 0 {
        "estimates.txt"
    } else {
        "estimates.csv"
    });
    match Estimates::from_bytes(path, bytes.to_vec(), None) {
        Ok(e) => {
            assert!(!e.stamps.is_empty());
            assert!(e.stamps.windows(2).all(|w| w[0] < w[1]));
            for p in &e.poses {
                assert!(p.x.is_finite() && p.y.is_finite() && p.theta.is_finite());
            }
            let [a, b] = e.span();
            for k in 0..=8 {
                let t = a + (b - a) * k as f64 / 8.0;
                let (p, _) = e.at(t);
                assert!(p.x.is_finite() && p.y.is_finite() && p.theta.is_finite());
            }
            let _ = e.default_name();
        }
        Err(err) => {
            let text = err.to_string();
            assert!(
                text.contains("estimates."),
                "the error does not name the file: {text}"
            );
        }
    }
});
