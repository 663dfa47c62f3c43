//! Property-based fuzzing of the error-map CSV parser (`ErrorMap::from_csv`, read by
//! data-driven choosers and sweep merges): mutated files never panic or allocate beyond the
//! limit (they parse or they are an error naming a line), and whatever parses is usable: a
//! finite grid within `ERROR_MAP_MAX_VALUES`, finite means, and it writes back to the same
//! map. Inputs that once failed are kept below as explicit regression tests.

use atrium_fuzz::{apply, config, mutation, HOSTILE_NUMBERS};
use atrium_localization::error_map::{ErrorMap, ERROR_MAP_MAX_VALUES};
use proptest::prelude::*;

/// A small map as `ErrorMap::to_csv` writes it: two layers, a few visited cells.
const BASE: &str = "# atrium error map: origin_x=-1 origin_y=-1 resolution=0.5 width=8 height=6
localizer,i,j,x,y,mean_error,samples,sum
laser,0,0,-0.75,-0.75,0.1,2,0.2
laser,3,2,0.75,0.25,0.05,4,0.2
laser,7,5,2.75,1.75,1.5,1,1.5
wifi,0,0,-0.75,-0.75,2,3,6
wifi,4,1,1.25,-0.25,1.25,4,5
";

/// Snippets a mutation may splice in: CSV syntax, header keys and rows.
const TOKENS: &[&str] = &[
    ",",
    "\n",
    "\r\n",
    " ",
    "=",
    "#",
    "# atrium error map:",
    "localizer,i,j,x,y,mean_error,samples,sum\n",
    "origin_x=",
    "resolution=",
    "width=",
    "height=1000000000 ",
    "width=4294967296 ",
    "laser,",
    "depth,1,1,0,0,1,1,1\n",
    "a,0,0,0,0,1,4294967295,1\n",
    "nan",
    "inf",
    "-inf",
    "1e308",
    "0",
    "-1",
    "18446744073709551616",
    "\u{0}",
    "\u{feff}",
    "é",
];

/// Numbers of the file: header values after `=`, and whole CSV fields.
fn number_spans(text: &str) -> Vec<(usize, usize)> {
    let b = text.as_bytes();
    let mut spans = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let boundary = i == 0 || b"=,\n".contains(&b[i - 1]);
        if boundary && (b[i].is_ascii_digit() || b"-+".contains(&b[i])) {
            let mut j = i;
            while j < b.len() && !b" ,\n\r".contains(&b[j]) {
                j += 1;
            }
            spans.push((i, j));
            i = j.max(i + 1);
        } else {
            i += 1;
        }
    }
    spans
}

/// What a parsed map must satisfy however hostile the file was.
fn check_usable(m: &ErrorMap) {
    assert!(m.origin.iter().all(|v| v.is_finite()), "{:?}", m.origin);
    assert!(m.resolution.is_finite() && m.resolution > 0.0);
    assert!(m.width >= 1 && m.height >= 1);
    let values = m.width as u128 * m.height as u128 * m.localizers.len() as u128;
    assert!(values <= ERROR_MAP_MAX_VALUES as u128, "{values}");
    for l in 0..m.localizers.len() {
        for j in 0..m.height {
            for i in 0..m.width {
                if let Some((mean, n)) = m.mean(l, i, j) {
                    assert!(mean.is_finite() && mean >= 0.0 && n >= 1);
                }
            }
        }
        // Lookups with any radius end (the radius is capped).
        let c = m.cell_centre(m.width / 2, m.height / 2);
        let _ = m.mean_near(l, c, usize::MAX);
    }
    // It writes back to the same map.
    let again = ErrorMap::from_csv(&m.to_csv()).expect("its own CSV parses");
    assert_eq!(&again, m);
}

fn parse(text: &str) {
    match ErrorMap::from_csv(text) {
        Ok(m) => check_usable(&m),
        Err(e) => assert!(e.line >= 1 && !e.message.is_empty(), "{e:?}"),
    }
}

#[test]
fn the_base_map_parses() {
    let m = ErrorMap::from_csv(BASE).unwrap();
    assert_eq!(m.localizers, ["laser", "wifi"]);
    check_usable(&m);
}

proptest! {
    #![proptest_config(config(256))]

    #[test]
    fn mutated_maps_parse_or_fail_cleanly(
        mutations in prop::collection::vec(mutation(TOKENS, HOSTILE_NUMBERS), 1..6)
    ) {
        let text = apply(BASE, &mutations, number_spans);
        parse(&text);
    }

    #[test]
    fn any_declared_grid_is_refused_or_fits(
        width in any::<u64>(),
        height in any::<u64>(),
        resolution in any::<f64>(),
        origin in any::<f64>(),
        layers in 1usize..8,
    ) {
        let mut text = format!(
            "# atrium error map: origin_x={origin:?} origin_y=0 resolution={resolution:?} \
             width={width} height={height}\nlocalizer,i,j,x,y,mean_error,samples,sum\n"
        );
        for l in 0..layers {
            text.push_str(&format!("l{l},0,0,0,0,1,1,1\n"));
        }
        parse(&text);
    }
}

/// Inputs the fuzzer broke, kept as regression tests.
#[test]
fn regressions() {
    // NaN origin and infinite resolution used to be accepted (silent garbage).
    let nan = BASE.replacen("origin_x=-1", "origin_x=NaN", 1);
    assert!(ErrorMap::from_csv(&nan)
        .unwrap_err()
        .message
        .starts_with("origin_x: must be finite"));
    let inf = BASE.replacen("resolution=0.5", "resolution=inf", 1);
    assert!(ErrorMap::from_csv(&inf)
        .unwrap_err()
        .message
        .starts_with("resolution: must be finite"));
    // 10,000 × 10,000 cells passed the old check (1e8 cells per layer), then 60 layers asked
    // for 48.8 GB and aborted the process.
    let mut huge = String::from(
        "# atrium error map: origin_x=0 origin_y=0 resolution=1 width=10000 height=10000\n\
         localizer,i,j,x,y,mean_error,samples,sum\n",
    );
    for k in 0..60 {
        huge.push_str(&format!("l{k},0,0,0.5,0.5,1,1,1\n"));
    }
    let e = ErrorMap::from_csv(&huge).unwrap_err();
    assert_eq!(e.line, 1);
    assert!(e.message.contains("ERROR_MAP_MAX_VALUES"), "{e:?}");
    // Two rows of one cell whose sample counts add up past u32 used to overflow.
    let twice = format!("{BASE}laser,0,0,0,0,1,4294967295,1\n");
    assert!(ErrorMap::from_csv(&twice)
        .unwrap_err()
        .message
        .starts_with("samples:"));
    // Found by the fuzzer on the old parser: a lower-case `nan` origin was accepted, and a row
    // with 0 samples kept its sum in a cell no mean or CSV could show (lost on write-back).
    let nan = BASE.replacen("origin_x=-1", "origin_x=nan", 1);
    assert!(ErrorMap::from_csv(&nan).is_err());
    let zero = BASE.replacen(
        "wifi,0,0,-0.75,-0.75,2,3,6",
        "wifi,0,0,-0.75,-0.75,2,0,6",
        1,
    );
    let e = ErrorMap::from_csv(&zero).unwrap_err();
    assert_eq!(
        (e.line, e.message.as_str()),
        (6, "samples: must be at least 1, got 0")
    );
    // A byte-order mark before the header.
    assert!(ErrorMap::from_csv(&format!("\u{feff}{BASE}")).is_err());
}
