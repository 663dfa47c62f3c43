//! Planar poses (REP-103: x forward, y left, yaw counter-clockwise from +x).

use serde::{Deserialize, Serialize};

/// Wraps an angle into (-π, π].
pub fn normalize_angle(a: f64) -> f64 {
    // Most angles are already in range, and for them the remainder below is `a` itself,
    // bit for bit (|a| < 2π); skipping it saves a library call per particle and step.
    if a > -std::f64::consts::PI && a <= std::f64::consts::PI {
        return a;
    }
    let two_pi = std::f64::consts::TAU;
    let mut r = a % two_pi;
    if r <= -std::f64::consts::PI {
        r += two_pi;
    } else if r > std::f64::consts::PI {
        r -= two_pi;
    }
    r
}

/// A planar pose: position in metres, heading in radians.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose2 {
    pub x: f64,
    pub y: f64,
    pub theta: f64,
}

impl Pose2 {
    pub const fn new(x: f64, y: f64, theta: f64) -> Self {
        Self { x, y, theta }
    }

    /// `self ⊕ other`: `other` expressed in `self`'s frame, taken to the parent frame.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let (s, c) = self.theta.sin_cos();
        Pose2 {
            x: self.x + c * other.x - s * other.y,
            y: self.y + s * other.x + c * other.y,
            theta: normalize_angle(self.theta + other.theta),
        }
    }

    pub fn inverse(&self) -> Pose2 {
        let (s, c) = self.theta.sin_cos();
        Pose2 {
            x: -c * self.x - s * self.y,
            y: s * self.x - c * self.y,
            theta: normalize_angle(-self.theta),
        }
    }

    /// The pose of `other` seen from `self` (`self⁻¹ ⊕ other`).
    pub fn between(&self, other: &Pose2) -> Pose2 {
        self.inverse().compose(other)
    }

    /// A point given in this pose's frame, expressed in the parent frame.
    pub fn transform_point(&self, p: [f64; 2]) -> [f64; 2] {
        let (s, c) = self.theta.sin_cos();
        [self.x + c * p[0] - s * p[1], self.y + s * p[0] + c * p[1]]
    }

    pub fn distance(&self, other: &Pose2) -> f64 {
        (self.x - other.x).hypot(self.y - other.y)
    }

    /// Absolute heading difference, wrapped, in radians.
    pub fn heading_error(&self, other: &Pose2) -> f64 {
        normalize_angle(self.theta - other.theta).abs()
    }

    pub fn is_finite(&self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.theta.is_finite()
    }
}

/// A sensor's pose in the robot's base frame in 3D: position (m) and URDF roll, pitch, yaw
/// (rad, R = Rz(yaw)·Ry(pitch)·Rx(roll)).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Mount3 {
    pub xyz: [f64; 3],
    pub rpy: [f64; 3],
}

impl Mount3 {
    pub fn to_isometry(&self) -> nalgebra::Isometry3<f64> {
        let [r, p, y] = self.rpy;
        nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::new(self.xyz[0], self.xyz[1], self.xyz[2]),
            nalgebra::UnitQuaternion::from_euler_angles(r, p, y),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn normalize_wraps_into_half_open_interval() {
        assert!((normalize_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((normalize_angle(-PI) - PI).abs() < 1e-12);
        assert!((normalize_angle(0.5) - 0.5).abs() < 1e-12);
        assert!((normalize_angle(-2.0 * PI - 0.25) + 0.25).abs() < 1e-12);
    }

    #[test]
    fn angles_in_range_come_back_as_the_remainder_gives_them() {
        // The in-range shortcut must not change a bit: the remainder of |a| < 2π is a.
        let edge = [PI, -PI, 0.0, -0.0, f64::MIN_POSITIVE, 3.0, -3.0];
        let near = edge.iter().flat_map(|a| {
            let b = a.to_bits();
            [f64::from_bits(b.wrapping_sub(1)), f64::from_bits(b + 1)]
        });
        let spread = (0..2000).map(|k| -3.2 + 6.4 * k as f64 / 1999.0);
        for a in edge.into_iter().chain(near).chain(spread) {
            let mut r = a % std::f64::consts::TAU;
            if r <= -PI {
                r += std::f64::consts::TAU;
            } else if r > PI {
                r -= std::f64::consts::TAU;
            }
            assert_eq!(normalize_angle(a).to_bits(), r.to_bits(), "{a}");
        }
        assert!(normalize_angle(f64::NAN).is_nan());
    }

    #[test]
    fn compose_then_between_round_trips() {
        let a = Pose2::new(1.0, 2.0, FRAC_PI_2);
        let d = Pose2::new(0.5, -0.2, 0.3);
        let b = a.compose(&d);
        // Hand-computed: rotate (0.5, -0.2) by 90° -> (0.2, 0.5).
        assert!((b.x - 1.2).abs() < 1e-12 && (b.y - 2.5).abs() < 1e-12);
        let back = a.between(&b);
        assert!((back.x - d.x).abs() < 1e-12);
        assert!((back.y - d.y).abs() < 1e-12);
        assert!((back.theta - d.theta).abs() < 1e-12);
    }
}
