//! The point estimate of a particle set: the weighted mean of the whole set, or the weighted
//! mean of its heaviest cluster, as ROS amcl reports it. The mean of a cloud split between two
//! corridors lies in the wall between them, metres from either hypothesis; the heaviest
//! cluster's mean sits on the likelier one and jumps when the other overtakes it. [004] §3
//! reports end errors of such multi-modal clouds in the open atrium: the cluster estimate is
//! what makes those errors the distance to a hypothesis rather than to a mid-point.
//!
//! Clusters are connected components of occupied histogram bins (x, y, θ; 26-neighbourhood,
//! θ wrapping), the clustering amcl does on its kd-tree leaves.

use crate::filter::lattice::floor_i64;
use crate::filter::particles::{weighted_mean_covariance_of, HeadingTrig};
use atrium_robots::Pose2;
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::f64::consts::PI;
use std::hash::{BuildHasherDefault, Hasher};

/// Which point estimate a particle filter reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PointEstimate {
    /// The weighted mean (circular for θ) of every particle.
    WeightedMean,
    /// The weighted mean of the cluster with the largest total weight (ROS amcl).
    #[default]
    HeaviestCluster,
}

/// Bin size of the clustering (x m, y m, θ rad): amcl's kd-tree leaves, 0.5 m and 10°.
pub const CLUSTER_BIN: [f64; 3] = [0.5, 0.5, 10.0 * PI / 180.0];

/// A multiplicative hash for small integer keys: the std SipHash costs more than the
/// clustering itself for a few thousand bins.
#[derive(Default)]
struct BinHasher(u64);

impl Hasher for BinHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    // An [i64; 3] key arrives as its length, then its 24 bytes at once (integer slices hash
    // as bytes): a word at a time, four mixing steps a key instead of 32.
    fn write(&mut self, bytes: &[u8]) {
        let mut words = bytes.chunks_exact(8);
        for word in &mut words {
            let mut w = [0u8; 8];
            w.copy_from_slice(word);
            self.write_u64(u64::from_ne_bytes(w));
        }
        for &b in words.remainder() {
            self.write_u64(u64::from(b));
        }
    }
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
    fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
}

type Bins = HashMap<[i64; 3], u32, BuildHasherDefault<BinHasher>>;

/// Scratch space of the clustering, kept by a filter so estimating allocates nothing once warm.
#[derive(Debug, Default, Clone)]
pub struct ClusterScratch {
    bin_of: Bins,
    keys: Vec<[i64; 3]>,
    parent: Vec<u32>,
    weight: Vec<f64>,
    particle_bin: Vec<u32>,
}

impl ClusterScratch {
    /// Room for `particles` particles (and as many bins), so clustering never allocates.
    pub fn with_capacity(particles: usize) -> ClusterScratch {
        ClusterScratch {
            bin_of: Bins::with_capacity_and_hasher(particles, Default::default()),
            keys: Vec::with_capacity(particles),
            parent: Vec::with_capacity(particles),
            weight: Vec::with_capacity(particles),
            particle_bin: Vec::with_capacity(particles),
        }
    }
}

fn find(parent: &mut [u32], mut i: u32) -> u32 {
    while parent[i as usize] != i {
        let up = parent[parent[i as usize] as usize];
        parent[i as usize] = up;
        i = up;
    }
    i
}

/// The histogram bin of a pose; θ bins count from −π and wrap at `theta_bins`.
fn bin_key(x: f64, y: f64, th: f64, bin: &[f64; 3], theta_bins: i64) -> [i64; 3] {
    let t = floor_i64((th + PI) / bin[2]);
    [
        floor_i64(x / bin[0]),
        floor_i64(y / bin[1]),
        t.rem_euclid(theta_bins),
    ]
}

/// The estimate of a particle set (weights summing to one) as `kind` asks, with its covariance
/// and the weight of the particles it summarises (1 for the weighted mean).
pub fn point_estimate(
    kind: PointEstimate,
    x: &[f64],
    y: &[f64],
    th: &[f64],
    w: &[f64],
    trig: HeadingTrig<'_>,
    scratch: &mut ClusterScratch,
) -> (Pose2, Matrix3<f64>, f64) {
    match kind {
        PointEstimate::WeightedMean => {
            let (mean, cov) = weighted_mean_covariance_of(x, y, th, w, trig, |_| true);
            (mean, cov, 1.0)
        }
        PointEstimate::HeaviestCluster => {
            heaviest_cluster(x, y, th, w, trig, &CLUSTER_BIN, scratch)
        }
    }
}

/// Weighted mean and covariance of the heaviest cluster of bins of size `bin`, and its weight.
pub fn heaviest_cluster(
    x: &[f64],
    y: &[f64],
    th: &[f64],
    w: &[f64],
    trig: HeadingTrig<'_>,
    bin: &[f64; 3],
    s: &mut ClusterScratch,
) -> (Pose2, Matrix3<f64>, f64) {
    let n = w.len();
    let theta_bins = ((2.0 * PI / bin[2]).ceil() as i64).max(1);
    s.bin_of.clear();
    s.keys.clear();
    s.weight.clear();
    s.particle_bin.clear();
    // Resampling leaves a particle's copies side by side, and a tight cloud fills few bins:
    // most particles share the bin of the one before, found without hashing.
    let mut last: Option<([i64; 3], u32)> = None;
    for i in 0..n {
        let key = bin_key(x[i], y[i], th[i], bin, theta_bins);
        let b = match last {
            Some((k, b)) if k == key => b,
            _ => {
                let next = s.keys.len() as u32;
                let b = *s.bin_of.entry(key).or_insert(next);
                if b == next {
                    s.keys.push(key);
                    s.weight.push(0.0);
                }
                last = Some((key, b));
                b
            }
        };
        s.weight[b as usize] += w[i];
        s.particle_bin.push(b);
    }
    let bins = s.keys.len();
    if bins <= 1 {
        let (mean, cov) = weighted_mean_covariance_of(x, y, th, w, trig, |_| true);
        return (mean, cov, 1.0);
    }
    s.parent.clear();
    s.parent.extend(0..bins as u32);
    for b in 0..bins {
        let [kx, ky, kt] = s.keys[b];
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dt in -1..=1 {
                    let key = [kx + dx, ky + dy, (kt + dt).rem_euclid(theta_bins)];
                    if let Some(&o) = s.bin_of.get(&key) {
                        let (ra, rb) = (find(&mut s.parent, b as u32), find(&mut s.parent, o));
                        if ra != rb {
                            s.parent[ra.max(rb) as usize] = ra.min(rb);
                        }
                    }
                }
            }
        }
    }
    // Cluster weights accumulate at their roots; ties go to the lowest root (deterministic).
    let mut cluster_weight = std::mem::take(&mut s.weight);
    for b in 0..bins {
        let r = find(&mut s.parent, b as u32) as usize;
        s.parent[b] = r as u32;
        if r != b {
            cluster_weight[r] += cluster_weight[b];
            cluster_weight[b] = 0.0;
        }
    }
    let mut best = 0;
    for b in 1..bins {
        if cluster_weight[b] > cluster_weight[best] {
            best = b;
        }
    }
    let total = cluster_weight[best];
    s.weight = cluster_weight;
    if total.is_nan() || total <= 0.0 {
        let (mean, cov) = weighted_mean_covariance_of(x, y, th, w, trig, |_| true);
        return (mean, cov, 1.0);
    }
    // Every bin's parent is its root now (set in the loop above).
    let (parent, particle_bin) = (&s.parent, &s.particle_bin);
    let (mean, cov) = weighted_mean_covariance_of(x, y, th, w, trig, |i| {
        parent[particle_bin[i] as usize] as usize == best
    });
    (mean, cov, total)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud(parts: &[(f64, f64, f64, usize, f64)]) -> [Vec<f64>; 4] {
        let (mut x, mut y, mut th, mut w) = (vec![], vec![], vec![], vec![]);
        for &(cx, cy, ct, n, weight) in parts {
            for k in 0..n {
                // A small deterministic spread inside 0.3 m and 3°.
                let f = k as f64 / n as f64 - 0.5;
                x.push(cx + 0.3 * f);
                y.push(cy - 0.2 * f);
                th.push(ct + 0.05 * f);
                w.push(weight / n as f64);
            }
        }
        [x, y, th, w]
    }

    #[test]
    fn a_two_mode_cloud_reports_the_heavier_mode_not_the_wall_between() {
        let [x, y, th, w] = cloud(&[(0.0, 0.0, 0.0, 100, 0.4), (10.0, 4.0, 1.0, 100, 0.6)]);
        let mut s = ClusterScratch::default();
        let mut estimate =
            |kind| point_estimate(kind, &x, &y, &th, &w, HeadingTrig::Compute, &mut s);
        let (mean, cov, weight) = estimate(PointEstimate::HeaviestCluster);
        assert!(
            (mean.x - 10.0).abs() < 0.01 && (mean.y - 4.0).abs() < 0.01,
            "{mean:?}"
        );
        assert!((mean.theta - 1.0).abs() < 0.01);
        assert!((weight - 0.6).abs() < 1e-12);
        assert!(
            cov[(0, 0)] < 0.02,
            "the cluster's own spread, not the modes': {cov}"
        );
        let (whole, whole_cov, _) = estimate(PointEstimate::WeightedMean);
        assert!((whole.x - 6.0).abs() < 0.01, "{whole:?}");
        assert!(whole_cov[(0, 0)] > 20.0);
    }

    #[test]
    fn one_connected_cloud_is_its_own_cluster() {
        // A 3 m streak along x in 0.05 m steps: bins touch, so one cluster, the whole mean.
        let n = 61;
        let x: Vec<f64> = (0..n).map(|i| 0.05 * i as f64).collect();
        let y = vec![1.0; n];
        let th = vec![PI - 0.01; n];
        let w = vec![1.0 / n as f64; n];
        let mut s = ClusterScratch::default();
        let (c, _, weight) =
            heaviest_cluster(&x, &y, &th, &w, HeadingTrig::Compute, &CLUSTER_BIN, &mut s);
        let (m, _) = weighted_mean_covariance_of(&x, &y, &th, &w, HeadingTrig::Compute, |_| true);
        assert!((weight - 1.0).abs() < 1e-9);
        assert!((c.x - m.x).abs() < 1e-12 && (c.theta - m.theta).abs() < 1e-12);
    }

    #[test]
    fn given_headings_and_interleaved_bins_give_the_same_estimate_bit_for_bit() {
        // Two modes, their particles interleaved so that consecutive particles change bins
        // (the clustering's shortcut for a run of one bin must not carry over), and the
        // headings' sines and cosines given as a sensor model would have them.
        // The modes share their x bins, so only a whole-key comparison tells them apart.
        let [x, y, th, w] = cloud(&[(0.0, 0.0, 0.0, 50, 0.4), (0.0, 4.0, 1.0, 50, 0.6)]);
        let order: Vec<usize> = (0..50).flat_map(|k| [k, 50 + k]).collect();
        let pick = |c: &[f64]| order.iter().map(|&i| c[i]).collect::<Vec<f64>>();
        let (xi, yi, ti, wi) = (pick(&x), pick(&y), pick(&th), pick(&w));
        let (sin, cos): (Vec<f64>, Vec<f64>) = ti.iter().map(|t| t.sin_cos()).unzip();
        let given = HeadingTrig::Given {
            sin: &sin,
            cos: &cos,
        };
        let mut s = ClusterScratch::default();
        for kind in [PointEstimate::HeaviestCluster, PointEstimate::WeightedMean] {
            let (a, ca, wa) = point_estimate(kind, &x, &y, &th, &w, HeadingTrig::Compute, &mut s);
            let (b, cb, wb) = point_estimate(kind, &xi, &yi, &ti, &wi, given, &mut s);
            let (c, cc, wc) =
                point_estimate(kind, &xi, &yi, &ti, &wi, HeadingTrig::Compute, &mut s);
            assert_eq!((b, cb, wb.to_bits()), (c, cc, wc.to_bits()), "{kind:?}");
            // Interleaving changes only the summation order: the same mode, to rounding.
            assert!(
                (a.x - b.x).abs() < 1e-9 && (wa - wb).abs() < 1e-12,
                "{kind:?}"
            );
            assert!((ca - cb).amax() < 1e-9, "{kind:?}");
        }
    }

    #[test]
    fn headings_either_side_of_pi_are_neighbours() {
        // Two groups at θ = ±(π − 0.02): adjacent across the wrap, so one cluster of weight 1.
        let x = vec![0.0, 0.1, 0.0, 0.1];
        let y = vec![0.0; 4];
        let th = vec![PI - 0.02, PI - 0.02, -PI + 0.02, -PI + 0.02];
        let w = vec![0.25; 4];
        let mut s = ClusterScratch::default();
        let (c, _, weight) =
            heaviest_cluster(&x, &y, &th, &w, HeadingTrig::Compute, &CLUSTER_BIN, &mut s);
        assert!((weight - 1.0).abs() < 1e-12);
        assert!(c.theta.abs() > PI - 0.03, "{c:?}");
    }
}
