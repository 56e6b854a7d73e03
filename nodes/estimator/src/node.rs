//! The estimator as a node: `/radar/spectrum` (`spectral` front end) or `/radar/echo`
//! (`waveform` front end) in, `/radar/detections` out (paper Sec. III-B).
//!
//! A `waveform` echo describes its own radar (carrier, Δf, N, M, K, spacing), so the estimator is
//! planned from the first echo and re-planned only if a later echo differs. A spectrum carries
//! only its bin sizes, so the node's `ofdm` parameters must be the front end's (the launch files
//! pass the same arguments to both).
//!
//! Each detection's `range_std_m` and `angle_std_rad` are the grid limits of the bin it fell in
//! (bin / √12), the honest spread of a DFT-grid estimate without refinement; after interpolation,
//! `interpolated_std_fraction` of them ([`published_detection`]).

use crate::{Estimator, EstimatorConfig, EstimatorError, RangeAngleDetection};
use nrslam_msgs::topics::{DETECTIONS, ECHO, SPECTRUM};
use nrslam_msgs::{Detection, Detections, Header, Message, RadarEcho, RadarSpectrum};
use nrslam_ofdm::{OfdmParams, RangeAngleSpectrum, ResourceGrid};
use nrslam_runtime::{InvalidParam, Node, NodeContext, NodeError, NodeResult, Outbox};
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// Which front-end output the node reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Input {
    /// `/radar/spectrum`: detection only.
    #[default]
    Spectral,
    /// `/radar/echo`: Y/X, IDFT, DFT, then detection.
    Waveform,
}

/// Parameters of the estimator node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Front-end output to read: `spectral` or `waveform`.
    pub input: Input,
    /// The radar (Table I, M = 1, as the front end's default); used to read spectra.
    pub ofdm: OfdmParams,
    /// Detection and refinement.
    pub estimator: EstimatorConfig,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            input: Input::Spectral,
            ofdm: OfdmParams {
                symbols: 1,
                ..OfdmParams::default()
            },
            // The hall's farthest echo is at 20 m: searching the whole 1249 m unambiguous range
            // would only add noise peaks and work.
            estimator: EstimatorConfig {
                max_range_m: Some(25.0),
                ..EstimatorConfig::default()
            },
        }
    }
}

impl Params {
    /// Checks every field; the error names it and its allowed range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        crate::validate_params(&self.ofdm)?;
        self.estimator
            .validate()
            .map_err(|e| InvalidParam::new(format!("estimator.{}", e.field), e.problem, e.allowed))
    }
}

/// The node.
pub struct EstimatorNode {
    params: Params,
    planned: Option<(OfdmParams, Estimator)>,
}

/// Builds the node.
pub fn build(params: Params, _ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    params.validate()?;
    let estimator =
        Estimator::new(&params.ofdm, params.estimator.clone()).map_err(NodeError::algorithm)?;
    Ok(Box::new(EstimatorNode {
        planned: Some((params.ofdm, estimator)),
        params,
    }))
}

fn complex(values: &[f64], topic: &str) -> Result<Vec<Complex64>, NodeError> {
    if !values.len().is_multiple_of(2) {
        return Err(NodeError::invalid_input(
            topic,
            format!("{} interleaved values is odd", values.len()),
        ));
    }
    Ok(values
        .chunks_exact(2)
        .map(|c| Complex64::new(c[0], c[1]))
        .collect())
}

impl EstimatorNode {
    fn estimator_for(&mut self, ofdm: OfdmParams) -> Result<&mut Estimator, NodeError> {
        if self
            .planned
            .as_ref()
            .is_none_or(|(planned, _)| *planned != ofdm)
        {
            let estimator = Estimator::new(&ofdm, self.params.estimator.clone())
                .map_err(NodeError::algorithm)?;
            self.planned = Some((ofdm, estimator));
        }
        Ok(&mut self.planned.as_mut().expect("planned above").1)
    }

    fn on_echo(&mut self, echo: &RadarEcho) -> Result<Vec<RangeAngleDetection>, NodeError> {
        let ofdm = OfdmParams {
            carrier_frequency_hz: echo.carrier_frequency_hz,
            subcarrier_spacing_hz: echo.subcarrier_spacing_hz,
            subcarriers: echo.subcarriers as usize,
            symbols: echo.symbols as usize,
            symbol_duration_s: echo.symbol_duration_s,
            antennas: echo.antennas as usize,
            antenna_spacing_wavelengths: echo.antenna_spacing_wavelengths,
            snr_db: echo.snr_db,
        };
        let grid = ResourceGrid {
            antennas: ofdm.antennas,
            symbols: ofdm.symbols,
            subcarriers: ofdm.subcarriers,
            received: complex(&echo.received, ECHO)?,
            transmitted: complex(&echo.transmitted, ECHO)?,
        };
        let estimator = self.estimator_for(ofdm)?;
        estimator.process_grid(&grid).map_err(|e| invalid(ECHO, e))
    }

    fn on_spectrum(
        &mut self,
        spectrum: &RadarSpectrum,
    ) -> Result<Vec<RangeAngleDetection>, NodeError> {
        let map = RangeAngleSpectrum {
            range_bins: spectrum.range_bins as usize,
            angle_bins: spectrum.angle_bins as usize,
            range_bin_m: spectrum.range_bin_m,
            values: complex(&spectrum.values, SPECTRUM)?,
            noise_power: spectrum.noise_power,
        };
        let ofdm = self.params.ofdm;
        let estimator = self.estimator_for(ofdm)?;
        estimator
            .process_spectrum(&map)
            .map_err(|e| invalid(SPECTRUM, e))
    }

    fn detections(
        &self,
        header: &Header,
        boresight_rad: f64,
        found: Vec<RangeAngleDetection>,
    ) -> Detections {
        let ofdm = self.planned.as_ref().map_or(self.params.ofdm, |(p, _)| *p);
        Detections {
            header: Header::new(header.stamp, "radar"),
            boresight_rad,
            detections: found
                .iter()
                .map(|d| published_detection(&ofdm, &self.params.estimator, d))
                .collect(),
        }
    }
}

/// A detection as `/radar/detections` carries it: the detection's own std when its method gives
/// one (super-resolution), else its resolution cell's std ([`cell_detection`]) times the
/// refinement's [`EstimatorConfig::published_std_fraction`].
pub fn published_detection(
    ofdm: &OfdmParams,
    config: &EstimatorConfig,
    found: &RangeAngleDetection,
) -> Detection {
    let cell = cell_detection(ofdm, found.range_m, found.angle_rad, found.power_db);
    if let Some(std) = found.std {
        return Detection {
            range_std_m: std.range_m,
            angle_std_rad: std.angle_rad,
            ..cell
        };
    }
    let fraction = config.published_std_fraction();
    Detection {
        range_std_m: cell.range_std_m * fraction,
        angle_std_rad: cell.angle_std_rad * fraction,
        ..cell
    }
}

/// A detection at `range_m` and `angle_rad` as `/radar/detections` carries it: with the standard
/// deviations of its resolution cell, Δr/√12 in range and Δ(sin θ)/√12 in the sine of the angle
/// (the grid limit of a peak at a bin centre, the paper's chain).
pub fn cell_detection(ofdm: &OfdmParams, range_m: f64, angle_rad: f64, power_db: f64) -> Detection {
    let sine_std = ofdm.sine_bin() / 12f64.sqrt();
    Detection {
        range_m,
        angle_rad,
        range_std_m: ofdm.range_bin_m() / 12f64.sqrt(),
        // dθ = d(sin θ) / cos θ, capped at endfire.
        angle_std_rad: (sine_std / angle_rad.cos().max(0.05)).min(std::f64::consts::FRAC_PI_2),
        power_db,
    }
}

fn invalid(topic: &str, error: EstimatorError) -> NodeError {
    NodeError::invalid_input(topic, error.to_string())
}

impl Node for EstimatorNode {
    fn inputs(&self) -> Vec<&'static str> {
        match self.params.input {
            Input::Spectral => vec![SPECTRUM],
            Input::Waveform => vec![ECHO],
        }
    }

    fn outputs(&self) -> Vec<&'static str> {
        vec![DETECTIONS]
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        let (header, boresight_rad, found) = match (topic, message) {
            (SPECTRUM, Message::RadarSpectrum(s)) => {
                (&s.header, s.boresight_rad, self.on_spectrum(s)?)
            }
            (ECHO, Message::RadarEcho(e)) => (&e.header, e.boresight_rad, self.on_echo(e)?),
            _ => return Err(NodeError::unexpected(topic, message)),
        };
        let detections = self.detections(header, boresight_rad, found);
        outbox.publish(DETECTIONS, detections);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Refinement;

    #[test]
    fn a_cell_detection_carries_its_cells_std() {
        let ofdm = OfdmParams::default();
        let broadside = cell_detection(&ofdm, 10.0, 0.0, -3.0);
        assert_eq!((broadside.range_m, broadside.power_db), (10.0, -3.0));
        assert!((broadside.range_std_m - ofdm.range_bin_m() / 12f64.sqrt()).abs() < 1e-15);
        assert!((broadside.angle_std_rad - ofdm.sine_bin() / 12f64.sqrt()).abs() < 1e-15);
        // A sine bin spans twice the angle at 60° off broadside (dθ = d(sin θ) / cos θ)...
        let off = cell_detection(&ofdm, 10.0, 60f64.to_radians(), 0.0);
        assert!((off.angle_std_rad / broadside.angle_std_rad - 2.0).abs() < 1e-9);
        // ...and at endfire, where a small array's sine bin spans more than the half-plane, the
        // std is capped at π/2 instead of growing without bound.
        let two_antennas = OfdmParams {
            antennas: 2,
            ..OfdmParams::default()
        };
        let endfire = cell_detection(&two_antennas, 10.0, std::f64::consts::FRAC_PI_2, 0.0);
        assert_eq!(endfire.angle_std_rad, std::f64::consts::FRAC_PI_2);
    }

    #[test]
    fn only_interpolated_detections_are_published_finer_than_their_cell() {
        let ofdm = OfdmParams::default();
        let found = RangeAngleDetection {
            range_m: 10.0,
            angle_rad: 0.3,
            power_db: 0.0,
            range_bin: 82,
            angle_bin: 18,
            std: None,
        };
        let cell = cell_detection(&ofdm, found.range_m, found.angle_rad, found.power_db);
        let with = |refinement| EstimatorConfig {
            refinement,
            ..EstimatorConfig::default()
        };
        let plain = published_detection(&ofdm, &with(Refinement::None), &found);
        assert_eq!(plain, cell);
        let padded =
            published_detection(&ofdm, &with(Refinement::ZeroPadding { factor: 4 }), &found);
        assert_eq!(padded, cell);
        let config = with(Refinement::Interpolation);
        let refined = published_detection(&ofdm, &config, &found);
        let fraction = config.interpolated_std_fraction;
        assert!(fraction < 1.0);
        assert!((refined.range_std_m - fraction * cell.range_std_m).abs() < 1e-15);
        assert!((refined.angle_std_rad - fraction * cell.angle_std_rad).abs() < 1e-15);
        assert_eq!(
            (refined.range_m, refined.angle_rad),
            (cell.range_m, cell.angle_rad)
        );
        // A super-resolution method publishes its waves' own std, and a DFT peak it kept (no
        // wave passed in that bin) with its cell's.
        for method in [
            Refinement::Music { subarray: 0 },
            Refinement::Esprit { subarray: 0 },
            Refinement::Nomp,
        ] {
            assert_eq!(published_detection(&ofdm, &with(method), &found), cell);
            let own = crate::DetectionStd {
                range_m: 0.01,
                angle_rad: 0.002,
            };
            let wave = RangeAngleDetection {
                std: Some(own),
                ..found
            };
            let published = published_detection(&ofdm, &with(method), &wave);
            assert_eq!(
                (published.range_std_m, published.angle_std_rad),
                (own.range_m, own.angle_rad)
            );
        }
    }
}
