//! `nrslam reproduce` writes every figure with its CSV; Fig. 4 shows what ET-GOPSA sees and
//! GOSPA does not.

mod common;
use common::*;

/// `nrslam reproduce` of 2 trials of 6 frames into `out`, with `extra` flags; it must succeed.
fn quick_reproduce(out: &std::path::Path, extra: &[&str]) {
    let mut args = vec![
        "reproduce",
        "--out",
        out.to_str().unwrap(),
        "--trials",
        "2",
        "--frames",
        "6",
    ];
    args.extend_from_slice(extra);
    let output = run(&args);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}

#[test]
fn quick_reproduce_writes_every_figure() {
    let dir = temp();
    let out = dir.path();
    quick_reproduce(out, &[]);
    for file in [
        "fig4.png",
        "fig4.csv",
        "fig6.png",
        "fig6.csv",
        "fig7.png",
        "fig7.csv",
        "fig5/map.png",
        "fig5/segments.png",
        "fig3/r0_a1/map.png",
        "fig3/r0.1_a5/segments.png",
    ] {
        assert!(out.join(file).exists(), "{file} missing");
    }
    let timing: serde_json::Value =
        serde_json::from_str(&read(&out.join("reproduce.json"))).expect("reproduce.json is JSON");
    assert_eq!(timing["trials"], 2);
    assert!(timing["wall_time_s"].as_f64().unwrap() > 0.0);
    assert_eq!(
        timing["wall_time_per_condition_s"]
            .as_object()
            .unwrap()
            .len(),
        5
    );
    let fig6 = read(&out.join("fig6.csv"));
    assert_eq!(
        fig6.lines().next().unwrap(),
        "time_s,5g,r0_a1,r0.1_a1,r0_a5,r0.1_a5"
    );
    assert_eq!(fig6.lines().count(), 7, "header + 6 steps");
    // Fig. 4: y1 and y2 are equally far from x1, so GOSPA cannot tell them apart; y1 is nearer
    // x2, so ET-GOPSA charges it confusion (the paper's eq. GOPSA_10).
    let fig4 = read(&out.join("fig4.csv"));
    let row = |label: &str| -> Vec<f64> {
        let line = fig4.lines().find(|l| l.starts_with(label)).unwrap();
        line.rsplit(',')
            .take(6)
            .map(|v| v.parse().unwrap())
            .collect::<Vec<_>>()
            .into_iter()
            .rev()
            .collect()
    };
    let (y1, y2) = (row("{y1},"), row("{y2},"));
    assert_eq!(y1[0], y2[0], "GOSPA equal");
    assert!(
        y1[1] > y2[1],
        "ET-GOPSA of y1 {} should exceed that of y2 {}",
        y1[1],
        y2[1]
    );
}

/// The value of `column` in the CSV's `row`.
fn value(csv: &str, row: &str, column: &str) -> f64 {
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let index = header.iter().position(|h| *h == column).unwrap();
    row.split(',').nth(index).unwrap().parse().unwrap()
}

/// The last row's value of `column` in a CSV.
fn last_value(csv: &str, column: &str) -> f64 {
    value(csv, csv.lines().last().unwrap(), column)
}

/// The first data row's value of `column` in a CSV.
fn first_value(csv: &str, column: &str) -> f64 {
    value(csv, csv.lines().nth(1).unwrap(), column)
}

#[test]
fn reproduce_with_the_oracle_maps_the_same_trials_at_the_true_poses() {
    let dir = temp();
    let out = dir.path();
    quick_reproduce(out, &["--oracle"]);
    let fig6 = read(&out.join("fig6.csv"));
    assert_eq!(
        fig6.lines().next().unwrap(),
        "time_s,5g,5g_true_poses,r0_a1,r0_a1_true_poses,r0.1_a1,r0.1_a1_true_poses,\
         r0_a5,r0_a5_true_poses,r0.1_a5,r0.1_a5_true_poses"
    );
    // Fig. 7 has no oracle: its position error is 0 up to rounding.
    let fig7 = read(&out.join("fig7.csv"));
    assert_eq!(
        fig7.lines().next().unwrap(),
        "time_s,5g,r0_a1,r0.1_a1,r0_a5,r0.1_a5"
    );
    let oracle = read(&out.join("oracle.csv"));
    let mut lines = oracle.lines();
    assert_eq!(
        lines.next().unwrap(),
        "condition,final_etgospa,final_etgospa_true_poses,ratio"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(rows.len(), 5);
    for row in &rows {
        let condition = row[0];
        let number = |i: usize| -> f64 { row[i].parse().unwrap() };
        // The table is the figure's last step, and its ratio is SLAM over the oracle.
        assert_eq!(number(1), last_value(&fig6, condition), "{condition}");
        let true_poses = format!("{condition}_true_poses");
        assert_eq!(number(2), last_value(&fig6, &true_poses), "{condition}");
        assert!(
            (number(3) - number(1) / number(2)).abs() < 1e-12,
            "{condition}"
        );
        // Same seeds, same detections: before the AGV has moved far, SLAM and the oracle map
        // the same points (different detections would differ from the first frame).
        assert_eq!(
            first_value(&fig6, condition),
            first_value(&fig6, &true_poses),
            "{condition}"
        );
        // The oracle's trials ran at the true poses; the SLAM trials did not.
        let trials = |dir: &str| read(&out.join("montecarlo").join(dir).join("montecarlo.csv"));
        let oracle_trials = trials(&true_poses);
        let slam_trials = trials(condition);
        let max_mse = |csv: &str| -> f64 {
            let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
            let index = header.iter().position(|h| *h == "position_mse_m2").unwrap();
            csv.lines()
                .skip(1)
                .map(|l| l.split(',').nth(index).unwrap().parse::<f64>().unwrap())
                .fold(0.0, f64::max)
        };
        assert!(max_mse(&oracle_trials) < 1e-12, "{condition}");
        assert!(max_mse(&slam_trials) > 0.0, "{condition}");
    }
    let timing: serde_json::Value =
        serde_json::from_str(&read(&out.join("reproduce.json"))).expect("reproduce.json is JSON");
    assert_eq!(timing["oracle"], true);
    let oracle_times = timing["oracle_wall_time_per_condition_s"]
        .as_object()
        .unwrap();
    assert_eq!(oracle_times.len(), 5);
}

#[test]
fn the_oracle_without_its_launch_file_is_refused_before_any_trial() {
    let dir = temp();
    let out = dir.path().join("out");
    let output = run(&[
        "reproduce",
        "--out",
        out.to_str().unwrap(),
        "--trials",
        "1",
        "--frames",
        "2",
        "--oracle",
        "--launch-dir",
        dir.path().to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("--oracle: no "), "{stderr}");
    assert!(stderr.contains("true-poses.toml"), "{stderr}");
    assert!(!out.join("fig4.csv").exists(), "no work before the refusal");
}
