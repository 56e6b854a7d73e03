//! The fusion algorithm's cost per keyframe against the number of AGVs (1, 2, 4, 8), all driving
//! one lap of the synthetic box scene from evenly spread start points, every AGV but the first
//! with a start unknown to the others (so each must be found by the whole-map search first).
//!
//!   cargo bench -p nrslam-fusion --bench fusion
//!
//! Each iteration fuses every AGV's lap from scratch; criterion reports the time per lap of all
//! agents, and the throughput in keyframes, so the time per keyframe is read off directly.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use nrslam_association::Pose2;
use nrslam_fusion::{Fusion, Params};
use std::hint::black_box;

mod common;
use common::{lap, observe, scene};

/// Each AGV's keyframes in its own frame (from its start) with what it sees, interleaved in
/// time as the node receives them: (agent, local id, local pose, points).
fn feed(agents: usize) -> Vec<(usize, u32, Pose2, Vec<[f64; 2]>)> {
    let scene = scene(0.0);
    let path = lap(5.0, 4.0, 36.0, 27.0, 1.5);
    let mut feed = Vec::new();
    for k in 0..path.len() {
        for a in 0..agents {
            let offset = a * path.len() / agents;
            let truth = path[(k + offset) % path.len()];
            let start = path[offset];
            let local = if a == 0 {
                truth
            } else {
                start.inverse().compose(&truth)
            };
            feed.push((a, k as u32, local, observe(&scene, &truth)));
        }
    }
    feed
}

fn fuse(agents: usize, feed: &[(usize, u32, Pose2, Vec<[f64; 2]>)]) -> Fusion {
    let mut fusion = Fusion::new(Params {
        agvs: agents as u32,
        ..Params::default()
    });
    for (a, id, pose, points) in feed {
        fusion.add_keyframe(*a, *id, *pose, points.clone()).unwrap();
    }
    fusion
}

fn per_agents(c: &mut Criterion) {
    let mut group = c.benchmark_group("fusion_lap");
    group.sample_size(10);
    for agents in [1usize, 2, 4, 8] {
        let feed = feed(agents);
        let stats = fuse(agents, &feed).stats();
        // What the cost is made of, beside the time: searches and query points scored.
        eprintln!("agents {agents}: keyframes {} {stats:?}", feed.len());
        group.throughput(Throughput::Elements(feed.len() as u64));
        group.bench_with_input(BenchmarkId::from_parameter(agents), &feed, |b, feed| {
            b.iter(|| black_box(fuse(agents, feed)))
        });
    }
    group.finish();
}

criterion_group!(benches, per_agents);
criterion_main!(benches);
