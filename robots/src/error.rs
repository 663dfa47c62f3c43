use std::path::PathBuf;

/// Everything that can be wrong with a robot description or its sensor file. Every variant
/// names the file (`source`) and says what is wrong where.
#[derive(Debug, thiserror::Error)]
pub enum RobotError {
    #[error("{source_name}: cannot read file: {err}")]
    Io {
        source_name: String,
        err: std::io::Error,
    },
    #[error("{source_name}: malformed XML: {msg}")]
    Xml { source_name: String, msg: String },
    #[error("{source_name}: this is a xacro file ({hint}); expand it first, e.g. `xacro robot.urdf.xacro > robot.urdf`")]
    Xacro { source_name: String, hint: String },
    #[error("{source_name}: {msg}")]
    Invalid { source_name: String, msg: String },
    #[error("{file}: {field}: {msg}")]
    Field {
        file: PathBuf,
        field: String,
        msg: String,
    },
}
