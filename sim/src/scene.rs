//! The static rapier world built from an [`atrium_worlds::World`]: floor, ceiling, walls and
//! pillars, each collider tagged with what it is and which material it is made of.

use crate::error::SimError;
use atrium_worlds::{LaserBehaviour, World};
use nalgebra::{Isometry3, Quaternion, UnitQuaternion};
use rapier3d::prelude::*;

/// Collision group of the floor.
pub const FLOOR_GROUP: Group = Group::GROUP_1;
/// Collision group of the robot's own colliders: they touch the static world only, and
/// sensor rays (which filter on [`STATIC_GROUP`]) never see them.
pub const ROBOT_GROUP: Group = Group::GROUP_2;
/// Collision group of walls, pillars and the ceiling. Separate from the floor so a wheel can
/// meet the floor with one collider and walls with another (see `robot.rs`).
pub const WALL_GROUP: Group = Group::GROUP_3;
/// Everything static.
pub const STATIC_GROUP: Group = FLOOR_GROUP.union(WALL_GROUP);
/// Collision group of people (`people.rs`): kinematic, seen by sensor rays, touching nothing
/// (the robot filters on [`STATIC_GROUP`] only, so it never collides with a person).
pub const PEOPLE_GROUP: Group = Group::GROUP_4;
/// What sensor rays see: the static world and people. Without people in the scene this
/// filter selects exactly the colliders [`STATIC_GROUP`] did, at the same cost.
pub const SENSED_GROUP: Group = STATIC_GROUP.union(PEOPLE_GROUP);

/// Margin of floor around the world's walls, m: the robot must never drive off the edge.
const FLOOR_MARGIN: f64 = 50.0;
const FLOOR_THICKNESS: f64 = 1.0;
const CEILING_THICKNESS: f64 = 0.2;
/// Wheels get their grip from this (rapier averages coefficients by default: wheel 1.0 and
/// floor 1.0 give 1.0).
const FLOOR_FRICTION: f32 = 1.0;

/// What a static collider is; encoded in its `user_data`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StaticKind {
    Floor,
    Ceiling,
    /// Index into `World::walls`.
    Wall(usize),
    /// Index into `World::pillars`.
    Pillar(usize),
    /// Index into `World::boxes` (furniture).
    Box(usize),
}

/// What a laser beam does at a material, precomputed for the ray caster.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LaserSurface {
    Opaque,
    /// Reflects when |cos(incidence)| >= `cos_reflect`, i.e. when the angle between the beam
    /// and the surface normal is within the material's `reflect_within_deg`.
    Glass {
        cos_reflect: f64,
    },
}

/// A material as the sensors need it.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneMaterial {
    pub name: String,
    pub laser: LaserSurface,
}

/// A static collider's `user_data`: kind in bits 0..8, object index in bits 8..72, material
/// index + 1 in bits 72..104 (0 = no material: floor and ceiling, which are opaque).
fn encode_tag(kind: StaticKind, material: Option<usize>) -> u128 {
    let (k, idx) = match kind {
        StaticKind::Floor => (1u128, 0u128),
        StaticKind::Ceiling => (2, 0),
        StaticKind::Wall(i) => (3, i as u128),
        StaticKind::Pillar(i) => (4, i as u128),
        StaticKind::Box(i) => (5, i as u128),
    };
    let m = material.map_or(0u128, |m| m as u128 + 1);
    k | (idx << 8) | (m << 72)
}

/// Inverse of [`encode_tag`]; `None` for colliders that are not static scene colliders.
pub fn decode_tag(user_data: u128) -> Option<(StaticKind, Option<usize>)> {
    let idx = ((user_data >> 8) & u64::MAX as u128) as usize;
    let kind = match user_data & 0xff {
        1 => StaticKind::Floor,
        2 => StaticKind::Ceiling,
        3 => StaticKind::Wall(idx),
        4 => StaticKind::Pillar(idx),
        5 => StaticKind::Box(idx),
        _ => return None,
    };
    let m = ((user_data >> 72) & u32::MAX as u128) as usize;
    Some((kind, m.checked_sub(1)))
}

/// How rapier resolves friction; see [`Scene::new`] for the choice.
pub const FRICTION_MODEL: FrictionModel = FrictionModel::Coulomb;

/// The physics world and what the sensors need to interpret it.
pub struct Scene {
    pub physics: PhysicsWorld,
    materials: Vec<SceneMaterial>,
    /// Every wall and pillar collider, with its kind, for overlap tests (spawn, teleport).
    obstacles: Vec<(StaticKind, ColliderHandle)>,
    world_name: String,
}

impl Scene {
    /// Builds the static scene. Gravity is −Z and the step is `1 / physics_hz`.
    ///
    /// Friction: `FrictionModel::Coulomb`. The default `Simplified` model adds a "twist"
    /// constraint per contact manifold that resists yaw at multi-point contacts, so a robot
    /// turning in place lags its commanded rate (CRATE-NOTES: ~7 %; measured here with flat
    /// cylinder wheels: 0.32 rad/s for 0.5 commanded). That is a solver artefact, not slip we
    /// mean to model. The wheels now touch the floor at a single point (see `robot.rs`), where
    /// both models gave identical trajectories in our runs; Coulomb stays so that the rare
    /// multi-point contacts (chassis against a wall) are also right, at no measurable cost.
    pub fn new(world: &World, physics_hz: f64) -> Result<Scene, SimError> {
        let hz = crate::error::positive("physics_hz", physics_hz)?;
        let werr = |field: String, msg: String| SimError::World {
            world: world.name.clone(),
            field,
            msg,
        };
        let mut materials = Vec::with_capacity(world.materials.len());
        for (i, m) in world.materials.iter().enumerate() {
            let laser = match m.laser {
                LaserBehaviour::Opaque => LaserSurface::Opaque,
                LaserBehaviour::Glass { reflect_within_deg } => {
                    if !(reflect_within_deg.is_finite()
                        && (0.0..=90.0).contains(&reflect_within_deg))
                    {
                        return Err(werr(
                            format!("materials[{i}].laser.reflect_within_deg"),
                            format!("must be within [0, 90] degrees, got {reflect_within_deg}"),
                        ));
                    }
                    LaserSurface::Glass {
                        cos_reflect: reflect_within_deg.to_radians().cos(),
                    }
                }
            };
            materials.push(SceneMaterial {
                name: m.name.clone(),
                laser,
            });
        }
        let material_index = |name: &str, field: String| {
            materials
                .iter()
                .position(|m| m.name == name)
                .ok_or_else(|| werr(field, format!("unknown material `{name}`")))
        };
        if !(world.ceiling_height.is_finite() && world.ceiling_height > 0.0) {
            return Err(werr(
                "ceiling_height".into(),
                format!("must be finite and > 0, got {}", world.ceiling_height),
            ));
        }

        let mut physics = PhysicsWorld::new();
        physics.gravity = Vector::new(0.0, 0.0, -9.81);
        physics.integration_parameters.dt = (1.0 / hz) as f32;
        physics.integration_parameters.friction_model = FRICTION_MODEL;
        // Stiffer contacts against fixed bodies than rapier's default (60 Hz): with the
        // default, the wheels' floor contacts sink about 0.8 mm, which shortens the rolling
        // radius and gives odometry an unrequested +0.8 % scale error. 120 Hz leaves 0.2 mm;
        // 240 Hz and above start to jitter sideways at 200 Hz steps.
        physics
            .integration_parameters
            .static_contact_softness
            .natural_frequency = 120.0;

        let groups = InteractionGroups::new(WALL_GROUP, Group::ALL, InteractionTestMode::And);
        let floor_groups =
            InteractionGroups::new(FLOOR_GROUP, Group::ALL, InteractionTestMode::And);

        // Bounds of everything, for the floor and ceiling slabs.
        let (mut lo, mut hi) = ([0.0f64; 2], [0.0f64; 2]);
        let mut grow = |p: [f64; 2], r: f64| {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k] - r);
                hi[k] = hi[k].max(p[k] + r);
            }
        };

        let mut obstacles = Vec::with_capacity(world.walls.len() + world.pillars.len());
        for (i, w) in world.walls.iter().enumerate() {
            let f = |s: &str| format!("walls[{i}].{s}");
            let finite = w.a.iter().chain(&w.b).all(|v| v.is_finite());
            if !finite {
                return Err(werr(f("a/b"), "end points must be finite".into()));
            }
            let (dx, dy) = (w.b[0] - w.a[0], w.b[1] - w.a[1]);
            let len = dx.hypot(dy);
            if len < 1e-6 {
                return Err(werr(f("b"), "the wall has zero length (a == b)".into()));
            }
            if !(w.thickness.is_finite() && w.thickness > 0.0) {
                return Err(werr(
                    f("thickness"),
                    format!("must be > 0, got {}", w.thickness),
                ));
            }
            if !(w.height.is_finite() && w.height > 0.0) {
                return Err(werr(f("height"), format!("must be > 0, got {}", w.height)));
            }
            let m = material_index(&w.material, f("material"))?;
            grow(w.a, w.thickness);
            grow(w.b, w.thickness);
            let yaw = dy.atan2(dx);
            let centre = [0.5 * (w.a[0] + w.b[0]), 0.5 * (w.a[1] + w.b[1])];
            let pose = Pose::from_parts(
                vec3(centre[0], centre[1], 0.5 * w.height),
                Rotation::from_rotation_z(yaw as f32),
            );
            let c = ColliderBuilder::cuboid(
                (0.5 * len) as f32,
                (0.5 * w.thickness) as f32,
                (0.5 * w.height) as f32,
            )
            .position(pose)
            .collision_groups(groups)
            .user_data(encode_tag(StaticKind::Wall(i), Some(m)));
            obstacles.push((StaticKind::Wall(i), physics.insert_collider(c, None)));
        }
        for (i, p) in world.pillars.iter().enumerate() {
            let f = |s: &str| format!("pillars[{i}].{s}");
            if !p.center.iter().all(|v| v.is_finite()) {
                return Err(werr(f("center"), "must be finite".into()));
            }
            if !(p.radius.is_finite() && p.radius > 0.0) {
                return Err(werr(f("radius"), format!("must be > 0, got {}", p.radius)));
            }
            if !(p.height.is_finite() && p.height > 0.0) {
                return Err(werr(f("height"), format!("must be > 0, got {}", p.height)));
            }
            let m = material_index(&p.material, f("material"))?;
            grow(p.center, p.radius);
            // parry's cylinder axis is its local +Y: a +90° turn about X stands it up along Z.
            let pose = Pose::from_parts(
                vec3(p.center[0], p.center[1], 0.5 * p.height),
                Rotation::from_rotation_x(std::f32::consts::FRAC_PI_2),
            );
            let c = ColliderBuilder::cylinder((0.5 * p.height) as f32, p.radius as f32)
                .position(pose)
                .collision_groups(groups)
                .user_data(encode_tag(StaticKind::Pillar(i), Some(m)));
            obstacles.push((StaticKind::Pillar(i), physics.insert_collider(c, None)));
        }

        let half = [
            0.5 * (hi[0] - lo[0]) + FLOOR_MARGIN,
            0.5 * (hi[1] - lo[1]) + FLOOR_MARGIN,
        ];
        let mid = [0.5 * (hi[0] + lo[0]), 0.5 * (hi[1] + lo[1])];
        let floor = ColliderBuilder::cuboid(
            half[0] as f32,
            half[1] as f32,
            (0.5 * FLOOR_THICKNESS) as f32,
        )
        .translation(vec3(mid[0], mid[1], -0.5 * FLOOR_THICKNESS))
        .friction(FLOOR_FRICTION)
        .collision_groups(floor_groups)
        .user_data(encode_tag(StaticKind::Floor, None));
        physics.insert_collider(floor, None);
        let ceiling = ColliderBuilder::cuboid(
            half[0] as f32,
            half[1] as f32,
            (0.5 * CEILING_THICKNESS) as f32,
        )
        .translation(vec3(
            mid[0],
            mid[1],
            world.ceiling_height + 0.5 * CEILING_THICKNESS,
        ))
        .collision_groups(groups)
        .user_data(encode_tag(StaticKind::Ceiling, None));
        physics.insert_collider(ceiling, None);

        // Furniture last, so that the colliders of worlds without it keep their handles.
        for (i, b) in world.boxes.iter().enumerate() {
            let f = |s: &str| format!("boxes[{i}].{s}");
            b.validate(world.ceiling_height)
                .map_err(|(key, msg)| werr(f(key), msg))?;
            let m = material_index(&b.material, f("material"))?;
            let pose = Pose::from_parts(
                vec3(b.center[0], b.center[1], 0.5 * b.size[2]),
                Rotation::from_rotation_z(b.yaw as f32),
            );
            let c = ColliderBuilder::cuboid(
                (0.5 * b.size[0]) as f32,
                (0.5 * b.size[1]) as f32,
                (0.5 * b.size[2]) as f32,
            )
            .position(pose)
            .collision_groups(groups)
            .user_data(encode_tag(StaticKind::Box(i), Some(m)));
            obstacles.push((StaticKind::Box(i), physics.insert_collider(c, None)));
        }

        // Colliders join the query structure only during a step; a zero-length step does
        // exactly that and nothing else, so rays work before the first real step.
        let dt = physics.integration_parameters.dt;
        physics.integration_parameters.dt = 0.0;
        physics.step();
        physics.integration_parameters.dt = dt;

        Ok(Scene {
            physics,
            materials,
            obstacles,
            world_name: world.name.clone(),
        })
    }

    pub fn world_name(&self) -> &str {
        &self.world_name
    }

    pub fn dt(&self) -> f64 {
        self.physics.integration_parameters.dt as f64
    }

    pub fn materials(&self) -> &[SceneMaterial] {
        &self.materials
    }

    /// The laser behaviour of a static collider, from its tag (floor and ceiling: opaque).
    #[inline]
    pub fn laser_surface(&self, user_data: u128) -> LaserSurface {
        match decode_tag(user_data) {
            Some((_, Some(m))) => self.materials[m].laser,
            _ => LaserSurface::Opaque,
        }
    }

    /// Sensor-ray filter: static colliders only.
    pub fn static_groups() -> InteractionGroups {
        InteractionGroups::new(Group::ALL, STATIC_GROUP, InteractionTestMode::And)
    }

    /// Sensor-ray filter: static colliders and people (never the robot).
    pub fn sensor_groups() -> InteractionGroups {
        InteractionGroups::new(Group::ALL, SENSED_GROUP, InteractionTestMode::And)
    }

    /// The first wall or pillar that one of `shapes` (poses in the world frame) overlaps,
    /// as (`walls[i]` / `pillars[i]`, material name).
    pub fn first_overlap(&self, shapes: &[(Pose, SharedShape)]) -> Option<(String, String)> {
        for (kind, h) in &self.obstacles {
            let co = &self.physics.colliders[*h];
            for (pose, shape) in shapes {
                let hit = rapier3d::parry::query::intersection_test(
                    co.position(),
                    co.shape(),
                    pose,
                    shape.as_ref(),
                )
                .map(|r| r.intersecting)
                // Every pair of our primitives is supported; if one ever is not, treat it
                // as overlapping rather than silently spawning inside a wall.
                .unwrap_or(true);
                if hit {
                    let name = match kind {
                        StaticKind::Wall(i) => format!("walls[{i}]"),
                        StaticKind::Pillar(i) => format!("pillars[{i}]"),
                        StaticKind::Box(i) => format!("boxes[{i}]"),
                        StaticKind::Floor => "the floor".into(),
                        StaticKind::Ceiling => "the ceiling".into(),
                    };
                    let material = decode_tag(co.user_data)
                        .and_then(|(_, m)| m)
                        .map_or_else(String::new, |m| self.materials[m].name.clone());
                    return Some((name, material));
                }
            }
        }
        None
    }
}

pub(crate) fn vec3(x: f64, y: f64, z: f64) -> Vector {
    Vector::new(x as f32, y as f32, z as f32)
}

/// nalgebra (f64) isometry -> rapier pose (f32).
pub fn iso_to_pose(iso: &Isometry3<f64>) -> Pose {
    let t = iso.translation.vector;
    let q = iso.rotation.quaternion();
    Pose::from_parts(
        vec3(t.x, t.y, t.z),
        Rotation::from_xyzw(q.i as f32, q.j as f32, q.k as f32, q.w as f32).normalize(),
    )
}

/// rapier pose (f32) -> nalgebra (f64) isometry.
pub fn pose_to_iso(p: &Pose) -> Isometry3<f64> {
    let t = p.translation;
    let q = p.rotation;
    Isometry3::from_parts(
        nalgebra::Translation3::new(t.x as f64, t.y as f64, t.z as f64),
        UnitQuaternion::new_normalize(Quaternion::new(
            q.w as f64, q.x as f64, q.y as f64, q.z as f64,
        )),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures;

    #[test]
    fn tags_round_trip() {
        for (k, m) in [
            (StaticKind::Floor, None),
            (StaticKind::Ceiling, None),
            (StaticKind::Wall(123_456), Some(7)),
            (StaticKind::Pillar(0), Some(0)),
            (StaticKind::Box(3), Some(1)),
        ] {
            assert_eq!(decode_tag(encode_tag(k, m)), Some((k, m)));
        }
        assert_eq!(decode_tag(0), None);
    }

    #[test]
    fn wall_collider_has_the_world_geometry() {
        let world = fixtures::box_room(4.0, 3.0, "concrete");
        let scene = Scene::new(&world, 200.0).unwrap();
        // A ray straight down from just under the ceiling (3 m) onto the south wall's centre
        // line hits its top at 2.5 m; one straight up hits the ceiling.
        let ray = Ray::new(Vector::new(0.0, -1.5, 2.9), Vector::new(0.0, 0.0, -1.0));
        let filter = QueryFilter::default().groups(Scene::static_groups());
        let (h, toi) = scene
            .physics
            .query_pipeline_with_filter(filter)
            .cast_ray(&ray, 100.0, true)
            .unwrap();
        assert!(
            (toi - (2.9 - fixtures::WALL_HEIGHT as f32)).abs() < 1e-4,
            "{toi}"
        );
        let tag = decode_tag(scene.physics.colliders[h].user_data).unwrap();
        assert!(matches!(tag, (StaticKind::Wall(0), Some(0))), "{tag:?}");
        let up = Ray::new(Vector::new(0.0, 0.0, 1.0), Vector::new(0.0, 0.0, 1.0));
        let q = scene.physics.query_pipeline_with_filter(filter);
        let (h, toi) = q.cast_ray(&up, 100.0, true).unwrap();
        assert!((toi - 2.0).abs() < 1e-4, "{toi}");
        let tag = decode_tag(scene.physics.colliders[h].user_data).unwrap();
        assert_eq!(tag, (StaticKind::Ceiling, None));
        let down = Ray::new(Vector::new(0.0, 0.0, 1.0), Vector::new(0.0, 0.0, -1.0));
        let (h, toi) = q.cast_ray(&down, 100.0, true).unwrap();
        assert!((toi - 1.0).abs() < 1e-4, "{toi}");
        let tag = decode_tag(scene.physics.colliders[h].user_data).unwrap();
        assert_eq!(tag, (StaticKind::Floor, None));
        assert_eq!(scene.dt(), (1.0f32 / 200.0) as f64);
        assert_eq!(scene.physics.gravity, Vector::new(0.0, 0.0, -9.81));
    }

    #[test]
    fn pillar_stands_along_z() {
        let mut world = fixtures::box_room(10.0, 10.0, "concrete");
        world.pillars.push(atrium_worlds::Pillar {
            center: [1.0, 2.0],
            radius: 0.3,
            height: 2.0,
            material: "concrete".into(),
        });
        let scene = Scene::new(&world, 100.0).unwrap();
        let q = scene
            .physics
            .query_pipeline_with_filter(QueryFilter::default().groups(Scene::static_groups()));
        // Horizontal ray at z = 1.9 from x = -1: hits the pillar side at x = 0.7.
        let ray = Ray::new(Vector::new(-1.0, 2.0, 1.9), Vector::new(1.0, 0.0, 0.0));
        let (_, toi) = q.cast_ray(&ray, 100.0, true).unwrap();
        assert!((toi - 1.7).abs() < 1e-4, "{toi}");
        // At z = 2.1 the ray passes over the pillar and hits the east wall (inner face x = 4.9).
        let ray = Ray::new(Vector::new(-1.0, 2.0, 2.1), Vector::new(1.0, 0.0, 0.0));
        let (_, toi) = q.cast_ray(&ray, 100.0, true).unwrap();
        assert!((toi - 5.9).abs() < 1e-4, "{toi}");
    }

    #[test]
    fn bad_worlds_are_named() {
        let mut world = fixtures::box_room(4.0, 3.0, "concrete");
        world.walls[2].material = "unobtainium".into();
        let e = Scene::new(&world, 200.0).err().unwrap().to_string();
        assert!(
            e.contains("walls[2].material") && e.contains("unobtainium"),
            "{e}"
        );

        let mut world = fixtures::box_room(4.0, 3.0, "concrete");
        world.walls[1].b = world.walls[1].a;
        let e = Scene::new(&world, 200.0).err().unwrap().to_string();
        assert!(e.contains("walls[1].b") && e.contains("zero length"), "{e}");

        let world = fixtures::box_room(4.0, 3.0, "concrete");
        let e = Scene::new(&world, f64::NAN).err().unwrap().to_string();
        assert!(e.contains("physics_hz"), "{e}");
    }
}
