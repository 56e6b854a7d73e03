//! Loop detection and verification: has the AGV come back to a place it has mapped?
//!
//! The paper's loop detection module (Sec. III-A: "to reduce the cumulative error caused by
//! environment sensing, loop detection module is generally adopted") is only named there; this is
//! ours. At each new keyframe, old keyframes (at least `min_separation_m` of travel ago) whose
//! estimated position lies within a search radius of the current estimate are candidates. The
//! radius grows with the distance travelled since the candidate, because so does the drift it
//! must cover.
//!
//! A candidate is tested by matching a *query* (the current keyframe and the few before it, in the
//! frame of their middle keyframe, the anchor) against a *submap* (the candidate and its
//! neighbours, in the candidate's frame):
//!
//! 1. **Correlative search.** The submap is rasterised on cells of `search_step_m`
//!    ([`crate::correlative::ProbabilityGrid`]): by default into a binary grid (cells within one
//!    cell of a submap point's are "hit", worth 1), or, with `search_sigma_m` > 0, into a
//!    likelihood field (`exp(-d²/2σ²)` of the distance to the nearest submap point). The rigid
//!    motions on a lattice of translations (within the radius, `search_step_m` apart) and
//!    rotations (± `max_search_rotation_deg`, `search_step_deg` apart) around the predicted
//!    relative pose are scored by the mean grid value at the moved query points (the fraction on
//!    hit cells), times a Gaussian prior on the offset from the prediction (σ =
//!    `prior_sigma_radii` radii, `scattered_prior_sigma_radii` for a query whose detections
//!    scatter). This needs no initial guess closer than the radius, unlike ICP. The best motion
//!    is found by branch and bound ([`crate::correlative::search_with`], after Hess et al.,
//!    "Real-Time Loop Closure in 2D LIDAR SLAM"), which returns exactly what scoring every
//!    motion would, at a fraction of the cost; a second search that leaves out the disc of
//!    `ambiguity_distance_m` around it finds the best score elsewhere
//!    ([`crate::correlative::runner_up`]).
//! 2. **Refinement.** Point-to-line ICP of the search's sample (at most ~400 query points)
//!    from the best motion ([`crate::icp::align`]), with a
//!    correspondence gate (`refine_correspondence_m`) wide enough to pull in a lap's drift.
//!    Least squares then lets the query points that have no counterpart in the submap (a
//!    revisit overlaps its old view only in part) pull the pose off by decimetres, even from
//!    the true pose; so a fine correlative search (`fine_sigma_m`, `fine_step_m`, within
//!    `fine_window_m` and `fine_window_deg` of the ICP's pose) settles the match where the most
//!    query points lie on the submap's outlines. It is a maximum of a likelihood field, robust
//!    to points with no counterpart as Cartographer's final scan-to-submap match is.
//!    When the query's detections scatter by a metre (Δθ 5°), every score near the truth is
//!    about the best and any single maximum is an accident of where the search began; the match
//!    is then the centre of that plateau on the search's grid
//!    ([`crate::correlative::plateau_centre`], `plateau_fraction`), which the caller switches on
//!    by the query's scatter (`plateau_min_scatter_m`).
//! 3. **Verification.** The loop is accepted only when enough query points have a submap point
//!    within `inlier_distance_m` (`min_inlier_ratio`), and the search peak is unambiguous (the
//!    runner-up scores at most `max_ambiguity` of the best): the hall's targets stand on a
//!    regular grid, and a query shifted by one station pitch can look much like the right one.
//!
//! Everything is deterministic: candidates are ordered by distance then id, and the search breaks
//! ties between equal scores by the smallest (rotation, x, y) step.

use crate::correlative::{
    plateau_centre, search_with, Exclusion, Kernel, MultiResolutionGrid, PreparedSearch,
    SearchOptions, SearchWindow,
};
use crate::icp::{align, IcpStatus, PointMap};
use crate::params::{IcpMetric, LoopClosureParams, Params};
use crate::pose::Pose2;

use std::sync::Arc;

/// What [`match_loop_with`] builds from a submap alone, kept between its calls: the ICP's map of
/// the submap (its k-d tree and the local lines fitted so far) and the correlative search's
/// grids. Consecutive keyframes test the same old place with the same submap until a closure
/// moves its keyframes (about 85 % of a hall run's searches reuse a submap, 60 % with the same
/// search radius), and a map or grid is a function of the submap's points and the parameters it
/// is built with, which the entries are found by (bit for bit): a search finds exactly what it
/// would build.
#[derive(Default)]
pub struct LoopCache {
    maps: Vec<(Vec<u64>, [u64; 3], Arc<PointMap>)>,
    grids: Vec<(Vec<u64>, [u64; 3], Arc<MultiResolutionGrid>)>,
}

impl std::fmt::Debug for LoopCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LoopCache")
            .field("maps", &self.maps.len())
            .field("grids", &self.grids.len())
            .finish()
    }
}

/// Submaps a [`LoopCache`] keeps, per kind (the most recently used).
const LOOP_CACHE_ENTRIES: usize = 4;

impl LoopCache {
    /// The entry of `entries` for (`submap`, `params`), made by `build` if there is none.
    fn find_or_build<T, E>(
        entries: &mut Vec<(Vec<u64>, [u64; 3], Arc<T>)>,
        submap: &[u64],
        params: [u64; 3],
        build: impl FnOnce() -> Result<T, E>,
    ) -> Result<Arc<T>, E> {
        if let Some(at) = entries
            .iter()
            .position(|(s, p, _)| *p == params && s.as_slice() == submap)
        {
            let entry = entries.remove(at);
            let value = Arc::clone(&entry.2);
            entries.push(entry);
            return Ok(value);
        }
        let value = Arc::new(build()?);
        if entries.len() == LOOP_CACHE_ENTRIES {
            entries.remove(0);
        }
        entries.push((submap.to_vec(), params, Arc::clone(&value)));
        Ok(value)
    }
}

/// A verified loop: the measured pose of the query keyframe in the candidate's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopMatch {
    /// Index (id) of the old keyframe the query matched; set by the caller, 0 from
    /// [`match_loop`].
    pub candidate: usize,
    /// Index (id) of the query keyframe whose pose `relative` measures; set by the caller, 0
    /// from [`match_loop`].
    pub query: usize,
    /// Measured relative pose (query keyframe in candidate keyframe's frame).
    pub relative: Pose2,
    /// Fraction of query points within `inlier_distance_m` of the submap after refinement.
    pub inlier_ratio: f64,
    /// Best correlative score: the mean grid value at the query points moved by the search's
    /// best motion, without the prior (with the default binary grid, the fraction of query
    /// points on hit cells).
    pub score: f64,
    /// Best score at least `ambiguity_distance_m` away from the best motion, in the same units
    /// (`score` times the ratio of the two motions' prior-weighted scores); 0 when none reaches
    /// `max_ambiguity` of the best (the search looks no further).
    pub runner_up: f64,
    /// Point-to-line information per inlier pair over (x m, y m, yaw rad), translation in the
    /// candidate's frame, heading about the query keyframe: what the match pins down, direction
    /// by direction (see [`LoopMatch::constraint`]).
    pub information: [[f64; 3]; 3],
}

impl LoopMatch {
    /// The smallest eigenvalue of [`LoopMatch::information`]: 0 when the query can slide along
    /// a straight edge, 0.5 with edges in every direction.
    pub fn constraint(&self) -> f64 {
        weakest_translation_information(&self.information).max(0.0)
    }
}

/// Why a candidate was not accepted (for logs and tests).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LoopRejection {
    /// Fewer than `min_points` points in the query or submap.
    TooFewPoints,
    /// The refinement did not converge.
    IcpFailed,
    /// Too few inliers after refinement.
    LowInlierRatio(f64),
    /// The search peak, or the refinement from it, lies on the edge of the searched window (the
    /// radius or the rotation range): the best motion may be outside it, where neither the
    /// search nor the ambiguity test has looked. In a hall whose targets repeat, this is how a
    /// drift larger than the window shows up: as a match one station pitch off at its edge.
    AtSearchEdge,
    /// The search peak was not distinct.
    Ambiguous {
        /// Best score.
        score: f64,
        /// Runner-up score.
        runner_up: f64,
    },
}

/// A runner-up's score at least `ambiguity_distance_m` from `best`'s motion, in `best`'s units: a
/// mean grid value scaled by the prior as `best.mean_value` is. Only a runner-up scoring at least
/// `max_ambiguity` of the best is looked for (that is all the verifier asks, and branch and bound
/// prunes the rest), and the search stops at the first that makes the match ambiguous: that one's
/// score, which may be below the highest runner-up's (a whole-map search of a repetitive hall
/// then costs half as much). When the match is not ambiguous the answer is the highest runner-up
/// at or above the fraction, or 0 when none is.
fn runner_up_mean_value(
    search: &mut PreparedSearch,
    best: &crate::correlative::Match,
    loop_params: &LoopClosureParams,
) -> f64 {
    let min_score = loop_params.max_ambiguity * best.score;
    let away = Exclusion::around(best, loop_params.ambiguity_distance_m);
    let scaled = |score: f64| {
        if best.score > 0.0 {
            best.mean_value * score / best.score
        } else {
            0.0
        }
    };
    // The very comparison match_loop makes, so that stopping early never changes its verdict.
    let ambiguous = |score: f64| scaled(score) > loop_params.max_ambiguity * best.mean_value;
    search
        .first_outside_where(Some(away), min_score, ambiguous)
        .ok()
        .flatten()
        .map_or(0.0, |m| scaled(m.score))
}

/// (inliers, overlapping): query points within `inlier_distance_m` + `slack_m` of the map after
/// `relative`, and those within `overlap_distance_m` + `slack_m` (every point when it is 0).
fn inliers_and_overlap(
    map: &PointMap,
    query_m: &[[f64; 2]],
    relative: &Pose2,
    loop_params: &LoopClosureParams,
    slack_m: f64,
) -> (usize, usize) {
    let inlier_m2 = (loop_params.inlier_distance_m + slack_m).powi(2);
    let overlap_m2 = (loop_params.overlap_distance_m + slack_m).powi(2);
    let (mut inliers, mut overlapping) = (0usize, 0usize);
    for p in query_m {
        let d2 = map
            .nearest(&relative.transform_point(*p))
            .map_or(f64::INFINITY, |(_, d2)| d2);
        if loop_params.overlap_distance_m <= 0.0 || d2 <= overlap_m2 {
            overlapping += 1;
        }
        if d2 <= inlier_m2 {
            inliers += 1;
        }
    }
    (inliers, overlapping)
}

/// Matches `query_m` (points in the query keyframe's frame) against `submap_m` (points in the
/// candidate keyframe's frame), starting from the predicted relative pose `predicted` and
/// searching translations within `radius_m`.
pub fn match_loop(
    query_m: &[[f64; 2]],
    submap_m: &[[f64; 2]],
    predicted: Pose2,
    radius_m: f64,
    loop_params: &LoopClosureParams,
    icp_params: &Params,
) -> Result<LoopMatch, LoopRejection> {
    match_loop_with(
        query_m,
        submap_m,
        predicted,
        radius_m,
        loop_params,
        icp_params,
        &mut LoopCache::default(),
    )
}

/// [`match_loop`], taking the submap's ICP map and search grids from `cache` when an earlier
/// call built them for the same submap and parameters (the same result either way).
pub fn match_loop_with(
    query_m: &[[f64; 2]],
    submap_m: &[[f64; 2]],
    predicted: Pose2,
    radius_m: f64,
    loop_params: &LoopClosureParams,
    icp_params: &Params,
    cache: &mut LoopCache,
) -> Result<LoopMatch, LoopRejection> {
    let min_points = loop_params.min_points as usize;
    if query_m.len() < min_points || submap_m.len() < min_points {
        return Err(LoopRejection::TooFewPoints);
    }
    // Non-finite points say nothing about the place; the search refuses them.
    let finite = |p: &&[f64; 2]| p[0].is_finite() && p[1].is_finite();
    let query_m: Vec<[f64; 2]> = query_m.iter().filter(finite).copied().collect();
    let submap_m: Vec<[f64; 2]> = submap_m.iter().filter(finite).copied().collect();
    if query_m.len() < min_points || submap_m.len() < min_points {
        return Err(LoopRejection::TooFewPoints);
    }
    // At most ~400 query points for the search: a deterministic stride keeps the cost bounded.
    let stride = query_m.len().div_ceil(400).max(1);
    let sample: Vec<[f64; 2]> = query_m.iter().step_by(stride).copied().collect();
    let step_m = loop_params.search_step_m;
    let submap_bits: Vec<u64> = submap_m
        .iter()
        .flat_map(|p| [p[0].to_bits(), p[1].to_bits()])
        .collect();
    let grids = LoopCache::find_or_build(
        &mut cache.grids,
        &submap_bits,
        [
            radius_m.to_bits(),
            loop_params.search_step_m.to_bits(),
            loop_params.search_sigma_m.to_bits(),
        ],
        || search_grids(&submap_m, radius_m, loop_params),
    )?;

    let steps_t = (radius_m / step_m).ceil() as i64;
    let step_rad = loop_params.search_step_deg.to_radians();
    let steps_r = (loop_params.max_search_rotation_deg / loop_params.search_step_deg).ceil() as i64;
    let window = SearchWindow {
        linear_m: radius_m,
        angular_rad: loop_params.max_search_rotation_deg.to_radians(),
    };
    // The prior on the offset from the prediction breaks near-ties in halls like ours whose
    // targets repeat on a grid: a query shifted by one station pitch can fit as well as the
    // right one, but is farther from where the pose graph says the AGV is.
    let options = SearchOptions {
        angular_step_rad: Some(step_rad),
        prior_sigma_m: Some(loop_params.prior_sigma_radii * radius_m.max(step_m)),
        exclude: None,
    };
    // The best motion, and later the runner-up, from one preparation of the sample's cells.
    let mut search = PreparedSearch::new(&grids, &sample, predicted, &window, &options)
        .map_err(|_| LoopRejection::TooFewPoints)?;
    let best = search
        .best_outside(None, 0.0)
        .ok()
        .flatten()
        .ok_or(LoopRejection::TooFewPoints)?;
    // A peak on the window's edge (outermost ring of translations or of rotations) is a
    // truncated slope, not a verified maximum.
    let edge_m = (radius_m - step_m).max(0.0);
    let edge_rad = steps_r as f64 * step_rad - 0.5 * step_rad;
    // A search over every heading (±180°, as fusion's search for an agent whose start is
    // unknown) has no rotation edge: its outermost rotations are neighbours of each other.
    let full_circle = loop_params.max_search_rotation_deg >= 180.0;
    let outside = |motion: &Pose2| {
        motion.distance_m(&predicted) > edge_m + 1e-9
            || (!full_circle && motion.rotation_to_rad(&predicted) > edge_rad.max(0.0))
    };
    if steps_t > 0 && steps_r > 0 && outside(&best.pose) {
        return Err(LoopRejection::AtSearchEdge);
    }

    // Refinement: ICP of the query against the submap, from the search's best motion. The
    // cheap refusals come first: a hopeless overlap, then an ambiguous peak (a second search).
    let refine = Params {
        max_correction_m: 2.0 * step_m + 1.0,
        max_correction_deg: 2.0 * loop_params.search_step_deg + 5.0,
        ..icp_params.clone()
    };
    // What PointMap::for_params reads of `refine`.
    let map_params = [
        match refine.metric {
            IcpMetric::PointToPoint => 0,
            IcpMetric::PointToLine => 1,
        },
        u64::from(refine.line_neighbours),
        refine.max_correspondence_m.to_bits(),
    ];
    let map = LoopCache::find_or_build(&mut cache.maps, &submap_bits, map_params, || {
        let mut map = PointMap::for_params(&refine);
        map.extend(&submap_m);
        Ok::<_, LoopRejection>(map)
    })?;
    let map: &PointMap = &map;
    refuse_hopeless(map, &sample, &best.pose, loop_params)?;
    let runner_up = runner_up_mean_value(&mut search, &best, loop_params);
    let score = best.mean_value;
    if runner_up > loop_params.max_ambiguity * score {
        return Err(LoopRejection::Ambiguous { score, runner_up });
    }
    // The ICP's gate is wide enough to pull a lap's drift in, and then lets query points with no
    // counterpart in the submap pull at the pose; the fine search settles it where the most
    // points lie on submap outlines.
    // On the search's sample, as the fine search is: the full query made the ICP a third of the
    // loop search's time and moved no study figure beyond its noise (docs/slam-log.md).
    let relative = refine_match(map, &sample, best.pose, &refine)?;
    let relative = fine_search(&submap_m, &sample, relative, loop_params);
    let relative = plateau_centre_of(&grids, &sample, relative, loop_params);
    if steps_t > 0 && steps_r > 0 && outside(&relative) {
        return Err(LoopRejection::AtSearchEdge);
    }
    let inlier_m2 = loop_params.inlier_distance_m * loop_params.inlier_distance_m;
    let (inliers, overlapping) = inliers_and_overlap(map, &query_m, &relative, loop_params, 0.0);
    if (overlapping as f64) < loop_params.min_overlap_ratio * query_m.len() as f64
        || overlapping < min_points
    {
        return Err(LoopRejection::TooFewPoints);
    }
    let inlier_ratio = inliers as f64 / overlapping as f64;
    if inlier_ratio < loop_params.min_inlier_ratio {
        return Err(LoopRejection::LowInlierRatio(inlier_ratio));
    }
    let information = match_information(map, &query_m, &relative, inlier_m2);
    Ok(LoopMatch {
        candidate: 0,
        query: 0,
        relative,
        inlier_ratio,
        score,
        runner_up,
        information,
    })
}

/// The search's grids of `submap_m` for a window of `radius_m`: a binary raster, or a Gaussian
/// likelihood field when `search_sigma_m` > 0. A grid that cannot be built (a runaway extent:
/// points kilometres apart) is not a submap worth searching.
fn search_grids(
    submap_m: &[[f64; 2]],
    radius_m: f64,
    loop_params: &LoopClosureParams,
) -> Result<MultiResolutionGrid, LoopRejection> {
    let step_m = loop_params.search_step_m;
    let kernel = if loop_params.search_sigma_m > 0.0 {
        Kernel::Gaussian {
            sigma_m: loop_params.search_sigma_m,
        }
    } else {
        Kernel::Hit { cells: 1 }
    };
    MultiResolutionGrid::for_window(submap_m, step_m, kernel, radius_m)
        .map_err(|_| LoopRejection::TooFewPoints)
}

/// The fine correlative search that settles a refined match (`LoopClosureParams::fine_sigma_m`):
/// the motion within the fine window of `refined` that maximises the mean likelihood of
/// `sample` on the submap's field; `refined` itself when the search is off or finds nothing.
fn fine_search(
    submap_m: &[[f64; 2]],
    sample: &[[f64; 2]],
    refined: Pose2,
    loop_params: &LoopClosureParams,
) -> Pose2 {
    let (sigma_m, step_m) = (loop_params.fine_sigma_m, loop_params.fine_step_m);
    if sigma_m <= 0.0 {
        return refined;
    }
    // Only the submap points whose blur the moved sample can reach enter the field: the
    // search moves a point by at most the window's translation plus its rotation times the
    // point's distance from the query's origin.
    let moved: Vec<[f64; 2]> = sample.iter().map(|p| refined.transform_point(*p)).collect();
    let farthest_m = moved
        .iter()
        .map(|p| (p[0] - refined.x_m).hypot(p[1] - refined.y_m))
        .fold(0.0, f64::max);
    let margin_m = loop_params.fine_window_m
        + farthest_m * loop_params.fine_window_deg.to_radians()
        + 3.0 * sigma_m
        + 2.0 * step_m;
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &moved {
        for axis in 0..2 {
            lo[axis] = lo[axis].min(p[axis] - margin_m);
            hi[axis] = hi[axis].max(p[axis] + margin_m);
        }
    }
    let reachable: Vec<[f64; 2]> = submap_m
        .iter()
        .filter(|p| (0..2).all(|axis| (lo[axis]..=hi[axis]).contains(&p[axis])))
        .copied()
        .collect();
    if reachable.is_empty() {
        return refined;
    }
    // A field too large for the grid's limits (a tiny step over a wide window) leaves the
    // ICP's pose, said in the log, rather than refusing every loop.
    let kernel = Kernel::Gaussian { sigma_m };
    let field =
        MultiResolutionGrid::for_window(&reachable, step_m, kernel, loop_params.fine_window_m);
    let grids = match field {
        Ok(grids) => grids,
        Err(error) => {
            tracing::warn!(%error, "loop closure: no fine search, the ICP's pose stands");
            return refined;
        }
    };
    let window = SearchWindow {
        linear_m: loop_params.fine_window_m,
        angular_rad: loop_params.fine_window_deg.to_radians(),
    };
    let options = SearchOptions {
        angular_step_rad: None,
        prior_sigma_m: None,
        exclude: None,
    };
    search_with(&grids, sample, refined, &window, &options, 0.0)
        .ok()
        .flatten()
        .map_or(refined, |found| found.pose)
}

/// The centre of the plateau of near-best scores around `settled` on the search's grid
/// (`LoopClosureParams::plateau_fraction`), without the prior: the prior pulls the arg-max of a
/// flat score towards the prediction, whose drift is what the loop is there to measure.
/// `settled` itself when the plateau estimate is off or finds nothing.
fn plateau_centre_of(
    grids: &MultiResolutionGrid,
    sample: &[[f64; 2]],
    settled: Pose2,
    loop_params: &LoopClosureParams,
) -> Pose2 {
    if loop_params.plateau_fraction <= 0.0 {
        return settled;
    }
    let window = SearchWindow {
        linear_m: loop_params.plateau_window_m,
        angular_rad: loop_params.plateau_window_deg.to_radians(),
    };
    let options = SearchOptions {
        angular_step_rad: Some(loop_params.search_step_deg.to_radians()),
        prior_sigma_m: None,
        exclude: None,
    };
    let found = plateau_centre(
        grids.grid(),
        sample,
        settled,
        &window,
        &options,
        loop_params.plateau_fraction,
    );
    match found {
        Ok(Some((centre, _))) => centre,
        Ok(None) => settled,
        Err(error) => {
            tracing::warn!(%error, "loop closure: no plateau estimate, the fine search's pose stands");
            settled
        }
    }
}

/// Refuses a candidate whose inlier ratio at the search's `best` motion of the query's `sample`
/// falls short even with two lattice steps of slack: refinement moves that motion by about a
/// step, so it cannot pass after it (and on such a candidate the ICP creeps through all its
/// iterations).
fn refuse_hopeless(
    map: &PointMap,
    sample: &[[f64; 2]],
    best: &Pose2,
    loop_params: &LoopClosureParams,
) -> Result<(), LoopRejection> {
    let slack_m = 2.0 * loop_params.search_step_m;
    let (inliers, overlapping) = inliers_and_overlap(map, sample, best, loop_params, slack_m);
    if (inliers as f64) < loop_params.min_inlier_ratio * overlapping as f64 {
        return Err(LoopRejection::LowInlierRatio(
            inliers as f64 / overlapping.max(1) as f64,
        ));
    }
    Ok(())
}

/// Refines the search's `best` motion of the query `query_m` against the submap `map` by ICP
/// with the `refine` parameters.
fn refine_match(
    map: &PointMap,
    query_m: &[[f64; 2]],
    best: Pose2,
    refine: &Params,
) -> Result<Pose2, LoopRejection> {
    let icp = align(map, query_m, best, refine);
    if !matches!(icp.status, IcpStatus::Converged | IcpStatus::MaxIterations) {
        return Err(LoopRejection::IcpFailed);
    }
    Ok(icp.pose)
}

/// How well the inlier pairs pin the query down, direction by direction: the point-to-line
/// information of the match over (x m, y m, yaw rad) — translation in the candidate's frame,
/// heading about the query's origin (the anchor keyframe) — per inlier pair. A pair whose
/// submap point has the unit normal n contributes J Jᵀ with J = (n, n × (moved point − t)):
/// pairs on normals spread over all directions pin every direction down, and pairs on one
/// straight edge leave the slide along it free (Zhang, Kaess and Singh, "On degeneracy of
/// optimization-based state estimation problems", ICRA 2016). Zero when no pair has a normal.
fn match_information(
    map: &PointMap,
    query_m: &[[f64; 2]],
    relative: &Pose2,
    inlier_m2: f64,
) -> [[f64; 3]; 3] {
    let mut h = [[0.0f64; 3]; 3];
    let mut pairs = 0usize;
    for p in query_m {
        let moved = relative.transform_point(*p);
        let Some((index, d2)) = map.nearest_index(&moved) else {
            continue;
        };
        if d2 > inlier_m2 {
            continue;
        }
        let Some(n) = map.normal(index) else {
            continue;
        };
        // d(R p + t)/dθ is R p turned by 90°, with R p = moved − t.
        let rp = [moved[0] - relative.x_m, moved[1] - relative.y_m];
        let j = [n[0], n[1], n[1] * rp[0] - n[0] * rp[1]];
        for (a, row) in h.iter_mut().enumerate() {
            for (b, cell) in row.iter_mut().enumerate() {
                *cell += j[a] * j[b];
            }
        }
        pairs += 1;
    }
    if pairs > 0 {
        for cell in h.iter_mut().flatten() {
            *cell /= pairs as f64;
        }
    }
    h
}

/// The information along the weakest translation direction of `information` (over x m, y m,
/// yaw rad) once the heading is free: the smallest eigenvalue of [`translation_marginal`], m⁻²
/// for an edge's information. Small when the match can slide along a straight side.
pub fn weakest_translation_information(information: &[[f64; 3]; 3]) -> f64 {
    symmetric_eigen_2x2(&translation_marginal(information)).1
}

/// The translation block of `information` once the heading is free (its Schur complement).
pub fn translation_marginal(information: &[[f64; 3]; 3]) -> [[f64; 2]; 2] {
    let h = information;
    if h[2][2] <= 0.0 {
        return [[h[0][0], h[0][1]], [h[1][0], h[1][1]]];
    }
    let m = |a: usize, b: usize| h[a][b] - h[a][2] * h[2][b] / h[2][2];
    [[m(0, 0), m(0, 1)], [m(1, 0), m(1, 1)]]
}

/// Eigenvalues (largest first) and the unit eigenvector of the largest of a symmetric 2×2 matrix.
pub fn symmetric_eigen_2x2(m: &[[f64; 2]; 2]) -> (f64, f64, [f64; 2]) {
    let (xx, xy, yy) = (m[0][0], 0.5 * (m[0][1] + m[1][0]), m[1][1]);
    let half_trace = 0.5 * (xx + yy);
    let root = (0.25 * (xx - yy) * (xx - yy) + xy * xy).sqrt();
    let angle = 0.5 * (2.0 * xy).atan2(xx - yy);
    (
        half_trace + root,
        half_trace - root,
        [angle.cos(), angle.sin()],
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Outlines of a few boxes of different sizes at irregular places, every 0.2 m.
    fn scene() -> Vec<[f64; 2]> {
        let mut points = Vec::new();
        for &(x0, y0, w, h) in &[
            (2.0, 3.0, 4.0, 2.0),
            (9.0, 1.0, 1.5, 3.0),
            (4.0, 9.0, 3.0, 1.0),
            (11.0, 8.0, 2.0, 2.0),
            (-3.0, 6.0, 1.0, 4.0),
        ] {
            let corners = [[x0, y0], [x0 + w, y0], [x0 + w, y0 + h], [x0, y0 + h]];
            for i in 0..4 {
                let (a, b): ([f64; 2], [f64; 2]) = (corners[i], corners[(i + 1) % 4]);
                let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / 0.2).round() as usize;
                for k in 0..n {
                    let s = k as f64 / n as f64;
                    points.push([a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])]);
                }
            }
        }
        points
    }

    fn seen_from(pose: &Pose2, points: &[[f64; 2]]) -> Vec<[f64; 2]> {
        let inv = pose.inverse();
        points.iter().map(|p| inv.transform_point(*p)).collect()
    }

    /// [`match_loop`] of `points` seen from `query` against them seen from `candidate`, from
    /// `predicted` in a 4 m window.
    fn match_views(
        points: &[[f64; 2]],
        candidate: &Pose2,
        query: &Pose2,
        predicted: Pose2,
        params: &LoopClosureParams,
    ) -> Result<LoopMatch, LoopRejection> {
        match_loop(
            &seen_from(query, points),
            &seen_from(candidate, points),
            predicted,
            4.0,
            params,
            &Params::default(),
        )
    }

    /// The scene, a candidate keyframe's pose and a query pose that revisits it, and the true
    /// motion from the candidate to the query.
    fn revisit() -> (Vec<[f64; 2]>, Pose2, Pose2, Pose2) {
        let candidate = Pose2::new(0.0, 0.0, 0.3);
        let query = Pose2::new(1.0, 0.5, 0.35);
        (scene(), candidate, query, candidate.between(&query))
    }

    #[test]
    fn a_straight_edge_leaves_the_slide_along_it_free_and_boxes_pin_everything() {
        let params = Params::default();
        let line: Vec<[f64; 2]> = (0..100).map(|i| [f64::from(i) * 0.1, 5.0]).collect();
        let mut map = PointMap::for_params(&params);
        map.extend(&line);
        let along_line = match_information(&map, &line, &Pose2::new(0.0, 0.0, 0.0), 0.25);
        let marginal = translation_marginal(&along_line);
        // Normals are ±y: all the information is across the line (a quarter of it is left once
        // the heading, which also moves points across the line, is free: 1 − E[x]²/E[x²]).
        assert!(marginal[1][1] > 0.2, "{marginal:?}");
        assert!(marginal[0][0].abs() < 1e-6, "{marginal:?}");

        let boxes = scene();
        let mut map = PointMap::for_params(&params);
        map.extend(&boxes);
        let found = LoopMatch {
            candidate: 0,
            query: 0,
            relative: Pose2::new(0.0, 0.0, 0.0),
            inlier_ratio: 1.0,
            score: 1.0,
            runner_up: 0.0,
            information: match_information(&map, &boxes, &Pose2::new(0.0, 0.0, 0.0), 0.25),
        };
        assert!(found.constraint() > 0.08, "{found:?}");
        let straight = LoopMatch {
            information: along_line,
            ..found
        };
        assert!(straight.constraint() < 1e-6, "{straight:?}");
    }

    #[test]
    fn a_kept_submap_gives_what_a_fresh_one_gives() {
        // One cache through searches of two submaps at several predictions and radii (the
        // second search of each reuses the first's map and grids): every result equals the
        // uncached search's, refusals included.
        let (points, candidate, query, truth) = revisit();
        let (lc, icp) = (LoopClosureParams::default(), Params::default());
        let query_m = seen_from(&query, &points[..points.len() * 2 / 3]);
        let other = seen_from(&Pose2::new(5.0, -3.0, 1.0), &points);
        let mut cache = LoopCache::default();
        for submap in [seen_from(&candidate, &points), other] {
            for (offset, radius_m) in [
                (Pose2::new(1.6, -1.2, 0.1), 3.0),
                (Pose2::new(-0.4, 0.7, -0.05), 3.0),
                (Pose2::new(0.3, 0.2, 0.02), 6.0),
            ] {
                let predicted = truth.compose(&offset);
                let fresh = match_loop(&query_m, &submap, predicted, radius_m, &lc, &icp);
                let kept = match_loop_with(
                    &query_m, &submap, predicted, radius_m, &lc, &icp, &mut cache,
                );
                assert_eq!(fresh, kept, "offset {offset:?}, radius {radius_m} m");
            }
        }
        assert_eq!((cache.maps.len(), cache.grids.len()), (2, 4));
    }

    #[test]
    fn the_weakest_translation_information_frees_the_heading_first() {
        // Without coupling to the heading it is the smaller translation diagonal.
        let decoupled = [[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 10.0]];
        assert!((weakest_translation_information(&decoupled) - 1.0).abs() < 1e-12);
        // Coupling y to the heading lets a turn explain part of a shift in y: less is pinned.
        let coupled = [[4.0, 0.0, 0.0], [0.0, 1.0, 2.0], [0.0, 2.0, 10.0]];
        assert!((weakest_translation_information(&coupled) - (1.0 - 4.0 / 10.0)).abs() < 1e-12);
    }

    #[test]
    fn eigen_2x2_returns_the_largest_first_with_its_axis() {
        let (largest, smallest, axis) = symmetric_eigen_2x2(&[[1.0, 1.0], [1.0, 1.0]]);
        assert!((largest - 2.0).abs() < 1e-12 && smallest.abs() < 1e-12);
        let diagonal = std::f64::consts::FRAC_1_SQRT_2;
        assert!((axis[0].abs() - diagonal).abs() < 1e-12 && (axis[0] - axis[1]).abs() < 1e-12);
        let (largest, smallest, axis) = symmetric_eigen_2x2(&[[0.1, 0.0], [0.0, 3.0]]);
        assert!((largest - 3.0).abs() < 1e-12 && (smallest - 0.1).abs() < 1e-12);
        assert!(axis[0].abs() < 1e-12 && (axis[1].abs() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn finds_a_loop_several_metres_off_the_prediction() {
        let (points, candidate, query, truth) = revisit();
        let predicted = truth.compose(&Pose2::new(1.6, -1.2, 6f64.to_radians()));
        let found = match_views(
            &points,
            &candidate,
            &query,
            predicted,
            &LoopClosureParams::default(),
        )
        .unwrap();
        assert!(found.relative.distance_m(&truth) < 0.05, "{found:?}");
        assert!(found.relative.rotation_to_rad(&truth) < 0.5f64.to_radians());
        assert!(found.inlier_ratio > 0.95);
        // The likelihood-field raster finds it too.
        let blurred = LoopClosureParams {
            search_sigma_m: 0.2,
            ..LoopClosureParams::default()
        };
        let found = match_views(&points, &candidate, &query, predicted, &blurred).unwrap();
        assert!(found.relative.distance_m(&truth) < 0.05, "{found:?}");
        assert!(found.score > 0.8 && found.score < 1.0, "{found:?}");
    }

    #[test]
    fn the_fine_search_settles_a_match_near_the_truth_and_off_leaves_it() {
        let (points, candidate, query, truth) = revisit();
        let submap = seen_from(&candidate, &points);
        let sample = seen_from(&query, &points);
        let off = truth.compose(&Pose2::new(0.15, -0.1, 0.8f64.to_radians()));
        let params = LoopClosureParams::default();
        let settled = fine_search(&submap, &sample, off, &params);
        assert!(settled.distance_m(&truth) < 0.05, "{settled:?}");
        assert!(
            settled.rotation_to_rad(&truth) < 0.3f64.to_radians(),
            "{settled:?}"
        );
        let without = LoopClosureParams {
            fine_sigma_m: 0.0,
            ..params.clone()
        };
        assert_eq!(fine_search(&submap, &sample, off, &without), off);
        // A field beyond the grid's limits leaves the pose too.
        let huge = LoopClosureParams {
            fine_step_m: 0.001,
            fine_window_m: 10.0,
            ..params.clone()
        };
        assert_eq!(fine_search(&submap, &sample, off, &huge), off);
        // A query with nothing near the submap keeps its pose.
        let far: Vec<[f64; 2]> = sample.iter().map(|p| [p[0] + 100.0, p[1]]).collect();
        assert_eq!(fine_search(&submap, &far, off, &params), off);
    }

    #[test]
    fn points_with_no_counterpart_do_not_pull_the_settled_match() {
        let (points, candidate, query, truth) = revisit();
        // The query also sees a wall the submap does not hold, 0.5 m beside the long side of
        // the first box, as many points as that side has: least squares would split the
        // difference, the likelihood field's maximum does not.
        let mut seen: Vec<[f64; 2]> = points.clone();
        seen.extend((0..20).map(|k| [2.0 + 0.2 * f64::from(k), 2.5]));
        let sample = seen_from(&query, &seen);
        let submap = seen_from(&candidate, &points);
        let off = truth.compose(&Pose2::new(-0.1, -0.2, -0.5f64.to_radians()));
        let settled = fine_search(&submap, &sample, off, &LoopClosureParams::default());
        assert!(settled.distance_m(&truth) < 0.05, "{settled:?}");
        assert!(
            settled.rotation_to_rad(&truth) < 0.3f64.to_radians(),
            "{settled:?}"
        );
    }

    #[test]
    fn a_match_beyond_the_window_is_refused_not_truncated() {
        // The truth lies 4.3 m from the prediction, just beyond a 4 m window: the best motion
        // inside is on the window's edge, a truncated slope rather than a verified peak.
        let (points, candidate, query, truth) = revisit();
        let beyond = truth.compose(&Pose2::new(3.44, -2.58, 0.0));
        let outcome = |predicted: Pose2| {
            match_views(
                &points,
                &candidate,
                &query,
                predicted,
                &LoopClosureParams::default(),
            )
        };
        assert_eq!(outcome(beyond), Err(LoopRejection::AtSearchEdge));
        // The same just beyond the rotation window (12°): 13.5° off.
        let turned = truth.compose(&Pose2::new(0.0, 0.0, 13.5f64.to_radians()));
        assert_eq!(outcome(turned), Err(LoopRejection::AtSearchEdge));
        // Well inside both, it is found.
        let inside = truth.compose(&Pose2::new(1.0, 1.0, 4f64.to_radians()));
        assert!(outcome(inside).is_ok());
    }

    #[test]
    fn a_different_place_is_refused() {
        let points = scene();
        let other: Vec<[f64; 2]> = points
            .iter()
            .map(|p| [p[1] * 1.3 - 4.0, -p[0] * 0.7 + 2.0])
            .collect();
        let result = match_loop(
            &seen_from(&Pose2::IDENTITY, &points),
            &other,
            Pose2::IDENTITY,
            3.0,
            &LoopClosureParams::default(),
            &Params::default(),
        );
        assert!(result.is_err(), "{result:?}");
    }

    #[test]
    fn a_repetitive_row_is_ambiguous() {
        // Identical boxes every 4 m along x, and a prediction halfway between the truth and a
        // shift by one pitch: both score alike, prior included.
        let mut points = Vec::new();
        for k in 0..8 {
            let x0 = 4.0 * f64::from(k);
            for i in 0..10 {
                let s = f64::from(i) * 0.2;
                points.extend([[x0 + s, 0.0], [x0 + s, 2.0], [x0, s], [x0 + 2.0, s]]);
            }
        }
        let query: Vec<[f64; 2]> = points
            .iter()
            .filter(|p| p[0] > 8.0 && p[0] < 20.0)
            .copied()
            .collect();
        let result = match_loop(
            &query,
            &points,
            Pose2::new(2.0, 0.0, 0.0),
            6.0,
            &LoopClosureParams::default(),
            &Params::default(),
        );
        assert!(
            matches!(result, Err(LoopRejection::Ambiguous { .. })),
            "{result:?}"
        );
    }

    #[test]
    fn the_prior_breaks_near_ties_but_does_not_overrule_a_better_fit() {
        // 2 m squares of 40 points, as a revisit's query sees one and as the submap holds
        // several 4 m apart along x. The prediction is 1 m from the square at x = 4 and 3 m
        // from the one at x = 0 (drift, as in a revisit the pose graph has not yet corrected).
        let square = |x0: f64| -> Vec<[f64; 2]> {
            let corners = [[x0, 0.0], [x0 + 2.0, 0.0], [x0 + 2.0, 2.0], [x0, 2.0]];
            (0..4)
                .flat_map(|i| {
                    let (a, b) = (corners[i], corners[(i + 1) % 4]);
                    (0..10).map(move |k| {
                        let t = f64::from(k) / 10.0;
                        [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
                    })
                })
                .collect()
        };
        let query = square(0.0);
        let predicted = Pose2::new(3.0, 0.0, 0.0);
        let search = |submap: &[[f64; 2]], params: &LoopClosureParams| {
            match_loop(&query, submap, predicted, 6.0, params, &Params::default())
        };
        let defaults = LoopClosureParams::default();

        // A tie: two whole squares. The prior takes the one nearer the prediction (with the
        // ambiguity test off, which would refuse a tie).
        let twins = [square(0.0), square(4.0)].concat();
        let tie_params = LoopClosureParams {
            max_ambiguity: 1.0,
            ..defaults.clone()
        };
        let nearer = search(&twins, &tie_params).unwrap();
        assert!(
            nearer.relative.distance_m(&Pose2::new(4.0, 0.0, 0.0)) < 0.5,
            "{nearer:?}"
        );

        // No tie: the square at x = 4 has only its bottom and left sides (points 0..10 and
        // 30..40). The whole square fits better, and the prior does not overrule that.
        let partial = square(4.0);
        let lookalike = [square(0.0).as_slice(), &partial[..10], &partial[30..]].concat();
        let found = search(&lookalike, &defaults).unwrap();
        assert!(
            found.relative.distance_m(&Pose2::IDENTITY) < 0.5,
            "{found:?}"
        );
        assert!(found.score > 0.95, "{found:?}");

        // Under a prior half as wide, the whole square still scores best, but the partial
        // one's score times its prior comes so close that the right loop is refused as
        // ambiguous.
        let tight = search(
            &lookalike,
            &LoopClosureParams {
                prior_sigma_radii: 0.5,
                ..defaults
            },
        );
        assert!(
            matches!(tight, Err(LoopRejection::Ambiguous { score, .. }) if score > 0.95),
            "{tight:?}"
        );
    }

    #[test]
    fn non_finite_points_are_ignored() {
        let (points, candidate, query, truth) = revisit();
        let mut query_m = seen_from(&query, &points);
        let mut submap_m = seen_from(&candidate, &points);
        query_m.insert(3, [f64::NAN, 1.0]);
        submap_m.push([0.0, f64::INFINITY]);
        let found = match_loop(
            &query_m,
            &submap_m,
            truth.compose(&Pose2::new(0.7, -0.4, 3f64.to_radians())),
            3.0,
            &LoopClosureParams::default(),
            &Params::default(),
        )
        .unwrap();
        assert!(found.relative.distance_m(&truth) < 0.05, "{found:?}");
        assert!(found.inlier_ratio > 0.95 && found.score > 0.8, "{found:?}");
        // Nothing but non-finite points is too few.
        let result = match_loop(
            &[[f64::NAN, 0.0]; 50],
            &submap_m,
            truth,
            3.0,
            &LoopClosureParams::default(),
            &Params::default(),
        );
        assert_eq!(result, Err(LoopRejection::TooFewPoints));
    }

    #[test]
    fn too_few_points_are_refused() {
        let result = match_loop(
            &[[0.0, 1.0]; 5],
            &scene(),
            Pose2::IDENTITY,
            3.0,
            &LoopClosureParams::default(),
            &Params::default(),
        );
        assert_eq!(result, Err(LoopRejection::TooFewPoints));
    }
}
