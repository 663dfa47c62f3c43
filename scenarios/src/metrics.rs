//! Scoring estimates against ground truth.

use serde::Serialize;
use std::collections::BTreeMap;

/// One scored instant: where the robot was, what the localizer believed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub t: f64,
    pub position_error: f64,
    pub heading_error: f64,
    /// Normalised estimation error squared over (x, y), when the covariance is usable.
    pub nees_xy: Option<f64>,
}

/// Summary statistics of a set of errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ErrorStats {
    pub samples: usize,
    pub min: f64,
    pub median: f64,
    pub mean: f64,
    pub rmse: f64,
    pub p95: f64,
    pub max: f64,
}

/// Linear interpolation between order statistics (type 7, as numpy's default).
pub fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    if n == 0 {
        return f64::NAN;
    }
    let pos = q.clamp(0.0, 1.0) * (n - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    let frac = pos - lo as f64;
    sorted[lo] + (sorted[hi] - sorted[lo]) * frac
}

impl ErrorStats {
    /// `None` for an empty set.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<ErrorStats> {
        let mut v: Vec<f64> = values.into_iter().collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let n = v.len() as f64;
        let sum: f64 = v.iter().sum();
        let sum_sq: f64 = v.iter().map(|e| e * e).sum();
        Some(ErrorStats {
            samples: v.len(),
            min: v[0],
            median: quantile_sorted(&v, 0.5),
            mean: sum / n,
            rmse: (sum_sq / n).sqrt(),
            p95: quantile_sorted(&v, 0.95),
            max: v[v.len() - 1],
        })
    }

    /// The statistic called `name` (`min`, `median`, `mean`, `rmse`, `p95`, `max`).
    pub fn get(&self, name: &str) -> Option<f64> {
        Some(match name {
            "min" => self.min,
            "median" => self.median,
            "mean" => self.mean,
            "rmse" => self.rmse,
            "p95" => self.p95,
            "max" => self.max,
            _ => return None,
        })
    }
}

/// When the run converged, scanned from `from_t` on: the first instant from which the error
/// stays at or below `threshold` for at least `hold_s` and afterwards never exceeds it for
/// longer than `hold_s`. `None` if there is no such instant: a stretch below the threshold
/// that is shorter than the hold (also at the very end of the run) does not count, and a
/// later excursion longer than the hold undoes an earlier convergence (dead reckoning is
/// below the threshold for its first seconds, then drifts off for good: it never converged).
pub fn converged_after(
    samples: &[Sample],
    threshold: f64,
    hold_s: f64,
    from_t: f64,
) -> Option<f64> {
    let mut converged: Option<f64> = None;
    let mut below_since: Option<f64> = None;
    let mut above_since: Option<f64> = None;
    for s in samples.iter().filter(|s| s.t >= from_t) {
        // NaN counts as above: an estimate that is not a number has not converged.
        if s.position_error <= threshold {
            above_since = None;
            let t0 = *below_since.get_or_insert(s.t);
            if converged.is_none() && s.t - t0 >= hold_s {
                converged = Some(t0);
            }
        } else {
            below_since = None;
            let t0 = *above_since.get_or_insert(s.t);
            if s.t - t0 > hold_s {
                converged = None;
            }
        }
    }
    converged
}

/// Everything measured for one localizer over one run.
#[derive(Debug, Clone, Serialize)]
pub struct LocalizerMetrics {
    pub position_error: ErrorStats,
    pub heading_error: ErrorStats,
    pub final_position_error: f64,
    /// Error statistics per named region of the world, for the samples taken there.
    pub per_region: BTreeMap<String, ErrorStats>,
    /// The same grouped by region kind (`corridor`, `atrium`, ...), plus `outside` for samples
    /// in no region.
    pub per_region_kind: BTreeMap<String, ErrorStats>,
    pub converged_after_s: Option<f64>,
    /// Statistics of the samples from convergence on.
    pub after_convergence: Option<ErrorStats>,
    /// Mean NEES over (x, y): 2 for a consistent filter.
    pub mean_nees_xy: Option<f64>,
    /// A chooser's share of the scored instants at which each member's estimate was its
    /// output (members never chosen are left out); empty for every other localizer.
    pub chosen: BTreeMap<String, f64>,
}

/// Scores one localizer's samples; `regions[i]` is the (name, kind) of the region sample `i`
/// was taken in.
pub fn score(
    samples: &[Sample],
    regions: &[Option<(String, String)>],
    converge_threshold: f64,
    converge_hold_s: f64,
) -> Option<LocalizerMetrics> {
    let position_error = ErrorStats::of(samples.iter().map(|s| s.position_error))?;
    let heading_error = ErrorStats::of(samples.iter().map(|s| s.heading_error))?;
    let mut by_name: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut by_kind: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for (s, r) in samples.iter().zip(regions) {
        match r {
            Some((name, kind)) => {
                by_name
                    .entry(name.clone())
                    .or_default()
                    .push(s.position_error);
                by_kind
                    .entry(kind.clone())
                    .or_default()
                    .push(s.position_error);
            }
            None => by_kind
                .entry("outside".into())
                .or_default()
                .push(s.position_error),
        }
    }
    let collect = |m: BTreeMap<String, Vec<f64>>| {
        m.into_iter()
            .filter_map(|(k, v)| ErrorStats::of(v).map(|s| (k, s)))
            .collect::<BTreeMap<_, _>>()
    };
    let converged_after_s = converged_after(
        samples,
        converge_threshold,
        converge_hold_s,
        f64::NEG_INFINITY,
    );
    let after_convergence = converged_after_s.and_then(|t0| {
        ErrorStats::of(
            samples
                .iter()
                .filter(|s| s.t >= t0)
                .map(|s| s.position_error),
        )
    });
    let nees: Vec<f64> = samples.iter().filter_map(|s| s.nees_xy).collect();
    let mean_nees_xy = (!nees.is_empty()).then(|| nees.iter().sum::<f64>() / nees.len() as f64);
    Some(LocalizerMetrics {
        position_error,
        heading_error,
        final_position_error: samples.last().map(|s| s.position_error).unwrap_or(f64::NAN),
        per_region: collect(by_name),
        per_region_kind: collect(by_kind),
        converged_after_s,
        after_convergence,
        mean_nees_xy,
        chosen: BTreeMap::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn samples(errors: &[f64]) -> Vec<Sample> {
        errors
            .iter()
            .enumerate()
            .map(|(i, &e)| Sample {
                t: i as f64,
                position_error: e,
                heading_error: 0.0,
                nees_xy: None,
            })
            .collect()
    }

    #[test]
    fn stats_match_hand_computed_values() {
        let s = ErrorStats::of([3.0, 1.0, 2.0, 4.0]).unwrap();
        assert_eq!(s.min, 1.0);
        assert_eq!(s.max, 4.0);
        assert!((s.median - 2.5).abs() < 1e-12);
        assert!((s.rmse - (30.0f64 / 4.0).sqrt()).abs() < 1e-12);
        // p95 of 1..4: position 0.95 * 3 = 2.85 -> 3 + 0.85.
        assert!((s.p95 - 3.85).abs() < 1e-12);
        assert!(ErrorStats::of(std::iter::empty()).is_none());
    }

    #[test]
    fn convergence_needs_the_hold_time() {
        let s = samples(&[2.0, 0.1, 0.5, 0.1, 0.1, 0.1, 0.1]);
        // Below 0.3 from t = 3 on, held for 3 s.
        assert_eq!(converged_after(&s, 0.3, 2.0, 0.0), Some(3.0));
        assert_eq!(converged_after(&samples(&[1.0, 1.0]), 0.3, 2.0, 0.0), None);
        // Below at the end but shorter than the hold: not converged.
        assert_eq!(converged_after(&samples(&[1.0, 0.1]), 0.3, 2.0, 0.0), None);
        assert_eq!(
            converged_after(&samples(&[1.0, 0.1, 0.1, 0.1]), 0.3, 2.0, 0.0),
            Some(1.0)
        );
    }

    #[test]
    fn a_later_long_excursion_undoes_convergence() {
        // Dead reckoning: below for the first seconds, then off for good.
        let drift = samples(&[0.0, 0.1, 0.2, 0.25, 0.4, 0.8, 1.5, 3.0, 6.0]);
        assert_eq!(converged_after(&drift, 0.3, 2.0, 0.0), None);
        // A 2 s excursion (not longer than the hold) keeps it; 3 s undoes it, and the
        // stretch after it converges anew.
        let brief = samples(&[0.1, 0.1, 0.1, 0.9, 0.9, 0.9, 0.1, 0.1]);
        assert_eq!(converged_after(&brief, 0.3, 2.0, 0.0), Some(0.0));
        let long = samples(&[0.1, 0.1, 0.1, 0.9, 0.9, 0.9, 0.9, 0.1, 0.1, 0.1]);
        assert_eq!(converged_after(&long, 0.3, 2.0, 0.0), Some(7.0));
        // NaN errors are never converged.
        let nan = samples(&[0.1, 0.1, 0.1, f64::NAN, f64::NAN, f64::NAN, f64::NAN]);
        assert_eq!(converged_after(&nan, 0.3, 2.0, 0.0), None);
        // Scanning starts at `from_t` (recovery after an event).
        assert_eq!(converged_after(&long, 0.3, 2.0, 4.0), Some(7.0));
    }

    #[test]
    fn per_region_groups_by_name_and_kind() {
        let s = samples(&[0.1, 0.2, 3.0]);
        let regions = vec![
            Some(("c1".to_string(), "corridor".to_string())),
            Some(("c2".to_string(), "corridor".to_string())),
            None,
        ];
        let m = score(&s, &regions, 0.3, 0.0).unwrap();
        assert_eq!(m.per_region.len(), 2);
        assert_eq!(m.per_region_kind["corridor"].samples, 2);
        assert_eq!(m.per_region_kind["outside"].max, 3.0);
        assert_eq!(m.final_position_error, 3.0);
    }
}
