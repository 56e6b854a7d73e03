//! The single-scatterer trials of `nrslam accuracy` (shared with `nrslam tradeoff`) and the
//! `--refine` parser.

use super::Tally;
use anyhow::{anyhow, bail, Result};
use nrslam_estimator::{Estimator, EstimatorConfig, Refinement};
use nrslam_ofdm::{bounds, spectral, waveform, OfdmParams, Scatterer};
use num_complex::Complex64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The estimator's sub-bin refinement and its zero-padding factor from `--refine` text
/// ([`Refinement::NAMES`]).
pub(crate) fn parse_refinement(text: &str) -> Result<(Refinement, usize)> {
    match Refinement::from_name(text) {
        Some(Refinement::ZeroPadding { factor }) if (1..=64).contains(&factor) => {
            Ok((Refinement::ZeroPadding { factor }, factor))
        }
        Some(Refinement::ZeroPadding { .. }) | None => bail!(
            "--refine: {text:?} is not a refinement (allowed: {})",
            Refinement::NAMES
        ),
        Some(refinement) => Ok((refinement, 1)),
    }
}

/// Runs `trials` single-scatterer frames at `params` (spectral, or waveform when
/// `waveform_level`) through the estimator and sums the errors of its strongest detection.
/// Trial t is seeded from (seed, `label`/t). `tick` is called after each trial.
#[allow(clippy::too_many_arguments)]
pub(crate) fn single_scatterer_trials(
    params: &OfdmParams,
    waveform_level: bool,
    refinement: Refinement,
    padding: usize,
    trials: u32,
    seed: u64,
    label: &str,
    tick: &(dyn Fn() + Sync),
) -> Result<Tally> {
    let config = EstimatorConfig {
        refinement,
        zero_padding_angle: padding,
        max_range_m: Some(25.0),
        max_detections: 1,
        ..EstimatorConfig::default()
    };
    let spectral_config = spectral::SpectralConfig {
        max_range_m: 25.0,
        range_zero_padding: padding,
        angle_zero_padding: padding,
        // A super-resolution method reads each array row back into the K elements' samples:
        // every angle bin must be evaluated (spectral::SpectralConfig::angle_window_cells).
        angle_window_cells: refinement
            .is_super_resolution()
            .then(|| params.antennas.div_ceil(2)),
        ..spectral::SpectralConfig::default()
    };
    let mut estimator = Estimator::new(params, config).map_err(|e| anyhow!("estimator: {e}"))?;
    let mut tally = Tally::default();
    for trial in 0..trials {
        let mut rng = ChaCha8Rng::seed_from_u64(nrslam_runtime::seed::derive(
            seed,
            &format!("{label}/{trial}"),
        ));
        let range_m = rng.random_range(2.0..20.0);
        let angle_rad = rng.random_range(-60f64.to_radians()..60f64.to_radians());
        let scatterer = Scatterer {
            range_m,
            angle_rad,
            radial_velocity_mps: 0.0,
            amplitude: Complex64::from_polar(1.0, rng.random_range(0.0..std::f64::consts::TAU)),
        };
        let found = if waveform_level {
            let grid = waveform::synthesize(
                params,
                &[scatterer],
                &waveform::WaveformConfig::default(),
                &mut rng,
            )?;
            estimator.process_grid(&grid)
        } else {
            let map = spectral::synthesize(params, &[scatterer], &spectral_config, &mut rng)?;
            estimator.process_spectrum(&map)
        }
        .map_err(|e| anyhow!("estimator: {e}"))?;
        tally.crb_angle_sq += bounds::angle_variance_bound_rad2(params, angle_rad);
        tally.grid_angle_sq += bounds::angle_grid_rms_rad(params, angle_rad, padding).powi(2);
        match found.first() {
            Some(d) => {
                tally.range_sq_m2 += (d.range_m - range_m).powi(2);
                tally.angle_sq_rad2 += (d.angle_rad - angle_rad).powi(2);
                tally.hits += 1;
            }
            None => tally.misses += 1,
        }
        tick();
    }
    Ok(tally)
}
