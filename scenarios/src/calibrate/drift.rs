//! Dead-reckoning drift over stretches of the path: the odometry's motion over each
//! successive stretch of `length` m of the true path compared with the true motion, as the
//! end-point error in % of the stretch and the heading error in °/m. The same figures for a
//! real log (odometry against its reference) and a simulated run (odometry against ground
//! truth) are what tells whether the simulated odometry drifts like the real one.

use atrium_robots::{normalize_angle, Pose2};
use serde::Serialize;

/// Truth and odometry at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Paired {
    pub t: f64,
    pub truth: Pose2,
    pub odometry: Pose2,
}

/// One stretch's drift.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct StretchDrift {
    pub start_s: f64,
    pub distance_m: f64,
    /// |odometry's end point − truth's|, both relative to the stretch's start, % of distance.
    pub position_pct: f64,
    /// |odometry's heading change − truth's| / distance, °/m.
    pub heading_deg_per_m: f64,
}

/// Median and 90th percentile of the stretches' drift.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DriftSummary {
    pub median_pct: f64,
    pub p90_pct: f64,
    /// Median heading drift, °/m.
    pub heading_deg_per_m: f64,
    pub stretches: usize,
}

/// The stretches of `samples` (time order), each ending at the first sample where the true
/// path since its start reaches `length` m. A gap longer than `max_gap_s` between samples
/// ends the current stretch unfinished (it is dropped): the motion across it is not known.
pub fn stretches(samples: &[Paired], length: f64, max_gap_s: f64) -> Vec<StretchDrift> {
    let mut out = Vec::new();
    let mut start = 0;
    let mut path = 0.0;
    for k in 1..samples.len() {
        if samples[k].t - samples[k - 1].t > max_gap_s {
            start = k;
            path = 0.0;
            continue;
        }
        path += samples[k - 1].truth.distance(&samples[k].truth);
        if path >= length {
            let (a, b) = (&samples[start], &samples[k]);
            let truth = a.truth.between(&b.truth);
            let odo = a.odometry.between(&b.odometry);
            out.push(StretchDrift {
                start_s: a.t,
                distance_m: path,
                position_pct: 100.0 * (odo.x - truth.x).hypot(odo.y - truth.y) / path,
                heading_deg_per_m: normalize_angle(odo.theta - truth.theta).abs().to_degrees()
                    / path,
            });
            start = k;
            path = 0.0;
        }
    }
    out
}

/// The value below which a fraction `q` of `v` lies (linear interpolation; `v` unsorted).
pub fn quantile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let x = q.clamp(0.0, 1.0) * (s.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x.fract());
    if i + 1 < s.len() {
        s[i] * (1.0 - f) + s[i + 1] * f
    } else {
        s[i]
    }
}

/// Median and p90 of position drift, median heading drift; `None` without a stretch.
pub fn summarize(stretches: &[StretchDrift]) -> Option<DriftSummary> {
    if stretches.is_empty() {
        return None;
    }
    let pos: Vec<f64> = stretches.iter().map(|s| s.position_pct).collect();
    let head: Vec<f64> = stretches.iter().map(|s| s.heading_deg_per_m).collect();
    Some(DriftSummary {
        median_pct: quantile(&pos, 0.5),
        p90_pct: quantile(&pos, 0.9),
        heading_deg_per_m: quantile(&head, 0.5),
        stretches: stretches.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight 30 m drive whose odometry reads 10 % long: three 10 m stretches, each 10 %
    /// off, no heading drift; a gap drops the stretch it interrupts.
    #[test]
    fn a_scaled_odometry_drifts_by_its_scale() {
        let samples: Vec<Paired> = (0..=300)
            .map(|k| {
                let x = k as f64 * 0.1;
                Paired {
                    t: k as f64,
                    truth: Pose2::new(x, 0.0, 0.0),
                    odometry: Pose2::new(1.1 * x, 0.0, 0.0),
                }
            })
            .collect();
        let s = stretches(&samples, 10.0, 5.0);
        assert_eq!(s.len(), 3);
        for d in &s {
            assert!((d.position_pct - 10.0).abs() < 1e-6, "{d:?}");
            assert_eq!(d.heading_deg_per_m, 0.0);
        }
        let mut gappy = samples.clone();
        for p in gappy.iter_mut().skip(150) {
            p.t += 100.0;
        }
        assert_eq!(stretches(&gappy, 10.0, 5.0).len(), 2);
        let sum = summarize(&s).unwrap();
        assert!((sum.median_pct - 10.0).abs() < 1e-6 && (sum.p90_pct - 10.0).abs() < 1e-6);
    }

    #[test]
    fn quantiles_interpolate() {
        assert_eq!(quantile(&[3.0, 1.0, 2.0], 0.5), 2.0);
        assert!((quantile(&[0.0, 10.0], 0.9) - 9.0).abs() < 1e-12);
        assert!(quantile(&[], 0.5).is_nan());
    }
}
