//! The atrium study reduced (issue 17, [004] §3): laser MCL and WiFi through a 10 m and a
//! 30 m atrium of the study's generated office (scenarios/atrium_study.toml), each cell with
//! its own WiFi survey. The laser localizes while the atrium's walls are within its 8 m range
//! of the aisle and is lost once they are not; WiFi's error does not depend on the width;
//! dead reckoning on the same routes is lost at both widths, so neither result is the
//! route's doing. The full study is scenarios/sweeps/atrium_size.toml (every width from 5 to
//! 40 m, laser and depth CGR too).
mod common;

use atrium_experiments::sweep::{run_sweep, Sweep, SweepSettings};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// atrium_study.toml without the CGR localizers, its paths made absolute, written to `dir`.
fn reduced_base(dir: &Path) -> PathBuf {
    let scenarios = root().join("scenarios");
    let text = std::fs::read_to_string(scenarios.join("atrium_study.toml")).unwrap();
    let mut doc: toml::Table = toml::from_str(&text).unwrap();
    let abs = |v: &toml::Value| {
        toml::Value::String(scenarios.join(v.as_str().unwrap()).display().to_string())
    };
    for key in ["world", "robot"] {
        let v = abs(&doc[key]);
        doc.insert(key.into(), v);
    }
    let localizers = doc["localizers"].as_array_mut().unwrap();
    localizers.retain(|l| !l["kind"].as_str().unwrap().starts_with("cgr"));
    for l in localizers.iter_mut() {
        let t = l.as_table_mut().unwrap();
        if let Some(v) = t.get("training").map(abs) {
            t.insert("training".into(), v);
        }
    }
    doc.remove("depth_cameras");
    let base = dir.join("atrium_base.toml");
    std::fs::write(&base, toml::to_string(&doc).unwrap()).unwrap();
    base
}

#[test]
fn the_laser_is_lost_in_a_wide_atrium_and_wifi_is_not() {
    let dir = common::tmpdir("atrium-study");
    let base = reduced_base(&dir);
    let file = dir.join("study.toml");
    std::fs::write(
        &file,
        format!(
            "base = {:?}\nseed = 17\ntrials = 2\n[axes]\n\"world.atrium_width\" = [10.0, 30.0]\n",
            base.display().to_string()
        ),
    )
    .unwrap();
    let sweep = Sweep::load(&file).unwrap();
    let out = dir.join("out");
    run_sweep(
        &sweep,
        &SweepSettings {
            out: out.clone(),
            jobs: Some(2),
            shard: None,
            resume: false,
            progress: false,
        },
    )
    .unwrap();
    let text = std::fs::read_to_string(out.join("failure_curves.csv")).unwrap();
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    // (localizer, width) -> column -> value
    let mut curves: BTreeMap<(String, String), BTreeMap<String, String>> = BTreeMap::new();
    for l in lines {
        let row: BTreeMap<String, String> = head
            .iter()
            .zip(l.split(','))
            .map(|(h, v)| (h.to_string(), v.to_string()))
            .collect();
        curves.insert((row["localizer"].clone(), row["value"].clone()), row);
    }
    let at = |loc: &str, width: &str, col: &str| -> f64 {
        curves[&(loc.to_string(), width.to_string())][col]
            .parse()
            .unwrap()
    };
    for w in ["10.0", "30.0"] {
        eprintln!(
            "width {w}: mcl median {:.3} m failed {:.2} lost {:.2}; wifi median {:.3} m failed \
             {:.2}; odometry failed {:.2}",
            at("mcl", w, "median_m"),
            at("mcl", w, "time_failed"),
            at("mcl", w, "lost"),
            at("wifi", w, "median_m"),
            at("wifi", w, "time_failed"),
            at("odometry", w, "time_failed"),
        );
    }
    // The laser: precise while the walls are in range, lost when they are not.
    assert!(at("mcl", "10.0", "time_failed") < 0.05);
    assert!(at("mcl", "10.0", "median_m") < 0.1);
    assert!(at("mcl", "30.0", "time_failed") > 0.3);
    assert_eq!(at("mcl", "30.0", "lost"), 1.0);
    // WiFi: bounded at both widths, its median changing by less than 2x.
    for w in ["10.0", "30.0"] {
        assert!(at("wifi", w, "time_failed") < 0.05, "width {w}");
    }
    let ratio = at("wifi", "30.0", "median_m") / at("wifi", "10.0", "median_m");
    assert!((0.5..2.0).contains(&ratio), "wifi median ratio {ratio}");
    // Dead reckoning on the same routes fails at both widths.
    for w in ["10.0", "30.0"] {
        assert!(at("odometry", w, "time_failed") > 0.5, "width {w}");
    }
}
