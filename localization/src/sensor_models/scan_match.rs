//! Local scan matching on a distance field: from a pose guess, Gauss–Newton steps on the
//! squared distances of a scan's endpoints to the nearest wall surface, each distance
//! truncated so that what the map does not hold (people, clutter, glass) pulls no pose.
//! The matcher is a field-based cousin of ICP; MCL uses it to draw poses from the
//! measurement when its belief is global, where uniform samples almost never fall into the
//! degree-wide basin a sharp laser model leaves around the true pose ([Thrun 2001] §3;
//! [Thrun 2005] §8.3.5: particles drawn in proportion to the measurement likelihood).

use crate::sensor_models::likelihood_field::LikelihoodField;
use atrium_robots::{normalize_angle, Pose2};

mod avx2;

/// How a pose is refined.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScanMatchParams {
    /// Gauss–Newton steps.
    pub iterations: usize,
    /// Endpoints farther than this from any wall (metres) are left out of a step: the
    /// truncation of the least squares.
    pub truncation: f64,
    /// Largest translation (metres) and rotation (radians) of one step, so that a step taken
    /// on a poor linearisation cannot throw the pose out of its basin.
    pub max_step: [f64; 2],
}

impl Default for ScanMatchParams {
    fn default() -> Self {
        ScanMatchParams {
            iterations: 8,
            truncation: 0.5,
            max_step: [0.25, 0.15],
        }
    }
}

/// The truncated cost Σ min(d, c)² of the endpoints `bx`, `by` (robot base frame) seen from
/// `pose`, with d the field's distance to the nearest wall surface and c the truncation.
/// Endpoints off the map cost c².
pub fn truncated_cost(
    field: &LikelihoodField,
    bx: &[f64],
    by: &[f64],
    pose: &Pose2,
    truncation: f64,
) -> f64 {
    let (s, c) = pose.theta.sin_cos();
    let c2 = truncation * truncation;
    let mut cost = 0.0;
    for (&u, &v) in bx.iter().zip(by) {
        let (x, y) = (pose.x + c * u - s * v, pose.y + s * u + c * v);
        cost += match field.distance_and_gradient(x, y) {
            Some((d, _, _)) => (d * d).min(c2),
            None => c2,
        };
    }
    cost
}

/// A field's distances resampled on cells `factor` times coarser, nearest-cell lookup, as
/// `f32`: a few hundred kilobytes for a building where the field's own table is tens of
/// megabytes. Scoring hundreds of thousands of random poses reads the table at random, and
/// a table that stays in the processor's cache makes that several times faster; the ranking
/// it gives only has to keep the candidates that refinement on the full field will finish.
#[derive(Debug, Clone)]
pub struct CoarseDistance {
    origin: [f64; 2],
    inv_resolution: f64,
    width: usize,
    height: usize,
    dist: Vec<f32>,
    /// Groups of poses go through the AVX2 kernel (the processor has it, and every cell
    /// index fits in i32).
    avx2: bool,
}

impl CoarseDistance {
    /// Samples `field`'s distance at the centre of every coarse cell (`factor` ≥ 1 fine
    /// cells a side, the last row and column possibly partial).
    pub fn new(field: &LikelihoodField, factor: usize) -> CoarseDistance {
        let factor = factor.max(1);
        let (w, h) = field.size();
        let res = field.resolution() * factor as f64;
        let origin = field.origin();
        let (width, height) = (w.div_ceil(factor), h.div_ceil(factor));
        let mut dist = Vec::with_capacity(width * height);
        for j in 0..height {
            for i in 0..width {
                let x = origin[0] + (i as f64 + 0.5) * res;
                let y = origin[1] + (j as f64 + 0.5) * res;
                let far = field.params().max_dist;
                dist.push(field.distance(x, y).unwrap_or(far) as f32);
            }
        }
        CoarseDistance {
            origin,
            inv_resolution: 1.0 / res,
            width,
            height,
            avx2: crate::sensor_models::simd::avx2_available() && dist.len() <= i32::MAX as usize,
            dist,
        }
    }

    /// The distances as the AVX2 kernel reads them.
    #[cfg(target_arch = "x86_64")]
    fn table(&self) -> crate::sensor_models::simd::GridTable<'_> {
        crate::sensor_models::simd::GridTable {
            origin: self.origin,
            inv_resolution: self.inv_resolution,
            width: self.width,
            height: self.height,
            cells: &self.dist,
        }
    }

    /// The distance of the coarse cell holding (x, y), `None` outside (or at NaN).
    #[inline]
    pub fn distance(&self, x: f64, y: f64) -> Option<f64> {
        let fx = (x - self.origin[0]) * self.inv_resolution;
        let fy = (y - self.origin[1]) * self.inv_resolution;
        if fx >= 0.0 && fy >= 0.0 && fx < self.width as f64 && fy < self.height as f64 {
            Some(self.dist[fy as usize * self.width + fx as usize] as f64)
        } else {
            None
        }
    }

    /// [`CoarseDistance::truncated_cost`] of every pose of `poses` into `out` (as long),
    /// bit for bit; four poses at a time with AVX2 where the processor has it.
    pub fn truncated_costs(
        &self,
        bx: &[f64],
        by: &[f64],
        poses: &[Pose2],
        truncation: f64,
        out: &mut [f64],
    ) {
        let out = &mut out[..poses.len()];
        let mut done = 0;
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the processor has AVX2 and the cell indices
            // fit in i32 (see `new`), and `out` is as long as `poses`.
            done = unsafe {
                avx2::truncated_costs(&self.table(), bx, by, poses, truncation * truncation, out)
            };
        }
        for (o, p) in out.iter_mut().zip(poses).skip(done) {
            *o = self.truncated_cost(bx, by, p, truncation);
        }
    }

    /// [`truncated_cost`] on the coarse cells.
    pub fn truncated_cost(&self, bx: &[f64], by: &[f64], pose: &Pose2, truncation: f64) -> f64 {
        let (s, c) = pose.theta.sin_cos();
        let c2 = truncation * truncation;
        let mut cost = 0.0;
        for (&u, &v) in bx.iter().zip(by) {
            let (x, y) = (pose.x + c * u - s * v, pose.y + s * u + c * v);
            cost += match self.distance(x, y) {
                Some(d) => (d * d).min(c2),
                None => c2,
            };
        }
        cost
    }
}

/// Refines `pose` so that the endpoints `bx`, `by` (robot base frame) lie on the walls of
/// `field`: Gauss–Newton on the truncated squared distances, each step bounded by
/// `max_step`, stopping early when a step no longer moves the pose by a millimetre or a
/// hundredth of a degree. Returns the refined pose and its [`truncated_cost`].
pub fn refine(
    field: &LikelihoodField,
    bx: &[f64],
    by: &[f64],
    pose: Pose2,
    params: &ScanMatchParams,
) -> (Pose2, f64) {
    let mut pose = pose;
    let t = params.truncation;
    for _ in 0..params.iterations {
        let (s, c) = pose.theta.sin_cos();
        // Normal equations JᵀJ δ = −Jᵀr for r = d, J = ∂d/∂(x, y, θ), symmetric 3 × 3.
        let (mut hxx, mut hxy, mut hxt, mut hyy, mut hyt, mut htt) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let (mut gx, mut gy, mut gt) = (0.0, 0.0, 0.0);
        let mut used = 0usize;
        for (&u, &v) in bx.iter().zip(by) {
            let (x, y) = (pose.x + c * u - s * v, pose.y + s * u + c * v);
            let Some((d, dx, dy)) = field.distance_and_gradient(x, y) else {
                continue;
            };
            if d >= t {
                continue;
            }
            // ∂p/∂θ = (−s·u − c·v, c·u − s·v).
            let jt = dx * (-s * u - c * v) + dy * (c * u - s * v);
            hxx += dx * dx;
            hxy += dx * dy;
            hxt += dx * jt;
            hyy += dy * dy;
            hyt += dy * jt;
            htt += jt * jt;
            gx += dx * d;
            gy += dy * d;
            gt += jt * d;
            used += 1;
        }
        if used < 3 {
            break;
        }
        // A little damping keeps the step defined along a corridor, where the walls say
        // nothing about the along-track position.
        let damp = 1e-3 * (hxx + hyy + htt) + 1e-9;
        let Some(step) = solve3(
            [
                [hxx + damp, hxy, hxt],
                [hxy, hyy + damp, hyt],
                [hxt, hyt, htt + damp],
            ],
            [-gx, -gy, -gt],
        ) else {
            break;
        };
        let norm = step[0].hypot(step[1]);
        let scale_t = if norm > params.max_step[0] {
            params.max_step[0] / norm
        } else {
            1.0
        };
        let dth = step[2].clamp(-params.max_step[1], params.max_step[1]);
        pose = Pose2::new(
            pose.x + step[0] * scale_t,
            pose.y + step[1] * scale_t,
            normalize_angle(pose.theta + dth),
        );
        if norm * scale_t < 1e-3 && dth.abs() < 1.7e-4 {
            break;
        }
    }
    let cost = truncated_cost(field, bx, by, &pose, t);
    (pose, cost)
}

/// Solves the 3 × 3 system `a x = b` by Cramer's rule; None when `a` is singular.
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    if !(d.is_finite() && d.abs() > 1e-300) {
        return None;
    }
    let mut x = [0.0; 3];
    for (k, xk) in x.iter_mut().enumerate() {
        let mut m = a;
        for r in 0..3 {
            m[r][k] = b[r];
        }
        *xk = det(m) / d;
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sensor_models::likelihood_field::{tests::field_where, LikelihoodField};

    /// A 6 m × 4 m room of 0.02 m cells, walls one cell thick on every side, and a pillar
    /// 0.4 m square off-centre so that the room has one pose that fits.
    fn room() -> LikelihoodField {
        let (w, h) = (300, 200);
        field_where(w, h, 0.02, |i, j| {
            let wall = i == 0 || j == 0 || i == w - 1 || j == h - 1;
            let pillar = (200..220).contains(&i) && (50..70).contains(&j);
            wall || pillar
        })
    }

    /// Endpoints of an ideal 72-beam scan from `pose`, ray-marched on the field's distances,
    /// in the robot frame.
    fn scan(field: &LikelihoodField, pose: Pose2) -> (Vec<f64>, Vec<f64>) {
        let (mut bx, mut by) = (Vec::new(), Vec::new());
        for k in 0..72 {
            let a = k as f64 * std::f64::consts::TAU / 72.0;
            let (s, c) = (pose.theta + a).sin_cos();
            let mut r = 0.0;
            loop {
                let (x, y) = (pose.x + r * c, pose.y + r * s);
                match field.distance(x, y) {
                    Some(d) if d > 0.011 => r += (d - 0.01).max(0.005),
                    _ => break,
                }
                if r > 8.0 {
                    break;
                }
            }
            bx.push(r * a.cos());
            by.push(r * a.sin());
        }
        (bx, by)
    }

    #[test]
    fn a_guess_in_the_basin_is_brought_to_the_true_pose() {
        let field = room();
        let truth = Pose2::new(2.0, 1.5, 0.3);
        let (bx, by) = scan(&field, truth);
        let p = ScanMatchParams::default();
        for guess in [
            Pose2::new(2.2, 1.4, 0.3),
            Pose2::new(1.8, 1.7, 0.25),
            Pose2::new(2.1, 1.6, 0.38),
        ] {
            let before = truncated_cost(&field, &bx, &by, &guess, p.truncation);
            let (q, after) = refine(&field, &bx, &by, guess, &p);
            assert!(after < before, "{guess:?}: {before} -> {after}");
            assert!(q.distance(&truth) < 0.03, "{guess:?} -> {q:?}");
            assert!(normalize_angle(q.theta - truth.theta).abs() < 0.01, "{q:?}");
        }
        // At the true pose the cost is what the ray marching leaves (under a centimetre a
        // beam), and refinement stays there.
        let (q, cost) = refine(&field, &bx, &by, truth, &p);
        assert!(cost < 72.0 * 1e-4, "{cost} {q:?}");
        assert!(q.distance(&truth) < 0.01, "{q:?}");
    }

    #[test]
    fn steps_are_bounded_and_endpoints_off_the_map_are_ignored() {
        let field = room();
        let truth = Pose2::new(2.0, 1.5, 0.3);
        let (bx, by) = scan(&field, truth);
        let p = ScanMatchParams {
            iterations: 1,
            ..Default::default()
        };
        let guess = Pose2::new(2.4, 1.2, 0.6);
        let (q, _) = refine(&field, &bx, &by, guess, &p);
        assert!(q.distance(&guess) <= p.max_step[0] + 1e-12, "{q:?}");
        assert!(normalize_angle(q.theta - guess.theta).abs() <= p.max_step[1] + 1e-12);
        // Far off the map every endpoint is ignored: the pose does not move, and each costs
        // the truncation squared.
        let off = Pose2::new(-50.0, -50.0, 0.0);
        let (q, cost) = refine(&field, &bx, &by, off, &ScanMatchParams::default());
        assert_eq!(q, off);
        assert!((cost - 72.0 * 0.25).abs() < 1e-9, "{cost}");
    }

    #[test]
    fn coarse_distances_sample_the_field_at_coarse_cell_centres() {
        let field = room();
        let coarse = CoarseDistance::new(&field, 5);
        // A 0.1 m cell whose centre (2.05, 1.55) is 1.55 m from the bottom wall's surface
        // (y = 0.01) and farther from every other surface.
        let d = coarse.distance(2.01, 1.59).unwrap();
        assert!(
            (d - field.distance(2.05, 1.55).unwrap()).abs() < 1e-6,
            "{d}"
        );
        assert!(coarse.distance(-0.01, 1.0).is_none() && coarse.distance(f64::NAN, 1.0).is_none());
        // The coarse cost of the true pose is within what 5 cm cells can be off per beam.
        let truth = Pose2::new(2.0, 1.5, 0.3);
        let (bx, by) = scan(&field, truth);
        let fine = truncated_cost(&field, &bx, &by, &truth, 0.5);
        let c = coarse.truncated_cost(&bx, &by, &truth, 0.5);
        assert!(c < fine + 72.0 * 0.075 * 0.075, "{c} vs {fine}");
        let off = Pose2::new(2.5, 1.2, 0.9);
        assert!(coarse.truncated_cost(&bx, &by, &off, 0.5) > 10.0 * c);
    }

    #[test]
    fn costs_of_many_poses_are_the_single_pose_costs_bit_for_bit() {
        // Poses inside, at the edges (some endpoints off the map) and far off it, one with a
        // NaN heading; 23 poses, so that groups of four leave a remainder.
        let field = room();
        let coarse = CoarseDistance::new(&field, 5);
        let (bx, by) = scan(&field, Pose2::new(2.0, 1.5, 0.3));
        let mut poses: Vec<Pose2> = (0..22)
            .map(|k| {
                let t = k as f64;
                Pose2::new(-0.5 + 0.31 * t, 4.2 - 0.23 * t, 0.7 * t - 3.0)
            })
            .collect();
        poses.push(Pose2::new(1.0, 1.0, f64::NAN));
        let mut out = vec![0.0; poses.len()];
        coarse.truncated_costs(&bx, &by, &poses, 0.5, &mut out);
        for (p, c) in poses.iter().zip(&out) {
            let one = coarse.truncated_cost(&bx, &by, p, 0.5);
            assert_eq!(c.to_bits(), one.to_bits(), "{p:?}");
        }
        assert!(out.iter().any(|c| *c < 72.0 * 0.25) && out.contains(&(72.0 * 0.25)));
    }

    #[test]
    fn solve3_by_hand() {
        let x = solve3(
            [[2.0, 0.0, 0.0], [0.0, 4.0, 1.0], [0.0, 1.0, 1.0]],
            [2.0, 5.0, 2.0],
        )
        .unwrap();
        // 2x = 2; 4y + z = 5; y + z = 2 -> x = 1, y = 1, z = 1.
        for v in x {
            assert!((v - 1.0).abs() < 1e-12, "{x:?}");
        }
        assert!(solve3(
            [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]],
            [1.0; 3]
        )
        .is_none());
    }
}
