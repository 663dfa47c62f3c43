//! Wheel encoders and the odometry a robot computes from them. The encoders read the wheels'
//! actual rotation (so slip and motor lag show up), quantised to ticks; odometry integrates
//! tick deltas with the geometry the robot BELIEVES it has (`OdometrySpec`'s systematic
//! errors), never with the commanded speeds.

use crate::error::SimError;
use atrium_robots::{normalize_angle, DiffDrive, OdometrySpec, Pose2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
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

/// Random slip of the two wheels: each wheel's scale error is a first-order Gauss–Markov
/// (Ornstein–Uhlenbeck) process over the distance it rolls, stationary with standard
/// deviation `sigma` and correlation length `length` m. Indexed by distance, not time, so a
/// robot that stands still accumulates nothing and the error over a stretch does not depend
/// on the odometry rate or the physics step.
#[derive(Debug, Clone, PartialEq)]
pub struct WheelSlip {
    sigma: f64,
    length: f64,
    /// Current scale error of the left and right wheel.
    error: [f64; 2],
    rng: ChaCha8Rng,
}

impl WheelSlip {
    /// Starts both wheels at a draw from the stationary distribution.
    pub fn new(sigma: f64, length: f64, mut rng: ChaCha8Rng) -> Self {
        let mut draw = || sigma * rng.sample::<f64, _>(StandardNormal);
        let error = [draw(), draw()];
        Self {
            sigma,
            length,
            error,
            rng,
        }
    }

    /// The wheel `w` (0 left, 1 right) rolled `d` m: advances its error by that distance
    /// (exact discretisation: e ← ρ·e + σ·√(1 − ρ²)·n, ρ = exp(−|d|/L)) and returns the
    /// distance the odometry reads, d·(1 + e).
    pub fn read(&mut self, w: usize, d: f64) -> f64 {
        if d == 0.0 {
            return 0.0;
        }
        let rho = (-d.abs() / self.length).exp();
        let n: f64 = self.rng.sample(StandardNormal);
        self.error[w] = rho * self.error[w] + self.sigma * (1.0 - rho * rho).sqrt() * n;
        d * (1.0 + self.error[w])
    }

    pub fn errors(&self) -> [f64; 2] {
        self.error
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
    slip: Option<WheelSlip>,
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
            slip: None,
        })
    }

    /// Adds the spec's random wheel slip (`slip_sigma` > 0), drawn from `rng`.
    pub fn with_slip(mut self, spec: &OdometrySpec, rng: ChaCha8Rng) -> Self {
        if spec.slip_sigma > 0.0 {
            self.slip = Some(WheelSlip::new(
                spec.slip_sigma,
                spec.slip_correlation_m,
                rng,
            ));
        }
        self
    }

    /// Integrates the change since the last call as one constant-speed arc.
    pub fn update(&mut self, left_ticks: i64, right_ticks: i64) -> Pose2 {
        let mut dl = (left_ticks - self.left_ticks) as f64 * self.rad_per_tick * self.left_radius;
        let mut dr =
            (right_ticks - self.right_ticks) as f64 * self.rad_per_tick * self.right_radius;
        if let Some(slip) = &mut self.slip {
            dl = slip.read(0, dl);
            dr = slip.read(1, dr);
        }
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
    use rand::SeedableRng;

    /// Over many independent stretches of 10 m, the slip's mean error over a stretch has the
    /// spread the Gauss–Markov process predicts: Var = 2σ²L²/D² (D/L − 1 + e^(−D/L)).
    #[test]
    fn slip_error_over_a_stretch_has_the_predicted_spread() {
        let (sigma, length, stretch, step) = (0.03, 2.0, 10.0, 0.01);
        let mut slip = WheelSlip::new(sigma, length, ChaCha8Rng::seed_from_u64(3));
        let n = 2000;
        let mut means = Vec::with_capacity(n);
        for _ in 0..n {
            let mut read = 0.0;
            for _ in 0..(stretch / step) as usize {
                read += slip.read(0, step);
            }
            means.push(read / stretch - 1.0);
        }
        let var = means.iter().map(|m| m * m).sum::<f64>() / n as f64;
        let x = stretch / length;
        let want = 2.0 * sigma * sigma / (x * x) * (x - 1.0 + (-x).exp());
        assert!(
            (var / want - 1.0).abs() < 0.15,
            "variance {var}, predicted {want}"
        );
        // A wheel that does not roll keeps its error; the other wheel's draws are its own.
        let before = slip.errors();
        assert_eq!(slip.read(0, 0.0), 0.0);
        assert_eq!(slip.errors(), before);
    }
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
            slip_sigma: 0.0,
            slip_correlation_m: 2.0,
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
