//! The fusion node: every agent's keyframes in, one fused pose graph out.
//!
//! Inputs, per AGV `agvN` (N = 1…`agvs`): `/agvN/slam/keyframe`, `/agvN/slam/keyframe_poses`
//! and `/agvN/slam/pose` (its association's outputs, in its own frame); per station `stationM`:
//! `/stationM/odom` (its surveyed pose, map frame) and `/stationM/radar/detections`.
//!
//! Outputs: `/slam/keyframe` and `/slam/keyframe_poses` over all agents (global keyframe ids in
//! the order keyframes entered the map frame; inter-agent edges as the pose graph's loop edges),
//! which the mapper, segmenter, shapes and evaluator use unchanged; `/agvN/fusion/pose` (each
//! AGV's pose corrected into the map frame, once it is merged) and `/stationM/fusion/pose`; and
//! `/fusion/edges`, one line marker per inter-agent edge between its two keyframes' fused
//! positions, whose `text` names the edge and its measurement for programs that score it:
//! `agv1/12 agv2/40 x_m=1.250000 y_m=-0.500000 yaw_rad=0.010000` (the pose of `agv2`'s keyframe
//! 40 in the frame of `agv1`'s keyframe 12, each keyframe by its agent's own id).
//!
//! Bad input is normal: a message with a NaN pose, a keyframe id not after the agent's last, a
//! header frame that is not the one the input is in (an AGV's keyframes, keyframe poses and pose,
//! and a station's surveyed pose, are all in `map`: the agent's own map frame for an AGV, the
//! survey's for a station), a stamp before an earlier input's, a station whose surveyed pose
//! changes, or a topic that is not an input is dropped, counted by topic and reason
//! ([`FusionNode::dropped`]) and logged once per kind, never fatal; the other agents keep fusing.
//! The counts go out on `/diagnostics` as component `nrslam/<node name>/inputs`, in the format of
//! the receive path's reports (`nrslam_runtime::receive::diagnostics`, behind the runtime's zenoh
//! feature, which a node crate does without), whenever a new kind of drop appears and at the
//! end, so that they reach the run's `summary.json` (`dropped`) in either mode.

use std::collections::BTreeMap;

use nrslam_association::{detection_to_agv_m, Pose2};
use nrslam_msgs::topics::{
    intern, DETECTIONS, DIAGNOSTICS, FUSION_EDGES, FUSION_POSE, KEYFRAME, KEYFRAME_POSES, ODOM,
    SLAM_POSE,
};
use nrslam_msgs::{
    ColorRGBA, Detections, DiagnosticArray, DiagnosticStatus, Header, KeyValue, Keyframe,
    KeyframePoses, Marker, MarkerArray, Message, Odometry, Point, Pose, PoseStamped, Time, Vector3,
};
use nrslam_runtime::{Node, NodeContext, NodeError, NodeResult, Outbox};

use crate::fusion::{Fusion, FusionError, Update};
use crate::params::Params;

/// Frame of everything published.
pub const MAP_FRAME: &str = "map";

/// What an input topic is, for the agent it belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Input {
    Keyframe,
    KeyframePoses,
    AgvPose,
    StationOdom,
    StationDetections,
}

/// [`Fusion`] bound to the node API.
#[derive(Debug)]
pub struct FusionNode {
    fusion: Fusion,
    /// Input topic → (agent, what it carries).
    inputs: BTreeMap<&'static str, (usize, Input)>,
    input_order: Vec<&'static str>,
    /// Per agent: its `fusion/pose` topic.
    pose_topics: Vec<&'static str>,
    /// Per agent: its namespace (`agv1`, `station2`).
    namespaces: Vec<String>,
    /// Per agent: the keyframe messages received, parallel to the algorithm's keyframes (their
    /// detections are republished with the fused pose).
    keyframes: Vec<Vec<Keyframe>>,
    /// Per station: the surveyed pose from its latest odometry.
    station_pose: Vec<Option<Pose2>>,
    /// Per AGV: the stamp of its newest keyframe taken (tells a restarted back end).
    last_keyframe_stamp: Vec<Option<Time>>,
    /// Inputs dropped, by topic and reason.
    dropped: BTreeMap<(String, &'static str), u64>,
    /// A new kind of drop (topic and reason) since the last `/diagnostics` report.
    unreported: bool,
    /// The `/diagnostics` component the drops are reported as.
    component: String,
    /// Stamp of the newest message handled: outputs never go back in time.
    last_stamp: Time,
}

/// Builds the fusion node from validated `params`; it draws no random numbers and reads no files.
/// Its drops are reported on `/diagnostics` as `nrslam/<ctx.name>/inputs`.
pub fn build(params: Params, ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    let mut node = FusionNode::new(params)?;
    node.component = format!("nrslam/{}/inputs", ctx.name);
    Ok(Box::new(node))
}

/// `/ns<topic>` as a `&'static str`.
fn namespaced(namespace: &str, topic: &str) -> &'static str {
    intern(&format!("/{namespace}{topic}"))
}

impl FusionNode {
    /// A node with `params`, which must pass [`Params::validate`].
    pub fn new(params: Params) -> Result<Self, NodeError> {
        params.validate()?;
        let fusion = Fusion::new(params.clone());
        let mut inputs = BTreeMap::new();
        let mut input_order = Vec::new();
        let mut pose_topics = Vec::new();
        let mut namespaces = Vec::new();
        let mut add = |topic: &'static str, agent: usize, input: Input| {
            inputs.insert(topic, (agent, input));
            input_order.push(topic);
        };
        for n in 0..params.agvs {
            let ns = format!("agv{}", n + 1);
            let agent = n as usize;
            // Keyframe before the poses that include it (they share a stamp), as the mapper.
            add(namespaced(&ns, KEYFRAME), agent, Input::Keyframe);
            add(namespaced(&ns, KEYFRAME_POSES), agent, Input::KeyframePoses);
            add(namespaced(&ns, SLAM_POSE), agent, Input::AgvPose);
            pose_topics.push(namespaced(&ns, FUSION_POSE));
            namespaces.push(ns);
        }
        for m in 0..params.stations {
            let ns = format!("station{}", m + 1);
            let agent = (params.agvs + m) as usize;
            // The surveyed pose before the same frame's detections.
            add(namespaced(&ns, ODOM), agent, Input::StationOdom);
            add(namespaced(&ns, DETECTIONS), agent, Input::StationDetections);
            pose_topics.push(namespaced(&ns, FUSION_POSE));
            namespaces.push(ns);
        }
        let agents = fusion.agent_count();
        Ok(FusionNode {
            fusion,
            inputs,
            input_order,
            pose_topics,
            namespaces,
            keyframes: vec![Vec::new(); agents],
            station_pose: vec![None; agents],
            last_keyframe_stamp: vec![None; agents],
            dropped: BTreeMap::new(),
            unreported: false,
            component: "nrslam/fusion/inputs".into(),
            last_stamp: Time::default(),
        })
    }

    /// The algorithm state.
    pub fn fusion(&self) -> &Fusion {
        &self.fusion
    }

    /// Inputs dropped so far, by topic and reason (`non_finite`, `wrong_frame`,
    /// `stamp_backwards`, `not_an_input`, `unexpected_type`, `station_moved`,
    /// `before_station_pose`, `out_of_order`, `wrong_kind`, `unknown_agent`).
    pub fn dropped(&self) -> &BTreeMap<(String, &'static str), u64> {
        &self.dropped
    }

    /// Drops an input on `topic` for `reason` (a word: the `/diagnostics` key is `"<topic>
    /// <reason>"`), logging `detail` the first time this topic and reason occur.
    fn drop_input(&mut self, topic: &str, reason: &'static str, detail: impl std::fmt::Display) {
        let count = self.dropped.entry((topic.to_owned(), reason)).or_insert(0);
        *count = count.saturating_add(1);
        if *count == 1 {
            self.unreported = true;
            tracing::warn!(
                topic,
                reason,
                "fusion dropped an input (later ones like it are only counted): {detail}"
            );
        }
    }

    /// The drops as a `/diagnostics` report: one status named after the component, WARN, one
    /// value per topic and reason, key `"<topic> <reason>"` and value the count (what the run's
    /// report reads back into `summary.json`'s `dropped`).
    fn diagnostics(&self) -> DiagnosticArray {
        let total: u64 = self.dropped.values().sum();
        DiagnosticArray {
            header: Header::new(self.last_stamp, ""),
            status: vec![DiagnosticStatus {
                level: DiagnosticStatus::WARN,
                name: self.component.clone(),
                message: format!("dropped {total} unusable inputs"),
                hardware_id: String::new(),
                values: self
                    .dropped
                    .iter()
                    .map(|((topic, reason), n)| KeyValue {
                        key: format!("{topic} {reason}"),
                        value: n.to_string(),
                    })
                    .collect(),
            }],
        }
    }

    /// What fusion did, as component `nrslam/<node name>/counters` (summary.json's `fusion`):
    /// one value per counter, keyed by its name.
    fn counters(&self, stats: &crate::FusionStats) -> DiagnosticArray {
        DiagnosticArray {
            header: Header::new(self.last_stamp, ""),
            status: vec![DiagnosticStatus {
                level: DiagnosticStatus::OK,
                name: self.component.replace("/inputs", "/counters"),
                message: format!(
                    "{} merges, {} moved, {} inter-agent edges",
                    stats.merges, stats.remerges, stats.inter_edges
                ),
                hardware_id: String::new(),
                values: stats
                    .counters()
                    .iter()
                    .map(|(key, n)| KeyValue {
                        key: (*key).to_owned(),
                        value: n.to_string(),
                    })
                    .collect(),
            }],
        }
    }

    fn drop_refused(&mut self, topic: &str, error: FusionError) {
        let reason = match error {
            FusionError::UnknownAgent(_) => "unknown_agent",
            FusionError::NonFinite(_) => "non_finite",
            FusionError::OutOfOrder { .. } => "out_of_order",
            FusionError::WrongKind(_) => "wrong_kind",
            FusionError::TooManyRestarts(_) => "too_many_restarts",
        };
        self.drop_input(topic, reason, error);
    }

    /// The drops on `/diagnostics`, once per new kind of drop (a bounded number of reports
    /// however many inputs are bad) and at the end. Nothing while nothing was dropped.
    fn report_drops(&mut self, outbox: &mut Outbox) {
        if std::mem::take(&mut self.unreported) {
            outbox.publish(DIAGNOSTICS, self.diagnostics());
        }
    }

    fn publish_update(&mut self, update: &Update, stamp: Time, outbox: &mut Outbox) {
        for &(agent, index) in &update.published {
            let Some((id, pose)) = self.fusion.fused_keyframe(agent, index) else {
                continue;
            };
            let Some(source) = self.keyframes[agent].get(index) else {
                continue;
            };
            outbox.publish(
                KEYFRAME,
                Keyframe {
                    header: Header::new(stamp, MAP_FRAME),
                    id,
                    pose: to_pose(&pose),
                    boresight_rad: source.boresight_rad,
                    detections: source.detections.clone(),
                },
            );
        }
        if !update.published.is_empty() || update.corrected {
            outbox.publish(KEYFRAME_POSES, self.keyframe_poses(stamp));
            // With the poses, so that a subscriber's input merge never waits on a silent stream
            // and the latest array always holds every edge (none is a statement too).
            outbox.publish(FUSION_EDGES, self.edge_markers(stamp));
        }
    }

    /// One line marker per inter-agent edge (see the module doc for its `text`).
    fn edge_markers(&self, stamp: Time) -> MarkerArray {
        let f = &self.fusion;
        let markers = f
            .inter_edges()
            .iter()
            .enumerate()
            .filter_map(|(i, e)| {
                let (_, from) = f.fused_keyframe(e.from.0, e.from.1)?;
                let (_, to) = f.fused_keyframe(e.to.0, e.to.1)?;
                let text = format!(
                    "{}/{} {}/{} x_m={:.6} y_m={:.6} yaw_rad={:.6}",
                    self.namespaces[e.from.0],
                    f.local_id(e.from.0, e.from.1)?,
                    self.namespaces[e.to.0],
                    f.local_id(e.to.0, e.to.1)?,
                    e.relative.x_m,
                    e.relative.y_m,
                    e.relative.yaw_rad
                );
                Some(Marker {
                    header: Header::new(stamp, MAP_FRAME),
                    ns: "inter_agent".into(),
                    id: i32::try_from(i).ok()?,
                    marker_type: Marker::LINE_LIST,
                    action: Marker::ADD,
                    pose: Pose::from_planar(0.0, 0.0, 0.0),
                    scale: Vector3 {
                        x: 0.1,
                        ..Vector3::default()
                    },
                    color: ColorRGBA {
                        r: 1.0,
                        g: 0.5,
                        b: 0.0,
                        a: 1.0,
                    },
                    points: vec![
                        Point::planar(from.x_m, from.y_m),
                        Point::planar(to.x_m, to.y_m),
                    ],
                    text,
                    ..Marker::default()
                })
            })
            .collect();
        MarkerArray { markers }
    }

    fn keyframe_poses(&self, stamp: Time) -> KeyframePoses {
        let (ids, poses): (Vec<u32>, Vec<Pose>) = self
            .fusion
            .fused_poses()
            .into_iter()
            .map(|(id, pose)| (id, to_pose(&pose)))
            .unzip();
        let edges = self.fusion.published_edges();
        let p = self.fusion.params();
        let (it, ir) = (
            1.0 / (p.inter_std_m * p.inter_std_m),
            1.0 / p.inter_std_deg.to_radians().powi(2),
        );
        KeyframePoses {
            header: Header::new(stamp, MAP_FRAME),
            revision: self.fusion.revision(),
            ids,
            poses,
            loop_from_ids: edges.iter().map(|e| e.0).collect(),
            loop_to_ids: edges.iter().map(|e| e.1).collect(),
            loop_relatives: edges.iter().map(|e| to_pose(&e.2)).collect(),
            loop_informations: edges
                .iter()
                .flat_map(|_| [it, 0.0, 0.0, 0.0, it, 0.0, 0.0, 0.0, ir])
                .collect(),
            pose_covariances: Vec::new(),
        }
    }

    fn on_keyframe(&mut self, topic: &str, agent: usize, keyframe: &Keyframe, outbox: &mut Outbox) {
        let (x_m, y_m, yaw_rad) = keyframe.pose.planar();
        let points = body_points(keyframe.boresight_rad, &keyframe.detections);
        let stamp = keyframe.header.stamp;
        // A back end numbers its keyframes upwards: an id not after its last, at a later stamp
        // than its last keyframe's, is its SLAM started over (a duplicate at the same stamp is
        // refused as out of order).
        let restarted = self
            .fusion
            .last_local_id(agent)
            .is_some_and(|last| keyframe.id <= last)
            && self.last_keyframe_stamp[agent].is_some_and(|last| stamp > last);
        if restarted {
            match self.fusion.start_new_session(agent) {
                Ok(Some(session)) => self.keep_earlier_session(agent, session),
                Ok(None) => {}
                Err(e) => return self.drop_refused(topic, e),
            }
        }
        match self
            .fusion
            .add_keyframe(agent, keyframe.id, Pose2::new(x_m, y_m, yaw_rad), points)
        {
            Ok(update) => {
                self.keyframes[agent].push(keyframe.clone());
                self.last_keyframe_stamp[agent] = Some(stamp);
                self.publish_update(&update, stamp, outbox);
            }
            Err(e) => self.drop_refused(topic, e),
        }
    }

    /// Mirrors [`Fusion::start_new_session`]: AGV `agent`'s keyframe messages so far move to
    /// agent `session` (always the next index), whose edges are named `agv2.1/12` (agv2's
    /// session 1, its keyframe 12).
    fn keep_earlier_session(&mut self, agent: usize, session: usize) {
        debug_assert_eq!(session, self.keyframes.len());
        let earlier = std::mem::take(&mut self.keyframes[agent]);
        self.keyframes.push(earlier);
        let prefix = format!("{}.", self.namespaces[agent]);
        let sessions = self
            .namespaces
            .iter()
            .filter(|n| n.starts_with(&prefix))
            .count();
        self.namespaces.push(format!("{prefix}{}", sessions + 1));
        self.station_pose.push(None);
        self.last_keyframe_stamp.push(None);
    }

    fn on_keyframe_poses(
        &mut self,
        topic: &str,
        agent: usize,
        poses: &KeyframePoses,
        outbox: &mut Outbox,
    ) {
        let local: Vec<(u32, Pose2)> = poses
            .ids
            .iter()
            .zip(&poses.poses)
            .map(|(id, p)| (*id, planar(p)))
            .collect();
        let loops: Vec<(u32, u32, Pose2)> = poses
            .loop_from_ids
            .iter()
            .zip(&poses.loop_to_ids)
            .zip(&poses.loop_relatives)
            .map(|((from, to), rel)| (*from, *to, planar(rel)))
            .collect();
        match self.fusion.set_local_poses(agent, &local, &loops) {
            Ok(update) => self.publish_update(&update, poses.header.stamp, outbox),
            Err(e) => self.drop_refused(topic, e),
        }
    }

    fn on_agv_pose(&mut self, topic: &str, agent: usize, pose: &PoseStamped, outbox: &mut Outbox) {
        let local = planar(&pose.pose);
        if !local.is_finite() {
            return self.drop_input(topic, "non_finite", "non-finite pose");
        }
        if let Some(corrected) = self.fusion.corrected_pose(agent, local) {
            outbox.publish(
                self.pose_topics[agent],
                PoseStamped {
                    header: Header::new(pose.header.stamp, MAP_FRAME),
                    pose: to_pose(&corrected),
                },
            );
        }
    }

    fn on_station_detections(
        &mut self,
        topic: &str,
        agent: usize,
        detections: &Detections,
        outbox: &mut Outbox,
    ) {
        let Some(pose) = self.station_pose[agent] else {
            return self.drop_input(
                topic,
                "before_station_pose",
                "detections before the station's surveyed pose",
            );
        };
        let stamp = detections.header.stamp;
        let points = body_points(detections.boresight_rad, &detections.detections);
        match self.fusion.add_station_frame(agent, pose, points) {
            Ok(update) => {
                if !update.published.is_empty() {
                    self.keyframes[agent].push(Keyframe {
                        header: Header::new(stamp, MAP_FRAME),
                        id: 0,
                        pose: to_pose(&pose),
                        boresight_rad: detections.boresight_rad,
                        detections: detections.detections.clone(),
                    });
                }
                self.publish_update(&update, stamp, outbox);
            }
            Err(e) => self.drop_refused(topic, e),
        }
        outbox.publish(
            self.pose_topics[agent],
            PoseStamped {
                header: Header::new(stamp, MAP_FRAME),
                pose: to_pose(&pose),
            },
        );
    }

    fn on_station_odom(&mut self, topic: &str, agent: usize, odometry: &Odometry) {
        let pose = planar(&odometry.pose.pose);
        if !pose.is_finite() {
            return self.drop_input(topic, "non_finite", "non-finite surveyed pose");
        }
        if let Some(known) = self.station_pose[agent] {
            // A station does not move: a changed survey is another program's bug.
            if known.distance_m(&pose) > 1e-3 || known.rotation_to_rad(&pose) > 1e-4 {
                return self.drop_input(
                    topic,
                    "station_moved",
                    format!("surveyed pose changed from {known:?} to {pose:?}"),
                );
            }
        }
        self.station_pose[agent] = Some(pose);
    }

    /// One input: checked (an input topic, the type and header frame it carries, not before an
    /// earlier input), then fused; anything unusable is dropped and counted.
    fn handle(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) {
        let Some(&(agent, input)) = self.inputs.get(topic) else {
            return self.drop_input(topic, "not_an_input", "not an input of this fusion node");
        };
        let Some((stamp, frame_id)) = header_of(input, message) else {
            return self.drop_input(
                topic,
                "unexpected_type",
                format!("unexpected {}", message.type_name()),
            );
        };
        // Checked before the stamp, so that a message dropped for its frame cannot move the
        // clock on and make the other agents' inputs late.
        if let Some(expected) = input.frame() {
            if frame_id != expected {
                return self.drop_input(
                    topic,
                    "wrong_frame",
                    format!("header frame {frame_id:?}, expected {expected:?}"),
                );
            }
        }
        if stamp < self.last_stamp {
            return self.drop_input(
                topic,
                "stamp_backwards",
                format!(
                    "stamp {} s before an earlier input's {} s",
                    stamp.as_seconds(),
                    self.last_stamp.as_seconds()
                ),
            );
        }
        self.last_stamp = stamp;
        // `header_of` matched the type to the input already.
        match message {
            Message::Keyframe(k) => self.on_keyframe(topic, agent, k, outbox),
            Message::KeyframePoses(p) => self.on_keyframe_poses(topic, agent, p, outbox),
            Message::PoseStamped(p) => self.on_agv_pose(topic, agent, p, outbox),
            Message::Odometry(o) => self.on_station_odom(topic, agent, o),
            Message::Detections(d) => self.on_station_detections(topic, agent, d, outbox),
            _ => {}
        }
    }
}

impl Input {
    /// The header frame this input must carry (`None`: any; a station's detections are in its
    /// radar's frame, whatever the driver calls it).
    fn frame(self) -> Option<&'static str> {
        match self {
            Input::Keyframe | Input::KeyframePoses | Input::AgvPose | Input::StationOdom => {
                Some(MAP_FRAME)
            }
            Input::StationDetections => None,
        }
    }
}

/// The stamp and header frame of `message` if it is of the type `input` carries.
fn header_of(input: Input, message: &Message) -> Option<(Time, &str)> {
    let header = match (input, message) {
        (Input::Keyframe, Message::Keyframe(k)) => &k.header,
        (Input::KeyframePoses, Message::KeyframePoses(p)) => &p.header,
        (Input::AgvPose, Message::PoseStamped(p)) => &p.header,
        (Input::StationOdom, Message::Odometry(o)) => &o.header,
        (Input::StationDetections, Message::Detections(d)) => &d.header,
        _ => return None,
    };
    Some((header.stamp, header.frame_id.as_str()))
}

impl Node for FusionNode {
    fn inputs(&self) -> Vec<&'static str> {
        self.input_order.clone()
    }

    fn outputs(&self) -> Vec<&'static str> {
        let mut out = vec![KEYFRAME, KEYFRAME_POSES, FUSION_EDGES, DIAGNOSTICS];
        out.extend(&self.pose_topics);
        out
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        self.handle(topic, message, outbox);
        self.report_drops(outbox);
        Ok(())
    }

    fn on_end(&mut self, outbox: &mut Outbox) -> Result<(), NodeError> {
        // The final counts, whatever was reported before.
        self.unreported = !self.dropped.is_empty();
        self.report_drops(outbox);
        if self.fusion.finish() {
            let stamp = self.last_stamp;
            outbox.publish(KEYFRAME_POSES, self.keyframe_poses(stamp));
            outbox.publish(FUSION_EDGES, self.edge_markers(stamp));
        }
        let stats = self.fusion.stats();
        outbox.publish(DIAGNOSTICS, self.counters(&stats));
        let unmerged: Vec<&str> = (0..self.fusion.agent_count())
            .filter(|&a| !self.fusion.is_aligned(a))
            .map(|a| self.namespaces[a].as_str())
            .collect();
        if !unmerged.is_empty() {
            tracing::warn!(
                ?unmerged,
                "AGVs never merged into the map frame: their keyframes are not in the fused map"
            );
        }
        tracing::info!(
            ?stats,
            dropped = self.dropped.values().sum::<u64>(),
            "fusion ended"
        );
        Ok(())
    }
}

fn planar(pose: &Pose) -> Pose2 {
    let (x_m, y_m, yaw_rad) = pose.planar();
    Pose2::new(x_m, y_m, yaw_rad)
}

fn to_pose(pose: &Pose2) -> Pose {
    Pose::from_planar(pose.x_m, pose.y_m, pose.yaw_rad)
}

fn body_points(boresight_rad: f64, detections: &[nrslam_msgs::Detection]) -> Vec<[f64; 2]> {
    detections
        .iter()
        .map(|d| detection_to_agv_m(d.range_m, d.angle_rad, boresight_rad))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{Clock, Detection, PoseWithCovariance};

    /// Two AGVs with known starts (both aligned from their first keyframe, so each good keyframe
    /// is published at once) and one station.
    fn node() -> FusionNode {
        FusionNode::new(Params {
            agvs: 2,
            stations: 1,
            known_starts: 2,
            ..Params::default()
        })
        .unwrap()
    }

    fn detections() -> Vec<Detection> {
        (0..5)
            .map(|i| Detection {
                range_m: 5.0 + f64::from(i),
                angle_rad: 0.1 * f64::from(i),
                range_std_m: 0.05,
                angle_std_rad: 0.02,
                power_db: 0.0,
            })
            .collect()
    }

    fn keyframe(stamp_s: f64, frame: &str, id: u32, x_m: f64) -> Message {
        Message::Keyframe(Keyframe {
            header: Header::new(Time::from_seconds(stamp_s), frame),
            id,
            pose: Pose::from_planar(x_m, 2.0, 0.0),
            boresight_rad: std::f64::consts::FRAC_PI_2,
            detections: detections(),
        })
    }

    fn station_odom(stamp_s: f64, x_m: f64) -> Message {
        Message::Odometry(Odometry {
            header: Header::new(Time::from_seconds(stamp_s), MAP_FRAME),
            child_frame_id: "base_link".into(),
            pose: PoseWithCovariance {
                pose: Pose::from_planar(x_m, 0.0, std::f64::consts::FRAC_PI_2),
                ..PoseWithCovariance::default()
            },
            ..Odometry::default()
        })
    }

    /// Feeds `message` on `topic`, which must never be an error; returns what was published.
    fn feed(node: &mut FusionNode, topic: &str, message: Message) -> Vec<(&'static str, Message)> {
        let mut outbox = Outbox::new();
        node.on_message(topic, &message, &mut outbox)
            .unwrap_or_else(|e| panic!("{topic}: an error instead of a drop: {e}"));
        outbox.drain().collect()
    }

    /// The fused keyframes published, as (global id, x).
    fn keyframes(published: &[(&'static str, Message)]) -> Vec<(u32, f64)> {
        published
            .iter()
            .filter_map(|(topic, m)| match (*topic, m) {
                (KEYFRAME, Message::Keyframe(k)) => Some((k.id, k.pose.position.x)),
                _ => None,
            })
            .collect()
    }

    /// The values of the last `/diagnostics` report of drops published, as (key, count).
    fn reported(published: &[(&'static str, Message)]) -> Option<Vec<(String, String)>> {
        published
            .iter()
            .rev()
            .find_map(|(topic, m)| match (*topic, m) {
                (DIAGNOSTICS, Message::DiagnosticArray(d))
                    if !d.status.iter().any(|s| s.name.ends_with("/counters")) =>
                {
                    assert_eq!(d.status.len(), 1);
                    assert_eq!(d.status[0].name, "nrslam/fusion/inputs");
                    assert_eq!(d.status[0].level, DiagnosticStatus::WARN);
                    Some(
                        d.status[0]
                            .values
                            .iter()
                            .map(|v| (v.key.clone(), v.value.clone()))
                            .collect(),
                    )
                }
                _ => None,
            })
    }

    #[test]
    fn misbehaving_inputs_are_dropped_and_counted_and_the_other_agents_keep_fusing() {
        let mut n = node();
        let (agv1, agv2) = ("/agv1/slam/keyframe", "/agv2/slam/keyframe");
        let out = feed(&mut n, agv1, keyframe(1.0, MAP_FRAME, 0, 10.0));
        assert_eq!(keyframes(&out), vec![(0, 10.0)]);
        assert_eq!(reported(&out), None, "nothing dropped, nothing reported");

        // A NaN pose.
        let mut nan = keyframe(2.0, MAP_FRAME, 0, 0.0);
        if let Message::Keyframe(k) = &mut nan {
            k.pose.position.y = f64::NAN;
        }
        let out = feed(&mut n, agv2, nan);
        assert!(keyframes(&out).is_empty());
        assert_eq!(
            reported(&out),
            Some(vec![(format!("{agv2} non_finite"), "1".into())]),
            "the first drop of a kind is reported at once"
        );
        // A keyframe in its odometry frame instead of its map frame, stamped far ahead: dropped
        // for its frame before its stamp can make every later input late.
        assert!(keyframes(&feed(&mut n, agv2, keyframe(100.0, "odom", 0, 20.0))).is_empty());
        // Before an input already handled.
        assert!(keyframes(&feed(&mut n, agv2, keyframe(0.5, MAP_FRAME, 0, 20.0))).is_empty());
        // A topic that is not an input (a third AGV this node does not fuse).
        let out = feed(
            &mut n,
            "/agv3/slam/keyframe",
            keyframe(2.5, MAP_FRAME, 0, 5.0),
        );
        assert!(out.iter().all(|(t, _)| *t == DIAGNOSTICS));
        // The wrong type on an input.
        let clock = Message::Clock(Clock {
            clock: Time::from_seconds(2.6),
        });
        assert!(keyframes(&feed(&mut n, agv2, clock)).is_empty());

        // A station whose surveyed pose changes keeps its first one.
        let (odom, station) = ("/station1/odom", "/station1/radar/detections");
        feed(&mut n, odom, station_odom(3.0, 27.0));
        let out = feed(&mut n, odom, station_odom(3.5, 28.0));
        assert!(out.iter().all(|(t, _)| *t == DIAGNOSTICS));
        let frame = Message::Detections(Detections {
            header: Header::new(Time::from_seconds(4.0), "radar"),
            boresight_rad: 0.0,
            detections: detections(),
        });
        let out = feed(&mut n, station, frame);
        assert_eq!(keyframes(&out), vec![(1, 27.0)]);
        let pose = out.iter().find_map(|(t, m)| match (*t, m) {
            ("/station1/fusion/pose", Message::PoseStamped(p)) => Some(p.pose.position.x),
            _ => None,
        });
        assert_eq!(pose, Some(27.0));

        // After all that, a good keyframe of the agent that misbehaved is fused, and so is the
        // other agent's next one.
        let out = feed(&mut n, agv2, keyframe(5.0, MAP_FRAME, 0, 20.0));
        assert_eq!(keyframes(&out), vec![(2, 20.0)]);
        let out = feed(&mut n, agv1, keyframe(6.0, MAP_FRAME, 1, 11.0));
        assert_eq!(keyframes(&out), vec![(3, 11.0)]);
        // An id the agent already sent, at the same stamp (at a later one it would be its SLAM
        // started over).
        assert!(keyframes(&feed(&mut n, agv1, keyframe(6.0, MAP_FRAME, 1, 11.0))).is_empty());

        let expected = [
            (agv1, "out_of_order"),
            (agv2, "non_finite"),
            (agv2, "stamp_backwards"),
            (agv2, "unexpected_type"),
            (agv2, "wrong_frame"),
            ("/agv3/slam/keyframe", "not_an_input"),
            (odom, "station_moved"),
        ];
        let dropped: Vec<(&str, &str, u64)> = n
            .dropped()
            .iter()
            .map(|((topic, reason), count)| (topic.as_str(), *reason, *count))
            .collect();
        assert_eq!(
            dropped,
            expected.map(|(topic, reason)| (topic, reason, 1)).to_vec()
        );
        // The end reports every count, keyed as the receive path's reports are.
        let mut outbox = Outbox::new();
        n.on_end(&mut outbox).unwrap();
        let end: Vec<_> = outbox.drain().collect();
        let mut keys: Vec<(String, String)> = expected
            .iter()
            .map(|(topic, reason)| (format!("{topic} {reason}"), "1".to_owned()))
            .collect();
        keys.sort();
        assert_eq!(reported(&end), Some(keys));
    }

    #[test]
    fn an_agv_whose_back_end_starts_over_is_followed_not_dropped() {
        let mut n = node();
        let agv1 = "/agv1/slam/keyframe";
        feed(&mut n, agv1, keyframe(1.0, MAP_FRAME, 0, 10.0));
        feed(&mut n, agv1, keyframe(2.0, MAP_FRAME, 1, 11.0));
        // Its SLAM restarted: ids from 0 again, later stamps. Its frame is unknown now, so
        // nothing is published until it is merged again; nothing is dropped either.
        let out = feed(&mut n, agv1, keyframe(3.0, MAP_FRAME, 0, 30.0));
        assert!(keyframes(&out).is_empty());
        feed(&mut n, agv1, keyframe(4.0, MAP_FRAME, 1, 31.0));
        assert!(n.dropped().is_empty(), "{:?}", n.dropped());
        assert_eq!(n.fusion().stats().restarts, 1);
        // Its keyframe 1 again at the same stamp is a duplicate, not another restart.
        feed(&mut n, agv1, keyframe(4.0, MAP_FRAME, 1, 31.0));
        assert_eq!(n.fusion().stats().restarts, 1);
        assert_eq!(
            n.dropped().keys().collect::<Vec<_>>(),
            [&(agv1.to_owned(), "out_of_order")]
        );
        // Agents 0-2 as built, the earlier session of agv1 after them, named for edge markers.
        assert_eq!(n.fusion().agent_count(), 4);
        assert_eq!(n.namespaces[3], "agv1.1");
        assert_eq!(n.keyframes[3].len(), 2);
        assert_eq!(n.keyframes[0].len(), 2);
        // Started over again with its keyframe 0 lost: its keyframe 1 at a later stamp.
        feed(&mut n, agv1, keyframe(5.0, MAP_FRAME, 1, 50.0));
        assert_eq!(n.fusion().stats().restarts, 2);
        assert_eq!(n.namespaces[4], "agv1.2");
        // Its earlier keyframes stay in the fused poses, with their global ids.
        let ids: Vec<u32> = n.fusion().fused_poses().iter().map(|(id, _)| *id).collect();
        assert_eq!(ids, vec![0, 1]);
        let mut outbox = Outbox::new();
        n.on_end(&mut outbox).unwrap();
        let counters = outbox.drain().find_map(|(_, m)| match m {
            Message::DiagnosticArray(d) if d.status[0].name.ends_with("/counters") => Some(d),
            _ => None,
        });
        let restarts = counters.expect("counters reported").status[0]
            .values
            .iter()
            .find(|v| v.key == "restarts")
            .map(|v| v.value.clone());
        assert_eq!(restarts.as_deref(), Some("2"));
    }

    #[test]
    fn a_drop_of_a_kind_already_reported_is_counted_without_a_new_report() {
        let mut n = node();
        let topic = "/agv1/slam/pose";
        let pose = |stamp_s: f64| {
            Message::PoseStamped(PoseStamped {
                header: Header::new(Time::from_seconds(stamp_s), "odom"),
                pose: Pose::from_planar(1.0, 2.0, 0.0),
            })
        };
        assert!(reported(&feed(&mut n, topic, pose(1.0))).is_some());
        for k in 2..10 {
            assert_eq!(reported(&feed(&mut n, topic, pose(f64::from(k)))), None);
        }
        assert_eq!(n.dropped()[&(topic.to_owned(), "wrong_frame")], 9);
    }

    #[test]
    fn a_clean_run_reports_no_drops_only_its_counters() {
        let mut n = node();
        feed(
            &mut n,
            "/agv1/slam/keyframe",
            keyframe(1.0, MAP_FRAME, 0, 1.0),
        );
        let mut outbox = Outbox::new();
        n.on_end(&mut outbox).unwrap();
        let statuses: Vec<&DiagnosticStatus> = outbox
            .iter()
            .filter_map(|(t, m)| match (*t, m) {
                (DIAGNOSTICS, Message::DiagnosticArray(d)) => Some(&d.status),
                _ => None,
            })
            .flatten()
            .collect();
        assert_eq!(statuses.len(), 1, "{statuses:?}");
        let counters = statuses[0];
        assert_eq!(counters.name, "nrslam/fusion/counters");
        assert_eq!(counters.level, DiagnosticStatus::OK);
        let value = |key: &str| {
            let v = counters.values.iter().find(|v| v.key == key);
            v.map(|v| v.value.as_str())
        };
        // One keyframe of the known-start AGV: nothing searched or merged.
        assert_eq!(value("merges"), Some("0"));
        assert_eq!(value("global_searches"), Some("0"));
        assert_eq!(
            counters.values.len(),
            crate::FusionStats::default().counters().len()
        );
        assert!(n.dropped().is_empty());
    }
}
