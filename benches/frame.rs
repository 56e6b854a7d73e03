//! Whole frames: the paper's 5G graph (launch/paper-5g.toml, loop closure on, viz off) run by the
//! `nrslam` binary for 20 and for 60 frames, in-process and as one OS process per node over zenoh
//! (`--mode processes`). Each sample is a whole process, start-up included; the marginal cost of
//! a frame is (t(60) − t(20)) / 40, which cancels start-up and the first keyframes' set-up. The
//! in-process run is the baseline of the processes run: their ratio is what zenoh costs.
//!
//!   cargo bench --bench frame
//!
//! The stage benches (synthesis, estimator, association, loop search, mapper, DBSCAN, metrics)
//! are in each crate's `benches/`; docs/performance.md gathers the figures.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use std::path::Path;
use std::process::Command;

fn run(mode: &str, frames: u32, out: &Path) {
    let status = Command::new(env!("CARGO_BIN_EXE_nrslam"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["launch", "launch/paper-5g.toml", "viz:=false"])
        .arg(format!("frames:={frames}"))
        .args(["--mode", mode, "--out"])
        .arg(out)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .expect("nrslam runs");
    assert!(status.success(), "nrslam launch --mode {mode} failed");
}

fn frames(c: &mut Criterion) {
    let out = tempfile::tempdir().unwrap();
    let mut group = c.benchmark_group("frame_5g");
    group.sample_size(10);
    for mode in ["in-process", "processes"] {
        for frames in [20, 60] {
            group.bench_with_input(BenchmarkId::new(mode, frames), &frames, |b, &f| {
                b.iter(|| run(mode, f, out.path()))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, frames);
criterion_main!(benches);
