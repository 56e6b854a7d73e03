//! The pieces the metrics use to split their assignment into independent parts: a uniform grid
//! of points for the pairs closer than the cut-off, and a union-find for the connected components
//! of the graph those pairs form.
//!
//! Both metrics reduce to a minimum-weight partial matching (or, for p = ∞, a bottleneck
//! matching) in which only pairs closer than the cut-off c can have a negative weight (be worth
//! taking). A pair never worth taking joins nothing, so the matching splits into one independent
//! problem per connected component of the graph of the pairs that are; each is solved exactly by
//! the dense solver of [`crate::assignment`] and the optima add up. A point with no such pair is
//! simply unassigned. The dense size limit ([`crate::assignment::MAX_CELLS`]) then applies to
//! each component, not to the whole input.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use crate::assignment::{solve_bottleneck, solve_partial, CostMatrix};
use crate::error::MetricError;
use crate::point::Point2;

/// Cells are this much wider than the cut-off, so two points closer than the cut-off lie in the
/// same or adjacent cells despite the rounding of their cell coordinates.
const CELL_MARGIN: f64 = 1.0 + 1e-3;

/// Past this many cells across an axis (coordinates far larger than the cut-off), the rounding of
/// a cell coordinate could exceed the margin; that axis is then not split at all (every point in
/// cell 0 along it), which is slower but still exact.
const MAX_CELLS_ACROSS: f64 = 1e12;

/// Most cells a box is entered into before it goes to the list checked against every query.
const MAX_CELLS_PER_BOX: i64 = 256;

/// Axis-aligned box, metres.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Box2 {
    pub min: Point2,
    pub max: Point2,
}

impl Box2 {
    pub fn of_point(p: Point2) -> Self {
        Self { min: p, max: p }
    }

    /// The bounding box of `points` (`None` when empty).
    pub fn of_points(points: &[Point2]) -> Option<Self> {
        let first = *points.first()?;
        Some(points.iter().fold(Self::of_point(first), |b, &p| b.grow(p)))
    }

    fn grow(self, p: Point2) -> Self {
        Self {
            min: Point2::new(self.min.x_m.min(p.x_m), self.min.y_m.min(p.y_m)),
            max: Point2::new(self.max.x_m.max(p.x_m), self.max.y_m.max(p.y_m)),
        }
    }

    fn union(self, other: Self) -> Self {
        self.grow(other.min).grow(other.max)
    }
}

/// A uniform grid of boxes (points are boxes of size 0): `near(q)` lists every box that may lie
/// closer than `radius` to the point q, each once (a superset: the caller measures the distance).
pub(crate) struct Grid {
    origin: Point2,
    cell: f64,
    split_x: bool,
    split_y: bool,
    /// Item ids per cell, as ranges of `items`.
    cells: Cells,
    items: Vec<u32>,
    /// Items whose box covers too many cells: checked for every query.
    everywhere: Vec<u32>,
    /// Stamp per item, so an item entered in several cells is listed once per query.
    seen: Vec<u32>,
    stamp: u32,
}

impl Grid {
    /// A grid of `boxes` for queries closer than `radius` > 0 (finite), queries lying within
    /// `query_bounds`.
    pub fn new(boxes: &[Box2], radius: f64, query_bounds: Option<Box2>) -> Self {
        let cell = radius * CELL_MARGIN;
        let bounds = boxes.iter().copied().reduce(Box2::union);
        let all = match (bounds, query_bounds) {
            (Some(a), Some(b)) => Some(a.union(b)),
            (a, b) => a.or(b),
        };
        let (origin, split_x, split_y) = match all {
            Some(b) => (
                b.min,
                (b.max.x_m - b.min.x_m) / cell <= MAX_CELLS_ACROSS,
                (b.max.y_m - b.min.y_m) / cell <= MAX_CELLS_ACROSS,
            ),
            None => (Point2::default(), true, true),
        };
        let mut grid = Self {
            origin,
            cell,
            split_x,
            split_y,
            cells: Cells::Map(FastMap::default()),
            items: Vec::new(),
            everywhere: Vec::new(),
            seen: vec![0; boxes.len()],
            stamp: 0,
        };
        // (cell, item) for every cell an item covers, sorted by cell.
        let mut entries: Vec<((i64, i64), u32)> = Vec::with_capacity(boxes.len());
        for (id, b) in boxes.iter().enumerate() {
            let (x0, y0) = grid.key(b.min);
            let (x1, y1) = grid.key(b.max);
            let across = (x1 - x0 + 1).saturating_mul(y1 - y0 + 1);
            if across > MAX_CELLS_PER_BOX {
                grid.everywhere.push(id as u32);
                continue;
            }
            for x in x0..=x1 {
                for y in y0..=y1 {
                    entries.push(((x, y), id as u32));
                }
            }
        }
        entries.sort_unstable();
        grid.items = entries.iter().map(|&(_, id)| id).collect();
        // A table of every cell of the occupied box when it is not much larger than the entries
        // (uniformly spread points), else a hash map of the occupied cells.
        let (x0, x1, y0, y1) = entries.iter().fold(
            (i64::MAX, i64::MIN, i64::MAX, i64::MIN),
            |(x0, x1, y0, y1), &((x, y), _)| (x0.min(x), x1.max(x), y0.min(y), y1.max(y)),
        );
        let span = |lo: i64, hi: i64| (hi as i128 - lo as i128 + 1).max(0) as u128;
        let table_cells = span(x0, x1) * span(y0, y1);
        if !entries.is_empty() && table_cells <= (4 * entries.len() as u128).max(4096) {
            let (nx, ny) = (span(x0, x1) as usize, span(y0, y1) as usize);
            let mut starts = vec![0u32; nx * ny + 1];
            for &((x, y), _) in &entries {
                starts[(x - x0) as usize * ny + (y - y0) as usize + 1] += 1;
            }
            for k in 1..starts.len() {
                starts[k] += starts[k - 1];
            }
            grid.cells = Cells::Table {
                x0,
                y0,
                nx,
                ny,
                starts,
            };
        } else {
            let mut map = FastMap::default();
            map.reserve(entries.len());
            let mut start = 0;
            while start < entries.len() {
                let key = entries[start].0;
                let mut end = start;
                while end < entries.len() && entries[end].0 == key {
                    end += 1;
                }
                map.insert(key, (start as u32, end as u32));
                start = end;
            }
            grid.cells = Cells::Map(map);
        }
        grid
    }

    fn key(&self, p: Point2) -> (i64, i64) {
        let along = |v: f64, o: f64, split: bool| {
            if split {
                // Saturating cast; coordinates are finite, the range was checked above.
                ((v - o) / self.cell).floor() as i64
            } else {
                0
            }
        };
        (
            along(p.x_m, self.origin.x_m, self.split_x),
            along(p.y_m, self.origin.y_m, self.split_y),
        )
    }

    /// Calls `visit(id)` once for each item that may lie closer than the radius to `q`.
    pub fn near(&mut self, q: Point2, mut visit: impl FnMut(usize)) {
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.seen.fill(0);
            self.stamp = 1;
        }
        let (kx, ky) = self.key(q);
        for dx in -1i64..=1 {
            let Some(x) = kx.checked_add(dx) else {
                continue;
            };
            for dy in -1i64..=1 {
                let Some(y) = ky.checked_add(dy) else {
                    continue;
                };
                if let Some((start, end)) = self.cells.get(x, y) {
                    for &id in &self.items[start as usize..end as usize] {
                        if self.seen[id as usize] != self.stamp {
                            self.seen[id as usize] = self.stamp;
                            visit(id as usize);
                        }
                    }
                }
            }
        }
        for &id in &self.everywhere {
            visit(id as usize);
        }
    }
}

/// The cells of a [`Grid`]: each occupied cell's range of items.
enum Cells {
    /// Every cell of the box [x0, x0 + nx) × [y0, y0 + ny): cell (x, y)'s items are
    /// `starts[k]..starts[k + 1]`, k = (x − x0) ny + (y − y0).
    Table {
        x0: i64,
        y0: i64,
        nx: usize,
        ny: usize,
        starts: Vec<u32>,
    },
    /// The occupied cells only.
    Map(FastMap),
}

impl Cells {
    fn get(&self, x: i64, y: i64) -> Option<(u32, u32)> {
        match self {
            Cells::Table {
                x0,
                y0,
                nx,
                ny,
                starts,
            } => {
                let (dx, dy) = (x.checked_sub(*x0)?, y.checked_sub(*y0)?);
                if dx < 0 || dy < 0 || dx as u64 >= *nx as u64 || dy as u64 >= *ny as u64 {
                    return None;
                }
                let k = dx as usize * ny + dy as usize;
                Some((starts[k], starts[k + 1]))
            }
            Cells::Map(map) => map.get(&(x, y)).copied(),
        }
    }
}

type FastMap = HashMap<(i64, i64), (u32, u32), BuildHasherDefault<CellHasher>>;

/// A multiply-rotate hash (as FxHash) for cell keys: the default SipHash costs more than the
/// distance tests it serves. Keys come from the input, but a collision only costs time.
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }

    fn write_i64(&mut self, v: i64) {
        self.write_u64(v as u64);
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// Union-find with path halving and union by size.
pub(crate) struct UnionFind {
    parent: Vec<u32>,
    size: Vec<u32>,
}

impl UnionFind {
    pub fn new(n: usize) -> Self {
        Self {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
        }
    }

    pub fn find(&mut self, mut x: usize) -> usize {
        while self.parent[x] as usize != x {
            let grand = self.parent[self.parent[x] as usize];
            self.parent[x] = grand;
            x = grand as usize;
        }
        x
    }

    pub fn union(&mut self, a: usize, b: usize) {
        let (mut a, mut b) = (self.find(a), self.find(b));
        if a == b {
            return;
        }
        if self.size[a] < self.size[b] {
            std::mem::swap(&mut a, &mut b);
        }
        self.parent[b] = a as u32;
        self.size[a] += self.size[b];
    }
}

/// The connected components of a bipartite graph on `left` + `right` vertices, built edge by edge
/// ([`Components::link`]) without storing the edges.
pub(crate) struct Components {
    left: usize,
    uf: UnionFind,
    has_edge: Vec<bool>,
}

impl Components {
    pub fn new(left: usize, right: usize) -> Self {
        Self {
            left,
            uf: UnionFind::new(left + right),
            has_edge: vec![false; left + right],
        }
    }

    /// Adds the edge (l, r).
    pub fn link(&mut self, l: usize, r: usize) {
        self.has_edge[l] = true;
        self.has_edge[self.left + r] = true;
        self.uf.union(l, self.left + r);
    }

    /// Per component, its left vertices and its right vertices, each sorted; components ordered
    /// by their smallest vertex (left first). Vertices without an edge are in none.
    pub fn finish(mut self) -> Vec<(Vec<usize>, Vec<usize>)> {
        let left = self.left;
        let mut part_of_root: Vec<u32> = vec![u32::MAX; self.has_edge.len()];
        let mut parts: Vec<(Vec<usize>, Vec<usize>)> = Vec::new();
        for v in 0..self.has_edge.len() {
            if !self.has_edge[v] {
                continue;
            }
            let root = self.uf.find(v);
            if part_of_root[root] == u32::MAX {
                part_of_root[root] = parts.len() as u32;
                parts.push((Vec::new(), Vec::new()));
            }
            let k = part_of_root[root] as usize;
            if v < left {
                parts[k].0.push(v);
            } else {
                parts[k].1.push(v - left);
            }
        }
        parts
    }
}

/// Solves each component of `graph` (truth, estimates) exactly by the pairs' `key` (bottleneck
/// cost for p = ∞, else weight), truth point or target i offering `slots(i)` slots (GOSPA: one).
/// `sizes` (slots, estimates) of the whole problem name it in a size error.
pub(crate) fn solve_components(
    graph: Components,
    slots: impl Fn(usize) -> usize,
    key: impl Fn(usize, usize) -> f64,
    infinite: bool,
    c: f64,
    sizes: (usize, usize),
) -> Result<Solved, MetricError> {
    let mut pairs: Vec<(usize, usize)> = Vec::new();
    let mut bottleneck: Option<f64> = None;
    for (tgts, cols) in graph.finish() {
        if cols.len() == 1 || (tgts.len() == 1 && slots(tgts[0]) == 1) {
            // A star (one estimate, or one target with one slot; every pair usable): one pair
            // at most, the cheapest.
            let (mut best, mut best_key) = ((tgts[0], cols[0]), f64::INFINITY);
            for &i in &tgts {
                for &j in &cols {
                    let k = key(i, j);
                    if k < best_key {
                        (best, best_key) = ((i, j), k);
                    }
                }
            }
            pairs.push(best);
            if infinite {
                bottleneck = Some(bottleneck.map_or(best_key, |b| b.max(best_key)));
            }
            continue;
        }
        // One row per slot; a target never fills more slots than the component has estimates.
        let slot_target: Vec<usize> = tgts
            .iter()
            .flat_map(|&i| std::iter::repeat_n(i, slots(i).min(cols.len())))
            .collect();
        let matrix = CostMatrix::from_fn(slot_target.len(), cols.len(), |r, k| {
            key(slot_target[r], cols[k])
        })
        .map_err(|e| MetricError::in_component(e, sizes.0, sizes.1))?;
        let component_pairs = if infinite {
            let matching = solve_bottleneck(&matrix, c);
            if let Some(d) = matching.bottleneck {
                bottleneck = Some(bottleneck.map_or(d, |b| b.max(d)));
            }
            matching.pairs
        } else {
            solve_partial(&matrix)
        };
        pairs.extend(
            component_pairs
                .into_iter()
                .map(|(r, k)| (slot_target[r], cols[k])),
        );
    }
    Ok(Solved { pairs, bottleneck })
}

/// The components' solutions together.
pub(crate) struct Solved {
    /// (target, estimate) pairs, unsorted.
    pub(crate) pairs: Vec<(usize, usize)>,
    /// For p = ∞, the largest pair cost (`None` without a pair).
    pub(crate) bottleneck: Option<f64>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_finds_every_point_closer_than_the_radius() {
        // 100 m wide: a table of cells; 10 km wide: a map of the occupied cells.
        for scale in [1.0, 100.0] {
            grid_finds_every_point_within(scale);
        }
    }

    fn grid_finds_every_point_within(scale: f64) {
        let mut state = 12345u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            ((state % 10_000) as f64 / 100.0 - 50.0) * scale
        };
        let points: Vec<Point2> = (0..400).map(|_| Point2::new(next(), next())).collect();
        let queries: Vec<Point2> = (0..200).map(|_| Point2::new(next(), next())).collect();
        let radius = 3.0;
        let boxes: Vec<Box2> = points.iter().map(|&p| Box2::of_point(p)).collect();
        let mut grid = Grid::new(&boxes, radius, Box2::of_points(&queries));
        assert_eq!(matches!(grid.cells, Cells::Table { .. }), scale == 1.0);
        for q in &queries {
            let mut found = Vec::new();
            grid.near(*q, |id| found.push(id));
            let mut unique = found.clone();
            unique.sort_unstable();
            unique.dedup();
            assert_eq!(unique.len(), found.len());
            for (id, p) in points.iter().enumerate() {
                if p.distance_m(q) < radius {
                    assert!(found.contains(&id));
                }
            }
        }
    }

    #[test]
    fn huge_coordinates_fall_back_to_one_cell_per_axis() {
        let points = [Point2::new(1e300, 0.0), Point2::new(-1e300, 0.0)];
        let boxes: Vec<Box2> = points.iter().map(|&p| Box2::of_point(p)).collect();
        let mut grid = Grid::new(&boxes, 1.0, None);
        let mut found = Vec::new();
        grid.near(Point2::new(1e300, 0.5), |id| found.push(id));
        assert!(found.contains(&0));
    }

    #[test]
    fn components_of_a_small_graph() {
        let mut graph = Components::new(4, 3);
        for (l, r) in [(0, 1), (2, 1), (3, 2)] {
            graph.link(l, r);
        }
        let parts = graph.finish();
        assert_eq!(parts, vec![(vec![0, 2], vec![1]), (vec![3], vec![2])]);
    }
}
