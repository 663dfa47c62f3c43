//! The open-area table of [004] §3 over several sweep seeds. One sweep (one seed, its trials)
//! gives one table: per localizer the min / max / median END error over the trials
//! ([`super::end_error`]). Its shape (which sensor has the smallest minimum, maximum, median)
//! can flip with the seed, so a claim about it means something only with its spread: here,
//! per cell (row × localizer), the min / median / max of that cell's value over the seeds
//! with a distribution-free interval for the median, and per row the order of the sensors
//! on each seed and how many seeds share it.

use super::end_error::EndErrorStats;
use std::collections::BTreeMap;

/// A row of the paper's table.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Statistic {
    Min,
    Max,
    Median,
}

impl Statistic {
    /// The rows in the paper's order.
    pub const ALL: [Statistic; 3] = [Statistic::Min, Statistic::Max, Statistic::Median];

    pub fn name(self) -> &'static str {
        match self {
            Statistic::Min => "min",
            Statistic::Max => "max",
            Statistic::Median => "median",
        }
    }

    pub fn of(self, s: &EndErrorStats) -> f64 {
        match self {
            Statistic::Min => s.min,
            Statistic::Max => s.max,
            Statistic::Median => s.median,
        }
    }
}

/// One cell of the table over the seeds: the spread of its per-seed values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    pub seeds: usize,
    pub min: f64,
    pub median: f64,
    pub max: f64,
    /// Order-statistic interval for the median over seeds ([`median_interval`]).
    pub interval: [f64; 2],
    /// Its exact coverage.
    pub coverage: f64,
}

/// P(X ≤ k) for X ~ Binomial(n, ½).
fn binomial_half_cdf(n: usize, k: usize) -> f64 {
    let mut c = 1.0f64; // C(n, 0)
    let mut sum = 0.0;
    for i in 0..=k.min(n) {
        if i > 0 {
            c = c * (n + 1 - i) as f64 / i as f64;
        }
        sum += c;
    }
    sum * 0.5f64.powi(n as i32)
}

/// The distribution-free interval for the median of `sorted` (ascending): [x_(k), x_(n−k+1)]
/// with the largest k whose coverage 1 − 2 P(Bin(n, ½) ≤ k − 1) is at least `level`, or the
/// whole range when none is (n < 6 at 95 %). Returns the interval and its exact coverage.
/// For 10 seeds at 95 %: the 2nd and 9th values, 97.9 %.
pub fn median_interval(sorted: &[f64], level: f64) -> ([f64; 2], f64) {
    let n = sorted.len();
    if n == 0 {
        return ([f64::NAN; 2], 0.0);
    }
    let coverage = |k: usize| 1.0 - 2.0 * binomial_half_cdf(n, k - 1);
    let mut k = 1;
    while k < n.div_ceil(2) && coverage(k + 1) >= level {
        k += 1;
    }
    ([sorted[k - 1], sorted[n - k]], coverage(k))
}

/// The open-area table of every seed.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OverSeeds {
    pub seeds: Vec<u64>,
    /// Per localizer, its end-error statistics on each seed (in `seeds` order; a localizer
    /// missing from a seed's table is left out of that seed).
    pub tables: Vec<BTreeMap<String, EndErrorStats>>,
}

impl OverSeeds {
    pub fn new(per_seed: Vec<(u64, BTreeMap<String, EndErrorStats>)>) -> Self {
        let (seeds, tables) = per_seed.into_iter().unzip();
        Self { seeds, tables }
    }

    /// The values of one cell over the seeds that have it.
    pub fn values(&self, stat: Statistic, localizer: &str) -> Vec<f64> {
        self.tables
            .iter()
            .filter_map(|t| t.get(localizer).map(|s| stat.of(s)))
            .collect()
    }

    pub fn spread(&self, stat: Statistic, localizer: &str) -> Option<Spread> {
        let mut v = self.values(stat, localizer);
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        let (interval, coverage) = median_interval(&v, 0.95);
        Some(Spread {
            seeds: v.len(),
            min: v[0],
            median: atrium_scenarios::metrics::quantile_sorted(&v, 0.5),
            max: v[v.len() - 1],
            interval,
            coverage,
        })
    }

    /// Seeds on which `a`'s value of `stat` is below `b`'s, of the seeds that have both.
    pub fn below(&self, stat: Statistic, a: &str, b: &str) -> (usize, usize) {
        let both: Vec<(f64, f64)> = self
            .tables
            .iter()
            .filter_map(|t| Some((stat.of(t.get(a)?), stat.of(t.get(b)?))))
            .collect();
        (both.iter().filter(|(x, y)| x < y).count(), both.len())
    }

    /// The orders of `among` by `stat` (smallest first) with the seeds showing each, most
    /// frequent first (ties in name order). Seeds lacking one of them are left out.
    pub fn orders(&self, stat: Statistic, among: &[&str]) -> Vec<(Vec<String>, usize)> {
        let mut count: BTreeMap<Vec<String>, usize> = BTreeMap::new();
        for t in &self.tables {
            let Some(mut v) = among
                .iter()
                .map(|n| Some((stat.of(t.get(*n)?), n.to_string())))
                .collect::<Option<Vec<_>>>()
            else {
                continue;
            };
            v.sort_by(|x, y| x.0.total_cmp(&y.0).then_with(|| x.1.cmp(&y.1)));
            *count
                .entry(v.into_iter().map(|(_, n)| n).collect())
                .or_default() += 1;
        }
        let mut out: Vec<(Vec<String>, usize)> = count.into_iter().collect();
        out.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
        out
    }

    /// The table as Markdown: each cell's median over seeds with its interval and range;
    /// then per row the sensors' orders and how many seeds each held on, and every pairwise
    /// comparison of the sensors with the baselines.
    pub fn to_markdown(&self, sensors: &[&str], baselines: &[&str]) -> String {
        let n = self.seeds.len();
        let cols: Vec<&str> = sensors.iter().chain(baselines).copied().collect();
        let mut s = format!(
            "End error (m) over {n} sweep seeds ({}): per cell, the median over seeds of that \
             seed's min / max / median over trials, its order-statistic interval in brackets, \
             and the range over seeds in parentheses.\n\n| end error (m) |",
            seed_list(&self.seeds)
        );
        for c in &cols {
            s.push_str(&format!(" {c} |"));
        }
        s.push_str("\n|---|");
        s.push_str(&"---:|".repeat(cols.len()));
        s.push('\n');
        let mut coverage = None;
        for stat in Statistic::ALL {
            s.push_str(&format!("| {} |", stat.name()));
            for c in &cols {
                match self.spread(stat, c) {
                    Some(p) => {
                        coverage.get_or_insert(p.coverage);
                        s.push_str(&format!(
                            " {:.2} [{:.2}, {:.2}] ({:.2}–{:.2}) |",
                            p.median, p.interval[0], p.interval[1], p.min, p.max
                        ))
                    }
                    None => s.push_str(" – |"),
                }
            }
            s.push('\n');
        }
        if let Some(c) = coverage {
            s.push_str(&format!(
                "\nIntervals: order statistics of the seeds' values, coverage {:.1} %.\n",
                100.0 * c
            ));
        }
        s.push_str("\n| row | order of the sensors (smallest first): seeds |\n|---|---|\n");
        for stat in Statistic::ALL {
            let o: Vec<String> = self
                .orders(stat, sensors)
                .into_iter()
                .map(|(order, k)| format!("{}: {k}/{n}", order.join(" < ")))
                .collect();
            s.push_str(&format!("| {} | {} |\n", stat.name(), o.join("; ")));
        }
        s.push_str("\n| row | below on (seeds) |\n|---|---|\n");
        for stat in Statistic::ALL {
            let mut pairs = Vec::new();
            for (i, a) in cols.iter().enumerate() {
                for b in &cols[i + 1..] {
                    let (ab, m) = self.below(stat, a, b);
                    pairs.push(format!("{a} < {b} {ab}/{m}"));
                }
            }
            s.push_str(&format!("| {} | {} |\n", stat.name(), pairs.join("; ")));
        }
        s
    }
}

/// `1..10` for a run of consecutive seeds, else the list.
fn seed_list(seeds: &[u64]) -> String {
    match (seeds.first(), seeds.last()) {
        (Some(a), Some(b)) if seeds.windows(2).all(|w| w[1] == w[0] + 1) && seeds.len() > 2 => {
            format!("seeds {a}..{b}")
        }
        _ => format!(
            "seeds {}",
            seeds
                .iter()
                .map(|s| s.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_interval_is_the_order_statistic_one() {
        let v: Vec<f64> = (1..=10).map(f64::from).collect();
        let (iv, cov) = median_interval(&v, 0.95);
        assert_eq!(iv, [2.0, 9.0]);
        assert!((cov - (1.0 - 22.0 / 1024.0)).abs() < 1e-12, "{cov}");
        // Too few values for 95 %: the whole range, with what it covers.
        let (iv, cov) = median_interval(&[1.0, 2.0, 3.0], 0.95);
        assert_eq!(iv, [1.0, 3.0]);
        assert!((cov - 0.75).abs() < 1e-12);
        let v: Vec<f64> = (1..=20).map(f64::from).collect();
        // Bin(20, ½): P(X ≤ 5) = 0.0207, P(X ≤ 6) = 0.0577.
        assert_eq!(median_interval(&v, 0.95).0, [6.0, 15.0]);
    }

    fn stats(min: f64, max: f64, median: f64) -> EndErrorStats {
        EndErrorStats {
            trials: 20,
            min,
            median,
            max,
        }
    }

    fn seeds() -> OverSeeds {
        let t = |l: [f64; 3], w: [f64; 3]| {
            BTreeMap::from([
                ("laser".to_string(), stats(l[0], l[1], l[2])),
                ("wifi".to_string(), stats(w[0], w[1], w[2])),
            ])
        };
        OverSeeds::new(vec![
            (1, t([0.01, 9.0, 1.0], [0.2, 1.0, 0.5])),
            (2, t([0.02, 12.0, 0.3], [0.1, 0.9, 0.6])),
            (3, t([0.01, 8.0, 2.0], [0.3, 1.1, 0.4])),
        ])
    }

    #[test]
    fn orders_and_pairs_count_seeds() {
        let o = seeds();
        assert_eq!(o.below(Statistic::Min, "laser", "wifi"), (3, 3));
        assert_eq!(o.below(Statistic::Median, "wifi", "laser"), (2, 3));
        let orders = o.orders(Statistic::Median, &["laser", "wifi"]);
        assert_eq!(
            orders,
            vec![
                (vec!["wifi".to_string(), "laser".to_string()], 2),
                (vec!["laser".to_string(), "wifi".to_string()], 1)
            ]
        );
        let sp = o.spread(Statistic::Max, "laser").unwrap();
        assert_eq!((sp.min, sp.median, sp.max), (8.0, 9.0, 12.0));
        assert!(o.spread(Statistic::Max, "depth").is_none());
        let md = o.to_markdown(&["laser", "wifi"], &[]);
        assert!(
            md.contains("| max | 9.00 [8.00, 12.00] (8.00–12.00) |"),
            "{md}"
        );
        assert!(md.contains("wifi < laser: 2/3; laser < wifi: 1/3"), "{md}");
        assert!(md.contains("laser < wifi 3/3"), "{md}");
    }
}
