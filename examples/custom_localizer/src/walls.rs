//! The mapped walls as segments, and the laser's view of them: the range a beam should read
//! and which wall face it hits.

use atrium_worlds::VectorMap;

/// One wall face: `a + s·e` for s in [0, 1], with unit normal `n`.
#[derive(Debug, Clone, Copy)]
struct Face {
    a: [f64; 2],
    e: [f64; 2],
    n: [f64; 2],
}

/// Where a beam meets the map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Distance from the beam's origin, m.
    pub range: f64,
    /// Unit normal of the face hit (either side).
    pub normal: [f64; 2],
}

/// The wall faces of a vector map (glass and furniture as the map has them).
#[derive(Debug, Clone)]
pub struct Walls {
    faces: Vec<Face>,
}

fn cross(u: [f64; 2], v: [f64; 2]) -> f64 {
    u[0] * v[1] - u[1] * v[0]
}

impl Walls {
    pub fn new(map: &VectorMap) -> Self {
        let faces = map
            .segments
            .iter()
            .filter_map(|s| {
                let e = [s.b[0] - s.a[0], s.b[1] - s.a[1]];
                let len = e[0].hypot(e[1]);
                (len > 1e-9).then(|| Face {
                    a: s.a,
                    e,
                    n: [-e[1] / len, e[0] / len],
                })
            })
            .collect();
        Self { faces }
    }

    /// The nearest face along the ray from `p` at heading `phi`, if one lies within `max`.
    pub fn cast(&self, p: [f64; 2], phi: f64, max: f64) -> Option<Hit> {
        let u = [phi.cos(), phi.sin()];
        let mut best: Option<Hit> = None;
        for f in &self.faces {
            let denom = cross(u, f.e);
            if denom.abs() < 1e-12 {
                continue; // parallel
            }
            let ap = [f.a[0] - p[0], f.a[1] - p[1]];
            let t = cross(ap, f.e) / denom;
            let s = cross(ap, u) / denom;
            if t > 0.0 && t <= max && (0.0..=1.0).contains(&s) && best.is_none_or(|b| t < b.range) {
                best = Some(Hit {
                    range: t,
                    normal: f.n,
                });
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use atrium_worlds::Segment;

    #[test]
    fn a_beam_hits_the_nearest_face() {
        let map = VectorMap {
            segments: vec![
                Segment {
                    a: [2.0, -1.0],
                    b: [2.0, 1.0],
                },
                Segment {
                    a: [5.0, -1.0],
                    b: [5.0, 1.0],
                },
            ],
        };
        let walls = Walls::new(&map);
        let hit = walls.cast([0.0, 0.0], 0.0, 8.0).unwrap();
        assert!((hit.range - 2.0).abs() < 1e-12 && hit.normal[0].abs() == 1.0);
        assert!(
            (walls.cast([0.0, 0.0], 0.25, 8.0).unwrap().range - 2.0 / 0.25f64.cos()).abs() < 1e-12
        );
        assert_eq!(walls.cast([0.0, 0.0], std::f64::consts::PI, 8.0), None);
        assert_eq!(walls.cast([0.0, 0.0], 0.0, 1.5), None);
    }
}
