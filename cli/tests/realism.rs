//! `atrium calibrate`, `twin` and `realism` on a bundled real log, cut short: the calibration
//! writes tables a scenario accepts, the twin loads and drives, and the realism report has
//! its interface fields and its drift agrees with the real one; with the old systematic-only
//! odometry (no random slip) the twin's drift does not vary, and the same check fails.

mod common;

use common::{atrium, datasets, tmpdir};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// The MIT CSAIL log scenario cut to its first `duration_s` seconds, MCL and dead reckoning.
fn mit_scenario(dir: &Path, duration_s: f64) -> PathBuf {
    let text = format!(
        r#"name = "mit_short"
map = "{map}"
seed = 1
duration_s = {duration_s}

[log]
path = "{log}"
reference = "{reference}"
relations = "{relations}"
reference_accuracy_m = 0.041

[initial_belief]
mode = "tracking"
sigma = [0.1, 0.1, 0.05]

[[localizers]]
name = "mcl"
kind = "mcl"

[[localizers]]
name = "odometry"
kind = "dead_reckoning"
"#,
        map = datasets("mit-csail/mit-csail_map.yaml"),
        log = datasets("mit-csail/mit-csail.clf.gz"),
        reference = datasets("mit-csail/mit-csail_reference.tum"),
        relations = datasets("mit-csail/mit-csail.relations"),
    );
    let p = dir.join("mit_short.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn calibrate_twin_and_realism_on_a_real_log() {
    let dir = tmpdir("realism");
    let s = mit_scenario(&dir, 200.0);
    let s = s.to_str().unwrap();

    let cal = dir.join("cal.toml");
    let o = atrium(&["calibrate", s, "-o", cal.to_str().unwrap(), "--json"]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let c: Value = serde_json::from_slice(&o.stdout).unwrap();
    let slip = c["odometry"]["slip_sigma"].as_f64().unwrap();
    assert!(slip > 0.0 && slip < 0.5, "{c}");
    let text = std::fs::read_to_string(&cal).unwrap();
    assert!(
        text.contains("[odometry]") && text.contains("[sensors.scan]"),
        "{text}"
    );

    let twin = dir.join("twin.toml");
    let o = atrium(&["twin", s, "-o", twin.to_str().unwrap()]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(dir.join("twin.urdf").is_file());

    let out = dir.join("out");
    let o = atrium(&[
        "realism",
        s,
        "--seeds",
        "1..3",
        "--json",
        "--out",
        out.to_str().unwrap(),
        "--report",
        dir.join("realism.html").to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let r: Value = serde_json::from_slice(&o.stdout).unwrap();
    let names: Vec<&str> = r["localizers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["mcl", "odometry"], "{r}");
    for l in r["localizers"].as_array().unwrap() {
        for part in ["real", "sim"] {
            for f in ["median", "p95", "failed_time_frac"] {
                assert!(l[part][f].is_number(), "{part}.{f} in {l}");
            }
        }
        for f in ["median", "p95", "failed_time_frac"] {
            assert_eq!(l["sim_spread"][f].as_array().unwrap().len(), 2, "{l}");
        }
        assert!(l["ratio"].get("median").is_some() && l["ratio"].get("p95").is_some());
    }
    for part in ["real", "sim"] {
        for f in ["median_pct", "p90_pct", "heading_deg_per_m"] {
            assert!(
                r["drift"][part][f].as_f64().unwrap() > 0.0,
                "drift.{part}.{f}: {r}"
            );
        }
    }
    // Dead reckoning differs between seeds now that the odometry has random slip.
    let spread = r["drift"]["sim_spread"]["median_pct"].as_array().unwrap();
    assert!(
        spread[1].as_f64().unwrap() > spread[0].as_f64().unwrap(),
        "the twin's drift is the same on every seed: {r}"
    );
    assert!(out.join("realism.json").is_file() && out.join("twin.toml").is_file());
    for stem in [
        "realism_error",
        "realism_drift",
        "realism_map_real",
        "realism_map_twin",
    ] {
        assert!(out.join(format!("{stem}.png")).is_file(), "{stem}.png");
        let svg = std::fs::read_to_string(out.join(format!("{stem}.svg"))).unwrap();
        assert!(
            svg.contains("<text") && svg.contains("mit_short"),
            "{stem}.svg"
        );
    }
    // One self-contained report with the comparison and the pictures inline.
    let html = std::fs::read_to_string(dir.join("realism.html")).unwrap();
    assert!(html.contains("Dead-reckoning drift") && html.matches("<svg").count() >= 4);
    assert!(!html.contains("https://") && !html.contains("src="));
    // The calibrated model's drift agrees with the real one: median, p90 and heading within
    // 0.67-1.5, and the real stretches fall within the seeds' range about as often as draws
    // of one process would.
    assert_eq!(r["drift"]["agrees"], true, "{}", r["drift"]);
    let covered = r["drift"]["coverage"].as_f64().unwrap();

    // Atrium's old odometry (systematic errors only) drifts alike on every seed: the same
    // check fails on it.
    let o = atrium(&[
        "realism",
        s,
        "--seeds",
        "1..3",
        "--json",
        "--systematic-only",
    ]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let r: Value = serde_json::from_slice(&o.stdout).unwrap();
    let d = &r["drift"];
    assert_eq!(d["agrees"], false, "{d}");
    let spread = d["sim_spread"]["median_pct"].as_array().unwrap();
    assert_eq!(spread[0], spread[1], "{d}");
    assert!(d["coverage"].as_f64().unwrap() < covered, "{d}");
}
