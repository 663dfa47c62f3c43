use std::path::PathBuf;

/// A world file that cannot be used; names the file, the field and what is wrong.
#[derive(Debug, thiserror::Error)]
pub enum WorldError {
    #[error("{file}: cannot read file: {err}")]
    Io { file: PathBuf, err: std::io::Error },
    #[error("{file}: malformed TOML: {msg}")]
    Parse { file: PathBuf, msg: String },
    #[error("{file}: {field}: {msg}")]
    Field {
        file: PathBuf,
        field: String,
        msg: String,
    },
}

/// A map export or import that cannot be done.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapError {
    #[error("occupancy grid resolution must be finite and > 0, got {0}")]
    Resolution(f64),
    #[error(
        "an occupancy grid of this world at {resolution} m would be {width} x {height} = \
         {cells} cells, over the limit of {limit} cells (MAX_GRID_CELLS); use a resolution \
         of at least {min_resolution} m"
    )]
    TooLarge {
        resolution: f64,
        /// Saturated at `usize::MAX` for absurd resolutions.
        width: usize,
        height: usize,
        cells: u128,
        limit: usize,
        /// The finest resolution (m, rounded up to 3 significant digits) that fits the limit.
        min_resolution: f64,
    },
    #[error(
        "cannot allocate an occupancy grid of {cells} cells ({cells} bytes): out of memory; \
         use a coarser resolution"
    )]
    OutOfMemory { cells: usize },
    #[error("the world's bounds are not finite ({lo:?} to {hi:?}); check it with World::validate")]
    NotFinite { lo: [f64; 2], hi: [f64; 2] },
    #[error("the world has no walls or pillars to map")]
    Empty,
    #[error("vector map line {line}: {msg}")]
    Text { line: usize, msg: String },
}
