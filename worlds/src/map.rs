//! Maps a localizer may be given. They are exports of a [`crate::World`], never the
//! simulator's scene.

use serde::{Deserialize, Serialize};

/// A line segment in the floor plane, metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Segment {
    pub a: [f64; 2],
    pub b: [f64; 2],
}

/// The vector map: the outline of every wall face and pillar as line segments.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct VectorMap {
    pub segments: Vec<Segment>,
}

/// Occupancy of one grid cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Cell {
    Free,
    Occupied,
    Unknown,
}

/// A 2D occupancy grid. Cell (i, j) covers x ∈ [origin.x + i·res, origin.x + (i+1)·res),
/// y likewise with j; cells are stored row-major with j (y) as the row: `cells[j * width + i]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OccupancyGrid {
    pub origin: [f64; 2],
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    pub cells: Vec<Cell>,
}
