//! WiFi RSSI: the signal strength of every access point of the world at the robot's antenna.
//!
//! Per access point (the standard indoor model behind [004] §2.3, whose
//! WiFi graph is learnt from such readings):
//!
//! RSSI = P₀ − 10·n·log₁₀(d / 1 m) − Σ_walls crossed A(material) + S(x, y) + M(x, y) + ε
//!
//! - P₀ (`tx_power_dbm`) the RSSI at 1 m, n the path-loss exponent, d the 3D distance from
//!   the antenna (at `antenna_height`) to the access point, clamped below at 0.1 m;
//! - A the `wifi_attenuation_db` of each wall (and pillar) the straight line between them
//!   crosses below the wall's top;
//! - S the shadow fading: a stationary Gaussian random field per access point with standard
//!   deviation σ_s and squared-exponential correlation exp(−|Δ|²/(2ℓ²)), fixed by the
//!   world's `[wifi] seed`, so two visits to one spot agree. It is drawn as random Fourier
//!   features (Rahimi & Recht 2007): S(p) = σ_s·√(2/M)·Σ_k cos(ω_k·p + b_k) with
//!   ω_k ~ N(0, ℓ⁻²I), b_k ~ U[0, 2π), whose covariance is exactly that kernel in
//!   expectation; M = 256 makes it Gaussian to the eye (central limit);
//! - M the small-scale (multipath) fading, drawn the same way with its own σ and a
//!   correlation length of about half a wavelength (`multipath_sigma_db`, off by default):
//!   fixed at a spot, but decorrelated within centimetres, so no metre-spaced graph can
//!   learn it; it is what keeps real WiFi localization at about a metre;
//! - ε per-scan Gaussian noise (`noise_db`).
//!
//! The reading is then quantized to `quantization_db` steps, and an access point whose
//! quantized RSSI is below `cutoff_dbm` is missing from the scan. [`WifiField::mean_rssi`]
//! is the noise-free mean (everything but ε, quantization and cut-off), for tests and plots.

use atrium_robots::{Pose2, WifiReading, WifiScan, WifiSpec};
use atrium_worlds::World;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// Random Fourier features per shadow field.
const FEATURES: usize = 256;
/// Distances below this are clamped (the log-distance model diverges at 0), m.
const MIN_DISTANCE: f64 = 0.1;

/// One access point's shadow fading field.
#[derive(Debug, Clone)]
struct ShadowField {
    /// σ_s·√(2/M).
    scale: f64,
    omega: Vec<[f64; 2]>,
    phase: Vec<f64>,
}

impl ShadowField {
    fn new(sigma: f64, length: f64, rng: &mut ChaCha8Rng) -> Self {
        let mut omega = Vec::with_capacity(FEATURES);
        let mut phase = Vec::with_capacity(FEATURES);
        for _ in 0..FEATURES {
            let a: f64 = StandardNormal.sample(rng);
            let b: f64 = StandardNormal.sample(rng);
            omega.push([a / length, b / length]);
            phase.push(rng.random::<f64>() * std::f64::consts::TAU);
        }
        Self {
            scale: sigma * (2.0 / FEATURES as f64).sqrt(),
            omega,
            phase,
        }
    }

    fn at(&self, x: f64, y: f64) -> f64 {
        if self.scale == 0.0 {
            return 0.0;
        }
        let s: f64 = self
            .omega
            .iter()
            .zip(&self.phase)
            .map(|(w, b)| (w[0] * x + w[1] * y + b).cos())
            .sum();
        self.scale * s
    }
}

#[derive(Debug, Clone)]
struct Source {
    name: String,
    channel: u32,
    position: [f64; 3],
    tx_power_dbm: f64,
    exponent: f64,
    shadow: ShadowField,
    multipath: ShadowField,
}

/// A wall's centre line (or a pillar) with what crossing it costs.
#[derive(Debug, Clone, Copy)]
enum Obstacle {
    Wall {
        a: [f64; 2],
        b: [f64; 2],
        height: f64,
        db: f64,
    },
    Pillar {
        c: [f64; 2],
        r: f64,
        height: f64,
        db: f64,
    },
}

/// FNV-1a of an access point's name: its shadow field's stream, so adding or reordering
/// access points never changes another one's field.
fn name_stream(name: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in name.bytes() {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// The noise-free RSSI field of every access point of a world.
#[derive(Debug, Clone)]
pub struct WifiField {
    sources: Vec<Source>,
    obstacles: Vec<Obstacle>,
    antenna_height: f64,
}

impl WifiField {
    /// The field seen by an antenna `antenna_height` above the floor. Walls and pillars of
    /// materials with zero attenuation are left out (they cost nothing).
    pub fn new(world: &World, antenna_height: f64) -> WifiField {
        let db = |m: &str| world.material(m).map_or(0.0, |m| m.wifi_attenuation_db);
        let mut obstacles = Vec::new();
        for w in &world.walls {
            let d = db(&w.material);
            if d > 0.0 {
                obstacles.push(Obstacle::Wall {
                    a: w.a,
                    b: w.b,
                    height: w.height,
                    db: d,
                });
            }
        }
        for p in &world.pillars {
            let d = db(&p.material);
            if d > 0.0 {
                obstacles.push(Obstacle::Pillar {
                    c: p.center,
                    r: p.radius,
                    height: p.height,
                    db: d,
                });
            }
        }
        let env = world.wifi;
        let sources = world
            .access_points
            .iter()
            .map(|ap| {
                let mut rng = ChaCha8Rng::seed_from_u64(env.seed);
                rng.set_stream(name_stream(&ap.name));
                Source {
                    name: ap.name.clone(),
                    channel: ap.channel,
                    position: ap.position,
                    tx_power_dbm: ap.tx_power_dbm,
                    exponent: ap.path_loss_exponent,
                    shadow: ShadowField::new(
                        env.shadowing_sigma_db,
                        env.shadowing_decorrelation_m,
                        &mut rng,
                    ),
                    // Drawn after the shadow field from the same stream, so turning
                    // multipath on leaves the shadow field as it was.
                    multipath: ShadowField::new(
                        env.multipath_sigma_db,
                        env.multipath_decorrelation_m,
                        &mut rng,
                    ),
                }
            })
            .collect();
        WifiField {
            sources,
            obstacles,
            antenna_height,
        }
    }

    pub fn len(&self) -> usize {
        self.sources.len()
    }

    pub fn is_empty(&self) -> bool {
        self.sources.is_empty()
    }

    /// Name of access point `ap` (world order).
    pub fn name(&self, ap: usize) -> &str {
        &self.sources[ap].name
    }

    /// P₀ − 10·n·log₁₀(d): free-space part of the mean at (x, y).
    pub fn path_loss_rssi(&self, ap: usize, x: f64, y: f64) -> f64 {
        let s = &self.sources[ap];
        let d = self.distance(s, x, y);
        s.tx_power_dbm - 10.0 * s.exponent * d.log10()
    }

    fn distance(&self, s: &Source, x: f64, y: f64) -> f64 {
        let [ax, ay, az] = s.position;
        let dz = az - self.antenna_height;
        ((ax - x).powi(2) + (ay - y).powi(2) + dz * dz)
            .sqrt()
            .max(MIN_DISTANCE)
    }

    /// Total attenuation of the walls and pillars the direct path from (x, y) crosses, dB.
    pub fn wall_loss(&self, ap: usize, x: f64, y: f64) -> f64 {
        let s = &self.sources[ap];
        let [ax, ay, az] = s.position;
        let h0 = self.antenna_height;
        let (dx, dy) = (ax - x, ay - y);
        let mut loss = 0.0;
        for o in &self.obstacles {
            match *o {
                Obstacle::Wall { a, b, height, db } => {
                    // Path p(t) = (x, y) + t·(dx, dy), wall q(u) = a + u·(b − a).
                    let (ex, ey) = (b[0] - a[0], b[1] - a[1]);
                    let den = dx * ey - dy * ex;
                    if den.abs() < 1e-12 {
                        continue; // parallel: runs along the wall, never through it
                    }
                    let (wx, wy) = (a[0] - x, a[1] - y);
                    let t = (wx * ey - wy * ex) / den;
                    let u = (wx * dy - wy * dx) / den;
                    // Half-open in u so a path through the joint of two collinear segments of
                    // one polyline counts one wall, not two.
                    if t > 0.0 && t < 1.0 && (0.0..1.0).contains(&u) {
                        let z = h0 + t * (az - h0);
                        if z < height {
                            loss += db;
                        }
                    }
                }
                Obstacle::Pillar { c, r, height, db } => {
                    // Closest approach of the segment to the pillar's axis.
                    let len2 = dx * dx + dy * dy;
                    if len2 == 0.0 {
                        continue;
                    }
                    let t = (((c[0] - x) * dx + (c[1] - y) * dy) / len2).clamp(0.0, 1.0);
                    let (px, py) = (x + t * dx - c[0], y + t * dy - c[1]);
                    if px * px + py * py < r * r && h0 + t * (az - h0) < height {
                        loss += db;
                    }
                }
            }
        }
        loss
    }

    /// The shadow fading of access point `ap` at (x, y), dB.
    pub fn shadowing(&self, ap: usize, x: f64, y: f64) -> f64 {
        self.sources[ap].shadow.at(x, y)
    }

    /// The small-scale (multipath) fading of access point `ap` at (x, y), dB.
    pub fn multipath(&self, ap: usize, x: f64, y: f64) -> f64 {
        self.sources[ap].multipath.at(x, y)
    }

    /// The noise-free mean RSSI of access point `ap` at (x, y), dBm: path loss, walls,
    /// shadow and multipath fading, before scan noise, quantization and cut-off.
    pub fn mean_rssi(&self, ap: usize, x: f64, y: f64) -> f64 {
        self.path_loss_rssi(ap, x, y) - self.wall_loss(ap, x, y)
            + self.shadowing(ap, x, y)
            + self.multipath(ap, x, y)
    }
}

/// A WiFi scanner: the field plus the receiver's noise, quantization and cut-off.
#[derive(Debug, Clone)]
pub struct WifiSensor {
    field: WifiField,
    spec: WifiSpec,
    rng: ChaCha8Rng,
}

impl WifiSensor {
    /// `rng` supplies the per-scan noise (one stream for this sensor).
    pub fn new(world: &World, spec: WifiSpec, rng: ChaCha8Rng) -> WifiSensor {
        WifiSensor {
            field: WifiField::new(world, spec.antenna_height),
            spec,
            rng,
        }
    }

    pub fn field(&self) -> &WifiField {
        &self.field
    }

    pub fn spec(&self) -> &WifiSpec {
        &self.spec
    }

    /// One scan with the robot's base at `pose` (the antenna is omnidirectional, so only the
    /// position matters). Access points in world order, the missing ones left out.
    pub fn scan(&mut self, pose: &Pose2, stamp: f64) -> WifiScan {
        let mut readings = Vec::with_capacity(self.field.len());
        for (i, s) in self.field.sources.iter().enumerate() {
            let mean = self.field.mean_rssi(i, pose.x, pose.y);
            let z: f64 = StandardNormal.sample(&mut self.rng);
            let mut rssi = mean + self.spec.noise_db * z;
            let q = self.spec.quantization_db;
            if q > 0.0 {
                rssi = (rssi / q).round() * q;
            }
            if rssi >= self.spec.cutoff_dbm {
                readings.push(WifiReading {
                    ap: s.name.clone(),
                    channel: s.channel,
                    rssi_dbm: rssi,
                });
            }
        }
        WifiScan {
            stamp,
            sensor: self.spec.name.clone(),
            readings,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures;
    use atrium_worlds::AccessPoint;

    fn ap(name: &str, x: f64, y: f64, tx: f64, n: f64) -> AccessPoint {
        AccessPoint {
            name: name.into(),
            position: [x, y, 2.4],
            tx_power_dbm: tx,
            path_loss_exponent: n,
            channel: 1,
        }
    }

    /// A 100 × 100 m concrete box with one AP in the middle; shadowing as given.
    fn big_room(sigma: f64) -> World {
        let mut w = fixtures::box_room(100.0, 100.0, "concrete");
        w.access_points.push(ap("a", 0.0, 0.0, -20.0, 2.5));
        w.wifi.shadowing_sigma_db = sigma;
        w
    }

    #[test]
    fn mean_falls_by_ten_n_db_per_decade() {
        let w = big_room(0.0);
        let f = WifiField::new(&w, 0.4);
        // Antenna 2 m below the AP: horizontal offsets for 3D distances 3 m and 30 m.
        let h = |d: f64| (d * d - 4.0f64).sqrt();
        let near = f.mean_rssi(0, h(3.0), 0.0);
        let far = f.mean_rssi(0, 0.0, -h(30.0));
        assert!((near - far - 25.0).abs() < 1e-9, "{near} {far}");
        assert!((near - (-20.0 - 25.0 * 3f64.log10())).abs() < 1e-9);
    }

    #[test]
    fn crossing_one_concrete_wall_costs_its_attenuation() {
        // AP at x = −5; a concrete wall (12 dB) along x = 0 from y = −10 to 10.
        let mut w = big_room(0.0);
        w.access_points[0].position = [-5.0, 0.0, 2.4];
        w.walls
            .push(fixtures::wall([0.0, -10.0], [0.0, 10.0], "concrete"));
        w.walls
            .push(fixtures::wall([0.0, 30.0], [0.0, 40.0], "glass"));
        let f = WifiField::new(&w, 0.4);
        // Same distance, one behind the wall and one in front of it.
        let behind = f.mean_rssi(0, 3.0, 0.0);
        let front = f.mean_rssi(0, -13.0, 0.0);
        assert!((front - behind - 12.0).abs() < 1e-9, "{front} {behind}");
        assert_eq!(f.wall_loss(0, 3.0, 0.0), 12.0);
        // Through the glass segment: 2.5 dB.
        assert_eq!(f.wall_loss(0, 1.0, 42.0), 2.5);
        // Beside the wall's end the path is clear.
        assert_eq!(f.wall_loss(0, 3.0, 20.0), 0.0);
    }

    #[test]
    fn walls_lower_than_the_path_are_passed_over() {
        let mut w = big_room(0.0);
        w.access_points[0].position = [-1.0, 0.0, 2.4];
        // A 1 m partition right below the AP side: the path from x = 10 at 0.4 m rises to
        // 2.4 m over 11 m and is at 2.22 m above x = 0.
        let mut low = fixtures::wall([0.0, -5.0], [0.0, 5.0], "concrete");
        low.height = 1.0;
        w.walls.push(low);
        let f = WifiField::new(&w, 0.4);
        assert_eq!(f.wall_loss(0, 10.0, 0.0), 0.0);
    }

    /// Sample correlation of two equally long series.
    fn corr(a: &[f64], b: &[f64]) -> f64 {
        let n = a.len() as f64;
        let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
        let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
        for (x, y) in a.iter().zip(b) {
            sab += (x - ma) * (y - mb);
            saa += (x - ma) * (x - ma);
            sbb += (y - mb) * (y - mb);
        }
        sab / (saa * sbb).sqrt()
    }

    #[test]
    fn shadowing_correlates_scans_at_one_spot_but_not_20_m_apart() {
        let w = big_room(4.0);
        let spec = WifiSpec {
            quantization_db: 0.0,
            ..WifiSpec::default()
        };
        let mut sensor = WifiSensor::new(&w, spec, ChaCha8Rng::seed_from_u64(5));
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let (mut first, mut again, mut away) = (vec![], vec![], vec![]);
        // Residual of a scan after the deterministic path loss: shadowing + noise.
        let residual = |s: &mut WifiSensor, x: f64, y: f64| {
            let scan = s.scan(&Pose2::new(x, y, 0.0), 0.0);
            scan.readings[0].rssi_dbm - s.field().path_loss_rssi(0, x, y)
        };
        for _ in 0..400 {
            let x = rng.random_range(-25.0..25.0);
            let y = rng.random_range(-25.0..25.0);
            let a = rng.random_range(0.0..std::f64::consts::TAU);
            first.push(residual(&mut sensor, x, y));
            again.push(residual(&mut sensor, x, y));
            away.push(residual(
                &mut sensor,
                x + 20.0 * a.cos(),
                y + 20.0 * a.sin(),
            ));
        }
        // Expected: σ_s²/(σ_s² + σ_n²) = 16/20 = 0.8 at one spot; exp(−200/9) ≈ 0 at 20 m.
        let same = corr(&first, &again);
        let apart = corr(&first, &away);
        assert!(same > 0.7, "same spot: {same}");
        assert!(apart.abs() < 0.15, "20 m apart: {apart}");
        // The field's spread is σ_s.
        let f = sensor.field();
        let vals: Vec<f64> = (0..2000)
            .map(|k| f.shadowing(0, (k % 50) as f64 * 7.3, (k / 50) as f64 * 7.3))
            .collect();
        let sd = (vals.iter().map(|v| v * v).sum::<f64>() / vals.len() as f64).sqrt();
        assert!((sd - 4.0).abs() < 0.6, "shadowing sd {sd}");
    }

    #[test]
    fn scans_are_quantized_and_cut_off() {
        let mut w = big_room(4.0);
        w.access_points.push(ap("weak", 40.0, 40.0, -75.0, 3.0));
        let mut sensor = WifiSensor::new(&w, WifiSpec::default(), ChaCha8Rng::seed_from_u64(1));
        let mut heard_weak = 0;
        for k in 0..50 {
            let scan = sensor.scan(&Pose2::new(-40.0 + k as f64, -40.0, 0.0), 1.0);
            for r in &scan.readings {
                assert_eq!(r.rssi_dbm, r.rssi_dbm.round(), "1 dB steps");
                assert!(r.rssi_dbm >= -90.0);
            }
            assert_eq!(scan.readings[0].ap, "a");
            heard_weak += scan.readings.iter().filter(|r| r.ap == "weak").count();
        }
        // 60–110 m from a −75 dBm, n = 3 AP: below −128 dBm, never heard.
        assert_eq!(heard_weak, 0);
    }
}
