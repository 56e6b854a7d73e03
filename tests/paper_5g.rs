//! The 5G launch end to end at each fidelity level: the front end's spectra or resource grids go
//! through the estimator node into the same SLAM back end.

mod common;
use common::*;

fn launch(fidelity: &str, frames: u32) -> serde_json::Value {
    let dir = temp();
    run_ok(&[
        "launch",
        "launch/paper-5g.toml",
        &format!("fidelity:={fidelity}"),
        &format!("frames:={frames}"),
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    summary(dir.path())
}

#[test]
fn spectral_waveform_and_ideal_all_run_the_graph() {
    for (fidelity, frames) in [("spectral", 12), ("waveform", 2), ("ideal", 12)] {
        let summary = launch(fidelity, frames);
        assert_eq!(summary["frames"], frames, "{fidelity}");
        assert_eq!(summary["metric_steps"], frames, "{fidelity}");
        assert_eq!(summary["arguments"]["fidelity"], fidelity);
        let error = summary["pose_rmse_m"].as_f64().unwrap();
        assert!(
            error.is_finite() && error < 2.0,
            "{fidelity}: pose RMSE {error} m after {frames} frames"
        );
        assert!(summary["keyframes"].as_u64().unwrap() >= 1);
    }
}

#[test]
fn the_estimator_is_left_out_at_ideal_fidelity() {
    // At ideal the radar publishes detections itself; an estimator would have no input.
    let dir = temp();
    run_ok(&[
        "launch",
        "launch/paper-5g.toml",
        "fidelity:=ideal",
        "frames:=3",
        "--mode",
        "processes",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    let nodes: Vec<String> = std::fs::read_dir(dir.path().join("params"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        !nodes.iter().any(|n| n.starts_with("estimator")),
        "{nodes:?}"
    );
    assert!(nodes.iter().any(|n| n.starts_with("radar")));
}

#[test]
fn bad_fidelity_is_refused_naming_the_field() {
    let output = run(&["launch", "launch/paper-5g.toml", "fidelity:=lidar"]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("paper-5g.toml")
            && stderr.contains("fidelity")
            && !stderr.contains("panicked"),
        "{stderr}"
    );
}
