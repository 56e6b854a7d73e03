//! Accuracy limits for range and angle estimates (docs/design.md): the Cramér–Rao bounds of a single
//! tone in white noise, and the RMS error of picking the nearest DFT bin.
//!
//! At Table I (SNR 10 dB, N 10240, M 256, K 32) the range CRB is about 9 µm and the angle CRB at
//! broadside about 0.8 µrad, while the grid limits are 3.5 cm and 18 mrad: the DFT grid, not
//! noise, limits a peak-picking estimator.
//!
//! SNR here is linear, per element and resource element ([`OfdmParams::snr_linear`]).

use crate::{OfdmParams, SPEED_OF_LIGHT_M_PER_S as C};
use std::f64::consts::PI;

/// Range CRB var(R) ≥ 3c² / (8π² Δf² SNR M N(N²−1)) (m²): one element's N·M resource elements
/// (the frequency-estimation bound 6/(SNR·M·N(N²−1)) on the phase slope 4πΔf/c per metre).
/// With all K elements combined coherently divide by K ([`range_variance_bound_array_m2`]).
pub fn range_variance_bound_m2(params: &OfdmParams) -> f64 {
    let n = params.subcarriers as f64;
    let m = params.symbols as f64;
    let df = params.subcarrier_spacing_hz;
    3.0 * C * C / (8.0 * PI * PI * df * df * params.snr_linear() * m * n * (n * n - 1.0))
}

/// [`range_variance_bound_m2`] / K: the range CRB using all K elements (m²).
pub fn range_variance_bound_array_m2(params: &OfdmParams) -> f64 {
    range_variance_bound_m2(params) / params.antennas as f64
}

/// √[`range_variance_bound_m2`] (m).
pub fn range_std_bound_m(params: &OfdmParams) -> f64 {
    range_variance_bound_m2(params).sqrt()
}

/// Angle CRB var(θ) ≥ 6 / (SNR_eff K(K²−1) (2π d/λ cos θ)²), SNR_eff = SNR·N·M (rad²), θ from
/// boresight. +∞ at endfire (cos θ = 0) and for K = 1.
pub fn angle_variance_bound_rad2(params: &OfdmParams, angle_rad: f64) -> f64 {
    let k = params.antennas as f64;
    let snr_eff = params.snr_linear() * params.subcarriers as f64 * params.symbols as f64;
    let slope = 2.0 * PI * params.antenna_spacing_wavelengths * angle_rad.cos();
    let den = snr_eff * k * (k * k - 1.0) * slope * slope;
    if den > 0.0 {
        6.0 / den
    } else {
        f64::INFINITY
    }
}

/// √[`angle_variance_bound_rad2`] (rad).
pub fn angle_std_bound_rad(params: &OfdmParams, angle_rad: f64) -> f64 {
    angle_variance_bound_rad2(params, angle_rad).sqrt()
}

/// RMS error of the nearest range bin, Δr/√12 with Δr = c/(2NΔf)/P (m): 3.5 cm at Table I.
pub fn range_grid_rms_m(params: &OfdmParams, zero_padding: usize) -> f64 {
    params.range_bin_m() / zero_padding.max(1) as f64 / 12f64.sqrt()
}

/// RMS error of the nearest angle bin in sin θ: (1/(K·P·d/λ))/√12 (0.018 at Table I).
pub fn sine_grid_rms(params: &OfdmParams, zero_padding: usize) -> f64 {
    params.sine_bin() / zero_padding.max(1) as f64 / 12f64.sqrt()
}

/// RMS error of the nearest angle bin in θ at `angle_rad`, to first order
/// [`sine_grid_rms`]/cos θ (rad): 0.018 rad = 1.03° at broadside for Table I. The first-order
/// form diverges towards endfire (+∞ at cos θ = 0), where it no longer describes the error.
pub fn angle_grid_rms_rad(params: &OfdmParams, angle_rad: f64, zero_padding: usize) -> f64 {
    let c = angle_rad.cos().abs();
    if c > 0.0 {
        sine_grid_rms(params, zero_padding) / c
    } else {
        f64::INFINITY
    }
}
