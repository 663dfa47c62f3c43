//! The fixed-step simulation: controller -> wheel motors -> rapier step -> ground truth ->
//! encoders -> sensors on their schedules, producing a time-ordered stream of readings.

use crate::controller::{ControllerParams, WaypointFollower};
use crate::encoders::{Encoder, Odometry};
use crate::error::SimError;
use crate::laser::Laser;
use crate::robot::{pose3, RobotBodies};
use crate::scene::{pose_to_iso, Scene};
use crate::schedule::Schedule;
use atrium_robots::{
    LaserScan, LaserSpec, OdometrySpec, Pose2, Reading, RobotModel, WheelOdometry,
};
use atrium_worlds::World;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// Everything a run needs besides the world and the robot.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// Physics steps per second (default 200).
    pub physics_hz: f64,
    /// Where the robot's base starts; odometry starts here too.
    pub start: Pose2,
    pub odometry: OdometrySpec,
    pub lasers: Vec<LaserSpec>,
    pub controller: ControllerParams,
    /// Every random stream of the run derives from this.
    pub seed: u64,
    /// The WiFi scanner (RSSI of the world's access points, see `wifi.rs`); none by default.
    pub wifi: Option<atrium_robots::WifiSpec>,
    /// Point-feature (pillar) detectors for EKF-SLAM; none by default.
    pub landmark_detectors: Vec<atrium_robots::LandmarkDetectorSpec>,
    /// Depth cameras (opt-in per scenario: each costs one ray per pixel per frame); none by
    /// default.
    pub depth_cameras: Vec<atrium_robots::DepthCameraSpec>,
    /// Intensity cameras and stereo rigs with the lighting they see (`camera_stream.rs`);
    /// none by default, and then nothing is rendered.
    pub cameras: crate::camera_stream::CameraSensors,
    /// Pedestrians (`people.rs`); density 0 by default, and then the scene, the random
    /// streams and every reading are exactly those of a run without the feature.
    pub people: crate::people::PeopleParams,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            physics_hz: 200.0,
            start: Pose2::default(),
            odometry: OdometrySpec::default(),
            lasers: Vec::new(),
            controller: ControllerParams::default(),
            seed: 0,
            wifi: None,
            landmark_detectors: Vec::new(),
            depth_cameras: Vec::new(),
            cameras: Default::default(),
            people: Default::default(),
        }
    }
}

/// Stream ids under the run seed: one per purpose, so adding a sensor never shifts another
/// sensor's noise.
const STREAM_LASER: u64 = 0x1000;
const STREAM_LASER_PROBE: u64 = 0x2000;
const STREAM_WIFI: u64 = 0x6000;
const STREAM_LANDMARKS: u64 = 0x3000;
const STREAM_DEPTH: u64 = 0x4000;
const STREAM_DEPTH_PROBE: u64 = 0x5000;
/// People's goals and starts (camera streams take 0x7000..0xb000).
const STREAM_PEOPLE: u64 = 0xb000;
/// The wheels' random slip.
const STREAM_ODOMETRY: u64 = 0xc000;

fn stream(seed: u64, id: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(id);
    rng
}

/// A robot in a world, stepped at a fixed rate.
pub struct Simulation {
    scene: Scene,
    robot: RobotBodies,
    follower: WaypointFollower,
    left_encoder: Encoder,
    right_encoder: Encoder,
    odometry: Odometry,
    odometry_schedule: Schedule,
    lasers: Vec<Laser>,
    laser_specs: Vec<LaserSpec>,
    laser_schedules: Vec<Schedule>,
    probe_rngs: Vec<ChaCha8Rng>,
    physics_hz: f64,
    steps: u64,
    truth: Pose2,
    /// Wheel speeds set directly (rad/s), overriding the follower until the next route.
    manual: Option<(f64, f64)>,
    /// The WiFi scanner and its schedule (last in each step's output).
    wifi: Option<(crate::wifi::WifiSensor, Schedule)>,
    /// The node controller (002 Table I), when the route is a node list; it then drives
    /// instead of the waypoint follower.
    node_controller: Option<crate::node_controller::NodeController>,
    /// The robot's true drive geometry, for the node controller's wheel speeds.
    drive: atrium_robots::DiffDrive,
    /// Feed the node controller the true pose instead of odometry (a surveyed teach run).
    nodes_on_truth: bool,
    /// Pillar detectors and their schedules (after the lasers in each step's output).
    landmark_detectors: Vec<(crate::landmarks::LandmarkDetector, Schedule)>,
    /// Depth cameras, their schedules and probe streams (after the landmark detectors in each
    /// step's output).
    depth_cameras: Vec<(crate::depth::DepthCamera, Schedule, ChaCha8Rng)>,
    /// Intensity cameras and stereo rigs (after the depth cameras in each step's output).
    cameras: Option<crate::camera_stream::CameraStream>,
    /// Pedestrians, when the density is above 0, and the robot's corridor ahead that they
    /// may block.
    people: Option<crate::people::People>,
    people_placement: crate::people::PeoplePlacement,
    look_ahead: crate::controller::LookAhead,
}

impl Simulation {
    pub fn new(
        world: &World,
        robot: &RobotModel,
        config: SimConfig,
    ) -> Result<Simulation, SimError> {
        let hz = crate::error::positive("physics_hz", config.physics_hz)?;
        config.controller.validate()?;
        let odometry = Odometry::new(&config.odometry, robot.drive(), config.start)?
            .with_slip(&config.odometry, stream(config.seed, STREAM_ODOMETRY));
        let odometry_schedule = Schedule::new(hz, config.odometry.rate_hz, "odometry.rate_hz")?;
        let mut lasers = Vec::with_capacity(config.lasers.len());
        let mut laser_schedules = Vec::with_capacity(config.lasers.len());
        let mut probe_rngs = Vec::with_capacity(config.lasers.len());
        for (i, spec) in config.lasers.iter().enumerate() {
            let field = format!("lasers[{i}]");
            let mount = robot.mount(&spec.mount).ok_or_else(|| {
                SimError::config(
                    format!("{field}.mount"),
                    format!("`{}` is not a link of robot `{}`", spec.mount, robot.name),
                )
            })?;
            let rng = stream(config.seed, STREAM_LASER + i as u64);
            lasers.push(Laser::new(spec.clone(), &mount.pose, rng, &field)?);
            laser_schedules.push(Schedule::new(
                hz,
                spec.rate_hz,
                &format!("{field}.rate_hz"),
            )?);
            probe_rngs.push(stream(config.seed, STREAM_LASER_PROBE + i as u64));
        }
        let mut landmark_detectors = Vec::with_capacity(config.landmark_detectors.len());
        for (i, spec) in config.landmark_detectors.iter().enumerate() {
            let field = format!("landmark_detectors[{i}]");
            let mount = robot.mount(&spec.mount).ok_or_else(|| {
                SimError::config(
                    format!("{field}.mount"),
                    format!("`{}` is not a link of robot `{}`", spec.mount, robot.name),
                )
            })?;
            let rng = stream(config.seed, STREAM_LANDMARKS + i as u64);
            let detector = crate::landmarks::LandmarkDetector::new(
                spec.clone(),
                &mount.pose,
                world,
                rng,
                &field,
            )?;
            let schedule = Schedule::new(hz, spec.rate_hz, &format!("{field}.rate_hz"))?;
            landmark_detectors.push((detector, schedule));
        }
        let mut depth_cameras = Vec::with_capacity(config.depth_cameras.len());
        for (i, spec) in config.depth_cameras.iter().enumerate() {
            let field = format!("depth_cameras[{i}]");
            let mount = robot.mount(&spec.mount).ok_or_else(|| {
                SimError::config(
                    format!("{field}.mount"),
                    format!("`{}` is not a link of robot `{}`", spec.mount, robot.name),
                )
            })?;
            let rng = stream(config.seed, STREAM_DEPTH + i as u64);
            let camera = crate::depth::DepthCamera::new(spec.clone(), &mount.pose, rng, &field)?;
            let schedule = Schedule::new(hz, spec.rate_hz, &format!("{field}.rate_hz"))?;
            let probe = stream(config.seed, STREAM_DEPTH_PROBE + i as u64);
            depth_cameras.push((camera, schedule, probe));
        }
        let wifi = match &config.wifi {
            Some(spec) => {
                spec.validate().map_err(|msg| {
                    let (key, why) = msg.split_once(": ").unwrap_or(("", msg.as_str()));
                    SimError::config(format!("wifi.{key}"), why)
                })?;
                let rng = stream(config.seed, STREAM_WIFI);
                let sensor = crate::wifi::WifiSensor::new(world, spec.clone(), rng);
                let schedule = Schedule::new(hz, 1.0 / spec.scan_period_s, "wifi.scan_period_s")?;
                Some((sensor, schedule))
            }
            None => None,
        };
        let follower = WaypointFollower::new(config.controller, robot.drive())?;

        let mut scene = Scene::new(world, hz)?;
        let robot_bodies = RobotBodies::spawn(&mut scene, robot, config.start)?;
        config.people.validate()?;
        let footprint = robot_bodies.footprint_box();
        let look_ahead = crate::controller::LookAhead {
            front: footprint.1[0],
            half_width: footprint.1[1].max(-footprint.0[1]),
        };
        // Bodies join the scene after the robot's, so its handles never depend on people.
        let people = if config.people.density > 0.0 {
            Some(crate::people::People::new(
                world,
                &mut scene,
                config.people,
                config.start,
                footprint,
                stream(config.seed, STREAM_PEOPLE),
            )?)
        } else {
            None
        };
        let cameras = crate::camera_stream::CameraStream::new(
            world,
            &scene,
            &config.cameras,
            hz,
            config.seed,
        )?;
        let (l, r) = robot_bodies.wheel_angles(&scene.physics);
        let ticks = config.odometry.ticks_per_rev;
        Ok(Simulation {
            truth: robot_bodies.ground_truth(&scene.physics),
            scene,
            robot: robot_bodies,
            follower,
            left_encoder: Encoder::new(ticks, l),
            right_encoder: Encoder::new(ticks, r),
            odometry,
            odometry_schedule,
            lasers,
            laser_specs: config.lasers,
            laser_schedules,
            probe_rngs,
            physics_hz: hz,
            steps: 0,
            manual: None,
            wifi,
            node_controller: None,
            drive: robot.drive(),
            nodes_on_truth: false,
            landmark_detectors,
            depth_cameras,
            cameras,
            people,
            people_placement: Default::default(),
            look_ahead,
        })
    }

    /// Replaces the route (waypoints in the world frame, m); an empty route stops the robot.
    pub fn set_route(&mut self, waypoints: &[[f64; 2]]) {
        self.manual = None;
        self.node_controller = None;
        self.follower.set_route(waypoints);
    }

    /// Limits each leg of the route set last to its own speed (see
    /// [`WaypointFollower::set_leg_speeds`]).
    pub fn set_leg_speeds(&mut self, speeds: &[f64]) -> Result<(), SimError> {
        self.follower.set_leg_speeds(speeds)
    }

    /// Drives the wheel motors directly (rad/s, forward positive) from the next step on,
    /// bypassing the waypoint follower until [`Simulation::set_route`] is called. For node
    /// controllers written elsewhere and for calibrating the physics.
    pub fn set_wheel_speeds(&mut self, left: f64, right: f64) -> Result<(), SimError> {
        if !(left.is_finite() && right.is_finite()) {
            return Err(SimError::config(
                "wheel speeds",
                format!("must be finite, got ({left}, {right})"),
            ));
        }
        self.manual = Some((left, right));
        Ok(())
    }

    /// One physics step: controller (on the true pose) -> wheel motors -> rapier step ->
    /// ground truth -> encoders and odometry; then pushes the readings that are due, all
    /// stamped with the new sim time (odometry first, then lasers in config order).
    /// Returns the ground-truth pose.
    pub fn step(&mut self, out: &mut Vec<Reading>) -> Pose2 {
        let dt = 1.0 / self.physics_hz;
        let place_people = self.people.is_some()
            && match self.people_placement {
                crate::people::PeoplePlacement::EveryStep => true,
                crate::people::PeoplePlacement::SensorInstants => {
                    self.scene_read_at(self.steps + 1)
                }
            };
        if let Some(people) = &mut self.people {
            people.step(&self.truth, dt);
            if place_people {
                people.place(&mut self.scene.physics);
            }
            let (v, _) = self.follower.command();
            let blocked = self.look_ahead.blocked(
                &self.truth,
                v,
                self.follower.params().max_accel,
                people.positions(),
                people.params().radius,
            );
            self.follower.set_blocked(blocked);
        }
        let (wl, wr) = match (self.manual, &mut self.node_controller) {
            (Some(w), _) => w,
            (None, Some(nodes)) => nodes.update(dt),
            (None, None) => self.follower.update(&self.truth, dt),
        };
        self.robot.set_wheel_speeds(&mut self.scene.physics, wl, wr);
        self.scene.physics.step();
        self.steps += 1;
        self.truth = self.robot.ground_truth(&self.scene.physics);

        let (l, r) = self.robot.wheel_angles(&self.scene.physics);
        self.left_encoder.update(l);
        self.right_encoder.update(r);
        let (lt, rt) = (self.left_encoder.ticks(), self.right_encoder.ticks());
        let odom = self.odometry.update(lt, rt);
        if let Some(nodes) = &mut self.node_controller {
            // The node controller drives on odometry, not on the true pose (002 Table I).
            let pose = if self.nodes_on_truth {
                self.truth
            } else {
                odom
            };
            nodes.odometry(pose, self.steps as f64 / self.physics_hz);
        }

        let stamp = self.time();
        if self.odometry_schedule.due(self.steps) {
            out.push(Reading::Odometry(WheelOdometry {
                stamp,
                pose: odom,
                left_ticks: lt,
                right_ticks: rt,
            }));
        }
        let base = self.robot.base_pose(&self.scene.physics);
        for (laser, schedule) in self.lasers.iter_mut().zip(&mut self.laser_schedules) {
            if schedule.due(self.steps) {
                out.push(Reading::Laser(laser.scan(&self.scene, &base, stamp)));
            }
        }
        for (detector, schedule) in &mut self.landmark_detectors {
            if schedule.due(self.steps) {
                out.push(Reading::Landmarks(detector.detect(
                    &self.scene,
                    &base,
                    stamp,
                )));
            }
        }
        for (camera, schedule, _) in &mut self.depth_cameras {
            if schedule.due(self.steps) {
                out.push(Reading::Depth(camera.frame(&self.scene, &base, stamp)));
            }
        }
        if let Some(cameras) = &mut self.cameras {
            cameras.step(&self.scene, &base, self.steps, stamp, out);
        }
        if let Some((sensor, schedule)) = &mut self.wifi {
            if schedule.due(self.steps) {
                out.push(Reading::Wifi(sensor.scan(&self.truth, stamp)));
            }
        }
        self.truth
    }

    /// Whether one of the simulation's sensors casts rays into the scene after step `step`
    /// (odometry and WiFi read no geometry).
    fn scene_read_at(&self, step: u64) -> bool {
        self.laser_schedules.iter().any(|s| s.due_at(step))
            || self.landmark_detectors.iter().any(|(_, s)| s.due_at(step))
            || self.depth_cameras.iter().any(|(_, s, _)| s.due_at(step))
            || self.cameras.as_ref().is_some_and(|c| c.due_at(step))
    }

    /// When people's colliders follow their walk: before every step (the default, so rays a
    /// caller casts into [`Simulation::scene`], [`Simulation::scan_at`] or
    /// [`Simulation::depth_at`] between readings see everyone where they are), or only
    /// before the steps after which the simulation's own sensors read; in between, those
    /// calls see people where the last reading saw them. The simulation's own readings are
    /// the same bits either way (`sim/tests/people.rs`).
    pub fn set_people_placement(&mut self, placement: crate::people::PeoplePlacement) {
        self.people_placement = placement;
    }

    /// The WiFi scanner, when configured (its field gives the noise-free mean RSSI).
    pub fn wifi(&self) -> Option<&crate::wifi::WifiSensor> {
        self.wifi.as_ref().map(|(s, _)| s)
    }

    /// Sim time, s: steps taken / physics_hz.
    pub fn time(&self) -> f64 {
        self.steps as f64 / self.physics_hz
    }

    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The base frame's true 3D pose in the world (f64, nalgebra).
    pub fn ground_truth_3d(&self) -> nalgebra::Isometry3<f64> {
        pose_to_iso(&self.robot.base_pose(&self.scene.physics))
    }

    /// The base frame's true planar pose.
    pub fn ground_truth(&self) -> Pose2 {
        self.truth
    }

    /// The odometry's current pose (it started at `SimConfig::start`).
    pub fn odometry_pose(&self) -> Pose2 {
        self.odometry.pose()
    }

    /// True (unquantised) wheel rotations since start, rad, forward positive.
    pub fn wheel_rotations(&self) -> (f64, f64) {
        (self.left_encoder.angle(), self.right_encoder.angle())
    }

    /// The follower's current body velocity command (v m/s, ω rad/s).
    pub fn command(&self) -> (f64, f64) {
        match &self.node_controller {
            Some(nodes) => nodes.command(),
            None => self.follower.command(),
        }
    }

    /// Drives a node list with the node controller of 002 Table I (turnTo / moveTo / update,
    /// thresholds γ_θ and γ_d) on the robot's odometry, from the next step on, with the speed
    /// and acceleration limits of `SimConfig::controller`. The controller's odometry
    /// coordinates start at the current true pose. [`Simulation::set_route`] returns to the
    /// waypoint follower.
    pub fn set_node_route(
        &mut self,
        nodes: &[[f64; 2]],
        params: crate::node_controller::NodeControllerParams,
    ) -> Result<(), SimError> {
        let controller = crate::node_controller::NodeController::new(
            *self.follower.params(),
            params,
            self.drive,
            nodes,
            self.truth,
        )?;
        self.manual = None;
        self.node_controller = Some(controller);
        self.nodes_on_truth = false;
        Ok(())
    }

    /// [`Simulation::set_node_route`], but the node controller is fed the true pose instead
    /// of odometry: a surveyed teach run that stops at the nodes themselves, for training a
    /// landmark model at them (002 §IV-A: "an ideal node, acquired earlier").
    pub fn set_node_route_on_ground_truth(
        &mut self,
        nodes: &[[f64; 2]],
        params: crate::node_controller::NodeControllerParams,
    ) -> Result<(), SimError> {
        self.set_node_route(nodes, params)?;
        self.nodes_on_truth = true;
        Ok(())
    }

    /// A landmark filter verified node `node` (002 Algorithm 1 lines 12–15): the node
    /// controller stops, sets its pose to the node and heads for the next. Returns whether it
    /// applied (false without a node route, or when `node` is not the one being approached).
    /// `pose`, when given, is the filter's pose after the reset, which the controller then
    /// steers on ([`crate::node_controller::NodeController::verify`]).
    pub fn verify_node(&mut self, node: usize, pose: Option<Pose2>) -> bool {
        let stamp = self.time();
        self.node_controller
            .as_mut()
            .is_some_and(|c| c.verify(node, stamp, pose))
    }

    /// The node controller, when the route is a node list.
    pub fn node_controller(&self) -> Option<&crate::node_controller::NodeController> {
        self.node_controller.as_ref()
    }

    /// Index of the waypoint being approached.
    pub fn next_waypoint(&self) -> usize {
        self.follower.next_waypoint()
    }

    pub fn route_finished(&self) -> bool {
        match &self.node_controller {
            Some(nodes) => nodes.finished(),
            None => self.follower.finished(),
        }
    }

    /// Kidnapping: moves every robot body so the base is at `pose`, zeroes all velocities
    /// and the controller's ramp. The encoders and odometry are not told. Fails with
    /// [`SimError::Spawn`] (and moves nothing) if the robot would overlap a wall or pillar.
    pub fn teleport(&mut self, pose: Pose2) -> Result<(), SimError> {
        if !pose.is_finite() {
            return Err(SimError::config(
                "teleport pose",
                format!("must be finite, got {pose:?}"),
            ));
        }
        if let Some((obstacle, material)) = self.robot.first_overlap(&self.scene, &pose) {
            return Err(SimError::Spawn {
                pose,
                obstacle,
                material,
            });
        }
        self.robot.teleport(&mut self.scene.physics, &pose);
        self.robot
            .set_wheel_speeds(&mut self.scene.physics, 0.0, 0.0);
        self.follower.halt();
        if self.manual.is_some() {
            self.manual = Some((0.0, 0.0));
        }
        self.truth = self.robot.ground_truth(&self.scene.physics);
        Ok(())
    }

    pub fn laser_specs(&self) -> &[LaserSpec] {
        &self.laser_specs
    }

    /// A one-off scan of laser `laser_index` with the robot's base (level, on the floor) at
    /// `pose`, stamped with the current time. The robot is not moved, and the noise comes
    /// from a separate stream so the run's own readings are unaffected.
    pub fn scan_at(&mut self, pose: Pose2, laser_index: usize) -> Result<LaserScan, SimError> {
        let n = self.lasers.len();
        let laser = self.lasers.get_mut(laser_index).ok_or_else(|| {
            SimError::config(
                "laser_index",
                format!("{laser_index} is out of range: {n} lasers configured"),
            )
        })?;
        let base = pose3(&pose, self.robot.base_z);
        let stamp = self.steps as f64 / self.physics_hz;
        Ok(laser.scan_with(&self.scene, &base, stamp, &mut self.probe_rngs[laser_index]))
    }

    /// A one-off frame of depth camera `index` with the robot's base (level, on the floor) at
    /// `pose`, stamped with the current time; noise from a separate stream, so the run's own
    /// readings are unaffected. The camera's `true_depths` then hold this frame's truth.
    pub fn depth_at(
        &mut self,
        pose: Pose2,
        index: usize,
    ) -> Result<atrium_robots::DepthImage, SimError> {
        let n = self.depth_cameras.len();
        let (camera, _, rng) = self.depth_cameras.get_mut(index).ok_or_else(|| {
            SimError::config(
                "depth_camera_index",
                format!("{index} is out of range: {n} depth cameras configured"),
            )
        })?;
        let base = pose3(&pose, self.robot.base_z);
        let stamp = self.steps as f64 / self.physics_hz;
        Ok(camera.frame_with(&self.scene, &base, stamp, rng))
    }

    /// Depth camera `index` (its spec and the noiseless depths of its last frame).
    pub fn depth_camera(&self, index: usize) -> Option<&crate::depth::DepthCamera> {
        self.depth_cameras.get(index).map(|(c, _, _)| c)
    }

    /// The noiseless ranges of laser `laser_index` from its last scan (or `scan_at`).
    pub fn last_true_ranges(&self, laser_index: usize) -> Option<&[f64]> {
        self.lasers.get(laser_index).map(|l| l.true_ranges())
    }

    /// The physics scene (read-only), for sensors written elsewhere and for inspection.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    pub fn robot_bodies(&self) -> &RobotBodies {
        &self.robot
    }

    /// The pedestrians, when the run has any.
    pub fn people(&self) -> Option<&crate::people::People> {
        self.people.as_ref()
    }

    /// Whether the waypoint follower is holding for something in its way.
    pub fn blocked(&self) -> bool {
        self.follower.blocked()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures;
    use atrium_robots::normalize_angle;

    fn exact_odometry() -> OdometrySpec {
        OdometrySpec {
            ticks_per_rev: 500,
            radius_error: 0.0,
            separation_error: 0.0,
            rate_hz: 50.0,
            ..Default::default()
        }
    }

    fn sim_in(world: &World, config: SimConfig) -> Simulation {
        Simulation::new(world, &fixtures::pioneer_3dx_like(), config).unwrap()
    }

    /// Steps for `seconds`, returning the readings and the heading unwrapped along the way.
    fn run(sim: &mut Simulation, seconds: f64) -> (Vec<Reading>, f64) {
        let mut out = Vec::new();
        let mut yaw = 0.0;
        let mut last = sim.ground_truth().theta;
        let n = (seconds * sim.physics_hz).round() as usize;
        for _ in 0..n {
            let p = sim.step(&mut out);
            yaw += normalize_angle(p.theta - last);
            last = p.theta;
        }
        (out, yaw)
    }

    /// Ramps the body velocity linearly to (v, ω) over 1 s (within the default controller
    /// limits, so the wheels do not spin up faster than the tyres can grip), then holds it.
    fn ramp(sim: &mut Simulation, v: f64, w: f64) {
        let d = fixtures::pioneer_3dx_like().drive();
        let mut out = Vec::new();
        let n = sim.physics_hz as usize;
        for i in 1..=n {
            let f = i as f64 / n as f64;
            let (l, r) = d.wheel_speeds(v * f, w * f);
            sim.set_wheel_speeds(l, r).unwrap();
            sim.step(&mut out);
        }
    }

    fn sick(name: &str) -> LaserSpec {
        LaserSpec::sick_lms200(name, "laser")
    }

    fn noiseless(mut spec: LaserSpec) -> LaserSpec {
        spec.sigma_hit = 0.0;
        spec.p_short = 0.0;
        spec.p_max = 0.0;
        spec.p_rand = 0.0;
        spec
    }

    #[test]
    fn straight_commands_give_the_commanded_speed_and_odometry_follows() {
        let world = fixtures::box_room(20.0, 20.0, "concrete");
        let config = SimConfig {
            start: Pose2::new(-6.0, 0.0, 0.0),
            odometry: exact_odometry(),
            ..Default::default()
        };
        let mut sim = sim_in(&world, config);
        ramp(&mut sim, 0.5, 0.0);
        let (p0, o0) = (sim.ground_truth(), sim.odometry_pose());
        let (_, yaw) = run(&mut sim, 5.0);
        let (p1, o1) = (sim.ground_truth(), sim.odometry_pose());
        let speed = p1.distance(&p0) / 5.0;
        assert!((speed - 0.5).abs() < 0.03 * 0.5, "speed {speed}");
        assert!(yaw.abs() < 0.01, "heading drifted by {yaw} rad");
        let (truth, odo) = (p1.distance(&p0), o1.distance(&o0));
        assert!(
            (odo - truth).abs() < 0.02 * truth,
            "odometry {odo} m vs truth {truth} m"
        );
    }

    #[test]
    fn turning_in_place_gives_the_commanded_rate() {
        let world = fixtures::box_room(20.0, 20.0, "concrete");
        let mut sim = sim_in(&world, SimConfig::default());
        ramp(&mut sim, 0.0, 0.5);
        let p0 = sim.ground_truth();
        let (_, yaw) = run(&mut sim, 4.0);
        let rate = yaw / 4.0;
        assert!((rate - 0.5).abs() < 0.03 * 0.5, "turn rate {rate}");
        assert!(
            sim.ground_truth().distance(&p0) < 0.02,
            "{:?}",
            sim.ground_truth()
        );
    }

    #[test]
    fn radius_error_curves_the_odometry_but_not_the_robot() {
        let world = fixtures::box_room(20.0, 20.0, "concrete");
        let e = 0.02;
        let config = SimConfig {
            start: Pose2::new(-6.0, 0.0, 0.0),
            odometry: OdometrySpec {
                radius_error: e,
                ..exact_odometry()
            },
            ..Default::default()
        };
        let mut sim = sim_in(&world, config);
        ramp(&mut sim, 0.5, 0.0);
        run(&mut sim, 5.0);
        assert!(
            sim.ground_truth().theta.abs() < 0.01,
            "{:?}",
            sim.ground_truth()
        );
        // Believed left radius r(1 + e/2), right r(1 − e/2): the odometry turns right by
        // (φr·r(1 − e/2) − φl·r(1 + e/2)) / b.
        let (fl, fr) = sim.wheel_rotations();
        let (r, b) = (0.0975, 0.33);
        let predicted = (fr * r * (1.0 - 0.5 * e) - fl * r * (1.0 + 0.5 * e)) / b;
        let odo = sim.odometry_pose();
        assert!(predicted < -0.1, "{predicted}");
        // One tick on one wheel is 2π/500 · r / b = 0.0037 rad.
        assert!(
            (odo.theta - predicted).abs() < 0.008,
            "odometry {odo:?}, predicted θ {predicted}"
        );
        assert!(
            odo.y < -0.1,
            "the odometry track should visibly curve right: {odo:?}"
        );
    }

    /// Distance from (ox, oy) along angle a to the inner faces of a box room.
    fn room_range(ox: f64, oy: f64, a: f64, hx: f64, hy: f64) -> f64 {
        let (c, s) = (a.cos(), a.sin());
        let hit = |h: f64, o: f64, d: f64| {
            if d.abs() < 1e-12 {
                f64::INFINITY
            } else {
                (h.copysign(d) - o) / d
            }
        };
        let (tx, ty) = (hit(hx, ox, c), hit(hy, oy, s));
        tx.min(ty)
    }

    #[test]
    fn laser_in_a_box_room_reads_the_known_distances() {
        let world = fixtures::box_room(6.0, 4.0, "concrete");
        let mut spec = noiseless(sick("front"));
        spec.sigma_hit = 0.01;
        let config = SimConfig {
            lasers: vec![spec],
            ..Default::default()
        };
        let mut sim = sim_in(&world, config);
        let pose = Pose2::new(0.5, -0.3, 0.4);
        let scan = sim.scan_at(pose, 0).unwrap();
        assert_eq!(scan.ranges.len(), 181);
        assert_eq!(scan.sensor, "front");
        assert!((scan.mount.x - 0.16).abs() < 1e-12 && scan.mount.y == 0.0);
        let o = pose.transform_point([0.16, 0.0]);
        let truth = sim.last_true_ranges(0).unwrap().to_vec();
        let (mut within, mut sq) = (0, 0.0);
        for (i, (&z, &t)) in scan.ranges.iter().zip(&truth).enumerate() {
            let expected = room_range(o[0], o[1], pose.theta + scan.beam_angle(i), 2.9, 1.9);
            assert!(
                (t - expected).abs() < 1e-4,
                "beam {i}: cast {t}, expected {expected}"
            );
            let err = z - expected;
            assert!(err.abs() < 5.0 * 0.01, "beam {i}: {z} vs {expected}");
            if err.abs() < 3.0 * 0.01 {
                within += 1;
            }
            sq += err * err;
        }
        assert!(within >= 178, "{within} of 181 beams within 3σ");
        let sd = (sq / 181.0).sqrt();
        assert!((sd - 0.01).abs() < 0.002, "noise σ {sd}");
    }

    #[test]
    fn glass_reflects_near_normal_incidence_and_is_transparent_at_30_degrees() {
        let mut world = fixtures::box_room(12.0, 12.0, "concrete");
        world
            .walls
            .push(fixtures::wall([2.0, -3.0], [2.0, 3.0], "glass"));
        world
            .walls
            .push(fixtures::wall([4.0, -5.0], [4.0, 5.0], "concrete"));
        let mut wide = noiseless(sick("wide"));
        (wide.beams, wide.fov) = (3, 60f64.to_radians());
        let mut narrow = noiseless(sick("narrow"));
        (narrow.beams, narrow.fov) = (3, 16f64.to_radians());
        let config = SimConfig {
            lasers: vec![wide, narrow],
            ..Default::default()
        };
        let mut sim = sim_in(&world, config);
        // Base 0.16 m behind the origin: the laser sits at the origin looking along +x.
        let pose = Pose2::new(-0.16, 0.0, 0.0);
        let wide = sim.scan_at(pose, 0).unwrap();
        let at30 = 3.9 / 30f64.to_radians().cos();
        for (got, want) in wide.ranges.iter().zip([at30, 1.9, at30]) {
            assert!((got - want).abs() < 1e-4, "{:?}", wide.ranges);
        }
        // 8° is within the glass's 10° reflection cone.
        let narrow = sim.scan_at(pose, 1).unwrap();
        let at8 = 1.9 / 8f64.to_radians().cos();
        for (got, want) in narrow.ranges.iter().zip([at8, 1.9, at8]) {
            assert!((got - want).abs() < 1e-4, "{:?}", narrow.ranges);
        }
    }

    #[test]
    fn the_robot_never_sees_itself_and_rays_work_before_the_first_step() {
        // A laser mounted inside the chassis box (z = 0.15) still reads the room.
        let world = fixtures::box_room(6.0, 6.0, "concrete");
        let mut model = fixtures::pioneer_3dx_like();
        model.mounts.push(atrium_robots::LinkMount {
            name: "inside".into(),
            pose: nalgebra::Isometry3::translation(0.0, 0.0, 0.15),
        });
        let spec = noiseless(LaserSpec::sick_lms200("inner", "inside"));
        let config = SimConfig {
            lasers: vec![spec],
            ..Default::default()
        };
        let mut sim = Simulation::new(&world, &model, config).unwrap();
        let scan = sim.scan_at(Pose2::default(), 0).unwrap();
        for (i, z) in scan.ranges.iter().enumerate() {
            let expected = room_range(0.0, 0.0, scan.beam_angle(i), 2.9, 2.9);
            assert!((z - expected).abs() < 1e-4, "beam {i}: {z} vs {expected}");
        }
    }

    #[test]
    fn spawning_inside_a_wall_or_pillar_is_an_error_naming_it() {
        let mut world = fixtures::box_room(6.0, 6.0, "concrete");
        world.pillars.push(atrium_worlds::Pillar {
            center: [-1.0, -1.0],
            radius: 0.2,
            height: 2.0,
            material: "glass".into(),
        });
        let model = fixtures::pioneer_3dx_like();
        let at = |x, y, theta| SimConfig {
            start: Pose2::new(x, y, theta),
            ..Default::default()
        };
        match Simulation::new(&world, &model, at(2.8, 0.0, 0.0)) {
            Err(SimError::Spawn {
                obstacle,
                material,
                pose,
            }) => {
                assert_eq!(
                    (obstacle.as_str(), material.as_str()),
                    ("walls[1]", "concrete")
                );
                assert_eq!(pose, Pose2::new(2.8, 0.0, 0.0));
            }
            other => panic!("expected a spawn error, got {:?}", other.err()),
        }
        let e = Simulation::new(&world, &model, at(-1.0, -0.7, 0.0))
            .err()
            .unwrap();
        assert!(
            e.to_string().contains("pillars[0]") && e.to_string().contains("glass"),
            "{e}"
        );
        // Clear of everything: the front of the chassis is at x = 2.5 + 0.1825 < 2.9.
        assert!(Simulation::new(&world, &model, at(2.5, 0.0, 0.0)).is_ok());
    }

    #[test]
    fn teleport_moves_the_robot_and_odometry_does_not_know() {
        let world = fixtures::box_room(8.0, 8.0, "concrete");
        let mut sim = sim_in(&world, SimConfig::default());
        sim.set_route(&[[2.0, 0.0]]);
        run(&mut sim, 2.0);
        let odo = sim.odometry_pose();
        assert!(odo.x > 0.3, "{odo:?}");
        let e = sim.teleport(Pose2::new(-4.0, 0.0, 0.0)).unwrap_err();
        assert!(matches!(e, SimError::Spawn { .. }), "{e}");
        let target = Pose2::new(-2.0, 1.0, 1.0);
        sim.teleport(target).unwrap();
        assert!(sim.ground_truth().distance(&target) < 1e-5);
        assert_eq!(sim.odometry_pose(), odo);
        // The robot drives on from where it was put (toward the same waypoint), and the
        // encoders did not jump: one step moves the odometry by at most a few mm.
        let mut out = Vec::new();
        sim.step(&mut out);
        assert!(sim.odometry_pose().distance(&odo) < 0.005);
        assert!(
            sim.ground_truth().distance(&target) < 0.005,
            "{:?}",
            sim.ground_truth()
        );
    }

    #[test]
    fn same_seed_gives_bit_identical_runs() {
        let world = fixtures::hundred_walls();
        let config = |seed| SimConfig {
            start: Pose2::new(-10.0, 0.0, 0.0),
            lasers: vec![sick("front")],
            seed,
            ..Default::default()
        };
        let go = |seed| {
            let mut sim = sim_in(&world, config(seed));
            sim.set_route(&[[-8.0, 0.0], [-8.0, 0.5]]);
            let mut out = Vec::new();
            let mut truth = Vec::new();
            for _ in 0..600 {
                truth.push(sim.step(&mut out));
            }
            (out, truth)
        };
        let (a, ta) = go(7);
        let (b, tb) = go(7);
        assert_eq!(a, b);
        assert_eq!(ta, tb);
        assert_eq!(a.len(), 150 + 30);
        let (c, tc) = go(8);
        assert_eq!(ta, tc, "the seed only drives sensor noise");
        assert_ne!(a, c);
    }

    #[test]
    fn readings_follow_their_schedules() {
        let world = fixtures::box_room(6.0, 6.0, "concrete");
        let mut slow = sick("slow");
        slow.rate_hz = 3.0;
        let config = SimConfig {
            lasers: vec![sick("front"), slow],
            ..Default::default()
        };
        let mut sim = sim_in(&world, config);
        let (out, _) = run(&mut sim, 1.0);
        let odo: Vec<f64> = out
            .iter()
            .filter_map(|r| match r {
                Reading::Odometry(o) => Some(o.stamp),
                _ => None,
            })
            .collect();
        assert_eq!(odo.len(), 50);
        for (k, t) in odo.iter().enumerate() {
            assert!((t - 0.02 * (k + 1) as f64).abs() < 1e-12, "{t}");
        }
        let stamps = |name: &str| -> Vec<f64> {
            out.iter()
                .filter_map(|r| match r {
                    Reading::Laser(l) if l.sensor == name => Some(l.stamp),
                    _ => None,
                })
                .collect()
        };
        assert_eq!(stamps("front").len(), 10);
        // 3 Hz at 200 Hz: steps round(66.67) = 67, 133, 200.
        assert_eq!(stamps("slow"), vec![0.335, 0.665, 1.0]);
        // The stream is time-ordered.
        assert!(out.windows(2).all(|w| w[0].stamp() <= w[1].stamp()));
    }

    #[test]
    fn follower_drives_a_square_through_every_corner() {
        let world = fixtures::box_room(8.0, 8.0, "concrete");
        let mut sim = sim_in(&world, SimConfig::default());
        let route = [[2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [0.0, 0.0]];
        sim.set_route(&route);
        let mut closest = [f64::MAX; 4];
        let mut out = Vec::new();
        while !sim.route_finished() && sim.time() < 60.0 {
            let p = sim.step(&mut out);
            for (c, w) in closest.iter_mut().zip(&route) {
                *c = c.min((p.x - w[0]).hypot(p.y - w[1]));
            }
        }
        assert!(
            sim.route_finished(),
            "not done after {} s: {:?}",
            sim.time(),
            sim.ground_truth()
        );
        for c in closest {
            assert!(c < 0.1, "corners missed: {closest:?}");
        }
    }

    #[test]
    fn bad_configs_name_the_field() {
        let world = fixtures::box_room(6.0, 6.0, "concrete");
        let model = fixtures::pioneer_3dx_like();
        let err = |config: SimConfig| {
            Simulation::new(&world, &model, config)
                .err()
                .unwrap()
                .to_string()
        };
        let e = err(SimConfig {
            lasers: vec![LaserSpec::sick_lms200("front", "lidar_link")],
            ..Default::default()
        });
        assert!(
            e.contains("lasers[0].mount") && e.contains("lidar_link"),
            "{e}"
        );
        let e = err(SimConfig {
            physics_hz: 0.0,
            ..Default::default()
        });
        assert!(e.contains("physics_hz"), "{e}");
        let e = err(SimConfig {
            odometry: OdometrySpec {
                rate_hz: 500.0,
                ..Default::default()
            },
            ..Default::default()
        });
        assert!(
            e.contains("odometry.rate_hz") && e.contains("exceeds"),
            "{e}"
        );
        let mut spec = sick("front");
        spec.p_short = 0.7;
        spec.p_rand = 0.7;
        let e = err(SimConfig {
            lasers: vec![spec],
            ..Default::default()
        });
        assert!(e.contains("lasers[0].p_short"), "{e}");
        let mut sim = Simulation::new(&world, &model, SimConfig::default()).unwrap();
        assert!(sim.scan_at(Pose2::default(), 0).is_err());
        assert!(sim.set_wheel_speeds(f64::NAN, 0.0).is_err());
    }
}
