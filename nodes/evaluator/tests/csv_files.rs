//! `evaluate_files` on user CSV files: results, grouping, and errors naming file, line, column.

use std::io::Write;
use std::path::PathBuf;

use nrslam_evaluator::csv_io::{read_estimates, read_truth};
use nrslam_evaluator::{
    etgospa, evaluate_files, gospa, DistanceMode, EvaluatorError, ExtendedTarget, MetricParams,
    Point2,
};
use tempfile::TempDir;

fn write(dir: &TempDir, name: &str, text: &str) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::File::create(&path)
        .unwrap()
        .write_all(text.as_bytes())
        .unwrap();
    path
}

const TRUTH: &str = "target,x,y\n\
wall,0,0\n\
wall,2,0\n\
7,10,0\n\
wall,2,1\n\
7,11,1\n";

#[test]
fn groups_targets_by_first_appearance_and_matches_the_library() {
    let dir = TempDir::new().unwrap();
    let truth = write(&dir, "truth.csv", TRUTH);
    let estimates = write(&dir, "est.csv", "x, y\n0.1,0\n 10 , 0.5\n30,30\n");
    let targets = read_truth(&truth).unwrap();
    assert_eq!(targets.len(), 2);
    assert_eq!(targets[0].id, "wall");
    assert_eq!(
        targets[0].samples,
        vec![
            Point2::new(0.0, 0.0),
            Point2::new(2.0, 0.0),
            Point2::new(2.0, 1.0)
        ]
    );
    assert_eq!(targets[1].id, "7");
    assert_eq!(targets[1].samples.len(), 2);

    let params = MetricParams::default();
    let report = evaluate_files(&truth, &estimates, &params).unwrap();
    assert_eq!(
        (
            report.target_count,
            report.truth_point_count,
            report.estimate_count
        ),
        (2, 5, 3)
    );
    let y = [
        Point2::new(0.1, 0.0),
        Point2::new(10.0, 0.5),
        Point2::new(30.0, 30.0),
    ];
    let all: Vec<Point2> = targets.iter().flat_map(|t| t.samples.clone()).collect();
    assert_eq!(report.gospa, gospa(&all, &y, &params.gospa()).unwrap());
    let ext: Vec<ExtendedTarget> = targets
        .iter()
        .map(|t| ExtendedTarget::from_samples(t.samples.clone()))
        .collect();
    assert_eq!(report.etgospa, etgospa(&ext, &y, &params).unwrap());
    assert_eq!(report.etgospa.slot_count, 5);

    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(json["etgospa"]["missed_count"], 3);
    assert!(json["etgospa"]["false"].is_number());
    assert!(json["gospa"]["localisation"].is_number());
    assert!(json["etgospa"].get("pairs").is_none());
}

#[test]
fn outline_mode_uses_the_samples_as_polygon_vertices() {
    let dir = TempDir::new().unwrap();
    let truth = write(&dir, "t.csv", "target,x,y\na,0,0\na,4,0\na,4,4\na,0,4\n");
    // (2, -1) is 1 m from the bottom edge but √5 m from the nearest corner.
    let estimates = write(&dir, "e.csv", "x,y\n2,-1\n");
    let params = MetricParams {
        distance: DistanceMode::Outline,
        ..MetricParams::default()
    };
    let report = evaluate_files(&truth, &estimates, &params).unwrap();
    assert!((report.etgospa.localisation - 1.0).abs() < 1e-12);
    assert!((report.gospa.localisation - 5f64.sqrt()).abs() < 1e-12);
}

#[test]
fn header_only_files_are_empty_sets() {
    let dir = TempDir::new().unwrap();
    let truth = write(&dir, "t.csv", "target,x,y\n");
    let estimates = write(&dir, "e.csv", "x,y\n");
    let report = evaluate_files(&truth, &estimates, &MetricParams::default()).unwrap();
    assert_eq!((report.gospa.total, report.etgospa.total), (0.0, 0.0));
}

/// The error's message must name the file, and the line and column when given.
fn assert_error(err: EvaluatorError, file: &str, needles: &[&str]) {
    let text = err.to_string();
    assert!(text.contains(file), "no file name in: {text}");
    for needle in needles {
        assert!(text.contains(needle), "no `{needle}` in: {text}");
    }
}

/// Writes `text` as the truth file `name`, scores it against one estimate, and checks the error
/// as [`assert_error`] does.
fn assert_truth_refused(dir: &TempDir, name: &str, text: &str, needles: &[&str]) {
    let estimates = write(dir, "ok_est.csv", "x,y\n1,1\n");
    let truth = write(dir, name, text);
    let err = evaluate_files(&truth, &estimates, &MetricParams::default()).unwrap_err();
    assert_error(err, name, needles);
}

/// Writes `text` as the estimates file `name`, scores it against [`TRUTH`], and checks the error
/// as [`assert_error`] does.
fn assert_estimates_refused(dir: &TempDir, name: &str, text: &str, needles: &[&str]) {
    let truth = write(dir, "ok_truth.csv", TRUTH);
    let estimates = write(dir, name, text);
    let err = evaluate_files(&truth, &estimates, &MetricParams::default()).unwrap_err();
    assert_error(err, name, needles);
}

#[test]
fn bad_fields_name_file_line_and_column() {
    let dir = TempDir::new().unwrap();
    assert_truth_refused(
        &dir,
        "nonnum.csv",
        "target,x,y\na,0,0\na,zero,1\n",
        &["line 3", "`x`", "zero"],
    );
    assert_truth_refused(
        &dir,
        "nan.csv",
        "target,x,y\na,0,0\na,1,0\nb,2,NaN\n",
        &["line 4", "`y`", "not a finite number"],
    );
    assert_estimates_refused(&dir, "inf_est.csv", "x,y\n1,2\ninf,3\n", &["line 3", "`x`"]);
    assert_estimates_refused(
        &dir,
        "short.csv",
        "x,y\n1,2\n3\n",
        &["line 3", "`y`", "missing"],
    );
    assert_truth_refused(
        &dir,
        "empty_id.csv",
        "target,x,y\n,1,2\n",
        &["line 2", "`target`", "empty"],
    );
}

#[test]
fn bad_headers_and_files_are_named() {
    let dir = TempDir::new().unwrap();
    let ok_est = write(&dir, "ok_est.csv", "x,y\n1,1\n");
    let p = MetricParams::default();

    assert_truth_refused(
        &dir,
        "nohead.csv",
        "0,0,0\n",
        &["line 1", "no column `target`"],
    );
    let t = write(&dir, "empty.csv", "");
    let err = evaluate_files(&t, &ok_est, &p).unwrap_err();
    assert!(matches!(err, EvaluatorError::MissingHeader { .. }), "{err}");
    assert_truth_refused(&dir, "twice.csv", "target,x,x,y\n", &["`x` appears twice"]);
    let missing = dir.path().join("does_not_exist.csv");
    let err = evaluate_files(&missing, &ok_est, &p).unwrap_err();
    assert!(matches!(err, EvaluatorError::Io { .. }));
    assert_error(err, "does_not_exist.csv", &[]);
    // Case and spaces in the header do not matter; extra columns are ignored.
    let e = write(&dir, "extra.csv", " X ,Y,comment\n1,2,hello\n");
    assert_eq!(read_estimates(&e).unwrap(), vec![Point2::new(1.0, 2.0)]);
}

#[test]
fn bad_parameters_are_refused_before_reading() {
    let dir = TempDir::new().unwrap();
    let missing = dir.path().join("never_read.csv");
    let p = MetricParams {
        alpha: 3.0,
        ..MetricParams::default()
    };
    let err = evaluate_files(&missing, &missing, &p).unwrap_err();
    assert!(err.to_string().contains("`alpha`"), "{err}");
}

#[test]
fn line_numbers_count_blank_lines_and_crlf() {
    let dir = TempDir::new().unwrap();
    // The csv crate skips blank lines without counting them; our line numbers must not.
    assert_truth_refused(
        &dir,
        "blank.csv",
        "target,x,y\na,1,2\n\n\r\nb,nan,1\n",
        &["line 5", "`x`"],
    );
    assert_truth_refused(
        &dir,
        "crlf.csv",
        "\r\ntarget,x\r\na,1\r\n",
        &["line 2", "no column `y`"],
    );
    let t = write(&dir, "crlf_ok.csv", "target,x,y\r\na,1,2\r\n");
    assert_eq!(
        read_truth(&t).unwrap()[0].samples,
        vec![Point2::new(1.0, 2.0)]
    );
}
