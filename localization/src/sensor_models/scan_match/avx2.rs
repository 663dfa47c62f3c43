//! [`CoarseDistance::truncated_cost`](super::CoarseDistance::truncated_cost) for four poses at a time with AVX2: each lane sums its
//! pose's beams in beam order with the scalar code's operations (no fused multiply-adds), so
//! every cost is the scalar one bit for bit.

#[cfg(target_arch = "x86_64")]
use crate::sensor_models::simd::{within, GridTable};
use atrium_robots::Pose2;

/// `out[i]` = the truncated cost of the endpoints from `poses[i]`, for the poses in whole
/// groups of four; returns how many it did (the caller does the rest).
///
/// # Safety
/// The processor has AVX2, every cell index of `coarse` fits in i32, and `out` is no longer
/// than `poses`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn truncated_costs(
    coarse: &GridTable<'_>,
    bx: &[f64],
    by: &[f64],
    poses: &[Pose2],
    c2: f64,
    out: &mut [f64],
) -> usize {
    use std::arch::x86_64::*;
    let n = out.len() / 4 * 4;
    let by = &by[..bx.len()];
    let table = coarse.cells.as_ptr();
    let (ox, oy) = (
        _mm256_set1_pd(coarse.origin[0]),
        _mm256_set1_pd(coarse.origin[1]),
    );
    let inv = _mm256_set1_pd(coarse.inv_resolution);
    let wmax = _mm256_set1_pd(coarse.width as f64);
    let hmax = _mm256_set1_pd(coarse.height as f64);
    let wide = _mm_set1_epi32(coarse.width as i32);
    let cap = _mm256_set1_pd(c2);
    for i in (0..n).step_by(4) {
        let p = &poses[i..i + 4];
        let sc: [(f64, f64); 4] = std::array::from_fn(|k| p[k].theta.sin_cos());
        let px = _mm256_set_pd(p[3].x, p[2].x, p[1].x, p[0].x);
        let py = _mm256_set_pd(p[3].y, p[2].y, p[1].y, p[0].y);
        let s = _mm256_set_pd(sc[3].0, sc[2].0, sc[1].0, sc[0].0);
        let c = _mm256_set_pd(sc[3].1, sc[2].1, sc[1].1, sc[0].1);
        let mut cost = _mm256_setzero_pd();
        for (&u, &v) in bx.iter().zip(by) {
            let (bu, bv) = (_mm256_set1_pd(u), _mm256_set1_pd(v));
            // x + c·u − s·v and y + s·u + c·v, left to right as the scalar code adds them.
            let x = _mm256_sub_pd(
                _mm256_add_pd(px, _mm256_mul_pd(c, bu)),
                _mm256_mul_pd(s, bv),
            );
            let y = _mm256_add_pd(
                _mm256_add_pd(py, _mm256_mul_pd(s, bu)),
                _mm256_mul_pd(c, bv),
            );
            let fx = _mm256_mul_pd(_mm256_sub_pd(x, ox), inv);
            let fy = _mm256_mul_pd(_mm256_sub_pd(y, oy), inv);
            let inside = within(fx, fy, wmax, hmax);
            // Outside lanes read cell 0 and are replaced by the cap below.
            let safe_x = _mm256_and_pd(fx, inside);
            let safe_y = _mm256_and_pd(fy, inside);
            let k = _mm_add_epi32(
                _mm_mullo_epi32(_mm256_cvttpd_epi32(safe_y), wide),
                _mm256_cvttpd_epi32(safe_x),
            );
            let d = _mm256_cvtps_pd(_mm_i32gather_ps::<4>(table, k));
            let term = _mm256_min_pd(_mm256_mul_pd(d, d), cap);
            cost = _mm256_add_pd(cost, _mm256_blendv_pd(cap, term, inside));
        }
        _mm256_storeu_pd(out.as_mut_ptr().add(i), cost);
    }
    n
}
