//! The omnicam eigenimage map of [001] (second part): panoramic
//! training images on a grid, each also taken at R rotation angles ("each of these images was
//! rotated to 32 different angles (11.25 degree resolution)"), eigenimages of all of them by
//! the snapshot trick of Turk ([`crate::pca`], `PcaMethod::Snapshot`), every sample projected
//! onto the first d eigenimages; then "at run-time, the robot takes an omnicam image from its
//! current position, projects the image to an l-dimensional vector using P, and calculates the
//! sum of square differences for each point of the map to generate an energy function".
//!
//! Rotation: for a panorama a turn of the robot is a circular shift of the columns (column c
//! looks at azimuth 2π c / W from the heading), so the R rotated copies of a training image
//! are shifts by W / R columns, and a training image taken at heading 0 stands for every
//! heading k · 2π / R. Rotation is thereby handled as 001 does, by putting the rotated views
//! into the map (not by a rotation-invariant descriptor): the energy is minimised over
//! position and rotation together, and the rotation found is the heading.
//!
//! "Points between the samples are obtained by interpolation": [`OmniMap::energy_at`]
//! interpolates the map's features bilinearly in position and linearly in rotation.

use crate::error::LocalizationError;
use crate::limits::{MAX_PCA_SAMPLES, OMNI_MAX_FEATURES};
use crate::pca::{Pca, PcaMethod};
use atrium_robots::{normalize_angle, Pose2};
use rand::seq::index::sample;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// How an omnicam map is built.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct OmniMapParams {
    /// Rotation angles per training image, R (001: 32). Must divide the panorama width.
    pub rotations: usize,
    /// Eigenimages kept, d (001 shows the first 5 and colours the map with 3). Default 20.
    pub d: usize,
    /// Training locations whose R rotated images give the eigenimages (001: 10 locations ×
    /// 32 rotations = 320 images). Default 10.
    pub pca_locations: usize,
    pub seed: u64,
}

impl Default for OmniMapParams {
    fn default() -> Self {
        Self {
            rotations: 32,
            d: 20,
            pca_locations: 10,
            seed: 0,
        }
    }
}

/// The best match of a panorama in the map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OmniMatch {
    /// Grid node position and the heading of the best rotation.
    pub pose: Pose2,
    pub node: (usize, usize),
    pub rotation: usize,
    /// Its energy (sum of squared feature differences).
    pub energy: f64,
}

/// Panoramas `width × height` (row-major) on a grid of nodes (x0 + i·step, y0 + j·step).
#[derive(Debug, Clone, PartialEq)]
pub struct OmniMap {
    pub width: usize,
    pub height: usize,
    origin: [f64; 2],
    step: f64,
    nx: usize,
    ny: usize,
    rotations: usize,
    pca: Pca,
    /// Features of node (i, j) at rotation r: `features[((j * nx + i) * R + r) * d ..][..d]`.
    features: Vec<f64>,
}

/// Circular shift of the columns of a row-major `width`-wide image by `k`:
/// `out[row][c] = image[row][(c + k) mod width]`, i.e. the view after turning the robot by
/// +2π k / width (counter-clockwise).
pub fn shift_columns(image: &[f32], width: usize, k: usize, out: &mut [f32]) {
    let k = k % width.max(1);
    for (src, dst) in image.chunks_exact(width).zip(out.chunks_exact_mut(width)) {
        dst[..width - k].copy_from_slice(&src[k..]);
        dst[width - k..].copy_from_slice(&src[..k]);
    }
}

impl OmniMap {
    /// Builds the map from panoramas taken at heading 0 at every node, `images[j * nx + i]`.
    #[allow(clippy::too_many_arguments)]
    pub fn build(
        origin: [f64; 2],
        step: f64,
        nx: usize,
        ny: usize,
        width: usize,
        height: usize,
        images: &[&[f32]],
        params: OmniMapParams,
    ) -> Result<OmniMap, LocalizationError> {
        let bad = |r: String| LocalizationError::InvalidParameter(format!("omni map: {r}"));
        if !(origin.iter().all(|v| v.is_finite()) && step.is_finite() && step > 0.0) {
            return Err(bad(format!(
                "origin must be finite and step finite and > 0, got {origin:?}, {step}"
            )));
        }
        if nx == 0 || ny == 0 || Some(images.len()) != nx.checked_mul(ny) {
            return Err(bad(format!(
                "need one panorama per node of the {nx} × {ny} grid, got {}",
                images.len()
            )));
        }
        if width < 2 || height == 0 {
            return Err(bad(format!(
                "panorama size must be at least 2 × 1, got {width} × {height}"
            )));
        }
        let r = params.rotations;
        if r == 0 || !width.is_multiple_of(r) {
            return Err(bad(format!(
                "rotations ({r}) must be >= 1 and divide the panorama width ({width})"
            )));
        }
        let dim = width * height;
        for (k, img) in images.iter().enumerate() {
            if img.len() != dim {
                return Err(bad(format!(
                    "panorama {k} has {} pixels, expected {width} × {height} = {dim}",
                    img.len()
                )));
            }
            if let Some(p) = img.iter().position(|v| !v.is_finite()) {
                return Err(bad(format!(
                    "panorama {k} has a non-finite pixel at index {p}"
                )));
            }
        }
        // Sizes, before the rotated copies and the features are allocated.
        let pca_images = params.pca_locations.clamp(1, images.len()) as f64 * r as f64;
        if pca_images > MAX_PCA_SAMPLES as f64 {
            return Err(bad(format!(
                "pca_locations × rotations = {pca_images} images, more than the limit of \
                 {MAX_PCA_SAMPLES} (MAX_PCA_SAMPLES)"
            )));
        }
        let features = images.len() as f64 * r as f64 * params.d as f64;
        if features > OMNI_MAX_FEATURES as f64 {
            return Err(bad(format!(
                "d: {} nodes × {r} rotations × {} = {features} features, more than the limit \
                 of {OMNI_MAX_FEATURES} (OMNI_MAX_FEATURES)",
                images.len(),
                params.d
            )));
        }
        let shift = width / r;
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
        let locs = sample(
            &mut rng,
            images.len(),
            params.pca_locations.clamp(1, images.len()),
        )
        .into_vec();
        let mut rotated: Vec<Vec<f32>> = Vec::with_capacity(locs.len() * r);
        for &l in &locs {
            for k in 0..r {
                let mut out = vec![0.0; dim];
                shift_columns(images[l], width, k * shift, &mut out);
                rotated.push(out);
            }
        }
        let refs: Vec<&[f32]> = rotated.iter().map(|v| v.as_slice()).collect();
        let pca = Pca::fit(&refs, params.d, PcaMethod::Snapshot)
            .map_err(|e| bad(format!("eigenimages: {e}")))?;
        let d = pca.d();
        let mut features = vec![0.0; images.len() * r * d];
        let mut buf = vec![0.0f32; dim];
        for (n, img) in images.iter().enumerate() {
            for k in 0..r {
                shift_columns(img, width, k * shift, &mut buf);
                let o = (n * r + k) * d;
                pca.project_into(&buf, &mut features[o..o + d])?;
            }
        }
        Ok(OmniMap {
            width,
            height,
            origin,
            step,
            nx,
            ny,
            rotations: r,
            pca,
            features,
        })
    }

    /// A map from its parts (kept from an earlier [`OmniMap::build`]: [`OmniMap::origin`],
    /// [`OmniMap::step`], [`OmniMap::nodes`], [`OmniMap::rotations`], [`OmniMap::pca`],
    /// [`OmniMap::features`]), refused unless they fit together: a finite origin, a finite
    /// step > 0, at least one node, panoramas of at least 2 × 1 pixels that the eigenimages
    /// span (`pca.dim() == width × height`), rotations that divide the width, and one finite
    /// feature vector of `pca.d()` per node and rotation.
    #[allow(clippy::too_many_arguments)]
    pub fn from_parts(
        origin: [f64; 2],
        step: f64,
        nx: usize,
        ny: usize,
        width: usize,
        height: usize,
        rotations: usize,
        pca: Pca,
        features: Vec<f64>,
    ) -> Result<OmniMap, LocalizationError> {
        let bad = |r: String| LocalizationError::InvalidParameter(format!("omni map: {r}"));
        if !(origin.iter().all(|v| v.is_finite()) && step.is_finite() && step > 0.0) {
            return Err(bad(format!(
                "origin must be finite and step finite and > 0, got {origin:?}, {step}"
            )));
        }
        if nx == 0 || ny == 0 || width < 2 || height == 0 {
            return Err(bad(format!(
                "need at least 1 × 1 nodes and 2 × 1 pixels, got {nx} × {ny} nodes of \
                 {width} × {height}"
            )));
        }
        if rotations == 0 || !width.is_multiple_of(rotations) {
            return Err(bad(format!(
                "rotations ({rotations}) must be >= 1 and divide the panorama width ({width})"
            )));
        }
        if width.checked_mul(height) != Some(pca.dim()) || pca.d() == 0 {
            return Err(bad(format!(
                "eigenimages of {} pixels ({} of them) do not fit {width} × {height} panoramas",
                pca.dim(),
                pca.d()
            )));
        }
        let expected = nx
            .checked_mul(ny)
            .and_then(|n| n.checked_mul(rotations))
            .and_then(|n| n.checked_mul(pca.d()));
        if expected != Some(features.len()) {
            return Err(bad(format!(
                "{} features for {nx} × {ny} nodes × {rotations} rotations × d = {}",
                features.len(),
                pca.d()
            )));
        }
        if features.iter().any(|v| !v.is_finite()) {
            return Err(bad("a feature is not finite".into()));
        }
        Ok(OmniMap {
            width,
            height,
            origin,
            step,
            nx,
            ny,
            rotations,
            pca,
            features,
        })
    }

    pub fn d(&self) -> usize {
        self.pca.d()
    }

    /// Position of node (0, 0).
    pub fn origin(&self) -> [f64; 2] {
        self.origin
    }

    /// Every node's features at every rotation: node (i, j) at rotation r is
    /// `features()[((j * nx + i) * R + r) * d ..][..d]`.
    pub fn features(&self) -> &[f64] {
        &self.features
    }

    pub fn rotations(&self) -> usize {
        self.rotations
    }

    /// The eigenimages and mean (001's "mean and eigenimages").
    pub fn pca(&self) -> &Pca {
        &self.pca
    }

    pub fn node_position(&self, i: usize, j: usize) -> [f64; 2] {
        [
            self.origin[0] + i as f64 * self.step,
            self.origin[1] + j as f64 * self.step,
        ]
    }

    /// The heading of rotation `r`: 2π r / R.
    pub fn heading(&self, r: usize) -> f64 {
        normalize_angle(2.0 * std::f64::consts::PI * r as f64 / self.rotations as f64)
    }

    /// Grid nodes along x and y.
    pub fn nodes(&self) -> (usize, usize) {
        (self.nx, self.ny)
    }

    /// Node spacing, m.
    pub fn step(&self) -> f64 {
        self.step
    }

    /// (x0, y0, x1, y1) of the node grid.
    pub fn extent(&self) -> [f64; 4] {
        let [x1, y1] = self.node_position(self.nx - 1, self.ny - 1);
        [self.origin[0], self.origin[1], x1, y1]
    }

    /// The median energy between the features of neighbouring nodes (one grid step along x
    /// or y, same rotation): how much the energy function rises one grid step away from a
    /// training pose, the natural scale for turning energies into likelihoods
    /// (`omni_mcl.rs`). 0 for a single-node map.
    pub fn step_energy(&self) -> f64 {
        let (d, r) = (self.d(), self.rotations);
        let f = |i: usize, j: usize, k: usize| {
            let o = ((j * self.nx + i) * r + k) * d;
            &self.features[o..o + d]
        };
        let mut e = Vec::with_capacity(self.nx * self.ny * r * 2);
        for j in 0..self.ny {
            for i in 0..self.nx {
                for k in 0..r {
                    let a = f(i, j, k);
                    let mut push = |b: &[f64]| {
                        e.push(a.iter().zip(b).map(|(p, q)| (p - q) * (p - q)).sum::<f64>())
                    };
                    if i + 1 < self.nx {
                        push(f(i + 1, j, k));
                    }
                    if j + 1 < self.ny {
                        push(f(i, j + 1, k));
                    }
                }
            }
        }
        if e.is_empty() {
            return 0.0;
        }
        let mid = e.len() / 2;
        *e.select_nth_unstable_by(mid, f64::total_cmp).1
    }

    /// Projects a panorama onto the eigenimages ("using P"). Errors name the problem: wrong
    /// size, non-finite pixel.
    pub fn features_into(&self, image: &[f32], out: &mut [f64]) -> Result<(), LocalizationError> {
        if image.len() != self.width * self.height {
            return Err(LocalizationError::InvalidParameter(format!(
                "omni map: panorama has {} pixels, the map was built from {} × {} = {}",
                image.len(),
                self.width,
                self.height,
                self.width * self.height
            )));
        }
        self.pca.project_into(image, out)
    }

    /// The energy function of 001: for every node and rotation, the sum of squared
    /// differences between `y` and the node's features; `out[(j * nx + i) * R + r]`.
    pub fn energy(&self, y: &[f64], out: &mut Vec<f64>) {
        let d = self.d();
        out.clear();
        out.extend(
            self.features
                .chunks_exact(d)
                .map(|f| f.iter().zip(y).map(|(a, b)| (a - b) * (a - b)).sum::<f64>()),
        );
    }

    /// The energy at any pose inside the grid, from features interpolated bilinearly between
    /// the four surrounding nodes and linearly between the two nearest rotations (001: "points
    /// between the samples are obtained by interpolation"). `None` outside the grid.
    pub fn energy_at(&self, y: &[f64], pose: &Pose2) -> Option<f64> {
        let u = (pose.x - self.origin[0]) / self.step;
        let v = (pose.y - self.origin[1]) / self.step;
        let (mx, my) = ((self.nx - 1) as f64, (self.ny - 1) as f64);
        if !(u >= 0.0 && v >= 0.0 && u <= mx && v <= my) || y.len() != self.d() {
            return None;
        }
        let i = (u.floor() as usize).min(self.nx.saturating_sub(2));
        let j = (v.floor() as usize).min(self.ny.saturating_sub(2));
        let (fu, fv) = (u - i as f64, v - j as f64);
        let r = self.rotations;
        let t = pose.theta.rem_euclid(2.0 * std::f64::consts::PI) / (2.0 * std::f64::consts::PI)
            * r as f64;
        let r0 = (t.floor() as usize) % r;
        let r1 = (r0 + 1) % r;
        let ft = t - t.floor();
        let d = self.d();
        let mut e = 0.0;
        for (k, yk) in y.iter().enumerate() {
            let mut f = 0.0;
            for (di, dj, wxy) in [
                (0, 0, (1.0 - fu) * (1.0 - fv)),
                (1, 0, fu * (1.0 - fv)),
                (0, 1, (1.0 - fu) * fv),
                (1, 1, fu * fv),
            ] {
                if wxy == 0.0 {
                    continue;
                }
                let node = (j + dj).min(self.ny - 1) * self.nx + (i + di).min(self.nx - 1);
                for (rr, wr) in [(r0, 1.0 - ft), (r1, ft)] {
                    f += wxy * wr * self.features[(node * r + rr) * d + k];
                }
            }
            e += (yk - f) * (yk - f);
        }
        Some(e)
    }

    /// The node and rotation of least energy for a panorama: its place and heading.
    pub fn lookup(&self, image: &[f32]) -> Result<OmniMatch, LocalizationError> {
        let mut y = vec![0.0; self.d()];
        self.features_into(image, &mut y)?;
        let mut e = Vec::with_capacity(self.features.len() / self.d());
        self.energy(&y, &mut e);
        let (best, energy) = e
            .iter()
            .copied()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("the map has at least one node");
        let (node, rotation) = (best / self.rotations, best % self.rotations);
        let (i, j) = (node % self.nx, node / self.nx);
        let [x, yy] = self.node_position(i, j);
        Ok(OmniMatch {
            pose: Pose2::new(x, yy, self.heading(rotation)),
            node: (i, j),
            rotation,
            energy,
        })
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A synthetic panorama: the azimuthal profile seen from (x, y) of three coloured posts.
    fn panorama(x: f64, y: f64, theta: f64, w: usize, h: usize) -> Vec<f32> {
        let posts = [(5.0, 1.0, 0.9), (-1.0, 4.0, 0.5), (2.0, -3.0, 0.2)];
        panorama_of(&posts, x, y, theta, w, h)
    }

    /// The panorama (`w` × `h`) seen from (x, y) with heading `theta` of `posts` (x, y,
    /// brightness), also for the filter's tests (`omni_mcl.rs`).
    pub(crate) fn panorama_of(
        posts: &[(f64, f64, f64)],
        x: f64,
        y: f64,
        theta: f64,
        w: usize,
        h: usize,
    ) -> Vec<f32> {
        let mut img = vec![0.3f32; w * h];
        for c in 0..w {
            let az = theta + 2.0 * std::f64::consts::PI * c as f64 / w as f64;
            for &(px, py, b) in posts {
                let bearing = (py - y).atan2(px - x);
                let dist = (px - x).hypot(py - y);
                let da = normalize_angle(bearing - az);
                let v = b * (-da * da * dist * dist / 0.5).exp();
                for r in 0..h {
                    let rows = (h as f64 * (0.3 + 1.0 / dist).min(1.0)) as usize;
                    if r < rows {
                        img[r * w + c] += v as f32;
                    }
                }
            }
        }
        img
    }

    fn map() -> OmniMap {
        let (nx, ny) = (7, 5);
        let imgs: Vec<Vec<f32>> = (0..ny)
            .flat_map(|j| {
                (0..nx).map(move |i| panorama(i as f64 * 0.5, j as f64 * 0.5, 0.0, 32, 4))
            })
            .collect();
        let refs: Vec<&[f32]> = imgs.iter().map(|v| v.as_slice()).collect();
        OmniMap::build(
            [0.0, 0.0],
            0.5,
            nx,
            ny,
            32,
            4,
            &refs,
            OmniMapParams {
                rotations: 16,
                d: 12,
                pca_locations: 12,
                seed: 1,
            },
        )
        .unwrap()
    }

    #[test]
    fn shift_is_a_rotation() {
        let img: Vec<f32> = (0..8).map(|v| v as f32).collect();
        let mut out = vec![0.0; 8];
        shift_columns(&img, 4, 1, &mut out);
        assert_eq!(out, vec![1.0, 2.0, 3.0, 0.0, 5.0, 6.0, 7.0, 4.0]);
        // The synthetic camera turned by 2π·3/32 is the heading-0 view shifted by 3.
        let a = panorama(1.0, 1.0, 0.0, 32, 4);
        let b = panorama(1.0, 1.0, 2.0 * std::f64::consts::PI * 3.0 / 32.0, 32, 4);
        let mut s = vec![0.0; a.len()];
        shift_columns(&a, 32, 3, &mut s);
        assert!(s.iter().zip(&b).all(|(p, q)| (p - q).abs() < 1e-6));
    }

    #[test]
    fn training_pose_is_found_under_rotation_and_energy_is_smooth() {
        let m = map();
        for (i, j, r) in [(2, 3, 5), (6, 0, 11), (0, 4, 0)] {
            let th = 2.0 * std::f64::consts::PI * r as f64 / 16.0;
            let img = panorama(i as f64 * 0.5, j as f64 * 0.5, th, 32, 4);
            let hit = m.lookup(&img).unwrap();
            assert_eq!((hit.node, hit.rotation), ((i, j), r), "{hit:?}");
            let mut y = vec![0.0; m.d()];
            m.features_into(&img, &mut y).unwrap();
            let at = m.energy_at(&y, &hit.pose).unwrap();
            assert!((at - hit.energy).abs() < 1e-9 * (1.0 + at));
        }
        // Between nodes the interpolated energy is lowest near the true pose.
        let img = panorama(1.25, 1.0, 0.0, 32, 4);
        let mut y = vec![0.0; m.d()];
        m.features_into(&img, &mut y).unwrap();
        let near = m.energy_at(&y, &Pose2::new(1.25, 1.0, 0.0)).unwrap();
        let far = m.energy_at(&y, &Pose2::new(2.75, 1.75, 1.0)).unwrap();
        assert!(near < far, "{near} {far}");
        assert!(m.energy_at(&y, &Pose2::new(-1.0, 0.0, 0.0)).is_none());
    }

    #[test]
    fn from_parts_gives_the_built_map_and_refuses_misfits() {
        let m = map();
        let (nx, ny) = m.nodes();
        let parts = |m: &OmniMap| {
            OmniMap::from_parts(
                m.origin(),
                m.step(),
                m.nodes().0,
                m.nodes().1,
                m.width,
                m.height,
                m.rotations(),
                m.pca().clone(),
                m.features().to_vec(),
            )
        };
        let back = parts(&m).unwrap();
        assert_eq!(back, m);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(back.features()), bits(m.features()));
        let img = panorama(1.3, 0.8, 0.4, 32, 4);
        assert_eq!(back.lookup(&img).unwrap(), m.lookup(&img).unwrap());
        let mut short = m.clone();
        short.features.pop();
        let mut nan = m.clone();
        nan.features[5] = f64::NAN;
        let mut wide = m.clone();
        wide.width = 64;
        let mut rot = m.clone();
        rot.rotations = 5;
        let mut step = m.clone();
        step.step = 0.0;
        let mut grid = m.clone();
        grid.nx = nx + 1;
        for bad in [short, nan, wide, rot, step, grid] {
            assert!(
                parts(&bad).is_err(),
                "{:?}",
                (bad.nx, ny, bad.width, bad.rotations)
            );
        }
    }

    #[test]
    fn bad_input_is_refused() {
        let m = map();
        assert!(m
            .lookup(&[0.0; 10])
            .unwrap_err()
            .to_string()
            .contains("10 pixels"));
        let mut img = panorama(1.0, 1.0, 0.0, 32, 4);
        img[7] = f32::NAN;
        assert!(m
            .lookup(&img)
            .unwrap_err()
            .to_string()
            .contains("non-finite"));
        let a = panorama(1.0, 1.0, 0.0, 32, 4);
        let e = OmniMap::build(
            [0.0, 0.0],
            0.5,
            2,
            1,
            32,
            4,
            &[&a],
            OmniMapParams::default(),
        )
        .unwrap_err();
        assert!(e.to_string().contains("one panorama per node"), "{e}");
        let e = OmniMap::build([0.0, 0.0], 0.5, 0, 0, 32, 4, &[], OmniMapParams::default())
            .unwrap_err();
        assert!(e.to_string().contains("one panorama per node"), "{e}");
        let e = OmniMap::build(
            [0.0, 0.0],
            0.5,
            1,
            1,
            32,
            4,
            &[&a],
            OmniMapParams {
                rotations: 5,
                ..Default::default()
            },
        )
        .unwrap_err();
        assert!(e.to_string().contains("divide"), "{e}");
    }

    #[test]
    fn sizes_above_their_limits_are_refused_before_allocating() {
        let img = vec![0.5f32; 32 * 4];
        let images: Vec<&[f32]> = vec![img.as_slice(); 4];
        let build = |params: OmniMapParams| {
            OmniMap::build([0.0, 0.0], 0.5, 2, 2, 32, 4, &images, params)
                .unwrap_err()
                .to_string()
        };
        let e = build(OmniMapParams {
            rotations: 32,
            d: 1_000_000_000,
            pca_locations: 2,
            seed: 0,
        });
        assert!(e.contains("OMNI_MAX_FEATURES"), "{e}");
        let many = vec![img.as_slice(); 100];
        let e = OmniMap::build(
            [0.0, 0.0],
            0.5,
            10,
            10,
            32,
            4,
            &many,
            OmniMapParams {
                rotations: 32,
                d: 5,
                pca_locations: 100,
                seed: 0,
            },
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("3200 images, more than the limit of 2000 (MAX_PCA_SAMPLES)"),
            "{e}"
        );
    }
}
