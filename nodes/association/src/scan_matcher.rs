//! Radar-aware scan matching: each detection, with its own error ellipse, against a map of local
//! Gaussians (a point-to-distribution normal-distributions transform).
//!
//! The map ([`DistributionMap`]) bins map points into square cells of `cell_m` and keeps, per
//! cell, the mean and covariance of the points in it: along a target's outline a cell is a thin
//! ellipse along the surface, whatever direction the radar blurred the individual detections in
//! (Biber and Straßer, "The Normal Distributions Transform: A New Approach to Laser Scan
//! Matching", IROS 2003). Averaging many viewpoints' detections into a cell also averages out the
//! grid quantisation of a radar whose detections sit on range and angle bins.
//!
//! A scan point `p` (AGV frame) measured at range ρ with errors σ_R along the beam and ρ·σ_θ
//! across it (the paper's ΔR and Δθ, or half a resolution cell over √3 for a radar without
//! refinement) has the covariance `C_p = R_b diag(σ_R², ρ²σ_θ²) R_bᵀ` (R_b the beam direction).
//! Against the nearest cell mean μ with covariance Σ, its residual `d = T(x)·p − μ` has covariance
//! `S = Σ + R C_p Rᵀ + σ_map² I`, and the pose `x = (x, y, ψ)` minimises
//! `Σ ρ(dᵀ S⁻¹ d) + ρ((x − x̂)ᵀ P⁻¹ (x − x̂))` by Gauss–Newton (iteratively reweighted), with a
//! Cauchy kernel ρ on each pair's squared Mahalanobis distance and on a prior `P` around the
//! odometry prediction `x̂`: the prior holds the directions the scan observes poorly (one straight
//! wall's length; a side-looking radar's heading against its along-track position), and mostly
//! gives way when the odometry has slipped far beyond its model. So a far point's
//! coarse cross-range position moves the pose little, and its fine range much: the radar is
//! weighted as it measures.
//!
//! Deterministic: cells are kept in a `BTreeMap`, so the index over their means is built in the
//! same order on every run. The index is a dense grid of the means ([`MeanGrid`]): a scan point's
//! nearest cells are read from the few squares its correspondence radius reaches, the cells a
//! k-d tree over the means returns, in its order (a property test compares the two); a k-d tree
//! remains for means too sparse for a grid.

use std::collections::BTreeMap;
use std::num::NonZero;

use kiddo::{ImmutableKdTree, SquaredEuclidean};
use nalgebra::{Matrix2, Matrix3, Vector2, Vector3};

use crate::icp::{IcpResult, IcpStatus};
use crate::point_grid::floor_i64;
use crate::pose::{wrap_angle_rad, Pose2};

/// Running sums of the points that fell in one cell.
#[derive(Debug, Clone, Copy, Default)]
struct CellSums {
    count: u32,
    sum: [f64; 2],
    /// Σ x², Σ xy, Σ y².
    sum_sq: [f64; 3],
}

/// One cell's sums and, once computed, its Gaussian. The Gaussian is a function of the sums
/// alone, so it is kept until the sums change: a keyframe's exchange recomputes the cells it
/// touched, not every cell of the map.
#[derive(Debug, Clone, Copy, Default)]
struct CellEntry {
    sums: CellSums,
    /// `None` while the sums changed since it was computed (or it never was).
    gaussian: Option<CellGaussian>,
}

/// One cell's Gaussian.
#[derive(Debug, Clone, Copy)]
struct CellGaussian {
    mean_m: [f64; 2],
    /// Covariance, regularised (see [`DistributionMap::floor_m`]).
    cov_m2: Matrix2<f64>,
}

/// The cell means binned on a dense grid of `cell_m` squares over their bounding box (keys
/// `floor(mean / cell_m)`), cell by cell in compressed rows: the means within a radius of a
/// query are those of the squares the radius reaches, found without a tree walk or an
/// allocation. Built with the Gaussians on each change of the map.
#[derive(Debug, Clone, Default)]
struct MeanGrid {
    /// Key of square (0, 0).
    min_key: [i64; 2],
    /// Squares along x and y.
    size: [usize; 2],
    /// Per square (row-major, x fastest), where its means start in `order`; one more entry at
    /// the end.
    starts: Vec<u32>,
    /// Indices into the map's `cells`, square by square, ascending within a square.
    order: Vec<u32>,
}

/// Squares a [`MeanGrid`] may have: beyond, the means are too sparse for a dense grid and the
/// k-d tree answers instead.
fn mean_grid_budget(cells: usize) -> usize {
    (16 * cells).max(1 << 16)
}

impl MeanGrid {
    /// The grid over `cells`' means, or `None` when their bounding box has more squares than
    /// [`mean_grid_budget`] allows.
    fn build(cells: &[CellGaussian], cell_m: f64) -> Option<MeanGrid> {
        let key = |m: &[f64; 2]| [floor_i64(m[0] / cell_m), floor_i64(m[1] / cell_m)];
        let mut lo = [i64::MAX; 2];
        let mut hi = [i64::MIN; 2];
        for c in cells {
            let k = key(&c.mean_m);
            for axis in 0..2 {
                lo[axis] = lo[axis].min(k[axis]);
                hi[axis] = hi[axis].max(k[axis]);
            }
        }
        if cells.is_empty() || u32::try_from(cells.len()).is_err() {
            return None;
        }
        // Means are binnable (within ±1e9 m of the origin), so the spans fit easily.
        let size = [(hi[0] - lo[0] + 1) as usize, (hi[1] - lo[1] + 1) as usize];
        let squares = size[0].checked_mul(size[1])?;
        if squares > mean_grid_budget(cells.len()) {
            return None;
        }
        let square = |c: &CellGaussian| {
            let k = key(&c.mean_m);
            (k[1] - lo[1]) as usize * size[0] + (k[0] - lo[0]) as usize
        };
        let mut starts = vec![0u32; squares + 1];
        for c in cells {
            starts[square(c) + 1] += 1;
        }
        for i in 0..squares {
            starts[i + 1] += starts[i];
        }
        let mut next = starts.clone();
        let mut order = vec![0u32; cells.len()];
        for (index, c) in cells.iter().enumerate() {
            let s = square(c);
            order[next[s] as usize] = index as u32;
            next[s] += 1;
        }
        Some(MeanGrid {
            min_key: lo,
            size,
            starts,
            order,
        })
    }

    /// The range of squares along `axis` that holds every mean within `radius_m` of coordinate
    /// `q` (slightly more: the bounds are widened by a millionth of the radius, far beyond the
    /// rounding of the division), clamped to the grid; `None` when it misses the grid.
    fn span(&self, axis: usize, q: f64, radius_m: f64, cell_m: f64) -> Option<(usize, usize)> {
        if !q.is_finite() {
            return None;
        }
        let reach = radius_m * (1.0 + 1e-6);
        let lo = floor_i64((q - reach) / cell_m).saturating_sub(self.min_key[axis]);
        let hi = floor_i64((q + reach) / cell_m).saturating_sub(self.min_key[axis]);
        let last = self.size[axis] as i64 - 1;
        if hi < 0 || lo > last {
            return None;
        }
        Some((lo.max(0) as usize, hi.min(last) as usize))
    }

    /// The indices of the means in squares `xs` × `ys` (inclusive spans from [`Self::span`]),
    /// row by row and in `order` within a row.
    fn means_in(&self, xs: (usize, usize), ys: (usize, usize)) -> impl Iterator<Item = u32> + '_ {
        (ys.0..=ys.1).flat_map(move |row| {
            let first = row * self.size[0];
            let from = self.starts[first + xs.0] as usize;
            let to = self.starts[first + xs.1 + 1] as usize;
            self.order[from..to].iter().copied()
        })
    }
}

/// The map as local Gaussians: points binned into cells of `cell_m`, each cell with at least
/// `min_points` points summarised by its mean and covariance, and an index over the means (a
/// dense [`MeanGrid`], or a k-d tree where the means are too sparse for one).
#[derive(Clone)]
pub struct DistributionMap {
    cell_m: f64,
    min_points: u32,
    floor_m: f64,
    sums: BTreeMap<(i64, i64), CellEntry>,
    cells: Vec<CellGaussian>,
    grid: Option<MeanGrid>,
    tree: Option<ImmutableKdTree<f64, 2>>,
    points: usize,
}

impl std::fmt::Debug for DistributionMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DistributionMap")
            .field("cell_m", &self.cell_m)
            .field("cells", &self.cells.len())
            .field("points", &self.points)
            .finish()
    }
}

/// The `k` nearest cells found so far, nearest first, as (squared distance m², cell index): the
/// collection kiddo's `nearest_n_within` keeps (a candidate enters while there is room, or
/// when strictly nearer than the farthest kept, which then leaves).
struct Nearest<'a> {
    k: usize,
    found: &'a mut Vec<(f64, u32)>,
}

impl Nearest<'_> {
    fn offer(&mut self, d2: f64, index: u32) {
        if self.found.len() == self.k {
            match self.found.last() {
                Some(&(last, _)) if d2 < last => {
                    self.found.pop();
                }
                _ => return,
            }
        }
        // Insertion by swaps from the end (a handful of entries): `Vec::insert` would call
        // memmove for every kept candidate.
        self.found.push((d2, index));
        let mut at = self.found.len() - 1;
        while at > 0 && self.found[at - 1].0 > d2 {
            self.found.swap(at - 1, at);
            at -= 1;
        }
    }
}

/// A point a [`DistributionMap`] bins: finite and within ±1e9 m (beyond, its cell index would
/// not be meaningful).
pub(crate) fn binnable(p: &[f64; 2]) -> bool {
    p[0].is_finite() && p[1].is_finite() && p[0].abs() < 1e9 && p[1].abs() < 1e9
}

impl DistributionMap {
    /// An empty map with cells of `cell_m` (> 0), Gaussians from cells of at least `min_points`
    /// (≥ 1) points, and covariance eigenvalues floored at `floor_m`² (a one-point cell, or the
    /// thickness of a perfectly thin wall, still has a finite error).
    pub fn new(cell_m: f64, min_points: u32, floor_m: f64) -> Self {
        DistributionMap {
            cell_m: if cell_m.is_finite() && cell_m > 0.0 {
                cell_m
            } else {
                1.0
            },
            min_points: min_points.max(1),
            floor_m: if floor_m.is_finite() && floor_m > 0.0 {
                floor_m
            } else {
                1e-3
            },
            sums: BTreeMap::new(),
            cells: Vec::new(),
            grid: None,
            tree: None,
            points: 0,
        }
    }

    /// The points worth a cell ([`binnable`]), each with its cell's key.
    fn binned<'a>(
        &self,
        points_m: &'a [[f64; 2]],
    ) -> impl Iterator<Item = (&'a [f64; 2], (i64, i64))> + use<'a> {
        let cell_m = self.cell_m;
        points_m.iter().filter(|p| binnable(p)).map(move |p| {
            let key = (floor_i64(p[0] / cell_m), floor_i64(p[1] / cell_m));
            (p, key)
        })
    }

    /// Adds map-frame points (metres) and rebuilds the cells' Gaussians and the tree. Non-finite
    /// points, and points beyond ±1e9 m (whose cell index would not be meaningful), are skipped.
    pub fn extend(&mut self, points_m: &[[f64; 2]]) {
        self.exchange(&[], points_m);
    }

    /// Takes points added before (map frame, metres) out of their cells' sums, drops the cells
    /// left empty and rebuilds the Gaussians and the tree: the map then equals one built without
    /// them, up to rounding in the sums. Points are skipped as [`Self::extend`] skips them, and
    /// so are points whose cell holds none. Only points that were added may be retracted: any
    /// other point in an occupied cell would be taken from that cell's sums.
    pub fn retract(&mut self, points_m: &[[f64; 2]]) {
        self.exchange(points_m, &[]);
    }

    /// [`Self::retract`]s `leaving`, then [`Self::extend`]s with `entering`, and rebuilds the
    /// Gaussians and the tree once: the back end's local window drops its oldest keyframes and
    /// takes the new one this way on each keyframe instead of rebuilding the map.
    pub fn exchange(&mut self, leaving_m: &[[f64; 2]], entering_m: &[[f64; 2]]) {
        let mut changed = false;
        for (p, key) in self.binned(leaving_m) {
            let Some(entry) = self.sums.get_mut(&key) else {
                continue;
            };
            let sums = &mut entry.sums;
            sums.count -= 1;
            sums.sum[0] -= p[0];
            sums.sum[1] -= p[1];
            sums.sum_sq[0] -= p[0] * p[0];
            sums.sum_sq[1] -= p[0] * p[1];
            sums.sum_sq[2] -= p[1] * p[1];
            entry.gaussian = None;
            if sums.count == 0 {
                self.sums.remove(&key);
            }
            self.points -= 1;
            changed = true;
        }
        for (p, key) in self.binned(entering_m) {
            let entry = self.sums.entry(key).or_default();
            let sums = &mut entry.sums;
            sums.count = sums.count.saturating_add(1);
            sums.sum[0] += p[0];
            sums.sum[1] += p[1];
            sums.sum_sq[0] += p[0] * p[0];
            sums.sum_sq[1] += p[0] * p[1];
            sums.sum_sq[2] += p[1] * p[1];
            entry.gaussian = None;
            self.points += 1;
            changed = true;
        }
        if changed {
            self.rebuild();
        }
    }

    /// The Gaussian of a cell's sums (the cell must hold a point).
    fn gaussian(s: &CellSums, floor2: f64) -> CellGaussian {
        let n = f64::from(s.count);
        let mean = [s.sum[0] / n, s.sum[1] / n];
        // Centred about the mean; tiny negative variances from rounding clamp to 0.
        let xx = (s.sum_sq[0] / n - mean[0] * mean[0]).max(0.0);
        let xy = s.sum_sq[1] / n - mean[0] * mean[1];
        let yy = (s.sum_sq[2] / n - mean[1] * mean[1]).max(0.0);
        let cov = Matrix2::new(xx, xy, xy, yy);
        CellGaussian {
            mean_m: mean,
            cov_m2: floor_eigenvalues(cov, floor2),
        }
    }

    /// The Gaussians of the cells with at least `min_points` points, in key order (those of
    /// cells whose sums did not change since the last rebuild are kept), and the index over
    /// their means.
    fn rebuild(&mut self) {
        let floor2 = self.floor_m * self.floor_m;
        let min_points = self.min_points;
        self.cells.clear();
        self.cells.extend(
            self.sums
                .values_mut()
                .filter(|e| e.sums.count >= min_points)
                .map(|e| {
                    *e.gaussian
                        .get_or_insert_with(|| Self::gaussian(&e.sums, floor2))
                }),
        );
        self.grid = MeanGrid::build(&self.cells, self.cell_m);
        self.tree = if self.grid.is_none() && !self.cells.is_empty() {
            let means: Vec<[f64; 2]> = self.cells.iter().map(|c| c.mean_m).collect();
            Some(ImmutableKdTree::new_from_slice(&means))
        } else {
            None
        };
    }

    /// Points held: added and not retracted.
    pub fn point_count(&self) -> usize {
        self.points
    }

    /// Cells with a Gaussian.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// True when no cell has a Gaussian yet.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The cell means, map frame, metres.
    pub fn means_m(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        self.cells.iter().map(|c| c.mean_m)
    }

    /// The `k` nearest cell Gaussians to `query_m` within `max_m` (squared distance at most
    /// `max_m`², as kiddo's `nearest_n_within` measures it), nearest first, as indices into
    /// `cells` in `found` (cleared first). Exactly the cells the k-d tree returns, in its order
    /// (up to cells at exactly equal distance).
    #[cfg(test)]
    fn nearest_into(&self, query_m: &[f64; 2], k: usize, max_m: f64, found: &mut Vec<(f64, u32)>) {
        self.nearest_from_index(query_m, k, max_m, found);
    }

    /// [`Self::nearest_into`], reading the candidates from `kept` when `query_m` is near enough
    /// its anchor, else from the grid, and then keeping the new candidates in `kept` (where the
    /// grid answers and they are few enough).
    fn nearest_kept(
        &self,
        query_m: &[f64; 2],
        k: usize,
        max_m: f64,
        found: &mut Vec<(f64, u32)>,
        kept: &mut Option<KeptCells>,
    ) {
        found.clear();
        if k == 0 {
            return;
        }
        let radius2 = max_m * max_m;
        // kiddo's squared distance: Σ over the axes of (mean − query)², from 0.
        let distance2 = |c: &CellGaussian| {
            let dx = c.mean_m[0] - query_m[0];
            let dy = c.mean_m[1] - query_m[1];
            0.0 + dx * dx + dy * dy
        };
        let mut nearest = Nearest { k, found };
        if let Some(cells) = kept {
            let dx = query_m[0] - cells.anchor[0];
            let dy = query_m[1] - cells.anchor[1];
            if (dx * dx + dy * dy).sqrt() + 1e-9 < KEPT_REACH_M {
                for &index in &cells.cells[..cells.len] {
                    let d2 = distance2(&self.cells[index as usize]);
                    if d2 <= radius2 {
                        nearest.offer(d2, index);
                    }
                }
                return;
            }
        }
        *kept = None;
        if let Some(grid) = &self.grid {
            // The squares of the radius plus the reach: the candidates to keep, and (in the same
            // order) those within the radius now.
            let reach_m = max_m + KEPT_REACH_M + 1e-9;
            let reach2 = reach_m * reach_m;
            if let (Some(xs), Some(ys)) = (
                grid.span(0, query_m[0], reach_m, self.cell_m),
                grid.span(1, query_m[1], reach_m, self.cell_m),
            ) {
                if (xs.1 - xs.0 + 1) * (ys.1 - ys.0 + 1) <= self.cells.len() {
                    let mut keep = KeptCells {
                        anchor: *query_m,
                        len: 0,
                        cells: [0; KEPT_CELLS],
                    };
                    let mut fits = true;
                    for index in grid.means_in(xs, ys) {
                        let d2 = distance2(&self.cells[index as usize]);
                        if d2 <= radius2 {
                            nearest.offer(d2, index);
                        }
                        if d2 <= reach2 {
                            if keep.len < KEPT_CELLS {
                                keep.cells[keep.len] = index;
                                keep.len += 1;
                            } else {
                                fits = false;
                            }
                        }
                    }
                    if fits {
                        *kept = Some(keep);
                    }
                    return;
                }
            }
            nearest.found.clear();
        }
        self.nearest_from_index(query_m, k, max_m, nearest.found);
    }

    /// The k nearest from the grid (or the tree where there is none), as [`Self::nearest_into`].
    fn nearest_from_index(
        &self,
        query_m: &[f64; 2],
        k: usize,
        max_m: f64,
        found: &mut Vec<(f64, u32)>,
    ) {
        found.clear();
        let radius2 = max_m * max_m;
        // kiddo's squared distance: Σ over the axes of (mean − query)², from 0.
        let distance2 = |c: &CellGaussian| {
            let dx = c.mean_m[0] - query_m[0];
            let dy = c.mean_m[1] - query_m[1];
            0.0 + dx * dx + dy * dy
        };
        let mut nearest = Nearest { k, found };
        if let Some(grid) = &self.grid {
            let (Some(xs), Some(ys)) = (
                grid.span(0, query_m[0], max_m, self.cell_m),
                grid.span(1, query_m[1], max_m, self.cell_m),
            ) else {
                return;
            };
            if (xs.1 - xs.0 + 1) * (ys.1 - ys.0 + 1) <= self.cells.len() {
                for index in grid.means_in(xs, ys) {
                    let d2 = distance2(&self.cells[index as usize]);
                    if d2 <= radius2 {
                        nearest.offer(d2, index);
                    }
                }
                return;
            }
            // A radius wider than the map: every mean is a candidate.
            for (index, cell) in self.cells.iter().enumerate() {
                let d2 = distance2(cell);
                if d2 <= radius2 {
                    nearest.offer(d2, index as u32);
                }
            }
            return;
        }
        let Some(tree) = self.tree.as_ref() else {
            return;
        };
        let Some(k) = NonZero::new(k) else {
            return;
        };
        // The radius prunes the tree walk: most scan points have few cells within it.
        for n in tree.nearest_n_within::<SquaredEuclidean>(query_m, radius2, k, true) {
            if let Ok(index) = u32::try_from(n.item) {
                nearest.found.push((n.distance, index));
            }
        }
    }

    /// The `k` nearest cell Gaussians to `query_m` within `max_m`, nearest first, by the k-d
    /// tree over the means (what [`Self::nearest_into`] reproduces; kept for its tests).
    #[cfg(test)]
    fn nearest_by_tree(&self, query_m: &[f64; 2], k: usize, max_m: f64) -> Vec<u32> {
        let means: Vec<[f64; 2]> = self.cells.iter().map(|c| c.mean_m).collect();
        let (Some(k), false) = (NonZero::new(k), means.is_empty()) else {
            return Vec::new();
        };
        let tree: ImmutableKdTree<f64, 2> = ImmutableKdTree::new_from_slice(&means);
        tree.nearest_n_within::<SquaredEuclidean>(query_m, max_m * max_m, k, true)
            .into_iter()
            .map(|n| n.item as u32)
            .collect()
    }
}

/// How far a scan point may move from where its candidate cells were gathered before they are
/// gathered again, metres: the Gauss–Newton iterations after the first move the scan by
/// centimetres and less.
const KEPT_REACH_M: f64 = 0.1;
/// Candidates a [`KeptCells`] holds at most (a point with more is looked up every time).
const KEPT_CELLS: usize = 16;

/// A scan point's candidate cells between Gauss–Newton iterations: every cell whose mean lies
/// within the correspondence radius plus [`KEPT_REACH_M`] of `anchor` (by a nanometre more),
/// in the order the grid's squares list them. While the point stays within [`KEPT_REACH_M`] of
/// `anchor`, every cell within the radius of it is among these, and scoring them in this order
/// gives the k nearest exactly as a lookup in the grid does.
#[derive(Debug, Clone, Copy)]
struct KeptCells {
    anchor: [f64; 2],
    len: usize,
    cells: [u32; KEPT_CELLS],
}

/// `cov` with its eigenvalues raised to at least `floor2`. (Raising a line-like cell's
/// along-line variance too, to make it point-to-line, was measured and not kept: 5G keyframe
/// RMSE over 20 hall seeds, open loop, 0.84 m without it against 1.14 m with it.)
fn floor_eigenvalues(cov: Matrix2<f64>, floor2: f64) -> Matrix2<f64> {
    let eigen = nalgebra::SymmetricEigen::new(cov);
    let values = eigen.eigenvalues.map(|v| v.max(floor2));
    let v = eigen.eigenvectors;
    v * Matrix2::from_diagonal(&values) * v.transpose()
}

/// A scan point with its measurement error, AGV frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadarPoint {
    /// Position in the AGV frame, metres.
    pub position_m: [f64; 2],
    /// Error std along the beam, metres.
    pub range_std_m: f64,
    /// Error std of the angle of arrival, radians.
    pub angle_std_rad: f64,
}

impl RadarPoint {
    /// Total position error std, metres: √(σ_R² + (ρ σ_θ)²), the trace of
    /// [`RadarPoint::covariance_m2`] under a root.
    pub fn position_std_m(&self) -> f64 {
        let range_m = self.position_m[0].hypot(self.position_m[1]);
        self.range_std_m.hypot(range_m * self.angle_std_rad)
    }

    /// Covariance in the AGV frame, m²: `σ_R²` along the beam, `(ρ σ_θ)²` across it.
    fn covariance_m2(&self) -> Matrix2<f64> {
        let [x, y] = self.position_m;
        let range_m = x.hypot(y);
        let (u, v) = if range_m > 0.0 {
            ([x / range_m, y / range_m], [-y / range_m, x / range_m])
        } else {
            ([1.0, 0.0], [0.0, 1.0])
        };
        let along = self.range_std_m * self.range_std_m;
        let across = (range_m * self.angle_std_rad).powi(2);
        Matrix2::new(
            along * u[0] * u[0] + across * v[0] * v[0],
            along * u[0] * u[1] + across * v[0] * v[1],
            along * u[0] * u[1] + across * v[0] * v[1],
            along * u[1] * u[1] + across * v[1] * v[1],
        )
    }
}

/// Settings of [`match_scan`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MatchSettings {
    /// A scan point pairs with cell means within this distance, metres.
    pub max_correspondence_m: f64,
    /// Cell Gaussians each scan point is scored against (the nearest ones).
    pub neighbours: usize,
    /// Std of the map's own error, added isotropically to every pair's covariance, metres.
    pub map_std_m: f64,
    /// Cauchy scale on the Mahalanobis distance: a pair this many σ off counts half.
    pub robust_sigma: f64,
    /// Prior std of the position around the prediction, metres.
    pub prior_std_m: f64,
    /// Prior std of the heading around the prediction, radians.
    pub prior_std_rad: f64,
    /// Gauss–Newton iterations at most.
    pub max_iterations: u32,
    /// Converged when a step moves the position less than this, metres…
    pub tolerance_m: f64,
    /// …and the heading less than this, radians.
    pub tolerance_rad: f64,
    /// Fewest pairs for a solve.
    pub min_correspondences: usize,
    /// A correction farther than this from the prediction is refused, metres.
    pub max_correction_m: f64,
    /// A correction turning more than this from the prediction is refused, radians.
    pub max_correction_rad: f64,
}

/// One scored pair of the last iteration.
struct Pair {
    residual: Vector2<f64>,
    info: Matrix2<f64>,
    lever: Vector2<f64>,
}

impl Pair {
    /// The residual's Jacobian over (x, y, ψ), d(T p)/d(x, y, ψ) = [I | perp(R p)] with
    /// perp(v) = (−v_y, v_x), and its information under the Cauchy weight at `robust2` (the
    /// squared scale on the Mahalanobis distance).
    fn weighted(&self, robust2: f64) -> (nalgebra::Matrix2x3<f64>, Matrix2<f64>) {
        let m2 = (self.residual.transpose() * self.info * self.residual)[0];
        let weight = 1.0 / (1.0 + m2 / robust2);
        let j = nalgebra::Matrix2x3::new(1.0, 0.0, -self.lever[1], 0.0, 1.0, self.lever[0]);
        (j, self.info * weight)
    }
}

/// Pairs each scan point (AGV frame, with its covariance) placed at `pose` with its nearest map
/// cells into `pairs`, each with the information of their combined covariance (cell, point
/// rotated into the map, `map_std_m`²). Returns (sum of squared residuals m², points paired).
fn pair_with_cells(
    map: &DistributionMap,
    points: &[(RadarPoint, Matrix2<f64>)],
    pose: Pose2,
    settings: &MatchSettings,
    pairs: &mut Vec<Pair>,
    kept: &mut [Option<KeptCells>],
) -> (f64, usize) {
    pairs.clear();
    let map_var = settings.map_std_m * settings.map_std_m;
    let map_var_i = Matrix2::identity() * map_var;
    let (sin, cos) = pose.yaw_rad.sin_cos();
    let rotation = Matrix2::new(cos, -sin, sin, cos);
    let mut sum_m2 = 0.0;
    let mut paired_points = 0usize;
    let mut found = Vec::with_capacity(settings.neighbours.min(64));
    for (index, (point, cov)) in points.iter().enumerate() {
        let in_map = pose.transform_point(point.position_m);
        let mut no_kept = None;
        map.nearest_kept(
            &in_map,
            settings.neighbours,
            settings.max_correspondence_m,
            &mut found,
            kept.get_mut(index).unwrap_or(&mut no_kept),
        );
        if found.is_empty() {
            continue;
        }
        paired_points += 1;
        let cov_map = rotation * cov * rotation.transpose();
        for cell in found.iter().filter_map(|&(_, i)| map.cells.get(i as usize)) {
            let residual = Vector2::new(in_map[0] - cell.mean_m[0], in_map[1] - cell.mean_m[1]);
            let s = cell.cov_m2 + cov_map + map_var_i;
            let Some(info) = s.try_inverse() else {
                continue;
            };
            sum_m2 += residual.norm_squared();
            pairs.push(Pair {
                residual,
                info,
                lever: Vector2::new(in_map[0] - pose.x_m, in_map[1] - pose.y_m),
            });
        }
    }
    (sum_m2, paired_points)
}

/// The information the scan's pairs with the map carry about the pose at `pose` (over x m, y m
/// and yaw rad about the AGV, map frame): the Gauss–Newton Hessian of [`match_scan`]'s cost
/// without its prior, robust weights included, divided by `settings.neighbours` (each point
/// pairs with that many cells, which are not independent measurements of it).
pub fn scan_information(
    map: &DistributionMap,
    scan: &[RadarPoint],
    pose: Pose2,
    settings: &MatchSettings,
) -> Matrix3<f64> {
    let points = usable_points(scan);
    let mut pairs = Vec::new();
    pair_with_cells(map, &points, pose, settings, &mut pairs, &mut []);
    let robust2 = settings.robust_sigma * settings.robust_sigma;
    let h: Matrix3<f64> = pairs
        .iter()
        .map(|pair| {
            let (j, w_info) = pair.weighted(robust2);
            j.transpose() * w_info * j
        })
        .sum();
    h / settings.neighbours.max(1) as f64
}

/// The scan's points with finite coordinates and standard deviations, each with its covariance.
fn usable_points(scan: &[RadarPoint]) -> Vec<(RadarPoint, Matrix2<f64>)> {
    scan.iter()
        .filter(|p| {
            p.position_m.iter().all(|v| v.is_finite())
                && p.range_std_m.is_finite()
                && p.angle_std_rad.is_finite()
        })
        .map(|p| (*p, p.covariance_m2()))
        .collect()
}

/// Matches `scan` against `map` from the `initial` pose (the prediction) by Gauss–Newton on the
/// point-to-distribution cost (module docs). Returns the corrected pose, or `initial` with the
/// reason it was kept. Non-finite points are ignored; no input yields a non-finite pose.
pub fn match_scan(
    map: &DistributionMap,
    scan: &[RadarPoint],
    initial: Pose2,
    settings: &MatchSettings,
) -> IcpResult {
    let points = usable_points(scan);
    let unchanged = |status| IcpResult::unchanged(initial, status);
    if points.is_empty() {
        return unchanged(IcpStatus::EmptyScan);
    }
    if map.is_empty() || !initial.is_finite() {
        return unchanged(IcpStatus::EmptyMap);
    }
    let robust2 = settings.robust_sigma * settings.robust_sigma;
    let prior_info = Matrix3::from_diagonal(&Vector3::new(
        1.0 / settings.prior_std_m.powi(2),
        1.0 / settings.prior_std_m.powi(2),
        1.0 / settings.prior_std_rad.powi(2),
    ));
    let mut pose = initial;
    let mut result = unchanged(IcpStatus::MaxIterations);
    let mut pairs: Vec<Pair> = Vec::with_capacity(points.len() * settings.neighbours);
    let mut kept: Vec<Option<KeptCells>> = vec![None; points.len()];
    for iteration in 1..=settings.max_iterations {
        let (sum_m2, paired_points) =
            pair_with_cells(map, &points, pose, settings, &mut pairs, &mut kept);
        result.iterations = iteration;
        result.correspondences = paired_points;
        if paired_points < settings.min_correspondences {
            return IcpResult {
                status: IcpStatus::TooFewCorrespondences,
                ..result
            };
        }
        result.rms_m = (sum_m2 / pairs.len().max(1) as f64).sqrt();
        // Gauss–Newton over (x, y, ψ) (Pair::weighted).
        let offset = Vector3::new(
            pose.x_m - initial.x_m,
            pose.y_m - initial.y_m,
            wrap_angle_rad(pose.yaw_rad - initial.yaw_rad),
        );
        // The prior is robust too (Cauchy): odometry that slipped far beyond its error model
        // (many σ from where the scan fits) mostly gives way instead of dragging the scan off
        // the map. Measured on the hall, 20 seeds open loop: a Geman–McClure prior, which gives
        // way entirely, doubled the 5G keyframe RMSE (0.84 → 1.69 m); a plain Gaussian one is
        // level with Cauchy for 5G and 5° and 13 % better at 1°, but never lets go of a slip.
        let prior_m2 = (offset.transpose() * prior_info * offset)[0];
        let prior_weight = 1.0 / (1.0 + prior_m2 / robust2);
        let mut h = prior_info * prior_weight;
        let mut g = prior_info * offset * prior_weight;
        for pair in &pairs {
            let (j, w_info) = pair.weighted(robust2);
            // Jᵀ W once for both products (the same operations as forming it twice).
            let jt_w = j.transpose() * w_info;
            h += jt_w * j;
            g += jt_w * pair.residual;
        }
        let Some(step) = h.cholesky().map(|c| c.solve(&(-g))) else {
            return IcpResult {
                status: IcpStatus::CorrectionRejected,
                ..result
            };
        };
        if !step.iter().all(|v| v.is_finite()) {
            return IcpResult {
                status: IcpStatus::CorrectionRejected,
                ..result
            };
        }
        pose = Pose2::new(
            pose.x_m + step[0],
            pose.y_m + step[1],
            wrap_angle_rad(pose.yaw_rad + step[2]),
        );
        if step[0].hypot(step[1]) < settings.tolerance_m && step[2].abs() < settings.tolerance_rad {
            result.status = IcpStatus::Converged;
            break;
        }
    }
    result.gated(
        initial,
        pose,
        settings.max_correction_m,
        settings.max_correction_rad,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn segment(a: [f64; 2], b: [f64; 2], step_m: f64) -> Vec<[f64; 2]> {
        let length_m = (b[0] - a[0]).hypot(b[1] - a[1]);
        let n = (length_m / step_m).ceil().max(1.0) as usize;
        (0..=n)
            .map(|i| {
                let t = i as f64 / n as f64;
                [a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]
            })
            .collect()
    }

    /// Two boxes and a circle, sampled every 5 cm: a map with corners, walls and a curve.
    fn outlines() -> Vec<[f64; 2]> {
        let mut points = Vec::new();
        for (a, b) in [
            ([2.0, 3.0], [6.0, 3.0]),
            ([6.0, 3.0], [6.0, 5.0]),
            ([6.0, 5.0], [2.0, 5.0]),
            ([2.0, 5.0], [2.0, 3.0]),
            ([-4.0, 6.0], [-1.0, 6.0]),
            ([-1.0, 6.0], [-1.0, 8.0]),
        ] {
            points.extend(segment(a, b, 0.05));
        }
        points.extend((0..120).map(|i| {
            let a = f64::from(i) * std::f64::consts::TAU / 120.0;
            [9.0 + 1.5 * a.cos(), 9.0 + 1.5 * a.sin()]
        }));
        points
    }

    fn map_of(points: &[[f64; 2]]) -> DistributionMap {
        let mut map = DistributionMap::new(0.5, 3, 0.02);
        map.extend(points);
        map
    }

    /// The world points as the radar at `agv` sees them, with the given errors.
    fn scan_from(agv: &Pose2, world: &[[f64; 2]], std: [f64; 2]) -> Vec<RadarPoint> {
        let inverse = agv.inverse();
        world
            .iter()
            .map(|p| RadarPoint {
                position_m: inverse.transform_point(*p),
                range_std_m: std[0],
                angle_std_rad: std[1],
            })
            .collect()
    }

    fn settings() -> MatchSettings {
        MatchSettings {
            max_correspondence_m: 1.0,
            neighbours: 4,
            map_std_m: 0.05,
            robust_sigma: 3.0,
            prior_std_m: 1.0,
            prior_std_rad: 10f64.to_radians(),
            max_iterations: 50,
            tolerance_m: 1e-5,
            tolerance_rad: 1e-6,
            min_correspondences: 8,
            max_correction_m: 1.0,
            max_correction_rad: 20f64.to_radians(),
        }
    }

    #[test]
    fn recovers_a_known_offset() {
        let world = outlines();
        let map = map_of(&world);
        let truth = Pose2::new(1.0, -1.0, 0.3);
        let scan = scan_from(&truth, &world[..world.len() * 2 / 3], [0.02, 0.002]);
        for offset in [
            Pose2::new(0.3, 0.0, 0.0),
            Pose2::new(-0.2, 0.25, 0.03),
            Pose2::new(0.0, -0.2, -0.05),
        ] {
            let result = match_scan(&map, &scan, truth.compose(&offset), &settings());
            assert_eq!(result.status, IcpStatus::Converged, "{result:?}");
            assert!(result.pose.distance_m(&truth) < 0.02, "{result:?}");
            assert!(
                result.pose.rotation_to_rad(&truth).to_degrees() < 0.2,
                "{result:?}"
            );
        }
    }

    #[test]
    fn weighting_trusts_range_over_angle() {
        // A wall ahead, along the beams, measured finely in range; a wall far to the side whose
        // points carry a 3° angle error (metres across the beam). Declared honestly, the side
        // wall's scatter moves the pose little; declared as fine as the front, it drags it.
        let front = segment([10.0, -3.0], [10.0, 3.0], 0.1);
        let side = segment([0.0, 12.0], [12.0, 12.0], 0.1);
        let mut world = front.clone();
        world.extend(side.iter().copied());
        let map = map_of(&world);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut honest = scan_from(&Pose2::IDENTITY, &front, [0.02, 0.2f64.to_radians()]);
        for p in &side {
            let (r, a) = (
                p[0].hypot(p[1]),
                p[1].atan2(p[0]) + rng.random_range(-3.0..3.0f64).to_radians(),
            );
            honest.push(RadarPoint {
                position_m: [r * a.cos(), r * a.sin()],
                range_std_m: 0.02,
                angle_std_rad: 3f64.to_radians(),
            });
        }
        let mut understated = honest.clone();
        for p in &mut understated {
            p.angle_std_rad = 0.2f64.to_radians();
        }
        let initial = Pose2::new(0.2, 0.2, 0.0);
        let weighted = match_scan(&map, &honest, initial, &settings());
        let equal = match_scan(&map, &understated, initial, &settings());
        assert!(weighted.pose.is_finite() && equal.pose.is_finite());
        assert!(weighted.pose.x_m.abs() < 0.03, "{weighted:?}");
        assert!(
            weighted.pose.x_m.abs() + weighted.pose.yaw_rad.abs() * 10.0
                < equal.pose.x_m.abs() + equal.pose.yaw_rad.abs() * 10.0,
            "weighted {weighted:?} equal {equal:?}"
        );
    }

    #[test]
    fn the_prior_holds_what_a_straight_wall_cannot_observe() {
        // One long wall: across it the scan decides, along it the prediction stands.
        let wall = segment([-10.0, 2.0], [10.0, 2.0], 0.05);
        let map = map_of(&wall);
        let scan = scan_from(&Pose2::IDENTITY, &wall[100..300], [0.02, 0.002]);
        let initial = Pose2::new(0.25, 0.2, 0.0);
        let result = match_scan(&map, &scan, initial, &settings());
        assert!(result.status.is_accepted(), "{result:?}");
        assert!(result.pose.y_m.abs() < 0.01, "{result:?}");
        assert!((result.pose.x_m - 0.25).abs() < 0.05, "{result:?}");
    }

    #[test]
    fn odometry_that_slipped_gives_way_to_the_scan() {
        // A tight prior (1 cm) on a prediction 0.2 m off: twenty of its σ, so the robust prior
        // yields and the scan decides.
        let world = outlines();
        let map = map_of(&world);
        let truth = Pose2::new(0.5, 0.5, 0.1);
        let scan = scan_from(&truth, &world, [0.02, 0.002]);
        let tight = MatchSettings {
            prior_std_m: 0.01,
            prior_std_rad: 0.1f64.to_radians(),
            ..settings()
        };
        let initial = truth.compose(&Pose2::new(0.2, 0.0, 0.0));
        let result = match_scan(&map, &scan, initial, &tight);
        assert!(result.pose.distance_m(&truth) < 0.03, "{result:?}");
    }

    #[test]
    fn without_map_or_scan_the_prediction_stands() {
        let initial = Pose2::new(1.0, 2.0, 0.3);
        let world = outlines();
        let scan = scan_from(&initial, &world, [0.02, 0.01]);
        let empty = DistributionMap::new(0.5, 3, 0.02);
        let result = match_scan(&empty, &scan, initial, &settings());
        assert_eq!((result.pose, result.status), (initial, IcpStatus::EmptyMap));
        let result = match_scan(&map_of(&world), &[], initial, &settings());
        assert_eq!(
            (result.pose, result.status),
            (initial, IcpStatus::EmptyScan)
        );
        // Points far from every cell: too few correspondences.
        let far = scan_from(&initial, &[[500.0, 500.0]; 20], [0.02, 0.01]);
        let result = match_scan(&map_of(&world), &far, initial, &settings());
        assert_eq!(
            (result.pose, result.status),
            (initial, IcpStatus::TooFewCorrespondences)
        );
    }

    #[test]
    fn bad_numbers_never_give_nan() {
        let world = outlines();
        let mut map = map_of(&world);
        // Non-finite and absurd map points are skipped.
        map.extend(&[[f64::NAN, 0.0], [f64::INFINITY, 1.0], [1e300, 1e300]]);
        assert_eq!(map.point_count(), world.len());
        let truth = Pose2::new(0.3, 0.1, 0.05);
        let mut scan = scan_from(&truth, &world, [0.0, 0.0]);
        scan.push(RadarPoint {
            position_m: [f64::NAN, 1.0],
            range_std_m: 0.02,
            angle_std_rad: 0.01,
        });
        scan.push(RadarPoint {
            position_m: [1.0, 1.0],
            range_std_m: f64::INFINITY,
            angle_std_rad: 0.01,
        });
        // Zero declared errors and coincident points: the covariance floors keep it solvable.
        scan.extend(std::iter::repeat_n(scan[0], 30));
        let result = match_scan(&map, &scan, truth, &settings());
        assert!(result.pose.is_finite(), "{result:?}");
        assert!(result.pose.distance_m(&truth) < 0.05, "{result:?}");
        let result = match_scan(&map, &scan, Pose2::new(f64::NAN, 0.0, 0.0), &settings());
        assert_eq!(result.status, IcpStatus::EmptyMap);
    }

    #[test]
    fn a_correction_beyond_the_gate_is_refused() {
        let world = outlines();
        let map = map_of(&world);
        let truth = Pose2::new(0.0, 0.0, 0.0);
        let scan = scan_from(&truth, &world, [0.02, 0.002]);
        let gated = MatchSettings {
            max_correction_m: 0.05,
            ..settings()
        };
        let initial = Pose2::new(0.3, 0.0, 0.0);
        let result = match_scan(&map, &scan, initial, &gated);
        assert_eq!(result.status, IcpStatus::CorrectionRejected, "{result:?}");
        assert_eq!(result.pose, initial);
    }

    #[test]
    fn matching_is_deterministic() {
        let world = outlines();
        let scan = scan_from(&Pose2::new(0.2, 0.1, 0.02), &world, [0.02, 0.01]);
        let a = match_scan(&map_of(&world), &scan, Pose2::IDENTITY, &settings());
        let b = match_scan(&map_of(&world), &scan, Pose2::IDENTITY, &settings());
        assert_eq!(a, b);
    }

    proptest! {
        /// A map that took points in and out has the cells, means and covariances of one that
        /// only ever held the rest, up to rounding in the cells' sums.
        #[test]
        fn retracted_points_leave_the_map_of_the_rest(
            kept in prop::collection::vec((-30.0f64..30.0, -30.0f64..30.0), 0..200),
            dropped in prop::collection::vec((-30.0f64..30.0, -30.0f64..30.0), 0..200),
        ) {
            let kept: Vec<[f64; 2]> = kept.into_iter().map(|(x, y)| [x, y]).collect();
            let dropped: Vec<[f64; 2]> = dropped.into_iter().map(|(x, y)| [x, y]).collect();
            let mut map = DistributionMap::new(2.0, 2, 0.05);
            map.extend(&dropped);
            map.extend(&kept);
            map.retract(&dropped);
            let mut reference = DistributionMap::new(2.0, 2, 0.05);
            reference.extend(&kept);
            prop_assert_eq!(map.point_count(), reference.point_count());
            prop_assert_eq!(map.sums.len(), reference.sums.len());
            prop_assert_eq!(map.len(), reference.len());
            for (a, b) in map.cells.iter().zip(&reference.cells) {
                for axis in 0..2 {
                    prop_assert!((a.mean_m[axis] - b.mean_m[axis]).abs() < 1e-9);
                }
                prop_assert!((a.cov_m2 - b.cov_m2).abs().max() < 1e-6, "{} against {}", a.cov_m2, b.cov_m2);
            }
        }
    }

    proptest! {
        /// The grid over the means finds the cells the k-d tree finds, in its order, for any
        /// radius and count, and so does the tree the map keeps for means too sparse for a grid.
        #[test]
        fn the_mean_grid_finds_what_the_k_d_tree_finds(
            points in prop::collection::vec((-12.0f64..12.0, -12.0f64..12.0), 0..400),
            queries in prop::collection::vec((-14.0f64..14.0, -14.0f64..14.0), 1..40),
            cell_m in 0.2f64..2.0,
            max_m in 0.05f64..3.0,
            k in 1usize..8,
            far in any::<bool>(),
        ) {
            let mut points: Vec<[f64; 2]> = points.into_iter().map(|(x, y)| [x, y]).collect();
            if far {
                // A cell a million metres away (two points, so that it has a Gaussian): too
                // sparse for the grid.
                points.push([1e6, 1e6]);
                points.push([1e6, 1e6]);
            }
            let mut map = DistributionMap::new(cell_m, 2, 0.05);
            map.extend(&points);
            if far && map.cells.len() > 1 {
                prop_assert!(map.grid.is_none() && map.tree.is_some());
            }
            let mut found = Vec::new();
            for (x, y) in queries {
                map.nearest_into(&[x, y], k, max_m, &mut found);
                let grid: Vec<u32> = found.iter().map(|&(_, i)| i).collect();
                prop_assert_eq!(grid, map.nearest_by_tree(&[x, y], k, max_m));
            }
        }
    }

    proptest! {
        /// Candidates kept between lookups give what a lookup in the grid gives, for a point
        /// walking in steps of up to 7 cm (so that it leaves its anchor's reach now and then).
        #[test]
        fn kept_candidates_find_what_the_grid_finds(
            points in prop::collection::vec((-12.0f64..12.0, -12.0f64..12.0), 0..400),
            start in (-12.0f64..12.0, -12.0f64..12.0),
            steps in prop::collection::vec((-0.07f64..0.07, -0.07f64..0.07), 1..40),
            k in 1usize..6,
        ) {
            let mut points: Vec<[f64; 2]> = points.into_iter().map(|(x, y)| [x, y]).collect();
            points.extend(outlines());
            let mut map = DistributionMap::new(0.5, 2, 0.02);
            map.extend(&points);
            let (mut kept, mut found, mut reference) = (None, Vec::new(), Vec::new());
            let mut query = [start.0, start.1];
            for (dx, dy) in steps {
                query = [query[0] + dx, query[1] + dy];
                map.nearest_kept(&query, k, 0.5, &mut found, &mut kept);
                map.nearest_into(&query, k, 0.5, &mut reference);
                prop_assert_eq!(&found, &reference);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// From any start within 0.25 m and 3° of the truth, a noise-free scan of the outlines is
        /// matched to within 2 cm and 0.2°.
        #[test]
        fn converges_from_nearby_starts(
            dx in -0.25f64..0.25, dy in -0.25f64..0.25, dyaw_deg in -3.0f64..3.0,
            x in -2.0f64..2.0, y in -2.0f64..2.0, yaw in -3.1f64..3.1,
        ) {
            let world = outlines();
            let map = map_of(&world);
            let truth = Pose2::new(x, y, yaw);
            let scan = scan_from(&truth, &world, [0.02, 0.002]);
            let start = truth.compose(&Pose2::new(dx, dy, dyaw_deg.to_radians()));
            let result = match_scan(&map, &scan, start, &settings());
            prop_assert!(result.status.is_accepted(), "{:?}", result);
            prop_assert!(result.pose.distance_m(&truth) < 0.02, "{:?}", result);
            prop_assert!(result.pose.rotation_to_rad(&truth).to_degrees() < 0.2, "{:?}", result);
        }
    }
}
