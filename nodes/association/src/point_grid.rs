//! The keyframe maps as the per-frame association statistics read them: map points hashed into
//! square cells as wide as the association gate, so that the nearest point within the gate is
//! found exactly in the 3 × 3 cells around a query, and a keyframe's points are added in O(1)
//! each. [`crate::icp::PointMap`]'s k-d tree answers the same question but is rebuilt whole on
//! every keyframe; for statistics alone that rebuild was about a tenth of a hall run's CPU time.
//!
//! A query scans its own cell first and a neighbouring cell only if that cell's nearest edge is
//! nearer than the best point so far and the gate; the cells are hashed by a multiplicative
//! hash ([`CellHasher`]) instead of the standard library's SipHash. The answer is the same
//! minimum either way.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use crate::icp::squared_distance_m2;

/// `x.floor() as i64` for every `x` (NaN gives 0, beyond the range saturates), without the library
/// call `floor` is on x86-64 without SSE4.1: truncation, one less for a negative non-integer.
/// Branch-free: map coordinates change sign at random.
#[inline]
pub(crate) fn floor_i64(x: f64) -> i64 {
    let whole = x as i64;
    whole.saturating_sub(i64::from((whole as f64) > x))
}

/// A hasher for integer cell keys: each written word is mixed in by a rotate, xor and
/// multiply (the Fx hash of rustc). Keys here are not chosen by an adversary, so SipHash's
/// protection buys nothing and costs a third of a lookup.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct CellHasher(u64);

impl Hasher for CellHasher {
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    fn write_u64(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn write_i64(&mut self, word: i64) {
        self.write_u64(word as u64);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// A hash map keyed by cells, with [`CellHasher`].
pub(crate) type CellMap<V> = HashMap<(i64, i64), V, BuildHasherDefault<CellHasher>>;

/// Map points (map frame, metres) in square cells of the gate's width.
#[derive(Debug, Clone)]
pub struct PointGrid {
    gate_m: f64,
    cells: CellMap<Vec<[f64; 2]>>,
    len: usize,
}

impl PointGrid {
    /// An empty grid for a gate of `gate_m` metres (a non-positive or non-finite gate finds
    /// nothing).
    pub fn new(gate_m: f64) -> Self {
        PointGrid {
            gate_m,
            cells: CellMap::default(),
            len: 0,
        }
    }

    fn usable_gate(&self) -> bool {
        self.gate_m.is_finite() && self.gate_m > 0.0
    }

    /// The cell of a finite point (coordinates beyond ±2⁶³ cells saturate, which merges far
    /// cells but never loses a point).
    fn cell_of(&self, point_m: &[f64; 2]) -> (i64, i64) {
        (
            floor_i64(point_m[0] / self.gate_m),
            floor_i64(point_m[1] / self.gate_m),
        )
    }

    /// Adds `points_m`; non-finite points are skipped, as [`crate::icp::PointMap`] skips them.
    pub fn extend(&mut self, points_m: &[[f64; 2]]) {
        for point in points_m
            .iter()
            .filter(|p| p[0].is_finite() && p[1].is_finite())
        {
            self.len += 1;
            if self.usable_gate() {
                let cell = self.cell_of(point);
                self.cells.entry(cell).or_default().push(*point);
            }
        }
    }

    /// Takes out points added before (map frame, metres), each once, so that the grid answers
    /// as if they had never been added: the back end drops the keyframes that leave its local
    /// window this way instead of rebuilding the grid. A point that is not in the grid is
    /// skipped; with an unusable gate (which stores no point) every finite point counts as
    /// taken out.
    pub fn retract(&mut self, points_m: &[[f64; 2]]) {
        for point in points_m
            .iter()
            .filter(|p| p[0].is_finite() && p[1].is_finite())
        {
            if !self.usable_gate() {
                self.len = self.len.saturating_sub(1);
                continue;
            }
            let cell = self.cell_of(point);
            let Some(points) = self.cells.get_mut(&cell) else {
                continue;
            };
            if let Some(i) = points.iter().position(|p| p == point) {
                // Order within a cell does not matter: the nearest distance is a minimum.
                points.swap_remove(i);
                self.len -= 1;
                if points.is_empty() {
                    self.cells.remove(&cell);
                }
            }
        }
    }

    /// The squared distance (m²) from `query_m` to the nearest map point, if one lies within
    /// the gate.
    pub fn nearest_within_gate_m2(&self, query_m: &[f64; 2]) -> Option<f64> {
        if !(self.usable_gate() && query_m[0].is_finite() && query_m[1].is_finite()) {
            return None;
        }
        let (cx, cy) = self.cell_of(query_m);
        let gate2 = self.gate_m * self.gate_m;
        let nearest_in = |cell: (i64, i64), best: f64| {
            self.cells
                .get(&cell)
                .into_iter()
                .flatten()
                .fold(best, |best, p| {
                    let d2 = squared_distance_m2(query_m, p);
                    if d2 < best {
                        d2
                    } else {
                        best
                    }
                })
        };
        // Own cell first: its best point bounds which neighbours can hold a nearer one.
        let mut best = nearest_in((cx, cy), f64::INFINITY);
        // The query's distances to its cell's edges (left, right; below, above), less a slack
        // far beyond the rounding of a point's cell, so that a neighbour is skipped only when
        // none of its points can be nearer than `best` or within the gate. Far from the origin
        // (where the cell indices saturate) no neighbour is skipped.
        let prune = query_m[0].abs() < 1e12 && query_m[1].abs() < 1e12;
        let slack_m = 1e-6 * self.gate_m + 1e-12 * (query_m[0].abs() + query_m[1].abs());
        let edge = |offset: i64, q: f64, c: i64| -> f64 {
            let gap_m = match offset {
                -1 => q - c as f64 * self.gate_m,
                1 => (c + 1) as f64 * self.gate_m - q,
                _ => return 0.0,
            };
            (gap_m - slack_m).max(0.0)
        };
        for dx in -1..=1i64 {
            for dy in -1..=1i64 {
                if dx == 0 && dy == 0 {
                    continue;
                }
                if prune {
                    let (gx, gy) = (edge(dx, query_m[0], cx), edge(dy, query_m[1], cy));
                    if gx * gx + gy * gy > best.min(gate2) {
                        continue;
                    }
                }
                best = nearest_in((cx.saturating_add(dx), cy.saturating_add(dy)), best);
            }
        }
        (best <= gate2).then_some(best)
    }

    /// Whether some map point lies within the gate of `query_m`:
    /// `nearest_within_gate_m2(query_m).is_some()`, stopping at the first such point.
    pub fn any_within_gate(&self, query_m: &[f64; 2]) -> bool {
        if !(self.usable_gate() && query_m[0].is_finite() && query_m[1].is_finite()) {
            return false;
        }
        let (cx, cy) = self.cell_of(query_m);
        let gate2 = self.gate_m * self.gate_m;
        // The own cell first: the likeliest to hold one.
        [
            (0, 0),
            (-1, 0),
            (1, 0),
            (0, -1),
            (0, 1),
            (-1, -1),
            (1, -1),
            (-1, 1),
            (1, 1),
        ]
        .iter()
        .any(|&(dx, dy): &(i64, i64)| {
            let cell = (cx.saturating_add(dx), cy.saturating_add(dy));
            self.cells.get(&cell).is_some_and(|points| {
                points
                    .iter()
                    .any(|p| squared_distance_m2(query_m, p) <= gate2)
            })
        })
    }

    /// Number of (finite) points held: added and not retracted.
    pub fn len(&self) -> usize {
        self.len
    }

    /// No point held.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::icp::PointMap;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn finds_what_the_k_d_tree_finds_within_the_gate(
            points in prop::collection::vec((-20.0f64..20.0, -20.0f64..20.0), 0..200),
            queries in prop::collection::vec((-25.0f64..25.0, -25.0f64..25.0), 1..50),
            gate_m in 0.05f64..3.0,
        ) {
            let points: Vec<[f64; 2]> = points.into_iter().map(|(x, y)| [x, y]).collect();
            let mut grid = PointGrid::new(gate_m);
            grid.extend(&points);
            let mut tree = PointMap::new();
            tree.extend(&points);
            prop_assert_eq!(grid.len(), tree.len());
            for (x, y) in queries {
                let reference = tree
                    .nearest(&[x, y])
                    .map(|(_, d2)| d2)
                    .filter(|&d2| d2 <= gate_m * gate_m);
                let found = grid.nearest_within_gate_m2(&[x, y]);
                prop_assert_eq!(found.is_some(), reference.is_some());
                prop_assert_eq!(grid.any_within_gate(&[x, y]), found.is_some());
                if let (Some(a), Some(b)) = (found, reference) {
                    prop_assert!((a - b).abs() <= 1e-12 * (1.0 + b), "{a} against {b}");
                }
            }
        }
    }

    proptest! {
        #[test]
        fn retracted_points_are_as_if_never_added(
            kept in prop::collection::vec((-20.0f64..20.0, -20.0f64..20.0), 0..150),
            dropped in prop::collection::vec((-20.0f64..20.0, -20.0f64..20.0), 0..150),
            queries in prop::collection::vec((-25.0f64..25.0, -25.0f64..25.0), 1..50),
            gate_m in 0.05f64..3.0,
        ) {
            let kept: Vec<[f64; 2]> = kept.into_iter().map(|(x, y)| [x, y]).collect();
            let dropped: Vec<[f64; 2]> = dropped.into_iter().map(|(x, y)| [x, y]).collect();
            let mut grid = PointGrid::new(gate_m);
            grid.extend(&dropped);
            grid.extend(&kept);
            // A point added twice and retracted once stays once.
            grid.extend(&kept[..kept.len().min(3)]);
            grid.retract(&kept[..kept.len().min(3)]);
            grid.retract(&dropped);
            let mut reference = PointGrid::new(gate_m);
            reference.extend(&kept);
            prop_assert_eq!(grid.len(), reference.len());
            for (x, y) in queries {
                prop_assert_eq!(
                    grid.nearest_within_gate_m2(&[x, y]),
                    reference.nearest_within_gate_m2(&[x, y])
                );
            }
        }
    }

    proptest! {
        #[test]
        fn floor_i64_is_floor(bits in any::<u64>(), x in -1e6f64..1e6) {
            for x in [f64::from_bits(bits), x, x.round(), x.round() + 0.5] {
                prop_assert_eq!(floor_i64(x), x.floor() as i64, "{}", x);
            }
        }
    }

    #[test]
    fn floor_i64_at_the_ends() {
        for x in [
            0.0,
            -0.0,
            -0.5,
            0.5,
            -1.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            // Either side of ±2⁶³, where the cast saturates.
            f64::from_bits(0x43df_ffff_ffff_ffff),
            9_223_372_036_854_775_808.0,
            -9_223_372_036_854_775_808.0,
            f64::from_bits(0xc3e0_0000_0000_0001),
            4_503_599_627_370_495.5,
            -4_503_599_627_370_495.5,
        ] {
            assert_eq!(floor_i64(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn retracting_what_is_not_there_changes_nothing() {
        let mut grid = PointGrid::new(0.5);
        grid.extend(&[[1.0, 1.0], [2.0, 2.0]]);
        grid.retract(&[[1.0, 1.01], [9.0, 9.0], [f64::NAN, 1.0]]);
        assert_eq!(grid.len(), 2);
        assert_eq!(grid.nearest_within_gate_m2(&[1.0, 1.0]), Some(0.0));
        grid.retract(&[[1.0, 1.0]]);
        assert_eq!(grid.len(), 1);
        assert_eq!(grid.nearest_within_gate_m2(&[1.0, 1.0]), None);
    }

    #[test]
    fn coincident_non_finite_and_far_points_are_handled() {
        let mut grid = PointGrid::new(0.5);
        grid.extend(&[[1.0, 1.0]; 1000]);
        grid.extend(&[[f64::NAN, 0.0], [0.0, f64::INFINITY], [1e300, -1e300]]);
        assert_eq!(grid.len(), 1001);
        assert_eq!(
            grid.nearest_within_gate_m2(&[1.0, 1.3]),
            Some(0.09000000000000002)
        );
        assert_eq!(grid.nearest_within_gate_m2(&[1.0, 1.6]), None);
        assert_eq!(grid.nearest_within_gate_m2(&[f64::NAN, 1.0]), None);
        assert_eq!(
            PointGrid::new(0.0).nearest_within_gate_m2(&[1.0, 1.0]),
            None
        );
    }
}
