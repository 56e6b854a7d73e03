//! `spectral` against the brute-force processing of the `waveform` grid, edge cases, noise.

mod common;

use common::*;
use nrslam_ofdm::spectral::{self, SpectralConfig};
use nrslam_ofdm::waveform::{self, WaveformConfig};
use nrslam_ofdm::{reference, FrameRng, Modulation, OfdmError, OfdmParams};
use num_complex::Complex64;
use proptest::prelude::*;
use rand::SeedableRng;

const TOL: f64 = 1e-9;

#[test]
fn equivalent_to_brute_force_small_grid() {
    // N = 256: range bin 4.88 m, so keep 300 m (63 bins) to see whole windows.
    let p = small(256, 8, 1);
    let cfg = SpectralConfig {
        max_range_m: 300.0,
        ..noise_free_spectral()
    };
    for (r, deg, amp) in [
        (3.0, 0.0, Complex64::new(1.0, 0.0)),
        (77.77, 23.4, Complex64::new(0.3, -2.0)),
        (120.6, -61.0, Complex64::new(-1.5, 0.5)),
        (199.0, 80.0, Complex64::new(0.0, 1.0)),
    ] {
        let cells = assert_equivalent(&p, &scatterer(r, deg, 0.0, amp), &cfg, TOL);
        assert!(cells >= 9 * 8, "window too small: {cells} cells");
    }
}

#[test]
fn equivalent_with_doppler_and_zero_padding() {
    let p = small(256, 8, 4);
    let cfg = SpectralConfig {
        range_zero_padding: 2,
        angle_zero_padding: 4,
        max_range_m: 10.0,
        ..noise_free_spectral()
    };
    let s = scatterer(4.321, -12.5, 37.0, Complex64::new(0.7, 0.2));
    // The Doppler factor really attenuates (37 m/s ≈ 0.25 turns over 4 symbols).
    assert!(spectral::doppler_response(&p, s.radial_velocity_mps).norm() < 0.95);
    assert_equivalent(&p, &s, &cfg, TOL);
}

#[test]
fn equivalent_at_table_i_subcarriers() {
    let p = small(10240, 32, 1);
    let cfg = noise_free_spectral();
    assert_eq!(spectral::range_bins(&p, &cfg), 165);
    let s = scatterer(12.345, 17.0, 0.0, Complex64::new(0.8, -0.6));
    assert_equivalent(&p, &s, &cfg, TOL);
}

#[test]
fn many_scatterers_equal_brute_force_with_full_windows_and_within_leakage_with_w8() {
    // N = 128 (range bin 9.76 m), K = 32, all range bins kept.
    let p = small(128, 32, 1);
    let scene = [
        scatterer(20.0, 10.0, 0.0, Complex64::new(1.0, 0.0)),
        scatterer(23.0, -30.0, 0.0, Complex64::new(0.5, 0.5)),
        scatterer(391.3, 45.0, 0.0, Complex64::new(-2.0, 0.1)),
    ];
    let full = SpectralConfig {
        window_cells: 1000,
        max_range_m: 1e9,
        ..noise_free_spectral()
    };
    let brute = brute_force(&p, &scene, &full, 3);
    let mut rng = FrameRng::seed_from_u64(0);
    let spec = spectral::synthesize(&p, &scene, &full, &mut rng).unwrap();
    let scale: f64 = scene.iter().map(|s| s.amplitude.norm()).sum::<f64>() * 32.0;
    for (a, b) in spec.values.iter().zip(&brute.values) {
        assert!((a - b).norm() <= TOL * scale);
    }
    // W = 8: the error anywhere is at most the documented leakage of each scatterer.
    let w8 = SpectralConfig {
        window_cells: 8,
        ..full
    };
    let spec8 = spectral::synthesize(&p, &scene, &w8, &mut rng).unwrap();
    let leak = 10f64
        .powf(spectral::window_leakage_db(8, 128).max(spectral::window_leakage_db(8, 32)) / 20.0);
    let max_err = spec8
        .values
        .iter()
        .zip(&brute.values)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    assert!(
        max_err > 1e-4 * scale,
        "W = 8 should drop some sidelobes: {max_err}"
    );
    assert!(
        max_err <= leak * scale,
        "max error {max_err} > leakage bound {}",
        leak * scale
    );
}

#[test]
fn sidelobes_outside_the_window_are_below_the_documented_leakage() {
    let p = small(512, 32, 1);
    let cfg = SpectralConfig {
        max_range_m: 40.0,
        ..noise_free_spectral()
    };
    let s = scatterer(15.55, 33.0, 0.0, Complex64::new(1.0, 0.0));
    let brute = brute_force(&p, &[s], &cfg, 4);
    let (rw, aw) = spectral::window_bins(&p, &cfg, &s);
    let leak = 10f64
        .powf(spectral::window_leakage_db(8, 512).max(spectral::window_leakage_db(8, 32)) / 20.0);
    let mut worst: f64 = 0.0;
    for i in 0..brute.range_bins {
        for j in 0..brute.angle_bins {
            if !(rw.contains(&i) && aw.contains(&j)) {
                worst = worst.max(brute.at(i, j).norm() / 32.0);
            }
        }
    }
    assert!(worst <= leak, "worst dropped {worst} > bound {leak}");
    assert!(worst > 0.3 * leak, "bound {leak} is loose against {worst}");
    assert!((spectral::window_leakage_db(8, 10240) + 28.0).abs() < 0.05);
}

#[test]
fn scatterer_at_zero_range_peaks_at_bin_zero() {
    let p = small(256, 8, 1);
    let cfg = noise_free_spectral();
    let s = scatterer(0.0, 0.0, 0.0, Complex64::new(1.0, 0.0));
    assert_equivalent(&p, &s, &cfg, TOL);
    let mut rng = FrameRng::seed_from_u64(0);
    let spec = spectral::synthesize(&p, &[s], &cfg, &mut rng).unwrap();
    let mid = spec.angle_bins / 2;
    assert!((spec.at(0, mid) - Complex64::new(8.0, 0.0)).norm() < 1e-12);
    assert!(
        spec.at(1, mid).norm() < 1e-12,
        "on-grid: the other bins are nulls"
    );
}

#[test]
fn ranges_at_and_beyond_the_unambiguous_range_wrap() {
    let p = small(256, 8, 1);
    let ru = p.unambiguous_range_m();
    let cfg = noise_free_spectral();
    let amp = Complex64::new(1.0, 0.0);
    let mut rng = FrameRng::seed_from_u64(0);
    let at_ru = spectral::synthesize(&p, &[scatterer(ru, 5.0, 0.0, amp)], &cfg, &mut rng).unwrap();
    let at_0 = spectral::synthesize(&p, &[scatterer(0.0, 5.0, 0.0, amp)], &cfg, &mut rng).unwrap();
    let beyond =
        spectral::synthesize(&p, &[scatterer(ru + 5.3, 5.0, 0.0, amp)], &cfg, &mut rng).unwrap();
    let near = spectral::synthesize(&p, &[scatterer(5.3, 5.0, 0.0, amp)], &cfg, &mut rng).unwrap();
    for (a, b) in at_ru.values.iter().zip(&at_0.values) {
        assert!((a - b).norm() < 1e-9);
    }
    for (a, b) in beyond.values.iter().zip(&near.values) {
        assert!((a - b).norm() < 1e-9);
    }
    assert_equivalent(&p, &scatterer(ru + 5.3, 5.0, 0.0, amp), &cfg, TOL);
    assert_equivalent(&p, &scatterer(ru, 5.0, 0.0, amp), &cfg, TOL);
}

#[test]
fn endfire_angles_alias_to_bin_zero_at_half_wavelength() {
    let p = small(128, 8, 1);
    let cfg = noise_free_spectral();
    let amp = Complex64::new(1.0, 0.0);
    let mut rng = FrameRng::seed_from_u64(0);
    for deg in [90.0, -90.0] {
        let s = scatterer(3.0, deg, 0.0, amp);
        assert_equivalent(&p, &s, &cfg, TOL);
        let spec = spectral::synthesize(&p, &[s], &cfg, &mut rng).unwrap();
        let i = (3.0 / spec.range_bin_m).round() as usize;
        let peak_j = (0..spec.angle_bins)
            .max_by(|&a, &b| spec.at(i, a).norm().total_cmp(&spec.at(i, b).norm()))
            .unwrap();
        assert_eq!(peak_j, 0, "endfire {deg} deg");
        assert!((spectral::angle_bin_sine(&p, &cfg, 0) + 1.0).abs() < 1e-15);
    }
}

#[test]
fn non_finite_scatterers_are_refused_by_name() {
    let p = small(64, 4, 1);
    let cfg = SpectralConfig::default();
    let good = scatterer(1.0, 0.0, 0.0, Complex64::new(1.0, 0.0));
    type Mutate = Box<dyn Fn(&mut nrslam_ofdm::Scatterer)>;
    let cases: [(&str, Mutate); 6] = [
        ("range_m", Box::new(|s| s.range_m = f64::NAN)),
        ("range_m", Box::new(|s| s.range_m = -1.0)),
        ("angle_rad", Box::new(|s| s.angle_rad = f64::INFINITY)),
        ("angle_rad", Box::new(|s| s.angle_rad = 1.6)),
        (
            "radial_velocity_mps",
            Box::new(|s| s.radial_velocity_mps = f64::NEG_INFINITY),
        ),
        (
            "amplitude",
            Box::new(|s| s.amplitude = Complex64::new(0.0, f64::NAN)),
        ),
    ];
    for (name, f) in cases {
        let mut bad = good;
        f(&mut bad);
        let mut rng = FrameRng::seed_from_u64(0);
        let e = spectral::synthesize(&p, &[good, bad], &cfg, &mut rng).unwrap_err();
        match &e {
            OfdmError::InvalidScatterer { index, field, .. } => {
                assert_eq!((*index, *field), (1, name));
            }
            other => panic!("expected InvalidScatterer, got {other:?}"),
        }
        assert!(e.to_string().contains(name));
        let e2 = waveform::synthesize(&p, &[bad], &WaveformConfig::default(), &mut rng);
        assert!(matches!(e2, Err(OfdmError::InvalidScatterer { field, .. }) if field == name));
    }
}

#[test]
fn processed_noise_matches_the_waveform_statistics() {
    // Noise-only frames through the brute-force chain: mean |V|² ≈ K σ² E[1/|X|²]/(N M).
    for modulation in [Modulation::Qpsk, Modulation::Qam16] {
        let p = OfdmParams {
            snr_db: 3.0,
            ..small(256, 8, 2)
        };
        let cfg = SpectralConfig {
            modulation,
            max_range_m: 1e9,
            ..SpectralConfig::default()
        };
        let wcfg = WaveformConfig {
            modulation,
            ..WaveformConfig::default()
        };
        let mut rng = FrameRng::seed_from_u64(11);
        let mut sum = 0.0;
        let mut count = 0usize;
        for _ in 0..2 {
            let grid = waveform::synthesize(&p, &[], &wcfg, &mut rng).unwrap();
            let map = reference::process(&grid, &p, &cfg).unwrap();
            sum += map.values.iter().map(|v| v.norm_sqr()).sum::<f64>();
            count += map.values.len();
        }
        let measured = sum / count as f64;
        let expected = spectral::processed_noise_power(&p, modulation);
        // 4096 cells: the estimate's relative std is ~1.6 %.
        assert!(
            (measured / expected - 1.0).abs() < 0.08,
            "{modulation:?}: measured {measured}, expected {expected}"
        );
    }
    // And the spectral synthesiser draws at that level.
    let p = small(1024, 16, 1);
    let mut rng = FrameRng::seed_from_u64(12);
    let all = SpectralConfig {
        max_range_m: 1e9,
        ..SpectralConfig::default()
    };
    let map = spectral::synthesize(&p, &[], &all, &mut rng).unwrap();
    assert_eq!(map.values.len(), 1024 * 16);
    let measured = map.values.iter().map(|v| v.norm_sqr()).sum::<f64>() / map.values.len() as f64;
    // 16384 cells: relative std 0.8 %.
    assert!(
        (measured / map.noise_power - 1.0).abs() < 0.04,
        "{measured} vs {}",
        map.noise_power
    );
}

#[test]
fn oversized_map_is_refused() {
    let p = OfdmParams::default();
    let cfg = SpectralConfig {
        max_range_m: 1e6,
        range_zero_padding: 8,
        max_cells: 1 << 20,
        ..SpectralConfig::default()
    };
    let mut rng = FrameRng::seed_from_u64(0);
    let e = spectral::synthesize(&p, &[], &cfg, &mut rng).unwrap_err();
    assert!(matches!(e, OfdmError::TooLarge { .. }), "{e}");
    assert!(e.to_string().contains("max_range_m"));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn prop_spectral_equals_brute_force(
        range_m in 0.0f64..1300.0,
        angle_deg in -90.0f64..=90.0,
        v in -30.0f64..30.0,
        re in -3.0f64..3.0,
        im in -3.0f64..3.0,
        m in 1usize..3,
        pr in 1usize..3,
        pa in 1usize..3,
    ) {
        let p = small(64, 4, m);
        let cfg = SpectralConfig {
            range_zero_padding: pr,
            angle_zero_padding: pa,
            max_range_m: 1e9,
            window_cells: 4,
            ..noise_free_spectral()
        };
        let s = scatterer(range_m, angle_deg, v, Complex64::new(re, im));
        assert_equivalent(&p, &s, &cfg, TOL);
    }

    #[test]
    fn prop_dirichlet_equals_direct_sum(len in 1usize..400, x in -3.0f64..3.0) {
        let direct: Complex64 = (0..len)
            .map(|t| Complex64::from_polar(1.0, 2.0 * std::f64::consts::PI * ((t as f64 * x) % 1.0)))
            .sum();
        let d = spectral::dirichlet(len, x);
        prop_assert!((d - direct).norm() <= 1e-10 * len as f64, "{d} vs {direct}");
    }
}

#[test]
fn kept_responses_give_the_same_map_bit_for_bit() {
    // Table I's subcarriers and antennas, noise on: the responses of one geometry, kept, then
    // used with other amplitudes (other trials' random phases) give exactly what a fresh
    // synthesis gives; a response kept for another geometry is evaluated afresh.
    let p = small(10240, 32, 1);
    let cfg = SpectralConfig::default();
    let geometry = |shift_m: f64| -> Vec<_> {
        (0..12)
            .map(|k| {
                let amplitude = Complex64::from_polar(1.0, 0.4 * f64::from(k));
                scatterer(
                    2.0 + 1.3 * f64::from(k) + shift_m,
                    -50.0 + 9.0 * f64::from(k),
                    0.3,
                    amplitude,
                )
            })
            .collect()
    };
    let kept = spectral::Responses::new(&p, &geometry(0.0), &cfg).unwrap();
    for (shift_m, phase) in [(0.0, 0.0), (0.0, 1.7), (0.01, 0.0)] {
        let mut scatterers = geometry(shift_m);
        for s in &mut scatterers {
            s.amplitude *= Complex64::from_polar(1.0, phase);
        }
        let fresh = spectral::synthesize(&p, &scatterers, &cfg, &mut FrameRng::seed_from_u64(3));
        let with = spectral::synthesize_with(
            &p,
            &scatterers,
            &cfg,
            &kept,
            &mut FrameRng::seed_from_u64(3),
        );
        let (fresh, with) = (fresh.unwrap(), with.unwrap());
        let bits = |m: &nrslam_ofdm::RangeAngleSpectrum| -> Vec<(u64, u64)> {
            m.values
                .iter()
                .map(|v| (v.re.to_bits(), v.im.to_bits()))
                .collect()
        };
        assert_eq!(
            bits(&fresh),
            bits(&with),
            "shift {shift_m} m, phase {phase}"
        );
    }
}
