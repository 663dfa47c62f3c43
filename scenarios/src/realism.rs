//! Sim-to-real agreement: a log scenario run on its real log and its twin run in simulation
//! once per seed, compared per localizer (median, p95, time above the convergence
//! threshold, relations) and for the dead reckoning's drift over 10 m stretches. A simulated
//! figure within 0.67–1.5 of the real one says the simulation would have given the same
//! verdict; the report says which figures are not, and the real figures below the
//! reference's accuracy are not compared (their ratio would measure the reference).

use crate::calibrate::drift::{self, DriftSummary, Paired};
use crate::runner::RunResult;
use crate::trajectory::pose_at;
use serde::Serialize;

/// Stretch length of the drift figures, m.
pub const DRIFT_STRETCH_M: f64 = 10.0;
/// The band a simulated figure must fall in, as a ratio to the real one.
pub const AGREEMENT: (f64, f64) = (0.67, 1.5);

/// One run's figures for one localizer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Figures {
    pub median: f64,
    pub p95: f64,
    pub failed_time_frac: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Spread {
    pub median: [f64; 2],
    pub p95: [f64; 2],
    pub failed_time_frac: [f64; 2],
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ratio {
    /// sim / real; `None` where the real figure is below the reference's accuracy.
    pub median: Option<f64>,
    pub p95: Option<f64>,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LocalizerRealism {
    pub name: String,
    pub real: Figures,
    /// Medians over the seeds.
    pub sim: Figures,
    /// Min and max over the seeds.
    pub sim_spread: Spread,
    pub ratio: Ratio,
    pub real_relations: Option<crate::relations::RelationsScore>,
    /// Whether every compared ratio is inside [`AGREEMENT`].
    pub agrees: bool,
}

#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DriftRealism {
    pub real: DriftSummary,
    /// Medians over the seeds.
    pub sim: DriftSummary,
    pub sim_spread: DriftSpread,
    pub ratio: DriftRatio,
    /// The fraction of the real stretches whose position drift lies within the twin's range
    /// over the seeds on the same stretch (the k-th 10 m of path in both).
    pub coverage: f64,
    /// The coverage of a twin whose seeds and the real run were draws of one process:
    /// (n − 1)/(n + 1) for n seeds. A twin whose drift does not vary between seeds covers
    /// next to nothing.
    pub coverage_expected: f64,
    /// Median, p90 and heading ratios inside [`AGREEMENT`], and coverage at least half the
    /// expected.
    pub agrees: bool,
    /// Every stretch, for histograms.
    pub real_stretches: Vec<f64>,
    pub sim_stretches: Vec<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DriftSpread {
    pub median_pct: [f64; 2],
    pub p90_pct: [f64; 2],
    pub heading_deg_per_m: [f64; 2],
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct DriftRatio {
    pub median_pct: f64,
    pub p90_pct: f64,
    pub heading_deg_per_m: f64,
}

/// The whole comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Realism {
    pub scenario: String,
    pub seeds: Vec<u64>,
    pub reference_accuracy_m: Option<f64>,
    pub localizers: Vec<LocalizerRealism>,
    pub drift: Option<DriftRealism>,
    /// Twin runs whose route was not completed (the robot stuck against the map).
    pub incomplete_sim_runs: usize,
}

/// A run's figures for the localizer `name`, `threshold` m the convergence threshold.
pub fn figures(run: &RunResult, name: &str, threshold: f64) -> Option<Figures> {
    let l = run.localizers.iter().find(|l| l.name == name)?;
    let m = l.metrics.as_ref()?;
    let failed = if l.samples.is_empty() {
        0.0
    } else {
        l.samples
            .iter()
            .filter(|s| s.position_error > threshold)
            .count() as f64
            / l.samples.len() as f64
    };
    Some(Figures {
        median: m.position_error.get("median")?,
        p95: m.position_error.get("p95")?,
        failed_time_frac: failed,
    })
}

/// Truth and the dead reckoning's estimate at the truth's stamps.
pub fn drift_pairs(run: &RunResult, dead_reckoning: &str) -> Vec<Paired> {
    let Some(l) = run.localizers.iter().find(|l| l.name == dead_reckoning) else {
        return Vec::new();
    };
    run.ground_truth
        .iter()
        .filter_map(|(t, truth)| {
            pose_at(&l.trajectory, *t, 1.0).map(|odometry| Paired {
                t: *t,
                truth: *truth,
                odometry,
            })
        })
        .collect()
}

fn median(v: &[f64]) -> f64 {
    drift::quantile(v, 0.5)
}

fn span(v: &[f64]) -> [f64; 2] {
    [
        v.iter().copied().fold(f64::INFINITY, f64::min),
        v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    ]
}

fn inside(r: f64) -> bool {
    r.is_finite() && r >= AGREEMENT.0 && r <= AGREEMENT.1
}

/// The fraction of `real` stretches that lie within the range of `per_seed` on the same
/// stretch index (stretches that not every seed reached are left out); NaN without any.
pub fn stretch_coverage(real: &[f64], per_seed: &[Vec<f64>]) -> f64 {
    let (mut inside_range, mut compared) = (0usize, 0usize);
    for (k, r) in real.iter().enumerate() {
        let at: Vec<f64> = per_seed.iter().filter_map(|s| s.get(k).copied()).collect();
        if at.len() < per_seed.len() || at.is_empty() {
            continue;
        }
        let [lo, hi] = span(&at);
        compared += 1;
        if (lo..=hi).contains(r) {
            inside_range += 1;
        }
    }
    if compared == 0 {
        f64::NAN
    } else {
        inside_range as f64 / compared as f64
    }
}

/// Compares the real run with the twin's runs (one per seed). `dead_reckoning` names the
/// localizer whose trajectory is the odometry (drift is left out without one).
pub fn compare(
    real: &RunResult,
    sims: &[RunResult],
    threshold: f64,
    reference_accuracy_m: Option<f64>,
    dead_reckoning: Option<&str>,
) -> Realism {
    let acc = reference_accuracy_m.unwrap_or(0.0);
    let mut localizers = Vec::new();
    for l in &real.localizers {
        let Some(r) = figures(real, &l.name, threshold) else {
            continue;
        };
        let per_seed: Vec<Figures> = sims
            .iter()
            .filter_map(|s| figures(s, &l.name, threshold))
            .collect();
        if per_seed.is_empty() {
            continue;
        }
        let col = |f: fn(&Figures) -> f64| per_seed.iter().map(f).collect::<Vec<_>>();
        let (med, p95, fail) = (
            col(|f| f.median),
            col(|f| f.p95),
            col(|f| f.failed_time_frac),
        );
        let sim = Figures {
            median: median(&med),
            p95: median(&p95),
            failed_time_frac: median(&fail),
        };
        let ratio_of = |s: f64, r: f64| (r > acc && r > 0.0).then(|| s / r);
        let ratio = Ratio {
            median: ratio_of(sim.median, r.median),
            p95: ratio_of(sim.p95, r.p95),
        };
        let agrees = [ratio.median, ratio.p95]
            .iter()
            .all(|x| x.is_none_or(inside));
        localizers.push(LocalizerRealism {
            name: l.name.clone(),
            real: r,
            sim,
            sim_spread: Spread {
                median: span(&med),
                p95: span(&p95),
                failed_time_frac: span(&fail),
            },
            ratio,
            real_relations: l.relations,
            agrees,
        });
    }
    let drift = dead_reckoning.and_then(|dr| {
        let real_s = drift::stretches(&drift_pairs(real, dr), DRIFT_STRETCH_M, 1.0);
        let real_sum = drift::summarize(&real_s)?;
        let mut sums = Vec::new();
        let mut sim_pct = Vec::new();
        let mut per_seed = Vec::new();
        for s in sims {
            let st = drift::stretches(&drift_pairs(s, dr), DRIFT_STRETCH_M, 1.0);
            sim_pct.extend(st.iter().map(|x| x.position_pct));
            if let Some(sum) = drift::summarize(&st) {
                sums.push(sum);
            }
            per_seed.push(st.iter().map(|x| x.position_pct).collect::<Vec<_>>());
        }
        if sums.is_empty() {
            return None;
        }
        let col = |f: fn(&DriftSummary) -> f64| sums.iter().map(f).collect::<Vec<_>>();
        let (m, p, h) = (
            col(|d| d.median_pct),
            col(|d| d.p90_pct),
            col(|d| d.heading_deg_per_m),
        );
        let sim = DriftSummary {
            median_pct: median(&m),
            p90_pct: median(&p),
            heading_deg_per_m: median(&h),
            stretches: sums.iter().map(|d| d.stretches).sum::<usize>() / sums.len(),
        };
        let ratio = DriftRatio {
            median_pct: sim.median_pct / real_sum.median_pct,
            p90_pct: sim.p90_pct / real_sum.p90_pct,
            heading_deg_per_m: sim.heading_deg_per_m / real_sum.heading_deg_per_m,
        };
        let real_pct: Vec<f64> = real_s.iter().map(|x| x.position_pct).collect();
        let coverage = stretch_coverage(&real_pct, &per_seed);
        let n = per_seed.len() as f64;
        let coverage_expected = (n - 1.0) / (n + 1.0);
        let agrees = inside(ratio.median_pct)
            && inside(ratio.p90_pct)
            && inside(ratio.heading_deg_per_m)
            && coverage >= 0.5 * coverage_expected;
        Some(DriftRealism {
            real: real_sum,
            sim,
            sim_spread: DriftSpread {
                median_pct: span(&m),
                p90_pct: span(&p),
                heading_deg_per_m: span(&h),
            },
            agrees,
            ratio,
            coverage,
            coverage_expected,
            real_stretches: real_pct,
            sim_stretches: sim_pct,
        })
    });
    Realism {
        scenario: real.scenario.clone(),
        seeds: sims.iter().map(|s| s.seed).collect(),
        reference_accuracy_m,
        localizers,
        drift,
        incomplete_sim_runs: sims.iter().filter(|s| !s.route_completed).count(),
    }
}

/// The report as text.
pub fn to_text(r: &Realism) -> String {
    use std::fmt::Write as _;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "realism of {} over seeds {:?}: real log against its simulated twin",
        r.scenario, r.seeds
    );
    if let Some(a) = r.reference_accuracy_m {
        let _ = writeln!(
            t,
            "reference accuracy {a:.3} m: real figures below it are not compared"
        );
    }
    let _ = writeln!(
        t,
        "\n{:<12} {:>22} {:>22} {:>16} {:>8}",
        "localizer", "median real/sim (ratio)", "p95 real/sim (ratio)", "failed real/sim", "agrees"
    );
    let show = |x: Option<f64>| x.map_or("  -  ".into(), |v| format!("{v:.2}"));
    for l in &r.localizers {
        let _ = writeln!(
            t,
            "{:<12} {:>7.3}/{:<7.3} ({:>5}) {:>7.3}/{:<7.3} ({:>5}) {:>7.2}/{:<7.2} {:>8}",
            l.name,
            l.real.median,
            l.sim.median,
            show(l.ratio.median),
            l.real.p95,
            l.sim.p95,
            show(l.ratio.p95),
            l.real.failed_time_frac,
            l.sim.failed_time_frac,
            if l.agrees { "yes" } else { "NO" }
        );
    }
    if let Some(d) = &r.drift {
        let _ = writeln!(
            t,
            "\ndead-reckoning drift over {DRIFT_STRETCH_M} m stretches (real / sim, ratio):\n  \
             median {:.1} % / {:.1} % ({:.2}), p90 {:.1} % / {:.1} % ({:.2}), heading {:.2} / {:.2} deg/m ({:.2}),\n  \
             real stretches within the twin's range over the seeds {:.0} % (expected {:.0} %): {}",
            d.real.median_pct,
            d.sim.median_pct,
            d.ratio.median_pct,
            d.real.p90_pct,
            d.sim.p90_pct,
            d.ratio.p90_pct,
            d.real.heading_deg_per_m,
            d.sim.heading_deg_per_m,
            d.ratio.heading_deg_per_m,
            100.0 * d.coverage,
            100.0 * d.coverage_expected,
            if d.agrees { "agrees" } else { "DOES NOT AGREE" }
        );
    }
    if r.incomplete_sim_runs > 0 {
        let _ = writeln!(
            t,
            "\n{} twin runs did not complete their route",
            r.incomplete_sim_runs
        );
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_counts_real_stretches_inside_the_seeds_range() {
        let real = [5.0, 9.0, 1.0, 4.0];
        let seeds = vec![vec![4.0, 6.0, 2.0, 3.0], vec![6.0, 8.0, 3.0]];
        // Stretch 0 inside [4, 6], 1 outside [6, 8], 2 outside [2, 3]; 3 not reached by
        // every seed.
        assert!((stretch_coverage(&real, &seeds) - 1.0 / 3.0).abs() < 1e-12);
        // Seeds that all drift alike cover nothing that differs from them.
        let same = vec![vec![4.0, 4.0, 4.0]; 10];
        assert_eq!(stretch_coverage(&[5.0, 3.0, 4.5], &same), 0.0);
        assert!(stretch_coverage(&real, &[]).is_nan());
    }
}
