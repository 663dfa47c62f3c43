use std::path::PathBuf;

/// Bad input to a scenario run. Every variant names the file and, where there is one, the field.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error("{file}: cannot read file: {err}")]
    Io { file: PathBuf, err: std::io::Error },
    /// An output that could not be written (the final path, never a temporary name).
    #[error("{file}: cannot write file: {err}")]
    Write { file: PathBuf, err: std::io::Error },
    #[error("{file}: malformed TOML: {msg}")]
    Parse { file: PathBuf, msg: String },
    #[error("{file}: {field}: {msg}")]
    Field {
        file: PathBuf,
        field: String,
        msg: String,
    },
    /// A localizer failed during a run (a process localizer that died, hung or answered
    /// garbage).
    #[error("localizer {name:?} failed on the {reading} reading at t = {t:.3} s: {msg}")]
    Localizer {
        name: String,
        reading: String,
        t: f64,
        msg: String,
        /// What each localizer kept up to the failure (name, text: a process localizer's
        /// stderr), for `--out` to write as `log_<name>.txt`.
        logs: Vec<(String, String)>,
    },
    #[error(transparent)]
    World(#[from] atrium_worlds::WorldError),
    #[error(transparent)]
    Robot(#[from] atrium_robots::RobotError),
}

impl From<atrium_formats::FormatError> for ScenarioError {
    fn from(e: atrium_formats::FormatError) -> Self {
        use atrium_formats::FormatError as F;
        match e {
            F::Io { file, err } => ScenarioError::Io { file, err },
            F::Write { file, err } => ScenarioError::Write { file, err },
            F::Field { file, field, msg } => ScenarioError::Field { file, field, msg },
        }
    }
}

impl ScenarioError {
    pub fn field(file: &std::path::Path, field: impl Into<String>, msg: impl Into<String>) -> Self {
        ScenarioError::Field {
            file: file.to_path_buf(),
            field: field.into(),
            msg: msg.into(),
        }
    }
}
