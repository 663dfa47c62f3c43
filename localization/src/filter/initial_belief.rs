//! Where the robot may be at the start, and drawing poses from it. Every particle filter of
//! the crate takes the same belief (MCL defined it first, and its module still re-exports
//! it), so it lives apart from any one filter.

use crate::error::LocalizationError;
use atrium_robots::{normalize_angle, Pose2};
use atrium_worlds::geometry::point_in_polygon;
use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::{Deserialize, Serialize};

/// Where the robot may be at the start.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum InitialBelief {
    /// Gaussian around a known pose with standard deviations (x m, y m, θ rad).
    Tracking { pose: Pose2, sigma: [f64; 3] },
    /// Uniform over the Free cells inside any of the polygons (x, y vertices in metres), or
    /// over every Free cell if there is none; uniform heading.
    Global {
        #[serde(default)]
        regions: Vec<Vec<[f64; 2]>>,
    },
}

/// One draw from a Gaussian around `pose` with standard deviations `sigma` (x, y, θ): three
/// standard normals, in that order (every filter's seeded runs depend on it).
#[inline]
pub fn gaussian_pose<R: Rng + ?Sized>(pose: &Pose2, sigma: &[f64; 3], rng: &mut R) -> Pose2 {
    let mut g = || -> f64 { StandardNormal.sample(rng) };
    let x = pose.x + sigma[0] * g();
    let y = pose.y + sigma[1] * g();
    let theta = normalize_angle(pose.theta + sigma[2] * g());
    Pose2 { x, y, theta }
}

/// True when a Gaussian belief can be drawn from: `pose` finite, each sigma finite and >= 0.
pub fn gaussian_is_valid(pose: &Pose2, sigma: &[f64; 3]) -> bool {
    pose.is_finite() && sigma.iter().all(|s| s.is_finite() && *s >= 0.0)
}

/// [`gaussian_is_valid`] as an error naming the field at fault (pose first).
pub fn check_gaussian(pose: &Pose2, sigma: &[f64; 3]) -> Result<(), LocalizationError> {
    if !pose.is_finite() {
        return Err(LocalizationError::belief(
            "pose",
            format!("must be finite, got {pose:?}"),
        ));
    }
    if sigma.iter().any(|s| !(s.is_finite() && *s >= 0.0)) {
        return Err(LocalizationError::belief(
            "sigma",
            format!("must be finite and >= 0, got {sigma:?}"),
        ));
    }
    Ok(())
}

/// A sampler of a global belief over an axis-aligned box: uniform over the polygons
/// (rejection inside their bounding box), or over `extent` (x0, y0, x1, y1) when there are
/// none; uniform heading. Built once, it draws without allocating.
#[derive(Debug, Clone)]
pub struct UniformInRegions<'a> {
    regions: &'a [Vec<[f64; 2]>],
    bounds: [f64; 4],
}

impl<'a> UniformInRegions<'a> {
    pub fn new(
        regions: &'a [Vec<[f64; 2]>],
        extent: [f64; 4],
    ) -> Result<UniformInRegions<'a>, LocalizationError> {
        let mut b = extent;
        if !regions.is_empty() {
            b = [
                f64::INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::NEG_INFINITY,
            ];
            for p in regions.iter().flatten() {
                b = [
                    b[0].min(p[0]),
                    b[1].min(p[1]),
                    b[2].max(p[0]),
                    b[3].max(p[1]),
                ];
            }
        }
        if !(b.iter().all(|v| v.is_finite()) && b[2] >= b[0] && b[3] >= b[1]) {
            return Err(LocalizationError::InvalidInitialBelief {
                field: "regions",
                reason: format!("no area to spread the particles over ({b:?})"),
            });
        }
        Ok(UniformInRegions { regions, bounds: b })
    }

    /// One pose: x, y (retried until inside a polygon), then the heading.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Result<Pose2, LocalizationError> {
        let b = self.bounds;
        let mut tries = 0;
        let (x, y) = loop {
            let px = b[0] + (b[2] - b[0]) * rng.random::<f64>();
            let py = b[1] + (b[3] - b[1]) * rng.random::<f64>();
            tries += 1;
            if self.regions.is_empty() || self.regions.iter().any(|r| point_in_polygon([px, py], r))
            {
                break (px, py);
            }
            if tries > 10_000 {
                return Err(LocalizationError::InvalidInitialBelief {
                    field: "regions",
                    reason: "the polygons have (almost) no area".into(),
                });
            }
        };
        let pi = std::f64::consts::PI;
        Ok(Pose2::new(x, y, rng.random_range(-pi..pi)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn a_zero_sigma_gaussian_is_the_pose_and_bad_ones_are_refused() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let p = Pose2::new(1.0, 2.0, 3.0);
        assert_eq!(gaussian_pose(&p, &[0.0; 3], &mut rng), p);
        assert!(gaussian_is_valid(&p, &[0.1; 3]));
        assert!(!gaussian_is_valid(&p, &[0.1, -1.0, 0.1]));
        assert!(!gaussian_is_valid(
            &Pose2::new(f64::NAN, 0.0, 0.0),
            &[0.1; 3]
        ));
    }

    #[test]
    fn uniform_draws_stay_inside_the_polygon() {
        let tri = vec![vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]]];
        let u = UniformInRegions::new(&tri, [0.0; 4]).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        for _ in 0..200 {
            let p = u.sample(&mut rng).unwrap();
            assert!(p.x >= 0.0 && p.y >= 0.0 && p.x + p.y <= 2.0, "{p:?}");
        }
        let none: Vec<Vec<[f64; 2]>> = vec![];
        assert!(UniformInRegions::new(&none, [0.0, 0.0, f64::NAN, 1.0]).is_err());
    }
}
