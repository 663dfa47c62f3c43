//! One MCL update (1000 particles, a 181-beam scan) on a 60 × 40 m map at 0.05 m, and the
//! likelihood-field build on that map.

use atrium_localization::{
    InitialBelief, LikelihoodField, LikelihoodFieldParams, Localizer, Mcl, MclParams, OdometryDelta,
};
use atrium_robots::{LaserScan, Pose2, Reading};
use atrium_worlds::{Cell, OccupancyGrid};
use criterion::{criterion_group, criterion_main, Criterion};
use std::f64::consts::{FRAC_PI_2, PI};
use std::hint::black_box;

const RES: f64 = 0.05;

/// 60 × 40 m: outer walls, a corridor grid of 0.1 m walls every 10 m with 2 m doorways, and
/// a pillar every 5 m.
fn office_floor() -> OccupancyGrid {
    let (w, h) = (1200, 800);
    let mut cells = vec![Cell::Free; w * h];
    for j in 0..h {
        for i in 0..w {
            let x = (i as f64 + 0.5) * RES;
            let y = (j as f64 + 0.5) * RES;
            let border = x < 0.1 || y < 0.1 || x > 59.9 || y > 39.9;
            let wall_x = (x % 10.0) < 0.1 && (y % 10.0 - 5.0).abs() > 1.0;
            let wall_y = (y % 10.0) < 0.1 && (x % 10.0 - 5.0).abs() > 1.0;
            let pillar = (x % 5.0 - 2.5).abs() < 0.15 && (y % 5.0 - 2.5).abs() < 0.15;
            if border || wall_x || wall_y || pillar {
                cells[j * w + i] = Cell::Occupied;
            }
        }
    }
    OccupancyGrid {
        origin: [0.0, 0.0],
        resolution: RES,
        width: w,
        height: h,
        cells,
    }
}

fn scan_from(grid: &OccupancyGrid, pose: &Pose2) -> LaserScan {
    let range_max = 8.0;
    let mut ranges = Vec::with_capacity(181);
    for b in 0..181 {
        let a = pose.theta - FRAC_PI_2 + b as f64 * PI / 180.0;
        let (s, c) = a.sin_cos();
        let mut r = 0.0;
        let mut hit = false;
        while r < range_max {
            let (x, y) = (pose.x + r * c, pose.y + r * s);
            let (i, j) = ((x / RES) as usize, (y / RES) as usize);
            if i >= grid.width
                || j >= grid.height
                || grid.cells[j * grid.width + i] == Cell::Occupied
            {
                hit = true;
                break;
            }
            r += RES / 4.0;
        }
        ranges.push(if hit { r } else { range_max });
    }
    LaserScan {
        stamp: 0.0,
        sensor: "laser".into(),
        mount: Pose2::default(),
        angle_min: -FRAC_PI_2,
        angle_increment: PI / 180.0,
        range_min: 0.05,
        range_max,
        ranges,
    }
}

fn benches(c: &mut Criterion) {
    let grid = office_floor();
    let pose = Pose2::new(13.0, 12.0, 0.3);
    let scan = Reading::Laser(scan_from(&grid, &pose));

    c.bench_function("likelihood_field_build_60x40m_0.05", |b| {
        let params = LikelihoodFieldParams {
            z_hit: 0.95,
            z_rand: 0.05,
            sigma_hit: 0.2,
            max_dist: 2.0,
            range_max: 8.0,
        };
        b.iter(|| LikelihoodField::new(black_box(&grid), params).unwrap())
    });

    for max_beams in [30, 60, 181] {
        let params = MclParams {
            min_particles: 1000,
            max_particles: 1000,
            max_beams,
            ..MclParams::default()
        };
        let init = InitialBelief::Tracking {
            pose,
            sigma: [0.1, 0.1, 0.05],
        };
        let mut mcl = Mcl::new("bench", params, &grid, init, 1).unwrap();
        let mut odom = Pose2::default();
        let mut k = 0u64;
        c.bench_function(&format!("mcl_predict_update_1000p_{max_beams}beams"), |b| {
            b.iter(|| {
                // Small back-and-forth motion so the motion model runs every time while the
                // particles stay around the pose the scan was taken from.
                let step = if k & 1 == 0 { 0.02 } else { -0.02 };
                k += 1;
                let next = odom.compose(&Pose2::new(step, 0.0, 0.0));
                mcl.predict(&OdometryDelta {
                    stamp: k as f64,
                    from: odom,
                    to: next,
                })
                .unwrap();
                odom = next;
                mcl.update(black_box(&scan)).unwrap();
                black_box(mcl.estimate())
            })
        });
        assert_eq!(mcl.particle_count(), 1000);
    }
}

criterion_group!(mcl_benches, benches);
criterion_main!(mcl_benches);
