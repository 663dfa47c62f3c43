//! The landmark-filter experiment of [002] (Table II): the bundled
//! scenario `wheelchair_nodes` run with the five seeds of its `[node_experiment]` table, the
//! node-error tables printed, and the paper's claims checked: every node verified by its
//! landmark, errors of the order of ρ, and a clear improvement over dead reckoning on the
//! same runs.

use atrium_experiments::node_experiment::run_experiment;
use atrium_scenarios::{LocalizerRegistry, Scenario};

#[test]
fn wheelchair_node_table_over_five_runs() {
    let path = atrium_scenarios::bundled_scenarios_dir().join("wheelchair_nodes.toml");
    let scenario = Scenario::load(&path).expect("the bundled scenario loads");
    let exp = run_experiment(&LocalizerRegistry::with_builtins(), &scenario, None)
        .expect("the experiment runs");
    println!("{}", exp.to_text());
    assert_eq!(exp.seeds.len(), 5);
    let filter = exp.table("filter").unwrap();
    let odometry = exp.table("odometry").unwrap();
    assert_eq!(filter.errors.len(), 6);
    assert_eq!(odometry.errors.len(), 6);
    let rho = 0.25;
    for n in 0..6 {
        for r in 0..5 {
            // Every node of every run is verified by its landmark, and the reset comes from
            // the scan alignment.
            assert!(exp.verified[n][r], "run {r}: node {} not verified", n + 1);
            assert!(exp.aligned[n][r], "run {r}: node {} not aligned", n + 1);
            // The filter's pose at the node is within ρ of the truth …
            let e = filter.errors[n][r].unwrap();
            assert!(e <= rho, "run {r}: node {} filter error {e} m", n + 1);
            // … and the robot really stood near the node: within 2ρ (002 Table II: ~ρ).
            let d = exp.reach.errors[n][r].unwrap();
            assert!(d <= 2.0 * rho, "run {r}: node {} reached at {d} m", n + 1);
        }
    }
    // Dead reckoning on the same runs, at the same instants, drifts far beyond ρ by the last
    // node, and the filter beats it on average by a wide margin.
    let last_odometry: f64 = (0..5).map(|r| odometry.errors[5][r].unwrap()).sum::<f64>() / 5.0;
    assert!(
        last_odometry > 2.0 * rho,
        "odometry at node 6: {last_odometry} m"
    );
    let (f, o) = (filter.mean().unwrap(), odometry.mean().unwrap());
    assert!(o > 5.0 * f, "filter {f} m vs odometry {o} m");
    // 002's own reset runs beside it (issue 16). What holds there: the first node is verified
    // by its landmark on every run, with the robot truly about ρ from it (Table II: 217-268 mm),
    // which dead reckoning (no verification at all) cannot do. What does not hold yet, and is
    // deliberately not claimed: later nodes (10/30 verified on seeds 1-5; see NOTES.md).
    let paper = exp
        .paper
        .as_ref()
        .expect("paper_reset = true runs 002's reset");
    assert_eq!(paper.seeds, exp.seeds);
    assert_eq!(paper.calibration, exp.calibration);
    for r in 0..5 {
        assert!(
            paper.verified[0][r],
            "002 reset, run {r}: node 1 not verified"
        );
        assert!(!paper.aligned[0][r], "002 reset must not align");
        let d = paper.reach.errors[0][r].unwrap();
        assert!(
            (0.15..=0.30).contains(&d),
            "002 reset, run {r}: node 1 at {d} m"
        );
        // Table I's reset puts the pose on the node itself, so its error is that distance.
        let e = paper.table("filter").unwrap().errors[0][r].unwrap();
        assert!((e - d).abs() < 0.02, "run {r}: {e} vs {d}");
    }
    // The scenario's own expectations (the paper's claims) hold.
    assert!(exp.passed(), "{}", exp.to_text());
}
