//! The node controller of [002] (Table I, §III-C and
//! Algorithm 1): for every node, turnTo (turn in place until the heading lies within γ_θ of
//! the bearing to the node), moveTo (drive until Table I's δ_d test holds within γ_d), update
//! (set the odometry coordinates to the node's, go to the next node).
//!
//! Unlike the waypoint follower, it drives on the robot's own odometry coordinates, as the
//! paper's robot does: it integrates the wheel odometry it is fed and corrects it only at
//! nodes. A landmark filter may verify a node early (Algorithm 1 lines 12–15: stop, set the
//! pose to the node) through [`NodeController::verify`]. Pure kinematics, no physics.

use crate::controller::ControllerParams;
use crate::error::SimError;
use atrium_robots::node_route::{turn_done, turn_to, Leg};
use atrium_robots::{normalize_angle, DiffDrive, Pose2};
use serde::{Deserialize, Serialize};

/// The thresholds of Table I.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NodeControllerParams {
    /// γ_θ, rad: turnTo ends once the heading is this close to the bearing of the node.
    pub gamma_theta: f64,
    /// γ_d, m: moveTo ends once the node is this close (Table I's δ_d interval).
    pub gamma_d: f64,
}

impl Default for NodeControllerParams {
    fn default() -> Self {
        Self {
            gamma_theta: 2f64.to_radians(),
            gamma_d: 0.05,
        }
    }
}

impl NodeControllerParams {
    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.gamma_theta.is_finite()
            && self.gamma_theta > 0.0
            && self.gamma_theta < std::f64::consts::FRAC_PI_2)
        {
            return Err(SimError::config(
                "route.gamma_theta",
                format!(
                    "must lie in (0, π/2) rad, got {} (a wider tolerance would let the robot \
                     drive off sideways)",
                    self.gamma_theta
                ),
            ));
        }
        crate::error::positive("route.gamma_d", self.gamma_d)?;
        Ok(())
    }
}

/// What happened at a node: the controller's update() ran, either because a landmark filter
/// verified the node or because odometry reached it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NodeArrival {
    /// Index into the node list.
    pub node: usize,
    /// Sim time, s (stamped by the simulation).
    pub stamp: f64,
    /// True when a landmark filter verified it (Algorithm 1), false when odometry alone
    /// reached it (Table I's moveTo).
    pub verified: bool,
    /// The controller's odometry pose just before update() reset it to the node.
    pub odometry_before: Pose2,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    Turn,
    Move,
    Done,
}

/// Proportional heading gain while turning and moving, 1/s.
const HEADING_GAIN: f64 = 2.0;

/// Drives a node list as in Algorithm 1; call [`NodeController::update`] once per control step
/// and [`NodeController::odometry`] with every new odometry pose.
#[derive(Debug, Clone)]
pub struct NodeController {
    limits: ControllerParams,
    params: NodeControllerParams,
    drive: DiffDrive,
    nodes: Vec<[f64; 2]>,
    next: usize,
    phase: Phase,
    leg: Leg,
    /// The robot's odometry coordinates, corrected at nodes (the pose Table I works on).
    pose: Pose2,
    last_odometry: Option<Pose2>,
    v: f64,
    omega: f64,
    arrivals: Vec<NodeArrival>,
}

impl NodeController {
    /// `start` is where the robot's odometry coordinates begin (the scenario's start pose);
    /// `drive` is the robot's TRUE geometry, so the wheel speeds produce the body velocity
    /// asked for.
    pub fn new(
        limits: ControllerParams,
        params: NodeControllerParams,
        drive: DiffDrive,
        nodes: &[[f64; 2]],
        start: Pose2,
    ) -> Result<Self, SimError> {
        limits.validate()?;
        params.validate()?;
        crate::error::positive("robot wheel_radius", drive.wheel_radius)?;
        crate::error::positive("robot wheel_separation", drive.wheel_separation)?;
        if nodes.is_empty() {
            return Err(SimError::config(
                "route.nodes",
                "the node list is empty: name at least one node",
            ));
        }
        for (i, n) in nodes.iter().enumerate() {
            if !(n[0].is_finite() && n[1].is_finite()) {
                return Err(SimError::config(
                    format!("route.nodes[{i}]"),
                    format!("must be finite, got {n:?}"),
                ));
            }
        }
        if !start.is_finite() {
            return Err(SimError::config(
                "start",
                format!("must be finite, got {start:?}"),
            ));
        }
        Ok(Self {
            limits,
            params,
            drive,
            nodes: nodes.to_vec(),
            next: 0,
            phase: Phase::Turn,
            leg: Leg {
                from: [start.x, start.y],
                node: nodes[0],
            },
            pose: start,
            last_odometry: None,
            v: 0.0,
            omega: 0.0,
            arrivals: Vec::new(),
        })
    }

    pub fn params(&self) -> &NodeControllerParams {
        &self.params
    }

    pub fn nodes(&self) -> &[[f64; 2]] {
        &self.nodes
    }

    /// Index of the node being approached (the node count when finished).
    pub fn next_node(&self) -> usize {
        self.next
    }

    pub fn finished(&self) -> bool {
        self.phase == Phase::Done
    }

    /// True while turning toward the next node (turnTo), false while moving or done.
    pub fn turning(&self) -> bool {
        self.phase == Phase::Turn
    }

    /// The odometry coordinates the controller drives on.
    pub fn pose(&self) -> Pose2 {
        self.pose
    }

    /// Every update() so far, in order.
    pub fn arrivals(&self) -> &[NodeArrival] {
        &self.arrivals
    }

    /// The current rate-limited body velocity command (v m/s, ω rad/s).
    pub fn command(&self) -> (f64, f64) {
        (self.v, self.omega)
    }

    /// Feeds a new wheel-odometry pose (in the odometry's own frame, which may start anywhere):
    /// the increment since the previous one moves the controller's pose. Checks moveTo
    /// afterwards, so `stamp` is that of the odometry.
    pub fn odometry(&mut self, odom: Pose2, stamp: f64) {
        if let Some(last) = self.last_odometry {
            self.pose = self.pose.compose(&last.between(&odom));
        }
        self.last_odometry = Some(odom);
        if self.phase == Phase::Move && self.leg.reached(&self.pose, self.params.gamma_d) {
            self.arrive(false, stamp);
        }
    }

    /// Algorithm 1 lines 12–15: a landmark filter verified node `node`. Applied (stop, pose
    /// to the node, next node) only when `node` is the one being approached and the robot is
    /// moving toward it; returns whether it was. `pose`, when given, is the filter's pose
    /// after its reset (the node corrected by the measured offset, heading included): the
    /// controller then steers on it; `None` is Table I's update() (x, y = x_n, y_n).
    pub fn verify(&mut self, node: usize, stamp: f64, pose: Option<Pose2>) -> bool {
        if node != self.next || self.phase != Phase::Move {
            return false;
        }
        self.arrive(true, stamp);
        if let Some(p) = pose.filter(Pose2::is_finite) {
            self.pose = p;
        }
        true
    }

    /// Table I update(): x = x_n, y = y_n; n = n + 1.
    fn arrive(&mut self, verified: bool, stamp: f64) {
        let node = self.nodes[self.next];
        self.arrivals.push(NodeArrival {
            node: self.next,
            stamp,
            verified,
            odometry_before: self.pose,
        });
        self.pose.x = node[0];
        self.pose.y = node[1];
        self.next += 1;
        match self.nodes.get(self.next) {
            Some(&n) => {
                self.leg = Leg {
                    from: node,
                    node: n,
                };
                self.phase = Phase::Turn;
            }
            None => self.phase = Phase::Done,
        }
    }

    /// One control step of length `dt`: returns the wheel angular speeds (left, right), rad/s.
    pub fn update(&mut self, dt: f64) -> (f64, f64) {
        let p = self.limits;
        let (v_des, w_des) = match self.phase {
            Phase::Done => (0.0, 0.0),
            // Algorithm 1: stop() at the node, then turn; a turn begun while still rolling
            // would swing the chair through an arc.
            Phase::Turn if self.v.abs() > 0.01 => (0.0, 0.0),
            Phase::Turn => {
                let target = turn_to(&self.pose, self.leg.node);
                // Stop turning only once the turn rate has been braked too: the test of
                // Table I on the heading, with the robot nearly still.
                if turn_done(self.pose.theta, target, self.params.gamma_theta)
                    && self.omega.abs() < 0.05
                    && self.v.abs() < 0.05
                {
                    self.phase = Phase::Move;
                    (0.0, 0.0)
                } else {
                    let err = normalize_angle(target - self.pose.theta);
                    (0.0, self.turn_rate(err))
                }
            }
            Phase::Move => {
                let target = turn_to(&self.pose, self.leg.node);
                let err = normalize_angle(target - self.pose.theta);
                let d_c = self.leg.current(&self.pose);
                // Brake to stop at the node: the speed that still stops within d_c.
                let v = p
                    .max_speed
                    .min((2.0 * p.max_accel * (d_c - 0.5 * self.params.gamma_d).max(0.0)).sqrt())
                    * err.cos().max(0.0);
                // Steering holds the bearing to the node; close to it the bearing swings,
                // so steering stops within half a metre.
                let w = if d_c > 0.5 { self.turn_rate(err) } else { 0.0 };
                (v, w)
            }
        };
        let dv = p.max_accel * dt;
        let dw = p.max_turn_accel * dt;
        self.v += (v_des - self.v).clamp(-dv, dv);
        self.omega += (w_des - self.omega).clamp(-dw, dw);
        self.drive.wheel_speeds(self.v, self.omega)
    }

    /// Heading rate toward an error: proportional, bounded by what max_turn_accel can still
    /// brake and by max_turn_rate.
    fn turn_rate(&self, err: f64) -> f64 {
        let p = self.limits;
        (HEADING_GAIN * err.abs())
            .min((2.0 * p.max_turn_accel * err.abs()).sqrt())
            .min(p.max_turn_rate)
            .copysign(err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drive() -> DiffDrive {
        DiffDrive {
            wheel_radius: 0.165,
            wheel_separation: 0.56,
        }
    }

    /// Integrates the commands as a perfect unicycle whose odometry is exact (the controller's
    /// pose then equals the true pose up to the node updates).
    fn run(c: &mut NodeController, start: Pose2, steps: usize) -> Pose2 {
        let dt = 0.005;
        let d = drive();
        let mut pose = start;
        for i in 0..steps {
            let (l, r) = c.update(dt);
            let (v, w) = d.body_velocity(l, r);
            let sep = d.wheel_separation;
            pose = DiffDrive::integrate(
                &pose,
                (v - 0.5 * w * sep) * dt,
                (v + 0.5 * w * sep) * dt,
                sep,
            );
            c.odometry(pose, i as f64 * dt);
            if c.finished() && c.command().0.abs() < 1e-9 && c.command().1.abs() < 1e-9 {
                break;
            }
        }
        pose
    }

    #[test]
    fn drives_a_square_of_nodes_and_updates_at_each() {
        let nodes = [[3.0, 0.0], [3.0, 3.0], [0.0, 3.0], [0.0, 0.0]];
        let mut c = NodeController::new(
            ControllerParams::default(),
            NodeControllerParams::default(),
            drive(),
            &nodes,
            Pose2::default(),
        )
        .unwrap();
        let end = run(&mut c, Pose2::default(), 200_000);
        assert!(c.finished());
        assert_eq!(c.arrivals().len(), 4);
        for (i, a) in c.arrivals().iter().enumerate() {
            assert_eq!(a.node, i);
            assert!(!a.verified);
            let n = nodes[i];
            let d = (a.odometry_before.x - n[0]).hypot(a.odometry_before.y - n[1]);
            assert!(d <= 0.05 + 1e-9, "node {i}: arrived {d} m away");
        }
        // The robot brakes to a stop at the last node.
        assert!(end.distance(&Pose2::new(0.0, 0.0, 0.0)) < 0.1, "{end:?}");
    }

    #[test]
    fn turn_ends_within_gamma_theta_before_moving() {
        let params = NodeControllerParams {
            gamma_theta: 0.02,
            gamma_d: 0.05,
        };
        let mut c = NodeController::new(
            ControllerParams::default(),
            params,
            drive(),
            &[[0.0, 4.0]],
            Pose2::default(),
        )
        .unwrap();
        let dt = 0.005;
        let d = drive();
        let mut pose = Pose2::default();
        let mut moved_at = None;
        for i in 0..4000 {
            let (l, r) = c.update(dt);
            let (v, w) = d.body_velocity(l, r);
            if moved_at.is_none() && !c.turning() {
                moved_at = Some(pose);
            }
            pose = DiffDrive::integrate(&pose, (v - 0.28 * w) * dt, (v + 0.28 * w) * dt, 0.56);
            c.odometry(pose, i as f64 * dt);
        }
        let at = moved_at.expect("the turn ended");
        let err = normalize_angle(at.theta - std::f64::consts::FRAC_PI_2).abs();
        assert!(err <= 0.02, "moveTo began {err} rad off the bearing");
        assert!(c.finished());
    }

    #[test]
    fn verification_stops_the_leg_and_resets_the_pose_to_the_node() {
        let mut c = NodeController::new(
            ControllerParams::default(),
            NodeControllerParams::default(),
            drive(),
            &[[5.0, 0.0], [5.0, 5.0]],
            Pose2::default(),
        )
        .unwrap();
        // Not while turning, not for another node.
        assert!(!c.verify(0, 0.0, None));
        let dt = 0.005;
        let mut pose = Pose2::default();
        let d = drive();
        while pose.x < 4.7 {
            let (l, r) = c.update(dt);
            let (v, w) = d.body_velocity(l, r);
            pose = DiffDrive::integrate(&pose, (v - 0.28 * w) * dt, (v + 0.28 * w) * dt, 0.56);
            c.odometry(pose, 0.0);
        }
        assert_eq!(c.next_node(), 0);
        assert!(!c.verify(1, 1.0, None));
        assert!(c.verify(0, 1.0, None));
        assert_eq!(c.next_node(), 1);
        assert!(c.turning());
        let a = c.arrivals()[0];
        assert!(a.verified && (a.odometry_before.x - pose.x).abs() < 1e-9);
        assert_eq!((c.pose().x, c.pose().y), (5.0, 0.0));
        // The heading is kept (Table I resets x and y only).
        assert!((c.pose().theta - pose.theta).abs() < 1e-12);
        // Node 1 verified with the filter's corrected pose: the controller takes all of it.
        while c.turning() {
            let (l, r) = c.update(dt);
            let (v, w) = d.body_velocity(l, r);
            pose = DiffDrive::integrate(&pose, (v - 0.28 * w) * dt, (v + 0.28 * w) * dt, 0.56);
            c.odometry(pose, 0.0);
        }
        let corrected = Pose2::new(5.1, 4.9, 1.5);
        assert!(c.verify(1, 2.0, Some(corrected)));
        assert_eq!(c.pose(), corrected);
        assert!(c.finished());
    }

    #[test]
    fn bad_input_is_rejected_with_the_field() {
        let e = |nodes: &[[f64; 2]], params: NodeControllerParams| {
            NodeController::new(
                ControllerParams::default(),
                params,
                drive(),
                nodes,
                Pose2::default(),
            )
            .unwrap_err()
            .to_string()
        };
        let p = NodeControllerParams::default();
        assert!(e(&[], p).contains("route.nodes"));
        assert!(e(&[[f64::NAN, 0.0]], p).contains("route.nodes[0]"));
        let bad = NodeControllerParams { gamma_d: 0.0, ..p };
        assert!(e(&[[1.0, 0.0]], bad).contains("route.gamma_d"));
        let bad = NodeControllerParams {
            gamma_theta: 2.0,
            ..p
        };
        assert!(e(&[[1.0, 0.0]], bad).contains("route.gamma_theta"));
    }
}
