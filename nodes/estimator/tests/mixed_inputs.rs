//! One estimator fed a synthesised spectrum and then a resource grid (and back) must answer each
//! correctly: the spectrum path must not leave state that the grid path trips over.

use nrslam_estimator::{Estimator, EstimatorConfig};
use nrslam_ofdm::{spectral, waveform, OfdmParams, Scatterer};
use num_complex::Complex64;
use rand::SeedableRng;

#[test]
fn spectrum_then_grid_then_spectrum() {
    let params = OfdmParams {
        symbols: 1,
        subcarriers: 2048,
        antennas: 16,
        ..OfdmParams::default()
    };
    let scatterer = Scatterer {
        range_m: 10.0,
        angle_rad: 0.3,
        radial_velocity_mps: 0.0,
        amplitude: Complex64::new(1.0, 0.0),
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    let config = EstimatorConfig {
        max_range_m: Some(25.0),
        ..EstimatorConfig::default()
    };
    let mut estimator = Estimator::new(&params, config).unwrap();
    let map = spectral::synthesize(
        &params,
        &[scatterer],
        &spectral::SpectralConfig::default(),
        &mut rng,
    )
    .unwrap();
    let grid = waveform::synthesize(
        &params,
        &[scatterer],
        &waveform::WaveformConfig::default(),
        &mut rng,
    )
    .unwrap();
    for _ in 0..2 {
        for found in [
            estimator.process_spectrum(&map).unwrap(),
            estimator.process_grid(&grid).unwrap(),
        ] {
            let best = found.first().expect("the echo is found");
            assert!(
                (best.range_m - 10.0).abs() < params.range_bin_m(),
                "{best:?}"
            );
            assert!(
                (best.angle_rad.sin() - 0.3f64.sin()).abs() < params.sine_bin(),
                "{best:?}"
            );
        }
    }
}
