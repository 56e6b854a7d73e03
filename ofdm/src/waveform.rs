//! `waveform` fidelity: one frame's OFDM resource grid, paper eq. (OFDM_receive).
//!
//! [`synthesize`] draws random QAM symbols X(m, n) of unit mean power, forms the per-antenna
//! echoes of every scatterer (the three phase factors of the crate docs, each computed per index
//! from its exact phase in turns reduced modulo 1, so nothing drifts over 10240 subcarriers or a
//! kilometre of range) and adds complex AWGN.
//!
//! # Noise definition
//!
//! Z(k, m, n) ~ CN(0, σ²) independent over antennas, symbols and subcarriers, with
//! σ² = 10^(−snr_db/10): an echo with |a| = 1 has, on each element and each resource element,
//! signal power E|a X|² = 1 and SNR = `snr_db` ([`noise_variance`]).
//!
//! # Memory
//!
//! The grid holds K·M·N received plus M·N transmitted complex values (16 bytes each): Table I
//! with M = 256 is 86 M values, 1.4 GB. M = 1 suffices for a static scene (range and angle need
//! no Doppler; 1 symbol of Table I is 338 k values, 5.4 MB). Above
//! [`WaveformConfig::max_complex_values`] [`synthesize`] returns [`OfdmError::TooLarge`] before
//! allocating anything, and an allocator refusal under the cap is
//! [`OfdmError::AllocationFailed`], never an abort.
//!
//! # Random stream
//!
//! X is drawn first (m-major, one `u32` per symbol), then, if enabled, the noise in storage
//! order (k, m, n; re then im, one standard normal each). The same RNG state gives the same grid.

use crate::phase::{cis_turns, product_turns};
use crate::SPEED_OF_LIGHT_M_PER_S as C;
use crate::{validate_scatterers, OfdmError, OfdmParams, ResourceGrid, Scatterer};
use num_complex::Complex64;
use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

/// Modulation of the transmitted symbols X(m, n), unit mean power.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Modulation {
    /// (±1 ± j)/√2: constant modulus, so Y/X does not colour or enhance the noise.
    #[default]
    Qpsk,
    /// (±1, ±3) ± j(±1, ±3), scaled by 1/√10.
    Qam16,
}

impl Modulation {
    /// E[1/|X|²]: the factor by which Y/X multiplies the noise power. 1 for QPSK; for 16-QAM
    /// (|X|² ∈ {0.2, 1, 1.8} with probabilities ¼, ½, ¼) it is 1.25 + 0.5 + 5/36 = 17/9 ≈ 1.889
    /// (+2.76 dB).
    pub fn noise_enhancement(self) -> f64 {
        match self {
            Self::Qpsk => 1.0,
            Self::Qam16 => 17.0 / 9.0,
        }
    }

    /// One random symbol (consumes one `u32`).
    pub fn draw<R: Rng + ?Sized>(self, rng: &mut R) -> Complex64 {
        let bits: u32 = rng.random();
        match self {
            Self::Qpsk => {
                let s = std::f64::consts::FRAC_1_SQRT_2;
                let re = if bits & 1 == 0 { s } else { -s };
                let im = if bits & 2 == 0 { s } else { -s };
                Complex64::new(re, im)
            }
            Self::Qam16 => {
                const LEVELS: [f64; 4] = [-3.0, -1.0, 1.0, 3.0];
                let s = 1.0 / 10f64.sqrt();
                Complex64::new(
                    LEVELS[(bits & 3) as usize] * s,
                    LEVELS[((bits >> 2) & 3) as usize] * s,
                )
            }
        }
    }
}

/// Knobs of [`synthesize`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct WaveformConfig {
    /// Modulation of X (default QPSK).
    pub modulation: Modulation,
    /// Add the AWGN Z (default true; false gives the noise-free echoes for tests).
    pub add_noise: bool,
    /// Cap on K·M·N + M·N complex values (default 2^25 ≈ 33.5 M, 512 MiB).
    pub max_complex_values: usize,
}

impl Default for WaveformConfig {
    fn default() -> Self {
        Self {
            modulation: Modulation::Qpsk,
            add_noise: true,
            max_complex_values: 1 << 25,
        }
    }
}

/// σ² = 10^(−snr_db/10): the per-element, per-resource-element noise power for which a
/// unit-amplitude echo has SNR `snr_db`.
pub fn noise_variance(params: &OfdmParams) -> f64 {
    1.0 / params.snr_linear()
}

/// K·M·N + M·N, or `None` on overflow.
pub fn grid_complex_values(params: &OfdmParams) -> Option<usize> {
    let mn = params.symbols.checked_mul(params.subcarriers)?;
    mn.checked_mul(params.antennas)?.checked_add(mn)
}

/// Range rate Δf·2r/c: turns of phase per subcarrier (the range phase of subcarrier n is
/// −2π·n·this).
pub fn range_turns_per_subcarrier(params: &OfdmParams, range_m: f64) -> f64 {
    params.subcarrier_spacing_hz * (2.0 * range_m) / C
}

/// Doppler rate T·2v·f_c/c: turns per symbol (the Doppler phase of symbol m is −2π·m·this).
pub fn doppler_turns_per_symbol(params: &OfdmParams, radial_velocity_mps: f64) -> f64 {
    params.symbol_duration_s * 2.0 * radial_velocity_mps * params.carrier_frequency_hz / C
}

/// Spatial rate (d/λ)·sin θ: turns per antenna (the array phase of element k is +2π·k·this).
pub fn array_turns_per_element(params: &OfdmParams, angle_rad: f64) -> f64 {
    params.antenna_spacing_wavelengths * angle_rad.sin()
}

/// The unit-modulus echo phasor of one scatterer at (k, m, n), without a_l and X:
/// e^{−j2π n Δf 2r/c} · e^{−j2π m T 2v f_c/c} · e^{+j2π k (d/λ) sin θ}, the three factors each
/// reduced modulo one turn before the sum of phases.
pub fn echo_phasor(
    params: &OfdmParams,
    scatterer: &Scatterer,
    antenna: usize,
    symbol: usize,
    subcarrier: usize,
) -> Complex64 {
    let turns = -product_turns(
        subcarrier,
        range_turns_per_subcarrier(params, scatterer.range_m),
    ) - product_turns(
        symbol,
        doppler_turns_per_symbol(params, scatterer.radial_velocity_mps),
    ) + product_turns(
        antenna,
        array_turns_per_element(params, scatterer.angle_rad),
    );
    cis_turns(turns)
}

fn try_zeroed(len: usize, what: &'static str) -> Result<Vec<Complex64>, OfdmError> {
    let mut v = Vec::new();
    v.try_reserve_exact(len)
        .map_err(|_| OfdmError::AllocationFailed {
            what,
            bytes: len.saturating_mul(std::mem::size_of::<Complex64>()),
        })?;
    v.resize(len, Complex64::new(0.0, 0.0));
    Ok(v)
}

/// Synthesises one frame: X(m, n) random QAM, Y(k, m, n) per the crate docs' model, plus
/// CN(0, σ²) noise if `config.add_noise`. Validates `params`, `config` and every scatterer first
/// (non-finite inputs are refused, naming the field). Scatterers at or beyond the unambiguous
/// range c/(2Δf) are legal and alias (wrap) in range exactly as a real OFDM radar's would.
///
/// Cost: L·N trig evaluations plus L·K·M·N complex multiply-adds for L scatterers.
pub fn synthesize<R: Rng + ?Sized>(
    params: &OfdmParams,
    scatterers: &[Scatterer],
    config: &WaveformConfig,
    rng: &mut R,
) -> Result<ResourceGrid, OfdmError> {
    params.validate()?;
    validate_scatterers(scatterers)?;
    let (k_n, m_n, n_n) = (params.antennas, params.symbols, params.subcarriers);
    let values = grid_complex_values(params);
    if values.is_none_or(|v| v > config.max_complex_values) {
        let values = values.unwrap_or(usize::MAX);
        return Err(OfdmError::TooLarge {
            what: format!("a resource grid of {k_n} antennas x {m_n} symbols x {n_n} subcarriers"),
            complex_values: values,
            bytes: values.saturating_mul(std::mem::size_of::<Complex64>()),
            cap_complex_values: config.max_complex_values,
            hint: "lower `symbols` (M = 1 suffices for a static scene) or raise \
                   `waveform.max_complex_values`",
        });
    }
    let mut transmitted = try_zeroed(m_n * n_n, "the transmitted symbols X")?;
    let mut received = try_zeroed(k_n * m_n * n_n, "the received grid Y")?;
    let mut range_row = try_zeroed(n_n, "a subcarrier phase row")?;

    for x in transmitted.iter_mut() {
        *x = config.modulation.draw(rng);
    }

    for s in scatterers {
        let fr = range_turns_per_subcarrier(params, s.range_m);
        for (n, r) in range_row.iter_mut().enumerate() {
            *r = cis_turns(-product_turns(n, fr));
        }
        let fd = doppler_turns_per_symbol(params, s.radial_velocity_mps);
        let fa = array_turns_per_element(params, s.angle_rad);
        for k in 0..k_n {
            for m in 0..m_n {
                let coeff = s.amplitude * cis_turns(product_turns(k, fa) - product_turns(m, fd));
                let row = &mut received[(k * m_n + m) * n_n..][..n_n];
                for (y, r) in row.iter_mut().zip(&range_row) {
                    *y += coeff * r;
                }
            }
        }
    }

    let sigma = (noise_variance(params) / 2.0).sqrt();
    for k in 0..k_n {
        for m in 0..m_n {
            let row = &mut received[(k * m_n + m) * n_n..][..n_n];
            let xs = &transmitted[m * n_n..][..n_n];
            for (y, x) in row.iter_mut().zip(xs) {
                *y *= x;
                if config.add_noise {
                    let re: f64 = rng.sample(StandardNormal);
                    let im: f64 = rng.sample(StandardNormal);
                    *y += Complex64::new(sigma * re, sigma * im);
                }
            }
        }
    }

    Ok(ResourceGrid {
        antennas: k_n,
        symbols: m_n,
        subcarriers: n_n,
        received,
        transmitted,
    })
}
