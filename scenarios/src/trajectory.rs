//! Poses between samples: a time-stamped track looked up at any instant, as a log's
//! odometry is read at its scans' stamps and a reference or a localizer's trajectory at a
//! relation's stamps.

use atrium_robots::{normalize_angle, Pose2};

/// Stamps closer than this are the same instant (stamps that went through nanoseconds or a
/// rounded text file are not bit-exact).
pub const SNAP_S: f64 = 1e-6;

/// `a` moved a fraction `f` of the way to `b`: position linearly, heading the short way.
pub fn interpolate(a: &Pose2, b: &Pose2, f: f64) -> Pose2 {
    Pose2::new(
        a.x + f * (b.x - a.x),
        a.y + f * (b.y - a.y),
        normalize_angle(a.theta + f * normalize_angle(b.theta - a.theta)),
    )
}

/// The pose of `track` (sorted by strictly increasing time) at `t`: the sample within
/// [`SNAP_S`] of it, else interpolated between the two samples around it when they are at
/// most `max_gap_s` apart; `None` outside the track or across a longer gap.
pub fn pose_at(track: &[(f64, Pose2)], t: f64, max_gap_s: f64) -> Option<Pose2> {
    let i = track.partition_point(|(s, _)| *s < t);
    if let Some((s, p)) = track.get(i) {
        if (s - t).abs() <= SNAP_S {
            return Some(*p);
        }
    }
    if i > 0 {
        let (s, p) = track[i - 1];
        if (t - s).abs() <= SNAP_S {
            return Some(p);
        }
    }
    let ((t0, a), (t1, b)) = (track.get(i.checked_sub(1)?)?, track.get(i)?);
    if t1 - t0 > max_gap_s {
        return None;
    }
    Some(interpolate(a, b, (t - t0) / (t1 - t0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn snaps_interpolates_and_refuses_gaps() {
        let track = [
            (1.0, Pose2::new(0.0, 0.0, 3.0)),
            (2.0, Pose2::new(1.0, 2.0, -3.0)),
            (10.0, Pose2::new(5.0, 5.0, 0.0)),
        ];
        assert_eq!(pose_at(&track, 1.0 + 1e-7, 1.0), Some(track[0].1));
        let mid = pose_at(&track, 1.5, 1.0).unwrap();
        assert_eq!((mid.x, mid.y), (0.5, 1.0));
        // 3 -> -3 rad the short way passes through pi.
        assert!((mid.theta.abs() - std::f64::consts::PI).abs() < 1e-12);
        assert_eq!(pose_at(&track, 5.0, 1.0), None, "an 8 s gap");
        assert!(pose_at(&track, 5.0, 10.0).is_some());
        assert_eq!(pose_at(&track, 0.5, 1.0), None);
        assert_eq!(pose_at(&track, 10.5, 1.0), None);
        assert_eq!(pose_at(&track, 10.0, 1.0), Some(track[2].1));
    }
}
