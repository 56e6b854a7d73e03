//! ICP refinement (`icp::align`, what a loop match runs after the correlative search) on a
//! loop-closure-sized case: a map of rectangle and circle outlines over ~20 m × 20 m (a point
//! every 0.05 m), a 1-in-4 subsample of it as the scan seen from 0.3 m and 2° off, 0.03 m noise.
//! Point-to-line (the default: a local line fitted at each matched map point, on first use)
//! beside point-to-point, its baseline; and building the map (`PointMap::extend`) for each.
//!
//! Group `tracking`: what tracking runs on every frame against the keyframe map, on the same
//! scene and scan: `match_scan` against the map's cell Gaussians (`DistributionMap`, 0.5 m cells,
//! the 4 nearest within 0.5 m per scan point), building that map, and the association
//! statistics' nearest-point queries (`PointGrid`, a 0.5 m gate) for every scan point.
//!
//! `cargo bench -p nrslam-association --bench icp`

#[path = "common/mod.rs"]
mod common;

use common::scene;
use criterion::{criterion_group, criterion_main, Criterion};
use nrslam_association::scan_matcher::{match_scan, RadarPoint};
use nrslam_association::{align, IcpMetric, Params, PointMap, Pose2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::hint::black_box;

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

    let params = Params::default();
    let mut group = c.benchmark_group("tracking");
    group.sample_size(20);
    let radar: Vec<RadarPoint> = scan
        .iter()
        .map(|&position_m| RadarPoint {
            position_m,
            range_std_m: 0.03,
            angle_std_rad: 1f64.to_radians(),
        })
        .collect();
    let build_cells = || {
        let mut cells = params.distribution_map();
        cells.extend(&map_points);
        cells
    };
    group.bench_function("cells/build_map", |b| b.iter(|| black_box(build_cells())));
    let cells = build_cells();
    let settings = params.tracking_settings(0.3);
    group.bench_function("cells/match_scan", |b| {
        b.iter(|| match_scan(&cells, black_box(&radar), initial, &settings))
    });
    let mut grid = params.statistics_grid();
    grid.extend(&map_points);
    group.bench_function("statistics/nearest_within_gate", |b| {
        b.iter(|| {
            scan.iter()
                .filter_map(|p| grid.nearest_within_gate_m2(black_box(p)))
                .sum::<f64>()
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
