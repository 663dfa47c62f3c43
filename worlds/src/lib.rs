//! Indoor worlds: walls, pillars, materials and named regions, loaded from TOML and
//! validated; plus the maps a localizer may know (vector map of line segments, occupancy
//! grid), exported with or without glass.

pub mod error;
pub mod furniture;
pub mod generate;
pub mod geometry;
pub mod grid_world;
pub mod lighting;
pub mod limits;
pub mod loader;
pub mod map;
pub mod wifi;
pub mod world;

pub use error::{MapError, WorldError};
pub use furniture::FurnitureBox;
pub use generate::{
    load_world_or_generator, world_from_text, GeneratorFile, GeneratorParams, GeneratorRegistry,
};
pub use grid_world::{vector_map_from_grid, world_from_grid};
pub use limits::{MAX_COORDINATE_M, MAX_POLYGON_POINTS, MIN_SIZE_M};
pub use loader::CAMPUS_TOML;
pub use map::{Cell, GridSize, OccupancyGrid, Segment, VectorMap};
pub use wifi::{AccessPoint, WifiEnvironment};
pub use world::{LaserBehaviour, Material, Pillar, Region, RegionKind, Wall, World};
