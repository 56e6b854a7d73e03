//! `spectral` fidelity: the closed-form processed response of one frame, without the grid.
//!
//! The processing of the crate docs (S = Y/X, IDFT over the N subcarriers with 1/N, DFT over the
//! K antennas, mean over the M symbols) is linear, so each scatterer's contribution is exactly
//!
//! ```text
//! V(i, j) = a · (1/N) D_N(i/(N P_r) − Δf 2r/c)              range,   eq. (OFDM_signal_33)
//!             · D_K((d/λ) sin θ − (j − ⌊A/2⌋)/A)            angle,   eq. (AOA_1_1_2), A = K P_a
//!             · (1/M) D_M(−T 2v f_c/c)                      Doppler folded into the amplitude
//! D_L(x) = Σ_{t=0}^{L−1} e^{j2π t x} = e^{jπ(L−1)x} · sin(πLx)/sin(πx)
//! ```
//!
//! with the Dirichlet kernel [`dirichlet`] in its exact discrete (periodic) form. [`synthesize`]
//! agrees with [`crate::reference::process`] applied to a noise-free [`crate::waveform`] grid to
//! rounding (the tests check 1e-9 relative in every evaluated cell).
//!
//! # Doppler (M > 1)
//!
//! The map is the zero-Doppler cut: the M symbols are averaged, so a scatterer with Doppler
//! rate f_D = T 2v f_c/c turns per symbol is scaled by (1/M) D_M(−f_D) (magnitude 1 when static).
//! At Table I (M = 256, T = 10.38 µs) a 1 m/s radial speed is 0.497 turns over the frame and
//! loses 3.9 dB; use M = 1 for the SLAM scenes (static, or motion negligible within 10 µs).
//!
//! # Windows
//!
//! Each scatterer is evaluated only in ±`window_cells` resolution cells (±`window_cells`·P bins)
//! around its peak cell, in range and in angle; outside, its kernel is dropped. The dropped
//! level is at most 1/(L sin(π W/L)) ≈ 1/(πW) of the peak per dimension ([`window_leakage_db`]):
//! −28.0 dB for W = 8 at N = 10240, −27.1 dB for W = 8 at K = 32; W = 32 gives −40 dB. The
//! noise floor after processing at Table I (SNR_eff = 10 dB + 10 log10(N K)) is far below these
//! levels for strong scatterers, so raise W when sidelobes matter (weak targets next to strong).
//!
//! # Noise
//!
//! Z(k,m,n)/X(m,n) is white over (k, m, n) with power σ² E[1/|X|²] (σ² from
//! [`crate::waveform::noise_variance`]; E[1/|X|²] = 1 for QPSK, independent of Z). The 1/N IDFT
//! leaves N·σ'²/N² = σ'²/N per range cell, the K-point DFT multiplies by K, the mean over M
//! divides by M:
//!
//! ```text
//! noise_power = K σ² E[1/|X|²] / (N M)
//! ```
//!
//! ([`processed_noise_power`]), so a unit echo (peak |a| K) has processed SNR
//! SNR · N · M · K / E[1/|X|²]. [`synthesize`] draws independent CN(0, noise_power) in every returned cell. Without zero-padding
//! (P_r = P_a = 1) cells are exactly uncorrelated, so this is the exact distribution (exactly
//! Gaussian for QPSK). With zero-padding the true noise is correlated between neighbouring padded
//! cells (by the same Dirichlet kernel); the per-cell power is right but the correlation is not
//! modelled.
//!
//! # Map size
//!
//! Only range bins 0 ..= ⌈max_range_m / cell⌉ are kept ([`range_bins`]); at Table I with 20 m
//! that is 165 bins × 32 angle bins = 5280 cells (84 kB). The output is a dense
//! [`RangeAngleSpectrum`] (noise in every cell), capped by `max_cells`.

use crate::phase::{cis_turns, reduce_turns};
use crate::waveform::{
    array_turns_per_element, doppler_turns_per_symbol, noise_variance, range_turns_per_subcarrier,
    Modulation,
};
use crate::{validate_scatterers, OfdmError, OfdmParams, RangeAngleSpectrum, Scatterer};
use num_complex::Complex64;
use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Knobs of [`synthesize`] (and of [`crate::reference::process`], which shares the map layout).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SpectralConfig {
    /// Largest range kept (m), default 20 m. Bins beyond are not returned.
    pub max_range_m: f64,
    /// Range zero-padding factor P_r (IDFT length N·P_r), 1 ..= 64, default 1.
    pub range_zero_padding: usize,
    /// Angle zero-padding factor P_a (DFT length K·P_a), 1 ..= 64, default 1.
    pub angle_zero_padding: usize,
    /// Half-width W of each scatterer's evaluation window, in resolution cells (unpadded bins),
    /// per dimension; default 8 (dropped sidelobes ≤ −28 dB, see the module docs).
    pub window_cells: usize,
    /// Half-width of the window in angle alone, in resolution cells; absent = `window_cells`.
    /// K/2 or more evaluates every angle bin, so each array row is exact: the super-resolution
    /// estimators (`music`, `esprit`) turn a row back into the K elements' samples, where the
    /// dropped side lobes (−27 dB at W = 8, K = 32) would be a model error. Costs up to
    /// K/(2W + 1) × the synthesis of the window.
    pub angle_window_cells: Option<usize>,
    /// Modulation assumed for the Y/X noise enhancement E[1/|X|²] (default QPSK).
    pub modulation: Modulation,
    /// Add the processed noise (default true).
    pub add_noise: bool,
    /// Cap on range_bins × angle_bins (default 2^24).
    pub max_cells: usize,
}

impl Default for SpectralConfig {
    fn default() -> Self {
        Self {
            max_range_m: 20.0,
            range_zero_padding: 1,
            angle_zero_padding: 1,
            window_cells: 8,
            angle_window_cells: None,
            modulation: Modulation::Qpsk,
            add_noise: true,
            max_cells: 1 << 24,
        }
    }
}

impl SpectralConfig {
    /// Checks every field; the error names it (`spectral.<field>`) and its allowed range.
    pub fn validate(&self) -> Result<(), OfdmError> {
        let bad = |field, value: String, allowed| OfdmError::InvalidParameter {
            field,
            value,
            allowed,
        };
        if !(self.max_range_m.is_finite() && self.max_range_m >= 0.0) {
            return Err(bad(
                "spectral.max_range_m",
                self.max_range_m.to_string(),
                "a finite range >= 0 m",
            ));
        }
        if !(1..=64).contains(&self.range_zero_padding) {
            return Err(bad(
                "spectral.range_zero_padding",
                self.range_zero_padding.to_string(),
                "1 ..= 64",
            ));
        }
        if !(1..=64).contains(&self.angle_zero_padding) {
            return Err(bad(
                "spectral.angle_zero_padding",
                self.angle_zero_padding.to_string(),
                "1 ..= 64",
            ));
        }
        if self.window_cells > 1 << 20 {
            return Err(bad(
                "spectral.window_cells",
                self.window_cells.to_string(),
                "0 ..= 1048576",
            ));
        }
        if self.angle_window_cells.is_some_and(|w| w > 1 << 20) {
            return Err(bad(
                "spectral.angle_window_cells",
                format!("{:?}", self.angle_window_cells),
                "0 ..= 1048576, or absent",
            ));
        }
        if self.max_cells == 0 {
            return Err(bad("spectral.max_cells", "0".into(), ">= 1"));
        }
        Ok(())
    }
}

/// Exact Dirichlet kernel D_L(x) = Σ_{t=0}^{L−1} e^{j2π t x} = e^{jπ(L−1)x} sin(πLx)/sin(πx),
/// periodic in x with period 1, D_L(0) = L. Evaluated on x reduced modulo 1 with the product
/// L·x formed exactly (FMA), so it stays accurate to rounding for L up to 2^24.
pub fn dirichlet(len: usize, x: f64) -> Complex64 {
    if len == 0 {
        return Complex64::new(0.0, 0.0);
    }
    let xr = reduce_turns(x);
    let l = len as f64;
    let mag = if xr.abs() < 1e-18 {
        l
    } else {
        // sin(π L xr) with L·xr = q + f exactly: (−1)^q sin(π f).
        let p = l * xr;
        let e = l.mul_add(xr, -p);
        let q = p.round();
        let f = (p - q) + e;
        let sign = if (q as i64) % 2 == 0 { 1.0 } else { -1.0 };
        sign * (PI * f).sin() / (PI * xr).sin()
    };
    mag * cis_turns(0.5 * (l - 1.0) * xr)
}

/// 20 log10 of the largest kernel magnitude (relative to the peak) dropped by a window of
/// ±`window_cells` resolution cells for an L-point transform: 1/(L sin(π W/L)), a bound over any
/// sub-bin offset. 0 dB when W = 0; −∞ when the window covers the whole period.
pub fn window_leakage_db(window_cells: usize, len: usize) -> f64 {
    if window_cells == 0 {
        return 0.0;
    }
    if 2 * window_cells >= len {
        return f64::NEG_INFINITY;
    }
    let l = len as f64;
    -20.0 * (l * (PI * window_cells as f64 / l).sin()).log10()
}

/// Range bins in the full (padded) IDFT: N·P_r.
pub fn total_range_bins(params: &OfdmParams, config: &SpectralConfig) -> usize {
    params.subcarriers * config.range_zero_padding
}

/// Range of one (padded) range bin: c/(2NΔf)/P_r (m).
pub fn range_cell_m(params: &OfdmParams, config: &SpectralConfig) -> f64 {
    params.range_bin_m() / config.range_zero_padding as f64
}

/// Range bins kept: min(N·P_r, ⌈max_range_m / cell⌉ + 1), so the last bin is at or beyond
/// `max_range_m` (165 at Table I for 20 m).
pub fn range_bins(params: &OfdmParams, config: &SpectralConfig) -> usize {
    let want = (config.max_range_m / range_cell_m(params, config)).ceil() + 1.0;
    let total = total_range_bins(params, config);
    if want >= total as f64 {
        total
    } else {
        want as usize
    }
}

/// Angle bins: K·P_a.
pub fn angle_bins(params: &OfdmParams, config: &SpectralConfig) -> usize {
    params.antennas * config.angle_zero_padding
}

/// sin θ at the centre of angle bin j (fftshifted): (j − ⌊A/2⌋)/A / (d/λ). Values beyond ±1
/// (d > λ/2) are not physical angles.
pub fn angle_bin_sine(params: &OfdmParams, config: &SpectralConfig, angle_bin: usize) -> f64 {
    let a = angle_bins(params, config);
    (angle_bin as f64 - (a / 2) as f64) / a as f64 / params.antenna_spacing_wavelengths
}

/// Processed noise power per cell, K σ² E[1/|X|²] / (N M) (module docs).
pub fn processed_noise_power(params: &OfdmParams, modulation: Modulation) -> f64 {
    params.antennas as f64 * noise_variance(params) * modulation.noise_enhancement()
        / (params.subcarriers as f64 * params.symbols as f64)
}

/// The range factor (1/N) D_N(i/(N P_r) − Δf 2r/c) of a scatterer at `range_m`, bin `range_bin`.
pub fn range_response(
    params: &OfdmParams,
    config: &SpectralConfig,
    range_m: f64,
    range_bin: usize,
) -> Complex64 {
    let total = total_range_bins(params, config);
    let bin_turns = reduce_turns(range_bin as f64 / total as f64);
    let x = bin_turns - reduce_turns(range_turns_per_subcarrier(params, range_m));
    dirichlet(params.subcarriers, x) / params.subcarriers as f64
}

/// The angle factor D_K((d/λ) sin θ − (j − ⌊A/2⌋)/A) at angle bin `angle_bin`.
pub fn angle_response(
    params: &OfdmParams,
    config: &SpectralConfig,
    angle_rad: f64,
    angle_bin: usize,
) -> Complex64 {
    let a = angle_bins(params, config);
    let bin_turns = (angle_bin as f64 - (a / 2) as f64) / a as f64;
    let y = reduce_turns(array_turns_per_element(params, angle_rad)) - bin_turns;
    dirichlet(params.antennas, y)
}

/// The Doppler factor (1/M) D_M(−T 2v f_c/c) of the zero-Doppler cut.
pub fn doppler_response(params: &OfdmParams, radial_velocity_mps: f64) -> Complex64 {
    dirichlet(
        params.symbols,
        -doppler_turns_per_symbol(params, radial_velocity_mps),
    ) / params.symbols as f64
}

/// A scatterer's noise-free contribution to cell (range_bin, angle_bin), evaluated anywhere
/// (no window): a · range · angle · Doppler factors.
pub fn cell_response(
    params: &OfdmParams,
    config: &SpectralConfig,
    scatterer: &Scatterer,
    range_bin: usize,
    angle_bin: usize,
) -> Complex64 {
    scatterer.amplitude
        * range_response(params, config, scatterer.range_m, range_bin)
        * angle_response(params, config, scatterer.angle_rad, angle_bin)
        * doppler_response(params, scatterer.radial_velocity_mps)
}

fn window(peak_turns: f64, total: usize, half: usize, kept: usize) -> Vec<usize> {
    if 2 * half + 1 >= total {
        return (0..kept.min(total)).collect();
    }
    let centre = ((peak_turns.rem_euclid(1.0) * total as f64).round() as usize) % total;
    (0..=2 * half)
        .map(|o| (centre + total - half + o) % total)
        .filter(|&b| b < kept)
        .collect()
}

/// The cells [`synthesize`] evaluates for one scatterer: (range bins, angle bins), each the
/// ±W·P window around the peak bin, wrapped modulo the transform length (range wraps at the
/// unambiguous range, angle at sin θ = ±λ/(2d)), range bins ≥ [`range_bins`] dropped.
pub fn window_bins(
    params: &OfdmParams,
    config: &SpectralConfig,
    scatterer: &Scatterer,
) -> (Vec<usize>, Vec<usize>) {
    let rw = window(
        range_turns_per_subcarrier(params, scatterer.range_m),
        total_range_bins(params, config),
        config
            .window_cells
            .saturating_mul(config.range_zero_padding),
        range_bins(params, config),
    );
    let a = angle_bins(params, config);
    let peak = array_turns_per_element(params, scatterer.angle_rad) + (a / 2) as f64 / a as f64;
    let aw = window(
        peak,
        a,
        config
            .angle_window_cells
            .unwrap_or(config.window_cells)
            .saturating_mul(config.angle_zero_padding),
        a,
    );
    (rw, aw)
}

/// One scatterer's part of [`Responses`]: what it was computed from (the bits of range, angle
/// and radial velocity), its window bins and its kernel factors there.
#[derive(Debug, Clone, PartialEq)]
struct ScattererResponse {
    geometry: [u64; 3],
    /// Doppler factor (1/M) D_M(−T 2v f_c/c), without the amplitude.
    doppler: Complex64,
    /// Range bins of the window and the range factor at each.
    range: Vec<(usize, Complex64)>,
    /// Angle bins of the window and the angle factor at each.
    angle: Vec<(usize, Complex64)>,
}

impl ScattererResponse {
    fn new(params: &OfdmParams, config: &SpectralConfig, s: &Scatterer) -> Self {
        let (rw, aw) = window_bins(params, config, s);
        ScattererResponse {
            geometry: geometry_bits(s),
            doppler: doppler_response(params, s.radial_velocity_mps),
            range: rw
                .into_iter()
                .map(|i| (i, range_response(params, config, s.range_m, i)))
                .collect(),
            angle: aw
                .into_iter()
                .map(|j| (j, angle_response(params, config, s.angle_rad, j)))
                .collect(),
        }
    }
}

/// The bits of what a scatterer's response depends on besides its amplitude.
fn geometry_bits(s: &Scatterer) -> [u64; 3] {
    [
        s.range_m.to_bits(),
        s.angle_rad.to_bits(),
        s.radial_velocity_mps.to_bits(),
    ]
}

/// The part of [`synthesize`] that neither the scatterers' amplitudes nor the noise change:
/// each scatterer's window ([`window_bins`]), its range and angle factors there and its Doppler
/// factor. A function of the parameters, the configuration and each scatterer's range, angle
/// and radial velocity alone, so a caller that synthesises the same geometry again (the radar
/// at the same true pose in every Monte Carlo trial) can keep it; [`synthesize_with`] then gives
/// bit for bit what [`synthesize`] gives, without the trigonometry.
#[derive(Debug, Clone, PartialEq)]
pub struct Responses {
    params: OfdmParams,
    config: SpectralConfig,
    scatterers: Vec<ScattererResponse>,
}

impl Responses {
    /// The responses of `scatterers` (their amplitudes are not read). Validates as
    /// [`synthesize`] does.
    pub fn new(
        params: &OfdmParams,
        scatterers: &[Scatterer],
        config: &SpectralConfig,
    ) -> Result<Self, OfdmError> {
        params.validate()?;
        config.validate()?;
        validate_scatterers(scatterers)?;
        Ok(Responses {
            params: *params,
            config: *config,
            scatterers: scatterers
                .iter()
                .map(|s| ScattererResponse::new(params, config, s))
                .collect(),
        })
    }

    /// Bytes held, roughly (for a cache's budget).
    pub fn heap_bytes(&self) -> usize {
        let per_bin = std::mem::size_of::<(usize, Complex64)>();
        self.scatterers
            .iter()
            .map(|s| {
                std::mem::size_of::<ScattererResponse>() + per_bin * (s.range.len() + s.angle.len())
            })
            .sum()
    }
}

/// Synthesises one frame's processed range × angle map: every scatterer's exact response in its
/// window, summed, plus independent CN(0, [`processed_noise_power`]) in every cell if
/// `config.add_noise` (drawn in storage order, re then im). Validates params, config and
/// scatterers (non-finite values refused, naming the field).
pub fn synthesize<R: Rng + ?Sized>(
    params: &OfdmParams,
    scatterers: &[Scatterer],
    config: &SpectralConfig,
    rng: &mut R,
) -> Result<RangeAngleSpectrum, OfdmError> {
    let responses = Responses::new(params, scatterers, config)?;
    synthesize_with(params, scatterers, config, &responses, rng)
}

/// [`synthesize`] with the scatterers' [`Responses`] computed before (by [`Responses::new`] for
/// the same parameters, configuration and scatterer geometry): the same map, bit for bit. A
/// scatterer whose geometry differs from the one its response was computed for (or any, when
/// the parameters, configuration or count differ) is evaluated afresh.
pub fn synthesize_with<R: Rng + ?Sized>(
    params: &OfdmParams,
    scatterers: &[Scatterer],
    config: &SpectralConfig,
    responses: &Responses,
    rng: &mut R,
) -> Result<RangeAngleSpectrum, OfdmError> {
    params.validate()?;
    config.validate()?;
    validate_scatterers(scatterers)?;
    let mut spectrum = empty_spectrum(params, config)?;
    let a = spectrum.angle_bins;
    let usable = responses.params == *params
        && responses.config == *config
        && responses.scatterers.len() == scatterers.len();
    let mut fresh = None;
    for (index, s) in scatterers.iter().enumerate() {
        let response = match responses.scatterers.get(index) {
            Some(r) if usable && r.geometry == geometry_bits(s) => r,
            _ => fresh.insert(ScattererResponse::new(params, config, s)),
        };
        let dop = s.amplitude * response.doppler;
        for &(i, range) in &response.range {
            let r = dop * range;
            let row = &mut spectrum.values[i * a..(i + 1) * a];
            for &(j, g) in &response.angle {
                row[j] += r * g;
            }
        }
    }
    if config.add_noise {
        let sigma = (spectrum.noise_power / 2.0).sqrt();
        for v in spectrum.values.iter_mut() {
            let re: f64 = rng.sample(StandardNormal);
            let im: f64 = rng.sample(StandardNormal);
            *v += Complex64::new(sigma * re, sigma * im);
        }
    }
    Ok(spectrum)
}

/// A zeroed map of the configured size with its noise power set; checks the cap.
pub(crate) fn empty_spectrum(
    params: &OfdmParams,
    config: &SpectralConfig,
) -> Result<RangeAngleSpectrum, OfdmError> {
    let (rb, ab) = (range_bins(params, config), angle_bins(params, config));
    let cells = rb.checked_mul(ab);
    if cells.is_none_or(|c| c > config.max_cells) {
        let cells = cells.unwrap_or(usize::MAX);
        return Err(OfdmError::TooLarge {
            what: format!("a range-angle map of {rb} range x {ab} angle bins"),
            complex_values: cells,
            bytes: cells.saturating_mul(std::mem::size_of::<Complex64>()),
            cap_complex_values: config.max_cells,
            hint: "lower `spectral.max_range_m` or the zero-padding, or raise `spectral.max_cells`",
        });
    }
    let cells = rb * ab;
    let mut values = Vec::new();
    values
        .try_reserve_exact(cells)
        .map_err(|_| OfdmError::AllocationFailed {
            what: "the range-angle map",
            bytes: cells.saturating_mul(std::mem::size_of::<Complex64>()),
        })?;
    values.resize(cells, Complex64::new(0.0, 0.0));
    Ok(RangeAngleSpectrum {
        range_bins: rb,
        angle_bins: ab,
        range_bin_m: range_cell_m(params, config),
        values,
        noise_power: processed_noise_power(params, config.modulation),
    })
}
