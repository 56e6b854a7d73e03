//! The super-resolution refinements (`music`, `esprit`) at the extremes: coherent equal-power
//! scatterers in one cell, K = 2 and K = 256, M = 1 and M = 256, SNR −30 dB and 80 dB, noise
//! alone (false detections per frame against the detector's design), and more scatterers than
//! the subarray can hold. Every case: no panic, no NaN, every detection in the visible region
//! (|θ| ≤ π/2) with a finite, positive std; and both fidelities agree on a clean case.

use nrslam_estimator::{Estimator, EstimatorConfig, RangeAngleDetection, Refinement};
use nrslam_ofdm::{spectral, waveform, OfdmParams, Scatterer};
use num_complex::Complex64;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const METHODS: [Refinement; 3] = [
    Refinement::Music { subarray: 0 },
    Refinement::Esprit { subarray: 0 },
    Refinement::Nomp,
];

fn params(n: usize, k: usize, m: usize, snr_db: f64) -> OfdmParams {
    OfdmParams {
        subcarriers: n,
        antennas: k,
        symbols: m,
        snr_db,
        ..OfdmParams::default()
    }
}

fn scatterer(range_m: f64, angle_deg: f64, phase: f64) -> Scatterer {
    Scatterer {
        range_m,
        angle_rad: angle_deg.to_radians(),
        radial_velocity_mps: 0.0,
        amplitude: Complex64::from_polar(1.0, phase),
    }
}

fn config(refinement: Refinement) -> EstimatorConfig {
    EstimatorConfig {
        refinement,
        max_range_m: Some(25.0),
        ..EstimatorConfig::default()
    }
}

/// Every angle bin evaluated, so an array row is exact (what super-resolution needs).
fn exact_rows(k: usize) -> spectral::SpectralConfig {
    spectral::SpectralConfig {
        max_range_m: 25.0,
        angle_window_cells: Some(k.div_ceil(2)),
        ..spectral::SpectralConfig::default()
    }
}

fn spectral_frame(
    p: &OfdmParams,
    refinement: Refinement,
    scatterers: &[Scatterer],
    seed: u64,
) -> Vec<RangeAngleDetection> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let map = spectral::synthesize(p, scatterers, &exact_rows(p.antennas), &mut rng).unwrap();
    let mut est = Estimator::new(p, config(refinement)).unwrap();
    est.process_spectrum(&map).unwrap()
}

fn waveform_frame(
    p: &OfdmParams,
    refinement: Refinement,
    scatterers: &[Scatterer],
    seed: u64,
) -> Vec<RangeAngleDetection> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let grid = waveform::synthesize(
        p,
        scatterers,
        &waveform::WaveformConfig::default(),
        &mut rng,
    )
    .unwrap();
    let mut est = Estimator::new(p, config(refinement)).unwrap();
    est.process_grid(&grid).unwrap()
}

/// No NaN, in the visible region, std finite and positive (a DFT fallback has none: the node
/// gives it its cell's).
fn assert_sane(found: &[RangeAngleDetection], what: &str) {
    for d in found {
        assert!(
            d.range_m.is_finite() && d.range_m >= 0.0,
            "{what}: range {d:?}"
        );
        assert!(
            d.angle_rad.is_finite() && d.angle_rad.abs() <= std::f64::consts::FRAC_PI_2,
            "{what}: angle {d:?}"
        );
        assert!(d.power_db.is_finite(), "{what}: power {d:?}");
        if let Some(std) = d.std {
            assert!(
                std.range_m.is_finite() && std.range_m > 0.0,
                "{what}: range std {d:?}"
            );
            assert!(
                std.angle_rad.is_finite() && std.angle_rad > 0.0,
                "{what}: angle std {d:?}"
            );
        }
    }
}

#[test]
fn coherent_equal_scatterers_in_one_cell_are_resolved_or_merged_never_broken() {
    let p = params(10240, 32, 1, 10.0);
    for method in METHODS {
        // Same range bin, 1° apart (under a third of the 3.58° beam), in phase and in
        // antiphase (where their sum nearly cancels at the middle).
        for phase in [0.0, std::f64::consts::PI] {
            let pair = [scatterer(10.0, 0.5, 0.0), scatterer(10.0, 1.5, phase)];
            let found = spectral_frame(&p, method, &pair, 3);
            assert_sane(&found, &format!("{method:?} phase {phase}"));
            if method == Refinement::Nomp {
                // NOMP resolves from about half a beam (docs/superresolution.md): here it need
                // only place its strongest atom between the two.
                assert!(
                    (found[0].angle_rad.to_degrees() - 1.0).abs() < 1.5,
                    "{found:?}"
                );
                continue;
            }
            // Both within a third of their separation.
            for s in &pair {
                assert!(
                    found
                        .iter()
                        .any(|d| (d.angle_rad - s.angle_rad).abs() < 0.33f64.to_radians()
                            && (d.range_m - s.range_m).abs() < 0.1),
                    "{method:?} phase {phase}: {s:?} not found in {found:?}"
                );
            }
        }
    }
}

#[test]
fn two_and_256_antennas() {
    for k in [2usize, 256] {
        let p = params(1024, k, 1, 10.0);
        for method in METHODS {
            let found = spectral_frame(
                &p,
                method,
                &[scatterer(8.0, 20.0, 0.3), scatterer(12.0, -35.0, 1.0)],
                5,
            );
            assert_sane(&found, &format!("K {k} {method:?}"));
            assert!(!found.is_empty(), "K {k} {method:?}");
            let found = waveform_frame(&p, method, &[scatterer(8.0, 20.0, 0.3)], 6);
            assert_sane(&found, &format!("K {k} {method:?} waveform"));
            let best = found[0];
            // K = 2 resolves sin θ to 0.1 at 10 dB · N; K = 256 to far better than 0.1°.
            let tol = if k == 2 {
                5f64.to_radians()
            } else {
                0.05f64.to_radians()
            };
            assert!(
                (best.angle_rad - 20f64.to_radians()).abs() < tol,
                "K {k} {method:?}: {best:?}"
            );
        }
    }
}

#[test]
fn one_and_256_symbols_on_the_grid_path() {
    for m in [1usize, 256] {
        // N = 1024 (1.22 m bins): enough noise cells in 25 m for the median floor.
        let p = params(1024, 8, m, 0.0);
        for method in METHODS {
            let found = waveform_frame(
                &p,
                method,
                &[scatterer(20.0, 10.0, 0.0), scatterer(20.0, -25.0, 2.0)],
                9,
            );
            assert_sane(&found, &format!("M {m} {method:?}"));
            for truth in [10.0f64, -25.0] {
                assert!(
                    found
                        .iter()
                        .any(|d| (d.angle_rad.to_degrees() - truth).abs() < 1.0),
                    "M {m} {method:?}: {truth}° not in {found:?}"
                );
            }
        }
    }
}

#[test]
fn snr_from_minus_30_to_80_db() {
    for snr_db in [-30.0, 80.0] {
        let p = params(10240, 32, 1, snr_db);
        for method in METHODS {
            for seed in 0..5 {
                let found = spectral_frame(&p, method, &[scatterer(9.0, -12.0, 0.7)], seed);
                assert_sane(&found, &format!("SNR {snr_db} {method:?}"));
                if snr_db > 0.0 {
                    // 80 dB per element: within a thousandth of a degree, and one wave only.
                    assert_eq!(found.len(), 1, "{method:?}: {found:?}");
                    assert!(
                        (found[0].angle_rad.to_degrees() + 12.0).abs() < 1e-3,
                        "{found:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn more_scatterers_in_one_range_bin_than_the_subarray_holds() {
    // K = 8: the subarray holds at most 5 waves; 12 scatterers share one range bin.
    let p = params(1024, 8, 1, 20.0);
    let many: Vec<Scatterer> = (0..12)
        .map(|i| scatterer(10.0, -55.0 + 10.0 * i as f64, i as f64))
        .collect();
    for method in METHODS {
        let found = spectral_frame(&p, method, &many, 11);
        assert_sane(&found, &format!("{method:?}"));
        assert!(!found.is_empty());
    }
}

/// Noise alone: with the noise power known, a cell exceeds T = 10^(threshold_db/10) times it
/// with probability e^(−T) (exponential power), so the design rate is the searched cells times
/// e^(−T) per frame. Over 10,000 frames the count must lie within ±50 % of it.
#[test]
fn noise_alone_gives_the_designed_false_alarm_rate() {
    let p = params(1024, 16, 1, 10.0);
    let threshold_db = 10.0;
    let frames = 10_000u64;
    let spectral_config = exact_rows(16);
    for refinement in [Refinement::None, METHODS[0], METHODS[1], METHODS[2]] {
        let mut est = Estimator::new(
            &p,
            EstimatorConfig {
                refinement,
                threshold_db,
                max_range_m: Some(25.0),
                ..EstimatorConfig::default()
            },
        )
        .unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let mut false_detections = 0usize;
        let mut cells = 0usize;
        for _ in 0..frames {
            let map = spectral::synthesize(&p, &[], &spectral_config, &mut rng).unwrap();
            let rows = ((25.0 / map.range_bin_m).floor() as usize + 1).min(map.range_bins);
            cells = rows * map.angle_bins;
            let found = est.process_spectrum(&map).unwrap();
            assert_sane(&found, "noise");
            false_detections += found.len();
        }
        let design = frames as f64 * cells as f64 * (-(10f64.powf(threshold_db / 10.0))).exp();
        let ratio = false_detections as f64 / design;
        assert!(
            (0.5..=1.5).contains(&ratio),
            "{refinement:?}: {false_detections} false detections in {frames} frames, design {design:.0}"
        );
    }
}

#[test]
fn spectral_and_waveform_agree_on_two_close_scatterers() {
    let p = params(2048, 32, 1, 10.0);
    for method in METHODS {
        // 1.5° is 0.42 of the beam; NOMP resolves from about half a beam, so its pair is 3° apart.
        let gap = if method == Refinement::Nomp { 3.0 } else { 1.5 };
        let pair = [scatterer(10.0, 3.0, 0.4), scatterer(10.0, 3.0 + gap, 2.0)];
        let s = spectral_frame(&p, method, &pair, 21);
        let w = waveform_frame(&p, method, &pair, 22);
        for truth in &pair {
            for (what, found) in [("spectral", &s), ("waveform", &w)] {
                assert!(
                    found
                        .iter()
                        .any(|d| (d.angle_rad - truth.angle_rad).abs() < 0.2f64.to_radians()),
                    "{method:?} {what}: {truth:?} not in {found:?}"
                );
            }
        }
    }
}

#[test]
fn the_methods_parse_from_toml_and_bad_subarrays_are_refused_by_name() {
    let parse = |text: &str| toml::from_str::<EstimatorConfig>(text);
    assert_eq!(
        parse("refinement = { kind = \"music\" }")
            .unwrap()
            .refinement,
        Refinement::Music { subarray: 0 }
    );
    assert_eq!(
        parse("refinement = { kind = \"esprit\", subarray = 20 }")
            .unwrap()
            .refinement,
        Refinement::Esprit { subarray: 20 }
    );
    assert_eq!(
        parse("refinement = { kind = \"nomp\" }")
            .unwrap()
            .refinement,
        Refinement::Nomp
    );
    assert!(parse("refinement = { kind = \"music\", order = 3 }").is_err());
    for name in [
        "none",
        "interpolation",
        "music",
        "esprit",
        "nomp",
        "zero-padding:4",
    ] {
        assert!(Refinement::from_name(name).is_some(), "{name}");
    }
    assert_eq!(Refinement::from_name("musik"), None);
    let p = params(256, 8, 1, 10.0);
    for (subarray, field) in [(1usize, "refinement.subarray"), (9, "refinement.subarray")] {
        let config = config(Refinement::Esprit { subarray });
        let error = Estimator::new(&p, config).unwrap_err().to_string();
        assert!(error.contains(field), "L = {subarray}: {error}");
    }
    // One element: nothing to resolve, the DFT peaks stand.
    let single = params(256, 1, 1, 10.0);
    for method in METHODS {
        let found = spectral_frame(&single, method, &[scatterer(8.0, 0.0, 0.0)], 1);
        assert_eq!(found.len(), 1, "{method:?}");
        assert_eq!(found[0].std, None, "{method:?}");
    }
}
