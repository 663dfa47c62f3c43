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
        "occupancy grid of {width} x {height} cells exceeds the limit of {limit} cells; \
         use a coarser resolution"
    )]
    TooLarge {
        width: usize,
        height: usize,
        limit: usize,
    },
    #[error("the world has no walls or pillars to map")]
    Empty,
    #[error("vector map line {line}: {msg}")]
    Text { line: usize, msg: String },
}
