//! `spectral` and `waveform` agree statistically: for the same scatterers, the range and angle
//! errors of the estimator have the same spread (within 10 %) and the same mean (within 10 % of
//! that spread), with and without refinement. Small N and K keep the waveform path quick; the
//! equality is a property of the model, not of the sizes.

use nrslam_estimator::{Estimator, EstimatorConfig, Refinement};
use nrslam_ofdm::{spectral, waveform, OfdmParams, Scatterer};
use num_complex::Complex64;
use rand::{Rng, SeedableRng};

fn errors(waveform_level: bool, refinement: Refinement, snr_db: f64) -> (Vec<f64>, Vec<f64>) {
    let params = OfdmParams {
        subcarriers: 1024,
        antennas: 8,
        symbols: 1,
        snr_db,
        ..OfdmParams::default()
    };
    let config = EstimatorConfig {
        refinement,
        max_range_m: Some(25.0),
        max_detections: 1,
        ..EstimatorConfig::default()
    };
    let mut estimator = Estimator::new(&params, config).unwrap();
    let mut scene = rand_chacha::ChaCha8Rng::seed_from_u64(11);
    let mut noise = rand_chacha::ChaCha8Rng::seed_from_u64(if waveform_level { 12 } else { 13 });
    let (mut range_errors, mut angle_errors) = (Vec::new(), Vec::new());
    for _ in 0..600 {
        let s = Scatterer {
            range_m: scene.random_range(3.0..20.0),
            angle_rad: scene.random_range(-1.0..1.0),
            radial_velocity_mps: 0.0,
            amplitude: Complex64::from_polar(1.0, scene.random_range(0.0..std::f64::consts::TAU)),
        };
        let found = if waveform_level {
            let grid = waveform::synthesize(
                &params,
                &[s],
                &waveform::WaveformConfig::default(),
                &mut noise,
            )
            .unwrap();
            estimator.process_grid(&grid).unwrap()
        } else {
            let map = spectral::synthesize(
                &params,
                &[s],
                &spectral::SpectralConfig::default(),
                &mut noise,
            )
            .unwrap();
            estimator.process_spectrum(&map).unwrap()
        };
        let best = found.first().expect("one echo, found");
        range_errors.push(best.range_m - s.range_m);
        angle_errors.push(best.angle_rad - s.angle_rad);
    }
    (range_errors, angle_errors)
}

fn mean_std(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    (
        mean,
        (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt(),
    )
}

fn assert_agree(label: &str, spectral: &[f64], waveform: &[f64]) {
    let (ms, ss) = mean_std(spectral);
    let (mw, sw) = mean_std(waveform);
    assert!(
        (ss / sw - 1.0).abs() < 0.10,
        "{label}: std spectral {ss:e} waveform {sw:e}"
    );
    assert!(
        (ms - mw).abs() < 0.10 * ss.max(sw),
        "{label}: mean spectral {ms:e} waveform {mw:e} (std {ss:e})"
    );
}

#[test]
fn grid_limited_errors_agree() {
    let (rs, a_s) = errors(false, Refinement::None, 10.0);
    let (rw, aw) = errors(true, Refinement::None, 10.0);
    assert_agree("range, none", &rs, &rw);
    assert_agree("angle, none", &a_s, &aw);
}

#[test]
fn noise_limited_errors_agree() {
    // At −10 dB per element (29 dB after N·K processing) interpolation is noise-limited.
    let (rs, a_s) = errors(false, Refinement::Interpolation, -10.0);
    let (rw, aw) = errors(true, Refinement::Interpolation, -10.0);
    assert_agree("range, interpolation", &rs, &rw);
    assert_agree("angle, interpolation", &a_s, &aw);
}
