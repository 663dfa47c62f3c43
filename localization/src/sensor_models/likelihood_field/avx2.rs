//! The field's lookup for four poses at a time with AVX2: the operations of
//! [`LikelihoodField::log_likelihood`](super::LikelihoodField::log_likelihood), lane by lane, in its order and without fused
//! multiply-adds, so that every value is the plain loop's bit for bit. Only the work is
//! shared: four endpoints transformed, tested and interpolated by one instruction each, and
//! the four corners of each read by one gather.

use crate::filter::particles::Poses;
use crate::sensor_models::simd::{within, GridTable};

/// `out[i]` set to (with `ADD`, increased by) the log-likelihood of the beam endpoint
/// (`u`, `v`) seen from pose i, for the poses in whole groups of four; returns how many it
/// did (the caller does the rest). Groups with an endpoint off the table's interior go
/// through the scalar lookup, lane by lane.
///
/// # Safety
/// The processor has AVX2, every cell index of `field` fits in i32 (`scalar` is the
/// field's scalar lookup, for lanes off the table's interior), and each column of
/// `poses` holds at least `out.len()` values.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn beam_row<const ADD: bool>(
    field: &GridTable<'_>,
    scalar: impl Fn(f64, f64) -> f64,
    (u, v): (f64, f64),
    poses: Poses<'_>,
    out: &mut [f64],
) -> usize {
    use std::arch::x86_64::*;
    let n = out.len() / 4 * 4;
    let w = field.width;
    let table = field.cells.as_ptr();
    let (bu, bv) = (_mm256_set1_pd(u), _mm256_set1_pd(v));
    let (ox, oy) = (
        _mm256_set1_pd(field.origin[0]),
        _mm256_set1_pd(field.origin[1]),
    );
    let inv = _mm256_set1_pd(field.inv_resolution);
    let half = _mm256_set1_pd(0.5);
    let umax = _mm256_set1_pd((field.width - 1) as f64);
    let vmax = _mm256_set1_pd((field.height - 1) as f64);
    let wide = _mm_set1_epi32(w as i32);
    for i in (0..n).step_by(4) {
        let x = _mm256_loadu_pd(poses.x.as_ptr().add(i));
        let y = _mm256_loadu_pd(poses.y.as_ptr().add(i));
        let s = _mm256_loadu_pd(poses.sin.as_ptr().add(i));
        let c = _mm256_loadu_pd(poses.cos.as_ptr().add(i));
        // x + c·u − s·v and y + s·u + c·v, left to right as the scalar code adds them.
        let ex = _mm256_sub_pd(_mm256_add_pd(x, _mm256_mul_pd(c, bu)), _mm256_mul_pd(s, bv));
        let ey = _mm256_add_pd(_mm256_add_pd(y, _mm256_mul_pd(s, bu)), _mm256_mul_pd(c, bv));
        let fu = _mm256_sub_pd(_mm256_mul_pd(_mm256_sub_pd(ex, ox), inv), half);
        let fv = _mm256_sub_pd(_mm256_mul_pd(_mm256_sub_pd(ey, oy), inv), half);
        let inside = within(fu, fv, umax, vmax);
        let l = if _mm256_movemask_pd(inside) == 0b1111 {
            // Truncation, as `as i32` converts the in-range, non-negative values.
            let ci = _mm256_cvttpd_epi32(fu);
            let cj = _mm256_cvttpd_epi32(fv);
            let tu = _mm256_sub_pd(fu, _mm256_cvtepi32_pd(ci));
            let tv = _mm256_sub_pd(fv, _mm256_cvtepi32_pd(cj));
            let k = _mm_add_epi32(_mm_mullo_epi32(cj, wide), ci);
            // Each lane's corners pair up along the row: (a, b) at k and (c, d) at k + w,
            // one 8-byte read each (faster here than gathering the sixteen values).
            let mut ks = [0i32; 4];
            _mm_storeu_si128(ks.as_mut_ptr().cast(), k);
            let pair = |k: i32| (table.add(k as usize) as *const i64).read_unaligned();
            let [k0, k1, k2, k3] = ks;
            let bottom_pairs =
                _mm256_castsi256_ps(_mm256_set_epi64x(pair(k3), pair(k2), pair(k1), pair(k0)));
            let top_pairs = _mm256_castsi256_ps(_mm256_set_epi64x(
                pair(k3 + w as i32),
                pair(k2 + w as i32),
                pair(k1 + w as i32),
                pair(k0 + w as i32),
            ));
            // [a0 b0 a1 b1 a2 b2 a3 b3] → [a0 a1 a2 a3 | b0 b1 b2 b3].
            let split = _mm256_set_epi32(7, 5, 3, 1, 6, 4, 2, 0);
            let ab = _mm256_permutevar8x32_ps(bottom_pairs, split);
            let cd = _mm256_permutevar8x32_ps(top_pairs, split);
            let a = _mm256_cvtps_pd(_mm256_castps256_ps128(ab));
            let b = _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(ab));
            let c = _mm256_cvtps_pd(_mm256_castps256_ps128(cd));
            let d = _mm256_cvtps_pd(_mm256_extractf128_ps::<1>(cd));
            let bottom = _mm256_add_pd(a, _mm256_mul_pd(_mm256_sub_pd(b, a), tu));
            let top = _mm256_add_pd(c, _mm256_mul_pd(_mm256_sub_pd(d, c), tu));
            _mm256_add_pd(bottom, _mm256_mul_pd(_mm256_sub_pd(top, bottom), tv))
        } else {
            let mut ex4 = [0.0; 4];
            let mut ey4 = [0.0; 4];
            _mm256_storeu_pd(ex4.as_mut_ptr(), ex);
            _mm256_storeu_pd(ey4.as_mut_ptr(), ey);
            let l4: [f64; 4] = std::array::from_fn(|k| scalar(ex4[k], ey4[k]));
            _mm256_loadu_pd(l4.as_ptr())
        };
        let o = out.as_mut_ptr().add(i);
        if ADD {
            _mm256_storeu_pd(o, _mm256_add_pd(_mm256_loadu_pd(o), l));
        } else {
            _mm256_storeu_pd(o, l);
        }
    }
    n
}
