//! The shape fit per segment, at the sizes the paper's map gives (0.1 m cells: 50–200 cells per
//! target), and a tracker update of a hall-sized map when nothing changed (the cache) against
//! one when every segment is new (after a loop closure's rebuild).
//!
//!   cargo bench -p nrslam-shapes --bench fit

use criterion::{criterion_group, criterion_main, Criterion};
use nrslam_shapes::{fit, Params, ShapeTracker};
use std::hint::black_box;

/// Cells of a band `thickness_m` wide along a polyline, on a 0.1 m grid, deterministic.
fn band(polyline: &[[f64; 2]], thickness_m: f64) -> Vec<[f64; 2]> {
    let mut cells = std::collections::BTreeSet::new();
    for pair in polyline.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let length = (b[0] - a[0]).hypot(b[1] - a[1]);
        let normal = [-(b[1] - a[1]) / length, (b[0] - a[0]) / length];
        let steps = (length / 0.03).ceil() as usize;
        for i in 0..=steps {
            let t = i as f64 / steps as f64;
            // A deterministic spread across the band, a few cells thick.
            let across = thickness_m * (((i * 7919) % 101) as f64 / 100.0 - 0.5);
            let x = a[0] + t * (b[0] - a[0]) + across * normal[0];
            let y = a[1] + t * (b[1] - a[1]) + across * normal[1];
            cells.insert(((x / 0.1).floor() as i64, (y / 0.1).floor() as i64));
        }
    }
    cells
        .into_iter()
        .map(|(i, j)| [(i as f64 + 0.5) * 0.1, (j as f64 + 0.5) * 0.1])
        .collect()
}

fn segments() -> Vec<(&'static str, Vec<[f64; 2]>)> {
    let arc: Vec<[f64; 2]> = (0..=40)
        .map(|k| {
            let phi = -2.0 + 2.5 * k as f64 / 40.0;
            [31.0 + 1.5 * phi.cos(), 13.0 + 1.5 * phi.sin()]
        })
        .collect();
    vec![
        (
            "rectangle, 4 sides",
            band(
                &[
                    [10.0, 11.5],
                    [14.0, 11.5],
                    [14.0, 14.5],
                    [10.0, 14.5],
                    [10.0, 11.5],
                ],
                0.3,
            ),
        ),
        (
            "rectangle, L",
            band(&[[19.5, 13.75], [19.5, 12.25], [24.5, 12.25]], 0.3),
        ),
        (
            "rectangle, 1 side",
            band(&[[29.0, 31.25], [37.0, 31.25]], 0.3),
        ),
        ("circle arc", band(&arc, 0.3)),
    ]
}

fn bench(c: &mut Criterion) {
    let params = Params::default();
    let viewpoints = [[25.0, 18.0], [5.0, 5.0]];
    let segments = segments();
    let mut group = c.benchmark_group("fit");
    for (name, points) in &segments {
        group.bench_function(format!("{name} ({} cells)", points.len()), |b| {
            b.iter(|| fit(black_box(points), &viewpoints, &params))
        });
    }
    group.finish();
    // A map of 10 targets (the hall), unchanged since the last update or all new.
    let map: Vec<Vec<[f64; 2]>> = (0..10)
        .map(|k| {
            let (dx, dy) = (10.0 * (k % 5) as f64, 10.0 * (k / 5) as f64);
            let (_, points) = &segments[k % segments.len()];
            points.iter().map(|p| [p[0] + dx, p[1] + dy]).collect()
        })
        .collect();
    let mut group = c.benchmark_group("tracker update, 10 targets");
    group.bench_function("unchanged map (cached fits)", |b| {
        let mut tracker = ShapeTracker::new(params.clone());
        tracker.update(&map, &viewpoints);
        b.iter(|| tracker.update(black_box(&map), &viewpoints))
    });
    group.bench_function("every segment new (after a rebuild)", |b| {
        b.iter(|| ShapeTracker::new(params.clone()).update(black_box(&map), &viewpoints))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
