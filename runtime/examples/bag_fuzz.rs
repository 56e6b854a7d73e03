//! Long-run fuzz driver for the bag reader: mutates a small bag N times (bit flips, truncations,
//! huge values over length fields, garbage runs; fixed seed), reads each strictly, recovering and
//! record by record, and reports outcomes. Fails (status 1) on a panic, an altered message let
//! through, or an allocation over 1 MiB + 4 KiB (a length trusted before it was checked).
//!
//!   cargo run --release -p nrslam-runtime --example bag_fuzz -- [N=100000] [SEED=1]

#[path = "../tests/bag_common/mod.rs"]
mod bag_common;
use bag_common::*;
use std::time::Instant;

#[global_allocator]
static WATCH: Watch = Watch;

fn main() {
    let mut args = std::env::args().skip(1);
    let n: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(100_000);
    let seed: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(1);
    let dir = tempfile::tempdir().expect("temp dir");
    let full = bag_with_chunks(dir.path(), "full", 4);
    let bytes = std::fs::read(&full.mcap_path).expect("read bag");
    let target = dir.path().join("m");
    let mut rng = Rng(seed.max(1));
    let started = Instant::now();
    let (mut strict_ok, mut recover_ok, mut with_losses, mut largest) = (0u64, 0u64, 0u64, 0usize);
    let mut failures = Vec::new();
    // Panics are failures; keep their messages off the report.
    std::panic::set_hook(Box::new(|_| {}));
    for case in 0..n {
        let mut mutated = bytes.clone();
        let mut done = Vec::new();
        for _ in 0..1 + rng.below(3) {
            if mutated.len() > 16 {
                done.push(mutate(&mut mutated, &mut rng));
            }
        }
        let path = copy_with(&full, &target, &mutated);
        let result = std::panic::catch_unwind(|| check_mutated(&target, &full.messages));
        match result {
            Ok(Ok(outcome)) => {
                strict_ok += u64::from(outcome.strict_ok);
                recover_ok += u64::from(outcome.recover_ok);
                with_losses += u64::from(outcome.losses > 0);
                largest = largest.max(outcome.largest_allocation);
                if outcome.largest_allocation > (1 << 20) + 4096 {
                    failures.push(format!(
                        "case {case} {done:?}: allocation of {} bytes",
                        outcome.largest_allocation
                    ));
                }
            }
            Ok(Err(e)) => failures.push(format!("case {case} {done:?}: {e}")),
            Err(_) => failures.push(format!("case {case} {done:?}: panicked")),
        }
        let _ = std::fs::remove_file(&path);
        if (case + 1) % 10_000 == 0 {
            eprintln!(
                "{} cases, {:.1} s",
                case + 1,
                started.elapsed().as_secs_f64()
            );
        }
    }
    let _ = std::panic::take_hook();
    println!(
        "{n} mutated bags (seed {seed}, {} bytes, 4 chunks) in {:.1} s: strict ok {strict_ok}, recover ok {recover_ok} ({with_losses} with losses reported), largest allocation while reading {largest} bytes, failures {}",
        bytes.len(),
        started.elapsed().as_secs_f64(),
        failures.len()
    );
    for failure in failures.iter().take(20) {
        println!("  {failure}");
    }
    if !failures.is_empty() {
        std::process::exit(1);
    }
}
