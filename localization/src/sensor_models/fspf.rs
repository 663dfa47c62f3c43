//! Fast Sampling Plane Filtering (FSPF): [004] §2.2, Algorithm 1, with
//! Table 1's parameters as defaults. From a depth image it samples random neighbourhoods,
//! fits a plane through three points in each, checks the plane by local RANSAC over a window
//! the size of a plane of S metres at that depth, and keeps the inliers of the accepted
//! neighbourhoods as plane-filtered points with their (least-squares) normals; the samples of
//! rejected neighbourhoods are outliers.
//!
//! [`vertical_planes_on_floor`] then keeps the points of vertical planes and projects them to
//! the floor plane (§2.2, last paragraph: "non-vertical planes are ignored, and the remaining
//! planes are matched to a 2D vector map"), which is what the depth CGR localizer consumes.
//!
//! Copies of a plane filter (a chooser's member copied when it re-seeds it) share their last
//! frame's result: see [`LastFrame`].

use crate::error::LocalizationError;
use crate::limits::{
    check_count, check_positive, FSPF_MAX_LOCAL_SAMPLES, FSPF_MAX_NEIGHBOURHOODS, FSPF_MAX_POINTS,
};
use atrium_robots::DepthImage;
use nalgebra::{Isometry3, Matrix3, Point3, SymmetricEigen, Vector3};
use rand::{RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::sync::{Arc, Mutex};

/// FSPF parameters (Table 1 of 004). Every field has the paper's value as default.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FspfParams {
    /// n_max: maximum total number of filtered points. Default 2000.
    pub n_max: usize,
    /// k_max: maximum number of neighbourhoods to sample. Default 20000.
    pub k_max: usize,
    /// l: number of local samples per neighbourhood. Default 80.
    pub l: usize,
    /// η: neighbourhood for the global samples d1, d2 around d0, pixels. Default 60.
    pub eta: usize,
    /// S: plane size in world space for the local window, m. Default 0.5.
    pub plane_size: f64,
    /// ε: maximum plane offset error of an inlier, m. Default 0.02.
    pub epsilon: f64,
    /// α_in: minimum inlier fraction to accept a neighbourhood. Default 0.8.
    pub alpha_in: f64,
}

impl Default for FspfParams {
    fn default() -> Self {
        Self {
            n_max: 2000,
            k_max: 20000,
            l: 80,
            eta: 60,
            plane_size: 0.5,
            epsilon: 0.02,
            alpha_in: 0.8,
        }
    }
}

impl FspfParams {
    /// Checks every field; the message names it.
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("n_max", self.n_max),
            ("k_max", self.k_max),
            ("eta", self.eta),
        ] {
            if v == 0 {
                return Err(format!("{name} must be >= 1, got 0"));
            }
        }
        check_count("n_max", self.n_max, FSPF_MAX_POINTS, "FSPF_MAX_POINTS")?;
        check_count(
            "k_max",
            self.k_max,
            FSPF_MAX_NEIGHBOURHOODS,
            "FSPF_MAX_NEIGHBOURHOODS",
        )?;
        check_count(
            "l",
            self.l,
            FSPF_MAX_LOCAL_SAMPLES,
            "FSPF_MAX_LOCAL_SAMPLES",
        )?;
        // Three points define the plane; fewer local samples could never confirm it.
        if self.l < 3 {
            return Err(format!("l must be >= 3, got {}", self.l));
        }
        for (name, v) in [("plane_size", self.plane_size), ("epsilon", self.epsilon)] {
            check_positive(name, v)?;
        }
        if !(self.alpha_in.is_finite() && self.alpha_in > 0.0 && self.alpha_in <= 1.0) {
            return Err(format!("alpha_in must be in (0, 1], got {}", self.alpha_in));
        }
        Ok(())
    }

    /// Checks the parameters against an image size: the neighbourhood η must fit the image
    /// (a larger η samples mostly outside it).
    pub fn validate_for_image(&self, width: usize, height: usize) -> Result<(), String> {
        self.validate()?;
        if width == 0 || height == 0 {
            return Err(format!("the depth image is empty ({width} × {height})"));
        }
        if self.eta >= width.min(height) {
            return Err(format!(
                "eta ({} px) must be smaller than the depth image ({width} × {height} px); \
                 scale it with the camera's decimation",
                self.eta
            ));
        }
        Ok(())
    }
}

/// The output of one [`PlaneFilter::filter`] call, in the camera frame (x along the optical
/// axis, y left, z up), metres.
#[derive(Debug, Clone, Copy)]
pub struct PlaneFiltered<'a> {
    /// P: plane-filtered points.
    pub points: &'a [[f64; 3]],
    /// R: the unit normal of each point's plane, facing the camera.
    pub normals: &'a [[f64; 3]],
    /// O: the samples of rejected neighbourhoods.
    pub outliers: &'a [[f64; 3]],
    /// k: neighbourhoods sampled.
    pub neighborhoods: usize,
}

/// FSPF with reusable buffers: after the first frame (or two, for a filter with clones),
/// filtering allocates nothing.
#[derive(Debug, Clone)]
pub struct PlaneFilter {
    params: FspfParams,
    rng: ChaCha8Rng,
    /// The last frame's result; held by the clones that took it too (see [`LastFrame`]).
    out: Arc<Output>,
    /// The result before it, whose buffers are written next once no clone holds them.
    spare: Option<Arc<Output>>,
    /// Valid local samples of the current neighbourhood, and which are inliers.
    local: Vec<[f64; 3]>,
    inlier: Vec<bool>,
    /// Shared by this filter and its clones.
    last: Arc<Mutex<LastFrame>>,
    rays: PixelRays,
}

/// What one frame gave: P, R and O of Algorithm 1, and the neighbourhoods sampled.
#[derive(Debug, Clone, Default)]
struct Output {
    points: Vec<[f64; 3]>,
    normals: Vec<[f64; 3]>,
    outliers: Vec<[f64; 3]>,
    neighborhoods: usize,
}

impl Output {
    /// Empty buffers with room for a frame's points under `params` (at most n_max, plus the
    /// last neighbourhood's l).
    fn for_params(params: &FspfParams) -> Output {
        let points = params.n_max + params.l;
        Output {
            points: Vec::with_capacity(points),
            normals: Vec::with_capacity(points),
            ..Output::default()
        }
    }

    fn clear(&mut self) {
        self.points.clear();
        self.normals.clear();
        self.outliers.clear();
        self.neighborhoods = 0;
    }
}

/// The last frame a filter or one of its clones filtered, what went in and what came out.
///
/// FSPF's output is a function of its parameters, the image and its random stream's state,
/// and nothing else. A clone starts with its original's stream, and every copy of a chooser's
/// member is given the same images in the same order, so copies filter the same frame from
/// the same state and get the same result: the first to filter a frame computes it, the
/// others (holding equal inputs, compared bit for bit) take it and the stream's state after
/// it. What each copy sees is exactly what it would have computed. The result is shared, not
/// copied: the record and the copies hold the computing filter's buffers, which it leaves
/// for its spare ones before it writes again. A filter without clones keeps no record.
#[derive(Debug, Default)]
struct LastFrame {
    params: Option<FspfParams>,
    rng_before: Option<ChaCha8Rng>,
    rng_after: Option<ChaCha8Rng>,
    /// The image's size and intrinsics (width, height, fx, fy, cx, cy), as bits.
    geometry: [u64; 6],
    depth_bits: Vec<u32>,
    out: Option<Arc<Output>>,
}

fn geometry_bits(img: &DepthImage) -> [u64; 6] {
    [
        img.width as u64,
        img.height as u64,
        img.fx.to_bits(),
        img.fy.to_bits(),
        img.cx.to_bits(),
        img.cy.to_bits(),
    ]
}

impl LastFrame {
    /// Whether this record is the frame `img` filtered with `params` from `rng`.
    fn matches(&self, params: &FspfParams, rng: &ChaCha8Rng, img: &DepthImage) -> bool {
        self.params.as_ref() == Some(params)
            && self.rng_before.as_ref() == Some(rng)
            && self.geometry == geometry_bits(img)
            && self.depth_bits.len() == img.depth.len()
            && self
                .depth_bits
                .iter()
                .zip(&img.depth)
                .all(|(a, b)| *a == b.to_bits())
    }
}

/// Camera-frame point of pixel (u, v) at depth d (pinhole; see `robots::DepthImage`): what
/// [`PixelRays::point`] computes with its factors.
#[cfg(test)]
fn reconstruct(img: &DepthImage, u: usize, v: usize) -> Option<[f64; 3]> {
    let d = img.depth[v * img.width + u] as f64;
    if d > 0.0 {
        Some([
            d,
            -(u as f64 - img.cx) / img.fx * d,
            -(v as f64 - img.cy) / img.fy * d,
        ])
    } else {
        None
    }
}

/// The factors of a pixel's camera-frame point, −(u − cx)/fx per column and −(v − cy)/fy per
/// row, divided once per image size and intrinsics instead of twice per sample. The point is
/// the factor times the depth, the very operations of the per-sample formula, so it is that
/// formula's bit for bit.
#[derive(Debug, Clone, Default)]
struct PixelRays {
    /// Width, height, and the bits of cx, cy, fx, fy the factors were divided for.
    key: Option<(usize, usize, [u64; 4])>,
    cols: Vec<f64>,
    rows: Vec<f64>,
}

impl PixelRays {
    fn update(&mut self, img: &DepthImage) {
        let key = (
            img.width,
            img.height,
            [img.cx, img.cy, img.fx, img.fy].map(f64::to_bits),
        );
        if self.key == Some(key) {
            return;
        }
        self.cols.clear();
        self.cols
            .extend((0..img.width).map(|u| -(u as f64 - img.cx) / img.fx));
        self.rows.clear();
        self.rows
            .extend((0..img.height).map(|v| -(v as f64 - img.cy) / img.fy));
        self.key = Some(key);
    }

    /// Pixel (u, v)'s point, or None without a depth; after [`PixelRays::update`] for `img`.
    #[inline]
    fn point(&self, img: &DepthImage, u: usize, v: usize) -> Option<[f64; 3]> {
        let d = img.depth[v * img.width + u] as f64;
        (d > 0.0).then(|| [d, self.cols[u] * d, self.rows[v] * d])
    }
}

/// `rng.random_range(low..=high)` for `i64` (`low ≤ high`), bit for bit: rand 0.9's
/// single-sample method (Canon's, `UniformInt::sample_single_inclusive` without the
/// `unbiased` feature) written out. Through rand's generic entry the draws were not inlined:
/// each of the six to two hundred per neighbourhood paid a call, a `Result` and an emptiness
/// assertion. `fspf::tests::draws_are_rands_bit_for_bit` compares the two streams, so a
/// change in rand's method fails a test instead of changing FSPF's samples.
#[inline(always)]
fn draw(rng: &mut ChaCha8Rng, low: i64, high: i64) -> i64 {
    debug_assert!(low <= high);
    let range = high.wrapping_sub(low).wrapping_add(1) as u64;
    if range == 0 {
        // The whole of i64.
        return rng.next_u64() as i64;
    }
    let wide = u128::from(rng.next_u64()) * u128::from(range);
    let (mut result, lo_order) = ((wide >> 64) as u64, wide as u64);
    if lo_order > range.wrapping_neg() {
        let new_hi_order = ((u128::from(rng.next_u64()) * u128::from(range)) >> 64) as u64;
        result += u64::from(lo_order.checked_add(new_hi_order).is_none());
    }
    low.wrapping_add(result as i64)
}

#[inline]
fn sub(a: [f64; 3], b: [f64; 3]) -> Vector3<f64> {
    Vector3::new(a[0] - b[0], a[1] - b[1], a[2] - b[2])
}

impl PlaneFilter {
    pub fn new(params: FspfParams, seed: u64) -> Result<Self, LocalizationError> {
        params
            .validate()
            .map_err(|m| LocalizationError::InvalidParameter(format!("fspf: {m}")))?;
        Ok(Self {
            rng: ChaCha8Rng::seed_from_u64(seed),
            out: Arc::new(Output::for_params(&params)),
            spare: None,
            local: Vec::with_capacity(params.l),
            inlier: Vec::with_capacity(params.l),
            last: Arc::default(),
            rays: PixelRays::default(),
            params,
        })
    }

    pub fn params(&self) -> &FspfParams {
        &self.params
    }

    /// Algorithm 1 on one depth image. Fails (naming the parameter) when η does not fit the
    /// image or the intrinsics are unusable.
    pub fn filter(&mut self, img: &DepthImage) -> Result<PlaneFiltered<'_>, LocalizationError> {
        let p = self.params;
        p.validate_for_image(img.width, img.height)
            .map_err(|m| LocalizationError::InvalidParameter(format!("fspf: {m}")))?;
        if img.depth.len() != img.width * img.height
            || !(img.fx.is_finite() && img.fx > 0.0 && img.fy.is_finite() && img.fy > 0.0)
        {
            return Err(LocalizationError::InvalidParameter(format!(
                "fspf: depth image of sensor {:?} is malformed ({} × {} with {} depths, fx {}, fy {})",
                img.sensor,
                img.width,
                img.height,
                img.depth.len(),
                img.fx,
                img.fy
            )));
        }
        let shared = Arc::strong_count(&self.last) > 1;
        if shared && self.take_shared(img) {
            return Ok(self.output());
        }
        let rng_before = shared.then(|| self.rng.clone());
        self.sample_planes(img);
        if let Some(rng_before) = rng_before {
            self.share(img, rng_before);
        }
        Ok(self.output())
    }

    fn output(&self) -> PlaneFiltered<'_> {
        PlaneFiltered {
            points: &self.out.points,
            normals: &self.out.normals,
            outliers: &self.out.outliers,
            neighborhoods: self.out.neighborhoods,
        }
    }

    /// Takes the result a clone computed for this very frame and state, if there is one.
    fn take_shared(&mut self, img: &DepthImage) -> bool {
        let last = self.last.lock().unwrap_or_else(|p| p.into_inner());
        if !last.matches(&self.params, &self.rng, img) {
            return false;
        }
        let (Some(after), Some(out)) = (&last.rng_after, &last.out) else {
            return false;
        };
        self.rng = after.clone();
        let before = std::mem::replace(&mut self.out, out.clone());
        // Buffers no one else holds are this filter's next to write.
        if Arc::strong_count(&before) == 1 {
            self.spare = Some(before);
        }
        true
    }

    /// Records this frame's inputs and result for the clones (buffers reused).
    fn share(&self, img: &DepthImage, rng_before: ChaCha8Rng) {
        let mut last = self.last.lock().unwrap_or_else(|p| p.into_inner());
        last.params = Some(self.params);
        last.rng_before = Some(rng_before);
        last.rng_after = Some(self.rng.clone());
        last.geometry = geometry_bits(img);
        last.depth_bits.clear();
        last.depth_bits
            .extend(img.depth.iter().map(|d| d.to_bits()));
        last.out = Some(self.out.clone());
    }

    /// Makes `out` buffers this filter alone holds, to write the next result into: its own
    /// unless a clone or the shared record holds them, else the spare ones if no one does,
    /// else new ones.
    fn make_writable(&mut self) {
        if Arc::get_mut(&mut self.out).is_none() {
            let fresh = match self.spare.take() {
                Some(spare) if Arc::strong_count(&spare) == 1 => spare,
                _ => Arc::new(Output::for_params(&self.params)),
            };
            self.spare = Some(std::mem::replace(&mut self.out, fresh));
        }
    }

    /// Lines 1–24 of Algorithm 1 on a validated image, into the filter's buffers.
    fn sample_planes(&mut self, img: &DepthImage) {
        let p = self.params;
        self.make_writable();
        let out = Arc::get_mut(&mut self.out).expect("made writable above");
        out.clear();
        self.rays.update(img);
        let (w, h) = (img.width as i64, img.height as i64);
        let eta = p.eta as i64;
        let need = p.alpha_in * p.l as f64;
        let mut n = 0usize;
        let mut k = 0usize;
        while n < p.n_max && k < p.k_max {
            k += 1;
            // Lines 9–11: d0 anywhere, d1 and d2 within η of it.
            let (v0, u0) = (draw(&mut self.rng, 0, h - 1), draw(&mut self.rng, 0, w - 1));
            let v1 = v0 + draw(&mut self.rng, -eta, eta);
            let u1 = u0 + draw(&mut self.rng, -eta, eta);
            let v2 = v0 + draw(&mut self.rng, -eta, eta);
            let u2 = u0 + draw(&mut self.rng, -eta, eta);
            let inside = |u: i64, v: i64| u >= 0 && v >= 0 && u < w && v < h;
            if !inside(u1, v1) || !inside(u2, v2) {
                continue;
            }
            // Line 12 (pixels without depth cannot seed a plane).
            let (Some(p0), Some(p1), Some(p2)) = (
                self.rays.point(img, u0 as usize, v0 as usize),
                self.rays.point(img, u1 as usize, v1 as usize),
                self.rays.point(img, u2 as usize, v2 as usize),
            ) else {
                continue;
            };
            // Line 13: the plane normal r.
            let cross = sub(p1, p0).cross(&sub(p2, p0));
            let norm = cross.norm();
            // Collinear samples (or NaN) define no plane.
            if norm.is_nan() || norm <= 1e-12 {
                continue;
            }
            let r = cross / norm;
            // Lines 14–16: a window the image size of a plane of S metres at the mean depth.
            // The paper prints w' = w·(S/z̄)·tan(f_h); we use the pinhole projection of S,
            // S·fx/z̄ = w·S / (2 z̄ tan(f_h/2)), which is what the window is meant to be.
            let zbar = (p0[0] + p1[0] + p2[0]) / 3.0;
            let half_w = (0.5 * p.plane_size * img.fx / zbar).max(1.0) as i64;
            let half_h = (0.5 * p.plane_size * img.fy / zbar).max(1.0) as i64;
            let (ulo, uhi) = ((u0 - half_w).max(0), (u0 + half_w).min(w - 1));
            let (vlo, vhi) = ((v0 - half_h).max(0), (v0 + half_h).min(h - 1));
            // Line 17: local RANSAC, l samples in the window, inliers within ε of the plane.
            self.local.clear();
            self.inlier.clear();
            let mut inliers = 0usize;
            for _ in 0..p.l {
                let u = draw(&mut self.rng, ulo, uhi) as usize;
                let v = draw(&mut self.rng, vlo, vhi) as usize;
                if let Some(q) = self.rays.point(img, u, v) {
                    let ok = r.dot(&sub(q, p0)).abs() < p.epsilon;
                    inliers += ok as usize;
                    self.local.push(q);
                    self.inlier.push(ok);
                }
            }
            if inliers as f64 > need {
                // Lines 18–21, with the normal from a least-squares fit on the inliers.
                let normal = least_squares_normal(&self.local, &self.inlier, r);
                for (q, _) in self.local.iter().zip(&self.inlier).filter(|(_, ok)| **ok) {
                    out.points.push(*q);
                    out.normals.push(normal);
                }
                n += inliers;
            } else {
                // Line 23.
                out.outliers.extend_from_slice(&self.local);
            }
        }
        out.neighborhoods = k;
    }
}

/// The unit normal of the least-squares plane through the selected points (eigenvector of
/// the smallest eigenvalue of their scatter matrix), oriented towards the camera at the
/// origin; `fallback` when the fit is degenerate.
fn least_squares_normal(points: &[[f64; 3]], keep: &[bool], fallback: Vector3<f64>) -> [f64; 3] {
    let mut c = Vector3::zeros();
    let mut m = 0.0;
    for (q, _) in points.iter().zip(keep).filter(|(_, k)| **k) {
        c += Vector3::new(q[0], q[1], q[2]);
        m += 1.0;
    }
    let mut normal = fallback;
    if m >= 3.0 {
        c /= m;
        let mut s = Matrix3::zeros();
        for (q, _) in points.iter().zip(keep).filter(|(_, k)| **k) {
            let d = Vector3::new(q[0], q[1], q[2]) - c;
            s += d * d.transpose();
        }
        let eig = SymmetricEigen::new(s);
        let i = eig.eigenvalues.imin();
        let v = eig.eigenvectors.column(i).into_owned();
        if v.norm() > 0.5 {
            normal = v.normalize();
        }
        // Facing the camera: the normal points from the plane towards the origin.
        if normal.dot(&c) > 0.0 {
            normal = -normal;
        }
    } else if normal.dot(&Vector3::new(points[0][0], points[0][1], points[0][2])) > 0.0 {
        normal = -normal;
    }
    [normal.x, normal.y, normal.z]
}

/// Keeps the plane-filtered points whose plane is vertical (|normal_z| <= `max_normal_z` in
/// the robot's base frame, `mount` being the camera's pose in it) and writes their floor
/// projections (x, y) and unit 2D normals, in the base frame, into `points` and `normals`
/// (cleared first). Floors, ceilings, table tops and ramps are dropped.
pub fn vertical_planes_on_floor(
    filtered: &PlaneFiltered<'_>,
    mount: &Isometry3<f64>,
    max_normal_z: f64,
    points: &mut Vec<[f64; 2]>,
    normals: &mut Vec<[f64; 2]>,
) {
    points.clear();
    normals.clear();
    for (p, n) in filtered.points.iter().zip(filtered.normals) {
        let nb = mount.rotation * Vector3::new(n[0], n[1], n[2]);
        if nb.z.abs() > max_normal_z {
            continue;
        }
        let horizontal = nb.x.hypot(nb.y);
        if horizontal < 1e-9 {
            continue;
        }
        let pb = mount * Point3::new(p[0], p[1], p[2]);
        points.push([pb.x, pb.y]);
        normals.push([nb.x / horizontal, nb.y / horizontal]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use atrium_robots::{DepthCameraSpec, Mount3};
    use rand::Rng;
    use rand_distr::StandardNormal;

    #[test]
    fn draws_are_rands_bit_for_bit() {
        let ranges = [
            (0, 0),
            (0, 119),
            (0, 159),
            (-15, 15),
            (3, 4),
            (-7, -7),
            (i64::MIN, i64::MAX),
            (i64::MIN / 2, i64::MAX / 2),
            (i64::MIN, 0),
            (-(1 << 62), 3 << 61),
        ];
        for seed in 0..4 {
            let mut ours = ChaCha8Rng::seed_from_u64(seed);
            let mut rands = ours.clone();
            for k in 0..20_000 {
                let (low, high) = ranges[k % ranges.len()];
                let want = if k % 3 == 0 && high < i64::MAX {
                    rands.random_range(low..high + 1)
                } else {
                    rands.random_range(low..=high)
                };
                assert_eq!(draw(&mut ours, low, high), want, "seed {seed}, draw {k}");
            }
            assert_eq!(ours, rands, "seed {seed}: the streams fell out of step");
        }
    }

    /// A plane n·p = c in the camera frame.
    struct Plane {
        n: [f64; 3],
        c: f64,
    }

    /// A synthetic Kinect frame (640 × 480, σ(z) noise, 1 mm quantization) of the planes seen
    /// from the origin looking along +x: the nearest positive hit per pixel.
    fn synthetic(planes: &[Plane], seed: u64) -> DepthImage {
        let spec = DepthCameraSpec::kinect("k", "camera");
        let (fx, fy, cx, cy) = spec.intrinsics();
        let (w, h) = (spec.image_width(), spec.image_height());
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut depth = vec![0.0f32; w * h];
        for v in 0..h {
            for u in 0..w {
                let d = [1.0, -(u as f64 - cx) / fx, -(v as f64 - cy) / fy];
                let mut best = f64::INFINITY;
                for pl in planes {
                    let den = pl.n[0] * d[0] + pl.n[1] * d[1] + pl.n[2] * d[2];
                    if den.abs() > 1e-9 {
                        let t = pl.c / den; // t is the depth: d has unit x
                        if t > 0.0 && t < best {
                            best = t;
                        }
                    }
                }
                if best >= spec.range_min && best <= spec.range_max {
                    let e: f64 = rng.sample(StandardNormal);
                    let z = best + spec.sigma(best) * e;
                    depth[v * w + u] = ((z / 0.001).round() * 0.001) as f32;
                }
            }
        }
        DepthImage {
            stamp: 0.0,
            sensor: "k".into(),
            mount: Mount3::default(),
            width: w,
            height: h,
            fx,
            fy,
            cx,
            cy,
            depth,
        }
    }

    /// A corridor corner seen by a camera 0.5 m above the floor: an end wall 2.5 m ahead, a
    /// left wall 0.8 m to the side, a wall at 45° on the right (x − y = 3), and the floor.
    /// (Farther than about 3 m, σ(z) approaches ε = 0.02 m and a Kinect's planes fail the
    /// 80 % inlier test, as they should.)
    fn scene() -> Vec<Plane> {
        let s = std::f64::consts::FRAC_1_SQRT_2;
        vec![
            Plane {
                n: [1.0, 0.0, 0.0],
                c: 2.5,
            },
            Plane {
                n: [0.0, 1.0, 0.0],
                c: 0.8,
            },
            Plane {
                n: [s, -s, 0.0],
                c: 3.0 * s,
            },
            Plane {
                n: [0.0, 0.0, 1.0],
                c: -0.5,
            },
        ]
    }

    fn plane_distance(pl: &Plane, p: &[f64; 3]) -> f64 {
        (pl.n[0] * p[0] + pl.n[1] * p[1] + pl.n[2] * p[2] - pl.c).abs()
    }

    /// Points, normals and outliers as bits, and the neighbourhoods sampled.
    type Bits = (Vec<[u64; 3]>, Vec<[u64; 3]>, Vec<[u64; 3]>, usize);

    /// One frame's output, owned, bit for bit.
    fn owned(out: &PlaneFiltered<'_>) -> Bits {
        let bits = |v: &[[f64; 3]]| {
            v.iter()
                .map(|p| [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()])
                .collect::<Vec<_>>()
        };
        (
            bits(out.points),
            bits(out.normals),
            bits(out.outliers),
            out.neighborhoods,
        )
    }

    #[test]
    fn clones_share_a_frame_only_when_it_is_theirs_bit_for_bit() {
        // Three frames, one with pixels of NaN depth (never equal as floats, equal as bits).
        let planes = scene();
        let mut frames = vec![synthetic(&planes, 1), synthetic(&planes, 2)];
        let mut holes = synthetic(&planes, 3);
        for d in holes.depth.iter_mut().step_by(7) {
            *d = f32::NAN;
        }
        frames.push(holes);
        let params = FspfParams {
            n_max: 500,
            ..FspfParams::default()
        };
        // A private filter per stream: what each clone must see.
        let mut alone = PlaneFilter::new(params, 9).unwrap();
        let mut original = PlaneFilter::new(params, 9).unwrap();
        let first = owned(&original.filter(&frames[0]).unwrap());
        assert_eq!(first, owned(&alone.filter(&frames[0]).unwrap()));
        let mut copy = original.clone();
        let mut other_copy = original.clone();
        for f in &frames[1..] {
            let expected = owned(&alone.filter(f).unwrap());
            assert_eq!(owned(&original.filter(f).unwrap()), expected);
            // Served from the record: same output and same stream afterwards.
            assert_eq!(owned(&copy.filter(f).unwrap()), expected);
            assert!(copy.rng == alone.rng);
        }
        // A copy that missed frames is at another state: it computes its own result, which is
        // what a private filter at that state gives, not the record's.
        let mut lagging = PlaneFilter::new(params, 9).unwrap();
        lagging.filter(&frames[0]).unwrap();
        let behind = owned(&lagging.filter(&frames[2]).unwrap());
        let got = owned(&other_copy.filter(&frames[2]).unwrap());
        assert_eq!(got, behind);
        assert_ne!(got, owned(&original.filter(&frames[2]).unwrap()));
        // Another image at the same state is not served the record either.
        let mut a = PlaneFilter::new(params, 4).unwrap();
        let mut b = a.clone();
        let mut reference = PlaneFilter::new(params, 4).unwrap();
        a.filter(&frames[0]).unwrap();
        assert_eq!(
            owned(&b.filter(&frames[1]).unwrap()),
            owned(&reference.filter(&frames[1]).unwrap())
        );
    }

    /// The per-image factors give every pixel's point bit for bit, for images whose size and
    /// intrinsics change between frames (the factors must follow them).
    #[test]
    fn pixel_rays_are_the_per_sample_formula_bit_for_bit() {
        let mut rays = PixelRays::default();
        for (k, (w, h, cx, fx)) in [
            (160, 120, 79.5, 131.25),
            (64, 48, 31.7, 57.1),
            (160, 120, 80.0, 131.25),
        ]
        .into_iter()
        .enumerate()
        {
            let img = DepthImage {
                width: w,
                height: h,
                cx,
                cy: 0.4 * h as f64,
                fx,
                fy: fx * 1.01,
                depth: (0..w * h)
                    .map(|i| {
                        if i % 7 == 0 {
                            0.0
                        } else {
                            0.5 + (i * 37 % 401) as f32 * 0.01
                        }
                    })
                    .collect(),
                ..synthetic(&scene(), k as u64)
            };
            rays.update(&img);
            for v in 0..h {
                for u in 0..w {
                    let bits = |p: Option<[f64; 3]>| p.map(|p| p.map(f64::to_bits));
                    assert_eq!(
                        bits(rays.point(&img, u, v)),
                        bits(reconstruct(&img, u, v)),
                        "image {k}, pixel ({u}, {v})"
                    );
                }
            }
        }
    }

    #[test]
    fn recovers_known_planes_and_their_normals() {
        let planes = scene();
        let img = synthetic(&planes, 7);
        let mut fspf = PlaneFilter::new(FspfParams::default(), 3).unwrap();
        let out = fspf.filter(&img).unwrap();
        assert!(out.points.len() >= 2000, "{} points", out.points.len());
        assert!(out.neighborhoods < 20000);
        let eps = FspfParams::default().epsilon;
        let mut within = 0;
        let mut per_plane = vec![(0usize, 0usize, Vector3::zeros()); planes.len()];
        for (p, n) in out.points.iter().zip(out.normals) {
            let (best, d) = planes
                .iter()
                .enumerate()
                .map(|(i, pl)| (i, plane_distance(pl, p)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            if d < eps {
                within += 1;
            }
            let truth = Vector3::from(planes[best].n);
            let normal = Vector3::from(*n);
            let angle = normal.dot(&truth).abs().min(1.0).acos().to_degrees();
            let e = &mut per_plane[best];
            e.0 += 1;
            e.1 += (angle < 2.0) as usize;
            // Orient the truth like the estimate (towards the camera) before summing.
            e.2 += normal;
        }
        let frac = within as f64 / out.points.len() as f64;
        assert!(frac >= 0.9, "{frac} of the points within ε of a true plane");
        for (i, (count, good, sum)) in per_plane.iter().enumerate() {
            assert!(*count > 50, "plane {i}: {count} points");
            let mean = sum.normalize();
            let truth = Vector3::from(planes[i].n);
            let angle = mean.dot(&truth).abs().min(1.0).acos().to_degrees();
            assert!(angle < 2.0, "plane {i}: mean normal {angle}° off");
            assert!(
                *good as f64 >= 0.9 * *count as f64,
                "plane {i}: {good} of {count} normals within 2°"
            );
        }
        // Outliers exist (neighbourhoods across corners or off the image's valid part).
        assert!(!out.outliers.is_empty());
    }

    #[test]
    fn only_vertical_planes_reach_the_floor_plane() {
        let planes = scene();
        let img = synthetic(&planes, 8);
        let mut fspf = PlaneFilter::new(FspfParams::default(), 4).unwrap();
        let out = fspf.filter(&img).unwrap();
        let floor_points = out
            .points
            .iter()
            .filter(|p| (p[2] + 0.5).abs() < 0.02)
            .count();
        assert!(floor_points > 100, "the floor is a plane FSPF finds");
        let (mut pts, mut nrm) = (Vec::new(), Vec::new());
        // Camera 0.5 m above the base origin, level.
        let mount = Isometry3::translation(0.1, 0.0, 0.5);
        vertical_planes_on_floor(&out, &mount, 0.2, &mut pts, &mut nrm);
        assert!(!pts.is_empty());
        // Every kept point lies on one of the three walls (in the base frame: x shifted by
        // 0.1); none is a floor point projected (the floor spans x 1.3–4.5 at any y).
        let on_wall = |p: &[f64; 2]| {
            let (x, y) = (p[0] - 0.1, p[1]);
            let s = std::f64::consts::FRAC_1_SQRT_2;
            (x - 2.5).abs() < 0.03
                || (y - 0.8).abs() < 0.03
                || (s * x - s * y - 3.0 * s).abs() < 0.03
        };
        let walls = pts.iter().filter(|p| on_wall(p)).count();
        assert!(
            walls as f64 >= 0.95 * pts.len() as f64,
            "{walls} of {} kept points on walls",
            pts.len()
        );
        for n in &nrm {
            assert!((n[0].hypot(n[1]) - 1.0).abs() < 1e-9);
        }
        let kept_floor = out
            .points
            .iter()
            .zip(out.normals)
            .filter(|(p, n)| (p[2] + 0.5).abs() < 0.02 && n[2].abs() > 0.9)
            .count();
        assert!(kept_floor > 0);
        assert!(pts.len() <= out.points.len() - kept_floor);
    }

    #[test]
    fn bad_parameters_are_named() {
        let img = synthetic(&scene(), 1);
        let mut fspf = PlaneFilter::new(
            FspfParams {
                eta: 480,
                ..Default::default()
            },
            1,
        )
        .unwrap();
        let e = fspf.filter(&img).unwrap_err().to_string();
        assert!(e.contains("eta (480 px)") && e.contains("640 × 480"), "{e}");
        let e = PlaneFilter::new(
            FspfParams {
                l: 2,
                ..Default::default()
            },
            1,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("l must be >= 3"), "{e}");
        assert!(FspfParams {
            alpha_in: 1.5,
            ..Default::default()
        }
        .validate()
        .unwrap_err()
        .contains("alpha_in"));
    }

    #[test]
    fn sizes_above_their_limits_name_field_and_limit() {
        use crate::limits::{FSPF_MAX_LOCAL_SAMPLES, FSPF_MAX_NEIGHBOURHOODS, FSPF_MAX_POINTS};
        let at = FspfParams {
            n_max: FSPF_MAX_POINTS,
            k_max: FSPF_MAX_NEIGHBOURHOODS,
            l: FSPF_MAX_LOCAL_SAMPLES,
            ..FspfParams::default()
        };
        assert!(at.validate().is_ok());
        for (p, msg) in [
            (
                FspfParams {
                    n_max: FSPF_MAX_POINTS + 1,
                    ..at
                },
                "n_max: 100001 is more than the limit of 100000 (FSPF_MAX_POINTS)",
            ),
            (
                FspfParams {
                    k_max: FSPF_MAX_NEIGHBOURHOODS + 1,
                    ..at
                },
                "k_max: 200001 is more than the limit of 200000 (FSPF_MAX_NEIGHBOURHOODS)",
            ),
            (
                FspfParams {
                    l: FSPF_MAX_LOCAL_SAMPLES + 1,
                    ..at
                },
                "l: 1001 is more than the limit of 1000 (FSPF_MAX_LOCAL_SAMPLES)",
            ),
        ] {
            assert_eq!(p.validate().unwrap_err(), msg);
        }
    }
}
