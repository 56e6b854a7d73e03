//! Every recorded run replays: `launch --record` stores the resolved launch in the bag, and
//! `launch/replay.toml bag:=DIR` rebuilds the recorded back end from it, so summary.json is the
//! recorded run's byte for byte, whatever launch file, arguments and seed were recorded. A bag
//! without that record replays into replay.toml's own back end with one warning; a parameter
//! changed on the replay's command line is named in summary.json.
//!
//! The runs are short (a few tens of frames) so the suite stays fast; the full-length runs the
//! docs quote are re-measured with the commands in docs/bags.md.

mod common;
use common::*;
use nrslam_runtime::bag::MetadataFile;
use std::path::{Path, PathBuf};

/// Records `launch` with `args` and replays the bag; returns (run dir, bag dir, replay dir, the
/// replay's stderr).
fn record_and_replay(
    dir: &Path,
    name: &str,
    launch: &[&str],
    replay_args: &[&str],
) -> (PathBuf, PathBuf, PathBuf, String) {
    let (run_dir, bag_dir, replay_dir) = (
        dir.join(format!("{name}-run")),
        dir.join(format!("{name}-bag")),
        dir.join(format!("{name}-replay")),
    );
    let mut args: Vec<&str> = vec!["launch"];
    args.extend_from_slice(launch);
    let (out, record) = (run_dir.to_str().unwrap(), bag_dir.to_str().unwrap());
    args.extend(["--out", out, "--record", record]);
    run_ok(&args);
    let bag = format!("bag:={}", bag_dir.display());
    let out = replay_dir.to_str().unwrap();
    let mut args = vec!["launch", "launch/replay.toml", &bag, "--out", out];
    args.extend_from_slice(replay_args);
    let output = run_ok(&args);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    (run_dir, bag_dir, replay_dir, stderr)
}

fn assert_identical(name: &str, run_dir: &Path, replay_dir: &Path) {
    let (run, replay) = (
        read(&run_dir.join("summary.json")),
        read(&replay_dir.join("summary.json")),
    );
    assert_eq!(run, replay, "{name}: summary.json differs");
    assert!(!replay.contains("differs_from_recording"), "{name}");
}

/// Replays `bag`, which carries no launch record, into `out`: its summary.json and the one
/// warning line the replay must print.
fn replay_without_record(bag: &Path, out: &Path) -> (serde_json::Value, String) {
    let output = run_ok(&[
        "launch",
        "launch/replay.toml",
        &format!("bag:={}", bag.display()),
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains("warning")).collect();
    assert_eq!(warnings.len(), 1, "{}: {stderr}", bag.display());
    assert!(warnings[0].contains("no nrslam launch record"), "{stderr}");
    (summary(out), warnings[0].to_owned())
}

#[test]
fn the_paper_5g_back_end_with_its_loop_closure_is_rebuilt_from_the_bag() {
    let dir = temp();
    let (run_dir, bag_dir, replay_dir, stderr) = record_and_replay(
        dir.path(),
        "5g",
        &["launch/paper-5g.toml", "frames:=40", "--seed", "3"],
        &[],
    );
    assert_identical("paper-5g", &run_dir, &replay_dir);
    assert!(!stderr.contains("warning"), "{stderr}");
    // The record is readable by other tools: plain TOML in metadata.yaml's custom_data.
    let metadata = read(&bag_dir.join("metadata.yaml"));
    for needle in [
        "nrslam.nodes:",
        "nrslam.version:",
        "kind = \"association\"",
        "min_inlier_ratio = 0.4",
    ] {
        assert!(metadata.contains(needle), "{needle} not in {metadata}");
    }
    let replay = summary(&replay_dir);
    assert_eq!(replay["seed"], 3, "the recorded seed, without --seed");
    assert_eq!(replay["launch"], "launch/paper-5g.toml");

    // A parameter changed on the replay's command line: applied, and named in the summary.
    let changed = dir.path().join("changed");
    let bag = format!("bag:={}", bag_dir.display());
    let output = run_ok(&[
        "launch",
        "launch/replay.toml",
        &bag,
        "association.loop_closure.min_inlier_ratio:=0.5",
        "--seed",
        "4",
        "--out",
        changed.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("association.loop_closure.min_inlier_ratio"),
        "{stderr}"
    );
    let differs = &summary(&changed)["differs_from_recording"];
    assert_eq!(
        differs["association.loop_closure.min_inlier_ratio"],
        serde_json::json!({"recorded": 0.4, "replay": 0.5}),
        "{differs}"
    );
    assert_eq!(
        differs["seed"],
        serde_json::json!({"recorded": 3, "replay": 4})
    );
    assert_eq!(differs.as_object().unwrap().len(), 2, "{differs}");

    // A replay-file argument cannot change a recorded back end: one clear line.
    let refused = run(&[
        "launch",
        "launch/replay.toml",
        &bag,
        "representatives:=shape",
        "--out",
        dir.path().join("refused").to_str().unwrap(),
    ]);
    assert_one_line_failure(&refused, &["representatives:=shape", "node.param:=value"]);
}

#[test]
fn true_poses_standard_input_and_a_random_scene_replay_byte_identical() {
    let dir = temp();
    let (run_dir, _, replay_dir, _) = record_and_replay(
        dir.path(),
        "true-poses",
        &["launch/true-poses.toml", "frames:=25"],
        &[],
    );
    assert_identical("true-poses", &run_dir, &replay_dir);

    // A run that itself plays a foreign bag through the sensor adapter: the adapter is the
    // recorded front end, the association and what follows the back end.
    let fixture = root().join("tests/fixtures/ros2/bags/v9_plain");
    let input = format!("bag:={}", fixture.display());
    let (run_dir, _, replay_dir, stderr) = record_and_replay(
        dir.path(),
        "standard-input",
        &["launch/standard-input.toml", &input],
        &[],
    );
    assert_identical("standard-input", &run_dir, &replay_dir);
    assert!(!stderr.contains("warning"), "{stderr}");
    assert!(summary(&replay_dir)["keyframes"].as_u64().unwrap() > 0);

    let scene = dir.path().join("scene.toml");
    run_ok(&[
        "scene",
        "--random",
        "--seed",
        "11",
        "--laps",
        "1",
        "--out",
        scene.to_str().unwrap(),
    ]);
    let scene = format!("scene:={}", scene.display());
    let (run_dir, _, replay_dir, _) = record_and_replay(
        dir.path(),
        "random",
        &[
            "launch/paper-ideal.toml",
            &scene,
            "frames:=30",
            "--seed",
            "9",
        ],
        &[],
    );
    assert_identical("random scene", &run_dir, &replay_dir);
}

#[test]
fn a_bag_without_a_launch_record_replays_with_one_warning() {
    let dir = temp();
    let (run_dir, bag_dir) = (dir.path().join("run"), dir.path().join("bag"));
    run_ok(&[
        "launch",
        "launch/paper-ideal.toml",
        "frames:=20",
        "--out",
        run_dir.to_str().unwrap(),
        "--record",
        bag_dir.to_str().unwrap(),
    ]);
    // What another tool writes: the same messages, no custom_data (rosbags writes `null`). The
    // MCAP file's `nrslam` metadata record is left: metadata.yaml is what replay reads first.
    let path = bag_dir.join("metadata.yaml");
    let mut metadata = MetadataFile::from_yaml(&read(&path)).unwrap();
    assert!(metadata
        .rosbag2_bagfile_information
        .custom_data
        .contains_key("nrslam.nodes"));
    metadata.rosbag2_bagfile_information.custom_data.clear();
    std::fs::write(&path, metadata.to_yaml().unwrap()).unwrap();

    let (replay, warning) = replay_without_record(&bag_dir, &dir.path().join("replay"));
    assert!(warning.contains("association"), "{warning}");
    assert_eq!(replay["launch"], "launch/replay.toml");
    assert_eq!(replay["frames"], 20);
    // paper-ideal's back end is replay.toml's default: the maps agree.
    assert_eq!(replay["etgospa"], summary(&run_dir)["etgospa"]);
}

#[test]
fn bags_written_by_rosbags_and_by_the_mcap_package_replay_with_one_warning() {
    let dir = temp();
    let fixtures = root().join("tests/fixtures/ros2/bags");
    let mut etgospa = Vec::new();
    for (name, bag) in [
        ("rosbags", fixtures.join("replay_rosbags")),
        ("mcap", fixtures.join("replay_mcap/replay_mcap_0.mcap")),
    ] {
        let (replay, _) = replay_without_record(&bag, &dir.path().join(name));
        assert_eq!(replay["frames"], 20, "{name}");
        assert_eq!(replay["launch"], "launch/replay.toml", "{name}");
        etgospa.push(replay["etgospa"].as_f64().expect("scored"));
    }
    assert_eq!(etgospa[0], etgospa[1], "the same messages, the same map");
}

#[test]
fn a_recording_without_what_the_back_end_needs_is_refused_by_name() {
    let dir = temp();
    let bag_dir = dir.path().join("bag");
    run_ok(&[
        "launch",
        "launch/paper-ideal.toml",
        "frames:=5",
        "--out",
        dir.path().join("run").to_str().unwrap(),
        "--record",
        bag_dir.to_str().unwrap(),
        "--record-topics",
        "/radar/detections",
        "/odom",
        "/clock",
    ]);
    let output = run(&[
        "launch",
        "launch/replay.toml",
        &format!("bag:={}", bag_dir.display()),
        "--out",
        dir.path().join("replay").to_str().unwrap(),
    ]);
    assert_one_line_failure(&output, &["/ground_truth/targets", "evaluator", "--record"]);
}
