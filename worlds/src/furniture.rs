//! Furniture: boxes standing on the floor (desks, cabinets, shelves). They are solid for the
//! robot and visible to every sensor, but they are clutter, not building: the maps a
//! localizer is given ([`crate::World::vector_map`], [`crate::World::occupancy_grid`]) leave
//! them out, as a map of walls drawn from floor plans would; so do [`World::clearance`] and
//! [`World::is_free`] (use [`World::furniture_at`]). The simulator's spawn check does see them.
//!
//! ```toml
//! [[boxes]]
//! center = [3.0, 5.0]       # footprint centre, m
//! size = [1.6, 0.8, 0.75]   # length along the box's own x, depth, height (m)
//! yaw = 0.0                 # optional, rad counter-clockwise (default 0: axis-aligned)
//! material = "wood"
//! ```

use serde::{Deserialize, Serialize};

use crate::geometry::{wall_corners, wall_signed_distance, P2};

/// A box standing on the floor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FurnitureBox {
    pub center: [f64; 2],
    /// Extent along the box's x (after `yaw`), its y, and its height; metres.
    pub size: [f64; 3],
    #[serde(default)]
    pub yaw: f64,
    pub material: String,
}

impl FurnitureBox {
    /// The footprint as a wall centre line (a, b) of thickness `size[1]`: the same rectangle,
    /// so the wall geometry helpers apply.
    pub fn as_wall_line(&self) -> (P2, P2) {
        let (s, c) = self.yaw.sin_cos();
        let h = 0.5 * self.size[0];
        (
            [self.center[0] - h * c, self.center[1] - h * s],
            [self.center[0] + h * c, self.center[1] + h * s],
        )
    }

    /// The four footprint corners, counter-clockwise.
    pub fn corners(&self) -> [P2; 4] {
        let (a, b) = self.as_wall_line();
        wall_corners(a, b, self.size[1])
    }

    /// Signed distance from `p` to the footprint (negative inside).
    pub fn signed_distance(&self, p: P2) -> f64 {
        let (a, b) = self.as_wall_line();
        wall_signed_distance(p, a, b, self.size[1])
    }

    /// Checks the numbers; the error is (key, message).
    pub fn validate(&self, ceiling_height: f64) -> Result<(), (&'static str, String)> {
        crate::limits::check_coordinates(&self.center).map_err(|msg| ("center", msg))?;
        for (k, v) in self.size.iter().enumerate() {
            if !(v.is_finite() && *v > 0.0) {
                return Err(("size", format!("size[{k}] must be finite and > 0, got {v}")));
            }
            crate::limits::check_length(*v).map_err(|msg| ("size", format!("size[{k}] {msg}")))?;
        }
        if self.size[2] > ceiling_height {
            return Err((
                "size",
                format!(
                    "height {} m exceeds the ceiling ({ceiling_height} m)",
                    self.size[2]
                ),
            ));
        }
        if !self.yaw.is_finite() {
            return Err(("yaw", format!("must be a finite number, got {}", self.yaw)));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn footprint_of_a_turned_box() {
        let b = FurnitureBox {
            center: [1.0, 2.0],
            size: [2.0, 1.0, 0.7],
            yaw: std::f64::consts::FRAC_PI_2,
            material: "wood".into(),
        };
        // Turned 90°: 1 m wide in x, 2 m long in y.
        assert!((b.signed_distance([1.0, 2.0]) + 0.5).abs() < 1e-12);
        assert!((b.signed_distance([2.0, 2.0]) - 0.5).abs() < 1e-12);
        assert!((b.signed_distance([1.0, 3.5]) - 0.5).abs() < 1e-12);
        let c = b.corners();
        for p in c {
            assert!(b.signed_distance(p).abs() < 1e-12, "{c:?}");
        }
        assert!(b.validate(3.0).is_ok());
        let mut bad = b.clone();
        bad.size[2] = 3.5;
        assert_eq!(bad.validate(3.0).unwrap_err().0, "size");
        bad.size[2] = 0.0;
        assert!(bad.validate(3.0).unwrap_err().1.contains("size[2]"));
    }
}
