//! What a run leaves behind: the reporter listens to the graph's topics (in-process or over zenoh,
//! the same messages either way) and writes `summary.json`, `metrics.csv`, `map.png` and
//! `segments.png`.

use anyhow::{Context, Result};
use nrslam_msgs::{topics, KeyframePoses, Message, Metrics, OccupancyGrid, Segments, TargetSet};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

/// Topics the reporter needs.
pub const REPORTED: &[&str] = &[
    topics::CLOCK,
    topics::GROUND_TRUTH_TARGETS,
    topics::GROUND_TRUTH_POSE,
    topics::SLAM_POSE,
    topics::KEYFRAME,
    topics::KEYFRAME_POSES,
    topics::ASSOCIATION_STATS,
    topics::MAP,
    topics::SEGMENTS,
    topics::METRICS,
];

/// A message stamp as (sec, nanosec), exact, for matching keyframes to the truth.
type StampKey = (i32, u32);
/// A planar position (x_m, y_m).
type PositionM = (f64, f64);

/// Loop edges off by more than this against the truth count as wrong (m).
pub const LOOP_EDGE_WRONG_M: f64 = 0.5;

/// The 99 % point of χ² with 3 degrees of freedom: a loop edge whose error's squared
/// Mahalanobis distance (x, y, heading) exceeds it is off beyond its own uncertainty.
pub const LOOP_EDGE_CHI2_99: f64 = 11.345;

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
}

impl Reporter {
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
            }
            (topics::SLAM_POSE, Message::PoseStamped(p)) => {
                self.slam_path.push((p.pose.position.x, p.pose.position.y))
            }
            _ => {}
        }
    }

    /// RMSE (m) of the keyframe positions at the end of the run against the truth at their
    /// stamps: the back end's final trajectory estimate, every loop closure applied (the latest
    /// `/slam/keyframe_poses`; without it, the keyframes as first published). `None` when no
    /// keyframe has a true pose at its stamp.
    pub fn keyframe_rmse_m(&self) -> Option<f64> {
        let mut final_at: BTreeMap<u32, PositionM> = self
            .keyframes_by_id
            .iter()
            .map(|(id, (_, at))| (*id, *at))
            .collect();
        if let Some(k) = &self.keyframe_poses {
            for (id, pose) in k.ids.iter().zip(&k.poses) {
                if let Some(at) = final_at.get_mut(id) {
                    *at = (pose.position.x, pose.position.y);
                }
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

    /// The position error (m) of every loop edge in the latest `/slam/keyframe_poses` whose
    /// two keyframes have a true pose at their stamps: the distance between the measured pose of
    /// the newer keyframe in the older one's frame and the true one.
    pub fn loop_edge_errors_m(&self) -> Vec<f64> {
        self.scored_loop_edges().iter().map(|e| e.error_m).collect()
    }

    /// Every loop edge of the latest `/slam/keyframe_poses` with both keyframes' true poses.
    pub fn scored_loop_edges(&self) -> Vec<ScoredLoopEdge> {
        let Some(k) = &self.keyframe_poses else {
            return Vec::new();
        };
        let true_pose = |id: &u32| {
            let (stamp, _) = self.keyframes_by_id.get(id)?;
            self.true_by_stamp.get(stamp).copied()
        };
        k.loop_from_ids
            .iter()
            .zip(&k.loop_to_ids)
            .zip(&k.loop_relatives)
            .enumerate()
            .filter_map(|(index, ((from, to), measured))| {
                let (a, b) = (true_pose(from)?, true_pose(to)?);
                // The true pose of `to` in the frame of `from`.
                let (sin, cos) = a.2.sin_cos();
                let (dx, dy) = (b.0 - a.0, b.1 - a.1);
                let truth = (cos * dx + sin * dy, -sin * dx + cos * dy);
                let (x_m, y_m, yaw_rad) = measured.planar();
                let error_m = (x_m - truth.0).hypot(y_m - truth.1);
                let true_yaw_rad = b.2 - a.2;
                let error_rad = nrslam_association::wrap_angle_rad(yaw_rad - true_yaw_rad);
                // The error as the pose graph whitens it: in the measurement's frame.
                let (sin_z, cos_z) = yaw_rad.sin_cos();
                let (ex, ey) = (truth.0 - x_m, truth.1 - y_m);
                let e = [
                    cos_z * ex + sin_z * ey,
                    -sin_z * ex + cos_z * ey,
                    -error_rad,
                ];
                let chi2 = k
                    .loop_informations
                    .get(9 * index..9 * index + 9)
                    .map(|omega| (0..9).map(|c| e[c / 3] * omega[c] * e[c % 3]).sum::<f64>())
                    .filter(|chi2| chi2.is_finite());
                let weak_axis_information =
                    k.loop_informations.get(9 * index..9 * index + 9).map(|o| {
                        let h = [[o[0], o[1], o[2]], [o[3], o[4], o[5]], [o[6], o[7], o[8]]];
                        let marginal = nrslam_association::loop_closure::translation_marginal(&h);
                        nrslam_association::loop_closure::symmetric_eigen_2x2(&marginal).1
                    });
                error_m.is_finite().then_some(ScoredLoopEdge {
                    from: *from,
                    to: *to,
                    measured: (x_m, y_m, yaw_rad),
                    truth: (truth.0, truth.1, true_yaw_rad),
                    error_m,
                    error_rad: error_rad.abs(),
                    chi2,
                    weak_axis_information,
                })
            })
            .collect()
    }

    /// Writes `loops.csv`: one row per scored loop edge, measured against true.
    pub fn write_loops_csv(&self, path: &Path) -> Result<()> {
        let mut writer = csv::Writer::from_path(path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        writer.write_record([
            "from_keyframe",
            "to_keyframe",
            "measured_x_m",
            "measured_y_m",
            "measured_yaw_rad",
            "true_x_m",
            "true_y_m",
            "true_yaw_rad",
            "error_m",
            "error_rad",
            "chi2",
            "weak_axis_information_per_m2",
        ])?;
        for e in self.scored_loop_edges() {
            writer.write_record([
                e.from.to_string(),
                e.to.to_string(),
                e.measured.0.to_string(),
                e.measured.1.to_string(),
                e.measured.2.to_string(),
                e.truth.0.to_string(),
                e.truth.1.to_string(),
                e.truth.2.to_string(),
                e.error_m.to_string(),
                e.error_rad.to_string(),
                e.chi2.map_or_else(String::new, |c| c.to_string()),
                e.weak_axis_information
                    .map_or_else(String::new, |c| c.to_string()),
            ])?;
        }
        writer
            .flush()
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(())
    }

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
        let loop_errors_m = self.loop_edge_errors_m();
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
            loop_edges_inconsistent: self
                .scored_loop_edges()
                .iter()
                .filter(|e| e.chi2.is_some_and(|c| c > LOOP_EDGE_CHI2_99))
                .count() as u64,
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
        }
    }

    /// Writes `metrics.csv`.
    pub fn write_metrics_csv(&self, path: &Path) -> Result<()> {
        let mut writer = csv::Writer::from_path(path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        writer.write_record([
            "step",
            "time_s",
            "etgospa",
            "etgospa_localisation",
            "etgospa_confusion",
            "etgospa_missed",
            "etgospa_false",
            "gospa",
            "gospa_localisation",
            "gospa_missed",
            "gospa_false",
            "position_error_m",
            "estimated_targets",
            "estimate_points",
        ])?;
        for (step, m) in self.metrics.iter().enumerate() {
            writer.write_record([
                step.to_string(),
                m.header.stamp.as_seconds().to_string(),
                m.etgospa.to_string(),
                m.etgospa_localisation.to_string(),
                m.etgospa_confusion.to_string(),
                m.etgospa_missed.to_string(),
                m.etgospa_false.to_string(),
                m.gospa.to_string(),
                m.gospa_localisation.to_string(),
                m.gospa_missed.to_string(),
                m.gospa_false.to_string(),
                m.position_error_m.to_string(),
                m.estimated_targets.to_string(),
                m.estimate_points.to_string(),
            ])?;
        }
        writer
            .flush()
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(())
    }

    /// Writes every output into `dir`.
    pub fn write_all(&self, dir: &Path, summary: &Summary) -> Result<()> {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let json = serde_json::to_string_pretty(summary)? + "\n";
        std::fs::write(dir.join("summary.json"), json)
            .with_context(|| format!("cannot write {}", dir.join("summary.json").display()))?;
        self.write_metrics_csv(&dir.join("metrics.csv"))?;
        self.write_loops_csv(&dir.join("loops.csv"))?;
        crate::plot::map_png(&dir.join("map.png"), self)?;
        crate::plot::segments_png(&dir.join("segments.png"), self)?;
        Ok(())
    }
}

/// One loop edge of the back end's pose graph beside the truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScoredLoopEdge {
    /// Older keyframe id.
    pub from: u32,
    /// Newer keyframe id.
    pub to: u32,
    /// Measured pose of `to` in the frame of `from` (x m, y m, yaw rad).
    pub measured: (f64, f64, f64),
    /// The true one.
    pub truth: (f64, f64, f64),
    /// Distance between the measured and true positions, metres.
    pub error_m: f64,
    /// Heading difference, radians (absolute, wrapped to [0, π]).
    pub error_rad: f64,
    /// The error's squared Mahalanobis distance under the edge's own information
    /// (`loop_informations`), when the back end published it.
    pub chi2: Option<f64>,
    /// The edge's information along its weakest translation direction (1/m², the smallest
    /// eigenvalue of the translation marginal of `loop_informations`): small when the match
    /// could slide along a wall.
    pub weak_axis_information: Option<f64>,
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
    /// ([`Reporter::loop_edge_errors_m`]).
    pub loop_edges_scored: u64,
    /// Of those, edges off by more than [`LOOP_EDGE_WRONG_M`] (0.5 m): wrong loops.
    pub loop_edges_wrong: u64,
    /// The largest loop-edge position error (m); `None` without a scored edge.
    pub max_loop_edge_error_m: Option<f64>,
    /// Scored edges whose error lies outside their own stated uncertainty: squared Mahalanobis
    /// distance under the published information above [`LOOP_EDGE_CHI2_99`]. An edge that says
    /// it cannot tell where it lies along a wall, and is off along it, is not counted here.
    pub loop_edges_inconsistent: u64,
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

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{Header, Keyframe, Point, Pose, PoseStamped, Time};
    use std::f64::consts::FRAC_PI_2;

    fn header(seconds: f64) -> Header {
        Header {
            stamp: Time::from_seconds(seconds),
            frame_id: "map".into(),
        }
    }

    fn pose(x: f64, y: f64) -> Pose {
        Pose {
            position: Point { x, y, z: 0.0 },
            ..Pose::default()
        }
    }

    /// Keyframes at t = 1, 2 first published 1 m and 2 m off the truth; the truth at t = 3 has no
    /// keyframe and must not count.
    fn reporter() -> Reporter {
        let mut r = Reporter::default();
        for (t, x) in [(1.0, 0.0), (2.0, 10.0), (3.0, 20.0)] {
            let truth = PoseStamped {
                header: header(t),
                pose: pose(x, 0.0),
            };
            r.take(topics::GROUND_TRUTH_POSE, &Message::PoseStamped(truth));
        }
        for (id, t, x) in [(0, 1.0, 1.0), (1, 2.0, 12.0)] {
            let keyframe = Keyframe {
                header: header(t),
                id,
                pose: pose(x, 0.0),
                ..Keyframe::default()
            };
            r.take(topics::KEYFRAME, &Message::Keyframe(keyframe));
        }
        r
    }

    #[test]
    fn keyframe_rmse_scores_keyframes_as_published_without_corrections() {
        let rmse = reporter().keyframe_rmse_m().unwrap();
        assert!((rmse - (2.5f64).sqrt()).abs() < 1e-12, "{rmse}");
    }

    #[test]
    fn keyframe_rmse_takes_the_latest_corrected_poses() {
        let mut r = reporter();
        for (revision, second_x) in [(1, 11.0), (2, 10.0)] {
            let corrected = KeyframePoses {
                header: header(2.0),
                revision,
                ids: vec![0, 1],
                poses: vec![pose(0.0, 0.0), pose(second_x, 0.0)],
                ..KeyframePoses::default()
            };
            r.take(topics::KEYFRAME_POSES, &Message::KeyframePoses(corrected));
        }
        assert_eq!(r.keyframe_rmse_m(), Some(0.0));
    }

    #[test]
    fn loop_edges_are_scored_in_the_older_keyframes_true_frame() {
        let mut r = Reporter::default();
        // Keyframe 0 truly at (1, 1) facing +y; keyframe 1 truly at (1, 4): 3 m ahead of it.
        for (id, t, (x, y, yaw)) in [(0, 1.0, (1.0, 1.0, FRAC_PI_2)), (1, 2.0, (1.0, 4.0, 0.0))] {
            let truth = PoseStamped {
                header: header(t),
                pose: Pose::from_planar(x, y, yaw),
            };
            r.take(topics::GROUND_TRUTH_POSE, &Message::PoseStamped(truth));
            let keyframe = Keyframe {
                header: header(t),
                id,
                ..Keyframe::default()
            };
            r.take(topics::KEYFRAME, &Message::Keyframe(keyframe));
        }
        let r_with_truth = r.clone();
        // One right loop, one 0.6 m off sideways, one naming a keyframe never seen (not scored),
        // and an excess relative pose without ids (ignored).
        let poses = KeyframePoses {
            header: header(2.0),
            loop_from_ids: vec![0, 0, 0],
            loop_to_ids: vec![1, 1, 7],
            loop_relatives: vec![
                Pose::from_planar(3.0, 0.0, -FRAC_PI_2),
                Pose::from_planar(3.0, 0.6, -FRAC_PI_2),
                Pose::from_planar(0.0, 0.0, 0.0),
                Pose::from_planar(9.0, 9.0, 0.0),
            ],
            ..KeyframePoses::default()
        };
        // The same edges saying they pin down (0.1 m std) only the measurement frame's x, then
        // only its y: the 0.6 m sideways error (along the older keyframe's y, which is the
        // measurement frame's x after its -90° turn) is inconsistent with the first and not with
        // the second.
        let sure_of = |axis: usize| {
            let mut omega = vec![0.0; 9];
            omega[4 * axis] = 100.0;
            omega[8] = 1.0;
            omega
        };
        for (axis, inconsistent) in [(0, 1), (1, 0)] {
            let mut informed = poses.clone();
            informed.loop_informations = [sure_of(axis), sure_of(axis)].concat();
            let mut r = r_with_truth.clone();
            r.take(topics::KEYFRAME_POSES, &Message::KeyframePoses(informed));
            let summary = r.summary(&BTreeMap::new(), 1, "x.toml");
            assert_eq!(summary.loop_edges_inconsistent, inconsistent, "axis {axis}");
        }
        r.take(topics::KEYFRAME_POSES, &Message::KeyframePoses(poses));
        let errors = r.loop_edge_errors_m();
        assert_eq!(errors.len(), 2, "{errors:?}");
        assert!(
            errors[0] < 1e-9 && (errors[1] - 0.6).abs() < 1e-9,
            "{errors:?}"
        );
        let summary = r.summary(&BTreeMap::new(), 1, "x.toml");
        assert_eq!(
            (summary.loop_edges_scored, summary.loop_edges_wrong),
            (2, 1)
        );
    }

    #[test]
    fn keyframe_rmse_is_none_without_truth_at_the_keyframe_stamps() {
        let mut r = Reporter::default();
        let keyframe = Keyframe {
            header: header(5.0),
            ..Keyframe::default()
        };
        r.take(topics::KEYFRAME, &Message::Keyframe(keyframe));
        assert_eq!(r.keyframe_rmse_m(), None);
    }
}
