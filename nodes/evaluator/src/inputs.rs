//! The inputs of a metric once its entry point has checked them: what the dense and sparse
//! solvers of [`crate::gospa`] and [`crate::etgospa`] take, so that a solver cannot be reached
//! with inputs that skipped the checks (parameters valid, coordinates finite, geometry present),
//! and the size rule by which both metrics choose between the two solvers.

use crate::error::MetricError;
use crate::point::Point2;

/// Inputs of at most this many pairs are solved by one dense matrix (no grid, no components):
/// the same optimum, and no slower up to about here (`cargo bench -p nrslam-evaluator --bench
/// metrics`, GOSPA: 4 × 4 points 0.9 µs dense against 1.5 µs by components, 16 × 16 3.1 against
/// 3.5 µs, 64 × 64 over 80 m 27 against 11 µs).
const DENSE_BELOW_CELLS: usize = 16 * 16;

/// Truth of type `T` (points or extended targets), estimates and parameters `P` that passed the
/// metric's checks; built only by that metric's `check_inputs`.
pub(crate) struct Checked<'a, T, P> {
    pub truth: &'a [T],
    pub estimates: &'a [Point2],
    pub params: &'a P,
}

// By hand: a derive would ask `T: Copy` and `P: Copy`, and extended targets are not.
impl<T, P> Clone for Checked<'_, T, P> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T, P> Copy for Checked<'_, T, P> {}

impl<'a, T, P> Checked<'a, T, P> {
    /// To be called by a `check_inputs` after its checks have passed.
    pub(crate) fn after_checks(truth: &'a [T], estimates: &'a [Point2], params: &'a P) -> Self {
        Self {
            truth,
            estimates,
            params,
        }
    }

    /// Solves with `dense` when `rows` × estimates is at most [`DENSE_BELOW_CELLS`] cells (`rows`:
    /// the truth points, or the larger of the slot and target counts), else with `sparse`.
    pub(crate) fn solve_by_size<R>(
        self,
        rows: usize,
        dense: fn(Self) -> Result<R, MetricError>,
        sparse: fn(Self) -> Result<R, MetricError>,
    ) -> Result<R, MetricError> {
        if rows.saturating_mul(self.estimates.len()) <= DENSE_BELOW_CELLS {
            dense(self)
        } else {
            sparse(self)
        }
    }
}
