//! Times one scan-to-map match: a 300-point scan against a 20,000-point map, for both metrics,
//! and the map rebuild a keyframe costs. A measurement to read, not a test:
//!
//! ```text
//! cargo run --release -p nrslam-association --example icp_timing
//! ```

use std::time::Instant;

use nrslam_association::{align, IcpMetric, Params, PointMap, Pose2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// A random point on the outline of one of a grid of 2 m × 1 m boxes filling a 40 m × 30 m hall,
/// with 5 cm of noise: what accumulated keyframe detections of extended targets look like.
fn outline_point(rng: &mut ChaCha8Rng, noise: &Normal<f64>) -> [f64; 2] {
    let (cx, cy) = (
        f64::from(rng.random_range(0..10u32)) * 4.0 + 2.0,
        f64::from(rng.random_range(0..10u32)) * 3.0 + 1.5,
    );
    let s: f64 = rng.random_range(0.0..6.0);
    let (x, y) = match s {
        s if s < 2.0 => (s - 1.0, -0.5),
        s if s < 3.0 => (1.0, s - 2.5),
        s if s < 5.0 => (4.0 - s, 0.5),
        s => (-1.0, 5.5 - s),
    };
    [cx + x + noise.sample(rng), cy + y + noise.sample(rng)]
}

fn main() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let noise = Normal::new(0.0, 0.05).unwrap();
    let map_points: Vec<[f64; 2]> = (0..20_000)
        .map(|_| outline_point(&mut rng, &noise))
        .collect();
    // The AGV in the middle of the hall; its scan: 300 outline points within 10 m.
    let truth = Pose2::new(20.0, 15.0, 0.3);
    let inverse = truth.inverse();
    let mut scan = Vec::new();
    while scan.len() < 300 {
        let p = outline_point(&mut rng, &noise);
        if (p[0] - truth.x_m).hypot(p[1] - truth.y_m) < 10.0 {
            scan.push(inverse.transform_point(p));
        }
    }
    let initial = Pose2::new(truth.x_m + 0.05, truth.y_m - 0.03, truth.yaw_rad + 0.01);

    for metric in [IcpMetric::PointToPoint, IcpMetric::PointToLine] {
        let params = Params {
            metric,
            ..Params::default()
        };
        let start = Instant::now();
        let mut map = PointMap::for_params(&params);
        map.extend(&map_points);
        let build_ms = start.elapsed().as_secs_f64() * 1e3;

        let runs = 200;
        let mut result = align(&map, &scan, initial, &params);
        let start = Instant::now();
        for _ in 0..runs {
            result = align(&map, &scan, initial, &params);
        }
        let align_us = start.elapsed().as_secs_f64() * 1e6 / f64::from(runs);

        // What a keyframe costs: its 300 points join the 20k map.
        let start = Instant::now();
        map.extend(
            &scan
                .iter()
                .map(|&p| truth.transform_point(p))
                .collect::<Vec<_>>(),
        );
        let keyframe_ms = start.elapsed().as_secs_f64() * 1e3;
        println!(
            "{metric:?}: align {align_us:.0} µs ({} iterations, {:?}, error {:.1} mm); \
             map build 20k {build_ms:.1} ms; keyframe rebuild {keyframe_ms:.1} ms",
            result.iterations,
            result.status,
            result.pose.distance_m(&truth) * 1e3,
        );
    }
}
