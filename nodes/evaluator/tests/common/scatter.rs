//! Deterministic spread-out point sets for the large-input tests and the benchmarks.

use nrslam_evaluator::Point2;

/// Deterministic pseudo-random points (xorshift), uniform in [0, extent)².
pub fn scatter(n: usize, extent: f64, seed: u64) -> Vec<Point2> {
    let mut state = seed.max(1);
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| Point2::new(next() * extent, next() * extent))
        .collect()
}
