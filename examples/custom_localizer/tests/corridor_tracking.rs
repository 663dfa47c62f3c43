// README snippet: keep in sync with README.md and docs/own-localizer.md (checked by
// `readme_shows_this_test` below).
use atrium_scenarios::{bundled_scenarios_dir, LocalizerRegistry, RunOptions, Scenario};

#[test]
fn wall_ekf_tracks_in_corridor_tracking() {
    // Atrium's own localizer kinds, plus this crate's "wall_ekf".
    let mut registry = LocalizerRegistry::with_builtins();
    custom_localizer::register(&mut registry).unwrap();

    // A bundled scenario (laser MCL and dead reckoning "odometry") with our EKF beside them,
    // and its bounds: what an [expect.wall_ekf] table in the scenario file would hold.
    let path = bundled_scenarios_dir().join("corridor_tracking.toml");
    let mut scenario = Scenario::load(&path).unwrap();
    let params = toml::toml! { beams = 30  sigma_range = 0.05 };
    let expect = toml::toml! { median_max = 0.02  max_max = 0.10 };
    scenario
        .add_localizer("wall_ekf", "wall_ekf", params, expect)
        .unwrap();

    let result = registry.run(&scenario, RunOptions::default()).unwrap();
    assert!(result.passed(), "{:#?}", result.localizers); // MCL's bounds and ours

    let median = |name: &str| {
        let run = result.localizers.iter().find(|l| l.name == name).unwrap();
        run.metrics.as_ref().unwrap().position_error.median
    };
    // The bound means something: dead reckoning on the same run misses it by metres.
    assert!(median("wall_ekf") <= 0.02 && median("odometry") > 1.0);
    assert!(median("wall_ekf") < 1.5 * median("mcl")); // about laser MCL's precision
}

#[test]
fn readme_shows_this_test() {
    readme_snippet_is_this_test(include_str!("../README.md"), "README.md");
    readme_snippet_is_this_test(
        include_str!("../../../docs/own-localizer.md"),
        "docs/own-localizer.md",
    );
}

fn readme_snippet_is_this_test(readme: &str, which: &str) {
    let start = readme
        .find("```rust\n")
        .unwrap_or_else(|| panic!("{which} has a ```rust block"))
        + 8;
    let len = readme[start..].find("```").expect("the ```rust block ends");
    let snippet = &readme[start..start + len];
    assert!(
        snippet.lines().count() < 30,
        "the README snippet grew past 30 lines"
    );
    assert!(
        include_str!("corridor_tracking.rs").contains(snippet),
        "{which}'s snippet is not verbatim in tests/corridor_tracking.rs"
    );
}
