//! The landmark-filter experiment of [002] (Table II): the bundled
//! scenario `wheelchair_nodes` run with the five seeds of its `[node_experiment]` table, the
//! node-error tables printed, and the paper's claims checked: nine in ten nodes verified by
//! their landmark, errors of the order of ρ, and a clear improvement over dead reckoning on
//! the same runs.

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
    // With the robot's random wheel slip a run can miss a node, and after it the rest of its
    // nodes (seeds 1-5: run 4 misses node 4, 327 mm from it; 27 of 30 verified; before the
    // slip all 30): at least 9 in 10 visits are verified.
    let mut verified = 0;
    for n in 0..6 {
        for r in 0..5 {
            if !exp.verified[n][r] {
                continue;
            }
            verified += 1;
            // A verified node's reset comes from the scan alignment …
            assert!(exp.aligned[n][r], "run {r}: node {} not aligned", n + 1);
            // … the filter's pose at the node is within ρ of the truth …
            let e = filter.errors[n][r].unwrap();
            assert!(e <= rho, "run {r}: node {} filter error {e} m", n + 1);
            // … and the robot really stood near the node: within 2.5ρ (002 Table II: ~ρ;
            // seeds 1-5 at most 514 mm with the slip, 500 mm before).
            let d = exp.reach.errors[n][r].unwrap();
            assert!(d <= 2.5 * rho, "run {r}: node {} reached at {d} m", n + 1);
        }
    }
    assert!(verified >= 27, "{verified} of 30 node visits verified");
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
    // which dead reckoning (no verification at all) cannot do. What does not hold, and is
    // deliberately not claimed: later nodes (10/30 verified on seeds 1-5). Even a perfect
    // landmark cannot verify them here (`landmark_node_diagnosis -- oracle`: 5/26): Table I's
    // reset keeps the chair's heading error, which puts it 0.4-1.3 m from nodes 2-6 (docs/design/0013-landmark-node-filter-scan-alignment.md,
    // issue 16).
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

/// 002's own method (Table I's reset, `scan_alignment = false`, `gamma_rule = "rim"`) in the
/// regime it is built for (`wheelchair_nodes_paper`: odometry that under-reads distance by
/// 3 %, heading calibrated): its `[node_experiment]` claims hold on seeds 1-5 and 6-10, and
/// dead reckoning on the same runs fails each of them.
#[test]
fn paper_reset_beats_dead_reckoning_when_odometry_errs_in_distance() {
    let path = atrium_scenarios::bundled_scenarios_dir().join("wheelchair_nodes_paper.toml");
    let base = Scenario::load(&path).expect("the bundled scenario loads");
    let table = base.node_experiment.as_ref().expect("[node_experiment]");
    let num = |k: &str| table.get(k).and_then(|v| v.as_float()).expect(k);
    let (mean_max, improvement_min) = (num("mean_error_max"), num("improvement_min"));
    let verified_min = table
        .get("verified_min")
        .and_then(|v| v.as_integer())
        .expect("verified_min") as usize;
    // The regime: a common-mode radius error (distance), heading calibrated.
    assert_eq!(base.odometry.scale_error, -0.03);
    assert_eq!(table.get("paper_reset"), None);
    let filter_spec = &base.localizers[0];
    assert_eq!(
        filter_spec.params.get("scan_alignment"),
        Some(&toml::Value::Boolean(false))
    );
    for first in [1u64, 6] {
        let mut scenario = base.clone();
        scenario.seed = first;
        let exp = run_experiment(&LocalizerRegistry::with_builtins(), &scenario, None)
            .expect("the experiment runs");
        println!("{}", exp.to_text());
        assert_eq!(exp.seeds, (first..first + 5).collect::<Vec<_>>());
        assert!(exp.paper.is_none());
        // Table I's reset, never the alignment; the pose is put on the node itself, so the
        // filter's error is the robot's true distance from the node (002 Table II).
        let filter = exp.table("filter").unwrap();
        for (n, row) in exp.aligned.iter().enumerate() {
            for (r, a) in row.iter().enumerate() {
                assert!(!a, "seeds {first}..: run {r} node {} aligned", n + 1);
                if exp.verified[n][r] {
                    let (e, d) = (
                        filter.errors[n][r].unwrap(),
                        exp.reach.errors[n][r].unwrap(),
                    );
                    assert!((e - d).abs() < 0.02, "run {r} node {}: {e} vs {d}", n + 1);
                }
            }
        }
        // The scenario's claims hold …
        assert!(exp.passed(), "seeds {first}..:\n{}", exp.to_text());
        // … and dead reckoning, on the same runs at the same instants, fails each: it
        // verifies no node (it has no landmark), its mean node error exceeds the bound, and
        // against itself the improvement is 1.
        let odometry = exp.table("odometry").unwrap().mean().unwrap();
        assert!(verified_min >= 1, "dead reckoning verifies none");
        assert!(
            odometry > mean_max,
            "seeds {first}..: odometry {odometry} m"
        );
        assert!(1.0 < improvement_min);
        let f = filter.mean().unwrap();
        assert!(
            odometry / f >= improvement_min,
            "seeds {first}..: {odometry} vs {f}"
        );
    }
}
