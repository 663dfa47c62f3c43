//! URDF loading. (Being written: see the robots brief.)
use crate::{error::RobotError, model::RobotModel};
use std::path::Path;

pub(crate) fn load_file(path: &Path) -> Result<RobotModel, RobotError> {
    let text = std::fs::read_to_string(path).map_err(|err| RobotError::Io {
        source_name: path.display().to_string(),
        err,
    })?;
    load_str(&text, &path.display().to_string())
}

pub(crate) fn load_str(_text: &str, source: &str) -> Result<RobotModel, RobotError> {
    Err(RobotError::Invalid {
        source_name: source.into(),
        msg: "URDF loading not written yet".into(),
    })
}
