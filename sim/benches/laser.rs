//! Simulator throughput: one 181-beam scan among 100 walls (rays/s), one physics step
//! (steps/s) and 10 s of driving with odometry at 50 Hz and a 10 Hz SICK laser (real-time
//! factor = 10 s / measured time).

use atrium_robots::{LaserSpec, Pose2};
use atrium_sim::{fixtures, SimConfig, Simulation};
use criterion::{criterion_group, criterion_main, BatchSize, Criterion, Throughput};
use std::hint::black_box;

fn sim(lasers: Vec<LaserSpec>) -> Simulation {
    let config = SimConfig {
        start: Pose2::new(-10.0, 0.0, 0.0),
        lasers,
        seed: 1,
        ..Default::default()
    };
    Simulation::new(
        &fixtures::hundred_walls(),
        &fixtures::pioneer_3dx_like(),
        config,
    )
    .expect("the fixture world and robot are valid")
}

fn sick() -> LaserSpec {
    LaserSpec::sick_lms200("front", "laser")
}

fn benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("laser");
    g.throughput(Throughput::Elements(181));
    let mut s = sim(vec![sick()]);
    let pose = Pose2::new(-3.0, 0.0, 0.3);
    g.bench_function("scan_181_beams_100_walls", |b| {
        b.iter(|| black_box(s.scan_at(black_box(pose), 0)))
    });
    g.finish();

    let mut g = c.benchmark_group("physics");
    g.throughput(Throughput::Elements(1));
    let mut s = sim(vec![]);
    // Turning in place keeps the robot moving (contacts changing) forever in one spot.
    s.set_wheel_speeds(-2.0, 2.0).expect("finite");
    let mut out = Vec::new();
    g.bench_function("step", |b| {
        b.iter(|| {
            out.clear();
            black_box(s.step(&mut out))
        })
    });
    g.finish();

    let mut g = c.benchmark_group("drive");
    g.sample_size(20);
    g.throughput(Throughput::Elements(2000));
    g.bench_function("10s_200Hz_odometry_50Hz_laser_10Hz", |b| {
        b.iter_batched(
            || {
                let mut s = sim(vec![sick()]);
                s.set_route(&[[12.0, 0.0]]);
                (s, Vec::with_capacity(1024))
            },
            |(mut s, mut out)| {
                for _ in 0..2000 {
                    s.step(&mut out);
                }
                black_box(out.len())
            },
            BatchSize::PerIteration,
        )
    });
    g.finish();
}

criterion_group!(sim_benches, benches);
criterion_main!(sim_benches);
