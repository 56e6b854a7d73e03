//! `nrslam tradeoff`: one row per setting with the columns the issue names, interpolation buys
//! range accuracy, the `trials` knob's standard error shrinks with the trial count, and the
//! Pareto flags mark exactly the undominated settings.

mod common;
use common::*;
use std::collections::BTreeMap;

type Record = BTreeMap<String, String>;

fn records(text: &str) -> Vec<Record> {
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = reader
        .headers()
        .unwrap()
        .iter()
        .map(str::to_owned)
        .collect();
    reader
        .records()
        .map(|r| {
            header
                .iter()
                .cloned()
                .zip(r.unwrap().iter().map(str::to_owned))
                .collect()
        })
        .collect()
}

fn number(r: &Record, column: &str) -> f64 {
    r[column]
        .parse()
        .unwrap_or_else(|_| panic!("{column} = {:?}", r[column]))
}

#[test]
fn a_small_sweep_writes_every_column_and_a_consistent_pareto_front() {
    let dir = temp();
    run_ok(&[
        "tradeoff",
        "--trials",
        "1",
        "--frames",
        "6",
        "--sensing-trials",
        "40",
        "--knobs",
        "refinement,resolution,trials",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(
        std::fs::metadata(dir.path().join("pareto.png"))
            .unwrap()
            .len()
            > 10_000
    );
    let rows = records(&read(&dir.path().join("tradeoff.csv")));
    for column in [
        "knob",
        "fidelity",
        "subcarriers",
        "symbols",
        "antennas",
        "refinement",
        "resolution_m",
        "scatterer_spacing_m",
        "trials",
        "time_per_frame_ms",
        "time_per_trial_s",
        "range_rmse_m",
        "angle_rmse_deg",
        "final_etgospa",
        "pose_rmse_m",
        "pareto",
    ] {
        assert!(rows[0].contains_key(column), "missing column {column}");
    }
    let knobs: Vec<&str> = rows.iter().map(|r| r["knob"].as_str()).collect();
    assert_eq!(
        knobs,
        [
            "baseline",
            "trials",
            "trials",
            "trials",
            "trials",
            "trials",
            // interpolation, MUSIC, ESPRIT, NOMP
            "refinement",
            "refinement",
            "refinement",
            "refinement",
            "resolution",
            "resolution",
            "resolution"
        ]
    );
    for r in &rows {
        assert!(number(r, "time_per_frame_ms") > 0.0, "{r:?}");
        assert!(number(r, "final_etgospa").is_finite(), "{r:?}");
        assert!(number(r, "pose_rmse_m").is_finite(), "{r:?}");
    }

    // Interpolation beats the grid-limited baseline on range by far (Δr/√12 = 0.035 m).
    let baseline = &rows[0];
    let interpolation = rows.iter().find(|r| r["knob"] == "refinement").unwrap();
    assert_eq!(interpolation["refinement"], "interpolation");
    assert!(number(baseline, "range_rmse_m") > 0.02, "{baseline:?}");
    assert!(
        number(interpolation, "range_rmse_m") < 0.5 * number(baseline, "range_rmse_m"),
        "{interpolation:?}"
    );
    // The back-end knobs leave the sensing errors alone.
    for r in rows.iter().filter(|r| r["knob"] == "resolution") {
        assert_eq!(r["range_rmse_m"], baseline["range_rmse_m"]);
    }

    // Trials: 1, 2, 5, 10, 20 of the same seeds; study time grows, standard error exists from 2.
    let trials: Vec<&Record> = rows.iter().filter(|r| r["knob"] == "trials").collect();
    let counts: Vec<f64> = trials.iter().map(|r| number(r, "trials")).collect();
    assert_eq!(counts, [1.0, 2.0, 5.0, 10.0, 20.0]);
    assert!(number(trials[0], "final_etgospa_sem").is_nan());
    for pair in trials.windows(2) {
        assert!(number(pair[1], "time_per_study_s") > number(pair[0], "time_per_study_s"));
        assert!(number(pair[1], "final_etgospa_sem").is_finite());
    }
    // The first trial is the baseline's own run.
    assert_eq!(trials[0]["final_etgospa"], baseline["final_etgospa"]);

    // Pareto: exactly the rows (other than the trials knob's) no other row beats on both axes.
    let swept: Vec<&Record> = rows.iter().filter(|r| r["knob"] != "trials").collect();
    for r in &swept {
        let (t, e) = (number(r, "time_per_frame_ms"), number(r, "final_etgospa"));
        let dominated = swept.iter().any(|o| {
            let (t2, e2) = (number(o, "time_per_frame_ms"), number(o, "final_etgospa"));
            t2 <= t && e2 <= e && (t2 < t || e2 < e)
        });
        assert_eq!(r["pareto"], (!dominated).to_string(), "{r:?}");
    }
    assert!(trials.iter().all(|r| r["pareto"] == "false"));
}

#[test]
fn an_unknown_knob_is_refused_with_the_allowed_list() {
    let dir = temp();
    let output = run(&[
        "tradeoff",
        "--knobs",
        "warp-drive",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("warp-drive") && stderr.contains("stride"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}
