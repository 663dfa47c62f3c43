//! The robot as rapier bodies: a chassis (one compound collider plus frictionless casters),
//! wheel bodies on motorised revolute joints: two for a differential drive, four or six for a
//! skid steer, whose wheels of one side all get that side's speed.
//!
//! A skid steer's slip comes from the physics, not from a kinematic model: each wheel touches
//! the floor at one Coulomb-friction point (see `scene::FRICTION_MODEL`), so turning drags
//! the front and rear wheels sideways, and the friction that resists that drag slows the
//! turn. For equal wheel loads and sliding contacts the yaw torque balance gives
//! ω = c·u / (a² + c²) for wheel rim speeds ±u, wheels at x = ±a and y = ±c, i.e. an effective
//! track of B·(1 + a²/c²), 1.8 × the geometric track for a Husky (a = 0.256 m, c = 0.285 m),
//! where Clearpath's controller uses 1.875. The physics also makes the factor depend on the
//! turn radius, speed and load transfer, which a constant effective track cannot follow:
//! that is the skid steer's poor odometry.

use crate::error::SimError;
use crate::scene::{iso_to_pose, vec3, Scene, FLOOR_GROUP, ROBOT_GROUP, STATIC_GROUP, WALL_GROUP};
use atrium_robots::model::DriveKind;
use atrium_robots::{normalize_angle, Pose2, RobotModel, Shape, Wheel};
use rapier3d::prelude::*;

/// Wheel–floor friction coefficient (rubber on a hard floor is about 1).
const WHEEL_FRICTION: f32 = 1.0;
/// Damping factor of the velocity motors (rapier's acceleration-based model: the motor
/// removes a fraction `dt·factor / (1 + dt·factor)` of the speed error per solver pass).
/// High enough that a 200 Hz step tracks a ramped target to well under 1 %.
const MOTOR_FACTOR: f32 = 1000.0;
/// Motor factor of a skid steer's wheels. Their motors hold a speed against the sideways
/// drag of the other wheels for the whole of a turn, and at `MOTOR_FACTOR` the soft motor gave
/// in: measured on skid4 with wheel rim speeds 0.3 / 0.4 m/s, the wheels settled at one common
/// speed and the robot drove straight (a real drive's integrating speed loop would not let
/// that happen). At 1e5 the wheels turn as commanded and the robot turns on every arc.
const SKID_MOTOR_FACTOR: f32 = 1.0e5;

/// One drive wheel's body and joint.
#[derive(Debug, Clone)]
pub struct WheelBody {
    pub body: RigidBodyHandle,
    pub joint: ImpulseJointHandle,
    /// Wheel centre in the base frame.
    pub offset: Vector,
    /// Unit axle direction in the base frame, oriented to the robot's left: a positive
    /// rotation about it rolls the robot forward, whatever sign the URDF axis had.
    pub axis_left: Vector,
    /// Wheel speed last sent to the motor (rad/s, forward positive).
    commanded: f32,
    /// The motor's damping factor.
    factor: f32,
}

/// Handles of the robot's bodies and what is needed to place and read them.
#[derive(Debug, Clone)]
pub struct RobotBodies {
    pub chassis: RigidBodyHandle,
    /// The (front) left and right driven wheels.
    pub left: WheelBody,
    pub right: WheelBody,
    /// A skid steer's other driven wheels of each side, front to back (empty for a
    /// differential drive). They get their side's speed; the side's encoder reads the mean
    /// rotation of its wheels.
    pub left_rear: Vec<WheelBody>,
    pub right_rear: Vec<WheelBody>,
    /// Height of the base origin above the floor when the wheels touch it, m.
    pub base_z: f64,
    /// Every robot collider's shape with its pose in the base frame (for overlap tests).
    footprint: Vec<(Pose, SharedShape)>,
    /// Scratch for `first_overlap` (reused so teleporting does not allocate).
    placed: Vec<(Pose, SharedShape)>,
}

fn robot_err(model: &RobotModel, field: impl Into<String>, msg: impl Into<String>) -> SimError {
    SimError::Robot {
        robot: model.name.clone(),
        field: field.into(),
        msg: msg.into(),
    }
}

fn pos(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// The planar pose as a 3D pose with the base origin at height `z`.
pub fn pose3(p: &Pose2, z: f64) -> Pose {
    Pose::from_parts(vec3(p.x, p.y, z), Rotation::from_rotation_z(p.theta as f32))
}

/// Projects a 3D body pose to the floor plane: position, and the yaw of its x axis.
pub fn project(p: &Pose) -> Pose2 {
    let x_axis = p.rotation * Vector::X;
    Pose2::new(
        p.translation.x as f64,
        p.translation.y as f64,
        (x_axis.y as f64).atan2(x_axis.x as f64),
    )
}

fn check_wheel(model: &RobotModel, name: &str, w: &Wheel) -> Result<Vector, SimError> {
    let f = |s: &str| format!("{name}.{s}");
    if !pos(w.radius) {
        return Err(robot_err(
            model,
            f("radius"),
            format!("must be > 0, got {}", w.radius),
        ));
    }
    if !pos(w.width) {
        return Err(robot_err(
            model,
            f("width"),
            format!("must be > 0, got {}", w.width),
        ));
    }
    if !pos(w.mass) {
        return Err(robot_err(
            model,
            f("mass"),
            format!("must be > 0, got {}", w.mass),
        ));
    }
    if !w.center.iter().all(|v| v.is_finite()) {
        return Err(robot_err(model, f("center"), "must be finite"));
    }
    let n = w.axis.norm();
    if !(n.is_finite() && n > 1e-9) || (w.axis.y / n).abs() < 0.9 {
        return Err(robot_err(
            model,
            f("axis"),
            format!(
                "a drive wheel must spin about the lateral (y) axis, got [{}, {}, {}]",
                w.axis.x, w.axis.y, w.axis.z
            ),
        ));
    }
    let a = w.axis / n * (w.axis.y / n).signum();
    Ok(vec3(a.x, a.y, a.z))
}

fn shared_shape(model: &RobotModel, i: usize, s: &Shape) -> Result<(SharedShape, Pose), SimError> {
    let field = format!(
        "chassis_shapes[{i}] (link `{}`)",
        model.chassis_shapes[i].link
    );
    Ok(match s {
        Shape::Box { size } => {
            if !size.iter().all(|v| pos(*v)) {
                return Err(robot_err(
                    model,
                    field,
                    format!("box size must be > 0, got {size:?}"),
                ));
            }
            let h = size.map(|v| (0.5 * v) as f32);
            (SharedShape::cuboid(h[0], h[1], h[2]), Pose::IDENTITY)
        }
        Shape::Cylinder { radius, length } => {
            if !pos(*radius) || !pos(*length) {
                return Err(robot_err(
                    model,
                    field,
                    format!("cylinder radius and length must be > 0, got {radius}, {length}"),
                ));
            }
            // URDF cylinders run along local z, parry's along local y.
            (
                SharedShape::cylinder((0.5 * length) as f32, *radius as f32),
                Pose::from_rotation(Rotation::from_rotation_x(std::f32::consts::FRAC_PI_2)),
            )
        }
        Shape::Sphere { radius } => {
            if !pos(*radius) {
                return Err(robot_err(
                    model,
                    field,
                    format!("sphere radius must be > 0, got {radius}"),
                ));
            }
            (SharedShape::ball(*radius as f32), Pose::IDENTITY)
        }
    })
}

impl RobotBodies {
    /// Inserts the robot with its base frame at `start` and its wheels on the floor.
    /// Fails with [`SimError::Spawn`] if any robot collider would overlap a wall or pillar.
    pub fn spawn(scene: &mut Scene, model: &RobotModel, start: Pose2) -> Result<Self, SimError> {
        if !start.is_finite() {
            return Err(SimError::config(
                "start",
                format!("pose must be finite, got {start:?}"),
            ));
        }
        if !pos(model.chassis_mass) {
            return Err(robot_err(
                model,
                "chassis_mass",
                format!("must be > 0, got {}", model.chassis_mass),
            ));
        }
        let left_axis = check_wheel(model, "left_wheel", &model.left_wheel)?;
        let right_axis = check_wheel(model, "right_wheel", &model.right_wheel)?;
        // The wheels behind the front pair, with the axis each spins about.
        let (left_rear, right_rear): (&[Wheel], &[Wheel]) = match &model.drive_kind {
            DriveKind::Differential => (&[], &[]),
            DriveKind::SkidSteer(s) => {
                if s.left.first() != Some(&model.left_wheel)
                    || s.right.first() != Some(&model.right_wheel)
                {
                    return Err(robot_err(
                        model,
                        "drive_kind",
                        "a skid steer's first wheel of each side must be its left_wheel / \
                         right_wheel",
                    ));
                }
                (&s.left[1..], &s.right[1..])
            }
        };
        let mut rear_axes = Vec::with_capacity(left_rear.len() + right_rear.len());
        for (side, wheels) in [("left", left_rear), ("right", right_rear)] {
            for (k, w) in wheels.iter().enumerate() {
                let field = format!("drive_kind.{side}[{}]", k + 1);
                rear_axes.push(check_wheel(model, &field, w)?);
            }
        }
        if model.left_wheel.center.y <= model.right_wheel.center.y {
            return Err(robot_err(
                model,
                "left_wheel.center",
                "the left wheel must be to the left (+y) of the right wheel",
            ));
        }
        // Stand on the wheels: the base origin goes as high as the lowest wheel point needs.
        let base_z = [&model.left_wheel, &model.right_wheel]
            .into_iter()
            .chain(left_rear)
            .chain(right_rear)
            .map(|w| w.radius - w.center.z)
            .fold(f64::MIN, f64::max);

        // Chassis: all shapes as one compound so the mass is exactly `chassis_mass`.
        let mut parts = Vec::with_capacity(model.chassis_shapes.len().max(1));
        for (i, s) in model.chassis_shapes.iter().enumerate() {
            let (shape, local) = shared_shape(model, i, &s.shape)?;
            parts.push((iso_to_pose(&s.pose) * local, shape));
        }
        let (l, r) = (&model.left_wheel, &model.right_wheel);
        if parts.is_empty() {
            // No geometry: a box spanning the wheel centres, one wheel diameter long.
            let c = 0.5 * (l.center + r.center);
            let hy = 0.5 * (l.center.y - r.center.y);
            parts.push((
                Pose::from_translation(vec3(c.x, c.y, c.z)),
                SharedShape::cuboid(
                    l.radius.max(r.radius) as f32,
                    hy as f32,
                    (0.25 * l.radius) as f32,
                ),
            ));
        }
        let compound = SharedShape::compound(parts.clone());
        let chassis_aabb = compound.compute_local_aabb();

        // Casters: frictionless balls (Min combine, so the floor's friction cannot creep in).
        let mut casters: Vec<(Vector, f32)> = Vec::new();
        for (i, c) in model.casters.iter().enumerate() {
            if !pos(c.radius) || !c.center.iter().all(|v| v.is_finite()) {
                return Err(robot_err(
                    model,
                    format!("casters[{i}] (link `{}`)", c.link),
                    format!(
                        "needs a finite centre and a radius > 0, got radius {}",
                        c.radius
                    ),
                ));
            }
            // A caster reaching below the wheels' floor plane would lift the drive wheels off
            // the floor; URDF caster geometry is often approximate, so rest it on the floor.
            let z = c.center.z.max(c.radius - base_z);
            casters.push((vec3(c.center.x, c.center.y, z), c.radius as f32));
        }
        if casters.is_empty() && model.drive_kind == DriveKind::Differential {
            // Without casters a two-wheeled body tips over: add support balls front and back.
            let rb = 0.5 * l.radius.min(r.radius);
            let ymid = 0.5 * (l.center.y + r.center.y);
            let z = rb - base_z;
            let front = (chassis_aabb.maxs.x as f64 - rb).max(l.radius + rb);
            let back = (chassis_aabb.mins.x as f64 + rb).min(-l.radius - rb);
            casters.push((vec3(front, ymid, z), rb as f32));
            casters.push((vec3(back, ymid, z), rb as f32));
        }

        let groups = InteractionGroups::new(ROBOT_GROUP, STATIC_GROUP, InteractionTestMode::And);
        let wall_groups = InteractionGroups::new(ROBOT_GROUP, WALL_GROUP, InteractionTestMode::And);
        let floor_groups =
            InteractionGroups::new(ROBOT_GROUP, FLOOR_GROUP, InteractionTestMode::And);
        let base = pose3(&start, base_z);
        let physics = &mut scene.physics;
        // Mass and centre of mass come from the URDF inertials, not from the collision
        // volumes (uniform density would put a heavy sensor's mass all over the body); the
        // rotational inertia is that of the collision compound at that mass.
        let chassis_mass = model.chassis_mass as f32;
        let volume_props = compound.mass_properties(1.0);
        let density = chassis_mass * volume_props.inv_mass;
        let shape_props = compound.mass_properties(density);
        let com = &model.chassis_com;
        let props = MassProperties::with_principal_inertia_frame(
            vec3(com.x, com.y, com.z),
            chassis_mass,
            shape_props.principal_inertia(),
            shape_props.principal_inertia_local_frame,
        );
        let chassis = physics.insert_body(
            RigidBodyBuilder::dynamic()
                .pose(base)
                .additional_mass_properties(props)
                .can_sleep(false),
        );
        physics.insert_collider(
            ColliderBuilder::new(compound.clone())
                .density(0.0)
                .collision_groups(groups),
            Some(chassis),
        );
        let mut footprint = parts;
        for (c, radius) in &casters {
            physics.insert_collider(
                ColliderBuilder::ball(*radius)
                    .translation(*c)
                    .density(0.0)
                    .friction(0.0)
                    .friction_combine_rule(CoefficientCombineRule::Min)
                    .collision_groups(groups),
                Some(chassis),
            );
            footprint.push((Pose::from_translation(*c), SharedShape::ball(*radius)));
        }

        let motor_factor = match model.drive_kind {
            DriveKind::Differential => MOTOR_FACTOR,
            DriveKind::SkidSteer(_) => SKID_MOTOR_FACTOR,
        };
        let mut make_wheel = |w: &Wheel, axis_left: Vector| {
            let offset = vec3(w.center.x, w.center.y, w.center.z);
            // The wheel body keeps the chassis orientation; its cylinder is turned so the
            // cylinder axis (parry: local +Y) lies along the axle.
            let shape_rot = Rotation::from_rotation_arc(Vector::Y, axis_left);
            let body = physics.insert_body(
                RigidBodyBuilder::dynamic()
                    .pose(base * Pose::from_translation(offset))
                    .allow_fast_rotation(true)
                    .can_sleep(false),
            );
            // Two colliders per wheel. Against walls: the true cylinder (mass and inertia
            // too). Against the floor: a massless ball of the wheel's radius, i.e. a point
            // contact under the wheel centre. A flat cylinder meets the floor along its whole
            // width, and the contact points at both rims resist yaw: measured at 200 Hz, a
            // Pioneer commanded to 0.5 rad/s in place turned at 0.44 rad/s with cylinders and
            // 0.498 with the point contact (a rounded "tyre" profile overshot to 0.538).
            let shape = SharedShape::cylinder((0.5 * w.width) as f32, w.radius as f32);
            physics.insert_collider(
                ColliderBuilder::new(shape.clone())
                    .rotation(shape_rot.to_scaled_axis())
                    .mass(w.mass as f32)
                    .collision_groups(wall_groups),
                Some(body),
            );
            physics.insert_collider(
                ColliderBuilder::ball(w.radius as f32)
                    .density(0.0)
                    .friction(WHEEL_FRICTION)
                    .collision_groups(floor_groups),
                Some(body),
            );
            footprint.push((Pose::from_parts(offset, shape_rot), shape));
            let joint = RevoluteJointBuilder::new(axis_left)
                .local_anchor1(offset)
                .local_anchor2(Vector::ZERO)
                .contacts_enabled(false)
                .motor_velocity(0.0, motor_factor);
            let joint = physics.insert_impulse_joint(chassis, body, joint);
            WheelBody {
                body,
                joint,
                offset,
                axis_left,
                commanded: 0.0,
                factor: motor_factor,
            }
        };
        let left = make_wheel(l, left_axis);
        let right = make_wheel(r, right_axis);
        let mut axes = rear_axes.into_iter();
        let mut rear = |wheels: &[Wheel]| -> Vec<WheelBody> {
            wheels
                .iter()
                .map(|w| make_wheel(w, axes.next().expect("one axis per rear wheel")))
                .collect()
        };
        let left_rear = rear(left_rear);
        let right_rear = rear(right_rear);

        let placed = footprint.clone();
        let mut robot = RobotBodies {
            chassis,
            left,
            right,
            left_rear,
            right_rear,
            base_z,
            footprint,
            placed,
        };
        if let Some((obstacle, material)) = robot.first_overlap(scene, &start) {
            return Err(SimError::Spawn {
                pose: start,
                obstacle,
                material,
            });
        }
        Ok(robot)
    }

    /// The planar bounding box of every robot collider in the base frame, m: (min, max)
    /// corners. People keep clear of it and the controller's look-ahead starts at its front.
    pub fn footprint_box(&self) -> ([f64; 2], [f64; 2]) {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for (pose, shape) in &self.footprint {
            let aabb = shape.compute_aabb(pose);
            for k in 0..2 {
                lo[k] = lo[k].min(aabb.mins[k] as f64);
                hi[k] = hi[k].max(aabb.maxs[k] as f64);
            }
        }
        (lo, hi)
    }

    /// The first wall or pillar the robot would overlap with its base at `pose`.
    pub fn first_overlap(&mut self, scene: &Scene, pose: &Pose2) -> Option<(String, String)> {
        let base = pose3(pose, self.base_z);
        for ((p, s), (local, shape)) in self.placed.iter_mut().zip(&self.footprint) {
            *p = base * *local;
            // Cloning a SharedShape bumps a reference count; it does not allocate.
            *s = shape.clone();
        }
        scene.first_overlap(&self.placed)
    }

    /// Every wheel body, left side first.
    fn wheels(&self) -> impl Iterator<Item = &WheelBody> {
        std::iter::once(&self.left)
            .chain(&self.left_rear)
            .chain(std::iter::once(&self.right))
            .chain(&self.right_rear)
    }

    /// Sets the wheel motors' target speeds, rad/s, forward positive: every wheel of a side
    /// gets its side's speed.
    pub fn set_wheel_speeds(&mut self, physics: &mut PhysicsWorld, left: f64, right: f64) {
        let (left, right) = (left as f32, right as f32);
        let sides = std::iter::once(&mut self.left)
            .chain(self.left_rear.iter_mut())
            .map(|w| (w, left))
            .chain(
                std::iter::once(&mut self.right)
                    .chain(self.right_rear.iter_mut())
                    .map(|w| (w, right)),
            );
        for (w, v) in sides {
            // Touching a joint marks it modified; skip it when the target is unchanged.
            if w.commanded != v {
                w.commanded = v;
                if let Some(j) = physics.impulse_joints.get_mut(w.joint, true) {
                    j.data.set_motor_velocity(JointAxis::AngX, v, w.factor);
                }
            }
        }
    }

    /// The chassis body's (= base frame's) pose in the world.
    pub fn base_pose(&self, physics: &PhysicsWorld) -> Pose {
        *physics.bodies[self.chassis].position()
    }

    pub fn ground_truth(&self, physics: &PhysicsWorld) -> Pose2 {
        project(&self.base_pose(physics))
    }

    /// Each side's wheel rotation relative to the chassis about its axle, in (−π, π],
    /// forward positive: the twist part of the relative rotation (swing–twist
    /// decomposition). For a skid steer, the mean over the side's wheels (the side's wheels
    /// share one drive train on Husky-like robots, so its encoder sees their mean), taken as
    /// offsets from the front wheel so that the ±π wrap cannot corrupt the mean.
    pub fn wheel_angles(&self, physics: &PhysicsWorld) -> (f64, f64) {
        let chassis = physics.bodies[self.chassis].rotation();
        let angle = |w: &WheelBody| {
            let rel = chassis.inverse() * *physics.bodies[w.body].rotation();
            let along = rel.x * w.axis_left.x + rel.y * w.axis_left.y + rel.z * w.axis_left.z;
            normalize_angle(2.0 * (along as f64).atan2(rel.w as f64))
        };
        let side = |front: &WheelBody, rear: &[WheelBody]| {
            let a0 = angle(front);
            let offsets: f64 = rear.iter().map(|w| normalize_angle(angle(w) - a0)).sum();
            normalize_angle(a0 + offsets / (1 + rear.len()) as f64)
        };
        (
            side(&self.left, &self.left_rear),
            side(&self.right, &self.right_rear),
        )
    }

    /// Moves every robot body so the base is at `pose` on the floor, keeping each wheel's
    /// rotation relative to the chassis (encoders see no jump), and zeroes all velocities.
    pub fn teleport(&self, physics: &mut PhysicsWorld, pose: &Pose2) {
        let base = pose3(pose, self.base_z);
        let old = *physics.bodies[self.chassis].rotation();
        for w in self.wheels() {
            let rb = &mut physics.bodies[w.body];
            let rel = old.inverse() * *rb.rotation();
            rb.set_position(base * Pose::from_parts(w.offset, rel), true);
            rb.set_linvel(Vector::ZERO, true);
            rb.set_angvel(Vector::ZERO, true);
        }
        let rb = &mut physics.bodies[self.chassis];
        rb.set_position(base, true);
        rb.set_linvel(Vector::ZERO, true);
        rb.set_angvel(Vector::ZERO, true);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures;

    #[test]
    fn spawned_robot_rests_on_its_wheels_and_caster() {
        let world = fixtures::box_room(6.0, 6.0, "concrete");
        let mut scene = Scene::new(&world, 200.0).unwrap();
        let model = fixtures::pioneer_3dx_like();
        let robot = RobotBodies::spawn(&mut scene, &model, Pose2::new(0.5, -0.25, 0.3)).unwrap();
        assert_eq!(robot.base_z, 0.0);
        for _ in 0..400 {
            scene.physics.step();
        }
        // Mass properties given to a body builder are applied at the first step.
        let total = scene.physics.bodies[robot.chassis].mass()
            + scene.physics.bodies[robot.left.body].mass()
            + scene.physics.bodies[robot.right.body].mass();
        assert!((total as f64 - model.mass()).abs() < 1e-4, "{total}");
        let com = scene.physics.bodies[robot.chassis].center_of_mass();
        let base = robot.base_pose(&scene.physics);
        let local = base.inverse_transform_point(com);
        assert!(
            (local.x as f64 - model.chassis_com.x).abs() < 1e-3,
            "{local:?}"
        );
        // Two seconds with the motors holding zero speed: the robot has settled in place,
        // no deeper than contact softness lets it sink, and level.
        let p = robot.base_pose(&scene.physics);
        let gt = project(&p);
        assert!(gt.distance(&Pose2::new(0.5, -0.25, 0.3)) < 2e-3, "{gt:?}");
        assert!((gt.theta - 0.3).abs() < 2e-3, "{gt:?}");
        assert!(p.translation.z.abs() < 5e-3, "{}", p.translation.z);
        let up = p.rotation * Vector::Z;
        assert!(up.z > 0.999, "tilted: {up:?}");
        // Settling onto the caster rolls the wheels a little (here about 1 mm, one tick).
        let (l, r) = robot.wheel_angles(&scene.physics);
        assert!(l.abs() < 0.03 && r.abs() < 0.03, "{l} {r}");
    }

    #[test]
    fn a_model_without_shapes_or_casters_still_stands() {
        let world = fixtures::box_room(6.0, 6.0, "concrete");
        let mut scene = Scene::new(&world, 200.0).unwrap();
        let mut model = fixtures::pioneer_3dx_like();
        model.chassis_shapes.clear();
        model.casters.clear();
        let robot = RobotBodies::spawn(&mut scene, &model, Pose2::default()).unwrap();
        for _ in 0..400 {
            scene.physics.step();
        }
        let up = robot.base_pose(&scene.physics).rotation * Vector::Z;
        assert!(up.z > 0.99, "tipped over: {up:?}");
    }

    #[test]
    fn sideways_wheel_axis_is_rejected() {
        let world = fixtures::box_room(6.0, 6.0, "concrete");
        let mut scene = Scene::new(&world, 200.0).unwrap();
        let mut model = fixtures::pioneer_3dx_like();
        model.right_wheel.axis = nalgebra::Vector3::new(1.0, 0.0, 0.0);
        let e = RobotBodies::spawn(&mut scene, &model, Pose2::default())
            .err()
            .unwrap();
        assert!(e.to_string().contains("right_wheel.axis"), "{e}");
    }
}
