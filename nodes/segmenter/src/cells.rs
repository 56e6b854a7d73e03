//! A uniform grid of square cells over planar points: DBSCAN's ε-neighbourhood queries in 2-D.
//!
//! Cells are at least ε wide, so every point within ε of a point lies in its cell or one of the
//! eight around it; a query scans those nine cells and keeps the points at squared distance
//! `≤ ε²` (the same test as the brute-force oracle). Points are stored cell by cell, so a query
//! reads a few contiguous runs of memory instead of walking a tree, and the cell adjacency is
//! found once, at construction.
//!
//! The cell coordinate of a point is `floor((x − x_min) / side)`. Its rounding error is bounded by
//! keeping at most 2³⁰ cells along an axis (the side grows for very spread or very fine inputs) and
//! making the side 0.1 % wider than ε: two points within ε then never land two cells apart. When
//! the points' extent overflows to infinity, every point goes into one cell and the query is the
//! brute-force scan, still exact.

use std::collections::HashMap;

/// Widening of the cell side over ε, so rounding in the cell coordinates never separates two
/// neighbours by more than one cell.
const SIDE_MARGIN: f64 = 1.001;

/// At most this many cells along an axis: keeps the cell coordinates far from f64's precision
/// limit (error below 2⁻²² cell) and inside u32.
const MAX_CELLS_PER_AXIS: f64 = (1u64 << 30) as f64;

/// Points grouped by cell, with each occupied cell's occupied neighbours.
pub(crate) struct CellIndex {
    /// Point indices (into the caller's slice), cell by cell.
    order: Vec<u32>,
    /// `points[order[k]]`, so that a cell's coordinates are contiguous.
    sorted: Vec<[f64; 2]>,
    /// Per cell c, its points are `order[cell_start[c]..cell_start[c + 1]]`.
    cell_start: Vec<u32>,
    /// Cell of each point, by the caller's index.
    cell_of: Vec<u32>,
    /// Position of each point in `order`, by the caller's index.
    rank: Vec<u32>,
    /// Per cell c, its occupied neighbour cells (itself included) are
    /// `neighbours[neighbour_start[c]..neighbour_start[c + 1]]`.
    neighbour_start: Vec<u32>,
    neighbours: Vec<u32>,
    eps_sq: f64,
}

impl CellIndex {
    /// Indexes `points` (finite, fewer than 2³² − 1) for queries of radius `eps_m ≥ 0`.
    pub(crate) fn new(points: &[[f64; 2]], eps_m: f64) -> Self {
        let keys = cell_keys(points, eps_m);
        // Sorting (key, index) pairs directly is several times faster than sorting indices by a
        // looked-up key; the index breaks ties, so the order is the same either way. When both
        // cell coordinates fit in 16 bits (a map up to 65,536 ε wide), key and index are packed
        // into one u64, whose order is the pairs' order, and sorted a third faster still.
        let order: Vec<u32> = if keys.iter().all(|&(kx, ky)| kx <= 0xffff && ky <= 0xffff) {
            let mut packed: Vec<u64> = keys
                .iter()
                .enumerate()
                .map(|(i, &(kx, ky))| {
                    (u64::from(kx) << 48) | (u64::from(ky) << 32) | u64::from(i as u32)
                })
                .collect();
            packed.sort_unstable();
            packed.iter().map(|&k| k as u32).collect()
        } else {
            let mut pairs: Vec<(u64, u32)> = keys
                .iter()
                .enumerate()
                .map(|(i, &(kx, ky))| ((u64::from(kx) << 32) | u64::from(ky), i as u32))
                .collect();
            pairs.sort_unstable();
            pairs.iter().map(|&(_, i)| i).collect()
        };

        let mut cell_start = Vec::new();
        let mut cell_keys_sorted = Vec::new();
        let mut cell_of = vec![0u32; points.len()];
        let mut rank = vec![0u32; points.len()];
        for (k, &i) in order.iter().enumerate() {
            rank[i as usize] = k as u32;
            let key = keys[i as usize];
            if cell_keys_sorted.last() != Some(&key) {
                cell_keys_sorted.push(key);
                cell_start.push(k as u32);
            }
            cell_of[i as usize] = (cell_keys_sorted.len() - 1) as u32;
        }
        cell_start.push(order.len() as u32);

        let number = CellNumbers::new(&cell_keys_sorted, points.len());
        let mut neighbour_start = Vec::with_capacity(cell_keys_sorted.len() + 1);
        let mut neighbours = Vec::new();
        // The cell itself first: counting a dense point's neighbours then usually stops there.
        const AROUND: [(i64, i64); 9] = [
            (0, 0),
            (-1, -1),
            (0, -1),
            (1, -1),
            (-1, 0),
            (1, 0),
            (-1, 1),
            (0, 1),
            (1, 1),
        ];
        for &(kx, ky) in &cell_keys_sorted {
            neighbour_start.push(neighbours.len() as u32);
            for (dx, dy) in AROUND {
                let (Ok(x), Ok(y)) = (
                    u32::try_from(i64::from(kx) + dx),
                    u32::try_from(i64::from(ky) + dy),
                ) else {
                    continue;
                };
                if let Some(c) = number.get(x, y) {
                    neighbours.push(c);
                }
            }
        }
        neighbour_start.push(neighbours.len() as u32);

        let sorted = order.iter().map(|&i| points[i as usize]).collect();
        Self {
            order,
            sorted,
            cell_start,
            cell_of,
            rank,
            neighbour_start,
            neighbours,
            eps_sq: eps_m * eps_m,
        }
    }

    /// Calls `visit(j)` for every point j within ε of point `i` (i itself included), in no
    /// particular order, until `visit` returns false.
    pub(crate) fn for_each_neighbour(&self, i: usize, mut visit: impl FnMut(usize) -> bool) {
        let centre = self.sorted[self.rank[i] as usize];
        let cell = self.cell_of[i] as usize;
        let cells = &self.neighbours
            [self.neighbour_start[cell] as usize..self.neighbour_start[cell + 1] as usize];
        for &c in cells {
            let range =
                self.cell_start[c as usize] as usize..self.cell_start[c as usize + 1] as usize;
            for (point, &j) in self.sorted[range.clone()].iter().zip(&self.order[range]) {
                if squared_distance(centre, *point) <= self.eps_sq && !visit(j as usize) {
                    return;
                }
            }
        }
    }

    /// Number of points within ε of point `i` (itself included), counting no further than `limit`.
    pub(crate) fn count_neighbours_up_to(&self, i: usize, limit: usize) -> usize {
        let mut count = 0;
        self.for_each_neighbour(i, |_| {
            count += 1;
            count < limit
        });
        count
    }
}

impl CellIndex {
    /// Whether each point is core (at least `min_samples` points within ε, itself included), by
    /// the caller's index. Points are visited cell by cell, so their neighbourhoods stay in cache.
    pub(crate) fn core_points(&self, min_samples: usize) -> Vec<bool> {
        let mut is_core = vec![false; self.order.len()];
        for &i in &self.order {
            is_core[i as usize] =
                self.count_neighbours_up_to(i as usize, min_samples) >= min_samples;
        }
        is_core
    }

    /// DBSCAN's expansion: clusters numbered in the order of their first core point by the
    /// caller's index, each taking every point density-reachable from it that no earlier cluster
    /// took. Returns (label of each point by the caller's index, `unassigned` for noise; number of
    /// clusters).
    ///
    /// Which points a cluster takes does not depend on the order it reaches them, so the search
    /// works in the index's own order (contiguous memory) and skips a neighbour cell once every
    /// point of it has a label: in a dense cluster most cells fill early and most of a core
    /// point's neighbourhood is never looked at again.
    pub(crate) fn expand_clusters(&self, is_core: &[bool], unassigned: i32) -> (Vec<i32>, usize) {
        let n = self.order.len();
        let core_by_rank: Vec<bool> = self.order.iter().map(|&i| is_core[i as usize]).collect();
        let cell_by_rank: Vec<u32> = self
            .order
            .iter()
            .map(|&i| self.cell_of[i as usize])
            .collect();
        let mut unlabelled: Vec<u32> = self.cell_start.windows(2).map(|w| w[1] - w[0]).collect();
        let mut label_by_rank = vec![unassigned; n];
        let mut frontier: Vec<usize> = Vec::new();
        let mut cluster = 0i32;
        for seed in 0..n {
            let seed = self.rank[seed] as usize;
            if label_by_rank[seed] != unassigned || !core_by_rank[seed] {
                continue;
            }
            label_by_rank[seed] = cluster;
            unlabelled[cell_by_rank[seed] as usize] -= 1;
            frontier.push(seed);
            while let Some(core) = frontier.pop() {
                let centre = self.sorted[core];
                let cell = cell_by_rank[core] as usize;
                let around =
                    self.neighbour_start[cell] as usize..self.neighbour_start[cell + 1] as usize;
                for &c in &self.neighbours[around] {
                    let c = c as usize;
                    if unlabelled[c] == 0 {
                        continue;
                    }
                    for k in self.cell_start[c] as usize..self.cell_start[c + 1] as usize {
                        if label_by_rank[k] == unassigned
                            && squared_distance(centre, self.sorted[k]) <= self.eps_sq
                        {
                            label_by_rank[k] = cluster;
                            unlabelled[c] -= 1;
                            if core_by_rank[k] {
                                frontier.push(k);
                            }
                        }
                    }
                }
            }
            cluster += 1;
        }
        let labels = self
            .rank
            .iter()
            .map(|&r| label_by_rank[r as usize])
            .collect();
        (labels, cluster as usize)
    }
}

/// The number of each occupied cell by its (column, row): a dense table when the occupied cells'
/// bounding box is at most a few times the point count (the common case), else a hash map.
enum CellNumbers {
    Dense {
        columns: u64,
        rows: u64,
        /// Row-major, `u32::MAX` for an empty cell.
        table: Vec<u32>,
    },
    Sparse(HashMap<(u32, u32), u32>),
}

impl CellNumbers {
    fn new(keys: &[(u32, u32)], points: usize) -> Self {
        let columns = keys.iter().map(|k| u64::from(k.0) + 1).max().unwrap_or(0);
        let rows = keys.iter().map(|k| u64::from(k.1) + 1).max().unwrap_or(0);
        if columns.saturating_mul(rows) <= 4 * points as u64 + 1024 {
            let mut table = vec![u32::MAX; (columns * rows) as usize];
            for (c, &(x, y)) in keys.iter().enumerate() {
                table[(u64::from(y) * columns + u64::from(x)) as usize] = c as u32;
            }
            CellNumbers::Dense {
                columns,
                rows,
                table,
            }
        } else {
            CellNumbers::Sparse(
                keys.iter()
                    .enumerate()
                    .map(|(c, &key)| (key, c as u32))
                    .collect(),
            )
        }
    }

    fn get(&self, x: u32, y: u32) -> Option<u32> {
        match self {
            CellNumbers::Dense {
                columns,
                rows,
                table,
            } => {
                let (x, y) = (u64::from(x), u64::from(y));
                if x >= *columns || y >= *rows {
                    return None;
                }
                let c = table[(y * columns + x) as usize];
                (c != u32::MAX).then_some(c)
            }
            CellNumbers::Sparse(map) => map.get(&(x, y)).copied(),
        }
    }
}

/// `dx*dx + dy*dy`: the distance test of the module docs.
pub(crate) fn squared_distance(a: [f64; 2], b: [f64; 2]) -> f64 {
    let dx = a[0] - b[0];
    let dy = a[1] - b[1];
    dx * dx + dy * dy
}

/// (column, row) of each point's cell.
fn cell_keys(points: &[[f64; 2]], eps_m: f64) -> Vec<(u32, u32)> {
    let (mut low, mut high) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in points {
        for axis in 0..2 {
            low[axis] = low[axis].min(p[axis]);
            high[axis] = high[axis].max(p[axis]);
        }
    }
    let extent = (high[0] - low[0]).max(high[1] - low[1]);
    let side = (eps_m * SIDE_MARGIN).max(extent / MAX_CELLS_PER_AXIS);
    if points.is_empty() || !side.is_finite() || side <= 0.0 {
        // No points, an extent that overflowed (one cell: the brute-force scan), or all points
        // identical with ε = 0 (one cell holds them all).
        return vec![(0, 0); points.len()];
    }
    // value ≥ low, so the quotient is ≥ 0 and truncation is its floor (a library call without
    // SSE4.1); the cast saturates as floor's would.
    let coordinate = |value: f64, axis: usize| ((value - low[axis]) / side) as u32;
    points
        .iter()
        .map(|p| (coordinate(p[0], 0), coordinate(p[1], 1)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn neighbours(index: &CellIndex, i: usize) -> Vec<usize> {
        let mut found = Vec::new();
        index.for_each_neighbour(i, |j| {
            found.push(j);
            true
        });
        found.sort_unstable();
        found
    }

    fn brute(points: &[[f64; 2]], i: usize, eps_m: f64) -> Vec<usize> {
        (0..points.len())
            .filter(|&j| squared_distance(points[i], points[j]) <= eps_m * eps_m)
            .collect()
    }

    #[test]
    fn a_spread_wider_than_the_cell_budget_widens_the_cells_and_stays_exact() {
        // Extent 1e12 m with ε = 1 mm: 2³⁰ cells of 1 mm cannot span it, so cells are ~931 m.
        let points = [
            [0.0, 0.0],
            [0.0009, 0.0],
            [1e12, 5.0],
            [1e12 - 0.001, 5.0],
            [500.0, 0.0],
        ];
        let index = CellIndex::new(&points, 0.001);
        for i in 0..points.len() {
            assert_eq!(neighbours(&index, i), brute(&points, i, 0.001), "point {i}");
        }
    }

    #[test]
    fn neighbours_exactly_eps_apart_across_a_cell_edge_are_found() {
        // Spacing exactly ε on a line: each point's neighbours are the points either side.
        let points: Vec<[f64; 2]> = (0..50).map(|k| [f64::from(k) * 0.5 - 7.0, 3.0]).collect();
        let index = CellIndex::new(&points, 0.5);
        for i in 0..points.len() {
            assert_eq!(neighbours(&index, i), brute(&points, i, 0.5), "point {i}");
        }
    }

    #[test]
    fn counting_stops_at_the_limit() {
        let points = vec![[1.0, 1.0]; 10];
        let index = CellIndex::new(&points, 0.0);
        assert_eq!(index.count_neighbours_up_to(3, 4), 4);
        assert_eq!(index.count_neighbours_up_to(3, 100), 10);
    }
}
