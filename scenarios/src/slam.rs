//! What a run reports for an EKF-SLAM localizer (`kind = "ekf_slam"`): the map against the
//! world's pillars, the covariance monitor's verdict ([003] §2.2,
//! eq. 12–13), its min / mean / max inter-cluster history, the filter's input problems, and
//! the snapshots the pictures are drawn from; plus the `[expect.<localizer>.slam]` checks.
//!
//! ```toml
//! [expect.ekf.slam]
//! violations_max = 0            # pairs × updates whose P_d grew (0: the monitor is silent)
//! flagged_within_s = 60         # the first violation came this early (faulty runs)
//! false_alarm_pairs_max = 0     # violating pairs with no fault-injected feature
//! faulty_missed_max = 0         # fault-injected features the monitor did not implicate
//! wrongly_implicated_max = 0    # implicated features that were not fault-injected
//! min_increases_max = 0         # times a cluster pair's minimum grew (fixed membership)
//! mean_ratio_max = 0.5          # final / first mean inter-cluster value, worst cluster pair
//! mean_growth_min = 2           # last / first picture frame's mean inter-cluster value,
//!                               # largest over cluster pairs (faulty runs: [003] §4, Fig. 8)
//! max_growth_min = 2            # the same for the maximum
//! features_min = 15             # features mapped
//! features_max = 15
//! feature_error_max = 0.05      # largest distance of a mapped feature to its pillar, m
//! issues_max = 0                # bad inputs the filter skipped
//! nees_chi2_fraction_min = 0.9  # share of scored (x, y) NEES inside the 95 % χ²(2) interval
//! ```

use crate::error::ScenarioError;
use crate::metrics::Sample;
use crate::scenario::Scenario;
use crate::verdict::{Bound, ExpectationResult};
use atrium_localization::covariance_monitor::{MonitorReport, MonitorStep};
use atrium_localization::ekf_slam::{EkfSlam, SlamIssues, SlamSnapshot};
use atrium_localization::Localizer;
use serde::Serialize;

/// Two-sided 95 % interval of a χ² variable with 2 degrees of freedom: −2 ln(0.975) and
/// −2 ln(0.025) (the χ²(2) CDF is 1 − e^(−x/2)).
pub const CHI2_2_95: (f64, f64) = (0.050_635_615_968_579_8, 7.377_758_908_227_871);

/// Two-sided 95 % interval of the mean of `m` independent χ²(2) NEES values, i.e. of
/// χ²(2m) / m (Bar-Shalom et al., Estimation with Applications to Tracking, §5.4), from the
/// Wilson–Hilferty approximation (within 0.5 % of tables for 2m ≥ 10).
pub fn mean_nees_bounds(m: usize) -> (f64, f64) {
    let k = 2.0 * m as f64;
    let quantile = |z: f64| {
        let a = 2.0 / (9.0 * k);
        k * (1.0 - a + z * a.sqrt()).powi(3)
    };
    (
        quantile(-1.959_964) / m as f64,
        quantile(1.959_964) / m as f64,
    )
}

/// One mapped feature and the pillar it stands for.
#[derive(Debug, Clone, Serialize)]
pub struct MappedFeature {
    pub index: usize,
    /// Detector id (the pillar's index) when association was known.
    pub id: Option<usize>,
    pub position: [f64; 2],
    /// Marginal covariance [[xx, xy], [xy, yy]], m².
    pub covariance: [[f64; 2]; 2],
    /// The pillar: by id, or the nearest one when ids were unknown.
    pub pillar: Option<usize>,
    pub error: Option<f64>,
    pub faulty: bool,
}

/// Everything a run keeps of an EKF-SLAM localizer.
#[derive(Debug, Clone, Serialize)]
pub struct SlamRun {
    pub updates: u64,
    pub features: Vec<MappedFeature>,
    pub fault_features: Vec<usize>,
    pub monitor: MonitorReport,
    pub min_intercluster_increases: usize,
    pub mean_intercluster_ratio: Option<f64>,
    /// The min / mean / max pictures' growth ([003] §4, Fig. 5 vs 8): per cluster pair with the
    /// same membership in the first and the last picture frame (`frames_s`, then the final
    /// state), last-frame value / first-frame value, largest over those cluster pairs. Below
    /// 1 the ellipses shrank (correct filter); None with a single frame.
    pub frame_mean_growth: Option<f64>,
    pub frame_max_growth: Option<f64>,
    pub issues: SlamIssues,
    pub cluster_distance: f64,
    #[serde(skip)]
    pub history: Vec<MonitorStep>,
    #[serde(skip)]
    pub snapshots: Vec<SlamSnapshot>,
}

impl SlamRun {
    /// The report of `localizer` if it is an [`EkfSlam`]; pillars come from the scenario's
    /// world.
    pub fn of(localizer: &mut dyn Localizer, scenario: &Scenario) -> Option<SlamRun> {
        let slam = localizer
            .capabilities()?
            .as_any()?
            .downcast_ref::<EkfSlam>()?;
        let pillars = &scenario.world.pillars;
        let p = slam.covariance();
        let features = (0..slam.feature_count())
            .map(|k| {
                let position = slam.feature(k);
                let id = slam.feature_id(k);
                let pillar = match id {
                    Some(i) if i < pillars.len() => Some(i),
                    Some(_) => None,
                    None => pillars
                        .iter()
                        .enumerate()
                        .min_by(|a, b| {
                            let da = dist(a.1.center, position);
                            let db = dist(b.1.center, position);
                            da.total_cmp(&db)
                        })
                        .map(|(i, _)| i),
                };
                let (a, b) = (3 + 2 * k, 4 + 2 * k);
                MappedFeature {
                    index: k,
                    id,
                    position,
                    covariance: [[p[(a, a)], p[(a, b)]], [p[(b, a)], p[(b, b)]]],
                    pillar,
                    error: pillar.map(|i| dist(pillars[i].center, position)),
                    faulty: slam.params().fault_features.contains(&k),
                }
            })
            .collect();
        let history = slam.monitor().history();
        let snapshots = slam.snapshots();
        let (frame_mean_growth, frame_max_growth) = frame_growth(history, &snapshots);
        Some(SlamRun {
            updates: slam.updates(),
            features,
            fault_features: slam.params().fault_features.clone(),
            monitor: slam.monitor().report(),
            min_intercluster_increases: slam.monitor().min_intercluster_increases(),
            mean_intercluster_ratio: slam.monitor().mean_intercluster_ratio(),
            frame_mean_growth,
            frame_max_growth,
            issues: slam.issues().clone(),
            cluster_distance: slam.monitor().params().cluster_distance,
            history: history.to_vec(),
            snapshots,
        })
    }

    /// Violating pairs that involve no fault-injected feature.
    pub fn false_alarm_pairs(&self) -> usize {
        self.monitor
            .violating_pairs
            .iter()
            .filter(|p| !self.fault_features.contains(&p.i) && !self.fault_features.contains(&p.j))
            .count()
    }

    /// Fault-injected features (that were mapped) the monitor did not implicate.
    pub fn faulty_missed(&self) -> usize {
        self.fault_features
            .iter()
            .filter(|&&k| k < self.features.len())
            .filter(|k| !self.monitor.implicated_features.contains(k))
            .count()
    }

    /// Implicated features that were not fault-injected.
    pub fn wrongly_implicated(&self) -> usize {
        self.monitor
            .implicated_features
            .iter()
            .filter(|k| !self.fault_features.contains(k))
            .count()
    }

    pub fn feature_error_max(&self) -> Option<f64> {
        self.features
            .iter()
            .map(|f| f.error)
            .try_fold(0.0f64, |acc, e| e.map(|e| acc.max(e)))
            .filter(|_| !self.features.is_empty())
    }
}

/// The monitor's step a picture frame shows: the last check at or before the snapshot (a
/// snapshot is taken right after a check; the final one may come later, after predictions).
fn step_of<'a>(history: &'a [MonitorStep], snap: &SlamSnapshot) -> Option<&'a MonitorStep> {
    history.iter().rev().find(|h| h.stamp <= snap.stamp)
}

/// [`SlamRun::frame_mean_growth`] and [`SlamRun::frame_max_growth`] from the monitor history
/// and the snapshots. A cluster pair whose membership changed between the frames is skipped:
/// a new feature brings pairs with a fresh, large value, which is not growth.
pub fn frame_growth(
    history: &[MonitorStep],
    snapshots: &[SlamSnapshot],
) -> (Option<f64>, Option<f64>) {
    let (Some(first), Some(last)) = (snapshots.first(), snapshots.last()) else {
        return (None, None);
    };
    if snapshots.len() < 2 {
        return (None, None);
    }
    let (Some(a), Some(b)) = (step_of(history, first), step_of(history, last)) else {
        return (None, None);
    };
    let largest = |v: Option<f64>, r: f64| Some(v.map_or(r, |w: f64| w.max(r)));
    let (mut mean, mut max) = (None, None);
    for e in &b.cluster_pairs {
        let Some(s) = a
            .cluster_pairs
            .iter()
            .find(|s| s.a == e.a && s.b == e.b && s.pairs == e.pairs)
        else {
            continue;
        };
        if s.mean > 0.0 && s.max > 0.0 {
            mean = largest(mean, e.mean / s.mean);
            max = largest(max, e.max / s.max);
        }
    }
    (mean, max)
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// Share of the samples with a NEES whose NEES lies inside [`CHI2_2_95`].
pub fn nees_chi2_fraction(samples: &[Sample]) -> Option<f64> {
    let v: Vec<f64> = samples.iter().filter_map(|s| s.nees_xy).collect();
    if v.is_empty() {
        return None;
    }
    let inside = v
        .iter()
        .filter(|&&x| x >= CHI2_2_95.0 && x <= CHI2_2_95.1)
        .count();
    Some(inside as f64 / v.len() as f64)
}

const KEYS: [(&str, Bound); 15] = [
    ("wrongly_implicated_max", Bound::Max),
    ("violations_max", Bound::Max),
    ("flagged_within_s", Bound::Max),
    ("false_alarm_pairs_max", Bound::Max),
    ("faulty_missed_max", Bound::Max),
    ("min_increases_max", Bound::Max),
    ("mean_ratio_max", Bound::Max),
    ("mean_growth_min", Bound::Min),
    ("max_growth_min", Bound::Min),
    ("features_min", Bound::Min),
    ("features_max", Bound::Max),
    ("feature_error_max", Bound::Max),
    ("issues_max", Bound::Max),
    ("nees_chi2_fraction_min", Bound::Min),
    ("updates_min", Bound::Min),
];

/// Checks an `[expect.<localizer>.slam]` table (at load time, so a typo fails before a run).
pub fn check_table(
    value: &toml::Value,
    file: &std::path::Path,
    field: &str,
) -> Result<Vec<(String, Bound, f64)>, ScenarioError> {
    let table = value
        .as_table()
        .ok_or_else(|| ScenarioError::field(file, field, "must be a table"))?;
    let mut out = Vec::new();
    for (k, v) in table {
        let f = format!("{field}.{k}");
        let (_, bound) = KEYS.iter().find(|(name, _)| name == k).ok_or_else(|| {
            let names: Vec<&str> = KEYS.iter().map(|(n, _)| *n).collect();
            ScenarioError::field(
                file,
                &f,
                format!("unknown key (known: {})", names.join(", ")),
            )
        })?;
        let x = match v {
            toml::Value::Float(x) => *x,
            toml::Value::Integer(i) => *i as f64,
            _ => return Err(ScenarioError::field(file, &f, "must be a number")),
        };
        if !x.is_finite() {
            return Err(ScenarioError::field(
                file,
                &f,
                format!("must be finite, got {x}"),
            ));
        }
        out.push((k.clone(), *bound, x));
    }
    Ok(out)
}

/// The value a key bounds, None when it does not exist in this run (which fails it).
fn value(key: &str, run: &SlamRun, samples: &[Sample]) -> Option<f64> {
    Some(match key {
        "violations_max" => run.monitor.total_violations as f64,
        "flagged_within_s" => run.monitor.first_violation?.stamp,
        "false_alarm_pairs_max" => run.false_alarm_pairs() as f64,
        "faulty_missed_max" => run.faulty_missed() as f64,
        "wrongly_implicated_max" => run.wrongly_implicated() as f64,
        "min_increases_max" => run.min_intercluster_increases as f64,
        "mean_ratio_max" => run.mean_intercluster_ratio?,
        "mean_growth_min" => run.frame_mean_growth?,
        "max_growth_min" => run.frame_max_growth?,
        "features_min" | "features_max" => run.features.len() as f64,
        "feature_error_max" => run.feature_error_max()?,
        "issues_max" => run.issues.total() as f64,
        "nees_chi2_fraction_min" => nees_chi2_fraction(samples)?,
        "updates_min" => run.updates as f64,
        _ => return None,
    })
}

/// Evaluates the `[expect.<localizer>.slam]` table of `localizer` against its run. A
/// localizer that is not EKF-SLAM fails every key (there is nothing to check).
pub fn evaluate(
    scenario: &Scenario,
    localizer: &str,
    run: Option<&SlamRun>,
    samples: &[Sample],
) -> Result<Vec<ExpectationResult>, ScenarioError> {
    let Some(table) = scenario
        .expect
        .get(localizer)
        .and_then(|t| t.as_table())
        .and_then(|t| t.get("slam"))
    else {
        return Ok(Vec::new());
    };
    let field = format!("expect.{localizer}.slam");
    let keys = check_table(table, &scenario.file, &field)?;
    Ok(keys
        .into_iter()
        .map(|(key, bound, limit)| {
            let v = run.and_then(|r| value(&key, r, samples));
            let passed = match (v, bound) {
                (Some(v), Bound::Max) => v <= limit,
                (Some(v), Bound::Min) => v >= limit,
                (None, _) => false,
            };
            ExpectationResult {
                metric: format!("slam.{key}"),
                bound,
                limit,
                value: v,
                passed,
            }
        })
        .collect())
}

/// The `slam` section of the `--json` document.
pub fn to_json(run: &SlamRun) -> serde_json::Value {
    let mut v = serde_json::to_value(run).unwrap_or(serde_json::Value::Null);
    if let Some(obj) = v.as_object_mut() {
        obj.insert(
            "false_alarm_pairs".into(),
            serde_json::json!(run.false_alarm_pairs()),
        );
        obj.insert(
            "faulty_missed".into(),
            serde_json::json!(run.faulty_missed()),
        );
        obj.insert(
            "feature_error_max".into(),
            serde_json::json!(run.feature_error_max()),
        );
        // The last update's min / mean / max per cluster pair.
        obj.insert(
            "cluster_pairs".into(),
            serde_json::to_value(run.history.last().map(|h| &h.cluster_pairs))
                .unwrap_or(serde_json::Value::Null),
        );
    }
    v
}

/// Lines for the text report.
pub fn to_text(name: &str, run: &SlamRun) -> String {
    let mut s = format!(
        "\nEKF-SLAM {name}: {} features after {} updates; feature error max {}; {} input issues\n",
        run.features.len(),
        run.updates,
        run.feature_error_max()
            .map(|e| format!("{e:.3} m"))
            .unwrap_or_else(|| "-".into()),
        run.issues.total()
    );
    s.push_str(&format!(
        "covariance monitor ({}): {}\n",
        run.monitor.measure,
        run.monitor.describe().replace('\n', "\n  ")
    ));
    if let (Some(m), Some(x)) = (run.frame_mean_growth, run.frame_max_growth) {
        s.push_str(&format!(
            "  min / mean / max pictures, last / first frame (largest over cluster pairs): mean x{m:.2}, max x{x:.2}\n"
        ));
    }
    if let Some(last) = run.history.last() {
        for c in &last.cluster_pairs {
            s.push_str(&format!(
                "  clusters {} / {}: {} pairs, min {:.3e} mean {:.3e} max {:.3e} m²\n",
                c.a, c.b, c.pairs, c.min, c.mean, c.max
            ));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi_square_bounds() {
        // χ²(2) is exponential with mean 2: P(X ≤ x) = 1 − e^(−x/2).
        let cdf = |x: f64| 1.0 - (-x / 2.0).exp();
        assert!((cdf(CHI2_2_95.0) - 0.025).abs() < 1e-12);
        assert!((cdf(CHI2_2_95.1) - 0.975).abs() < 1e-12);
        // Tables: χ²(20) 2.5 % = 9.591, 97.5 % = 34.170, so 10 runs give [0.959, 3.417].
        let (lo, hi) = mean_nees_bounds(10);
        assert!(
            (lo - 0.9591).abs() < 0.005 && (hi - 3.417).abs() < 0.01,
            "{lo} {hi}"
        );
    }

    #[test]
    fn frame_growth_compares_the_first_and_last_frames() {
        use atrium_localization::covariance_monitor::ClusterPairStats;
        let pair = |a, b, pairs, mean: f64, max: f64| ClusterPairStats {
            a,
            b,
            pairs,
            min: 0.5 * mean,
            mean,
            max,
            min_pair: (0, 0),
            max_pair: (0, 0),
        };
        let step = |stamp: f64, cluster_pairs| MonitorStep {
            step: 0,
            stamp,
            features: 6,
            clusters: 3,
            violations: 0,
            cluster_pairs,
        };
        let snap = |stamp| SlamSnapshot {
            stamp,
            state: vec![0.0; 3],
            covariance: vec![0.0; 9],
            ids: Vec::new(),
        };
        let history = [
            step(1.0, vec![pair(0, 2, 4, 9.0, 9.0)]),
            step(2.0, vec![pair(0, 2, 4, 2.0, 4.0), pair(0, 4, 4, 1.0, 1.0)]),
            step(3.0, vec![pair(0, 2, 4, 1.0, 2.0), pair(0, 4, 4, 3.0, 2.0)]),
            // The last frame (4.5 s) shows this check; (2, 4) is new, (0, 4) gained a pair.
            step(
                4.0,
                vec![
                    pair(0, 2, 4, 1.0, 6.0),
                    pair(0, 4, 6, 9.0, 9.0),
                    pair(2, 4, 4, 9.0, 9.0),
                ],
            ),
        ];
        // First frame at 2 s: (0, 2) mean 2 -> 1 (x0.5), max 4 -> 6 (x1.5).
        let (mean, max) = frame_growth(&history, &[snap(2.0), snap(4.5)]);
        assert_eq!((mean, max), (Some(0.5), Some(1.5)));
        // With the first frame at 3 s (0, 4) still changed membership: only (0, 2) counts.
        assert_eq!(
            frame_growth(&history, &[snap(3.0), snap(4.5)]),
            (Some(1.0), Some(3.0))
        );
        // One frame, or a frame before any check: nothing to compare.
        assert_eq!(frame_growth(&history, &[snap(4.5)]), (None, None));
        assert_eq!(
            frame_growth(&history, &[snap(0.5), snap(4.5)]),
            (None, None)
        );
    }

    #[test]
    fn nees_fraction_counts_only_samples_with_nees() {
        let s = |n: Option<f64>| Sample {
            t: 0.0,
            position_error: 0.0,
            heading_error: 0.0,
            nees_xy: n,
        };
        let v = [
            s(None),
            s(Some(1.0)),
            s(Some(9.0)),
            s(Some(0.01)),
            s(Some(2.0)),
        ];
        assert_eq!(nees_chi2_fraction(&v), Some(0.5));
        assert_eq!(nees_chi2_fraction(&[s(None)]), None);
    }
}
