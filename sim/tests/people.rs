//! Pedestrians in the simulation (issue 17): deterministic from the seed, never inside a
//! wall or the robot, seen by the laser, and the robot stops for them and still finishes.

use atrium_robots::{LaserSpec, Pose2, Reading};
use atrium_sim::fixtures;
use atrium_sim::people::footprint_distance;
use atrium_sim::{PeopleParams, PeoplePlacement, SimConfig, Simulation};
use atrium_worlds::World;

fn people(density: f64) -> PeopleParams {
    PeopleParams {
        density,
        ..Default::default()
    }
}

fn sim(world: &World, config: SimConfig) -> Simulation {
    Simulation::new(world, &fixtures::pioneer_3dx_like(), config).unwrap()
}

/// Distance from `p` to the nearest wall surface of `world`.
fn wall_clearance(world: &World, p: [f64; 2]) -> f64 {
    world
        .walls
        .iter()
        .map(|w| {
            let (dx, dy) = (w.b[0] - w.a[0], w.b[1] - w.a[1]);
            let t = (((p[0] - w.a[0]) * dx + (p[1] - w.a[1]) * dy) / (dx * dx + dy * dy))
                .clamp(0.0, 1.0);
            (p[0] - w.a[0] - t * dx).hypot(p[1] - w.a[1] - t * dy) - 0.5 * w.thickness
        })
        .fold(f64::INFINITY, f64::min)
}

/// A 20 m x 4 m hall with a dividing wall stub, the robot driving its length and back.
fn hall() -> World {
    let mut world = fixtures::box_room(20.0, 4.0, "concrete");
    world
        .walls
        .push(fixtures::wall([3.0, 1.9], [3.0, 0.8], "concrete"));
    world
}

fn hall_config(seed: u64, density: f64) -> SimConfig {
    SimConfig {
        start: Pose2::new(-8.0, -1.0, 0.0),
        seed,
        people: people(density),
        ..Default::default()
    }
}

const HALL_ROUTE: [[f64; 2]; 3] = [[8.0, -1.0], [-8.0, -1.0], [0.0, -1.0]];

fn trajectories(seed: u64, steps: usize) -> Vec<Vec<[f64; 2]>> {
    let world = hall();
    let mut s = sim(&world, hall_config(seed, 8.0));
    s.set_route(&HALL_ROUTE);
    let mut out = Vec::new();
    let mut traj = Vec::new();
    for k in 0..steps {
        s.step(&mut out);
        if k % 50 == 0 {
            traj.push(s.people().unwrap().positions().to_vec());
        }
    }
    traj
}

#[test]
fn people_are_deterministic_from_the_seed() {
    let a = trajectories(3, 2000);
    assert!(!a[0].is_empty(), "the hall should hold a few people");
    assert_eq!(a, trajectories(3, 2000));
    assert_ne!(a, trajectories(4, 2000));
    // They walk: somebody moved by metres within 10 s.
    let moved = a[0]
        .iter()
        .zip(a.last().unwrap())
        .map(|(p, q)| (p[0] - q[0]).hypot(p[1] - q[1]))
        .fold(0.0, f64::max);
    assert!(moved > 2.0, "{moved}");
}

#[test]
fn zero_density_changes_nothing() {
    let world = fixtures::hundred_walls();
    let go = |people: PeopleParams| {
        let config = SimConfig {
            start: Pose2::new(-10.0, 0.0, 0.0),
            lasers: vec![LaserSpec::sick_lms200("front", "laser")],
            seed: 5,
            people,
            ..Default::default()
        };
        let mut s = sim(&world, config);
        assert!(s.people().is_none());
        s.set_route(&[[-8.0, 0.0], [-8.0, 0.5]]);
        let mut out = Vec::new();
        let truth: Vec<Pose2> = (0..600).map(|_| s.step(&mut out)).collect();
        (out, truth)
    };
    let other = PeopleParams {
        density: 0.0,
        speed: 2.0,
        radius: 0.4,
        height: 1.2,
    };
    assert_eq!(go(PeopleParams::default()), go(other));
}

#[test]
fn people_stay_out_of_walls_and_the_robot_which_stops_for_them_and_finishes() {
    let world = hall();
    let mut s = sim(&world, hall_config(11, 8.0));
    s.set_route(&HALL_ROUTE);
    let footprint = s.robot_bodies().footprint_box();
    let r = PeopleParams::default().radius;
    let n = s.people().unwrap().positions().len();
    // 8 per 100 m² of the 19.8 m x 3.8 m floor.
    assert!((4..=8).contains(&n), "{n} people");
    let mut out = Vec::new();
    let (mut blocked, mut min_wall, mut min_robot) = (0usize, f64::INFINITY, f64::INFINITY);
    while !s.route_finished() && s.time() < 150.0 {
        let truth = s.step(&mut out);
        out.clear();
        blocked += s.blocked() as usize;
        for &p in s.people().unwrap().positions() {
            min_wall = min_wall.min(wall_clearance(&world, p));
            min_robot = min_robot.min(footprint_distance(p, &truth, footprint));
        }
    }
    assert!(
        s.route_finished(),
        "route not finished after {} s",
        s.time()
    );
    assert!(blocked > 0, "people never blocked the robot's way");
    assert!(min_wall >= r, "a person came within {min_wall} m of a wall");
    assert!(
        min_robot >= r,
        "a person came within {min_robot} m of the robot"
    );
}

#[test]
fn a_laser_scan_sees_a_person_where_the_map_sees_the_far_wall() {
    let world = fixtures::box_room(12.0, 5.0, "concrete");
    let mut spec = LaserSpec::sick_lms200("front", "laser");
    (spec.sigma_hit, spec.p_short, spec.p_max, spec.p_rand) = (0.0, 0.0, 0.0, 0.0);
    let pose = Pose2::new(-4.0, 0.0, 0.0);
    let config = |density| SimConfig {
        start: pose,
        lasers: vec![spec.clone()],
        seed: 2,
        people: people(density),
        ..Default::default()
    };
    let mut empty = sim(&world, config(0.0));
    let mut crowded = sim(&world, config(10.0));
    empty.step(&mut Vec::new());
    let map = empty.scan_at(pose, 0).unwrap().ranges;
    let o = pose.transform_point([0.16, 0.0]);
    let r = PeopleParams::default().radius;
    // The robot stands still; within a few seconds someone walks in front of it.
    let mut out = Vec::new();
    let mut seen = 0;
    for _ in 0..2000 {
        crowded.step(&mut out);
        out.retain(|x| !matches!(x, Reading::Odometry(_)));
        let Some(Reading::Laser(scan)) = out.pop() else {
            continue;
        };
        out.clear();
        let truth = crowded.last_true_ranges(0).unwrap();
        for &c in crowded.people().unwrap().positions() {
            let (dx, dy) = (c[0] - o[0], c[1] - o[1]);
            let bearing = dy.atan2(dx);
            let Some(i) = (0..scan.ranges.len())
                .min_by(|&a, &b| {
                    let e = |k: usize| (scan.beam_angle(k) - bearing).abs();
                    e(a).total_cmp(&e(b))
                })
                .filter(|&i| (scan.beam_angle(i) - bearing).abs() < 0.01)
            else {
                continue;
            };
            let expected = dx.hypot(dy) - r;
            // Unless someone nearer stands on the same beam, it reads the person's surface,
            // metres short of the wall the map predicts.
            if (truth[i] - expected).abs() < 0.02 {
                assert!(
                    map[i] > truth[i] + 0.3,
                    "beam {i}: map {} vs {}",
                    map[i],
                    truth[i]
                );
                seen += 1;
            } else {
                assert!(
                    truth[i] < expected,
                    "beam {i}: {} passes the person at {expected}",
                    truth[i]
                );
            }
        }
    }
    assert!(
        seen > 5,
        "a person was in front of the laser in only {seen} scans"
    );
}

/// People placed only before the steps after which a sensor reads give every reading of
/// placing them before every step, bit for bit: a laser and a depth camera at rates whose
/// instants mostly differ, in the hall with the robot driving through a crowd whom the laser
/// does see (beams end on people).
#[test]
fn people_placed_at_sensor_instants_give_the_every_step_readings() {
    let world = hall();
    let mut laser = LaserSpec::sick_lms200("front", "laser");
    laser.rate_hz = 10.0;
    let mut depth = atrium_robots::DepthCameraSpec::kinect("kinect", "laser");
    (depth.decimation, depth.rate_hz) = (16, 7.0);
    let config = SimConfig {
        lasers: vec![laser],
        depth_cameras: vec![depth],
        ..hall_config(5, 8.0)
    };
    let radius = config.people.radius;
    let run = |placement: PeoplePlacement| {
        let mut s = sim(&world, config.clone());
        s.set_people_placement(placement);
        s.set_route(&HALL_ROUTE);
        let (mut out, mut on_people) = (Vec::new(), 0);
        for _ in 0..3000 {
            let before = out.len();
            s.step(&mut out);
            let Some(Reading::Laser(scan)) = out[before..]
                .iter()
                .find(|r| matches!(r, Reading::Laser(_)))
            else {
                continue;
            };
            let g = s.ground_truth();
            let o = g.transform_point([0.16, 0.0]);
            let truth = s.last_true_ranges(0).unwrap();
            for (k, &r) in truth.iter().enumerate() {
                let a = g.theta + scan.beam_angle(k);
                let hit = [o[0] + r * a.cos(), o[1] + r * a.sin()];
                let people = s.people().unwrap().positions();
                if people
                    .iter()
                    .any(|c| (hit[0] - c[0]).hypot(hit[1] - c[1]) < radius + 0.02)
                {
                    on_people += 1;
                }
            }
        }
        (out, on_people)
    };
    let (every, seen) = run(PeoplePlacement::EveryStep);
    let (instants, seen_too) = run(PeoplePlacement::SensorInstants);
    let sensed = |r: &&Reading| matches!(r, Reading::Laser(_) | Reading::Depth(_));
    assert!(every.iter().filter(sensed).count() > 200);
    eprintln!("{seen} beams ended on people");
    assert!(seen > 100, "{seen} beams ended on people");
    assert_eq!(seen, seen_too);
    assert_eq!(every.len(), instants.len());
    for (k, (a, b)) in every.iter().zip(&instants).enumerate() {
        assert_eq!(a, b, "reading {k}");
    }
}
