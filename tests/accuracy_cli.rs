//! `nrslam accuracy`: without refinement the range RMSE sits at the grid limit Δr/√12; with
//! interpolation it drops far below it but never below the Cramér–Rao bound.

mod common;
use common::*;

fn rows(refine: &str, snr: &str) -> Vec<std::collections::BTreeMap<String, f64>> {
    let dir = temp();
    run_ok(&[
        "accuracy",
        "--fidelity",
        "spectral",
        "--refine",
        refine,
        "--snr-db",
        snr,
        "--trials",
        "400",
        "--subcarriers",
        "1024",
        "--antennas",
        "8",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(dir.path().join("accuracy.png").exists());
    let text = read(&dir.path().join("accuracy.csv"));
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_owned)
        .collect();
    for column in [
        "snr_db",
        "range_rmse_m",
        "range_crb_m",
        "range_grid_m",
        "angle_rmse_deg",
        "angle_crb_deg",
        "angle_grid_deg",
    ] {
        assert!(header.iter().any(|h| h == column), "missing {column}");
    }
    lines
        .map(|l| {
            header
                .iter()
                .cloned()
                .zip(l.split(',').map(|v| v.parse().unwrap()))
                .collect()
        })
        .collect()
}

#[test]
fn without_refinement_range_error_is_the_grid_limit() {
    for row in rows("none", "20:30:10") {
        let ratio = row["range_rmse_m"] / row["range_grid_m"];
        assert!(
            (0.8..1.2).contains(&ratio),
            "SNR {}: RMSE/grid = {ratio}",
            row["snr_db"]
        );
        assert_eq!(row["missed_trials"], 0.0);
    }
}

#[test]
fn interpolation_beats_the_grid_fivefold_and_respects_the_bound() {
    for row in rows("interpolation", "0:30:15") {
        assert!(
            row["range_rmse_m"] >= row["range_crb_m"],
            "SNR {}: RMSE {} below CRB {}",
            row["snr_db"],
            row["range_rmse_m"],
            row["range_crb_m"]
        );
        assert!(
            row["angle_rmse_deg"] >= row["angle_crb_deg"],
            "SNR {}: angle RMSE below CRB",
            row["snr_db"]
        );
        if row["snr_db"] >= 30.0 {
            assert!(
                row["range_rmse_m"] * 5.0 < row["range_grid_m"],
                "SNR 30 dB: {} not 5x below grid {}",
                row["range_rmse_m"],
                row["range_grid_m"]
            );
        }
    }
}

#[test]
fn bad_sweep_is_refused() {
    let output = run(&["accuracy", "--snr-db", "30:0:5", "--out", "/tmp/never"]);
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("--snr-db"));
}
