//! The illumination experiment of 000 §VII (Fig. 4) as a test, driven by the bundled
//! scenario `appearance_lab` and its `[appearance_experiment]` table: under the training
//! light (`tube`) the sensor model's error is what a 50 cm grid allows; under `bulb` and
//! `natural` light adding sparse disparity lowers both the mean and the variance of the
//! error; the training disparities are sparse and agree with the ground truth; EM-PCA at
//! the paper's size (N = 100, d = 20, D = 19200, ~20 % missing) converges.

use atrium_experiments::appearance_lab::run_experiment;
use atrium_scenarios::Scenario;

#[test]
fn lab_illumination_experiment() {
    let path = atrium_scenarios::bundled_scenarios_dir().join("appearance_lab.toml");
    let scenario = Scenario::load(&path).expect("the bundled scenario loads");
    let exp = run_experiment(&scenario).expect("the experiment runs");
    let text = exp.to_text();
    println!("{text}");
    let r = &exp.report;
    assert_eq!(r.training_images, 19 * 11 * 36);
    assert_eq!(
        r.conditions
            .iter()
            .map(|c| c.lighting.as_str())
            .collect::<Vec<_>>(),
        ["tube", "bulb", "natural"]
    );
    assert!(r.disparity_within_1px >= 0.95, "{text}");
    assert!(
        r.disparity_missing > 0.1 && r.disparity_missing < 0.45,
        "{text}"
    );
    let tube = &r.conditions[0];
    assert!(tube.intensity.mean <= 50.0, "{text}");
    assert!(tube.intensity_disparity.mean <= 50.0, "{text}");
    for c in &r.conditions[1..] {
        assert!(
            c.intensity_disparity.mean < c.intensity.mean,
            "{}: {text}",
            c.lighting
        );
        assert!(
            c.intensity_disparity.variance < c.intensity.variance,
            "{}: {text}",
            c.lighting
        );
    }
    let full = r.empca_full.as_ref().expect("EM-PCA at full size ran");
    assert_eq!((full.n, full.d, full.dim), (100, 20, 19200));
    assert!(full.missing > 0.1 && full.missing < 0.35, "{text}");
    assert!(full.converged && full.iterations > 1, "{text}");
    // The file's own claims (the same, stated in the scenario) all hold.
    assert_eq!(exp.checks.len(), 5);
    assert!(exp.passed(), "{text}");
}
