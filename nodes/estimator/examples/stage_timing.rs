//! Quick interleaved timing of the estimator against the bare-FFT floor (minimum over reps,
//! robust to a loaded machine). Not part of the acceptance measurement (that is the bench).
#[path = "../tests/common/mod.rs"]
mod common;
use common::{grid, params, twenty_echoes};
use nrslam_estimator::{Estimator, EstimatorConfig};
use num_complex::Complex64;
use rustfft::FftPlanner;
use std::time::Instant;
fn main() {
    let p = params(10240, 32, 1);
    let echoes = twenty_echoes(&p);
    let g = grid(&p, &echoes, Some(p.snr_db), 1);
    let mut est = Estimator::new(&p, EstimatorConfig::default()).unwrap();
    let mut planner = FftPlanner::<f64>::new();
    let ifft = planner.plan_fft_inverse(10240);
    let fft = planner.plan_fft_forward(32);
    let mut scratch = vec![Complex64::new(0.0, 0.0); 20480];
    let (mut kn, mut nk) = (g.received.clone(), g.received.clone());
    let (mut best_e, mut best_f) = (f64::MAX, f64::MAX);
    let only_estimator = std::env::var_os("ONLY_ESTIMATOR").is_some();
    for _ in 0..300 {
        let t = Instant::now();
        std::hint::black_box(est.process_grid(&g).unwrap());
        best_e = best_e.min(t.elapsed().as_secs_f64());
        if only_estimator {
            continue;
        }
        kn.copy_from_slice(&g.received);
        nk.copy_from_slice(&g.received);
        let t = Instant::now();
        ifft.process_with_scratch(&mut kn, &mut scratch);
        fft.process_with_scratch(&mut nk, &mut scratch);
        best_f = best_f.min(t.elapsed().as_secs_f64());
    }
    println!(
        "estimator {:.3} ms, floor {:.3} ms, ratio {:.2}",
        best_e * 1e3,
        best_f * 1e3,
        best_e / best_f
    );
}
