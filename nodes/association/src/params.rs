//! Parameters of the association node, with their validation.
//!
//! The paper (Sec. III-A) names the steps, data association against key frames and location, but
//! gives no numbers for them, so every default here is ours; docs/slam.md measures them.
//! Tracking matches detections against cell Gaussians within `max_correspondence_m` (0.5 m);
//! the ICP's metric and robust scale (`metric`, `robust_scale_m`) now weigh only the loop
//! match's refinement. They were chosen when tracking itself ran ICP, on simulated runs like
//! those of `tests/slam.rs` (five scenarios × six seeds, point-to-point and point-to-line, scales
//! 0 to 0.3 m): point-to-line with a 0.1 m scale was best or within 1 cm of the best mean
//! position error on each scenario, and without the kernel (scale 0) every variant was several
//! times worse; the launch files use 0.5 m for the loop refinement.

use nrslam_runtime::InvalidParam;
use serde::{Deserialize, Serialize};

/// What a scan point is matched to (see [`crate::icp`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IcpMetric {
    /// The nearest map point.
    PointToPoint,
    /// The foot of the perpendicular on the line fitted around the nearest map point (the point
    /// itself where its neighbourhood is not a line).
    PointToLine,
}

/// Parameters of odometry prediction, scan-to-map ICP and keyframe selection.
///
/// Deserialised from the node's TOML table; unknown keys are an error, missing keys take the
/// default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Run scan-to-map matching. `false` gives pure odometry dead reckoning (a baseline).
    pub scan_matching: bool,
    /// ICP metric: `"point_to_point"` or `"point_to_line"`.
    pub metric: IcpMetric,
    /// Point-to-line only: map neighbours (the point included) a local line is fitted to; only
    /// those within `max_correspondence_m` count.
    pub line_neighbours: u32,
    /// A scan point and its nearest map point form a correspondence only if they are at most this
    /// far apart, metres.
    pub max_correspondence_m: f64,
    /// Iterations at most per match: of tracking's Gauss–Newton scan match and of the loop
    /// match's ICP refinement, which share it (and the two convergence tolerances below).
    pub max_iterations: u32,
    /// A match has converged when an iteration moves it by less than this (the ICP: the matched
    /// scan points' centroid), metres…
    pub convergence_translation_m: f64,
    /// …and by less than this rotation, degrees.
    pub convergence_rotation_deg: f64,
    /// Scale of the Cauchy kernel that down-weights correspondences with large residuals,
    /// metres: a pair whose residual is this large counts half. Widened, within an ICP run, to
    /// the residuals' median-based spread while that is larger (far from the solution); 0 weights
    /// every pair equally (plain least squares).
    pub robust_scale_m: f64,
    /// Fewer correspondences than this in any ICP iteration: keep the odometry prediction.
    pub min_correspondences: u32,
    /// A scan-matching correction that moves the predicted position farther than this is rejected
    /// (the prediction is kept), metres.
    pub max_correction_m: f64,
    /// A scan-matching correction that turns the predicted heading by more than this is rejected
    /// (the prediction is kept), degrees.
    pub max_correction_deg: f64,
    /// Matched scan points whose spread has a smaller-to-larger eigenvalue ratio below this are
    /// treated as collinear (a straight wall or corridor): the translation along the line, which
    /// point-to-point matching cannot observe, is left to odometry. 0 disables the check.
    pub degeneracy_ratio: f64,
    /// A new keyframe when the SLAM position is at least this far from the last keyframe's,
    /// metres.
    pub keyframe_distance_m: f64,
    /// A new keyframe when the SLAM heading differs from the last keyframe's by at least this,
    /// degrees.
    pub keyframe_rotation_deg: f64,
    /// A new keyframe when fewer than this fraction of the frame's detections lie within
    /// `max_correspondence_m` of the last keyframe's points (the view has changed), even before
    /// the distance or rotation threshold. 0 disables the rule.
    pub keyframe_min_overlap: f64,
    /// Floor of the range std used for weighting, metres (detections that report 0).
    pub min_range_std_m: f64,
    /// Floor of the angle std used for weighting, degrees (detections that report 0).
    pub min_angle_std_deg: f64,
    /// Std of the map's own error added to every residual's variance, metres: a map point is a
    /// past detection placed with a past pose, so it is never exact.
    pub map_std_m: f64,
    /// A pair whose residual exceeds this many standard deviations is an outlier: it is dropped
    /// from the solve and not counted as an inlier in the statistics.
    pub gate_sigma: f64,
    /// An odometry increment implying a speed above this is a spike: the previous accepted
    /// motion is used instead, metres per second. 0 disables the gate.
    pub max_speed_mps: f64,
    /// An odometry increment implying a turn rate above this is a spike, degrees per second.
    pub max_turn_rate_deg_s: f64,
    /// Loop closure (revisit detection, pose graph, map rebuild).
    pub loop_closure: LoopClosureParams,
    /// Edge of the map cells that tracking's local Gaussians summarise, metres.
    pub cell_m: f64,
    /// Cell Gaussians each scan point is scored against, nearest first.
    pub cell_neighbours: u32,
    /// Fewest map points for a cell to have a Gaussian.
    pub cell_min_points: u32,
    /// Smallest std of a cell Gaussian along any axis, metres.
    pub cell_floor_m: f64,
    /// Cauchy scale of scan matching on the Mahalanobis distance: a pair this many standard
    /// deviations off counts half.
    pub robust_sigma: f64,
    /// Floor of the std of the prior that holds the pose near the odometry prediction, metres.
    /// The prior's std is the odometry increment's own (`loop_closure.odometry_std_per_m` × the
    /// distance driven since the last frame) where that is larger: a side-looking radar confounds
    /// heading with along-track translation, and the wheels measure the latter well.
    pub prior_std_m: f64,
    /// Floor of that prior's heading std, degrees (the increment's own is
    /// `loop_closure.odometry_std_deg_per_m` × the distance).
    pub prior_std_deg: f64,
    /// The keyframes' published pose covariances (`/slam/keyframe_poses`) are the marginals of
    /// the pose graph with every sequential edge's information (its odometry model plus what
    /// the scan match that placed the keyframe knows of its pose) times this factor. Both parts
    /// are deliberately loose for the optimisation; × 8 makes the keyframes' position NEES 2.1
    /// on the hall and on random scenes alike (docs/slam.md). 1e-6..=1e6.
    pub covariance_sequential_scale: f64,
    /// The same factor for loop edges' information (their match's). Default 0: loops make the
    /// map agree with itself, not with the true frame, and the measured keyframe errors are
    /// those of the sequential chain alone (docs/slam.md). 0..=1e6.
    pub covariance_loop_scale: f64,
}

/// Loop detection, verification and pose-graph parameters (see [`crate::loop_closure`] and
/// [`crate::pose_graph`]). Deserialised from the `loop_closure` sub-table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LoopClosureParams {
    /// Detect loops and optimise the pose graph. `false` keeps the keyframe poses as tracked.
    pub enabled: bool,
    /// A keyframe is a loop candidate only if at least this much travel lies between it and the
    /// current keyframe, metres (closer ones are the ordinary chain).
    pub min_separation_m: f64,
    /// …and if its estimated position is within this distance of the current one plus the
    /// search radius, metres: the radar sees targets up to its maximum range away, so two
    /// keyframes some metres apart share much of their view.
    pub candidate_distance_m: f64,
    /// Search radius around the predicted relative pose, metres…
    pub search_radius_m: f64,
    /// …plus this fraction of the distance travelled since the candidate (drift grows with it)…
    pub search_radius_per_m: f64,
    /// …up to this, metres.
    pub max_search_radius_m: f64,
    /// Rotations searched either side of the predicted relative heading, degrees.
    pub max_search_rotation_deg: f64,
    /// Translation step of the correlative search (and its raster cell), metres.
    pub search_step_m: f64,
    /// Rotation step of the correlative search, degrees.
    pub search_step_deg: f64,
    /// Keyframes either side of the candidate that form its submap.
    pub submap_keyframes: u32,
    /// Keyframes (the current one included) that form the query.
    pub query_keyframes: u32,
    /// Candidates tried per keyframe, nearest first.
    pub max_candidates: u32,
    /// Fewest points in the query and the submap.
    pub min_points: u32,
    /// A query point is an inlier when a submap point lies within this, metres, or within
    /// `inlier_scatter_ratio` times the query's scatter if that is more.
    pub inlier_distance_m: f64,
    /// The inlier distance in units of the query's scatter: the median position error std of
    /// its detections (√(σ_R² + (ρ σ_θ)²), from their reported std), averaged over its
    /// keyframes. Detections of Δθ = 5° scatter by ~0.9 m at 10 m, so that a fixed distance
    /// made for Δθ = 1° refuses every right loop. Where it widens the inlier distance, the
    /// overlap distance and the loop edge's std (`loop_std_m`) widen in proportion, and so does
    /// the tolerance within which two matches confirm each other (`pair_scatter_widening`); the
    /// slide test and the agreement with the graph stay. 0 keeps the fixed tolerances.
    pub inlier_scatter_ratio: f64,
    /// Fewest inliers, as a fraction of the query points in the overlap (those within
    /// `overlap_distance_m` of a submap point after alignment), to accept a loop.
    pub min_inlier_ratio: f64,
    /// A query point farther than this from every submap point after alignment saw something the
    /// submap did not (the views only partly overlap) and does not count in the inlier ratio,
    /// metres. 0 counts every query point.
    pub overlap_distance_m: f64,
    /// Fewest query points in the overlap, as a fraction of the query, to accept a loop.
    pub min_overlap_ratio: f64,
    /// The best score elsewhere (at least `ambiguity_distance_m` from the best motion) must be
    /// at most this fraction of the best.
    pub max_ambiguity: f64,
    /// See `max_ambiguity`, metres.
    pub ambiguity_distance_m: f64,
    /// Keyframes after an accepted loop during which no other is searched.
    pub cooldown_keyframes: u32,
    /// Std of an odometry edge's translation per metre travelled (fraction).
    pub odometry_std_per_m: f64,
    /// Std of an odometry edge's heading per metre travelled, degrees per metre.
    pub odometry_std_deg_per_m: f64,
    /// Floor of an odometry edge's translation std, metres.
    pub odometry_min_std_m: f64,
    /// Floor of an odometry edge's heading std, degrees.
    pub odometry_min_std_deg: f64,
    /// Std of a loop edge's translation along the direction its match pins down best, metres
    /// (times the edge's `std_scale` where its query's detections scatter, see
    /// `inlier_scatter_ratio`).
    pub loop_std_m: f64,
    /// Cap of a loop edge's translation std along the direction its match pins down worst,
    /// metres. That std is `loop_std_m` × √(best / worst information), so a match along one
    /// straight edge, free to slide along it, hardly moves the graph that way; equal to
    /// `loop_std_m`, every loop edge is isotropic.
    pub loop_max_std_m: f64,
    /// Std of a loop edge's heading, degrees.
    pub loop_std_deg: f64,
    /// Levenberg–Marquardt iterations per optimisation.
    pub max_iterations: u32,
    /// Scan matching uses only the keyframes within this much travel of the current one,
    /// metres (0 to 1e6): local tracking, as Cartographer's local SLAM against its recent
    /// submaps. Drift then stays in the chain of keyframes, where loop closure sees and spreads
    /// it, instead of being pulled piecemeal onto old parts of the map; and a second lap
    /// measures the place afresh instead of copying the first lap's errors into its own chain.
    /// After a closure the local map is rebuilt at the corrected poses. 0 uses the whole map.
    /// With loop closure off the whole map is always used: it is then the only correction there
    /// is.
    pub local_map_m: f64,
    /// Local tracking (`local_map_m`) only while the detections scatter by at most this much,
    /// metres (0 to 1e6): the scatter of the last `query_keyframes` keyframes before the one
    /// being added, each keyframe's `KeyframeRecord::scatter_m` weighed by its detections (as
    /// the loop tolerances are widened by it); a query without detections keeps the last
    /// choice. Farther-scattered detections (Δθ 5°: 0.9 m at 10 m) make loop edges off by
    /// 0.5–2 m, and the whole map then corrects the pose better than they do. 1e6 tracks
    /// locally whatever the scatter; 0 only on noise-free detections.
    pub local_map_max_scatter_m: f64,
    /// Hysteresis of `local_map_max_scatter_m`, as a fraction of it: local tracking stops only
    /// above the limit times 1 + this, and resumes only below it times 1 − this. Each switch
    /// rebuilds the tracking maps, so detections whose scatter hovers at the limit must not
    /// switch at every keyframe. Finite, 0..=0.9.
    pub local_map_scatter_band: f64,
    /// Raster of the correlative search, metres. 0: binary, a query point scores 1 within a
    /// cell of a submap point's cell and 0 elsewhere. > 0: a likelihood field of this blur σ, a
    /// query point scoring exp(−d²/2σ²) at distance d from the nearest submap point (0 beyond
    /// 3σ). Scores, and so `max_ambiguity`, mean different things in the two.
    pub search_sigma_m: f64,
    /// The ICP refinement of a loop match pairs a query point with submap points up to this far,
    /// metres (tracking's `max_correspondence_m` is tighter: it corrects one frame's odometry,
    /// this a lap's drift).
    pub refine_correspondence_m: f64,
    /// After the ICP refinement, a loop match is settled by a fine correlative search around
    /// it on a likelihood field of the submap with this blur σ, metres: the motion that puts the
    /// most query points on submap outlines, where least squares lets the points with no
    /// counterpart (a revisit overlaps its old view in part) pull the pose off by decimetres.
    /// 0: no fine search (the ICP's pose is the match). Finite, 0..=10.
    pub fine_sigma_m: f64,
    /// Cell of the fine search's likelihood field and its translation step, metres. Finite,
    /// 0.001..=1. Its rotation step moves the farthest query point by at most one cell.
    pub fine_step_m: f64,
    /// Translations the fine search tries around the ICP's pose, up to this far, metres.
    /// Finite, 0..=10.
    pub fine_window_m: f64,
    /// Rotations the fine search tries either side of the ICP's heading, degrees. Finite,
    /// 0..=30.
    pub fine_window_deg: f64,
    /// When the query's detections scatter by at least `plateau_min_scatter_m`, the match is
    /// the centre of the plateau of near-best scores rather than its arg-max: every motion of
    /// the search's lattice within `plateau_window_m` and `plateau_window_deg` of the fine
    /// search's pose that scores at least 1 − `plateau_fraction` of the best and connects to
    /// it through such motions, averaged. With
    /// detections scattered by a metre (Δθ 5°) the score is flat over half a metre or more,
    /// and its arg-max sits on the side nearest where the search started. 0: the arg-max
    /// always. Finite, 0..=0.5.
    pub plateau_fraction: f64,
    /// See `plateau_fraction`: the detections' scatter from which the plateau's centre is the
    /// match and the search prior is `scattered_prior_sigma_radii` wide, metres (the same
    /// measure as `local_map_max_scatter_m`; a query at exactly both limits tracks locally and
    /// takes the plateau's centre). 0: every query. Finite, 0..=1e6.
    pub plateau_min_scatter_m: f64,
    /// See `plateau_fraction`: the translations averaged, up to this far from the fine
    /// search's pose, metres. Finite, 0..=20; the cost grows with its square.
    pub plateau_window_m: f64,
    /// See `plateau_fraction`: the rotations averaged, either side of the fine search's
    /// heading, degrees (in `search_step_deg` steps). Finite, 0..=30.
    pub plateau_window_deg: f64,
    /// The loop search scores each motion times a Gaussian prior on its offset from where the
    /// pose graph predicts the query, with σ this many search radii (the radius grows with
    /// the travel since the candidate, as its drift does). The prior only breaks near-ties:
    /// in a hall whose targets repeat on a grid, a query shifted by one pitch fits about as
    /// well as the right one but lies farther from the prediction. Tighter and it overrules the
    /// score, keeping the drifted place when the right one fits better (docs/slam-log.md).
    /// Finite, 0.01..=10.
    pub prior_sigma_radii: f64,
    /// See `prior_sigma_radii`: σ, in search radii, for a query whose detections scatter by at
    /// least `plateau_min_scatter_m` (Δθ 5°). Its scores are flat over a metre near every
    /// place that looks alike, so the score tells right from drifted less and the prior must
    /// say more. Finite, 0.01..=10.
    pub scattered_prior_sigma_radii: f64,
    /// A verified match is accepted at once when it agrees with the pose graph's current
    /// estimate of the same relative pose within this, metres (and `agreement_deg`): it
    /// confirms what the graph already holds. Otherwise it waits for a second match it agrees
    /// with (`pair_m`), or a score of `standalone_score`.
    pub agreement_m: f64,
    /// See `agreement_m`, degrees.
    pub agreement_deg: f64,
    /// Two matches confirm each other when the cycle they close with the tracked motion between
    /// their keyframes (old and new) is off by at most this, metres, plus `pair_per_m` per metre
    /// of that motion, and by at most `pair_deg`. A wrong match in a repetitive layout is off
    /// by a pitch or a few degrees, and two wrong ones rarely agree.
    pub pair_m: f64,
    /// See `pair_m`, metres per metre.
    pub pair_per_m: f64,
    /// See `pair_m`, degrees.
    pub pair_deg: f64,
    /// A loop edge whose match scored below this leaves the pose graph once a later edge of the
    /// same old place (old keyframes at most `submap_keyframes` apart) scoring at least
    /// `superseding_score` joins it. A run's first revisit sees its old place only in part: its
    /// match scores ~0.67 and, though within its own uncertainty, is often 0.5–1 m and 2–4°
    /// off, where the loops a few keyframes later score 0.9–1 and are centimetres off
    /// (docs/slam-log.md). 0: no edge leaves. Finite, 0..=1.
    pub supersede_below_score: f64,
    /// See `supersede_below_score`; at least that (an edge is superseded only by a fuller view
    /// than its own) unless superseding is off. Finite, 0..=1.
    pub superseding_score: f64,
    /// A match whose correlative score is at least this is accepted alone (1 disables it: every
    /// loop that changes the graph needs a second one).
    pub standalone_score: f64,
    /// Weakest translation information of a match's loop edge (its smallest eigenvalue once the
    /// heading is marginalised, m⁻², as `loops.csv`'s `weak_axis_information_per_m2`) for the
    /// match to join the graph by agreeing with it or by a pending match's confirmation; a match
    /// scoring `standalone_score` joins without it. Those two paths are how a first revisit
    /// closes, and a first revisit along one side can slide along it. 0: no minimum.
    pub confirm_min_information_per_m2: f64,
    /// Two matches confirm each other within `pair_m` and `pair_deg` times this factor × the
    /// larger of their edges' std scale ([`Self::scatter_scale`]) where that exceeds 1: a match
    /// of detections that scatter by a metre (Δθ 5°) is itself off by about that much, as its
    /// widened edge says, and a fixed 0.3 m left 40 % of the hall's single laps at Δθ 5°
    /// without a closure (docs/slam.md). 0: the tolerances stay. Finite, 0..=10.
    pub pair_scatter_widening: f64,
    /// A match that waits for confirmation is dropped after this many keyframes.
    pub pending_keyframes: u32,
    /// Research oracle, simulation only: a loop match whose translation is more than this off
    /// the truth is refused outright (neither accepted nor kept pending), metres; headings are
    /// not judged. The truth is `/ground_truth/pose` at each keyframe's stamp, to which the node
    /// then subscribes; a match with a keyframe that got none is refused too. Beside the
    /// true-pose oracle (`launch/true-poses.toml`) it separates verification from matching: the
    /// map the same matches give when every one that far off is refused, which no verifier
    /// without the truth can do (docs/slam.md, "The verification oracle"). 0: off, the back end
    /// as it runs on a real sensor. Finite, 0..=1e3.
    pub oracle_max_error_m: f64,
    /// At every closure, each earlier closure not yet verified is tested against the rest of
    /// the graph (optimised without it): its edges' χ² against that graph's estimate, under the
    /// edge's and the graph's uncertainty. Above this (3 degrees of freedom; 16.27 is the
    /// 99.9 % point) the closure leaves the graph: a wrong first closure of a repetitive place
    /// that later closures of the places around it contradict. 0: no recheck. Finite,
    /// 0..=1e6.
    pub recheck_chi2: f64,
    /// A rechecked closure that agrees while the rest of the graph pins its relative pose down
    /// to this std (m, weakest axis) is verified and not tested again. Finite, > 0, ≤ 1e3.
    pub verified_std_m: f64,
}

impl Default for LoopClosureParams {
    fn default() -> Self {
        LoopClosureParams {
            enabled: true,
            min_separation_m: 30.0,
            candidate_distance_m: 12.0,
            search_radius_m: 2.0,
            search_radius_per_m: 0.03,
            max_search_radius_m: 6.0,
            max_search_rotation_deg: 12.0,
            search_step_m: 0.25,
            search_step_deg: 1.0,
            submap_keyframes: 10,
            query_keyframes: 10,
            max_candidates: 2,
            min_points: 30,
            inlier_distance_m: 0.5,
            inlier_scatter_ratio: 2.0,
            min_inlier_ratio: 0.5,
            overlap_distance_m: 0.0,
            min_overlap_ratio: 0.3,
            max_ambiguity: 0.85,
            ambiguity_distance_m: 2.0,
            cooldown_keyframes: 2,
            odometry_std_per_m: 0.02,
            odometry_std_deg_per_m: 0.5,
            odometry_min_std_m: 0.02,
            odometry_min_std_deg: 0.2,
            loop_std_m: 0.3,
            loop_max_std_m: 3.0,
            loop_std_deg: 2.0,
            max_iterations: 20,
            local_map_m: 60.0,
            local_map_max_scatter_m: 0.5,
            local_map_scatter_band: 0.1,
            search_sigma_m: 0.0,
            refine_correspondence_m: 1.0,
            fine_sigma_m: 0.1,
            fine_step_m: 0.05,
            fine_window_m: 0.3,
            fine_window_deg: 1.5,
            plateau_fraction: 0.03,
            plateau_min_scatter_m: 0.5,
            plateau_window_m: 2.5,
            plateau_window_deg: 3.0,
            prior_sigma_radii: 1.0,
            scattered_prior_sigma_radii: 0.5,
            agreement_m: 0.3,
            agreement_deg: 2.0,
            pair_m: 0.3,
            pair_per_m: 0.02,
            pair_deg: 1.5,
            standalone_score: 0.95,
            supersede_below_score: 0.75,
            superseding_score: 0.85,
            confirm_min_information_per_m2: 1.0,
            pair_scatter_widening: 1.0,
            pending_keyframes: 20,
            oracle_max_error_m: 0.0,
            recheck_chi2: 16.27,
            verified_std_m: 1.0,
        }
    }
}

impl LoopClosureParams {
    /// Checks every field; the error names the first offending field (as `loop_closure.NAME`).
    pub fn validate(&self) -> Result<(), InvalidParam> {
        let ranges = self
            .real_ranges()
            .into_iter()
            .chain(self.matching_ranges())
            .chain(self.graph_ranges());
        for (field, value, min, max) in ranges {
            InvalidParam::check_range(field, value, min, max)?;
        }
        let counts = self.count_ranges();
        for (field, value, min, max) in counts {
            if !(min..=max).contains(&value) {
                return Err(InvalidParam::new(
                    field,
                    format!("is {value}"),
                    format!("{min}..={max}"),
                ));
            }
        }
        // An edge is superseded only by a fuller view than its own.
        if self.supersede_below_score > 0.0 && self.superseding_score < self.supersede_below_score {
            return Err(InvalidParam::new(
                "loop_closure.superseding_score",
                format!("is {}", self.superseding_score),
                format!(
                    "loop_closure.supersede_below_score ({})..=1",
                    self.supersede_below_score
                ),
            ));
        }
        Ok(())
    }

    /// (field, value, min, max) of the real fields of matching, confirmation and oracle
    /// verification, which [`Self::validate`] checks after [`Self::real_ranges`].
    fn matching_ranges(&self) -> [(&'static str, f64, f64, f64); 15] {
        [
            (
                "loop_closure.search_sigma_m",
                self.search_sigma_m,
                0.0,
                10.0,
            ),
            (
                "loop_closure.refine_correspondence_m",
                self.refine_correspondence_m,
                0.01,
                100.0,
            ),
            ("loop_closure.fine_sigma_m", self.fine_sigma_m, 0.0, 10.0),
            ("loop_closure.fine_step_m", self.fine_step_m, 0.001, 1.0),
            ("loop_closure.fine_window_m", self.fine_window_m, 0.0, 10.0),
            (
                "loop_closure.fine_window_deg",
                self.fine_window_deg,
                0.0,
                30.0,
            ),
            ("loop_closure.agreement_m", self.agreement_m, 0.0, 1e3),
            ("loop_closure.agreement_deg", self.agreement_deg, 0.0, 180.0),
            ("loop_closure.pair_m", self.pair_m, 0.0, 1e3),
            ("loop_closure.pair_per_m", self.pair_per_m, 0.0, 1.0),
            ("loop_closure.pair_deg", self.pair_deg, 0.0, 180.0),
            (
                "loop_closure.standalone_score",
                self.standalone_score,
                0.0,
                1.0,
            ),
            (
                "loop_closure.supersede_below_score",
                self.supersede_below_score,
                0.0,
                1.0,
            ),
            (
                "loop_closure.superseding_score",
                self.superseding_score,
                0.0,
                1.0,
            ),
            (
                "loop_closure.oracle_max_error_m",
                self.oracle_max_error_m,
                0.0,
                1e3,
            ),
        ]
    }

    /// (field, value, min, max) of the real-valued fields checked as plain closed ranges, in the
    /// order [`Self::validate`] checks them first.
    fn real_ranges(&self) -> [(&'static str, f64, f64, f64); 25] {
        [
            (
                "loop_closure.overlap_distance_m",
                self.overlap_distance_m,
                0.0,
                1e3,
            ),
            (
                "loop_closure.min_overlap_ratio",
                self.min_overlap_ratio,
                0.0,
                1.0,
            ),
            (
                "loop_closure.candidate_distance_m",
                self.candidate_distance_m,
                0.0,
                1e4,
            ),
            ("loop_closure.local_map_m", self.local_map_m, 0.0, 1e6),
            (
                "loop_closure.plateau_fraction",
                self.plateau_fraction,
                0.0,
                0.5,
            ),
            (
                "loop_closure.plateau_min_scatter_m",
                self.plateau_min_scatter_m,
                0.0,
                1e6,
            ),
            (
                "loop_closure.plateau_window_m",
                self.plateau_window_m,
                0.0,
                20.0,
            ),
            (
                "loop_closure.plateau_window_deg",
                self.plateau_window_deg,
                0.0,
                30.0,
            ),
            (
                "loop_closure.prior_sigma_radii",
                self.prior_sigma_radii,
                0.01,
                10.0,
            ),
            (
                "loop_closure.scattered_prior_sigma_radii",
                self.scattered_prior_sigma_radii,
                0.01,
                10.0,
            ),
            (
                "loop_closure.local_map_max_scatter_m",
                self.local_map_max_scatter_m,
                0.0,
                1e6,
            ),
            (
                "loop_closure.local_map_scatter_band",
                self.local_map_scatter_band,
                0.0,
                0.9,
            ),
            (
                "loop_closure.min_separation_m",
                self.min_separation_m,
                0.0,
                1e6,
            ),
            (
                "loop_closure.search_radius_m",
                self.search_radius_m,
                0.0,
                1e3,
            ),
            (
                "loop_closure.search_radius_per_m",
                self.search_radius_per_m,
                0.0,
                1.0,
            ),
            (
                "loop_closure.max_search_radius_m",
                self.max_search_radius_m,
                0.0,
                100.0,
            ),
            (
                "loop_closure.max_search_rotation_deg",
                self.max_search_rotation_deg,
                0.0,
                180.0,
            ),
            ("loop_closure.search_step_m", self.search_step_m, 0.01, 10.0),
            (
                "loop_closure.search_step_deg",
                self.search_step_deg,
                0.05,
                45.0,
            ),
            (
                "loop_closure.inlier_distance_m",
                self.inlier_distance_m,
                0.001,
                100.0,
            ),
            (
                "loop_closure.inlier_scatter_ratio",
                self.inlier_scatter_ratio,
                0.0,
                100.0,
            ),
            (
                "loop_closure.min_inlier_ratio",
                self.min_inlier_ratio,
                0.0,
                1.0,
            ),
            ("loop_closure.max_ambiguity", self.max_ambiguity, 0.0, 1.0),
            (
                "loop_closure.confirm_min_information_per_m2",
                self.confirm_min_information_per_m2,
                0.0,
                1e6,
            ),
            (
                "loop_closure.ambiguity_distance_m",
                self.ambiguity_distance_m,
                0.0,
                1e3,
            ),
        ]
    }

    /// (field, value, min, max) of the pose graph's edge model and of the checks between its
    /// closures (recheck, pair widening), which [`Self::validate`] checks
    /// after [`Self::matching_ranges`].
    fn graph_ranges(&self) -> [(&'static str, f64, f64, f64); 10] {
        [
            (
                "loop_closure.odometry_std_per_m",
                self.odometry_std_per_m,
                0.0,
                1.0,
            ),
            (
                "loop_closure.odometry_std_deg_per_m",
                self.odometry_std_deg_per_m,
                0.0,
                90.0,
            ),
            (
                "loop_closure.odometry_min_std_m",
                self.odometry_min_std_m,
                1e-6,
                100.0,
            ),
            (
                "loop_closure.odometry_min_std_deg",
                self.odometry_min_std_deg,
                1e-6,
                90.0,
            ),
            ("loop_closure.loop_std_m", self.loop_std_m, 1e-6, 100.0),
            (
                "loop_closure.loop_max_std_m",
                self.loop_max_std_m,
                1e-6,
                1e4,
            ),
            ("loop_closure.loop_std_deg", self.loop_std_deg, 1e-6, 90.0),
            ("loop_closure.recheck_chi2", self.recheck_chi2, 0.0, 1e6),
            (
                "loop_closure.pair_scatter_widening",
                self.pair_scatter_widening,
                0.0,
                10.0,
            ),
            (
                "loop_closure.verified_std_m",
                self.verified_std_m,
                1e-6,
                1e3,
            ),
        ]
    }

    /// (field, value, min, max) of the count fields, checked last.
    fn count_ranges(&self) -> [(&'static str, u32, u32, u32); 7] {
        [
            (
                "loop_closure.pending_keyframes",
                self.pending_keyframes,
                0,
                1_000_000,
            ),
            (
                "loop_closure.submap_keyframes",
                self.submap_keyframes,
                0,
                100,
            ),
            ("loop_closure.query_keyframes", self.query_keyframes, 1, 100),
            ("loop_closure.max_candidates", self.max_candidates, 1, 100),
            ("loop_closure.min_points", self.min_points, 3, 1_000_000),
            (
                "loop_closure.cooldown_keyframes",
                self.cooldown_keyframes,
                0,
                1_000_000,
            ),
            ("loop_closure.max_iterations", self.max_iterations, 1, 1000),
        ]
    }

    /// How much a query whose detections scatter by `scatter_m` widens the loop's metric
    /// tolerances (see `inlier_scatter_ratio`): its inlier distance and its edge's std grow by
    /// this factor, 1 while `inlier_scatter_ratio` × scatter stays under `inlier_distance_m`.
    pub fn scatter_scale(&self, scatter_m: f64) -> f64 {
        let scale = self.inlier_scatter_ratio * scatter_m / self.inlier_distance_m;
        if scale.is_finite() {
            scale.max(1.0)
        } else {
            1.0
        }
    }

    /// The first keyframe of the query a loop search at keyframe `current` matches: the last
    /// `query_keyframes` keyframes, or all there are.
    pub fn query_from(&self, current: usize) -> usize {
        current.saturating_sub((self.query_keyframes as usize).saturating_sub(1))
    }

    /// Search radius for a candidate `since_candidate_m` of travel ago, metres: it grows with the
    /// drift since then, or since the last closure (`since_closure_m`) where that is less.
    pub fn search_radius_for_m(&self, since_candidate_m: f64, since_closure_m: Option<f64>) -> f64 {
        let drifting_m = since_closure_m.map_or(since_candidate_m, |c| since_candidate_m.min(c));
        (self.search_radius_m + self.search_radius_per_m * drifting_m).min(self.max_search_radius_m)
    }
}

impl Default for Params {
    fn default() -> Self {
        Params {
            scan_matching: true,
            metric: IcpMetric::PointToLine,
            line_neighbours: 6,
            max_correspondence_m: 0.5,
            max_iterations: 20,
            convergence_translation_m: 1e-4,
            convergence_rotation_deg: 1e-3,
            robust_scale_m: 0.1,
            min_correspondences: 8,
            max_correction_m: 0.5,
            max_correction_deg: 10.0,
            degeneracy_ratio: 0.01,
            keyframe_distance_m: 1.0,
            keyframe_rotation_deg: 15.0,
            keyframe_min_overlap: 0.0,
            min_range_std_m: 0.02,
            min_angle_std_deg: 0.2,
            map_std_m: 0.1,
            gate_sigma: 5.0,
            max_speed_mps: 5.0,
            max_turn_rate_deg_s: 90.0,
            loop_closure: LoopClosureParams::default(),
            cell_m: 0.5,
            cell_neighbours: 4,
            cell_min_points: 2,
            cell_floor_m: 0.02,
            robust_sigma: 3.0,
            prior_std_m: 0.01,
            prior_std_deg: 0.1,
            covariance_sequential_scale: 8.0,
            covariance_loop_scale: 0.0,
        }
    }
}

/// `Ok` when the whole number `value` is in `allowed`; the error shows the range as Rust writes
/// it (`3..=64`).
fn check_within<T>(
    field: &str,
    value: T,
    allowed: std::ops::RangeInclusive<T>,
) -> Result<(), InvalidParam>
where
    T: PartialOrd + std::fmt::Display + std::fmt::Debug,
{
    if allowed.contains(&value) {
        Ok(())
    } else {
        Err(InvalidParam::new(
            field,
            format!("is {value}"),
            format!("{allowed:?}"),
        ))
    }
}

/// `Ok` when `value` is finite and inside `[min, max]` (or `(min, max]` when `min_exclusive`).
fn check_range(
    field: &'static str,
    value: f64,
    min: f64,
    min_exclusive: bool,
    max: f64,
    allowed: &'static str,
) -> Result<(), InvalidParam> {
    let above_min = if min_exclusive {
        value > min
    } else {
        value >= min
    };
    if value.is_finite() && above_min && value <= max {
        Ok(())
    } else {
        Err(InvalidParam::new(field, format!("is {value}"), allowed))
    }
}

impl Params {
    /// Settings of tracking's scan matcher.
    pub fn match_settings(&self) -> crate::scan_matcher::MatchSettings {
        crate::scan_matcher::MatchSettings {
            max_correspondence_m: self.max_correspondence_m,
            neighbours: self.cell_neighbours as usize,
            map_std_m: self.map_std_m,
            robust_sigma: self.robust_sigma,
            prior_std_m: self.prior_std_m,
            prior_std_rad: self.prior_std_deg.to_radians(),
            max_iterations: self.max_iterations,
            tolerance_m: self.convergence_translation_m,
            tolerance_rad: self.convergence_rotation_rad(),
            min_correspondences: self.min_correspondences as usize,
            max_correction_m: self.max_correction_m,
            max_correction_rad: self.max_correction_rad(),
        }
    }

    /// Tracking's matcher settings for a frame `step_m` metres from the last pose: the prior
    /// around the odometry prediction takes the increment's own error model
    /// (`loop_closure.odometry_std_per_m` and `odometry_std_deg_per_m` times the step) where that
    /// exceeds the floors `prior_std_m` and `prior_std_deg`: a side-looking radar confounds
    /// heading with along-track translation, and the wheels measure the latter well.
    pub fn tracking_settings(&self, step_m: f64) -> crate::scan_matcher::MatchSettings {
        let mut settings = self.match_settings();
        let lc = &self.loop_closure;
        settings.prior_std_m = settings.prior_std_m.max(lc.odometry_std_per_m * step_m);
        settings.prior_std_rad = settings
            .prior_std_rad
            .max((lc.odometry_std_deg_per_m * step_m).to_radians());
        settings
    }

    /// The `[range m, angle rad]` standard deviations scan matching weighs a detection by: its
    /// reported ones, at least `min_range_std_m` and `min_angle_std_deg` (and those where it
    /// reports none or a non-finite one).
    pub fn point_std(&self, reported: Option<[f64; 2]>) -> [f64; 2] {
        let floor = [self.min_range_std_m, self.min_angle_std_deg.to_radians()];
        let pick = |v: f64, floor: f64| if v.is_finite() { v.max(floor) } else { floor };
        reported.map_or(floor, |s| [pick(s[0], floor[0]), pick(s[1], floor[1])])
    }

    /// An empty map of cell Gaussians for these parameters.
    pub fn distribution_map(&self) -> crate::scan_matcher::DistributionMap {
        crate::scan_matcher::DistributionMap::new(
            self.cell_m,
            self.cell_min_points,
            self.cell_floor_m,
        )
    }

    /// An empty map of points for the per-frame association statistics, gated at
    /// `max_correspondence_m`.
    pub fn statistics_grid(&self) -> crate::point_grid::PointGrid {
        crate::point_grid::PointGrid::new(self.max_correspondence_m)
    }

    /// Checks every field; the error names the first offending field and its allowed range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        self.validate_matching()?;
        self.validate_keyframes_and_gates()?;
        self.validate_covariance_model()?;
        self.loop_closure.validate()
    }

    /// The factors of the published keyframe covariances' model.
    fn validate_covariance_model(&self) -> Result<(), InvalidParam> {
        check_range(
            "covariance_sequential_scale",
            self.covariance_sequential_scale,
            1e-6,
            false,
            1e6,
            "1e-6 <= value <= 1e6",
        )?;
        check_range(
            "covariance_loop_scale",
            self.covariance_loop_scale,
            0.0,
            false,
            1e6,
            "0 <= value <= 1e6",
        )?;
        Ok(())
    }

    /// The scan matcher's and ICP's fields, in [`Self::validate`]'s order.
    fn validate_matching(&self) -> Result<(), InvalidParam> {
        check_range(
            "max_correspondence_m",
            self.max_correspondence_m,
            0.0,
            true,
            1e3,
            "0 < value <= 1000 (metres)",
        )?;
        // A line needs at least three points to be told from a pair.
        check_within("line_neighbours", self.line_neighbours, 3..=64)?;
        check_within("max_iterations", self.max_iterations, 1..=10_000)?;
        check_range(
            "convergence_translation_m",
            self.convergence_translation_m,
            0.0,
            true,
            1.0,
            "0 < value <= 1 (metres)",
        )?;
        check_range(
            "convergence_rotation_deg",
            self.convergence_rotation_deg,
            0.0,
            true,
            10.0,
            "0 < value <= 10 (degrees)",
        )?;
        check_range(
            "robust_scale_m",
            self.robust_scale_m,
            0.0,
            false,
            1e3,
            "0 <= value <= 1000 (metres; 0 disables the kernel)",
        )?;
        // A cell bigger than a target merges its sides into one blob; one smaller than a
        // centimetre holds single detections, whose covariance says nothing.
        check_range(
            "cell_m",
            self.cell_m,
            0.01,
            false,
            10.0,
            "0.01 <= value <= 10 (metres)",
        )?;
        check_within("cell_neighbours", self.cell_neighbours, 1..=16)?;
        check_within("cell_min_points", self.cell_min_points, 1..=1_000_000)?;
        for (field, value, allowed) in [
            (
                "cell_floor_m",
                self.cell_floor_m,
                "0 < value <= 10 (metres)",
            ),
            (
                "robust_sigma",
                self.robust_sigma,
                "0 < value <= 10 (standard deviations)",
            ),
            ("prior_std_m", self.prior_std_m, "0 < value <= 10 (metres)"),
        ] {
            check_range(field, value, 0.0, true, 10.0, allowed)?;
        }
        check_range(
            "prior_std_deg",
            self.prior_std_deg,
            0.0,
            true,
            180.0,
            "0 < value <= 180 (degrees)",
        )?;
        // Two distinct correspondences determine a planar rigid transform; fewer never can.
        check_within(
            "min_correspondences",
            self.min_correspondences,
            2..=1_000_000,
        )?;
        check_range(
            "max_correction_m",
            self.max_correction_m,
            0.0,
            true,
            1e3,
            "0 < value <= 1000 (metres)",
        )?;
        check_range(
            "max_correction_deg",
            self.max_correction_deg,
            0.0,
            true,
            180.0,
            "0 < value <= 180 (degrees)",
        )?;
        check_range(
            "degeneracy_ratio",
            self.degeneracy_ratio,
            0.0,
            false,
            0.5,
            "0 <= value <= 0.5 (0 disables the check)",
        )?;
        Ok(())
    }

    /// Keyframe selection, error floors and motion gates, in [`Self::validate`]'s order.
    fn validate_keyframes_and_gates(&self) -> Result<(), InvalidParam> {
        check_range(
            "keyframe_distance_m",
            self.keyframe_distance_m,
            0.0,
            false,
            1e6,
            "0 <= value <= 1e6 (metres; 0 makes every frame a keyframe)",
        )?;
        check_range(
            "keyframe_rotation_deg",
            self.keyframe_rotation_deg,
            0.0,
            false,
            180.0,
            "0 <= value <= 180 (degrees)",
        )?;
        InvalidParam::check_range("keyframe_min_overlap", self.keyframe_min_overlap, 0.0, 1.0)?;
        InvalidParam::check_range("min_range_std_m", self.min_range_std_m, 1e-6, 100.0)?;
        InvalidParam::check_range("min_angle_std_deg", self.min_angle_std_deg, 1e-6, 90.0)?;
        InvalidParam::check_range("map_std_m", self.map_std_m, 0.0, 100.0)?;
        InvalidParam::check_range("gate_sigma", self.gate_sigma, 0.5, 1e3)?;
        InvalidParam::check_range("max_speed_mps", self.max_speed_mps, 0.0, 1e3)?;
        InvalidParam::check_range("max_turn_rate_deg_s", self.max_turn_rate_deg_s, 1e-3, 1e5)?;
        Ok(())
    }

    /// `convergence_rotation_deg` in radians.
    pub fn convergence_rotation_rad(&self) -> f64 {
        self.convergence_rotation_deg.to_radians()
    }

    /// `max_correction_deg` in radians.
    pub fn max_correction_rad(&self) -> f64 {
        self.max_correction_deg.to_radians()
    }

    /// `keyframe_rotation_deg` in radians.
    pub fn keyframe_rotation_rad(&self) -> f64 {
        self.keyframe_rotation_deg.to_radians()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tolerances_widen_with_the_scatter_only_past_the_fixed_ones() {
        let lc = LoopClosureParams::default();
        // Δθ = 1° at 10 m scatters by 0.17 m: the fixed 0.5 m stands.
        let one_degree_m = 10.0 * 1f64.to_radians();
        assert_eq!(lc.scatter_scale(one_degree_m), 1.0);
        // Δθ = 5°: 0.87 m; the inlier distance becomes twice that.
        let five_degrees_m = 10.0 * 5f64.to_radians();
        let scaled_m = lc.scatter_scale(five_degrees_m) * lc.inlier_distance_m;
        assert!((scaled_m - lc.inlier_scatter_ratio * five_degrees_m).abs() < 1e-12);
        assert!(scaled_m > 3.0 * lc.inlier_distance_m);
        let off = LoopClosureParams {
            inlier_scatter_ratio: 0.0,
            ..lc.clone()
        };
        assert_eq!(off.scatter_scale(five_degrees_m), 1.0);
        for wild in [f64::NAN, f64::INFINITY, -1.0] {
            assert_eq!(lc.scatter_scale(wild), 1.0);
        }
    }

    #[test]
    fn defaults_are_valid() {
        Params::default().validate().unwrap();
    }

    #[test]
    fn each_bad_field_is_named() {
        type Mutation = fn(&mut Params);
        let cases: Vec<(&str, Mutation)> = vec![
            ("max_correspondence_m", |p| p.max_correspondence_m = 0.0),
            ("covariance_sequential_scale", |p| {
                p.covariance_sequential_scale = 0.0
            }),
            ("covariance_loop_scale", |p| p.covariance_loop_scale = -1.0),
            ("loop_closure.inlier_scatter_ratio", |p| {
                p.loop_closure.inlier_scatter_ratio = f64::NAN
            }),
            ("loop_closure.oracle_max_error_m", |p| {
                p.loop_closure.oracle_max_error_m = -0.5
            }),
            ("loop_closure.oracle_max_error_m", |p| {
                p.loop_closure.oracle_max_error_m = f64::NAN
            }),
            ("max_correspondence_m", |p| {
                p.max_correspondence_m = f64::NAN
            }),
            ("max_iterations", |p| p.max_iterations = 0),
            ("line_neighbours", |p| p.line_neighbours = 2),
            ("convergence_translation_m", |p| {
                p.convergence_translation_m = -1.0
            }),
            ("convergence_rotation_deg", |p| {
                p.convergence_rotation_deg = f64::INFINITY
            }),
            ("min_correspondences", |p| p.min_correspondences = 1),
            ("robust_scale_m", |p| p.robust_scale_m = -0.1),
            ("max_correction_m", |p| p.max_correction_m = 0.0),
            ("max_correction_deg", |p| p.max_correction_deg = 181.0),
            ("degeneracy_ratio", |p| p.degeneracy_ratio = 0.9),
            ("cell_m", |p| p.cell_m = 0.0),
            ("cell_m", |p| p.cell_m = f64::INFINITY),
            ("cell_neighbours", |p| p.cell_neighbours = 0),
            ("cell_min_points", |p| p.cell_min_points = 0),
            ("cell_floor_m", |p| p.cell_floor_m = -1.0),
            ("robust_sigma", |p| p.robust_sigma = f64::NAN),
            ("prior_std_m", |p| p.prior_std_m = 0.0),
            ("prior_std_deg", |p| p.prior_std_deg = 1e9),
            ("keyframe_distance_m", |p| p.keyframe_distance_m = -0.1),
            ("keyframe_rotation_deg", |p| p.keyframe_rotation_deg = 200.0),
            ("keyframe_min_overlap", |p| p.keyframe_min_overlap = 1.5),
            ("min_angle_std_deg", |p| p.min_angle_std_deg = 0.0),
            ("gate_sigma", |p| p.gate_sigma = f64::NAN),
            ("max_speed_mps", |p| p.max_speed_mps = -1.0),
            ("loop_closure.search_step_m", |p| {
                p.loop_closure.search_step_m = 0.0
            }),
            ("loop_closure.min_inlier_ratio", |p| {
                p.loop_closure.min_inlier_ratio = 2.0
            }),
            ("loop_closure.query_keyframes", |p| {
                p.loop_closure.query_keyframes = 0
            }),
            ("loop_closure.fine_sigma_m", |p| {
                p.loop_closure.fine_sigma_m = -0.1
            }),
            ("loop_closure.fine_step_m", |p| {
                p.loop_closure.fine_step_m = 0.0
            }),
            ("loop_closure.fine_window_m", |p| {
                p.loop_closure.fine_window_m = f64::NAN
            }),
            ("loop_closure.fine_window_deg", |p| {
                p.loop_closure.fine_window_deg = 45.0
            }),
            ("loop_closure.plateau_fraction", |p| {
                p.loop_closure.plateau_fraction = 0.9
            }),
            ("loop_closure.supersede_below_score", |p| {
                p.loop_closure.supersede_below_score = 1.5
            }),
            ("loop_closure.superseding_score", |p| {
                p.loop_closure.superseding_score = -0.1
            }),
            ("loop_closure.superseding_score", |p| {
                p.loop_closure.superseding_score = 0.5
            }),
            ("loop_closure.plateau_window_m", |p| {
                p.loop_closure.plateau_window_m = f64::INFINITY
            }),
            ("loop_closure.plateau_min_scatter_m", |p| {
                p.loop_closure.plateau_min_scatter_m = -0.5
            }),
            ("loop_closure.prior_sigma_radii", |p| {
                p.loop_closure.prior_sigma_radii = 0.0
            }),
            ("loop_closure.scattered_prior_sigma_radii", |p| {
                p.loop_closure.scattered_prior_sigma_radii = f64::NAN
            }),
            ("loop_closure.recheck_chi2", |p| {
                p.loop_closure.recheck_chi2 = f64::NAN
            }),
            ("loop_closure.verified_std_m", |p| {
                p.loop_closure.verified_std_m = 0.0
            }),
            ("loop_closure.pair_scatter_widening", |p| {
                p.loop_closure.pair_scatter_widening = 11.0
            }),
            ("loop_closure.plateau_window_deg", |p| {
                p.loop_closure.plateau_window_deg = 60.0
            }),
        ];
        for (field, mutate) in cases {
            let mut p = Params::default();
            mutate(&mut p);
            let err = p.validate().expect_err(field);
            assert!(err.to_string().contains(field), "{field}: {err}");
        }
    }

    #[test]
    fn parses_from_toml() {
        let parse = |text: &str| {
            nrslam_runtime::parse_params::<Params>(text.parse::<toml::Table>().unwrap())
        };
        let p = parse("metric = \"point_to_point\"\nkeyframe_distance_m = 2.0").unwrap();
        assert_eq!(p.metric, IcpMetric::PointToPoint);
        assert_eq!(p.keyframe_distance_m, 2.0);
        assert_eq!(p.max_iterations, Params::default().max_iterations);
        assert_eq!(parse("").unwrap(), Params::default());
        let err = parse("keyframe_distance = 2.0").unwrap_err().to_string();
        assert!(err.contains("keyframe_distance"), "{err}");
        assert!(parse("metric = \"point_to_plane\"").is_err());
        let p = parse("[loop_closure]\nenabled = false\nloop_std_m = 0.2").unwrap();
        assert!(!p.loop_closure.enabled);
        assert_eq!(p.loop_closure.loop_std_m, 0.2);
        let err = parse("[loop_closure]\nenable = false")
            .unwrap_err()
            .to_string();
        assert!(err.contains("enable"), "{err}");
    }

    #[test]
    fn zero_keyframe_thresholds_are_allowed() {
        let p = Params {
            keyframe_distance_m: 0.0,
            keyframe_rotation_deg: 0.0,
            degeneracy_ratio: 0.0,
            ..Params::default()
        };
        p.validate().unwrap();
    }
}
