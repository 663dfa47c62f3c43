//! The wheel odometry's error model estimated from a log's odometry against its reference,
//! in the terms of [`atrium_robots::OdometrySpec`] for a robot of wheel track `b`:
//!
//! * systematic errors ([Borenstein 1996]'s E_s, E_d, E_b): over short segments of the path,
//!   the odometry's forward distance against the reference's gives the scale error
//!   (d_odo = (1 + s)·d); its heading change minus the reference's, regressed on the distance
//!   driven and the angle turned (Δθ_odo − Δθ = k_d·d + k_θ·Δθ), gives the radius error
//!   (a wheel pair of radii r(1 + s)(1 ± e/2) turns the odometry by −(1 + s)·e·d/(b(1 + e_b))
//!   per metre) and the track error (Δθ_odo = Δθ·(1 + s)/(1 + e_b));
//! * random slip per wheel (`slip_sigma`, `slip_correlation_m`): what the systematic part
//!   leaves, summed over windows of increasing wheel travel D, has a variance that grows as
//!   the integral of the two wheels' Gauss–Markov errors predicts,
//!   Var(D) = 2σ²L²·(D/L − 1 + e^(−D/L))·w + c, with w = 2/b² for the heading and 1/2 for the
//!   distance, and c the reference's own noise. σ and L are the least-squares fit of that
//!   curve to the measured variances over D from 0.5 to 40 m (a method of moments over
//!   scales, as an Allan-variance analysis reads a gyro's noise).
//!
//! Each estimate's standard error comes from a moving-block bootstrap: the segments are
//! resampled in blocks of 10 m of path (so that the slip's correlation survives) and the
//! whole fit repeated. Nothing here knows which log it reads: every number is fitted.

use super::drift::Paired;
use atrium_robots::{normalize_angle, Pose2};
use rand::{Rng, SeedableRng};
use serde::Serialize;

/// A segment ends when the reference has moved this far (m) or turned this much (rad).
pub const SEGMENT_M: f64 = 0.25;
pub const SEGMENT_RAD: f64 = 0.15;
/// Window lengths of wheel travel over which residual variances are measured, m.
pub const WINDOWS_M: [f64; 8] = [0.5, 1.0, 2.0, 4.0, 7.0, 10.0, 20.0, 40.0];
/// Bootstrap resamples and block length (m of path).
pub const BOOTSTRAP: usize = 60;
pub const BLOCK_M: f64 = 10.0;

/// One segment: the reference's and the odometry's motion over it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Segment {
    /// Forward distance (signed) and heading change of the reference and the odometry.
    d: f64,
    th: f64,
    d_odo: f64,
    th_odo: f64,
}

/// The fitted model with the standard error of each figure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OdometryFit {
    pub scale_error: f64,
    pub radius_error: f64,
    pub separation_error: f64,
    pub slip_sigma: f64,
    pub slip_correlation_m: f64,
    /// Variance of the reference's own heading noise absorbed by the fit, rad².
    pub reference_heading_var: f64,
    pub stderr: OdometryStderr,
    pub segments: usize,
    pub path_m: f64,
    /// The wheel track the errors are expressed for, m.
    pub track_m: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct OdometryStderr {
    pub scale_error: f64,
    pub radius_error: f64,
    pub separation_error: f64,
    pub slip_sigma: f64,
    pub slip_correlation_m: f64,
}

/// Cuts `samples` (time order) into segments; a gap over `max_gap_s` starts afresh.
fn segments(samples: &[Paired], max_gap_s: f64) -> Vec<Segment> {
    let mut out = Vec::new();
    let mut a = 0;
    for k in 1..samples.len() {
        if samples[k].t - samples[k - 1].t > max_gap_s {
            a = k;
            continue;
        }
        let truth = samples[a].truth.between(&samples[k].truth);
        if truth.x.hypot(truth.y) >= SEGMENT_M || truth.theta.abs() >= SEGMENT_RAD {
            let odo = samples[a].odometry.between(&samples[k].odometry);
            out.push(Segment {
                d: truth.x,
                th: truth.theta,
                d_odo: odo.x,
                th_odo: odo.theta,
            });
            a = k;
        }
    }
    out
}

/// Systematic part: (s, k_d, k_θ) by least squares.
fn systematic(segs: &[Segment]) -> Option<(f64, f64, f64)> {
    let (mut sdd, mut sdo) = (0.0, 0.0);
    let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for g in segs {
        sdd += g.d * g.d;
        sdo += g.d * g.d_odo;
        let r = normalize_angle(g.th_odo - g.th);
        a11 += g.d * g.d;
        a12 += g.d * g.th;
        a22 += g.th * g.th;
        b1 += g.d * r;
        b2 += g.th * r;
    }
    let det = a11 * a22 - a12 * a12;
    if sdd <= 0.0 || det.abs() < 1e-12 {
        return None;
    }
    Some((
        sdo / sdd - 1.0,
        (b1 * a22 - b2 * a12) / det,
        (a11 * b2 - a12 * b1) / det,
    ))
}

/// g(x) = x − 1 + e^(−x), the integrated Gauss–Markov variance shape (x = D/L).
fn shape(x: f64) -> f64 {
    if x < 1e-4 {
        0.5 * x * x
    } else {
        x - 1.0 + (-x).exp()
    }
}

/// Variances of the heading and distance residuals summed over windows of wheel travel D.
fn window_variances(segs: &[Segment], sys: (f64, f64, f64), track: f64) -> Vec<(f64, f64, f64)> {
    let (s, kd, kt) = sys;
    let mut out = Vec::new();
    for &w in &WINDOWS_M {
        let (mut acc_th, mut acc_d, mut travel) = (0.0, 0.0, 0.0);
        let (mut sum_th, mut sum_d, mut n, mut sum_travel) = (0.0, 0.0, 0usize, 0.0);
        for g in segs {
            acc_th += normalize_angle(g.th_odo - g.th) - kd * g.d - kt * g.th;
            acc_d += g.d_odo - (1.0 + s) * g.d;
            travel += g.d.abs() + 0.5 * track * g.th.abs();
            if travel >= w {
                sum_th += acc_th * acc_th;
                sum_d += acc_d * acc_d;
                sum_travel += travel;
                n += 1;
                (acc_th, acc_d, travel) = (0.0, 0.0, 0.0);
            }
        }
        if n >= 5 {
            out.push((sum_travel / n as f64, sum_th / n as f64, sum_d / n as f64));
        }
    }
    out
}

/// σ, L and the reference's heading variance c fitted to the window variances (relative
/// least squares, L on a log grid, σ² and c ≥ 0 in closed form for each L).
fn random_part(vars: &[(f64, f64, f64)], track: f64) -> Option<(f64, f64, f64)> {
    if vars.len() < 3 {
        return None;
    }
    let w_th = 2.0 / (track * track);
    let mut best: Option<(f64, f64, f64, f64)> = None;
    for k in 0..=80 {
        let l = 0.05 * 10f64.powf(k as f64 / 20.0); // 0.05 m .. 500 m
                                                    // Rows: heading (a·w_th·G + c) and distance (a·G/2), each divided by its measured
                                                    // variance so that every scale counts alike.
        let mut rows: Vec<([f64; 2], f64)> = Vec::new();
        for &(d, v_th, v_d) in vars {
            let g = 2.0 * l * l * shape(d / l);
            if v_th > 0.0 {
                rows.push(([w_th * g / v_th, 1.0 / v_th], 1.0));
            }
            if v_d > 0.0 {
                rows.push(([0.5 * g / v_d, 0.0], 1.0));
            }
        }
        // 2×2 normal equations, then clamp to the non-negative quadrant.
        let (mut a11, mut a12, mut a22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for (x, y) in &rows {
            a11 += x[0] * x[0];
            a12 += x[0] * x[1];
            a22 += x[1] * x[1];
            b1 += x[0] * y;
            b2 += x[1] * y;
        }
        let det = a11 * a22 - a12 * a12;
        let (mut a, mut c) = if det.abs() > 1e-300 {
            ((b1 * a22 - b2 * a12) / det, (a11 * b2 - a12 * b1) / det)
        } else {
            (b1 / a11, 0.0)
        };
        if c < 0.0 {
            c = 0.0;
            a = b1 / a11;
        }
        if a < 0.0 {
            a = 0.0;
            c = if a22 > 0.0 { b2 / a22 } else { 0.0 }.max(0.0);
        }
        let cost: f64 = rows
            .iter()
            .map(|(x, y)| (x[0] * a + x[1] * c - y).powi(2))
            .sum();
        if best.is_none_or(|b| cost < b.0) {
            best = Some((cost, a.sqrt(), l, c));
        }
    }
    best.map(|(_, sigma, l, c)| (sigma, l, c))
}

fn fit_segments(segs: &[Segment], track: f64) -> Option<[f64; 6]> {
    let sys = systematic(segs)?;
    let (sigma, l, c) = random_part(&window_variances(segs, sys, track), track)?;
    let (s, kd, kt) = sys;
    // The scale error scales turns too: Δθ_odo = Δθ·(1 + s)/(1 + e_b), and the radius
    // split's heading per metre is −(1 + s)·e/(b·(1 + e_b)).
    let eb = (1.0 + s) / (1.0 + kt) - 1.0;
    let e = -kd * track * (1.0 + eb) / (1.0 + s);
    Some([s, e, eb, sigma, l, c])
}

fn std_dev(v: &[f64]) -> f64 {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt()
}

/// Fits the odometry model to `samples` (truth = reference, time order) for a robot of wheel
/// track `track_m`; gaps over `max_gap_s` are not bridged. Errors say what is missing.
pub fn fit_odometry(
    samples: &[Paired],
    track_m: f64,
    max_gap_s: f64,
) -> Result<OdometryFit, String> {
    if !(track_m.is_finite() && track_m > 0.0) {
        return Err(format!(
            "the wheel track must be a positive length, got {track_m}"
        ));
    }
    if let Some(p) = samples
        .iter()
        .find(|p| !(p.truth.is_finite() && p.odometry.is_finite() && p.t.is_finite()))
    {
        return Err(format!("a sample is not finite: {p:?}"));
    }
    let segs = segments(samples, max_gap_s);
    let path: f64 = segs.iter().map(|g| g.d.abs()).sum();
    if segs.len() < 50 || path < 2.0 * WINDOWS_M[5] {
        return Err(format!(
            "{} segments over {path:.1} m of path: at least 50 segments and {} m are needed to \
             fit the odometry",
            segs.len(),
            2.0 * WINDOWS_M[5]
        ));
    }
    let p = fit_segments(&segs, track_m)
        .ok_or("the odometry's errors cannot be separated (no turns, or no straight driving)")?;
    // Moving-block bootstrap over blocks of BLOCK_M of path.
    let mut blocks: Vec<std::ops::Range<usize>> = Vec::new();
    let (mut start, mut len) = (0, 0.0);
    for (k, g) in segs.iter().enumerate() {
        len += g.d.abs();
        if len >= BLOCK_M {
            blocks.push(start..k + 1);
            (start, len) = (k + 1, 0.0);
        }
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x0d0);
    let mut draws: Vec<[f64; 6]> = Vec::with_capacity(BOOTSTRAP);
    if blocks.len() >= 4 {
        for _ in 0..BOOTSTRAP {
            let mut resampled = Vec::with_capacity(segs.len());
            for _ in 0..blocks.len() {
                let b = &blocks[rng.random_range(0..blocks.len())];
                resampled.extend_from_slice(&segs[b.clone()]);
            }
            if let Some(q) = fit_segments(&resampled, track_m) {
                draws.push(q);
            }
        }
    }
    let se = |i: usize| {
        if draws.len() < 2 {
            f64::NAN
        } else {
            std_dev(&draws.iter().map(|q| q[i]).collect::<Vec<_>>())
        }
    };
    Ok(OdometryFit {
        scale_error: p[0],
        radius_error: p[1],
        separation_error: p[2],
        slip_sigma: p[3],
        slip_correlation_m: p[4],
        reference_heading_var: p[5],
        stderr: OdometryStderr {
            scale_error: se(0),
            radius_error: se(1),
            separation_error: se(2),
            slip_sigma: se(3),
            slip_correlation_m: se(4),
        },
        segments: segs.len(),
        path_m: path,
        track_m,
    })
}

/// Truth and odometry at the reference's stamps, for a log: `odometry_at(t)` gives the log's
/// odometry pose at any instant.
pub fn paired_from(reference: &[(f64, Pose2)], odometry_at: impl Fn(f64) -> Pose2) -> Vec<Paired> {
    reference
        .iter()
        .map(|(t, p)| Paired {
            t: *t,
            truth: *p,
            odometry: odometry_at(*t),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_distr::StandardNormal;

    /// A synthetic drive (straights and turns) with a known odometry error — systematic and
    /// Gauss–Markov wheel slip — integrated as the simulator does: the fit recovers it.
    #[test]
    fn recovers_a_known_odometry_model() {
        let (track, s, e, eb, sigma, l) = (0.4, 0.02, 0.01, 0.03, 0.02, 3.0);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut slip = [0.0f64; 2];
        let (mut truth, mut odo) = (Pose2::default(), Pose2::default());
        let mut samples = vec![Paired {
            t: 0.0,
            truth,
            odometry: odo,
        }];
        let step = 0.02;
        let mut t = 0.0;
        for k in 0..120_000 {
            // 8 m straight, then a turn in place of ±90° (about 0.9 m of wheel travel).
            let phase = k % 560;
            let (dl, dr) = if phase < 400 {
                (step, step)
            } else {
                let turn = if (k / 560) % 3 == 0 { -1.0 } else { 1.0 };
                (-turn * step * 0.5, turn * step * 0.5)
            };
            truth = atrium_robots::DiffDrive::integrate(&truth, dl, dr, track);
            let mut read = [
                dl * (1.0 + s) * (1.0 + e / 2.0),
                dr * (1.0 + s) * (1.0 - e / 2.0),
            ];
            for (w, d) in [dl, dr].iter().enumerate() {
                let rho = (-d.abs() / l).exp();
                let n: f64 = rng.sample(StandardNormal);
                slip[w] = rho * slip[w] + sigma * (1.0 - rho * rho).sqrt() * n;
                read[w] *= 1.0 + slip[w];
            }
            odo = atrium_robots::DiffDrive::integrate(&odo, read[0], read[1], track * (1.0 + eb));
            t += 0.05;
            if k % 5 == 0 {
                samples.push(Paired {
                    t,
                    truth,
                    odometry: odo,
                });
            }
        }
        let f = fit_odometry(&samples, track, 1.0).unwrap();
        assert!((f.scale_error - s).abs() < 0.005, "{f:?}");
        assert!((f.radius_error - e).abs() < 0.005, "{f:?}");
        assert!((f.separation_error - eb).abs() < 0.01, "{f:?}");
        assert!((f.slip_sigma / sigma - 1.0).abs() < 0.35, "{f:?}");
        assert!(
            f.slip_correlation_m > l / 3.0 && f.slip_correlation_m < l * 3.0,
            "{f:?}"
        );
        assert!(
            f.stderr.scale_error.is_finite() && f.stderr.slip_sigma > 0.0,
            "{f:?}"
        );
    }

    #[test]
    fn too_little_data_is_refused() {
        let samples: Vec<Paired> = (0..10)
            .map(|k| Paired {
                t: k as f64,
                truth: Pose2::new(k as f64 * 0.3, 0.0, 0.0),
                odometry: Pose2::new(k as f64 * 0.3, 0.0, 0.0),
            })
            .collect();
        let e = fit_odometry(&samples, 0.4, 1.0).unwrap_err();
        assert!(e.contains("segments"), "{e}");
        assert!(fit_odometry(&samples, f64::NAN, 1.0).is_err());
    }
}
