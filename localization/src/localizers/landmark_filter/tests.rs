use super::*;
use atrium_robots::LaserScan;

/// A 180-sample scan: `near` beams at `r_near` m, the rest at `r_far` m.
fn ranges(near: usize, r_near: f64, r_far: f64) -> Vec<f64> {
    (0..180)
        .map(|i| if i < near { r_near } else { r_far })
        .collect()
}

fn scan(stamp: f64, ranges: Vec<f64>) -> Reading {
    Reading::Laser(LaserScan {
        stamp,
        sensor: "laser".into(),
        mount: Pose2::default(),
        angle_min: -std::f64::consts::FRAC_PI_2,
        angle_increment: std::f64::consts::PI / 180.0,
        range_min: 0.05,
        range_max: 8.0,
        ranges,
    })
}

fn entropy(h: &Histogram) -> f64 {
    -h.iter().map(|p| p * p.ln()).sum::<f64>()
}

#[test]
fn signature_is_a_smoothed_six_bin_histogram() {
    // 8 m over 6 bins: 1.333 m each. 60 beams at 0.7 m (bin 0), 120 at 3.5 m (bin 2), plus one
    // pseudo-count per bin: (61, 1, 121, 1, 1, 1) / 186.
    let s = LandmarkSignature::from_ranges(&ranges(60, 0.7, 3.5), 8.0);
    let expect = [61.0, 1.0, 121.0, 1.0, 1.0, 1.0].map(|c| c / 186.0);
    for (a, b) in s.bins().iter().zip(&expect) {
        assert!((a - b).abs() < 1e-12, "{:?}", s.bins());
    }
    // Max-range readings land in the last bin; NaN is skipped.
    let s = LandmarkSignature::from_ranges(&[8.0, 9.0, f64::NAN], 8.0);
    assert!((s.bins()[5] - 3.0 / 8.0).abs() < 1e-12);
}

#[test]
fn identical_scans_match_and_different_landmarks_differ() {
    let a1 = LandmarkSignature::from_ranges(&ranges(60, 0.7, 3.5), 8.0);
    let a2 = LandmarkSignature::from_ranges(&ranges(60, 0.7, 3.5), 8.0);
    assert_eq!(a1, a2);
    assert_eq!(covariance_error(a1.bins(), a2.bins()), 0.0);
    // Another landmark: a box at 2 m in a third of the view, a wall at 5 m.
    let b = LandmarkSignature::from_ranges(&ranges(60, 2.0, 5.0), 8.0);
    let g = covariance_error(a1.bins(), b.bins());
    assert!(g > 1e-2, "γ between different landmarks {g}");
    // Eq. 6 by hand: p = (1, 0, ...), q = (0, 1, 0, ...): means 1/6, so
    // Cov = [(5/6)(−1/6) + (−1/6)(5/6) + 4 (1/36)] / 6 = (−10/36 + 4/36) / 6 = −1/36.
    let p = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let q = [0.0, 1.0, 0.0, 0.0, 0.0, 0.0];
    assert!((covariance(&p, &q) + 1.0 / 36.0).abs() < 1e-15);
    // γ = Cov[p,p] − 2 Cov[p,q] + Cov[q,q] = 5/36 + 2/36 + 5/36 = 1/3 = mean of (p − q)².
    assert!((covariance_error(&p, &q) - 1.0 / 3.0).abs() < 1e-15);
}

#[test]
fn posterior_concentrates_when_observations_repeat() {
    let obs = *LandmarkSignature::from_ranges(&ranges(60, 0.7, 3.5), 8.0).bins();
    let mut m = RecursiveLandmarkModel::new(obs, 0.5);
    let mut peak = 0.0;
    let mut ent = f64::INFINITY;
    let mut gamma = f64::INFINITY;
    // (1 − w)^12 = 2.4e-4: still short of the limit, so every step is a strict improvement.
    for _ in 0..12 {
        let post = *m.update(&obs);
        let (p, e, g) = (post[2], entropy(&post), m.gamma());
        assert!(
            p > peak && e < ent,
            "peak {p} <= {peak} or entropy {e} >= {ent}"
        );
        assert!(g <= gamma, "γ rose: {g} > {gamma}");
        (peak, ent, gamma) = (p, e, g);
    }
    for _ in 0..40 {
        m.update(&obs);
    }
    let gamma = m.gamma();
    // It settles on the node's signature, ∝ c^(1 + 1/w) = c³ for w = 0.5.
    assert!(gamma < 1e-12, "γ {gamma}");
    let cubes = obs.map(|c| c.powi(3));
    let s: f64 = cubes.iter().sum();
    assert!((m.posterior()[2] - cubes[2] / s).abs() < 1e-9);
    // Sharper than the observation itself: Bayes multiplies prior and conditional.
    assert!(entropy(m.posterior()) < entropy(&obs));
    // A different landmark keeps γ away from zero.
    // (With the default weight: the larger w, the less the conditional dominates.)
    let other = *LandmarkSignature::from_ranges(&ranges(60, 2.0, 5.0), 8.0).bins();
    let mut m =
        RecursiveLandmarkModel::new(obs, LandmarkFilterParams::default().observation_weight);
    for _ in 0..40 {
        m.update(&other);
    }
    assert!(m.gamma() > 1e-2, "γ {}", m.gamma());
}

fn model_at(node: [f64; 2], r: &[f64], gamma_n: f64) -> NodeModel {
    NodeModel {
        node,
        conditional: *LandmarkSignature::from_ranges(r, 8.0).bins(),
        gamma_n,
        gamma_inside_max: gamma_n,
        gamma_outside_min: None,
        scans_inside: 1,
        reference: None,
    }
}

fn odo(stamp: f64, from: Pose2, to: Pose2) -> OdometryDelta {
    OdometryDelta { stamp, from, to }
}

#[test]
fn a_node_is_not_verified_outside_rho_nor_during_the_warmup() {
    let landmark = ranges(60, 0.7, 3.5);
    let models = vec![model_at([5.0, 0.0], &landmark, 1e-3)];
    let params = LandmarkFilterParams {
        warmup_steps: 5,
        ..Default::default()
    };
    let mut f = LandmarkFilter::new("lf", params, models, Pose2::default(), 0.05).unwrap();
    // Odometry puts the robot 0.5 m short of the node (outside ρ = 0.25 m); the scans match
    // the landmark perfectly, yet the node is not verified.
    let p0 = Pose2::default();
    let p1 = Pose2::new(4.5, 0.0, 0.0);
    f.predict(&odo(1.0, p0, p1)).unwrap();
    for k in 0..20 {
        f.update(&scan(1.0 + 0.1 * k as f64, landmark.clone()))
            .unwrap();
    }
    assert!(f.gamma() < 1e-3, "γ {}", f.gamma());
    assert_eq!(f.next_node(), 0);
    assert!(f.events().is_empty());
    assert_eq!(f.take_node_verification(), None);
    // Inside ρ (0.2 m from the node), with matching scans: verified, pose reset to the node.
    let p2 = Pose2::new(4.8, 0.01, 0.02);
    f.predict(&odo(3.0, p1, p2)).unwrap();
    f.update(&scan(3.1, landmark.clone())).unwrap();
    assert_eq!(f.next_node(), 1);
    assert_eq!(f.take_node_verification(), Some(0));
    assert_eq!(f.take_node_verification(), None, "taken once");
    let e = f.estimate();
    assert_eq!((e.pose.x, e.pose.y), (5.0, 0.0));
    assert!((e.pose.theta - 0.02).abs() < 1e-12, "heading is kept");
    assert!(f.events()[0].verified);

    // Warm-up: inside ρ from the first scan, nothing is verified during the first 5 scans.
    let models = vec![model_at([0.1, 0.0], &landmark, 1e-3)];
    let params = LandmarkFilterParams {
        warmup_steps: 5,
        ..Default::default()
    };
    let mut f = LandmarkFilter::new("lf", params, models, Pose2::default(), 0.05).unwrap();
    for k in 0..5 {
        f.update(&scan(0.1 * k as f64, landmark.clone())).unwrap();
        assert_eq!(f.next_node(), 0, "verified during warm-up at scan {k}");
    }
    f.update(&scan(0.6, landmark.clone())).unwrap();
    assert_eq!(f.next_node(), 1);
}

#[test]
fn a_different_landmark_is_not_verified_and_odometry_reaches_the_node() {
    let models = vec![
        model_at([5.0, 0.0], &ranges(60, 0.7, 3.5), 1e-3),
        model_at([5.0, 5.0], &ranges(60, 0.7, 3.5), 1e-3),
    ];
    let params = LandmarkFilterParams {
        warmup_steps: 2,
        ..Default::default()
    };
    let mut f = LandmarkFilter::new("lf", params, models, Pose2::default(), 0.05).unwrap();
    let p1 = Pose2::new(4.9, 0.0, 0.0);
    f.predict(&odo(1.0, Pose2::default(), p1)).unwrap();
    for k in 0..10 {
        f.update(&scan(1.0 + 0.1 * k as f64, ranges(60, 2.0, 5.0)))
            .unwrap();
    }
    assert_eq!(f.next_node(), 0, "γ {}", f.gamma());
    // Table I moveTo: within γ_d of the node by odometry, update() without verification.
    f.predict(&odo(3.0, p1, Pose2::new(4.97, 0.0, 0.0)))
        .unwrap();
    assert_eq!(f.next_node(), 1);
    assert_eq!(f.take_node_verification(), None);
    assert!(!f.events()[0].verified);
    assert_eq!((f.estimate().pose.x, f.estimate().pose.y), (5.0, 0.0));
}

#[test]
fn training_learns_the_conditional_and_gamma_n() {
    let nodes = [[5.0, 0.0]];
    let landmark = ranges(60, 0.7, 3.5);
    // A leg of 40 scans: 35 far from the node (another view), 5 inside ρ.
    let mut scans = Vec::new();
    for k in 0..40 {
        let x = 0.1 * k as f64 + if k >= 35 { 1.3 } else { 0.0 };
        let r = if k >= 35 {
            landmark.clone()
        } else {
            ranges(10, 2.0, 5.0)
        };
        scans.push(TrainingScan {
            pose: Pose2::new(x, 0.0, 0.0),
            target: 0,
            ranges: r,
            range_max: 8.0,
            geometry: Default::default(),
        });
    }
    // Model radius = ρ: every scan within 0.25 m of the node counts.
    let params = LandmarkFilterParams {
        warmup_steps: 30,
        model_radius: 0.25,
        ..Default::default()
    };
    let models = train(&nodes, &scans, &[], &params).unwrap();
    let m = &models[0];
    assert_eq!(m.scans_inside, 5);
    assert_eq!(
        m.conditional,
        *LandmarkSignature::from_ranges(&landmark, 8.0).bins()
    );
    assert!((m.gamma_n - 1.5 * m.gamma_inside_max).abs() < 1e-15);
    // Far from the node γ stays above the threshold: the landmark tells the node apart.
    assert!(m.gamma_outside_min.unwrap() > m.gamma_n);
    // A margin that would reach the far γ is cut to the geometric mean of near and far.
    let wide = LandmarkFilterParams {
        gamma_margin: 1e9,
        ..params.clone()
    };
    let w = &train(&nodes, &scans, &[], &wide).unwrap()[0];
    let (inside, outside) = (w.gamma_inside_max, w.gamma_outside_min.unwrap());
    assert!(inside > 0.0 && outside > inside);
    assert!((w.gamma_n - (inside * outside).sqrt()).abs() < 1e-15 * outside.max(1.0));
    assert!(inside < w.gamma_n && w.gamma_n < outside);

    // No scan inside ρ: a clear error naming the node.
    let far: Vec<TrainingScan> = scans.iter().take(30).cloned().collect();
    let e = train(&nodes, &far, &[], &params).unwrap_err().to_string();
    assert!(e.contains("node 0") && e.contains("rho"), "{e}");
    // A survey inside ρ is enough on its own, and its settled γ sets γ_n.
    let survey: Vec<TrainingScan> = (0..3)
        .map(|k| TrainingScan {
            pose: Pose2::new(5.0 + 0.1 * k as f64, 0.0, 0.0),
            target: 0,
            ranges: ranges(60 + 5 * k, 0.7, 3.5),
            range_max: 8.0,
            geometry: Default::default(),
        })
        .collect();
    let m = &train(&nodes, &far, &survey, &params).unwrap()[0];
    assert_eq!(m.scans_inside, 3);
    let model = RecursiveLandmarkModel::new(m.conditional, params.observation_weight);
    let worst = survey
        .iter()
        .map(|s| model.settled_gamma(LandmarkSignature::from_ranges(&s.ranges, 8.0).bins()))
        .fold(0.0, f64::max);
    assert!((m.gamma_inside_max - worst).abs() < 1e-15);
    // The settled γ of the model's own conditional is zero.
    assert!(model.settled_gamma(&m.conditional) < 1e-15);
}

#[test]
fn bad_parameters_are_rejected() {
    let p = LandmarkFilterParams {
        rho: 0.0,
        ..Default::default()
    };
    assert!(p.validate().unwrap_err().contains("rho"));
    let p = LandmarkFilterParams {
        rho: -0.25,
        ..Default::default()
    };
    assert!(p.validate().unwrap_err().contains("rho"));
    let e = LandmarkFilter::new("lf", p, Vec::new(), Pose2::default(), 0.05).unwrap_err();
    assert!(e.to_string().contains("rho"), "{e}");
    let e = LandmarkFilter::new(
        "lf",
        LandmarkFilterParams::default(),
        Vec::new(),
        Pose2::default(),
        0.05,
    )
    .unwrap_err();
    assert!(e.to_string().contains("empty"), "{e}");
    let p = LandmarkFilterParams {
        observation_weight: 0.0,
        ..Default::default()
    };
    assert!(p.validate().unwrap_err().contains("observation_weight"));
    let p = LandmarkFilterParams {
        model_radius: 0.3,
        ..Default::default()
    };
    assert!(p.validate().unwrap_err().contains("model_radius"));
    let p = LandmarkFilterParams {
        training_runs: 0,
        ..Default::default()
    };
    assert!(p.validate().unwrap_err().contains("training_runs"));
    let p = LandmarkFilterParams {
        survey_heading: -0.1,
        ..Default::default()
    };
    assert!(p.validate().unwrap_err().contains("survey_heading"));
    assert!(train(&[], &[], &[], &LandmarkFilterParams::default()).is_err());
}

#[test]
fn training_runs_above_the_limit_are_refused() {
    let p = |runs: usize| LandmarkFilterParams {
        training_runs: runs,
        ..LandmarkFilterParams::default()
    };
    assert!(p(crate::limits::MAX_TRAINING_RUNS).validate().is_ok());
    assert_eq!(
        p(1_000_000_000_000).validate().unwrap_err(),
        "training_runs: 1000000000000 is more than the limit of 100 (MAX_TRAINING_RUNS)"
    );
}

#[test]
fn the_rim_rule_sets_gamma_n_where_the_approach_crosses_rho() {
    // One approach, 1.0 m to 0 m from the node in 0.1 m steps: the landmark's 60 beams come
    // nearer as the robot approaches, so γ falls toward the node (002 Fig. 4c).
    let nodes = [[5.0, 0.0]];
    let scans: Vec<TrainingScan> = (0..=10)
        .map(|k| {
            let d = 1.0 - 0.1 * k as f64;
            TrainingScan {
                pose: Pose2::new(5.0 - d, 0.0, 0.0),
                target: 0,
                ranges: ranges(60, 0.7 + d, 3.5),
                range_max: 8.0,
                geometry: Default::default(),
            }
        })
        .collect();
    let params = LandmarkFilterParams {
        warmup_steps: 2,
        gamma_rule: GammaRule::Rim,
        ..Default::default()
    };
    let m = &train(&nodes, &scans, &[], &params).unwrap()[0];
    // Replay: the first scan within ρ = 0.25 m is the one 0.2 m out (k = 8).
    let mut model = RecursiveLandmarkModel::new(m.conditional, params.observation_weight);
    let mut at_rim = f64::NAN;
    for (k, s) in scans.iter().enumerate() {
        model.update(LandmarkSignature::from_ranges(&s.ranges, 8.0).bins());
        if k == 8 {
            at_rim = model.gamma();
        }
    }
    assert!((m.gamma_n - params.gamma_margin * at_rim).abs() < 1e-15 * at_rim.max(1.0));
    // The disk rule takes the largest γ over the model disk instead: never tighter here.
    let disk = LandmarkFilterParams {
        gamma_rule: GammaRule::Disk,
        model_radius: 0.25,
        ..params.clone()
    };
    let d = &train(&nodes, &scans, &[], &disk).unwrap()[0];
    assert!(
        d.gamma_n >= m.gamma_n,
        "disk {} rim {}",
        d.gamma_n,
        m.gamma_n
    );
    // No teach scan inside ρ (only a survey scan there): the rim rule has nothing to learn
    // from and says so.
    let outside: Vec<TrainingScan> = scans[..8].to_vec();
    let survey = vec![TrainingScan {
        pose: Pose2::new(5.0, 0.0, 0.0),
        ..scans[10].clone()
    }];
    assert!(train(&nodes, &outside, &survey, &disk).is_ok());
    let e = train(&nodes, &outside, &survey, &params)
        .unwrap_err()
        .to_string();
    assert!(e.contains("node 0") && e.contains("rim"), "{e}");
}
