//! The beam model of a range finder ([Thrun 2005] §6.3, Table 6.1): each reading is a
//! mixture of a hit near the range the map predicts, an unexpected short obstacle, a
//! max-range failure and uniform noise. Unlike the likelihood field it ray-casts every beam on
//! the map, so it uses the beams that return nothing (in a glass corridor, half of them) and
//! it sees which wall a beam meets first, at many times the cost: on the route of
//! corridor_tracking its filter took 22 s against the likelihood field's 0.8 s (BENCHMARKS.md's
//! real-time table, corridor_tracking_beam against corridor_tracking).
//!
//! Ray casting sphere-traces the likelihood field's distance transform: from the sensor the
//! ray advances by the distance to the nearest surface, which can never step through one.

use crate::sensor_models::likelihood_field::LikelihoodField;
use std::ops::ControlFlow;

/// Weights and shapes of the four components.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeamModelParams {
    pub z_hit: f64,
    pub z_short: f64,
    pub z_max: f64,
    pub z_rand: f64,
    /// Standard deviation of the hit component, m.
    pub sigma_hit: f64,
    /// Rate of the short-reading exponential, 1/m.
    pub lambda_short: f64,
}

impl Default for BeamModelParams {
    /// ROS amcl's defaults for its beam model (z_hit 0.95 there with the others small), with
    /// σ_hit as the caller's likelihood field uses.
    fn default() -> Self {
        BeamModelParams {
            z_hit: 0.85,
            z_short: 0.05,
            z_max: 0.05,
            z_rand: 0.05,
            sigma_hit: 0.05,
            lambda_short: 0.1,
        }
    }
}

impl BeamModelParams {
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("beam z_hit", self.z_hit),
            ("beam z_short", self.z_short),
            ("beam z_max", self.z_max),
            ("beam z_rand", self.z_rand),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{name} must be finite and >= 0, got {v}"));
            }
        }
        if self.z_rand <= 0.0 {
            // Without it one unexplained reading zeroes a particle's weight for good.
            return Err(format!("beam z_rand must be > 0, got {}", self.z_rand));
        }
        crate::limits::check_positive("sigma_hit", self.sigma_hit)?;
        if !(self.lambda_short.is_finite() && self.lambda_short > 0.0) {
            return Err(format!(
                "beam lambda_short must be finite and > 0, got {}",
                self.lambda_short
            ));
        }
        Ok(())
    }
}

/// p(z | z*) of one beam ([Thrun 2005] §6.3.1, eqs. 6.4–6.12): `z` the reading, `z_star` the
/// range the map predicts (`range_max` when the ray meets nothing), both in [0, range_max].
/// The hit Gaussian is normalised over [0, range_max] and the short exponential over
/// [0, z*], as the book does; a reading at range_max is the max-range component's point mass.
pub fn beam_probability(z: f64, z_star: f64, range_max: f64, p: &BeamModelParams) -> f64 {
    let at_max = z >= range_max;
    let hit = if at_max {
        0.0
    } else {
        let s = p.sigma_hit;
        let norm = 0.5
            * (erf((range_max - z_star) / (s * std::f64::consts::SQRT_2))
                + erf(z_star / (s * std::f64::consts::SQRT_2)));
        let g =
            (-0.5 * ((z - z_star) / s).powi(2)).exp() / ((2.0 * std::f64::consts::PI).sqrt() * s);
        if norm > 0.0 {
            g / norm
        } else {
            0.0
        }
    };
    let short = if !at_max && z <= z_star {
        let eta = 1.0 / (1.0 - (-p.lambda_short * z_star).exp());
        if eta.is_finite() {
            eta * p.lambda_short * (-p.lambda_short * z).exp()
        } else {
            0.0
        }
    } else {
        0.0
    };
    let max = if at_max { 1.0 } else { 0.0 };
    let rand = if at_max { 0.0 } else { 1.0 / range_max };
    p.z_hit * hit + p.z_short * short + p.z_max * max + p.z_rand * rand
}

/// The error function (Abramowitz and Stegun 7.1.26, |error| < 1.5e-7): enough for
/// normalising a Gaussian truncated to the sensor's range.
fn erf(x: f64) -> f64 {
    let t = 1.0 / (1.0 + 0.3275911 * x.abs());
    let y = 1.0
        - (((((1.061405429 * t - 1.453152027) * t) + 1.421413741) * t - 0.284496736) * t
            + 0.254829592)
            * t
            * (-x * x).exp();
    if x >= 0.0 {
        y
    } else {
        -y
    }
}

/// Range from `(x, y)` along the unit direction `(c, s)` to the first obstacle surface of
/// `field`'s map, or `range_max` if there is none within it (or the ray leaves the map).
/// Sphere tracing: the distance transform bounds how far the ray can go without meeting a
/// surface, so it never skips one; it stops within half a cell of the surface cell's centre,
/// the accuracy of the map itself.
pub fn cast_ray(field: &LikelihoodField, x: f64, y: f64, c: f64, s: f64, range_max: f64) -> f64 {
    let stop = 0.5 * field.resolution();
    let mut t = 0.0;
    loop {
        match ray_step(field, (x, y), (c, s), t, stop, range_max) {
            ControlFlow::Continue(next) => t = next,
            ControlFlow::Break(range) => return range,
        }
    }
}

/// One step of sphere tracing from `t` along the ray: the next `t`, or the ray's range once
/// it ends (at a surface, off the map, at `range_max`, or at NaN).
#[inline(always)]
fn ray_step(
    field: &LikelihoodField,
    (x, y): (f64, f64),
    (c, s): (f64, f64),
    t: f64,
    stop: f64,
    range_max: f64,
) -> ControlFlow<f64, f64> {
    if t < range_max {
        match field.distance(x + c * t, y + s * t) {
            None => ControlFlow::Break(range_max),
            Some(d) if d <= stop => ControlFlow::Break(t),
            // At least half a cell, so a ray grazing a surface does not crawl.
            Some(d) => ControlFlow::Continue(t + (d - stop).max(stop)),
        }
    } else {
        ControlFlow::Break(range_max)
    }
}

/// Rays [`cast_rays`] keeps in flight: enough to keep the processor busy while each waits
/// for its next distance lookup.
const RAYS_IN_FLIGHT: usize = 8;

/// [`cast_ray`] from `(x, y)` along each unit direction `(c, s)` of `dirs`, into `ranges`
/// (the same length), bit for bit. A ray's steps wait on each other (each lookup decides the
/// next), so one ray at a time leaves the processor waiting on memory; this advances up to
/// [`RAYS_IN_FLIGHT`] rays a step each in turn, whose lookups overlap, and starts the next
/// ray in the slot of one that ends.
pub fn cast_rays(
    field: &LikelihoodField,
    origin: (f64, f64),
    dirs: &[(f64, f64)],
    range_max: f64,
    ranges: &mut [f64],
) {
    assert_eq!(dirs.len(), ranges.len(), "one range per ray direction");
    let stop = 0.5 * field.resolution();
    // Per slot: the ray it holds (`usize::MAX`: none left to start) and how far it has gone.
    let mut next = dirs.len().min(RAYS_IN_FLIGHT);
    let mut ray = [usize::MAX; RAYS_IN_FLIGHT];
    for (k, slot) in ray.iter_mut().take(next).enumerate() {
        *slot = k;
    }
    let mut t = [0.0; RAYS_IN_FLIGHT];
    let mut live = next;
    while live > 0 {
        for k in 0..RAYS_IN_FLIGHT {
            let r = ray[k];
            if r == usize::MAX {
                continue;
            }
            match ray_step(field, origin, dirs[r], t[k], stop, range_max) {
                ControlFlow::Continue(step) => t[k] = step,
                ControlFlow::Break(range) => {
                    ranges[r] = range;
                    t[k] = 0.0;
                    if next < dirs.len() {
                        ray[k] = next;
                        next += 1;
                    } else {
                        ray[k] = usize::MAX;
                        live -= 1;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> BeamModelParams {
        BeamModelParams::default()
    }

    #[test]
    fn erf_matches_known_values() {
        assert!((erf(0.0)).abs() < 1e-7);
        assert!((erf(1.0) - 0.842_700_79).abs() < 2e-7);
        assert!((erf(-2.0) + 0.995_322_27).abs() < 2e-7);
    }

    #[test]
    fn a_reading_at_the_predicted_range_is_the_most_likely() {
        let p = params();
        let at = beam_probability(3.0, 3.0, 8.0, &p);
        for z in [2.8, 2.95, 3.05, 3.2, 5.0] {
            assert!(beam_probability(z, 3.0, 8.0, &p) < at, "z {z}");
        }
        // Hand computed: the hit density peaks at 1/(√(2π) σ) = 7.979 (the truncation to
        // [0, 8] changes it by < 1e-9), the short term is η λ e^{-λ z*} with
        // η = 1/(1 − e^{-0.3}), and uniform noise is 1/8.
        let eta = 1.0 / (1.0 - (-0.3f64).exp());
        let expect = 0.85 * 7.978_845_6 + 0.05 * eta * 0.1 * (-0.3f64).exp() + 0.05 / 8.0;
        assert!((at - expect).abs() < 1e-5, "{at} vs {expect}");
    }

    #[test]
    fn short_readings_are_likelier_than_long_ones_by_the_same_margin() {
        // A person in front of a wall: a reading 1 m short keeps a floor from the short
        // component, one 1 m long only the uniform noise.
        let p = params();
        let short = beam_probability(2.0, 3.0, 8.0, &p);
        let long = beam_probability(4.0, 3.0, 8.0, &p);
        assert!(short > long);
        assert!((long - 0.05 / 8.0).abs() < 1e-12);
    }

    #[test]
    fn a_max_range_reading_is_the_point_mass() {
        let p = params();
        assert_eq!(beam_probability(8.0, 8.0, 8.0, &p), 0.05);
        assert_eq!(beam_probability(8.0, 3.0, 8.0, &p), 0.05);
    }

    fn room() -> LikelihoodField {
        // 4 m × 2 m at 0.05 m, walls one cell thick on every side, plus a 0.5 m thick wall
        // at x ∈ [3.0, 3.5).
        let (w, h) = (80, 40);
        crate::sensor_models::likelihood_field::tests::field_where(w, h, 0.05, |i, j| {
            let edge = i == 0 || j == 0 || i == w - 1 || j == h - 1;
            edge || (60..70).contains(&i)
        })
    }

    #[test]
    fn a_ray_stops_at_the_first_surface_it_meets() {
        let f = room();
        // From x = 1 towards +x: the thick wall's face at x = 3.0 (its first cell's centre is
        // 3.025), not its far side.
        let r = cast_ray(&f, 1.0, 1.0, 1.0, 0.0, 8.0);
        assert!((r - 2.0).abs() <= 0.05, "{r}");
        // Towards −x: the outer wall's cell centred at 0.025.
        let r = cast_ray(&f, 1.0, 1.0, -1.0, 0.0, 8.0);
        assert!((r - 0.975).abs() <= 0.05, "{r}");
        // A short range_max that ends before the wall returns range_max.
        assert_eq!(cast_ray(&f, 1.0, 1.0, 1.0, 0.0, 1.5), 1.5);
    }

    #[test]
    fn a_ray_leaving_the_map_meets_nothing() {
        let f = room();
        assert_eq!(cast_ray(&f, -1.0, 1.0, -1.0, 0.0, 8.0), 8.0);
    }

    #[test]
    fn rays_cast_together_are_the_rays_cast_alone_bit_for_bit() {
        let f = room();
        // 19 rays (two full groups in flight and a partial one) from inside the room, from
        // outside it and from inside the thick wall, with ranges that end before, at and past
        // the walls, and NaN.
        let dirs: Vec<(f64, f64)> = (0..19)
            .map(|k| {
                let (s, c) = (0.37 * k as f64 - 3.0).sin_cos();
                (c, s)
            })
            .collect();
        let mut ranges = vec![f64::NAN; dirs.len()];
        for origin in [(1.0, 1.0), (2.9, 0.3), (-1.0, 1.0), (3.2, 1.0), (3.9, 1.9)] {
            for range_max in [0.5, 1.5, 8.0, f64::NAN] {
                cast_rays(&f, origin, &dirs, range_max, &mut ranges);
                for (&(c, s), &r) in dirs.iter().zip(&ranges) {
                    let alone = cast_ray(&f, origin.0, origin.1, c, s, range_max);
                    assert_eq!(
                        r.to_bits(),
                        alone.to_bits(),
                        "{origin:?} {range_max} ({c}, {s})"
                    );
                }
            }
        }
    }
}
