//! The cells a beam crosses: segment clipping and grid traversal.
//!
//! Free space is the part of a beam between the sensor and its hit (paper Sec. III-A, "Location &
//! mapping": the map is an OGM, and an OGM learns "free" from the beams that cross a cell). The
//! traversal here is Amanatides and Woo's (1987) voxel walk in 2-D: it visits every cell the
//! continuous segment passes through, in order, unlike Bresenham's line which visits one cell per
//! column (or row) and so skips cells the beam clips at a corner. OctoMap's `computeRayKeys` makes
//! the same choice.
//!
//! Coordinates here are in *cell units*: the grid's corner is (0, 0) and cell (i, j) covers
//! `[i, i+1) × [j, j+1)`.

/// Clips the segment `start → end` (cell units) to the box `[0, width] × [0, height]`
/// (Liang–Barsky). Returns the parameters `(t0, t1)`, `0 ≤ t0 ≤ t1 ≤ 1`, of the part inside, or
/// `None` if the segment misses the box.
pub(crate) fn clip_to_box(
    start: [f64; 2],
    end: [f64; 2],
    width: f64,
    height: f64,
) -> Option<(f64, f64)> {
    let delta = [end[0] - start[0], end[1] - start[1]];
    let mut t0: f64 = 0.0;
    let mut t1: f64 = 1.0;
    for axis in 0..2 {
        let size = if axis == 0 { width } else { height };
        // Each axis bounds t by the two slab planes 0 and size.
        for (p, q) in [
            (-delta[axis], start[axis]),
            (delta[axis], size - start[axis]),
        ] {
            if p == 0.0 {
                // Parallel to this slab: inside it or not at all.
                if q < 0.0 {
                    return None;
                }
            } else {
                let t = q / p;
                if p < 0.0 {
                    t0 = t0.max(t);
                } else {
                    t1 = t1.min(t);
                }
            }
        }
    }
    (t0 <= t1).then_some((t0, t1))
}

/// Calls `visit(i, j)` for each cell the segment from `start` to `end` (cell units) passes
/// through, in order from `start`'s cell, stopping *before* `end`'s cell (which is not visited).
///
/// Both cells are given as integer indices (`start_cell`, `end_cell`) computed by the caller, so
/// that the walk ends exactly in `end_cell` whatever the rounding of the crossing parameters: it
/// takes exactly `|Δi| + |Δj|` steps and never steps further along an axis whose target index is
/// reached. The cells are not clamped to the grid; the caller clips the segment first.
pub(crate) fn walk_cells(
    start: [f64; 2],
    end: [f64; 2],
    start_cell: [i64; 2],
    end_cell: [i64; 2],
    mut visit: impl FnMut(i64, i64),
) {
    let delta = [end[0] - start[0], end[1] - start[1]];
    let mut step = [0i64; 2];
    // Parameter t (0 at start, 1 at end) at which the beam crosses the next cell boundary on each
    // axis, and the t needed to cross one whole cell.
    let mut t_next = [f64::INFINITY; 2];
    let mut t_delta = [f64::INFINITY; 2];
    for axis in 0..2 {
        step[axis] = (end_cell[axis] - start_cell[axis]).signum();
        if step[axis] != 0 && delta[axis] != 0.0 {
            let boundary = if step[axis] > 0 {
                (start_cell[axis] + 1) as f64
            } else {
                start_cell[axis] as f64
            };
            t_next[axis] = (boundary - start[axis]) / delta[axis];
            t_delta[axis] = 1.0 / delta[axis].abs();
        }
    }
    let steps = (end_cell[0] - start_cell[0]).abs() + (end_cell[1] - start_cell[1]).abs();
    // The state in locals rather than indexed by axis, so that it stays in registers.
    let [mut column, mut row] = start_cell;
    let [mut t_next_x, mut t_next_y] = t_next;
    for _ in 0..steps {
        visit(column, row);
        // Step the axis whose boundary comes first, unless that axis is already done.
        let x_done = column == end_cell[0];
        let y_done = row == end_cell[1];
        if !x_done && (y_done || t_next_x <= t_next_y) {
            column += step[0];
            t_next_x += t_delta[0];
        } else {
            row += step[1];
            t_next_y += t_delta[1];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells(start: [f64; 2], end: [f64; 2]) -> Vec<(i64, i64)> {
        let floor = |p: [f64; 2]| [p[0].floor() as i64, p[1].floor() as i64];
        let mut out = Vec::new();
        walk_cells(start, end, floor(start), floor(end), |i, j| {
            out.push((i, j))
        });
        out
    }

    #[test]
    fn horizontal_beam_visits_each_cell_before_the_end() {
        assert_eq!(
            cells([0.5, 0.5], [4.5, 0.5]),
            vec![(0, 0), (1, 0), (2, 0), (3, 0)]
        );
        assert_eq!(
            cells([4.5, 0.5], [0.5, 0.5]),
            vec![(4, 0), (3, 0), (2, 0), (1, 0)]
        );
    }

    #[test]
    fn same_cell_visits_nothing() {
        assert!(cells([0.2, 0.2], [0.8, 0.9]).is_empty());
    }

    #[test]
    fn diagonal_beam_visits_the_cells_it_crosses_not_a_bresenham_staircase() {
        // From (0.5, 0.2) to (2.5, 1.2): crosses x = 1 at y = 0.45, y = 1 at x = 2.1, x = 2 at y = 0.95.
        assert_eq!(cells([0.5, 0.2], [2.5, 1.2]), vec![(0, 0), (1, 0), (2, 0)]);
        // Shifted up: crosses y = 1 (at x = 1.9) before x = 2 (at y = 1.05).
        assert_eq!(cells([0.5, 0.3], [2.5, 1.3]), vec![(0, 0), (1, 0), (1, 1)]);
    }

    #[test]
    fn every_visited_cell_touches_the_segment() {
        // A fan of beams: each visited cell's box must intersect the segment, and consecutive cells
        // must be 4-neighbours.
        let start = [3.3, 2.7];
        for k in 0..360 {
            let angle = f64::from(k).to_radians();
            let end = [start[0] + 7.9 * angle.cos(), start[1] + 7.9 * angle.sin()];
            let visited = cells(start, end);
            for pair in visited.windows(2) {
                let d = (pair[0].0 - pair[1].0).abs() + (pair[0].1 - pair[1].1).abs();
                assert_eq!(d, 1, "beam {k}: {pair:?} not 4-adjacent");
            }
            for &(i, j) in &visited {
                // The cell grown by 1e-9: where the beam passes exactly through a cell corner
                // (beam 135 runs along x + y = 6) the walk may step into a cell it only touches.
                const SLACK: f64 = 1e-9;
                let local = |p: [f64; 2]| [p[0] - i as f64 + SLACK, p[1] - j as f64 + SLACK];
                let size = 1.0 + 2.0 * SLACK;
                assert!(
                    clip_to_box(local(start), local(end), size, size).is_some(),
                    "beam {k} visits ({i}, {j}) which it does not cross"
                );
            }
        }
    }

    #[test]
    fn clipping_keeps_the_inside_part() {
        assert_eq!(
            clip_to_box([-1.0, 1.0], [3.0, 1.0], 2.0, 2.0),
            Some((0.25, 0.75))
        );
        assert_eq!(
            clip_to_box([0.5, 0.5], [1.5, 1.5], 2.0, 2.0),
            Some((0.0, 1.0))
        );
        assert_eq!(clip_to_box([-1.0, 3.0], [3.0, 3.0], 2.0, 2.0), None);
        assert_eq!(clip_to_box([-1.0, -1.0], [-0.5, 5.0], 2.0, 2.0), None);
    }
}
