//! Exact assignment solvers: the linear sum assignment problem for GOSPA/ET-GOPSA with 1 ≤ p < ∞,
//! and a bottleneck matching for p = ∞.
//!
//! [`solve`] finds, for an n×m cost matrix, a matching that covers every row (n ≤ m) or every
//! column (n > m) with the least total cost. It is the shortest augmenting path method of Jonker
//! and Volgenant as given for rectangular matrices by D. F. Crouse, "On implementing 2D
//! rectangular assignment algorithms", IEEE Trans. AES 52(4), 2016 (the algorithm behind SciPy's
//! `linear_sum_assignment`): one Dijkstra search on reduced costs per row of the smaller side,
//! O(n²m) time, O(n + m) extra memory. A 40 × 5000 matrix (40 target slots, 5000 map points)
//! takes a few milliseconds.
//!
//! [`solve_partial`] is the form both metrics need: the best partial matching (any number of
//! pairs) for a weight matrix, through [`solve`] on the rows and columns that matter.
//!
//! [`solve_bottleneck`] answers the p = ∞ limit of the metrics: among the matchings that use only
//! entries below a limit, those with the most pairs, and among them one whose largest entry is the
//! smallest (binary search over the sorted entries, each step a maximum bipartite matching by
//! augmenting paths).
//!
//! Both are deterministic: same matrix, same answer, whatever the platform.

use thiserror::Error;

/// Largest magnitude accepted in a cost matrix. The dual potentials of [`solve`] are sums of up to
/// n + m costs; this bound keeps them, and every reduced cost, far from f64 overflow, so the
/// solver can never meet an infinity or a NaN of its own making.
pub const MAX_ABS_COST: f64 = 1e150;

/// Most cells a dense cost matrix may have: 2^26 = 67 108 864 (512 MiB of f64). Both metrics
/// build one rows × columns matrix per connected component of the pairs closer than c (target
/// slots or truth points × estimates); past this a component is refused before anything is
/// allocated, instead of asking the allocator for, say, the 320 GB of 200 000 × 200 000 points
/// within c of one another and aborting the process. Points spread far wider than c form small
/// components and are scored whatever their number.
pub const MAX_CELLS: usize = 1 << 26;

/// Checks that a `rows` × `cols` dense matrix stays within [`MAX_CELLS`].
///
/// # Errors
/// [`AssignmentError::TooLarge`] naming the sizes and the limit.
pub fn check_size(rows: usize, cols: usize) -> Result<(), AssignmentError> {
    match rows.checked_mul(cols) {
        Some(cells) if cells <= MAX_CELLS => Ok(()),
        _ => Err(AssignmentError::TooLarge { rows, cols }),
    }
}

/// A cost matrix refused by [`CostMatrix::new`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum AssignmentError {
    /// The data length is not rows × cols.
    #[error("cost matrix of {rows} × {cols} needs {expected} entries, got {len}")]
    ShapeMismatch {
        /// Rows requested.
        rows: usize,
        /// Columns requested.
        cols: usize,
        /// rows × cols (saturating).
        expected: usize,
        /// Entries given.
        len: usize,
    },
    /// An entry is NaN or infinite.
    #[error("cost matrix entry ({row}, {col}) is {value}: costs must be finite")]
    NonFinite {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// The entry.
        value: f64,
    },
    /// The matrix would have more than [`MAX_CELLS`] cells.
    #[error(
        "a dense assignment of {rows} × {cols} = {} cells is more than the limit of {MAX_CELLS} \
         cells (512 MiB); score fewer points",
        (*rows as u128) * (*cols as u128)
    )]
    TooLarge {
        /// Rows requested.
        rows: usize,
        /// Columns requested.
        cols: usize,
    },
    /// An entry's magnitude exceeds [`MAX_ABS_COST`].
    #[error(
        "cost matrix entry ({row}, {col}) is {value}: |cost| must not exceed {MAX_ABS_COST:e}"
    )]
    OutOfRange {
        /// Row of the entry.
        row: usize,
        /// Column of the entry.
        col: usize,
        /// The entry.
        value: f64,
    },
}

/// A dense, row-major matrix of finite costs with |cost| ≤ [`MAX_ABS_COST`] (checked on
/// construction, so the solvers cannot fail).
#[derive(Debug, Clone, PartialEq)]
pub struct CostMatrix {
    rows: usize,
    cols: usize,
    data: Vec<f64>,
}

impl CostMatrix {
    /// A `rows` × `cols` matrix from row-major `data`.
    ///
    /// # Errors
    /// [`AssignmentError::TooLarge`] past [`MAX_CELLS`],
    /// [`AssignmentError::ShapeMismatch`] if `data.len() != rows * cols`,
    /// [`AssignmentError::NonFinite`] / [`AssignmentError::OutOfRange`] naming the first bad entry.
    pub fn new(rows: usize, cols: usize, data: Vec<f64>) -> Result<Self, AssignmentError> {
        check_size(rows, cols)?;
        let expected = rows.saturating_mul(cols);
        if rows.checked_mul(cols) != Some(data.len()) {
            return Err(AssignmentError::ShapeMismatch {
                rows,
                cols,
                expected,
                len: data.len(),
            });
        }
        for (k, &value) in data.iter().enumerate() {
            let (row, col) = (k / cols, k % cols);
            if !value.is_finite() {
                return Err(AssignmentError::NonFinite { row, col, value });
            }
            if value.abs() > MAX_ABS_COST {
                return Err(AssignmentError::OutOfRange { row, col, value });
            }
        }
        Ok(Self { rows, cols, data })
    }

    /// A `rows` × `cols` matrix whose entry (r, c) is `cost(r, c)`.
    ///
    /// # Errors
    /// As [`CostMatrix::new`].
    pub fn from_fn(
        rows: usize,
        cols: usize,
        mut cost: impl FnMut(usize, usize) -> f64,
    ) -> Result<Self, AssignmentError> {
        check_size(rows, cols)?;
        let mut data = Vec::with_capacity(rows.saturating_mul(cols));
        for r in 0..rows {
            for c in 0..cols {
                data.push(cost(r, c));
            }
        }
        Self::new(rows, cols, data)
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Entry (row, col).
    ///
    /// # Panics
    /// If `row >= rows()` or `col >= cols()`.
    pub fn get(&self, row: usize, col: usize) -> f64 {
        assert!(
            row < self.rows && col < self.cols,
            "index out of the cost matrix"
        );
        self.data[row * self.cols + col]
    }

    fn transposed(&self) -> CostMatrix {
        let mut data = Vec::with_capacity(self.data.len());
        for c in 0..self.cols {
            for r in 0..self.rows {
                data.push(self.data[r * self.cols + c]);
            }
        }
        CostMatrix {
            rows: self.cols,
            cols: self.rows,
            data,
        }
    }
}

/// A minimum-cost matching that covers the smaller side of the matrix.
#[derive(Debug, Clone, PartialEq)]
pub struct Assignment {
    /// (row, col) pairs, sorted by row; min(rows, cols) of them.
    pub pairs: Vec<(usize, usize)>,
    /// Sum of the costs of `pairs`.
    pub cost: f64,
}

/// Minimum-cost assignment covering min(rows, cols) rows and columns (every row when
/// rows ≤ cols, every column otherwise). An empty matrix gives no pair and cost 0.
///
/// Costs may be negative. Ties are broken deterministically (the first minimal column in index
/// order, preferring free columns), but which of several optimal matchings comes back is otherwise
/// unspecified.
pub fn solve(costs: &CostMatrix) -> Assignment {
    if costs.rows == 0 || costs.cols == 0 {
        return Assignment {
            pairs: Vec::new(),
            cost: 0.0,
        };
    }
    let mut pairs: Vec<(usize, usize)> = if costs.rows <= costs.cols {
        shortest_augmenting_path(costs)
            .into_iter()
            .enumerate()
            .collect()
    } else {
        // The algorithm needs rows ≤ cols: solve the transpose and swap back.
        shortest_augmenting_path(&costs.transposed())
            .into_iter()
            .enumerate()
            .map(|(c, r)| (r, c))
            .collect()
    };
    pairs.sort_unstable();
    let cost = pairs.iter().map(|&(r, c)| costs.get(r, c)).sum();
    Assignment { pairs, cost }
}

/// Minimum-weight partial matching: among all one-to-one partial matchings γ (any number of
/// pairs, possibly none), one minimising Σ_{(r,c)∈γ} w(r, c). Returns its pairs, sorted; all have
/// w < 0 (a pair of weight ≥ 0 never helps, and pairs of weight exactly 0 are left out).
///
/// This is the form GOSPA and ET-GOPSA reduce to. It is solved exactly by [`solve`] on min(0, w)
/// restricted to the rows and columns that hold a negative entry: a full matching F of the smaller
/// side costs Σ_F min(0, w) = the weight of its negative pairs, and any partial matching extends
/// to such an F without raising that sum, so the two minima coincide. The restriction matters for
/// speed: most estimates of a map are far from every target, and their all-zero columns drop out;
/// of the rest, only each row's n cheapest can be needed (n rows), see the code.
pub fn solve_partial(weights: &CostMatrix) -> Vec<(usize, usize)> {
    let negative = |r: usize, c: usize| weights.data[r * weights.cols + c] < 0.0;
    let mut rows: Vec<usize> = (0..weights.rows)
        .filter(|&r| (0..weights.cols).any(|c| negative(r, c)))
        .collect();
    let mut cols: Vec<usize> = (0..weights.cols)
        .filter(|&c| rows.iter().any(|&r| negative(r, c)))
        .collect();
    // Each line of the narrower side needs only its k cheapest partners, k = that side's size:
    // if an optimal matching paired it elsewhere, one of those k would be free (the other k − 1
    // lines hold at most k − 1 of them) and no dearer, so moving it there keeps the optimum.
    // With 40 slots and 5000 estimates this leaves at most 40 columns per distinct row.
    let w = |r: usize, c: usize| weights.data[r * weights.cols + c];
    if rows.len() <= cols.len() {
        cols = keep_cheapest(&rows, &cols, w);
    } else {
        rows = keep_cheapest(&cols, &rows, |c, r| w(r, c));
    }
    let reduced = CostMatrix {
        rows: rows.len(),
        cols: cols.len(),
        data: rows
            .iter()
            .flat_map(|&r| cols.iter().map(move |&c| weights.get(r, c).min(0.0)))
            .collect(),
    };
    let mut pairs: Vec<(usize, usize)> = solve(&reduced)
        .pairs
        .into_iter()
        .map(|(r, c)| (rows[r], cols[c]))
        .filter(|&(r, c)| negative(r, c))
        .collect();
    pairs.sort_unstable();
    pairs
}

/// The members of `others` that are among the `lines.len()` cheapest negative partners of some
/// line, by (weight, position) so ties are broken deterministically; order kept.
fn keep_cheapest(
    lines: &[usize],
    others: &[usize],
    weight: impl Fn(usize, usize) -> f64,
) -> Vec<usize> {
    let k = lines.len();
    let mut keep = vec![false; others.len()];
    let mut candidates: Vec<(f64, usize)> = Vec::with_capacity(others.len());
    for &line in lines {
        candidates.clear();
        candidates.extend(others.iter().enumerate().filter_map(|(pos, &other)| {
            let w = weight(line, other);
            (w < 0.0).then_some((w, pos))
        }));
        if candidates.len() > k {
            candidates
                .select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            candidates.truncate(k);
        }
        for &(_, pos) in &candidates {
            keep[pos] = true;
        }
    }
    others
        .iter()
        .zip(&keep)
        .filter(|(_, &kept)| kept)
        .map(|(&other, _)| other)
        .collect()
}

/// Crouse's Algorithm (shortest augmenting path with dual potentials u, v) for rows ≤ cols.
/// Returns the column of each row.
fn shortest_augmenting_path(costs: &CostMatrix) -> Vec<usize> {
    const FREE: usize = usize::MAX;
    let (n, m) = (costs.rows, costs.cols);
    debug_assert!(n <= m && n > 0);
    let mut u = vec![0.0_f64; n];
    let mut v = vec![0.0_f64; m];
    let mut col_for_row = vec![FREE; n];
    let mut row_for_col = vec![FREE; m];
    let mut path = vec![FREE; m];
    let mut shortest = vec![f64::INFINITY; m];
    let mut row_seen = vec![false; n];
    let mut col_seen = vec![false; m];
    let mut remaining: Vec<usize> = Vec::with_capacity(m);

    for current_row in 0..n {
        // Dijkstra from current_row over the reduced costs c(i,j) − u(i) − v(j), which are ≥ 0 on
        // every edge except those leaving current_row (not yet in the dual solution); edges out of
        // the source may be negative without harming Dijkstra.
        shortest.fill(f64::INFINITY);
        row_seen.fill(false);
        col_seen.fill(false);
        remaining.clear();
        remaining.extend((0..m).rev());
        let mut min_val = 0.0_f64;
        let mut i = current_row;
        let sink = loop {
            row_seen[i] = true;
            let row = &costs.data[i * m..(i + 1) * m];
            let mut lowest = f64::INFINITY;
            let mut lowest_at = usize::MAX;
            for (it, &j) in remaining.iter().enumerate() {
                let reduced = min_val + row[j] - u[i] - v[j];
                if reduced < shortest[j] {
                    path[j] = i;
                    shortest[j] = reduced;
                }
                // Prefer a free column on ties: it ends the search one step earlier.
                if shortest[j] < lowest || (shortest[j] == lowest && row_for_col[j] == FREE) {
                    lowest = shortest[j];
                    lowest_at = it;
                }
            }
            // Costs are bounded by MAX_ABS_COST, so `lowest` is finite and `lowest_at` was set:
            // n ≤ m guarantees a free column is always among `remaining`.
            debug_assert!(lowest.is_finite() && lowest_at != usize::MAX);
            min_val = lowest;
            let j = remaining.swap_remove(lowest_at);
            col_seen[j] = true;
            if row_for_col[j] == FREE {
                break j;
            }
            i = row_for_col[j];
        };

        // Update the dual potentials so reduced costs stay ≥ 0 on matched edges.
        u[current_row] += min_val;
        for r in 0..n {
            if row_seen[r] && r != current_row {
                u[r] += min_val - shortest[col_for_row[r]];
            }
        }
        for c in 0..m {
            if col_seen[c] {
                v[c] -= min_val - shortest[c];
            }
        }
        // Augment along the alternating path ending at the free column `sink`.
        let mut j = sink;
        loop {
            let r = path[j];
            row_for_col[j] = r;
            std::mem::swap(&mut col_for_row[r], &mut j);
            if r == current_row {
                break;
            }
        }
    }
    col_for_row
}

/// A bottleneck matching from [`solve_bottleneck`].
#[derive(Debug, Clone, PartialEq)]
pub struct BottleneckMatching {
    /// (row, col) pairs, sorted by row.
    pub pairs: Vec<(usize, usize)>,
    /// Largest entry among `pairs`; `None` when there is no pair.
    pub bottleneck: Option<f64>,
}

/// Among the matchings that use only entries strictly below `limit`, those with the most pairs;
/// among them, one whose largest entry is the smallest.
///
/// This is the p = ∞ limit of GOSPA-type metrics: with every cost ≤ c and an unassigned point
/// costing c, the ∞-norm of an assignment is c unless it pairs everyone with costs below c.
pub fn solve_bottleneck(costs: &CostMatrix, limit: f64) -> BottleneckMatching {
    // Work with the smaller side on the left: augmenting paths start there.
    let transpose = costs.rows > costs.cols;
    let (left, right) = if transpose {
        (costs.cols, costs.rows)
    } else {
        (costs.rows, costs.cols)
    };
    let entry = |l: usize, r: usize| {
        if transpose {
            costs.get(r, l)
        } else {
            costs.get(l, r)
        }
    };
    // Admissible edges of each left vertex, sorted by cost (ties by index): the edges with
    // cost ≤ t are then a prefix of each list.
    let mut adjacency: Vec<Vec<(f64, usize)>> = (0..left)
        .map(|l| {
            let mut edges: Vec<(f64, usize)> = (0..right)
                .map(|r| (entry(l, r), r))
                .filter(|&(cost, _)| cost < limit)
                .collect();
            edges.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            edges
        })
        .collect();
    adjacency.shrink_to_fit();
    let mut thresholds: Vec<f64> = adjacency.iter().flatten().map(|&(c, _)| c).collect();
    thresholds.sort_by(f64::total_cmp);
    thresholds.dedup();

    let matching_at = |threshold: f64| -> Vec<Option<usize>> {
        let prefix: Vec<usize> = adjacency
            .iter()
            .map(|edges| edges.partition_point(|&(c, _)| c <= threshold))
            .collect();
        maximum_matching(&adjacency, &prefix, right)
    };
    let size = |m: &[Option<usize>]| m.iter().flatten().count();

    let Some(&largest) = thresholds.last() else {
        return BottleneckMatching {
            pairs: Vec::new(),
            bottleneck: None,
        };
    };
    let best_size = size(&matching_at(largest));
    // Smallest threshold index whose matching still has best_size pairs.
    let (mut lo, mut hi) = (0usize, thresholds.len() - 1);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        if size(&matching_at(thresholds[mid])) == best_size {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    let matched = matching_at(thresholds[lo]);
    let mut pairs: Vec<(usize, usize)> = matched
        .iter()
        .enumerate()
        .filter_map(|(l, r)| r.map(|r| if transpose { (r, l) } else { (l, r) }))
        .collect();
    pairs.sort_unstable();
    let bottleneck = pairs
        .iter()
        .map(|&(r, c)| costs.get(r, c))
        .fold(None, |acc: Option<f64>, c| {
            Some(acc.map_or(c, |a| a.max(c)))
        });
    BottleneckMatching { pairs, bottleneck }
}

/// Maximum bipartite matching (Kuhn's augmenting paths, iterative DFS so deep paths cannot
/// overflow the stack) using, for left vertex l, the first `prefix[l]` edges of `adjacency[l]`.
/// Returns the right vertex matched to each left vertex.
fn maximum_matching(
    adjacency: &[Vec<(f64, usize)>],
    prefix: &[usize],
    right: usize,
) -> Vec<Option<usize>> {
    let left = adjacency.len();
    let mut left_match: Vec<Option<usize>> = vec![None; left];
    let mut right_match: Vec<Option<usize>> = vec![None; right];
    let mut seen_stamp = vec![0u32; right];
    let mut stack: Vec<(usize, usize)> = Vec::new();
    let mut via: Vec<usize> = Vec::new();
    for (root, stamp) in (0..left).zip(1u32..) {
        stack.clear();
        via.clear();
        stack.push((root, 0));
        // stack[k] is a left vertex; via[k] the right vertex leading from stack[k] to stack[k+1]
        // (or, on success, to the free right vertex that ends the augmenting path).
        while let Some(top) = stack.len().checked_sub(1) {
            let (l, pos) = stack[top];
            if pos == prefix[l] {
                stack.pop();
                via.pop();
                continue;
            }
            stack[top].1 += 1;
            let r = adjacency[l][pos].1;
            if seen_stamp[r] == stamp {
                continue;
            }
            seen_stamp[r] = stamp;
            via.push(r);
            match right_match[r] {
                Some(next) => stack.push((next, 0)),
                None => {
                    for (&(l, _), &r) in stack.iter().zip(&via) {
                        left_match[l] = Some(r);
                        right_match[r] = Some(l);
                    }
                    break;
                }
            }
        }
    }
    left_match
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Minimum over all injective maps of the smaller side into the larger one.
    #[test]
    fn matrices_past_the_cell_limit_are_refused_before_allocating() {
        assert!(check_size(MAX_CELLS, 1).is_ok());
        assert!(check_size(1 << 13, 1 << 13).is_ok());
        for (rows, cols) in [(200_000, 200_000), (MAX_CELLS + 1, 1), (usize::MAX, 2)] {
            let error = check_size(rows, cols).unwrap_err();
            assert_eq!(error, AssignmentError::TooLarge { rows, cols });
            let message = error.to_string();
            assert!(
                message.contains(&format!("{rows} × {cols}"))
                    && message.contains(&MAX_CELLS.to_string()),
                "{message}"
            );
        }
        assert_eq!(
            AssignmentError::TooLarge {
                rows: 200_000,
                cols: 200_000
            }
            .to_string(),
            "a dense assignment of 200000 × 200000 = 40000000000 cells is more than the limit \
             of 67108864 cells (512 MiB); score fewer points"
        );
        // from_fn never calls the cost function (nor allocates) for a refused size.
        let refused = CostMatrix::from_fn(200_000, 200_000, |_, _| unreachable!());
        assert!(matches!(refused, Err(AssignmentError::TooLarge { .. })));
    }

    fn brute_force_min(costs: &CostMatrix) -> f64 {
        fn rec(costs: &CostMatrix, row: usize, used: &mut Vec<bool>, transpose: bool) -> f64 {
            let (n, m) = if transpose {
                (costs.cols(), costs.rows())
            } else {
                (costs.rows(), costs.cols())
            };
            if row == n {
                return 0.0;
            }
            let mut best = f64::INFINITY;
            for c in 0..m {
                if !used[c] {
                    used[c] = true;
                    let here = if transpose {
                        costs.get(c, row)
                    } else {
                        costs.get(row, c)
                    };
                    best = best.min(here + rec(costs, row + 1, used, transpose));
                    used[c] = false;
                }
            }
            best
        }
        let transpose = costs.rows() > costs.cols();
        let m = costs.rows().max(costs.cols());
        rec(costs, 0, &mut vec![false; m], transpose)
    }

    fn random_matrix(rng: &mut ChaCha8Rng, rows: usize, cols: usize, integer: bool) -> CostMatrix {
        CostMatrix::from_fn(rows, cols, |_, _| {
            if integer {
                // Small integers make ties frequent: the hard case for tie handling.
                f64::from(rng.random_range(-3i32..4))
            } else {
                rng.random_range(-10.0..10.0)
            }
        })
        .unwrap()
    }

    fn check_valid(costs: &CostMatrix, a: &Assignment) {
        assert_eq!(a.pairs.len(), costs.rows().min(costs.cols()));
        let mut rows: Vec<usize> = a.pairs.iter().map(|p| p.0).collect();
        let mut cols: Vec<usize> = a.pairs.iter().map(|p| p.1).collect();
        rows.sort_unstable();
        cols.sort_unstable();
        rows.dedup();
        cols.dedup();
        assert_eq!(rows.len(), a.pairs.len(), "a row used twice");
        assert_eq!(cols.len(), a.pairs.len(), "a column used twice");
    }

    #[test]
    fn matches_brute_force_on_small_random_matrices() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for trial in 0..600 {
            let rows = rng.random_range(1..=6);
            let cols = rng.random_range(1..=6);
            let costs = random_matrix(&mut rng, rows, cols, trial % 2 == 0);
            let a = solve(&costs);
            check_valid(&costs, &a);
            let best = brute_force_min(&costs);
            assert!(
                (a.cost - best).abs() < 1e-9,
                "trial {trial}: {rows}x{cols} solver {} brute force {best}",
                a.cost
            );
        }
    }

    #[test]
    fn empty_matrices_give_no_pairs() {
        for (r, c) in [(0, 0), (0, 5), (5, 0)] {
            let a = solve(&CostMatrix::new(r, c, vec![]).unwrap());
            assert!(a.pairs.is_empty());
            assert_eq!(a.cost, 0.0);
        }
    }

    #[test]
    fn known_3x3() {
        // Classic example: optimum 5 = 1 (0,1) + 2 (1,0) + 2 (2,2).
        let costs = CostMatrix::new(3, 3, vec![4., 1., 3., 2., 0., 5., 3., 2., 2.]).unwrap();
        let a = solve(&costs);
        assert_eq!(a.pairs, vec![(0, 1), (1, 0), (2, 2)]);
        assert_eq!(a.cost, 5.0);
    }

    #[test]
    fn refuses_nan_infinite_huge_and_misshaped() {
        assert!(matches!(
            CostMatrix::new(2, 2, vec![0.0, f64::NAN, 1.0, 2.0]),
            Err(AssignmentError::NonFinite { row: 0, col: 1, .. })
        ));
        assert!(matches!(
            CostMatrix::new(2, 2, vec![0.0, 1.0, f64::NEG_INFINITY, 2.0]),
            Err(AssignmentError::NonFinite { row: 1, col: 0, .. })
        ));
        assert!(matches!(
            CostMatrix::new(1, 2, vec![0.0, 1e200]),
            Err(AssignmentError::OutOfRange { row: 0, col: 1, .. })
        ));
        assert!(matches!(
            CostMatrix::new(2, 3, vec![0.0; 5]),
            Err(AssignmentError::ShapeMismatch {
                expected: 6,
                len: 5,
                ..
            })
        ));
        let message = CostMatrix::new(1, 1, vec![f64::NAN])
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("(0, 0)") && message.contains("NaN"),
            "{message}"
        );
    }

    #[test]
    fn extreme_but_allowed_costs_do_not_break_the_solver() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..50 {
            let costs =
                CostMatrix::from_fn(4, 5, |_, _| rng.random_range(-1.0..1.0) * MAX_ABS_COST)
                    .unwrap();
            let a = solve(&costs);
            check_valid(&costs, &a);
            let best = brute_force_min(&costs);
            assert!((a.cost - best).abs() <= 1e-9 * MAX_ABS_COST);
        }
    }

    #[test]
    fn large_rectangular_problem_is_optimal_against_a_lower_bound() {
        // 40 × 5000: no brute force possible; check optimality by LP duality instead. Any
        // assignment costs at least Σ_r min_c cost(r, c) when each row's minimum lies in a
        // distinct column, which we arrange by construction.
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (n, m) = (40, 5000);
        let costs = CostMatrix::from_fn(n, m, |r, c| {
            if c == r * 100 {
                -1.0 - r as f64
            } else {
                rng.random_range(0.0..10.0)
            }
        })
        .unwrap();
        let a = solve(&costs);
        check_valid(&costs, &a);
        let expected: f64 = (0..n).map(|r| -1.0 - r as f64).sum();
        assert_eq!(a.cost, expected);
        assert!(a.pairs.iter().all(|&(r, c)| c == r * 100));
    }

    #[test]
    fn partial_matching_matches_brute_force() {
        // Enumerate every partial matching (each row: unassigned or an unused column).
        fn best(w: &CostMatrix, row: usize, used: &mut Vec<bool>) -> f64 {
            if row == w.rows() {
                return 0.0;
            }
            let mut b = best(w, row + 1, used);
            for c in 0..w.cols() {
                if !used[c] {
                    used[c] = true;
                    b = b.min(w.get(row, c) + best(w, row + 1, used));
                    used[c] = false;
                }
            }
            b
        }
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        for trial in 0..600 {
            let rows = rng.random_range(0..=5);
            let cols = rng.random_range(0..=5);
            let w = CostMatrix::from_fn(rows, cols, |_, _| {
                if trial % 2 == 0 {
                    f64::from(rng.random_range(-2i32..3))
                } else {
                    rng.random_range(-5.0..5.0)
                }
            })
            .unwrap();
            let pairs = solve_partial(&w);
            let value: f64 = pairs.iter().map(|&(r, c)| w.get(r, c)).sum();
            let oracle = best(&w, 0, &mut vec![false; cols]);
            assert!(
                (value - oracle).abs() < 1e-9,
                "trial {trial}: {value} vs {oracle}"
            );
            assert!(pairs.iter().all(|&(r, c)| w.get(r, c) < 0.0));
            let mut used: Vec<usize> = pairs.iter().map(|p| p.1).collect();
            used.sort_unstable();
            used.dedup();
            assert_eq!(used.len(), pairs.len());
        }
    }

    /// Brute force for the bottleneck: all partial injective maps of rows into columns using
    /// entries < limit; the best is (max pairs, then min largest entry).
    fn brute_force_bottleneck(costs: &CostMatrix, limit: f64) -> (usize, Option<f64>) {
        fn rec(
            costs: &CostMatrix,
            row: usize,
            used: &mut Vec<bool>,
            limit: f64,
            count: usize,
            worst: Option<f64>,
            best: &mut (usize, Option<f64>),
        ) {
            if row == costs.rows() {
                let better = count > best.0
                    || (count == best.0
                        && match (worst, best.1) {
                            (Some(w), Some(b)) => w < b,
                            _ => false,
                        });
                if better {
                    *best = (count, worst);
                }
                return;
            }
            rec(costs, row + 1, used, limit, count, worst, best);
            for c in 0..costs.cols() {
                let e = costs.get(row, c);
                if !used[c] && e < limit {
                    used[c] = true;
                    let w = Some(worst.map_or(e, |w: f64| w.max(e)));
                    rec(costs, row + 1, used, limit, count + 1, w, best);
                    used[c] = false;
                }
            }
        }
        let mut best = (0, None);
        rec(
            costs,
            0,
            &mut vec![false; costs.cols()],
            limit,
            0,
            None,
            &mut best,
        );
        best
    }

    #[test]
    fn bottleneck_matches_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for trial in 0..600 {
            let rows = rng.random_range(0..=5);
            let cols = rng.random_range(0..=5);
            let costs =
                CostMatrix::from_fn(rows, cols, |_, _| f64::from(rng.random_range(0i32..8)))
                    .unwrap();
            let limit = 5.0;
            let b = solve_bottleneck(&costs, limit);
            let (count, worst) = brute_force_bottleneck(&costs, limit);
            assert_eq!(b.pairs.len(), count, "trial {trial}");
            assert_eq!(b.bottleneck, worst, "trial {trial}");
            assert!(b.pairs.iter().all(|&(r, c)| costs.get(r, c) < limit));
            let mut cols_used: Vec<usize> = b.pairs.iter().map(|p| p.1).collect();
            cols_used.sort_unstable();
            cols_used.dedup();
            assert_eq!(cols_used.len(), b.pairs.len());
        }
    }
}
