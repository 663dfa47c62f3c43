//! Automatic checks of the EKF-SLAM map-covariance behaviour that Kozlov, MacDonald and
//! Wünsche visualise ([003] §2.2 and §4): the relative covariance
//! of every feature pair (eq. 12–13),
//!
//! d_ij = f_i − f_j,   P_d = P_ii + P_jj − P_ij − P_ijᵀ,
//!
//! must not grow from one update to the next (Dissanayake et al. 2001; Huang and Dissanayake
//! 2007). The theorem is an ordering of matrices (P_d after ≤ P_d before); we check its
//! **largest eigenvalue**, the squared major semi-axis of the correlation ellipse the paper
//! draws. A determinant would miss an ellipse that grows along one axis while it shrinks
//! faster along the other; the largest eigenvalue is monotone under the same ordering and
//! catches that. A pair is exempt at the update where one of its features is newly
//! initialised: it has no previous value.
//!
//! Features are grouped by single-linkage clustering on Euclidean distance (§3.2: spatial
//! clusters), and per cluster pair the monitor keeps the min / mean / max of the inter-
//! cluster values over time (the paper's third visualisation mode). The report names every
//! violating pair and the update (step and time) at which it first violated.

use serde::Serialize;

/// Settings of the [`CovarianceMonitor`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct MonitorParams {
    /// Single-linkage threshold: features closer than this (m) share a cluster.
    pub cluster_distance: f64,
    /// A pair violates when its value grows by more than `rel_tol · before + abs_tol`. The
    /// EKF's P_d decrease is exact in exact arithmetic; the tolerance absorbs rounding only.
    pub rel_tol: f64,
    pub abs_tol: f64,
    /// At most this many violations are kept with their details (all are counted).
    pub max_recorded: usize,
}

impl Default for MonitorParams {
    fn default() -> Self {
        Self {
            cluster_distance: 0.6,
            rel_tol: 1e-6,
            abs_tol: 1e-12,
            max_recorded: 1000,
        }
    }
}

impl MonitorParams {
    pub fn validate(&self) -> Result<(), String> {
        if !(self.cluster_distance.is_finite() && self.cluster_distance > 0.0) {
            return Err(format!(
                "cluster_distance: must be > 0 (got {})",
                self.cluster_distance
            ));
        }
        if !(self.rel_tol.is_finite() && self.rel_tol >= 0.0) {
            return Err(format!("rel_tol: must be >= 0 (got {})", self.rel_tol));
        }
        if !(self.abs_tol.is_finite() && self.abs_tol >= 0.0) {
            return Err(format!("abs_tol: must be >= 0 (got {})", self.abs_tol));
        }
        Ok(())
    }
}

/// One pair whose relative covariance grew.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Violation {
    /// The monitor's update counter (1 = first check) and the update's time stamp.
    pub step: u64,
    pub stamp: f64,
    /// Feature indices (map order, i < j).
    pub i: usize,
    pub j: usize,
    /// Largest eigenvalue of P_d before and after the update, m².
    pub before: f64,
    pub after: f64,
}

/// The inter-cluster values of one cluster pair at one update.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ClusterPairStats {
    /// Cluster labels: the smallest feature index in each cluster (a < b).
    pub a: usize,
    pub b: usize,
    /// Number of feature pairs (i in a, j in b).
    pub pairs: usize,
    /// Largest eigenvalue of P_d, m²: smallest, mean and largest over the pairs.
    pub min: f64,
    pub mean: f64,
    pub max: f64,
    /// The pairs with the smallest and the largest value.
    pub min_pair: (usize, usize),
    pub max_pair: (usize, usize),
}

/// What the monitor saw at one update.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MonitorStep {
    pub step: u64,
    pub stamp: f64,
    pub features: usize,
    pub clusters: usize,
    /// Pairs that violated at this update.
    pub violations: usize,
    pub cluster_pairs: Vec<ClusterPairStats>,
}

/// A pair that violated at least once.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ViolatingPair {
    pub i: usize,
    pub j: usize,
    /// The first violation of this pair.
    pub first_step: u64,
    pub first_stamp: f64,
    /// How many updates it violated at.
    pub count: usize,
}

/// The monitor's verdict.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MonitorReport {
    pub measure: &'static str,
    pub updates_checked: u64,
    pub total_violations: usize,
    pub first_violation: Option<Violation>,
    /// Every pair that violated, ordered by first violation.
    pub violating_pairs: Vec<ViolatingPair>,
    /// Every feature named in a violating pair, ascending.
    pub violating_features: Vec<usize>,
    /// The features the violations point at: a greedy cover of the violating pairs (take the
    /// feature in most not yet covered pairs, repeat). A fault in one feature's covariance
    /// update makes every pair it is in violate, with partners that are themselves fine; the
    /// cover names the culprit, not the partners. In order of pairs covered.
    pub implicated_features: Vec<usize>,
}

impl MonitorReport {
    /// One line per violating pair: "features 3 and 7 first violated at update 41 (t = 20.2 s)".
    pub fn describe(&self) -> String {
        if self.violating_pairs.is_empty() {
            return format!(
                "no relative covariance grew in {} updates",
                self.updates_checked
            );
        }
        let mut s = format!(
            "{} violations by {} pairs; implicated features {:?} (all named: {:?}):",
            self.total_violations,
            self.violating_pairs.len(),
            self.implicated_features,
            self.violating_features
        );
        for p in &self.violating_pairs {
            s.push_str(&format!(
                "\n  features {} and {} first violated at update {} (t = {:.2} s), {} times",
                p.i, p.j, p.first_step, p.first_stamp, p.count
            ));
        }
        s
    }
}

/// Largest eigenvalue of the symmetric 2×2 matrix [[a, b], [b, c]].
#[inline]
pub fn largest_eigenvalue(a: f64, b: f64, c: f64) -> f64 {
    let m = 0.5 * (a + c);
    let d = 0.5 * (a - c);
    m + (d * d + b * b).sqrt()
}

/// P_d (eq. 13) of features `i` and `j` from a covariance accessor over the map block
/// (`cov(r, c)` for map-state indices, feature k at 2k, 2k + 1), as (a, b, c) of
/// [[a, b], [b, c]].
#[inline]
pub fn relative_covariance(cov: &dyn Fn(usize, usize) -> f64, i: usize, j: usize) -> [f64; 3] {
    let (u, v) = (2 * i, 2 * j);
    let a = cov(u, u) + cov(v, v) - cov(u, v) - cov(v, u);
    let b = cov(u, u + 1) + cov(v, v + 1) - cov(u, v + 1) - cov(v, u + 1);
    let c = cov(u + 1, u + 1) + cov(v + 1, v + 1) - cov(u + 1, v + 1) - cov(v + 1, u + 1);
    [a, b, c]
}

/// Index of pair (i, j), i < j, in a triangular array that grows with j.
#[inline]
fn pair_index(i: usize, j: usize) -> usize {
    j * (j - 1) / 2 + i
}

/// Single-linkage clustering of points by Euclidean distance `threshold`: the connected
/// components of the graph joining points closer than it. Returns each point's label, the
/// smallest index in its cluster.
pub fn single_linkage(points: &[[f64; 2]], threshold: f64) -> Vec<usize> {
    let n = points.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(parent: &mut [usize], mut k: usize) -> usize {
        while parent[k] != k {
            parent[k] = parent[parent[k]];
            k = parent[k];
        }
        k
    }
    for i in 0..n {
        for j in i + 1..n {
            let d = (points[i][0] - points[j][0]).hypot(points[i][1] - points[j][1]);
            if d < threshold {
                let (ri, rj) = (find(&mut parent, i), find(&mut parent, j));
                // Union by smaller index, so every root is its cluster's smallest member.
                let (lo, hi) = (ri.min(rj), ri.max(rj));
                parent[hi] = lo;
            }
        }
    }
    (0..n).map(|k| find(&mut parent, k)).collect()
}

/// Checks the relative covariances after every update and keeps their history.
#[derive(Debug, Clone)]
pub struct CovarianceMonitor {
    params: MonitorParams,
    /// Largest eigenvalue of P_d per pair at the previous check (triangular by j).
    prev: Vec<f64>,
    /// Features present at the previous check.
    prev_features: usize,
    steps: u64,
    total_violations: usize,
    recorded: Vec<Violation>,
    pairs: Vec<ViolatingPair>,
    history: Vec<MonitorStep>,
    /// Scratch: current values and labels, reused between checks.
    current: Vec<f64>,
}

impl CovarianceMonitor {
    pub fn new(params: MonitorParams) -> Self {
        Self {
            params,
            prev: Vec::new(),
            prev_features: 0,
            steps: 0,
            total_violations: 0,
            recorded: Vec::new(),
            pairs: Vec::new(),
            history: Vec::new(),
            current: Vec::new(),
        }
    }

    pub fn params(&self) -> &MonitorParams {
        &self.params
    }

    /// Checks one update. `features` are the estimated feature positions (map order);
    /// `cov(r, c)` reads the map covariance block (feature k at rows 2k, 2k + 1). Features
    /// beyond those of the previous check count as newly initialised. Returns the number of
    /// pairs that violated at this update.
    pub fn check(
        &mut self,
        stamp: f64,
        features: &[[f64; 2]],
        cov: &dyn Fn(usize, usize) -> f64,
    ) -> usize {
        self.steps += 1;
        let n = features.len();
        let npairs = n * n.saturating_sub(1) / 2;
        self.current.clear();
        self.current.resize(npairs, 0.0);
        let mut violations = 0;
        for j in 1..n {
            for i in 0..j {
                let [a, b, c] = relative_covariance(cov, i, j);
                let value = largest_eigenvalue(a, b, c);
                let k = pair_index(i, j);
                self.current[k] = value;
                // Pairs with a feature initialised since the last check have no "before".
                if j >= self.prev_features {
                    continue;
                }
                let before = self.prev[k];
                // NaN counts as growth: a broken covariance must not pass silently.
                let limit = before + self.params.rel_tol * before.abs() + self.params.abs_tol;
                let grew = !matches!(
                    value.partial_cmp(&limit),
                    Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
                );
                if grew {
                    violations += 1;
                    self.record(Violation {
                        step: self.steps,
                        stamp,
                        i,
                        j,
                        before,
                        after: value,
                    });
                }
            }
        }
        std::mem::swap(&mut self.prev, &mut self.current);
        self.prev_features = n;

        let labels = single_linkage(features, self.params.cluster_distance);
        let mut cluster_ids: Vec<usize> = labels.clone();
        cluster_ids.sort_unstable();
        cluster_ids.dedup();
        let mut cluster_pairs = Vec::new();
        for (ka, &ca) in cluster_ids.iter().enumerate() {
            for &cb in &cluster_ids[ka + 1..] {
                let mut s = ClusterPairStats {
                    a: ca,
                    b: cb,
                    pairs: 0,
                    min: f64::INFINITY,
                    mean: 0.0,
                    max: f64::NEG_INFINITY,
                    min_pair: (0, 0),
                    max_pair: (0, 0),
                };
                for j in 1..n {
                    for i in 0..j {
                        let (li, lj) = (labels[i], labels[j]);
                        if !((li == ca && lj == cb) || (li == cb && lj == ca)) {
                            continue;
                        }
                        let v = self.prev[pair_index(i, j)];
                        s.pairs += 1;
                        s.mean += v;
                        if v < s.min {
                            s.min = v;
                            s.min_pair = (i, j);
                        }
                        if v > s.max {
                            s.max = v;
                            s.max_pair = (i, j);
                        }
                    }
                }
                s.mean /= s.pairs.max(1) as f64;
                cluster_pairs.push(s);
            }
        }
        self.history.push(MonitorStep {
            step: self.steps,
            stamp,
            features: n,
            clusters: cluster_ids.len(),
            violations,
            cluster_pairs,
        });
        violations
    }

    fn record(&mut self, v: Violation) {
        self.total_violations += 1;
        if self.recorded.len() < self.params.max_recorded {
            self.recorded.push(v);
        }
        match self.pairs.iter_mut().find(|p| p.i == v.i && p.j == v.j) {
            Some(p) => p.count += 1,
            None => self.pairs.push(ViolatingPair {
                i: v.i,
                j: v.j,
                first_step: v.step,
                first_stamp: v.stamp,
                count: 1,
            }),
        }
    }

    /// The recorded violations (the first `max_recorded`).
    pub fn violations(&self) -> &[Violation] {
        &self.recorded
    }

    /// Per update: feature count, clusters and the min / mean / max per cluster pair.
    pub fn history(&self) -> &[MonitorStep] {
        &self.history
    }

    /// The largest eigenvalue of P_d of pair (i, j) at the last check.
    pub fn last_value(&self, i: usize, j: usize) -> Option<f64> {
        let (i, j) = (i.min(j), i.max(j));
        (i != j && j < self.prev_features).then(|| self.prev[pair_index(i, j)])
    }

    pub fn report(&self) -> MonitorReport {
        let mut features: Vec<usize> = self.pairs.iter().flat_map(|p| [p.i, p.j]).collect();
        features.sort_unstable();
        features.dedup();
        let mut uncovered: Vec<(usize, usize)> = self.pairs.iter().map(|p| (p.i, p.j)).collect();
        let mut implicated = Vec::new();
        while !uncovered.is_empty() {
            // Most pairs first; ties to the smaller index, so the result is deterministic.
            let best = features
                .iter()
                .copied()
                .max_by_key(|&f| {
                    let n = uncovered.iter().filter(|p| p.0 == f || p.1 == f).count();
                    (n, std::cmp::Reverse(f))
                })
                .unwrap_or(uncovered[0].0);
            implicated.push(best);
            uncovered.retain(|p| p.0 != best && p.1 != best);
        }
        MonitorReport {
            measure: "largest eigenvalue of P_d",
            updates_checked: self.steps,
            total_violations: self.total_violations,
            first_violation: self.recorded.first().copied(),
            violating_pairs: self.pairs.clone(),
            violating_features: features,
            implicated_features: implicated,
        }
    }

    /// How often the minimum inter-cluster value of a cluster pair grew between consecutive
    /// updates while the pair's membership (its number of feature pairs) stayed the same.
    /// Adding a feature can only add pairs, which can only lower a minimum, so with fixed
    /// membership this counts genuine increases.
    pub fn min_intercluster_increases(&self) -> usize {
        let mut count = 0;
        for w in self.history.windows(2) {
            for s in &w[1].cluster_pairs {
                if let Some(p) = w[0]
                    .cluster_pairs
                    .iter()
                    .find(|p| p.a == s.a && p.b == s.b && p.pairs == s.pairs)
                {
                    if s.min > p.min + self.params.rel_tol * p.min.abs() + self.params.abs_tol {
                        count += 1;
                    }
                }
            }
        }
        count
    }

    /// Per cluster pair present at the last update: its mean inter-cluster value at the end
    /// divided by the mean when the pair first had its final membership. Below 1 means the
    /// mean trended down; the largest ratio over the cluster pairs is returned (None without
    /// cluster pairs).
    pub fn mean_intercluster_ratio(&self) -> Option<f64> {
        let last = self.history.last()?;
        let mut worst: Option<f64> = None;
        for s in &last.cluster_pairs {
            let first = self.history.iter().find_map(|h| {
                h.cluster_pairs
                    .iter()
                    .find(|p| p.a == s.a && p.b == s.b && p.pairs == s.pairs)
            })?;
            if first.mean > 0.0 {
                let r = s.mean / first.mean;
                worst = Some(worst.map_or(r, |w: f64| w.max(r)));
            }
        }
        worst
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn eigenvalue_and_relative_covariance_by_hand() {
        // [[2, 1], [1, 2]] has eigenvalues 1 and 3.
        assert!((largest_eigenvalue(2.0, 1.0, 2.0) - 3.0).abs() < 1e-12);
        assert!((largest_eigenvalue(1.0, 0.0, 4.0) - 4.0).abs() < 1e-12);
        // Two features with P_ii = diag(1, 2), P_jj = diag(3, 4), P_ij = [[0.5, 0.1], [0.2, 0.3]]:
        // P_d = [[1 + 3 − 1, 0 + 0 − 0.1 − 0.2], [.., 2 + 4 − 0.6]] = [[3, −0.3], [−0.3, 5.4]].
        let mut p = DMatrix::<f64>::zeros(4, 4);
        p[(0, 0)] = 1.0;
        p[(1, 1)] = 2.0;
        p[(2, 2)] = 3.0;
        p[(3, 3)] = 4.0;
        let pij = [[0.5, 0.1], [0.2, 0.3]];
        for r in 0..2 {
            for c in 0..2 {
                p[(r, 2 + c)] = pij[r][c];
                p[(2 + c, r)] = pij[r][c];
            }
        }
        let cov = |r: usize, c: usize| p[(r, c)];
        let [a, b, c] = relative_covariance(&cov, 0, 1);
        assert!((a - 3.0).abs() < 1e-12 && (b + 0.3).abs() < 1e-12 && (c - 5.4).abs() < 1e-12);
    }

    #[test]
    fn single_linkage_chains_and_labels_by_smallest_index() {
        let pts = [
            [0.0, 0.0],
            [5.0, 0.0],
            [0.5, 0.0],
            [1.0, 0.0],
            [5.3, 0.0],
            [9.0, 9.0],
        ];
        // 0–2–3 chain at 0.5 m steps (single linkage joins them though 0 and 3 are 1 m apart).
        assert_eq!(single_linkage(&pts, 0.6), vec![0, 1, 0, 0, 1, 5]);
    }

    /// Two features, independent, diagonal covariance s·I each: P_d = 2s·I.
    fn diag_cov(s: &[f64]) -> impl Fn(usize, usize) -> f64 + '_ {
        move |r, c| if r == c { s[r / 2] } else { 0.0 }
    }

    #[test]
    fn growth_is_flagged_with_pair_and_step_except_for_new_features() {
        let mut m = CovarianceMonitor::new(MonitorParams::default());
        let f2 = [[0.0, 0.0], [3.0, 0.0]];
        assert_eq!(m.check(1.0, &f2, &diag_cov(&[1.0, 1.0])), 0);
        assert_eq!(m.check(2.0, &f2, &diag_cov(&[0.5, 1.0])), 0);
        // A third feature appears with a large covariance: new, so exempt.
        let f3 = [[0.0, 0.0], [3.0, 0.0], [3.2, 0.0]];
        assert_eq!(m.check(3.0, &f3, &diag_cov(&[0.5, 1.0, 9.0])), 0);
        // Feature 2's covariance grows: pairs (0, 2) and (1, 2) violate at update 4.
        assert_eq!(m.check(4.0, &f3, &diag_cov(&[0.5, 1.0, 10.0])), 2);
        let r = m.report();
        assert_eq!(r.total_violations, 2);
        assert_eq!(r.violating_features, vec![0, 1, 2]);
        // Both violating pairs contain feature 2: it alone is implicated.
        assert_eq!(r.implicated_features, vec![2]);
        assert_eq!((r.violating_pairs[0].i, r.violating_pairs[0].j), (0, 2));
        assert_eq!(r.violating_pairs[0].first_step, 4);
        let v = r.first_violation.unwrap();
        assert!((v.before - 9.5).abs() < 1e-12 && (v.after - 10.5).abs() < 1e-12);
        assert!(r
            .describe()
            .contains("features 0 and 2 first violated at update 4"));
        // Clusters {0} and {1, 2}: pairs (0,1) = 1.5 and (0,2) = 10.5.
        let last = m.history().last().unwrap();
        assert_eq!(last.clusters, 2);
        let s = last.cluster_pairs[0];
        assert_eq!((s.a, s.b, s.pairs), (0, 1, 2));
        assert!((s.min - 1.5).abs() < 1e-12 && (s.max - 10.5).abs() < 1e-12);
        assert!((s.mean - 6.0).abs() < 1e-12);
        assert_eq!((s.min_pair, s.max_pair), ((0, 1), (0, 2)));
        assert_eq!(m.last_value(2, 0), Some(10.5));
    }

    #[test]
    fn rounding_sized_growth_is_tolerated() {
        let mut m = CovarianceMonitor::new(MonitorParams::default());
        let f = [[0.0, 0.0], [3.0, 0.0]];
        m.check(0.0, &f, &diag_cov(&[1.0, 1.0]));
        assert_eq!(m.check(1.0, &f, &diag_cov(&[1.0 + 1e-12, 1.0])), 0);
        assert_eq!(m.check(2.0, &f, &diag_cov(&[1.001, 1.0])), 1);
    }

    #[test]
    fn min_and_mean_trend_metrics() {
        let mut m = CovarianceMonitor::new(MonitorParams::default());
        let f = [[0.0, 0.0], [3.0, 0.0]];
        for s in [1.0, 0.8, 0.6, 0.5] {
            m.check(0.0, &f, &diag_cov(&[s, s]));
        }
        assert_eq!(m.min_intercluster_increases(), 0);
        assert!((m.mean_intercluster_ratio().unwrap() - 0.5).abs() < 1e-12);
        m.check(0.0, &f, &diag_cov(&[0.7, 0.7]));
        assert_eq!(m.min_intercluster_increases(), 1);
    }
}
