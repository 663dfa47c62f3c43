//! Recording overhead: the same 20 s of `corridor_tracking` run plain and recorded to MCAP,
//! plus the cost of recording one 160 × 120 depth image and one WiFi scan (sensors whose
//! simulation lands separately). Prints MB written per simulated minute.
//!
//! `cargo bench -p atrium-scenarios --bench record`

use atrium_recordings::{self as dataset, Recorder};
use atrium_robots::{DepthImage, Mount3, Pose2, Reading, WifiReading, WifiScan};
use atrium_scenarios::runner::{RunObserver, Tick};
use atrium_scenarios::{run_scenario, RunOptions, Scenario};
use criterion::{criterion_group, criterion_main, Criterion};

fn short(duration_s: f64) -> Scenario {
    let path = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let mut t: toml::Table = std::fs::read_to_string(&path).unwrap().parse().unwrap();
    t.insert("duration_s".into(), toml::Value::Float(duration_s));
    Scenario::from_toml_str(&toml::to_string(&t).unwrap(), &path).unwrap()
}

fn bench(c: &mut Criterion) {
    let scenario = short(20.0);
    let dir = std::env::temp_dir().join(format!("atrium-bench-record-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("bench.mcap");

    let rec = dataset::record(
        &atrium_scenarios::LocalizerRegistry::with_builtins(),
        &scenario,
        &out,
        RunOptions::default(),
    )
    .unwrap();
    let mb_per_min = rec.bytes as f64 / 1e6 / (rec.run.sim_time_s / 60.0);
    eprintln!(
        "recording: {} bytes, {} messages for {:.0} s simulated = {mb_per_min:.3} MB per simulated minute (laser + odometry + truth + 2 estimates)",
        rec.bytes, rec.messages, rec.run.sim_time_s
    );

    let mut g = c.benchmark_group("corridor_tracking_20s");
    g.sample_size(10);
    g.bench_function("run", |b| {
        b.iter(|| run_scenario(&scenario, RunOptions::default()).unwrap())
    });
    g.bench_function("run_and_record", |b| {
        b.iter(|| {
            dataset::record(
                &atrium_scenarios::LocalizerRegistry::with_builtins(),
                &scenario,
                &out,
                RunOptions::default(),
            )
            .unwrap()
        })
    });
    g.finish();

    // One depth image at 160 × 120 and one WiFi scan through the recorder.
    let depth = Reading::Depth(DepthImage {
        stamp: 0.0,
        sensor: "kinect".into(),
        mount: Mount3 {
            xyz: [0.1, 0.0, 0.5],
            rpy: [0.0; 3],
        },
        width: 160,
        height: 120,
        fx: 146.0,
        fy: 146.0,
        cx: 79.5,
        cy: 59.5,
        depth: (0..160 * 120)
            .map(|i| {
                if i % 9 == 0 {
                    0.0
                } else {
                    0.8 + (i % 977) as f32 * 0.0037
                }
            })
            .collect(),
    });
    let wifi = Reading::Wifi(WifiScan {
        stamp: 0.0,
        sensor: "wifi".into(),
        readings: (0..12)
            .map(|i| WifiReading {
                ap: format!("ap_{i}"),
                channel: [1, 6, 11][i % 3],
                rssi_dbm: -50.0 - i as f64,
            })
            .collect(),
    });
    let mut recorder = Recorder::create(&dir.join("sensors.mcap"), &scenario, 1).unwrap();
    let mut k = 0u64;
    let mut g = c.benchmark_group("record_message");
    for (name, reading) in [("depth_160x120", depth), ("wifi_12_aps", wifi)] {
        g.bench_function(name, |b| {
            b.iter(|| {
                k += 1;
                let tick = Tick {
                    t: k as f64 / 200.0,
                    truth: Some(Pose2::default()),
                    score: false,
                    events: Vec::new(),
                };
                recorder
                    .instant(&tick, std::slice::from_ref(&reading), None)
                    .unwrap()
            })
        });
    }
    g.finish();
    drop(recorder);
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, bench);
criterion_main!(benches);
