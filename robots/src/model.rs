//! The robot as the simulator and the CLI need it: a rigid chassis, two drive wheels,
//! passive casters and the poses of every link (sensor mounts) in the base frame.

use crate::diff_drive::DiffDrive;
use nalgebra::{Isometry3, Vector3};

/// A collision primitive, in its own frame (URDF conventions: a cylinder's axis is local z).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    Box { size: [f64; 3] },
    Cylinder { radius: f64, length: f64 },
    Sphere { radius: f64 },
}

/// A shape placed in the robot's base frame.
#[derive(Debug, Clone, PartialEq)]
pub struct ShapeInstance {
    /// The URDF link it came from.
    pub link: String,
    pub shape: Shape,
    /// Pose of the shape's frame in the base frame.
    pub pose: Isometry3<f64>,
}

/// A driven wheel.
#[derive(Debug, Clone, PartialEq)]
pub struct Wheel {
    pub joint: String,
    pub link: String,
    /// Wheel centre in the base frame.
    pub center: Vector3<f64>,
    /// Unit joint axis in the base frame, as the URDF states it (after the joint origin's
    /// rotation). Its sign matters: a positive joint velocity about `axis` drives the robot
    /// forward when `axis` points to +y (left).
    pub axis: Vector3<f64>,
    pub radius: f64,
    pub width: f64,
    /// kg, from the wheel link's `<inertial><mass>`. When the URDF gives 0 or no inertial at
    /// all, the loader uses 2 % of the chassis mass (a light wheel that still has inertia for
    /// the physics solver) and says so in [`RobotModel::warnings`].
    pub mass: f64,
}

/// A passive support (caster wheel, ball or skid) modelled as a frictionless sphere.
#[derive(Debug, Clone, PartialEq)]
pub struct Caster {
    pub link: String,
    /// Centre of the support sphere in the base frame.
    pub center: Vector3<f64>,
    pub radius: f64,
}

/// A link's pose in the base frame: where sensors are mounted.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkMount {
    pub name: String,
    pub pose: Isometry3<f64>,
}

impl LinkMount {
    /// Translation (m) and URDF roll, pitch, yaw (rad) of the link in the base frame, the
    /// inverse of a URDF `<origin xyz rpy>`: the rotation is Rz(yaw)·Ry(pitch)·Rx(roll).
    pub fn xyz_rpy(&self) -> ([f64; 3], [f64; 3]) {
        let t = self.pose.translation.vector;
        // nalgebra's Euler angles use the same fixed-axis x-y-z convention as URDF.
        let (roll, pitch, yaw) = self.pose.rotation.euler_angles();
        ([t.x, t.y, t.z], [roll, pitch, yaw])
    }
}

/// One joint of a URDF's tree, as written (see [`RobotModel::joint_tree`]).
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfJoint {
    pub name: String,
    pub parent: String,
    pub child: String,
    /// The joint's `<origin>`: the child frame in the parent frame at joint position zero.
    pub origin: Isometry3<f64>,
    /// A fixed joint (its transform never changes: `/tf_static`); else it moves (`/joint_states`).
    pub fixed: bool,
    /// The URDF joint type (`fixed`, `continuous`, `revolute`, ...).
    pub kind: &'static str,
    /// The joint axis in the child frame, as written (`[1, 0, 0]` when omitted).
    pub axis: [f64; 3],
}

/// A revolving (continuous or revolute) URDF joint that the loader did not make one of the two
/// drive wheels, and why (its axis is not lateral, it is a caster by name or sits below a
/// swivel, or its link has no round geometry).
#[derive(Debug, Clone, PartialEq)]
pub struct ExcludedJoint {
    pub joint: String,
    /// The joint's child link.
    pub link: String,
    /// Human-readable, e.g. `it hangs below the swivel joint "caster_swivel_joint" (...)`.
    pub reason: String,
}

/// A robot loaded from a URDF together with the loader's per-joint decisions, for
/// `atrium inspect robot`. (Kept beside the [`RobotModel`] rather than in it so that code
/// building a `RobotModel` with a struct literal keeps compiling.)
#[derive(Debug, Clone, PartialEq)]
pub struct RobotInspection {
    pub model: RobotModel,
    /// Every revolving joint that is not a drive wheel, in tree order (parents first).
    pub excluded_joints: Vec<ExcludedJoint>,
    /// Where the wheel radius and track came from.
    pub drive_source: DriveSource,
}

/// How the driven wheels move the robot.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum DriveKind {
    /// One driven wheel per side ([`RobotModel::left_wheel`], [`RobotModel::right_wheel`]);
    /// passive casters carry the rest of the weight.
    #[default]
    Differential,
    /// Two or three driven wheels per side, every wheel of a side given the same speed
    /// (Clearpath Husky and Jackal style). Turning needs the wheels to slide sideways.
    SkidSteer(SkidSteer),
}

/// Where a skid steer's [`SkidSteer::effective_track`] came from.
#[derive(Debug, Clone, PartialEq)]
pub enum TrackSource {
    /// [`crate::diff_drive::DEFAULT_EFFECTIVE_TRACK_RATIO`] × the geometric track.
    DefaultRatio,
    /// The URDF's `<skid_steer effective_track=".."/>` or `effective_track_ratio=".."`.
    Urdf,
}

/// The wheels and the turning geometry of a skid-steer drive.
#[derive(Debug, Clone, PartialEq)]
pub struct SkidSteer {
    /// Driven wheels on the left (y > 0), front to back; the first is
    /// [`RobotModel::left_wheel`].
    pub left: Vec<Wheel>,
    /// Driven wheels on the right (y < 0), front to back; the first is
    /// [`RobotModel::right_wheel`].
    pub right: Vec<Wheel>,
    /// The track (m) the robot's drive software turns with: wheel speeds from a body
    /// velocity, and odometry from the wheel encoders, use this instead of the geometric
    /// [`RobotModel::wheel_separation`], because the sliding wheels make a skid steer turn
    /// as if its wheels were farther apart (see [`crate::diff_drive`]).
    pub effective_track: f64,
    pub effective_track_source: TrackSource,
}

/// A wheeled robot derived from a URDF: a differential drive or a skid steer.
#[derive(Debug, Clone, PartialEq)]
pub struct RobotModel {
    pub name: String,
    /// The URDF's root link; its floor projection is the robot's planar pose.
    pub base_link: String,
    /// Collision shapes of every link rigidly attached to the base (not wheels or casters).
    pub chassis_shapes: Vec<ShapeInstance>,
    /// Mass of everything except the drive wheels (casters included), kg.
    pub chassis_mass: f64,
    /// Centre of mass of everything except the drive wheels, in the base frame, from the
    /// URDF's inertial origins.
    pub chassis_com: Vector3<f64>,
    /// The driven wheel on the left (for a skid steer, the front one of its left side).
    pub left_wheel: Wheel,
    /// The driven wheel on the right (for a skid steer, the front one of its right side).
    pub right_wheel: Wheel,
    pub casters: Vec<Caster>,
    /// Every link, including the base (identity) and the wheels.
    pub mounts: Vec<LinkMount>,
    /// Mean of the drive wheels' radii, m.
    pub wheel_radius: f64,
    /// Distance between the two drive wheels' contact points (for a skid steer, between
    /// the mean lateral positions of its two sides: the geometric track), m.
    pub wheel_separation: f64,
    /// Height of the base frame's origin above the floor when the wheels touch it, m.
    pub base_height: f64,
    /// Human-readable notes about what the loader could not use or had to assume (mesh-only
    /// links, defaulted wheel masses, joints held at zero, ...). Empty for a clean URDF.
    pub warnings: Vec<String>,
    /// Differential drive or skid steer (then with every driven wheel).
    pub drive_kind: DriveKind,
}

impl RobotModel {
    /// The drive's kinematics as the robot's software uses them: the wheel separation of a
    /// differential drive, the effective track of a skid steer.
    pub fn drive(&self) -> DiffDrive {
        DiffDrive {
            wheel_radius: self.wheel_radius,
            wheel_separation: match &self.drive_kind {
                DriveKind::Differential => self.wheel_separation,
                DriveKind::SkidSteer(s) => s.effective_track,
            },
        }
    }

    /// Every driven wheel, left side first (front to back), then the right side.
    pub fn driven_wheels(&self) -> Vec<&Wheel> {
        match &self.drive_kind {
            DriveKind::Differential => vec![&self.left_wheel, &self.right_wheel],
            DriveKind::SkidSteer(s) => s.left.iter().chain(&s.right).collect(),
        }
    }

    pub fn mount(&self, link: &str) -> Option<&LinkMount> {
        self.mounts.iter().find(|m| m.name == link)
    }

    /// Total mass, kg.
    pub fn mass(&self) -> f64 {
        self.chassis_mass + self.driven_wheels().iter().map(|w| w.mass).sum::<f64>()
    }
}

/// The drive geometry a user states in place of (or over) the URDF's.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DriveOverride {
    /// Radius of every driven wheel, m.
    pub wheel_radius: Option<f64>,
    /// Distance between the left and right wheels' contact lines (the wheel separation; for a
    /// skid steer the geometric track), m.
    pub track: Option<f64>,
}

/// Where a robot's drive geometry came from, for `atrium inspect robot`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DriveSource {
    /// The URDF's wheel joints and their collision (or visual) cylinders and spheres.
    #[default]
    Urdf,
    /// `[robot] wheel_radius` and/or `track` over the URDF's wheels.
    Override,
    /// Wheels the URDF describes with meshes only (or on fixed joints), placed by `[robot]
    /// track` and sized by `[robot] wheel_radius`.
    OverrideMeshWheels,
}
