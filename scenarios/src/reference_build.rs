//! A reference trajectory for a log that has benchmark relations but no dense reference (MIT
//! CSAIL's CARMEN log): the poses at the log's scans that best agree with the relations and,
//! between them, with the wheel odometry, found as a 2D pose graph ([Grisetti 2010]) whose
//! edges are the relations ([Kümmerle 2009] §4: hand-checked relative poses between scan
//! stamps) and the odometry's motion between consecutive scans.
//!
//! The relations are near-exact and the odometry is only a bridge between the scans they
//! cover, so the odometry edges are weak: their standard deviation grows with the motion they
//! span (the odometry's own error is a few per cent of the distance, and it must never pull a
//! relation apart). The result is only as good as the relations' coverage: how far it is from
//! the truth is estimated by cross-validation, fitting on half of the relations and scoring
//! on the other half ([`ReferenceSummary::held_out`]), which is the figure a scenario should
//! give as its `reference_accuracy_m` (a fit's error on its own relations says nothing).

use crate::error::ScenarioError;
use crate::log::{check_order, pick_topic};
use crate::relations::{score, RelationsScore};
use crate::trajectory::pose_at;
use atrium_formats::relations::Relation;
use atrium_formats::robot_log::RobotLog;
use atrium_formats::ros_msgs::{yaw_of, MessageKind};
use atrium_localization::pose_graph::{diagonal_information, PoseGraph};
use atrium_robots::Pose2;
use serde::Serialize;
use std::path::Path;

/// Standard deviation of a relation edge: translation m, heading rad. The benchmark gives no
/// covariance; its relations were checked by hand to the scan matcher's precision.
pub const RELATION_SIGMA: [f64; 2] = [0.02, 0.2_f64 * std::f64::consts::PI / 180.0];

/// Standard deviation of an odometry edge: a floor plus a fraction of the motion it spans.
pub const ODOMETRY_SIGMA_FLOOR: [f64; 2] = [0.05, 0.02];
pub const ODOMETRY_SIGMA_PER_MOTION: f64 = 0.2;

/// Gauss–Newton iterations at most per fit.
const MAX_ITERATIONS: usize = 50;

/// What went into a reference and how good it is.
#[derive(Debug, Clone, Serialize)]
pub struct ReferenceSummary {
    pub scans: usize,
    pub relations_used: usize,
    /// Relations whose stamps match no scan of the log.
    pub relations_unmatched: usize,
    /// The reference's error on the relations it was fitted to (small by construction).
    pub fit: RelationsScore,
    /// Two-fold cross-validation: fitted on the even-numbered relations and scored on the
    /// odd-numbered ones, and the other way round; the means of the two folds. The estimate
    /// of the reference's own error between relation stamps.
    pub held_out: RelationsScore,
    pub iterations: usize,
}

/// The index of the scan stamped `t` (within half the smallest scan interval), if any.
fn node_of(stamps: &[f64], t: f64, tolerance: f64) -> Option<usize> {
    let i = stamps.partition_point(|s| *s < t);
    [i.checked_sub(1), Some(i)]
        .into_iter()
        .flatten()
        .filter(|&k| k < stamps.len())
        .min_by(|&a, &b| (stamps[a] - t).abs().total_cmp(&(stamps[b] - t).abs()))
        .filter(|&k| (stamps[k] - t).abs() <= tolerance)
}

/// The odometry edge's diagonal information for a motion `m`.
fn odometry_information(m: &Pose2) -> [f64; 3] {
    let s_xy = ODOMETRY_SIGMA_FLOOR[0] + ODOMETRY_SIGMA_PER_MOTION * m.x.hypot(m.y);
    let s_th = ODOMETRY_SIGMA_FLOOR[1] + ODOMETRY_SIGMA_PER_MOTION * m.theta.abs();
    [
        1.0 / (s_xy * s_xy),
        1.0 / (s_xy * s_xy),
        1.0 / (s_th * s_th),
    ]
}

/// Poses at `stamps` from `odometry` (the initial guess) optimised against the relations
/// edges `rel_edges` (node pairs and motions). Returns the poses and the iterations used.
fn fit(
    odometry: &[Pose2],
    rel_edges: &[(usize, usize, Pose2)],
) -> Result<(Vec<Pose2>, usize), String> {
    let mut graph = PoseGraph::new(odometry.to_vec());
    for k in 1..odometry.len() {
        let z = odometry[k - 1].between(&odometry[k]);
        graph.add_edge(k - 1, k, z, diagonal_information(odometry_information(&z)));
    }
    let w_rel = [
        1.0 / RELATION_SIGMA[0].powi(2),
        1.0 / RELATION_SIGMA[0].powi(2),
        1.0 / RELATION_SIGMA[1].powi(2),
    ];
    for &(i, j, z) in rel_edges {
        graph.add_edge(i, j, z, diagonal_information(w_rel));
    }
    let summary = graph.optimize(MAX_ITERATIONS).map_err(|e| e.to_string())?;
    Ok((graph.poses().to_vec(), summary.iterations))
}

fn track(stamps: &[f64], poses: &[Pose2]) -> Vec<(f64, Pose2)> {
    stamps.iter().copied().zip(poses.iter().copied()).collect()
}

/// Builds the reference of the log at `log_path` from `relations` (log time): poses at the
/// scans of `scan_topic` (default: the log's only LaserScan topic), starting from the
/// odometry of `odom_topic`. The first scan's pose is its odometry pose, which fixes the
/// frame. Errors name `log_path` and the flag (`--scan-topic`, `--odom-topic`,
/// `--relations`).
pub fn build_reference(
    log_path: &Path,
    scan_topic: Option<&str>,
    odom_topic: Option<&str>,
    relations: &[Relation],
    relations_path: &Path,
) -> Result<(Vec<(f64, Pose2)>, ReferenceSummary), ScenarioError> {
    let log = RobotLog::open(log_path)?;
    let scan_topic = pick_topic(
        log_path,
        &log,
        "scan_topic",
        scan_topic,
        MessageKind::LaserScan,
    )?;
    let odom_topic = pick_topic(
        log_path,
        &log,
        "odom_topic",
        odom_topic,
        MessageKind::Odometry,
    )?;
    let stamps: Vec<f64> = log
        .scans(&scan_topic)?
        .iter()
        .map(|s| s.header.stamp)
        .collect();
    let odom: Vec<(f64, Pose2)> = log
        .odometry(&odom_topic)?
        .iter()
        .map(|o| {
            (
                o.header.stamp,
                Pose2::new(o.position[0], o.position[1], yaw_of(o.orientation)),
            )
        })
        .collect();
    check_order(log_path, &scan_topic, stamps.iter().copied())?;
    check_order(log_path, &odom_topic, odom.iter().map(|(t, _)| *t))?;
    if stamps.len() < 2 {
        return Err(ScenarioError::field(
            log_path,
            &scan_topic,
            format!("holds {} scans: a reference needs at least 2", stamps.len()),
        ));
    }
    // Odometry at each scan: interpolated, or held at the ends of the odometry.
    let initial: Vec<Pose2> = stamps
        .iter()
        .map(|&t| {
            pose_at(&odom, t, f64::INFINITY).unwrap_or(if t < odom[0].0 {
                odom[0].1
            } else {
                odom[odom.len() - 1].1
            })
        })
        .collect();
    if let Some(p) = initial.iter().find(|p| !p.is_finite()) {
        return Err(ScenarioError::field(
            log_path,
            &odom_topic,
            format!("an odometry pose is not finite: {p:?}"),
        ));
    }
    let min_gap = stamps
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    let tolerance = (0.5 * min_gap).min(0.01);
    let mut edges = Vec::new();
    let mut unmatched = 0;
    for r in relations {
        match (
            node_of(&stamps, r.t1, tolerance),
            node_of(&stamps, r.t2, tolerance),
        ) {
            (Some(i), Some(j)) if i != j => edges.push((i, j, r.motion)),
            _ => unmatched += 1,
        }
    }
    if edges.len() < 2 {
        return Err(ScenarioError::field(
            relations_path,
            "t1/t2",
            format!(
                "{} of {} relations join two scans of {} ({scan_topic}): a reference needs \
                 at least 2 (are the relations of this log?)",
                edges.len(),
                relations.len(),
                log_path.display()
            ),
        ));
    }
    let fail = |e: String| ScenarioError::field(relations_path, "relations", e);
    let matched: Vec<Relation> = relations
        .iter()
        .filter(|r| {
            matches!((node_of(&stamps, r.t1, tolerance), node_of(&stamps, r.t2, tolerance)),
                (Some(i), Some(j)) if i != j)
        })
        .cloned()
        .collect();
    // Two folds, each scored on the relations it did not see.
    let mut folds = Vec::new();
    let mut iterations = 0;
    for parity in 0..2 {
        let train: Vec<_> = edges
            .iter()
            .enumerate()
            .filter(|(k, _)| k % 2 == parity)
            .map(|(_, e)| *e)
            .collect();
        let test: Vec<Relation> = matched
            .iter()
            .enumerate()
            .filter(|(k, _)| k % 2 != parity)
            .map(|(_, r)| *r)
            .collect();
        let (poses, it) = fit(&initial, &train).map_err(fail)?;
        iterations += it;
        if let Some(s) = score(&track(&stamps, &poses), &test, f64::INFINITY) {
            folds.push(s);
        }
    }
    let (poses, it) = fit(&initial, &edges).map_err(fail)?;
    iterations += it;
    let reference = track(&stamps, &poses);
    let fitted = score(&reference, &matched, f64::INFINITY)
        .ok_or_else(|| fail("no relation could be scored on the fitted reference".into()))?;
    let mean = |f: fn(&RelationsScore) -> f64| {
        folds.iter().map(f).sum::<f64>() / folds.len().max(1) as f64
    };
    let held_out = RelationsScore {
        trans_mean_m: mean(|s| s.trans_mean_m),
        trans_std_m: mean(|s| s.trans_std_m),
        rot_mean_deg: mean(|s| s.rot_mean_deg),
        rot_std_deg: mean(|s| s.rot_std_deg),
        count: folds.iter().map(|s| s.count).sum(),
        skipped: folds.iter().map(|s| s.skipped).sum(),
    };
    Ok((
        reference,
        ReferenceSummary {
            scans: stamps.len(),
            relations_used: edges.len(),
            relations_unmatched: unmatched,
            fit: fitted,
            held_out,
            iterations,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stamps_match_the_nearest_scan_within_tolerance() {
        let s = [0.0, 0.1, 0.2, 0.3];
        assert_eq!(node_of(&s, 0.1004, 0.01), Some(1));
        assert_eq!(node_of(&s, 0.196, 0.01), Some(2));
        assert_eq!(node_of(&s, 0.15, 0.01), None);
        assert_eq!(node_of(&s, 0.9, 0.01), None);
        assert_eq!(node_of(&s, -0.005, 0.01), Some(0));
    }

    /// A square loop driven with an odometry that turns 5 % too far: the relations around
    /// the loop pull the poses back onto the true square, far closer than the odometry.
    #[test]
    fn relations_correct_a_drifting_odometry() {
        let mut truth = vec![Pose2::default()];
        let mut odo = vec![Pose2::default()];
        for k in 0..40 {
            let turn = if k % 10 == 9 {
                std::f64::consts::FRAC_PI_2
            } else {
                0.0
            };
            let step = Pose2::new(0.5, 0.0, turn);
            let bad = Pose2::new(0.5, 0.0, turn * 1.05);
            truth.push(truth[k].compose(&step));
            odo.push(odo[k].compose(&bad));
        }
        let mut edges = Vec::new();
        for k in (0..truth.len() - 3).step_by(2) {
            edges.push((k, k + 3, truth[k].between(&truth[k + 3])));
        }
        edges.push((0, 40, truth[0].between(&truth[40])));
        let (poses, _) = fit(&odo, &edges).unwrap();
        let err = |p: &[Pose2]| {
            p.iter()
                .zip(&truth)
                .map(|(a, b)| (a.x - b.x).hypot(a.y - b.y))
                .fold(0.0, f64::max)
        };
        assert!(err(&odo) > 0.5, "odometry error {}", err(&odo));
        assert!(err(&poses) < 0.02, "fitted error {}", err(&poses));
    }
}
