//! What the crate's AVX2 kernels share: whether the processor runs them, the read-only view of a
//! grid of f32 cells they look up (the likelihood field's log-likelihood table, scan matching's
//! coarse distances), and the lanes' bounds test. The kernels themselves sit beside the scalar
//! code they reproduce bit for bit (`likelihood_field/avx2.rs`, `scan_match/avx2.rs`).

/// Whether this processor runs the crate's AVX2 kernels.
pub(crate) fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// A row-major grid of f32 cells as a kernel reads it: `cells[v * width + u]`, cell (0, 0)
/// starting at `origin`, `inv_resolution` cells per metre.
#[derive(Debug, Clone, Copy)]
pub(crate) struct GridTable<'a> {
    pub origin: [f64; 2],
    pub inv_resolution: f64,
    pub width: usize,
    pub height: usize,
    pub cells: &'a [f32],
}

/// Lanes with 0 ≤ `u` < `umax` and 0 ≤ `v` < `vmax`, all bits set (the scalar lookups'
/// bounds test). Ordered comparisons: NaN fails them, as in the scalar test.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
pub(crate) fn within(
    u: std::arch::x86_64::__m256d,
    v: std::arch::x86_64::__m256d,
    umax: std::arch::x86_64::__m256d,
    vmax: std::arch::x86_64::__m256d,
) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let zero = _mm256_setzero_pd();
    _mm256_and_pd(
        _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_GE_OQ>(u, zero),
            _mm256_cmp_pd::<_CMP_GE_OQ>(v, zero),
        ),
        _mm256_and_pd(
            _mm256_cmp_pd::<_CMP_LT_OQ>(u, umax),
            _mm256_cmp_pd::<_CMP_LT_OQ>(v, vmax),
        ),
    )
}
