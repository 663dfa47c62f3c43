//! Aligning the scan taken at verification with the node's training scan: the offset that
//! turns the paper's "x, y = x_n, y_n" reset into "the pose is the node's training pose,
//! corrected by where the robot stands relative to it".
//!
//! BEYOND THE PAPER. [002] (Table I update(), Algorithm 1 line 14) resets
//! only x and y to the node, so the robot inherits the whole offset between where it stands
//! and the node (up to ρ) and keeps its heading error. The feature triplet of eq. 5 / eq. 7
//! stores the range vector r_t and the pose x_t of each node, so the node's own training
//! scan and pose are at hand; a small point-to-line ICP of the current scan against it
//! measures x, y and θ of the robot relative to the node.

use atrium_robots::Pose2;
use nalgebra::{Matrix3, Vector3};

/// Parameters of the point-to-line ICP.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlignParams {
    /// Gauss-Newton iterations at most.
    pub iterations: usize,
    /// Pairs farther apart than this are ignored at the first iteration, m; the gate shrinks
    /// geometrically to `final_gate` (a coarse-to-fine schedule: wide enough to catch an
    /// initial error of half a metre, tight enough at the end to drop unmatched points).
    pub initial_gate: f64,
    pub final_gate: f64,
    /// The alignment is accepted only if at least this fraction of the current scan's points
    /// pair up within `final_gate` …
    pub min_inlier_fraction: f64,
    /// … with an RMS point-to-line residual of at most this, m.
    pub max_rms: f64,
}

impl Default for AlignParams {
    fn default() -> Self {
        Self {
            iterations: 40,
            initial_gate: 0.8,
            final_gate: 0.1,
            min_inlier_fraction: 0.5,
            max_rms: 0.05,
        }
    }
}

/// A scan as points in its own laser frame, with a unit normal per point (from its beam
/// neighbours; `None` where a neighbour is missing or too far to lie on the same surface).
#[derive(Debug, Clone, PartialEq)]
pub struct ScanPoints {
    pub points: Vec<[f64; 2]>,
    pub normals: Vec<Option<[f64; 2]>>,
}

impl ScanPoints {
    /// Points of the returned beams (range_min < r < range_max, finite), at angle
    /// `angle_min + i · angle_increment`.
    pub fn from_ranges(
        ranges: &[f64],
        angle_min: f64,
        angle_increment: f64,
        range_min: f64,
        range_max: f64,
    ) -> ScanPoints {
        let mut beam: Vec<Option<[f64; 2]>> = Vec::with_capacity(ranges.len());
        for (i, &r) in ranges.iter().enumerate() {
            let ok = r.is_finite() && r > range_min && r < range_max * 0.999;
            beam.push(ok.then(|| {
                let a = angle_min + i as f64 * angle_increment;
                [r * a.cos(), r * a.sin()]
            }));
        }
        let mut points = Vec::new();
        let mut normals = Vec::new();
        for i in 0..beam.len() {
            let Some(p) = beam[i] else { continue };
            let prev = i.checked_sub(1).and_then(|j| beam[j]);
            let next = beam.get(i + 1).copied().flatten();
            // Neighbours on the same surface lie within a few beam spacings of the point.
            let near = |q: Option<[f64; 2]>| {
                q.filter(|q| (q[0] - p[0]).hypot(q[1] - p[1]) < 0.15 + 0.05 * p[0].hypot(p[1]))
            };
            let n = match (near(prev), near(next)) {
                (Some(a), Some(b)) => Some([b[0] - a[0], b[1] - a[1]]),
                (Some(a), None) => Some([p[0] - a[0], p[1] - a[1]]),
                (None, Some(b)) => Some([b[0] - p[0], b[1] - p[1]]),
                (None, None) => None,
            }
            .and_then(|t| {
                let l = t[0].hypot(t[1]);
                (l > 1e-9).then(|| [-t[1] / l, t[0] / l])
            });
            points.push(p);
            normals.push(n);
        }
        ScanPoints { points, normals }
    }
}

/// Result of [`align`]: `transform` maps points of the current scan's frame into the
/// reference scan's frame (the current laser pose expressed in the reference laser frame).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Alignment {
    pub transform: Pose2,
    pub rms: f64,
    pub inlier_fraction: f64,
}

/// Point-to-line ICP of `current` onto `reference`, starting from `initial` (the current
/// laser pose in the reference frame as odometry believes it). Nearest neighbours by brute
/// force: two 180-point scans, once per node, cost nothing worth an index. Returns `None`
/// when the match is poor (too few inliers or a large residual), so that a robot that does
/// not in fact see the node's scene is not "corrected" into it.
pub fn align(
    reference: &ScanPoints,
    current: &ScanPoints,
    initial: Pose2,
    params: &AlignParams,
) -> Option<Alignment> {
    if reference.points.len() < 3 || current.points.is_empty() || !initial.is_finite() {
        return None;
    }
    let mut t = initial;
    let iters = params.iterations.max(1);
    let ratio = (params.final_gate / params.initial_gate).powf(1.0 / (iters.max(2) - 1) as f64);
    let mut gate = params.initial_gate;
    for _ in 0..iters {
        let (c, s) = (t.theta.cos(), t.theta.sin());
        let mut h = Matrix3::<f64>::zeros();
        let mut g = Vector3::<f64>::zeros();
        let mut pairs = 0usize;
        for p in &current.points {
            let q = [c * p[0] - s * p[1] + t.x, s * p[0] + c * p[1] + t.y];
            let Some((j, d2)) = nearest(reference, q) else {
                continue;
            };
            if d2 > gate * gate {
                continue;
            }
            let r = reference.points[j];
            // Point-to-line where the reference has a surface direction, point-to-point
            // otherwise (both components then).
            let dirs: [Option<[f64; 2]>; 2] = match reference.normals[j] {
                Some(n) => [Some(n), None],
                None => [Some([1.0, 0.0]), Some([0.0, 1.0])],
            };
            // ∂q/∂θ = (−s·px − c·py, c·px − s·py).
            let dq = [-s * p[0] - c * p[1], c * p[0] - s * p[1]];
            for n in dirs.into_iter().flatten() {
                let e = (q[0] - r[0]) * n[0] + (q[1] - r[1]) * n[1];
                let jac = Vector3::new(n[0], n[1], dq[0] * n[0] + dq[1] * n[1]);
                h += jac * jac.transpose();
                g += jac * e;
            }
            pairs += 1;
        }
        if pairs < 3 {
            return None;
        }
        // A small damping keeps the step finite where the scene constrains one direction
        // weakly (a long wall).
        let damped = h + Matrix3::from_diagonal(&Vector3::new(1e-6, 1e-6, 1e-6));
        let step = damped.lu().solve(&(-g))?;
        t = Pose2::new(t.x + step[0], t.y + step[1], t.theta + step[2]);
        gate = (gate * ratio).max(params.final_gate);
        if step[0].hypot(step[1]) < 1e-5 && step[2].abs() < 1e-6 && gate <= params.final_gate {
            break;
        }
    }
    // Score the final transform with the final gate.
    let (c, s) = (t.theta.cos(), t.theta.sin());
    let mut sum = 0.0;
    let mut inliers = 0usize;
    for p in &current.points {
        let q = [c * p[0] - s * p[1] + t.x, s * p[0] + c * p[1] + t.y];
        let Some((j, d2)) = nearest(reference, q) else {
            continue;
        };
        if d2 > params.final_gate * params.final_gate {
            continue;
        }
        let r = reference.points[j];
        let e2 = match reference.normals[j] {
            Some(n) => ((q[0] - r[0]) * n[0] + (q[1] - r[1]) * n[1]).powi(2),
            None => d2,
        };
        sum += e2;
        inliers += 1;
    }
    if inliers == 0 {
        return None;
    }
    let rms = (sum / inliers as f64).sqrt();
    let inlier_fraction = inliers as f64 / current.points.len() as f64;
    (t.is_finite() && inlier_fraction >= params.min_inlier_fraction && rms <= params.max_rms)
        .then_some(Alignment {
            transform: Pose2::new(t.x, t.y, atrium_robots::normalize_angle(t.theta)),
            rms,
            inlier_fraction,
        })
}

fn nearest(reference: &ScanPoints, q: [f64; 2]) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for (j, r) in reference.points.iter().enumerate() {
        let d2 = (r[0] - q[0]).powi(2) + (r[1] - q[1]).powi(2);
        if best.is_none_or(|(_, b)| d2 < b) {
            best = Some((j, d2));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ranges of a laser at `pose` (laser frame = pose) inside the axis-aligned room
    /// [0, w] × [0, h] with a box [bx0, bx1] × [by0, by1] standing in it, by ray casting.
    fn room_scan(pose: Pose2, beams: usize) -> Vec<f64> {
        let (w, h) = (6.0, 8.0);
        let boxes = [[4.0, 4.6, 5.0, 6.0], [0.0, 0.6, 1.0, 2.2]];
        (0..beams)
            .map(|i| {
                let a = pose.theta - std::f64::consts::FRAC_PI_2
                    + i as f64 * std::f64::consts::PI / (beams - 1) as f64;
                let (dx, dy) = (a.cos(), a.sin());
                let mut best = f64::INFINITY;
                // Room walls.
                for (t, ok) in [
                    ((0.0 - pose.x) / dx, dx < 0.0),
                    ((w - pose.x) / dx, dx > 0.0),
                    ((0.0 - pose.y) / dy, dy < 0.0),
                    ((h - pose.y) / dy, dy > 0.0),
                ] {
                    if ok && t > 0.0 {
                        best = best.min(t);
                    }
                }
                // Boxes (slab test).
                for b in boxes {
                    let (tx0, tx1) = ((b[0] - pose.x) / dx, (b[1] - pose.x) / dx);
                    let (ty0, ty1) = ((b[2] - pose.y) / dy, (b[3] - pose.y) / dy);
                    let t0 = tx0.min(tx1).max(ty0.min(ty1));
                    let t1 = tx0.max(tx1).min(ty0.max(ty1));
                    if t0 <= t1 && t0 > 0.0 {
                        best = best.min(t0);
                    }
                }
                best.min(8.0)
            })
            .collect()
    }

    fn points(pose: Pose2) -> ScanPoints {
        let beams = 180;
        ScanPoints::from_ranges(
            &room_scan(pose, beams),
            -std::f64::consts::FRAC_PI_2,
            std::f64::consts::PI / (beams - 1) as f64,
            0.05,
            8.0,
        )
    }

    #[test]
    fn icp_recovers_a_known_offset_from_the_identity_guess() {
        let reference_pose = Pose2::new(3.0, 3.0, 1.2);
        let reference = points(reference_pose);
        // The robot stands 0.3 m off and 4° turned; ICP starts from "at the node".
        let actual = Pose2::new(3.2, 2.8, 1.2 + 4f64.to_radians());
        let current = points(actual);
        let a = align(
            &reference,
            &current,
            Pose2::new(0.0, 0.0, 0.0),
            &AlignParams::default(),
        )
        .expect("aligned");
        let expected = reference_pose.between(&actual);
        assert!(
            (a.transform.x - expected.x).abs() < 0.01
                && (a.transform.y - expected.y).abs() < 0.01
                && (a.transform.theta - expected.theta).abs() < 0.2f64.to_radians(),
            "{a:?} vs {expected:?}"
        );
        assert!(a.rms < 0.01 && a.inlier_fraction > 0.8, "{a:?}");
    }

    #[test]
    fn a_different_scene_is_rejected() {
        let reference = points(Pose2::new(3.0, 3.0, 1.2));
        // Facing the other way: the scan shows a different part of the room.
        let current = points(Pose2::new(3.0, 3.0, 1.2 + std::f64::consts::PI));
        let tight = AlignParams {
            iterations: 10,
            initial_gate: 0.2,
            ..AlignParams::default()
        };
        assert!(align(&reference, &current, Pose2::new(0.0, 0.0, 0.0), &tight).is_none());
        assert!(align(
            &ScanPoints::from_ranges(&[], 0.0, 0.01, 0.05, 8.0),
            &current,
            Pose2::new(0.0, 0.0, 0.0),
            &tight
        )
        .is_none());
    }
}
