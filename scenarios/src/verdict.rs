//! The outcome of checking a run against an expectation: shared by the `[expect]` tables
//! and the SLAM checks.

use serde::Serialize;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Bound {
    Max,
    Min,
}

/// The outcome of one expectation, as reported.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExpectationResult {
    pub metric: String,
    pub bound: Bound,
    pub limit: f64,
    /// `None` when the metric does not exist for this run (never converged, region never
    /// visited, ...): that fails the expectation.
    pub value: Option<f64>,
    pub passed: bool,
}
