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
