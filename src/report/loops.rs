//! Loop edges of the back end's pose graph scored against the truth, and `loops.csv`.

use super::Reporter;
use anyhow::{Context, Result};
use std::path::Path;

/// Loop edges off by more than this against the truth count as wrong (m).
pub const LOOP_EDGE_WRONG_M: f64 = 0.5;

/// The 99 % point of χ² with 3 degrees of freedom: a loop edge whose error's squared
/// Mahalanobis distance (x, y, heading) exceeds it is off beyond its own uncertainty.
pub const LOOP_EDGE_CHI2_99: f64 = 11.345;

impl Reporter {
    /// Every loop edge of the latest `/slam/keyframe_poses` with both keyframes' true poses, its
    /// position error (`error_m`) the distance between the measured position of the newer
    /// keyframe in the older one's frame and the true one.
    pub fn scored_loop_edges(&self) -> Vec<ScoredLoopEdge> {
        let Some(k) = &self.keyframe_poses else {
            return Vec::new();
        };
        let true_pose = |id: &u32| {
            let (stamp, _) = self.keyframes_by_id.get(id)?;
            self.true_by_stamp.get(stamp).copied()
        };
        let estimated: std::collections::HashMap<u32, (f64, f64, f64)> = self
            .corrected_keyframe_poses()
            .map(|(id, p)| (id, p.planar()))
            .collect();
        k.loop_from_ids
            .iter()
            .zip(&k.loop_to_ids)
            .zip(&k.loop_relatives)
            .enumerate()
            .filter_map(|(index, ((from, to), measured))| {
                let (a, b) = (true_pose(from)?, true_pose(to)?);
                let truth = position_in_frame_of(a, b);
                let (x_m, y_m, yaw_rad) = measured.planar();
                let error_m = (x_m - truth.0).hypot(y_m - truth.1);
                // The same relative position as the final graph has it, every edge (this one
                // included) applied.
                let graph_error_m = estimated
                    .get(from)
                    .zip(estimated.get(to))
                    .map(|(&a, &b)| {
                        let graph = position_in_frame_of(a, b);
                        (graph.0 - truth.0).hypot(graph.1 - truth.1)
                    })
                    .filter(|g| g.is_finite());
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
                        nrslam_association::loop_closure::weakest_translation_information(&h)
                    });
                error_m.is_finite().then_some(ScoredLoopEdge {
                    from: *from,
                    to: *to,
                    measured: (x_m, y_m, yaw_rad),
                    truth: (truth.0, truth.1, true_yaw_rad),
                    error_m,
                    graph_error_m,
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
            "graph_error_m",
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
                e.graph_error_m.map_or_else(String::new, |c| c.to_string()),
            ])?;
        }
        writer
            .flush()
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(())
    }
}

/// The position of planar pose `b` (x m, y m, yaw rad) in the frame of `a`.
fn position_in_frame_of(a: (f64, f64, f64), b: (f64, f64, f64)) -> (f64, f64) {
    let (sin, cos) = a.2.sin_cos();
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    (cos * dx + sin * dy, -sin * dx + cos * dy)
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
    /// The same distance for the final graph's relative pose of the two keyframes (m), every
    /// edge (this one included) applied: how far off the map is at this loop, whatever the
    /// edge measured. `None` when the graph does not publish both keyframes' poses, or they are
    /// not finite, or its ids and poses do not pair up.
    pub graph_error_m: Option<f64>,
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
