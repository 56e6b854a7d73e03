//! The range/angle estimator of nrslam (paper Sec. III-B): turns one OFDM frame into range and
//! angle detections.
//!
//! - `waveform` fidelity: [`Estimator::process_grid`] takes the resource grid Y(k, m, n), X(m, n),
//!   divides element-wise, runs an IDFT over the subcarriers of every antenna (scaled 1/N as the
//!   paper), a DFT over the array (fftshifted: broadside in the middle) and, for M > 1, a DFT over
//!   the symbols (scaled 1/M) of which each cell keeps its strongest Doppler bin, then detects.
//!   Peak Doppler bin rather than a non-coherent sum: the map stays complex (interpolation works)
//!   and a static echo's value equals the zero-Doppler cut (mean over symbols) of
//!   `nrslam_ofdm::reference`/`spectral`; noise cells are the maximum of M exponentials, so the
//!   CFAR threshold formula is then only approximate and the median floor is biased up.
//! - `spectral` fidelity: [`Estimator::process_spectrum`] detects on a synthesised
//!   [`RangeAngleSpectrum`]; [`Estimator::range_angle_map`] produces the same map from a grid so
//!   the two paths can be compared.
//!
//! Every FFT is planned and every buffer allocated in [`Estimator::new`]; frames reuse them.
//! The angle transform is done a tile of range bins at a time (gathered from the antenna-major
//! rows while they are in cache), and only over the range window of `max_range_m`.
//!
//! Conventions: an echo at range r, angle θ (from boresight, counter-clockwise positive) is
//! Y(k, m, n) = a X(m, n) e^(−j2π nΔf 2r/c) e^(+j2π (d/λ) k sin θ); it peaks at range bin r/Δr
//! and signed angle bin s = A (d/λ) sin θ, i.e. sin θ = s · (2/A) / (2d/λ). Ranges alias modulo
//! c/(2Δf); sin θ wraps modulo 1/(d/λ) (at λ/2, sin θ = +1 and −1 are the same bin, reported as
//! −π/2); bins outside |sin θ| ≤ 1 (d < λ/2) are not searched.
//!
//! ```
//! use nrslam_estimator::{Estimator, EstimatorConfig};
//! use nrslam_ofdm::{OfdmParams, ResourceGrid};
//! use num_complex::Complex64;
//!
//! let params = OfdmParams { subcarriers: 256, symbols: 1, antennas: 8, ..OfdmParams::default() };
//! let mut est = Estimator::new(&params, EstimatorConfig::default()).unwrap();
//! // One echo at range bin 40 and broadside, X = 1.
//! let (k, n) = (8, 256);
//! let received = (0..k * n)
//!     .map(|i| Complex64::from_polar(1.0, -2.0 * std::f64::consts::PI * ((i % n) * 40) as f64 / n as f64))
//!     .collect();
//! let grid = ResourceGrid {
//!     antennas: k, symbols: 1, subcarriers: n, received,
//!     transmitted: vec![Complex64::new(1.0, 0.0); n],
//! };
//! let det = est.process_grid(&grid).unwrap();
//! assert_eq!(det.len(), 1);
//! assert_eq!((det[0].range_bin, det[0].angle_bin), (40, 4));
//! assert!((det[0].range_m - 40.0 * params.range_bin_m()).abs() < 1e-9);
//! assert_eq!(det[0].angle_rad, 0.0);
//! ```
#![warn(missing_docs)]

pub mod config;
mod detect;
pub mod error;
mod estimator;
mod kernels;
mod nomp;
pub mod refine;
mod superres;

pub use config::{Detector, EstimatorConfig, Refinement};
pub use error::EstimatorError;
pub use estimator::{validate_params, DetectionStd, Estimator, RangeAngleDetection};
pub mod node;
pub use node::{build, cell_detection, published_detection, Params};
