//! Namespaces, through the binary: two agents' radar → association chains run side by side under
//! `a1` and `a2` (tests/launch/two-agents.toml), with their own topics and their own noise, the
//! same in one process, in node processes, from a repeated include and replayed from their bag; a
//! namespaced node's parameter is set from the command line; and a launch without namespaces
//! computes exactly what it computed before namespaces existed.

mod common;
use common::*;

use nrslam_runtime::bag::{self, ReadMode};
use std::collections::BTreeMap;
use std::path::Path;

/// Each recorded topic's messages (CDR bytes), in recorded order.
fn recorded(dir: &Path) -> BTreeMap<String, Vec<Vec<u8>>> {
    let contents =
        bag::open(dir, ReadMode::Strict).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    let mut topics: BTreeMap<String, Vec<Vec<u8>>> = BTreeMap::new();
    for message in contents.messages {
        topics.entry(message.topic).or_default().push(message.data);
    }
    topics
}

/// Launches `args` with `--out DIR/name --record DIR/name-bag`; returns the bag's messages.
fn launch_recorded(dir: &Path, name: &str, args: &[&str]) -> BTreeMap<String, Vec<Vec<u8>>> {
    let (out, bag) = (dir.join(name), dir.join(format!("{name}-bag")));
    let mut all = vec!["launch"];
    all.extend_from_slice(args);
    all.extend([
        "--out",
        out.to_str().unwrap(),
        "--record",
        bag.to_str().unwrap(),
    ]);
    run_ok(&all);
    recorded(&bag)
}

/// What each agent's chain publishes, under its namespace.
const CHAIN: [&str; 9] = [
    "/clock",
    "/ground_truth/pose",
    "/ground_truth/targets",
    "/odom",
    "/radar/detections",
    "/slam/association_stats",
    "/slam/keyframe",
    "/slam/keyframe_poses",
    "/slam/pose",
];

#[test]
fn two_agents_run_side_by_side_under_their_namespaces() {
    let dir = temp();
    let two = launch_recorded(dir.path(), "two", &["tests/launch/two-agents.toml"]);
    // Every topic under its agent's namespace, but a1's true targets, remapped to their global
    // name; nothing on the bare catalogue names otherwise.
    let mut expected: Vec<String> = Vec::new();
    for agent in ["a1", "a2"] {
        for topic in CHAIN {
            expected.push(if agent == "a1" && topic == "/ground_truth/targets" {
                topic.to_owned()
            } else {
                format!("/{agent}{topic}")
            });
        }
    }
    expected.sort();
    assert_eq!(two.keys().cloned().collect::<Vec<_>>(), expected);
    assert_eq!(two["/a1/odom"].len(), 5);
    // One trajectory, two agents: the same true poses, but each radar draws its own odometry
    // and measurement noise (seed streams a1/radar and a2/radar).
    assert_eq!(two["/a1/ground_truth/pose"], two["/a2/ground_truth/pose"]);
    assert_eq!(
        two["/ground_truth/targets"],
        two["/a2/ground_truth/targets"]
    );
    for (a, b) in two["/a1/odom"].iter().zip(&two["/a2/odom"]).skip(1) {
        assert_ne!(a, b, "the two agents' odometry noise is one stream");
    }
    assert_ne!(two["/a1/radar/detections"], two["/a2/radar/detections"]);
    assert_ne!(two["/a1/slam/pose"], two["/a2/slam/pose"]);

    // One OS process per node (names a1/radar, ...; --node-namespace and --remap passed on):
    // the same streams.
    let processes = launch_recorded(
        dir.path(),
        "processes",
        &["tests/launch/two-agents.toml", "--mode", "processes"],
    );
    assert_eq!(processes, two);
    // The launcher hears each agent's poses too (summary.json's `agents`).
    assert_eq!(
        read(&dir.path().join("processes/summary.json")),
        read(&dir.path().join("two/summary.json"))
    );
    assert!(dir.path().join("processes/params/a2/radar.toml").is_file());

    // The same chain from a repeated include, copy i in namespace a<i>: the same streams (a1's
    // targets keep their namespace there, no remap).
    let repeated = launch_recorded(dir.path(), "repeat", &["tests/launch/agents-repeat.toml"]);
    let mut renamed = two.clone();
    let targets = renamed.remove("/ground_truth/targets").unwrap();
    renamed.insert("/a1/ground_truth/targets".into(), targets);
    assert_eq!(repeated, renamed);

    // The recording replays: the bag plays each agent's streams into the recorded back end
    // (both associations, under their namespaces), which computes the recorded bytes.
    let bag_dir = dir.path().join("two-bag");
    let replayed = launch_recorded(
        dir.path(),
        "replay",
        &["launch/replay.toml", &format!("bag:={}", bag_dir.display())],
    );
    assert_eq!(replayed, two);
    assert_eq!(
        read(&dir.path().join("replay/summary.json")),
        read(&dir.path().join("two/summary.json"))
    );
}

#[test]
fn a_namespaced_node_is_set_from_the_command_line_by_its_full_name() {
    let dir = temp();
    let runs = launch_recorded(
        dir.path(),
        "run",
        &["tests/launch/agents-repeat.toml", "a2/radar.frames:=3"],
    );
    assert_eq!(
        (runs["/a1/odom"].len(), runs["/a2/odom"].len()),
        (5, 3),
        "only a2's radar stops early"
    );
    assert_eq!(
        summary(&dir.path().join("run"))["arguments"]["a2/radar.frames"],
        3
    );
    // By its name without the namespace: no such node, the nodes listed.
    let output = run(&[
        "launch",
        "tests/launch/agents-repeat.toml",
        "radar.frames:=3",
    ]);
    assert_one_line_failure(
        &output,
        &[
            "radar.frames:=3",
            "no node radar",
            "a1/radar, a1/association, a2/radar",
        ],
    );
    // Zero agents: nothing runs; more than 64: refused naming the field.
    let output = run(&["launch", "tests/launch/agents-repeat.toml", "agents:=0"]);
    assert_one_line_failure(&output, &["no node runs"]);
    let output = run(&["launch", "tests/launch/agents-repeat.toml", "agents:=65"]);
    assert_one_line_failure(
        &output,
        &[
            "include agent-chain.toml",
            "repeat: \"$(var agents)\" (= 65) is out of range",
        ],
    );
}

#[test]
fn a_remap_that_is_not_one_of_the_nodes_topics_is_refused_listing_them() {
    assert_launch_refused(
        "[[node]]\nname = \"association\"\nkind = \"association\"\nnamespace = \"a1\"\n\
         remap = { \"/map\" = \"/map\" }\n",
        &[
            "node a1/association",
            "remap /map: not a topic of this node",
            "its topics: /odom, /radar/detections",
        ],
    );
}

#[test]
fn without_namespaces_a_launch_computes_what_it_always_did() {
    let dir = temp();
    let (paper, included) = (dir.path().join("paper"), dir.path().join("included"));
    let launch = |file: &str, out: &Path| {
        run_ok(&["launch", file, "frames:=5", "--out", out.to_str().unwrap()]);
    };
    launch("launch/paper-ideal.toml", &paper);
    launch("tests/launch/paper-include.toml", &included);
    // Through an include with `repeat = 1` and no namespace: every metric row and the summary,
    // but for what names the run.
    assert_eq!(
        read(&paper.join("metrics.csv")),
        read(&included.join("metrics.csv"))
    );
    let strip = |dir: &Path| {
        let mut s = summary(dir);
        let object = s.as_object_mut().unwrap();
        object.remove("launch");
        object.remove("arguments");
        s
    };
    assert_eq!(strip(&paper), strip(&included));
    // The figures of this run before namespaces existed (nrslam at da7d1f5, seed 1): a graph
    // without namespaces is built from the same nodes with the same seed streams.
    let s = summary(&paper);
    for (key, before) in [
        ("etgospa", 48.33169097216353),
        ("gospa", 74.84845110374366),
        ("pose_rmse_m", 0.01604124902640371),
        ("keyframe_rmse_m", 0.009231843199017733),
        ("mean_inlier_ratio", 0.7556220359879283),
    ] {
        assert_eq!(s[key].as_f64(), Some(before), "{key}");
    }
    assert_eq!(
        (s["keyframes"].as_u64(), s["occupied_cells"].as_u64()),
        (Some(2), Some(118))
    );
}
