//! Shared helpers of the integration tests.
#![allow(dead_code)]

use nrslam_ofdm::spectral::{self, SpectralConfig};
use nrslam_ofdm::waveform::{self, WaveformConfig};
use nrslam_ofdm::{reference, FrameRng, OfdmParams, RangeAngleSpectrum, Scatterer};
use num_complex::Complex64;
use rand::SeedableRng;

/// Small params: Table I radio, N subcarriers, K antennas, M symbols.
pub fn small(n: usize, k: usize, m: usize) -> OfdmParams {
    OfdmParams {
        subcarriers: n,
        antennas: k,
        symbols: m,
        ..OfdmParams::default()
    }
}

pub fn scatterer(range_m: f64, angle_deg: f64, v: f64, amp: Complex64) -> Scatterer {
    Scatterer {
        range_m,
        angle_rad: angle_deg.to_radians(),
        radial_velocity_mps: v,
        amplitude: amp,
    }
}

pub fn noise_free_spectral() -> SpectralConfig {
    SpectralConfig {
        add_noise: false,
        ..SpectralConfig::default()
    }
}

/// The brute-force map of a noise-free waveform grid.
pub fn brute_force(
    params: &OfdmParams,
    scatterers: &[Scatterer],
    cfg: &SpectralConfig,
    seed: u64,
) -> RangeAngleSpectrum {
    let wcfg = WaveformConfig {
        add_noise: false,
        modulation: cfg.modulation,
        ..WaveformConfig::default()
    };
    let mut rng = FrameRng::seed_from_u64(seed);
    let grid = waveform::synthesize(params, scatterers, &wcfg, &mut rng).unwrap();
    reference::process(&grid, params, cfg).unwrap()
}

/// Asserts spectral == brute force in every window cell of a single scatterer, to `tol`
/// relative to the scatterer's peak |a| K. Returns the number of cells compared.
pub fn assert_equivalent(
    params: &OfdmParams,
    s: &Scatterer,
    cfg: &SpectralConfig,
    tol: f64,
) -> usize {
    let mut rng = FrameRng::seed_from_u64(1);
    let spec = spectral::synthesize(params, &[*s], cfg, &mut rng).unwrap();
    let brute = brute_force(params, &[*s], cfg, 2);
    assert_eq!(
        (spec.range_bins, spec.angle_bins),
        (brute.range_bins, brute.angle_bins)
    );
    let scale = s.amplitude.norm() * params.antennas as f64;
    let (rw, aw) = spectral::window_bins(params, cfg, s);
    let mut worst: f64 = 0.0;
    for &i in &rw {
        for &j in &aw {
            let (a, b) = (spec.at(i, j), brute.at(i, j));
            worst = worst.max((a - b).norm() / scale);
            assert!(
                (a - b).norm() <= tol * scale,
                "cell ({i},{j}): spectral {a} vs brute force {b}, diff {:e} > {tol:e} x {scale}",
                (a - b).norm()
            );
        }
    }
    if std::env::var_os("OFDM_TEST_VERBOSE").is_some() {
        eprintln!(
            "max relative difference {worst:e} over {} cells",
            rw.len() * aw.len()
        );
    }
    rw.len() * aw.len()
}
