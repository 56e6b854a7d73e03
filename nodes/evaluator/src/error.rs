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
    /// The points linked by pairs closer than c (one connected component of the assignment)
    /// are too many for the dense solver of that component: `rows` × `cols` is more than
    /// [`MAX_CELLS`](crate::assignment::MAX_CELLS) cells.
    #[error(
        "scoring {truth} truth points or slots against {estimates} estimates: {rows} × {cols} \
         of them are linked by pairs closer than c, and their dense assignment of {rows} × \
         {cols} = {} cells is more than the limit of {} cells (512 MiB); score fewer points or \
         use a smaller c",
        (*rows as u128) * (*cols as u128),
        crate::assignment::MAX_CELLS
    )]
    ComponentTooLarge {
        /// Truth points or target slots in the component.
        rows: usize,
        /// Estimates in the component.
        cols: usize,
        /// Truth points or target slots in the whole input.
        truth: usize,
        /// Estimates in the whole input.
        estimates: usize,
    },
    /// The assignment refused its cost matrix: more than
    /// [`MAX_CELLS`](crate::assignment::MAX_CELLS) cells (too many points for the dense solver;
    /// from [`gospa_dense`](crate::gospa_dense) / [`etgospa_dense`](crate::etgospa_dense) and
    /// inputs they are used for), or (cannot happen for validated inputs) a non-finite cost.
    #[error(transparent)]
    Assignment(#[from] AssignmentError),
}

impl MetricError {
    /// Too many points for the assignment (either error naming the cell limit): the input is
    /// well-formed but cannot be scored within the memory limit.
    pub fn is_too_large(&self) -> bool {
        matches!(
            self,
            MetricError::ComponentTooLarge { .. }
                | MetricError::Assignment(AssignmentError::TooLarge { .. })
        )
    }

    /// [`MetricError::ComponentTooLarge`] for a component's [`AssignmentError::TooLarge`] (other
    /// errors unchanged).
    pub(crate) fn in_component(error: AssignmentError, truth: usize, estimates: usize) -> Self {
        match error {
            AssignmentError::TooLarge { rows, cols } => MetricError::ComponentTooLarge {
                rows,
                cols,
                truth,
                estimates,
            },
            other => MetricError::Assignment(other),
        }
    }
}
