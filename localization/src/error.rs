//! Errors of the localization crate. Localizers get their parameters from scenario files;
//! the message names the field so the caller can point at the file.

use thiserror::Error;

#[derive(Debug, Clone, PartialEq, Error)]
pub enum LocalizationError {
    /// A parameter is out of range, NaN or inconsistent with another one.
    #[error("invalid localizer parameter: {0}")]
    InvalidParameter(String),
    /// The occupancy grid handed to a localizer is malformed.
    #[error("invalid occupancy grid: field `{field}`: {reason}")]
    InvalidGrid { field: &'static str, reason: String },
    /// The initial belief cannot be sampled (bad pose, empty region, no free cell).
    #[error("invalid initial belief: field `{field}`: {reason}")]
    InvalidInitialBelief { field: &'static str, reason: String },
}

impl LocalizationError {
    pub(crate) fn grid(field: &'static str, reason: impl Into<String>) -> Self {
        Self::InvalidGrid {
            field,
            reason: reason.into(),
        }
    }

    pub(crate) fn belief(field: &'static str, reason: impl Into<String>) -> Self {
        Self::InvalidInitialBelief {
            field,
            reason: reason.into(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_field() {
        let e = LocalizationError::grid("resolution", "must be > 0, got -1");
        assert_eq!(
            e.to_string(),
            "invalid occupancy grid: field `resolution`: must be > 0, got -1"
        );
        let e = LocalizationError::InvalidParameter("sigma_hit must be > 0, got 0".into());
        assert!(e.to_string().contains("sigma_hit"));
    }
}
