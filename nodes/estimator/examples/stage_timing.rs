//! Quick interleaved timing of the estimator against the bare-FFT floor (minimum over reps,
//! robust to a loaded machine). Not part of the acceptance measurement (that is the bench).
#[path = "../tests/common/mod.rs"]
mod common;
#[path = "../../../ofdm/benches/floor/mod.rs"]
mod floor;
use common::table_one_frame;
use floor::FftFloor;
use nrslam_estimator::{Estimator, EstimatorConfig};
use std::time::Instant;
fn main() {
    let (p, g) = table_one_frame();
    let mut est = Estimator::new(&p, EstimatorConfig::default()).unwrap();
    let mut floor = FftFloor::new(p.subcarriers, p.antennas);
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
        floor.transform(&mut kn, &mut nk);
        best_f = best_f.min(t.elapsed().as_secs_f64());
    }
    println!(
        "estimator {:.3} ms, floor {:.3} ms, ratio {:.2}",
        best_e * 1e3,
        best_f * 1e3,
        best_e / best_f
    );
}
