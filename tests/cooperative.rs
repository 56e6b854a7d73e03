//! Cooperative runs through the binary (launch/cooperative.toml, docs/cooperative.md; issue 43's
//! acceptance 5, 6 and 8), kept small (ideal fidelity, 30 to 120 frames) so that each takes
//! seconds in a debug build:
//!
//! - across processes: every agent's nodes in their own processes, joined over zenoh, give the
//!   fused summary of the in-process run, byte for byte;
//! - faults: an agent whose streams end early, or whose process is killed mid-run, leaves the
//!   others fused to the end; an agent switched on late is merged once it overlaps;
//! - stations alone: fixed stations map what they see in the true frame, with no alignment.
//!
//! (A fusion node fed misbehaving messages, NaN poses, wrong frames, stamps in the past, is tested
//! on the node itself: nodes/fusion/src/node.rs.)

mod common;
use common::*;

use nrslam_msgs::{Message, Segments, TargetSet};
use nrslam_runtime::bag::{Bag, ReadMode};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// `nrslam launch launch/cooperative.toml ARGS --out DIR/NAME`, which must succeed; the output
/// folder.
fn cooperative(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let out = dir.join(name);
    let mut all = vec!["launch", "launch/cooperative.toml"];
    all.extend_from_slice(args);
    all.extend(["--out", out.to_str().unwrap()]);
    run_ok(&all);
    out
}

/// `summary.json`'s `agents.NAME.FIELD`, which must be there.
fn agent<'a>(summary: &'a Value, name: &str, field: &str) -> &'a Value {
    summary["agents"]
        .get(name)
        .and_then(|a| a.get(field))
        .unwrap_or_else(|| panic!("no agents.{name}.{field} in {summary:#}"))
}

fn agent_u64(summary: &Value, name: &str, field: &str) -> u64 {
    agent(summary, name, field)
        .as_u64()
        .unwrap_or_else(|| panic!("agents.{name}.{field} is not a count"))
}

#[test]
fn each_node_in_its_own_process_gives_the_in_process_fused_summary() {
    let dir = temp();
    let args = [
        "agvs:=2",
        "stations:=1",
        "frames:=80",
        "fidelity:=ideal",
        "known_starts:=2",
    ];
    let one = cooperative(dir.path(), "in-process", &args);
    let mut processes_args = args.to_vec();
    processes_args.extend(["--mode", "processes"]);
    let many = cooperative(dir.path(), "processes", &processes_args);
    // The whole summary.json: nothing in it is run-specific (the mode and the wall time are in
    // run.json), and the launcher hears every agent's poses and keyframes and the inter-agent
    // edges over zenoh as the in-process observer does.
    assert_eq!(
        read(&many.join("summary.json")),
        read(&one.join("summary.json"))
    );
    for file in ["metrics.csv", "loops.csv", "shapes.csv"] {
        assert_eq!(read(&many.join(file)), read(&one.join(file)), "{file}");
    }
    // What was compared is the fused result of three agents, not an empty section.
    let s = summary(&one);
    for name in ["agv1", "agv2", "station1"] {
        assert_eq!(agent_u64(&s, name, "fused_frames"), 80, "{name}");
    }
    assert!(
        s["inter_agent_edges"]["accepted"].as_u64() > Some(0),
        "{:#}",
        s["inter_agent_edges"]
    );
}

#[test]
fn agents_on_launches_of_their_own_joined_over_zenoh_give_the_in_process_fused_summary() {
    // As across hosts: the fusion launch listens, each AGV's chain is a launch of its own
    // (launch/cooperative-agent.toml) that connects to it, and so is the station's
    // (launch/cooperative-station.toml).
    let dir = temp();
    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let fused = dir.path().join("fused");
    // Each program's stderr to a file of its own: a pipe nobody reads while another program
    // is waited for could fill and stall it.
    let launch = |args: &[&str], out: &Path| {
        let log = std::fs::File::create(out.with_extension("log")).unwrap();
        let child = nrslam()
            .arg("launch")
            .args(args)
            .arg("--out")
            .arg(out)
            .stdout(std::process::Stdio::null())
            .stderr(log)
            .spawn()
            .expect("nrslam launch starts");
        (child, out.with_extension("log"))
    };
    // The sensing arguments are the agents' own: with every agent remote the fusion launch
    // takes none (and refuses them by name).
    let mut fusion_args = vec!["launch/cooperative.toml"];
    fusion_args.extend(TWO_AGVS.iter().filter(|a| !a.starts_with("fidelity")));
    fusion_args.extend(["agents:=remote", "--listen", &endpoint]);
    let (mut fusion, fusion_log) = launch(&fusion_args, &fused);
    // The agents start once the fusion launch listens: what they publish before anyone
    // subscribes is gone.
    wait_listening(port, || {
        if fusion.try_wait().unwrap().is_some() {
            panic!("the fusion launch ended: {}", read(&fusion_log));
        }
    });
    std::thread::sleep(std::time::Duration::from_millis(500));
    let connect = [
        "frames:=80",
        "fidelity:=ideal",
        "--connect",
        endpoint.as_str(),
    ];
    let mut agents: Vec<_> = ["1", "2"]
        .iter()
        .map(|n| {
            let agv = format!("agv:={n}");
            let mut args = vec!["launch/cooperative-agent.toml", &agv, "odom_origin:=map"];
            args.extend(connect);
            launch(&args, &dir.path().join(format!("agv{n}")))
        })
        .collect();
    let mut station = vec!["launch/cooperative-station.toml", "station:=1"];
    station.extend(connect);
    agents.push(launch(&station, &dir.path().join("station1")));
    for (mut child, log) in agents.into_iter().chain([(fusion, fusion_log)]) {
        assert!(child.wait().unwrap().success(), "{}", read(&log));
    }
    let one = cooperative(dir.path(), "in-process", &TWO_AGVS);
    // Everything but the arguments' record (agents:=remote).
    let (mut remote, mut here) = (summary(&fused), summary(&one));
    for s in [&mut remote, &mut here] {
        s.as_object_mut().unwrap().remove("arguments");
    }
    assert_eq!(remote, here);
    for name in ["agv1", "agv2", "station1"] {
        assert_eq!(agent_u64(&remote, name, "fused_frames"), 80, "{name}");
    }
}

/// The ideal-fidelity hall run of two AGVs with known starts and one station, 80 frames.
const TWO_AGVS: [&str; 5] = [
    "agvs:=2",
    "stations:=1",
    "known_starts:=2",
    "frames:=80",
    "fidelity:=ideal",
];

/// Stamp (s) of frame `k` of the hall scenes (t0 = 1 s, 0.5 s apart).
fn frame_stamp_s(k: u64) -> f64 {
    1.0 + 0.5 * k as f64
}

/// Each `/map` of the bag at `dir`: (stamp s, occupied cells, at or above the segmenter's 65 %).
fn maps(dir: &Path) -> Vec<(f64, usize)> {
    let bag = Bag::open(dir, ReadMode::Strict).unwrap();
    bag.messages_on(&["/map".to_owned()])
        .unwrap()
        .map(|message| match message.unwrap().decode().unwrap() {
            Message::OccupancyGrid(grid) => (
                grid.header.stamp.as_seconds(),
                grid.data.iter().filter(|&&p| p >= 65).count(),
            ),
            other => panic!("/map carried {}", other.type_name()),
        })
        .collect()
}

/// Asserts that the fused map went on growing after `stopped_s` (an agent's last frame): the
/// last map has more occupied cells than the last one published by then, and came later.
fn assert_map_grew_after(bag: &Path, stopped_s: f64) {
    let maps = maps(bag);
    let before = maps
        .iter()
        .rfind(|(stamp, _)| *stamp <= stopped_s)
        .unwrap_or_else(|| panic!("no map by {stopped_s} s: {maps:?}"));
    let last = maps.last().unwrap();
    assert!(
        last.0 > before.0 && last.1 > before.1,
        "the map stopped at {before:?} (agent stopped at {stopped_s} s): {maps:?}"
    );
}

#[test]
fn an_agent_whose_streams_end_early_leaves_the_others_fused_to_the_end() {
    let dir = temp();
    let bag = dir.path().join("stopped-bag");
    let mut args = TWO_AGVS.to_vec();
    args.extend(["agv2/radar.frames:=40", "--record", bag.to_str().unwrap()]);
    args.extend(["--record-topics", "/map"]);
    let out = cooperative(dir.path(), "stopped", &args);
    let s = summary(&out);
    assert_eq!(s["frames"], 80);
    // agv2 sensed and was fused for its 40 frames; agv1 on to the end.
    assert_eq!(agent_u64(&s, "agv2", "frames"), 40);
    assert_eq!(agent_u64(&s, "agv2", "fused_frames"), 40);
    assert_eq!(agent_u64(&s, "agv1", "fused_frames"), 80);
    assert_eq!(agent_u64(&s, "station1", "fused_frames"), 80);
    // The fused map is scored at every step, and agv1 keeps adding to it after agv2 stopped.
    assert_eq!(s["metric_steps"], 80);
    assert_map_grew_after(&bag, frame_stamp_s(39));
    // What agv2 mapped before it stopped stays in the map: it scores better than the same run
    // without agv2 at all.
    let alone = cooperative(
        dir.path(),
        "alone",
        &[
            "agvs:=1",
            "stations:=1",
            "known_starts:=1",
            "frames:=80",
            "fidelity:=ideal",
        ],
    );
    let (with, without) = (s["etgospa"].as_f64(), summary(&alone)["etgospa"].as_f64());
    assert!(
        with.is_some() && without.is_some() && with < without,
        "ET-GOPSA {with:?} with agv2's first 40 frames, {without:?} without agv2"
    );
}

#[cfg(target_os = "linux")]
mod killed {
    use super::*;
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    use std::time::{Duration, Instant};

    /// Runs launch/cooperative.toml with TWO_AGVS and `extra` in processes mode, paced (2 ×
    /// real time: 20 s for 80 frames) so that the kill lands mid-run, and SIGKILLs node `victim`
    /// once agv2's association has handled `after` frames (it logs each at debug level, which
    /// tells when the run is under way). Returns the exit's success, the log without the
    /// per-frame lines, and whether the kill happened.
    fn run_and_kill(
        out: &Path,
        extra: &[&str],
        victim: &str,
        after: usize,
        log_filter: &str,
    ) -> (bool, String, bool) {
        let mut child = nrslam()
            .args(["launch", "launch/cooperative.toml"])
            .args(TWO_AGVS)
            .args(["--mode", "processes", "--rate", "2", "--out"])
            .arg(out)
            .args(extra)
            .env("NRSLAM_LOG", log_filter)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("nrslam launch starts");
        let stderr = BufReader::new(child.stderr.take().unwrap());
        let mut log = Vec::new();
        let mut handled = 0;
        let mut killed = false;
        let deadline = Instant::now() + Duration::from_secs(300);
        // Reading to the end of stderr is waiting for the launcher to exit.
        for line in stderr.lines().map_while(Result::ok) {
            if !killed
                && line.starts_with("[agv2/association]")
                && line.contains("association frame")
            {
                handled += 1;
                if handled == after {
                    let pid = node_pid(child.id(), victim).expect("the node runs");
                    let status = std::process::Command::new("kill")
                        .args(["-9", &pid.to_string()])
                        .status()
                        .unwrap();
                    assert!(status.success());
                    killed = true;
                }
            }
            if !line.contains("association frame") {
                log.push(line);
            }
            if Instant::now() > deadline {
                let _ = child.kill();
                panic!("nrslam launch still running after 300 s");
            }
        }
        let status = child.wait().unwrap();
        let log = format!("agv2 handled {handled} frames\n{}", log.join("\n"));
        (status.success(), log, killed)
    }

    #[test]
    fn an_agent_killed_mid_run_leaves_the_others_fused_to_the_end() {
        let dir = temp();
        let (out, bag) = (dir.path().join("killed"), dir.path().join("bag"));
        let bag_arg = bag.to_str().unwrap();
        // 20 frames in (of 80): kill agv2's radar, the AGV switched off mid-run.
        let (success, log, killed) = run_and_kill(
            &out,
            &["--record", bag_arg, "--record-topics", "/map"],
            "agv2/radar",
            20,
            "warn,nrslam_association=debug",
        );
        assert!(killed, "{log}");
        assert!(success, "{log}");
        assert!(
            log.contains("node process died (signal: 9 (SIGKILL)); on_exit = \"continue\"")
                && log.contains("agv2/radar"),
            "{log}"
        );

        let s = summary(&out);
        assert_eq!(
            s["exited"],
            serde_json::json!({ "agv2/radar": "signal: 9 (SIGKILL)" })
        );
        assert!(s.get("restarts").is_none());
        // agv2 stopped mid-run: fused for the frames it sensed, at least those its association
        // had handled when it was killed, and fewer than the run's.
        let agv2 = agent_u64(&s, "agv2", "frames");
        assert!((20..80).contains(&agv2), "agv2 sensed {agv2} frames");
        assert!(agent_u64(&s, "agv2", "fused_frames") >= 20);
        // Everyone else to the end, the map scored at every step and still growing.
        assert_eq!(s["frames"], 80);
        assert_eq!(agent_u64(&s, "agv1", "fused_frames"), 80);
        assert_eq!(agent_u64(&s, "station1", "fused_frames"), 80);
        assert_eq!(s["metric_steps"], 80);
        assert_map_grew_after(&bag, frame_stamp_s(agv2 - 1));
        assert!(s["etgospa"].as_f64().is_some_and(f64::is_finite));
    }

    #[test]
    fn an_agents_slam_killed_mid_run_is_respawned_and_fused_as_a_new_session() {
        let dir = temp();
        let out = dir.path().join("restarted");
        // 15 frames in (of 80): agv2's SLAM crashes; launch/cooperative.toml respawns it.
        let (success, log, killed) = run_and_kill(
            &out,
            &[],
            "agv2/association",
            15,
            "warn,nrslam_association=debug,nrslam_fusion=info",
        );
        assert!(killed, "{log}");
        assert!(success, "{log}");
        let s = summary(&out);
        assert_eq!(
            s["restarts"],
            serde_json::json!({ "agv2/association": 1 }),
            "{log}"
        );
        // The restarted SLAM numbers its keyframes from 0 again: a new session of agv2, not
        // keyframes dropped as out of order.
        assert_eq!(s["counters"]["fusion"]["restarts"], 1, "{log}");
        assert!(
            s["dropped"].as_object().is_none_or(|d| d.is_empty()),
            "{}",
            s["dropped"]
        );
        assert!(log.contains("an AGV's back end started over"), "{log}");
        // Its first session stays fused (the new one, its start unknown now, is merged once it
        // has seen enough of the map: tests/merge.rs, beyond these 80 frames); agv1 fused on to
        // the end. The association logs a frame before it publishes it: a few of the 15 frames
        // it logged may not have gone out.
        assert_eq!(agent_u64(&s, "agv1", "fused_frames"), 80);
        assert!(
            agent_u64(&s, "agv2", "fused_frames") >= 10,
            "{}",
            s["agents"]
        );
        assert!(s["etgospa"].as_f64().is_some_and(f64::is_finite));
    }
}

#[test]
fn an_agent_switched_on_late_is_merged_once_it_overlaps() {
    let dir = temp();
    // tests/launch/late-join-scene.toml: agv2 drives agv1's loop 30 m behind it, its start
    // unknown to fusion (known_starts = 1), switched on at frame 60, where agv1 started.
    let scene = root().join("tests/launch/late-join-scene.toml");
    let scene = format!("scene:={}", scene.display());
    let args = [
        "agvs:=2",
        "stations:=0",
        "known_starts:=1",
        "frames:=120",
        "fidelity:=ideal",
        &scene,
    ];
    let mut late = args.to_vec();
    late.push("agv2/radar.start_frame:=60");
    let out = cooperative(dir.path(), "late", &late);
    let s = summary(&out);
    // Nothing of agv2 before frame 60: its first true pose is its 61st frame's.
    assert_eq!(agent_u64(&s, "agv2", "frames"), 60);
    // Merged: fused poses from a time after it was switched on, through to the end.
    let merged_after_s = agent(&s, "agv2", "merged_after_s")
        .as_f64()
        .unwrap_or_else(|| panic!("agv2 never merged: {:#}", s["agents"]));
    let fused = agent_u64(&s, "agv2", "fused_frames");
    assert!(merged_after_s > 0.0 && fused > 0, "{:#}", s["agents"]);
    // Once merged, a fused pose for each of its frames to the end (0.5 s apart).
    assert_eq!(fused, 60 - (merged_after_s / 0.5).round() as u64);
    // At its true place in the map frame, not merely somewhere.
    let error = agent(&s, "agv2", "fused_pose_rmse_m").as_f64().unwrap();
    assert!(error < 0.5, "agv2's fused pose RMSE {error} m");
    assert_eq!(s["inter_agent_edges"]["wrong"], 0);
    assert_eq!(agent_u64(&s, "agv1", "fused_frames"), 120);
    // The fusion node's counters in summary.json: one merge, at the true place, never moved;
    // its merge re-checked on the way.
    let counters = &s["counters"]["fusion"];
    assert_eq!(counters["merges"], 1, "{counters:#}");
    assert_eq!(counters["remerges"], 0, "{counters:#}");
    assert!(
        counters["verify_searches"].as_u64() > Some(0),
        "{counters:#}"
    );

    // Switched on late is not the same run as from the start: agv2's first 60 frames are gone.
    let early = cooperative(dir.path(), "early", &args);
    assert_eq!(agent_u64(&summary(&early), "agv2", "frames"), 120);
}

/// Distance (m) from `p` to the closed polygon `outline`.
fn distance_to_outline(p: (f64, f64), outline: &[(f64, f64)]) -> f64 {
    let n = outline.len();
    (0..n)
        .map(|i| {
            let (a, b) = (outline[i], outline[(i + 1) % n]);
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let length2 = dx * dx + dy * dy;
            let t = if length2 > 0.0 {
                (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / length2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            (p.0 - (a.0 + t * dx)).hypot(p.1 - (a.1 + t * dy))
        })
        .fold(f64::INFINITY, f64::min)
}

/// The last message on `topic` in the bag at `dir`.
fn last_on(dir: &Path, topic: &str) -> Message {
    let bag = Bag::open(dir, ReadMode::Strict).unwrap();
    let mut last = None;
    for message in bag.messages_on(&[topic.to_owned()]).unwrap() {
        last = Some(message.unwrap().decode().unwrap());
    }
    last.unwrap_or_else(|| panic!("nothing on {topic}"))
}

#[test]
fn stations_alone_map_what_they_see_in_the_true_frame() {
    let dir = temp();
    let (out, bag) = (dir.path().join("stations"), dir.path().join("bag"));
    let output = run_ok(&[
        "launch",
        "launch/cooperative.toml",
        "agvs:=0",
        "stations:=4",
        "known_starts:=0",
        "frames:=30",
        "fidelity:=ideal",
        "--out",
        out.to_str().unwrap(),
        "--record",
        bag.to_str().unwrap(),
        "--record-topics",
        "/map/segments",
        "/ground_truth/targets",
    ]);
    // Ends cleanly: no agent left unmerged, nothing dropped, no warning at all.
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("WARN"), "{stderr}");
    let s = summary(&out);
    assert!(s.get("dropped").is_none(), "{s:#}");
    // The evaluator scores station1's surveyed pose: exact, at every step.
    assert_eq!(s["metric_steps"], 30);
    assert_eq!(s["pose_rmse_m"], 0.0);
    for m in 1..=4 {
        let name = format!("station{m}");
        assert_eq!(agent_u64(&s, &name, "fused_frames"), 30, "{name}");
        assert_eq!(agent(&s, &name, "fused_pose_rmse_m"), 0.0, "{name}");
    }
    // No alignment: nothing is matched, every keyframe stays at its survey.
    assert_eq!(s["inter_agent_edges"]["accepted"], 0);

    let Message::TargetSet(TargetSet { targets, .. }) = last_on(&bag, "/ground_truth/targets")
    else {
        panic!("/ground_truth/targets is not a TargetSet")
    };
    let Message::Segments(Segments {
        points,
        labels,
        cluster_count,
        ..
    }) = last_on(&bag, "/map/segments")
    else {
        panic!("/map/segments is not a Segments")
    };
    let outlines: Vec<Vec<(f64, f64)>> = targets
        .iter()
        .map(|t| t.outline.iter().map(|p| (p.x, p.y)).collect())
        .collect();
    assert_eq!(outlines.len(), 10);
    assert!(points.len() > 100, "{} occupied cells", points.len());
    // Every occupied cell of the final map in the true frame within 1 m of a true outline (the
    // cells are 0.1 m; the angle error at 20 m is about 0.4 m), with no alignment: the map
    // frame is the survey's.
    let nearest = |p: (f64, f64)| {
        outlines
            .iter()
            .enumerate()
            .map(|(id, o)| (distance_to_outline(p, o), id))
            .fold((f64::INFINITY, 0), |a, b| if b.0 < a.0 { b } else { a })
    };
    for p in &points {
        let (distance, id) = nearest((p.x, p.y));
        assert!(
            distance <= 1.0,
            "cell ({:.2}, {:.2}) is {distance:.2} m from the nearest target ({id})",
            p.x,
            p.y
        );
    }
    // At least one cluster on each target a station sees (docs/scene.md: south sees targets 0
    // to 3, east 3, 7 and 9, north 8 and 9, west 0, 4 and 8), none on the two no station sees
    // whole (the conveyor, 5, and the pillar, 6).
    let mut clustered: Vec<usize> = points
        .iter()
        .zip(&labels)
        .filter(|(_, label)| **label >= 0)
        .map(|(p, _)| nearest((p.x, p.y)).1)
        .collect();
    clustered.sort_unstable();
    clustered.dedup();
    assert_eq!(clustered, vec![0, 1, 2, 3, 4, 7, 8, 9]);
    assert!(cluster_count >= 8, "{cluster_count} clusters");
    // Of those two, only the conveyor's one scatterer within the north station's 20 m (its
    // corner at (24.09, 24.06), 19.94 m away): a few cells there, too few for a cluster.
    let unseen: Vec<_> = points
        .iter()
        .zip(&labels)
        .map(|(p, label)| ((p.x, p.y), *label, nearest((p.x, p.y)).1))
        .filter(|(_, _, id)| *id == 5 || *id == 6)
        .collect();
    assert!(
        unseen.len() < 10
            && unseen.iter().all(|((x, y), label, id)| {
                *id == 5 && *label == -1 && (x - 24.09).hypot(y - 24.06) < 1.0
            }),
        "{unseen:?}"
    );
}

#[test]
fn with_viz_each_agv_gets_its_fused_path_and_transforms() {
    let dir = temp();
    let bag = dir.path().join("bag");
    let mut args = TWO_AGVS.to_vec();
    args.extend(["viz:=true", "frames:=40", "--record", bag.to_str().unwrap()]);
    args.extend([
        "--record-topics",
        "/agv1/fusion/pose",
        "/agv1/fusion/path",
        "/agv2/tf",
    ]);
    cooperative(dir.path(), "viz", &args);
    // The path ends at the last fused pose; it holds every one of them.
    let Message::PoseStamped(pose) = last_on(&bag, "/agv1/fusion/pose") else {
        panic!("/agv1/fusion/pose is not a pose");
    };
    let Message::Path(path) = last_on(&bag, "/agv1/fusion/path") else {
        panic!("/agv1/fusion/path is not a path");
    };
    assert_eq!(path.header.frame_id, "map");
    assert_eq!(path.poses.len(), 40);
    assert_eq!(path.poses.last().unwrap().pose, pose.pose);
    // agv2's transforms, on its own /tf: map -> odom -> base_link, the map frame the fused one.
    let Message::TFMessage(tf) = last_on(&bag, "/agv2/tf") else {
        panic!("/agv2/tf is not a TFMessage");
    };
    let frames: Vec<(&str, &str)> = tf
        .transforms
        .iter()
        .map(|t| (t.header.frame_id.as_str(), t.child_frame_id.as_str()))
        .collect();
    assert!(frames.contains(&("map", "odom")), "{frames:?}");
}

#[test]
fn an_agents_launch_alone_says_how_its_own_slam_did() {
    let dir = temp();
    let out = dir.path().join("agv2");
    let output = nrslam()
        .args([
            "launch",
            "launch/cooperative-agent.toml",
            "agv:=2",
            "frames:=20",
        ])
        .args(["fidelity:=ideal", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(output.status.success());
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        stdout.contains("agv2: 20 frames, own pose RMSE ")
            && stdout.contains("(scored where they are fused)"),
        "{stdout}"
    );
    assert_eq!(agent_u64(&summary(&out), "agv2", "frames"), 20);
}
