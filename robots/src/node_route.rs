//! The multi-node odometry model of Theodoridis et al., [002]
//! Table I and §III-C: a route is a list of nodes ⟨x_n, y_n⟩; the robot turns to the next node
//! (turnTo, angular threshold γ_θ), moves to it (moveTo, distance threshold γ_d), and on
//! arrival its odometry coordinates are set to the node's (update).
//!
//! These are pure functions of the robot's *odometry* coordinates, shared by the node
//! controller that drives the robot (`atrium-sim`) and by the landmark filter that tracks the
//! same route (`atrium-localization`), so both decide "node reached" identically.

use crate::pose::{normalize_angle, Pose2};

/// turnTo(x_n, y_n), Table I: the heading ϑ_n from the robot's position to the node,
/// ϑ_n = 2·arctan(y / (√(x² + y²) + x)) on the relative vector (x, y) — the half-angle form of
/// atan2, which is what `f64::atan2` computes. Radians (Table I converts to degrees for
/// display; Atrium keeps SI units).
pub fn turn_to(pose: &Pose2, node: [f64; 2]) -> f64 {
    (node[1] - pose.y).atan2(node[0] - pose.x)
}

/// The rotational transition δ_θ of Table I: the turn is complete when
/// (ϑ_n − γ_θ) ≤ θ ≤ (ϑ_n + γ_θ), the comparison taken on the circle (angles wrap).
pub fn turn_done(theta: f64, target: f64, gamma_theta: f64) -> bool {
    normalize_angle(theta - target).abs() <= gamma_theta
}

/// The translational transition δ_d of Table I: with d_t the total length of the leg and d_c
/// the current distance to the node, the move is complete when
/// (d_t − γ_d) ≤ (d_t − d_c) ≤ (d_t + γ_d).
pub fn move_done(d_t: f64, d_c: f64, gamma_d: f64) -> bool {
    let travelled = d_t - d_c;
    (d_t - gamma_d) <= travelled && travelled <= (d_t + gamma_d)
}

/// One leg of a node route: from `from` (where the previous update() put the robot, or the
/// start) to `node`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Leg {
    pub from: [f64; 2],
    pub node: [f64; 2],
}

impl Leg {
    /// d_t of Table I.
    pub fn total(&self) -> f64 {
        (self.node[0] - self.from[0]).hypot(self.node[1] - self.from[1])
    }

    /// d_c of Table I.
    pub fn current(&self, pose: &Pose2) -> f64 {
        (self.node[0] - pose.x).hypot(self.node[1] - pose.y)
    }

    /// Distance covered along the leg's direction (the projection of the displacement).
    pub fn progress(&self, pose: &Pose2) -> f64 {
        let d = self.total();
        if d < 1e-12 {
            return 0.0;
        }
        ((pose.x - self.from[0]) * (self.node[0] - self.from[0])
            + (pose.y - self.from[1]) * (self.node[1] - self.from[1]))
            / d
    }

    /// Whether the odometry pose has reached the node: Table I's δ_d test, or — when the
    /// robot passed beside the node, which the Euclidean d_c alone would never catch — the
    /// progress along the leg beyond d_t + γ_d (the interval's upper bound read along the
    /// leg).
    pub fn reached(&self, pose: &Pose2, gamma_d: f64) -> bool {
        let d_t = self.total();
        move_done(d_t, self.current(pose), gamma_d) || self.progress(pose) > d_t + gamma_d
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn turn_to_points_at_the_node() {
        let p = Pose2::new(1.0, 1.0, 0.0);
        assert!((turn_to(&p, [1.0, 3.0]) - FRAC_PI_2).abs() < 1e-12);
        assert!((turn_to(&p, [-1.0, 1.0]).abs() - PI).abs() < 1e-12);
        // The half-angle form of Table I agrees with atan2 off the negative x axis.
        let (x, y) = (0.3_f64, -0.7_f64);
        let half = 2.0 * (y / ((x * x + y * y).sqrt() + x)).atan();
        assert!((turn_to(&Pose2::default(), [x, y]) - half).abs() < 1e-12);
    }

    #[test]
    fn turn_test_holds_exactly_at_the_threshold_and_wraps() {
        // Binary fractions, so the bounds are exact in floating point.
        let g = 0.125;
        assert!(turn_done(1.0 + g, 1.0, g));
        assert!(turn_done(1.0 - g, 1.0, g));
        assert!(!turn_done(1.0 + g + 1e-9, 1.0, g));
        assert!(!turn_done(1.0 - g - 1e-9, 1.0, g));
        // Across ±π: 179.9° and −179.9° are 0.2° apart.
        let a = 179.9f64.to_radians();
        assert!(turn_done(a, -a, 0.21f64.to_radians()));
        assert!(!turn_done(a, -a, 0.19f64.to_radians()));
    }

    #[test]
    fn move_test_holds_exactly_at_the_threshold() {
        // d_t = 4 m, γ_d = 0.125 m: done once d_c ≤ 0.125 m.
        assert!(move_done(4.0, 0.125, 0.125));
        assert!(move_done(4.0, 0.0, 0.125));
        assert!(!move_done(4.0, 0.125 + 1e-9, 0.125));
        assert!(!move_done(4.0, 2.0, 0.125));
    }

    #[test]
    fn a_leg_is_reached_at_the_node_or_when_passed_beside_it() {
        let leg = Leg {
            from: [0.0, 0.0],
            node: [4.0, 0.0],
        };
        assert!((leg.total() - 4.0).abs() < 1e-12);
        assert!(!leg.reached(&Pose2::new(3.8, 0.0, 0.0), 0.1));
        assert!(leg.reached(&Pose2::new(3.95, 0.02, 0.0), 0.1));
        // 0.3 m to the side, level with the node: not yet; 0.15 m beyond it: passed.
        assert!(!leg.reached(&Pose2::new(4.0, 0.3, 0.0), 0.1));
        assert!(leg.reached(&Pose2::new(4.15, 0.3, 0.0), 0.1));
    }
}
