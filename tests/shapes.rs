//! Extended targets as shapes, through the binary: the shapes node runs in the paper's launch
//! file, `summary.json` scores its shapes against the truth, and the evaluator's
//! `representatives:=shape` scores exactly the samples the reporter scores.

mod common;
use common::*;

fn launch(args: &[&str]) -> tempfile::TempDir {
    let out = temp();
    let mut all = vec![
        "launch",
        "launch/true-poses.toml",
        "frames:=120",
        "--out",
        out.path().to_str().unwrap(),
    ];
    all.extend_from_slice(args);
    run_ok(&all);
    out
}

#[test]
fn shapes_are_fitted_scored_and_drawn() {
    let out = launch(&[]);
    let s = summary(out.path());
    let shapes = &s["shapes"];
    let matched = shapes["matched"].as_u64().unwrap();
    assert!(matched >= 3, "{shapes}");
    assert!(shapes["fitted"].as_u64().unwrap() >= matched);
    // At the true poses with Δθ = 1°, what is seen fits well: most of each outline overlaps.
    let iou = shapes["mean_iou"].as_f64().unwrap();
    assert!(iou > 0.6 && iou <= 1.0, "{shapes}");
    // 120 frames are under half a lap: one target seen only in part may take the other kind.
    assert!(
        shapes["kind_correct"].as_u64().unwrap() + 1 >= matched,
        "{shapes}"
    );
    for file in ["shapes.png", "shapes.csv"] {
        assert!(out.path().join(file).is_file(), "{file}");
    }
    let csv = read(&out.path().join("shapes.csv"));
    assert_eq!(
        csv.lines().count() as u64,
        1 + shapes["fitted"].as_u64().unwrap()
    );
}

#[test]
fn the_evaluators_shape_mode_scores_the_reporters_shape_samples() {
    let out = launch(&["representatives:=shape"]);
    let s = summary(out.path());
    let from_evaluator = s["etgospa"].as_f64().unwrap();
    let from_reporter = s["shapes"]["etgospa_shape"].as_f64().unwrap();
    assert!(
        (from_evaluator - from_reporter).abs() < 1e-9,
        "{from_evaluator} vs {from_reporter}"
    );
    // And they are not the box corners' score.
    let boxes = s["shapes"]["etgospa_box_corners"].as_f64().unwrap();
    assert!((boxes - from_reporter).abs() > 1e-3, "{boxes}");
}
