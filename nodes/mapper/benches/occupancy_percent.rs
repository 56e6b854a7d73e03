//! The cost of turning a grid's log-odds into ROS occupancy percentages, done for every published
//! map (one per keyframe): one `exp` per cell ([`occupancy_percent`], the definition) against
//! counting the precomputed thresholds ([`occupancy_percent_from`], what the mapper uses; equal
//! to the definition for every f64, see the map module's tests).
//!
//! ```text
//! cargo bench -p nrslam-mapper --bench occupancy_percent
//! ```

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nrslam_mapper::{occupancy_percent, occupancy_percent_from, percent_thresholds};
use std::hint::black_box;

/// Log-odds as a mapped hall holds them: sums of hit (+0.85) and miss (−0.4) updates, clamped
/// to ±3.5, one cell in ten still at 0. A 500 × 400 grid, 0.1 m cells (the hall at the default
/// resolution is of this order).
fn cells() -> Vec<f64> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    (0..200_000)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let hits = (state % 7) as f64;
            let misses = ((state >> 8) % 11) as f64;
            if state.is_multiple_of(10) {
                0.0
            } else {
                (0.85 * hits - 0.4 * misses).clamp(-3.5, 3.5)
            }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let cells = cells();
    let thresholds = percent_thresholds();
    let mut group = c.benchmark_group("occupancy_percent");
    group.throughput(Throughput::Elements(cells.len() as u64));
    group.bench_function("exp per cell", |b| {
        b.iter(|| {
            black_box(&cells)
                .iter()
                .map(|&l| occupancy_percent(l))
                .collect::<Vec<i8>>()
        })
    });
    group.bench_function("threshold table", |b| {
        b.iter(|| {
            black_box(&cells)
                .iter()
                .map(|&l| occupancy_percent_from(thresholds, l))
                .collect::<Vec<i8>>()
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
