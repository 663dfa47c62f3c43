//! Camera images: grey intensity images and disparity maps with missing values
//! ([000] §III), carried in the reading stream as [`crate::Reading::Intensity`] and
//! [`crate::Reading::Disparity`] (rendered by `atrium_sim::camera` and `atrium_sim::stereo`).

use crate::pose::Mount3;
use serde::{Deserialize, Serialize};

/// A grey image from a pinhole camera looking along the mount's +x (x forward, y left, z up).
/// `pixels[v * width + u]`, column u from the left, row v from the top, values in [0, 1].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IntensityImage {
    pub stamp: f64,
    pub sensor: String,
    pub mount: Mount3,
    pub width: usize,
    pub height: usize,
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    pub pixels: Vec<f32>,
}

/// A disparity map of a rectified stereo pair (left image's pixels): `disparity[v * width + u]`
/// in pixels, `f32::NAN` where stereo found no reliable match (a missing value). Depth is
/// `baseline · fx / disparity`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisparityImage {
    pub stamp: f64,
    pub sensor: String,
    pub width: usize,
    pub height: usize,
    pub fx: f64,
    pub baseline: f64,
    pub disparity: Vec<f32>,
}

impl DisparityImage {
    /// Fraction of pixels without a disparity.
    pub fn missing_fraction(&self) -> f64 {
        let n = self.disparity.iter().filter(|d| d.is_nan()).count();
        n as f64 / self.disparity.len().max(1) as f64
    }
}
