//! Wheel encoders and the odometry a robot computes from them. The encoders read the wheels'
//! actual rotation (so slip and motor lag show up), quantised to ticks; odometry integrates
//! tick deltas with the geometry the robot BELIEVES it has (`OdometrySpec`'s systematic
//! errors), never with the commanded speeds.

use crate::error::SimError;
use atrium_robots::{normalize_angle, DiffDrive, OdometrySpec, Pose2};
use std::f64::consts::TAU;

/// One quadrature encoder on a wheel joint.
#[derive(Debug, Clone, PartialEq)]
pub struct Encoder {
    ticks_per_rev: f64,
    /// Last wrapped joint angle read, rad.
    last: f64,
    /// Unwrapped joint angle since start, rad.
    angle: f64,
}

impl Encoder {
    /// `initial` is the wrapped joint angle at start: the count starts at zero there.
    pub fn new(ticks_per_rev: u32, initial: f64) -> Self {
        Self {
            ticks_per_rev: ticks_per_rev as f64,
            last: initial,
            angle: 0.0,
        }
    }

    /// Feeds the joint's current wrapped angle. Unwraps by taking the shortest way from the
    /// last reading, which is right as long as a wheel turns less than half a turn per call
    /// (at 200 Hz, 100 rev/s).
    pub fn update(&mut self, wrapped: f64) {
        self.angle += normalize_angle(wrapped - self.last);
        self.last = wrapped;
    }

    /// Unwrapped rotation since start, rad (not quantised: ground truth for tests).
    pub fn angle(&self) -> f64 {
        self.angle
    }

    /// Cumulative ticks: whole tick intervals passed, rounding toward −∞ like a counter
    /// that counts edges.
    pub fn ticks(&self) -> i64 {
        (self.angle / TAU * self.ticks_per_rev).floor() as i64
    }
}

/// Dead reckoning from tick counts with the believed wheel radii and separation.
#[derive(Debug, Clone, PartialEq)]
pub struct Odometry {
    rad_per_tick: f64,
    left_radius: f64,
    right_radius: f64,
    separation: f64,
    pose: Pose2,
    left_ticks: i64,
    right_ticks: i64,
}

impl Odometry {
    /// `truth` is the robot's true geometry; the believed one follows `OdometrySpec`'s docs:
    /// left radius r·(1 + s)·(1 + e/2), right r·(1 + s)·(1 − e/2), separation b·(1 + e_b)
    /// (s the common-mode `scale_error`, e the differential `radius_error`).
    pub fn new(spec: &OdometrySpec, truth: DiffDrive, start: Pose2) -> Result<Self, SimError> {
        if spec.ticks_per_rev == 0 {
            return Err(SimError::config("odometry.ticks_per_rev", "must be > 0"));
        }
        let e = spec.radius_error;
        if !(e.is_finite() && e.abs() < 1.0) {
            return Err(SimError::config(
                "odometry.radius_error",
                format!("must be finite with |e| < 1, got {e}"),
            ));
        }
        let eb = spec.separation_error;
        if !(eb.is_finite() && eb > -1.0) {
            return Err(SimError::config(
                "odometry.separation_error",
                format!("must be finite and > −1, got {eb}"),
            ));
        }
        let es = spec.scale_error;
        if !(es.is_finite() && es.abs() < 1.0) {
            return Err(SimError::config(
                "odometry.scale_error",
                format!("must be finite with |s| < 1, got {es}"),
            ));
        }
        crate::error::positive("odometry.rate_hz", spec.rate_hz)?;
        // The common-mode radius error multiplies both radii; s = 0 leaves them bit-identical.
        let r = truth.wheel_radius * (1.0 + es);
        Ok(Self {
            rad_per_tick: TAU / spec.ticks_per_rev as f64,
            left_radius: r * (1.0 + 0.5 * e),
            right_radius: r * (1.0 - 0.5 * e),
            separation: truth.wheel_separation * (1.0 + eb),
            pose: start,
            left_ticks: 0,
            right_ticks: 0,
        })
    }

    /// Integrates the change since the last call as one constant-speed arc.
    pub fn update(&mut self, left_ticks: i64, right_ticks: i64) -> Pose2 {
        let dl = (left_ticks - self.left_ticks) as f64 * self.rad_per_tick * self.left_radius;
        let dr = (right_ticks - self.right_ticks) as f64 * self.rad_per_tick * self.right_radius;
        self.left_ticks = left_ticks;
        self.right_ticks = right_ticks;
        if dl != 0.0 || dr != 0.0 {
            self.pose = DiffDrive::integrate(&self.pose, dl, dr, self.separation);
        }
        self.pose
    }

    pub fn pose(&self) -> Pose2 {
        self.pose
    }

    pub fn ticks(&self) -> (i64, i64) {
        (self.left_ticks, self.right_ticks)
    }

    /// Believed (left radius, right radius, separation), m.
    pub fn believed_geometry(&self) -> (f64, f64, f64) {
        (self.left_radius, self.right_radius, self.separation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn encoder_unwraps_across_pi_and_counts_ticks() {
        let mut e = Encoder::new(500, 3.0);
        // Forward through +π to −π and on: 1.5 turns in 0.1 rad steps.
        let mut a: f64 = 3.0;
        for _ in 0..(3.0 * PI / 0.1) as usize {
            a += 0.1;
            e.update(normalize_angle(a));
        }
        assert!((e.angle() - (a - 3.0)).abs() < 1e-9);
        assert_eq!(e.ticks(), ((a - 3.0) / TAU * 500.0).floor() as i64);
        // And backwards below the start: negative counts round toward −∞.
        let mut e = Encoder::new(500, 0.0);
        e.update(-0.001);
        assert_eq!(e.ticks(), -1);
        e.update(0.0);
        assert_eq!(e.ticks(), 0);
    }

    #[test]
    fn believed_geometry_follows_the_spec() {
        let spec = OdometrySpec {
            ticks_per_rev: 500,
            radius_error: 0.02,
            separation_error: 0.05,
            rate_hz: 50.0,
            ..Default::default()
        };
        let truth = DiffDrive {
            wheel_radius: 0.1,
            wheel_separation: 0.4,
        };
        let o = Odometry::new(&spec, truth, Pose2::default()).unwrap();
        let (l, r, b) = o.believed_geometry();
        assert!((l - 0.101).abs() < 1e-12 && (r - 0.099).abs() < 1e-12 && (b - 0.42).abs() < 1e-12);
    }

    #[test]
    fn straight_ticks_give_the_hand_computed_distance() {
        let spec = OdometrySpec {
            ticks_per_rev: 500,
            radius_error: 0.0,
            separation_error: 0.0,
            rate_hz: 50.0,
            ..Default::default()
        };
        let truth = DiffDrive {
            wheel_radius: 0.1,
            wheel_separation: 0.4,
        };
        let mut o = Odometry::new(&spec, truth, Pose2::new(1.0, 2.0, PI / 2.0)).unwrap();
        // 1000 ticks = 2 turns = 0.4π m, heading +y.
        let p = o.update(1000, 1000);
        assert!(
            (p.x - 1.0).abs() < 1e-12 && (p.y - (2.0 + 0.4 * PI)).abs() < 1e-12,
            "{p:?}"
        );
        // Opposite ticks turn in place: Δθ = (dr − dl)/b = 2·(250·2π/500·0.1)/0.4 = π/2.
        let p = o.update(750, 1250);
        assert!((p.theta - PI).abs() < 1e-12, "{p:?}");
    }

    #[test]
    fn scale_error_over_reads_a_straight_drive_by_its_factor() {
        // Both believed radii 3 % large (a tyre rolling on less than its nominal radius):
        // 1000 ticks (0.4π m truly) read as 1.03 · 0.4π m, straight ahead, and a turn in place
        // over-reads its angle by the same factor.
        let spec = OdometrySpec {
            ticks_per_rev: 500,
            radius_error: 0.0,
            separation_error: 0.0,
            scale_error: 0.03,
            rate_hz: 50.0,
        };
        let truth = DiffDrive {
            wheel_radius: 0.1,
            wheel_separation: 0.4,
        };
        let mut o = Odometry::new(&spec, truth, Pose2::default()).unwrap();
        let (l, r, b) = o.believed_geometry();
        assert!((l - 0.103).abs() < 1e-12 && (r - 0.103).abs() < 1e-12 && b == 0.4);
        let p = o.update(1000, 1000);
        assert!((p.x - 1.03 * 0.4 * PI).abs() < 1e-12, "{p:?}");
        assert!(p.y.abs() < 1e-12 && p.theta.abs() < 1e-12, "{p:?}");
        let p = o.update(750, 1250);
        assert!((p.theta - 1.03 * PI / 2.0).abs() < 1e-12, "{p:?}");
        // With the differential error too, the mean believed radius is r·(1 + s).
        let spec = OdometrySpec {
            radius_error: 0.02,
            ..spec
        };
        let (l, r, _) = Odometry::new(&spec, truth, Pose2::default())
            .unwrap()
            .believed_geometry();
        assert!((0.5 * (l + r) - 0.103).abs() < 1e-12 && (l - r - 0.103 * 0.02).abs() < 1e-12);
        // s = 0 (the default) leaves the believed radii bit-identical to the model without it.
        let spec = OdometrySpec {
            scale_error: 0.0,
            ..spec
        };
        let (l, r, _) = Odometry::new(&spec, truth, Pose2::default())
            .unwrap()
            .believed_geometry();
        assert_eq!((l, r), (0.1 * (1.0 + 0.5 * 0.02), 0.1 * (1.0 - 0.5 * 0.02)));
    }

    #[test]
    fn bad_scale_error_is_named() {
        let truth = DiffDrive {
            wheel_radius: 0.1,
            wheel_separation: 0.4,
        };
        for s in [1.0, -1.0, f64::NAN, f64::INFINITY] {
            let spec = OdometrySpec {
                scale_error: s,
                ..Default::default()
            };
            let e = Odometry::new(&spec, truth, Pose2::default())
                .unwrap_err()
                .to_string();
            assert!(e.contains("odometry.scale_error"), "{s}: {e}");
            let v = spec.validate().unwrap_err();
            assert!(v.starts_with("scale_error: must be"), "{s}: {v}");
        }
        let spec = OdometrySpec {
            scale_error: -0.5,
            ..Default::default()
        };
        assert!(spec.validate().is_ok() && Odometry::new(&spec, truth, Pose2::default()).is_ok());
    }

    #[test]
    fn bad_spec_is_named() {
        let truth = DiffDrive {
            wheel_radius: 0.1,
            wheel_separation: 0.4,
        };
        let spec = OdometrySpec {
            rate_hz: 0.0,
            ..Default::default()
        };
        let e = Odometry::new(&spec, truth, Pose2::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("odometry.rate_hz"), "{e}");
    }
}
