//! Seed robustness (`atrium check SCENARIO --seeds 1..10`): runs a scenario on every seed of
//! a range and reports, per expectation, on how many seeds it held and how close its values
//! came to the bound. A claim that holds on the bundled seed only is luck; the check passes
//! when the whole scenario passes on at least `min_pass` seeds (by default 9 of 10).

use atrium_scenarios::metrics::ErrorStats;
use atrium_scenarios::verdict::Bound;
use atrium_scenarios::{LocalizerRegistry, RunOptions, Scenario, ScenarioError};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The most seeds one check may run: each is a whole scenario run.
pub const MAX_SEEDS: u64 = 1000;

/// The seeds `A..B` (both included, as in "seeds 1..10"), `A..=B`, a single seed, or a comma
/// list. Refuses empty, reversed and oversized ranges.
pub fn parse_seeds(text: &str) -> Result<Vec<u64>, String> {
    let bad = |why: String| format!("--seeds {text:?}: {why}");
    let number = |s: &str| {
        s.trim()
            .parse::<u64>()
            .map_err(|e| bad(format!("{s:?} is not a seed ({e})")))
    };
    let seeds: Vec<u64> = if let Some((a, b)) = text.split_once("..") {
        let (a, b) = (number(a)?, number(b.trim_start_matches('='))?);
        if b < a {
            return Err(bad(format!("the range ends ({b}) before it starts ({a})")));
        }
        if b - a >= MAX_SEEDS {
            return Err(bad(format!(
                "{} seeds is more than the limit of {MAX_SEEDS}",
                (b - a).saturating_add(1)
            )));
        }
        (a..=b).collect()
    } else {
        text.split(',').map(number).collect::<Result<_, _>>()?
    };
    if seeds.len() as u64 > MAX_SEEDS {
        return Err(bad(format!(
            "{} seeds is more than the limit of {MAX_SEEDS}",
            seeds.len()
        )));
    }
    let mut unique = seeds.clone();
    unique.sort_unstable();
    unique.dedup();
    if unique.len() != seeds.len() {
        return Err(bad("names a seed twice".into()));
    }
    Ok(seeds)
}

/// The default pass count: 90 % of the seeds, rounded up (9 of 10).
pub fn default_min_pass(seeds: usize) -> usize {
    (seeds * 9).div_ceil(10)
}

/// One seed's run.
#[derive(Debug, Clone, Serialize)]
pub struct SeedOutcome {
    pub seed: u64,
    pub passed: bool,
    /// The failed expectations, as `localizer: metric value vs bound`.
    pub failures: Vec<String>,
    /// How far the robot drove, m, and whether it reached the route's end.
    pub distance_m: f64,
    pub route_completed: bool,
}

/// A seed whose robot drove less than this fraction of the seeds' median distance is named
/// in the report: its expectations were judged on part of the route only.
pub const SHORT_DRIVE: f64 = 0.9;

/// The seeds (with their distances) that drove less than [`SHORT_DRIVE`] of the median
/// distance over `outcomes`, and that median.
pub fn short_drives(outcomes: &[SeedOutcome]) -> (f64, Vec<(u64, f64)>) {
    let Some(stats) = ErrorStats::of(outcomes.iter().map(|o| o.distance_m)) else {
        return (0.0, Vec::new());
    };
    let median = stats.median;
    let short = outcomes
        .iter()
        .filter(|o| o.distance_m < SHORT_DRIVE * median)
        .map(|o| (o.seed, o.distance_m))
        .collect();
    (median, short)
}

/// One expectation over all seeds.
#[derive(Debug, Clone, Serialize)]
pub struct ExpectationSpread {
    pub localizer: String,
    pub metric: String,
    pub bound: Bound,
    pub limit: f64,
    pub held: usize,
    /// The values over the seeds that have one (a metric may not exist: never converged).
    pub min: Option<f64>,
    pub median: Option<f64>,
    pub max: Option<f64>,
    /// Seeds without a value (counted as failures).
    pub missing: usize,
}

/// A scenario's expectations over a range of seeds.
#[derive(Debug, Clone, Serialize)]
pub struct SeedCheck {
    pub scenario: String,
    pub seeds: Vec<u64>,
    pub min_pass: usize,
    pub outcomes: Vec<SeedOutcome>,
    pub expectations: Vec<ExpectationSpread>,
}

impl SeedCheck {
    pub fn passed_seeds(&self) -> usize {
        self.outcomes.iter().filter(|o| o.passed).count()
    }

    /// The check holds: the scenario passed on at least `min_pass` seeds.
    pub fn passed(&self) -> bool {
        self.passed_seeds() >= self.min_pass
    }

    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(self).unwrap_or(serde_json::Value::Null);
        v["passed_seeds"] = self.passed_seeds().into();
        v["passed"] = self.passed().into();
        v
    }

    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{}: passed on {} of {} seeds (needs {}): {}",
            self.scenario,
            self.passed_seeds(),
            self.seeds.len(),
            self.min_pass,
            if self.passed() { "PASS" } else { "FAIL" }
        );
        let _ = writeln!(
            s,
            "\n{:<18} {:<52} {:>11} {:>6} {:>10} {:>10} {:>10}",
            "localizer", "expectation", "bound", "held", "min", "median", "max"
        );
        let num = |v: Option<f64>| v.map_or("never".to_string(), |v| format!("{v:.3}"));
        for e in &self.expectations {
            let bound = match e.bound {
                Bound::Max => format!("<= {}", e.limit),
                Bound::Min => format!(">= {}", e.limit),
            };
            let _ = writeln!(
                s,
                "{:<18} {:<52} {:>11} {:>6} {:>10} {:>10} {:>10}",
                e.localizer,
                e.metric,
                bound,
                format!("{}/{}", e.held, self.seeds.len()),
                num(e.min),
                num(e.median),
                num(e.max)
            );
        }
        let (median, short) = short_drives(&self.outcomes);
        if !self.outcomes.is_empty() {
            let done = self.outcomes.iter().filter(|o| o.route_completed).count();
            let _ = writeln!(
                s,
                "\ndistance driven: {median:.1} m median over the seeds; route completed on {done} of {}",
                self.outcomes.len()
            );
        }
        for (seed, d) in short {
            let _ = writeln!(
                s,
                "note: seed {seed} drove {d:.1} m, less than {:.0} % of the median: its expectations \
                 were judged on part of the route only",
                100.0 * SHORT_DRIVE
            );
        }
        for o in self.outcomes.iter().filter(|o| !o.passed) {
            let _ = writeln!(s, "\nseed {} failed: {}", o.seed, o.failures.join("; "));
        }
        s
    }
}

/// Runs `scenario` on every seed (in parallel, one run per task) and gathers the verdicts.
pub fn check_seeds(
    registry: &LocalizerRegistry,
    scenario: &Scenario,
    seeds: &[u64],
    min_pass: usize,
) -> Result<SeedCheck, ScenarioError> {
    check_seeds_observed(registry, scenario, seeds, min_pass, &|_| {})
}

/// [`check_seeds`], calling `on_run` with every run as it finishes (from the worker threads,
/// in any order): a progress bar counts them, a report keeps what it draws.
pub fn check_seeds_observed(
    registry: &LocalizerRegistry,
    scenario: &Scenario,
    seeds: &[u64],
    min_pass: usize,
    on_run: &(dyn Fn(&atrium_scenarios::RunResult) + Sync),
) -> Result<SeedCheck, ScenarioError> {
    if min_pass > seeds.len() {
        return Err(ScenarioError::field(
            &scenario.file,
            "--min-pass",
            format!("{min_pass} is more than the {} seeds run", seeds.len()),
        ));
    }
    // Without expectations every seed "passes": a PASS that checked nothing.
    if scenario.expect.is_empty() {
        return Err(ScenarioError::field(
            &scenario.file,
            "expect",
            "the scenario states no expectations ([expect.<localizer>]), so `check` has \
             nothing to check on any seed; add expectations, or use `atrium run` to see the \
             figures",
        ));
    }
    // Bad localizer tables or expectations fail once, before any run.
    registry.check(scenario)?;
    let runs = seeds
        .par_iter()
        .map(|&seed| {
            let options = RunOptions {
                seed: Some(seed),
                ..RunOptions::default()
            };
            let run = registry.run(scenario, options)?;
            on_run(&run);
            Ok(run)
        })
        .collect::<Result<Vec<_>, ScenarioError>>()?;
    let mut outcomes = Vec::with_capacity(runs.len());
    // (localizer, metric, bound, limit) → values per seed, in the scenario's order.
    type Claim = (String, String, Bound, f64);
    let mut spreads: Vec<(Claim, Vec<Option<f64>>)> = Vec::new();
    let mut index: BTreeMap<(String, String), usize> = BTreeMap::new();
    for run in &runs {
        let mut failures = Vec::new();
        for l in &run.localizers {
            for e in &l.expectations {
                let key = (
                    l.name.clone(),
                    format!("{} {:?} {}", e.metric, e.bound, e.limit),
                );
                let i = *index.entry(key).or_insert_with(|| {
                    spreads.push((
                        (l.name.clone(), e.metric.clone(), e.bound, e.limit),
                        Vec::new(),
                    ));
                    spreads.len() - 1
                });
                spreads[i].1.push(e.value);
                if !e.passed {
                    failures.push(format!(
                        "{}: {} = {} (bound {} {})",
                        l.name,
                        e.metric,
                        e.value.map_or("never".into(), |v| format!("{v:.3}")),
                        match e.bound {
                            Bound::Max => "<=",
                            Bound::Min => ">=",
                        },
                        e.limit
                    ));
                }
            }
        }
        outcomes.push(SeedOutcome {
            seed: run.seed,
            passed: run.passed(),
            failures,
            distance_m: run.distance_m,
            route_completed: run.route_completed,
        });
    }
    let expectations = spreads
        .into_iter()
        .map(|((localizer, metric, bound, limit), values)| {
            let held = values
                .iter()
                .filter(|v| match (v, bound) {
                    (Some(v), Bound::Max) => *v <= limit,
                    (Some(v), Bound::Min) => *v >= limit,
                    (None, _) => false,
                })
                .count();
            let mut present: Vec<f64> = values.iter().flatten().copied().collect();
            present.sort_by(f64::total_cmp);
            let median = (!present.is_empty()).then(|| {
                let n = present.len();
                if n % 2 == 1 {
                    present[n / 2]
                } else {
                    0.5 * (present[n / 2 - 1] + present[n / 2])
                }
            });
            ExpectationSpread {
                localizer,
                metric,
                bound,
                limit,
                held,
                min: present.first().copied(),
                median,
                max: present.last().copied(),
                missing: values.len() - present.len(),
            }
        })
        .collect();
    Ok(SeedCheck {
        scenario: scenario.name.clone(),
        seeds: seeds.to_vec(),
        min_pass,
        outcomes,
        expectations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_that_drove_short_are_named() {
        let outcome = |seed: u64, d: f64| SeedOutcome {
            seed,
            passed: true,
            failures: Vec::new(),
            distance_m: d,
            route_completed: false,
        };
        let outcomes: Vec<SeedOutcome> = [40.0, 41.0, 12.0, 40.5, 36.0, 37.0]
            .iter()
            .enumerate()
            .map(|(k, &d)| outcome(k as u64 + 1, d))
            .collect();
        // Median 38.5 m: 90 % of it is 34.65 m; only seed 3 is below.
        assert_eq!(short_drives(&outcomes), (38.5, vec![(3, 12.0)]));
        let check = SeedCheck {
            scenario: "s".into(),
            seeds: (1..=6).collect(),
            min_pass: 5,
            outcomes,
            expectations: Vec::new(),
        };
        let text = check.to_text();
        assert!(
            text.contains(
                "distance driven: 38.5 m median over the seeds; route completed on 0 of 6"
            ),
            "{text}"
        );
        assert!(
            text.contains("note: seed 3 drove 12.0 m, less than 90 % of the median"),
            "{text}"
        );
        assert_eq!(check.to_json()["outcomes"][2]["distance_m"], 12.0);
        assert_eq!(short_drives(&[]), (0.0, Vec::new()));
    }

    #[test]
    fn seed_ranges_are_inclusive_and_checked() {
        assert_eq!(parse_seeds("1..10").unwrap(), (1..=10).collect::<Vec<_>>());
        assert_eq!(parse_seeds("3..=5").unwrap(), vec![3, 4, 5]);
        assert_eq!(parse_seeds("7").unwrap(), vec![7]);
        assert_eq!(parse_seeds("1,4,9").unwrap(), vec![1, 4, 9]);
        assert!(parse_seeds("10..1")
            .unwrap_err()
            .contains("ends (1) before it starts (10)"));
        assert!(parse_seeds("0..18446744073709551615")
            .unwrap_err()
            .contains("more than the limit of 1000"));
        assert!(parse_seeds("1,1").unwrap_err().contains("twice"));
        assert!(parse_seeds("a..3")
            .unwrap_err()
            .contains("\"a\" is not a seed"));
        assert_eq!(default_min_pass(10), 9);
        assert_eq!(default_min_pass(3), 3);
        assert_eq!(default_min_pass(20), 18);
    }
}
