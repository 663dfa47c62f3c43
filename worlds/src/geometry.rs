//! Plane geometry on `[f64; 2]` points: the few primitives the world model, its validation and
//! its map exports need. All pure, allocation-free and panic-free.

/// A point or vector in the floor plane, metres.
pub type P2 = [f64; 2];

#[inline]
fn sub(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}

#[inline]
fn dot(a: P2, b: P2) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// z component of the 3D cross product: > 0 when `b` is counter-clockwise of `a`.
#[inline]
pub fn cross(a: P2, b: P2) -> f64 {
    a[0] * b[1] - a[1] * b[0]
}

/// Euclidean distance between two points.
#[inline]
pub fn distance(a: P2, b: P2) -> f64 {
    let d = sub(a, b);
    d[0].hypot(d[1])
}

/// The point of segment `a`–`b` nearest to `p` (`a` when the segment is degenerate).
pub fn closest_point_on_segment(p: P2, a: P2, b: P2) -> P2 {
    let ab = sub(b, a);
    let len2 = dot(ab, ab);
    if len2 == 0.0 {
        return a;
    }
    let t = (dot(sub(p, a), ab) / len2).clamp(0.0, 1.0);
    [a[0] + t * ab[0], a[1] + t * ab[1]]
}

/// Distance from `p` to the segment `a`–`b`.
pub fn point_segment_distance(p: P2, a: P2, b: P2) -> f64 {
    distance(p, closest_point_on_segment(p, a, b))
}

/// A common point of segments `a1`–`b1` and `a2`–`b2`, if they touch or cross. For collinear
/// overlapping segments the returned point is the overlap's end nearest `a1`.
pub fn segment_intersection(a1: P2, b1: P2, a2: P2, b2: P2) -> Option<P2> {
    let r = sub(b1, a1);
    let s = sub(b2, a2);
    let qp = sub(a2, a1);
    let denom = cross(r, s);
    // Relative tolerance so that the test does not depend on the coordinates' scale.
    let scale = (dot(r, r) * dot(s, s)).sqrt();
    if denom.abs() > 1e-12 * scale {
        let t = cross(qp, s) / denom;
        let u = cross(qp, r) / denom;
        if (-1e-12..=1.0 + 1e-12).contains(&t) && (-1e-12..=1.0 + 1e-12).contains(&u) {
            let t = t.clamp(0.0, 1.0);
            return Some([a1[0] + t * r[0], a1[1] + t * r[1]]);
        }
        return None;
    }
    // Parallel: they meet only if collinear, and then where their parameter ranges overlap.
    if cross(qp, r).abs() > 1e-12 * dot(r, r).max(dot(s, s)).max(1e-300) {
        return None;
    }
    let rr = dot(r, r);
    if rr == 0.0 {
        // First segment is a point: it is on the second one or not.
        return (point_segment_distance(a1, a2, b2) <= 1e-12 * dot(s, s).sqrt().max(1.0))
            .then_some(a1);
    }
    let t0 = dot(sub(a2, a1), r) / rr;
    let t1 = dot(sub(b2, a1), r) / rr;
    let (lo, hi) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    let start = lo.max(0.0);
    let end = hi.min(1.0);
    (start <= end).then(|| [a1[0] + start * r[0], a1[1] + start * r[1]])
}

/// Whether the two segments touch or cross.
pub fn segments_intersect(a1: P2, b1: P2, a2: P2, b2: P2) -> bool {
    segment_intersection(a1, b1, a2, b2).is_some()
}

/// Distance (metres) from `origin` along the ray direction `dir` (any non-zero length) to the
/// first point of segment `a`–`b`, or `None` if the ray misses it.
pub fn ray_segment_intersection(origin: P2, dir: P2, a: P2, b: P2) -> Option<f64> {
    let len = dir[0].hypot(dir[1]);
    if len == 0.0 || !len.is_finite() {
        return None;
    }
    let d = [dir[0] / len, dir[1] / len];
    let s = sub(b, a);
    let qp = sub(a, origin);
    let denom = cross(d, s);
    let seg_len = dot(s, s).sqrt();
    if denom.abs() > 1e-12 * seg_len {
        let t = cross(qp, s) / denom;
        let u = cross(qp, d) / denom;
        return (t >= 0.0 && (-1e-12..=1.0 + 1e-12).contains(&u)).then_some(t);
    }
    // Parallel: a hit only when the segment lies on the ray's line, at its nearer end.
    if cross(qp, d).abs() > 1e-12 * seg_len.max(1.0) {
        return None;
    }
    let ta = dot(sub(a, origin), d);
    let tb = dot(sub(b, origin), d);
    let (lo, hi) = if ta <= tb { (ta, tb) } else { (tb, ta) };
    if hi < 0.0 {
        None
    } else {
        Some(lo.max(0.0))
    }
}

/// Signed area of a polygon (vertices in order, not closed): positive when counter-clockwise.
pub fn polygon_area(poly: &[P2]) -> f64 {
    let n = poly.len();
    if n < 3 {
        return 0.0;
    }
    let mut twice = 0.0;
    for i in 0..n {
        twice += cross(poly[i], poly[(i + 1) % n]);
    }
    0.5 * twice
}

/// Whether `p` lies inside the polygon (even-odd rule). Points exactly on an edge may go
/// either way.
pub fn point_in_polygon(p: P2, poly: &[P2]) -> bool {
    let n = poly.len();
    if n < 3 {
        return false;
    }
    let mut inside = false;
    let mut j = n - 1;
    for i in 0..n {
        let (pi, pj) = (poly[i], poly[j]);
        if (pi[1] > p[1]) != (pj[1] > p[1]) {
            let x = pi[0] + (p[1] - pi[1]) * (pj[0] - pi[0]) / (pj[1] - pi[1]);
            if p[0] < x {
                inside = !inside;
            }
        }
        j = i;
    }
    inside
}

/// A pair of non-adjacent edges of the polygon that touch or cross, if any: the polygon is
/// simple when this is `None`. Edge `k` runs from vertex `k` to vertex `k + 1` (wrapping).
pub fn polygon_self_intersection(poly: &[P2]) -> Option<(usize, usize)> {
    let n = poly.len();
    for i in 0..n {
        for j in (i + 1)..n {
            let adjacent = j == i + 1 || (i == 0 && j == n - 1);
            if adjacent {
                continue;
            }
            if segments_intersect(poly[i], poly[(i + 1) % n], poly[j], poly[(j + 1) % n]) {
                return Some((i, j));
            }
        }
    }
    None
}

/// The four corners of a wall's footprint: the centre line `a`–`b` widened by `thickness`,
/// with square ends at `a` and `b`. Counter-clockwise, starting right of `a`.
pub fn wall_corners(a: P2, b: P2, thickness: f64) -> [P2; 4] {
    let d = sub(b, a);
    let len = d[0].hypot(d[1]);
    let h = 0.5 * thickness;
    // A degenerate centre line has no direction; any normal gives the same (empty) rectangle.
    let n = if len > 0.0 {
        [-d[1] / len * h, d[0] / len * h]
    } else {
        [0.0, h]
    };
    [
        [a[0] - n[0], a[1] - n[1]],
        [b[0] - n[0], b[1] - n[1]],
        [b[0] + n[0], b[1] + n[1]],
        [a[0] + n[0], a[1] + n[1]],
    ]
}

/// Signed distance from `p` to a wall's footprint (see [`wall_corners`]): positive outside,
/// negative inside, zero on its boundary.
pub fn wall_signed_distance(p: P2, a: P2, b: P2, thickness: f64) -> f64 {
    let d = sub(b, a);
    let len = d[0].hypot(d[1]);
    let mid = [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
    let rel = sub(p, mid);
    let (u, v) = if len > 0.0 {
        let ux = [d[0] / len, d[1] / len];
        (dot(rel, ux), cross(ux, rel))
    } else {
        (rel[0], rel[1])
    };
    // Box signed distance in the wall's own frame.
    let qx = u.abs() - 0.5 * len;
    let qy = v.abs() - 0.5 * thickness;
    let outside = qx.max(0.0).hypot(qy.max(0.0));
    let inside = qx.max(qy).min(0.0);
    outside + inside
}

/// How deeply two convex polygons overlap: the smallest overlap of their projections over all
/// edge normals (separating axis theorem). `> 0` means their interiors intersect; `<= 0` means
/// they are disjoint or only touch.
pub fn convex_overlap(p: &[P2], q: &[P2]) -> f64 {
    let mut depth = f64::INFINITY;
    for poly in [p, q] {
        let n = poly.len();
        for i in 0..n {
            let e = sub(poly[(i + 1) % n], poly[i]);
            let len = e[0].hypot(e[1]);
            if len == 0.0 {
                continue;
            }
            let axis = [-e[1] / len, e[0] / len];
            let (pmin, pmax) = project(p, axis);
            let (qmin, qmax) = project(q, axis);
            depth = depth.min(pmax.min(qmax) - pmin.max(qmin));
        }
    }
    depth
}

fn project(poly: &[P2], axis: P2) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for &v in poly {
        let s = dot(v, axis);
        lo = lo.min(s);
        hi = hi.max(s);
    }
    (lo, hi)
}

/// Distance from `p` to the axis-aligned box `[min, max]` (zero inside it).
pub fn point_box_distance(p: P2, min: P2, max: P2) -> f64 {
    let dx = (min[0] - p[0]).max(0.0).max(p[0] - max[0]);
    let dy = (min[1] - p[1]).max(0.0).max(p[1] - max[1]);
    dx.hypot(dy)
}

/// The vertices of a regular `n`-gon inscribed in the circle (`center`, `radius`), the first on
/// the +x side, counter-clockwise.
pub fn regular_polygon(center: P2, radius: f64, n: usize) -> impl Iterator<Item = P2> {
    (0..n).map(move |k| {
        let a = std::f64::consts::TAU * k as f64 / n as f64;
        [center[0] + radius * a.cos(), center[1] + radius * a.sin()]
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn point_segment_distance_interior_end_and_degenerate() {
        // Perpendicular foot inside the segment.
        assert!(close(
            point_segment_distance([1.0, 2.0], [0.0, 0.0], [4.0, 0.0]),
            2.0
        ));
        // Beyond `b`: distance to `b` is the 3-4-5 hypotenuse.
        assert!(close(
            point_segment_distance([7.0, 4.0], [0.0, 0.0], [4.0, 0.0]),
            5.0
        ));
        // Before `a` on a diagonal segment.
        assert!(close(
            point_segment_distance([-1.0, -1.0], [0.0, 0.0], [1.0, 1.0]),
            2f64.sqrt()
        ));
        assert!(close(
            point_segment_distance([3.0, 4.0], [0.0, 0.0], [0.0, 0.0]),
            5.0
        ));
    }

    #[test]
    fn segment_intersection_cases() {
        let p = segment_intersection([0.0, 0.0], [2.0, 2.0], [0.0, 2.0], [2.0, 0.0]).unwrap();
        assert!(close(p[0], 1.0) && close(p[1], 1.0));
        // T-touch at an endpoint counts.
        let p = segment_intersection([0.0, 0.0], [2.0, 0.0], [1.0, 0.0], [1.0, 5.0]).unwrap();
        assert!(close(p[0], 1.0) && close(p[1], 0.0));
        // Lines cross outside the second segment.
        assert!(segment_intersection([0.0, 0.0], [2.0, 0.0], [1.0, 0.5], [1.0, 5.0]).is_none());
        // Parallel, not collinear.
        assert!(!segments_intersect(
            [0.0, 0.0],
            [2.0, 0.0],
            [0.0, 1.0],
            [2.0, 1.0]
        ));
        // Collinear overlapping: the overlap starts at x = 1.
        let p = segment_intersection([0.0, 0.0], [3.0, 0.0], [5.0, 0.0], [1.0, 0.0]).unwrap();
        assert!(close(p[0], 1.0) && close(p[1], 0.0));
        // Collinear disjoint.
        assert!(!segments_intersect(
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [3.0, 0.0]
        ));
    }

    #[test]
    fn ray_segment_distances() {
        // Straight ahead to a wall at x = 5.
        let t = ray_segment_intersection([0.0, 0.0], [1.0, 0.0], [5.0, -1.0], [5.0, 1.0]);
        assert!(close(t.unwrap(), 5.0));
        // Direction length does not scale the answer; 45° ray to x = 3 travels 3·√2.
        let t = ray_segment_intersection([0.0, 0.0], [2.0, 2.0], [3.0, -10.0], [3.0, 10.0]);
        assert!(close(t.unwrap(), 3.0 * 2f64.sqrt()));
        // Behind the origin.
        assert!(
            ray_segment_intersection([0.0, 0.0], [1.0, 0.0], [-5.0, -1.0], [-5.0, 1.0]).is_none()
        );
        // Passes beside the segment's end.
        assert!(ray_segment_intersection([0.0, 0.0], [1.0, 0.0], [5.0, 0.5], [5.0, 1.0]).is_none());
        // Collinear ahead: the nearer end.
        let t = ray_segment_intersection([0.0, 0.0], [1.0, 0.0], [7.0, 0.0], [4.0, 0.0]);
        assert!(close(t.unwrap(), 4.0));
        assert!(
            ray_segment_intersection([0.0, 0.0], [0.0, 0.0], [1.0, -1.0], [1.0, 1.0]).is_none()
        );
    }

    #[test]
    fn polygon_area_and_containment() {
        let square = [[0.0, 0.0], [2.0, 0.0], [2.0, 3.0], [0.0, 3.0]];
        assert!(close(polygon_area(&square), 6.0));
        let mut cw = square;
        cw.reverse();
        assert!(close(polygon_area(&cw), -6.0));
        assert_eq!(polygon_area(&square[..2]), 0.0);
        // L-shape: the notch (1.5, 2.5) is outside.
        let l = [
            [0.0, 0.0],
            [2.0, 0.0],
            [2.0, 1.0],
            [1.0, 1.0],
            [1.0, 3.0],
            [0.0, 3.0],
        ];
        assert!(close(polygon_area(&l), 4.0));
        assert!(point_in_polygon([0.5, 2.5], &l));
        assert!(point_in_polygon([1.5, 0.5], &l));
        assert!(!point_in_polygon([1.5, 2.5], &l));
        assert!(!point_in_polygon([-0.1, 0.5], &l));
        assert_eq!(polygon_self_intersection(&l), None);
        let bowtie = [[0.0, 0.0], [2.0, 2.0], [2.0, 0.0], [0.0, 2.0]];
        assert_eq!(polygon_self_intersection(&bowtie), Some((0, 2)));
    }

    #[test]
    fn wall_corners_and_signed_distance() {
        let c = wall_corners([0.0, 0.0], [4.0, 0.0], 0.2);
        assert_eq!(c, [[0.0, -0.1], [4.0, -0.1], [4.0, 0.1], [0.0, 0.1]]);
        assert!(polygon_area(&c) > 0.0);
        // Vertical wall from (1, 0) to (1, 2), 0.5 thick: x ∈ [0.75, 1.25].
        let c = wall_corners([1.0, 0.0], [1.0, 2.0], 0.5);
        let expect = [[1.25, 0.0], [1.25, 2.0], [0.75, 2.0], [0.75, 0.0]];
        for (got, want) in c.iter().zip(expect) {
            assert!(close(got[0], want[0]) && close(got[1], want[1]));
        }
        let (a, b, t) = ([0.0, 0.0], [4.0, 0.0], 0.2);
        assert!(close(wall_signed_distance([2.0, 1.0], a, b, t), 0.9));
        assert!(close(wall_signed_distance([2.0, 0.0], a, b, t), -0.1));
        assert!(close(wall_signed_distance([3.95, 0.0], a, b, t), -0.05));
        // Past the square end, diagonally off the corner (4, 0.1).
        assert!(close(wall_signed_distance([7.0, 4.1], a, b, t), 5.0));
        assert!(close(wall_signed_distance([-1.0, 0.05], a, b, t), 1.0));
    }

    #[test]
    fn convex_overlap_and_box_distance() {
        let a = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let b = [[0.5, 0.25], [2.0, 0.25], [2.0, 2.0], [0.5, 2.0]];
        assert!(close(convex_overlap(&a, &b), 0.5));
        let touching = [[1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0]];
        assert!(convex_overlap(&a, &touching) <= 0.0);
        // A diamond whose bounding box overlaps the square but whose body does not.
        let diamond = [[1.6, 1.0], [2.0, 1.4], [1.6, 1.8], [1.2, 1.4]];
        assert!(convex_overlap(&a, &diamond) < 0.0);
        assert!(close(
            point_box_distance([4.0, 5.0], [0.0, 0.0], [1.0, 1.0]),
            5.0
        ));
        assert_eq!(point_box_distance([0.5, 0.5], [0.0, 0.0], [1.0, 1.0]), 0.0);
    }

    #[test]
    fn regular_polygon_vertices_on_circle() {
        let v: Vec<P2> = regular_polygon([1.0, 2.0], 0.5, 16).collect();
        assert_eq!(v.len(), 16);
        for p in &v {
            assert!(close(distance(*p, [1.0, 2.0]), 0.5));
        }
        assert!(close(v[0][0], 1.5) && close(v[0][1], 2.0));
        assert!(close(v[4][0], 1.0) && close(v[4][1], 2.5));
    }
}
