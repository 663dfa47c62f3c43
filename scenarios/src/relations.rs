//! The relations metric of [Kümmerle 2009] §4: a trajectory's motion between the two stamps
//! of each benchmark relation compared with the relation, as a translation error (m) and a
//! rotation error (deg), summarised by their means and standard deviations. It needs no
//! global frame, so it scores a localizer against the benchmark's hand-checked relative
//! poses as it scores a SLAM system.

use crate::trajectory::pose_at;
use atrium_formats::relations::Relation;
use atrium_robots::Pose2;
use serde::Serialize;

/// A trajectory scored against relations.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RelationsScore {
    pub trans_mean_m: f64,
    pub trans_std_m: f64,
    pub rot_mean_deg: f64,
    pub rot_std_deg: f64,
    /// Relations scored (both stamps inside the trajectory).
    pub count: usize,
    /// Relations left out: a stamp outside the trajectory or across a gap of it.
    pub skipped: usize,
}

/// Translation (m) and rotation (rad, absolute) error of an estimated motion against a
/// relation's: the residual motion `relation⁻¹ ⊕ estimated` [Kümmerle 2009] eq. 2.
pub fn relation_error(estimated: &Pose2, relation: &Pose2) -> (f64, f64) {
    let e = relation.between(estimated);
    (e.x.hypot(e.y), e.theta.abs())
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n;
    (mean, var.sqrt())
}

/// Scores `trajectory` (sorted by strictly increasing time) against `relations`; a relation's
/// stamps are looked up in the trajectory with [`pose_at`] (interpolated across gaps of at
/// most `max_gap_s`). `None` when no relation could be scored.
pub fn score(
    trajectory: &[(f64, Pose2)],
    relations: &[Relation],
    max_gap_s: f64,
) -> Option<RelationsScore> {
    let mut trans = Vec::with_capacity(relations.len());
    let mut rot = Vec::with_capacity(relations.len());
    for r in relations {
        let (Some(a), Some(b)) = (
            pose_at(trajectory, r.t1, max_gap_s),
            pose_at(trajectory, r.t2, max_gap_s),
        ) else {
            continue;
        };
        let (t, q) = relation_error(&a.between(&b), &r.motion);
        trans.push(t);
        rot.push(q.to_degrees());
    }
    if trans.is_empty() {
        return None;
    }
    let (trans_mean_m, trans_std_m) = mean_std(&trans);
    let (rot_mean_deg, rot_std_deg) = mean_std(&rot);
    Some(RelationsScore {
        trans_mean_m,
        trans_std_m,
        rot_mean_deg,
        rot_std_deg,
        count: trans.len(),
        skipped: relations.len() - trans.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(t1: f64, t2: f64, x: f64, y: f64, th: f64) -> Relation {
        Relation {
            t1,
            t2,
            motion: Pose2::new(x, y, th),
        }
    }

    #[test]
    fn a_trajectory_that_moves_as_the_relations_scores_zero() {
        // A robot driving a quarter circle: relations are its own motions.
        let traj: Vec<(f64, Pose2)> = (0..=10)
            .map(|k| {
                let a = 0.1 * k as f64;
                (k as f64, Pose2::new(a.sin(), 1.0 - a.cos(), a))
            })
            .collect();
        let rels: Vec<Relation> = (0..10)
            .map(|k| {
                let m = traj[k].1.between(&traj[k + 1].1);
                rel(k as f64, k as f64 + 1.0, m.x, m.y, m.theta)
            })
            .collect();
        let s = score(&traj, &rels, 1.5).unwrap();
        assert!(s.trans_mean_m < 1e-12 && s.rot_mean_deg < 1e-9);
        assert_eq!((s.count, s.skipped), (10, 0));
    }

    #[test]
    fn errors_are_measured_in_the_first_pose_frame() {
        // Facing +y, the robot moves 1 m forward: the relation says 1 m ahead and 0.1 rad.
        let traj = [
            (0.0, Pose2::new(0.0, 0.0, std::f64::consts::FRAC_PI_2)),
            (1.0, Pose2::new(0.0, 1.0, std::f64::consts::FRAC_PI_2)),
        ];
        let s = score(&traj, &[rel(0.0, 1.0, 1.2, 0.0, 0.1)], 2.0).unwrap();
        assert!((s.trans_mean_m - 0.2).abs() < 1e-12);
        assert!((s.rot_mean_deg - 0.1f64.to_degrees()).abs() < 1e-9);
        assert_eq!(s.trans_std_m, 0.0);
        // Hand-computed mean and std over two relations.
        let two = [rel(0.0, 1.0, 1.2, 0.0, 0.0), rel(0.0, 1.0, 1.4, 0.0, 0.0)];
        let s = score(&traj, &two, 2.0).unwrap();
        assert!((s.trans_mean_m - 0.3).abs() < 1e-12 && (s.trans_std_m - 0.1).abs() < 1e-12);
    }

    #[test]
    fn stamps_outside_the_trajectory_are_skipped() {
        let traj = [(0.0, Pose2::default()), (1.0, Pose2::new(1.0, 0.0, 0.0))];
        let s = score(
            &traj,
            &[rel(0.0, 1.0, 1.0, 0.0, 0.0), rel(0.5, 3.0, 1.0, 0.0, 0.0)],
            2.0,
        )
        .unwrap();
        assert_eq!((s.count, s.skipped), (1, 1));
        assert!(score(&traj, &[rel(5.0, 6.0, 0.0, 0.0, 0.0)], 2.0).is_none());
    }
}
