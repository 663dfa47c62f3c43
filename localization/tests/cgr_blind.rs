//! CGR where its sensor sees nothing (the open area of [004] §3: walls
//! beyond the laser's range): the estimate must follow the odometry, not freeze at the last
//! pose where something was seen.

use atrium_localization::{Cgr, CgrParams, Localizer, OdometryDelta};
use atrium_robots::{LaserScan, Pose2, Reading};
use atrium_worlds::{Segment, VectorMap};

/// A scan with every beam out of range.
fn empty_scan(stamp: f64) -> Reading {
    Reading::Laser(LaserScan {
        stamp,
        sensor: "laser".into(),
        mount: Pose2::default(),
        angle_min: -std::f64::consts::FRAC_PI_2,
        angle_increment: std::f64::consts::PI / 180.0,
        range_min: 0.05,
        range_max: 8.0,
        ranges: vec![8.0; 181],
    })
}

#[test]
fn blind_cgr_estimate_follows_odometry() {
    // One wall far beyond the laser's 8 m: nothing is ever seen.
    let map = VectorMap {
        segments: vec![Segment {
            a: [100.0, -10.0],
            b: [100.0, 10.0],
        }],
    };
    let params = CgrParams {
        particles: 50,
        alpha: [0.0; 4],
        ..Default::default()
    };
    let mut cgr = Cgr::laser("cgr", params, &map, Pose2::new(0.0, 0.0, 0.0), [0.0; 3], 3).unwrap();
    let mut odo = Pose2::new(0.0, 0.0, 0.0);
    for k in 1..=50 {
        let next = odo.compose(&Pose2::new(0.1, 0.0, 0.01));
        cgr.predict(&OdometryDelta {
            stamp: k as f64 * 0.1,
            from: odo,
            to: next,
        })
        .unwrap();
        odo = next;
        cgr.update(&empty_scan(k as f64 * 0.1)).unwrap();
        let est = cgr.estimate().pose;
        // Noise-free motion model: the estimate is the odometry itself.
        assert!(
            est.distance(&odo) < 1e-9 && est.heading_error(&odo) < 1e-9,
            "step {k}: estimate {est:?}, odometry {odo:?}"
        );
    }
    assert!(odo.distance(&Pose2::default()) > 4.5, "the robot moved");
}
