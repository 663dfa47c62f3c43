//! `[expect.<localizer>]`: bounds a run must meet, each on a metric named by a path.
//!
//! Shorthand keys (`median_max = 0.05`) bound the position error; the full set is:
//! - `<stat>_max` / `<stat>_min`, stat ∈ min, median, mean, rmse, p95, max: position error (m)
//! - `final_max` / `final_min`: position error at the end of the run
//! - `heading_<stat>_max` / `_min`: heading error (rad)
//! - `converged_within_s`: time to converge; `converged_<stat>_max` / `_min`: error after it
//! - `recovered_within_s`: the longest recovery after a kidnapping
//! - `nees_max` / `nees_min`: mean NEES over (x, y)
//! - `[expect.L.regions.<name>]` / `[expect.L.region_kinds.<kind>]`: `<stat>_max` / `_min` there
//! - `[expect.L.chosen]`: `<member>_min` / `_max`, a chooser's share (0–1) of the scored
//!   instants at which that member's estimate was its output; a localizer that chooses
//!   nothing has no share, so a single member never meets such a bound
//! - `[[expect.L.ratios]] numerator = "<path>", denominator = "<path>", min = .., max = ..`
//! - `[[expect.L.compare]] metric = "<path>", other = "<localizer>", max_ratio = .., min_ratio = ..`
//! - `[expect.L.slam]`: EKF-SLAM map and covariance-monitor checks, documented in `slam.rs`
//! - `baselines = ["<localizer>", ..]`: trivial localizers of the same run (dead reckoning, a
//!   chooser's single member) that must fail at least one of L's other expectations
//!
//! A metric path is `position_error.<stat>`, `heading_error.<stat>`, `final_position_error`,
//! `converged_after_s`, `after_convergence.<stat>`, `recovered_after_s`, `mean_nees_xy`,
//! `regions.<name>.<stat>`, `region_kinds.<kind>.<stat>` or `chosen.<member>`.

use crate::error::ScenarioError;
use crate::metrics::LocalizerMetrics;
use crate::scenario::Scenario;
pub use crate::verdict::{Bound, ExpectationResult};

const STATS: [&str; 6] = ["min", "median", "mean", "rmse", "p95", "max"];

#[derive(Debug, Clone, PartialEq)]
pub enum Expectation {
    /// `metric` of this localizer must be <= (Max) or >= (Min) `limit`.
    Bound {
        metric: String,
        bound: Bound,
        limit: f64,
    },
    /// numerator / denominator, both of this localizer.
    Ratio {
        numerator: String,
        denominator: String,
        bound: Bound,
        limit: f64,
    },
    /// metric of this localizer / the same metric of `other`.
    Compare {
        metric: String,
        other: String,
        bound: Bound,
        limit: f64,
    },
    /// `baselines = ["odometry"]`: this localizer's other expectations, evaluated on the
    /// trivial localizer `other` of the same run, must not all hold. A claim a baseline also
    /// meets says nothing about the localizer.
    Baseline { other: String },
}

/// What a metric path resolves against.
pub struct MetricSource<'a> {
    pub metrics: &'a LocalizerMetrics,
    /// Recovery time per kidnapping (None: never recovered).
    pub recoveries: &'a [Option<f64>],
    /// On a real log with benchmark relations: the localizer's relations error.
    pub relations: Option<&'a crate::relations::RelationsScore>,
}

/// The relations figures an expectation may bound (`relations_trans_mean_m_max = 0.3`).
const RELATIONS_STATS: [&str; 4] = ["trans_mean_m", "trans_std_m", "rot_mean_deg", "rot_std_deg"];

fn stat_suffix(key: &str) -> Option<(&str, Bound)> {
    if let Some(s) = key.strip_suffix("_max") {
        Some((s, Bound::Max))
    } else {
        key.strip_suffix("_min").map(|s| (s, Bound::Min))
    }
}

fn number(v: &toml::Value, file: &std::path::Path, field: &str) -> Result<f64, ScenarioError> {
    let x = match v {
        toml::Value::Float(f) => *f,
        toml::Value::Integer(i) => *i as f64,
        _ => return Err(ScenarioError::field(file, field, "must be a number")),
    };
    if x.is_finite() {
        Ok(x)
    } else {
        Err(ScenarioError::field(
            file,
            field,
            format!("must be finite, got {x}"),
        ))
    }
}

/// Checks that a metric path names something that can exist.
fn check_path(path: &str, scenario: &Scenario, field: &str) -> Result<(), ScenarioError> {
    let parts: Vec<&str> = path.split('.').collect();
    let ok = match parts.as_slice() {
        ["position_error" | "heading_error" | "after_convergence", stat] => STATS.contains(stat),
        ["final_position_error" | "converged_after_s" | "recovered_after_s" | "mean_nees_xy"] => {
            true
        }
        ["relations", stat] => {
            if scenario.log.as_ref().is_none_or(|l| l.relations.is_none()) {
                return Err(ScenarioError::field(
                    &scenario.file,
                    field,
                    "relations expectations need a [log] with relations",
                ));
            }
            RELATIONS_STATS.contains(stat)
        }
        ["regions", name, stat] => {
            if !scenario.world.regions.iter().any(|r| r.name == *name) {
                return Err(ScenarioError::field(
                    &scenario.file,
                    field,
                    format!(
                        "world {:?} has no region named {name:?}",
                        scenario.world.name
                    ),
                ));
            }
            STATS.contains(stat)
        }
        ["region_kinds", kind, stat] => {
            ["corridor", "glass_corridor", "atrium", "room", "outside"].contains(kind)
                && STATS.contains(stat)
        }
        ["chosen", member] => {
            if !scenario.localizers.iter().any(|l| l.name == *member) {
                return Err(ScenarioError::field(
                    &scenario.file,
                    field,
                    format!("no localizer named {member:?} in this scenario"),
                ));
            }
            true
        }
        _ => false,
    };
    if ok {
        Ok(())
    } else {
        Err(ScenarioError::field(
            &scenario.file,
            field,
            format!("unknown metric {path:?}"),
        ))
    }
}

fn bounds_in_table(
    table: &toml::Table,
    prefix: &str,
    field: &str,
    scenario: &Scenario,
    out: &mut Vec<Expectation>,
) -> Result<(), ScenarioError> {
    for (key, v) in table {
        let f = format!("{field}.{key}");
        let (stat, bound) = stat_suffix(key)
            .filter(|(s, _)| STATS.contains(s))
            .ok_or_else(|| ScenarioError::field(&scenario.file, &f, "unknown key: use <stat>_max or <stat>_min with stat one of min, median, mean, rmse, p95, max"))?;
        out.push(Expectation::Bound {
            metric: format!("{prefix}.{stat}"),
            bound,
            limit: number(v, &scenario.file, &f)?,
        });
    }
    Ok(())
}

/// Reads every `[expect.<localizer>]` table of a scenario.
pub fn parse_expectations(
    scenario: &Scenario,
) -> Result<Vec<(String, Expectation)>, ScenarioError> {
    let file = &scenario.file;
    let mut all = Vec::new();
    for (loc, value) in &scenario.expect {
        let table = value.as_table().ok_or_else(|| {
            ScenarioError::field(file, format!("expect.{loc}"), "must be a table")
        })?;
        let mut list = Vec::new();
        for (key, v) in table {
            let field = format!("expect.{loc}.{key}");
            match key.as_str() {
                "regions" | "region_kinds" => {
                    let regions = v.as_table().ok_or_else(|| {
                        ScenarioError::field(file, &field, "must be a table of regions")
                    })?;
                    for (name, t) in regions {
                        let f = format!("{field}.{name}");
                        let t = t
                            .as_table()
                            .ok_or_else(|| ScenarioError::field(file, &f, "must be a table"))?;
                        let prefix = format!("{key}.{name}");
                        let before = list.len();
                        bounds_in_table(t, &prefix, &f, scenario, &mut list)?;
                        if let Some(Expectation::Bound { metric, .. }) = list.get(before) {
                            check_path(metric, scenario, &f)?;
                        }
                    }
                }
                "ratios" | "compare" => {
                    let arr = v.as_array().ok_or_else(|| {
                        ScenarioError::field(file, &field, "must be an array of tables")
                    })?;
                    for (i, item) in arr.iter().enumerate() {
                        let f = format!("{field}[{i}]");
                        let t = item
                            .as_table()
                            .ok_or_else(|| ScenarioError::field(file, &f, "must be a table"))?;
                        let text = |k: &str| -> Result<String, ScenarioError> {
                            t.get(k)
                                .and_then(|v| v.as_str())
                                .map(str::to_string)
                                .ok_or_else(|| {
                                    ScenarioError::field(
                                        file,
                                        format!("{f}.{k}"),
                                        "a string is required",
                                    )
                                })
                        };
                        let mut bounds = Vec::new();
                        for (k, v) in t {
                            let b = match (key.as_str(), k.as_str()) {
                                ("ratios", "min") | ("compare", "min_ratio") => Bound::Min,
                                ("ratios", "max") | ("compare", "max_ratio") => Bound::Max,
                                ("ratios", "numerator" | "denominator")
                                | ("compare", "metric" | "other") => continue,
                                _ => {
                                    return Err(ScenarioError::field(
                                        file,
                                        format!("{f}.{k}"),
                                        "unknown key",
                                    ))
                                }
                            };
                            bounds.push((b, number(v, file, &format!("{f}.{k}"))?));
                        }
                        if bounds.is_empty() {
                            return Err(ScenarioError::field(
                                file,
                                &f,
                                "give a lower or an upper bound",
                            ));
                        }
                        for (bound, limit) in bounds {
                            if key == "ratios" {
                                let (numerator, denominator) =
                                    (text("numerator")?, text("denominator")?);
                                check_path(&numerator, scenario, &format!("{f}.numerator"))?;
                                check_path(&denominator, scenario, &format!("{f}.denominator"))?;
                                list.push(Expectation::Ratio {
                                    numerator,
                                    denominator,
                                    bound,
                                    limit,
                                });
                            } else {
                                let (metric, other) = (text("metric")?, text("other")?);
                                check_path(&metric, scenario, &format!("{f}.metric"))?;
                                if !scenario.localizers.iter().any(|l| l.name == other) {
                                    return Err(ScenarioError::field(
                                        file,
                                        format!("{f}.other"),
                                        format!("no localizer named {other:?}"),
                                    ));
                                }
                                list.push(Expectation::Compare {
                                    metric,
                                    other,
                                    bound,
                                    limit,
                                });
                            }
                        }
                    }
                }
                "chosen" => {
                    let shares = v.as_table().ok_or_else(|| {
                        ScenarioError::field(file, &field, "must be a table of members")
                    })?;
                    for (k, limit) in shares {
                        let f = format!("{field}.{k}");
                        let (member, bound) = stat_suffix(k).ok_or_else(|| {
                            ScenarioError::field(
                                file,
                                &f,
                                "unknown key: use <member>_min or <member>_max",
                            )
                        })?;
                        let metric = format!("chosen.{member}");
                        check_path(&metric, scenario, &f)?;
                        list.push(Expectation::Bound {
                            metric,
                            bound,
                            limit: number(limit, file, &f)?,
                        });
                    }
                }
                // Checked here for typos, evaluated by the runner from the SLAM report.
                "slam" => {
                    crate::slam::check_table(v, file, &field)?;
                }
                "baselines" => {
                    let names = v.as_array().ok_or_else(|| {
                        ScenarioError::field(file, &field, "must be an array of localizer names")
                    })?;
                    for (i, name) in names.iter().enumerate() {
                        let f = format!("{field}[{i}]");
                        let other = name.as_str().ok_or_else(|| {
                            ScenarioError::field(file, &f, "must be a localizer name")
                        })?;
                        if other == loc || !scenario.localizers.iter().any(|l| l.name == other) {
                            return Err(ScenarioError::field(
                                file,
                                f,
                                format!("no other localizer named {other:?} in this scenario"),
                            ));
                        }
                        list.push(Expectation::Baseline {
                            other: other.to_string(),
                        });
                    }
                }
                "converged_within_s" => list.push(Expectation::Bound {
                    metric: "converged_after_s".into(),
                    bound: Bound::Max,
                    limit: number(v, file, &field)?,
                }),
                "recovered_within_s" => list.push(Expectation::Bound {
                    metric: "recovered_after_s".into(),
                    bound: Bound::Max,
                    limit: number(v, file, &field)?,
                }),
                _ => {
                    let (stem, bound) = stat_suffix(key).ok_or_else(|| {
                        ScenarioError::field(file, &field, "unknown expectation key")
                    })?;
                    let metric = if stem == "final" {
                        "final_position_error".to_string()
                    } else if stem == "nees" {
                        "mean_nees_xy".to_string()
                    } else if let Some(s) = stem.strip_prefix("heading_") {
                        format!("heading_error.{s}")
                    } else if let Some(s) = stem.strip_prefix("relations_") {
                        format!("relations.{s}")
                    } else if let Some(s) = stem.strip_prefix("converged_") {
                        format!("after_convergence.{s}")
                    } else {
                        format!("position_error.{stem}")
                    };
                    check_path(&metric, scenario, &field).map_err(|_| {
                        ScenarioError::field(file, &field, "unknown expectation key")
                    })?;
                    list.push(Expectation::Bound {
                        metric,
                        bound,
                        limit: number(v, file, &field)?,
                    });
                }
            }
        }
        all.extend(list.into_iter().map(|e| (loc.clone(), e)));
    }
    Ok(all)
}

/// Resolves a metric path; `None` when the metric has no value in this run.
pub fn metric_value(src: &MetricSource, path: &str) -> Option<f64> {
    let m = src.metrics;
    let parts: Vec<&str> = path.split('.').collect();
    match parts.as_slice() {
        ["position_error", s] => m.position_error.get(s),
        ["heading_error", s] => m.heading_error.get(s),
        ["after_convergence", s] => m.after_convergence.and_then(|a| a.get(s)),
        ["final_position_error"] => Some(m.final_position_error),
        ["relations", "trans_mean_m"] => src.relations.map(|r| r.trans_mean_m),
        ["relations", "trans_std_m"] => src.relations.map(|r| r.trans_std_m),
        ["relations", "rot_mean_deg"] => src.relations.map(|r| r.rot_mean_deg),
        ["relations", "rot_std_deg"] => src.relations.map(|r| r.rot_std_deg),
        ["converged_after_s"] => m.converged_after_s,
        ["mean_nees_xy"] => m.mean_nees_xy,
        ["recovered_after_s"] => {
            if src.recoveries.is_empty() {
                return None;
            }
            src.recoveries
                .iter()
                .try_fold(0.0f64, |acc, r| r.map(|r| acc.max(r)))
        }
        ["regions", name, s] => m.per_region.get(*name).and_then(|r| r.get(s)),
        ["region_kinds", kind, s] => m.per_region_kind.get(*kind).and_then(|r| r.get(s)),
        // A chooser never choosing a member chose it 0 % of the time; a localizer that
        // chooses nothing has no share.
        ["chosen", member] => {
            (!m.chosen.is_empty()).then(|| m.chosen.get(*member).copied().unwrap_or(0.0))
        }
        _ => None,
    }
}

fn check_bound(value: Option<f64>, bound: Bound, limit: f64) -> bool {
    match (value, bound) {
        (Some(v), Bound::Max) => v <= limit,
        (Some(v), Bound::Min) => v >= limit,
        (None, _) => false,
    }
}

/// Evaluates one localizer's expectations; `lookup` finds another localizer's metrics.
pub fn evaluate<'a>(
    expectations: impl Iterator<Item = &'a Expectation>,
    own: &MetricSource,
    lookup: &dyn Fn(&str) -> Option<MetricSource<'a>>,
) -> Vec<ExpectationResult> {
    let all: Vec<&Expectation> = expectations.collect();
    let claims: Vec<&Expectation> = all
        .iter()
        .filter(|e| !matches!(e, Expectation::Baseline { .. }))
        .copied()
        .collect();
    all.iter()
        .map(|e| match e {
            Expectation::Baseline { other } => {
                // How many of the claims the baseline meets as well; all of them: no claim.
                let met = lookup(other).map(|src| {
                    claims
                        .iter()
                        .filter(|c| evaluate_one(c, &src, lookup).passed)
                        .count()
                });
                let limit = claims.len() as f64 - 1.0;
                let value = met.map(|m| m as f64);
                ExpectationResult {
                    metric: format!("claims also met by {other}"),
                    bound: Bound::Max,
                    limit,
                    value,
                    passed: check_bound(value, Bound::Max, limit),
                }
            }
            claim => evaluate_one(claim, own, lookup),
        })
        .collect()
}

fn evaluate_one<'a>(
    e: &Expectation,
    own: &MetricSource,
    lookup: &dyn Fn(&str) -> Option<MetricSource<'a>>,
) -> ExpectationResult {
    match e {
        Expectation::Bound {
            metric,
            bound,
            limit,
        } => {
            let value = metric_value(own, metric);
            ExpectationResult {
                metric: metric.clone(),
                bound: *bound,
                limit: *limit,
                value,
                passed: check_bound(value, *bound, *limit),
            }
        }
        Expectation::Ratio {
            numerator,
            denominator,
            bound,
            limit,
        } => {
            let value = match (metric_value(own, numerator), metric_value(own, denominator)) {
                (Some(n), Some(d)) if d > 0.0 => Some(n / d),
                _ => None,
            };
            ExpectationResult {
                metric: format!("{numerator} / {denominator}"),
                bound: *bound,
                limit: *limit,
                value,
                passed: check_bound(value, *bound, *limit),
            }
        }
        Expectation::Compare {
            metric,
            other,
            bound,
            limit,
        } => {
            let value = match (
                metric_value(own, metric),
                lookup(other).and_then(|o| metric_value(&o, metric)),
            ) {
                (Some(a), Some(b)) if b > 0.0 => Some(a / b),
                _ => None,
            };
            ExpectationResult {
                metric: format!("{metric} / {other}.{metric}"),
                bound: *bound,
                limit: *limit,
                value,
                passed: check_bound(value, *bound, *limit),
            }
        }
        // Baselines are judged by `evaluate`, over the other claims.
        Expectation::Baseline { other } => ExpectationResult {
            metric: format!("claims also met by {other}"),
            bound: Bound::Max,
            limit: f64::NAN,
            value: None,
            passed: false,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::{score, Sample};

    #[test]
    fn bounds_and_missing_values() {
        let samples: Vec<Sample> = [0.1, 0.2, 0.3]
            .iter()
            .enumerate()
            .map(|(i, &e)| Sample {
                t: i as f64,
                position_error: e,
                heading_error: 0.01,
                nees_xy: None,
            })
            .collect();
        let m = score(&samples, &[None, None, None], 0.5, 0.0).unwrap();
        let src = MetricSource {
            metrics: &m,
            recoveries: &[],
            relations: None,
        };
        let exps = [
            Expectation::Bound {
                metric: "position_error.median".into(),
                bound: Bound::Max,
                limit: 0.25,
            },
            Expectation::Bound {
                metric: "position_error.max".into(),
                bound: Bound::Max,
                limit: 0.25,
            },
            Expectation::Bound {
                metric: "recovered_after_s".into(),
                bound: Bound::Max,
                limit: 10.0,
            },
            Expectation::Ratio {
                numerator: "position_error.max".into(),
                denominator: "position_error.min".into(),
                bound: Bound::Min,
                limit: 2.9,
            },
        ];
        let r = evaluate(exps.iter(), &src, &|_| None);
        assert!(r[0].passed);
        assert!(!r[1].passed);
        assert!(!r[2].passed && r[2].value.is_none());
        assert!(r[3].passed && (r[3].value.unwrap() - 3.0).abs() < 1e-9);
    }

    fn metrics_of(errors: &[f64]) -> LocalizerMetrics {
        let samples: Vec<Sample> = errors
            .iter()
            .enumerate()
            .map(|(i, &e)| Sample {
                t: i as f64,
                position_error: e,
                heading_error: 0.01,
                nees_xy: None,
            })
            .collect();
        score(&samples, &vec![None; samples.len()], 0.5, 0.0).unwrap()
    }

    #[test]
    fn a_claim_the_baseline_also_meets_fails() {
        let good = metrics_of(&[0.01, 0.02, 0.03]);
        let drift = metrics_of(&[0.0, 0.5, 3.0]);
        let src = |m| MetricSource {
            metrics: m,
            recoveries: &[],
            relations: None,
        };
        let claims = |median: f64| {
            vec![
                Expectation::Bound {
                    metric: "position_error.median".into(),
                    bound: Bound::Max,
                    limit: median,
                },
                Expectation::Bound {
                    metric: "position_error.min".into(),
                    bound: Bound::Max,
                    limit: 0.05,
                },
                Expectation::Baseline {
                    other: "odometry".into(),
                },
            ]
        };
        let lookup = |name: &str| (name == "odometry").then(|| src(&drift));
        // A median bound of 0.1 m: dead reckoning (median 0.5 m) fails it, so the claim holds.
        let tight = claims(0.1);
        let r = evaluate(tight.iter(), &src(&good), &lookup);
        assert!(r.iter().all(|r| r.passed), "{r:?}");
        assert_eq!((r[2].value, r[2].limit), (Some(1.0), 1.0));
        // A median bound of 1 m: dead reckoning meets both claims; the baseline check fails.
        let loose = claims(1.0);
        let r = evaluate(loose.iter(), &src(&good), &lookup);
        assert!(r[0].passed && r[1].passed && !r[2].passed, "{r:?}");
        assert_eq!(r[2].metric, "claims also met by odometry");
    }

    /// `[expect.L.chosen]` bounds a chooser's share of time per member; a localizer that
    /// chooses nothing has no share, so it fails such a bound (a baseline member cannot meet
    /// it); a member name that is no localizer of the scenario is refused at load.
    #[test]
    fn chosen_shares_bound_a_chooser_and_no_single_member() {
        let mut s =
            Scenario::load(&crate::bundled_scenarios_dir().join("corridor_tracking.toml")).unwrap();
        s.expect = toml::from_str("[mcl.chosen]\nodometry_min = 0.2\nmcl_max = 0.5").unwrap();
        let exps: Vec<Expectation> = parse_expectations(&s)
            .unwrap()
            .into_iter()
            .map(|(_, e)| e)
            .collect();
        let mut chooser = metrics_of(&[0.01, 0.02]);
        chooser.chosen = [("odometry".to_string(), 1.0)].into_iter().collect();
        let src = |m| MetricSource {
            metrics: m,
            recoveries: &[],
            relations: None,
        };
        let r = evaluate(exps.iter(), &src(&chooser), &|_| None);
        // odometry chosen all the time; mcl never, which is a share of 0, not a missing value.
        assert!(r.iter().all(|r| r.passed), "{r:?}");
        assert_eq!(r[0].metric, "chosen.mcl");
        assert_eq!(r[0].value, Some(0.0));
        let single = metrics_of(&[0.01, 0.02]);
        let r = evaluate(exps.iter(), &src(&single), &|_| None);
        assert!(r.iter().all(|r| !r.passed && r.value.is_none()), "{r:?}");

        s.expect = toml::from_str("[mcl.chosen]\nsonar_min = 0.2").unwrap();
        let e = parse_expectations(&s).unwrap_err().to_string();
        assert!(e.contains("expect.mcl.chosen.sonar_min"), "{e}");
        assert!(e.contains("no localizer named \"sonar\""), "{e}");
        s.expect = toml::from_str("[mcl.chosen]\nodometry = 0.2").unwrap();
        let e = parse_expectations(&s).unwrap_err().to_string();
        assert!(e.contains("use <member>_min or <member>_max"), "{e}");
    }
}
