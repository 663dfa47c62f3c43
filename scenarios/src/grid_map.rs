//! Maps from reality: a scenario's `map = "X.yaml"` (a ROS map_server map) in place of a
//! world. The localizers get the map as it is (its grid for likelihood fields and free space,
//! line segments traced along its occupied cells for CGR), and the simulation gets a world
//! whose walls are the occupied cells merged into rectangles. Unknown cells are neither solid
//! nor free space: a simulated beam passes through them and a global belief is not spread
//! over them.

use crate::error::ScenarioError;
use atrium_worlds::{OccupancyGrid, VectorMap, World};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Height of the walls a map's occupied cells become in the simulation, m: above any
/// planar laser's scan plane, below a typical ceiling.
pub const MAP_WALL_HEIGHT: f64 = 2.5;

/// A map read from a ROS map file, with the line map traced from it.
#[derive(Debug, Clone)]
pub struct GridMap {
    /// The YAML file.
    pub file: PathBuf,
    /// The image file it names.
    pub image: PathBuf,
    pub grid: Arc<OccupancyGrid>,
    /// Faces of the occupied cells as line segments, simplified to one cell.
    pub vector: Arc<VectorMap>,
}

impl GridMap {
    /// Reads the map `yaml` (named in the scenario `file`'s field `map`) and the world the
    /// simulation drives in.
    pub fn load(file: &Path, yaml: &Path) -> Result<(GridMap, World), ScenarioError> {
        if !yaml.is_file() {
            return Err(ScenarioError::field(
                file,
                "map",
                format!("{} does not exist", yaml.display()),
            ));
        }
        let grid = atrium_formats::ros_map::read_map(yaml)?;
        let text = std::fs::read_to_string(yaml).map_err(|err| ScenarioError::Io {
            file: yaml.to_path_buf(),
            err,
        })?;
        let meta = atrium_formats::ros_map::parse_yaml(&text, yaml)?;
        let image = atrium_formats::ros_map::image_path(yaml, &meta.image);
        if !grid.cells.contains(&atrium_worlds::Cell::Occupied) {
            return Err(ScenarioError::field(
                yaml,
                "image",
                "the map has no occupied cell: there is nothing to localize against",
            ));
        }
        let name = yaml
            .file_stem()
            .map_or("map".to_string(), |s| s.to_string_lossy().into_owned());
        let world = atrium_worlds::grid_world::world_from_grid(&grid, &name, MAP_WALL_HEIGHT);
        let vector = atrium_worlds::grid_world::vector_map_from_grid(&grid, grid.resolution);
        Ok((
            GridMap {
                file: yaml.to_path_buf(),
                image,
                grid: Arc::new(grid),
                vector: Arc::new(vector),
            },
            world,
        ))
    }
}
