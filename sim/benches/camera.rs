//! Cameras per frame (issue 5 item 7): one 160 × 120 intensity frame rendered in the lab
//! (19,200 rays through the rapier scene, Lambert shading under `tube` light), one stereo
//! pair block-matched (SAD, 32 disparities, 7 × 7 windows, texture, uniqueness and
//! left-right checks), and a whole stereo frame (both renders plus matching).

use atrium_robots::Pose2;
use atrium_sim::camera::{floor_pose, Camera, CameraSpec, Shader};
use atrium_sim::stereo::{StereoRig, StereoSpec};
use atrium_sim::Scene;
use atrium_worlds::lighting::LightingCondition;
use atrium_worlds::World;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;

fn benches(c: &mut Criterion) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/lab.toml");
    let world = World::load(&path).expect("lab world");
    let scene = Scene::new(&world, 200.0).expect("scene");
    let shader = Shader::new(&world, &scene, LightingCondition::Tube);
    let base = floor_pose(&Pose2::new(5.5, 3.5, 0.4));
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut g = c.benchmark_group("camera");
    g.sample_size(20);
    g.throughput(Throughput::Elements(160 * 120));

    let mut cam = Camera::new(CameraSpec::paper("cam"), "camera").expect("valid");
    let mut pixels = vec![0.0; 160 * 120];
    g.bench_function("intensity_frame_160x120_lab", |b| {
        b.iter(|| cam.render_into(&scene, &shader, black_box(&base), &mut rng, &mut pixels))
    });

    let mut rig = StereoRig::new(StereoSpec::paper("stereo"), "stereo").expect("valid");
    let frame = rig.frame(&scene, &shader, &base, 0.0, &mut rng);
    let mut out = vec![0.0; 160 * 120];
    g.bench_function("stereo_match_160x120", |b| {
        b.iter(|| {
            rig.match_pair(black_box(&frame.left), black_box(&frame.right), &mut out)
                .expect("sizes match")
        })
    });
    g.bench_function("stereo_frame_160x120_lab", |b| {
        b.iter(|| black_box(rig.frame(&scene, &shader, &base, 0.0, &mut rng)))
    });
    g.finish();
}

criterion_group!(camera, benches);
criterion_main!(camera);
