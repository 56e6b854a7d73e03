//! GOSPA and ET-GOPSA by components (what `gospa` / `etgospa` use) beside the dense assignment
//! over all pairs, in the same run, on point sets spread over a square much wider than the
//! cut-off c = 5 m (most pairs beyond c), and on small sets (where `gospa` uses the dense solver).
//!
//! ```text
//! cargo bench -p nrslam-evaluator --bench metrics
//! ```

use criterion::measurement::WallTime;
use criterion::{criterion_group, criterion_main, BenchmarkGroup, BenchmarkId, Criterion};
use nrslam_evaluator::{
    etgospa_dense, etgospa_sparse, gospa_dense, gospa_sparse, EtGospaParams, ExtendedTarget,
    GospaParams, Point2,
};
use std::hint::black_box;

#[path = "../tests/common/scatter.rs"]
mod scatter;
use scatter::scatter;

/// Targets of 4 samples within 1 m of each other, one per 4 points of `points`.
fn targets(points: &[Point2]) -> Vec<ExtendedTarget> {
    points
        .chunks(4)
        .map(|c| {
            let o = c[0];
            ExtendedTarget::from_samples(
                c.iter()
                    .enumerate()
                    .map(|(k, _)| Point2::new(o.x_m + (k % 2) as f64, o.y_m + (k / 2) as f64))
                    .collect(),
            )
        })
        .collect()
}

/// Times the component solver against the dense one on the input named `id`.
fn compare<T>(
    group: &mut BenchmarkGroup<'_, WallTime>,
    id: &str,
    components: impl Fn() -> T,
    dense: impl Fn() -> T,
) {
    group.bench_with_input(BenchmarkId::new("components", id), &(), |b, _| {
        b.iter(&components)
    });
    group.bench_with_input(BenchmarkId::new("dense", id), &(), |b, _| b.iter(&dense));
}

fn gospa_bench(c: &mut Criterion) {
    let params = GospaParams::default();
    let mut group = c.benchmark_group("gospa");
    group.sample_size(10);
    // (points per side, extent m): 1000 over 300 m is the `nrslam metric` comparison with SciPy;
    // the small sizes decide where the dense solver is used.
    for (n, extent) in [
        (4usize, 10.0),
        (8, 20.0),
        (16, 30.0),
        (64, 80.0),
        (1000, 300.0),
    ] {
        let x = scatter(n, extent, 1);
        let y = scatter(n, extent, 2);
        let id = format!("{n}x{n}_{extent}m");
        compare(
            &mut group,
            &id,
            || gospa_sparse(black_box(&x), black_box(&y), &params).unwrap(),
            || gospa_dense(black_box(&x), black_box(&y), &params).unwrap(),
        );
    }
    group.finish();
}

fn etgospa_bench(c: &mut Criterion) {
    let params = EtGospaParams::default();
    let mut group = c.benchmark_group("etgospa");
    group.sample_size(10);
    for (n, extent) in [(4usize, 10.0), (16, 30.0), (1000, 300.0)] {
        let truth = targets(&scatter(n, extent, 1));
        let y = scatter(n, extent, 2);
        let id = format!("{n}x{n}_{extent}m");
        compare(
            &mut group,
            &id,
            || etgospa_sparse(black_box(&truth), black_box(&y), &params).unwrap(),
            || etgospa_dense(black_box(&truth), black_box(&y), &params).unwrap(),
        );
    }
    group.finish();
}

criterion_group!(benches, gospa_bench, etgospa_bench);
criterion_main!(benches);
