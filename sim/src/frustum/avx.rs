//! The caster's per-ray work eight pixels at a time with AVX: turning a row's camera-frame
//! directions into the world, and for a cuboid, turning the rays into its frame, its slab test
//! (`cast_cuboid`) and the pixels' search updates (`RowSearch::wants` and `offer`). Each lane
//! performs the scalar code's operations in its order and without fused multiply-adds —
//! glam's `Quat * Vec3` (its SSE2 path: the vector part's dot products summed x, y then z, the
//! cross product as `a.zxy * b − a * b.zxy` rotated back) and parry's slab test as
//! `cast_cuboid` writes it — so every lane is the scalar result bit for bit (the tests compare
//! them on random and degenerate rays and on searches part-way through).

use super::search::{self, Columns, CuboidGroup, CuboidLanes, RowSearch, LANES, TIE};
use rapier3d::prelude::{Rotation, Vector};
use std::arch::x86_64::*;

/// Whether this processor runs the kernels below.
pub(super) fn available() -> bool {
    std::arch::is_x86_feature_detected!("avx")
}

/// glam's `q * v` on eight vectors at once.
#[inline]
#[target_feature(enable = "avx")]
fn rotate(q: Rotation, v: [__m256; 3]) -> [__m256; 3] {
    let two = _mm256_set1_ps(2.0);
    let (bx, by, bz, w) = (
        _mm256_set1_ps(q.x),
        _mm256_set1_ps(q.y),
        _mm256_set1_ps(q.z),
        _mm256_set1_ps(q.w),
    );
    let b2 = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(bx, bx), _mm256_mul_ps(by, by)),
        _mm256_mul_ps(bz, bz),
    );
    let ww_b2 = _mm256_sub_ps(_mm256_mul_ps(w, w), b2);
    let [vx, vy, vz] = v;
    let vb = _mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(vx, bx), _mm256_mul_ps(vy, by)),
        _mm256_mul_ps(vz, bz),
    );
    let vb2 = _mm256_mul_ps(vb, two);
    let w2 = _mm256_mul_ps(w, two);
    let cross = [
        _mm256_sub_ps(_mm256_mul_ps(by, vz), _mm256_mul_ps(vy, bz)),
        _mm256_sub_ps(_mm256_mul_ps(bz, vx), _mm256_mul_ps(vz, bx)),
        _mm256_sub_ps(_mm256_mul_ps(bx, vy), _mm256_mul_ps(vx, by)),
    ];
    let b = [bx, by, bz];
    std::array::from_fn(|i| {
        _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(v[i], ww_b2), _mm256_mul_ps(b[i], vb2)),
            _mm256_mul_ps(cross[i], w2),
        )
    })
}

/// `out[u] = q * dirs[u]` for every pixel of a row (the columns are padded to whole groups).
///
/// # Safety
/// The processor has AVX.
#[target_feature(enable = "avx")]
pub(super) unsafe fn rotate_row(q: Rotation, dirs: &[Vector], out: &mut Columns) {
    let mut gather = [[0f32; LANES]; 3];
    for (g, chunk) in dirs.chunks(LANES).enumerate() {
        for (j, d) in chunk.iter().enumerate() {
            gather[0][j] = d.x;
            gather[1][j] = d.y;
            gather[2][j] = d.z;
        }
        let v = gather.map(|c| unsafe { _mm256_loadu_ps(c.as_ptr()) });
        let r = rotate(q, v);
        let at = g * LANES;
        for (col, r) in [&mut out.x, &mut out.y, &mut out.z].into_iter().zip(r) {
            // The columns hold a whole group past the row's end.
            unsafe { _mm256_storeu_ps(col[at..at + LANES].as_mut_ptr(), r) };
        }
    }
}

/// [`RowSearch::cuboid_scalar`] eight lanes at a time: the group's cuboid offered to its
/// pixels in `search`, whose wants, slab tests and offers are the scalar code's lane by lane.
/// Returns the lanes parry must cast (their rays in `out.dir`).
///
/// # Safety
/// The processor has AVX, and the columns hold `u + LANES` values.
#[target_feature(enable = "avx")]
pub(super) unsafe fn cuboid_lanes(
    g: &CuboidGroup,
    search: &mut RowSearch,
    out: &mut CuboidLanes,
) -> u32 {
    let CuboidGroup {
        near,
        origin,
        inv_rotation,
        half,
        k,
        world,
        u,
        n,
        max_toi,
    } = *g;
    let ld = |c: &Vec<f32>| unsafe { _mm256_loadu_ps(c[u..u + LANES].as_ptr()) };
    let ld_bits = |c: &Vec<u32>| unsafe {
        _mm256_castsi256_ps(_mm256_loadu_si256(c[u..u + LANES].as_ptr().cast()))
    };
    let iota = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
    let in_range = _mm256_cmp_ps::<_CMP_LT_OQ>(iota, _mm256_set1_ps(n as f32));
    // `RowSearch::wants`, lane by lane.
    let best = ld(&search.toi);
    let threshold = _mm256_mul_ps(best, _mm256_set1_ps(1.0 + 2.0 * TIE));
    let done = ld_bits(&search.done);
    let stop = _mm256_andnot_ps(
        done,
        _mm256_and_ps(
            in_range,
            _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_set1_ps(near), threshold),
        ),
    );
    let done = _mm256_or_ps(done, stop);
    unsafe {
        _mm256_storeu_si256(
            search.done[u..u + LANES].as_mut_ptr().cast(),
            _mm256_castps_si256(done),
        )
    };
    let active = _mm256_andnot_ps(done, in_range);
    if _mm256_movemask_ps(active) == 0 {
        return 0;
    }
    let d = rotate(inv_rotation, [ld(&world.x), ld(&world.y), ld(&world.z)]);
    for (col, d) in out.dir.iter_mut().zip(d) {
        unsafe { _mm256_storeu_ps(col.as_mut_ptr(), d) };
    }
    let (o, h) = (origin.to_array(), half.to_array());
    let zero = _mm256_setzero_ps();
    let one = _mm256_set1_ps(1.0);
    let inf = _mm256_set1_ps(f32::INFINITY);
    let abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
    let truth = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
    let mut tmax = _mm256_set1_ps(f32::MAX);
    let mut tmin = _mm256_set1_ps(-f32::MAX);
    let (mut near_side, mut far_side) = (zero, zero);
    let (mut near_diag, mut far_diag) = (zero, zero);
    // Lanes whose answer is settled (`cast_cuboid` returned), and of those the ones it
    // returned None (ask parry) for; the rest of the settled lanes missed.
    let mut settled = zero;
    let mut ask = zero;
    for i in 0..3 {
        let di = d[i];
        let denom = _mm256_div_ps(one, di);
        let bad = _mm256_or_ps(
            _mm256_or_ps(
                _mm256_cmp_ps::<_CMP_EQ_OQ>(di, zero),
                _mm256_cmp_ps::<_CMP_UNORD_Q>(di, di),
            ),
            // Not finite: |denom| < ∞ fails (NaN too).
            _mm256_xor_ps(
                _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_and_ps(denom, abs_mask), inf),
                truth,
            ),
        );
        ask = _mm256_or_ps(ask, _mm256_andnot_ps(settled, bad));
        settled = _mm256_or_ps(settled, bad);
        let a = _mm256_mul_ps(_mm256_set1_ps(-h[i] - o[i]), denom);
        let b = _mm256_mul_ps(_mm256_set1_ps(h[i] - o[i]), denom);
        let flip = _mm256_cmp_ps::<_CMP_GT_OQ>(a, b);
        let near = _mm256_blendv_ps(a, b, flip);
        let far = _mm256_blendv_ps(b, a, flip);
        let side = _mm256_set1_ps(i as f32 + 1.0);
        let neg_side = _mm256_set1_ps(-(i as f32 + 1.0));
        let near_gt = _mm256_cmp_ps::<_CMP_GT_OQ>(near, tmin);
        let near_eq = _mm256_cmp_ps::<_CMP_EQ_OQ>(near, tmin);
        tmin = _mm256_blendv_ps(tmin, near, near_gt);
        near_side = _mm256_blendv_ps(near_side, _mm256_blendv_ps(side, neg_side, flip), near_gt);
        near_diag = _mm256_andnot_ps(near_gt, _mm256_or_ps(near_diag, near_eq));
        let far_lt = _mm256_cmp_ps::<_CMP_LT_OQ>(far, tmax);
        let far_eq = _mm256_cmp_ps::<_CMP_EQ_OQ>(far, tmax);
        tmax = _mm256_blendv_ps(tmax, far, far_lt);
        far_side = _mm256_blendv_ps(far_side, _mm256_blendv_ps(neg_side, side, flip), far_lt);
        far_diag = _mm256_andnot_ps(far_lt, _mm256_or_ps(far_diag, far_eq));
        let miss = _mm256_or_ps(
            _mm256_cmp_ps::<_CMP_LT_OQ>(tmax, zero),
            _mm256_cmp_ps::<_CMP_GT_OQ>(tmin, tmax),
        );
        settled = _mm256_or_ps(settled, miss);
    }
    let degenerate = _mm256_or_ps(
        _mm256_or_ps(near_diag, far_diag),
        _mm256_or_ps(
            _mm256_cmp_ps::<_CMP_EQ_OQ>(near_side, zero),
            _mm256_cmp_ps::<_CMP_EQ_OQ>(far_side, zero),
        ),
    );
    ask = _mm256_or_ps(ask, _mm256_andnot_ps(settled, degenerate));
    settled = _mm256_or_ps(settled, degenerate);
    let open = _mm256_xor_ps(settled, truth);
    let inside = _mm256_and_ps(open, _mm256_cmp_ps::<_CMP_LT_OQ>(tmin, zero));
    let enters = _mm256_andnot_ps(
        inside,
        _mm256_and_ps(
            open,
            _mm256_cmp_ps::<_CMP_LE_OQ>(tmin, _mm256_set1_ps(max_toi)),
        ),
    );
    // Codes as in `CuboidLanes`: MISS 0, INSIDE 1, ENTERS 2, ASK 3.
    let code = _mm256_or_ps(
        _mm256_and_ps(ask, _mm256_set1_ps(search::ASK)),
        _mm256_or_ps(
            _mm256_and_ps(inside, _mm256_set1_ps(search::INSIDE)),
            _mm256_and_ps(enters, _mm256_set1_ps(search::ENTERS)),
        ),
    );
    let side = _mm256_blendv_ps(near_side, far_side, inside);
    unsafe {
        _mm256_storeu_ps(out.code.as_mut_ptr(), code);
        _mm256_storeu_ps(out.toi.as_mut_ptr(), tmin);
        _mm256_storeu_ps(out.side.as_mut_ptr(), side);
    }
    // `RowSearch::offer` of the lanes with a hit, lane by lane: a nearer hit replaces the
    // nearest, which becomes a candidate for the nearest other; a farther one is one itself.
    let hit = _mm256_and_ps(active, _mm256_or_ps(inside, enters));
    let hit_toi = _mm256_blendv_ps(tmin, zero, inside);
    let nearer = _mm256_and_ps(hit, _mm256_cmp_ps::<_CMP_LT_OQ>(hit_toi, best));
    let second = ld(&search.second);
    let other = _mm256_blendv_ps(hit_toi, best, nearer);
    let second = _mm256_blendv_ps(second, _mm256_min_ps(second, other), hit);
    let store =
        |c: &mut Vec<f32>, x: __m256| unsafe { _mm256_storeu_ps(c[u..u + LANES].as_mut_ptr(), x) };
    store(&mut search.second, second);
    store(&mut search.toi, _mm256_blendv_ps(best, hit_toi, nearer));
    let was = ld(&search.code);
    store(&mut search.code, _mm256_blendv_ps(was, code, nearer));
    let was = ld(&search.side);
    store(&mut search.side, _mm256_blendv_ps(was, side, nearer));
    let was = ld_bits(&search.cand);
    let cand = _mm256_castsi256_ps(_mm256_set1_epi32(k as i32));
    unsafe {
        _mm256_storeu_si256(
            search.cand[u..u + LANES].as_mut_ptr().cast(),
            _mm256_castps_si256(_mm256_blendv_ps(was, cand, nearer)),
        )
    };
    _mm256_movemask_ps(_mm256_and_ps(active, ask)) as u32
}

#[cfg(test)]
mod tests {
    use super::search::CuboidHit;
    use super::search::{Found, ENTERS, MISS};
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn columns(dirs: &[Vector]) -> Columns {
        let mut c = Columns::default();
        c.resize(dirs.len() + LANES);
        for (u, d) in dirs.iter().enumerate() {
            (c.x[u], c.y[u], c.z[u]) = (d.x, d.y, d.z);
        }
        c
    }

    fn random_rotation(rng: &mut ChaCha8Rng) -> Rotation {
        (Rotation::from_rotation_z(rng.random_range(-3.2..3.2))
            * Rotation::from_rotation_y(rng.random_range(-1.6..1.6))
            * Rotation::from_rotation_x(rng.random_range(-3.2..3.2)))
        .normalize()
    }

    /// Rays from random, axis-aligned and zero directions (every branch of the slab test:
    /// misses, hits from inside and outside, ties at edges and corners, parry's cases).
    fn random_dirs(rng: &mut ChaCha8Rng, n: usize) -> Vec<Vector> {
        (0..n)
            .map(|k| {
                let mut d = Vector::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                );
                match k % 11 {
                    0 => d.x = 0.0,
                    1 => d = Vector::new(1.0, 1.0, 1.0),
                    2 => d = Vector::new(-0.0, 0.0, 1.0),
                    3 => d.z = 1e-40,
                    4 => d.y = f32::NAN,
                    _ => {}
                }
                d
            })
            .collect()
    }

    #[test]
    fn avx_kernels_are_the_scalar_code_bit_for_bit() {
        if !available() {
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (mut codes, mut total) = ([0usize; 4], 0);
        for k in 0..3000 {
            let q = if k % 5 == 0 {
                Rotation::IDENTITY
            } else {
                random_rotation(&mut rng)
            };
            let dirs = random_dirs(&mut rng, 2 * LANES + 3);
            let mut simd = Columns::default();
            simd.resize(dirs.len().div_ceil(LANES) * LANES + LANES);
            // SAFETY: checked above; the columns hold a group past the row.
            unsafe { rotate_row(q, &dirs, &mut simd) };
            for (u, d) in dirs.iter().enumerate() {
                let want = (q * *d).to_array().map(f32::to_bits);
                assert_eq!(
                    simd.get(u).to_array().map(f32::to_bits),
                    want,
                    "{q:?} {d:?}"
                );
            }
            let world = columns(&dirs);
            let half = Vector::new(
                rng.random_range(0.01..3.0),
                rng.random_range(0.01..3.0),
                rng.random_range(0.01..3.0),
            );
            // Half the origins on a face, edge or corner's extension (tied slabs).
            let mut origin = Vector::new(
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
            );
            if k % 2 == 0 {
                origin.x = half.x;
            }
            let inv = random_rotation(&mut rng);
            let max_toi = rng.random_range(0.5..8.0);
            let mut near = rng.random_range(-0.5..4.0);
            for u in [0, LANES, LANES + 3] {
                // A search part-way through: some pixels done, some with a hit already, some
                // of those at exactly the time this cuboid gives (ties).
                let mut probe = CuboidLanes::default();
                let all = CuboidGroup {
                    near: f32::NEG_INFINITY,
                    origin,
                    inv_rotation: inv,
                    half,
                    k: 0,
                    world: &world,
                    u,
                    n: LANES,
                    max_toi,
                };
                probe.cast_scalar(&all, u32::MAX);
                let mut search = RowSearch::default();
                search.reset(world.x.len());
                for p in 0..world.x.len() {
                    let toi = match p.checked_sub(u) {
                        Some(j) if j < LANES && probe.code[j] == ENTERS && k % 3 == 0 => {
                            probe.toi[j]
                        }
                        _ => rng.random_range(0.0..6.0),
                    };
                    match rng.random_range(0..4) {
                        0 => search.done[p] = u32::MAX,
                        1 | 2 => search.offer(
                            p,
                            7,
                            Some(Found::Cuboid(CuboidHit::Enters { toi, side: -2 })),
                        ),
                        _ => {}
                    }
                }
                // Now and then a candidate exactly at a pixel's threshold.
                if k % 4 == 1 && search.toi[u].is_finite() {
                    near = search.toi[u] * (1.0 + 2.0 * TIE);
                }
                let n = rng.random_range(1..=LANES);
                let (mut a, mut b) = (search.clone(), search);
                let (mut la, mut lb) = (CuboidLanes::default(), CuboidLanes::default());
                // Lanes the scalar twin casts get a code; the others keep this one.
                lb.code = [-1.0; LANES];
                // SAFETY: as above.
                let group = CuboidGroup {
                    near,
                    origin,
                    inv_rotation: inv,
                    half,
                    k: 3,
                    world: &world,
                    u,
                    n,
                    max_toi,
                };
                let ask_a = unsafe { cuboid_lanes(&group, &mut a, &mut la) };
                let ask_b = b.cuboid_scalar(&group, &mut lb);
                let what = format!("{half:?} {origin:?} {inv:?} {u} {n}");
                assert_eq!(ask_a, ask_b, "{what}");
                for j in (0..n).filter(|j| ask_b & (1 << j) != 0) {
                    let bits = |l: &CuboidLanes| l.dir.map(|c| c[j].to_bits());
                    assert_eq!(bits(&la), bits(&lb), "{what}");
                }
                let bits = |c: &[f32]| c.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&a.toi), bits(&b.toi), "{what}");
                assert_eq!(a.second, b.second, "{what}");
                assert_eq!(a.done, b.done, "{what}");
                assert_eq!(bits(&a.code), bits(&b.code), "{what}");
                for p in 0..a.code.len() {
                    if a.code[p] != MISS {
                        assert_eq!(a.cand[p], b.cand[p], "{what}");
                        assert_eq!(a.side[p], b.side[p], "{what}");
                    }
                }
                for j in (0..n).filter(|&j| lb.code[j] >= 0.0) {
                    codes[lb.code[j] as usize] += 1;
                    total += 1;
                }
            }
        }
        // Every answer occurs often enough to have been compared.
        assert!(
            codes.iter().all(|&c| c * 50 > total),
            "{codes:?} of {total}"
        );
    }
}
