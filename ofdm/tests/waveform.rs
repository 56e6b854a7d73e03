//! `waveform`: noise level, phase accuracy, sign conventions, determinism, memory cap.

mod common;

use common::*;
use nrslam_ofdm::waveform::{self, WaveformConfig};
use nrslam_ofdm::{FrameRng, Modulation, OfdmError, OfdmParams, ResourceGrid};
use num_complex::Complex64;
use proptest::prelude::*;
use rand::SeedableRng;
use std::f64::consts::PI;

fn noise_free() -> WaveformConfig {
    WaveformConfig {
        add_noise: false,
        ..WaveformConfig::default()
    }
}

fn s_over_x(g: &ResourceGrid, k: usize, m: usize, n: usize) -> Complex64 {
    g.received[g.received_index(k, m, n)] / g.transmitted[g.transmitted_index(m, n)]
}

/// Wrapped difference of two phases (rad), in [−π, π].
fn phase_diff(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(2.0 * PI);
    if d > PI {
        d - 2.0 * PI
    } else {
        d
    }
}

#[test]
fn noise_power_matches_snr() {
    for snr_db in [10.0, -5.0] {
        let p = OfdmParams {
            snr_db,
            ..small(4096, 4, 2)
        };
        let mut rng = FrameRng::seed_from_u64(7);
        let g = waveform::synthesize(&p, &[], &WaveformConfig::default(), &mut rng).unwrap();
        let n = g.received.len() as f64;
        let power = g.received.iter().map(|z| z.norm_sqr()).sum::<f64>() / n;
        let re = g.received.iter().map(|z| z.re * z.re).sum::<f64>() / n;
        let mean = g.received.iter().sum::<Complex64>() / n;
        let sigma2 = 10f64.powf(-snr_db / 10.0);
        assert!((waveform::noise_variance(&p) - sigma2).abs() < 1e-15);
        // 32768 samples: relative std of the estimate 0.55 %.
        assert!(
            (power / sigma2 - 1.0).abs() < 0.03,
            "snr {snr_db}: {power} vs {sigma2}"
        );
        assert!(
            (re / (sigma2 / 2.0) - 1.0).abs() < 0.04,
            "circular: re power {re}"
        );
        assert!(mean.norm() < 0.03 * sigma2.sqrt(), "zero mean: {mean}");
    }
}

#[test]
fn unit_echo_has_the_configured_snr() {
    // Signal power per element per resource element of |a| = 1 is exactly 1 for QPSK.
    let p = small(512, 2, 2);
    let s = scatterer(10.0, 20.0, 3.0, Complex64::new(0.6, 0.8));
    let mut rng = FrameRng::seed_from_u64(3);
    let g = waveform::synthesize(&p, &[s], &noise_free(), &mut rng).unwrap();
    for y in &g.received {
        assert!((y.norm_sqr() - 1.0).abs() < 1e-12);
    }
}

#[test]
fn qam16_has_unit_mean_power_and_documented_noise_enhancement() {
    let mut rng = FrameRng::seed_from_u64(5);
    let n = 200_000;
    let (mut p, mut inv) = (0.0, 0.0);
    for _ in 0..n {
        let x = Modulation::Qam16.draw(&mut rng);
        p += x.norm_sqr();
        inv += 1.0 / x.norm_sqr();
    }
    assert!((p / n as f64 - 1.0).abs() < 0.01);
    assert!((inv / n as f64 / Modulation::Qam16.noise_enhancement() - 1.0).abs() < 0.01);
    let q = Modulation::Qpsk.draw(&mut rng);
    assert!((q.norm_sqr() - 1.0).abs() < 1e-15);
}

/// Exact subcarrier phase in turns for integer Δf (Hz), r (m), c (m/s): frac(n Δf 2r / c),
/// from integer arithmetic.
fn exact_range_turns(n: u128, df_hz: u128, r_m: u128) -> f64 {
    let c = 299_792_458u128;
    let num = n * df_hz * 2 * r_m;
    (num % c) as f64 / c as f64
}

#[test]
fn subcarrier_phase_ramp_does_not_drift_over_table_i_at_one_kilometre() {
    let p = small(10240, 1, 1);
    let s = scatterer(1000.0, 0.0, 0.0, Complex64::new(1.0, 0.0));
    let mut rng = FrameRng::seed_from_u64(9);
    let g = waveform::synthesize(&p, &[s], &noise_free(), &mut rng).unwrap();
    let mut worst: f64 = 0.0;
    for n in 0..10240 {
        let expected = -2.0 * PI * exact_range_turns(n as u128, 120_000, 1000);
        let got = s_over_x(&g, 0, 0, n).arg();
        worst = worst.max(phase_diff(got, expected).abs());
    }
    let n = 10239;
    let at_last = phase_diff(
        s_over_x(&g, 0, 0, n).arg(),
        -2.0 * PI * exact_range_turns(n as u128, 120_000, 1000),
    );
    assert!(
        at_last.abs() < 1e-9,
        "phase error at n = 10239: {at_last:e} rad"
    );
    assert!(worst < 1e-9, "worst phase error {worst:e} rad");
    if std::env::var_os("OFDM_TEST_VERBOSE").is_some() {
        eprintln!("phase error: {at_last:e} rad at n = 10239, worst {worst:e} rad");
    }
}

#[test]
fn doppler_and_array_signs_follow_the_crate_conventions() {
    let p = small(16, 4, 3);
    let v = 5.0; // receding
    let theta = 30f64.to_radians();
    let s = scatterer(2.0, 30.0, v, Complex64::new(1.0, 0.0));
    let mut rng = FrameRng::seed_from_u64(1);
    let g = waveform::synthesize(&p, &[s], &noise_free(), &mut rng).unwrap();
    // Doppler: symbol 1 vs 0 at the same (k, n) turns by −2π T 2v f_c/c (receding lowers phase).
    let fd = p.symbol_duration_s * 2.0 * v * p.carrier_frequency_hz / 299_792_458.0;
    let d = (s_over_x(&g, 0, 1, 3) / s_over_x(&g, 0, 0, 3)).arg();
    assert!(
        phase_diff(d, -2.0 * PI * fd).abs() < 1e-12,
        "{d} vs {}",
        -2.0 * PI * fd
    );
    // Array: element 1 vs 0 turns by +π sin θ at d = λ/2 (counter-clockwise positive).
    let a = (s_over_x(&g, 1, 0, 3) / s_over_x(&g, 0, 0, 3)).arg();
    assert!(phase_diff(a, PI * theta.sin()).abs() < 1e-12);
    // Range: subcarrier 1 vs 0 turns by −2π Δf 2r/c.
    let r = (s_over_x(&g, 0, 0, 1) / s_over_x(&g, 0, 0, 0)).arg();
    assert!(phase_diff(r, -2.0 * PI * 120e3 * 4.0 / 299_792_458.0).abs() < 1e-12);
}

#[test]
fn zero_range_and_endfire_and_wrapped_range() {
    let p = small(64, 4, 1);
    let mut rng = FrameRng::seed_from_u64(1);
    let amp = Complex64::new(1.0, 0.0);
    // 0 m at broadside: Y/X = a everywhere.
    let g = waveform::synthesize(
        &p,
        &[scatterer(0.0, 0.0, 0.0, amp)],
        &noise_free(),
        &mut rng,
    )
    .unwrap();
    for k in 0..4 {
        for n in 0..64 {
            assert!((s_over_x(&g, k, 0, n) - amp).norm() < 1e-15);
        }
    }
    // Endfire ±90° at λ/2: element k alternates sign (e^{±jπk}), identical for both.
    for deg in [90.0, -90.0] {
        let g = waveform::synthesize(
            &p,
            &[scatterer(0.0, deg, 0.0, amp)],
            &noise_free(),
            &mut rng,
        )
        .unwrap();
        for k in 0..4 {
            let want = if k % 2 == 0 { 1.0 } else { -1.0 };
            assert!((s_over_x(&g, k, 0, 5) - Complex64::new(want, 0.0)).norm() < 1e-12);
        }
    }
    // At the unambiguous range the echo equals the one at 0 m; beyond, it wraps.
    let ru = p.unambiguous_range_m();
    let g1 = waveform::synthesize(
        &p,
        &[scatterer(ru + 3.0, 10.0, 0.0, amp)],
        &noise_free(),
        &mut rng,
    )
    .unwrap();
    let g2 = waveform::synthesize(
        &p,
        &[scatterer(3.0, 10.0, 0.0, amp)],
        &noise_free(),
        &mut rng,
    )
    .unwrap();
    for n in 0..64 {
        assert!((s_over_x(&g1, 2, 0, n) - s_over_x(&g2, 2, 0, n)).norm() < 1e-9);
    }
}

#[test]
fn same_seed_same_grid() {
    let p = small(128, 4, 2);
    let scene = [scatterer(5.0, 10.0, 1.0, Complex64::new(1.0, 0.5))];
    let run = |seed| {
        let mut rng = FrameRng::seed_from_u64(seed);
        waveform::synthesize(&p, &scene, &WaveformConfig::default(), &mut rng).unwrap()
    };
    assert_eq!(run(42), run(42));
    assert_ne!(run(42).received, run(43).received);
}

#[test]
fn table_i_frame_is_refused_above_the_cap_without_allocating() {
    let p = OfdmParams::default(); // M = 256: 86 M complex values
    assert_eq!(
        waveform::grid_complex_values(&p),
        Some(32 * 256 * 10240 + 256 * 10240)
    );
    let mut rng = FrameRng::seed_from_u64(0);
    let e = waveform::synthesize(&p, &[], &WaveformConfig::default(), &mut rng).unwrap_err();
    match &e {
        OfdmError::TooLarge {
            complex_values,
            bytes,
            ..
        } => {
            assert_eq!(*complex_values, 86_507_520);
            assert_eq!(*bytes, 86_507_520 * 16);
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
    assert!(e.to_string().contains("M = 1 suffices"), "{e}");
    // M = 1 of Table I fits the default cap.
    let p1 = OfdmParams { symbols: 1, ..p };
    let g = waveform::synthesize(&p1, &[], &WaveformConfig::default(), &mut rng).unwrap();
    assert_eq!(g.received.len(), 32 * 10240);
    // Overflowing dimensions are refused too, not wrapped.
    let huge = OfdmParams {
        symbols: usize::MAX / 2,
        ..p
    };
    assert_eq!(waveform::grid_complex_values(&huge), None);
    assert!(matches!(
        waveform::synthesize(&huge, &[], &WaveformConfig::default(), &mut rng),
        Err(OfdmError::TooLarge { .. })
    ));
}

#[test]
fn invalid_params_are_refused_before_synthesis() {
    let p = OfdmParams {
        subcarrier_spacing_hz: f64::NAN,
        ..small(16, 1, 1)
    };
    let mut rng = FrameRng::seed_from_u64(0);
    let e = waveform::synthesize(&p, &[], &WaveformConfig::default(), &mut rng).unwrap_err();
    assert!(matches!(
        e,
        OfdmError::InvalidParameter {
            field: "subcarrier_spacing_hz",
            ..
        }
    ));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

    /// The grid is linear in the scatterers: two at once equal the sum of each alone
    /// (same seed, so the same X).
    #[test]
    fn prop_superposition(
        r1 in 0.0f64..2000.0, r2 in 0.0f64..2000.0,
        a1 in -90.0f64..=90.0, a2 in -90.0f64..=90.0,
        v1 in -50.0f64..50.0,
    ) {
        let p = small(32, 3, 2);
        let s1 = scatterer(r1, a1, v1, Complex64::new(1.0, -0.5));
        let s2 = scatterer(r2, a2, 0.0, Complex64::new(-0.2, 2.0));
        let run = |sc: &[nrslam_ofdm::Scatterer]| {
            let mut rng = FrameRng::seed_from_u64(77);
            waveform::synthesize(&p, sc, &noise_free(), &mut rng).unwrap()
        };
        let (both, g1, g2) = (run(&[s1, s2]), run(&[s1]), run(&[s2]));
        for ((b, x), y) in both.received.iter().zip(&g1.received).zip(&g2.received) {
            prop_assert!((b - (x + y)).norm() < 1e-12);
        }
    }

    /// Every element equals the documented model computed directly from echo_phasor.
    #[test]
    fn prop_matches_the_documented_model(r in 0.0f64..1500.0, a in -90.0f64..=90.0, v in -50.0f64..50.0) {
        let p = small(40, 3, 3);
        let s = scatterer(r, a, v, Complex64::new(0.3, 0.4));
        let mut rng = FrameRng::seed_from_u64(5);
        let g = waveform::synthesize(&p, &[s], &noise_free(), &mut rng).unwrap();
        for k in 0..3 { for m in 0..3 { for n in 0..40 {
            let want = s.amplitude * g.transmitted[g.transmitted_index(m, n)]
                * waveform::echo_phasor(&p, &s, k, m, n);
            prop_assert!((g.received[g.received_index(k, m, n)] - want).norm() < 1e-12);
            // and the phasor's phase is the model's (range and Doppler negative, array positive)
            let turns = -(n as f64) * 120e3 * 2.0 * r / 299_792_458.0
                - (m as f64) * p.symbol_duration_s * 2.0 * v * 28e9 / 299_792_458.0
                + (k as f64) * 0.5 * s.angle_rad.sin();
            let d = phase_diff(waveform::echo_phasor(&p, &s, k, m, n).arg(), 2.0 * PI * turns);
            prop_assert!(d.abs() < 1e-9, "phase off by {d}");
        }}}
    }
}
