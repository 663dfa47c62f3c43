//! Scenario loading refuses bad numbers under the scenario's own field names, and accepts the
//! values just inside each limit.

use atrium_scenarios::{Scenario, ScenarioError};
use std::path::{Path, PathBuf};

fn file() -> PathBuf {
    // Beside the bundled scenarios, so the relative world and robot paths resolve.
    Path::new(env!("CARGO_MANIFEST_DIR")).join("limits_probe.toml")
}

fn scenario(start_theta: &str, extra: &str) -> Result<Scenario, ScenarioError> {
    let text = format!(
        r#"
name = "probe"
duration_s = 2.0
world = "../worlds/campus.toml"
robot = "../robots/urdf/pioneer3dx.urdf"
[start]
pose = [2.0, 20.0, {start_theta}]
[route]
waypoints = [[8.0, 20.0]]
[[localizers]]
name = "odometry"
kind = "dead_reckoning"
{extra}
"#
    );
    Scenario::from_toml_str(&text, &file())
}

#[test]
fn headings_are_wrapped_and_absurd_ones_refused() {
    let s = scenario("9.42477796076938", "").unwrap(); // 3π
    assert!((s.start.theta.abs() - std::f64::consts::PI).abs() < 1e-9);
    let s = scenario("-100.0", "").unwrap();
    assert!(s.start.theta.abs() <= std::f64::consts::PI);
    let e = scenario("100.5", "").unwrap_err().to_string();
    assert!(
        e.contains("start.pose: heading 100.5 rad is beyond the limit of ±100 rad"),
        "{e}"
    );
    let e = scenario("1e39", "").unwrap_err().to_string();
    assert!(e.contains("start.pose: heading"), "{e}");
}

#[test]
fn sensor_rates_above_the_physics_rate_are_refused_under_the_sensors_name() {
    let e = scenario("0.0", "[sensors.laser]\nrate_hz = 201")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("sensors.laser.rate_hz: 201 Hz is faster than physics_hz = 200 Hz"),
        "{e}"
    );
    assert!(!e.contains("lasers[0]") && !e.contains("start.pose"), "{e}");
    scenario("0.0", "[sensors.laser]\nrate_hz = 200").unwrap();
    let e = scenario("0.0", "[odometry]\nrate_hz = 250")
        .unwrap_err()
        .to_string();
    assert!(e.contains("odometry.rate_hz: 250 Hz"), "{e}");
}

fn route_with_speeds(speeds: &str) -> Result<Scenario, ScenarioError> {
    let text = format!(
        r#"
name = "probe"
duration_s = 2.0
world = "../worlds/campus.toml"
robot = "../robots/urdf/pioneer3dx.urdf"
[start]
pose = [2.0, 20.0, 0.0]
[route]
waypoints = [[8.0, 20.0], [12.0, 20.0]]
speeds = {speeds}
[[localizers]]
name = "odometry"
kind = "dead_reckoning"
"#
    );
    Scenario::from_toml_str(&text, &file())
}

#[test]
fn route_speeds_are_one_finite_positive_speed_per_waypoint() {
    let s = route_with_speeds("[0.3, 0.6]").unwrap();
    assert_eq!(s.route_speeds, vec![0.3, 0.6]);
    let e = route_with_speeds("[0.3]").unwrap_err().to_string();
    assert!(
        e.contains("route.speeds: has 1 speeds for 2 waypoints"),
        "{e}"
    );
    for bad in ["[0.3, 0.0]", "[0.3, -1.0]", "[0.3, nan]", "[0.3, inf]"] {
        let e = route_with_speeds(bad).unwrap_err().to_string();
        assert!(e.contains("route.speeds[1]"), "{bad}: {e}");
    }
}
