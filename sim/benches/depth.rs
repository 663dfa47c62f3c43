//! Depth camera ray casting (rays/s): one Kinect frame at full resolution (640 × 480) and at
//! the decimation the bundled scenarios use (160 × 120), from the office corridor of the
//! bundled campus (walls, floor, ceiling, pillars, furniture in view through doors).

use atrium_robots::{DepthCameraSpec, LinkMount, Pose2};
use atrium_sim::{fixtures, DepthCamera, Scene, SimConfig, Simulation};
use atrium_worlds::World;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use std::hint::black_box;

fn sim(decimation: usize) -> Simulation {
    let mut model = fixtures::pioneer_3dx_like();
    model.mounts.push(LinkMount {
        name: "camera".into(),
        pose: nalgebra::Isometry3::translation(0.12, 0.0, 0.4025),
    });
    let mut cam = DepthCameraSpec::kinect("kinect", "camera");
    cam.decimation = decimation;
    let config = SimConfig {
        start: Pose2::new(2.0, 20.0, 0.0),
        depth_cameras: vec![cam],
        seed: 1,
        ..Default::default()
    };
    Simulation::new(&World::campus().expect("campus"), &model, config).expect("valid")
}

fn benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("depth_camera");
    g.sample_size(20);
    for (decimation, pixels) in [(1usize, 640u64 * 480), (4, 160 * 120)] {
        let mut s = sim(decimation);
        g.throughput(Throughput::Elements(pixels));
        let pose = Pose2::new(14.0, 20.0, 0.2);
        g.bench_function(format!("frame_decimation_{decimation}_corridor"), |b| {
            b.iter(|| black_box(s.depth_at(black_box(pose), 0)))
        });
    }
    // The culled renderer against one query-pipeline cast per pixel (same depths), noiseless.
    let scene = Scene::new(&World::campus().expect("campus"), 200.0).expect("scene");
    let mount = nalgebra::Isometry3::translation(0.12, 0.0, 0.4025);
    let mut spec = DepthCameraSpec::kinect("kinect", "camera");
    spec.decimation = 4;
    let rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(1);
    let mut cam = DepthCamera::new(spec, &mount, rng, "kinect").expect("camera");
    let base = rapier3d::prelude::Pose::from_parts(
        rapier3d::prelude::Vector::new(14.0, 20.0, 0.0),
        rapier3d::prelude::Rotation::from_rotation_z(0.2),
    );
    g.throughput(Throughput::Elements(160 * 120));
    g.bench_function("cast_decimation_4_corridor_culled", |b| {
        b.iter(|| cam.cast(&scene, black_box(&base)))
    });
    g.bench_function("cast_decimation_4_corridor_pipeline", |b| {
        b.iter(|| cam.cast_reference(&scene, black_box(&base)))
    });
    g.finish();
}

criterion_group!(depth, benches);
criterion_main!(depth);
