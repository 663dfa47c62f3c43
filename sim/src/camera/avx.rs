//! The light samples' sum of [`Shader::shade`](super::Shader) eight samples at a time with
//! AVX: each sample's term is computed by the scalar loop's operations, lane by lane, in its
//! order and without fused multiply-adds (IEEE division and square root are exact in both), and
//! the terms are then added to the radiance one by one in sample order, so the sum is the
//! scalar loop's bit for bit. Only the work is shared: a lamp's eight samples cost one
//! division per component instead of eight.

use super::light_sample::LightSample;
use rapier3d::prelude::Vector;

/// The light samples in columns, padded to whole groups of eight (the padding is never
/// added).
#[derive(Debug, Clone, Default)]
pub(super) struct SampleColumns {
    len: usize,
    px: Vec<f32>,
    py: Vec<f32>,
    pz: Vec<f32>,
    dx: Vec<f32>,
    dy: Vec<f32>,
    dz: Vec<f32>,
    isotropic: Vec<f32>,
    power: Vec<f32>,
}

impl SampleColumns {
    pub(super) fn new(samples: &[LightSample]) -> SampleColumns {
        let padded = samples.len().div_ceil(8) * 8;
        let column = |f: &dyn Fn(&LightSample) -> f32, pad: f32| {
            let mut c: Vec<f32> = samples.iter().map(f).collect();
            c.resize(padded, pad);
            c
        };
        SampleColumns {
            len: samples.len(),
            px: column(&|l| l.pos.x, 0.0),
            py: column(&|l| l.pos.y, 0.0),
            pz: column(&|l| l.pos.z, 1.0),
            dx: column(&|l| l.dir.x, 0.0),
            dy: column(&|l| l.dir.y, 0.0),
            dz: column(&|l| l.dir.z, -1.0),
            isotropic: column(&|l| l.isotropic, 1.0),
            power: column(&|l| l.power, 0.0),
        }
    }
}

/// Whether this processor runs [`add_samples`].
pub(super) fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// `e` plus, in sample order, each lit sample's `power · lambert · emit / (r² + softening)`
/// at the point `p` with normal `n`: what the scalar loop of `Shader::shade` returns.
///
/// # Safety
/// The processor has AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
pub(super) unsafe fn add_samples(
    c: &SampleColumns,
    p: Vector,
    n: Vector,
    softening: f32,
    mut e: f32,
) -> f32 {
    use std::arch::x86_64::*;
    let (ppx, ppy, ppz) = (
        _mm256_set1_ps(p.x),
        _mm256_set1_ps(p.y),
        _mm256_set1_ps(p.z),
    );
    let (nx, ny, nz) = (
        _mm256_set1_ps(n.x),
        _mm256_set1_ps(n.y),
        _mm256_set1_ps(n.z),
    );
    let (zero, one, soft) = (
        _mm256_setzero_ps(),
        _mm256_set1_ps(1.0),
        _mm256_set1_ps(softening),
    );
    let (mut lamberts, mut terms) = ([0f32; 8], [0f32; 8]);
    let mut k = 0;
    while k < c.len {
        let at = |col: &Vec<f32>| unsafe { _mm256_loadu_ps(col.as_ptr().add(k)) };
        // d = l.pos − p; r² = d·d as glam's dot: (x·x + y·y) + z·z.
        let dx = _mm256_sub_ps(at(&c.px), ppx);
        let dy = _mm256_sub_ps(at(&c.py), ppy);
        let dz = _mm256_sub_ps(at(&c.pz), ppz);
        let r2 = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)),
            _mm256_mul_ps(dz, dz),
        );
        // dir = d / √r², component by component.
        let r = _mm256_sqrt_ps(r2);
        let (ux, uy, uz) = (
            _mm256_div_ps(dx, r),
            _mm256_div_ps(dy, r),
            _mm256_div_ps(dz, r),
        );
        let lambert = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(nx, ux), _mm256_mul_ps(ny, uy)),
            _mm256_mul_ps(nz, uz),
        );
        // (−dir)·l.dir, then max(·, 0) as f32::max does (a NaN gives 0: the second operand).
        let neg = _mm256_set1_ps(-0.0);
        let facing = _mm256_add_ps(
            _mm256_add_ps(
                _mm256_mul_ps(_mm256_xor_ps(ux, neg), at(&c.dx)),
                _mm256_mul_ps(_mm256_xor_ps(uy, neg), at(&c.dy)),
            ),
            _mm256_mul_ps(_mm256_xor_ps(uz, neg), at(&c.dz)),
        );
        let iso = at(&c.isotropic);
        let emit = _mm256_add_ps(
            iso,
            _mm256_mul_ps(_mm256_sub_ps(one, iso), _mm256_max_ps(facing, zero)),
        );
        let term = _mm256_div_ps(
            _mm256_mul_ps(_mm256_mul_ps(at(&c.power), lambert), emit),
            _mm256_add_ps(r2, soft),
        );
        _mm256_storeu_ps(lamberts.as_mut_ptr(), lambert);
        _mm256_storeu_ps(terms.as_mut_ptr(), term);
        for j in 0..8.min(c.len - k) {
            // As the scalar loop: `lambert <= 0` is skipped, a NaN is not.
            if lamberts[j] <= 0.0 {
                continue;
            }
            e += terms[j];
        }
        k += 8;
    }
    e
}
