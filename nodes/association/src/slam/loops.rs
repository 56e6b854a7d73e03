//! Loop closure's side of the association (step 4 of [`super`]): which old keyframes are
//! searched as revisits of the newest one, which matches join the pose graph, and what joining
//! does.
//!
//! A match ([`crate::loop_closure::match_loop`]) joins when its correlative score alone vouches
//! for it (`standalone_score`), when it agrees with the graph's current estimate, or when a
//! pending match of an independent query confirms it; a match that may slide along one side
//! waits. Joining adds its edges with the information the match pins down
//! ([`loop_information`]), supersedes earlier partial revisits of the same place, optimises the
//! graph, removes earlier closures that the rest of the graph now contradicts
//! (`recheck_chi2`), recomputes the keyframes' covariances and rebuilds the tracking maps. The
//! paper's SLAM
//! has no loop closure; docs/slam.md describes this back end and measures each rule.

use super::{planar_rotation, Association};
use crate::loop_closure::{
    match_loop_with, symmetric_eigen_2x2, translation_marginal, weakest_translation_information,
    LoopMatch,
};
use crate::params::{LoopClosureParams, Params};
use crate::pose::Pose2;
use crate::pose_graph::{leaf_covariance, Edge, EdgeKind, OptimiserSettings, PoseGraph};

/// Whether loop edge `new` supersedes the earlier `old`: `old`'s match scored below
/// `supersede_below_score`, `new`'s at least `superseding_score`, `new` revisits later and
/// measures the same old place (their old keyframes at most `submap_keyframes` apart).
fn supersedes(new: &LoopEdge, old: &LoopEdge, lc: &LoopClosureParams) -> bool {
    old.score < lc.supersede_below_score
        && new.score >= lc.superseding_score
        && new.to > old.to
        && new.from.abs_diff(old.from) <= lc.submap_keyframes as usize
}

/// A match may have slid along one side: with the heading free, its edge pins the weakest
/// translation direction down by less than `confirm_min_information_per_m2`. Judged on the
/// match's own geometry (its edge at `std_scale` 1): the floor every edge gets
/// (`loop_max_std_m`) would otherwise hide the slide of a widened edge.
fn may_slide(edge: &LoopEdge, lc: &LoopClosureParams) -> bool {
    let geometry = LoopEdge {
        std_scale: 1.0,
        ..*edge
    };
    weakest_translation_information(&loop_information(&geometry, lc).into())
        < lc.confirm_min_information_per_m2
}

/// What a pending match that confirms a new one adds to the graph: itself, or nothing if it may
/// have slid along a side ([`may_slide`]). Such a match still vouches that the place is the same
/// (it is why the new match is accepted), but its measurement along the slide is no better than
/// its own confirmation would be, which is none: a match that may slide is never confirmed itself.
/// On the hall at Δθ 5° such partners had slid 2.8–3.7 m (seeds 2, 19, 30, 32 and 35).
/// Measured against keeping them (docs/slam-log.md): final keyframe RMSE −0.035 ± 0.010 m over hall
/// seeds 1–200 at Δθ 5°, ET-GOPSA +0.15 ± 0.61, and every other row within its noise.
fn partner_edges(partner: &LoopEdge, lc: &LoopClosureParams) -> Vec<LoopEdge> {
    if may_slide(partner, lc) {
        Vec::new()
    } else {
        vec![*partner]
    }
}

/// Closures tested by each recheck at most, the newest; older unverified ones stay in the graph
/// untested, so that a run whose closures the graph can never judge does not pay a growing
/// re-optimisation per closure.
const MAX_UNVERIFIED_CLOSURES: usize = 8;

/// Of two closures or revisits the rest of the graph could do without, the one with fewer
/// closures leaves only if the other has at least this many times as many
/// ([`Association::recheck_closures`]).
const OUTVOTING_FACTOR: usize = 3;

/// Calibrated information of the sequential edges, by (older, newer) keyframe.
type Calibrated = std::collections::HashMap<(usize, usize), nalgebra::Matrix3<f64>>;

/// A closure left out of the graph ([`Association::leave_out`]).
struct LeftOut {
    /// The graph without it, optimised.
    graph: PoseGraph,
    /// The largest χ² of its edges against that graph.
    chi2: f64,
    /// Whether that graph pins each of its edges' relative poses down to `verified_std_m`.
    pinned: bool,
}

/// A loop edge: the measured pose of keyframe `to` in the frame of the older keyframe `from`
/// (indices into [`Association::keyframe_records`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopEdge {
    /// The older keyframe.
    pub from: usize,
    /// The newer keyframe (the revisit).
    pub to: usize,
    /// Pose of `to` in the frame of `from`.
    pub relative: Pose2,
    /// What the match pins down, direction by direction ([`LoopMatch::information`], in the
    /// frame of `from`); all zero when unknown (the edge is then isotropic).
    pub information: [[f64; 3]; 3],
    /// The edge's std in units of `loop_std_m`: 1, or the query's
    /// [`LoopClosureParams::scatter_scale`] where its detections scatter more.
    pub std_scale: f64,
    /// The match's correlative score ([`LoopMatch::score`]): how much of the query lies on the
    /// submap, which a partial revisit keeps low ([`LoopClosureParams::supersede_below_score`]).
    pub score: f64,
}

/// The information of a loop edge over (x m, y m, yaw rad) in the frame of its measurement
/// (as [`crate::pose_graph`] whitens the error): the match's own point-to-line information,
/// scaled so that the direction it pins down best has the std `loop_std_m` × the edge's
/// `std_scale`, plus a floor of `loop_max_std_m` (or that std if more, and 30°) on every axis.
/// A match along a straight edge then moves the graph across the edge, where it is right, and
/// hardly along it, where it can slide and turn. Without the match's information the edge is
/// isotropic (`loop_std_m` × `std_scale`, `loop_std_deg`).
pub(super) fn loop_information(edge: &LoopEdge, lc: &LoopClosureParams) -> nalgebra::Matrix3<f64> {
    let strongest = symmetric_eigen_2x2(&translation_marginal(&edge.information)).0;
    let loop_std_m = lc.loop_std_m * edge.std_scale.max(1.0);
    let isotropic = || {
        let (it, ir) = (
            1.0 / loop_std_m.powi(2),
            1.0 / lc.loop_std_deg.to_radians().powi(2),
        );
        nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(it, it, ir))
    };
    if !(strongest.is_finite() && strongest > 0.0) {
        return isotropic();
    }
    let scale = 1.0 / (loop_std_m.powi(2) * strongest);
    let from_frame = nalgebra::Matrix3::from_fn(|a, b| scale * edge.information[a][b]);
    // The error's translation is in the measurement's frame: e = R_zᵀ δ for a shift δ in the
    // frame of `from`.
    let rotate = planar_rotation(edge.relative.yaw_rad);
    let floor_m = 1.0 / lc.loop_max_std_m.max(loop_std_m).powi(2);
    let floor_rad = 1.0 / 30f64.to_radians().powi(2);
    let information = rotate.transpose() * from_frame * rotate
        + nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(floor_m, floor_m, floor_rad));
    if information.iter().all(|v| v.is_finite()) {
        0.5 * (information + information.transpose())
    } else {
        isotropic()
    }
}

impl Association {
    /// Tests old keyframes near the newest one as revisits; on a verified one, optimises the
    /// graph and rebuilds the map. Returns the accepted match.
    pub(super) fn close_loop(&mut self) -> Option<LoopMatch> {
        let lc = self.params.loop_closure.clone();
        let current = self.records.len().checked_sub(1)?;
        let keep = lc.pending_keyframes as usize;
        self.pending.retain(|p| current - p.to <= keep);
        let here = self.records[current].pose;
        let travelled_now = self.records[current].travelled_m;
        let mut candidates: Vec<(f64, usize, f64)> = self.records[..current]
            .iter()
            .enumerate()
            .filter_map(|(j, r)| {
                let travelled = travelled_now - r.travelled_m;
                let since_closure = self.travelled_at_closure_m.map(|at| travelled_now - at);
                let radius = lc.search_radius_for_m(travelled, since_closure);
                let distance = r.pose.distance_m(&here);
                (travelled >= lc.min_separation_m && distance <= radius + lc.candidate_distance_m)
                    .then_some((distance, j, radius))
            })
            .collect();
        candidates.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let query_from = lc.query_from(current);
        // The query is expressed in its middle keyframe's frame, and the loop edge measures that
        // keyframe: the tracking error within the query (chiefly heading) then reaches the edge
        // over half the query's length instead of all of it.
        let anchor = (query_from + current) / 2;
        let query = self.cloud(query_from..=current, anchor);
        let (lc, std_scale) = self.widened_for_scatter(lc, query_from..=current);
        let anchor_pose = self.records[anchor].pose;
        // The loop's ICP refinement pairs points across a larger gap than tracking does: after a
        // lap the drift is metres, not centimetres.
        let refine_params = Params {
            max_correspondence_m: lc.refine_correspondence_m,
            ..self.params.clone()
        };
        let mut tried: Vec<usize> = Vec::new();
        for &(_, j, radius_m) in &candidates {
            if tried.len() >= lc.max_candidates as usize {
                break;
            }
            // Neighbours of a tried candidate would test the same place again.
            if tried
                .iter()
                .any(|&t| t.abs_diff(j) <= lc.submap_keyframes as usize)
            {
                continue;
            }
            tried.push(j);
            let w = lc.submap_keyframes as usize;
            let last_old = (j + w).min(current);
            // The submap must stay in the old part of the trajectory.
            let last_old = last_old.min(
                self.records
                    .iter()
                    .rposition(|r| travelled_now - r.travelled_m >= lc.min_separation_m)
                    .unwrap_or(j),
            );
            let submap = self.cloud(j.saturating_sub(w)..=last_old.max(j), j);
            let predicted = self.records[j].pose.between(&anchor_pose);
            let found = match_loop_with(
                &query,
                &submap,
                predicted,
                radius_m,
                &lc,
                &refine_params,
                &mut self.loop_cache,
            );
            match found {
                Ok(found) => {
                    let found = LoopMatch {
                        candidate: j,
                        query: anchor,
                        ..found
                    };
                    let edge = LoopEdge {
                        from: j,
                        to: anchor,
                        relative: found.relative,
                        information: found.information,
                        std_scale,
                        score: found.score,
                    };
                    if !self.oracle_admits(&edge) {
                        tracing::debug!(
                            candidate = j,
                            anchor,
                            ?found,
                            "loop refused by the oracle"
                        );
                        continue;
                    }
                    let (confirmed, why) = if found.score >= lc.standalone_score {
                        (Some(Vec::new()), "score")
                    } else if may_slide(&edge, &lc) {
                        // Neither agreement nor a pending match can vouch for a match that may
                        // have slid along a side: both pass it with the slide in it.
                        (None, "may slide")
                    } else if self.agrees_with_graph(&edge) {
                        (Some(Vec::new()), "agrees with the graph")
                    } else {
                        let pair = self.pending.iter().rev().find(|p| self.confirm(p, &edge));
                        (
                            pair.map(|p| partner_edges(p, &lc)),
                            "confirmed by a pending match",
                        )
                    };
                    if let Some(mut edges) = confirmed {
                        tracing::debug!(
                            candidate = j,
                            anchor,
                            ?found,
                            ?predicted,
                            why,
                            "loop accepted"
                        );
                        edges.push(edge);
                        self.apply_loop(&edges);
                        return Some(found);
                    }
                    tracing::debug!(candidate = j, anchor, ?found, ?predicted, "loop pending");
                    self.pending.push(edge);
                }
                Err(reason) => {
                    tracing::debug!(candidate = j, current, ?reason, "loop rejected");
                }
            }
        }
        None
    }

    /// `lc` with the inlier and overlap distances widened for the scatter of the query made of
    /// keyframes `query`, and that factor (`LoopClosureParams::scatter_scale`), which its edge's
    /// std takes too. The agreement with the graph (`agreement_m`) stays; two widened matches
    /// confirm each other within a tolerance widened by the same factor (`confirm`,
    /// `pair_scatter_widening`). The plateau estimate
    /// (`plateau_fraction`) is switched off for a query that scatters less than
    /// `plateau_min_scatter_m`: there the best score is a sharp peak, and the plateau on the
    /// search's 0.25 m lattice would only blur it. A query that scatters at least that much
    /// takes the search prior's `scattered_prior_sigma_radii`.
    ///
    /// # Panics
    ///
    /// If `query` reaches past the last keyframe.
    pub fn widened_for_scatter(
        &self,
        lc: LoopClosureParams,
        query: std::ops::RangeInclusive<usize>,
    ) -> (LoopClosureParams, f64) {
        let scatter_m = self.scatter_m(query).unwrap_or(0.0);
        let std_scale = lc.scatter_scale(scatter_m);
        let scattered = scatter_m >= lc.plateau_min_scatter_m;
        let widened = LoopClosureParams {
            inlier_distance_m: lc.inlier_distance_m * std_scale,
            // The overlap is the inliers' superset: it widens with them.
            overlap_distance_m: lc.overlap_distance_m * std_scale,
            plateau_fraction: if scattered { lc.plateau_fraction } else { 0.0 },
            prior_sigma_radii: if scattered {
                lc.scattered_prior_sigma_radii
            } else {
                lc.prior_sigma_radii
            },
            ..lc
        };
        (widened, std_scale)
    }

    /// The match agrees with the graph's current estimate of the same relative pose, and that
    /// estimate is itself held by a recent loop (before it, the estimate is the drift the loop
    /// is there to measure, and a match pulled towards it would confirm the drift).
    fn agrees_with_graph(&self, edge: &LoopEdge) -> bool {
        let lc = &self.params.loop_closure;
        let anchored = self
            .loop_edges
            .last()
            .is_some_and(|last| edge.to - last.to <= lc.pending_keyframes as usize);
        if !anchored {
            return false;
        }
        let estimate = self.records[edge.from]
            .pose
            .between(&self.records[edge.to].pose);
        estimate.distance_m(&edge.relative) <= lc.agreement_m
            && estimate.rotation_to_rad(&edge.relative) <= lc.agreement_deg.to_radians()
    }

    /// Two matches `a` and `b` confirm each other: the cycle old `a.from` → new `a.to` (match
    /// `a`) → new `b.to` (tracked) → old `b.from` (match `b`, inverted) → old `a.from` (tracked)
    /// closes within `pair_m` (+ `pair_per_m` per metre tracked) and `pair_deg`, both times
    /// `pair_scatter_widening` × the larger edge's `std_scale` where that exceeds 1.
    fn confirm(&self, a: &LoopEdge, b: &LoopEdge) -> bool {
        let lc = &self.params.loop_closure;
        // Queries that share keyframes share their points, and with them the same wrong fit:
        // only disjoint ones are independent evidence. The exception, the same query against
        // two old places a submap apart, is what lets a single lap close its loop: its revisit
        // is its last few keyframes, too few for a second, disjoint query.
        let same_query_elsewhere =
            a.to == b.to && a.from.abs_diff(b.from) >= lc.submap_keyframes as usize;
        if a.to.abs_diff(b.to) < lc.query_keyframes as usize && !same_query_elsewhere {
            return false;
        }
        let pose = |i: usize| self.records[i].pose;
        let old = pose(a.from).between(&pose(b.from));
        let new = pose(a.to).between(&pose(b.to));
        let via_a = a.relative.compose(&new);
        let via_b = old.compose(&b.relative);
        let tracked_m = old.x_m.hypot(old.y_m) + new.x_m.hypot(new.y_m);
        // Matches of scattered detections are as far off as their widened edges say.
        let widening = (lc.pair_scatter_widening * a.std_scale.max(b.std_scale)).max(1.0);
        via_a.distance_m(&via_b) <= widening * (lc.pair_m + lc.pair_per_m * tracked_m)
            && via_a.rotation_to_rad(&via_b) <= widening * lc.pair_deg.to_radians()
    }

    /// Whether oracle verification (`loop_closure.oracle_max_error_m`) lets `edge` through: always
    /// when it is off; otherwise only when both keyframes carry a true pose and the edge's
    /// translation (the newer keyframe's position in the older one's frame, as `loops.csv`'s
    /// `error_m` scores it) is within the limit of theirs. Headings are not judged. A pending
    /// match was admitted when it was matched, so its partner edges need no second verdict.
    fn oracle_admits(&self, edge: &LoopEdge) -> bool {
        let limit_m = self.params.loop_closure.oracle_max_error_m;
        if limit_m <= 0.0 {
            return true;
        }
        let truth = |k: usize| self.records.get(k).and_then(|r| r.true_pose);
        let (Some(from), Some(to)) = (truth(edge.from), truth(edge.to)) else {
            tracing::debug!(
                from = edge.from,
                to = edge.to,
                "loop refused by the oracle: a keyframe has no true pose"
            );
            return false;
        };
        edge.relative.distance_m(&from.between(&to)) <= limit_m
    }

    fn apply_loop(&mut self, edges: &[LoopEdge]) {
        let lc = self.params.loop_closure.clone();
        let earlier = self.loop_edges.len();
        let mut in_graph = Vec::with_capacity(edges.len());
        for edge in edges {
            let information = loop_information(edge, &lc);
            if self.graph.add_edge(Edge::with_information(
                edge.from,
                edge.to,
                edge.relative,
                information,
                EdgeKind::Loop,
            )) {
                self.uncertainty_information
                    .push(information * self.params.covariance_loop_scale);
                in_graph.push(*edge);
            }
            self.loop_edges.push(*edge);
        }
        self.supersede_partial_loops(&in_graph, earlier);
        self.pending.clear();
        let settings = OptimiserSettings {
            max_iterations: lc.max_iterations,
            ..OptimiserSettings::default()
        };
        self.graph.optimise(&settings);
        if !self.graph.nodes().iter().all(Pose2::is_finite) {
            return;
        }
        self.unverified_closures
            .push(in_graph.iter().map(|e| (e.from, e.to)).collect());
        self.recheck_closures(&settings);
        for (record, pose) in self.records.iter_mut().zip(self.graph.nodes()) {
            record.pose = *pose;
        }
        self.update_covariances(&settings);
        self.travelled_at_closure_m = Some(self.travelled_m);
        self.rebuild_map();
        self.revision += 1;
        self.loop_closures += 1;
        self.cooldown = lc.cooldown_keyframes;
    }

    /// Takes out of the graph, and out of [`Association::loop_edges`], the edges among the first
    /// `earlier` of them (accepted before this closure: a match's own confirmation stays with
    /// it) that the `accepted` ones, now in the graph, supersede ([`supersedes`]), together with
    /// the low-score edges of the same query (the partners that confirmed them). A first revisit
    /// overlaps its old view only in part, and its match, though inside its own uncertainty, can
    /// be decimetres and degrees off (docs/slam.md); once a fuller view of the same old place is
    /// in the graph, the partial one only pulls the graph away from it. Loop edges are told apart
    /// by (old, new) keyframe: one closure per keyframe, and the edges of one closure differ in
    /// one or the other.
    fn supersede_partial_loops(&mut self, accepted: &[LoopEdge], earlier: usize) {
        let lc = &self.params.loop_closure;
        let before = &self.loop_edges[..earlier.min(self.loop_edges.len())];
        let superseded: Vec<&LoopEdge> = before
            .iter()
            .filter(|old| accepted.iter().any(|new| supersedes(new, old, lc)))
            .collect();
        let gone: Vec<(usize, usize)> = before
            .iter()
            .filter(|old| {
                superseded.iter().any(|s| {
                    (s.from, s.to) == (old.from, old.to)
                        || (s.to == old.to && old.score < lc.supersede_below_score)
                })
            })
            .map(|old| (old.from, old.to))
            .collect();
        if gone.is_empty() {
            return;
        }
        tracing::debug!(?gone, "loop edges superseded");
        self.remove_loop_edges(&gone);
    }

    /// Takes the loop edges `gone` (by old and new keyframe) out of the graph and out of
    /// [`Association::loop_edges`].
    fn remove_loop_edges(&mut self, gone: &[(usize, usize)]) {
        self.loop_edges.retain(|e| !gone.contains(&(e.from, e.to)));
        let kept = self.graph.retain_edges(|edge| !Self::is_member(edge, gone));
        // One entry per graph edge: the same edges leave.
        let mut kept = kept.into_iter();
        self.uncertainty_information
            .retain(|_| kept.next().unwrap_or(true));
        debug_assert_eq!(self.uncertainty_information.len(), self.graph.edges().len());
    }

    /// Tests every earlier closure not yet verified (the edges accepted together, by old and new
    /// keyframe) against the rest of the graph, the newest closure (last in the list) included in
    /// that rest. A closure is judged without its revisit ([`Self::revisit`]: every loop edge whose
    /// query shares keyframes with its own), since matches of overlapping queries share their
    /// detections and with them a wrong fit, unless that leaves no loop edge to judge by. When none
    /// is further off than `recheck_chi2`, those the rest of the graph pins down to
    /// `verified_std_m` are verified and not tested again. When some are, the newest becomes a
    /// suspect too, and a culprit leaves the graph (which keeps the poses optimised without it): a
    /// failing closure, or a revisit's closures together ([`Self::revisits`]), without which
    /// every other closure agrees. A revisit's several matches are one piece of evidence, so it may
    /// not outvote a closure elsewhere by their number: when two culprits are possible, the smaller
    /// leaves only if the other has at least [`OUTVOTING_FACTOR`] times as many closures (a revisit
    /// that could go only because one of its closures could is no rival to that closure), and
    /// otherwise both stay until a later closure takes a side (as two closures that contradict only
    /// each other do). A closure is judged only against other loop closures: the sequential chain
    /// alone, however long, neither refutes nor verifies it (a single lap keeps its one closure).
    /// At most [`MAX_UNVERIFIED_CLOSURES`], the newest, are tested; older ones stay in the graph as
    /// they are. Returns whether a closure left.
    fn recheck_closures(&mut self, settings: &OptimiserSettings) -> bool {
        let threshold = self.params.loop_closure.recheck_chi2;
        if threshold <= 0.0 {
            return false;
        }
        let excess = self
            .unverified_closures
            .len()
            .saturating_sub(MAX_UNVERIFIED_CLOSURES);
        self.unverified_closures.drain(..excess);
        let calibrated = self.calibrated();
        let mut dropped = false;
        loop {
            let graph = &self.graph;
            self.unverified_closures
                .retain(|closure| Self::members(graph, closure).next().is_some());
            let Some(newest) = self.unverified_closures.len().checked_sub(1) else {
                return dropped;
            };
            // Without its revisit, or, where that leaves no loop edge (a first revisit's several
            // matches and nothing else), without itself: its revisit's other matches then judge
            // it, by their number, as nothing else can; but they do not verify it.
            let judge = |graph: &PoseGraph, closure: &[(usize, usize)]| {
                let revisit = self.revisit(graph, closure);
                let judged_without_revisit = graph
                    .edges()
                    .iter()
                    .any(|e| e.kind == EdgeKind::Loop && !Self::is_member(e, &revisit));
                if judged_without_revisit {
                    self.leave_out(graph, &revisit, closure, &calibrated, settings)
                } else {
                    LeftOut {
                        pinned: false,
                        ..self.leave_out(graph, closure, closure, &calibrated, settings)
                    }
                }
            };
            let mut verdicts: Vec<LeftOut> = self.unverified_closures[..newest]
                .iter()
                .map(|closure| judge(&self.graph, closure))
                .collect();
            for (closure, verdict) in self.unverified_closures.iter().zip(&verdicts) {
                let (chi2, pinned) = (verdict.chi2, verdict.pinned);
                tracing::debug!(?closure, chi2, pinned, "closure rechecked");
            }
            if verdicts.iter().all(|v| v.chi2 <= threshold) {
                let mut pinned = verdicts.iter().map(|v| v.pinned);
                self.unverified_closures
                    .retain(|_| !pinned.next().unwrap_or(false));
                return dropped;
            }
            verdicts.push(judge(&self.graph, &self.unverified_closures[newest]));
            let failing: Vec<usize> = (0..verdicts.len())
                .filter(|&i| verdicts[i].chi2 > threshold)
                .collect();
            let count = self.unverified_closures.len();
            let mut suspects: Vec<Vec<usize>> = failing.iter().map(|&c| vec![c]).collect();
            suspects.extend(self.revisits().into_iter().filter(|revisit| {
                // A revisit that is all the closures there are has no one to outvote.
                (2..count).contains(&revisit.len()) && revisit.iter().any(|c| failing.contains(c))
            }));
            // (its closures' indices, their edges, the graph without them) of each possible
            // culprit.
            type Culprit = (Vec<usize>, Vec<(usize, usize)>, PoseGraph);
            let culprits: Vec<Culprit> = suspects
                .into_iter()
                .filter_map(|suspect| {
                    let pairs: Vec<(usize, usize)> = suspect
                        .iter()
                        .flat_map(|&c| self.unverified_closures[c].iter().copied())
                        .collect();
                    let rest = Self::without(&self.graph, &pairs, settings);
                    let agree = self
                        .unverified_closures
                        .iter()
                        .enumerate()
                        .filter(|(d, _)| !suspect.contains(d))
                        .all(|(_, other)| judge(&rest, other).chi2 <= threshold);
                    agree.then_some((suspect, pairs, rest))
                })
                .collect();
            // A revisit that could go because one of its closures could is no rival to it.
            let mut minimal: Vec<&Culprit> = culprits
                .iter()
                .filter(|(mine, _, _)| {
                    !culprits.iter().any(|(other, _, _)| {
                        other.len() < mine.len() && other.iter().all(|c| mine.contains(c))
                    })
                })
                .collect();
            minimal.sort_by_key(|(closures, _, _)| closures.len());
            let outvoted = match &minimal[..] {
                [only] => Some(*only),
                [smallest, others @ ..] => others
                    .iter()
                    .all(|(closures, _, _)| closures.len() >= OUTVOTING_FACTOR * smallest.0.len())
                    .then_some(*smallest),
                [] => None,
            };
            let Some((_, gone, without)) = outvoted else {
                tracing::debug!(
                    closures = ?self.unverified_closures,
                    culprits = ?minimal.iter().map(|(_, c, _)| c).collect::<Vec<_>>(),
                    "closures contradict each other; waiting for another closure"
                );
                return dropped;
            };
            tracing::debug!(closures = ?gone, "closures refuted by the rest of the graph");
            let gone = gone.clone();
            self.unverified_closures
                .retain(|closure| !closure.iter().any(|pair| gone.contains(pair)));
            for (node, pose) in without.nodes().iter().enumerate() {
                self.graph.set_node(node, *pose);
            }
            self.remove_loop_edges(&gone);
            dropped = true;
        }
    }

    /// The information the keyframes' covariances give each sequential edge, by its keyframes:
    /// the optimiser's own is deliberately looser (`covariance_sequential_scale`).
    fn calibrated(&self) -> Calibrated {
        self.graph
            .edges()
            .iter()
            .zip(&self.uncertainty_information)
            .filter(|(edge, _)| edge.kind == EdgeKind::Odometry)
            .map(|(edge, information)| ((edge.from, edge.to), *information))
            .collect()
    }

    /// `closure`'s revisit in `graph`: its own loop edges and every other loop edge whose newer
    /// keyframe lies less than `query_keyframes` from one of its own, so that their queries
    /// share keyframes.
    fn revisit(&self, graph: &PoseGraph, closure: &[(usize, usize)]) -> Vec<(usize, usize)> {
        let mut pairs: Vec<(usize, usize)> = closure.to_vec();
        pairs.extend(
            graph
                .edges()
                .iter()
                .filter(|e| e.kind == EdgeKind::Loop)
                .filter(|e| {
                    closure
                        .iter()
                        .any(|&(_, to)| self.queries_overlap(to, e.to))
                })
                .map(|e| (e.from, e.to))
                .filter(|pair| !closure.contains(pair)),
        );
        pairs
    }

    /// The unverified closures' indices grouped by revisit: two closures belong together when
    /// the queries of two of their edges share a keyframe (newer keyframes less than
    /// `query_keyframes` apart), and so on transitively.
    fn revisits(&self) -> Vec<Vec<usize>> {
        let near = |a: usize, b: usize| {
            self.unverified_closures[a].iter().any(|&(_, x)| {
                self.unverified_closures[b]
                    .iter()
                    .any(|&(_, y)| self.queries_overlap(x, y))
            })
        };
        let mut groups: Vec<Vec<usize>> = Vec::new();
        for c in 0..self.unverified_closures.len() {
            let (joined, rest): (Vec<Vec<usize>>, Vec<Vec<usize>>) = groups
                .into_iter()
                .partition(|g| g.iter().any(|&d| near(c, d)));
            let mut group: Vec<usize> = joined.into_iter().flatten().collect();
            group.push(c);
            group.sort_unstable();
            groups = rest;
            groups.push(group);
        }
        groups.sort();
        groups
    }

    /// Whether the queries of two loop edges, by their newer keyframes, share keyframes: those lie
    /// less than `query_keyframes` apart.
    fn queries_overlap(&self, newer_a: usize, newer_b: usize) -> bool {
        newer_a.abs_diff(newer_b) < self.params.loop_closure.query_keyframes as usize
    }

    /// Whether `edge` is one of `closure`'s loop edges.
    fn is_member(edge: &Edge, closure: &[(usize, usize)]) -> bool {
        edge.kind == EdgeKind::Loop && closure.contains(&(edge.from, edge.to))
    }

    /// The loop edges of `graph` that belong to `closure`.
    fn members<'g>(
        graph: &'g PoseGraph,
        closure: &'g [(usize, usize)],
    ) -> impl Iterator<Item = &'g Edge> + 'g {
        graph
            .edges()
            .iter()
            .filter(|edge| Self::is_member(edge, closure))
    }

    /// `graph` without the loop edges `left_out`, optimised.
    fn without(
        graph: &PoseGraph,
        left_out: &[(usize, usize)],
        settings: &OptimiserSettings,
    ) -> PoseGraph {
        let mut without = graph.clone();
        without.retain_edges(|edge| !Self::is_member(edge, left_out));
        without.optimise(settings);
        without
    }

    /// `graph` without the loop edges `left_out` (`closure`'s among them), optimised, and how
    /// `closure`'s edges fare against it: the largest χ² among them
    /// ([`PoseGraph::relative_consistency`], the sequential edges at their calibrated information,
    /// the loop edges at their own), and whether that graph pins every one of their relative poses
    /// down to `verified_std_m`. A graph with no other loop edge, or one that cannot be judged
    /// (optimisation or covariance failing), refutes nothing and pins nothing.
    fn leave_out(
        &self,
        graph: &PoseGraph,
        left_out: &[(usize, usize)],
        closure: &[(usize, usize)],
        calibrated: &Calibrated,
        settings: &OptimiserSettings,
    ) -> LeftOut {
        let members: Vec<Edge> = Self::members(graph, closure).copied().collect();
        let without = Self::without(graph, left_out, settings);
        // Only other loop closures can judge a closure: without them its relative pose is the
        // chain's dead reckoning, whose drift the closure is there to measure.
        let judged = without.edges().iter().any(|e| e.kind == EdgeKind::Loop);
        let mut verdict = LeftOut {
            chi2: 0.0,
            pinned: judged && without.nodes().iter().all(Pose2::is_finite),
            graph: without,
        };
        if !verdict.pinned {
            return verdict;
        }
        for edge in &members {
            match verdict.graph.relative_consistency(
                edge.from,
                edge.to,
                &edge.measurement,
                &edge.information,
                settings,
                |_, e| match e.kind {
                    EdgeKind::Loop => e.information,
                    EdgeKind::Odometry => calibrated
                        .get(&(e.from, e.to))
                        .copied()
                        .unwrap_or(e.information),
                },
            ) {
                Ok((chi2, std_m)) => {
                    verdict.chi2 = verdict.chi2.max(chi2);
                    verdict.pinned &= std_m <= self.params.loop_closure.verified_std_m;
                }
                Err(_) => verdict.pinned = false,
            }
        }
        verdict
    }

    /// Recomputes every keyframe's covariance at the current poses. With loop edges left out of
    /// the covariance model (`covariance_loop_scale` = 0) the informative edges form the
    /// sequential chain, whose marginals are the propagation along it (`leaf_covariance`, one
    /// step per keyframe; the optimiser's odometry kernel being the identity, as
    /// `OptimiserSettings` has it); otherwise the graph's sparse marginals.
    fn update_covariances(&mut self, settings: &OptimiserSettings) {
        debug_assert_eq!(
            settings.odometry_kernel,
            OptimiserSettings::default().odometry_kernel
        );
        if self.params.covariance_loop_scale > 0.0 {
            let uncertainty = &self.uncertainty_information;
            match self
                .graph
                .marginal_covariances(settings, |index, _| uncertainty[index])
            {
                Ok(covariances) => {
                    for (record, covariance) in self.records.iter_mut().zip(covariances) {
                        record.covariance = covariance;
                    }
                }
                Err(reason) => {
                    tracing::warn!(%reason, "keyframe covariances kept from before the loop closure");
                }
            }
            return;
        }
        let sequential = self
            .graph
            .edges()
            .iter()
            .zip(&self.uncertainty_information)
            .filter(|(edge, _)| edge.kind == EdgeKind::Odometry);
        for (edge, information) in sequential {
            let (from, to) = (&self.records[edge.from], &self.records[edge.to]);
            if let Some(covariance) = leaf_covariance(
                &from.pose,
                &to.pose,
                &edge.measurement,
                &from.covariance,
                information,
            ) {
                self.records[edge.to].covariance = covariance;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::slam::KeyframeRecord;

    /// Keyframes `0..count` one metre apart on x, each a graph node, none linked yet, each
    /// truly where it is estimated.
    fn keyframes_in_a_row(slam: &mut Association, count: u32) {
        for k in 0..count {
            push_keyframe(slam, Pose2::new(f64::from(k), 0.0, 0.0), Vec::new());
        }
    }

    /// The next keyframe (a graph node, not linked) at `pose`, truly there, with the scan
    /// `scan_agv_m`, one metre of travel after the previous one.
    fn push_keyframe(slam: &mut Association, pose: Pose2, scan_agv_m: Vec<[f64; 2]>) {
        let k = slam.records.len() as u32;
        slam.graph.add_node(pose);
        slam.records.push(KeyframeRecord {
            id: k,
            pose,
            scan_agv_m,
            scatter_m: 0.0,
            travelled_m: f64::from(k),
            covariance: nalgebra::Matrix3::identity(),
            true_pose: Some(pose),
        });
    }

    /// A match's information pinned down across y only: it may slide along x.
    fn sliding_information() -> [[f64; 3]; 3] {
        let mut information = [[0.0; 3]; 3];
        information[1][1] = 0.5;
        information[2][2] = 50.0;
        information
    }

    #[test]
    fn a_loop_edge_is_weak_only_where_its_match_can_slide() {
        let lc = LoopClosureParams::default();
        // A match along a straight edge in x (of the old keyframe's frame), measured from an
        // old keyframe turned by 90°: in the measurement's frame the free slide is along y.
        let information = sliding_information();
        let edge = LoopEdge {
            from: 0,
            to: 1,
            relative: Pose2::new(3.0, 4.0, std::f64::consts::FRAC_PI_2),
            information,
            std_scale: 1.0,
            score: 0.9,
        };
        let omega = loop_information(&edge, &lc);
        let across = 1.0 / lc.loop_std_m.powi(2);
        assert!((omega[(0, 0)] - across).abs() < 0.05 * across, "{omega}");
        let along_std_m = 1.0 / omega[(1, 1)].sqrt();
        assert!(along_std_m > 0.9 * lc.loop_max_std_m, "{omega}");
        // Without the match's information the edge is isotropic.
        let plain = loop_information(
            &LoopEdge {
                information: [[0.0; 3]; 3],
                ..edge
            },
            &lc,
        );
        assert!((plain[(0, 0)] - across).abs() < 1e-9 && (plain[(1, 1)] - across).abs() < 1e-9);
        // A query of scattered detections widens the edge's std in proportion.
        let scattered = loop_information(
            &LoopEdge {
                std_scale: 3.0,
                ..edge
            },
            &lc,
        );
        // Its strongest direction, plus the floor every edge has.
        let expected = 1.0 / (3.0 * lc.loop_std_m).powi(2) + 1.0 / lc.loop_max_std_m.powi(2);
        assert!(
            (scattered[(0, 0)] - expected).abs() < 1e-9 * expected,
            "{scattered}"
        );
    }

    #[test]
    fn a_scattered_query_widens_the_inlier_and_overlap_distances_not_the_agreement() {
        let mut slam = Association::new(Params::default()).unwrap();
        let record = |scatter_m: f64, detections: usize| KeyframeRecord {
            id: 0,
            pose: Pose2::new(0.0, 0.0, 0.0),
            scan_agv_m: vec![[10.0, 0.0]; detections],
            scatter_m,
            travelled_m: 0.0,
            covariance: nalgebra::Matrix3::zeros(),
            true_pose: None,
        };
        // An empty keyframe adds no query point, so its scatter of 0 must not dilute the rest.
        slam.records = vec![record(0.1, 40), record(0.9, 40), record(0.0, 0)];
        let lc = LoopClosureParams {
            overlap_distance_m: 1.0,
            ..LoopClosureParams::default()
        };
        let (widened, std_scale) = slam.widened_for_scatter(lc.clone(), 0..=2);
        let expected_scale = lc.inlier_scatter_ratio * 0.5 / lc.inlier_distance_m;
        assert!((std_scale - expected_scale).abs() < 1e-12, "{std_scale}");
        assert!((widened.inlier_distance_m - lc.inlier_distance_m * std_scale).abs() < 1e-12);
        assert!((widened.overlap_distance_m - lc.overlap_distance_m * std_scale).abs() < 1e-12);
        assert_eq!(
            widened.confirm_min_information_per_m2,
            lc.confirm_min_information_per_m2
        );
        assert_eq!(widened.agreement_m, lc.agreement_m);
        assert_eq!(widened.pair_m, lc.pair_m);
        // A metre-scatter query's match is its plateau's centre.
        assert_eq!(lc.plateau_min_scatter_m, 0.5);
        assert_eq!(widened.plateau_fraction, lc.plateau_fraction);
        assert!(widened.plateau_fraction > 0.0);
        // And its flat scores take the narrower search prior.
        assert_eq!(widened.prior_sigma_radii, lc.scattered_prior_sigma_radii);
        assert!(lc.scattered_prior_sigma_radii < lc.prior_sigma_radii);
        // Detections that scatter less than the fixed distance allows change nothing but the
        // plateau, which they do not have (the search prior stays `prior_sigma_radii`).
        let (plain, one) = slam.widened_for_scatter(lc.clone(), 0..=0);
        let without_plateau = LoopClosureParams {
            plateau_fraction: 0.0,
            ..lc
        };
        assert_eq!((plain, one), (without_plateau, 1.0));
    }

    #[test]
    fn a_partial_revisit_is_superseded_by_a_fuller_view_of_the_same_place_only() {
        let lc = LoopClosureParams::default();
        let edge = |from: usize, to: usize, score: f64| LoopEdge {
            from,
            to,
            relative: Pose2::new(1.0, 0.0, 0.0),
            information: [[0.0; 3]; 3],
            std_scale: 1.0,
            score,
        };
        let partial = edge(0, 98, 0.67);
        assert!(supersedes(&edge(4, 107, 0.95), &partial, &lc));
        // At the limits: `superseding_score` supersedes, `supersede_below_score` is not
        // superseded, `submap_keyframes` apart is the same place.
        let w = lc.submap_keyframes as usize;
        assert!(supersedes(
            &edge(w, 107, lc.superseding_score),
            &partial,
            &lc
        ));
        assert!(!supersedes(&edge(w + 1, 107, 0.95), &partial, &lc));
        assert!(!supersedes(
            &edge(4, 107, 0.95),
            &edge(0, 98, lc.supersede_below_score),
            &lc
        ));
        // Not by a match that scores no better than a partial one,
        assert!(!supersedes(&edge(4, 107, 0.8), &partial, &lc));
        // nor by one of another old place, nor by an earlier one,
        assert!(!supersedes(&edge(30, 107, 0.95), &partial, &lc));
        assert!(!supersedes(&edge(4, 90, 0.95), &partial, &lc));
        // and a full view is never superseded.
        assert!(!supersedes(&edge(4, 107, 0.95), &edge(0, 98, 0.8), &lc));
        let off = LoopClosureParams {
            supersede_below_score: 0.0,
            ..lc
        };
        assert!(!supersedes(&edge(4, 107, 0.95), &partial, &off));
    }

    #[test]
    fn superseded_loop_edges_leave_the_graph_and_its_edge_information() {
        // Loop edges enter the covariance model, so that their entries are not all zero; old
        // keyframes more than one apart are different places.
        let mut params = Params {
            covariance_loop_scale: 1.0,
            ..Params::default()
        };
        params.loop_closure.submap_keyframes = 1;
        let mut slam = Association::new(params).unwrap();
        keyframes_in_a_row(&mut slam, 8);
        for k in 1..8 {
            let edge = Edge::with_std(
                k - 1,
                k,
                Pose2::new(1.0, 0.0, 0.0),
                0.1,
                0.01,
                EdgeKind::Odometry,
            );
            assert!(slam.graph.add_edge(edge));
            slam.uncertainty_information
                .push(nalgebra::Matrix3::identity() * k as f64);
        }
        let edge = |from: usize, to: usize, score: f64| LoopEdge {
            from,
            to,
            relative: Pose2::new((to - from) as f64, 0.0, 0.0),
            information: [[0.0; 3]; 3],
            std_scale: 1.0,
            score,
        };
        // A first closure: the same query against two old places, both seen in part.
        slam.apply_loop(&[edge(0, 5, 0.67), edge(1, 5, 0.7)]);
        // Elsewhere, a full match confirmed by a partial one: it keeps its confirmation.
        slam.apply_loop(&[edge(3, 6, 0.6), edge(4, 6, 0.95)]);
        assert_eq!(slam.loop_edges().len(), 4);
        // A fuller view of old keyframe 0 supersedes the first closure, with its partner.
        slam.apply_loop(&[edge(0, 7, 0.95)]);
        let kept = [edge(3, 6, 0.6), edge(4, 6, 0.95), edge(0, 7, 0.95)];
        assert_eq!(slam.loop_edges(), &kept);
        let loops: Vec<(usize, usize)> = slam
            .graph
            .edges()
            .iter()
            .filter(|e| e.kind == EdgeKind::Loop)
            .map(|e| (e.from, e.to))
            .collect();
        assert_eq!(loops, vec![(3, 6), (4, 6), (0, 7)]);
        // Every edge left keeps its own entry, in its order.
        assert_eq!(slam.uncertainty_information.len(), 7 + kept.len());
        for k in 0..7 {
            assert_eq!(
                slam.uncertainty_information[k],
                nalgebra::Matrix3::identity() * (k + 1) as f64
            );
        }
        let lc = slam.params.loop_closure.clone();
        for (k, edge) in kept.iter().enumerate() {
            assert_eq!(
                slam.uncertainty_information[7 + k],
                loop_information(edge, &lc) * slam.params.covariance_loop_scale
            );
        }
    }

    /// Keyframes 0..13 one metre apart on x, joined by exact odometry edges whose calibrated
    /// std is `chain_std_m` per step; the optimiser takes them ten times looser, as the real
    /// graph takes its sequential edges looser than their calibration.
    fn thirteen_in_a_row(chain_std_m: f64) -> Association {
        in_a_row(13, chain_std_m)
    }

    /// `count` keyframes 1 m apart on x, chained by steps of std `chain_std_m` (calibrated; the
    /// optimiser's ten times looser, as the back end has them).
    fn in_a_row(count: u32, chain_std_m: f64) -> Association {
        let mut slam = Association::new(Params::default()).unwrap();
        keyframes_in_a_row(&mut slam, count);
        for k in 1..count as usize {
            let step = Pose2::new(1.0, 0.0, 0.0);
            let calibrated = Edge::with_std(k - 1, k, step, chain_std_m, 0.01, EdgeKind::Odometry);
            slam.uncertainty_information.push(calibrated.information);
            let loose = Edge::with_std(k - 1, k, step, 10.0 * chain_std_m, 0.1, EdgeKind::Odometry);
            assert!(slam.graph.add_edge(loose));
        }
        slam
    }

    fn measured(from: usize, to: usize, x_m: f64) -> LoopEdge {
        LoopEdge {
            from,
            to,
            relative: Pose2::new(x_m, 0.0, 0.0),
            information: [[0.0; 3]; 3],
            std_scale: 1.0,
            score: 0.9,
        }
    }

    fn loops_in_graph(slam: &Association) -> Vec<(usize, usize)> {
        let graph = slam
            .graph
            .edges()
            .iter()
            .filter(|e| e.kind == EdgeKind::Loop);
        graph.map(|e| (e.from, e.to)).collect()
    }

    #[test]
    fn a_closure_later_closures_contradict_leaves_the_graph() {
        // A chain of 0.4 m per step cannot judge a closure ten steps long (1.3 m), so keyframe
        // 10 measured 4 m farther from 0 than it is joins, unverified.
        let mut slam = thirteen_in_a_row(0.4);
        slam.apply_loop(&[measured(0, 10, 14.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(0, 10)]);
        assert!(slam.records[10].pose.x_m > 11.0, "the graph bends to it");
        // Two right closures nearby pin the same stretch down: the wrong one leaves, and the
        // poses are those optimised without it.
        slam.apply_loop(&[measured(2, 12, 10.0)]);
        slam.apply_loop(&[measured(1, 11, 10.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(2, 12), (1, 11)]);
        assert_eq!(
            slam.loop_edges(),
            &[measured(2, 12, 10.0), measured(1, 11, 10.0)]
        );
        assert_eq!(slam.uncertainty_information.len(), slam.graph.edges().len());
        let x_m = slam.records[10].pose.x_m;
        assert!((x_m - 10.0).abs() < 0.1, "the poses without it: {x_m}");
        // Switched off, the same closure stays.
        let mut slam = thirteen_in_a_row(0.4);
        slam.params.loop_closure.recheck_chi2 = 0.0;
        slam.apply_loop(&[measured(0, 10, 14.0)]);
        slam.apply_loop(&[measured(2, 12, 10.0)]);
        slam.apply_loop(&[measured(1, 11, 10.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(0, 10), (2, 12), (1, 11)]);
    }

    #[test]
    fn of_two_closures_that_contradict_each_other_the_next_closure_decides() {
        // A right closure, then a wrong one 3 m off: each disagrees with the other, and the
        // chain alone judges neither, so both stay for now.
        let mut slam = thirteen_in_a_row(0.1);
        slam.apply_loop(&[measured(0, 10, 10.0)]);
        slam.apply_loop(&[measured(2, 12, 13.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(0, 10), (2, 12)]);
        // A third closure sides with the first: the newer, wrong one leaves.
        slam.apply_loop(&[measured(1, 11, 10.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(0, 10), (1, 11)]);
        let x_m = slam.records[12].pose.x_m;
        assert!((x_m - 12.0).abs() < 0.05, "{x_m}");
    }

    #[test]
    fn two_wrong_closures_of_one_revisit_neither_verify_each_other_nor_outvote_another_revisit() {
        // One revisit's two matches, 3 m off in the same way (keyframes 20 and 23 measured 3 m
        // farther along): they agree with each other.
        let mut slam = in_a_row(50, 0.05);
        slam.apply_loop(&[measured(0, 20, 23.0)]);
        slam.apply_loop(&[measured(3, 23, 23.0)]);
        let apart = vec![vec![(0, 20)], vec![(3, 23)]];
        assert_eq!(
            slam.unverified_closures, apart,
            "neither verified by the other"
        );
        // A right closure of another revisit contradicts both: one piece of evidence against
        // one, so everything stays for now.
        slam.apply_loop(&[measured(12, 35, 23.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(0, 20), (3, 23), (12, 35)]);
        // A second right revisit sides with the first: the wrong revisit leaves, both its
        // closures.
        slam.apply_loop(&[measured(24, 47, 23.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(12, 35), (24, 47)]);
        let x_m = slam.records[23].pose.x_m;
        assert!((x_m - 23.0).abs() < 0.1, "{x_m}");
    }

    #[test]
    fn a_wrong_closure_leaves_though_a_right_one_shares_its_revisit() {
        // Keyframe 10 measured 3 m off, then a right match of an overlapping query, then a
        // right closure of another revisit: the wrong one alone is the culprit (its revisit as
        // a whole could go too, but only because it could), and leaves.
        let mut slam = in_a_row(30, 0.1);
        slam.apply_loop(&[measured(0, 10, 13.0)]);
        slam.apply_loop(&[measured(2, 12, 10.0)]);
        slam.apply_loop(&[measured(5, 25, 20.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(2, 12), (5, 25)]);
    }

    #[test]
    fn a_closure_stays_where_the_graph_agrees_or_cannot_judge() {
        // A single closure: the chain alone judges nothing, however tight.
        let mut slam = thirteen_in_a_row(0.1);
        slam.apply_loop(&[measured(0, 10, 13.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(0, 10)]);
        // Agrees with a later closure of the same revisit (queries sharing keyframes): not
        // verified by it. Agrees with one of another revisit too: verified, never tested again;
        // the newest waits.
        let mut slam = in_a_row(25, 0.1);
        slam.apply_loop(&[measured(0, 10, 10.1)]);
        slam.apply_loop(&[measured(2, 12, 10.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(0, 10), (2, 12)]);
        assert_eq!(slam.unverified_closures, vec![vec![(0, 10)], vec![(2, 12)]]);
        slam.apply_loop(&[measured(5, 22, 17.0)]);
        assert_eq!(slam.unverified_closures, vec![vec![(5, 22)]]);
        // A chain of 2 m per step knows too little to refute 3 m: the closures stay, unverified.
        let mut slam = thirteen_in_a_row(2.0);
        slam.apply_loop(&[measured(0, 10, 13.0)]);
        slam.apply_loop(&[measured(2, 12, 10.0)]);
        assert_eq!(loops_in_graph(&slam), vec![(0, 10), (2, 12)]);
        assert_eq!(slam.unverified_closures, vec![vec![(0, 10)], vec![(2, 12)]]);
    }

    #[test]
    fn scattered_matches_confirm_each_other_within_their_widened_tolerance() {
        let mut slam = Association::new(Params::default()).unwrap();
        keyframes_in_a_row(&mut slam, 31);
        // One query against two old places 15 keyframes apart; the second match is 0.8 m off
        // along x, beyond 0.3 m + 0.02 m/m × 15 m = 0.6 m.
        let edge = |from: usize, off_m: f64, std_scale: f64| LoopEdge {
            from,
            to: 30,
            relative: Pose2::new((30 - from) as f64 + off_m, 0.0, 0.0),
            information: [[0.0; 3]; 3],
            std_scale,
            score: 0.7,
        };
        assert!(slam.confirm(&edge(0, 0.0, 1.0), &edge(15, 0.3, 1.0)));
        assert!(!slam.confirm(&edge(0, 0.0, 1.0), &edge(15, 0.8, 1.0)));
        // Detections scattered enough to widen an edge three times widen the tolerance too.
        assert!(slam.confirm(&edge(0, 0.0, 3.0), &edge(15, 0.8, 1.0)));
        assert!(!slam.confirm(&edge(0, 0.0, 3.0), &edge(15, 1.9, 3.0)));
        slam.params.loop_closure.pair_scatter_widening = 0.0;
        assert!(!slam.confirm(&edge(0, 0.0, 3.0), &edge(15, 0.8, 3.0)));
    }

    #[test]
    fn a_partner_that_may_slide_vouches_but_stays_out_of_the_graph() {
        let lc = LoopClosureParams::default();
        let sliding = sliding_information();
        let mut pinned = sliding;
        pinned[0][0] = 0.5;
        let partner = |information| LoopEdge {
            from: 0,
            to: 10,
            relative: Pose2::new(3.0, 4.0, 0.0),
            information,
            std_scale: 3.0,
            score: 0.4,
        };
        assert!(partner_edges(&partner(sliding), &lc).is_empty());
        assert_eq!(partner_edges(&partner(pinned), &lc), vec![partner(pinned)]);
    }

    #[test]
    fn a_widened_edge_that_may_slide_is_still_caught() {
        let lc = LoopClosureParams::default();
        let sliding = sliding_information();
        let mut pinned = sliding;
        pinned[0][0] = 0.5;
        for std_scale in [1.0, 3.0, 10.0] {
            let edge = |information| LoopEdge {
                from: 0,
                to: 1,
                relative: Pose2::new(3.0, 4.0, 0.0),
                information,
                std_scale,
                score: 0.9,
            };
            assert!(may_slide(&edge(sliding), &lc), "std_scale {std_scale}");
            assert!(!may_slide(&edge(pinned), &lc), "std_scale {std_scale}");
        }
    }

    /// Keyframes 1 m apart around a circle of 8 m radius, a little more than one lap, each with
    /// the exact scan of a fixed, irregular scene of boxes: the last keyframes revisit the
    /// first. Estimated and true poses are the same, and consecutive keyframes are joined by
    /// their exact motion.
    fn one_lap_in_a_scene_of_boxes() -> Association {
        let radius_m = 8.0;
        let step_rad = 1.0 / radius_m;
        let count = (std::f64::consts::TAU / step_rad) as u32 + 8;
        let boxes: [([f64; 2], [f64; 2]); 6] = [
            ([0.0, 0.0], [3.0, 1.5]),
            ([12.0, 3.0], [1.0, 4.0]),
            ([-11.5, -2.0], [2.0, 2.5]),
            ([4.0, -13.0], [5.0, 1.0]),
            ([-5.0, 12.5], [1.5, 1.5]),
            ([9.0, 10.0], [2.5, 1.0]),
        ];
        let mut scene: Vec<[f64; 2]> = Vec::new();
        for (centre, size) in boxes {
            let (x0, x1) = (centre[0] - size[0] / 2.0, centre[0] + size[0] / 2.0);
            let (y0, y1) = (centre[1] - size[1] / 2.0, centre[1] + size[1] / 2.0);
            let mut t = 0.0;
            while t < 1.0 {
                scene.push([x0 + t * (x1 - x0), y0]);
                scene.push([x0 + t * (x1 - x0), y1]);
                scene.push([x0, y0 + t * (y1 - y0)]);
                scene.push([x1, y0 + t * (y1 - y0)]);
                t += 0.1 / size[0].max(size[1]);
            }
        }
        let mut slam = Association::new(Params::default()).unwrap();
        for k in 0..count {
            let angle = f64::from(k) * step_rad;
            let pose = Pose2::new(
                radius_m * angle.cos(),
                radius_m * angle.sin(),
                angle + std::f64::consts::FRAC_PI_2,
            );
            let to_agv = pose.inverse();
            let scan = scene.iter().map(|p| to_agv.transform_point(*p)).collect();
            push_keyframe(&mut slam, pose, scan);
            if k > 0 {
                let previous = slam.records[k as usize - 1].pose;
                let step = previous.between(&pose);
                let edge = Edge::with_std(
                    k as usize - 1,
                    k as usize,
                    step,
                    0.05,
                    0.01,
                    EdgeKind::Odometry,
                );
                slam.uncertainty_information.push(edge.information);
                assert!(slam.graph.add_edge(edge));
            }
        }
        slam
    }

    #[test]
    fn a_match_the_oracle_refuses_is_neither_accepted_nor_kept_pending() {
        // Without the oracle, the revisit closes a loop on its exact scans.
        let mut slam = one_lap_in_a_scene_of_boxes();
        let found = slam.close_loop().expect("the revisit closes a loop");
        assert_eq!(slam.loop_edges().len(), 1);
        let anchor = found.query;
        // The revisit's truth 1 m elsewhere: a match of its exact scans is then 1 m off.
        let truth_elsewhere = |slam: &mut Association| {
            for record in &mut slam.records[anchor - 5..] {
                let truth = record.pose;
                record.true_pose = Some(Pose2::new(truth.x_m + 1.0, truth.y_m, truth.yaw_rad));
            }
        };
        // With the oracle and the true poses where the scans were taken, the loop closes too.
        let mut slam = one_lap_in_a_scene_of_boxes();
        slam.params.loop_closure.oracle_max_error_m = 0.5;
        assert!(
            slam.close_loop().is_some(),
            "a right match passes the oracle"
        );
        // When the truth puts the revisit 1 m elsewhere, the same match is 1 m off: refused,
        // and not kept to confirm a later one either.
        let mut slam = one_lap_in_a_scene_of_boxes();
        slam.params.loop_closure.oracle_max_error_m = 0.5;
        truth_elsewhere(&mut slam);
        assert!(slam.close_loop().is_none());
        assert!(slam.loop_edges().is_empty());
        assert!(slam.pending.is_empty(), "{:?}", slam.pending);
        // Where no score is enough to stand alone, the right match waits for a partner; the
        // refused one does not.
        for (oracle_m, shifted, waits) in
            [(0.0, true, true), (0.5, false, true), (0.5, true, false)]
        {
            let mut slam = one_lap_in_a_scene_of_boxes();
            slam.params.loop_closure.standalone_score = 2.0;
            // One old place per search: a second would confirm the first.
            slam.params.loop_closure.max_candidates = 1;
            slam.params.loop_closure.oracle_max_error_m = oracle_m;
            if shifted {
                truth_elsewhere(&mut slam);
            }
            assert!(slam.close_loop().is_none(), "nothing stands alone");
            assert_eq!(
                !slam.pending.is_empty(),
                waits,
                "oracle {oracle_m} m, shifted {shifted}"
            );
        }
    }

    #[test]
    fn oracle_verification_admits_only_edges_within_its_limit_of_the_truth() {
        let mut slam = in_a_row(13, 0.01);
        // Keyframe 9 truly lies 8 m ahead of keyframe 1; this edge says 8.6 m.
        let off = measured(1, 9, 8.6);
        assert!(
            slam.oracle_admits(&off),
            "off by default: every edge passes"
        );
        slam.params.loop_closure.oracle_max_error_m = 0.5;
        assert!(!slam.oracle_admits(&off), "0.6 m off a 0.5 m limit");
        assert!(slam.oracle_admits(&measured(1, 9, 8.4)), "0.4 m off");
        slam.params.loop_closure.oracle_max_error_m = 0.7;
        assert!(slam.oracle_admits(&off), "0.6 m off a 0.7 m limit");
        // The error is the translation's, in the older keyframe's frame: turn the truth of
        // keyframe 9 by 90° about itself and the edge is still 0.6 m off, but turn keyframe 1 and
        // where 9 truly lies from it turns with it.
        slam.records[9].true_pose = Some(Pose2::new(9.0, 0.0, std::f64::consts::FRAC_PI_2));
        assert!(slam.oracle_admits(&off));
        slam.records[1].true_pose = Some(Pose2::new(1.0, 0.0, std::f64::consts::PI));
        assert!(!slam.oracle_admits(&off), "truly 8 m behind keyframe 1");
        assert!(slam.oracle_admits(&measured(1, 9, -8.0)));
        // A keyframe without a true pose cannot be verified, so its matches are refused.
        slam.records[1].true_pose = None;
        assert!(!slam.oracle_admits(&measured(1, 9, -8.0)));
        assert!(
            !slam.oracle_admits(&measured(5, 20, 15.0)),
            "no such keyframe"
        );
    }
}
