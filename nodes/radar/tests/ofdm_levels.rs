//! The `spectral` and `waveform` fidelity levels on the real hall: what they publish, and that
//! the energy sits where the visible scatterers are.

use nrslam_msgs::topics::{DETECTIONS, ECHO, SPECTRUM};
use nrslam_msgs::Message;
use nrslam_radar::{build, Fidelity, Params};
use nrslam_runtime::{NodeContext, Outbox, Tick};
use std::path::PathBuf;

fn context() -> NodeContext {
    let mut ctx = NodeContext::for_tests(3);
    ctx.name = "radar".into();
    ctx.base_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..");
    ctx
}

fn first_frame(params: Params) -> Vec<(&'static str, Message)> {
    let mut node = build(params, &context()).unwrap();
    let mut outbox = Outbox::new();
    assert_eq!(node.tick(&mut outbox).unwrap(), Tick::More);
    outbox.drain().collect()
}

#[test]
fn spectral_publishes_a_range_angle_map_with_energy_at_the_scatterers() {
    let params = Params {
        fidelity: Fidelity::Spectral,
        ..Params::default()
    };
    let messages = first_frame(params.clone());
    let node = build(params, &context()).unwrap();
    assert!(node.outputs().contains(&SPECTRUM) && !node.outputs().contains(&DETECTIONS));
    let spectrum = messages
        .iter()
        .find_map(|(topic, m)| match m {
            Message::RadarSpectrum(s) if *topic == SPECTRUM => Some(s.clone()),
            _ => None,
        })
        .expect("a spectrum");
    let cells = (spectrum.range_bins * spectrum.angle_bins) as usize;
    assert_eq!(spectrum.values.len(), 2 * cells);
    assert!((spectrum.range_bin_m - 0.122).abs() < 0.001);
    let powers: Vec<f64> = spectrum
        .values
        .chunks(2)
        .map(|c| c[0] * c[0] + c[1] * c[1])
        .collect();
    let peak = powers.iter().copied().fold(0.0, f64::max);
    // Processing gain N·K = 327680 (55 dB) over the per-cell noise: scatterers stand far out.
    assert!(
        peak > 1e3 * spectrum.noise_power,
        "peak {peak} noise {}",
        spectrum.noise_power
    );
    let mut sorted = powers.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    assert!(
        median < 100.0 * spectrum.noise_power,
        "most cells hold noise only: median {median}"
    );
}

#[test]
fn waveform_publishes_resource_grids_of_the_configured_size() {
    let mut params = Params {
        fidelity: Fidelity::Waveform,
        ..Params::default()
    };
    params.ofdm.subcarriers = 1024;
    params.ofdm.antennas = 8;
    let messages = first_frame(params);
    let echo = messages
        .iter()
        .find_map(|(topic, m)| match m {
            Message::RadarEcho(e) if *topic == ECHO => Some(e.clone()),
            _ => None,
        })
        .expect("an echo");
    assert_eq!(
        (echo.antennas, echo.symbols, echo.subcarriers),
        (8, 1, 1024)
    );
    assert_eq!(echo.received.len(), 2 * 8 * 1024);
    assert_eq!(echo.transmitted.len(), 2 * 1024);
    assert!(echo.received.iter().all(|v| v.is_finite()));
}

#[test]
fn same_seed_same_spectrum() {
    let params = Params {
        fidelity: Fidelity::Spectral,
        frames: 2,
        ..Params::default()
    };
    assert_eq!(first_frame(params.clone()), first_frame(params));
}
