//! The bare-FFT floor with its buffers on transparent huge pages too (the estimator's own buffers
//! are), beside the plain floor and the estimator, best of 300 interleaved: how much of the
//! estimator's lead over the plain floor the huge pages give it (Linux; elsewhere the advice is
//! not given and the two floors coincide).
#[path = "../tests/common/mod.rs"]
mod common;
#[path = "../../../ofdm/benches/floor/mod.rs"]
mod floor;
use common::table_one_frame;
use floor::FftFloor;
use nrslam_estimator::{Estimator, EstimatorConfig};
use num_complex::Complex64;
use std::time::Instant;

const HUGE_PAGE: usize = 2 << 20;

/// `len` copies of `source` in a buffer starting on a 2 MiB boundary, huge pages advised before
/// first touch. Returns the backing vector and the start offset.
fn huge_copy(source: &[Complex64]) -> (Vec<Complex64>, usize) {
    let slack = HUGE_PAGE / std::mem::size_of::<Complex64>();
    let mut v: Vec<Complex64> = Vec::with_capacity(source.len() + slack);
    let addr = v.as_ptr() as usize;
    let start = (addr.next_multiple_of(HUGE_PAGE) - addr) / std::mem::size_of::<Complex64>();
    #[cfg(target_os = "linux")]
    // SAFETY: advice on this vector's own allocation, not yet touched; madvise only changes how
    // its pages are backed.
    unsafe {
        libc::madvise(
            (addr + start * 16) as *mut libc::c_void,
            (source.len() * 16).next_multiple_of(HUGE_PAGE),
            libc::MADV_HUGEPAGE,
        );
    }
    v.resize(start, Complex64::new(0.0, 0.0));
    v.extend_from_slice(source);
    (v, start)
}

fn main() {
    let (p, g) = table_one_frame();
    let mut est = Estimator::new(&p, EstimatorConfig::default()).unwrap();
    let mut floor = FftFloor::new(p.subcarriers, p.antennas);
    let (mut kn, mut nk) = (g.received.clone(), g.received.clone());
    let ((mut hkn, kn0), (mut hnk, nk0)) = (huge_copy(&g.received), huge_copy(&g.received));
    let n = g.received.len();
    let (mut best_e, mut best_f, mut best_h) = (f64::MAX, f64::MAX, f64::MAX);
    for _ in 0..300 {
        let t = Instant::now();
        std::hint::black_box(est.process_grid(&g).unwrap());
        best_e = best_e.min(t.elapsed().as_secs_f64());
        kn.copy_from_slice(&g.received);
        nk.copy_from_slice(&g.received);
        let t = Instant::now();
        floor.transform(&mut kn, &mut nk);
        best_f = best_f.min(t.elapsed().as_secs_f64());
        hkn[kn0..kn0 + n].copy_from_slice(&g.received);
        hnk[nk0..nk0 + n].copy_from_slice(&g.received);
        let t = Instant::now();
        floor.transform(&mut hkn[kn0..kn0 + n], &mut hnk[nk0..nk0 + n]);
        best_h = best_h.min(t.elapsed().as_secs_f64());
    }
    println!(
        "estimator {:.3} ms, floor {:.3} ms (ratio {:.2}), floor on huge pages {:.3} ms (ratio {:.2})",
        best_e * 1e3,
        best_f * 1e3,
        best_e / best_f,
        best_h * 1e3,
        best_e / best_h
    );
}
