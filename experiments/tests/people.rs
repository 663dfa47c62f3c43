//! Pedestrians as a sweep axis (issue 17): `people.density` is swept like any scenario key.

#[test]
fn people_density_is_a_sweep_axis() {
    let dir = atrium_scenarios::bundled_scenarios_dir().join("sweeps");
    let file = dir.join("people_density_test.toml");
    let text = "base = \"../people_corridor.toml\"\nseed = 1\ntrials = 1\n\n[axes]\n\"people.density\" = [0, 2, 5]\n";
    let sweep = atrium_experiments::sweep::Sweep::from_toml_str(text, &file).unwrap();
    assert_eq!(sweep.cells(), 3);
    let densities: Vec<f64> = (0..3)
        .map(|c| sweep.cell_scenario(c).unwrap().people.density)
        .collect();
    assert_eq!(densities, [0.0, 2.0, 5.0]);
    // A crowd that fills the floor is refused before any trial runs, naming the field.
    let bad = text.replace("[0, 2, 5]", "[0, 500]");
    let e = atrium_experiments::sweep::Sweep::from_toml_str(&bad, &file)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("people.density"), "{e}");
}
