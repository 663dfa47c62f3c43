//! The `[people]` section (issue 17): parsed with defaults, integer densities accepted (what a
//! sweep axis such as `"people.density" = [0, 2, 5]` writes), bad values refused naming the
//! file and the field.

use atrium_scenarios::Scenario;

fn with_people(people: &str) -> Result<Scenario, String> {
    let path = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut table: toml::Table = text.parse().unwrap();
    let people: toml::Table = people.parse().unwrap();
    table.insert("people".into(), toml::Value::Table(people));
    Scenario::from_toml_str(&toml::to_string(&table).unwrap(), &path).map_err(|e| e.to_string())
}

#[test]
fn people_parse_with_defaults_and_integer_densities() {
    let path = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    let plain = Scenario::load(&path).unwrap();
    assert_eq!(plain.people, atrium_sim::PeopleParams::default());
    assert_eq!(plain.sim_config(1).people.density, 0.0);
    for (text, density) in [
        ("density = 0", 0.0),
        ("density = 2", 2.0),
        ("density = 5.5", 5.5),
    ] {
        let s = with_people(text).unwrap();
        assert_eq!(s.people.density, density);
        assert_eq!(s.people.speed, atrium_sim::PeopleParams::default().speed);
        assert_eq!(s.sim_config(1).people, s.people);
    }
    let s = with_people("density = 1\nspeed = 0.8\nradius = 0.3").unwrap();
    assert_eq!((s.people.speed, s.people.radius), (0.8, 0.3));
}

#[test]
fn bad_people_are_refused_naming_the_field() {
    for (text, field) in [
        ("density = -1.0", "people.density"),
        ("density = nan", "people.density"),
        ("density = inf", "people.density"),
        // r = 0.25 m discs cover more than a third of the floor above 169.8 per 100 m².
        ("density = 200.0", "people.density"),
        ("density = 50.0\nradius = 0.5", "people.density"),
        ("speed = 0.0", "people.speed"),
        ("speed = -1.2", "people.speed"),
        ("radius = 0.0", "people.radius"),
        ("radius = -0.25", "people.radius"),
        ("height = 0", "people.height"),
        ("crowd = 3", "people.crowd"),
    ] {
        let e = with_people(text).unwrap_err();
        assert!(
            e.contains(field) && e.contains("corridor_tracking.toml"),
            "{text}: {e}"
        );
    }
}
