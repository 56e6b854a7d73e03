//! The floor that the waveform synthesis bench (`nrslam-ofdm`) and the estimator bench and
//! examples (`nrslam-estimator`, by `#[path]`) compare against: the bare rustfft transforms that
//! turning a K × N resource grid into a range × angle map needs (K inverse FFTs of N, N forward
//! FFTs of K, f64, planned once, in place, scratch reused).
// The timing examples time `transform` by hand and leave `bench` unused.
#![allow(dead_code)]

use criterion::{measurement::WallTime, BatchSize, BenchmarkGroup};
use num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use std::hint::black_box;
use std::sync::Arc;

/// The two planned transforms and their shared scratch.
pub struct FftFloor {
    ifft: Arc<dyn Fft<f64>>,
    fft: Arc<dyn Fft<f64>>,
    scratch: Vec<Complex64>,
}

impl FftFloor {
    /// Plans the transforms for `n` subcarriers and `k` antennas.
    pub fn new(n: usize, k: usize) -> Self {
        let mut planner = FftPlanner::<f64>::new();
        let ifft = planner.plan_fft_inverse(n);
        let fft = planner.plan_fft_forward(k);
        let scratch_len = ifft
            .get_inplace_scratch_len()
            .max(fft.get_inplace_scratch_len());
        Self {
            ifft,
            fft,
            scratch: vec![Complex64::new(0.0, 0.0); scratch_len],
        }
    }

    /// The inverse FFTs of N over `kn` and the forward FFTs of K over `nk` (two copies of one
    /// grid, each transformed in place: the floor measures the transforms, not their layout).
    pub fn transform(&mut self, kn: &mut [Complex64], nk: &mut [Complex64]) {
        self.ifft.process_with_scratch(kn, &mut self.scratch);
        self.fft.process_with_scratch(nk, &mut self.scratch);
    }

    /// Benches [`FftFloor::transform`] of fresh copies of `grid` as `floor_rustfft` in `group`.
    pub fn bench(mut self, group: &mut BenchmarkGroup<'_, WallTime>, grid: &[Complex64]) {
        group.bench_function("floor_rustfft", |b| {
            b.iter_batched_ref(
                || (grid.to_vec(), grid.to_vec()),
                |(kn, nk)| {
                    self.transform(kn, nk);
                    black_box((kn[1], nk[1]));
                },
                BatchSize::LargeInput,
            )
        });
    }
}
