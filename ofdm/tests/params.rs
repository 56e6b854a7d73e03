//! `OfdmParams::validate`, `warnings`, and `SpectralConfig::validate`.

use nrslam_ofdm::spectral::SpectralConfig;
use nrslam_ofdm::{OfdmError, OfdmParams, ParamWarning};
use proptest::prelude::*;

fn field_of(e: OfdmError) -> &'static str {
    match e {
        OfdmError::InvalidParameter { field, .. } => field,
        other => panic!("expected InvalidParameter, got {other:?}"),
    }
}

#[test]
fn table_i_is_valid_and_warns_only_about_the_bandwidth() {
    let p = OfdmParams::default();
    p.validate().unwrap();
    let w = p.warnings();
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(matches!(
        w[0],
        ParamWarning::BandwidthExceedsNrCarrier { bandwidth_hz, .. } if (bandwidth_hz - 1.2288e9).abs() < 1.0
    ));
    assert!(w[0].to_string().contains("400 MHz"));
}

#[test]
fn one_nr_carrier_has_no_warnings() {
    // 264 resource blocks at 120 kHz: 380 MHz, inside one FR2 carrier.
    let p = OfdmParams {
        subcarriers: 264 * 12,
        ..OfdmParams::default()
    };
    assert!(p.warnings().is_empty(), "{:?}", p.warnings());
}

#[test]
fn other_warnings() {
    let p = OfdmParams {
        subcarrier_spacing_hz: 100e3,
        antenna_spacing_wavelengths: 0.7,
        subcarriers: 1000,
        symbol_duration_s: 1e-5,
        ..OfdmParams::default()
    };
    p.validate().unwrap();
    let w = p.warnings();
    assert!(w
        .iter()
        .any(|w| matches!(w, ParamWarning::NonNrSubcarrierSpacing { .. })));
    assert!(w
        .iter()
        .any(|w| matches!(w, ParamWarning::GratingLobes { .. })));
}

#[test]
fn each_bad_field_is_named_with_its_allowed_range() {
    let d = OfdmParams::default();
    let cases: Vec<(&str, OfdmParams)> = vec![
        (
            "carrier_frequency_hz",
            OfdmParams {
                carrier_frequency_hz: 0.0,
                ..d
            },
        ),
        (
            "carrier_frequency_hz",
            OfdmParams {
                carrier_frequency_hz: f64::INFINITY,
                ..d
            },
        ),
        (
            "subcarrier_spacing_hz",
            OfdmParams {
                subcarrier_spacing_hz: -1.0,
                ..d
            },
        ),
        (
            "subcarriers",
            OfdmParams {
                subcarriers: 0,
                ..d
            },
        ),
        (
            "subcarriers",
            OfdmParams {
                subcarriers: (1 << 24) + 1,
                ..d
            },
        ),
        ("symbols", OfdmParams { symbols: 0, ..d }),
        (
            "symbol_duration_s",
            OfdmParams {
                symbol_duration_s: 8e-6,
                ..d
            },
        ),
        (
            "symbol_duration_s",
            OfdmParams {
                symbol_duration_s: f64::NAN,
                ..d
            },
        ),
        ("antennas", OfdmParams { antennas: 0, ..d }),
        (
            "antenna_spacing_wavelengths",
            OfdmParams {
                antenna_spacing_wavelengths: 0.0,
                ..d
            },
        ),
        (
            "snr_db",
            OfdmParams {
                snr_db: f64::NAN,
                ..d
            },
        ),
        // band above the carrier
        (
            "subcarriers",
            OfdmParams {
                carrier_frequency_hz: 1e9,
                ..d
            },
        ),
    ];
    for (name, p) in cases {
        let e = p.validate().unwrap_err();
        let msg = e.to_string();
        assert_eq!(field_of(e), name);
        assert!(msg.contains(name) && msg.contains("allowed"), "{msg}");
    }
}

#[test]
fn symbol_duration_may_equal_the_useful_symbol() {
    let p = OfdmParams {
        symbol_duration_s: 1.0 / 120e3,
        ..OfdmParams::default()
    };
    p.validate().unwrap();
}

#[test]
fn spectral_config_fields_are_named() {
    let d = SpectralConfig::default();
    for (name, c) in [
        (
            "spectral.max_range_m",
            SpectralConfig {
                max_range_m: f64::NAN,
                ..d
            },
        ),
        (
            "spectral.range_zero_padding",
            SpectralConfig {
                range_zero_padding: 0,
                ..d
            },
        ),
        (
            "spectral.angle_zero_padding",
            SpectralConfig {
                angle_zero_padding: 65,
                ..d
            },
        ),
        ("spectral.max_cells", SpectralConfig { max_cells: 0, ..d }),
    ] {
        assert_eq!(field_of(c.validate().unwrap_err()), name);
    }
}

proptest! {
    /// Any non-finite float field is refused, and the error names that field.
    #[test]
    fn prop_non_finite_fields_refused(which in 0usize..5, bad in prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)]) {
        let mut p = OfdmParams::default();
        let name = match which {
            0 => { p.carrier_frequency_hz = bad; "carrier_frequency_hz" }
            1 => { p.subcarrier_spacing_hz = bad; "subcarrier_spacing_hz" }
            2 => { p.symbol_duration_s = bad; "symbol_duration_s" }
            3 => { p.antenna_spacing_wavelengths = bad; "antenna_spacing_wavelengths" }
            _ => { p.snr_db = bad; "snr_db" }
        };
        prop_assert_eq!(field_of(p.validate().unwrap_err()), name);
    }
}
