//! Per-agent poses of a cooperative run (several AGVs and stations, each under its namespace):
//! how well each AGV knew where it was on its own, and once fused into the common map frame.

use super::StampKey;
use nrslam_msgs::{topics, Message};
use serde::Serialize;
use std::collections::BTreeMap;

use nrslam_association::Pose2;

/// The poses one agent published, by stamp.
#[derive(Debug, Default, Clone)]
pub struct AgentTrack {
    /// `/<ns>/ground_truth/pose`.
    pub truth: BTreeMap<StampKey, Pose2>,
    /// `/<ns>/slam/pose`: its own SLAM, in its own frame.
    pub own: BTreeMap<StampKey, Pose2>,
    /// `/<ns>/fusion/pose`: corrected into the map frame by the fusion node.
    pub fused: BTreeMap<StampKey, Pose2>,
    /// `/<ns>/slam/keyframe`: each keyframe's stamp by the agent's own id.
    pub keyframes: BTreeMap<u32, StampKey>,
}

/// One agent's line in `summary.json`.
#[derive(Debug, Serialize, PartialEq)]
pub struct AgentSummary {
    /// Frames with a true pose.
    pub frames: u64,
    /// Frames with a fused pose (the agent merged into the map frame).
    pub fused_frames: u64,
    /// Seconds from the agent's first true pose to its first fused pose (`None`: never merged).
    pub merged_after_s: Option<f64>,
    /// RMSE (m) of its own SLAM pose over every frame, its frame put on the truth's by the first
    /// pose (an AGV whose start is unknown to the others knows its start in its own frame).
    pub own_pose_rmse_m: Option<f64>,
    /// The same over the frames that have a fused pose (m): what fusion is compared with.
    pub own_pose_rmse_fused_frames_m: Option<f64>,
    /// RMSE (m) of its fused pose against the truth, map frame.
    pub fused_pose_rmse_m: Option<f64>,
}

/// The namespace of a namespaced pose topic this module tracks, and which track it feeds.
fn classify(topic: &str) -> Option<(&str, &'static str)> {
    let base = topics::base_name(topic)?;
    if base == topic {
        return None;
    }
    let tracked = [
        topics::GROUND_TRUTH_POSE,
        topics::SLAM_POSE,
        topics::FUSION_POSE,
        topics::KEYFRAME,
    ];
    if !tracked.contains(&base) {
        return None;
    }
    let namespace = topic.strip_suffix(base)?.trim_start_matches('/');
    Some((namespace, base))
}

/// Takes `message` on `topic` into `agents` if it is an agent's pose.
pub fn take(agents: &mut BTreeMap<String, AgentTrack>, topic: &str, message: &Message) {
    let Some((namespace, base)) = classify(topic) else {
        return;
    };
    if let Message::Keyframe(k) = message {
        let track = agents.entry(namespace.to_owned()).or_default();
        let stamp = (k.header.stamp.sec, k.header.stamp.nanosec);
        track.keyframes.insert(k.id, stamp);
        return;
    }
    let Message::PoseStamped(p) = message else {
        return;
    };
    let track = agents.entry(namespace.to_owned()).or_default();
    let stamp = (p.header.stamp.sec, p.header.stamp.nanosec);
    let (x_m, y_m, yaw_rad) = p.pose.planar();
    let pose = Pose2::new(x_m, y_m, yaw_rad);
    let into = match base {
        topics::GROUND_TRUTH_POSE => &mut track.truth,
        topics::SLAM_POSE => &mut track.own,
        _ => &mut track.fused,
    };
    into.insert(stamp, pose);
}

fn squared_distance_m2(a: &Pose2, b: &Pose2) -> f64 {
    (a.x_m - b.x_m).powi(2) + (a.y_m - b.y_m).powi(2)
}

fn rms(squared: &[f64]) -> Option<f64> {
    (!squared.is_empty()).then(|| (squared.iter().sum::<f64>() / squared.len() as f64).sqrt())
}

fn seconds(stamp: StampKey) -> f64 {
    f64::from(stamp.0) + f64::from(stamp.1) * 1e-9
}

impl AgentTrack {
    /// The agent's summary.
    pub fn summary(&self) -> AgentSummary {
        let own_in_true_frame = self.own_in_true_frame();
        let own_error = |stamp: &StampKey| {
            let own = own_in_true_frame.get(stamp)?;
            let truth = self.truth.get(stamp)?;
            Some(squared_distance_m2(own, truth))
        };
        let own_all: Vec<f64> = self.own.keys().filter_map(own_error).collect();
        let own_fused: Vec<f64> = self.fused.keys().filter_map(own_error).collect();
        let fused: Vec<f64> = self
            .fused
            .iter()
            .filter_map(|(stamp, f)| {
                let truth = self.truth.get(stamp)?;
                Some(squared_distance_m2(f, truth))
            })
            .collect();
        AgentSummary {
            frames: self.truth.len() as u64,
            fused_frames: self.fused.len() as u64,
            merged_after_s: match (self.truth.keys().next(), self.fused.keys().next()) {
                (Some(start), Some(merged)) => Some(seconds(*merged) - seconds(*start)),
                _ => None,
            },
            own_pose_rmse_m: rms(&own_all),
            own_pose_rmse_fused_frames_m: rms(&own_fused),
            fused_pose_rmse_m: rms(&fused),
        }
    }
}

impl AgentTrack {
    /// Its own SLAM pose put into the truth's frame by the first frame that has both (the
    /// alignment `own_pose_rmse_m` uses), by stamp.
    fn own_in_true_frame(&self) -> BTreeMap<StampKey, Pose2> {
        let first = self
            .own
            .iter()
            .find_map(|(stamp, own)| Some((*own, *self.truth.get(stamp)?)));
        let Some(to_truth) = first.map(|(own, truth)| truth.compose(&own.inverse())) else {
            return BTreeMap::new();
        };
        self.own
            .iter()
            .map(|(stamp, own)| (*stamp, to_truth.compose(own)))
            .collect()
    }
}

/// Writes `agents.csv`: one row per agent and stamp with its true pose, its own SLAM pose (its
/// frame put on the truth's by its first pose, as `own_pose_rmse_m` is scored) and its fused
/// pose, metres and radians, map frame; a pose the agent did not publish is left empty.
pub fn write_agents_csv(
    agents: &BTreeMap<String, AgentTrack>,
    path: &std::path::Path,
) -> anyhow::Result<()> {
    use anyhow::Context;
    let mut writer =
        csv::Writer::from_path(path).with_context(|| format!("cannot write {}", path.display()))?;
    writer.write_record([
        "agent",
        "time_s",
        "true_x_m",
        "true_y_m",
        "true_yaw_rad",
        "own_x_m",
        "own_y_m",
        "own_yaw_rad",
        "fused_x_m",
        "fused_y_m",
        "fused_yaw_rad",
    ])?;
    let cells = |pose: Option<&Pose2>| -> [String; 3] {
        match pose {
            Some(p) => [p.x_m.to_string(), p.y_m.to_string(), p.yaw_rad.to_string()],
            None => Default::default(),
        }
    };
    for (name, track) in agents {
        let own = track.own_in_true_frame();
        let stamps: std::collections::BTreeSet<StampKey> = track
            .truth
            .keys()
            .chain(own.keys())
            .chain(track.fused.keys())
            .copied()
            .collect();
        for stamp in stamps {
            let mut row = vec![name.clone(), seconds(stamp).to_string()];
            row.extend(cells(track.truth.get(&stamp)));
            row.extend(cells(own.get(&stamp)));
            row.extend(cells(track.fused.get(&stamp)));
            writer.write_record(&row)?;
        }
    }
    writer.flush()?;
    Ok(())
}

/// An inter-agent edge is wrong beyond this position error (m) …
pub const INTER_EDGE_WRONG_M: f64 = 0.5;
/// … or this heading error (degrees).
pub const INTER_EDGE_WRONG_DEG: f64 = 2.0;

/// The fusion node's inter-agent edges (`/fusion/edges`) against the truth.
#[derive(Debug, Serialize, PartialEq, Default)]
pub struct InterAgentEdges {
    /// Edges in the final fused graph.
    pub accepted: u64,
    /// Of those, edges whose two keyframes have a true pose (both ends' agents reported).
    pub scored: u64,
    /// Scored edges off by more than [`INTER_EDGE_WRONG_M`] or [`INTER_EDGE_WRONG_DEG`].
    pub wrong: u64,
    /// Largest position error of a scored edge (m).
    pub max_error_m: Option<f64>,
    /// Largest heading error of a scored edge (degrees).
    pub max_error_deg: Option<f64>,
    /// Scored and wrong edges by pair of agents, `agv1-agv2` (the matched map's agent first).
    pub by_pair: BTreeMap<String, PairEdges>,
}

/// Scored and wrong inter-agent edges between two agents.
#[derive(Debug, Serialize, PartialEq, Default)]
pub struct PairEdges {
    /// Edges scored.
    pub scored: u64,
    /// Of those, wrong.
    pub wrong: u64,
}

/// (from namespace, from id, to namespace, to id, measured relative pose) of an edge marker's
/// text, `agv1/12 agv2/40 x_m=… y_m=… yaw_rad=…` (nodes/fusion/src/node.rs).
fn parse_edge(text: &str) -> Option<(&str, u32, &str, u32, Pose2)> {
    let mut words = text.split_whitespace();
    fn end(word: &str) -> Option<(&str, u32)> {
        let (ns, id) = word.rsplit_once('/')?;
        Some((ns, id.parse().ok()?))
    }
    let (from_ns, from_id) = end(words.next()?)?;
    let (to_ns, to_id) = end(words.next()?)?;
    let mut value = |key: &str| -> Option<f64> { words.next()?.strip_prefix(key)?.parse().ok() };
    let relative = Pose2::new(value("x_m=")?, value("y_m=")?, value("yaw_rad=")?);
    Some((from_ns, from_id, to_ns, to_id, relative))
}

/// The true pose of keyframe `id` of `agent`: an AGV's at the keyframe's stamp; a station's is
/// its one surveyed pose.
fn true_keyframe_pose(
    agents: &BTreeMap<String, AgentTrack>,
    agent: &str,
    id: u32,
) -> Option<Pose2> {
    let track = agents.get(agent)?;
    match track.keyframes.get(&id) {
        Some(stamp) => track.truth.get(stamp).copied(),
        None if agent.starts_with("station") => track.truth.values().next().copied(),
        None => None,
    }
}

/// Scores the edges of the latest `/fusion/edges`.
pub fn score_edges(
    agents: &BTreeMap<String, AgentTrack>,
    markers: &nrslam_msgs::MarkerArray,
) -> InterAgentEdges {
    let mut scored = InterAgentEdges::default();
    for marker in markers.markers.iter().filter(|m| m.ns == "inter_agent") {
        scored.accepted += 1;
        let Some((from_ns, from_id, to_ns, to_id, measured)) = parse_edge(&marker.text) else {
            continue;
        };
        let (Some(from), Some(to)) = (
            true_keyframe_pose(agents, from_ns, from_id),
            true_keyframe_pose(agents, to_ns, to_id),
        ) else {
            continue;
        };
        let truth = from.between(&to);
        let error_m = measured.distance_m(&truth);
        let error_deg = nrslam_association::wrap_angle_rad(measured.yaw_rad - truth.yaw_rad)
            .abs()
            .to_degrees();
        scored.scored += 1;
        let pair = scored
            .by_pair
            .entry(format!("{from_ns}-{to_ns}"))
            .or_default();
        pair.scored += 1;
        if error_m > INTER_EDGE_WRONG_M || error_deg > INTER_EDGE_WRONG_DEG {
            scored.wrong += 1;
            pair.wrong += 1;
        }
        scored.max_error_m = Some(scored.max_error_m.map_or(error_m, |m| m.max(error_m)));
        scored.max_error_deg = Some(scored.max_error_deg.map_or(error_deg, |m| m.max(error_deg)));
    }
    scored
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{Header, Pose, PoseStamped, Time};

    fn pose(stamp_s: f64, x: f64, y: f64, yaw: f64) -> Message {
        Message::PoseStamped(PoseStamped {
            header: Header::new(Time::from_seconds(stamp_s), "map"),
            pose: Pose::from_planar(x, y, yaw),
        })
    }

    #[test]
    fn an_agent_in_its_own_frame_is_scored_after_aligning_its_first_pose() {
        let mut agents = BTreeMap::new();
        // Truth starts at (10, 5) heading +y; the AGV's own frame starts at the origin.
        for k in 0..4 {
            let t = f64::from(k);
            take(
                &mut agents,
                "/agv2/ground_truth/pose",
                &pose(t, 10.0, 5.0 + t, std::f64::consts::FRAC_PI_2),
            );
            // Its own estimate: exact for 3 frames, then 1 m off sideways.
            let off = if k == 3 { 1.0 } else { 0.0 };
            take(&mut agents, "/agv2/slam/pose", &pose(t, t, off, 0.0));
            if k >= 2 {
                take(
                    &mut agents,
                    "/agv2/fusion/pose",
                    &pose(t, 10.0, 5.0 + t, 0.0),
                );
            }
        }
        // Not agents' topics: ignored.
        take(&mut agents, "/slam/pose", &pose(0.0, 1.0, 1.0, 0.0));
        take(&mut agents, "/agv2/map", &pose(0.0, 1.0, 1.0, 0.0));
        assert_eq!(agents.keys().collect::<Vec<_>>(), vec!["agv2"]);
        let s = agents["agv2"].summary();
        assert_eq!((s.frames, s.fused_frames), (4, 2));
        assert!((s.merged_after_s.unwrap() - 2.0).abs() < 1e-9);
        assert!((s.own_pose_rmse_m.unwrap() - 0.5).abs() < 1e-9, "{s:?}");
        assert!((s.own_pose_rmse_fused_frames_m.unwrap() - 0.5f64.sqrt()).abs() < 1e-9);
        assert!(s.fused_pose_rmse_m.unwrap() < 1e-9);
    }

    #[test]
    fn agents_csv_holds_each_pose_with_the_own_frame_put_on_the_truth() {
        let mut agents = BTreeMap::new();
        for k in 0..3 {
            let t = f64::from(k);
            take(
                &mut agents,
                "/agv2/ground_truth/pose",
                &pose(t, 10.0 + t, 5.0, 0.0),
            );
            take(&mut agents, "/agv2/slam/pose", &pose(t, t, 0.0, 0.0));
            if k == 2 {
                take(&mut agents, "/agv2/fusion/pose", &pose(t, 12.5, 5.0, 0.0));
            }
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("agents.csv");
        write_agents_csv(&agents, &path).unwrap();
        let mut reader = csv::Reader::from_path(&path).unwrap();
        let headers = reader.headers().unwrap().clone();
        let rows: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
        assert_eq!(rows.len(), 3);
        let cell = |row: usize, column: &str| {
            let index = headers.iter().position(|h| h == column);
            rows[row][index.unwrap()].to_owned()
        };
        assert_eq!(cell(1, "agent"), "agv2");
        assert_eq!(cell(1, "time_s"), "1");
        // Its own frame starts at the origin; put on the truth's it starts at (10, 5).
        assert_eq!(cell(1, "own_x_m").parse::<f64>().unwrap(), 11.0);
        assert_eq!(cell(1, "own_y_m").parse::<f64>().unwrap(), 5.0);
        // No fused pose before the merge: empty cells, not zeros.
        assert_eq!(cell(1, "fused_x_m"), "");
        assert_eq!(cell(2, "fused_x_m").parse::<f64>().unwrap(), 12.5);
    }

    #[test]
    fn inter_agent_edges_are_scored_against_the_true_keyframe_poses() {
        let mut agents = BTreeMap::new();
        let keyframe = |stamp_s: f64, id: u32| {
            Message::Keyframe(nrslam_msgs::Keyframe {
                header: Header::new(Time::from_seconds(stamp_s), "map"),
                id,
                ..Default::default()
            })
        };
        take(
            &mut agents,
            "/agv1/ground_truth/pose",
            &pose(1.0, 0.0, 0.0, 0.0),
        );
        take(&mut agents, "/agv1/slam/keyframe", &keyframe(1.0, 3));
        take(
            &mut agents,
            "/agv2/ground_truth/pose",
            &pose(2.0, 2.0, 1.0, 0.1),
        );
        take(&mut agents, "/agv2/slam/keyframe", &keyframe(2.0, 7));
        take(
            &mut agents,
            "/station1/ground_truth/pose",
            &pose(0.0, 10.0, 0.0, 0.0),
        );
        let edge = |text: &str| nrslam_msgs::Marker {
            ns: "inter_agent".into(),
            text: text.into(),
            ..Default::default()
        };
        let markers = nrslam_msgs::MarkerArray {
            markers: vec![
                // Right: agv2's keyframe 7 is at (2, 1, 0.1) in agv1's keyframe 3's frame.
                edge("agv1/3 agv2/7 x_m=2.1 y_m=1.0 yaw_rad=0.1"),
                // Wrong by 3 m.
                edge("agv1/3 agv2/7 x_m=5.0 y_m=1.0 yaw_rad=0.1"),
                // The station's keyframe 0 at (10, 0): agv1 at (-10, 0) in its frame.
                edge("station1/0 agv1/3 x_m=-10.0 y_m=0.0 yaw_rad=0.0"),
                // No truth for agv2's keyframe 9: accepted, not scored.
                edge("agv1/3 agv2/9 x_m=0 y_m=0 yaw_rad=0"),
                // Unreadable: accepted, not scored.
                edge("garbage"),
            ],
        };
        let s = score_edges(&agents, &markers);
        assert_eq!((s.accepted, s.scored, s.wrong), (5, 3, 1), "{s:?}");
        assert!((s.max_error_m.unwrap() - 3.0).abs() < 1e-9);
    }
}
