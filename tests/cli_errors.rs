//! A bad launch or config file gets a one-line error naming the file, the field and the allowed
//! range, a non-zero exit, and no panic.

mod common;
use common::*;

#[test]
fn missing_launch_file() {
    let output = run(&["launch", "launch/does-not-exist.toml"]);
    assert_one_line_failure(&output, &["launch/does-not-exist.toml", "cannot read"]);
}

#[test]
fn argument_out_of_range_names_file_node_field_and_range() {
    let dir = temp();
    let out = dir.path().to_str().unwrap();
    let output = run(&[
        "launch",
        "launch/paper-ideal.toml",
        "angle_std_deg:=-1",
        "--out",
        out,
    ]);
    assert_one_line_failure(
        &output,
        &[
            "launch/paper-ideal.toml",
            "node radar",
            "angle_std_deg",
            "allowed",
        ],
    );
}

#[test]
fn malformed_and_unknown_arguments() {
    let output = run(&["launch", "launch/paper-ideal.toml", "angle_std_deg:=five"]);
    assert_one_line_failure(
        &output,
        &["launch/paper-ideal.toml", "angle_std_deg", "not a number"],
    );
    let output = run(&["launch", "launch/paper-ideal.toml", "speed:=2"]);
    assert_one_line_failure(
        &output,
        &["launch/paper-ideal.toml", "speed", "not declared"],
    );
    let output = run(&["launch", "launch/paper-ideal.toml", "angle_std_deg=2"]);
    assert_one_line_failure(&output, &["name:=value"]);
}

#[test]
fn unknown_field_in_launch_and_in_node_params() {
    assert_launch_refused(
        "[launch]\nmodee = \"in-process\"\n[[node]]\nname = \"r\"\nkind = \"radar\"\n",
        &["bad.toml", "modee", "line 2"],
    );

    assert_launch_refused(
        "[[node]]\nname = \"r\"\nkind = \"radar\"\n[node.params]\nrange_sdt_m = 1.0\n",
        &["bad.toml", "node r", "range_sdt_m"],
    );
}

#[test]
fn unknown_kind_and_unwired_input() {
    assert_launch_refused(
        "[[node]]\nname = \"x\"\nkind = \"lidar\"\n",
        &["bad.toml", "node x", "lidar", "known:"],
    );
    assert_launch_refused(
        "[[node]]\nname = \"m\"\nkind = \"mapper\"\n",
        &["bad.toml", "node m", "/slam/keyframe", "no node"],
    );
}

#[test]
fn missing_scene_file_names_the_path() {
    assert_launch_refused(
        "[[node]]\nname = \"radar\"\nkind = \"radar\"\n[node.params]\nscene = \"nowhere/hall.toml\"\n",
        &["bad.toml", "node radar", "nowhere/hall.toml"],
    );
}

#[test]
fn bad_rate_is_refused() {
    assert_one_line_failure(
        &run(&["launch", "launch/paper-ideal.toml", "--rate", "-2"]),
        &["--rate", "allowed"],
    );
}

#[test]
fn bad_metric_input_names_file_line_and_column() {
    let dir = temp();
    let truth = dir.path().join("truth.csv");
    let estimates = dir.path().join("estimates.csv");
    std::fs::write(&truth, "target,x,y\n0,1,1\n0,abc,2\n").unwrap();
    std::fs::write(&estimates, "x,y\n1,1\n").unwrap();
    let output = metric(&truth, &estimates, &[]);
    assert_one_line_failure(&output, &["truth.csv", "3"]);
    let output = metric(&truth, &estimates, &["--c", "-1"]);
    assert_one_line_failure(&output, &["c"]);
}

#[test]
fn a_closed_output_pipe_ends_quietly_instead_of_panicking() {
    // `nrslam topics | head -0`: the reader is gone before nrslam writes its catalogue.
    let mut child = nrslam()
        .arg("topics")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("nrslam starts");
    drop(child.stdout.take());
    let output = child.wait_with_output().expect("nrslam ends");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{:?}: {stderr}", output.status);
    assert!(!stderr.contains("panicked"), "{stderr}");
}
