//! One keyframe into the occupancy grid, at the hall's scale (60 m × 50 m at 0.1 m, 300,000
//! cells): 40 detections at 5–20 m, the paper's ideal-condition scan. With free-space rays (the
//! default: every beam lowers the cells it crosses) beside hits only (`free_space = false`, the
//! paper's raw maps), the baseline this knob's cost is measured against; and the published map's
//! conversion (`to_occupancy_grid`, one per keyframe).
//!
//! ```text
//! cargo bench -p nrslam-mapper --bench keyframe
//! ```

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use nrslam_mapper::{OccupancyMap, Params, Pose2};
use nrslam_msgs::{Detection, Time};
use std::hint::black_box;

fn scan() -> Vec<Detection> {
    (0..40)
        .map(|i| Detection {
            range_m: 5.0 + 15.0 * f64::from(i % 8) / 7.0,
            angle_rad: -1.2 + 2.4 * f64::from(i) / 39.0,
            range_std_m: 0.1,
            angle_std_rad: 0.0175,
            power_db: 20.0,
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let detections = scan();
    let pose = Pose2 {
        x_m: 20.0,
        y_m: 15.0,
        yaw_rad: 0.3,
    };
    let mut group = c.benchmark_group("mapper_keyframe");
    for (name, free_space) in [("free_space_rays", true), ("hits_only", false)] {
        let params = Params {
            free_space,
            ..Params::default()
        };
        let empty = OccupancyMap::new(&params).unwrap();
        group.bench_function(name, |b| {
            b.iter_batched_ref(
                || empty.clone(),
                |map| {
                    map.integrate_detections(pose, 1.5, black_box(&detections))
                        .unwrap()
                },
                BatchSize::LargeInput,
            )
        });
    }
    let mut map = OccupancyMap::new(&Params::default()).unwrap();
    map.integrate_detections(pose, 1.5, &detections).unwrap();
    group.bench_function("to_occupancy_grid", |b| {
        b.iter(|| black_box(map.to_occupancy_grid(Time::from_seconds(1.0))))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
