//! DBSCAN on the grid of eps-cells, at the sizes users segment: 10k and 100k points.
//!
//! The points are `scripts/dbscan_peer.py`'s (the same xorshift64* stream, so the same floats):
//! 200 square blobs of 3 m × 3 m on a 10 m pitch (about 50 points per m²) and one point in ten
//! spread uniformly over 200 m × 100 m as noise; eps 0.3 m, min_samples 4. The script times
//! scikit-learn's `DBSCAN.fit` (all cores) on the same points and checks the labels against
//! `nrslam segment`'s; the ratio of the two is in docs/performance.md. The O(n²) reference
//! (`dbscan_brute_force`) runs beside the grid at 10k points as the baseline.
//!
//!   cargo bench -p nrslam-segmenter --bench dbscan

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use nrslam_segmenter::{dbscan_brute_force, Dbscan};
use std::hint::black_box;

/// The benchmark's points; `scripts/dbscan_peer.py` writes the same ones.
fn peer_points(n: usize) -> Vec<[f64; 2]> {
    let mut state: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut uniform = move || {
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    };
    (0..n)
        .map(|i| {
            if i % 10 == 0 {
                [uniform() * 200.0, uniform() * 100.0]
            } else {
                let c = (i % 200) as f64;
                let centre = [
                    (c % 20.0).floor() * 10.0 + 5.0,
                    (c / 20.0).floor() * 10.0 + 5.0,
                ];
                [
                    centre[0] + (uniform() - 0.5) * 3.0,
                    centre[1] + (uniform() - 0.5) * 3.0,
                ]
            }
        })
        .collect()
}

fn dbscan(c: &mut Criterion) {
    let mut group = c.benchmark_group("dbscan");
    group.sample_size(20);
    let model = Dbscan::new(0.3, 4).unwrap();
    for n in [10_000, 100_000] {
        let points = peer_points(n);
        group.bench_with_input(BenchmarkId::new("grid", n), &points, |b, p| {
            b.iter(|| model.fit(black_box(p)).unwrap())
        });
    }
    let points = peer_points(10_000);
    group.bench_with_input(
        BenchmarkId::new("brute_force_reference", 10_000),
        &points,
        |b, p| b.iter(|| dbscan_brute_force(black_box(p), 0.3, 4).unwrap()),
    );
    group.finish();
}

criterion_group!(benches, dbscan);
criterion_main!(benches);
