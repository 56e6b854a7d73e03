//! Monte Carlo studies: the result depends on the seed alone, not on threads or shards.

mod common;
use common::*;
use std::path::Path;

fn study(out: &Path, extra: &[&str]) {
    let mut args = vec![
        "montecarlo",
        "launch/paper-ideal.toml",
        "frames:=15",
        "--trials",
        "6",
        "--seed",
        "9",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    run_ok(&args);
}

#[test]
fn threads_and_shards_do_not_change_the_numbers() {
    let dir = temp();
    let root = dir.path();
    study(&root.join("one-thread"), &["--threads", "1"]);
    study(&root.join("two-threads"), &["--threads", "2"]);
    study(&root.join("shard1"), &["--shard", "1/2"]);
    study(&root.join("shard2"), &["--shard", "2/2"]);
    let merged = root.join("merged");
    run_ok(&[
        "merge",
        root.join("shard1").to_str().unwrap(),
        root.join("shard2").to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    for file in ["trials.csv", "montecarlo.csv"] {
        let reference = read(&root.join("one-thread").join(file));
        assert_eq!(
            reference,
            read(&root.join("two-threads").join(file)),
            "{file}: threads"
        );
        assert_eq!(reference, read(&merged.join(file)), "{file}: merged shards");
    }
    let table = read(&root.join("one-thread/montecarlo.csv"));
    assert_eq!(table.lines().count(), 16, "header + one row per step");
    // Trials differ (each has its own seed), so the spread of the position error is not zero.
    let last: Vec<&str> = table.lines().last().unwrap().split(',').collect();
    assert_eq!(last[2], "6");
    let header: Vec<&str> = table.lines().next().unwrap().split(',').collect();
    let std_column = header
        .iter()
        .position(|h| *h == "position_error_m_std")
        .unwrap();
    assert!(last[std_column].parse::<f64>().unwrap() > 0.0);
}

#[test]
fn merging_a_shard_twice_is_refused() {
    let dir = temp();
    study(&dir.path().join("a"), &["--shard", "1/2"]);
    let a = dir.path().join("a");
    let output = run(&[
        "merge",
        a.to_str().unwrap(),
        a.to_str().unwrap(),
        "--out",
        dir.path().join("m").to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("two shards"));
}
