//! The wheelchair (002's robot) loads as a rear-drive chair and drives a square of nodes
//! through the physics on odometry alone.

use atrium_robots::Pose2;
use atrium_robots::{OdometrySpec, RobotModel};
use atrium_sim::NodeControllerParams;
use atrium_sim::{SimConfig, Simulation};

fn wheelchair() -> RobotModel {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../robots/urdf/wheelchair.urdf"
    );
    RobotModel::from_urdf(std::path::Path::new(path)).unwrap()
}

#[test]
fn the_wheelchair_loads_as_a_rear_drive_chair_with_front_casters() {
    let m = wheelchair();
    assert!((m.wheel_radius - 0.165).abs() < 1e-9);
    assert!((m.wheel_separation - 0.56).abs() < 1e-9);
    assert_eq!(m.casters.len(), 2);
    // Both casters ahead of the drive axle; the laser at the front, 0.30 m up.
    assert!(m.casters.iter().all(|c| c.center.x > 0.3));
    let laser = m.mount("laser").unwrap().pose.translation.vector;
    assert!(laser.x > 0.6 && (laser.z - 0.30).abs() < 1e-9);
    assert!((100.0..130.0).contains(&m.mass()));
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
}

#[test]
fn the_wheelchair_drives_a_node_square_through_physics() {
    let world = atrium_sim::fixtures::box_room(12.0, 12.0, "concrete");
    let config = SimConfig {
        start: Pose2::new(-2.0, -2.0, 0.0),
        odometry: OdometrySpec {
            ticks_per_rev: 1024,
            radius_error: 0.0,
            separation_error: 0.0,
            rate_hz: 50.0,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut sim = Simulation::new(&world, &wheelchair(), config).unwrap();
    let nodes = [[2.0, -2.0], [2.0, 2.0], [-2.0, 2.0], [-2.0, -2.0]];
    sim.set_node_route(&nodes, NodeControllerParams::default())
        .unwrap();
    let mut out = Vec::new();
    let mut closest = [f64::MAX; 4];
    while !sim.route_finished() && sim.time() < 120.0 {
        out.clear();
        let p = sim.step(&mut out);
        for (c, n) in closest.iter_mut().zip(&nodes) {
            *c = c.min((p.x - n[0]).hypot(p.y - n[1]));
        }
    }
    assert!(sim.route_finished(), "stuck at {:?}", sim.ground_truth());
    let arrivals = sim.node_controller().unwrap().arrivals();
    assert_eq!(arrivals.len(), 4);
    // Driven on odometry alone: the true path stays within a few cm of each node over
    // a 16 m square (the physics slips a little in the turns).
    for (i, c) in closest.iter().enumerate() {
        assert!(*c < 0.15, "node {i}: closest approach {c} m ({closest:?})");
    }
}
