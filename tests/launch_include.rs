//! Launch includes and command-line node-parameter overrides, through the binary:
//! `launch/true-poses.toml` (which includes the paper's files) computes exactly what the paper's
//! file computes with its differences typed as `node.param:=value`; an included file found from
//! another folder still finds its scene; a parameter a node refuses names the override.

mod common;
use common::*;

use std::path::Path;

/// The parameters by which the pose oracle differs from the paper's runs.
const ORACLE: [&str; 6] = [
    "radar.odom_translation_noise:=0.0",
    "radar.odom_rotation_noise_deg_per_m:=0.0",
    "radar.odom_scale_bias:=0.0",
    "radar.odom_rotation_bias_deg_per_m:=0.0",
    "association.scan_matching:=false",
    "association.covariance_sequential_scale:=1e6",
];

fn launch(file: &str, out: &Path, args: &[&str]) {
    let mut all = vec!["launch", file, "--out", out.to_str().unwrap()];
    all.extend_from_slice(args);
    run_ok(&all);
}

/// Asserts two runs computed the same: every metric row, and the summary but for what names the
/// run (launch file, arguments).
fn assert_same_run(a: &Path, b: &Path) {
    let metrics = |dir: &Path| read(&dir.join("metrics.csv"));
    assert_eq!(metrics(a), metrics(b));
    let strip = |dir: &Path| {
        let mut s = summary(dir);
        let object = s.as_object_mut().unwrap();
        object.remove("launch");
        object.remove("arguments");
        s
    };
    assert_eq!(strip(a), strip(b));
}

#[test]
fn the_pose_oracle_is_the_paper_file_with_its_differences_on_the_command_line() {
    let (oracle, paper) = (temp(), temp());
    launch(
        "launch/true-poses.toml",
        oracle.path(),
        &["frames:=30", "angle_std_deg:=5", "--seed", "2"],
    );
    let mut args = vec![
        "frames:=30",
        "angle_std_deg:=5",
        "loop_closure:=false",
        "--seed",
        "2",
    ];
    args.extend(ORACLE);
    launch("launch/paper-ideal.toml", paper.path(), &args);
    assert_same_run(oracle.path(), paper.path());
    let s = summary(paper.path());
    assert_eq!(s["arguments"]["association.scan_matching"], false);
    assert_eq!(s["arguments"]["radar.odom_scale_bias"], 0.0);
    // The oracle's exact poses: its pose error is zero (so the overrides were applied).
    assert!(s["pose_rmse_m"].as_f64().unwrap() < 1e-9, "{s}");
    // The record of the oracle names its own arguments, as before includes.
    let o = summary(oracle.path());
    let names: Vec<&String> = o["arguments"].as_object().unwrap().keys().collect();
    assert_eq!(
        names,
        [
            "angle_std_deg",
            "fidelity",
            "frames",
            "loop_closure",
            "range_std_m",
            "refinement",
            "representatives",
            "scene",
            "shapes",
            "viz"
        ]
    );

    // At 5G fidelity it includes paper-5g.toml, whose arguments become its own.
    let (oracle, paper) = (temp(), temp());
    launch(
        "launch/true-poses.toml",
        oracle.path(),
        &["fidelity:=spectral", "snr_db:=5", "frames:=8"],
    );
    let mut args = vec![
        "fidelity:=spectral",
        "snr_db:=5",
        "frames:=8",
        "loop_closure:=false",
    ];
    args.extend(ORACLE);
    launch("launch/paper-5g.toml", paper.path(), &args);
    assert_same_run(oracle.path(), paper.path());
    assert_eq!(summary(oracle.path())["arguments"]["snr_db"], 5.0);
}

#[test]
fn an_included_file_resolves_its_paths_against_its_own_folder() {
    let dir = temp();
    let variant = dir.path().join("coarse.toml");
    let paper = root().join("launch/paper-ideal.toml");
    std::fs::write(
        &variant,
        format!(
            "[[include]]\nfile = {:?}\n[include.params.mapper]\nresolution_m = 0.2\n",
            paper.display().to_string()
        ),
    )
    .unwrap();
    let out = dir.path().join("out");
    let out_dir = out.to_str().unwrap();
    run_ok_in(
        dir.path(),
        &["launch", "coarse.toml", "frames:=3", "--out", out_dir],
    );
    // paper-ideal.toml's arguments are the variant's; its scene default was found from launch/.
    let s = summary(&out);
    assert_eq!(s["frames"], 3);
    assert_eq!(s["arguments"]["scene"], "../config/hall.toml");
}

#[test]
fn a_bad_override_is_an_error_that_names_it() {
    let out = temp();
    let out = out.path().to_str().unwrap();
    let cases: [(&[&str], &[&str]); 4] = [
        (
            &[
                "launch",
                "launch/paper-ideal.toml",
                "association.nope:=1",
                "frames:=1",
            ],
            &[
                "node association",
                "the command line (association.nope:=1)",
                "nope",
            ],
        ),
        (
            &["launch", "launch/true-poses.toml", "radar.frames:=many"],
            &[
                "declared in launch/paper-ideal.toml",
                "radar.frames:=many",
                "frames",
            ],
        ),
        (
            &["launch", "launch/true-poses.toml", "radr.frames:=1"],
            &["radr.frames:=1: no node radr in this launch (nodes: radar, association"],
        ),
        (
            &[
                "montecarlo",
                "launch/true-poses.toml",
                "association.nope:=1",
                "--trials",
                "1",
            ],
            &["association.nope:=1", "nope"],
        ),
    ];
    for (args, expected) in cases {
        let mut args = args.to_vec();
        args.extend(["--out", out]);
        let output = run(&args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
        for text in expected {
            assert!(stderr.contains(text), "{args:?}: {text:?} not in {stderr}");
        }
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
}
