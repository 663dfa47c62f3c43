//! The static parts of a recording: the world as a `foxglove.SceneUpdate` (walls as boxes,
//! glass drawn translucent, pillars as cylinders, furniture as boxes, access points as spheres
//! with their names) and the robot's frame tree from its URDF as a `foxglove.FrameTransforms`.

use super::foxglove::{frame_transform, timestamp, yaw_quaternion};
use atrium_robots::{Mount3, RobotModel};
use atrium_worlds::World;
use foxglove::messages as fg;

/// Opaque walls: light grey; glass: pale blue at 25 % opacity so what lies behind shows.
const WALL: fg::Color = fg::Color {
    r: 0.72,
    g: 0.72,
    b: 0.70,
    a: 1.0,
};
const GLASS: fg::Color = fg::Color {
    r: 0.55,
    g: 0.80,
    b: 0.95,
    a: 0.25,
};
const PILLAR: fg::Color = fg::Color {
    r: 0.55,
    g: 0.55,
    b: 0.55,
    a: 1.0,
};
const FURNITURE: fg::Color = fg::Color {
    r: 0.62,
    g: 0.45,
    b: 0.28,
    a: 1.0,
};
/// People: a saturated magenta that no world material uses.
const PERSON: fg::Color = fg::Color {
    r: 0.85,
    g: 0.20,
    b: 0.60,
    a: 1.0,
};
const ACCESS_POINT: fg::Color = fg::Color {
    r: 0.95,
    g: 0.45,
    b: 0.10,
    a: 1.0,
};

fn pose(x: f64, y: f64, z: f64, yaw: f64) -> fg::Pose {
    fg::Pose {
        position: Some(fg::Vector3 { x, y, z }),
        orientation: Some(yaw_quaternion(yaw)),
    }
}

fn entity(ns: u64, frame: &str, id: &str) -> fg::SceneEntity {
    fg::SceneEntity {
        timestamp: Some(timestamp(ns)),
        frame_id: frame.to_string(),
        id: id.to_string(),
        frame_locked: true,
        ..Default::default()
    }
}

/// The pedestrians at one instant in `frame`: one entity per person (`person/<i>`, its index
/// in the run), a cylinder of the person's size standing on the floor. Each update replaces
/// the entities of the last by id, so a viewer shows them walking.
/// `positions` are the centres of the people's discs on the floor (m), `radius` and `height`
/// their size.
pub fn people_update(
    positions: &[[f64; 2]],
    radius: f64,
    height: f64,
    frame: &str,
    ns: u64,
) -> fg::SceneUpdate {
    let d = 2.0 * radius;
    let entities = positions
        .iter()
        .enumerate()
        .map(|(i, p)| fg::SceneEntity {
            cylinders: vec![fg::CylinderPrimitive {
                pose: Some(pose(p[0], p[1], 0.5 * height, 0.0)),
                size: Some(fg::Vector3 {
                    x: d,
                    y: d,
                    z: height,
                }),
                bottom_scale: 1.0,
                top_scale: 1.0,
                color: Some(PERSON),
            }],
            ..entity(ns, frame, &format!("person/{i}"))
        })
        .collect();
    fg::SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}

/// The world in the `map` frame: entities `walls`, `glass`, `pillars` and `access_points`
/// (only those the world has).
pub fn scene_update(world: &World, frame: &str, ns: u64) -> fg::SceneUpdate {
    let mut walls = entity(ns, frame, "walls");
    let mut glass = entity(ns, frame, "glass");
    for w in &world.walls {
        let (dx, dy) = (w.b[0] - w.a[0], w.b[1] - w.a[1]);
        let cube = fg::CubePrimitive {
            pose: Some(pose(
                0.5 * (w.a[0] + w.b[0]),
                0.5 * (w.a[1] + w.b[1]),
                0.5 * w.height,
                dy.atan2(dx),
            )),
            // A wall's footprint extends half a thickness past its end points, as in the
            // loader's geometry (wall_corners).
            size: Some(fg::Vector3 {
                x: dx.hypot(dy),
                y: w.thickness,
                z: w.height,
            }),
            color: None,
        };
        if world.is_glass(&w.material) {
            glass.cubes.push(fg::CubePrimitive {
                color: Some(GLASS),
                ..cube
            });
        } else {
            walls.cubes.push(fg::CubePrimitive {
                color: Some(WALL),
                ..cube
            });
        }
    }
    let mut pillars = entity(ns, frame, "pillars");
    for p in &world.pillars {
        pillars.cylinders.push(fg::CylinderPrimitive {
            pose: Some(pose(p.center[0], p.center[1], 0.5 * p.height, 0.0)),
            size: Some(fg::Vector3 {
                x: 2.0 * p.radius,
                y: 2.0 * p.radius,
                z: p.height,
            }),
            bottom_scale: 1.0,
            top_scale: 1.0,
            color: Some(if world.is_glass(&p.material) {
                GLASS
            } else {
                PILLAR
            }),
        });
    }
    // Furniture is in the scene the sensors see (not in the localizers' maps): draw it so a
    // viewer shows what the depth camera and laser hit.
    let mut furniture = entity(ns, frame, "furniture");
    for b in &world.boxes {
        furniture.cubes.push(fg::CubePrimitive {
            pose: Some(pose(b.center[0], b.center[1], 0.5 * b.size[2], b.yaw)),
            size: Some(fg::Vector3 {
                x: b.size[0],
                y: b.size[1],
                z: b.size[2],
            }),
            color: Some(FURNITURE),
        });
    }
    let mut aps = entity(ns, frame, "access_points");
    for ap in &world.access_points {
        let [x, y, z] = ap.position;
        aps.spheres.push(fg::SpherePrimitive {
            pose: Some(pose(x, y, z, 0.0)),
            size: Some(fg::Vector3 {
                x: 0.3,
                y: 0.3,
                z: 0.3,
            }),
            color: Some(ACCESS_POINT),
        });
        aps.texts.push(fg::TextPrimitive {
            pose: Some(pose(x, y, z + 0.35, 0.0)),
            billboard: true,
            font_size: 14.0,
            scale_invariant: true,
            color: Some(ACCESS_POINT),
            text: format!("{} (ch {})", ap.name, ap.channel),
        });
    }
    let entities = [walls, glass, pillars, furniture, aps]
        .into_iter()
        .filter(|e| !(e.cubes.is_empty() && e.cylinders.is_empty() && e.spheres.is_empty()))
        .collect();
    fg::SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}

/// The URDF's links as transforms from the base link (every link's pose in the base frame;
/// the base itself is left out).
pub fn robot_transforms(robot: &RobotModel, ns: u64) -> Vec<fg::FrameTransform> {
    robot
        .mounts
        .iter()
        .filter(|m| m.name != robot.base_link)
        .map(|m| {
            let (xyz, rpy) = m.xyz_rpy();
            frame_transform(ns, &robot.base_link, &m.name, &Mount3 { xyz, rpy })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn campus_scene_has_translucent_glass_and_opaque_walls() {
        let world = World::campus().unwrap();
        let s = scene_update(&world, "map", 0);
        let by_id = |id: &str| s.entities.iter().find(|e| e.id == id);
        let walls = by_id("walls").unwrap();
        let glass = by_id("glass").unwrap();
        let n_glass = world
            .walls
            .iter()
            .filter(|w| world.is_glass(&w.material))
            .count();
        assert!(n_glass > 0);
        assert_eq!(glass.cubes.len(), n_glass);
        assert_eq!(walls.cubes.len(), world.walls.len() - n_glass);
        assert!(glass.cubes.iter().all(|c| c.color.unwrap().a < 0.5));
        assert!(walls.cubes.iter().all(|c| c.color.unwrap().a == 1.0));
        // The first wall, by hand: centre and length from its end points.
        let w = &world.walls[0];
        let c = s
            .entities
            .iter()
            .flat_map(|e| &e.cubes)
            .find(|c| {
                let p = c.pose.unwrap().position.unwrap();
                (p.x - 0.5 * (w.a[0] + w.b[0])).abs() < 1e-12
                    && (p.y - 0.5 * (w.a[1] + w.b[1])).abs() < 1e-12
            })
            .unwrap();
        let len = (w.b[0] - w.a[0]).hypot(w.b[1] - w.a[1]);
        assert!((c.size.unwrap().x - len).abs() < 1e-12);
        assert_eq!(
            by_id("pillars").map_or(0, |e| e.cylinders.len()),
            world.pillars.len()
        );
        assert_eq!(
            by_id("access_points").map_or(0, |e| e.spheres.len()),
            world.access_points.len()
        );
        assert!(!world.boxes.is_empty());
        let furniture = by_id("furniture").unwrap();
        assert_eq!(furniture.cubes.len(), world.boxes.len());
        let (b, c) = (&world.boxes[0], &furniture.cubes[0]);
        let p = c.pose.unwrap().position.unwrap();
        assert!((p.x - b.center[0]).abs() < 1e-12 && (p.z - 0.5 * b.size[2]).abs() < 1e-12);
    }
}
