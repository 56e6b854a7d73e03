//! GOSPA, the generalised optimal sub-pattern assignment metric for point sets
//! (A. S. Rahmathullah, Á. F. García-Fernández, L. Svensson, "Generalized optimal sub-pattern
//! assignment metric", FUSION 2017), in the assignment-set form of docs/design.md ("Metrics"):
//!
//! d_p^(c,α)(X, Y) = ( min_γ Σ_{(i,j)∈γ} d^(c)(x_i, y_j)^p + c^p/α · (|X| + |Y| − 2|γ|) )^{1/p},
//! d^(c)(x, y) = min(c, ‖x − y‖₂),
//!
//! γ ranging over the partial one-to-one assignments between X and Y. For every 0 < α ≤ 2 a pair
//! costs at most c^p ≤ 2c^p/α, so some optimal γ has the most pairs possible and this equals the
//! FUSION 2017 definition (min over permutations of the smaller set into the larger one, plus
//! c^p/α per point of the cardinality mismatch); the tests check both against enumeration. With
//! α = 2 the value splits into localisation (Σ over γ of the pair costs, pairs closer than c),
//! missed (c^p/2 per unassigned truth point) and false (c^p/2 per unassigned estimate), Sec. IV of
//! that paper.
//!
//! **Solution.** The constant c^p/α (|X| + |Y|) comes out of the minimum, leaving
//! min_γ Σ_γ (d^(c)^p − 2c^p/α), a minimum-weight partial matching, which
//! [`crate::assignment::solve_partial`] finds exactly (a pair is worth taking only when its weight
//! is negative; the minimum over partial assignments is the minimum over full assignments of the
//! smaller set of min(0, weight)). Pairs whose weight is exactly 0 are reported as unassigned
//! (with α = 2: points c or more apart are a miss and a false estimate, the usual GOSPA
//! convention); the total does not depend on that choice.
//!
//! **Components.** Only pairs closer than c can weigh less than a pair at c or beyond, and all of
//! the latter weigh the same (0 for α = 2; for α < 2 the common weight c^p − 2c^p/α is negative
//! and taken out of every pair, the points left over at the end being paired in index order). So
//! the matching splits into the connected components of the graph of the pairs closer than c,
//! found with a uniform grid of c-sized cells and a union-find; each component is solved by the
//! dense solver above (one pair alone is taken as it is) and the optima add up. Inputs of at
//! most 16 × 16 pairs go to the dense solver directly ([`gospa_dense`]).
//!
//! **Accuracy with large p.** The assignment is exact on the f64 weights d^p − 2c^p/α, which
//! cannot tell apart pair costs that differ by less than about ε·c^p (ε = 2.2e−16). A chosen
//! assignment can therefore exceed the optimum by about 2nε c^p/α in the p-th power (n pairs), so
//! the total by at most about (2nε/α)^{1/p}·c: 1e−13 c for p = 1, 1e−7 c for p = 2, but a sizeable
//! fraction of c for p in the tens or more. For the large-p regime use p = ∞, which is computed
//! exactly. The total itself is rescaled when the p-th powers underflow (see `root_p`), so
//! p = 2000 with c = 1 m does not collapse to 0; the p-th-power parts of the decomposition may
//! then underflow to 0.
//!
//! **p = ∞** is the limit p → ∞. Every term is at most c and an unassigned point costs c (as
//! (c^p/α)^{1/p} → c), so d_∞ = c unless X and Y can be paired completely with all distances below
//! c, in which case d_∞ is the least possible largest distance (a bottleneck assignment); both
//! empty gives 0. α plays no role at p = ∞. See [`GospaResult`] for the decomposition reported.

use serde::{Deserialize, Serialize};

use crate::assignment::{check_size, solve_bottleneck, solve_partial, CostMatrix};
use crate::error::{InvalidMetricParam, MetricError};
use crate::inputs::Checked;
use crate::point::{check_finite, Point2};
use crate::sparse::{solve_components, Box2, Components, Grid, Solved};
use crate::unassigned::Parts;

/// Smallest and largest c^p accepted: keeps every cost of the assignment well inside f64 range
/// (c = 5 m allows p up to 143).
pub const CP_RANGE: (f64, f64) = (1e-100, 1e100);

/// GOSPA parameters (docs/design.md "Metrics"; paper Table I: c = 5, p = 1, α = 2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GospaParams {
    /// Cut-off distance c > 0, metres: the largest localisation error counted.
    pub c: f64,
    /// Order 1 ≤ p < ∞, or `f64::INFINITY` for p = ∞. Larger p punishes outliers more.
    pub p: f64,
    /// Cardinality-mismatch parameter 0 < α ≤ 2; an unassigned point costs c^p/α.
    pub alpha: f64,
}

impl Default for GospaParams {
    /// The paper's Table I: c = 5, p = 1, α = 2.
    fn default() -> Self {
        Self {
            c: 5.0,
            p: 1.0,
            alpha: 2.0,
        }
    }
}

impl GospaParams {
    /// Checks c > 0 finite, 1 ≤ p ≤ ∞, 0 < α ≤ 2, and (finite p) c^p and c^p/α within
    /// [`CP_RANGE`].
    ///
    /// # Errors
    /// [`InvalidMetricParam`] naming the first bad field and its allowed range.
    pub fn validate(&self) -> Result<(), InvalidMetricParam> {
        validate_c_p_alpha(self.c, self.p, self.alpha)
    }

    /// c^p, the cost unit of the metric (c for p = ∞).
    pub(crate) fn c_pow_p(&self) -> f64 {
        pow_p(self.c, self.p)
    }
}

/// Shared check of (c, p, α) for GOSPA and ET-GOPSA.
pub(crate) fn validate_c_p_alpha(c: f64, p: f64, alpha: f64) -> Result<(), InvalidMetricParam> {
    if !(c.is_finite() && c > 0.0) {
        return Err(InvalidMetricParam::new(
            "c",
            format!("c = {c}"),
            "finite c > 0",
        ));
    }
    // NaN is refused explicitly (it compares false with everything); +∞ is allowed and means the
    // p = ∞ limit.
    if p.is_nan() || p < 1.0 {
        return Err(InvalidMetricParam::new(
            "p",
            format!("p = {p}"),
            "1 <= p < inf, or p = inf",
        ));
    }
    if !(alpha > 0.0 && alpha <= 2.0) {
        return Err(InvalidMetricParam::new(
            "alpha",
            format!("alpha = {alpha}"),
            "0 < alpha <= 2",
        ));
    }
    if p.is_finite() {
        let cp = c.powf(p);
        if !(CP_RANGE.0..=CP_RANGE.1).contains(&cp) {
            return Err(InvalidMetricParam::new(
                "p",
                format!("c^p = {cp:e} for c = {c}, p = {p}"),
                "p such that 1e-100 <= c^p <= 1e100",
            ));
        }
        // The cost of an unassigned point, c^p/α, must stay in range too.
        if cp / alpha > CP_RANGE.1 {
            return Err(InvalidMetricParam::new(
                "alpha",
                format!(
                    "c^p/alpha = {:e} for c = {c}, p = {p}, alpha = {alpha}",
                    cp / alpha
                ),
                "0 < alpha <= 2 with c^p/alpha <= 1e100",
            ));
        }
    }
    Ok(())
}

/// x^p, exact for p = 1 and p = 2 (the common cases), x for p = ∞ (the ∞-norm works on the
/// distances themselves).
pub(crate) fn pow_p(x: f64, p: f64) -> f64 {
    if p == 1.0 || p.is_infinite() {
        x
    } else if p == 2.0 {
        x * x
    } else {
        x.powf(p)
    }
}

/// The p-th root of a sum of p-th powers, Σ_k n_k b_k^p, given both `direct` (that sum as computed
/// in the p-th-power domain) and the bases b_k ≥ 0 with their multiplicities n_k.
///
/// `direct` is used when the largest b^p is a comfortably normal number: terms that underflowed are
/// then far below its rounding. Otherwise (huge p with bases below 1, e.g. c = 1 m, p = 2000, where
/// 0.5^p underflows to 0) the sum is rescaled by the largest base, the usual p-norm scaling, so the
/// total stays right even though the p-th-power parts cannot be represented.
pub(crate) fn root_p(direct: f64, bases: &[(f64, usize)], p: f64) -> f64 {
    let largest = bases
        .iter()
        .filter(|&&(_, n)| n > 0)
        .map(|&(b, _)| b)
        .fold(0.0_f64, f64::max);
    if largest == 0.0 {
        return 0.0;
    }
    if pow_p(largest, p) >= 1e-200 {
        return direct.powf(1.0 / p);
    }
    // Skip absent terms: a base above `largest` with n = 0 would give 0 × ∞ = NaN.
    let scaled: f64 = bases
        .iter()
        .filter(|&&(_, n)| n > 0)
        .map(|&(b, n)| n as f64 * pow_p(b / largest, p))
        .sum();
    largest * scaled.powf(1.0 / p)
}

/// GOSPA value and its decomposition.
///
/// For 1 ≤ p < ∞ the parts are the summed p-th-power contributions (units m^p) of one optimal
/// assignment, and `total = (localisation + missed + false_estimates)^{1/p}` (metres):
/// - `localisation` = Σ over assigned pairs of min(c, ‖x − y‖)^p;
/// - `missed` = c^p/α × (truth points left unassigned);
/// - `false_estimates` = c^p/α × (estimates left unassigned).
///
/// For p = ∞ the parts are ∞-norms (metres) and `total` is their maximum: the assignment is a
/// largest matching using only pairs closer than c, with the smallest possible largest distance;
/// `localisation` is that largest distance (0 if no pair), `missed` is c if a truth point is left
/// unassigned (else 0), `false_estimates` likewise for estimates.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GospaResult {
    /// The metric, metres.
    pub total: f64,
    /// Localisation part (see the type's doc for the units).
    pub localisation: f64,
    /// Missed-truth part.
    pub missed: f64,
    /// False-estimate part.
    #[serde(rename = "false")]
    pub false_estimates: f64,
    /// Number of (truth, estimate) pairs.
    pub assigned_count: usize,
    /// Number of truth points left unassigned.
    pub missed_count: usize,
    /// Number of estimates left unassigned.
    pub false_count: usize,
    /// The (truth index, estimate index) pairs, sorted by truth index.
    #[serde(skip)]
    pub pairs: Vec<(usize, usize)>,
}

/// GOSPA between truth points `truth` and estimates `estimates` (see the module doc).
///
/// # Errors
/// [`MetricError::InvalidParam`] for bad parameters, [`MetricError::NonFiniteInput`] for a NaN
/// or infinite coordinate (set `truth` or `estimates`).
///
/// ```
/// use nrslam_evaluator::{gospa, GospaParams, Point2};
/// let truth = [Point2::new(0.0, 0.0), Point2::new(10.0, 0.0)];
/// let estimates = [Point2::new(0.0, 1.0)];
/// let r = gospa(&truth, &estimates, &GospaParams::default()).unwrap();
/// // One pair 1 m apart, one missed truth point at c^p/2 = 2.5.
/// assert_eq!((r.localisation, r.missed, r.false_estimates), (1.0, 2.5, 0.0));
/// assert_eq!(r.total, 3.5);
/// ```
pub fn gospa(
    truth: &[Point2],
    estimates: &[Point2],
    params: &GospaParams,
) -> Result<GospaResult, MetricError> {
    check_inputs(truth, estimates, params)?.solve_by_size(truth.len(), dense, sparse)
}

/// GOSPA by one dense assignment over all truth × estimate pairs, at most
/// [`MAX_CELLS`](crate::assignment::MAX_CELLS) of them: the reference [`gospa`] is checked
/// against, and what it uses for small inputs. Same value and decomposition as [`gospa`] (which
/// of several optimal assignments is reported may differ).
///
/// # Errors
/// As [`gospa`], and [`MetricError::Assignment`] past the cell limit.
pub fn gospa_dense(
    truth: &[Point2],
    estimates: &[Point2],
    params: &GospaParams,
) -> Result<GospaResult, MetricError> {
    dense(check_inputs(truth, estimates, params)?)
}

/// The inputs of a GOSPA solver.
type Inputs<'a> = Checked<'a, Point2, GospaParams>;

/// The checks every entry point runs: parameters and finite coordinates.
fn check_inputs<'a>(
    truth: &'a [Point2],
    estimates: &'a [Point2],
    params: &'a GospaParams,
) -> Result<Inputs<'a>, MetricError> {
    params.validate()?;
    check_finite(truth, || "truth".to_owned())?;
    check_finite(estimates, || "estimates".to_owned())?;
    Ok(Checked::after_checks(truth, estimates, params))
}

/// GOSPA by one dense assignment (see [`gospa_dense`]).
fn dense(inputs: Inputs) -> Result<GospaResult, MetricError> {
    let (truth, estimates, params) = (inputs.truth, inputs.estimates, inputs.params);
    check_size(truth.len(), estimates.len())?;
    let GospaParams { c, p, alpha } = *params;
    let clipped = |i: usize, j: usize| truth[i].distance_m(&estimates[j]).min(c);

    if p.is_infinite() {
        let costs = CostMatrix::from_fn(truth.len(), estimates.len(), clipped)?;
        let matching = solve_bottleneck(&costs, c);
        return Ok(GospaResult::bottleneck(
            (truth.len(), estimates.len()),
            c,
            matching.pairs,
            matching.bottleneck,
        ));
    }

    let unassigned_cost = params.c_pow_p() / alpha;
    let weight = |i: usize, j: usize| pow_p(clipped(i, j), p) - 2.0 * unassigned_cost;
    let pairs = solve_partial(&CostMatrix::from_fn(truth.len(), estimates.len(), weight)?);
    Ok(GospaResult::summed(truth, estimates, params, pairs))
}

/// GOSPA through the connected components of the graph of the pairs worth taking, each solved
/// exactly by the dense solver, the optima summed. For 1 ≤ p < ∞ a pair is worth taking when its weight
/// min(c, d)^p − 2c^p/α is below that of a pair at c or farther, c^p − 2c^p/α (0 for α = 2); with
/// α < 2 every pair beats leaving both points unassigned, so after the components the points
/// left over are paired in index order, each such pair costing c^p. For p = ∞ a pair is usable
/// when closer than c.
///
/// What [`gospa`] uses for all but the smallest inputs; exposed for tests and benchmarks. The
/// dense size limit applies to each component.
///
/// # Errors
/// As [`gospa`]; [`MetricError::Assignment`] when a component is past the cell limit.
#[doc(hidden)]
pub fn gospa_sparse(
    truth: &[Point2],
    estimates: &[Point2],
    params: &GospaParams,
) -> Result<GospaResult, MetricError> {
    sparse(check_inputs(truth, estimates, params)?)
}

/// GOSPA by the components of the pairs worth taking (see [`gospa_sparse`]).
fn sparse(inputs: Inputs) -> Result<GospaResult, MetricError> {
    let (truth, estimates, params) = (inputs.truth, inputs.estimates, inputs.params);
    let (n, m) = (truth.len(), estimates.len());
    if n.saturating_add(m) >= u32::MAX as usize {
        // Beyond the components' u32 indices, and past any dense limit anyway.
        return dense(inputs);
    }
    let GospaParams { c, p, alpha } = *params;
    let infinite = p.is_infinite();
    let clipped = |i: usize, j: usize| truth[i].distance_m(&estimates[j]).min(c);
    let unassigned_cost = params.c_pow_p() / alpha;
    // Weight of a pair at the cut-off or beyond, and of any pair relative to it.
    let far = params.c_pow_p() - 2.0 * unassigned_cost;
    let weight = |i: usize, j: usize| (pow_p(clipped(i, j), p) - 2.0 * unassigned_cost) - far;
    // What a pair is ranked by: its bottleneck cost for p = ∞, else its weight; worth taking
    // below `worth_below`.
    let key = |i: usize, j: usize| {
        if infinite {
            clipped(i, j)
        } else {
            weight(i, j)
        }
    };
    let worth_below = if infinite { c } else { 0.0 };

    let boxes: Vec<Box2> = estimates.iter().map(|&y| Box2::of_point(y)).collect();
    let mut grid = Grid::new(&boxes, c, Box2::of_points(truth));
    let mut graph = Components::new(n, m);
    for (i, x) in truth.iter().enumerate() {
        grid.near(*x, |j| {
            if key(i, j) < worth_below {
                graph.link(i, j);
            }
        });
    }
    drop(grid);

    // One slot per truth point: a star (one point on one side) takes its cheapest pair, every
    // other component is solved densely.
    let Solved {
        mut pairs,
        bottleneck,
    } = solve_components(graph, |_| 1, key, infinite, c, (n, m))?;
    if infinite {
        pairs.sort_unstable();
        return Ok(GospaResult::bottleneck((n, m), c, pairs, bottleneck));
    }
    if far < 0.0 {
        let mut truth_used = vec![false; n];
        let mut estimate_used = vec![false; m];
        for &(i, j) in &pairs {
            truth_used[i] = true;
            estimate_used[j] = true;
        }
        let free_truth = (0..n).filter(|&i| !truth_used[i]);
        let free_estimates = (0..m).filter(|&j| !estimate_used[j]);
        let filler: Vec<(usize, usize)> = free_truth.zip(free_estimates).collect();
        pairs.extend(filler);
    }
    pairs.sort_unstable();
    Ok(GospaResult::summed(truth, estimates, params, pairs))
}

impl GospaResult {
    /// The result of an assignment `pairs` (truth, estimate), sorted.
    fn assemble(parts: Parts, pairs: Vec<(usize, usize)>) -> Self {
        Self {
            total: parts.total,
            localisation: parts.localisation,
            missed: parts.left.missed,
            false_estimates: parts.left.false_estimates,
            assigned_count: pairs.len(),
            missed_count: parts.left.missed_count,
            false_count: parts.left.false_count,
            pairs,
        }
    }

    /// The p = ∞ result of a bottleneck matching (see [`GospaResult`]).
    fn bottleneck(
        (n, m): (usize, usize),
        c: f64,
        pairs: Vec<(usize, usize)>,
        bottleneck: Option<f64>,
    ) -> Self {
        Self::assemble(Parts::bottleneck((n, m), pairs.len(), c, bottleneck), pairs)
    }

    /// The 1 ≤ p < ∞ result of an optimal assignment `pairs` (sorted).
    fn summed(
        truth: &[Point2],
        estimates: &[Point2],
        params: &GospaParams,
        pairs: Vec<(usize, usize)>,
    ) -> Self {
        let GospaParams { c, p, alpha } = *params;
        let parts = Parts::summed(
            &pairs,
            (truth.len(), estimates.len()),
            (c, p, alpha),
            |i: usize, j: usize| truth[i].distance_m(&estimates[j]).min(c),
            None::<fn(usize, usize) -> f64>,
        );
        Self::assemble(parts, pairs)
    }
}
