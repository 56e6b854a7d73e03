//! ICP refinement (`icp::align`, what a loop match runs after the correlative search) on a
//! loop-closure-sized case: a map of rectangle and circle outlines over ~20 m × 20 m (a point
//! every 0.05 m), a 1-in-4 subsample of it as the scan seen from 0.3 m and 2° off, 0.03 m noise.
//! Point-to-line (the default: a local line fitted at each matched map point, on first use)
//! beside point-to-point, its baseline; and building the map (`PointMap::extend`) for each.
//!
//! `cargo bench -p nrslam-association --bench icp`

use criterion::{criterion_group, criterion_main, Criterion};
use nrslam_association::{align, IcpMetric, Params, PointMap, Pose2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::f64::consts::PI;
use std::hint::black_box;

fn scene(spacing_m: f64) -> Vec<[f64; 2]> {
    let mut points = Vec::new();
    for &(x0, y0, w, h) in &[
        (-8.0, -7.0, 3.0, 2.0),
        (-2.0, -8.0, 5.0, 1.5),
        (5.0, -6.0, 2.0, 4.0),
        (-9.0, 1.0, 1.5, 5.0),
        (-3.0, 4.0, 4.0, 2.0),
        (6.0, 5.0, 3.0, 3.0),
    ] {
        let corners = [[x0, y0], [x0 + w, y0], [x0 + w, y0 + h], [x0, y0 + h]];
        for i in 0..4 {
            let (a, b): ([f64; 2], [f64; 2]) = (corners[i], corners[(i + 1) % 4]);
            let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / spacing_m).round() as usize;
            for k in 0..n {
                let s = k as f64 / n as f64;
                points.push([a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])]);
            }
        }
    }
    for &(cx, cy, r) in &[(0.0, 0.0, 1.2), (3.0, 1.5, 0.6), (-5.5, -2.0, 0.9)] {
        let n = (2.0 * PI * r / spacing_m).round() as usize;
        for k in 0..n {
            let a = 2.0 * PI * k as f64 / n as f64;
            points.push([cx + r * a.cos(), cy + r * a.sin()]);
        }
    }
    points
}

fn bench(c: &mut Criterion) {
    let map_points = scene(0.05);
    let truth = Pose2 {
        x_m: 0.3,
        y_m: -0.2,
        yaw_rad: 2f64.to_radians(),
    };
    // The scan in the AGV frame: map points seen from `truth`, with noise.
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let noise = Normal::new(0.0, 0.03).unwrap();
    let (sin, cos) = truth.yaw_rad.sin_cos();
    let scan: Vec<[f64; 2]> = map_points
        .iter()
        .step_by(4)
        .map(|p| {
            let (dx, dy) = (p[0] - truth.x_m, p[1] - truth.y_m);
            [
                cos * dx + sin * dy + noise.sample(&mut rng),
                -sin * dx + cos * dy + noise.sample(&mut rng),
            ]
        })
        .collect();
    let initial = Pose2 {
        x_m: 0.0,
        y_m: 0.0,
        yaw_rad: 0.0,
    };
    let mut group = c.benchmark_group("icp");
    group.sample_size(20);
    for (name, metric) in [
        ("point_to_line", IcpMetric::PointToLine),
        ("point_to_point", IcpMetric::PointToPoint),
    ] {
        let params = Params {
            metric,
            ..Params::default()
        };
        group.bench_function(format!("{name}/build_map"), |b| {
            b.iter(|| {
                let mut map = PointMap::for_params(&params);
                map.extend(black_box(&map_points));
                map
            })
        });
        group.bench_function(format!("{name}/build_map_and_align"), |b| {
            b.iter(|| {
                let mut map = PointMap::for_params(&params);
                map.extend(&map_points);
                align(&map, black_box(&scan), initial, &params)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
