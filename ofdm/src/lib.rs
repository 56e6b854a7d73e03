//! The 5G OFDM sensing signal model shared by the front end (which synthesises echoes) and the
//! estimator (which turns them into range/angle detections): paper Sec. II-B and III-B, Table I.
//!
//! - [`OfdmParams`]: carrier, subcarrier spacing Δf, N subcarriers, M symbols, K antennas at
//!   spacing d, per-element SNR, and the figures derived from them (range bin c/(2NΔf),
//!   unambiguous range c/(2Δf), angle bins). [`OfdmParams::validate`] and
//!   [`OfdmParams::warnings`] check them.
//! - [`Scatterer`]: one point reflector as the sensor sees it.
//! - [`ResourceGrid`]: the received Y(k, m, n) and transmitted X(m, n) of one frame
//!   ([`waveform::synthesize`]).
//! - [`RangeAngleSpectrum`]: the processed range × angle response of one frame (what
//!   [`spectral::synthesize`] synthesises directly, what [`reference::process`] computes from a
//!   grid by direct DFTs, and what the estimator computes from a grid by FFTs).
//! - [`bounds`]: Cramér–Rao bounds and DFT-grid limits for range and angle.
//!
//! # Conventions (one place for all signs)
//!
//! Scatterer l has range r_l, angle θ_l from boresight (counter-clockwise, so the array elements
//! are indexed along the +y axis of the sensor frame when boresight is +x), radial velocity v_l
//! (positive moving away) and complex amplitude a_l. Antenna k, symbol m, subcarrier n receive
//!
//! ```text
//! Y(k,m,n) = Σ_l a_l X(m,n) · e^{−j2π n Δf 2r_l/c}        range,   paper eq. (OFDM_receive)/(OFDM_signal_2)
//!                          · e^{−j2π m T 2v_l f_c/c}      Doppler, paper eq. (OFDM_receive)/(OFDM_signal_3)
//!                          · e^{+j2π k (d/λ) sin θ_l}     array,   paper eq. (AOA_1_1_1)
//!          + Z(k,m,n)
//! ```
//!
//! - Range: as printed in the paper.
//! - Doppler: the paper prints e^{+j2π m T 2v f_c/c} without saying which way v counts; a
//!   receding reflector physically lowers the carrier phase (e^{−j2π f_c 2 r(t)/c}), so with
//!   [`Scatterer::radial_velocity_mps`] positive moving away we write the minus sign: the paper's
//!   v_l is our −`radial_velocity_mps` (a closing speed).
//! - Array: the paper writes Ω = 2π d/λ · cos θ with θ from the array axis; we measure θ from
//!   boresight, so Ω = 2π d/λ · sin θ = π (2d/λ) sin θ. Element 0 is the phase reference; the far
//!   field range r_l is taken at the array centre and the array phase is not re-centred.
//! - The carrier phase e^{−j2π f_c 2r_l/c} and the frame-start phase are absorbed in a_l (the
//!   paper's A(m,n)); r_l is constant over the frame (no range migration).
//! - Processing (paper eq. (OFDM_signal_1), (OFDM_signal_33), (AOA_1_1_2)): S = Y/X, IDFT over
//!   n with 1/N and e^{+j2π n i/N'}, DFT over k without normalisation and e^{−j2π k q/A}, and (for
//!   M > 1) the mean over the M symbols, i.e. the zero-Doppler cut. Range bin i is range
//!   i · c/(2NΔf)/P_r; angle bin j is sin θ = (j − ⌊A/2⌋)/A / (d/λ) (fftshifted, broadside at
//!   ⌊A/2⌋). A unit echo at a bin centre therefore peaks at |a| K.
//!
//! Everything random is drawn from a caller-provided [`rand::Rng`]; with a seeded
//! [`FrameRng`] (ChaCha8) every output is a deterministic function of the seed.
//!
//! # Example
//!
//! ```
//! use nrslam_ofdm::{spectral, waveform, reference, FrameRng, OfdmParams, Scatterer};
//! use num_complex::Complex64;
//! use rand::SeedableRng;
//!
//! // Table I with one symbol (a static scene needs no Doppler).
//! let params = OfdmParams { symbols: 1, ..OfdmParams::default() };
//! params.validate()?;
//! let wall = Scatterer {
//!     range_m: 7.5,
//!     angle_rad: 0.2,
//!     radial_velocity_mps: 0.0,
//!     amplitude: Complex64::new(1.0, 0.0),
//! };
//! let mut rng = FrameRng::seed_from_u64(1);
//! let cfg = spectral::SpectralConfig::default(); // 0..20 m, 165 x 32 cells, ±8-cell windows
//! let map = spectral::synthesize(&params, &[wall], &cfg, &mut rng)?;
//! assert_eq!((map.range_bins, map.angle_bins), (165, 32));
//! let peak = (0..map.values.len())
//!     .max_by(|&a, &b| map.values[a].norm().total_cmp(&map.values[b].norm()))
//!     .unwrap();
//! assert_eq!(peak / map.angle_bins, (7.5 / map.range_bin_m).round() as usize);
//!
//! // The same frame at waveform fidelity (338 k complex values), processed by direct DFTs.
//! let grid = waveform::synthesize(&params, &[wall], &waveform::WaveformConfig::default(), &mut rng)?;
//! let slow = reference::process(&grid, &params, &cfg)?;
//! assert_eq!(slow.values.len(), map.values.len());
//! # Ok::<(), nrslam_ofdm::OfdmError>(())
//! ```
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

pub mod bounds;
mod config;
mod error;
mod phase;
pub mod reference;
pub mod spectral;
pub mod waveform;

pub use config::{ParamWarning, MAX_SUBCARRIERS, NR_FR2_MAX_CARRIER_BANDWIDTH_HZ};
pub use error::OfdmError;
pub use waveform::Modulation;

/// The seeded RNG every test and node uses for reproducible frames.
pub type FrameRng = rand_chacha::ChaCha8Rng;

/// Speed of light (m/s).
pub const SPEED_OF_LIGHT_M_PER_S: f64 = 299_792_458.0;

/// Radar parameters; defaults are Table I of the paper (28 GHz, 120 kHz, N 10240, M 256,
/// 32 antennas at λ/2, SNR 10 dB per element).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OfdmParams {
    /// Carrier frequency f_c (Hz).
    pub carrier_frequency_hz: f64,
    /// Subcarrier spacing Δf (Hz).
    pub subcarrier_spacing_hz: f64,
    /// Number of subcarriers N.
    pub subcarriers: usize,
    /// Number of OFDM symbols M per frame.
    pub symbols: usize,
    /// Whole OFDM symbol duration T including the cyclic prefix (s).
    pub symbol_duration_s: f64,
    /// Number of receive antennas K of the uniform linear array.
    pub antennas: usize,
    /// Element spacing d in wavelengths (0.5 = λ/2).
    pub antenna_spacing_wavelengths: f64,
    /// Per-element, per-resource-element SNR (dB) of a unit-amplitude echo.
    pub snr_db: f64,
}

impl Default for OfdmParams {
    fn default() -> Self {
        Self {
            carrier_frequency_hz: 28e9,
            subcarrier_spacing_hz: 120e3,
            subcarriers: 10240,
            symbols: 256,
            symbol_duration_s: 10.38e-6,
            antennas: 32,
            antenna_spacing_wavelengths: 0.5,
            snr_db: 10.0,
        }
    }
}

impl OfdmParams {
    /// Wavelength λ = c / f_c (m).
    pub fn wavelength_m(&self) -> f64 {
        SPEED_OF_LIGHT_M_PER_S / self.carrier_frequency_hz
    }

    /// Occupied bandwidth N·Δf (Hz).
    pub fn bandwidth_hz(&self) -> f64 {
        self.subcarriers as f64 * self.subcarrier_spacing_hz
    }

    /// Range bin c / (2 N Δf) (m): 0.122 m at Table I.
    pub fn range_bin_m(&self) -> f64 {
        SPEED_OF_LIGHT_M_PER_S / (2.0 * self.bandwidth_hz())
    }

    /// Unambiguous range c / (2 Δf) (m): 1249 m at Table I.
    pub fn unambiguous_range_m(&self) -> f64 {
        SPEED_OF_LIGHT_M_PER_S / (2.0 * self.subcarrier_spacing_hz)
    }

    /// Angle bin in sin θ: 1 / (K · d/λ) (2/32 at Table I).
    pub fn sine_bin(&self) -> f64 {
        1.0 / (self.antennas as f64 * self.antenna_spacing_wavelengths)
    }

    /// Linear SNR.
    pub fn snr_linear(&self) -> f64 {
        10f64.powf(self.snr_db / 10.0)
    }
}

/// One point reflector in the sensor frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Scatterer {
    /// Range from the array centre (m).
    pub range_m: f64,
    /// Angle from boresight, counter-clockwise (rad), in [−π/2, π/2] (endfire included; the two
    /// endfire directions alias at d = λ/2).
    pub angle_rad: f64,
    /// Radial velocity, positive moving away (m/s); see the crate docs for the Doppler sign.
    pub radial_velocity_mps: f64,
    /// Complex amplitude of the echo relative to the noise reference: |a| = 1 has the per-element,
    /// per-resource-element SNR `OfdmParams::snr_db`.
    pub amplitude: Complex64,
}

/// One frame's resource grids (`waveform` fidelity): the received Y(k, m, n) for antenna k,
/// symbol m, subcarrier n, and the transmitted X(m, n).
#[derive(Debug, Clone, PartialEq)]
pub struct ResourceGrid {
    /// Antennas K.
    pub antennas: usize,
    /// Symbols M.
    pub symbols: usize,
    /// Subcarriers N.
    pub subcarriers: usize,
    /// Received, index `(k * symbols + m) * subcarriers + n`.
    pub received: Vec<Complex64>,
    /// Transmitted, index `m * subcarriers + n`.
    pub transmitted: Vec<Complex64>,
}

/// The processed range × angle response of one frame: complex values on a grid of
/// `range_bins` × `angle_bins`, index `range_bin * angle_bins + angle_bin`. Range bin i is range
/// i · `range_bin_m` (which already includes the zero-padding: c/(2NΔf)/P_r); angle bin j is
/// sin θ = (j − ⌊angle_bins/2⌋) · 2/angle_bins / (2 d/λ) after fftshift (broadside at
/// ⌊angle_bins/2⌋). Normalisation: see the crate docs (a unit echo peaks at magnitude K).
#[derive(Debug, Clone, PartialEq)]
pub struct RangeAngleSpectrum {
    /// Range bins (N × zero-padding, or fewer when only near ranges are kept).
    pub range_bins: usize,
    /// Angle bins (K × zero-padding).
    pub angle_bins: usize,
    /// Range of one range bin (m).
    pub range_bin_m: f64,
    /// The values.
    pub values: Vec<Complex64>,
    /// Noise power per cell after processing (same units as |value|²).
    pub noise_power: f64,
}

impl RangeAngleSpectrum {
    /// The value at (`range_bin`, `angle_bin`).
    ///
    /// # Panics
    /// If either index is out of bounds.
    pub fn at(&self, range_bin: usize, angle_bin: usize) -> Complex64 {
        assert!(range_bin < self.range_bins && angle_bin < self.angle_bins);
        self.values[range_bin * self.angle_bins + angle_bin]
    }
}

impl ResourceGrid {
    /// Index of Y(k, m, n) in `received`.
    pub fn received_index(&self, antenna: usize, symbol: usize, subcarrier: usize) -> usize {
        (antenna * self.symbols + symbol) * self.subcarriers + subcarrier
    }

    /// Index of X(m, n) in `transmitted`.
    pub fn transmitted_index(&self, symbol: usize, subcarrier: usize) -> usize {
        symbol * self.subcarriers + subcarrier
    }
}

impl Scatterer {
    /// Checks that every field is finite, the range is ≥ 0 and the angle in [−π/2, π/2]
    /// (±1e-12 rad). Ranges at or beyond the unambiguous range c/(2Δf) are allowed: they wrap.
    /// `index` only labels the error.
    pub fn validate(&self, index: usize) -> Result<(), OfdmError> {
        let err = |field, value: f64, allowed| OfdmError::InvalidScatterer {
            index,
            field,
            value: format!("{value}"),
            allowed,
        };
        if !(self.range_m.is_finite() && self.range_m >= 0.0) {
            return Err(err("range_m", self.range_m, "a finite range >= 0 m"));
        }
        let half_pi = std::f64::consts::FRAC_PI_2 + 1e-12;
        if !(self.angle_rad.is_finite() && self.angle_rad.abs() <= half_pi) {
            return Err(err(
                "angle_rad",
                self.angle_rad,
                "a finite angle in [-pi/2, pi/2] rad from boresight",
            ));
        }
        if !self.radial_velocity_mps.is_finite() {
            return Err(err(
                "radial_velocity_mps",
                self.radial_velocity_mps,
                "a finite velocity (m/s)",
            ));
        }
        if !(self.amplitude.re.is_finite() && self.amplitude.im.is_finite()) {
            return Err(OfdmError::InvalidScatterer {
                index,
                field: "amplitude",
                value: format!("{}", self.amplitude),
                allowed: "a finite complex amplitude",
            });
        }
        Ok(())
    }
}

/// Validates every scatterer of a slice (the error names the first bad one).
pub fn validate_scatterers(scatterers: &[Scatterer]) -> Result<(), OfdmError> {
    scatterers
        .iter()
        .enumerate()
        .try_for_each(|(i, s)| s.validate(i))
}
