//! Numerical robustness of the estimator: bad samples, degenerate references, edges of the range
//! and angle grids, odd and large sizes, extreme SNRs.

mod common;

use common::{grid, params, sine_error, Echo};
use nrslam_estimator::{
    Detector, Estimator, EstimatorConfig, EstimatorError, RangeAngleDetection, Refinement,
};
use nrslam_ofdm::OfdmParams;
use num_complex::Complex64;

fn interp() -> EstimatorConfig {
    EstimatorConfig {
        refinement: Refinement::Interpolation,
        ..EstimatorConfig::default()
    }
}

fn run(
    p: &OfdmParams,
    cfg: EstimatorConfig,
    echoes: &[Echo],
    snr: Option<f64>,
) -> Vec<RangeAngleDetection> {
    let mut est = Estimator::new(p, cfg).unwrap();
    est.process_grid(&grid(p, echoes, snr, 7)).unwrap()
}

#[test]
fn non_finite_samples_are_refused_with_their_index() {
    let p = params(64, 4, 1);
    let mut est = Estimator::new(&p, EstimatorConfig::default()).unwrap();
    let good = grid(&p, &[Echo::new(3.0, 0.1)], Some(20.0), 1);
    for (i, bad) in [
        (0usize, f64::NAN),
        (77, f64::INFINITY),
        (255, f64::NEG_INFINITY),
    ] {
        let mut g = good.clone();
        g.received[i].im = bad;
        match est.process_grid(&g) {
            Err(EstimatorError::NonFinite { input, index, .. }) => {
                assert_eq!((input, index), ("received", i));
            }
            other => panic!("expected NonFinite, got {other:?}"),
        }
    }
    let mut g = good.clone();
    g.transmitted[5] = Complex64::new(f64::INFINITY, 0.0);
    let err = est.process_grid(&g).unwrap_err();
    assert!(matches!(
        err,
        EstimatorError::NonFinite {
            input: "transmitted",
            index: 5,
            ..
        }
    ));
    assert!(err.to_string().contains("transmitted[5]"), "{err}");
    // NaN in a cell whose X is zero is still refused.
    let mut g = good.clone();
    g.transmitted[9] = Complex64::new(0.0, 0.0);
    g.received[9] = Complex64::new(f64::NAN, 0.0);
    assert!(matches!(
        est.process_grid(&g),
        Err(EstimatorError::NonFinite {
            input: "received",
            index: 9,
            ..
        })
    ));
    // And the estimator still works afterwards.
    assert_eq!(est.process_grid(&good).unwrap().len(), 1);
    // Spectrum path.
    let mut s = est.range_angle_map(&good).unwrap();
    s.values[3].re = f64::NAN;
    assert!(matches!(
        est.process_spectrum(&s),
        Err(EstimatorError::NonFinite {
            input: "spectrum",
            index: 3,
            ..
        })
    ));
}

#[test]
fn overflow_of_y_over_x_is_an_error_not_a_panic() {
    let p = params(64, 4, 1);
    let mut est = Estimator::new(&p, EstimatorConfig::default()).unwrap();
    let mut g = grid(&p, &[Echo::new(3.0, 0.1)], None, 1);
    g.received[10] = Complex64::new(1e300, 0.0);
    g.transmitted[10] = Complex64::new(1e-300, 0.0);
    assert!(matches!(
        est.process_grid(&g),
        Err(EstimatorError::Overflow(_))
    ));
    // Huge but representable everywhere: the transforms overflow.
    let mut g = grid(&p, &[Echo::new(3.0, 0.1)], None, 1);
    g.received.iter_mut().for_each(|v| *v *= 1e307);
    assert!(matches!(
        est.process_grid(&g),
        Err(EstimatorError::Overflow(_))
    ));
}

#[test]
fn zero_reference_cells_are_skipped_and_all_zero_is_an_error() {
    let p = params(256, 8, 1);
    let truth = Echo::new(40.3 * p.range_bin_m(), 0.2);
    let mut g = grid(&p, &[truth], Some(10.0), 3);
    // A DC null and a guard band: X = 0 there, and nothing received but noise.
    for n in (0..8).chain(248..256) {
        g.transmitted[n] = Complex64::new(0.0, 0.0);
    }
    // A subnormal reference is treated the same way.
    g.transmitted[100] = Complex64::new(1e-310, 0.0);
    let mut est = Estimator::new(&p, interp()).unwrap();
    let det = est.process_grid(&g).unwrap();
    assert!(!det.is_empty());
    assert!(
        (det[0].range_m - truth.range_m).abs() < 0.1 * p.range_bin_m(),
        "{det:?}"
    );
    g.transmitted
        .iter_mut()
        .for_each(|x| *x = Complex64::new(0.0, 0.0));
    assert_eq!(est.process_grid(&g), Err(EstimatorError::NoReference));
}

#[test]
fn grids_of_the_wrong_shape_are_refused() {
    let p = params(64, 4, 1);
    let mut est = Estimator::new(&p, EstimatorConfig::default()).unwrap();
    let g = grid(&params(64, 8, 1), &[], None, 1);
    assert_eq!(
        est.process_grid(&g),
        Err(EstimatorError::GridShape {
            what: "antennas",
            expected: 4,
            found: 8
        })
    );
    let mut g = grid(&p, &[], None, 1);
    g.received.pop();
    assert!(matches!(
        est.process_grid(&g),
        Err(EstimatorError::GridShape {
            what: "received.len()",
            ..
        })
    ));
}

#[test]
fn scatterer_at_zero_range() {
    let p = params(256, 8, 1);
    for cfg in [EstimatorConfig::default(), interp()] {
        let det = run(&p, cfg.clone(), &[Echo::new(0.0, 0.0)], None);
        assert_eq!(det.len(), 1, "{det:?}");
        assert_eq!(det[0].range_bin, 0);
        assert!(det[0].range_m.abs() < 1e-9, "{:?}", det[0]);
        // Noisy: never a negative range, never wrapped to the far end.
        let det = run(&p, cfg.clone(), &[Echo::new(0.0, 0.0)], Some(0.0));
        assert!(
            det[0].range_m >= 0.0 && det[0].range_m < 0.5 * p.range_bin_m(),
            "{det:?}"
        );
        // And with a window that is not circular (Rife two-point at the edge).
        let windowed = EstimatorConfig {
            max_range_m: Some(10.0),
            ..cfg
        };
        let r = 0.3 * p.range_bin_m();
        let det = run(&p, windowed, &[Echo::new(r, 0.0)], None);
        assert_eq!(det[0].range_bin, 0);
        if det[0].range_m != 0.0 {
            assert!((det[0].range_m - r).abs() < 1e-6, "{det:?}");
        }
    }
}

#[test]
fn ranges_alias_modulo_the_unambiguous_range() {
    let p = params(256, 8, 1);
    let (ru, dr) = (p.unambiguous_range_m(), p.range_bin_m());
    let cases = [
        (ru, 0.0),                      // exactly R_u: bin N ≡ bin 0
        (ru + 5.0 * dr, 5.0 * dr),      // beyond: aliased
        (ru - 0.3 * dr, 0.0),           // within half a bin of R_u: its alias at bin 0
        (ru - 0.7 * dr, ru - 0.7 * dr), // last bin, interpolated with bin 0 (circular)
        (2.0 * ru + 17.25 * dr, 17.25 * dr),
    ];
    for (r, expected) in cases {
        let det = run(&p, interp(), &[Echo::new(r, 0.0)], None);
        let err = (det[0].range_m - expected).abs();
        let wrapped = err.min((err - ru).abs());
        assert!(wrapped < 0.01 * dr, "r {r}: {det:?}, expected {expected}");
        assert!(det[0].range_m >= 0.0 && det[0].range_m < ru);
    }
}

#[test]
fn angles_at_and_near_endfire() {
    let p = params(128, 8, 1);
    let r = 20.0 * p.range_bin_m();
    // sin θ = ±1 are the same array phase at λ/2: one bin (A/2 − A/2 = 0 after fftshift).
    for sine in [1.0, -1.0] {
        for cfg in [EstimatorConfig::default(), interp()] {
            let det = run(&p, cfg, &[Echo::at_sine(r, sine)], None);
            assert_eq!(det.len(), 1, "{det:?}");
            assert_eq!(det[0].angle_bin, 0);
            assert!(det[0].angle_rad.sin().abs() > 1.0 - 1e-6, "{det:?}");
        }
    }
    // Near endfire the peak wraps to the other end of the angle grid; interpolation follows it.
    for sine in [0.99, -0.99, 0.97, 0.9, -0.93] {
        let det = run(&p, interp(), &[Echo::at_sine(r, sine)], Some(30.0));
        let e = sine_error(det[0].angle_rad, sine.asin());
        assert!(e.abs() < 0.01, "sine {sine}: {det:?}");
        assert!(det[0].angle_rad.abs() <= std::f64::consts::FRAC_PI_2);
        let det = run(
            &p,
            EstimatorConfig::default(),
            &[Echo::at_sine(r, sine)],
            Some(30.0),
        );
        let e = sine_error(det[0].angle_rad, sine.asin());
        assert!(
            e.abs() <= 0.5 * p.sine_bin() + 1e-12,
            "sine {sine}: {det:?}"
        );
    }
}

#[test]
fn odd_and_large_sizes() {
    for (n, k) in [(1023usize, 5usize), (1023, 8), (16384, 4)] {
        let p = params(n, k, 1);
        let r = 0.37 * n as f64 * p.range_bin_m() + 0.21 * p.range_bin_m();
        let sine = 0.3;
        let det = run(&p, interp(), &[Echo::at_sine(r, sine)], Some(0.0));
        assert!(
            (det[0].range_m - r).abs() < 0.05 * p.range_bin_m(),
            "N {n}: {det:?}"
        );
        assert!(
            sine_error(det[0].angle_rad, sine.asin()).abs() < 0.1 * p.sine_bin(),
            "{det:?}"
        );
        let det = run(
            &p,
            EstimatorConfig::default(),
            &[Echo::at_sine(r, sine)],
            Some(0.0),
        );
        assert!(
            (det[0].range_m - r).abs() <= 0.5 * p.range_bin_m(),
            "N {n}: {det:?}"
        );
    }
}

#[test]
fn snr_from_minus_30_to_plus_300_db_and_noise_free() {
    let p = params(10240, 32, 1);
    let dr = p.range_bin_m();
    let truth = Echo::at_sine(123.4 * dr, -0.4);
    let mut est = Estimator::new(&p, interp()).unwrap();
    for snr in [
        Some(-30.0),
        Some(0.0),
        Some(30.0),
        Some(100.0),
        Some(300.0),
        None,
    ] {
        let det = est.process_grid(&grid(&p, &[truth], snr, 11)).unwrap();
        assert!(!det.is_empty(), "snr {snr:?}");
        let d = det[0];
        let tol = if snr.unwrap_or(400.0) < 10.0 {
            0.3
        } else {
            0.01
        };
        assert!(
            (d.range_m - truth.range_m).abs() < tol * dr,
            "snr {snr:?}: {det:?}"
        );
        assert!(
            sine_error(d.angle_rad, truth.angle_rad).abs() < tol * p.sine_bin(),
            "{det:?}"
        );
        assert!(det.len() <= 2, "snr {snr:?}: {det:?}");
        if snr.unwrap_or(400.0) >= 30.0 {
            assert_eq!(det.len(), 1, "snr {snr:?}: {det:?}");
        }
    }
}

#[test]
fn one_kilometre_at_table_one_bandwidth() {
    let p = params(10240, 8, 1);
    let dr = p.range_bin_m();
    let mut est = Estimator::new(&p, interp()).unwrap();
    let mut plain = Estimator::new(&p, EstimatorConfig::default()).unwrap();
    for r in [1000.0, 1000.0 + 0.37 * dr, 1234.567] {
        let g = grid(&p, &[Echo::new(r, 0.05)], None, 5);
        let det = est.process_grid(&g).unwrap();
        assert_eq!(det.len(), 1);
        assert!((det[0].range_m - r).abs() < 0.005 * dr, "r {r}: {det:?}");
        let det = plain.process_grid(&g).unwrap();
        assert!(
            (det[0].range_m - r).abs() <= 0.5 * dr + 1e-9,
            "r {r}: {det:?}"
        );
    }
}

#[test]
fn two_scatterers_one_bin_apart_are_resolved_by_zero_padding() {
    let p = params(1024, 8, 1);
    let dr = p.range_bin_m();
    let echoes = [Echo::new(300.2 * dr, 0.1), Echo::new(301.2 * dr, 0.1)];
    let cfg = EstimatorConfig {
        refinement: Refinement::ZeroPadding { factor: 4 },
        max_detections: 2,
        ..EstimatorConfig::default()
    };
    let det = run(&p, cfg, &echoes, Some(20.0));
    // Resolved: two detections, each nearer its own echo than the other (the two main lobes
    // push each other's peaks outwards by a few tenths of a bin).
    assert_eq!(det.len(), 2, "{det:?}");
    let mut ranges: Vec<f64> = det.iter().map(|d| d.range_m).collect();
    ranges.sort_by(f64::total_cmp);
    for (got, e) in ranges.iter().zip(&echoes) {
        assert!((got - e.range_m).abs() < 0.4 * dr, "{det:?}");
    }
}

#[test]
fn the_range_window_bounds_the_search() {
    let p = params(1024, 8, 1);
    let cfg = EstimatorConfig {
        max_range_m: Some(20.0),
        ..EstimatorConfig::default()
    };
    let mut est = Estimator::new(&p, cfg).unwrap();
    let last = (20.0 / p.range_bin_m()).floor() as usize;
    assert_eq!(est.range_bins(), last + 2);
    let det = est
        .process_grid(&grid(
            &p,
            &[Echo::new(10.0, 0.0), Echo::new(30.0, 0.3)],
            Some(10.0),
            2,
        ))
        .unwrap();
    assert_eq!(det.len(), 1, "{det:?}");
    assert!((det[0].range_m - 10.0).abs() < p.range_bin_m());
}

#[test]
fn cfar_detects_and_keeps_false_alarms_rare() {
    let p = params(1024, 16, 1);
    let cfg = EstimatorConfig {
        detector: Detector::Cfar,
        ..interp()
    };
    let mut est = Estimator::new(&p, cfg).unwrap();
    let mut false_alarms = 0;
    for seed in 0..5 {
        false_alarms += est
            .process_grid(&grid(&p, &[], Some(0.0), seed))
            .unwrap()
            .len();
    }
    assert!(
        false_alarms <= 1,
        "{false_alarms} false alarms in 5 noise-only frames"
    );
    // −20 dB per element + 42 dB processing gain − 3.4 dB 16-QAM noise enhancement.
    let truth = Echo::at_sine(500.3 * p.range_bin_m(), 0.25);
    let det = est
        .process_grid(&grid(&p, &[truth], Some(-20.0), 9))
        .unwrap();
    assert!(!det.is_empty());
    assert!(
        (det[0].range_m - truth.range_m).abs() < 0.5 * p.range_bin_m(),
        "{det:?}"
    );
    // A CFAR window wider than the angle bins is refused at construction.
    let wide = EstimatorConfig {
        detector: Detector::Cfar,
        cfar_train_angle: 8,
        ..interp()
    };
    assert!(matches!(
        Estimator::new(&params(64, 4, 1), wide),
        Err(EstimatorError::Param(e)) if e.field == "cfar_train_angle"
    ));
}

#[test]
fn doppler_symbols_keep_the_peak_bin() {
    let p = params(256, 8, 8);
    let dr = p.range_bin_m();
    let moving = Echo {
        velocity_mps: 15.0,
        ..Echo::at_sine(50.3 * dr, 0.2)
    };
    let still = Echo::at_sine(120.0 * dr, -0.5);
    let det = run(&p, interp(), &[moving, still], Some(0.0));
    assert_eq!(det.len(), 2, "{det:?}");
    for e in [moving, still] {
        assert!(
            det.iter().any(|d| (d.range_m - e.range_m).abs() < 0.05 * dr
                && sine_error(d.angle_rad, e.angle_rad).abs() < 0.05 * p.sine_bin()),
            "{e:?} not in {det:?}"
        );
    }
    // A static on-bin unit echo peaks at |S| = K (the zero-Doppler mean over symbols).
    let mut est = Estimator::new(&p, EstimatorConfig::default()).unwrap();
    let map = est
        .range_angle_map(&grid(&p, &[Echo::new(120.0 * dr, 0.0)], None, 1))
        .unwrap();
    let peak = map.values[120 * map.angle_bins + map.angle_bins / 2];
    assert!((peak.norm() - 8.0).abs() < 1e-9, "{peak}");
}

#[test]
fn config_validation_names_the_field() {
    let p = params(64, 4, 1);
    let mut bad = nrslam_runtime::one_bad_field!(EstimatorConfig {
        max_detections: [0],
        threshold_db: [f64::NAN],
        cfar_pfa: [0.0],
        max_range_m: [Some(-1.0)],
        zero_padding_angle: [0],
        interpolated_std_fraction: [0.0, 2.0, f64::NAN],
    });
    // A nested field, named with its path.
    let no_padding = EstimatorConfig {
        refinement: Refinement::ZeroPadding { factor: 0 },
        ..Default::default()
    };
    bad.push((no_padding, "refinement.factor"));
    for (cfg, field) in bad {
        match Estimator::new(&p, cfg) {
            Err(EstimatorError::Param(e)) => {
                assert_eq!(e.field, field);
                assert!(!e.allowed.is_empty());
            }
            other => panic!("{field}: {other:?}"),
        }
    }
    let err = Estimator::new(&params(0, 4, 1), EstimatorConfig::default()).unwrap_err();
    assert!(err.to_string().contains("ofdm.subcarriers"), "{err}");
}

#[test]
fn config_parses_from_toml_and_refuses_unknown_fields() {
    let cfg: EstimatorConfig = toml::from_str(
        "detector = \"cfar\"\nmax_range_m = 20.0\nrefinement = { kind = \"zero_padding\", factor = 4 }\n",
    )
    .unwrap();
    assert_eq!(cfg.detector, Detector::Cfar);
    assert_eq!(cfg.refinement, Refinement::ZeroPadding { factor: 4 });
    assert_eq!(cfg.max_range_m, Some(20.0));
    assert_eq!(cfg.threshold_db, EstimatorConfig::default().threshold_db);
    let cfg: EstimatorConfig = toml::from_str("refinement = { kind = \"interpolation\" }").unwrap();
    assert_eq!(cfg.refinement, Refinement::Interpolation);
    assert!(toml::from_str::<EstimatorConfig>("treshold_db = 3.0").is_err());
    assert!(toml::from_str::<EstimatorConfig>(
        "refinement = { kind = \"zero_padding\", factor = 2, extra = 1 }"
    )
    .is_err());
    assert_eq!(
        toml::from_str::<EstimatorConfig>("").unwrap(),
        EstimatorConfig::default()
    );
}

#[test]
fn the_spectrum_path_matches_the_grid_path() {
    let p = params(512, 8, 1);
    let dr = p.range_bin_m();
    let echoes = [
        Echo::at_sine(100.3 * dr, 0.3),
        Echo::at_sine(220.8 * dr, -0.6),
    ];
    for cfg in [
        EstimatorConfig::default(),
        interp(),
        EstimatorConfig {
            zero_padding_angle: 4,
            ..interp()
        },
    ] {
        let mut est = Estimator::new(&p, cfg).unwrap();
        let g = grid(&p, &echoes, Some(0.0), 4);
        let from_grid = est.process_grid(&g).unwrap();
        let map = est.range_angle_map(&g).unwrap();
        let from_map = est.process_spectrum(&map).unwrap();
        assert_eq!(from_grid.len(), from_map.len());
        for (a, b) in from_grid.iter().zip(&from_map) {
            assert_eq!((a.range_bin, a.angle_bin), (b.range_bin, b.angle_bin));
            assert!(
                (a.range_m - b.range_m).abs() < 1e-9 && (a.angle_rad - b.angle_rad).abs() < 1e-9
            );
        }
    }
    // A malformed spectrum is an error.
    let mut est = Estimator::new(&p, EstimatorConfig::default()).unwrap();
    let mut map = est.range_angle_map(&grid(&p, &echoes, None, 1)).unwrap();
    map.range_bins += 1;
    assert!(matches!(
        est.process_spectrum(&map),
        Err(EstimatorError::SpectrumShape(_))
    ));
}
