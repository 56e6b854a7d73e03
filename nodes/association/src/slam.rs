//! The association algorithm: odometry prediction, scan-to-map correction, keyframes.
//!
//! This is the loop between the paper's "location" and "mapping" tasks (Sec. III-A, *Location &
//! mapping*: "location requires feature points […] of map, and mapping requires accurate location
//! information"). Each frame:
//!
//! 1. **Predict.** The wheel-odometry increment since the previous frame, a relative pose in the
//!    odometry frame, is applied to the current SLAM pose. Odometry drifts, but its increments are
//!    accurate over one frame; only increments are used, so the drift of the odometry frame
//!    against the map frame does not matter. The first odometry message initialises the SLAM pose
//!    (the map frame equals the odometry frame at t0, `docs/conventions.md`).
//! 2. **Correct.** The frame's detections, each with its range and angle error, are matched
//!    against the keyframe map's cell Gaussians ([`crate::scan_matcher::match_scan`]) under a prior
//!    around the prediction whose spread is the odometry increment's own error model; the result
//!    replaces the prediction when it is trusted.
//! 3. **Map.** If the corrected pose is far enough from the last keyframe
//!    ([`crate::keyframe::KeyframeSelector`]), the frame is a keyframe and its detections, placed
//!    with the corrected pose, join the map.
//!
//! 4. **Close loops.** With `loop_closure.enabled`, every keyframe becomes a node of a pose graph
//!    ([`crate::pose_graph`]) linked to the previous keyframe by its tracked motion; old keyframes
//!    near the current estimate are tested as revisits ([`crate::loop_closure`]). A verified
//!    revisit adds a loop edge, the graph is optimised, every keyframe moves to its corrected pose
//!    and the keyframe map is rebuilt from the keyframes' scans; the current pose follows its
//!    keyframe. Which revisits are searched and which matches join the graph is the submodule
//!    `loops` (`slam/loops.rs`).
//!
//! Without loop closure (the paper's setting), errors that scan matching cannot see (the map's own
//! error) accumulate: the paper's Fig. 7 shows the AGV position MSE growing with time.
//!
//! Robustness to what real data does: an odometry increment faster than `max_speed_mps` (or
//! turning faster than `max_turn_rate_deg_s`) is a spike and is replaced by the last accepted
//! motion scaled to the elapsed time; an empty frame keeps the prediction; a dropped frame is a
//! longer odometry increment; a stationary AGV adds no keyframes. No input yields a NaN pose: the
//! odometry and detections are checked for finiteness, and every estimator falls back to its
//! input when its own result is not finite.

mod loops;

use nrslam_runtime::InvalidParam;

use crate::icp::IcpResult;
use crate::keyframe::KeyframeSelector;
use crate::loop_closure::LoopMatch;
use crate::params::Params;
use crate::point_grid::PointGrid;
use crate::pose::Pose2;
use crate::pose_graph::{leaf_covariance, Edge, EdgeKind, PoseGraph};
use crate::scan_matcher::{binnable, match_scan, scan_information, DistributionMap, RadarPoint};

use loops::loop_information;
pub use loops::LoopEdge;

/// A detection at `range_m` and angle of arrival `angle_rad` (from the array boresight,
/// counter-clockwise), for an array whose boresight is `boresight_rad` from the AGV heading, as a
/// point in the AGV frame, metres (`docs/conventions.md`, "Frames and units").
pub fn detection_to_agv_m(range_m: f64, angle_rad: f64, boresight_rad: f64) -> [f64; 2] {
    let (sin, cos) = (boresight_rad + angle_rad).sin_cos();
    [range_m * cos, range_m * sin]
}

/// Errors of the association algorithm.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AssociationError {
    /// A scan arrived before any odometry, so there is no pose to start from.
    #[error("detections arrived before the first odometry message: no initial pose")]
    NoOdometry,
    /// An odometry pose had a non-finite component.
    #[error("odometry pose is not finite: {0:?}")]
    NonFiniteOdometry(Pose2),
}

/// An odometry prediction: the pose, whether the increment was rejected as a spike, and the
/// accepted increment with the seconds it spans (if known).
type Prediction = (Pose2, bool, Option<(Pose2, f64)>);

/// Data-association statistics of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameStats {
    /// Finite scan points.
    pub detections: usize,
    /// Scan points with a map point within `max_correspondence_m` at the final pose.
    pub associated: usize,
    /// Associated points within `gate_sigma` standard deviations of their map point.
    pub inliers: usize,
    /// RMS distance of the associated points to their nearest map point, metres.
    pub rms_residual_m: f64,
    /// Fraction of the scan within `max_correspondence_m` of the last keyframe's points before
    /// this frame (1 when there is no keyframe yet or the scan is empty).
    pub keyframe_overlap: f64,
    /// The odometry increment failed the speed gate.
    pub odometry_rejected: bool,
}

/// What one frame produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameOutcome {
    /// The SLAM estimate of the AGV pose in the map frame.
    pub pose: Pose2,
    /// The odometry prediction the estimate started from.
    pub predicted: Pose2,
    /// The scan matching that turned the prediction into the estimate.
    pub icp: IcpResult,
    /// The keyframe id if this frame is a keyframe (its points have joined the map).
    pub keyframe_id: Option<u32>,
    /// Association statistics.
    pub stats: FrameStats,
    /// The loop closed on this frame, if one did.
    pub loop_match: Option<LoopMatch>,
    /// Pose-graph optimisations so far; it changes when keyframe poses were corrected.
    pub revision: u32,
}

/// One keyframe as the back end keeps it: its scan in its own frame, and its current pose.
#[derive(Debug, Clone)]
pub struct KeyframeRecord {
    /// Keyframe id (also its pose-graph node index).
    pub id: u32,
    /// Current estimate of its pose, map frame (changes on loop closure).
    pub pose: Pose2,
    /// Its detections, AGV frame, metres.
    pub scan_agv_m: Vec<[f64; 2]>,
    /// Median position error std of its detections, metres (see
    /// `loop_closure.inlier_scatter_ratio`); 0 for an empty scan.
    pub scatter_m: f64,
    /// Distance travelled from the start to this keyframe, metres.
    pub travelled_m: f64,
    /// Uncertainty of `pose` over (x m, y m, yaw rad), map frame: the pose graph's marginal
    /// covariance under `covariance_sequential_scale` and `covariance_loop_scale` (zero for the
    /// first keyframe, which anchors the map).
    pub covariance: nalgebra::Matrix3<f64>,
    /// The true pose at its stamp, map frame, when the node was given one
    /// ([`Association::set_true_pose`]); only oracle verification reads it.
    pub true_pose: Option<Pose2>,
}

impl KeyframeRecord {
    /// Its scan in the map frame, at its current pose.
    fn points_in_map(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.scan_agv_m
            .iter()
            .map(|p| self.pose.transform_point(*p))
    }
}

/// R(ψ) acting on (x, y, yaw): the translation turned by `yaw_rad`, the heading untouched.
fn planar_rotation(yaw_rad: f64) -> nalgebra::Matrix3<f64> {
    let (sin, cos) = yaw_rad.sin_cos();
    nalgebra::Matrix3::new(cos, -sin, 0.0, sin, cos, 0.0, 0.0, 0.0, 1.0)
}

/// The median of the points' position error std (the upper of the two middle values for an
/// even count), metres; 0 for no points.
fn median_position_std_m(points: &[RadarPoint]) -> f64 {
    let mut std_m: Vec<f64> = points.iter().map(RadarPoint::position_std_m).collect();
    if std_m.is_empty() {
        return 0.0;
    }
    let middle = std_m.len() / 2;
    *std_m.select_nth_unstable_by(middle, f64::total_cmp).1
}

/// The association state: SLAM pose, last odometry, keyframe map, pose graph.
#[derive(Debug)]
pub struct Association {
    params: Params,
    /// The keyframe map's points, for the association statistics.
    map: PointGrid,
    /// The map as cell Gaussians, which tracking matches against.
    cells: DistributionMap,
    keyframes: KeyframeSelector,
    records: Vec<KeyframeRecord>,
    graph: PoseGraph,
    /// Points of the last keyframe (map frame), for the overlap rule.
    last_keyframe_map: PointGrid,
    /// The SLAM pose after the last scan (or the initial pose before any scan).
    slam_pose: Option<Pose2>,
    /// The odometry pose that `slam_pose` corresponds to, and its stamp.
    odom_at_slam_pose: Option<(Pose2, Option<f64>)>,
    /// The latest odometry pose received, and its stamp.
    latest_odom: Option<(Pose2, Option<f64>)>,
    /// The last accepted odometry increment and the seconds it spanned.
    last_motion: Option<(Pose2, f64)>,
    travelled_m: f64,
    revision: u32,
    loop_closures: u32,
    cooldown: u32,
    /// Distance travelled at the last accepted loop closure, metres.
    travelled_at_closure_m: Option<f64>,
    /// First keyframe of the maps scan matching uses (`map`, `cells`): they hold exactly the
    /// keyframes `records[local_from..]`, at their current poses. A closure rebuilds them at the
    /// corrected poses; keyframes leaving the local window are retracted as they went in.
    local_from: usize,
    /// Whether the last keyframe chose local tracking (kept while a query has no detections).
    tracking_locally: bool,
    /// Loop edges in the pose graph, in the order they were accepted.
    loop_edges: Vec<LoopEdge>,
    /// Verified matches that wait for a second one to confirm them.
    pending: Vec<LoopEdge>,
    /// Closures (their loop edges by old and new keyframe) that the rest of the graph has not
    /// yet confirmed ([`Association::recheck_closures`]).
    unverified_closures: Vec<Vec<(usize, usize)>>,
    /// Per pose-graph edge, the information the keyframes' covariances take it to carry: a
    /// sequential edge's odometry model plus the scan match's own information, a loop edge's
    /// match information.
    uncertainty_information: Vec<nalgebra::Matrix3<f64>>,
    /// The truth of the next scan, for oracle verification (`loop_closure.oracle_max_error_m`).
    next_true_pose: Option<Pose2>,
    /// The loop searches' maps and grids of recent submaps.
    loop_cache: crate::loop_closure::LoopCache,
}

impl Association {
    /// A new association with validated `params`, before any odometry.
    pub fn new(params: Params) -> Result<Self, InvalidParam> {
        params.validate()?;
        let keyframes =
            KeyframeSelector::new(params.keyframe_distance_m, params.keyframe_rotation_rad());
        let map = params.statistics_grid();
        let last_keyframe_map = params.statistics_grid();
        let cells = params.distribution_map();
        Ok(Association {
            params,
            map,
            cells,
            keyframes,
            records: Vec::new(),
            graph: PoseGraph::new(),
            last_keyframe_map,
            slam_pose: None,
            odom_at_slam_pose: None,
            latest_odom: None,
            last_motion: None,
            travelled_m: 0.0,
            revision: 0,
            loop_closures: 0,
            cooldown: 0,
            travelled_at_closure_m: None,
            local_from: 0,
            tracking_locally: true,
            loop_edges: Vec::new(),
            pending: Vec::new(),
            unverified_closures: Vec::new(),
            uncertainty_information: Vec::new(),
            next_true_pose: None,
            loop_cache: crate::loop_closure::LoopCache::default(),
        })
    }

    /// Records an odometry pose (odometry frame). The first one also initialises the SLAM pose.
    /// Without a stamp the speed gate cannot apply; see [`Association::on_odometry_at`].
    pub fn on_odometry(&mut self, odom_pose: Pose2) -> Result<(), AssociationError> {
        self.record_odometry(odom_pose, None)
    }

    /// Records an odometry pose taken at `stamp_s` (seconds). With stamps, increments faster than
    /// `max_speed_mps` or `max_turn_rate_deg_s` are treated as spikes.
    pub fn on_odometry_at(
        &mut self,
        stamp_s: f64,
        odom_pose: Pose2,
    ) -> Result<(), AssociationError> {
        self.record_odometry(odom_pose, stamp_s.is_finite().then_some(stamp_s))
    }

    fn record_odometry(
        &mut self,
        odom_pose: Pose2,
        stamp_s: Option<f64>,
    ) -> Result<(), AssociationError> {
        if !odom_pose.is_finite() {
            return Err(AssociationError::NonFiniteOdometry(odom_pose));
        }
        if self.slam_pose.is_none() {
            self.slam_pose = Some(odom_pose);
            self.odom_at_slam_pose = Some((odom_pose, stamp_s));
        }
        self.latest_odom = Some((odom_pose, stamp_s));
        Ok(())
    }

    /// The odometry prediction for a scan now: the SLAM pose moved by the odometry increment
    /// since the last scan. `None` before the first odometry.
    pub fn predict(&self) -> Option<Pose2> {
        self.predict_gated().map(|(pose, _, _)| pose)
    }

    /// The prediction, whether the increment was rejected as a spike, and the increment used
    /// with the seconds it spans (if known).
    fn predict_gated(&self) -> Option<Prediction> {
        let slam = self.slam_pose?;
        let ((from, from_s), (to, to_s)) = (self.odom_at_slam_pose?, self.latest_odom?);
        if from == to {
            // No motion: keep the pose bit for bit instead of composing a rounded identity.
            return Some((slam, false, None));
        }
        let increment = from.between(&to);
        let dt_s = match (from_s, to_s) {
            (Some(a), Some(b)) if b > a => Some(b - a),
            _ => None,
        };
        let Some(dt_s) = dt_s else {
            return Some((slam.compose(&increment), false, None));
        };
        let speed_ok = self.params.max_speed_mps <= 0.0
            || increment.x_m.hypot(increment.y_m) <= self.params.max_speed_mps * dt_s;
        let turn_ok =
            increment.yaw_rad.abs() <= self.params.max_turn_rate_deg_s.to_radians() * dt_s;
        if speed_ok && turn_ok {
            return Some((slam.compose(&increment), false, Some((increment, dt_s))));
        }
        // A spike: the last accepted motion, scaled to the time elapsed, stands in for it.
        let replacement = match self.last_motion {
            Some((motion, motion_s)) if motion_s > 0.0 => {
                let k = (dt_s / motion_s).min(10.0);
                Pose2::new(motion.x_m * k, motion.y_m * k, motion.yaw_rad * k)
            }
            _ => Pose2::IDENTITY,
        };
        Some((slam.compose(&replacement), true, None))
    }

    /// The true pose (map frame) of the next scan only, or `None`: a keyframe made from that scan
    /// keeps it for oracle verification (`loop_closure.oracle_max_error_m`), which refuses a
    /// loop match between keyframes without one. Tracking never reads it.
    pub fn set_true_pose(&mut self, pose: Option<Pose2>) {
        self.next_true_pose = pose;
    }

    /// Processes one frame's detections, as points in the AGV frame (metres; see
    /// [`detection_to_agv_m`]). Non-finite points are ignored. An empty scan is valid: the
    /// prediction stands.
    pub fn on_scan(&mut self, scan_agv_m: &[[f64; 2]]) -> Result<FrameOutcome, AssociationError> {
        self.on_scan_with_std(scan_agv_m, None)
    }

    /// As [`Association::on_scan`], with each point's measurement standard deviations
    /// `[range m, angle rad]` (a radar's resolution cell over √12 where it reports no finer error):
    /// scan matching weighs each point by them. Without them every point gets the floors
    /// `min_range_std_m` and `min_angle_std_deg`.
    pub fn on_scan_with_std(
        &mut self,
        scan_agv_m: &[[f64; 2]],
        std: Option<&[[f64; 2]]>,
    ) -> Result<FrameOutcome, AssociationError> {
        let true_pose = self.next_true_pose.take();
        let (predicted, odometry_rejected, motion) =
            self.predict_gated().ok_or(AssociationError::NoOdometry)?;
        let scan: Vec<[f64; 2]> = scan_agv_m
            .iter()
            .copied()
            .filter(|p| p[0].is_finite() && p[1].is_finite())
            .collect();
        let point_std: Vec<[f64; 2]> = match std {
            Some(std) if std.len() == scan_agv_m.len() => scan_agv_m
                .iter()
                .zip(std)
                .filter(|(p, _)| p[0].is_finite() && p[1].is_finite())
                .map(|(_, s)| self.params.point_std(Some(*s)))
                .collect(),
            _ => vec![self.params.point_std(None); scan.len()],
        };
        let radar_points: Vec<RadarPoint> = scan
            .iter()
            .zip(&point_std)
            .map(|(p, s)| RadarPoint {
                position_m: *p,
                range_std_m: s[0],
                angle_std_rad: s[1],
            })
            .collect();
        let icp = if self.params.scan_matching {
            let step_m = self
                .slam_pose
                .map_or(0.0, |previous| previous.distance_m(&predicted));
            let mut settings = self.params.tracking_settings(step_m);
            if odometry_rejected {
                settings.prior_std_m = settings.max_correction_m;
                settings.prior_std_rad = settings.max_correction_rad;
            }
            match_scan(&self.cells, &radar_points, predicted, &settings)
        } else {
            crate::icp::IcpResult::unchanged(predicted, crate::icp::IcpStatus::Disabled)
        };
        let mut pose = if icp.pose.is_finite() {
            icp.pose
        } else {
            predicted
        };
        let mut stats = self.frame_stats(&scan, &point_std, &pose);
        stats.odometry_rejected = odometry_rejected;
        if motion.is_some() {
            self.last_motion = motion;
        }
        if let Some(previous) = self.slam_pose {
            let step = previous.distance_m(&pose);
            if step.is_finite() {
                self.travelled_m += step;
            }
        }

        let overlap_new_view = self.params.keyframe_min_overlap > 0.0
            && !scan.is_empty()
            && stats.keyframe_overlap < self.params.keyframe_min_overlap;
        let keyframe_id = if self.keyframes.is_keyframe(&pose) || overlap_new_view {
            self.keyframes.force(&pose)
        } else {
            None
        };
        let mut loop_match = None;
        if let Some(id) = keyframe_id {
            let matched = icp.status.is_accepted();
            self.add_keyframe(id, pose, scan, &radar_points, matched, true_pose);
            if self.params.loop_closure.enabled {
                if self.cooldown > 0 {
                    self.cooldown -= 1;
                } else if let Some(found) = self.close_loop() {
                    loop_match = Some(found);
                    pose = self.records.last().map_or(pose, |r| r.pose);
                    self.keyframes.rebase(&pose);
                }
            }
        }
        self.slam_pose = Some(pose);
        self.odom_at_slam_pose = self.latest_odom;
        stats.keyframe_overlap = stats.keyframe_overlap.clamp(0.0, 1.0);
        Ok(FrameOutcome {
            pose,
            predicted,
            icp,
            keyframe_id,
            stats,
            loop_match,
            revision: self.revision,
        })
    }

    fn frame_stats(&self, scan: &[[f64; 2]], std: &[[f64; 2]], pose: &Pose2) -> FrameStats {
        let mut stats = FrameStats {
            detections: scan.len(),
            keyframe_overlap: 1.0,
            ..FrameStats::default()
        };
        let mut sum_m2 = 0.0;
        let mut overlapping = 0;
        for (p, s) in scan.iter().zip(std) {
            let in_map = pose.transform_point(*p);
            if let Some(d2) = self.map.nearest_within_gate_m2(&in_map) {
                stats.associated += 1;
                sum_m2 += d2;
                // The larger axis of the point's error ellipse, plus the map's own error.
                let range_m = p[0].hypot(p[1]);
                let sigma2 =
                    s[0].powi(2).max((range_m * s[1]).powi(2)) + self.params.map_std_m.powi(2);
                if d2 <= self.params.gate_sigma.powi(2) * sigma2 {
                    stats.inliers += 1;
                }
            }
            if self.last_keyframe_map.any_within_gate(&in_map) {
                overlapping += 1;
            }
        }
        if stats.associated > 0 {
            stats.rms_residual_m = (sum_m2 / stats.associated as f64).sqrt();
        }
        if !scan.is_empty() && !self.last_keyframe_map.is_empty() {
            stats.keyframe_overlap = overlapping as f64 / scan.len() as f64;
        }
        stats
    }

    /// True when scan matching uses the local map (see `loop_closure.local_map_m`): with loop
    /// closure on, and while the last query's detections scatter by at most
    /// `local_map_max_scatter_m`, precise enough for loop edges to correct the chain (see
    /// there), with the hysteresis of `local_map_scatter_band` around that limit.
    fn local_tracking(&self) -> bool {
        let lc = &self.params.loop_closure;
        if !lc.enabled || lc.local_map_m <= 0.0 {
            return false;
        }
        let Some(last) = self.records.len().checked_sub(1) else {
            return true;
        };
        // A query without detections says nothing of their scatter: the choice stands.
        self.scatter_m(lc.query_from(last)..=last)
            .map_or(self.tracking_locally, |scatter_m| {
                let band_m = lc.local_map_scatter_band * lc.local_map_max_scatter_m;
                if self.tracking_locally {
                    scatter_m <= lc.local_map_max_scatter_m + band_m
                } else {
                    scatter_m <= lc.local_map_max_scatter_m - band_m
                }
            })
    }

    /// Adds keyframe `id` at `pose` to the maps and the pose graph. `points` are its detections
    /// with their std, as scan matching weighed them; `matched` says whether an accepted match
    /// placed it (a rejected one left it at the prediction, knowing nothing of the pose).
    fn add_keyframe(
        &mut self,
        id: u32,
        pose: Pose2,
        scan: Vec<[f64; 2]>,
        points: &[RadarPoint],
        matched: bool,
        true_pose: Option<Pose2>,
    ) {
        // What that scan match knows of the pose (map frame), before the keyframe joins the map.
        let tracking_information = if matched && !self.cells.is_empty() {
            scan_information(&self.cells, points, pose, &self.params.match_settings())
        } else {
            nalgebra::Matrix3::zeros()
        };
        let points_m: Vec<[f64; 2]> = scan.iter().map(|&p| pose.transform_point(p)).collect();
        // Drop keyframes that fell out of the local window (or take every keyframe back when
        // tracking turns global), then add the new one.
        self.tracking_locally = self.local_tracking();
        let first_kept = if self.tracking_locally {
            let window_m = self.params.loop_closure.local_map_m;
            self.records
                .iter()
                .position(|r| self.travelled_m - r.travelled_m <= window_m)
                .unwrap_or(self.records.len())
        } else {
            0
        };
        let mut leaving: Vec<[f64; 2]> = Vec::new();
        if first_kept > self.local_from {
            // The maps hold the kept keyframes at their current poses (`local_from`): those that
            // left the window come out as they went in, which re-bins a keyframe's points, not
            // the window's.
            leaving = self.records[self.local_from..first_kept]
                .iter()
                .flat_map(KeyframeRecord::points_in_map)
                .collect();
            self.local_from = first_kept;
        } else if first_kept < self.local_from {
            self.local_from = first_kept;
            self.rebuild_maps_from(first_kept);
        }
        self.map.retract(&leaving);
        self.map.extend(&points_m);
        self.cells.exchange(&leaving, &points_m);
        self.last_keyframe_map = self.params.statistics_grid();
        self.last_keyframe_map.extend(&points_m);
        let node = self.graph.add_node(pose);
        let mut covariance = nalgebra::Matrix3::zeros();
        if let Some(previous) = self.records.last() {
            let lc = &self.params.loop_closure;
            let relative = previous.pose.between(&pose);
            let distance_m = relative.x_m.hypot(relative.y_m);
            let std_m = (lc.odometry_std_per_m * distance_m).max(lc.odometry_min_std_m);
            let std_rad = (lc.odometry_std_deg_per_m * distance_m)
                .max(lc.odometry_min_std_deg)
                .to_radians();
            let edge = Edge::with_std(node - 1, node, relative, std_m, std_rad, EdgeKind::Odometry);
            // The scan match's information is over map-frame shifts δ of this keyframe; the
            // edge's error moves by e = R_zᵀ R_iᵀ δ = R(ψ)ᵀ δ, ψ this keyframe's heading.
            let to_error = planar_rotation(pose.yaw_rad).transpose();
            let information = (edge.information
                + to_error * tracking_information * to_error.transpose())
                * self.params.covariance_sequential_scale;
            covariance = leaf_covariance(
                &previous.pose,
                &pose,
                &relative,
                &previous.covariance,
                &information,
            )
            .unwrap_or(previous.covariance);
            // One entry per edge the graph holds, so that edge indices stay aligned.
            if self.graph.add_edge(edge) {
                self.uncertainty_information.push(information);
            }
        }
        self.records.push(KeyframeRecord {
            id,
            pose,
            scan_agv_m: scan,
            scatter_m: median_position_std_m(points),
            travelled_m: self.travelled_m,
            covariance,
            true_pose,
        });
        debug_assert!(self.maps_hold_the_window(), "the tracking maps lost count");
    }

    /// The maps scan matching uses hold as many points as `records[local_from..]` (the
    /// invariant `retract` relies on; cells' contents are the property tests' business).
    fn maps_hold_the_window(&self) -> bool {
        let points = || {
            self.records[self.local_from..]
                .iter()
                .flat_map(KeyframeRecord::points_in_map)
        };
        let finite = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
        self.map.len() == points().filter(finite).count()
            && self.cells.point_count() == points().filter(binnable).count()
    }

    /// Points of keyframes `range` in the frame of keyframe `frame`.
    fn cloud(&self, range: std::ops::RangeInclusive<usize>, frame: usize) -> Vec<[f64; 2]> {
        let to_frame = self.records[frame].pose.inverse();
        let mut points = Vec::new();
        for record in &self.records[range] {
            let relative = to_frame.compose(&record.pose);
            points.extend(
                record
                    .scan_agv_m
                    .iter()
                    .map(|p| relative.transform_point(*p)),
            );
        }
        points
    }

    /// The detections' scatter over `keyframes` (`KeyframeRecord::scatter_m`), each keyframe
    /// weighed by its detections: an empty scan adds no point. `None` without detections.
    ///
    /// # Panics
    ///
    /// If `keyframes` reaches past the last keyframe.
    fn scatter_m(&self, keyframes: std::ops::RangeInclusive<usize>) -> Option<f64> {
        let (weighted_m, detections) =
            self.records[keyframes]
                .iter()
                .fold((0.0, 0usize), |(sum_m, n), r| {
                    let count = r.scan_agv_m.len();
                    (sum_m + r.scatter_m * count as f64, n + count)
                });
        (detections > 0).then(|| weighted_m / detections as f64)
    }

    /// Rebuilds the point map and the cell map from the keyframes `records[first..]` at their
    /// current poses.
    fn rebuild_maps_from(&mut self, first: usize) {
        let mut points_m = Vec::new();
        for record in &self.records[first..] {
            points_m.extend(record.points_in_map());
        }
        self.map = self.params.statistics_grid();
        self.map.extend(&points_m);
        self.cells = self.params.distribution_map();
        self.cells.extend(&points_m);
    }

    /// Rebuilds the maps scan matching uses (the local map's keyframes, or all of them) at the
    /// keyframes' current poses.
    fn rebuild_map(&mut self) {
        self.rebuild_maps_from(self.local_from);
        if let Some(last) = self.records.last() {
            let points: Vec<[f64; 2]> = last.points_in_map().collect();
            self.last_keyframe_map = self.params.statistics_grid();
            self.last_keyframe_map.extend(&points);
        }
    }

    /// The information the pose graph gives loop edge `edge` over (x m, y m, yaw rad), error in
    /// the measurement's frame (see `loop_information`).
    pub fn loop_edge_information(&self, edge: &LoopEdge) -> nalgebra::Matrix3<f64> {
        loop_information(edge, &self.params.loop_closure)
    }

    /// The current SLAM pose (map frame); `None` before the first odometry.
    pub fn pose(&self) -> Option<Pose2> {
        self.slam_pose
    }

    /// The points of the keyframes scan matching uses (the local window's while tracking
    /// locally, see `loop_closure.local_map_m`), as the association statistics read them.
    pub fn map(&self) -> &PointGrid {
        &self.map
    }

    /// The keyframe selector (count and last keyframe pose).
    pub fn keyframes(&self) -> &KeyframeSelector {
        &self.keyframes
    }

    /// The keyframes with their current poses.
    pub fn keyframe_records(&self) -> &[KeyframeRecord] {
        &self.records
    }

    /// Distance travelled (m) when the last loop closure was applied; `None` before the first.
    /// The loop search's radius grows with the travel since then.
    pub fn travelled_at_last_closure_m(&self) -> Option<f64> {
        self.travelled_at_closure_m
    }

    /// The loop edges in the pose graph, in the order they were accepted.
    pub fn loop_edges(&self) -> &[LoopEdge] {
        &self.loop_edges
    }

    /// Loop closures accepted so far.
    pub fn loop_closures(&self) -> u32 {
        self.loop_closures
    }

    /// Pose-graph optimisations so far.
    pub fn revision(&self) -> u32 {
        self.revision
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_keyframes_scatter_is_the_median_of_its_detections_position_std() {
        let point = |x_m: f64, range_std_m: f64, angle_std_deg: f64| RadarPoint {
            position_m: [x_m, 0.0],
            range_std_m,
            angle_std_rad: angle_std_deg.to_radians(),
        };
        assert_eq!(median_position_std_m(&[]), 0.0);
        // 10 m away at Δθ = 5°: ρ σ_θ = 0.873 m across the beam, with 0.1 m along it.
        let far = point(10.0, 0.1, 5.0);
        let expected_m = 0.1f64.hypot(10.0 * 5f64.to_radians());
        assert!((far.position_std_m() - expected_m).abs() < 1e-12);
        // One wild point does not move the median.
        let scan = [
            point(10.0, 0.1, 5.0),
            point(10.0, 0.1, 5.0),
            point(1e6, 1.0, 90.0),
        ];
        assert!((median_position_std_m(&scan) - expected_m).abs() < 1e-12);
    }

    #[test]
    fn local_tracking_does_not_switch_on_scatter_that_hovers_at_its_limit() {
        let with_band = |band: f64| {
            let mut params = Params::default();
            params.loop_closure.local_map_scatter_band = band;
            params.loop_closure.query_keyframes = 1;
            Association::new(params).unwrap()
        };
        let record = |scatter_m: f64| KeyframeRecord {
            id: 0,
            pose: Pose2::default(),
            scan_agv_m: vec![[10.0, 0.0]; 10],
            scatter_m,
            travelled_m: 0.0,
            covariance: nalgebra::Matrix3::zeros(),
            true_pose: None,
        };
        // The limit is 0.5 m: 0.52 and 0.48 m lie either side of it, inside a 10 % band.
        let choices = |band: f64| {
            let mut slam = with_band(band);
            [0.52, 0.48, 0.52, 0.6, 0.48, 0.44]
                .iter()
                .map(|&scatter_m| {
                    slam.records.push(record(scatter_m));
                    slam.tracking_locally = slam.local_tracking();
                    slam.tracking_locally
                })
                .collect::<Vec<bool>>()
        };
        assert_eq!(choices(0.1), [true, true, true, false, false, true]);
        assert_eq!(choices(0.0), [false, true, false, false, true, true]);
    }

    #[test]
    fn a_keyframe_records_the_scatter_of_the_std_it_was_given() {
        let agv = Pose2::new(0.0, 0.0, 0.0);
        let scan = scan_from(&agv);
        let scatter_m = |std: Option<[f64; 2]>| {
            let mut slam = Association::new(Params::default()).unwrap();
            slam.on_odometry(agv).unwrap();
            let std = std.map(|s| vec![s; scan.len()]);
            slam.on_scan_with_std(&scan, std.as_deref()).unwrap();
            slam.keyframe_records()[0].scatter_m
        };
        let points = |angle_std_deg: f64| -> Vec<RadarPoint> {
            let angle_std_rad = angle_std_deg.to_radians();
            let to_point = |p: &[f64; 2]| RadarPoint {
                position_m: *p,
                range_std_m: 0.05,
                angle_std_rad,
            };
            scan.iter().map(to_point).collect()
        };
        for angle_std_deg in [1.0f64, 5.0] {
            let given = scatter_m(Some([0.05, angle_std_deg.to_radians()]));
            assert!((given - median_position_std_m(&points(angle_std_deg))).abs() < 1e-12);
        }
        assert!(
            scatter_m(Some([0.05, 5f64.to_radians()]))
                > 2.5 * scatter_m(Some([0.05, 1f64.to_radians()]))
        );
        // Without std every point has the floors.
        let floors = Params::default();
        let floor_points: Vec<RadarPoint> = points(floors.min_angle_std_deg)
            .into_iter()
            .map(|p| RadarPoint {
                range_std_m: floors.min_range_std_m,
                ..p
            })
            .collect();
        assert!((scatter_m(None) - median_position_std_m(&floor_points)).abs() < 1e-12);
    }

    /// A 4 m box of points around the origin, every 0.2 m, seen from `agv`.
    fn scan_from(agv: &Pose2) -> Vec<[f64; 2]> {
        let inverse = agv.inverse();
        (0..80)
            .map(|i| {
                let s = f64::from(i % 20) * 0.2 - 2.0;
                [[s, 2.0], [2.0, s], [-s, -2.0], [-2.0, -s]][i as usize / 20]
            })
            .map(|p| inverse.transform_point(p))
            .collect()
    }

    #[test]
    fn a_true_pose_is_kept_by_the_next_scans_keyframe_only() {
        let mut slam = Association::new(Params::default()).unwrap();
        let truth = Pose2::new(5.0, 1.0, 0.3);
        slam.set_true_pose(Some(truth));
        let mut keyframes = 0;
        for k in 0..4 {
            let agv = Pose2::new(0.5 * f64::from(k), 0.0, 0.0);
            slam.on_odometry_at(1.0 + f64::from(k), agv).unwrap();
            keyframes += usize::from(
                slam.on_scan(&scan_from(&agv))
                    .unwrap()
                    .keyframe_id
                    .is_some(),
            );
        }
        let kept: Vec<Option<Pose2>> = slam
            .keyframe_records()
            .iter()
            .map(|r| r.true_pose)
            .collect();
        assert!(keyframes >= 2, "{kept:?}");
        assert_eq!(kept[0], Some(truth));
        assert!(kept[1..].iter().all(Option::is_none), "{kept:?}");
    }

    #[test]
    fn a_stationary_agv_keeps_its_pose_and_adds_no_keyframes() {
        let mut slam = Association::new(Params::default()).unwrap();
        let here = Pose2::new(0.3, -0.2, 0.1);
        let mut last_pose: Option<Pose2> = None;
        for k in 0..50 {
            slam.on_odometry_at(1.0 + 0.5 * f64::from(k), here).unwrap();
            let out = slam.on_scan(&scan_from(&here)).unwrap();
            // The cell Gaussians summarise 0.5 m of outline each, and on this small box sampled
            // every 0.2 m a cell holds two or three points whose mean is not where the scan's
            // points fall: even a noise-free scan settles a few centimetres from the truth (the
            // prior lets it get there over a few frames; 2.8 cm when measured). What matters is
            // that it settles and stays: no drift while standing still.
            assert!(out.pose.distance_m(&here) < 0.05, "frame {k}: {out:?}");
            if let Some(previous) = last_pose.filter(|_| k >= 40) {
                assert!(out.pose.distance_m(&previous) < 1e-5, "frame {k}: {out:?}");
            }
            last_pose = Some(out.pose);
            assert_eq!(out.keyframe_id, (k == 0).then_some(0));
            assert_eq!(out.stats.inliers, if k == 0 { 0 } else { 80 });
        }
        assert_eq!(slam.keyframe_records().len(), 1);
    }

    #[test]
    fn an_odometry_spike_is_replaced_by_the_last_motion() {
        let mut slam = Association::new(Params::default()).unwrap();
        // 0.1 m per 0.5 s frame along x, then one frame where odometry jumps 5 m.
        let mut outcomes = Vec::new();
        for k in 0..8 {
            let truth = Pose2::new(0.1 * f64::from(k), 0.0, 0.0);
            let reported = if k == 5 {
                truth.compose(&Pose2::new(5.0, 0.0, 0.0))
            } else {
                truth
            };
            slam.on_odometry_at(1.0 + 0.5 * f64::from(k), reported)
                .unwrap();
            let out = slam.on_scan(&[]).unwrap();
            assert!(out.pose.is_finite());
            outcomes.push((truth, out));
        }
        for (k, (truth, out)) in outcomes.iter().enumerate() {
            // The spike frame and the frame after (odometry jumps back) are both rejected.
            assert_eq!(out.stats.odometry_rejected, k == 5 || k == 6, "frame {k}");
            assert!(out.pose.distance_m(truth) < 1e-9, "frame {k}: {out:?}");
        }
    }

    #[test]
    fn without_stamps_there_is_no_gate_and_no_nan() {
        let mut slam = Association::new(Params::default()).unwrap();
        slam.on_odometry(Pose2::IDENTITY).unwrap();
        slam.on_scan(&[]).unwrap();
        slam.on_odometry(Pose2::new(50.0, 0.0, 0.0)).unwrap();
        let out = slam.on_scan(&[[f64::NAN, 1.0]]).unwrap();
        assert!(!out.stats.odometry_rejected);
        assert_eq!(out.pose, Pose2::new(50.0, 0.0, 0.0));
        assert_eq!(out.stats.detections, 0);
    }

    #[test]
    fn keyframe_covariances_start_at_zero_and_grow_along_the_chain() {
        let params = Params::default();
        let scale = params.covariance_sequential_scale;
        let mut slam = Association::new(params.clone()).unwrap();
        for k in 0..40 {
            slam.on_odometry_at(
                0.5 * f64::from(k),
                Pose2::new(0.25 * f64::from(k), 0.0, 0.0),
            )
            .unwrap();
            slam.on_scan(&[]).unwrap();
        }
        let records = slam.keyframe_records();
        assert!(records.len() >= 5, "{} keyframes", records.len());
        assert_eq!(records[0].covariance, nalgebra::Matrix3::zeros());
        for pair in records.windows(2) {
            let (a, b) = (&pair[0].covariance, &pair[1].covariance);
            for d in 0..3 {
                assert!(b[(d, d)] > a[(d, d)], "{a} then {b}");
            }
        }
        // Without scans, each 1 m step adds the odometry model's variance divided by the scale.
        let lc = &params.loop_closure;
        let step_m = records[1].pose.distance_m(&records[0].pose);
        let std_m = (lc.odometry_std_per_m * step_m).max(lc.odometry_min_std_m);
        let along = records[1].covariance[(0, 0)];
        assert!((along - std_m * std_m / scale).abs() < 1e-12, "{along}");
    }
}
