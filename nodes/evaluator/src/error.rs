//! Errors of the metric functions.

use thiserror::Error;

use crate::assignment::AssignmentError;

/// A metric parameter outside its allowed range, naming the field and the range.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("invalid metric parameter `{field}`: {problem} (allowed: {allowed})")]
pub struct InvalidMetricParam {
    /// The field, as spelled in the parameter struct (`c`, `p`, `alpha`).
    pub field: &'static str,
    /// What is wrong with the value given.
    pub problem: String,
    /// The allowed range.
    pub allowed: &'static str,
}

impl InvalidMetricParam {
    pub(crate) fn new(
        field: &'static str,
        problem: impl Into<String>,
        allowed: &'static str,
    ) -> Self {
        Self {
            field,
            problem: problem.into(),
            allowed,
        }
    }
}

/// Why a metric could not be computed. Bad input is refused, never silently mis-scored.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MetricError {
    /// A parameter is outside its range.
    #[error(transparent)]
    InvalidParam(#[from] InvalidMetricParam),
    /// A point has a NaN or infinite coordinate.
    #[error("{set}: point {index} has a non-finite coordinate ({x_m}, {y_m})")]
    NonFiniteInput {
        /// Which input: `truth`, `estimates`, `target 3 samples`, …
        set: String,
        /// Index of the point within that input.
        index: usize,
        /// Its x coordinate, metres.
        x_m: f64,
        /// Its y coordinate, metres.
        y_m: f64,
    },
    /// A target has no point of the geometry the distance mode measures to.
    #[error("target {target} has no {geometry} points: no distance to it can be computed")]
    EmptyGeometry {
        /// Index of the target.
        target: usize,
        /// `sample` or `outline`.
        geometry: &'static str,
    },
    /// The assignment refused its cost matrix: more than
    /// [`MAX_CELLS`](crate::assignment::MAX_CELLS) cells (too many points for the dense solver),
    /// or (cannot happen for validated inputs) a non-finite cost.
    #[error(transparent)]
    Assignment(#[from] AssignmentError),
}
