//! The reporter: collects a run's messages and writes every output.

use super::{PositionM, StampKey, Summary};
use anyhow::{Context, Result};
use nrslam_msgs::{
    topics, KeyframePoses, MapTargets, Message, Metrics, OccupancyGrid, Pose, Segments, TargetSet,
};
use std::collections::BTreeMap;
use std::path::Path;

/// Collected run.
#[derive(Debug, Default, Clone)]
pub struct Reporter {
    /// Frames seen on /clock.
    pub frames: u64,
    /// Keyframes seen.
    pub keyframes: u64,
    /// Loop closures the back end reported (latest `/slam/association_stats`).
    pub loop_closures: u64,
    /// Frames whose association statistics were seen, and the sum of their inlier ratios.
    pub association_frames: u64,
    /// Sum of the per-frame inlier ratios.
    pub inlier_ratio_sum: f64,
    /// Per-step metrics.
    pub metrics: Vec<Metrics>,
    /// Latest map.
    pub map: Option<OccupancyGrid>,
    /// Latest segments.
    pub segments: Option<Segments>,
    /// Latest fitted shapes (`/map/targets`).
    pub map_targets: Option<MapTargets>,
    /// True targets.
    pub targets: Option<TargetSet>,
    /// True path (x_m, y_m).
    pub true_path: Vec<(f64, f64)>,
    /// SLAM path (x_m, y_m).
    pub slam_path: Vec<(f64, f64)>,
    /// True pose (x_m, y_m, yaw_rad) by stamp (sec, nanosec), to score keyframes and loops.
    pub true_by_stamp: BTreeMap<StampKey, (f64, f64, f64)>,
    /// Each keyframe's stamp and the position it was first published at, by id.
    pub keyframes_by_id: BTreeMap<u32, (StampKey, PositionM)>,
    /// Latest `/slam/keyframe_poses`: every keyframe after the last loop closure.
    pub keyframe_poses: Option<KeyframePoses>,
    /// Topics whose stream has ended.
    pub ended: Vec<&'static str>,
    /// What each process's receive path dropped (latest `/diagnostics` report of each, and the
    /// launcher's own), by component, e.g. `nrslam/mapper/receive`.
    pub dropped: BTreeMap<String, nrslam_runtime::receive::Drops>,
    /// Node processes restarted by supervision, and how many times.
    pub restarts: BTreeMap<String, u32>,
    /// Node processes that died for good while the graph went on without them (`on_exit =
    /// "continue"`), and how they died.
    pub exited: BTreeMap<String, String>,
    /// The evaluator's parameters (the launch's, else the paper's), for the final ET-GOPSA of
    /// each choice of representatives in `summary.json`.
    pub evaluator: nrslam_evaluator::Params,
    /// Poses of each agent of a cooperative run, by namespace (`agv1`, `station2`, ...).
    pub agents: BTreeMap<String, super::AgentTrack>,
    /// Latest `/fusion/edges`: the fusion node's inter-agent edges.
    pub fusion_edges: Option<nrslam_msgs::MarkerArray>,
    /// Counters a node reports at its end as `/diagnostics` component
    /// `nrslam/<node>/counters` (the fusion node's merges, moves and searches), by node.
    pub counters: BTreeMap<String, BTreeMap<String, u64>>,
}

impl Reporter {
    /// Scores what the summary scores itself with the parameters of `launch`'s evaluator node,
    /// if it has one whose parameters parse (else the paper's).
    pub fn score_as(&mut self, launch: &nrslam_runtime::launch::Launch) {
        self.evaluator = launch
            .nodes
            .iter()
            .find(|node| node.kind == "evaluator")
            .and_then(|node| nrslam_runtime::parse_params(node.params.clone()).ok())
            .unwrap_or_default();
    }

    /// Records `component`'s drops so far (a later report of the same component replaces it).
    pub fn note_drops(&mut self, component: &str, drops: &nrslam_runtime::receive::Drops) {
        if !drops.is_empty() {
            self.dropped.insert(component.to_owned(), drops.clone());
        }
    }

    /// Takes one message.
    pub fn take(&mut self, topic: &str, message: &Message) {
        match (topic, message) {
            (topics::CLOCK, Message::Clock(_)) => self.frames += 1,
            (topics::KEYFRAME, Message::Keyframe(k)) => {
                self.keyframes += 1;
                let stamp = (k.header.stamp.sec, k.header.stamp.nanosec);
                let at = (k.pose.position.x, k.pose.position.y);
                self.keyframes_by_id.insert(k.id, (stamp, at));
            }
            (topics::KEYFRAME_POSES, Message::KeyframePoses(k)) => {
                self.keyframe_poses = Some(k.clone())
            }
            (topics::ASSOCIATION_STATS, Message::AssociationStats(s)) => {
                self.loop_closures = u64::from(s.loop_closures);
                self.association_frames += 1;
                self.inlier_ratio_sum += s.inlier_ratio;
            }
            (topics::METRICS, Message::Metrics(m)) => self.metrics.push(m.clone()),
            (topics::MAP, Message::OccupancyGrid(m)) => self.map = Some(m.clone()),
            (topics::SEGMENTS, Message::Segments(s)) => self.segments = Some(s.clone()),
            (topics::MAP_TARGETS, Message::MapTargets(t)) => self.map_targets = Some(t.clone()),
            (topics::GROUND_TRUTH_TARGETS, Message::TargetSet(t)) => self.targets = Some(t.clone()),
            (topics::GROUND_TRUTH_POSE, Message::PoseStamped(p)) => {
                let (x_m, y_m, yaw_rad) = p.pose.planar();
                self.true_path.push((x_m, y_m));
                let stamp = (p.header.stamp.sec, p.header.stamp.nanosec);
                self.true_by_stamp.insert(stamp, (x_m, y_m, yaw_rad));
            }
            (topics::DIAGNOSTICS, Message::DiagnosticArray(report)) => {
                for (component, drops) in nrslam_runtime::receive::drops_in(report) {
                    self.note_drops(&component, &drops);
                }
                for status in &report.status {
                    let node = status
                        .name
                        .strip_prefix("nrslam/")
                        .and_then(|rest| rest.strip_suffix("/counters"));
                    if let Some(node) = node {
                        // A value that is not a count is another program's: left out.
                        let counts = status
                            .values
                            .iter()
                            .filter_map(|v| Some((v.key.clone(), v.value.parse::<u64>().ok()?)))
                            .collect();
                        self.counters.insert(node.to_owned(), counts);
                    }
                }
            }
            (topics::SLAM_POSE, Message::PoseStamped(p)) => {
                self.slam_path.push((p.pose.position.x, p.pose.position.y))
            }
            (topics::FUSION_EDGES, Message::MarkerArray(m)) => self.fusion_edges = Some(m.clone()),
            _ => super::agents::take(&mut self.agents, topic, message),
        }
    }

    /// RMSE (m) of the keyframe positions at the end of the run against the truth at their
    /// stamps: the back end's final trajectory estimate, every loop closure applied (the latest
    /// `/slam/keyframe_poses`; without it, or if its ids and poses do not pair up, the keyframes
    /// as first published). `None` when no keyframe has a true pose at its stamp.
    pub fn keyframe_rmse_m(&self) -> Option<f64> {
        let mut final_at: BTreeMap<u32, PositionM> = self
            .keyframes_by_id
            .iter()
            .map(|(id, (_, at))| (*id, *at))
            .collect();
        for (id, pose) in self.corrected_keyframe_poses() {
            if let Some(at) = final_at.get_mut(&id) {
                *at = (pose.position.x, pose.position.y);
            }
        }
        let squared: Vec<f64> = final_at
            .iter()
            .filter_map(|(id, at)| {
                let (stamp, _) = self.keyframes_by_id.get(id)?;
                let truth = self.true_by_stamp.get(stamp)?;
                Some((at.0 - truth.0).powi(2) + (at.1 - truth.1).powi(2))
            })
            .collect();
        (!squared.is_empty()).then(|| (squared.iter().sum::<f64>() / squared.len() as f64).sqrt())
    }

    /// Each keyframe's pose in the latest `/slam/keyframe_poses`, by id; none without it, or if
    /// its ids and poses do not pair up (they cannot say which pose is whose).
    pub fn corrected_keyframe_poses(&self) -> impl Iterator<Item = (u32, &Pose)> + '_ {
        self.keyframe_poses
            .iter()
            .filter(|k| k.ids.len() == k.poses.len())
            .flat_map(|k| k.ids.iter().copied().zip(&k.poses))
    }

    /// Writes every output into `dir`.
    pub fn write_all(&self, dir: &Path, summary: &Summary) -> Result<()> {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let json = serde_json::to_string_pretty(summary)? + "\n";
        std::fs::write(dir.join("summary.json"), json)
            .with_context(|| format!("cannot write {}", dir.join("summary.json").display()))?;
        self.write_metrics_csv(&dir.join("metrics.csv"))?;
        self.write_loops_csv(&dir.join("loops.csv"))?;
        if !self.agents.is_empty() {
            super::agents::write_agents_csv(&self.agents, &dir.join("agents.csv"))?;
        }
        crate::plot::map_png(&dir.join("map.png"), self)?;
        crate::plot::segments_png(&dir.join("segments.png"), self)?;
        if self.map_targets.is_some() {
            crate::plot::shapes_png(&dir.join("shapes.png"), self)?;
            self.write_shapes_csv(&dir.join("shapes.csv"))?;
        }
        Ok(())
    }
}
