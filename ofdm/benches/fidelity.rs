//! Per-frame synthesis time of the two fidelities at Table I sizes with M = 1 (N 10240, K 32)
//! for a realistic frame of 70 scatterers (3–20 m, ±60°, unit amplitude, random phase):
//! `spectral::synthesize` (the processed range × angle map directly) against
//! `waveform::synthesize` (the full resource grid), beside the floor of what the waveform path
//! must still spend afterwards: the bare rustfft transforms (K inverse FFTs of N, N forward FFTs
//! of K, planned once, in place, scratch reused). Also the spectral knobs' cost: a wider window
//! (32 cells) and 4 × zero-padding in range and angle. Acceptance bar: spectral ≥ 20 × faster
//! per frame than waveform.
//!
//! `cargo bench -p nrslam-ofdm --bench fidelity -- --warm-up-time 1 --measurement-time 3`

mod floor;

use criterion::{criterion_group, criterion_main, Criterion};
use floor::FftFloor;
use nrslam_ofdm::spectral::{self, SpectralConfig};
use nrslam_ofdm::waveform::{self, WaveformConfig};
use nrslam_ofdm::{FrameRng, OfdmParams, Scatterer};
use num_complex::Complex64;
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;
use std::hint::black_box;

/// Seventy scatterers, ranges uniform in 3–20 m, angles uniform in ±60°, unit amplitude with a
/// random phase, static; fixed seed so every run measures the same frame.
fn frame() -> Vec<Scatterer> {
    let mut rng = FrameRng::seed_from_u64(0x5ca7);
    (0..70)
        .map(|_| Scatterer {
            range_m: rng.random_range(3.0..20.0),
            angle_rad: rng.random_range(-60f64..60.0).to_radians(),
            radial_velocity_mps: 0.0,
            amplitude: Complex64::from_polar(1.0, rng.random_range(-PI..PI)),
        })
        .collect()
}

fn table_one(c: &mut Criterion) {
    let p = OfdmParams {
        symbols: 1,
        ..Default::default()
    };
    let (n, k) = (p.subcarriers, p.antennas);
    assert_eq!((n, k), (10240, 32));
    let scatterers = frame();

    let mut group = c.benchmark_group("fidelity_table1_m1");
    group.sample_size(20);

    let spectral_cfgs = [
        ("spectral_default", SpectralConfig::default()),
        (
            "spectral_window_32",
            SpectralConfig {
                window_cells: 32,
                ..Default::default()
            },
        ),
        (
            "spectral_zero_padding_4x4",
            SpectralConfig {
                range_zero_padding: 4,
                angle_zero_padding: 4,
                ..Default::default()
            },
        ),
    ];
    for (name, cfg) in spectral_cfgs {
        let mut rng = FrameRng::seed_from_u64(1);
        let map = spectral::synthesize(&p, &scatterers, &cfg, &mut rng).unwrap();
        assert!(!map.values.is_empty());
        group.bench_function(name, |b| {
            b.iter(|| {
                black_box(spectral::synthesize(&p, black_box(&scatterers), &cfg, &mut rng).unwrap())
            })
        });
    }

    let wcfg = WaveformConfig::default();
    let mut rng = FrameRng::seed_from_u64(2);
    let grid = waveform::synthesize(&p, &scatterers, &wcfg, &mut rng).unwrap();
    assert_eq!(grid.received.len(), k * n);
    group.bench_function("waveform", |b| {
        b.iter(|| {
            black_box(waveform::synthesize(&p, black_box(&scatterers), &wcfg, &mut rng).unwrap())
        })
    });

    FftFloor::new(n, k).bench(&mut group, &grid.received);
    group.finish();
}

criterion_group!(benches, table_one);
criterion_main!(benches);
