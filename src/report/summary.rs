//! `summary.json`: the run in one record.

use super::{Reporter, LOOP_EDGE_CHI2_99, LOOP_EDGE_WRONG_M};
use serde::Serialize;
use std::collections::BTreeMap;

impl Reporter {
    /// The summary of the run.
    pub fn summary(
        &self,
        arguments: &BTreeMap<String, toml::Value>,
        seed: u64,
        launch: &str,
    ) -> Summary {
        let last = self.metrics.last();
        let squared: Vec<f64> = self
            .metrics
            .iter()
            .map(|m| m.position_error_m * m.position_error_m)
            .collect();
        let rms = |values: &[f64]| {
            (!values.is_empty()).then(|| (values.iter().sum::<f64>() / values.len() as f64).sqrt())
        };
        let scored_loops = self.scored_loop_edges();
        let loop_errors_m: Vec<f64> = scored_loops.iter().map(|e| e.error_m).collect();
        let graph_errors_m: Vec<f64> = scored_loops
            .iter()
            .filter_map(|e| e.graph_error_m)
            .collect();
        Summary {
            etgospa: last.map(|m| m.etgospa),
            gospa: last.map(|m| m.gospa),
            pose_rmse_m: rms(&squared),
            second_half_pose_rmse_m: rms(&squared[squared.len() / 2..]),
            final_position_error_m: last.map(|m| m.position_error_m),
            keyframe_rmse_m: self.keyframe_rmse_m(),
            frames: self.frames,
            metric_steps: self.metrics.len() as u64,
            keyframes: self.keyframes,
            loop_closures: self.loop_closures,
            loop_edges_scored: loop_errors_m.len() as u64,
            loop_edges_wrong: loop_errors_m
                .iter()
                .filter(|&&e| e > LOOP_EDGE_WRONG_M)
                .count() as u64,
            max_loop_edge_error_m: loop_errors_m.iter().copied().reduce(f64::max),
            loop_edges_inconsistent: scored_loops
                .iter()
                .filter(|e| e.chi2.is_some_and(|c| c > LOOP_EDGE_CHI2_99))
                .count() as u64,
            loop_edges_off_in_graph: (!graph_errors_m.is_empty()).then(|| {
                graph_errors_m
                    .iter()
                    .filter(|&&g| g > LOOP_EDGE_WRONG_M)
                    .count() as u64
            }),
            mean_inlier_ratio: (self.association_frames > 0)
                .then(|| self.inlier_ratio_sum / self.association_frames as f64),
            estimated_targets: last.map(|m| m.estimated_targets),
            occupied_cells: self.segments.as_ref().map(|s| s.points.len() as u64),
            seed,
            launch: launch.to_owned(),
            arguments: arguments
                .iter()
                .map(|(k, v)| (k.clone(), toml_to_json(v)))
                .collect(),
            dropped: self.dropped.clone(),
            restarts: self.restarts.clone(),
            exited: self.exited.clone(),
            shapes: self.shape_summary(),
            differs_from_recording: BTreeMap::new(),
            agents: self
                .agents
                .iter()
                .map(|(name, track)| (name.clone(), track.summary()))
                .collect(),
            inter_agent_edges: self
                .fusion_edges
                .as_ref()
                .map(|m| super::agents::score_edges(&self.agents, m)),
            counters: self.counters.clone(),
        }
    }
}

/// `summary.json`: the same for a seed whatever the mode (no wall time in it).
#[derive(Debug, Serialize, PartialEq)]
pub struct Summary {
    /// Final ET-GOPSA.
    pub etgospa: Option<f64>,
    /// Final GOSPA.
    pub gospa: Option<f64>,
    /// Root mean square of the per-step AGV position error (m).
    pub pose_rmse_m: Option<f64>,
    /// The same over the second half of the steps (m): on a run of two laps, the second lap,
    /// where loops closed on the first should keep the pose the user gets on the map.
    pub second_half_pose_rmse_m: Option<f64>,
    /// Position error at the last step (m).
    pub final_position_error_m: Option<f64>,
    /// RMSE of the final keyframe trajectory, every loop closure applied (m); see
    /// [`Reporter::keyframe_rmse_m`]. `pose_rmse_m` scores each pose when it was published.
    pub keyframe_rmse_m: Option<f64>,
    /// Radar frames.
    pub frames: u64,
    /// Rows of metrics.csv.
    pub metric_steps: u64,
    /// Keyframes.
    pub keyframes: u64,
    /// Loop closures accepted by the back end (0 if it reports none).
    pub loop_closures: u64,
    /// Loop edges of the final pose graph scored against the truth
    /// ([`Reporter::scored_loop_edges`]).
    pub loop_edges_scored: u64,
    /// Of those, edges off by more than [`LOOP_EDGE_WRONG_M`] (0.5 m): wrong loops.
    pub loop_edges_wrong: u64,
    /// The largest loop-edge position error (m); `None` without a scored edge.
    pub max_loop_edge_error_m: Option<f64>,
    /// Scored edges whose error lies outside their own stated uncertainty: squared Mahalanobis
    /// distance under the published information above [`LOOP_EDGE_CHI2_99`]. An edge that says
    /// it cannot tell where it lies along a wall, and is off along it, is not counted here.
    pub loop_edges_inconsistent: u64,
    /// Scored edges, wrong or not, whose two keyframes the final graph (every edge applied)
    /// holds more than [`LOOP_EDGE_WRONG_M`] off their true relative position
    /// ([`super::ScoredLoopEdge::graph_error_m`]): how often the map itself is that far off at a
    /// loop. `None` when no scored edge has a graph estimate (a back end that publishes no
    /// keyframe poses).
    pub loop_edges_off_in_graph: Option<u64>,
    /// Mean over frames of the association inlier ratio (`/slam/association_stats`).
    pub mean_inlier_ratio: Option<f64>,
    /// Clusters in the final map.
    pub estimated_targets: Option<u32>,
    /// Occupied cells in the final map.
    pub occupied_cells: Option<u64>,
    /// Run seed.
    pub seed: u64,
    /// Launch file.
    pub launch: String,
    /// Launch arguments used.
    pub arguments: BTreeMap<String, serde_json::Value>,
    /// Unusable samples dropped, by component, topic and reason (absent when none).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub dropped: BTreeMap<String, nrslam_runtime::receive::Drops>,
    /// Node processes restarted by supervision (absent when none).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub restarts: BTreeMap<String, u32>,
    /// Node processes that died for good while the graph went on without them (`on_exit =
    /// "continue"`, docs/launch.md), each with how it died (absent when none).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub exited: BTreeMap<String, String>,
    /// The fitted shapes against the truth, and the final ET-GOPSA with each choice of
    /// representatives (absent when the run fits no shapes; see `report/shapes.rs`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shapes: Option<super::ShapeSummary>,
    /// A replay run with other parameters than the recording (`node.param:=value` or `--seed` on
    /// the replay's command line): each one that differs, as `{"recorded": .., "replay": ..}`
    /// (`recorded` null: the recording left it at the node's default). Absent when the replay
    /// runs the recorded back end as it was.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub differs_from_recording: BTreeMap<String, serde_json::Value>,
    /// Each agent of a cooperative run (namespaced `ground_truth/pose`, `slam/pose`,
    /// `fusion/pose`): its pose error on its own and fused (absent for a single-AGV run).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub agents: BTreeMap<String, super::AgentSummary>,
    /// The fusion node's inter-agent edges against the truth (absent without a fusion node).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inter_agent_edges: Option<super::InterAgentEdges>,
    /// What nodes counted, by node (`/diagnostics` components `nrslam/<node>/counters`): the
    /// fusion node's searches, merges, moved merges (`remerges`) and edges. Absent when no node
    /// reports any.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub counters: BTreeMap<String, BTreeMap<String, u64>>,
}

fn toml_to_json(value: &toml::Value) -> serde_json::Value {
    match value {
        toml::Value::String(s) => serde_json::Value::String(s.clone()),
        toml::Value::Integer(i) => serde_json::Value::from(*i),
        toml::Value::Float(f) => serde_json::Value::from(*f),
        toml::Value::Boolean(b) => serde_json::Value::Bool(*b),
        other => serde_json::Value::String(other.to_string()),
    }
}
