//! Pose-graph optimisation on SE(2): the back end of loop closure.
//!
//! The paper (Sec. III-A) notes that "to reduce the cumulative error caused by environment
//! sensing, loop detection module is generally adopted". Detecting the loop (see
//! [`crate::loop_closure`]) gives one more relative-pose measurement between two keyframes far
//! apart in time; this module spreads the error it reveals over the whole trajectory. Nodes are
//! keyframe poses; edges are relative-pose measurements `z_ij` (pose of j in i's frame) with a
//! 3×3 information matrix over (x, y, yaw). The cost is
//!
//! ```text
//! F(X) = Σ_edges ρ( e_ijᵀ Ω_ij e_ij ),   e_ij = log( z_ij⁻¹ ⊕ (x_i⁻¹ ⊕ x_j) )
//! ```
//!
//! with ρ chosen per edge kind ([`RobustKernel`]): by default the identity for odometry edges
//! and a Cauchy kernel for loop edges, so that a wrong loop that passed verification is
//! down-weighted rather than allowed to bend the whole map. It is minimised by
//! Levenberg–Marquardt (Gauss–Newton with an adaptive damping term, the robust kernel applied by
//! iteratively reweighted least squares) with the fixed nodes held in place: by default the
//! first node, which anchors the map frame at the first keyframe. The planar error uses the
//! simple (x, y, wrapped yaw) parametrisation of Grisetti et al. (2010, "A tutorial on
//! graph-based SLAM"), whose Jacobians are closed-form.
//!
//! # The linear solve
//!
//! Each iteration solves the damped normal equations `(H + λ·diag H) δ = −g`. `H` has one 3×3
//! block per node and one per pair of nodes joined by an edge, so for a run of many laps with
//! hundreds to thousands of keyframes it is almost empty: a dense 3n × 3n Cholesky costs
//! O(n³) time and O(n²) memory for a matrix with O(n) non-zeros. [`PoseGraph::optimise`]
//! therefore assembles the upper triangle of `H` in compressed-column form and factors it with
//! `faer`'s sparse Cholesky, whose approximate-minimum-degree (AMD) ordering keeps the factor
//! close to the sparsity of `H` even when loop edges join keyframes laps apart (in natural order
//! every loop edge fills the factor between its two ends). The ordering and the symbolic
//! factorisation depend only on which nodes are joined, so they are computed once per call and
//! reused by every iteration and every damping retry; only the numerical factorisation repeats.
//!
//! Degenerate inputs never panic and never make a pose non-finite: [`PoseGraph::try_add_edge`]
//! refuses edges that name missing nodes or carry non-finite, asymmetric, indefinite or zero
//! information ([`EdgeError`]), and [`PoseGraph::optimise`] leaves the poses untouched and says
//! why in [`OptimiseReport::status`] when it cannot run.

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, CholeskySymbolicParams, SymbolicCholesky, SymmetricOrdering,
};
use faer::sparse::{SparseColMatRef, SymbolicSparseColMatRef};
use faer::{Conj, MatMut, Par, Side};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3};

use crate::pose::{wrap_angle_rad, Pose2};

/// What kind of measurement an edge is; decides its robust kernel
/// ([`OptimiserSettings::odometry_kernel`], [`OptimiserSettings::loop_kernel`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EdgeKind {
    /// Between consecutive keyframes, from the tracked (odometry + scan-matching) motion.
    Odometry,
    /// From a verified revisit; robustified with a Cauchy kernel by default.
    Loop,
}

/// A relative-pose measurement between nodes `from` and `to`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Edge {
    /// Index of the first node.
    pub from: usize,
    /// Index of the second node.
    pub to: usize,
    /// Measured pose of `to` in `from`'s frame.
    pub measurement: Pose2,
    /// Information (inverse covariance) of the measurement over (x m, y m, yaw rad).
    pub information: Matrix3<f64>,
    /// Odometry or loop.
    pub kind: EdgeKind,
}

impl Edge {
    /// An edge with diagonal information from standard deviations (metres, radians).
    pub fn with_std(
        from: usize,
        to: usize,
        measurement: Pose2,
        std_m: f64,
        std_rad: f64,
        kind: EdgeKind,
    ) -> Self {
        let (it, ir) = (1.0 / (std_m * std_m), 1.0 / (std_rad * std_rad));
        Self::with_information(
            from,
            to,
            measurement,
            Matrix3::from_diagonal(&Vector3::new(it, it, ir)),
            kind,
        )
    }

    /// An edge with a full 3×3 information matrix over (x m, y m, yaw rad), e.g. the inverse of
    /// a scan matcher's covariance, whose off-diagonal terms [`Edge::with_std`] cannot express.
    /// It must be symmetric positive semi-definite and not zero; [`PoseGraph::try_add_edge`]
    /// checks.
    pub fn with_information(
        from: usize,
        to: usize,
        measurement: Pose2,
        information: Matrix3<f64>,
        kind: EdgeKind,
    ) -> Self {
        Edge {
            from,
            to,
            measurement,
            information,
            kind,
        }
    }
}

/// Why [`PoseGraph::try_add_edge`] refused an edge.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EdgeError {
    /// The edge names a node index the graph does not have.
    #[error("edge names node {index} but the graph has {nodes} nodes")]
    MissingNode {
        /// The index named.
        index: usize,
        /// Nodes in the graph.
        nodes: usize,
    },
    /// Both ends are the same node: the error would be a constant.
    #[error("edge joins node {0} to itself")]
    SelfLoop(usize),
    /// The measured relative pose has a NaN or infinite component.
    #[error("edge measurement is not finite")]
    NonFiniteMeasurement,
    /// The information matrix has a NaN or infinite entry (e.g. a zero standard deviation).
    #[error("edge information is not finite (a zero standard deviation?)")]
    NonFiniteInformation,
    /// The information matrix differs from its transpose beyond rounding.
    #[error("edge information is not symmetric")]
    AsymmetricInformation,
    /// The information matrix has a negative eigenvalue: the cost could fall without bound.
    #[error("edge information is not positive semi-definite")]
    IndefiniteInformation,
    /// The information matrix is zero (e.g. infinite standard deviations): the edge would
    /// constrain nothing.
    #[error("edge information is zero: the edge constrains nothing")]
    ZeroInformation,
}

/// A robust kernel ρ applied to an edge's squared whitened error χ² = eᵀΩe. Its scale `k` is in
/// units of the whitened error (standard deviations) and comes from [`OptimiserSettings`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RobustKernel {
    /// Plain least squares, ρ(χ²) = χ².
    #[default]
    None,
    /// Huber: quadratic up to `k` σ, linear beyond (an outlier's pull stays bounded but never
    /// vanishes).
    Huber,
    /// Cauchy, ρ(χ²) = k² ln(1 + χ²/k²): an edge `k` σ off counts half, and the pull of a
    /// far-off edge falls towards zero.
    Cauchy,
}

impl RobustKernel {
    /// ρ(χ²) for scale `k_sigma`.
    fn cost(self, chi2: f64, k_sigma: f64) -> f64 {
        let k2 = k_sigma * k_sigma;
        match self {
            RobustKernel::None => chi2,
            RobustKernel::Huber if chi2 <= k2 => chi2,
            RobustKernel::Huber => 2.0 * k_sigma * chi2.sqrt() - k2,
            RobustKernel::Cauchy => k2 * (chi2 / k2).ln_1p(),
        }
    }

    /// dρ/dχ², the weight iteratively reweighted least squares puts on the edge's information.
    fn weight(self, chi2: f64, k_sigma: f64) -> f64 {
        let k2 = k_sigma * k_sigma;
        match self {
            RobustKernel::None => 1.0,
            RobustKernel::Huber if chi2 <= k2 => 1.0,
            RobustKernel::Huber => k_sigma / chi2.sqrt(),
            RobustKernel::Cauchy => 1.0 / (1.0 + chi2 / k2),
        }
    }
}

/// Optimiser settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimiserSettings {
    /// Maximum Levenberg–Marquardt iterations.
    pub max_iterations: u32,
    /// Stop when the largest update component is below this (metres or radians).
    pub tolerance: f64,
    /// Scale of the loop-edge kernel, in units of the whitened error (standard deviations):
    /// with the default Cauchy kernel a loop edge this many σ off counts half.
    pub loop_kernel_sigma: f64,
    /// Kernel on loop edges. Default Cauchy.
    pub loop_kernel: RobustKernel,
    /// Kernel on odometry edges. Default none: consecutive keyframes are tracked, not guessed.
    pub odometry_kernel: RobustKernel,
    /// Scale of the odometry-edge kernel, standard deviations (unused with no kernel).
    pub odometry_kernel_sigma: f64,
}

impl Default for OptimiserSettings {
    fn default() -> Self {
        OptimiserSettings {
            max_iterations: 20,
            tolerance: 1e-6,
            loop_kernel_sigma: 3.0,
            loop_kernel: RobustKernel::Cauchy,
            odometry_kernel: RobustKernel::None,
            odometry_kernel_sigma: 3.0,
        }
    }
}

impl OptimiserSettings {
    /// The kernel and its scale (σ) for edges of `kind`.
    fn kernel(&self, kind: EdgeKind) -> (RobustKernel, f64) {
        match kind {
            EdgeKind::Odometry => (self.odometry_kernel, self.odometry_kernel_sigma),
            EdgeKind::Loop => (self.loop_kernel, self.loop_kernel_sigma),
        }
    }

    fn validate(&self) -> Result<(), OptimiseError> {
        let scale_ok = |kernel: RobustKernel, k_sigma: f64| {
            kernel == RobustKernel::None || (k_sigma.is_finite() && k_sigma > 0.0)
        };
        if !scale_ok(self.loop_kernel, self.loop_kernel_sigma) {
            return Err(OptimiseError::InvalidSettings(
                "loop_kernel_sigma must be finite and positive",
            ));
        }
        if !scale_ok(self.odometry_kernel, self.odometry_kernel_sigma) {
            return Err(OptimiseError::InvalidSettings(
                "odometry_kernel_sigma must be finite and positive",
            ));
        }
        if self.tolerance.is_nan() {
            return Err(OptimiseError::InvalidSettings("tolerance is NaN"));
        }
        Ok(())
    }
}

/// Why [`PoseGraph::optimise`] did not run; the poses are as they were.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum OptimiseError {
    /// There is no edge, so nothing to minimise.
    #[error("the graph has no edges")]
    NoEdges,
    /// Every node is fixed.
    #[error("no node is free to move")]
    NoFreeNodes,
    /// A node's pose is NaN or infinite (from [`PoseGraph::add_node`] or
    /// [`PoseGraph::set_node`]); the cost cannot be evaluated.
    #[error("node {index} has a non-finite pose")]
    NonFiniteNode {
        /// The first such node.
        index: usize,
    },
    /// The cost at the initial poses overflows (information too large for f64), so no step can
    /// be compared with it.
    #[error("the cost at the initial poses is not finite")]
    NonFiniteCost,
    /// A kernel scale or the tolerance is unusable.
    #[error("invalid optimiser settings: {0}")]
    InvalidSettings(&'static str),
    /// The sparse symbolic factorisation could not be set up (out of memory or index overflow).
    #[error("sparse Cholesky setup failed: {0}")]
    SolverSetup(&'static str),
    /// The information matrix is not numerically positive definite: some motion of the free
    /// nodes is not constrained by the edges, so its covariance is unbounded.
    #[error("the graph's information matrix is singular (a free node is not pinned down)")]
    Singular,
}

/// How [`PoseGraph::optimise`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OptimiseStatus {
    /// The largest update fell below [`OptimiserSettings::tolerance`].
    Converged,
    /// [`OptimiserSettings::max_iterations`] ran out first (the poses are the best found).
    MaxIterations,
    /// No damping tried lowered the cost further: at a minimum up to rounding, or stuck on a
    /// numerically unusable system. The poses are the best found.
    Stalled,
    /// Nothing was done, for the reason given.
    NotRun(OptimiseError),
}

/// Outcome of [`PoseGraph::optimise`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OptimiseReport {
    /// Iterations run.
    pub iterations: u32,
    /// Robust cost before.
    pub initial_cost: f64,
    /// Robust cost after.
    pub final_cost: f64,
    /// How it ended.
    pub status: OptimiseStatus,
    /// Nodes the optimiser was free to move (not fixed).
    pub free_nodes: usize,
    /// Nodes not joined to any fixed node through edges (isolated nodes included). The cost
    /// does not depend on where such a group sits as a whole, so only the damping keeps it near
    /// its initial placement; a non-zero count usually means a missing edge.
    pub unanchored_nodes: usize,
}

/// Keyframe poses and the measurements between them.
#[derive(Debug, Clone, Default)]
pub struct PoseGraph {
    nodes: Vec<Pose2>,
    fixed: Vec<bool>,
    edges: Vec<Edge>,
}

/// Error of edge `e` at poses `xi`, `xj`: `z⁻¹ ⊕ (xi⁻¹ ⊕ xj)` as (x, y, yaw).
fn edge_error(xi: &Pose2, xj: &Pose2, z: &Pose2) -> Vector3<f64> {
    let d = z.inverse().compose(&xi.between(xj));
    Vector3::new(d.x_m, d.y_m, d.yaw_rad)
}

/// Jacobians of the simplified error `Rzᵀ(Riᵀ(tj − ti) − tz), θj − θi − θz` w.r.t. xi and xj.
fn jacobians(xi: &Pose2, xj: &Pose2, z: &Pose2) -> (Matrix3<f64>, Matrix3<f64>) {
    let (si, ci) = xi.yaw_rad.sin_cos();
    let (sz, cz) = z.yaw_rad.sin_cos();
    let rz_t = nalgebra::Matrix2::new(cz, sz, -sz, cz);
    let ri_t = nalgebra::Matrix2::new(ci, si, -si, ci);
    let dri_t = nalgebra::Matrix2::new(-si, ci, -ci, -si);
    let dt = nalgebra::Vector2::new(xj.x_m - xi.x_m, xj.y_m - xi.y_m);
    let a_t = -(rz_t * ri_t);
    let a_r = rz_t * dri_t * dt;
    let b_t = rz_t * ri_t;
    let mut a = Matrix3::zeros();
    let mut b = Matrix3::zeros();
    a.fixed_view_mut::<2, 2>(0, 0).copy_from(&a_t);
    a[(0, 2)] = a_r[0];
    a[(1, 2)] = a_r[1];
    a[(2, 2)] = -1.0;
    b.fixed_view_mut::<2, 2>(0, 0).copy_from(&b_t);
    b[(2, 2)] = 1.0;
    (a, b)
}

/// The marginal covariance of a node `xj` joined to the rest of a graph by one edge only, from
/// `xi` (whose marginal covariance is `covariance_i`) with measurement `z` and `information`:
/// the linearised propagation `B⁻¹A Σᵢ AᵀB⁻ᵀ + B⁻¹ Ω⁻¹ B⁻ᵀ` of the edge's error Jacobians, which
/// is what [`PoseGraph::marginal_covariances`] gives such a leaf at these poses. `None` when
/// the information cannot be inverted.
pub fn leaf_covariance(
    xi: &Pose2,
    xj: &Pose2,
    z: &Pose2,
    covariance_i: &Matrix3<f64>,
    information: &Matrix3<f64>,
) -> Option<Matrix3<f64>> {
    let (a, b) = jacobians(xi, xj, z);
    let b_inv = b.try_inverse()?;
    let edge_covariance = information.try_inverse()?;
    let from_i = b_inv * a;
    let covariance =
        from_i * covariance_i * from_i.transpose() + b_inv * edge_covariance * b_inv.transpose();
    covariance
        .iter()
        .all(|v| v.is_finite())
        .then(|| (covariance + covariance.transpose()) * 0.5)
}

/// Checks an information matrix: finite, symmetric, positive semi-definite, not zero.
fn check_information(information: &Matrix3<f64>) -> Result<(), EdgeError> {
    if !information.iter().all(|v| v.is_finite()) {
        return Err(EdgeError::NonFiniteInformation);
    }
    let scale = information.amax();
    if scale == 0.0 {
        return Err(EdgeError::ZeroInformation);
    }
    // Checked on the matrix scaled to a largest entry of 1: information values span many orders
    // of magnitude (1/σ² for σ from millimetres to metres), and sums or eigenvalues of entries
    // near f64::MAX would overflow. The tolerances allow for a matrix built as the inverse of a
    // covariance, symmetric and semi-definite only up to rounding.
    let unit = information / scale;
    if (unit - unit.transpose()).amax() > 1e-9 {
        return Err(EdgeError::AsymmetricInformation);
    }
    let min_eigenvalue = ((unit + unit.transpose()) * 0.5)
        .symmetric_eigenvalues()
        .min();
    if min_eigenvalue.is_nan() || min_eigenvalue < -1e-12 {
        return Err(EdgeError::IndefiniteInformation);
    }
    Ok(())
}

/// One edge's contribution to the normal equations, with `f` its `from` node and `t` its `to`
/// node: `H_ff = AᵀΩA`, `H_tt = BᵀΩB`, `H_ft = AᵀΩB`, `g_f = AᵀΩe`, `g_t = BᵀΩe`.
struct EdgeBlocks {
    h_ff: Matrix3<f64>,
    h_tt: Matrix3<f64>,
    h_ft: Matrix3<f64>,
    g_f: Vector3<f64>,
    g_t: Vector3<f64>,
}

/// Which unknowns the free nodes are: node `k` is block `block_of[k]` (3 unknowns), fixed
/// nodes have none.
struct Layout {
    block_of: Vec<Option<usize>>,
    free: usize,
    /// Per edge, the blocks of its `from` and `to` nodes.
    edge_blocks: Vec<[Option<usize>; 2]>,
}

impl Layout {
    fn new(fixed: &[bool], edges: &[Edge]) -> Self {
        let mut free = 0;
        let block_of: Vec<Option<usize>> = fixed
            .iter()
            .map(|&is_fixed| {
                (!is_fixed).then(|| {
                    free += 1;
                    free - 1
                })
            })
            .collect();
        let edge_blocks = edges
            .iter()
            .map(|e| [block_of[e.from], block_of[e.to]])
            .collect();
        Layout {
            block_of,
            free,
            edge_blocks,
        }
    }

    fn dim(&self) -> usize {
        3 * self.free
    }
}

/// A linear solver for the damped normal equations: assembled edge by edge, then solved for
/// several dampings.
trait NormalEquations: Sized {
    /// Sets up for `layout` (the sparsity pattern is fixed from here on).
    fn new(layout: &Layout) -> Result<Self, OptimiseError>;
    /// Zeroes `H` and `g`.
    fn clear(&mut self);
    /// Adds edge `index`'s blocks; `blocks` are the free blocks of its two nodes.
    fn add(&mut self, index: usize, blocks: [Option<usize>; 2], edge: &EdgeBlocks);
    /// Solves `(H + λ (diag H + 1e-9)) δ = −g` into `delta`; false when the damped matrix is
    /// not numerically positive definite.
    fn solve(&mut self, lambda: f64, delta: &mut [f64]) -> bool;
}

/// Where one 3×3 block lives in the compressed-column values: entry (p, q) of the block is at
/// `column_base[q] + p`.
#[derive(Clone, Copy)]
struct BlockSlot {
    column_base: [usize; 3],
}

/// Per edge: the slots of its two diagonal blocks and of its off-diagonal block (`true` when the
/// stored block is `H_tf = H_ftᵀ`, i.e. the `to` node comes first in the unknowns).
#[derive(Clone, Copy)]
struct EdgeSlots {
    diagonal: [Option<BlockSlot>; 2],
    cross: Option<(BlockSlot, bool)>,
}

/// The sparse normal equations: the upper triangle of `H` in compressed-column form, factored
/// by `faer`'s sparse Cholesky with an AMD ordering.
struct SparseNormalEquations {
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    /// Undamped `H` values (upper triangle), in `row_idx` order.
    hessian: Vec<f64>,
    /// `H` plus damping, rewritten for every damping tried.
    damped: Vec<f64>,
    /// Position of each diagonal entry in the values.
    diagonal: Vec<usize>,
    slots: Vec<EdgeSlots>,
    gradient: Vec<f64>,
    symbolic: SymbolicCholesky<usize>,
    factor: Vec<f64>,
    workspace: MemBuffer,
}

impl SparseNormalEquations {
    /// Builds the pattern and the symbolic factorisation with the given ordering (tests compare
    /// AMD with the natural order).
    fn with_ordering(layout: &Layout, ordering: Ordering) -> Result<Self, OptimiseError> {
        let free = layout.free;
        // Block rows r ≤ c present in block column c: the diagonal and every edge's pair.
        let mut rows_of: Vec<Vec<usize>> = (0..free).map(|c| vec![c]).collect();
        for blocks in &layout.edge_blocks {
            if let [Some(a), Some(b)] = *blocks {
                rows_of[a.max(b)].push(a.min(b));
            }
        }
        for rows in &mut rows_of {
            rows.sort_unstable();
            rows.dedup();
        }
        let dim = layout.dim();
        let mut col_ptr = Vec::with_capacity(dim + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        for (c, rows) in rows_of.iter().enumerate() {
            for q in 0..3 {
                for &r in rows {
                    // Strictly-upper blocks are stored whole; the diagonal block only down to
                    // the diagonal. Rows stay sorted because 3r + 2 < 3c for r < c.
                    let last = if r < c { 3 } else { q + 1 };
                    row_idx.extend((0..last).map(|p| 3 * r + p));
                }
                col_ptr.push(row_idx.len());
            }
        }
        let slot = |r: usize, c: usize| -> BlockSlot {
            // `rows_of[c]` holds r by construction; the diagonal block is last in its column.
            let position = rows_of[c].binary_search(&r).unwrap_or(0);
            BlockSlot {
                column_base: [0, 1, 2].map(|q| col_ptr[3 * c + q] + 3 * position),
            }
        };
        let slots = layout
            .edge_blocks
            .iter()
            .map(|blocks| EdgeSlots {
                diagonal: blocks.map(|b| b.map(|b| slot(b, b))),
                cross: match *blocks {
                    [Some(f), Some(t)] if f < t => Some((slot(f, t), false)),
                    [Some(f), Some(t)] => Some((slot(t, f), true)),
                    _ => None,
                },
            })
            .collect();
        let diagonal = (0..dim).map(|d| col_ptr[d + 1] - 1).collect();
        let pattern = SymbolicSparseColMatRef::new_checked(dim, dim, &col_ptr, None, &row_idx);
        let ordering = match ordering {
            Ordering::Amd => SymmetricOrdering::Amd,
            Ordering::Natural => SymmetricOrdering::Identity,
        };
        let symbolic = factorize_symbolic_cholesky(
            pattern,
            Side::Upper,
            ordering,
            CholeskySymbolicParams::default(),
        )
        .map_err(|_| OptimiseError::SolverSetup("symbolic factorisation"))?;
        let scratch = symbolic
            .factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default())
            .or(symbolic.solve_in_place_scratch::<f64>(1, Par::Seq));
        let workspace = MemBuffer::try_new(scratch)
            .map_err(|_| OptimiseError::SolverSetup("out of memory for the workspace"))?;
        let nnz = row_idx.len();
        Ok(SparseNormalEquations {
            factor: vec![0.0; symbolic.len_val()],
            col_ptr,
            row_idx,
            hessian: vec![0.0; nnz],
            damped: vec![0.0; nnz],
            diagonal,
            slots,
            gradient: vec![0.0; dim],
            symbolic,
            workspace,
        })
    }
}

/// Fill-reducing ordering for [`SparseNormalEquations::with_ordering`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ordering {
    Amd,
    #[cfg_attr(not(test), allow(dead_code))]
    Natural,
}

/// Adds a whole off-diagonal `block` (or its transpose) at `slot`.
fn add_block(values: &mut [f64], slot: BlockSlot, block: &Matrix3<f64>, transpose: bool) {
    for q in 0..3 {
        for p in 0..3 {
            values[slot.column_base[q] + p] += if transpose {
                block[(q, p)]
            } else {
                block[(p, q)]
            };
        }
    }
}

/// Adds the upper triangle of a symmetric diagonal block at `slot`.
fn add_diagonal_block(values: &mut [f64], slot: BlockSlot, block: &Matrix3<f64>) {
    for q in 0..3 {
        for p in 0..=q {
            values[slot.column_base[q] + p] += block[(p, q)];
        }
    }
}

impl SparseNormalEquations {
    /// The diagonal 3×3 blocks of `H⁻¹` (the undamped `H` as last assembled), one per free
    /// block, by solving for the unit vectors in batches of columns; `None` when `H` is not
    /// numerically positive definite. Costs one factorisation and 3n sparse triangular solves.
    fn inverse_diagonal_blocks(&mut self) -> Option<Vec<Matrix3<f64>>> {
        let blocks: Vec<usize> = (0..self.gradient.len() / 3).collect();
        self.inverse_blocks(&blocks)
    }

    /// The diagonal 3×3 blocks of `H⁻¹` of the free blocks `wanted`, in that order: one
    /// factorisation and three sparse triangular solves per block.
    fn inverse_blocks(&mut self, wanted: &[usize]) -> Option<Vec<Matrix3<f64>>> {
        /// Blocks solved per batch: the right-hand sides take dim × 3 × BATCH values.
        const BATCH: usize = 32;
        let dim = self.gradient.len();
        let pattern =
            SymbolicSparseColMatRef::new_checked(dim, dim, &self.col_ptr, None, &self.row_idx);
        let matrix = SparseColMatRef::new(pattern, &self.hessian);
        let llt = self
            .symbolic
            .factorize_numeric_llt::<f64>(
                &mut self.factor,
                matrix,
                Side::Upper,
                LltRegularization::default(),
                Par::Seq,
                MemStack::new(&mut self.workspace),
                Default::default(),
            )
            .ok()?;
        let columns = 3 * BATCH.min(wanted.len().max(1));
        let mut scratch = MemBuffer::try_new(
            self.symbolic
                .solve_in_place_scratch::<f64>(columns, Par::Seq),
        )
        .ok()?;
        let mut rhs = vec![0.0; dim * columns];
        let mut out = Vec::with_capacity(wanted.len());
        for batch in wanted.chunks(BATCH) {
            rhs.fill(0.0);
            for (b, &block) in batch.iter().enumerate() {
                for d in 0..3 {
                    rhs[(3 * b + d) * dim + 3 * block + d] = 1.0;
                }
            }
            let count = batch.len();
            let view =
                MatMut::from_column_major_slice_mut(&mut rhs[..dim * 3 * count], dim, 3 * count);
            llt.solve_in_place_with_conj(Conj::No, view, Par::Seq, MemStack::new(&mut scratch));
            for (b, &block) in batch.iter().enumerate() {
                let row = 3 * block;
                let block = Matrix3::from_fn(|p, q| rhs[(3 * b + q) * dim + row + p]);
                if !block.iter().all(|v| v.is_finite()) || (0..3).any(|d| block[(d, d)] <= 0.0) {
                    return None;
                }
                out.push((block + block.transpose()) * 0.5);
            }
        }
        Some(out)
    }
}

impl NormalEquations for SparseNormalEquations {
    fn new(layout: &Layout) -> Result<Self, OptimiseError> {
        Self::with_ordering(layout, Ordering::Amd)
    }

    fn clear(&mut self) {
        self.hessian.fill(0.0);
        self.gradient.fill(0.0);
    }

    fn add(&mut self, index: usize, blocks: [Option<usize>; 2], edge: &EdgeBlocks) {
        let slots = self.slots[index];
        let diagonal = [&edge.h_ff, &edge.h_tt];
        let gradient = [&edge.g_f, &edge.g_t];
        for k in 0..2 {
            if let (Some(slot), Some(block)) = (slots.diagonal[k], blocks[k]) {
                add_diagonal_block(&mut self.hessian, slot, diagonal[k]);
                for (total, g) in self.gradient[3 * block..3 * block + 3]
                    .iter_mut()
                    .zip(gradient[k].iter())
                {
                    *total += g;
                }
            }
        }
        if let Some((slot, transpose)) = slots.cross {
            add_block(&mut self.hessian, slot, &edge.h_ft, transpose);
        }
    }

    fn solve(&mut self, lambda: f64, delta: &mut [f64]) -> bool {
        self.damped.copy_from_slice(&self.hessian);
        for &d in &self.diagonal {
            self.damped[d] += lambda * (self.hessian[d] + 1e-9);
        }
        let dim = self.gradient.len();
        let pattern =
            SymbolicSparseColMatRef::new_checked(dim, dim, &self.col_ptr, None, &self.row_idx);
        let matrix = SparseColMatRef::new(pattern, &self.damped);
        let stack = MemStack::new(&mut self.workspace);
        let Ok(llt) = self.symbolic.factorize_numeric_llt::<f64>(
            &mut self.factor,
            matrix,
            Side::Upper,
            LltRegularization::default(),
            Par::Seq,
            stack,
            Default::default(),
        ) else {
            return false;
        };
        for (d, g) in delta.iter_mut().zip(&self.gradient) {
            *d = -g;
        }
        let rhs = MatMut::from_column_major_slice_mut(delta, dim, 1);
        llt.solve_in_place_with_conj(Conj::No, rhs, Par::Seq, MemStack::new(&mut self.workspace));
        true
    }
}

/// The dense normal equations (nalgebra Cholesky of the whole 3n × 3n matrix): the solver this
/// module used before the sparse one, kept only as the reference [`PoseGraph::optimise_dense`]
/// measures against.
struct DenseNormalEquations {
    hessian: DMatrix<f64>,
    gradient: DVector<f64>,
}

impl NormalEquations for DenseNormalEquations {
    fn new(layout: &Layout) -> Result<Self, OptimiseError> {
        let dim = layout.dim();
        Ok(DenseNormalEquations {
            hessian: DMatrix::zeros(dim, dim),
            gradient: DVector::zeros(dim),
        })
    }

    fn clear(&mut self) {
        self.hessian.fill(0.0);
        self.gradient.fill(0.0);
    }

    fn add(&mut self, _index: usize, blocks: [Option<usize>; 2], edge: &EdgeBlocks) {
        let h = [[edge.h_ff, edge.h_ft], [edge.h_ft.transpose(), edge.h_tt]];
        let g = [edge.g_f, edge.g_t];
        for k in 0..2 {
            let Some(bk) = blocks[k] else { continue };
            let mut gk = self.gradient.fixed_rows_mut::<3>(3 * bk);
            gk += g[k];
            for l in 0..2 {
                let Some(bl) = blocks[l] else { continue };
                let mut hkl = self.hessian.fixed_view_mut::<3, 3>(3 * bk, 3 * bl);
                hkl += h[k][l];
            }
        }
    }

    fn solve(&mut self, lambda: f64, delta: &mut [f64]) -> bool {
        let mut damped = self.hessian.clone();
        for d in 0..damped.nrows() {
            damped[(d, d)] += lambda * (self.hessian[(d, d)] + 1e-9);
        }
        let Some(chol) = damped.cholesky() else {
            return false;
        };
        let solution = chol.solve(&(-&self.gradient));
        delta.copy_from_slice(solution.as_slice());
        true
    }
}

impl PoseGraph {
    /// An empty graph.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a node at `pose`; returns its index. The first node is fixed (it anchors the map
    /// frame); see [`PoseGraph::set_fixed`]. A non-finite pose is stored, but
    /// [`PoseGraph::optimise`] refuses to run until it is replaced.
    pub fn add_node(&mut self, pose: Pose2) -> usize {
        self.fixed.push(self.nodes.is_empty());
        self.nodes.push(pose);
        self.nodes.len() - 1
    }

    /// Adds an edge. Edges [`PoseGraph::try_add_edge`] refuses are ignored (returns false), so
    /// that no input can make the optimisation produce NaN.
    pub fn add_edge(&mut self, edge: Edge) -> bool {
        self.try_add_edge(edge).is_ok()
    }

    /// Adds an edge, or says why it is refused: a missing or repeated node, a non-finite
    /// measurement, or information that is non-finite, asymmetric, indefinite or zero. Returns
    /// the edge's index.
    pub fn try_add_edge(&mut self, edge: Edge) -> Result<usize, EdgeError> {
        let nodes = self.nodes.len();
        for index in [edge.from, edge.to] {
            if index >= nodes {
                return Err(EdgeError::MissingNode { index, nodes });
            }
        }
        if edge.from == edge.to {
            return Err(EdgeError::SelfLoop(edge.from));
        }
        if !edge.measurement.is_finite() {
            return Err(EdgeError::NonFiniteMeasurement);
        }
        check_information(&edge.information)?;
        self.edges.push(edge);
        Ok(self.edges.len() - 1)
    }

    /// The node poses.
    pub fn nodes(&self) -> &[Pose2] {
        &self.nodes
    }

    /// The edges.
    pub fn edges(&self) -> &[Edge] {
        &self.edges
    }

    /// Keeps only the edges for which `keep` holds, in their order; returns, per edge before,
    /// whether it was kept.
    pub fn retain_edges(&mut self, mut keep: impl FnMut(&Edge) -> bool) -> Vec<bool> {
        let kept: Vec<bool> = self.edges.iter().map(&mut keep).collect();
        let mut flags = kept.iter();
        self.edges.retain(|_| flags.next().copied().unwrap_or(true));
        kept
    }

    /// Replaces node `index`'s pose (e.g. the front end's latest estimate).
    pub fn set_node(&mut self, index: usize, pose: Pose2) {
        if let Some(node) = self.nodes.get_mut(index) {
            *node = pose;
        }
    }

    /// Holds node `index` in place during optimisation (`true`) or lets it move (`false`);
    /// false when there is no such node. Node 0 is fixed from the start. Fixing several nodes
    /// pins a graph to known poses (e.g. surveyed markers, or an earlier session's map); a
    /// group of nodes with no fixed node among them is counted in
    /// [`OptimiseReport::unanchored_nodes`].
    pub fn set_fixed(&mut self, index: usize, fixed: bool) -> bool {
        match self.fixed.get_mut(index) {
            Some(flag) => {
                *flag = fixed;
                true
            }
            None => false,
        }
    }

    /// True when node `index` exists and is held in place.
    pub fn is_fixed(&self, index: usize) -> bool {
        self.fixed.get(index).copied().unwrap_or(false)
    }

    /// Robust cost at `nodes`.
    fn cost(&self, nodes: &[Pose2], settings: &OptimiserSettings) -> f64 {
        self.edges
            .iter()
            .map(|e| {
                let err = edge_error(&nodes[e.from], &nodes[e.to], &e.measurement);
                let chi2 = (err.transpose() * e.information * err)[0];
                let (kernel, k_sigma) = settings.kernel(e.kind);
                kernel.cost(chi2, k_sigma)
            })
            .sum()
    }

    /// Nodes not joined through edges to any fixed node (union–find over the edges).
    fn unanchored_nodes(&self) -> usize {
        fn root(parent: &mut [usize], mut k: usize) -> usize {
            while parent[k] != k {
                parent[k] = parent[parent[k]];
                k = parent[k];
            }
            k
        }
        let n = self.nodes.len();
        let mut parent: Vec<usize> = (0..n).collect();
        for e in &self.edges {
            let (a, b) = (root(&mut parent, e.from), root(&mut parent, e.to));
            parent[a.max(b)] = a.min(b);
        }
        let mut anchored = vec![false; n];
        for k in (0..n).filter(|&k| self.fixed[k]) {
            let r = root(&mut parent, k);
            anchored[r] = true;
        }
        (0..n).filter(|&k| !anchored[root(&mut parent, k)]).count()
    }

    /// Minimises the robust cost by Levenberg–Marquardt with the fixed nodes held in place,
    /// solving each step with a sparse Cholesky (see the module documentation). Deterministic;
    /// never panics; a step that fails numerically is retried with more damping and never
    /// applied, so the poses stay finite. [`OptimiseReport::status`] says how it ended.
    pub fn optimise(&mut self, settings: &OptimiserSettings) -> OptimiseReport {
        self.run::<SparseNormalEquations>(settings)
    }

    /// [`PoseGraph::optimise`] with the dense 3n × 3n Cholesky this module used before. Same
    /// iterations and results up to rounding; O(n³) per iteration. For benchmarks and tests
    /// only.
    #[doc(hidden)]
    pub fn optimise_dense(&mut self, settings: &OptimiserSettings) -> OptimiseReport {
        self.run::<DenseNormalEquations>(settings)
    }

    /// Why the graph cannot be optimised as it stands, if it cannot.
    fn check(
        &self,
        settings: &OptimiserSettings,
        layout: &Layout,
        initial_cost: f64,
    ) -> Result<(), OptimiseError> {
        settings.validate()?;
        if let Some(index) = self.nodes.iter().position(|p| !p.is_finite()) {
            return Err(OptimiseError::NonFiniteNode { index });
        }
        if self.edges.is_empty() {
            return Err(OptimiseError::NoEdges);
        }
        if layout.free == 0 {
            return Err(OptimiseError::NoFreeNodes);
        }
        if !initial_cost.is_finite() {
            return Err(OptimiseError::NonFiniteCost);
        }
        Ok(())
    }

    /// Assembles the normal equations at the current poses into `system`, each edge with the
    /// information `information(index, edge)` times its robust kernel's weight.
    fn assemble<S: NormalEquations>(
        &self,
        layout: &Layout,
        settings: &OptimiserSettings,
        system: &mut S,
        information: impl Fn(usize, &Edge) -> Matrix3<f64>,
    ) {
        system.clear();
        for (index, e) in self.edges.iter().enumerate() {
            let blocks = layout.edge_blocks[index];
            if blocks == [None, None] {
                continue;
            }
            let (xi, xj) = (&self.nodes[e.from], &self.nodes[e.to]);
            let err = edge_error(xi, xj, &e.measurement);
            let chi2 = (err.transpose() * e.information * err)[0];
            let (kernel, k_sigma) = settings.kernel(e.kind);
            let omega = information(index, e) * kernel.weight(chi2, k_sigma);
            let (a, b) = jacobians(xi, xj, &e.measurement);
            let (at_omega, bt_omega) = (a.transpose() * omega, b.transpose() * omega);
            let edge = EdgeBlocks {
                h_ff: at_omega * a,
                h_tt: bt_omega * b,
                h_ft: at_omega * b,
                g_f: at_omega * err,
                g_t: bt_omega * err,
            };
            system.add(index, blocks, &edge);
        }
    }

    /// The marginal covariance of every node's pose (x m, y m, yaw rad; map frame) at the
    /// current poses: the diagonal 3×3 blocks of the inverse of the Gauss–Newton information
    /// matrix, the Laplace approximation of the posterior (Grisetti et al. 2010). Fixed nodes
    /// get zero. `information(index, edge)` is the information each edge is taken to carry
    /// (its own, [`Edge::information`], or a calibrated one), weighted by its robust kernel at
    /// its current residual as in [`PoseGraph::optimise`].
    ///
    /// # Errors
    /// What [`PoseGraph::optimise`] would refuse (no edges, no free node, a non-finite pose or
    /// cost, bad settings), and [`OptimiseError::Singular`] when an unanchored node leaves the
    /// information singular.
    pub fn marginal_covariances(
        &self,
        settings: &OptimiserSettings,
        information: impl Fn(usize, &Edge) -> Matrix3<f64>,
    ) -> Result<Vec<Matrix3<f64>>, OptimiseError> {
        let layout = Layout::new(&self.fixed, &self.edges);
        self.check(settings, &layout, self.cost(&self.nodes, settings))?;
        let mut system = SparseNormalEquations::new(&layout)?;
        self.assemble(&layout, settings, &mut system, information);
        let blocks = system
            .inverse_diagonal_blocks()
            .ok_or(OptimiseError::Singular)?;
        Ok(layout
            .block_of
            .iter()
            .map(|b| b.map_or_else(Matrix3::zeros, |b| blocks[b]))
            .collect())
    }

    /// How well a measurement `measurement` of node `to`'s pose in node `from`'s frame agrees
    /// with this graph: its error against the graph's estimate of that relative pose, as χ²
    /// under both uncertainties, the measurement's (`measurement_information`) and the
    /// graph's. The graph's is the marginal covariance of `to` with `from` held fixed in place
    /// of the graph's own fixed nodes (every edge is relative, so that is the uncertainty of
    /// the relative pose), with edges carrying `information(index, edge)` as in
    /// [`PoseGraph::marginal_covariances`]. Also returns the graph's own std of that relative
    /// position along its weakest axis (m): a large one means the graph holds little
    /// evidence on it to agree or disagree with.
    ///
    /// # Errors
    /// What [`PoseGraph::marginal_covariances`] refuses, and [`OptimiseError::Singular`] when
    /// the combined covariance cannot be inverted.
    ///
    /// # Panics
    /// If `from` or `to` is not a node.
    pub fn relative_consistency(
        &self,
        from: usize,
        to: usize,
        measurement: &Pose2,
        measurement_information: &Matrix3<f64>,
        settings: &OptimiserSettings,
        information: impl Fn(usize, &Edge) -> Matrix3<f64>,
    ) -> Result<(f64, f64), OptimiseError> {
        let mut fixed = vec![false; self.nodes.len()];
        fixed[from] = true;
        let covariance_to = self.marginal_covariance_anchored(&fixed, to, settings, information)?;
        let (xi, xj) = (&self.nodes[from], &self.nodes[to]);
        let err = edge_error(xi, xj, measurement);
        let (_, b) = jacobians(xi, xj, measurement);
        let graph = b * covariance_to * b.transpose();
        let measurement_covariance = measurement_information
            .try_inverse()
            .ok_or(OptimiseError::Singular)?;
        let combined = (graph + measurement_covariance)
            .try_inverse()
            .ok_or(OptimiseError::Singular)?;
        let chi2 = (err.transpose() * combined * err)[0];
        let position = graph.fixed_view::<2, 2>(0, 0).symmetric_eigenvalues();
        let weakest_std_m = position.max().max(0.0).sqrt();
        Ok((chi2, weakest_std_m))
    }

    /// [`PoseGraph::marginal_covariances`] of node `node` alone (zero if it is fixed), at the
    /// cost of three triangular solves instead of three per node.
    ///
    /// # Errors
    /// As [`PoseGraph::marginal_covariances`].
    ///
    /// # Panics
    /// If `node` is not a node.
    pub fn marginal_covariance_of(
        &self,
        node: usize,
        settings: &OptimiserSettings,
        information: impl Fn(usize, &Edge) -> Matrix3<f64>,
    ) -> Result<Matrix3<f64>, OptimiseError> {
        self.marginal_covariance_anchored(&self.fixed, node, settings, information)
    }

    /// [`PoseGraph::marginal_covariance_of`] with the nodes `fixed` holds fixed in place of the
    /// graph's own: no copy of the graph to move its anchor.
    fn marginal_covariance_anchored(
        &self,
        fixed: &[bool],
        node: usize,
        settings: &OptimiserSettings,
        information: impl Fn(usize, &Edge) -> Matrix3<f64>,
    ) -> Result<Matrix3<f64>, OptimiseError> {
        let layout = Layout::new(fixed, &self.edges);
        self.check(settings, &layout, self.cost(&self.nodes, settings))?;
        let Some(block) = layout.block_of[node] else {
            return Ok(Matrix3::zeros());
        };
        let mut system = SparseNormalEquations::new(&layout)?;
        self.assemble(&layout, settings, &mut system, information);
        let blocks = system
            .inverse_blocks(&[block])
            .ok_or(OptimiseError::Singular)?;
        Ok(blocks[0])
    }

    /// The Levenberg–Marquardt loop, on either linear solver.
    fn run<S: NormalEquations>(&mut self, settings: &OptimiserSettings) -> OptimiseReport {
        let layout = Layout::new(&self.fixed, &self.edges);
        let initial_cost = self.cost(&self.nodes, settings);
        let mut report = OptimiseReport {
            iterations: 0,
            initial_cost,
            final_cost: initial_cost,
            status: OptimiseStatus::MaxIterations,
            free_nodes: layout.free,
            unanchored_nodes: self.unanchored_nodes(),
        };
        let setup = self
            .check(settings, &layout, initial_cost)
            .and_then(|()| S::new(&layout));
        let mut system = match setup {
            Ok(system) => system,
            Err(reason) => {
                report.status = OptimiseStatus::NotRun(reason);
                return report;
            }
        };
        let mut delta = vec![0.0; layout.dim()];
        let mut lambda = 1e-4;
        let mut cost = initial_cost;
        for iteration in 1..=settings.max_iterations {
            report.iterations = iteration;
            self.assemble(&layout, settings, &mut system, |_, e| e.information);
            // Levenberg–Marquardt: retry with more damping until the cost falls.
            let mut accepted = false;
            for _ in 0..10 {
                if !system.solve(lambda, &mut delta) || !delta.iter().all(|v| v.is_finite()) {
                    lambda *= 10.0;
                    continue;
                }
                let candidate: Vec<Pose2> = self
                    .nodes
                    .iter()
                    .zip(&layout.block_of)
                    .map(|(p, block)| match block {
                        None => *p,
                        Some(b) => {
                            let r = 3 * b;
                            Pose2::new(
                                p.x_m + delta[r],
                                p.y_m + delta[r + 1],
                                wrap_angle_rad(p.yaw_rad + delta[r + 2]),
                            )
                        }
                    })
                    .collect();
                let new_cost = self.cost(&candidate, settings);
                if new_cost.is_finite() && new_cost <= cost {
                    let step = delta.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
                    self.nodes = candidate;
                    cost = new_cost;
                    lambda = (lambda * 0.1).max(1e-9);
                    accepted = true;
                    if step < settings.tolerance {
                        report.final_cost = cost;
                        report.status = OptimiseStatus::Converged;
                        return report;
                    }
                    break;
                }
                lambda *= 10.0;
            }
            if !accepted {
                report.status = OptimiseStatus::Stalled;
                break;
            }
        }
        report.final_cost = cost;
        report
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::{laps, multi_lap_graph, odometry_graph, Drift};
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A square loop of `side` poses per side, 1 m apart, turning 90° at each corner.
    fn square(side: usize) -> Vec<Pose2> {
        laps(side, 4 * side)
    }

    /// A graph with drifting odometry edges over `truth` and, optionally, an exact loop edge
    /// from the last pose back to the first.
    fn drifting_graph(truth: &[Pose2], seed: u64, with_loop: bool) -> PoseGraph {
        // A systematic heading bias plus noise: the drift loop closure exists for.
        let drift = Drift {
            step_m: 0.02,
            yaw_rad: 0.005,
            yaw_bias_rad: 0.01,
            std_m: 0.05,
            std_rad: 0.02,
        };
        let mut graph = odometry_graph(truth, &mut ChaCha8Rng::seed_from_u64(seed), &drift);
        if with_loop {
            let last = truth.len() - 1;
            let z = truth[last].between(&truth[0]);
            graph.add_edge(Edge::with_std(last, 0, z, 0.02, 0.005, EdgeKind::Loop));
        }
        graph
    }

    /// A graph at `truth` with exact odometry edges of these standard deviations.
    fn exact_odometry_graph(truth: &[Pose2], std_m: f64, std_rad: f64) -> PoseGraph {
        let mut graph = PoseGraph::new();
        for p in truth {
            graph.add_node(*p);
        }
        for k in 1..truth.len() {
            let z = truth[k - 1].between(&truth[k]);
            graph.add_edge(Edge::with_std(
                k - 1,
                k,
                z,
                std_m,
                std_rad,
                EdgeKind::Odometry,
            ));
        }
        graph
    }

    fn max_error_m(graph: &PoseGraph, truth: &[Pose2]) -> f64 {
        graph
            .nodes()
            .iter()
            .zip(truth)
            .map(|(a, b)| a.distance_m(b))
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_loop_edge_removes_most_of_the_drift() {
        let truth = square(10);
        let open = drifting_graph(&truth, 3, false);
        let mut closed = drifting_graph(&truth, 3, true);
        let before = max_error_m(&open, &truth);
        let report = closed.optimise(&OptimiserSettings::default());
        let after = max_error_m(&closed, &truth);
        assert!(before > 2.0, "the test needs real drift: {before}");
        assert!(
            after < 0.25 * before,
            "{before} m -> {after} m ({report:?})"
        );
        assert!(report.final_cost < report.initial_cost);
        assert_eq!(closed.nodes()[0], truth[0], "node 0 is fixed");
    }

    #[test]
    fn retained_edges_keep_their_order_and_the_mask_says_which_left() {
        let mut graph = PoseGraph::new();
        for k in 0..4 {
            graph.add_node(Pose2::new(f64::from(k), 0.0, 0.0));
        }
        for (from, to) in [(0, 1), (1, 2), (2, 3), (0, 3)] {
            assert!(graph.add_edge(Edge::with_std(
                from,
                to,
                Pose2::default(),
                0.1,
                0.01,
                EdgeKind::Odometry
            )));
        }
        let kept = graph.retain_edges(|e| e.to != 2);
        assert_eq!(kept, vec![true, false, true, true]);
        let left: Vec<(usize, usize)> = graph.edges().iter().map(|e| (e.from, e.to)).collect();
        assert_eq!(left, vec![(0, 1), (2, 3), (0, 3)]);
    }

    #[test]
    fn a_consistent_graph_does_not_move() {
        let truth = square(5);
        let mut graph = exact_odometry_graph(&truth, 0.1, 0.01);
        graph.add_edge(Edge::with_std(
            truth.len() - 1,
            0,
            truth[truth.len() - 1].between(&truth[0]),
            0.1,
            0.01,
            EdgeKind::Loop,
        ));
        graph.optimise(&OptimiserSettings::default());
        assert!(max_error_m(&graph, &truth) < 1e-9);
    }

    #[test]
    fn a_wrong_loop_edge_is_down_weighted() {
        // A loop edge 5 m off with the same information as a right one: the Cauchy kernel keeps
        // the map from bending to it as far as plain least squares would.
        let truth = square(8);
        let graph = exact_odometry_graph(&truth, 0.05, 0.01);
        let last = truth.len() - 1;
        let wrong = truth[last]
            .between(&truth[0])
            .compose(&Pose2::new(5.0, 0.0, 0.0));
        let mut robust = graph.clone();
        robust.add_edge(Edge::with_std(last, 0, wrong, 0.05, 0.01, EdgeKind::Loop));
        let mut plain = graph.clone();
        plain.add_edge(Edge::with_std(
            last,
            0,
            wrong,
            0.05,
            0.01,
            EdgeKind::Odometry,
        ));
        robust.optimise(&OptimiserSettings::default());
        plain.optimise(&OptimiserSettings::default());
        let (r, p) = (max_error_m(&robust, &truth), max_error_m(&plain, &truth));
        assert!(r < 0.5 * p, "robust {r} m, plain {p} m");
    }

    #[test]
    fn bad_edges_are_refused_and_nothing_turns_nan() {
        let mut graph = PoseGraph::new();
        graph.add_node(Pose2::IDENTITY);
        graph.add_node(Pose2::new(1.0, 0.0, 0.0));
        let edge = |from, to, z, kind| Edge::with_std(from, to, z, 0.1, 0.1, kind);
        assert!(!graph.add_edge(edge(0, 5, Pose2::IDENTITY, EdgeKind::Loop)));
        assert!(!graph.add_edge(edge(1, 1, Pose2::IDENTITY, EdgeKind::Loop)));
        let nan = Pose2 {
            x_m: f64::NAN,
            ..Pose2::IDENTITY
        };
        assert!(!graph.add_edge(edge(0, 1, nan, EdgeKind::Loop)));
        assert!(graph.add_edge(edge(0, 1, Pose2::new(2.0, 0.0, 0.0), EdgeKind::Odometry)));
        graph.optimise(&OptimiserSettings::default());
        assert!(graph.nodes().iter().all(Pose2::is_finite));
        assert!((graph.nodes()[1].x_m - 2.0).abs() < 1e-6);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(16))]
        #[test]
        fn a_synthetic_loop_recovers_ground_truth(seed in 0u64..1000, side in 4usize..9) {
            let truth = square(side);
            let mut graph = drifting_graph(&truth, seed, true);
            let before = max_error_m(&graph, &truth);
            graph.optimise(&OptimiserSettings::default());
            let after = max_error_m(&graph, &truth);
            prop_assert!(graph.nodes().iter().all(Pose2::is_finite));
            // What remains is the odometry noise, not the heading bias.
            prop_assert!(after < 0.35 * before.max(0.3), "{before} -> {after}");
        }
    }

    /// The optimiser as it was before the sparse solve (dense 3n × 3n nalgebra Cholesky, node 0
    /// fixed, Cauchy on loop edges), kept verbatim as the oracle the sparse solve must match.
    fn old_dense_optimise(graph: &mut PoseGraph, settings: &OptimiserSettings) -> (u32, f64) {
        let weight = |edge: &Edge, chi2: f64| match edge.kind {
            EdgeKind::Odometry => 1.0,
            EdgeKind::Loop => {
                let c2 = settings.loop_kernel_sigma * settings.loop_kernel_sigma;
                1.0 / (1.0 + chi2 / c2)
            }
        };
        let cost = |nodes: &[Pose2]| -> f64 {
            graph
                .edges
                .iter()
                .map(|e| {
                    let err = edge_error(&nodes[e.from], &nodes[e.to], &e.measurement);
                    let chi2 = (err.transpose() * e.information * err)[0];
                    match e.kind {
                        EdgeKind::Odometry => chi2,
                        EdgeKind::Loop => {
                            let c2 = settings.loop_kernel_sigma * settings.loop_kernel_sigma;
                            c2 * (chi2 / c2).ln_1p()
                        }
                    }
                })
                .sum()
        };
        let n = graph.nodes.len();
        let mut nodes = graph.nodes.clone();
        let mut iterations = 0;
        let mut cost_now = cost(&nodes);
        if n < 2 || graph.edges.is_empty() {
            return (iterations, cost_now);
        }
        let dim = 3 * (n - 1);
        let mut lambda = 1e-4;
        'outer: for iteration in 1..=settings.max_iterations {
            iterations = iteration;
            let mut h = DMatrix::<f64>::zeros(dim, dim);
            let mut g = DVector::<f64>::zeros(dim);
            for e in &graph.edges {
                let (xi, xj) = (&nodes[e.from], &nodes[e.to]);
                let err = edge_error(xi, xj, &e.measurement);
                let chi2 = (err.transpose() * e.information * err)[0];
                let omega = e.information * weight(e, chi2);
                let (a, b) = jacobians(xi, xj, &e.measurement);
                let blocks = [(e.from, a), (e.to, b)];
                for &(k, jk) in &blocks {
                    if k == 0 {
                        continue;
                    }
                    let rk = 3 * (k - 1);
                    let gk = jk.transpose() * omega * err;
                    for r in 0..3 {
                        g[rk + r] += gk[r];
                    }
                    for &(l, jl) in &blocks {
                        if l == 0 {
                            continue;
                        }
                        let rl = 3 * (l - 1);
                        let hkl = jk.transpose() * omega * jl;
                        for r in 0..3 {
                            for c in 0..3 {
                                h[(rk + r, rl + c)] += hkl[(r, c)];
                            }
                        }
                    }
                }
            }
            let mut accepted = false;
            for _ in 0..10 {
                let mut damped = h.clone();
                for d in 0..dim {
                    damped[(d, d)] += lambda * (h[(d, d)] + 1e-9);
                }
                let Some(chol) = damped.cholesky() else {
                    lambda *= 10.0;
                    continue;
                };
                let delta = chol.solve(&(-&g));
                if !delta.iter().all(|v| v.is_finite()) {
                    lambda *= 10.0;
                    continue;
                }
                let candidate: Vec<Pose2> = nodes
                    .iter()
                    .enumerate()
                    .map(|(k, p)| {
                        if k == 0 {
                            *p
                        } else {
                            let r = 3 * (k - 1);
                            Pose2::new(
                                p.x_m + delta[r],
                                p.y_m + delta[r + 1],
                                wrap_angle_rad(p.yaw_rad + delta[r + 2]),
                            )
                        }
                    })
                    .collect();
                let new_cost = cost(&candidate);
                if new_cost.is_finite() && new_cost <= cost_now {
                    let step = delta.amax();
                    nodes = candidate;
                    cost_now = new_cost;
                    lambda = (lambda * 0.1).max(1e-9);
                    accepted = true;
                    if step < settings.tolerance {
                        break 'outer;
                    }
                    break;
                }
                lambda *= 10.0;
            }
            if !accepted {
                break;
            }
        }
        graph.nodes = nodes;
        (iterations, cost_now)
    }

    /// A random symmetric positive-definite information matrix with correlations, for standard
    /// deviations around `std_m` and `std_rad`.
    fn random_information(rng: &mut ChaCha8Rng, std_m: f64, std_rad: f64) -> Matrix3<f64> {
        // Ω = L Lᵀ with L lower triangular and a positive diagonal; exactly symmetric because
        // both triangles are the same sums of the same products.
        let scale = Vector3::new(1.0 / std_m, 1.0 / std_m, 1.0 / std_rad);
        let mut l = Matrix3::zeros();
        for r in 0..3 {
            l[(r, r)] = scale[r] * rng.random_range(0.5..2.0);
            for c in 0..r {
                l[(r, c)] = scale[r] * rng.random_range(-0.5..0.5);
            }
        }
        l * l.transpose()
    }

    /// A random graph: a random walk of `n` poses as truth, noisy odometry edges along it (the
    /// initial guess is their composition), and `extra` edges between random non-consecutive
    /// pairs, each an odometry or loop edge with diagonal or correlated information.
    fn random_graph(seed: u64, n: usize, extra: usize) -> PoseGraph {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut truth = vec![Pose2::IDENTITY];
        for _ in 1..n {
            let step = Pose2::new(
                rng.random_range(0.5..1.5),
                rng.random_range(-0.2..0.2),
                rng.random_range(-0.6..0.6),
            );
            truth.push(truth.last().unwrap().compose(&step));
        }
        let mut graph = PoseGraph::new();
        let mut estimate = truth[0];
        graph.add_node(estimate);
        for k in 1..n {
            let exact = truth[k - 1].between(&truth[k]);
            let noisy = Pose2::new(
                exact.x_m + rng.random_range(-0.05..0.05),
                exact.y_m + rng.random_range(-0.05..0.05),
                exact.yaw_rad + 0.02 + rng.random_range(-0.01..0.01),
            );
            estimate = estimate.compose(&noisy);
            graph.add_node(estimate);
            let edge = if rng.random_bool(0.5) {
                Edge::with_std(k - 1, k, noisy, 0.05, 0.02, EdgeKind::Odometry)
            } else {
                let information = random_information(&mut rng, 0.05, 0.02);
                Edge::with_information(k - 1, k, noisy, information, EdgeKind::Odometry)
            };
            assert!(graph.add_edge(edge));
        }
        for _ in 0..extra {
            let i = rng.random_range(0..n - 2);
            let j = rng.random_range(i + 2..n);
            let (from, to) = if rng.random_bool(0.5) { (i, j) } else { (j, i) };
            let exact = truth[from].between(&truth[to]);
            let z = Pose2::new(
                exact.x_m + rng.random_range(-0.03..0.03),
                exact.y_m + rng.random_range(-0.03..0.03),
                exact.yaw_rad + rng.random_range(-0.01..0.01),
            );
            let kind = if rng.random_bool(0.7) {
                EdgeKind::Loop
            } else {
                EdgeKind::Odometry
            };
            let information = random_information(&mut rng, 0.1, 0.02);
            assert!(graph.add_edge(Edge::with_information(from, to, z, information, kind)));
        }
        graph
    }

    fn max_pose_difference(a: &[Pose2], b: &[Pose2]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(p, q)| {
                (p.x_m - q.x_m)
                    .abs()
                    .max((p.y_m - q.y_m).abs())
                    .max(wrap_angle_rad(p.yaw_rad - q.yaw_rad).abs())
            })
            .fold(0.0, f64::max)
    }

    /// Both end at a minimum, one by a step below tolerance, the other by finding no damping
    /// that lowers the cost: near the minimum that is decided by rounding in the last digits,
    /// which the two factorisations do not share.
    fn same_ending(a: OptimiseStatus, b: OptimiseStatus) -> bool {
        let at_minimum = |s| matches!(s, OptimiseStatus::Converged | OptimiseStatus::Stalled);
        a == b || (at_minimum(a) && at_minimum(b))
    }

    /// The sparse optimiser against the old dense one on `random_graph(seed, n, extra)`.
    fn sparse_matches_old_dense(seed: u64, n: usize, extra: usize) -> Result<(), TestCaseError> {
        let graph = random_graph(seed, n, if n > 2 { extra } else { 0 });
        let settings = OptimiserSettings::default();
        let mut sparse = graph.clone();
        let report = sparse.optimise(&settings);
        let mut old = graph.clone();
        let (old_iterations, old_cost) = old_dense_optimise(&mut old, &settings);
        let difference = max_pose_difference(sparse.nodes(), old.nodes());
        prop_assert!(
            difference < 1e-6,
            "poses differ by {difference} ({report:?})"
        );
        prop_assert!(
            (report.final_cost - old_cost).abs() <= 1e-9 * old_cost.max(1.0),
            "cost {} vs {old_cost}",
            report.final_cost
        );
        prop_assert!(report.iterations.abs_diff(old_iterations) <= 1);
        prop_assert!(report.final_cost <= report.initial_cost);
        Ok(())
    }

    /// The sparse and dense solvers on `random_graph(seed, n, extra)` with node 0 free, two
    /// other nodes fixed and Huber kernels on both edge kinds.
    fn sparse_matches_dense_with_options(
        seed: u64,
        n: usize,
        extra: usize,
    ) -> Result<(), TestCaseError> {
        let mut graph = random_graph(seed, n, extra);
        graph.set_fixed(0, false);
        graph.set_fixed(n / 2, true);
        graph.set_fixed(n - 1, true);
        let settings = OptimiserSettings {
            odometry_kernel: RobustKernel::Huber,
            odometry_kernel_sigma: 2.0,
            loop_kernel: RobustKernel::Huber,
            ..OptimiserSettings::default()
        };
        let mut sparse = graph.clone();
        let sparse_report = sparse.optimise(&settings);
        let mut dense = graph.clone();
        let dense_report = dense.optimise_dense(&settings);
        let difference = max_pose_difference(sparse.nodes(), dense.nodes());
        prop_assert!(difference < 1e-6, "poses differ by {difference}");
        prop_assert!(
            sparse_report.iterations.abs_diff(dense_report.iterations) <= 1
                && same_ending(sparse_report.status, dense_report.status),
            "{sparse_report:?} vs {dense_report:?}"
        );
        prop_assert_eq!(sparse.nodes()[n / 2], graph.nodes()[n / 2]);
        prop_assert_eq!(sparse.nodes()[n - 1], graph.nodes()[n - 1]);
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn the_sparse_solve_matches_the_old_dense_solve(
            seed in 0u64..100_000,
            n in 2usize..30,
            extra in 0usize..12,
        ) {
            sparse_matches_old_dense(seed, n, extra)?;
        }

        #[test]
        fn the_sparse_and_dense_solvers_agree_with_more_fixed_nodes_and_huber(
            seed in 0u64..100_000,
            n in 4usize..30,
            extra in 0usize..12,
        ) {
            sparse_matches_dense_with_options(seed, n, extra)?;
        }
    }

    #[test]
    fn a_graph_where_the_solvers_end_differently_at_the_same_minimum() {
        // Found by the property test: the dense solve converged where the sparse one stalled,
        // at the same poses.
        sparse_matches_dense_with_options(77184, 28, 1).unwrap();
    }

    fn rms_error_m(graph: &PoseGraph, truth: &[Pose2]) -> f64 {
        let sum: f64 = graph
            .nodes()
            .iter()
            .zip(truth)
            .map(|(a, b)| a.distance_m(b).powi(2))
            .sum();
        (sum / truth.len() as f64).sqrt()
    }

    #[test]
    fn a_3000_node_run_with_50_loops_is_corrected() {
        let truth = laps(25, 3000);
        let mut graph = multi_lap_graph(&truth, 100, 50, 7);
        assert_eq!(graph.edges().len(), 2999 + 50);
        let (rms_before, max_before) = (rms_error_m(&graph, &truth), max_error_m(&graph, &truth));
        // The Cauchy kernel starts the loop edges hundreds of σ off, where they weigh almost
        // nothing, and reweighting lets them pull harder only as the drift shrinks: that takes
        // ~60 iterations here, more than the default 20 (which stop at rms 10.7 m).
        let settings = OptimiserSettings {
            max_iterations: 100,
            ..OptimiserSettings::default()
        };
        let report = graph.optimise(&settings);
        let (rms_after, max_after) = (rms_error_m(&graph, &truth), max_error_m(&graph, &truth));
        assert!(
            rms_before > 5.0,
            "the test needs real drift: {rms_before} m"
        );
        assert!(
            rms_after < 0.02 * rms_before && max_after < 0.02 * max_before,
            "rms {rms_before} -> {rms_after} m, max {max_before} -> {max_after} m ({report:?})"
        );
        assert_eq!(report.status, OptimiseStatus::Converged);
        assert!(report.final_cost < 0.05 * report.initial_cost, "{report:?}");
        assert_eq!(report.free_nodes, 2999);
        assert_eq!(report.unanchored_nodes, 0);
        assert!(graph.nodes().iter().all(Pose2::is_finite));
    }

    #[test]
    fn the_amd_ordering_keeps_the_factor_sparse() {
        // Loop edges laps apart fill the natural-order factor between their ends; AMD must
        // keep the factor within a small multiple of H itself. (Measured: H 15.3k entries,
        // factor 25.6k with AMD, 78.5k in natural order.)
        let truth = laps(25, 1000);
        let graph = multi_lap_graph(&truth, 100, 40, 1);
        let layout = Layout::new(&graph.fixed, &graph.edges);
        let amd = SparseNormalEquations::with_ordering(&layout, Ordering::Amd).unwrap();
        let natural = SparseNormalEquations::with_ordering(&layout, Ordering::Natural).unwrap();
        let h_nnz = amd.row_idx.len();
        let (amd_nnz, natural_nnz) = (amd.symbolic.len_val(), natural.symbolic.len_val());
        assert!(amd.symbolic.perm().is_some(), "AMD computed a permutation");
        assert!(
            amd_nnz < natural_nnz / 2,
            "factor entries: AMD {amd_nnz}, natural {natural_nnz} (H {h_nnz})"
        );
        assert!(amd_nnz < 4 * h_nnz, "AMD {amd_nnz}, H {h_nnz}");
    }

    #[test]
    fn kernel_weights_are_the_derivatives_of_their_costs() {
        for kernel in [
            RobustKernel::None,
            RobustKernel::Huber,
            RobustKernel::Cauchy,
        ] {
            for chi2 in [0.1, 3.0, 8.9, 9.1, 50.0, 1e4] {
                let h = 1e-6 * chi2;
                let numeric = (kernel.cost(chi2 + h, 3.0) - kernel.cost(chi2 - h, 3.0)) / (2.0 * h);
                let weight = kernel.weight(chi2, 3.0);
                assert!(
                    (numeric - weight).abs() < 1e-6,
                    "{kernel:?} at {chi2}: {numeric} vs {weight}"
                );
            }
            // Continuous at the Huber threshold (k² = 9).
            let below = kernel.cost(9.0 - 1e-9, 3.0);
            let above = kernel.cost(9.0 + 1e-9, 3.0);
            assert!((above - below).abs() < 1e-6, "{kernel:?}");
        }
        assert!(RobustKernel::Huber.cost(100.0, 3.0) < 100.0);
        assert!(RobustKernel::Cauchy.cost(100.0, 3.0) < RobustKernel::Huber.cost(100.0, 3.0));
    }

    #[test]
    fn refused_edges_say_why() {
        let mut graph = PoseGraph::new();
        graph.add_node(Pose2::IDENTITY);
        graph.add_node(Pose2::new(1.0, 0.0, 0.0));
        let z = Pose2::new(1.0, 0.0, 0.0);
        let nan = Pose2 {
            yaw_rad: f64::NAN,
            ..z
        };
        let odo = EdgeKind::Odometry;
        let with = |information: Matrix3<f64>| Edge::with_information(0, 1, z, information, odo);
        let cases = [
            (
                Edge::with_std(0, 2, z, 0.1, 0.1, odo),
                EdgeError::MissingNode { index: 2, nodes: 2 },
            ),
            (
                Edge::with_std(1, 1, z, 0.1, 0.1, odo),
                EdgeError::SelfLoop(1),
            ),
            (
                Edge::with_std(0, 1, nan, 0.1, 0.1, odo),
                EdgeError::NonFiniteMeasurement,
            ),
            (
                Edge::with_std(0, 1, z, 0.0, 0.1, odo),
                EdgeError::NonFiniteInformation,
            ),
            (
                Edge::with_std(0, 1, z, f64::INFINITY, f64::INFINITY, odo),
                EdgeError::ZeroInformation,
            ),
            (with(Matrix3::zeros()), EdgeError::ZeroInformation),
            (
                with(Matrix3::from_element(f64::NAN)),
                EdgeError::NonFiniteInformation,
            ),
            (
                with(Matrix3::new(1.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)),
                EdgeError::AsymmetricInformation,
            ),
            (
                with(Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 1.0))),
                EdgeError::IndefiniteInformation,
            ),
        ];
        for (edge, expected) in cases {
            assert_eq!(graph.try_add_edge(edge), Err(expected), "{edge:?}");
            assert!(!graph.add_edge(edge));
        }
        assert!(graph.edges().is_empty());
        // Semi-definite is fine: an edge that knows the heading and nothing of the position.
        let heading_only = with(Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, 100.0)));
        assert_eq!(graph.try_add_edge(heading_only), Ok(0));
        assert!(EdgeError::ZeroInformation.to_string().contains("zero"));
    }

    #[test]
    fn degenerate_graphs_give_a_clear_report_and_keep_their_poses() {
        let settings = OptimiserSettings::default();
        let empty = PoseGraph::new().optimise(&settings);
        assert_eq!(empty.status, OptimiseStatus::NotRun(OptimiseError::NoEdges));
        assert_eq!(empty.iterations, 0);

        let mut lonely = PoseGraph::new();
        lonely.add_node(Pose2::new(1.0, 2.0, 0.3));
        lonely.add_node(Pose2::new(4.0, 2.0, 0.3));
        let report = lonely.optimise(&settings);
        assert_eq!(
            report.status,
            OptimiseStatus::NotRun(OptimiseError::NoEdges)
        );
        assert_eq!(report.unanchored_nodes, 1);
        assert_eq!(lonely.nodes()[1], Pose2::new(4.0, 2.0, 0.3));

        // Every node fixed.
        let mut pinned = lonely.clone();
        pinned.add_edge(Edge::with_std(
            0,
            1,
            Pose2::IDENTITY,
            0.1,
            0.1,
            EdgeKind::Odometry,
        ));
        pinned.set_fixed(1, true);
        let report = pinned.optimise(&settings);
        assert_eq!(
            report.status,
            OptimiseStatus::NotRun(OptimiseError::NoFreeNodes)
        );
        assert_eq!(pinned.nodes(), lonely.nodes());
        assert!(!pinned.set_fixed(9, true));

        // A NaN pose set after the edges were added.
        let mut poisoned = lonely.clone();
        poisoned.add_edge(Edge::with_std(
            0,
            1,
            Pose2::IDENTITY,
            0.1,
            0.1,
            EdgeKind::Odometry,
        ));
        poisoned.set_node(1, Pose2::new(f64::NAN, 0.0, 0.0));
        let report = poisoned.optimise(&settings);
        assert_eq!(
            report.status,
            OptimiseStatus::NotRun(OptimiseError::NonFiniteNode { index: 1 })
        );
        assert_eq!(poisoned.nodes()[0], lonely.nodes()[0]);

        // Unusable settings.
        let mut graph = lonely.clone();
        graph.add_edge(Edge::with_std(
            0,
            1,
            Pose2::IDENTITY,
            0.1,
            0.1,
            EdgeKind::Loop,
        ));
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let settings = OptimiserSettings {
                loop_kernel_sigma: bad,
                ..OptimiserSettings::default()
            };
            let report = graph.clone().optimise(&settings);
            assert!(
                matches!(
                    report.status,
                    OptimiseStatus::NotRun(OptimiseError::InvalidSettings(_))
                ),
                "{bad}: {report:?}"
            );
        }
        // The same graph with a usable setting: the loop edge, left unrobustified, pulls node 1
        // onto node 0.
        let settings = OptimiserSettings {
            loop_kernel: RobustKernel::None,
            ..OptimiserSettings::default()
        };
        let report = graph.optimise(&settings);
        assert_eq!(report.status, OptimiseStatus::Converged);
        let (first, second) = (graph.nodes()[0], graph.nodes()[1]);
        assert_eq!(first, lonely.nodes()[0]);
        assert!(
            max_pose_difference(&[second], &[first]) < 1e-6,
            "{second:?}"
        );
    }

    #[test]
    fn disconnected_parts_are_reported_and_stay_finite() {
        // 0–1–2 anchored at 0; 3 alone; 4–5 joined to each other only.
        let mut graph = PoseGraph::new();
        for k in 0..6 {
            graph.add_node(Pose2::new(k as f64, 0.5 * k as f64, 0.1 * k as f64));
        }
        let z = Pose2::new(1.0, 0.0, 0.0);
        for (from, to) in [(0, 1), (1, 2), (4, 5)] {
            assert!(graph.add_edge(Edge::with_std(from, to, z, 0.1, 0.05, EdgeKind::Odometry)));
        }
        let before = graph.nodes().to_vec();
        let report = graph.optimise(&OptimiserSettings::default());
        assert_eq!(report.unanchored_nodes, 3, "{report:?}");
        assert_eq!(report.free_nodes, 5);
        assert!(graph.nodes().iter().all(Pose2::is_finite));
        assert_eq!(
            graph.nodes()[3],
            before[3],
            "an unconstrained node does not move"
        );
        for (from, to) in [(0, 1), (1, 2), (4, 5)] {
            let relative = graph.nodes()[from].between(&graph.nodes()[to]);
            assert!(max_pose_difference(&[relative], &[z]) < 1e-6, "{from}-{to}");
        }
        // With no fixed node at all the damping alone holds the frame; still finite.
        graph.set_fixed(0, false);
        let report = graph.optimise(&OptimiserSettings::default());
        assert_eq!(report.unanchored_nodes, 6);
        assert!(graph.nodes().iter().all(Pose2::is_finite));
    }

    #[test]
    fn enormous_information_does_not_break_the_solve() {
        let truth = square(4);
        let last = truth.len() - 1;
        let z = truth[last].between(&truth[0]);
        // Finite but absurd information: the solve still works and the edge is met exactly.
        let mut graph = drifting_graph(&truth, 5, false);
        let huge = Matrix3::from_diagonal(&Vector3::new(1e300, 1e300, 1e300));
        assert!(graph.add_edge(Edge::with_information(last, 0, z, huge, EdgeKind::Odometry)));
        let report = graph.optimise(&OptimiserSettings::default());
        assert!(graph.nodes().iter().all(Pose2::is_finite), "{report:?}");
        let closing = graph.nodes()[last].between(&graph.nodes()[0]);
        assert!(max_pose_difference(&[closing], &[z]) < 1e-6, "{report:?}");
        // Information so large that the cost overflows: no step could be shown to lower it, so
        // the optimiser does not start and says why.
        let mut graph = drifting_graph(&truth, 5, false);
        let overflowing = Matrix3::from_diagonal(&Vector3::new(1e308, 1e308, 1e308));
        let far = z.compose(&Pose2::new(100.0, 0.0, 0.0));
        let edge = Edge::with_information(last, 0, far, overflowing, EdgeKind::Odometry);
        assert!(graph.add_edge(edge));
        let before = graph.nodes().to_vec();
        let report = graph.optimise(&OptimiserSettings::default());
        assert!(report.initial_cost.is_infinite(), "{report:?}");
        assert_eq!(
            report.status,
            OptimiseStatus::NotRun(OptimiseError::NonFiniteCost)
        );
        assert_eq!(graph.nodes(), &before[..]);
    }

    #[test]
    fn fixed_nodes_stay_put_and_the_rest_follow() {
        let truth = square(6);
        let mut graph = drifting_graph(&truth, 11, false);
        // Anchor the far end at its true pose too (a surveyed marker).
        let last = truth.len() - 1;
        graph.set_node(last, truth[last]);
        assert!(graph.set_fixed(last, true));
        assert!(graph.is_fixed(0) && graph.is_fixed(last) && !graph.is_fixed(1));
        let before = max_error_m(&graph, &truth);
        let report = graph.optimise(&OptimiserSettings::default());
        assert_eq!(graph.nodes()[last], truth[last]);
        assert_eq!(graph.nodes()[0], truth[0]);
        assert_eq!(report.free_nodes, truth.len() - 2);
        assert!(report.final_cost < report.initial_cost);
        // The accumulated drift is now shared between both ends.
        let middle = graph.nodes()[last / 2].distance_m(&truth[last / 2]);
        assert!(middle < before, "{middle} m vs {before} m");
    }

    /// `laps(side, n)` as a multi-lap graph (`lap` nodes a lap, `loops` loop edges, `seed`),
    /// optimised with the default settings.
    fn optimised_laps(
        (side, n): (usize, usize),
        lap: usize,
        loops: usize,
        seed: u64,
    ) -> (Vec<Pose2>, PoseGraph, OptimiserSettings) {
        let truth = laps(side, n);
        let mut graph = multi_lap_graph(&truth, lap, loops, seed);
        let settings = OptimiserSettings::default();
        graph.optimise(&settings);
        (truth, graph, settings)
    }

    /// The dense reference: the diagonal blocks of the inverse of the whole information matrix.
    fn dense_marginals(graph: &PoseGraph, settings: &OptimiserSettings) -> Vec<Matrix3<f64>> {
        let layout = Layout::new(&graph.fixed, &graph.edges);
        let mut system = DenseNormalEquations::new(&layout).unwrap();
        graph.assemble(&layout, settings, &mut system, |_, e| e.information);
        let inverse = system.hessian.cholesky().unwrap().inverse();
        layout
            .block_of
            .iter()
            .map(|b| {
                b.map_or_else(Matrix3::zeros, |b| {
                    inverse.fixed_view::<3, 3>(3 * b, 3 * b).into_owned()
                })
            })
            .collect()
    }

    #[test]
    fn marginals_match_the_dense_inverse_across_batches_and_loops() {
        // 3 laps of 40 poses (more blocks than one batch of solves) with loop edges between laps.
        let (truth, graph, settings) = optimised_laps((10, 120), 40, 6, 5);
        let sparse = graph
            .marginal_covariances(&settings, |_, e| e.information)
            .unwrap();
        let dense = dense_marginals(&graph, &settings);
        assert_eq!(sparse.len(), truth.len());
        assert_eq!(sparse[0], Matrix3::zeros(), "the fixed first node");
        for (k, (a, b)) in sparse.iter().zip(&dense).enumerate() {
            let scale = b.abs().max().max(1e-12);
            assert!((a - b).abs().max() <= 1e-9 * scale, "node {k}: {a} vs {b}");
        }
    }

    #[test]
    fn a_straight_chain_accumulates_its_steps_variances() {
        // Along a straight line with exact heading the along-track variance after k steps is
        // k σ², whatever the (tiny) heading uncertainty does across the track.
        let truth: Vec<Pose2> = (0..30).map(|k| Pose2::new(k as f64, 0.0, 0.0)).collect();
        let (std_m, std_rad) = (0.1, 1e-6);
        let graph = exact_odometry_graph(&truth, std_m, std_rad);
        let settings = OptimiserSettings::default();
        let covariances = graph
            .marginal_covariances(&settings, |_, e| e.information)
            .unwrap();
        for (k, c) in covariances.iter().enumerate() {
            let expected = k as f64 * std_m * std_m;
            assert!(
                (c[(0, 0)] - expected).abs() < 1e-9,
                "node {k}: {}",
                c[(0, 0)]
            );
            assert!(
                c[(1, 1)] >= expected - 1e-9,
                "across-track no smaller than along"
            );
        }
        // Doubling every edge's information halves every covariance.
        let halved = graph
            .marginal_covariances(&settings, |_, e| e.information * 2.0)
            .unwrap();
        for (a, b) in covariances.iter().zip(&halved) {
            assert!((a * 0.5 - b).abs().max() < 1e-12);
        }
    }

    #[test]
    fn an_unanchored_node_has_no_covariance() {
        let truth: Vec<Pose2> = (0..4).map(|k| Pose2::new(k as f64, 0.0, 0.0)).collect();
        let mut graph = exact_odometry_graph(&truth, 0.1, 0.01);
        graph.add_node(Pose2::new(9.0, 9.0, 0.0));
        let settings = OptimiserSettings::default();
        assert_eq!(
            graph.marginal_covariances(&settings, |_, e| e.information),
            Err(OptimiseError::Singular)
        );
    }

    #[test]
    fn a_leaf_propagates_as_the_whole_graph_says() {
        let (_, mut graph, settings) = optimised_laps((8, 40), 32, 3, 9);
        let before = graph
            .marginal_covariances(&settings, |_, e| e.information)
            .unwrap();
        let last = graph.nodes().len() - 1;
        let z = Pose2::new(0.9, 0.2, 0.1);
        let xi = graph.nodes()[last];
        let xj = xi.compose(&z);
        let leaf = graph.add_node(xj);
        let information = Matrix3::new(400.0, 30.0, 5.0, 30.0, 250.0, -8.0, 5.0, -8.0, 900.0);
        graph.add_edge(Edge::with_information(
            last,
            leaf,
            z,
            information,
            EdgeKind::Odometry,
        ));
        let after = graph
            .marginal_covariances(&settings, |_, e| e.information)
            .unwrap();
        let propagated = leaf_covariance(&xi, &xj, &z, &before[last], &information).unwrap();
        assert!((propagated - after[leaf]).abs().max() < 1e-9 * after[leaf].abs().max());
        assert!(leaf_covariance(&xi, &xj, &z, &before[last], &Matrix3::zeros()).is_none());
    }

    #[test]
    fn relative_consistency_of_a_turned_pair_is_the_two_informations_combined() {
        // Two nodes, the older turned and fixed, one edge `g` with a full information. A second
        // measurement `z` of the same relative pose with the same heading, off in x and y, is as
        // far from the graph as the difference of the two measurements under both covariances.
        let from = Pose2::new(2.0, -1.0, 0.7);
        let g = Pose2::new(1.0, 0.5, 0.3);
        let graph_information = Matrix3::new(40.0, 6.0, 2.0, 6.0, 25.0, -3.0, 2.0, -3.0, 90.0);
        let mut graph = PoseGraph::new();
        graph.add_node(from);
        graph.add_node(from.compose(&g));
        assert!(graph.add_edge(Edge::with_information(
            0,
            1,
            g,
            graph_information,
            EdgeKind::Odometry
        )));
        let z = Pose2::new(1.3, 0.1, 0.3);
        let z_information = Matrix3::new(30.0, -5.0, 0.0, -5.0, 12.0, 1.0, 0.0, 1.0, 70.0);
        let d = z.inverse().compose(&g);
        let e = Vector3::new(d.x_m, d.y_m, d.yaw_rad);
        let combined = (graph_information.try_inverse().unwrap()
            + z_information.try_inverse().unwrap())
        .try_inverse()
        .unwrap();
        let expected = (e.transpose() * combined * e)[0];
        let settings = OptimiserSettings::default();
        let (chi2, _) = graph
            .relative_consistency(0, 1, &z, &z_information, &settings, |_, e| e.information)
            .unwrap();
        assert!(
            (chi2 - expected).abs() < 1e-9 * expected,
            "{chi2} vs {expected}"
        );
    }

    #[test]
    fn one_node_s_marginal_is_the_whole_graph_s_block() {
        let (_, graph, settings) = optimised_laps((8, 40), 32, 3, 9);
        let all = graph
            .marginal_covariances(&settings, |_, e| e.information)
            .unwrap();
        for node in [0, 1, graph.nodes().len() / 2, graph.nodes().len() - 1] {
            let one = graph
                .marginal_covariance_of(node, &settings, |_, e| e.information)
                .unwrap();
            let scale = all[node].abs().max().max(1e-300);
            assert!((one - all[node]).abs().max() <= 1e-9 * scale, "node {node}");
        }
        assert!(graph.is_fixed(0));
        assert_eq!(
            graph.marginal_covariance_of(0, &settings, |_, e| e.information),
            Ok(Matrix3::zeros())
        );
    }

    #[test]
    fn without_loop_information_the_marginals_are_the_chain_propagated() {
        // What Association::update_covariances relies on when loops are left out of the model.
        let (_, graph, settings) = optimised_laps((10, 80), 40, 4, 2);
        let chain_only = |_: usize, e: &Edge| match e.kind {
            EdgeKind::Odometry => e.information,
            EdgeKind::Loop => Matrix3::zeros(),
        };
        let marginals = graph.marginal_covariances(&settings, chain_only).unwrap();
        let mut propagated = vec![Matrix3::zeros(); graph.nodes().len()];
        for e in graph
            .edges()
            .iter()
            .filter(|e| e.kind == EdgeKind::Odometry)
        {
            let (xi, xj) = (graph.nodes()[e.from], graph.nodes()[e.to]);
            propagated[e.to] = leaf_covariance(
                &xi,
                &xj,
                &e.measurement,
                &propagated[e.from],
                &e.information,
            )
            .unwrap();
        }
        for (k, (a, b)) in marginals.iter().zip(&propagated).enumerate() {
            assert!(
                (a - b).abs().max() <= 1e-9 * b.abs().max().max(1e-12),
                "node {k}"
            );
        }
    }

    /// Nodes 0, 1, 2 one metre apart on x, joined by exact odometry edges of std `std_m` (and
    /// 0.01 rad), node `fixed` fixed.
    fn three_in_a_row(std_m: f64, fixed: usize) -> PoseGraph {
        let mut graph = PoseGraph::new();
        for k in 0..3 {
            graph.add_node(Pose2::new(f64::from(k), 0.0, 0.0));
        }
        for k in 1..3 {
            let step = Pose2::new(1.0, 0.0, 0.0);
            assert!(graph.add_edge(Edge::with_std(
                k - 1,
                k,
                step,
                std_m,
                0.01,
                EdgeKind::Odometry
            )));
        }
        graph.set_fixed(0, false);
        graph.set_fixed(fixed, true);
        graph
    }

    #[test]
    fn relative_consistency_weighs_the_error_by_both_uncertainties() {
        let (chain_std_m, measured_std_m, off_m): (f64, f64, f64) = (0.2, 0.3, 1.5);
        let measurement = Pose2::new(2.0 + off_m, 0.0, 0.0);
        let information = Matrix3::from_diagonal(&Vector3::new(
            measured_std_m.powi(-2),
            measured_std_m.powi(-2),
            1e4,
        ));
        let settings = OptimiserSettings::default();
        // Along x the two steps add their variances; whichever node the graph holds fixed.
        let expected_chi2 =
            off_m * off_m / (2.0 * chain_std_m * chain_std_m + measured_std_m.powi(2));
        for fixed in 0..3 {
            let graph = three_in_a_row(chain_std_m, fixed);
            let (chi2, graph_std_m) = graph
                .relative_consistency(0, 2, &measurement, &information, &settings, |_, e| {
                    e.information
                })
                .unwrap();
            assert!(
                (chi2 - expected_chi2).abs() < 1e-6 * expected_chi2,
                "{chi2} vs {expected_chi2}"
            );
            // The weakest axis is across the row: two steps' position std plus the heading's lever.
            assert!(
                graph_std_m >= chain_std_m * 2f64.sqrt() - 1e-9,
                "{graph_std_m}"
            );
            assert!(graph_std_m < 0.3, "{graph_std_m}");
        }
        // A measurement the graph holds is consistent.
        let graph = three_in_a_row(chain_std_m, 0);
        let (chi2, _) = graph
            .relative_consistency(
                0,
                2,
                &Pose2::new(2.0, 0.0, 0.0),
                &information,
                &settings,
                |_, e| e.information,
            )
            .unwrap();
        assert!(chi2 < 1e-12, "{chi2}");
        // A loose chain can neither agree nor disagree much: the same error costs little.
        let loose = three_in_a_row(20.0, 0);
        let (chi2, graph_std_m) = loose
            .relative_consistency(0, 2, &measurement, &information, &settings, |_, e| {
                e.information
            })
            .unwrap();
        assert!(chi2 < 0.01 && graph_std_m > 20.0, "{chi2} {graph_std_m}");
    }
}
