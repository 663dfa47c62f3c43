//! Waypoint following for a differential drive: turn in place toward the next waypoint when
//! the heading error is large, otherwise drive with proportional heading correction; brake
//! to stop at the last waypoint (and at corners sharp enough to need a turn in place).
//! Pure kinematics, no physics: it maps a pose to wheel speeds.

use crate::error::SimError;
use atrium_robots::{normalize_angle, DiffDrive, Pose2};
use serde::{Deserialize, Serialize};

/// Limits and tolerances of the waypoint follower (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ControllerParams {
    /// m/s
    pub max_speed: f64,
    /// m/s²
    pub max_accel: f64,
    /// rad/s
    pub max_turn_rate: f64,
    /// rad/s²
    pub max_turn_accel: f64,
    /// A waypoint counts as reached within this distance, m.
    pub goal_tolerance: f64,
    /// Heading errors above this (rad) make the robot stop and turn in place.
    pub turn_in_place_above: f64,
}

impl Default for ControllerParams {
    fn default() -> Self {
        Self {
            max_speed: 0.5,
            max_accel: 0.5,
            max_turn_rate: 1.0,
            max_turn_accel: 2.0,
            goal_tolerance: 0.1,
            turn_in_place_above: 0.5,
        }
    }
}

impl ControllerParams {
    /// Every field finite and > 0; `turn_in_place_above` at most π.
    pub fn validate(&self) -> Result<(), SimError> {
        let fields = [
            ("controller.max_speed", self.max_speed),
            ("controller.max_accel", self.max_accel),
            ("controller.max_turn_rate", self.max_turn_rate),
            ("controller.max_turn_accel", self.max_turn_accel),
            ("controller.goal_tolerance", self.goal_tolerance),
            ("controller.turn_in_place_above", self.turn_in_place_above),
        ];
        for (name, v) in fields {
            crate::error::positive(name, v)?;
        }
        if self.turn_in_place_above > std::f64::consts::PI {
            return Err(SimError::config(
                "controller.turn_in_place_above",
                format!("must be at most π rad, got {}", self.turn_in_place_above),
            ));
        }
        Ok(())
    }
}

/// Proportional heading gain, 1/s: a 0.1 rad error asks for 0.2 rad/s.
const HEADING_GAIN: f64 = 2.0;
/// A turn in place ends once the heading error is below this fraction of the threshold
/// that started it (hysteresis, so the robot does not start driving while still swinging).
const TURN_EXIT_FRACTION: f64 = 0.1;

/// Follows a list of waypoints; call [`WaypointFollower::update`] once per control step.
#[derive(Debug, Clone)]
pub struct WaypointFollower {
    params: ControllerParams,
    drive: DiffDrive,
    waypoints: Vec<[f64; 2]>,
    /// Speed limit of the leg that ends at each waypoint, m/s (below `max_speed`); empty when
    /// every leg may be driven at `max_speed`.
    leg_speeds: Vec<f64>,
    next: usize,
    turning: bool,
    /// Current (rate-limited) body velocity command.
    v: f64,
    omega: f64,
    /// Something is in the way ahead ([`LookAhead`]): brake to a stop, turning in place is
    /// still allowed.
    blocked: bool,
}

/// Gap kept between the robot's front and a person ahead once stopped, m.
pub const PERSON_STOP_GAP: f64 = 0.5;
/// Extra width on each side of the driving corridor, m.
pub const CORRIDOR_SIDE_MARGIN: f64 = 0.1;

/// The robot's driving corridor ahead: as wide as its footprint plus a margin each side, as
/// long as its braking distance plus [`PERSON_STOP_GAP`] beyond its front.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LookAhead {
    /// Front of the footprint ahead of the base origin, m.
    pub front: f64,
    /// Half the footprint's width, m.
    pub half_width: f64,
}

impl LookAhead {
    /// Whether a disc of `radius` at one of `centres` (world frame) lies in the corridor ahead
    /// of a robot at `pose` driving at `v` m/s that brakes at `max_accel`.
    pub fn blocked(
        &self,
        pose: &Pose2,
        v: f64,
        max_accel: f64,
        centres: &[[f64; 2]],
        radius: f64,
    ) -> bool {
        let reach = self.front + PERSON_STOP_GAP + radius + v.max(0.0).powi(2) / (2.0 * max_accel);
        let half = self.half_width + CORRIDOR_SIDE_MARGIN + radius;
        let (s, c) = pose.theta.sin_cos();
        centres.iter().any(|p| {
            let (dx, dy) = (p[0] - pose.x, p[1] - pose.y);
            let (x, y) = (c * dx + s * dy, -s * dx + c * dy);
            x > 0.0 && x < reach && y.abs() < half
        })
    }
}

impl WaypointFollower {
    /// `drive` is the robot's TRUE geometry: wheel speeds must produce the body velocity
    /// the controller wants, whatever the odometry believes.
    pub fn new(params: ControllerParams, drive: DiffDrive) -> Result<Self, SimError> {
        params.validate()?;
        crate::error::positive("robot wheel_radius", drive.wheel_radius)?;
        crate::error::positive("robot wheel_separation", drive.wheel_separation)?;
        Ok(Self {
            params,
            drive,
            waypoints: Vec::new(),
            leg_speeds: Vec::new(),
            next: 0,
            turning: false,
            v: 0.0,
            omega: 0.0,
            blocked: false,
        })
    }

    pub fn params(&self) -> &ControllerParams {
        &self.params
    }

    /// Replaces the route; the robot heads for the first waypoint next. An empty route
    /// means "stop".
    pub fn set_route(&mut self, waypoints: &[[f64; 2]]) {
        self.waypoints.clear();
        self.waypoints.extend_from_slice(waypoints);
        self.leg_speeds.clear();
        self.next = 0;
        self.turning = false;
    }

    /// Limits the speed of each leg of the route set last: `speeds[i]` (m/s) on the leg that
    /// ends at waypoint `i`, `max_speed` still the cap. A twin drives its reference this way
    /// at the speeds it was recorded at. Every speed must be finite and > 0, one per waypoint.
    pub fn set_leg_speeds(&mut self, speeds: &[f64]) -> Result<(), SimError> {
        if speeds.len() != self.waypoints.len() {
            return Err(SimError::config(
                "route.speeds",
                format!(
                    "has {} speeds for {} waypoints: give one per waypoint",
                    speeds.len(),
                    self.waypoints.len()
                ),
            ));
        }
        for (i, &v) in speeds.iter().enumerate() {
            crate::error::positive(&format!("route.speeds[{i}]"), v)?;
        }
        self.leg_speeds.clear();
        self.leg_speeds.extend_from_slice(speeds);
        Ok(())
    }

    /// Speed limit on the leg ending at waypoint `i`, m/s.
    fn leg_speed(&self, i: usize) -> f64 {
        match self.leg_speeds.get(i) {
            Some(&v) => v.min(self.params.max_speed),
            None => self.params.max_speed,
        }
    }

    pub fn finished(&self) -> bool {
        self.next >= self.waypoints.len()
    }

    /// Index of the waypoint being approached (equals the route length when finished).
    pub fn next_waypoint(&self) -> usize {
        self.next
    }

    /// The current rate-limited body velocity command (v m/s, ω rad/s).
    pub fn command(&self) -> (f64, f64) {
        (self.v, self.omega)
    }

    /// Holds the robot (brakes to a stop, still turns in place) while `blocked`; see
    /// [`LookAhead`].
    pub fn set_blocked(&mut self, blocked: bool) {
        self.blocked = blocked;
    }

    pub fn blocked(&self) -> bool {
        self.blocked
    }

    /// Forgets the current velocity (after the robot was picked up and put down).
    pub fn halt(&mut self) {
        self.v = 0.0;
        self.omega = 0.0;
        self.turning = false;
    }

    /// Speed at which the robot may pass waypoint `i`: zero at the last one and where the
    /// next leg turns by more than the turn-in-place threshold, else scaled down with the turn.
    fn pass_speed(&self, i: usize) -> f64 {
        if i + 1 >= self.waypoints.len() {
            return 0.0;
        }
        let a = self.waypoints[i];
        let b = self.waypoints[i + 1];
        let prev = if i == 0 {
            return 0.0; // the approach direction is unknown: be safe
        } else {
            self.waypoints[i - 1]
        };
        let h_in = (a[1] - prev[1]).atan2(a[0] - prev[0]);
        let h_out = (b[1] - a[1]).atan2(b[0] - a[0]);
        let turn = normalize_angle(h_out - h_in).abs();
        if turn >= self.params.turn_in_place_above {
            0.0
        } else {
            // No faster than either leg allows: the next one may be a slower stretch.
            self.leg_speed(i).min(self.leg_speed(i + 1))
                * (1.0 - turn / self.params.turn_in_place_above)
        }
    }

    /// Target speed magnitude that still allows braking to `v_end` within `dist` at max_accel.
    fn braking_speed(&self, dist: f64, v_end: f64) -> f64 {
        (v_end * v_end + 2.0 * self.params.max_accel * dist.max(0.0)).sqrt()
    }

    /// One control step of length `dt` from the (true) pose: returns the wheel angular
    /// speeds (left, right), rad/s, forward positive.
    pub fn update(&mut self, pose: &Pose2, dt: f64) -> (f64, f64) {
        let p = self.params;
        while !self.finished() {
            let w = self.waypoints[self.next];
            if (w[0] - pose.x).hypot(w[1] - pose.y) < p.goal_tolerance {
                self.next += 1;
                self.turning = false;
            } else {
                break;
            }
        }
        let (v_des, w_des) = if self.finished() {
            (0.0, 0.0)
        } else {
            let w = self.waypoints[self.next];
            let (dx, dy) = (w[0] - pose.x, w[1] - pose.y);
            let dist = dx.hypot(dy);
            let err = normalize_angle(dy.atan2(dx) - pose.theta);
            if err.abs() > p.turn_in_place_above {
                self.turning = true;
            } else if self.turning && err.abs() < TURN_EXIT_FRACTION * p.turn_in_place_above {
                self.turning = false;
            }
            // Heading rate: proportional near the target, bounded by what can still be braked
            // at max_turn_accel, and by max_turn_rate.
            let w_mag = (HEADING_GAIN * err.abs())
                .min((2.0 * p.max_turn_accel * err.abs()).sqrt())
                .min(p.max_turn_rate);
            let w_des = w_mag.copysign(err);
            if self.turning || self.blocked {
                (0.0, w_des)
            } else {
                // Aim to stop (or slow to the pass speed) half a tolerance before the
                // waypoint, so braking ends inside the tolerance circle.
                let v_pass = self.pass_speed(self.next);
                let v = self
                    .leg_speed(self.next)
                    .min(self.braking_speed(dist - 0.5 * p.goal_tolerance, v_pass))
                    * err.cos().max(0.0);
                (v, w_des)
            }
        };
        let dv = p.max_accel * dt;
        let dw = p.max_turn_accel * dt;
        self.v += (v_des - self.v).clamp(-dv, dv);
        self.omega += (w_des - self.omega).clamp(-dw, dw);
        self.drive.wheel_speeds(self.v, self.omega)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn drive() -> DiffDrive {
        DiffDrive {
            wheel_radius: 0.1,
            wheel_separation: 0.4,
        }
    }

    /// Integrates the follower's own command as a perfect unicycle.
    fn run(
        f: &mut WaypointFollower,
        start: Pose2,
        dt: f64,
        steps: usize,
        mut each: impl FnMut(&Pose2, &WaypointFollower),
    ) -> Pose2 {
        let d = drive();
        let mut pose = start;
        for _ in 0..steps {
            let (l, r) = f.update(&pose, dt);
            let (v, w) = d.body_velocity(l, r);
            pose = DiffDrive::integrate(
                &pose,
                (v - 0.5 * w * 0.4) * dt,
                (v + 0.5 * w * 0.4) * dt,
                0.4,
            );
            each(&pose, f);
        }
        pose
    }

    #[test]
    fn each_leg_keeps_its_own_speed_limit() {
        let p = ControllerParams {
            max_speed: 1.0,
            ..Default::default()
        };
        let mut f = WaypointFollower::new(p, drive()).unwrap();
        f.set_route(&[[10.0, 0.0], [20.0, 0.0]]);
        f.set_leg_speeds(&[0.3, 0.8]).unwrap();
        let mut top = [0.0f64; 2];
        run(&mut f, Pose2::new(0.0, 0.0, 0.0), 0.05, 1200, |_, f| {
            let leg = f.next_waypoint().min(1);
            top[leg] = top[leg].max(f.command().0);
        });
        assert!((top[0] - 0.3).abs() < 1e-9, "{top:?}");
        assert!((top[1] - 0.8).abs() < 1e-9, "{top:?}");
        // One speed per waypoint, each finite and > 0.
        assert!(f.set_leg_speeds(&[0.3]).is_err());
        let err = f.set_leg_speeds(&[0.3, f64::NAN]).unwrap_err().to_string();
        assert!(err.contains("route.speeds[1]"), "{err}");
        // A new route drops the old limits.
        f.set_route(&[[1.0, 0.0]]);
        assert_eq!(f.leg_speed(0), 1.0);
    }

    #[test]
    fn defaults_match_the_brief_and_parse_from_toml() {
        let p = ControllerParams::default();
        assert_eq!((p.max_speed, p.max_accel, p.max_turn_rate), (0.5, 0.5, 1.0));
        assert_eq!(
            (p.max_turn_accel, p.goal_tolerance, p.turn_in_place_above),
            (2.0, 0.1, 0.5)
        );
        let q: ControllerParams = toml::from_str("max_speed = 0.3").unwrap();
        assert_eq!(q.max_speed, 0.3);
        assert_eq!(q.max_accel, 0.5);
        assert!(toml::from_str::<ControllerParams>("max_sped = 0.3").is_err());
    }

    #[test]
    fn validate_names_the_field() {
        let p = ControllerParams {
            max_turn_accel: f64::NAN,
            ..Default::default()
        };
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains("controller.max_turn_accel"), "{e}");
        let p = ControllerParams {
            goal_tolerance: -1.0,
            ..Default::default()
        };
        assert!(p
            .validate()
            .unwrap_err()
            .to_string()
            .contains("goal_tolerance"));
    }

    #[test]
    fn straight_ahead_accelerates_at_the_limit_then_cruises() {
        let mut f = WaypointFollower::new(ControllerParams::default(), drive()).unwrap();
        f.set_route(&[[10.0, 0.0]]);
        let dt = 0.01;
        // After 0.5 s at 0.5 m/s²: 0.25 m/s, both wheels 2.5 rad/s.
        let mut pose = Pose2::default();
        for _ in 0..50 {
            let (l, r) = f.update(&pose, dt);
            pose.x += f.command().0 * dt;
            assert!((l - r).abs() < 1e-12);
        }
        assert!((f.command().0 - 0.25).abs() < 1e-9, "{:?}", f.command());
        let (l, _) = f.update(&pose, dt);
        assert!((l - 2.55).abs() < 1e-9, "{l}");
        // Much later: capped at max_speed.
        for _ in 0..300 {
            f.update(&pose, dt);
            pose.x += f.command().0 * dt;
        }
        assert!((f.command().0 - 0.5).abs() < 1e-12);
    }

    #[test]
    fn large_heading_error_turns_in_place_rate_limited() {
        let mut f = WaypointFollower::new(ControllerParams::default(), drive()).unwrap();
        f.set_route(&[[0.0, 5.0]]); // 90° to the left
        let pose = Pose2::default();
        let (l, r) = f.update(&pose, 0.01);
        // v stays 0; ω ramps by 2 rad/s² · 0.01 s = 0.02 rad/s: wheels ∓0.02·0.2/0.1.
        assert!(
            (l + 0.04).abs() < 1e-12 && (r - 0.04).abs() < 1e-12,
            "{l} {r}"
        );
        for _ in 0..100 {
            f.update(&pose, 0.01);
        }
        assert_eq!(f.command(), (0.0, 1.0));
    }

    #[test]
    fn stops_at_the_last_waypoint_within_tolerance() {
        let mut f = WaypointFollower::new(ControllerParams::default(), drive()).unwrap();
        f.set_route(&[[3.0, 1.0]]);
        let mut max_v: f64 = 0.0;
        let end = run(&mut f, Pose2::new(0.0, 0.0, 0.2), 0.005, 4000, |_, f| {
            max_v = max_v.max(f.command().0)
        });
        assert!(f.finished());
        assert!(end.distance(&Pose2::new(3.0, 1.0, 0.0)) < 0.1, "{end:?}");
        assert!(f.command().0.abs() < 1e-9, "{:?}", f.command());
        assert!((max_v - 0.5).abs() < 1e-9);
    }

    #[test]
    fn square_route_visits_every_corner() {
        let mut f = WaypointFollower::new(ControllerParams::default(), drive()).unwrap();
        let route = [[2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [0.0, 0.0]];
        f.set_route(&route);
        let mut closest = [f64::MAX; 4];
        run(&mut f, Pose2::default(), 0.005, 8000, |p, _| {
            for (c, w) in closest.iter_mut().zip(&route) {
                *c = c.min((p.x - w[0]).hypot(p.y - w[1]));
            }
        });
        assert!(f.finished());
        for c in closest {
            assert!(c < 0.1, "{closest:?}");
        }
    }

    #[test]
    fn a_person_in_the_corridor_ahead_stops_the_robot_until_clear() {
        let look = LookAhead {
            front: 0.3,
            half_width: 0.2,
        };
        let pose = Pose2::new(0.0, 0.0, 0.0);
        let r = 0.25;
        // Ahead within gap + radius of the front, beside within the widened corridor.
        assert!(look.blocked(&pose, 0.0, 0.5, &[[1.0, 0.0]], r));
        assert!(look.blocked(&pose, 0.0, 0.5, &[[1.0, 0.5]], r));
        assert!(!look.blocked(&pose, 0.0, 0.5, &[[1.0, 0.6]], r));
        assert!(!look.blocked(&pose, 0.0, 0.5, &[[-1.0, 0.0]], r));
        assert!(!look.blocked(&pose, 0.0, 0.5, &[[1.2, 0.0]], r));
        // At speed the corridor grows by the braking distance (0.25 m at 0.5 m/s, 0.5 m/s²).
        assert!(look.blocked(&pose, 0.5, 0.5, &[[1.2, 0.0]], r));

        let mut f = WaypointFollower::new(ControllerParams::default(), drive()).unwrap();
        f.set_route(&[[10.0, 0.0]]);
        let dt = 0.01;
        for _ in 0..300 {
            f.update(&pose, dt);
        }
        assert!((f.command().0 - 0.5).abs() < 1e-9);
        f.set_blocked(true);
        for _ in 0..100 {
            f.update(&pose, dt);
        }
        assert_eq!(f.command().0, 0.0, "braked within v / max_accel = 1 s");
        f.set_blocked(false);
        for _ in 0..100 {
            f.update(&pose, dt);
        }
        assert!(f.command().0 > 0.4, "{:?}", f.command());
    }
}
