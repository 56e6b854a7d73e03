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
//! Bad input is normal: a message with a NaN pose, a keyframe id not after the agent's last, or
//! a frame that is not the agent's own is dropped, counted and logged once per kind, never
//! fatal; the other agents keep fusing.

use std::collections::BTreeMap;

use nrslam_association::{detection_to_agv_m, Pose2};
use nrslam_msgs::topics::{
    intern, DETECTIONS, FUSION_EDGES, FUSION_POSE, KEYFRAME, KEYFRAME_POSES, ODOM, SLAM_POSE,
};
use nrslam_msgs::{
    ColorRGBA, Detections, Header, Keyframe, KeyframePoses, Marker, MarkerArray, Message, Odometry,
    Point, Pose, PoseStamped, Time, Vector3,
};
use nrslam_runtime::{Node, NodeContext, NodeError, NodeResult, Outbox};

use crate::fusion::{Fusion, Update};
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
    /// Inputs dropped, by reason.
    dropped: BTreeMap<String, u64>,
    /// Stamp of the newest message handled: outputs never go back in time.
    last_stamp: Time,
}

/// Builds the fusion node from validated `params`; it draws no random numbers and reads no files.
pub fn build(params: Params, _ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    Ok(Box::new(FusionNode::new(params)?))
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
            dropped: BTreeMap::new(),
            last_stamp: Time::default(),
        })
    }

    /// The algorithm state.
    pub fn fusion(&self) -> &Fusion {
        &self.fusion
    }

    /// Inputs dropped so far, by reason.
    pub fn dropped(&self) -> &BTreeMap<String, u64> {
        &self.dropped
    }

    fn drop_input(&mut self, topic: &str, reason: impl std::fmt::Display) {
        let key = format!("{topic}: {reason}");
        let count = self.dropped.entry(key.clone()).or_insert(0);
        *count += 1;
        if *count == 1 {
            tracing::warn!("fusion dropped an input (later ones like it are counted): {key}");
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

    fn on_keyframe(
        &mut self,
        topic: &str,
        agent: usize,
        keyframe: &Keyframe,
        outbox: &mut Outbox,
    ) -> NodeResult {
        let (x_m, y_m, yaw_rad) = keyframe.pose.planar();
        let points = body_points(keyframe.boresight_rad, &keyframe.detections);
        let stamp = keyframe.header.stamp;
        match self
            .fusion
            .add_keyframe(agent, keyframe.id, Pose2::new(x_m, y_m, yaw_rad), points)
        {
            Ok(update) => {
                self.keyframes[agent].push(keyframe.clone());
                self.publish_update(&update, stamp, outbox);
            }
            Err(e) => self.drop_input(topic, e),
        }
        Ok(())
    }

    fn on_keyframe_poses(
        &mut self,
        topic: &str,
        agent: usize,
        poses: &KeyframePoses,
        outbox: &mut Outbox,
    ) -> NodeResult {
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
            Err(e) => self.drop_input(topic, e),
        }
        Ok(())
    }

    fn on_agv_pose(&mut self, topic: &str, agent: usize, pose: &PoseStamped, outbox: &mut Outbox) {
        let local = planar(&pose.pose);
        if !local.is_finite() {
            return self.drop_input(topic, "non-finite pose");
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
    ) -> NodeResult {
        let Some(pose) = self.station_pose[agent] else {
            self.drop_input(topic, "detections before the station's surveyed pose");
            return Ok(());
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
            Err(e) => self.drop_input(topic, e),
        }
        outbox.publish(
            self.pose_topics[agent],
            PoseStamped {
                header: Header::new(stamp, MAP_FRAME),
                pose: to_pose(&pose),
            },
        );
        Ok(())
    }

    fn on_station_odom(&mut self, topic: &str, agent: usize, odometry: &Odometry) {
        let pose = planar(&odometry.pose.pose);
        if !pose.is_finite() {
            return self.drop_input(topic, "non-finite surveyed pose");
        }
        if let Some(known) = self.station_pose[agent] {
            // A station does not move: a changed survey is another program's bug.
            if known.distance_m(&pose) > 1e-3 || known.rotation_to_rad(&pose) > 1e-4 {
                return self.drop_input(topic, "surveyed pose changed");
            }
        }
        self.station_pose[agent] = Some(pose);
    }
}

impl Node for FusionNode {
    fn inputs(&self) -> Vec<&'static str> {
        self.input_order.clone()
    }

    fn outputs(&self) -> Vec<&'static str> {
        let mut out = vec![KEYFRAME, KEYFRAME_POSES, FUSION_EDGES];
        out.extend(&self.pose_topics);
        out
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        let Some(&(agent, input)) = self.inputs.get(topic) else {
            self.drop_input(topic, "not an input of this fusion node");
            return Ok(());
        };
        let stamp = message_stamp(message);
        if let Some(stamp) = stamp {
            if stamp < self.last_stamp {
                self.drop_input(topic, "stamp before an earlier input's");
                return Ok(());
            }
            self.last_stamp = stamp;
        }
        match (input, message) {
            (Input::Keyframe, Message::Keyframe(k)) => self.on_keyframe(topic, agent, k, outbox),
            (Input::KeyframePoses, Message::KeyframePoses(p)) => {
                self.on_keyframe_poses(topic, agent, p, outbox)
            }
            (Input::AgvPose, Message::PoseStamped(p)) => {
                self.on_agv_pose(topic, agent, p, outbox);
                Ok(())
            }
            (Input::StationOdom, Message::Odometry(o)) => {
                self.on_station_odom(topic, agent, o);
                Ok(())
            }
            (Input::StationDetections, Message::Detections(d)) => {
                self.on_station_detections(topic, agent, d, outbox)
            }
            (_, other) => {
                self.drop_input(topic, format!("unexpected {}", other.type_name()));
                Ok(())
            }
        }
    }

    fn on_end(&mut self, outbox: &mut Outbox) -> Result<(), NodeError> {
        if self.fusion.finish() {
            let stamp = self.last_stamp;
            outbox.publish(KEYFRAME_POSES, self.keyframe_poses(stamp));
            outbox.publish(FUSION_EDGES, self.edge_markers(stamp));
        }
        let stats = self.fusion.stats();
        let unmerged: Vec<usize> = (0..self.fusion.agent_count())
            .filter(|&a| !self.fusion.is_aligned(a))
            .map(|a| a + 1)
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

fn message_stamp(message: &Message) -> Option<Time> {
    match message {
        Message::Keyframe(k) => Some(k.header.stamp),
        Message::KeyframePoses(p) => Some(p.header.stamp),
        Message::PoseStamped(p) => Some(p.header.stamp),
        Message::Odometry(o) => Some(o.header.stamp),
        Message::Detections(d) => Some(d.header.stamp),
        _ => None,
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
