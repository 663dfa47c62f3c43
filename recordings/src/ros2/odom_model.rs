//! The uncertainty of the wheel odometry, as `/odom` carries it (`nav_msgs/Odometry` pose and
//! twist covariances), derived from the robot's odometry model (`OdometrySpec`), the same one
//! the simulator's encoders use:
//!
//! - systematic errors, unknown to the robot's software and so uncertain to it: the wheels'
//!   common-mode scale error `scale_error` (both wheels together), the differential radius
//!   error `radius_error` (left +e/2, right −e/2) and the separation error `separation_error`,
//!   each a bias whose standard deviation is the spec's magnitude (a systematic error of 2 %
//!   means the software's belief is 2 % off one way or the other);
//! - random slip `slip_sigma`, a Gauss–Markov scale error per wheel over the distance it rolls
//!   with correlation length `slip_correlation_m` (exactly as `atrium_sim`'s `WheelSlip`:
//!   e ← ρ·e + σ·√(1 − ρ²)·n, ρ = exp(−|d|/L));
//! - the encoders' quantisation, one tick, which bounds the twist's variance from below (a
//!   robot at rest still reads its speed only to a tick per reading).
//!
//! The pose covariance is propagated with the odometry's own arc integration linearised about
//! the measured motion, over the state (x, y, θ, b_l, b_r, b_sep, g_l, g_r): pose, the wheel and
//! separation biases, and the two slip states. It starts at zero (the odom frame starts at the
//! robot) and grows with the distance driven, quadratically while the systematic and the
//! slowly decorrelating slip errors dominate and linearly (a random walk) once a wheel has
//! rolled many correlation lengths.

use atrium_robots::{OdometrySpec, Pose2};
use nalgebra::{Matrix3, SMatrix, SVector};

type M8 = SMatrix<f64, 8, 8>;

/// Covariances of one odometry reading: pose (x, y, yaw) in `odom` and twist (vx, vy, wz) in
/// the base frame, with the twist itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdomUncertainty {
    pub pose: Matrix3<f64>,
    /// Linear x, y (m/s) and angular z (rad/s) in the base frame.
    pub twist: [f64; 3],
    pub twist_covariance: Matrix3<f64>,
}

/// Propagates the odometry's covariance reading by reading.
#[derive(Debug, Clone)]
pub struct OdomModel {
    separation: f64,
    /// Distance one encoder tick stands for, m.
    tick_m: f64,
    sigma: f64,
    length: f64,
    cov: M8,
    last: Option<(f64, Pose2)>,
}

impl OdomModel {
    /// `wheel_radius` and `separation` are the geometry the odometry integrates with (the
    /// drive's: a skid steer's effective track).
    pub fn new(spec: &OdometrySpec, wheel_radius: f64, separation: f64) -> OdomModel {
        let mut cov = M8::zeros();
        // Biases: (e/2)²·[[1, −1], [−1, 1]] + s²·[[1, 1], [1, 1]] on (b_l, b_r); e_b² on b_sep.
        let (d, s) = (0.5 * spec.radius_error, spec.scale_error);
        cov[(3, 3)] = d * d + s * s;
        cov[(4, 4)] = d * d + s * s;
        cov[(3, 4)] = s * s - d * d;
        cov[(4, 3)] = s * s - d * d;
        cov[(5, 5)] = spec.separation_error * spec.separation_error;
        // Slip starts at its stationary distribution.
        let var = spec.slip_sigma * spec.slip_sigma;
        cov[(6, 6)] = var;
        cov[(7, 7)] = var;
        OdomModel {
            separation,
            tick_m: std::f64::consts::TAU * wheel_radius / f64::from(spec.ticks_per_rev.max(1)),
            sigma: spec.slip_sigma,
            length: spec.slip_correlation_m.max(f64::MIN_POSITIVE),
            cov,
            last: None,
        }
    }

    /// The pose covariance so far.
    pub fn pose_covariance(&self) -> Matrix3<f64> {
        self.cov.fixed_view::<3, 3>(0, 0).into_owned()
    }

    /// Feeds the odometry pose read at `t` s; returns its twist and covariances. The first
    /// reading has zero twist (no earlier reading to difference with).
    pub fn update(&mut self, t: f64, pose: Pose2) -> OdomUncertainty {
        let Some((t0, p0)) = self.last.replace((t, pose)) else {
            return OdomUncertainty {
                pose: self.pose_covariance(),
                twist: [0.0; 3],
                twist_covariance: self.twist_covariance(0.0, 0.0, 0.0),
            };
        };
        // The wheels' travel, from the motion in the previous base frame (one arc).
        let delta = p0.inverse().compose(&pose);
        let dtheta = atrium_robots::normalize_angle(delta.theta);
        let chord = delta.x.hypot(delta.y);
        let ds = if dtheta.abs() < 1e-9 {
            chord.copysign(delta.x)
        } else {
            // Arc length from the chord: chord = 2·(ds/dθ)·sin(dθ/2).
            (chord * 0.5 * dtheta / (0.5 * dtheta).sin()).copysign(delta.x)
        };
        let b = self.separation;
        let (sl, sr) = (ds - 0.5 * b * dtheta, ds + 0.5 * b * dtheta);
        self.propagate(p0.theta, ds, dtheta, sl, sr);
        let dt = t - t0;
        let twist = if dt > 0.0 {
            [delta.x / dt, delta.y / dt, dtheta / dt]
        } else {
            [0.0; 3]
        };
        OdomUncertainty {
            pose: self.pose_covariance(),
            twist,
            twist_covariance: self.twist_covariance(sl, sr, dt),
        }
    }

    /// One step of the arc integration x' = x + ds·cos(θ + dθ/2), y' = y + ds·sin(θ + dθ/2),
    /// θ' = θ + dθ with ds = (s_l + s_r)/2, dθ = (s_r − s_l)/b, each wheel's true travel
    /// s_i·(1 + b_i + g_i) and the true separation b·(1 + b_sep), linearised.
    fn propagate(&mut self, theta: f64, ds: f64, dtheta: f64, sl: f64, sr: f64) {
        let b = self.separation;
        let phi = theta + 0.5 * dtheta;
        let (s, c) = phi.sin_cos();
        // Sensitivities of (ds, dθ) to the wheel errors (b_l + g_l, b_r + g_r) and b_sep.
        let dds = [0.5 * sl, 0.5 * sr];
        let ddth = [-sl / b, sr / b];
        let ddth_sep = -dtheta;
        let mut f = M8::identity();
        f[(0, 2)] = -ds * s;
        f[(1, 2)] = ds * c;
        for (w, col) in [(0usize, 3usize), (1, 4)] {
            for extra in [0usize, 3] {
                let k = col + extra;
                f[(0, k)] = dds[w] * c - 0.5 * ds * s * ddth[w];
                f[(1, k)] = dds[w] * s + 0.5 * ds * c * ddth[w];
                f[(2, k)] = ddth[w];
            }
        }
        f[(0, 5)] = -0.5 * ds * s * ddth_sep;
        f[(1, 5)] = 0.5 * ds * c * ddth_sep;
        f[(2, 5)] = ddth_sep;
        // The slip states decay over the distance each wheel rolled; their new draws enter
        // after this step's travel (as the simulator reads the wheel with the updated error,
        // the increment's effect on this step is second order and left out).
        let mut q = SVector::<f64, 8>::zeros();
        for (w, d) in [(6usize, sl), (7, sr)] {
            let rho = (-d.abs() / self.length).exp();
            f[(w, w)] = rho;
            q[w] = self.sigma * self.sigma * (1.0 - rho * rho);
        }
        self.cov = f * self.cov * f.transpose() + M8::from_diagonal(&q);
        // Keep it exactly symmetric against rounding.
        self.cov = 0.5 * (self.cov + self.cov.transpose());
    }

    /// Covariance of (vx, vy, wz) over one reading interval `dt` in which the wheels rolled
    /// `sl`, `sr`: the wheels' scale uncertainties (biases and slip) plus one tick of
    /// quantisation per wheel, which is also the floor for vy (no sideways slip is modelled).
    fn twist_covariance(&self, sl: f64, sr: f64, dt: f64) -> Matrix3<f64> {
        let dt = if dt > 0.0 { dt } else { 1.0 };
        let b = self.separation;
        // Wheel-error covariance: bias block plus the slip states (each wheel's own).
        let idx = [[3usize, 6], [4, 7]];
        let mut we = nalgebra::Matrix2::<f64>::zeros();
        for i in 0..2 {
            for j in 0..2 {
                for &a in &idx[i] {
                    for &c in &idx[j] {
                        we[(i, j)] += self.cov[(a, c)];
                    }
                }
            }
        }
        let travel = nalgebra::Matrix2::new(sl, 0.0, 0.0, sr);
        let q = self.tick_m * self.tick_m / 6.0;
        let wheels = travel * we * travel + nalgebra::Matrix2::from_diagonal_element(q);
        // (v, ω) = ((s_l + s_r)/2, (s_r − s_l)/b)/dt, and ω also scales with the separation.
        let j = nalgebra::Matrix2::new(0.5, 0.5, -1.0 / b, 1.0 / b) / dt;
        let vw = j * wheels * j.transpose();
        let omega = (sr - sl) / b / dt;
        let mut m = Matrix3::zeros();
        m[(0, 0)] = vw[(0, 0)];
        m[(0, 2)] = vw[(0, 1)];
        m[(2, 0)] = vw[(1, 0)];
        m[(2, 2)] = vw[(1, 1)] + omega * omega * self.cov[(5, 5)];
        m[(1, 1)] = q / (dt * dt);
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> OdometrySpec {
        OdometrySpec {
            ticks_per_rev: 500,
            radius_error: 0.0,
            separation_error: 0.0,
            rate_hz: 50.0,
            ..Default::default()
        }
    }

    /// Drives `n` steps of `ds` m and `dth` rad from the origin, reading at 50 Hz.
    fn drive(m: &mut OdomModel, n: usize, ds: f64, dth: f64) -> OdomUncertainty {
        let mut p = Pose2::default();
        let mut out = m.update(0.0, p);
        for k in 1..=n {
            p = atrium_robots::DiffDrive::integrate(
                &p,
                ds - 0.5 * m.separation * dth,
                ds + 0.5 * m.separation * dth,
                m.separation,
            );
            out = m.update(k as f64 / 50.0, p);
        }
        out
    }

    #[test]
    fn a_differential_radius_error_gives_one_sigma_the_drift_it_causes() {
        // e = 2 %: over a straight 10 m the heading drifts by e·D/b (left wheel reads long,
        // right short): exactly the model's one sigma, and y by e·D²/(2b).
        let (e, b, d) = (0.02, 0.4, 10.0);
        let mut m = OdomModel::new(
            &OdometrySpec {
                radius_error: e,
                ..spec()
            },
            0.1,
            b,
        );
        let u = drive(&mut m, 1000, d / 1000.0, 0.0);
        let sth = u.pose[(2, 2)].sqrt();
        assert!((sth / (e * d / b) - 1.0).abs() < 1e-3, "{sth}");
        let sy = u.pose[(1, 1)].sqrt();
        assert!((sy / (e * d * d / (2.0 * b)) - 1.0).abs() < 1e-2, "{sy}");
        // A scale error alone moves x only: σx = s·D, heading unaffected on a straight line.
        let mut m = OdomModel::new(
            &OdometrySpec {
                scale_error: 0.03,
                ..spec()
            },
            0.1,
            b,
        );
        let u = drive(&mut m, 1000, d / 1000.0, 0.0);
        assert!((u.pose[(0, 0)].sqrt() / (0.03 * d) - 1.0).abs() < 1e-6);
        assert!(u.pose[(2, 2)] < 1e-20 && u.pose[(1, 1)] < 1e-20);
        // Twist: 0.5 m/s forward; one tick per wheel bounds vy from below.
        assert!((u.twist[0] - 0.5).abs() < 1e-9 && u.twist[2].abs() < 1e-9);
        assert!(u.twist_covariance[(1, 1)] > 0.0);
        // vx: the scale error (3 % of 0.5 m/s) plus one tick of each wheel over 20 ms, the
        // difference of two floored counts (variance tick²/6 per wheel), halved twice.
        let tick = std::f64::consts::TAU * 0.1 / 500.0;
        let want = (0.03f64 * 0.5).powi(2) + 0.25 * 2.0 * tick * tick / 6.0 / (0.02f64 * 0.02);
        assert!(
            (u.twist_covariance[(0, 0)] / want - 1.0).abs() < 1e-6,
            "{} vs {want}",
            u.twist_covariance[(0, 0)]
        );
    }

    #[test]
    fn slip_alone_matches_the_simulators_wheel_slip_over_many_runs() {
        // The simulator's Gauss–Markov slip, 400 runs of a 6 m arc: the spread of the final
        // pose matches the propagated covariance within sampling error.
        use rand::SeedableRng;
        let (sigma, length, b) = (0.03, 2.0, 0.4);
        let s = OdometrySpec {
            slip_sigma: sigma,
            slip_correlation_m: length,
            ..spec()
        };
        let (n, ds, dth) = (300usize, 0.02, 0.004);
        let mut m = OdomModel::new(&s, 0.1, b);
        let predicted = drive(&mut m, n, ds, dth).pose;
        let (sl, sr) = (ds - 0.5 * b * dth, ds + 0.5 * b * dth);
        let runs = 400;
        let mut finals = Vec::new();
        for seed in 0..runs {
            let mut slip = atrium_sim::encoders::WheelSlip::new(
                sigma,
                length,
                rand_chacha::ChaCha8Rng::seed_from_u64(seed),
            );
            let mut p = Pose2::default();
            for _ in 0..n {
                let (l, r) = (slip.read(0, sl), slip.read(1, sr));
                p = atrium_robots::DiffDrive::integrate(&p, l, r, b);
            }
            finals.push(p);
        }
        let mut exact = Pose2::default();
        for _ in 0..n {
            exact = atrium_robots::DiffDrive::integrate(&exact, sl, sr, b);
        }
        let var = |f: &dyn Fn(&Pose2) -> f64| {
            finals.iter().map(|p| f(p).powi(2)).sum::<f64>() / runs as f64
        };
        let vx = var(&|p| p.x - exact.x);
        let vy = var(&|p| p.y - exact.y);
        let vth = var(&|p| atrium_robots::normalize_angle(p.theta - exact.theta));
        for (name, got, want) in [
            ("x", vx, predicted[(0, 0)]),
            ("y", vy, predicted[(1, 1)]),
            ("theta", vth, predicted[(2, 2)]),
        ] {
            assert!(
                (got / want - 1.0).abs() < 0.2,
                "{name}: sampled variance {got}, propagated {want}"
            );
        }
    }
}
