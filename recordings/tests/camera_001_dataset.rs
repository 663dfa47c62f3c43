//! The cameras of [001] in recordings (issue 5): the bundled `omni_lab` scenario with an
//! upward ceiling camera added, recorded to MCAP, has its panoramas and ceiling images as
//! `mono8` RawImages on `/image/<camera>` with the projection named in the channel metadata;
//! they decode back into exactly the readings the simulator produced, and replaying the file
//! gives the live run's metrics (the omni localizer included).

#[allow(dead_code)] // this test uses only `tmpdir`
mod common;

use atrium_formats::mcap::images;
use atrium_recordings::{self as dataset, ReplayOptions};
use atrium_robots::{IntensityImage, Reading};
use atrium_scenarios::seeds::derive_seed;
use atrium_scenarios::{report, run_scenario, RunOptions, Scenario};
use common::tmpdir;
use foxglove::messages as fg;
use foxglove::Decode;

const DURATION_S: f64 = 4.0;

fn short() -> Scenario {
    let path = atrium_scenarios::bundled_scenarios_dir().join("omni_lab.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut table: toml::Table = text.parse().unwrap();
    table.insert("duration_s".into(), toml::Value::Float(DURATION_S));
    // Expectations are for the whole lap; this is a few seconds of it.
    table.remove("expect");
    let ceiling: toml::Table = "kind = \"ceiling\"\nrate_hz = 4.0\n".parse().unwrap();
    table["sensors"]
        .as_table_mut()
        .unwrap()
        .insert("ceiling".into(), toml::Value::Table(ceiling));
    Scenario::from_toml_str(&toml::to_string(&table).unwrap(), &path).unwrap()
}

#[test]
fn panoramas_and_ceiling_images_round_trip_through_mcap_and_replay() {
    let scenario = short();
    let dir = tmpdir("camera_001_roundtrip");
    let out = dir.join("omni.mcap");
    let rec = dataset::record(
        &atrium_scenarios::LocalizerRegistry::with_builtins(),
        &scenario,
        &out,
        RunOptions::default(),
    )
    .unwrap();

    let mut sim = atrium_sim::Simulation::new(
        &scenario.world,
        &scenario.robot,
        scenario.sim_config(derive_seed(scenario.seed, "sim")),
    )
    .unwrap();
    sim.set_route(&scenario.waypoints);
    let mut live = Vec::new();
    while sim.time() < DURATION_S - 1e-9 {
        sim.step(&mut live);
    }
    let live_of = |name: &str| -> Vec<IntensityImage> {
        live.iter()
            .filter_map(|r| match r {
                Reading::Intensity(i) if i.sensor == name => Some(i.clone()),
                _ => None,
            })
            .collect()
    };
    let (live_omni, live_up) = (live_of("omni"), live_of("ceiling"));
    assert_eq!(
        (live_omni.len(), live_up.len()),
        (8, 16),
        "2 Hz and 4 Hz for 4 s"
    );

    let bytes = std::fs::read(&out).unwrap();
    let (mut omni, mut up) = (Vec::new(), Vec::new());
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let meta = &m.channel.metadata;
        let stamp = m.log_time as f64 * 1e-9;
        let (list, sensor, projection) = match m.channel.topic.as_str() {
            "/image/omni" => (&mut omni, "omni", "cylindrical"),
            "/image/ceiling" => (&mut up, "ceiling", "pinhole"),
            _ => continue,
        };
        assert_eq!(m.channel.schema.as_ref().unwrap().name, "foxglove.RawImage");
        assert_eq!(meta["projection"], projection);
        let msg = fg::RawImage::decode(&m.data[..]).unwrap();
        assert_eq!(msg.encoding, "mono8");
        assert_eq!(msg.data.len(), (msg.width * msg.height) as usize);
        list.push(images::intensity_from_message(&msg, meta, sensor, stamp).unwrap());
    }
    for (got, want) in [(&omni, &live_omni), (&up, &live_up)] {
        assert_eq!(got.len(), want.len());
        for (a, b) in got.iter().zip(want.iter()) {
            assert_eq!(a.pixels, b.pixels);
            assert_eq!(
                (a.width, a.height, a.fx, a.fy, a.cx, a.cy, a.mount),
                (b.width, b.height, b.fx, b.fy, b.cx, b.cy, b.mount)
            );
            assert!((a.stamp - b.stamp).abs() < 1e-6);
        }
    }
    assert_eq!((omni[0].width, omni[0].height, omni[0].cx), (64, 16, 0.0));
    assert_eq!((up[0].width, up[0].height), (9, 9));

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
