//! The reference processing of a [`ResourceGrid`] by direct DFTs (no FFT): the oracle that
//! [`crate::spectral`] is checked against and that an FFT estimator can be checked against.
//!
//! Steps (crate docs, paper eq. (OFDM_signal_1), (OFDM_signal_33), (AOA_1_1_2)):
//! S(k,m,n) = Y/X; S̄(k,n) = (1/M) Σ_m S (zero-Doppler cut);
//! R(k,i) = (1/N) Σ_n S̄(k,n) e^{+j2π n i/(N P_r)} for the kept range bins;
//! V(i,j) = Σ_k R(k,i) e^{−j2π k q/A}, q = j − ⌊A/2⌋ (mod A), A = K P_a.
//! Twiddles are indexed by (n·i) mod (N P_r) in integers, so they are exact to one rounding.
//!
//! Cost O(K·M·N + K·N·range_bins + range_bins·A·K): Table I, 20 m, M = 1 is 54 M complex
//! multiply-adds. For tests and validation, not for the real-time path.

use crate::phase::cis_turns;
use crate::spectral::{empty_spectrum, total_range_bins, SpectralConfig};
use crate::{OfdmError, OfdmParams, RangeAngleSpectrum, ResourceGrid};
use num_complex::Complex64;

/// Processes `grid` into the range × angle map laid out as [`crate::spectral::synthesize`]'s
/// (same bins, same normalisation). `noise_power` is set to the expected processed noise power
/// for `config.modulation`, which should be the grid's.
pub fn process(
    grid: &ResourceGrid,
    params: &OfdmParams,
    config: &SpectralConfig,
) -> Result<RangeAngleSpectrum, OfdmError> {
    params.validate()?;
    config.validate()?;
    let (k_n, m_n, n_n) = (params.antennas, params.symbols, params.subcarriers);
    if (grid.antennas, grid.symbols, grid.subcarriers) != (k_n, m_n, n_n)
        || grid.received.len() != k_n * m_n * n_n
        || grid.transmitted.len() != m_n * n_n
    {
        return Err(OfdmError::GridMismatch(format!(
            "grid is {}x{}x{} (K x M x N) with {} received and {} transmitted values, params \
             want {k_n}x{m_n}x{n_n}",
            grid.antennas,
            grid.symbols,
            grid.subcarriers,
            grid.received.len(),
            grid.transmitted.len()
        )));
    }
    if let Some(pos) = grid.transmitted.iter().position(|x| x.norm_sqr() == 0.0) {
        return Err(OfdmError::GridMismatch(format!(
            "X(m={}, n={}) = 0: Y/X undefined",
            pos / n_n,
            pos % n_n
        )));
    }
    let mut spectrum = empty_spectrum(params, config)?;
    let (rb, ab) = (spectrum.range_bins, spectrum.angle_bins);

    // S̄(k, n): Y/X averaged over the symbols.
    let mut s_bar = vec![Complex64::new(0.0, 0.0); k_n * n_n];
    for k in 0..k_n {
        for m in 0..m_n {
            for n in 0..n_n {
                s_bar[k * n_n + n] += grid.received[grid.received_index(k, m, n)]
                    / grid.transmitted[grid.transmitted_index(m, n)];
            }
        }
    }
    let inv_m = 1.0 / m_n as f64;
    s_bar.iter_mut().for_each(|v| *v *= inv_m);

    // Range IDFT with exact twiddles e^{+j2π t/(N P_r)}.
    let total = total_range_bins(params, config);
    let tw_r: Vec<Complex64> = (0..total)
        .map(|t| cis_turns(t as f64 / total as f64))
        .collect();
    let mut r = vec![Complex64::new(0.0, 0.0); k_n * rb];
    let inv_n = 1.0 / n_n as f64;
    for k in 0..k_n {
        let row = &s_bar[k * n_n..][..n_n];
        for i in 0..rb {
            let mut acc = Complex64::new(0.0, 0.0);
            let mut t = 0usize; // (n·i) mod total, stepped without overflow
            for v in row {
                acc += v * tw_r[t];
                t += i;
                if t >= total {
                    t -= total;
                }
            }
            r[k * rb + i] = acc * inv_n;
        }
    }

    // Angle DFT with twiddles e^{−j2π t/A}, fftshifted output.
    let tw_a: Vec<Complex64> = (0..ab)
        .map(|t| cis_turns(-(t as f64) / ab as f64))
        .collect();
    for i in 0..rb {
        for j in 0..ab {
            let q = (j + ab - ab / 2) % ab;
            let mut acc = Complex64::new(0.0, 0.0);
            for k in 0..k_n {
                acc += r[k * rb + i] * tw_a[(k * q) % ab];
            }
            spectrum.values[i * ab + j] = acc;
        }
    }
    Ok(spectrum)
}
