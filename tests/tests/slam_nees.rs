//! NEES consistency of EKF-SLAM on the paper's setup ([003] §4;
//! issue 7): over M Monte Carlo runs of `scenarios/slam_paper.toml` (seeds 1..=M), the
//! average (x, y) NEES at each scoring instant must lie within the two-sided 95 % bounds of
//! χ²(2M) / M (Bar-Shalom et al., Estimation with Applications to Tracking, §5.4; the test
//! Bailey et al. use for EKF-SLAM consistency), at nearly all instants and on average.

use atrium_scenarios::slam::mean_nees_bounds;
use atrium_scenarios::{run_scenario, RunOptions, Scenario};

const RUNS: u64 = 10;

#[test]
fn ekf_slam_position_nees_is_within_chi_square_bounds() {
    let path = atrium_scenarios::bundled_scenarios_dir().join("slam_paper.toml");
    let scenario = Scenario::load(&path).expect("slam_paper.toml loads");
    let mut per_run: Vec<Vec<Option<f64>>> = Vec::new();
    for seed in 1..=RUNS {
        let r = run_scenario(
            &scenario,
            RunOptions {
                seed: Some(seed),
                ..Default::default()
            },
        )
        .expect("run");
        let ekf = r.localizers.iter().find(|l| l.name == "ekf").expect("ekf");
        per_run.push(ekf.samples.iter().map(|s| s.nees_xy).collect());
    }
    // Scoring instants are the same step counts in every run; runs end at slightly
    // different times (the route's end), so compare over the shortest.
    let len = per_run.iter().map(Vec::len).min().unwrap();
    let (lo, hi) = mean_nees_bounds(RUNS as usize);
    let mut anees = Vec::new();
    for k in 0..len {
        // Before the first detection the pose covariance is zero and NEES undefined.
        let v: Option<Vec<f64>> = per_run.iter().map(|r| r[k]).collect();
        if let Some(v) = v {
            anees.push(v.iter().sum::<f64>() / v.len() as f64);
        }
    }
    assert!(
        anees.len() > 1000,
        "only {} instants with a NEES",
        anees.len()
    );
    let inside = anees.iter().filter(|&&a| a >= lo && a <= hi).count() as f64 / anees.len() as f64;
    let mean = anees.iter().sum::<f64>() / anees.len() as f64;
    eprintln!(
        "ANEES over {RUNS} runs: bounds [{lo:.3}, {hi:.3}], {:.1} % of {} instants inside, time average {mean:.3}",
        100.0 * inside,
        anees.len()
    );
    assert!(
        inside >= 0.9,
        "only {:.1} % of instants within [{lo:.3}, {hi:.3}]",
        100.0 * inside
    );
    assert!(
        (lo..=hi).contains(&mean),
        "time-averaged ANEES {mean:.3} outside [{lo:.3}, {hi:.3}]"
    );
}
