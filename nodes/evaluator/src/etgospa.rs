//! ET-GOPSA, the extended-target metric of the paper (Sec. IV-B, eqs. (GOPSA_8)–(GOPSA_5)), in the
//! well-posed form docs/design.md ("Metrics") specifies; this module implements that text literally.
//!
//! Truth: extended targets **x**_i, target i offering s_i slots (by default one per sample point;
//! the paper samples 4 points per target). Estimates: points y_j. With δ the base distance
//! (Euclidean, or its square with `squared_distance`, the paper's eq. (GOPSA_55) taken literally):
//!
//! - D_i(y) = min(c, δ(y, target i))^p, δ to the nearest sample point of target i
//!   (`distance = "samples"`, the paper's choice) or to its closed outline polygon
//!   (`distance = "outline"`, the polygon's boundary);
//! - D_{−i}(y) = min_{k ≠ i} D_k(y), or c^p when there is no other target;
//! - assigning y to a slot of target i costs E_i(y) = D_i(y) + (c^p − D_{−i}(y)) ∈ [0, 2c^p]:
//!   localisation plus confusion (an estimate near another target is ambiguous);
//! - each estimate fills at most one slot; an unfilled slot (missed) and an unassigned estimate
//!   (false) each cost c^p/α;
//! - d = ( min over assignments Σ E + c^p/α · (#missed + #false) )^{1/p}.
//!
//! It keeps the paper's two claims (Sec. IV-B, eqs. (GOPSA_10), (GOPSA_11)): an estimate costs
//! less the closer it is to its target and the farther from the others, and an extra estimate that
//! fills a free slot well (E < c^p/α) lowers the metric. With α = 2, one slot per target and no
//! estimate within c of two targets, the confusion term vanishes on every pair worth taking and
//! d is exactly GOSPA of the targets' points.
//!
//! **Solution.** With S = Σ s_i slots, Y estimates and |γ| filled slots the objective is
//! Σ_γ E + c^p/α (S + Y − 2|γ|): a minimum-weight partial matching of the slots × estimates
//! weights E − 2c^p/α, solved exactly by [`crate::assignment::solve_partial`] (only negative
//! weights are worth taking). Pairs of weight exactly 0 are reported unassigned. Accuracy for
//! large p is as for GOSPA (see [`crate::gospa`](mod@crate::gospa)): use p = ∞ rather than a large finite p.
//!
//! **Components.** With α = 2 a pair whose estimate is c or more from the target weighs
//! c^p − D_{−i}(y) ≥ 0 and is never taken, so, as for GOSPA, the matching splits into the
//! connected components of the (target, estimate) pairs closer than c, found with a uniform grid
//! of the targets' bounding boxes; each component is solved densely with one row per slot (at
//! most as many slots per target as the component has estimates: further slots are identical
//! rows). When such a pair can weigh less than 0 (α < 2 with estimates far from every target)
//! the problem does not split and the dense solver is used ([`etgospa_dense`]), as it is for
//! inputs of at most 16 × 16 slot-estimate pairs.
//!
//! **p = ∞** is the limit p → ∞: (c^p − D_{−i})^{1/p} tends to c when another target is closer
//! than c and to 0 otherwise, so a pair costs max(min(c, δ_i), c·[δ_{−i} < c]) and an unassigned
//! slot or estimate costs c. The value is c unless every slot and estimate can be paired with pair
//! costs below c, then the least possible largest one (bottleneck assignment); 0 when S = Y = 0.
//! See [`EtGospaResult`] for the decomposition reported.

use serde::{Deserialize, Serialize};

use crate::assignment::{check_size, solve_bottleneck, solve_partial, AssignmentError, CostMatrix};
use crate::error::{InvalidMetricParam, MetricError};
use crate::gospa::{pow_p, validate_c_p_alpha, GospaParams};
use crate::inputs::Checked;
use crate::point::{check_finite, distance_to_outline_m, Point2};
use crate::sparse::{solve_components, Box2, Components, Grid, Solved};
use crate::unassigned::Parts;

/// What D_i measures the distance to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DistanceMode {
    /// The nearest of the target's sample points (the paper's choice).
    #[default]
    Samples,
    /// The target's outline: the boundary of its closed polygon.
    Outline,
}

/// ET-GOPSA parameters (docs/design.md "Metrics"; paper Table I: c = 5, p = 1, α = 2; the paper's
/// Fig. 6 uses c = 10).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EtGospaParams {
    /// Cut-off c > 0: metres, or square metres with `squared_distance`.
    pub c: f64,
    /// Order 1 ≤ p < ∞, or `f64::INFINITY` for p = ∞.
    pub p: f64,
    /// 0 < α ≤ 2; an unfilled slot or unassigned estimate costs c^p/α.
    pub alpha: f64,
    /// What D_i measures the distance to.
    pub distance: DistanceMode,
    /// Use the squared Euclidean distance, as the paper's eq. (GOPSA_55) literally writes.
    pub squared_distance: bool,
}

impl Default for EtGospaParams {
    /// The paper's Table I (c = 5, p = 1, α = 2), sample-point distance, not squared.
    fn default() -> Self {
        Self {
            c: 5.0,
            p: 1.0,
            alpha: 2.0,
            distance: DistanceMode::Samples,
            squared_distance: false,
        }
    }
}

impl EtGospaParams {
    /// Checks c > 0 finite, 1 ≤ p ≤ ∞, 0 < α ≤ 2, and c^p within [`crate::gospa::CP_RANGE`].
    ///
    /// # Errors
    /// [`InvalidMetricParam`] naming the first bad field and its allowed range.
    pub fn validate(&self) -> Result<(), InvalidMetricParam> {
        validate_c_p_alpha(self.c, self.p, self.alpha)
    }

    /// The GOSPA parameters with the same c, p, α (GOSPA always uses the plain Euclidean
    /// distance).
    pub fn gospa(&self) -> GospaParams {
        GospaParams {
            c: self.c,
            p: self.p,
            alpha: self.alpha,
        }
    }
}

/// One true extended target: the points and slots ET-GOPSA sees.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ExtendedTarget {
    /// Sample points (metres): the paper's x_{i,k}, used by `distance = "samples"`.
    pub samples: Vec<Point2>,
    /// Outline vertices (metres), a closed polygon without the repeated first vertex, used by
    /// `distance = "outline"`.
    pub outline: Vec<Point2>,
    /// Number of estimates this target can absorb, s_i.
    pub slots: usize,
}

impl ExtendedTarget {
    /// A target with these sample points, one slot per sample and no outline.
    pub fn from_samples(samples: Vec<Point2>) -> Self {
        Self {
            slots: samples.len(),
            samples,
            outline: Vec::new(),
        }
    }

    /// The same target with this outline.
    pub fn with_outline(mut self, outline: Vec<Point2>) -> Self {
        self.outline = outline;
        self
    }

    /// The same target with `slots` slots.
    pub fn with_slots(mut self, slots: usize) -> Self {
        self.slots = slots;
        self
    }
}

/// ET-GOPSA value and its decomposition.
///
/// For 1 ≤ p < ∞ the parts are summed p-th-power contributions of one optimal assignment (units
/// m^p, or m^{2p} with `squared_distance`) and `total = (localisation + confusion + missed +
/// false_estimates)^{1/p}`:
/// - `localisation` = Σ over filled slots (target i, estimate y) of D_i(y);
/// - `confusion` = Σ over filled slots of c^p − D_{−i}(y);
/// - `missed` = c^p/α × unfilled slots;
/// - `false_estimates` = c^p/α × unassigned estimates.
///
/// For p = ∞ the parts are ∞-norms and `total` is their maximum. The assignment is a largest
/// matching among the pairs costing less than c (estimate within c of its target and of no
/// other), with the smallest possible largest distance; `localisation` is that distance (0 if no
/// pair), `confusion` is always 0 (a confused estimate costs c matched or not, so it is left
/// unassigned and shows in `false_estimates`), `missed` is c if a slot is unfilled (else 0),
/// `false_estimates` is c if an estimate is unassigned (else 0).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct EtGospaResult {
    /// The metric: metres, or square metres with `squared_distance`.
    pub total: f64,
    /// Localisation part.
    pub localisation: f64,
    /// Confusion part.
    pub confusion: f64,
    /// Unfilled-slot part.
    pub missed: f64,
    /// Unassigned-estimate part.
    #[serde(rename = "false")]
    pub false_estimates: f64,
    /// Total number of slots, S = Σ s_i.
    pub slot_count: usize,
    /// Number of filled slots.
    pub assigned_count: usize,
    /// Number of unfilled slots.
    pub missed_count: usize,
    /// Number of unassigned estimates.
    pub false_count: usize,
    /// The (target index, estimate index) pairs, one per filled slot, sorted.
    #[serde(skip)]
    pub pairs: Vec<(usize, usize)>,
}

/// ET-GOPSA between extended targets and estimate points (see the module doc).
///
/// # Errors
/// [`MetricError::InvalidParam`] for bad parameters; [`MetricError::NonFiniteInput`] for a NaN or
/// infinite coordinate in a target's samples or outline or in the estimates;
/// [`MetricError::EmptyGeometry`] when a target has no sample point (`distance = "samples"`) or no
/// outline vertex (`distance = "outline"`).
///
/// ```
/// use nrslam_evaluator::{etgospa, EtGospaParams, ExtendedTarget, Point2};
/// let square = |x: f64| ExtendedTarget::from_samples(vec![
///     Point2::new(x, 0.0), Point2::new(x + 2.0, 0.0),
///     Point2::new(x + 2.0, 2.0), Point2::new(x, 2.0)]);
/// let targets = [square(0.0), square(6.0)];
/// let params = EtGospaParams::default(); // c = 5, p = 1, α = 2
/// // Both estimates are 0.5 m from target 0; y_near is 4.03 m from target 1, y_far 6.02 m.
/// let y_near = Point2::new(2.0, -0.5);
/// let y_far = Point2::new(0.0, -0.5);
/// let near = etgospa(&targets, &[y_near], &params).unwrap().total;
/// let far = etgospa(&targets, &[y_far], &params).unwrap().total;
/// let both = etgospa(&targets, &[y_near, y_far], &params).unwrap().total;
/// assert!(near > far);                  // eq. (GOPSA_10)
/// assert!(near > both && far > both);   // eq. (GOPSA_11)
/// ```
pub fn etgospa(
    targets: &[ExtendedTarget],
    estimates: &[Point2],
    params: &EtGospaParams,
) -> Result<EtGospaResult, MetricError> {
    let inputs = check_inputs(targets, estimates, params)?;
    let slots = targets
        .iter()
        .try_fold(0usize, |sum, t| sum.checked_add(t.slots))
        .unwrap_or(usize::MAX);
    inputs.solve_by_size(slots.max(targets.len()), dense, sparse)
}

/// ET-GOPSA by one dense assignment over all slots × estimates, at most
/// [`MAX_CELLS`](crate::assignment::MAX_CELLS) cells: the reference [`etgospa`] is checked
/// against, and what it uses for small inputs. Same value and decomposition as [`etgospa`]
/// (which of several optimal assignments is reported may differ).
///
/// # Errors
/// As [`etgospa`], and [`MetricError::Assignment`] past the cell limit.
pub fn etgospa_dense(
    targets: &[ExtendedTarget],
    estimates: &[Point2],
    params: &EtGospaParams,
) -> Result<EtGospaResult, MetricError> {
    dense(check_inputs(targets, estimates, params)?)
}

/// ET-GOPSA through the components of the graph of the (target, estimate) pairs worth taking,
/// what [`etgospa`] uses for all but the smallest inputs; exposed for tests and benchmarks. The
/// dense size limit applies to each component (slots of a target beyond the component's
/// estimates are left out: they are identical rows). When a pair beyond the cut-off can be worth
/// taking (α < 2 with an estimate whose nearest target is farther than about c(2 − 2/α)^{1/p}),
/// the components do not separate and this is the dense solution.
///
/// # Errors
/// As [`etgospa`]; [`MetricError::Assignment`] when a component is past the cell limit.
#[doc(hidden)]
pub fn etgospa_sparse(
    targets: &[ExtendedTarget],
    estimates: &[Point2],
    params: &EtGospaParams,
) -> Result<EtGospaResult, MetricError> {
    sparse(check_inputs(targets, estimates, params)?)
}

/// The checks every entry point runs: parameters, finite coordinates, measured geometry present.
fn check_inputs<'a>(
    targets: &'a [ExtendedTarget],
    estimates: &'a [Point2],
    params: &'a EtGospaParams,
) -> Result<Inputs<'a>, MetricError> {
    params.validate()?;
    for (i, target) in targets.iter().enumerate() {
        check_finite(&target.samples, || format!("target {i} samples"))?;
        check_finite(&target.outline, || format!("target {i} outline"))?;
        let (geometry, empty) = match params.distance {
            DistanceMode::Samples => ("sample", target.samples.is_empty()),
            DistanceMode::Outline => ("outline", target.outline.is_empty()),
        };
        if empty {
            return Err(MetricError::EmptyGeometry {
                target: i,
                geometry,
            });
        }
    }
    check_finite(estimates, || "estimates".to_owned())?;
    Ok(Checked::after_checks(targets, estimates, params))
}

/// The inputs of an ET-GOPSA solver.
type Inputs<'a> = Checked<'a, ExtendedTarget, EtGospaParams>;

/// ET-GOPSA by one dense assignment (see [`etgospa_dense`]).
fn dense(inputs: Inputs) -> Result<EtGospaResult, MetricError> {
    let (targets, estimates, params) = (inputs.truth, inputs.estimates, inputs.params);
    let EtGospaParams { c, p, alpha, .. } = *params;
    let (n_targets, n_est) = (targets.len(), estimates.len());
    // The dense slots × estimates matrix (and the targets × estimates tables below, no larger)
    // must fit before anything is allocated.
    let n_slots_total = targets
        .iter()
        .try_fold(0usize, |sum, t| sum.checked_add(t.slots))
        .unwrap_or(usize::MAX);
    check_size(n_slots_total.max(n_targets), n_est)?;
    // clipped[i * n_est + j] = min(c, δ(y_j, target i)).
    let mut clipped = Vec::with_capacity(n_targets * n_est);
    for target in targets {
        for y in estimates {
            clipped.push(base_distance(target, y, params).min(c));
        }
    }
    // min(c, δ_{−i}(y_j)): the nearest other target, via the best and second best per estimate.
    let table = &clipped;
    let nearest = NearestTwo::new(n_est, c, |j| {
        (0..n_targets).map(move |i| (i, table[i * n_est + j]))
    });
    let clipped_other = |i: usize, j: usize| nearest.other(i, j);
    // Row r of the slots × estimates matrix belongs to target slot_target[r].
    let slot_target: Vec<usize> = targets
        .iter()
        .enumerate()
        .flat_map(|(i, t)| std::iter::repeat_n(i, t.slots))
        .collect();
    let n_slots = slot_target.len();

    if p.is_infinite() {
        let pair_cost = |i: usize, j: usize| {
            let confusion = if clipped_other(i, j) < c { c } else { 0.0 };
            clipped[i * n_est + j].max(confusion)
        };
        let costs = CostMatrix::from_fn(n_slots, n_est, |r, j| pair_cost(slot_target[r], j))?;
        let matching = solve_bottleneck(&costs, c);
        let mut pairs: Vec<(usize, usize)> = matching
            .pairs
            .iter()
            .map(|&(r, j)| (slot_target[r], j))
            .collect();
        pairs.sort_unstable();
        return Ok(EtGospaResult::bottleneck(
            pairs,
            (n_slots, n_est),
            c,
            matching.bottleneck,
        ));
    }

    let c_pow_p = pow_p(c, p);
    let unassigned_cost = c_pow_p / alpha;
    let localisation_of = |i: usize, j: usize| pow_p(clipped[i * n_est + j], p);
    let confusion_of = |i: usize, j: usize| c_pow_p - pow_p(clipped_other(i, j), p);
    // Weight of a pair relative to leaving both its slot and its estimate unassigned.
    let weights: Vec<f64> = (0..n_targets)
        .flat_map(|i| (0..n_est).map(move |j| (i, j)))
        .map(|(i, j)| localisation_of(i, j) + confusion_of(i, j) - 2.0 * unassigned_cost)
        .collect();
    let slot_weights =
        CostMatrix::from_fn(n_slots, n_est, |r, j| weights[slot_target[r] * n_est + j])?;
    let mut pairs: Vec<(usize, usize)> = solve_partial(&slot_weights)
        .into_iter()
        .map(|(r, j)| (slot_target[r], j))
        .collect();
    pairs.sort_unstable();
    Ok(EtGospaResult::summed(
        pairs,
        (n_slots, n_est),
        params,
        |i, j| clipped[i * n_est + j],
        clipped_other,
    ))
}

impl EtGospaResult {
    /// The result of an assignment `pairs` (target, estimate), sorted, over `slot_count` slots.
    fn assemble(parts: Parts, slot_count: usize, pairs: Vec<(usize, usize)>) -> Self {
        Self {
            total: parts.total,
            localisation: parts.localisation,
            confusion: parts.confusion,
            missed: parts.left.missed,
            false_estimates: parts.left.false_estimates,
            slot_count,
            assigned_count: pairs.len(),
            missed_count: parts.left.missed_count,
            false_count: parts.left.false_count,
            pairs,
        }
    }

    /// The p = ∞ result of a bottleneck matching, `pairs` (target, estimate) sorted.
    fn bottleneck(
        pairs: Vec<(usize, usize)>,
        (n_slots, n_est): (usize, usize),
        c: f64,
        bottleneck: Option<f64>,
    ) -> Self {
        let parts = Parts::bottleneck((n_slots, n_est), pairs.len(), c, bottleneck);
        Self::assemble(parts, n_slots, pairs)
    }

    /// The 1 ≤ p < ∞ result of an optimal assignment, `pairs` (target, estimate) sorted, given
    /// min(c, δ_i(y_j)) and min(c, δ_{−i}(y_j)).
    fn summed(
        pairs: Vec<(usize, usize)>,
        (n_slots, n_est): (usize, usize),
        params: &EtGospaParams,
        clipped: impl Fn(usize, usize) -> f64,
        clipped_other: impl Fn(usize, usize) -> f64,
    ) -> Self {
        let parts = Parts::summed(
            &pairs,
            (n_slots, n_est),
            (params.c, params.p, params.alpha),
            clipped,
            Some(clipped_other),
        );
        Self::assemble(parts, n_slots, pairs)
    }
}

/// min(c, δ) to the best and second best target of each estimate: (best target, best, second
/// best), both c when there is none, from which min(c, δ_{−i}(y_j)) is read.
struct NearestTwo {
    per_estimate: Vec<(usize, f64, f64)>,
}

impl NearestTwo {
    /// From `candidates(j)`: (target, min(c, δ)) for the targets of estimate j, in index order
    /// (targets left out are at c).
    fn new<I: Iterator<Item = (usize, f64)>>(
        n_est: usize,
        c: f64,
        candidates: impl Fn(usize) -> I,
    ) -> Self {
        let per_estimate = (0..n_est)
            .map(|j| {
                let (mut best_at, mut best, mut second) = (usize::MAX, c, c);
                for (i, d) in candidates(j) {
                    if d < best {
                        (best_at, best, second) = (i, d, best);
                    } else if d < second {
                        second = d;
                    }
                }
                (best_at, best, second)
            })
            .collect();
        Self { per_estimate }
    }

    /// min(c, δ_{−i}(y_j)): estimate j's distance to its nearest target other than i.
    fn other(&self, i: usize, j: usize) -> f64 {
        let (best_at, best, second) = self.per_estimate[j];
        if i == best_at {
            second
        } else {
            best
        }
    }

    /// min(c, δ) to estimate j's nearest target.
    fn best(&self, j: usize) -> f64 {
        self.per_estimate[j].1
    }
}

/// For each estimate, the targets closer than c (by δ) with min(c, δ), in target order: the only
/// pairs whose clipped distance is not c.
struct NearTargets {
    /// near[start[j]..start[j + 1]]: estimate j's (target, min(c, δ)).
    near: Vec<(u32, f64)>,
    start: Vec<usize>,
    c: f64,
}

impl NearTargets {
    /// Found through a uniform grid of the targets' bounding boxes.
    fn find(targets: &[ExtendedTarget], estimates: &[Point2], params: &EtGospaParams) -> Self {
        let c = params.c;
        // The geometry δ measures to, as boxes; a point closer than c (δ) is within `radius` metres.
        let radius = if params.squared_distance { c.sqrt() } else { c };
        let boxes: Vec<Box2> = targets
            .iter()
            .map(|t| {
                let geometry = match params.distance {
                    DistanceMode::Samples => &t.samples,
                    DistanceMode::Outline => &t.outline,
                };
                // Non-empty: checked by the caller.
                Box2::of_points(geometry).unwrap_or(Box2::of_point(Point2::default()))
            })
            .collect();
        let mut grid = Grid::new(&boxes, radius, Box2::of_points(estimates));
        let mut near: Vec<(u32, f64)> = Vec::new();
        let mut start: Vec<usize> = Vec::with_capacity(estimates.len() + 1);
        for y in estimates {
            let from = near.len();
            start.push(from);
            grid.near(*y, |i| {
                let d = base_distance(&targets[i], y, params).min(c);
                if d < c {
                    near.push((i as u32, d));
                }
            });
            near[from..].sort_unstable_by_key(|&(i, _)| i);
        }
        start.push(near.len());
        Self { near, start, c }
    }

    /// Estimate j's near targets.
    fn of(&self, j: usize) -> &[(u32, f64)] {
        &self.near[self.start[j]..self.start[j + 1]]
    }

    /// min(c, δ_i(y_j)).
    fn clipped(&self, i: usize, j: usize) -> f64 {
        let near = self.of(j);
        match near.binary_search_by_key(&(i as u32), |e| e.0) {
            Ok(at) => near[at].1,
            Err(_) => self.c,
        }
    }
}

/// See [`etgospa_sparse`]. Every value (clipped distances, nearest other target, weights) is
/// computed exactly as the dense path computes it, for the pairs closer than c; every other pair
/// has min(c, δ_i) = c.
fn sparse(inputs: Inputs) -> Result<EtGospaResult, MetricError> {
    let (targets, estimates, params) = (inputs.truth, inputs.estimates, inputs.params);
    let (n_targets, n_est) = (targets.len(), estimates.len());
    if n_targets.saturating_add(n_est) >= u32::MAX as usize {
        return dense(inputs);
    }
    let EtGospaParams { c, p, alpha, .. } = *params;
    let Some(n_slots) = targets
        .iter()
        .try_fold(0usize, |sum, t| sum.checked_add(t.slots))
    else {
        return Err(AssignmentError::TooLarge {
            rows: usize::MAX,
            cols: n_est,
        }
        .into());
    };
    let near = NearTargets::find(targets, estimates, params);
    let clipped = |i: usize, j: usize| near.clipped(i, j);
    // As the dense path: best and second best over the targets in index order (the others are c).
    let nearest = NearestTwo::new(n_est, c, |j| {
        near.of(j).iter().map(|&(i, d)| (i as usize, d))
    });
    let clipped_other = |i: usize, j: usize| nearest.other(i, j);

    let infinite = p.is_infinite();
    let c_pow_p = pow_p(c, p);
    let unassigned_cost = c_pow_p / alpha;
    if !infinite && n_slots > 0 {
        // A pair farther than c weighs c^p + (c^p − D_{−i}(y_j)) − 2c^p/α with D_{−i}(y_j) the
        // nearest target's clipped distance: never negative for α = 2. If it can be, pairs
        // beyond the cut-off matter and the problem does not split.
        let far_can_help = (0..n_est)
            .any(|j| c_pow_p + (c_pow_p - pow_p(nearest.best(j), p)) - 2.0 * unassigned_cost < 0.0);
        if far_can_help {
            return dense(inputs);
        }
    }
    let pair_cost = |i: usize, j: usize| {
        let confusion = if clipped_other(i, j) < c { c } else { 0.0 };
        clipped(i, j).max(confusion)
    };
    let weight = |i: usize, j: usize| {
        pow_p(clipped(i, j), p) + (c_pow_p - pow_p(clipped_other(i, j), p)) - 2.0 * unassigned_cost
    };
    // What a pair is ranked by: its bottleneck cost for p = ∞, else its weight relative to
    // leaving both its slot and its estimate unassigned; worth taking below `worth_below`.
    let key = |i: usize, j: usize| {
        if infinite {
            pair_cost(i, j)
        } else {
            weight(i, j)
        }
    };
    let worth_below = if infinite { c } else { 0.0 };

    let mut graph = Components::new(n_targets, n_est);
    for j in 0..n_est {
        for &(i, _) in near.of(j) {
            let i = i as usize;
            if targets[i].slots > 0 && key(i, j) < worth_below {
                graph.link(i, j);
            }
        }
    }
    let Solved {
        mut pairs,
        bottleneck,
    } = solve_components(
        graph,
        |i| targets[i].slots,
        key,
        infinite,
        c,
        (n_slots, n_est),
    )?;
    pairs.sort_unstable();
    if infinite {
        return Ok(EtGospaResult::bottleneck(
            pairs,
            (n_slots, n_est),
            c,
            bottleneck,
        ));
    }
    Ok(EtGospaResult::summed(
        pairs,
        (n_slots, n_est),
        params,
        clipped,
        clipped_other,
    ))
}

/// δ(y, target): Euclidean (or squared) distance to the nearest sample or to the outline.
/// The geometry is non-empty (checked by the caller).
fn base_distance(target: &ExtendedTarget, y: &Point2, params: &EtGospaParams) -> f64 {
    match (params.distance, params.squared_distance) {
        (DistanceMode::Samples, squared) => {
            // Nearest sample by squared distance: one square root per target, not per sample.
            let d_sq = target
                .samples
                .iter()
                .map(|s| s.distance_sq_m2(y))
                .fold(f64::INFINITY, f64::min);
            if squared {
                d_sq
            } else {
                d_sq.sqrt()
            }
        }
        (DistanceMode::Outline, squared) => {
            let d = distance_to_outline_m(y, &target.outline).unwrap_or(f64::INFINITY);
            if squared {
                d * d
            } else {
                d
            }
        }
    }
}
