use std::path::{Path, PathBuf};

/// Bad input in a file Atrium reads, or an output it could not write. Every variant names the
/// file and, where there is one, the field, topic, line or byte offset.
#[derive(Debug, thiserror::Error)]
pub enum FormatError {
    #[error("{file}: cannot read file: {err}")]
    Io { file: PathBuf, err: std::io::Error },
    /// An output that could not be written (the final path, never a temporary name).
    #[error("{file}: cannot write file: {err}")]
    Write { file: PathBuf, err: std::io::Error },
    #[error("{file}: {field}: {msg}")]
    Field {
        file: PathBuf,
        field: String,
        msg: String,
    },
}

impl FormatError {
    pub fn field(file: &Path, field: impl Into<String>, msg: impl Into<String>) -> Self {
        FormatError::Field {
            file: file.to_path_buf(),
            field: field.into(),
            msg: msg.into(),
        }
    }

    pub fn io(file: &Path, err: std::io::Error) -> Self {
        FormatError::Io {
            file: file.to_path_buf(),
            err,
        }
    }
}
