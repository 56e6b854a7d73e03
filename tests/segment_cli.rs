//! `nrslam segment` labels a CSV of points with DBSCAN and keeps every row.

mod common;
use common::*;

#[test]
fn two_blobs_and_a_noise_point() {
    let dir = temp();
    let input = dir.path().join("points.csv");
    let output = dir.path().join("labels.csv");
    let mut text = String::from("x,y\n");
    for i in 0..5 {
        text += &format!("{},0\n", i as f64 * 0.1);
    }
    for i in 0..5 {
        text += &format!("{},10\n", 10.0 + i as f64 * 0.1);
    }
    text += "50,50\n";
    std::fs::write(&input, text).unwrap();
    run_ok(&[
        "segment",
        "--input",
        input.to_str().unwrap(),
        "--eps",
        "0.15",
        "--min-samples",
        "3",
        "--output",
        output.to_str().unwrap(),
    ]);
    let labels: Vec<i32> = read(&output)
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    assert_eq!(labels, vec![0, 0, 0, 0, 0, 1, 1, 1, 1, 1, -1]);
}

#[test]
fn nan_input_is_refused() {
    let dir = temp();
    let input = dir.path().join("points.csv");
    std::fs::write(&input, "x,y\n1,2\nNaN,3\n").unwrap();
    let result = run(&[
        "segment",
        "--input",
        input.to_str().unwrap(),
        "--eps",
        "1",
        "--min-samples",
        "2",
    ]);
    assert!(!result.status.success());
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        stderr.contains("line 3") && !stderr.contains("panicked"),
        "{stderr}"
    );
}
