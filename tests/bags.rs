//! Bags end to end with the real binary: a short paper-ideal run recorded with `--record`, its
//! `bag info`, a replay through `launch/replay.toml` that reproduces summary.json byte for byte, a
//! recording cut off mid-write read with `--recover`, a recorder killed mid-run, and `bag play`
//! over zenoh into `bag record`.

mod common;
use common::*;
use nrslam_runtime::bag::{self, ReadMode};
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

fn ok(args: &[&str]) -> String {
    stdout(&run_ok(args))
}

fn info_json(dir: &Path, recover: bool) -> serde_json::Value {
    let mut args = vec!["bag", "info", dir.to_str().unwrap(), "--json"];
    if recover {
        args.push("--recover");
    }
    serde_json::from_str(&ok(&args)).expect("bag info --json prints JSON")
}

fn count(info: &serde_json::Value, topic: &str) -> u64 {
    info["topics"]
        .as_array()
        .unwrap()
        .iter()
        .find(|t| t["name"] == topic)
        .unwrap_or_else(|| panic!("{topic} not in {info}"))["count"]
        .as_u64()
        .unwrap()
}

#[test]
fn a_recorded_run_is_counted_replayed_exactly_and_recovered_after_a_cut() {
    let dir = temp();
    let (run_dir, bag_dir, replay_dir) = (
        dir.path().join("run"),
        dir.path().join("bag"),
        dir.path().join("replay"),
    );
    ok(&[
        "launch",
        "launch/paper-ideal.toml",
        "frames:=30",
        "--seed",
        "7",
        "--out",
        run_dir.to_str().unwrap(),
        "--record",
        bag_dir.to_str().unwrap(),
        "--chunk-size-kib",
        "64",
    ]);

    // bag info: every topic the launch publishes, with its count.
    let info = info_json(&bag_dir, false);
    for topic in ["/clock", "/odom", "/radar/detections", "/ground_truth/pose"] {
        assert_eq!(count(&info, topic), 30, "{topic}");
    }
    assert_eq!(count(&info, "/ground_truth/targets"), 1);
    assert_eq!(count(&info, "/metrics"), 30);
    assert_eq!(count(&info, "/slam/pose"), 30);
    assert!(count(&info, "/map") >= 1);
    assert_eq!(info["undecodable"], 0);
    assert_eq!(info["complete"], true);
    assert_eq!(
        info["start_ns"], 1_000_000_000u64,
        "log time = simulated clock"
    );
    assert!(info["chunks"].as_u64().unwrap() > 2, "{info}");
    let metadata = read(&bag_dir.join("metadata.yaml"));
    assert!(
        metadata.contains("storage_identifier: mcap")
            && metadata.contains("version: 9")
            && metadata.contains(
                "type_description_hash: RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7"
            ),
        "{metadata}"
    );

    // Replay: the same summary.json and metrics.csv, byte for byte.
    ok(&[
        "launch",
        "launch/replay.toml",
        &format!("bag:={}", bag_dir.display()),
        "--out",
        replay_dir.to_str().unwrap(),
    ]);
    assert_eq!(
        read(&run_dir.join("summary.json")),
        read(&replay_dir.join("summary.json"))
    );
    assert_eq!(
        read(&run_dir.join("metrics.csv")),
        read(&replay_dir.join("metrics.csv"))
    );
    let run_json = read(&replay_dir.join("run.json"));
    assert!(run_json.contains("replayed_bag"), "{run_json}");

    // A recording cut off at 60 % of its MCAP file, without metadata.yaml (the recorder was
    // killed): a strict read refuses with a hint, --recover keeps exactly the chunks before the cut.
    let full = bag::open(&bag_dir, ReadMode::Strict).unwrap();
    let cut_dir = dir.path().join("cut");
    std::fs::create_dir(&cut_dir).unwrap();
    let bytes = std::fs::read(&full.mcap_path).unwrap();
    let cut = bytes.len() * 6 / 10;
    std::fs::write(cut_dir.join("cut_0.mcap"), &bytes[..cut]).unwrap();
    let output = run(&["bag", "info", cut_dir.to_str().unwrap()]);
    assert!(!output.status.success());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.contains("--recover") && !stderr.contains("panicked"),
        "{stderr}"
    );
    let recovered = info_json(&cut_dir, true);
    let expected = full.messages_in_chunks_ending_by(cut as u64);
    assert!(expected > 0);
    assert_eq!(recovered["messages"].as_u64().unwrap(), expected);
    assert_eq!(recovered["undecodable"], 0);
    assert_eq!(recovered["complete"], false);
    let lost_chunks = full.chunks.len() as u64 - recovered["chunks"].as_u64().unwrap();
    let after_cut = full
        .chunks
        .iter()
        .filter(|c| c.end_byte > cut as u64)
        .count() as u64;
    assert_eq!(
        lost_chunks, after_cut,
        "only chunks not yet written are lost"
    );
    let prefix = bag::open(&cut_dir, ReadMode::Recover).unwrap();
    assert_eq!(
        prefix.messages[..],
        full.messages[..prefix.messages.len()],
        "recovered messages are the recording's first ones"
    );

    // The recovered bag replays too (run identity from the MCAP metadata record).
    let replay_cut = dir.path().join("replay-cut");
    ok(&[
        "launch",
        "launch/replay.toml",
        &format!("bag:={}", cut_dir.display()),
        "recover:=true",
        "--out",
        replay_cut.to_str().unwrap(),
    ]);
    let summary = summary(&replay_cut);
    assert_eq!(summary["seed"], 7);
    assert!(summary["frames"].as_u64().unwrap() < 30);
}

#[test]
fn a_recorder_killed_mid_run_loses_at_most_the_chunk_it_was_filling() {
    let dir = temp();
    let bag_dir = dir.path().join("bag");
    let chunk_kib = 32u64;
    let mut child = nrslam()
        .args([
            "launch",
            "launch/paper-ideal.toml",
            "--rate",
            "20",
            "--out",
            dir.path().join("run").to_str().unwrap(),
            "--record",
            bag_dir.to_str().unwrap(),
            "--chunk-size-kib",
            &chunk_kib.to_string(),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Wait until a few chunks are on disk (a map alone is ~300 KiB), then kill (SIGKILL: no chance
    // to finish the file).
    let deadline = Instant::now() + Duration::from_secs(120);
    let file = loop {
        let found = std::fs::read_dir(&bag_dir).ok().and_then(|entries| {
            entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .find(|p| p.extension().is_some_and(|e| e == "mcap"))
        });
        if let Some(path) = found {
            if std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0) > 1024 * 1024 {
                break path;
            }
        }
        assert!(Instant::now() < deadline, "the recording did not grow");
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it could be killed"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    child.kill().unwrap();
    child.wait().unwrap();
    assert!(!bag_dir.join("metadata.yaml").exists());
    let file_bytes = std::fs::metadata(&file).unwrap().len();
    let recovered = bag::open(&bag_dir, ReadMode::Recover).unwrap();
    assert!(recovered.chunks.len() >= 2, "{:?}", recovered.chunks);
    assert!(recovered.messages.iter().all(|m| m.decode().is_ok()));
    // What follows the last complete chunk is at most one chunk: its message data (chunk size plus
    // the message that crossed it; an occupancy grid at most) and its record framing.
    let largest = recovered
        .messages
        .iter()
        .map(|m| m.data.len() as u64)
        .max()
        .unwrap();
    let unread = file_bytes - recovered.complete_bytes();
    assert!(
        unread <= chunk_kib * 1024 + largest + 64 * 1024,
        "{unread} bytes after the last complete chunk"
    );
}

/// Records `topics` of a paper-ideal run of `frames` (`frames:=N`) into the bag `dir`/source
/// (the run's report in `dir`/run).
fn recorded_run(dir: &Path, frames: &str, topics: &[&str]) -> std::path::PathBuf {
    let source = dir.join("source");
    let (run, bag) = (dir.join("run"), source.to_str().unwrap().to_owned());
    let mut args = vec![
        "launch",
        "launch/paper-ideal.toml",
        frames,
        "--out",
        run.to_str().unwrap(),
        "--record",
        &bag,
        "--record-topics",
    ];
    args.extend_from_slice(topics);
    ok(&args);
    source
}

#[test]
fn play_at_rate_zero_delivers_every_message_to_a_recorder_over_zenoh() {
    let dir = temp();
    let source = recorded_run(
        dir.path(),
        "frames:=10",
        &[
            "/clock",
            "/odom",
            "/radar/detections",
            "/ground_truth/targets",
            "/map",
        ],
    );
    let copy = dir.path().join("copy");
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let recorder = nrslam()
        .args([
            "bag",
            "record",
            copy.to_str().unwrap(),
            "--listen",
            &endpoint,
            "--duration-s",
            "120",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(500));
    ok(&[
        "bag",
        "play",
        source.to_str().unwrap(),
        "--rate",
        "0",
        "--connect",
        &endpoint,
    ]);
    let output = recorder.wait_with_output().unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let original = bag::open(&source, ReadMode::Strict).unwrap();
    let copied = bag::open(&copy, ReadMode::Strict).unwrap();
    assert_eq!(copied.topics.len(), 5);
    for topic in &original.topics {
        let mine: Vec<_> = original
            .messages
            .iter()
            .filter(|m| m.topic == topic.name)
            .collect();
        let theirs: Vec<_> = copied
            .messages
            .iter()
            .filter(|m| m.topic == topic.name)
            .collect();
        assert_eq!(
            mine, theirs,
            "{}: every message, in order, same bytes",
            topic.name
        );
    }
}

#[test]
fn bad_bag_input_is_one_clear_line() {
    let dir = temp();
    for (args, needle) in [
        (vec!["bag", "info", "does/not/exist"], "does/not/exist"),
        (
            vec!["bag", "info", dir.path().to_str().unwrap()],
            "no metadata.yaml",
        ),
        (vec!["launch", "launch/replay.toml"], "no bag folder given"),
        (
            vec![
                "bag",
                "record",
                "x",
                "--topics",
                "/nope",
                "--connect",
                "tcp/127.0.0.1:1",
            ],
            "unknown topic",
        ),
    ] {
        let output = run(&args);
        assert!(!output.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "{args:?}: {stderr}");
        assert!(
            lines[0].contains(needle) && !stderr.contains("panicked"),
            "{args:?}: {stderr}"
        );
    }
}

/// A received zenoh sample: key expression, payload, attachment.
type Sample = (String, Vec<u8>, Option<Vec<u8>>);

#[test]
fn play_with_a_ros_domain_id_speaks_rmw_zenoh_key_expressions_and_attachments() {
    let dir = temp();
    let source = recorded_run(dir.path(), "frames:=3", &["/map", "/slam/pose"]);
    let recorded = bag::open(&source, ReadMode::Strict).unwrap();
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let session = zenoh_peer(std::slice::from_ref(&endpoint), &[]);
    let (sender, received) = std::sync::mpsc::channel();
    let _subscriber =
        zenoh::Wait::wait(session.declare_subscriber("7/**").callback(move |sample| {
            let _ = sender.send((
                sample.key_expr().as_str().to_owned(),
                sample.payload().to_bytes().into_owned(),
                sample.attachment().map(|a| a.to_bytes().into_owned()),
            ));
        }))
        .unwrap();
    ok(&[
        "bag",
        "play",
        source.to_str().unwrap(),
        "--connect",
        &endpoint,
        "--ros-domain-id",
        "7",
        "--match-timeout-s",
        "20",
    ]);
    let mut samples = Vec::new();
    while samples.len() < recorded.messages.len() {
        match received.recv_timeout(Duration::from_secs(30)) {
            Ok(sample) => samples.push(sample),
            Err(_) => break,
        }
    }
    assert_eq!(
        samples.len(),
        recorded.messages.len(),
        "every message, no end marker"
    );
    let map_key = "7/map/nav_msgs::msg::dds_::OccupancyGrid_/RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7";
    let pose_key = format!(
        "7/slam/pose/geometry_msgs::msg::dds_::PoseStamped_/{}",
        nrslam_runtime::type_hash::rihs01("geometry_msgs/msg/PoseStamped").unwrap()
    );
    for (topic, key) in [("/map", map_key.to_owned()), ("/slam/pose", pose_key)] {
        let mine: Vec<&Vec<u8>> = recorded
            .messages
            .iter()
            .filter(|m| m.topic == topic)
            .map(|m| &m.data)
            .collect();
        let theirs: Vec<&Sample> = samples.iter().filter(|(k, _, _)| *k == key).collect();
        assert_eq!(theirs.len(), mine.len(), "{key}");
        let mut gids = std::collections::BTreeSet::new();
        for (index, ((_, payload, attachment), data)) in theirs.iter().zip(&mine).enumerate() {
            assert_eq!(payload, *data, "{key}: CDR unchanged");
            let (sequence, timestamp_ns, gid) = nrslam_runtime::rmw_zenoh::parse_attachment(
                attachment
                    .as_deref()
                    .expect("rmw_zenoh needs an attachment"),
            )
            .expect("a 33-byte rmw_zenoh attachment");
            assert_eq!(sequence, index as i64 + 1, "{key}: sequence from 1");
            assert!(
                timestamp_ns > 1_600_000_000_000_000_000,
                "wall-clock source timestamp"
            );
            gids.insert(gid);
        }
        assert_eq!(gids.len(), 1, "{key}: one publisher GID");
    }
}
