//! CGR in an open area with a few stray laser returns (the open-area failure of
//! [004] §3 as it showed in the sweeps): the point-to-line likelihood has
//! no term for beams that return nothing, so a handful of stray points would reward the
//! particles at the fringe of a wide cloud that place them on a wall the laser does not see,
//! and pull the whole cloud there. Observations with fewer than `min_points` points are not
//! used (the particles only move).

use atrium_localization::{Cgr, CgrParams, Localizer};
use atrium_robots::{LaserScan, Pose2, Reading};
use atrium_worlds::{Segment, VectorMap};

/// 181 beams over 180° (SICK LMS200-like), all out of range but four near +90° that return
/// 7.5 m: stray returns in open space, 10 m from the only wall.
fn stray_scan() -> Reading {
    let mut ranges = vec![8.0; 181];
    for r in &mut ranges[177..181] {
        *r = 7.5;
    }
    Reading::Laser(LaserScan {
        stamp: 0.1,
        sensor: "laser".into(),
        mount: Pose2::default(),
        angle_min: -std::f64::consts::FRAC_PI_2,
        angle_increment: std::f64::consts::PI / 180.0,
        range_min: 0.05,
        range_max: 8.0,
        ranges,
    })
}

fn estimate_after_stray_returns(min_points: usize) -> Pose2 {
    // The only wall: y = 10 (a thin box), far beyond the laser's 8 m from the truth (0, 0).
    let map = VectorMap {
        segments: vec![
            Segment {
                a: [-30.0, 10.0],
                b: [30.0, 10.0],
            },
            Segment {
                a: [30.0, 10.1],
                b: [-30.0, 10.1],
            },
        ],
    };
    let params = CgrParams {
        particles: 500,
        min_points,
        ..Default::default()
    };
    // A cloud 1 m wide after a long blind drive: some particles sit 2.5 m north, where the
    // stray returns would lie on the wall.
    let mut c = Cgr::laser(
        "cgr",
        params,
        &map,
        Pose2::new(0.0, 0.0, 0.0),
        [1.0, 1.0, 0.0],
        7,
    )
    .unwrap();
    let before = c.estimate().pose;
    assert!(before.y.abs() < 0.2, "{before:?}");
    c.update(&stray_scan()).unwrap();
    c.estimate().pose
}

#[test]
fn a_few_stray_returns_do_not_pull_the_cloud_onto_an_unseen_wall() {
    // Used as an observation (min_points = 3, the old behaviour), four stray points drag the
    // estimate metres north, toward the wall ...
    let pulled = estimate_after_stray_returns(3);
    assert!(pulled.y > 1.5, "{pulled:?}");
    // ... with the default (10) they are not an observation and the cloud stays put.
    let kept = estimate_after_stray_returns(CgrParams::default().min_points);
    assert!(kept.y.abs() < 0.2, "{kept:?}");
}
