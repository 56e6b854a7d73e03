//! The one error type of the crate.

use thiserror::Error;

/// Everything that can go wrong when validating parameters or synthesising a frame.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum OfdmError {
    /// A parameter (of [`crate::OfdmParams`], [`crate::waveform::WaveformConfig`] or
    /// [`crate::spectral::SpectralConfig`]) lies outside its allowed range.
    #[error("`{field}` = {value} is out of range: allowed {allowed}")]
    InvalidParameter {
        /// Field name, prefixed by its struct when not an `OfdmParams` field
        /// (e.g. `spectral.window_cells`).
        field: &'static str,
        /// The offending value, formatted.
        value: String,
        /// The allowed range in words.
        allowed: &'static str,
    },
    /// A scatterer has a non-finite or out-of-range field.
    #[error("scatterer {index}: `{field}` = {value} is invalid: allowed {allowed}")]
    InvalidScatterer {
        /// Index of the scatterer in the slice passed in.
        index: usize,
        /// Field name of [`crate::Scatterer`].
        field: &'static str,
        /// The offending value, formatted.
        value: String,
        /// The allowed range in words.
        allowed: &'static str,
    },
    /// The requested grid or map exceeds the configured cap; nothing was allocated.
    #[error(
        "{what} needs {complex_values} complex values ({bytes} bytes), above the cap of \
         {cap_complex_values} values; {hint}"
    )]
    TooLarge {
        /// What was to be allocated, with its dimensions.
        what: String,
        /// Complex values needed (saturates at `usize::MAX`).
        complex_values: usize,
        /// Bytes needed (saturates at `usize::MAX`).
        bytes: usize,
        /// The configured cap in complex values.
        cap_complex_values: usize,
        /// How to get under the cap.
        hint: &'static str,
    },
    /// The allocator refused a request under the cap.
    #[error("could not allocate {bytes} bytes for {what}")]
    AllocationFailed {
        /// What was to be allocated.
        what: &'static str,
        /// Bytes requested.
        bytes: usize,
    },
    /// A resource grid does not match the parameters it is processed with.
    #[error("resource grid mismatch: {0}")]
    GridMismatch(String),
}
