//! Differential-drive kinematics, which a skid steer shares with an effective track.
//!
//! A skid-steer robot (two or three wheels per side, a side's wheels driven together) turns
//! only by sliding its wheels sideways. Its motion is still described well by the
//! differential-drive equations if the geometric track `B` is replaced by a larger
//! effective track `χ·B`: the instantaneous centres of rotation of the two sides lie
//! outside the wheels. Mandow et al. measured this "expansion factor" χ on a skid-steer
//! robot (A. Mandow, J. L. Martínez, J. Morales, J. L. Blanco, A. García-Cerezo and
//! J. González, "Experimental kinematics for wheeled skid-steer mobile robots", IEEE/RSJ
//! IROS 2007, pp. 1222–1227), and it depends on the floor, the load and the turn. Clearpath
//! ships its ROS drive controllers with `wheel_separation_multiplier: 1.875` for the Husky
//! and `1.5` for the Jackal (husky/husky `husky_control/config/control.yaml`,
//! jackal/jackal `jackal_control/config/control.yaml`).

use crate::pose::{normalize_angle, Pose2};

/// The effective track of a skid steer as a multiple of its geometric track when its URDF
/// does not state one: 1.5, Clearpath's Jackal value and the low end of the range above, the
/// value a robot whose drive was not calibrated on its floor plausibly carries. A URDF
/// overrides it with `<skid_steer effective_track_ratio="1.875"/>` (or
/// `effective_track="1.07"`, in metres) directly under `<robot>`; a scenario scales what
/// the odometry believes with `[odometry] separation_error`.
pub const DEFAULT_EFFECTIVE_TRACK_RATIO: f64 = 1.5;

/// Wheel radius and separation (track width) of a differential drive, in metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiffDrive {
    pub wheel_radius: f64,
    pub wheel_separation: f64,
}

impl DiffDrive {
    /// Wheel angular speeds (left, right) in rad/s for a body velocity (v m/s, ω rad/s).
    pub fn wheel_speeds(&self, v: f64, omega: f64) -> (f64, f64) {
        let half = 0.5 * self.wheel_separation;
        (
            (v - omega * half) / self.wheel_radius,
            (v + omega * half) / self.wheel_radius,
        )
    }

    /// Body velocity (v, ω) from wheel angular speeds (left, right).
    pub fn body_velocity(&self, left: f64, right: f64) -> (f64, f64) {
        let vl = left * self.wheel_radius;
        let vr = right * self.wheel_radius;
        (0.5 * (vl + vr), (vr - vl) / self.wheel_separation)
    }

    /// Integrates wheel rotations (left, right, radians) as an arc: exact for constant
    /// wheel speeds over the interval.
    pub fn integrate(pose: &Pose2, left_dist: f64, right_dist: f64, separation: f64) -> Pose2 {
        let ds = 0.5 * (left_dist + right_dist);
        let dtheta = (right_dist - left_dist) / separation;
        let (dx, dy) = if dtheta.abs() < 1e-9 {
            (ds, 0.0)
        } else {
            let r = ds / dtheta;
            (r * dtheta.sin(), r * (1.0 - dtheta.cos()))
        };
        let delta = Pose2::new(dx, dy, dtheta);
        let mut p = pose.compose(&delta);
        p.theta = normalize_angle(p.theta);
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wheel_speeds_round_trip() {
        let d = DiffDrive {
            wheel_radius: 0.1,
            wheel_separation: 0.4,
        };
        let (l, r) = d.wheel_speeds(0.5, 0.25);
        assert!((l - 4.5).abs() < 1e-12 && (r - 5.5).abs() < 1e-12);
        let (v, w) = d.body_velocity(l, r);
        assert!((v - 0.5).abs() < 1e-12 && (w - 0.25).abs() < 1e-12);
    }

    #[test]
    fn integrate_quarter_circle() {
        // Left wheel still, right wheel travels a quarter of a circle of radius b.
        let b = 0.5;
        let p = DiffDrive::integrate(&Pose2::default(), 0.0, std::f64::consts::FRAC_PI_2 * b, b);
        // Centre of the axle moves on a circle of radius b/2 about the left wheel.
        assert!((p.x - 0.25).abs() < 1e-12, "{p:?}");
        assert!((p.y - 0.25).abs() < 1e-12, "{p:?}");
        assert!((p.theta - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
    }
}
