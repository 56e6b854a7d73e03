//! The inputs of a metric once its entry point has checked them: what the dense and sparse
//! solvers of [`crate::gospa`] and [`crate::etgospa`] take, so that a solver cannot be reached
//! with inputs that skipped the checks (parameters valid, coordinates finite, geometry present).

use crate::point::Point2;

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
}
