//! Cameras in recordings (issues 5 and 8): the bundled `appearance_lab` scenario (a stereo
//! head in the simulation stream) recorded to MCAP has its left images as `mono8` and its
//! disparity maps as `32FC1` RawImages on their own topics, they decode back into exactly
//! the readings the simulator produced, and replaying the file equals the live run.

#[allow(dead_code)] // this test uses only `tmpdir`
mod common;

use atrium_formats::mcap::images;
use atrium_recordings::{self as dataset, ReplayOptions};
use atrium_robots::Reading;
use atrium_scenarios::seeds::derive_seed;
use atrium_scenarios::{report, run_scenario, RunOptions, Scenario};
use common::tmpdir;
use foxglove::messages as fg;
use foxglove::Decode;

fn short(duration_s: f64) -> Scenario {
    let path = atrium_scenarios::bundled_scenarios_dir().join("appearance_lab.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut table: toml::Table = text.parse().unwrap();
    table.insert("duration_s".into(), toml::Value::Float(duration_s));
    Scenario::from_toml_str(&toml::to_string(&table).unwrap(), &path).unwrap()
}

#[test]
fn camera_images_round_trip_through_mcap_and_replay() {
    let scenario = short(3.0);
    let dir = tmpdir("camera_roundtrip");
    let out = dir.join("lab.mcap");
    let rec = dataset::record(
        &atrium_scenarios::LocalizerRegistry::with_builtins(),
        &scenario,
        &out,
        RunOptions::default(),
    )
    .unwrap();

    // What the simulator produced live (the runner's sim seed).
    let mut sim = atrium_sim::Simulation::new(
        &scenario.world,
        &scenario.robot,
        scenario.sim_config(derive_seed(scenario.seed, "sim")),
    )
    .unwrap();
    sim.set_route(&scenario.waypoints);
    let mut live = Vec::new();
    while sim.time() < 3.0 - 1e-9 {
        sim.step(&mut live);
    }
    let live_images: Vec<_> = live
        .iter()
        .filter_map(|r| match r {
            Reading::Intensity(i) => Some(i.clone()),
            _ => None,
        })
        .collect();
    let live_disp: Vec<_> = live
        .iter()
        .filter_map(|r| match r {
            Reading::Disparity(d) => Some(d.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(live_images.len(), 3, "1 Hz for 3 s");
    assert_eq!(live_disp.len(), 3);

    let bytes = std::fs::read(&out).unwrap();
    let (mut imgs, mut disps) = (Vec::new(), Vec::new());
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m.channel.schema.as_ref().map(|s| s.name.clone()).unwrap();
        let meta = &m.channel.metadata;
        let stamp = m.log_time as f64 * 1e-9;
        match m.channel.topic.as_str() {
            "/image/stereo" => {
                assert_eq!(schema, "foxglove.RawImage");
                let msg = fg::RawImage::decode(&m.data[..]).unwrap();
                assert_eq!(msg.encoding, "mono8");
                imgs.push(images::intensity_from_message(&msg, meta, "stereo", stamp).unwrap());
            }
            "/disparity/stereo" => {
                assert_eq!(schema, "foxglove.RawImage");
                let msg = fg::RawImage::decode(&m.data[..]).unwrap();
                assert_eq!(msg.encoding, "32FC1");
                disps.push(images::disparity_from_message(&msg, meta, "stereo", stamp).unwrap());
            }
            _ => {}
        }
    }
    assert_eq!(imgs.len(), 3);
    assert_eq!(disps.len(), 3);
    for (a, b) in imgs.iter().zip(&live_images) {
        assert_eq!(a.pixels, b.pixels);
        assert_eq!(
            (a.width, a.height, a.fx, a.mount),
            (b.width, b.height, b.fx, b.mount)
        );
        assert!((a.stamp - b.stamp).abs() < 1e-6);
    }
    for (a, b) in disps.iter().zip(&live_disp) {
        assert_eq!(
            (a.width, a.height, a.fx, a.baseline),
            (b.width, b.height, b.fx, b.baseline)
        );
        // NaN (missing) where the live map is missing, the same disparity elsewhere.
        for (x, y) in a.disparity.iter().zip(&b.disparity) {
            assert!(x == y || (x.is_nan() && y.is_nan()), "{x} vs {y}");
        }
        let m = b.missing_fraction();
        assert!(m > 0.0 && m < 1.0, "{m}");
    }

    // Replaying the file gives the live run's metrics.
    let strip = |r: &atrium_scenarios::RunResult| {
        let mut v = report::to_json(r);
        v.as_object_mut().unwrap().remove("timing");
        v
    };
    let live_run = run_scenario(&scenario, RunOptions::default()).unwrap();
    assert_eq!(strip(&rec.run), strip(&live_run));
    let replayed = dataset::replay(&out, ReplayOptions::default()).unwrap();
    assert_eq!(strip(&replayed.run), strip(&live_run));
}
