//! Validation of [`OfdmParams`]: hard errors ([`OfdmParams::validate`]) and soft, reported
//! departures from 5G NR ([`OfdmParams::warnings`]).

use crate::{OfdmError, OfdmParams};
use std::fmt;

/// Largest channel bandwidth of one NR carrier in FR2-1 (24.25–52.6 GHz), 3GPP TS 38.101-2:
/// 400 MHz (at 120 kHz subcarrier spacing, 264 resource blocks).
pub const NR_FR2_MAX_CARRIER_BANDWIDTH_HZ: f64 = 400e6;

/// Largest subcarrier count N accepted (2^24): beyond it f64 phase bookkeeping and memory are
/// both unreasonable.
pub const MAX_SUBCARRIERS: usize = 1 << 24;

/// A departure from 5G NR that the signal model tolerates but a reader should know about.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamWarning {
    /// N·Δf exceeds the 400 MHz of one NR carrier in FR2-1 (Table I's 1.23 GHz does: it needs
    /// carrier aggregation of at least four carriers, or a non-NR waveform).
    BandwidthExceedsNrCarrier {
        /// N·Δf (Hz).
        bandwidth_hz: f64,
        /// One NR carrier's maximum (Hz).
        nr_max_hz: f64,
    },
    /// Δf is not an NR numerology 15·2^μ kHz, μ = 0..6.
    NonNrSubcarrierSpacing {
        /// Δf (Hz).
        subcarrier_spacing_hz: f64,
    },
    /// d > λ/2: the array has grating lobes, so sin θ is ambiguous within [−1, 1].
    GratingLobes {
        /// d/λ.
        antenna_spacing_wavelengths: f64,
    },
}

impl fmt::Display for ParamWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BandwidthExceedsNrCarrier {
                bandwidth_hz,
                nr_max_hz,
            } => write!(
                f,
                "bandwidth N*subcarrier_spacing = {:.1} MHz exceeds one NR FR2 carrier \
                 ({:.0} MHz, TS 38.101-2); the model treats it as one contiguous band",
                bandwidth_hz / 1e6,
                nr_max_hz / 1e6
            ),
            Self::NonNrSubcarrierSpacing {
                subcarrier_spacing_hz,
            } => write!(
                f,
                "subcarrier_spacing_hz = {subcarrier_spacing_hz} is not an NR numerology \
                 (15 kHz * 2^mu, mu = 0..6)"
            ),
            Self::GratingLobes {
                antenna_spacing_wavelengths,
            } => write!(
                f,
                "antenna_spacing_wavelengths = {antenna_spacing_wavelengths} > 0.5: grating \
                 lobes, angles are ambiguous"
            ),
        }
    }
}

fn bad(field: &'static str, value: impl fmt::Display, allowed: &'static str) -> OfdmError {
    OfdmError::InvalidParameter {
        field,
        value: value.to_string(),
        allowed,
    }
}

impl OfdmParams {
    /// Checks every field; the error names the first bad field and its allowed range.
    ///
    /// - `carrier_frequency_hz`: finite, > 0
    /// - `subcarrier_spacing_hz`: finite, > 0
    /// - `subcarriers`: 1 ..= 2^24
    /// - `symbols`, `antennas`: ≥ 1
    /// - `symbol_duration_s`: finite, ≥ 1/Δf (T = T_p + T_c with T_p = 1/Δf)
    /// - `antenna_spacing_wavelengths`: finite, > 0
    /// - `snr_db`: finite, in [−300, 300]
    /// - the band N·Δf must lie below f_c (a baseband model of a passband signal)
    pub fn validate(&self) -> Result<(), OfdmError> {
        let pos = |x: f64| x.is_finite() && x > 0.0;
        if !pos(self.carrier_frequency_hz) {
            return Err(bad(
                "carrier_frequency_hz",
                self.carrier_frequency_hz,
                "a finite frequency > 0 Hz",
            ));
        }
        if !pos(self.subcarrier_spacing_hz) {
            return Err(bad(
                "subcarrier_spacing_hz",
                self.subcarrier_spacing_hz,
                "a finite spacing > 0 Hz",
            ));
        }
        if !(1..=MAX_SUBCARRIERS).contains(&self.subcarriers) {
            return Err(bad("subcarriers", self.subcarriers, "1 ..= 16777216"));
        }
        if self.symbols == 0 {
            return Err(bad("symbols", self.symbols, ">= 1"));
        }
        let min_t = 1.0 / self.subcarrier_spacing_hz;
        if !(self.symbol_duration_s.is_finite() && self.symbol_duration_s >= min_t * (1.0 - 1e-9)) {
            return Err(bad(
                "symbol_duration_s",
                self.symbol_duration_s,
                "a finite duration >= 1/subcarrier_spacing_hz (symbol plus cyclic prefix)",
            ));
        }
        if self.antennas == 0 {
            return Err(bad("antennas", self.antennas, ">= 1"));
        }
        if !pos(self.antenna_spacing_wavelengths) {
            return Err(bad(
                "antenna_spacing_wavelengths",
                self.antenna_spacing_wavelengths,
                "a finite spacing > 0 wavelengths",
            ));
        }
        if !(self.snr_db.is_finite() && self.snr_db.abs() <= 300.0) {
            return Err(bad("snr_db", self.snr_db, "a finite SNR in [-300, 300] dB"));
        }
        if self.bandwidth_hz() >= self.carrier_frequency_hz {
            return Err(bad(
                "subcarriers",
                self.subcarriers,
                "subcarriers * subcarrier_spacing_hz below carrier_frequency_hz",
            ));
        }
        Ok(())
    }

    /// Departures from 5G NR that are reported, not refused. At the Table I defaults this
    /// reports [`ParamWarning::BandwidthExceedsNrCarrier`]: N·Δf = 1.23 GHz exceeds the 400 MHz
    /// of one NR carrier in FR2 (TS 38.101-2); the paper's band is a contiguous aggregate.
    pub fn warnings(&self) -> Vec<ParamWarning> {
        let mut out = Vec::new();
        if self.bandwidth_hz() > NR_FR2_MAX_CARRIER_BANDWIDTH_HZ {
            out.push(ParamWarning::BandwidthExceedsNrCarrier {
                bandwidth_hz: self.bandwidth_hz(),
                nr_max_hz: NR_FR2_MAX_CARRIER_BANDWIDTH_HZ,
            });
        }
        let nr =
            (0..=6).any(|mu| (self.subcarrier_spacing_hz - 15e3 * f64::from(1 << mu)).abs() < 1e-6);
        if !nr {
            out.push(ParamWarning::NonNrSubcarrierSpacing {
                subcarrier_spacing_hz: self.subcarrier_spacing_hz,
            });
        }
        if self.antenna_spacing_wavelengths > 0.5 {
            out.push(ParamWarning::GratingLobes {
                antenna_spacing_wavelengths: self.antenna_spacing_wavelengths,
            });
        }
        out
    }
}
