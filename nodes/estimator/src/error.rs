//! Errors of the estimator. None of them is a panic: bad parameters, grids of the wrong shape and
//! non-finite samples come back as values that say what and where.

use nrslam_runtime::InvalidParam;

/// Why the estimator could not be built or could not process a frame.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EstimatorError {
    /// A configuration or OFDM parameter is out of range (OFDM fields are prefixed `ofdm.`).
    #[error("estimator parameter {0}")]
    Param(#[from] InvalidParam),
    /// The resource grid does not match the parameters the estimator was built for.
    #[error("resource grid: {what} is {found}, expected {expected}")]
    GridShape {
        /// Which dimension or buffer (`antennas`, `received.len()`, …).
        what: &'static str,
        /// What the estimator was built for.
        expected: usize,
        /// What the grid has.
        found: usize,
    },
    /// The spectrum is not usable (shape, bin size, angle bins).
    #[error("range-angle spectrum: {0}")]
    SpectrumShape(String),
    /// A sample is NaN or infinite.
    #[error("{input}[{index}] is not finite ({value})")]
    NonFinite {
        /// `received`, `transmitted` or `spectrum`.
        input: &'static str,
        /// Flat index into that buffer.
        index: usize,
        /// The offending value, as text.
        value: String,
    },
    /// Every input was finite but Y/X or the transforms overflowed f64.
    #[error("overflow: {0} is not finite although every input sample is")]
    Overflow(&'static str),
    /// Every transmitted cell X(m, n) is zero (or subnormal): nothing to divide by.
    #[error("every transmitted cell X(m, n) is zero or subnormal: no reference for Y/X")]
    NoReference,
    /// The buffers for these sizes cannot be allocated.
    #[error("cannot allocate {bytes} bytes of estimator buffers")]
    Allocation {
        /// The size that failed.
        bytes: usize,
    },
}
