//! Hand-built robots and worlds for tests and benchmarks (this crate's and others'), so
//! nobody needs the URDF or world loaders to exercise the simulator.

use atrium_robots::{Caster, LinkMount, RobotModel, Shape, ShapeInstance, Wheel};
use atrium_worlds::{LaserBehaviour, Material, Wall, World};
use nalgebra::{Isometry3, Vector3};

pub const WALL_THICKNESS: f64 = 0.2;
pub const WALL_HEIGHT: f64 = 2.5;

/// A Pioneer-3DX-like robot, base frame on the floor under the axle midpoint: wheels of
/// radius 0.0975 m and width 0.0475 m, 0.33 m apart; a 0.455 × 0.381 × 0.237 m chassis box
/// of 13.5 kg whose centre sits 4.5 cm behind the axle (as on the real robot, so it leans on
/// its caster); one rear caster of radius 0.0375 m; a `laser` link at x = 0.16 m, z = 0.30 m.
///
/// The only place in this crate that builds a `RobotModel` with a struct literal.
pub fn pioneer_3dx_like() -> RobotModel {
    let r = 0.0975;
    let mount = |name: &str, x: f64, y: f64, z: f64| LinkMount {
        name: name.into(),
        pose: Isometry3::translation(x, y, z),
    };
    let wheel = |side: &str, y: f64| Wheel {
        joint: format!("{side}_wheel_joint"),
        link: format!("{side}_wheel"),
        center: Vector3::new(0.0, y, r),
        axis: Vector3::new(0.0, 1.0, 0.0),
        radius: r,
        width: 0.0475,
        mass: 0.5,
    };
    RobotModel {
        name: "pioneer3dx_like".into(),
        base_link: "base_link".into(),
        chassis_shapes: vec![ShapeInstance {
            link: "chassis".into(),
            shape: Shape::Box {
                size: [0.455, 0.381, 0.237],
            },
            pose: Isometry3::translation(-0.045, 0.0, 0.06 + 0.5 * 0.237),
        }],
        chassis_mass: 13.5,
        chassis_com: Vector3::new(-0.045, 0.0, 0.06 + 0.5 * 0.237),
        left_wheel: wheel("left", 0.165),
        right_wheel: wheel("right", -0.165),
        casters: vec![Caster {
            link: "caster_wheel".into(),
            center: Vector3::new(-0.2, 0.0, 0.0375),
            radius: 0.0375,
        }],
        mounts: vec![
            mount("base_link", 0.0, 0.0, 0.0),
            mount("chassis", -0.045, 0.0, 0.1785),
            mount("left_wheel", 0.0, 0.165, r),
            mount("right_wheel", 0.0, -0.165, r),
            mount("caster_wheel", -0.2, 0.0, 0.0375),
            mount("laser", 0.16, 0.0, 0.30),
        ],
        wheel_radius: r,
        wheel_separation: 0.33,
        base_height: 0.0,
        warnings: Vec::new(),
        drive_kind: atrium_robots::model::DriveKind::Differential,
    }
}

/// The two materials every fixture world has: `concrete` (opaque, 12 dB per WiFi crossing)
/// and `glass` (reflects within 10° of normal incidence, 2.5 dB per WiFi crossing).
pub fn materials() -> Vec<Material> {
    vec![
        Material {
            name: "concrete".into(),
            laser: LaserBehaviour::Opaque,
            wifi_attenuation_db: 12.0,
        },
        Material {
            name: "glass".into(),
            laser: LaserBehaviour::Glass {
                reflect_within_deg: 10.0,
            },
            wifi_attenuation_db: 2.5,
        },
    ]
}

pub fn wall(a: [f64; 2], b: [f64; 2], material: &str) -> Wall {
    Wall {
        a,
        b,
        thickness: WALL_THICKNESS,
        height: WALL_HEIGHT,
        material: material.into(),
    }
}

/// A closed rectangular room centred on the origin: wall centre lines at x = ±`size_x`/2 and
/// y = ±`size_y`/2, so the inner faces are at ±(size/2 − 0.1). Walls: south, east, north, west.
pub fn box_room(size_x: f64, size_y: f64, material: &str) -> World {
    let (hx, hy) = (0.5 * size_x, 0.5 * size_y);
    World {
        name: format!("box_room_{size_x}x{size_y}"),
        ceiling_height: 3.0,
        materials: materials(),
        walls: vec![
            wall([-hx, -hy], [hx, -hy], material),
            wall([hx, -hy], [hx, hy], material),
            wall([hx, hy], [-hx, hy], material),
            wall([-hx, hy], [-hx, -hy], material),
        ],
        pillars: vec![],
        regions: vec![],
        access_points: vec![],
        wifi: Default::default(),
        boxes: Vec::new(),
        lighting: Default::default(),
    }
}

/// 100 walls: a 26 × 20 m box around 96 one-metre partitions on a 12 × 8 grid (x = −11 …
/// 11 every 2 m, y = ±1.25, ±3.75, … every 2.5 m), alternately along x and y. Every fourth
/// one is glass. The line y = 0 is clear from x = −12.9 to 12.9 (0.75 m to the nearest
/// partition), for driving benchmarks.
pub fn hundred_walls() -> World {
    let mut w = box_room(26.0, 20.0, "concrete");
    w.name = "hundred_walls".into();
    for i in 0..12 {
        for j in 0..8 {
            let (x, y) = (-11.0 + 2.0 * i as f64, -8.75 + 2.5 * j as f64);
            let material = if (i + j) % 4 == 0 {
                "glass"
            } else {
                "concrete"
            };
            let seg = if (i + j) % 2 == 0 {
                wall([x - 0.5, y], [x + 0.5, y], material)
            } else {
                wall([x, y - 0.5], [x, y + 0.5], material)
            };
            w.walls.push(seg);
        }
    }
    w
}
