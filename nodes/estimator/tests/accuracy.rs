//! The FFT path against a direct O(N²) DFT (the oracle), and the accuracy of each refinement
//! against the DFT-grid limit Δr/√12.

mod common;

use common::{grid, params, sine_error, Echo};
use nrslam_estimator::{Estimator, EstimatorConfig, Refinement};
use nrslam_ofdm::{OfdmParams, ResourceGrid};
use num_complex::Complex64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// Direct evaluation: S = Y/X (X = 0 skipped), R = (1/N) Σ_n S e^{+j2π n i/N'},
/// V = (1/M) Σ_k Σ_m R e^{−j2π k q/A} e^{−j2π m d/M}, strongest d per cell, fftshifted angle.
fn oracle(g: &ResourceGrid, n_pad: usize, a: usize, rows: usize) -> Vec<Complex64> {
    let (k_n, m_n, n_n) = (g.antennas, g.symbols, g.subcarriers);
    let cis = |num: usize, den: usize, sign: f64| {
        Complex64::from_polar(1.0, sign * 2.0 * PI * (num % den) as f64 / den as f64)
    };
    let mut r = vec![Complex64::new(0.0, 0.0); k_n * m_n * rows];
    for k in 0..k_n {
        for m in 0..m_n {
            for i in 0..rows {
                let mut acc = Complex64::new(0.0, 0.0);
                for n in 0..n_n {
                    let x = g.transmitted[m * n_n + n];
                    if x.norm_sqr() == 0.0 {
                        continue;
                    }
                    acc += g.received[(k * m_n + m) * n_n + n] / x * cis(n * i, n_pad, 1.0);
                }
                r[(k * m_n + m) * rows + i] = acc / n_n as f64;
            }
        }
    }
    let mut out = vec![Complex64::new(0.0, 0.0); rows * a];
    for i in 0..rows {
        for q in 0..a {
            let mut best = (Complex64::new(0.0, 0.0), -1.0);
            for d in 0..m_n {
                let mut acc = Complex64::new(0.0, 0.0);
                for k in 0..k_n {
                    for m in 0..m_n {
                        acc += r[(k * m_n + m) * rows + i]
                            * cis(k * q, a, -1.0)
                            * cis(m * d, m_n, -1.0);
                    }
                }
                acc /= m_n as f64;
                if acc.norm_sqr() > best.1 {
                    best = (acc, acc.norm_sqr());
                }
            }
            out[i * a + (q + a / 2) % a] = best.0;
        }
    }
    out
}

fn check_against_oracle(p: &OfdmParams, cfg: EstimatorConfig, echoes: &[Echo]) {
    let n_pad = p.subcarriers * cfg.range_padding();
    let mut est = Estimator::new(p, cfg).unwrap();
    let mut g = grid(p, echoes, Some(10.0), 3);
    g.transmitted[2] = Complex64::new(0.0, 0.0);
    let map = est.range_angle_map(&g).unwrap();
    assert_eq!(map.angle_bins, est.angle_bins());
    let want = oracle(&g, n_pad, map.angle_bins, map.range_bins);
    let scale = want.iter().map(|v| v.norm()).fold(0.0, f64::max);
    for (idx, (got, w)) in map.values.iter().zip(&want).enumerate() {
        assert!(
            (got - w).norm() <= 1e-10 * scale,
            "cell {idx}: fft {got} vs direct {w}"
        );
    }
}

#[test]
fn fft_path_matches_the_direct_dft() {
    let p = params(64, 8, 1);
    let dr = p.range_bin_m();
    let echoes = [
        Echo::at_sine(10.3 * dr, 0.4),
        Echo::at_sine(40.0 * dr, -0.8),
    ];
    check_against_oracle(&p, EstimatorConfig::default(), &echoes);
    check_against_oracle(
        &p,
        EstimatorConfig {
            refinement: Refinement::ZeroPadding { factor: 2 },
            zero_padding_angle: 2,
            max_range_m: Some(30.0 * dr),
            ..EstimatorConfig::default()
        },
        &echoes,
    );
    // Odd sizes, and Doppler over symbols.
    check_against_oracle(&params(63, 5, 1), EstimatorConfig::default(), &echoes);
    let moving = Echo {
        velocity_mps: 20.0,
        ..echoes[0]
    };
    check_against_oracle(
        &params(64, 4, 3),
        EstimatorConfig::default(),
        &[moving, echoes[1]],
    );
}

/// RMS range and sine errors of the strongest detection over `trials` random echoes.
fn rms_errors(cfg: EstimatorConfig, snr: f64, trials: usize) -> (f64, f64, f64) {
    let p = params(256, 8, 1);
    let dr = p.range_bin_m();
    let mut est = Estimator::new(&p, cfg).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let (mut se_r, mut se_s, mut worst) = (0.0, 0.0, 0.0f64);
    for t in 0..trials {
        let e = Echo::at_sine(
            rng.random_range(10.0..200.0) * dr,
            rng.random_range(-0.8..0.8),
        );
        let det = est
            .process_grid(&grid(&p, &[e], Some(snr), t as u64))
            .unwrap();
        let err = det[0].range_m - e.range_m;
        worst = worst.max(err.abs());
        se_r += err * err;
        se_s += sine_error(det[0].angle_rad, e.angle_rad).powi(2);
    }
    let n = trials as f64;
    ((se_r / n).sqrt(), (se_s / n).sqrt(), worst)
}

#[test]
fn without_refinement_the_error_is_the_grid_limit() {
    let p = params(256, 8, 1);
    let grid_rms = p.range_bin_m() / 12f64.sqrt();
    let (rms, sine_rms, worst) = rms_errors(EstimatorConfig::default(), 60.0, 600);
    assert!(worst <= 0.5 * p.range_bin_m() + 1e-9, "worst {worst}");
    assert!(
        (rms / grid_rms - 1.0).abs() < 0.2,
        "rms {rms} vs grid {grid_rms}"
    );
    let sine_grid = p.sine_bin() / 12f64.sqrt();
    assert!(
        (sine_rms / sine_grid - 1.0).abs() < 0.2,
        "sine rms {sine_rms} vs {sine_grid}"
    );
}

#[test]
fn refinement_beats_the_grid_limit_five_times_at_30_db() {
    let p = params(256, 8, 1);
    let grid_rms = p.range_bin_m() / 12f64.sqrt();
    let interp = EstimatorConfig {
        refinement: Refinement::Interpolation,
        ..Default::default()
    };
    let (rms, sine_rms, _) = rms_errors(interp, 30.0, 300);
    assert!(
        rms < grid_rms / 5.0,
        "interpolation rms {rms} vs grid {grid_rms}"
    );
    assert!(
        sine_rms < p.sine_bin() / 12f64.sqrt() / 5.0,
        "sine rms {sine_rms}"
    );
    let padded = EstimatorConfig {
        refinement: Refinement::ZeroPadding { factor: 8 },
        ..Default::default()
    };
    let (rms_pad, _, _) = rms_errors(padded, 30.0, 300);
    assert!(
        rms_pad < grid_rms / 5.0,
        "zero-padding rms {rms_pad} vs grid {grid_rms}"
    );
    eprintln!("grid {grid_rms:.3e} m, interpolation {rms:.3e} m, zero padding ×8 {rms_pad:.3e} m");
}
