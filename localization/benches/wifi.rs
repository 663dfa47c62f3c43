//! WiFi graph benchmarks (issue 4): graph learning time for 100,000 samples on 15 access
//! points (aim: under 30 s on one core), and the cost of one particle's WiFi likelihood for
//! graphs learnt from 1,000, 10,000 and 100,000 samples (it must not depend on the count).
//!
//! Also one whole filter update (motion, likelihood of every particle, estimate, resampling)
//! with 1,000 particles on the graph learnt from 10,000 samples (issue 19).
//!
//! `cargo bench -p atrium-localization --bench wifi`. Learning is timed once per size with
//! `Instant` (a criterion group would repeat a 10 s job ten times); the likelihood with
//! criterion. A filter argument skips the learning of groups it does not select
//! (`cargo bench -p atrium-localization --bench wifi -- wifi_update`).

use atrium_localization::mcl::InitialBelief;
use atrium_localization::wifi_graph::{WifiGraph, WifiGraphParams};
use atrium_localization::wifi_mcl::{WifiMcl, WifiMclParams};
use atrium_localization::{Localizer, OdometryDelta};
use atrium_robots::{Pose2, Reading, WifiReading, WifiScan};
use atrium_worlds::{Cell, OccupancyGrid};
use criterion::{criterion_group, Criterion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::sync::Arc;
use std::time::Instant;

const APS: usize = 15;

fn ap_position(a: usize) -> [f64; 2] {
    [4.0 + (a % 5) as f64 * 13.0, 5.0 + (a / 5) as f64 * 15.0]
}

/// RSSI of AP `a` at `p`: log-distance plus a smooth ripple, dBm.
fn rssi(a: usize, p: [f64; 2]) -> f64 {
    let c = ap_position(a);
    let d = ((c[0] - p[0]).powi(2) + (c[1] - p[1]).powi(2) + 6.0).sqrt();
    -38.0 - 27.0 * d.log10() + 4.0 * (0.35 * p[0] + a as f64).sin() * (0.25 * p[1]).cos()
}

/// `n` scans along a lawnmower route over a 60 × 40 m floor (lanes 2.5 m apart, repeated),
/// with 2 dB noise, 1 dB steps and a −90 dBm cut-off.
fn samples(n: usize) -> Vec<([f64; 2], WifiScan)> {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let lanes = 16;
    let lane_len = 58.0;
    let total = lanes as f64 * lane_len;
    (0..n)
        .map(|k| {
            // About 0.5 m between scans, around the route again and again.
            let s = (k as f64 * 0.5) % total;
            let lane = (s / lane_len).floor();
            let u = s - lane * lane_len;
            let x = if lane as i64 % 2 == 0 {
                1.0 + u
            } else {
                59.0 - u
            };
            let p = [
                x + rng.random_range(-0.2..0.2),
                1.0 + lane * 2.5 + rng.random_range(-0.2..0.2),
            ];
            let readings = (0..APS)
                .filter_map(|a| {
                    let z: f64 =
                        rand_distr::Distribution::sample(&rand_distr::StandardNormal, &mut rng);
                    let r = (rssi(a, p) + 2.0 * z).round();
                    (r >= -90.0).then(|| WifiReading {
                        ap: format!("ap{a:02}"),
                        channel: 1,
                        rssi_dbm: r,
                    })
                })
                .collect();
            (
                p,
                WifiScan {
                    stamp: k as f64,
                    sensor: "wifi".into(),
                    readings,
                },
            )
        })
        .collect()
}

fn learn(n: usize) -> (WifiGraph, f64) {
    let data = samples(n);
    let pairs: Vec<([f64; 2], &WifiScan)> = data.iter().map(|(p, s)| (*p, s)).collect();
    let t = Instant::now();
    let g = WifiGraph::learn(
        &pairs,
        [0.0, 0.0],
        [60.0, 40.0],
        &WifiGraphParams::default(),
        &|_| true,
    )
    .expect("learn");
    (g, t.elapsed().as_secs_f64())
}

fn grid() -> OccupancyGrid {
    OccupancyGrid {
        origin: [0.0, 0.0],
        resolution: 0.25,
        width: 240,
        height: 160,
        cells: vec![Cell::Free; 240 * 160],
    }
}

/// Whether the command line's filter (criterion's positional argument) can select a benchmark
/// named `name`, so an unselected group does not learn its graphs.
fn selected(name: &str) -> bool {
    let filters: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    filters.is_empty() || filters.iter().any(|f| name.contains(f.as_str()))
}

/// The scan heard at `p`: every AP but one in four, rounded like a receiver reports it.
fn scan_at(p: [f64; 2], stamp: f64) -> WifiScan {
    WifiScan {
        stamp,
        sensor: "wifi".into(),
        readings: (0..APS)
            .filter(|a| a % 4 != 3) // some missing
            .map(|a| WifiReading {
                ap: format!("ap{a:02}"),
                channel: 1,
                rssi_dbm: rssi(a, p).round(),
            })
            .collect(),
    }
}

/// One filter update with 1,000 particles: the motion step (a 0.1 m back-and-forth move), the
/// likelihood of every particle, the estimate and resampling.
fn update(c: &mut Criterion) {
    if !selected("wifi_update/1000_particles") {
        return;
    }
    let (g, _) = learn(10_000);
    let p = [23.3, 17.6];
    let reading = Reading::Wifi(scan_at(p, 0.0));
    let mut f = WifiMcl::new(
        "wifi",
        WifiMclParams {
            particles: 1000,
            ..Default::default()
        },
        Arc::new(g),
        &grid(),
        InitialBelief::Tracking {
            pose: Pose2::new(p[0], p[1], 0.0),
            sigma: [1.0, 1.0, 0.1],
        },
        1,
    )
    .unwrap();
    let mut group = c.benchmark_group("wifi_update");
    let mut odom = Pose2::default();
    let mut k = 0u64;
    group.bench_function("1000_particles", |b| {
        b.iter(|| {
            let step = if k & 1 == 0 { 0.1 } else { -0.1 };
            k += 1;
            let next = odom.compose(&Pose2::new(step, 0.0, 0.0));
            f.predict(&OdometryDelta {
                stamp: k as f64,
                from: odom,
                to: next,
            })
            .unwrap();
            odom = next;
            f.update(black_box(&reading)).unwrap();
            black_box(f.estimate())
        })
    });
    assert_eq!(f.particle_count(), 1000);
    group.finish();
}

fn likelihood(c: &mut Criterion) {
    if !selected("wifi_likelihood_per_particle/trained_on_100000") {
        return;
    }
    let mut group = c.benchmark_group("wifi_likelihood_per_particle");
    let p = [23.3, 17.6];
    let scan = scan_at(p, 0.0);
    for n in [1_000usize, 10_000, 100_000] {
        let (g, secs) = learn(n);
        eprintln!("graph learning, {n} samples x {APS} APs: {secs:.2} s (one core)");
        let mut f = WifiMcl::new(
            "wifi",
            WifiMclParams {
                particles: 1,
                ..Default::default()
            },
            Arc::new(g),
            &grid(),
            InitialBelief::Tracking {
                pose: atrium_robots::Pose2::new(p[0], p[1], 0.0),
                sigma: [0.0; 3],
            },
            1,
        )
        .unwrap();
        f.update(&Reading::Wifi(scan.clone())).unwrap(); // loads the scan
        group.bench_function(format!("trained_on_{n}"), |b| {
            b.iter(|| black_box(f.log_likelihood_at(black_box(p[0]), black_box(p[1]))))
        });
    }
    group.finish();
}

criterion_group!(benches, update, likelihood);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
