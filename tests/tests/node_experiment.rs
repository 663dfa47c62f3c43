//! The landmark-filter experiment of 002_4f056f43b5d8a234.txt (Table II): the bundled
//! scenario `wheelchair_nodes` run with the five seeds of its `[node_experiment]` table, the
//! node-error tables printed, and its checks required to pass.

use atrium_scenarios::{node_experiment::run_experiment, Scenario};

#[test]
fn wheelchair_node_table_over_five_runs() {
    let path = atrium_scenarios::bundled_scenarios_dir().join("wheelchair_nodes.toml");
    let scenario = Scenario::load(&path).expect("the bundled scenario loads");
    let exp = run_experiment(&scenario, None).expect("the experiment runs");
    println!("{}", exp.to_text());
    assert_eq!(exp.seeds.len(), 5);
    let filter = exp.table("filter").unwrap();
    let odometry = exp.table("odometry").unwrap();
    // The first node, reached from a known start, is verified in every run within ρ.
    for r in 0..5 {
        assert!(exp.verified[0][r], "run {r}: node 1 not verified");
        let e = filter.errors[0][r].unwrap();
        assert!(e <= 0.25, "run {r}: node 1 error {e} m");
    }
    // Both tables cover the same runs and nodes.
    assert_eq!(filter.errors.len(), 6);
    assert_eq!(odometry.errors.len(), 6);
    assert!(exp.passed(), "{}", exp.to_text());
}
