//! FSPF on a synthetic 640 × 480 Kinect frame with Table 1's parameters (004 §2.2: real time
//! on the robot; the aim here is under 5 ms), and one CGR update (motion, r = 3 refinements,
//! acceptance, weighting, resampling) with the laser in the campus's office corridor.

use atrium_localization::{Cgr, CgrParams, FspfParams, Localizer, OdometryDelta, PlaneFilter};
use atrium_robots::{DepthCameraSpec, DepthImage, LaserScan, Mount3, Pose2, Reading};
use atrium_worlds::{geometry::ray_segment_intersection, World};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::hint::black_box;

/// A corridor seen by a level Kinect 0.5 m above the floor: walls 1 m to each side, an end
/// wall 4 m ahead, the floor; σ(z) noise.
fn frame() -> DepthImage {
    let spec = DepthCameraSpec::kinect("k", "camera");
    let (fx, fy, cx, cy) = spec.intrinsics();
    let (w, h) = (spec.image_width(), spec.image_height());
    let planes: [([f64; 3], f64); 4] = [
        ([1.0, 0.0, 0.0], 4.0),
        ([0.0, 1.0, 0.0], 1.0),
        ([0.0, 1.0, 0.0], -1.0),
        ([0.0, 0.0, 1.0], -0.5),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut depth = vec![0.0f32; w * h];
    for v in 0..h {
        for u in 0..w {
            let d = [1.0, -(u as f64 - cx) / fx, -(v as f64 - cy) / fy];
            let t = planes
                .iter()
                .filter_map(|(n, c)| {
                    let den = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
                    (den.abs() > 1e-9).then(|| c / den).filter(|t| *t > 0.0)
                })
                .fold(f64::INFINITY, f64::min);
            if t >= spec.range_min && t <= spec.range_max {
                let e: f64 = rng.sample(StandardNormal);
                depth[v * w + u] = (t + spec.sigma(t) * e) as f32;
            }
        }
    }
    DepthImage {
        stamp: 0.0,
        sensor: "k".into(),
        mount: Mount3::default(),
        width: w,
        height: h,
        fx,
        fy,
        cx,
        cy,
        depth,
    }
}

/// An exact 181-beam, 180° scan of the campus vector map from `pose`.
fn scan(world: &World, pose: Pose2) -> LaserScan {
    let map = world.vector_map(false);
    let ranges = (0..181)
        .map(|i| {
            let a =
                pose.theta - std::f64::consts::FRAC_PI_2 + i as f64 * std::f64::consts::PI / 180.0;
            map.segments
                .iter()
                .filter_map(|s| {
                    ray_segment_intersection([pose.x, pose.y], [a.cos(), a.sin()], s.a, s.b)
                })
                .fold(8.0f64, f64::min)
        })
        .collect();
    LaserScan {
        stamp: 0.0,
        sensor: "laser".into(),
        mount: Pose2::default(),
        angle_min: -std::f64::consts::FRAC_PI_2,
        angle_increment: std::f64::consts::PI / 180.0,
        range_min: 0.05,
        range_max: 8.0,
        ranges,
    }
}

fn benches(c: &mut Criterion) {
    let img = frame();
    let mut g = c.benchmark_group("fspf");
    g.throughput(Throughput::Elements(1));
    let mut fspf = PlaneFilter::new(FspfParams::default(), 1).expect("valid");
    g.bench_function("frame_640x480_table1", |b| {
        b.iter(|| black_box(fspf.filter(black_box(&img)).map(|f| f.points.len())))
    });
    g.finish();

    let world = World::campus().expect("campus");
    let pose = Pose2::new(14.0, 20.0, 0.0);
    let reading = Reading::Laser(scan(&world, pose));
    let mut g = c.benchmark_group("cgr");
    for particles in [100usize, 150, 300] {
        // cgr_corridor's motion model; the default's α = 0.05 spreads the cloud wider.
        let params = CgrParams {
            particles,
            alpha: [0.02; 4],
            ..Default::default()
        };
        let mut cgr = Cgr::laser(
            "cgr",
            params,
            &world.vector_map(false),
            pose,
            [0.05, 0.05, 0.02],
            1,
        )
        .expect("valid");
        let mut odom = Pose2::default();
        let mut k = 0u64;
        g.throughput(Throughput::Elements(particles as u64));
        g.bench_function(format!("laser_update_{particles}_particles"), |b| {
            b.iter(|| {
                // A back-and-forth of 5 cm (a scan's travel at 0.5 m/s and 10 Hz), so the
                // motion model spreads the cloud every update and each sample is refined as
                // on a drive. Standing still, the resampled copies of one pose would stop
                // refining after their first evaluation, a quarter of a drive's work.
                let step = if k & 1 == 0 { 0.05 } else { -0.05 };
                k += 1;
                let next = odom.compose(&Pose2::new(step, 0.0, 0.0));
                cgr.predict(&OdometryDelta {
                    stamp: k as f64,
                    from: odom,
                    to: next,
                })
                .unwrap();
                odom = next;
                cgr.update(black_box(&reading)).unwrap();
            })
        });
    }
    g.finish();
}

criterion_group!(cgr, benches);
criterion_main!(cgr);
