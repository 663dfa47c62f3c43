//! Seeded waypoint jitter (`[route] jitter = 2.0`, metres): every trial of a sweep drives its
//! own variant of the route, as the manually driven trials of the open-area experiment did
//! ([004] §3: "the robot started out from the same fixed location, and
//! was manually driven around the open area ... then driven back to the starting location").
//!
//! Each waypoint except the last is moved by an offset drawn uniformly from the disc of
//! radius `jitter`; the last waypoint is the route's destination (the return to the start)
//! and stays where the file puts it. A draw is kept only when the moved waypoint and the legs
//! into and out of it keep [`CLEARANCE_M`] from every solid; otherwise it is redrawn, up to
//! [`MAX_DRAWS`] times, after which the waypoint stays unmoved. The draws come from a
//! ChaCha8 stream derived from the run's seed, so a seed always gives the same route.

use crate::seeds::derive_seed;
use atrium_worlds::World;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Clearance a jittered leg keeps from walls and pillars, m (a Pioneer's half-width plus a
/// margin, so the waypoint controller never has to scrape along a wall).
pub const CLEARANCE_M: f64 = 0.45;
/// Draws per waypoint before giving up and keeping it unmoved.
pub const MAX_DRAWS: usize = 32;
/// Spacing of the clearance checks along a leg, m.
const LEG_STEP_M: f64 = 0.1;

/// Whether the straight leg `a` → `b` keeps `CLEARANCE_M` from every solid, furniture
/// (the world's boxes and a scenario's clutter) included.
fn leg_is_free(world: &World, a: [f64; 2], b: [f64; 2]) -> bool {
    let len = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
    let n = (len / LEG_STEP_M).ceil().max(1.0) as usize;
    (0..=n).all(|i| {
        let s = i as f64 / n as f64;
        let p = [a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])];
        world.is_free(p, CLEARANCE_M)
            && world
                .boxes
                .iter()
                .all(|bx| bx.signed_distance(p) >= CLEARANCE_M)
    })
}

/// The route driven in a run with seed `seed`: `waypoints` themselves when `jitter` is 0,
/// otherwise every waypoint but the last moved within a disc of radius `jitter` (see the
/// module comment). `start` is where the robot begins (the first leg starts there).
pub fn jittered_waypoints(
    world: &World,
    start: [f64; 2],
    waypoints: &[[f64; 2]],
    jitter: f64,
    seed: u64,
) -> Vec<[f64; 2]> {
    let mut out = waypoints.to_vec();
    if jitter <= 0.0 || waypoints.len() < 2 {
        return out;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(derive_seed(seed, "route/jitter"));
    let last = out.len() - 1;
    for i in 0..last {
        let prev = if i == 0 { start } else { out[i - 1] };
        let next = out[i + 1];
        for _ in 0..MAX_DRAWS {
            // Uniform in the disc: radius ∝ sqrt(u), so area elements are equally likely.
            let r = jitter * rng.random::<f64>().sqrt();
            let phi = std::f64::consts::TAU * rng.random::<f64>();
            let p = [out[i][0] + r * phi.cos(), out[i][1] + r * phi.sin()];
            if leg_is_free(world, prev, p) && leg_is_free(world, p, next) {
                out[i] = p;
                break;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn campus() -> World {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/campus.toml");
        World::load(&p).unwrap()
    }

    const LOOP: [[f64; 2]; 4] = [[40.0, 12.0], [50.0, 20.0], [40.0, 30.0], [32.0, 20.0]];

    #[test]
    fn zero_jitter_keeps_the_route() {
        let w = campus();
        assert_eq!(
            jittered_waypoints(&w, [32.0, 20.0], &LOOP, 0.0, 5),
            LOOP.to_vec()
        );
    }

    #[test]
    fn jitter_is_seeded_bounded_and_keeps_the_destination() {
        let w = campus();
        let a = jittered_waypoints(&w, [32.0, 20.0], &LOOP, 2.0, 5);
        let b = jittered_waypoints(&w, [32.0, 20.0], &LOOP, 2.0, 5);
        let c = jittered_waypoints(&w, [32.0, 20.0], &LOOP, 2.0, 6);
        assert_eq!(a, b, "same seed, same route");
        assert_ne!(a, c, "another seed, another route");
        assert_eq!(a[3], LOOP[3], "the destination never moves");
        for (p, q) in a.iter().zip(&LOOP).take(3) {
            let d = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
            assert!(d > 0.0 && d <= 2.0 + 1e-12, "moved {d} m");
        }
    }

    #[test]
    fn bad_jitter_is_named() {
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("open_area.toml");
        let text = std::fs::read_to_string(&file).unwrap();
        let ok = crate::Scenario::from_toml_str(&text, &file).unwrap();
        assert_eq!(ok.route_jitter, 2.0);
        let bad = text.replace("jitter = 2.0", "jitter = -1.0");
        let err = crate::Scenario::from_toml_str(&bad, &file).unwrap_err();
        assert!(err.to_string().contains("route.jitter"), "{err}");
    }

    #[test]
    fn jittered_legs_keep_clear_of_walls() {
        // A waypoint 0.6 m from the atrium's east wall (x = 60): a 2 m jitter would often put
        // it into or against the wall; every kept draw must leave CLEARANCE_M.
        let w = campus();
        let route = [[59.4, 20.0], [45.0, 20.0]];
        for seed in 0..50 {
            let r = jittered_waypoints(&w, [45.0, 20.0], &route, 2.0, seed);
            assert!(leg_is_free(&w, [45.0, 20.0], r[0]), "seed {seed}: {r:?}");
            assert!(w.is_free(r[0], CLEARANCE_M), "seed {seed}: {r:?}");
        }
    }
}
