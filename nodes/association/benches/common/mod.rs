//! Synthetic scenes and pose graphs shared by the benches and the crate's unit tests (which
//! include this file as `crate::fixtures`): outlines of rectangles and circles, and an AGV lapping
//! a square hall with drifting odometry.
#![allow(dead_code)]

use nrslam_association::correlative::Kernel;
use nrslam_association::{Edge, EdgeKind, MultiResolutionGrid, Pose2, PoseGraph, ProbabilityGrid};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

/// The outlines of `boxes` (x0, y0, width, height) and `circles` (centre x, centre y, radius),
/// in metres, a point every `spacing_m`.
pub fn outlines(
    boxes: &[(f64, f64, f64, f64)],
    circles: &[(f64, f64, f64)],
    spacing_m: f64,
) -> Vec<[f64; 2]> {
    let mut points = Vec::new();
    for &(x0, y0, w, h) in boxes {
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
    for &(cx, cy, r) in circles {
        let n = (2.0 * PI * r / spacing_m).round() as usize;
        for k in 0..n {
            let a = 2.0 * PI * k as f64 / n as f64;
            points.push([cx + r * a.cos(), cy + r * a.sin()]);
        }
    }
    points
}

/// The benches' scene: outlines of a few rectangles and circles over about 20 m × 20 m, a point
/// every `spacing_m`.
pub fn scene(spacing_m: f64) -> Vec<[f64; 2]> {
    outlines(
        &[
            (-8.0, -7.0, 3.0, 2.0),
            (-2.0, -8.0, 5.0, 1.5),
            (5.0, -6.0, 2.0, 4.0),
            (-9.0, 1.0, 1.5, 5.0),
            (-3.0, 4.0, 4.0, 2.0),
            (6.0, 5.0, 3.0, 3.0),
        ],
        &[(0.0, 0.0, 1.2), (3.0, 1.5, 0.6), (-5.5, -2.0, 0.9)],
        spacing_m,
    )
}

/// Truth for `n` keyframes 1 m apart round a square of `side` steps per side, turning 90° at
/// each corner, lap after lap.
pub fn laps(side: usize, n: usize) -> Vec<Pose2> {
    let mut poses = vec![Pose2::IDENTITY];
    for k in 1..n {
        let turn = if k % side == 0 {
            std::f64::consts::FRAC_PI_2
        } else {
            0.0
        };
        let last = *poses.last().expect("starts with one pose");
        poses.push(last.compose(&Pose2::new(1.0, 0.0, turn)));
    }
    poses
}

/// How odometry drifts from the truth: uniform noise of ± `step_m` per axis and ± `yaw_rad`
/// plus a systematic `yaw_bias_rad` per step; its edges are weighted with `std_m`, `std_rad`.
pub struct Drift {
    pub step_m: f64,
    pub yaw_rad: f64,
    pub yaw_bias_rad: f64,
    pub std_m: f64,
    pub std_rad: f64,
}

/// A graph of the poses dead-reckoned from drifting odometry over `truth`, with its odometry
/// edges, the noise drawn from `rng`.
pub fn odometry_graph(truth: &[Pose2], rng: &mut ChaCha8Rng, drift: &Drift) -> PoseGraph {
    let mut graph = PoseGraph::new();
    let mut estimate = truth[0];
    graph.add_node(estimate);
    for k in 1..truth.len() {
        let exact = truth[k - 1].between(&truth[k]);
        let noisy = Pose2::new(
            exact.x_m + rng.random_range(-drift.step_m..drift.step_m),
            exact.y_m + rng.random_range(-drift.step_m..drift.step_m),
            exact.yaw_rad + drift.yaw_bias_rad + rng.random_range(-drift.yaw_rad..drift.yaw_rad),
        );
        estimate = estimate.compose(&noisy);
        graph.add_node(estimate);
        graph.add_edge(Edge::with_std(
            k - 1,
            k,
            noisy,
            drift.std_m,
            drift.std_rad,
            EdgeKind::Odometry,
        ));
    }
    graph
}

/// Odometry with a heading bias over `truth` (seeded by `seed`), and `loops` loop edges spread
/// over the run, each from a node to the same place one to three laps (`lap` nodes) earlier.
pub fn multi_lap_graph(truth: &[Pose2], lap: usize, loops: usize, seed: u64) -> PoseGraph {
    let drift = Drift {
        step_m: 0.01,
        yaw_rad: 0.002,
        yaw_bias_rad: 0.0005,
        std_m: 0.02,
        std_rad: 0.005,
    };
    let mut graph = odometry_graph(truth, &mut ChaCha8Rng::seed_from_u64(seed), &drift);
    let n = truth.len();
    for m in 0..loops {
        let to = lap + m * (n - 1 - lap) / (loops - 1).max(1);
        let laps_back = 1 + m % 3.min(to / lap);
        let from = to - laps_back * lap;
        let z = truth[from].between(&truth[to]);
        assert!(graph.add_edge(Edge::with_std(from, to, z, 0.05, 0.01, EdgeKind::Loop)));
    }
    graph
}

/// The correlative matcher's grids over `points`: cells of `cell_m` filled with `kernel`, stored
/// with `pad_cells` of zeros around them, `depth` levels.
pub fn build_grids(
    points: &[[f64; 2]],
    cell_m: f64,
    kernel: Kernel,
    pad_cells: usize,
    depth: u32,
) -> MultiResolutionGrid {
    let grid = ProbabilityGrid::with_kernel(points, cell_m, kernel).unwrap();
    MultiResolutionGrid::new(grid.padded(pad_cells, depth), depth).unwrap()
}

/// The padding `MultiResolutionGrid::for_window` gives a window of `window_m` either side on
/// cells of `cell_m`: twice its steps.
pub fn window_pad(window_m: f64, cell_m: f64) -> usize {
    2 * (window_m / cell_m).ceil() as usize
}
