//! Real graphs end to end: the paper-ideal launch in one process and as one OS process per node
//! over zenoh, the outputs it must write, the trend of ET-GOPSA, and an outside zenoh client.

mod common;
use common::*;
use std::path::Path;

fn launch(out: &Path, extra: &[&str]) {
    let mut args = vec![
        "launch",
        "launch/paper-ideal.toml",
        "--seed",
        "7",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    run_ok(&args);
}

#[test]
fn zenoh_processes_and_in_process_agree_bit_for_bit() {
    let dir = temp();
    let (a, b) = (dir.path().join("in-process"), dir.path().join("processes"));
    launch(&a, &["frames:=60"]);
    launch(&b, &["frames:=60", "--mode", "processes"]);
    assert_eq!(read(&a.join("summary.json")), read(&b.join("summary.json")));
    assert_eq!(read(&a.join("metrics.csv")), read(&b.join("metrics.csv")));
    let summary = summary(&a);
    assert_eq!(summary["frames"], 60);
    assert_eq!(summary["metric_steps"], 60);
}

#[test]
fn a_full_run_writes_every_output_and_etgospa_falls_as_the_map_fills() {
    let dir = temp();
    let (good, noisy) = (dir.path().join("good"), dir.path().join("noisy"));
    launch(&good, &["range_std_m:=0", "angle_std_deg:=1"]);
    launch(&noisy, &["range_std_m:=0.1", "angle_std_deg:=5"]);
    for file in [
        "summary.json",
        "metrics.csv",
        "map.png",
        "segments.png",
        "run.json",
    ] {
        let path = good.join(file);
        assert!(
            std::fs::metadata(&path)
                .map(|m| m.len() > 0)
                .unwrap_or(false),
            "{} missing or empty",
            path.display()
        );
    }
    for png in ["map.png", "segments.png"] {
        let bytes = std::fs::read(good.join(png)).unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{png} is a PNG");
    }
    let metrics = read(&good.join("metrics.csv"));
    let etgospa = csv_column(&metrics, "etgospa");
    let time = csv_column(&metrics, "time_s");
    assert!(time.windows(2).all(|w| w[0] < w[1]), "time_s increases");
    let tenth = etgospa.len() / 10;
    let mean = |values: &[f64]| values.iter().sum::<f64>() / values.len() as f64;
    let early = mean(&etgospa[..tenth]);
    let best_late = etgospa[etgospa.len() / 2..]
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let (first, last) = (etgospa[0], *etgospa.last().unwrap());
    // Per-step values jump as clusters merge and split, and drift (before the loop closes, which it
    // does only near the end of the lap) pushes the map off the truth, so the check is on the trend.
    assert!(best_late < 0.85 * early, "ET-GOPSA should fall as the map fills: first tenth {early}, best of second half {best_late}");
    assert!(
        last < 0.85 * first,
        "final ET-GOPSA {last} should be below the first step's {first}"
    );
    let (good, noisy) = (summary(&good), summary(&noisy));
    let (g, n) = (
        good["etgospa"].as_f64().unwrap(),
        noisy["etgospa"].as_f64().unwrap(),
    );
    assert!(
        g < n,
        "final ET-GOPSA ΔR=0,Δθ=1° ({g}) should be below ΔR=0.1 m,Δθ=5° ({n})"
    );
    assert_eq!(good["arguments"]["angle_std_deg"], 1.0);
    assert_eq!(noisy["arguments"]["range_std_m"], 0.1);
}
