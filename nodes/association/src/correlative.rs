//! Correlative scan matching by multi-resolution branch and bound.
//!
//! Loop closure must find where a query scan lies in a submap when the prediction may be metres
//! and degrees off, farther than ICP converges from. Correlative matching scores every rigid
//! motion on a lattice around the prediction (translations one grid cell apart inside a disc,
//! rotations one angular step apart) by how well the moved scan points land on the submap, and
//! keeps the best. Scoring the lattice motion by motion costs translations × rotations × points
//! lookups; this module finds the same best motion with the branch-and-bound search of Hess,
//! Kohler, Rapp and Andor, "Real-Time Loop Closure in 2D LIDAR SLAM" (ICRA 2016), Sec. V:
//!
//! - [`ProbabilityGrid`]: the submap rasterised into a likelihood field. By default a cell holds
//!   the largest `exp(-d² / 2σ²)` over the map points, `d` being the distance from the point to
//!   the nearest spot of the cell, truncated at 3σ: σ (`sigma_m`) represents the radar's blur,
//!   and taking the nearest spot of the cell means a perfectly aligned point always scores 1
//!   whatever the cell size. [`Kernel::Hit`] is the binary raster loop closure used before
//!   (1 within a cell of a map point's cell). The grid's extent is the points' bounding box plus
//!   the kernel's reach; absurd extents are refused ([`CorrelativeError::TooLarge`]) rather than
//!   allocated.
//! - [`MultiResolutionGrid`]: the precomputed grids of Sec. V-C. At depth `h` the value at cell
//!   (x, y) is the maximum of the base grid over the 2^h × 2^h block starting at (x, y), so the
//!   sum of those values over the scan points bounds, from above, the score of every
//!   translation in a 2^h × 2^h block of the search lattice.
//! - [`search`] and [`search_with`]: depth-first branch and bound. The root's children are
//!   every rotation × every block of the translation window at the coarsest depth; a node's
//!   children are the four half-size blocks; children are visited best bound first, and a node
//!   whose bound cannot beat the best leaf found so far is pruned. The bound never
//!   underestimates, so the result is exactly [`exhaustive_search`]'s.
//! - [`runner_up`]: the best motion at least some distance from a given one (the second peak
//!   that loop closure's ambiguity test needs), by the same search with a disc of translations
//!   excluded; it prunes against its own best, so it costs about as much as the first search.
//! - [`plateau_centre`]: the mean of the motions scoring within a fraction of the best, for
//!   scans whose points scatter so much that the best is one point of a flat (loop closure at
//!   Δθ 5°).
//! - [`exhaustive_search`]: the same lattice scored motion by motion, the reference that the
//!   tests compare the branch and bound with and the benchmark's baseline.
//!
//! **Scores.** The score of a motion is the mean grid value at the moved scan points, optionally
//! times a Gaussian prior on the translation's offset from the initial pose (loop closure uses it
//! to prefer, among look-alike places, the one nearer where the pose graph puts the AGV). The
//! prior is largest at the offset nearest the initial pose, so a node's bound is its sum of maxima
//! times the prior at the block's offset nearest the initial pose: still never below any leaf's
//! score.
//! A scan point's cell is computed once per rotation, and a translation by (i, j) steps moves it
//! by exactly (i, j) cells (the translation step is the cell size), as Hess et al. do.
//!
//! **Determinism.** Grid values are 16-bit fixed point, so sums are exact integers independent of
//! order, and a bound compares with the scores it bounds without rounding doubt. Ties are broken
//! by the smallest (rotation index, x offset, y offset), in that order, which is the order in
//! which [`exhaustive_search`] visits the lattice: both return the same motion. Nothing depends
//! on threads or on memory addresses.

use crate::pose::Pose2;

/// Largest base grid, cells (4 Mi cells, 8 MiB): a submap spanning more than ~500 m at 0.25 m is
/// not one worth matching, and points kilometres apart must not allocate gigabytes.
pub const MAX_GRID_CELLS: usize = 1 << 22;
/// Deepest precomputed level (blocks of 2^10 cells).
pub const MAX_DEPTH: u32 = 10;
/// Largest total of the precomputed levels, cells (64 MiB).
const MAX_LEVEL_CELLS: f64 = (1u64 << 25) as f64;
/// Largest number of cell updates spent rasterising (points × kernel cells).
const MAX_RASTER_UPDATES: f64 = (1u64 << 30) as f64;
/// Largest number of translation steps either side of the initial pose.
const MAX_LINEAR_STEPS: f64 = (1u64 << 14) as f64;
/// Largest number of rotations searched.
const MAX_ROTATIONS: f64 = (1u64 << 16) as f64;
/// Largest number of (rotation, scan point) cells kept (16 MiB).
const MAX_ROTATED_CELLS: f64 = (1u64 << 21) as f64;
/// Largest number of (rotation, scan point, level) indices kept (32 MiB); a larger search reads
/// its cells with bounds tests instead.
const MAX_LEVEL_INDICES: f64 = (1u64 << 23) as f64;
/// Largest number of root nodes (rotations × coarsest blocks).
const MAX_ROOT_NODES: f64 = (1u64 << 22) as f64;
/// Largest number of motions [`plateau_centre`] scores and keeps (8 MiB of scores).
const MAX_PLATEAU_MOTIONS: f64 = (1u64 << 20) as f64;
/// The Gaussian kernel is cut off at this many σ (its value there is 0.011).
const TRUNCATION_SIGMAS: f64 = 3.0;
/// Grid values are fixed point in [0, `VALUE_SCALE`].
const VALUE_SCALE: f64 = u16::MAX as f64;
/// A scan point's cell is clamped to ±`CELL_LIMIT`: far outside any grid (so it scores 0), yet
/// far from overflow when window and level offsets are added to it.
const CELL_LIMIT: f64 = (1i64 << 30) as f64;
/// Slack for ratios that should be integers (12° / 1° computed in radians is 12.000000000000002).
const RATIO_SLACK: f64 = 1e-9;

/// Why a grid could not be built or a search not run.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CorrelativeError {
    /// There is no map point to rasterise.
    #[error("the map has no point")]
    EmptyMap,
    /// There is no scan point to match.
    #[error("the scan has no point")]
    EmptyScan,
    /// An input that must be finite is not (a NaN or infinite point or pose).
    #[error("{0} is not finite")]
    NonFinite(&'static str),
    /// A parameter is outside its valid range.
    #[error("{name} = {value} is outside its valid range")]
    InvalidParameter {
        /// The parameter.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// The grid or the search would exceed a size limit (cells, steps or work).
    #[error("{what} would need {amount:e}, more than the limit {limit:e}")]
    TooLarge {
        /// What would be too large.
        what: &'static str,
        /// How much it would need.
        amount: f64,
        /// The limit.
        limit: f64,
    },
}

/// One level of values on a rectangle of cells, 0 outside it. Level `h` stores the cells
/// x ∈ [−offset, width − offset) (and likewise y) with offset = pad + 2^h − 1: a block starting
/// up to 2^h − 1 cells before the base grid still overlaps it, and a search window's `pad` cells
/// of zeros around the base grid let the search read most cells without a bounds test
/// ([`ProbabilityGrid::padded`]).
#[derive(Debug, Clone)]
struct Level {
    offset: i64,
    /// Cells per side of this level's blocks: 2^h.
    block: i64,
    width: usize,
    height: usize,
    values: Vec<u16>,
}

impl Level {
    /// The value at cell (x, y) of the base grid's indexing; 0 outside the stored rectangle.
    #[inline]
    fn get(&self, x: i64, y: i64) -> u16 {
        let (column, row) = (x + self.offset, y + self.offset);
        if column < 0 || row < 0 || column >= self.width as i64 || row >= self.height as i64 {
            0
        } else {
            self.values[row as usize * self.width + column as usize]
        }
    }

    /// The sum of the values at `cells` each moved by (`x0`, `y0`), bounds-checked: the part of
    /// a node's score from the cells near the grid's edges ([`Lattice::sum_at`]).
    #[inline]
    fn sum_at(&self, cells: &[[i32; 2]], x0: i64, y0: i64) -> u64 {
        let (shift_x, shift_y) = (x0 + self.offset, y0 + self.offset);
        let (width, height) = (self.width as u64, self.height as u64);
        cells
            .iter()
            .map(|c| {
                // A cell before the stored rectangle wraps to a huge u64: one comparison per
                // axis tests both ends.
                let column = (i64::from(c[0]) + shift_x) as u64;
                let row = (i64::from(c[1]) + shift_y) as u64;
                if column < width && row < height {
                    u64::from(self.values[(row * width + column) as usize])
                } else {
                    0
                }
            })
            .sum()
    }

    /// The next level: blocks of 2^(h+1) cells from blocks of 2^h. A block of 2s cells starting
    /// at x is the blocks of s cells starting at x and at x + s, so each level is two maxima per
    /// cell (along x, then along y) of the one before: O(cells) per level.
    fn doubled(&self) -> Level {
        let offset = self.offset + self.block;
        let shift = self.block as usize;
        let width = self.width + shift;
        let height = self.height + shift;
        // New column c holds block x = c − offset, the maximum of the previous level's blocks x
        // and x + half, stored there at columns c − half and c: new[c] = max(previous[c − half],
        // previous[c]), 0 where either is outside. Likewise for rows.
        let mut along_x = vec![0u16; width * self.height];
        for (row, previous) in along_x
            .chunks_exact_mut(width)
            .zip(self.values.chunks_exact(self.width))
        {
            row[..self.width].copy_from_slice(previous);
            max_into(&mut row[shift..], previous);
        }
        // Likewise along y, on whole rows.
        let mut values = vec![0u16; width * height];
        values[..along_x.len()].copy_from_slice(&along_x);
        max_into(&mut values[shift * width..], &along_x);
        Level {
            offset,
            block: 2 * self.block,
            width,
            height,
            values,
        }
    }
}

/// `target[i] = max(target[i], source[i])` over the shorter of the two.
fn max_into(target: &mut [u16], source: &[u16]) {
    for (t, &s) in target.iter_mut().zip(source) {
        *t = (*t).max(s);
    }
}

/// How a map point spreads over the cells of a [`ProbabilityGrid`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Kernel {
    /// `exp(-d² / 2σ²)`, `d` the distance from the point to the nearest spot of the cell (0 in
    /// the point's own cell), cut off at 3σ: a likelihood field whose σ represents the sensor's
    /// blur.
    Gaussian {
        /// σ, metres.
        sigma_m: f64,
    },
    /// 1 on the cells within `cells` columns and rows of the point's own cell, 0 elsewhere: the
    /// binary "hit" raster that loop closure scored with before this module (one cell of
    /// dilation), whose scores are fractions of points on hit cells.
    Hit {
        /// Dilation, cells.
        cells: u32,
    },
}

/// A point set rasterised into a likelihood field: each cell's value in [0, 1] is the largest
/// over the points of their [`Kernel`] at the cell (by default a Gaussian of the distance to the
/// cell). Cells outside the grid are worth 0.
#[derive(Debug, Clone)]
pub struct ProbabilityGrid {
    origin_m: [f64; 2],
    cell_m: f64,
    kernel: Kernel,
    level: Level,
}

impl ProbabilityGrid {
    /// Rasterises `points_m` (metres) into cells of `cell_m` with a Gaussian blur `sigma_m`.
    ///
    /// Errors: no point ([`CorrelativeError::EmptyMap`]), a non-finite point, a non-positive or
    /// non-finite cell or σ, or a bounding box (plus 3σ) of more than [`MAX_GRID_CELLS`] cells.
    pub fn new(points_m: &[[f64; 2]], cell_m: f64, sigma_m: f64) -> Result<Self, CorrelativeError> {
        Self::with_kernel(points_m, cell_m, Kernel::Gaussian { sigma_m })
    }

    /// Rasterises `points_m` (metres) into cells of `cell_m` with `kernel`. The grid covers the
    /// points' bounding box plus the kernel's reach (3σ, or the dilation plus a cell).
    ///
    /// Errors: as [`ProbabilityGrid::new`]; a dilation of more than 1000 cells is refused.
    pub fn with_kernel(
        points_m: &[[f64; 2]],
        cell_m: f64,
        kernel: Kernel,
    ) -> Result<Self, CorrelativeError> {
        check_positive("cell_m", cell_m)?;
        let reach_m = match kernel {
            Kernel::Gaussian { sigma_m } => {
                check_positive("sigma_m", sigma_m)?;
                TRUNCATION_SIGMAS * sigma_m
            }
            Kernel::Hit { cells } => {
                if cells > 1000 {
                    return Err(CorrelativeError::InvalidParameter {
                        name: "cells",
                        value: f64::from(cells),
                    });
                }
                // A cell more than the dilation, so that rounding cannot put the lowest point's
                // dilated cells below the grid.
                f64::from(cells + 1) * cell_m
            }
        };
        check_points(points_m, CorrelativeError::EmptyMap, "a map point")?;
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in points_m {
            for axis in 0..2 {
                lo[axis] = lo[axis].min(p[axis]);
                hi[axis] = hi[axis].max(p[axis]);
            }
        }
        let origin_m = [lo[0] - reach_m, lo[1] - reach_m];
        let columns = ((hi[0] + reach_m - origin_m[0]) / cell_m).floor() + 1.0;
        let rows = ((hi[1] + reach_m - origin_m[1]) / cell_m).floor() + 1.0;
        // Checked in floating point, before any cast or allocation.
        let cells = columns * rows;
        if cells.is_nan() || cells > MAX_GRID_CELLS as f64 {
            return Err(CorrelativeError::TooLarge {
                what: "the probability grid (cells)",
                amount: cells,
                limit: MAX_GRID_CELLS as f64,
            });
        }
        let kernel_cells = (2.0 * reach_m / cell_m + 2.0).powi(2).min(cells);
        let updates = kernel_cells * points_m.len() as f64;
        if updates > MAX_RASTER_UPDATES {
            return Err(CorrelativeError::TooLarge {
                what: "rasterising the map (cell updates)",
                amount: updates,
                limit: MAX_RASTER_UPDATES,
            });
        }
        let (width, height) = (columns as usize, rows as usize);
        let mut values = vec![0u16; width * height];
        match kernel {
            Kernel::Gaussian { sigma_m } => {
                rasterise_gaussian(&mut values, width, points_m, origin_m, cell_m, sigma_m)
            }
            Kernel::Hit { cells } => {
                let reach = i64::from(cells);
                for p in points_m {
                    let column = ((p[0] - origin_m[0]) / cell_m).floor() as i64;
                    let row = ((p[1] - origin_m[1]) / cell_m).floor() as i64;
                    for r in (row - reach).max(0)..=(row + reach).min(height as i64 - 1) {
                        for c in (column - reach).max(0)..=(column + reach).min(width as i64 - 1) {
                            values[r as usize * width + c as usize] = u16::MAX;
                        }
                    }
                }
            }
        }
        Ok(ProbabilityGrid {
            origin_m,
            cell_m,
            kernel,
            level: Level {
                offset: 0,
                block: 1,
                width,
                height,
                values,
            },
        })
    }

    /// Cell size, metres.
    pub fn cell_m(&self) -> f64 {
        self.cell_m
    }

    /// The kernel the grid was built with.
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// The lower-left corner of cell (0, 0), metres.
    pub fn origin_m(&self) -> [f64; 2] {
        self.origin_m
    }

    /// Number of columns (cells along x).
    pub fn width(&self) -> usize {
        self.level.width - 2 * self.level.offset as usize
    }

    /// Number of rows (cells along y).
    pub fn height(&self) -> usize {
        self.level.height - 2 * self.level.offset as usize
    }

    /// The same grid stored with `pad_cells` cells of zeros around it (fewer if the whole would
    /// exceed [`MAX_GRID_CELLS`], or its levels to `depth` the limit of
    /// [`MultiResolutionGrid::new`]; none if it is padded already): every value and search result
    /// stays the same, but a search whose window reaches L ≤ `pad_cells` / 2 steps reads the
    /// scan's cells without a bounds test, about twice as fast (`benches/correlative.rs`).
    /// [`MultiResolutionGrid::for_window`] pads by twice its window.
    pub fn padded(self, pad_cells: usize, depth: u32) -> Self {
        if self.level.offset != 0 {
            return self;
        }
        let depth = depth.min(MAX_DEPTH);
        let (width, height) = (self.level.width, self.level.height);
        let fits = |pad: usize| {
            let (padded_width, padded_height) = (width + 2 * pad, height + 2 * pad);
            padded_width
                .checked_mul(padded_height)
                .is_some_and(|cells| cells <= MAX_GRID_CELLS)
                && level_cells(padded_width, padded_height, depth) <= MAX_LEVEL_CELLS
        };
        let mut pad = pad_cells.min(MAX_GRID_CELLS);
        while pad > 0 && !fits(pad) {
            pad /= 2;
        }
        if pad == 0 {
            return self;
        }
        let padded_width = width + 2 * pad;
        let mut values = vec![0u16; padded_width * (height + 2 * pad)];
        for (row, source) in self.level.values.chunks_exact(width).enumerate() {
            let start = (row + pad) * padded_width + pad;
            values[start..start + width].copy_from_slice(source);
        }
        ProbabilityGrid {
            level: Level {
                offset: pad as i64,
                block: 1,
                width: padded_width,
                height: height + 2 * pad,
                values,
            },
            ..self
        }
    }

    /// The value of cell (`column`, `row`) in [0, 1]; 0 outside the grid.
    pub fn value(&self, column: i64, row: i64) -> f64 {
        f64::from(self.level.get(column, row)) / VALUE_SCALE
    }

    /// The value of the cell containing `point_m`; 0 outside the grid or for a non-finite point.
    pub fn value_at_m(&self, point_m: [f64; 2]) -> f64 {
        if !(point_m[0].is_finite() && point_m[1].is_finite()) {
            return 0.0;
        }
        let [column, row] = self.cell_of(point_m);
        self.value(i64::from(column), i64::from(row))
    }

    /// The cell containing a finite point, clamped far outside the grid for far points.
    fn cell_of(&self, point_m: [f64; 2]) -> [i32; 2] {
        [
            clamp_cell((point_m[0] - self.origin_m[0]) / self.cell_m),
            clamp_cell((point_m[1] - self.origin_m[1]) / self.cell_m),
        ]
    }
}

/// A [`ProbabilityGrid`] with its precomputed maxima over blocks of 2^h × 2^h cells,
/// h = 1..=`depth` (Hess et al., Sec. V-C).
#[derive(Debug, Clone)]
pub struct MultiResolutionGrid {
    grid: ProbabilityGrid,
    /// `levels[h - 1]` holds depth h.
    levels: Vec<Level>,
}

impl MultiResolutionGrid {
    /// Precomputes depths 1..=`depth` over `grid` (depth 0 is the grid itself).
    ///
    /// Errors: `depth` above [`MAX_DEPTH`], or levels totalling more than 2^25 cells.
    pub fn new(grid: ProbabilityGrid, depth: u32) -> Result<Self, CorrelativeError> {
        if depth > MAX_DEPTH {
            return Err(CorrelativeError::InvalidParameter {
                name: "depth",
                value: f64::from(depth),
            });
        }
        let total = level_cells(grid.level.width, grid.level.height, depth);
        if total > MAX_LEVEL_CELLS {
            return Err(CorrelativeError::TooLarge {
                what: "the precomputed grids (cells)",
                amount: total,
                limit: MAX_LEVEL_CELLS,
            });
        }
        let mut levels: Vec<Level> = Vec::with_capacity(depth as usize);
        for _ in 0..depth {
            let next = levels.last().unwrap_or(&grid.level).doubled();
            levels.push(next);
        }
        Ok(MultiResolutionGrid { grid, levels })
    }

    /// `points_m` rasterised on cells of `cell_m` with `kernel`, with the maxima a branch and
    /// bound over a window of `linear_m` either side wants ([`suggested_depth`]).
    ///
    /// Errors: as [`ProbabilityGrid::with_kernel`] and [`MultiResolutionGrid::new`].
    pub fn for_window(
        points_m: &[[f64; 2]],
        cell_m: f64,
        kernel: Kernel,
        linear_m: f64,
    ) -> Result<Self, CorrelativeError> {
        let grid = ProbabilityGrid::with_kernel(points_m, cell_m, kernel)?;
        let depth = suggested_depth(linear_m, cell_m);
        let window_steps = (linear_m / cell_m).ceil();
        let grid = if window_steps.is_finite() && window_steps >= 1.0 {
            grid.padded(2 * window_steps.min(MAX_LINEAR_STEPS) as usize, depth)
        } else {
            grid
        };
        Self::new(grid, depth)
    }

    /// The base grid.
    pub fn grid(&self) -> &ProbabilityGrid {
        &self.grid
    }

    /// The deepest precomputed level.
    pub fn depth(&self) -> u32 {
        self.levels.len() as u32
    }

    /// The maximum of the base grid over the 2^`depth` × 2^`depth` block of cells whose lowest
    /// corner is (`column`, `row`), in [0, 1]; `None` for a depth not precomputed.
    pub fn max_value(&self, depth: u32, column: i64, row: i64) -> Option<f64> {
        (depth <= self.depth()).then(|| f64::from(self.level(depth).get(column, row)) / VALUE_SCALE)
    }

    /// Every level, depth 0 (the base grid) first.
    fn levels_from_base(&self) -> Vec<&Level> {
        std::iter::once(&self.grid.level)
            .chain(&self.levels)
            .collect()
    }

    fn level(&self, depth: u32) -> &Level {
        match depth {
            0 => &self.grid.level,
            h => &self.levels[h as usize - 1],
        }
    }
}

/// The cells of the precomputed levels 1..=`depth` over a base of `width` × `height` cells.
fn level_cells(width: usize, height: usize, depth: u32) -> f64 {
    (1..=depth)
        .map(|h| {
            let extra = f64::from((1u32 << h) - 1);
            (width as f64 + extra) * (height as f64 + extra)
        })
        .sum()
}

/// A depth for [`MultiResolutionGrid::new`] suited to a window of `linear_m` either side on
/// cells of `cell_m`: the coarsest blocks span a quarter to a half of the window's width.
/// Coarser blocks bound too loosely to prune (a block metres wide nearly always holds a map point
/// somewhere), finer ones leave more roots to score; every depth gives the same result. Measured
/// in `benches/correlative.rs` (group `depth`): at ±6 m with Hess et al.'s angular step, depth 5
/// was fastest on 0.25 m cells (4: +10 %) and on 0.1 m cells (4: +2×, 6: +30 %); with loop
/// closure's hit raster, prior and 1° steps on 0.25 m cells, 3 and 7 were (4: +20 %, 5: +2×).
pub fn suggested_depth(linear_m: f64, cell_m: f64) -> u32 {
    let width = 2.0 * (linear_m / cell_m).ceil() + 1.0;
    if !(width.is_finite() && width >= 1.0) {
        return 1;
    }
    (width.log2().floor().min(f64::from(MAX_DEPTH)) as u32)
        .saturating_sub(1)
        .clamp(1, 7)
}

/// The motions searched around the initial pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchWindow {
    /// Translations within this distance of the initial position (a disc), metres. They lie on
    /// a lattice with the grid's cell as step.
    pub linear_m: f64,
    /// Rotations up to this either side of the initial heading, radians, in [0, π]. The steps
    /// either side are ⌈`angular_rad` / step⌉.
    pub angular_rad: f64,
}

/// A disc of translations left out of a search (see [`runner_up`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Exclusion {
    /// The disc's centre, metres (in the grid's frame).
    pub center_m: [f64; 2],
    /// Motions whose position is closer than this to the centre are left out, metres.
    pub radius_m: f64,
}

impl Exclusion {
    /// The motions closer than `distance_m` to `best`'s position.
    pub fn around(best: &Match, distance_m: f64) -> Self {
        Exclusion {
            center_m: [best.pose.x_m, best.pose.y_m],
            radius_m: distance_m,
        }
    }
}

/// Options of [`search_with`] beyond the window.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SearchOptions {
    /// Rotation step, radians; `None` takes [`angular_step_rad`] of the scan (Hess et al.'s
    /// choice: the farthest scan point moves at most one cell per step).
    pub angular_step_rad: Option<f64>,
    /// σ of a Gaussian prior on the translation's offset from the initial pose that multiplies
    /// the score, metres; `None` for no prior.
    pub prior_sigma_m: Option<f64>,
    /// Translations left out of the search.
    pub exclude: Option<Exclusion>,
}

/// The best motion of a search.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Match {
    /// The scan's pose in the grid's frame.
    pub pose: Pose2,
    /// What was maximised: `mean_value` times the prior at this offset (1 without a prior).
    pub score: f64,
    /// Mean grid value at the moved scan points, in [0, 1].
    pub mean_value: f64,
    /// Translation from the initial pose, in cells (steps) along x and y.
    pub offset_cells: [i64; 2],
    /// Rotation from the initial pose, in angular steps.
    pub rotation_steps: i64,
    /// The angular step searched, radians.
    pub angular_step_rad: f64,
}

/// Hess et al.'s rotation step for a scan: `acos(1 − r² / (2 d²))` with r the cell size and d
/// the largest distance of a scan point from the scan's origin, so that a step moves no point by
/// more than about one cell. π when every point lies within half a cell of the origin (rotation
/// hardly matters there); NaN for an empty scan or a non-finite point.
pub fn angular_step_rad(scan_points_m: &[[f64; 2]], cell_m: f64) -> f64 {
    let farthest_m = scan_points_m
        .iter()
        .map(|p| p[0].hypot(p[1]))
        .fold(f64::NAN, f64::max);
    if scan_points_m
        .iter()
        .any(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return f64::NAN;
    }
    (1.0 - cell_m * cell_m / (2.0 * farthest_m * farthest_m))
        .clamp(-1.0, 1.0)
        .acos()
}

/// The best motion of `scan_points_m` (metres, in the scan's frame) against `grids` within
/// `window` of `initial`, with a score of at least `min_score`; `Ok(None)` if none has. The
/// rotation step is [`angular_step_rad`] of the scan, and there is no prior.
pub fn search(
    grids: &MultiResolutionGrid,
    scan_points_m: &[[f64; 2]],
    initial: Pose2,
    window: &SearchWindow,
    min_score: f64,
) -> Result<Option<Match>, CorrelativeError> {
    search_with(
        grids,
        scan_points_m,
        initial,
        window,
        &SearchOptions::default(),
        min_score,
    )
}

/// [`search`] with options: a given rotation step, a prior, an excluded disc.
///
/// Errors: an empty scan, a non-finite point or initial pose, an invalid window or option, or a
/// window too large to enumerate (more than 2^14 steps either side, 2^16 rotations, or 2^22
/// root nodes).
pub fn search_with(
    grids: &MultiResolutionGrid,
    scan_points_m: &[[f64; 2]],
    initial: Pose2,
    window: &SearchWindow,
    options: &SearchOptions,
    min_score: f64,
) -> Result<Option<Match>, CorrelativeError> {
    PreparedSearch::new(grids, scan_points_m, initial, window, options)?
        .best_outside(options.exclude, min_score)
}

/// A search of one scan from one initial pose over one window, prepared once (the scan's cells
/// at every rotation) and run as often as asked: loop closure's best motion and then its
/// runner-up share it, instead of placing the scan's points twice. Each run is
/// [`search_with`]'s, with its own excluded disc and minimum score.
pub struct PreparedSearch<'g> {
    grids: &'g MultiResolutionGrid,
    lattice: Lattice,
}

impl<'g> PreparedSearch<'g> {
    /// Prepares the search of `scan_points_m` over `grids` within `window` of `initial`, with
    /// `options`' rotation step and prior (its excluded disc is each run's).
    ///
    /// Errors: as [`search_with`].
    pub fn new(
        grids: &'g MultiResolutionGrid,
        scan_points_m: &[[f64; 2]],
        initial: Pose2,
        window: &SearchWindow,
        options: &SearchOptions,
    ) -> Result<Self, CorrelativeError> {
        let lattice = Lattice::new(
            grids.grid(),
            &grids.levels_from_base(),
            scan_points_m,
            initial,
            window,
            &SearchOptions {
                exclude: None,
                ..*options
            },
            0.0,
        )?;
        Ok(PreparedSearch { grids, lattice })
    }

    /// The best motion outside `away` (none: anywhere in the window) with a score of at least
    /// `min_score`; `Ok(None)` if none has.
    ///
    /// Errors: an exclusion with a non-finite centre or a negative radius, a NaN `min_score`, or
    /// more root nodes than the search may enumerate.
    pub fn best_outside(
        &mut self,
        away: Option<Exclusion>,
        min_score: f64,
    ) -> Result<Option<Match>, CorrelativeError> {
        self.first_outside_where(away, min_score, |_| false)
    }

    /// As [`PreparedSearch::best_outside`], but the search stops at the first motion it meets
    /// whose score makes `enough` true, and returns that one: the question "does any motion
    /// outside `away` score above a threshold?" is answered by the first that does, without
    /// finding the highest. When no motion satisfies `enough` the answer is exactly
    /// `best_outside`'s. `enough` must be monotone (true for a score, true for every higher one)
    /// for "none satisfies it" to follow from the best not satisfying it.
    ///
    /// Errors: as [`PreparedSearch::best_outside`].
    pub fn first_outside_where(
        &mut self,
        away: Option<Exclusion>,
        min_score: f64,
        enough: impl Fn(f64) -> bool,
    ) -> Result<Option<Match>, CorrelativeError> {
        check_target(away, min_score)?;
        self.lattice.exclude = away;
        self.lattice.min_score = min_score;
        Ok(self.lattice.branch_and_bound(self.grids, &enough)?.0)
    }
}

/// The best motion outside `away` (a disc around the best motion, see [`Exclusion::around`]) with
/// a score of at least `min_score`, found by [`search_with`] with that disc excluded: the
/// runner-up whose score, against the best's, says how distinct the best peak is. `Ok(None)` when
/// the window holds no such motion. A caller that only asks "is the runner-up above a fraction
/// of the best?" passes that fraction of the best's score as `min_score`, and branch and bound
/// prunes all the rest.
pub fn runner_up(
    grids: &MultiResolutionGrid,
    scan_points_m: &[[f64; 2]],
    initial: Pose2,
    window: &SearchWindow,
    options: &SearchOptions,
    away: Exclusion,
    min_score: f64,
) -> Result<Option<Match>, CorrelativeError> {
    let options = SearchOptions {
        exclude: Some(away),
        ..*options
    };
    search_with(grids, scan_points_m, initial, window, &options, min_score)
}

/// The same search as [`search_with`], scoring every motion of the lattice in turn: the
/// reference for tests and benchmarks. Its cost grows with the window's area times its
/// rotations times the scan's points.
pub fn exhaustive_search(
    grid: &ProbabilityGrid,
    scan_points_m: &[[f64; 2]],
    initial: Pose2,
    window: &SearchWindow,
    options: &SearchOptions,
    min_score: f64,
) -> Result<Option<Match>, CorrelativeError> {
    let lattice = Lattice::on_base(grid, scan_points_m, initial, window, options, min_score)?;
    let mut best: Option<Node> = None;
    for leaf in lattice.leaves(&grid.level) {
        // Visited in key order: only a strictly higher score replaces the best.
        if leaf.bound >= min_score && best.is_none_or(|b| leaf.bound > b.bound) {
            best = Some(leaf);
        }
    }
    Ok(best.map(|leaf| lattice.to_match(&leaf)))
}

/// The centre of the plateau of near-best motions: the mean pose of every motion of the lattice
/// (scored as [`exhaustive_search`] scores them) whose score is at least `1 − fraction` of the
/// best in the window, and how many there are. Where the scan's points scatter by more than the
/// grid's cell the score is flat around the truth, and the arg-max lands anywhere on the flat,
/// wherever ties and the prior put it; the centre of the flat is the estimate that does not
/// depend on where the search started (up to a cell: the lattice steps from the start). The
/// rotation is averaged in steps from the initial heading, so the window may reach at most π/2
/// either side. Only the near-best motions connected to the best (through neighbours in
/// rotation, x or y) count: a second peak elsewhere in the window, as a repetitive layout has,
/// would pull the mean between the two, where the scan fits neither. `Ok(None)` when no motion
/// scores above 0. `fraction` lies in [0, 1).
pub fn plateau_centre(
    grid: &ProbabilityGrid,
    scan_points_m: &[[f64; 2]],
    initial: Pose2,
    window: &SearchWindow,
    options: &SearchOptions,
    fraction: f64,
) -> Result<Option<(Pose2, usize)>, CorrelativeError> {
    if !(0.0..1.0).contains(&fraction) {
        return Err(CorrelativeError::InvalidParameter {
            name: "fraction",
            value: fraction,
        });
    }
    if window.angular_rad > std::f64::consts::FRAC_PI_2 {
        return Err(CorrelativeError::InvalidParameter {
            name: "window.angular_rad",
            value: window.angular_rad,
        });
    }
    let lattice = Lattice::on_base(grid, scan_points_m, initial, window, options, 0.0)?;
    let steps = lattice.linear_steps;
    let side = (2 * steps + 1) as usize;
    too_large(
        "plateau motions",
        lattice.rotations() as f64 * (side as f64).powi(2),
        MAX_PLATEAU_MOTIONS,
    )?;
    // Every motion's score, in key order (rotation, x, y); motions outside the window's disc
    // never score.
    let index = |rotation: usize, x: i64, y: i64| {
        (rotation * side + (x + steps) as usize) * side + (y + steps) as usize
    };
    let mut scores = vec![f64::NEG_INFINITY; lattice.rotations() * side * side];
    for leaf in lattice.leaves(&grid.level) {
        scores[index(leaf.rotation, leaf.x0, leaf.y0)] = leaf.bound;
    }
    // The first of equal scores is the best, as in `exhaustive_search`.
    let best = scores.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let Some(first) = scores
        .iter()
        .position(|&s| s == best)
        .filter(|_| best > 0.0)
    else {
        return Ok(None);
    };
    let floor = (1.0 - fraction) * best;
    // The near-best motions connected to the best one (each step to one of the 26 neighbours in
    // rotation, x and y): a second peak elsewhere in the window is not part of its plateau. A
    // motion counted is struck off.
    let start = (
        first / (side * side),
        (first / side % side) as i64 - steps,
        (first % side) as i64 - steps,
    );
    scores[first] = f64::NEG_INFINITY;
    let (mut sum, mut count) = ([0.0; 3], 0usize);
    let mut queue = vec![start];
    while let Some((rotation, x, y)) = queue.pop() {
        sum[0] += x as f64;
        sum[1] += y as f64;
        sum[2] += rotation as f64 - lattice.angular_steps as f64;
        count += 1;
        for dr in -1i64..=1 {
            for dx in -1i64..=1 {
                for dy in -1i64..=1 {
                    let (r, nx, ny) = (rotation as i64 + dr, x + dx, y + dy);
                    let inside = (0..lattice.rotations() as i64).contains(&r)
                        && (-steps..=steps).contains(&nx)
                        && (-steps..=steps).contains(&ny);
                    if inside && scores[index(r as usize, nx, ny)] >= floor {
                        scores[index(r as usize, nx, ny)] = f64::NEG_INFINITY;
                        queue.push((r as usize, nx, ny));
                    }
                }
            }
        }
    }
    let mean = sum.map(|s| s / count as f64);
    let centre = Pose2::new(
        initial.x_m + mean[0] * lattice.cell_m,
        initial.y_m + mean[1] * lattice.cell_m,
        initial.yaw_rad + mean[2] * lattice.angular_step_rad,
    );
    Ok(Some((centre, count)))
}

/// Writes into `values` (a grid `width` cells wide whose cell (0, 0) has its lower-left corner at
/// `origin_m`) the largest `exp(-d² / 2σ²)` over `points_m`, `d` the distance from the point to
/// the nearest spot of the cell, cut off at 3σ. Every point lies at least 3σ inside the grid's
/// lower edges, so the first cells below are never negative.
fn rasterise_gaussian(
    values: &mut [u16],
    width: usize,
    points_m: &[[f64; 2]],
    origin_m: [f64; 2],
    cell_m: f64,
    sigma_m: f64,
) {
    let height = values.len() / width;
    let reach_m = TRUNCATION_SIGMAS * sigma_m;
    let reach2_m2 = reach_m * reach_m;
    let inverse_two_sigma2 = 1.0 / (2.0 * sigma_m * sigma_m);
    // exp(−(dx² + dy²)/2σ²) = exp(−dx²/2σ²)·exp(−dy²/2σ²): one exp per column and per row of
    // a point's square instead of one per cell.
    let mut column_factors: Vec<(f64, f64)> = Vec::new();
    for p in points_m {
        let first = |axis: usize| ((p[axis] - reach_m - origin_m[axis]) / cell_m).floor();
        let last = |axis: usize| ((p[axis] + reach_m - origin_m[axis]) / cell_m).floor();
        let (c0, c1) = (first(0).max(0.0) as usize, last(0) as usize);
        let (r0, r1) = (first(1).max(0.0) as usize, last(1) as usize);
        let c1 = c1.min(width - 1);
        if c0 > c1 {
            continue;
        }
        column_factors.clear();
        column_factors.extend((c0..=c1).map(|column| {
            let x0 = origin_m[0] + column as f64 * cell_m;
            let dx = (x0 - p[0]).max(p[0] - (x0 + cell_m)).max(0.0);
            (dx * dx, (-dx * dx * inverse_two_sigma2).exp())
        }));
        for row in r0..=r1.min(height - 1) {
            let y0 = origin_m[1] + row as f64 * cell_m;
            let dy = (y0 - p[1]).max(p[1] - (y0 + cell_m)).max(0.0);
            let row_factor = (-dy * dy * inverse_two_sigma2).exp() * VALUE_SCALE;
            let cells = &mut values[row * width + c0..=row * width + c1];
            for (cell, &(dx2, column_factor)) in cells.iter_mut().zip(&column_factors) {
                if dx2 + dy * dy > reach2_m2 {
                    continue;
                }
                let value = round_to_u16(row_factor * column_factor);
                *cell = (*cell).max(value);
            }
        }
    }
}

/// `value.round() as u16` for a `value` in [0, 65535]: its truncation, plus one when the dropped
/// fraction (exact in f64) is at least a half. Without SSE4.1 `round` is a library call, and
/// the fine field rounds every cell of every point's kernel. Written without a branch: the
/// fractions are as good as random, and a branch on them mispredicts half the time.
#[inline]
fn round_to_u16(value: f64) -> u16 {
    let whole = value as u16;
    let up = u32::from(value - f64::from(whole) >= 0.5);
    (u32::from(whole) + up).min(u32::from(u16::MAX)) as u16
}

/// Checks what a search looks for: an excluded disc with a finite centre and a radius of at
/// least 0, and a minimum score that is a number.
fn check_target(exclude: Option<Exclusion>, min_score: f64) -> Result<(), CorrelativeError> {
    if min_score.is_nan() {
        return Err(CorrelativeError::InvalidParameter {
            name: "min_score",
            value: min_score,
        });
    }
    if let Some(exclude) = exclude {
        if !(exclude.center_m[0].is_finite() && exclude.center_m[1].is_finite()) {
            return Err(CorrelativeError::NonFinite("the exclusion's centre"));
        }
        if !(exclude.radius_m.is_finite() && exclude.radius_m >= 0.0) {
            return Err(CorrelativeError::InvalidParameter {
                name: "options.exclude.radius_m",
                value: exclude.radius_m,
            });
        }
    }
    Ok(())
}

fn check_positive(name: &'static str, value: f64) -> Result<(), CorrelativeError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(CorrelativeError::InvalidParameter { name, value })
    }
}

/// The floor of `cells` clamped to ±`CELL_LIMIT`, as an integer (0 for NaN). Truncation and a
/// correction instead of `f64::floor`, which without SSE4.1 is a library call: this is in the
/// loop that places every scan point at every rotation.
#[inline]
fn clamp_cell(cells: f64) -> i32 {
    let clamped = cells.clamp(-CELL_LIMIT, CELL_LIMIT);
    let truncated = clamped as i32;
    if f64::from(truncated) > clamped {
        truncated - 1
    } else {
        truncated
    }
}

fn too_large(what: &'static str, amount: f64, limit: f64) -> Result<(), CorrelativeError> {
    if amount > limit {
        Err(CorrelativeError::TooLarge {
            what,
            amount,
            limit,
        })
    } else {
        Ok(())
    }
}

/// A search node: rotation `rotation`, translations [x0, x0 + 2^depth) × [y0, y0 + 2^depth)
/// (clipped to the window), and its bound; for a leaf (depth 0) the bound is its score.
#[derive(Debug, Clone, Copy)]
struct Node {
    rotation: usize,
    x0: i64,
    y0: i64,
    depth: u32,
    bound: f64,
    mean_value: f64,
}

impl Node {
    /// No leaf of the node has a smaller key than this.
    fn key(&self) -> (usize, i64, i64) {
        (self.rotation, self.x0, self.y0)
    }

    /// Whether a leaf under this node might be preferred to `best`: a higher score, or the same
    /// with a smaller key.
    fn may_beat(&self, min_score: f64, best: Option<&Node>) -> bool {
        self.bound >= min_score
            && best.is_none_or(|b| {
                self.bound > b.bound || (self.bound == b.bound && self.key() < b.key())
            })
    }
}

/// Where one rotation's cells lie in [`Lattice`]'s inner and rim lists.
struct RotatedCells {
    inner: std::ops::Range<usize>,
    rim: std::ops::Range<usize>,
}

/// The discretised search: the scan's cells for every rotation and the window's lattice.
struct Lattice {
    initial: Pose2,
    cell_m: f64,
    angular_step_rad: f64,
    linear_steps: i64,
    angular_steps: i64,
    linear2_m2: f64,
    prior_inverse_two_sigma2: Option<f64>,
    exclude: Option<Exclusion>,
    /// The scan's cells at the initial translation, rotation by rotation, split by where the
    /// window's motions can move them.
    rotated: Vec<RotatedCells>,
    /// `inner_indices[h]`: each inner cell's index into depth h's level at the initial
    /// translation, in the order of the rotations' `inner` ranges.
    inner_indices: Vec<Vec<u32>>,
    /// Cells some motion moves off some level's stored rectangle, bounds-checked at each node.
    rim: Vec<[i32; 2]>,
    /// 1 / (points × `VALUE_SCALE`): a sum of values times this is their mean.
    mean_scale: f64,
    min_score: f64,
}

impl Lattice {
    /// The lattice of `window` around `initial` for `scan_points_m` on `grid`, to be scored on
    /// `levels` (depth 0, the base grid, first; then each depth in turn).
    fn new(
        grid: &ProbabilityGrid,
        levels: &[&Level],
        scan_points_m: &[[f64; 2]],
        initial: Pose2,
        window: &SearchWindow,
        options: &SearchOptions,
        min_score: f64,
    ) -> Result<Self, CorrelativeError> {
        check_points(scan_points_m, CorrelativeError::EmptyScan, "a scan point")?;
        if !initial.is_finite() {
            return Err(CorrelativeError::NonFinite("the initial pose"));
        }
        let invalid = |name, value| Err(CorrelativeError::InvalidParameter { name, value });
        if !(window.linear_m.is_finite() && window.linear_m >= 0.0) {
            return invalid("window.linear_m", window.linear_m);
        }
        if !(0.0..=std::f64::consts::PI).contains(&window.angular_rad) {
            return invalid("window.angular_rad", window.angular_rad);
        }
        if let Some(sigma_m) = options.prior_sigma_m {
            check_positive("options.prior_sigma_m", sigma_m)?;
        }
        check_target(options.exclude, min_score)?;
        debug_assert!(levels
            .first()
            .is_some_and(|l| std::ptr::eq(*l, &grid.level)));
        let cell_m = grid.cell_m;
        let angular_step_rad = match options.angular_step_rad {
            Some(step_rad) => {
                check_positive("options.angular_step_rad", step_rad)?;
                step_rad
            }
            None => angular_step_rad(scan_points_m, cell_m),
        };
        let linear_steps = (window.linear_m / cell_m - RATIO_SLACK).ceil().max(0.0);
        too_large("translation steps", linear_steps, MAX_LINEAR_STEPS)?;
        let angular_steps = (window.angular_rad / angular_step_rad - RATIO_SLACK)
            .ceil()
            .max(0.0);
        let rotations = 2.0 * angular_steps + 1.0;
        too_large("rotations", rotations, MAX_ROTATIONS)?;
        too_large(
            "rotated scan cells",
            rotations * scan_points_m.len() as f64,
            MAX_ROTATED_CELLS,
        )?;
        let (linear_steps, angular_steps) = (linear_steps as i64, angular_steps as i64);

        // Each point's cell at every rotation, once: translations are integer offsets of these.
        let base_m = [
            initial.x_m - grid.origin_m[0],
            initial.y_m - grid.origin_m[1],
        ];
        // A cell that no translation x ∈ [−L, L] of the window brings onto the base grid scores
        // 0 at every motion searched, so it is dropped: every bound still bounds every score
        // from above, and every score is the same. A level stores the cells
        // [−offset, size − offset) along each axis; a cell that every translation keeps inside
        // every level's rectangle is read by the innermost loop with one addition and no range
        // test of its own. With a grid padded by 2L ([`ProbabilityGrid::padded`]) that is every
        // cell kept; the rest, the rim, are tested cell by cell. Sums are exact integers.
        let steps = linear_steps;
        let inside_from = |size: fn(&Level) -> usize| {
            let lowest = levels.iter().map(|l| steps - l.offset).max().unwrap_or(0);
            let highest = levels
                .iter()
                .map(|l| size(l) as i64 - l.offset - steps)
                .min()
                .unwrap_or(0);
            (lowest, highest)
        };
        let (inside_x, inside_y) = (inside_from(|l| l.width), inside_from(|l| l.height));
        let within = |c: i64, (lowest, highest): (i64, i64)| c >= lowest && c < highest;
        // The inner cells' indices, one per level, are bounded (`MAX_LEVEL_INDICES`); a search
        // too large for them reads every cell through the rim's bounds tests instead.
        let indexed =
            rotations * scan_points_m.len() as f64 * levels.len() as f64 <= MAX_LEVEL_INDICES;
        let (reach_x, reach_y) = (
            (-steps, grid.width() as i64 + steps),
            (-steps, grid.height() as i64 + steps),
        );
        let mut rotated = Vec::with_capacity(rotations as usize);
        let mut inner_cells: Vec<[i64; 2]> = Vec::new();
        let mut rim = Vec::new();
        for step in -angular_steps..=angular_steps {
            let (sin, cos) = (initial.yaw_rad + step as f64 * angular_step_rad).sin_cos();
            let (inner_start, rim_start) = (inner_cells.len(), rim.len());
            for p in scan_points_m {
                let x = clamp_cell((cos * p[0] - sin * p[1] + base_m[0]) / cell_m);
                let y = clamp_cell((sin * p[0] + cos * p[1] + base_m[1]) / cell_m);
                let (cx, cy) = (i64::from(x), i64::from(y));
                if !(within(cx, reach_x) && within(cy, reach_y)) {
                    continue;
                }
                if indexed && within(cx, inside_x) && within(cy, inside_y) {
                    inner_cells.push([cx, cy]);
                } else {
                    rim.push([x, y]);
                }
            }
            rotated.push(RotatedCells {
                inner: inner_start..inner_cells.len(),
                rim: rim_start..rim.len(),
            });
        }
        // Levels hold at most `MAX_LEVEL_CELLS` cells (the base `MAX_GRID_CELLS`), so every
        // index fits in 32 bits.
        let inner_indices = levels
            .iter()
            .map(|level| {
                let (offset, width) = (level.offset, level.width as i64);
                inner_cells
                    .iter()
                    .map(|c| ((c[1] + offset) * width + c[0] + offset) as u32)
                    .collect()
            })
            .collect();
        Ok(Lattice {
            initial,
            cell_m,
            angular_step_rad,
            linear_steps,
            angular_steps,
            linear2_m2: window.linear_m * window.linear_m,
            prior_inverse_two_sigma2: options
                .prior_sigma_m
                .map(|sigma_m| 1.0 / (2.0 * sigma_m * sigma_m)),
            exclude: options.exclude,
            rotated,
            inner_indices,
            rim,
            mean_scale: 1.0 / (scan_points_m.len() as f64 * VALUE_SCALE),
            min_score,
        })
    }

    /// [`Lattice::new`] scored on the base grid alone: the exhaustive search and the plateau.
    fn on_base(
        grid: &ProbabilityGrid,
        scan_points_m: &[[f64; 2]],
        initial: Pose2,
        window: &SearchWindow,
        options: &SearchOptions,
        min_score: f64,
    ) -> Result<Self, CorrelativeError> {
        let levels = [&grid.level];
        Self::new(
            grid,
            &levels,
            scan_points_m,
            initial,
            window,
            options,
            min_score,
        )
    }

    fn rotations(&self) -> usize {
        (2 * self.angular_steps + 1) as usize
    }

    /// The position of the motion `(x, y)` steps from the initial pose, metres.
    fn position_m(&self, x: i64, y: i64) -> [f64; 2] {
        [
            self.initial.x_m + x as f64 * self.cell_m,
            self.initial.y_m + y as f64 * self.cell_m,
        ]
    }

    fn excluded(&self, x: i64, y: i64, slack_m: f64) -> bool {
        self.exclude.is_some_and(|e| {
            let p = self.position_m(x, y);
            (p[0] - e.center_m[0]).hypot(p[1] - e.center_m[1]) < e.radius_m - slack_m
        })
    }

    /// Every leaf (a single motion) in the window's disc and outside the exclusion, scored from
    /// the base `level`, in key order: rotation, then x, then y.
    fn leaves<'a>(&'a self, level: &'a Level) -> impl Iterator<Item = Node> + 'a {
        let steps = self.linear_steps;
        (0..self.rotations()).flat_map(move |rotation| {
            (-steps..=steps).flat_map(move |x| {
                (-steps..=steps).filter_map(move |y| self.node(level, rotation, x, y, 0))
            })
        })
    }

    /// The node of `rotation` over the block of 2^`depth` translations starting at (x0, y0), with
    /// its bound from `level` (which must be that depth's); `None` when no leaf of the block is
    /// in the window's disc, or all are excluded.
    fn node(&self, level: &Level, rotation: usize, x0: i64, y0: i64, depth: u32) -> Option<Node> {
        let nearest2 = self.admit(x0, y0, depth)?;
        let sum = self.sum_at(level, depth, rotation, x0, y0);
        Some(self.scored_node(rotation, x0, y0, depth, nearest2, sum))
    }

    /// Whether some leaf of the block of 2^`depth` translations starting at (x0, y0) is in the
    /// window's disc and not excluded: the squared distance (m²) of the block's offset nearest
    /// the initial pose, where the disc and the prior are judged, or `None`.
    fn admit(&self, x0: i64, y0: i64, depth: u32) -> Option<f64> {
        let x1 = (x0 + (1 << depth) - 1).min(self.linear_steps);
        let y1 = (y0 + (1 << depth) - 1).min(self.linear_steps);
        let nearest = |a: i64, b: i64| if b < 0 { b } else { a.max(0) };
        let (nx, ny) = (nearest(x0, x1), nearest(y0, y1));
        let nearest2 = (nx * nx + ny * ny) as f64 * self.cell_m * self.cell_m;
        if nearest2 > self.linear2_m2 {
            return None;
        }
        if depth == 0 {
            if self.excluded(x0, y0, 0.0) {
                return None;
            }
        } else if self.exclude.is_some() {
            // The distance to the centre is convex, so the block's farthest leaf is a corner. A
            // little slack keeps rounding from dropping a block whose corner is just outside.
            let slack_m = 1e-9 * (1.0 + self.exclude.map_or(0.0, |e| e.radius_m));
            if [(x0, y0), (x0, y1), (x1, y0), (x1, y1)]
                .iter()
                .all(|&(x, y)| self.excluded(x, y, slack_m))
            {
                return None;
            }
        }
        Some(nearest2)
    }

    /// The node of an admitted block (`nearest2` from [`Self::admit`]) whose cells' values sum
    /// to `sum`.
    fn scored_node(
        &self,
        rotation: usize,
        x0: i64,
        y0: i64,
        depth: u32,
        nearest2: f64,
        sum: u64,
    ) -> Node {
        let mean_value = sum as f64 * self.mean_scale;
        let prior = self
            .prior_inverse_two_sigma2
            .map_or(1.0, |k| (-nearest2 * k).exp());
        Node {
            rotation,
            x0,
            y0,
            depth,
            bound: mean_value * prior,
            mean_value,
        }
    }

    /// The nodes of `rotation` over the blocks of 2^`depth` translations starting at `starts`
    /// that [`Self::admit`] admits, in that order, into `out`: [`Self::node`] of each, with the
    /// sums of up to four blocks taken in one pass over the scan's cells. Four gathers per cell
    /// index instead of one keep more loads in flight, and a node's four children read
    /// neighbouring cells, mostly on the same cache lines.
    fn nodes_at(
        &self,
        level: &Level,
        rotation: usize,
        depth: u32,
        starts: impl IntoIterator<Item = (i64, i64)>,
        out: &mut Vec<Node>,
    ) {
        let mut batch: [(i64, i64, f64); 4] = [(0, 0, 0.0); 4];
        let mut count = 0;
        let flush = |batch: &[(i64, i64, f64)], out: &mut Vec<Node>| {
            let sums = self.sums_at(level, depth, rotation, batch);
            for (&(x0, y0, nearest2), &sum) in batch.iter().zip(&sums) {
                out.push(self.scored_node(rotation, x0, y0, depth, nearest2, sum));
            }
        };
        for (x0, y0) in starts {
            if let Some(nearest2) = self.admit(x0, y0, depth) {
                batch[count] = (x0, y0, nearest2);
                count += 1;
                if count == batch.len() {
                    flush(&batch, out);
                    count = 0;
                }
            }
        }
        if count > 0 {
            flush(&batch[..count], out);
        }
    }

    /// [`Self::sum_at`] of up to four blocks `at` (x0, y0, ·) of one rotation and depth, in one
    /// pass over the inner cells; integer sums, so the same whatever the order.
    fn sums_at(
        &self,
        level: &Level,
        depth: u32,
        rotation: usize,
        at: &[(i64, i64, f64)],
    ) -> [u64; 4] {
        let cells = &self.rotated[rotation];
        let width = level.width as i64;
        // Fewer than four blocks repeat the last one; its extra sums are not returned.
        let shift = |k: usize| {
            let (x0, y0, _) = at[k.min(at.len() - 1)];
            y0 * width + x0
        };
        let shifts = [shift(0), shift(1), shift(2), shift(3)];
        let mut sums = [0u64; 4];
        for &index in &self.inner_indices[depth as usize][cells.inner.clone()] {
            let index = i64::from(index);
            for (sum, shift) in sums.iter_mut().zip(shifts) {
                *sum += u64::from(level.values[(index + shift) as usize]);
            }
        }
        for (sum, &(x0, y0, _)) in sums.iter_mut().zip(at) {
            *sum += level.sum_at(&self.rim[cells.rim.clone()], x0, y0);
        }
        sums
    }

    /// The sum of `level`'s values (depth `depth`) at the scan's cells at `rotation`, translated
    /// by (`x0`, `y0`) steps: a node's score before scaling, the innermost loop of every search.
    #[inline]
    fn sum_at(&self, level: &Level, depth: u32, rotation: usize, x0: i64, y0: i64) -> u64 {
        let cells = &self.rotated[rotation];
        let shift = y0 * level.width as i64 + x0;
        let inner: u64 = self.inner_indices[depth as usize][cells.inner.clone()]
            .iter()
            .map(|&index| u64::from(level.values[(i64::from(index) + shift) as usize]))
            .sum();
        inner + level.sum_at(&self.rim[cells.rim.clone()], x0, y0)
    }

    /// Branch and bound from the coarsest level of `grids`; the best leaf and the number of nodes
    /// scored.
    fn branch_and_bound(
        &self,
        grids: &MultiResolutionGrid,
        enough: &dyn Fn(f64) -> bool,
    ) -> Result<(Option<Match>, u64), CorrelativeError> {
        let depth = grids.depth();
        let size = 1i64 << depth;
        let per_axis = (2 * self.linear_steps + 1 + size - 1) / size;
        too_large(
            "root nodes",
            (per_axis * per_axis) as f64 * self.rotations() as f64,
            MAX_ROOT_NODES,
        )?;
        let level = grids.level(depth);
        let mut roots = Vec::new();
        for rotation in 0..self.rotations() {
            let starts = (0..per_axis).flat_map(|i| {
                (0..per_axis)
                    .map(move |j| (-self.linear_steps + i * size, -self.linear_steps + j * size))
            });
            self.nodes_at(level, rotation, depth, starts, &mut roots);
        }
        let mut scored = roots.len() as u64;
        let mut best = None;
        self.descend(grids, roots, &mut best, &mut scored, enough);
        Ok((best.map(|leaf| self.to_match(&leaf)), scored))
    }

    /// Visits `nodes` best bound first (then smallest key), descending into those that may beat
    /// the best leaf so far; true (and the search is over) once a best leaf's score is `enough`.
    fn descend(
        &self,
        grids: &MultiResolutionGrid,
        mut nodes: Vec<Node>,
        best: &mut Option<Node>,
        scored: &mut u64,
        enough: &dyn Fn(f64) -> bool,
    ) -> bool {
        nodes.sort_unstable_by(|a, b| b.bound.total_cmp(&a.bound).then(a.key().cmp(&b.key())));
        for node in nodes {
            // Sorted by bound, then key: once a node cannot beat the best, no later one can
            // (and the best only gets harder to beat).
            if !node.may_beat(self.min_score, best.as_ref()) {
                break;
            }
            if node.depth == 0 {
                *best = Some(node);
                if enough(node.bound) {
                    return true;
                }
                continue;
            }
            let depth = node.depth - 1;
            let half = 1i64 << depth;
            let level = grids.level(depth);
            let mut children = Vec::with_capacity(4);
            let starts = [(0, 0), (0, half), (half, 0), (half, half)]
                .into_iter()
                .map(|(dx, dy)| (node.x0 + dx, node.y0 + dy))
                .filter(|&(x0, y0)| x0 <= self.linear_steps && y0 <= self.linear_steps);
            self.nodes_at(level, node.rotation, depth, starts, &mut children);
            *scored += children.len() as u64;
            if self.descend(grids, children, best, scored, enough) {
                return true;
            }
        }
        false
    }

    fn to_match(&self, leaf: &Node) -> Match {
        let rotation_steps = leaf.rotation as i64 - self.angular_steps;
        let [x_m, y_m] = self.position_m(leaf.x0, leaf.y0);
        Match {
            pose: Pose2::new(
                x_m,
                y_m,
                self.initial.yaw_rad + rotation_steps as f64 * self.angular_step_rad,
            ),
            score: leaf.bound,
            mean_value: leaf.mean_value,
            offset_cells: [leaf.x0, leaf.y0],
            rotation_steps,
            angular_step_rad: self.angular_step_rad,
        }
    }
}

/// `empty` for no point, [`CorrelativeError::NonFinite`] naming `point` for a non-finite one.
fn check_points(
    points_m: &[[f64; 2]],
    empty: CorrelativeError,
    point: &'static str,
) -> Result<(), CorrelativeError> {
    if points_m.is_empty() {
        return Err(empty);
    }
    if !points_m
        .iter()
        .all(|p| p[0].is_finite() && p[1].is_finite())
    {
        return Err(CorrelativeError::NonFinite(point));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::f64::consts::PI;

    proptest! {
        /// The fine field's rounding is `f64::round`'s over the values a kernel can take.
        #[test]
        fn round_to_u16_is_rounding(value in 0.0f64..=VALUE_SCALE) {
            prop_assert_eq!(round_to_u16(value), value.round() as u16);
        }
    }

    #[test]
    fn round_to_u16_at_halves_and_ends() {
        for value in [
            0.0,
            0.5,
            1.5,
            2.5,
            0.49999999999999994,
            65534.5,
            65535.0,
            65535.4,
            65535.5,
        ] {
            assert_eq!(round_to_u16(value), value.round() as u16, "{value}");
            let below = f64::from_bits(f64::to_bits(value).saturating_sub(1));
            assert_eq!(round_to_u16(below), below.round() as u16, "{below}");
        }
    }

    /// Outlines of boxes and circles over about 20 m, a point every `spacing_m`.
    fn scene(spacing_m: f64) -> Vec<[f64; 2]> {
        crate::fixtures::outlines(
            &[
                (2.0, 3.0, 4.0, 2.0),
                (9.0, 1.0, 1.5, 3.0),
                (4.0, 9.0, 3.0, 1.0),
                (-6.0, -4.0, 2.0, 5.0),
            ],
            &[(12.0, 8.0, 1.0), (-3.0, 7.0, 0.6), (6.0, -5.0, 1.5)],
            spacing_m,
        )
    }

    fn seen_from(pose: &Pose2, points: &[[f64; 2]]) -> Vec<[f64; 2]> {
        let inverse = pose.inverse();
        points.iter().map(|p| inverse.transform_point(*p)).collect()
    }

    fn grids(points: &[[f64; 2]], cell_m: f64, sigma_m: f64, depth: u32) -> MultiResolutionGrid {
        crate::fixtures::build_grids(points, cell_m, Kernel::Gaussian { sigma_m }, 0, depth)
    }

    /// A window of ±`linear_m` and ±`angular_rad`, searched in rotation steps of `step_rad`.
    fn stepped(linear_m: f64, angular_rad: f64, step_rad: f64) -> (SearchWindow, SearchOptions) {
        let window = SearchWindow {
            linear_m,
            angular_rad,
        };
        let options = SearchOptions {
            angular_step_rad: Some(step_rad),
            ..SearchOptions::default()
        };
        (window, options)
    }

    /// The branch and bound with its count of scored nodes.
    fn counted(
        grids: &MultiResolutionGrid,
        scan: &[[f64; 2]],
        initial: Pose2,
        window: &SearchWindow,
        options: &SearchOptions,
        min_score: f64,
    ) -> (Option<Match>, u64) {
        Lattice::new(
            grids.grid(),
            &grids.levels_from_base(),
            scan,
            initial,
            window,
            options,
            min_score,
        )
        .unwrap()
        .branch_and_bound(grids, &|_| false)
        .unwrap()
    }

    #[test]
    fn padding_keeps_every_value_and_stays_within_the_limits() {
        let points = [[0.0, 0.0], [1.0, 0.5], [0.3, -0.7]];
        let kernel = Kernel::Gaussian { sigma_m: 0.1 };
        let grid = ProbabilityGrid::with_kernel(&points, 0.1, kernel).unwrap();
        let padded = grid.clone().padded(7, 3);
        assert_eq!(padded.level.offset, 7);
        assert_eq!(
            (padded.width(), padded.height(), padded.origin_m()),
            (grid.width(), grid.height(), grid.origin_m())
        );
        for column in -10..grid.width() as i64 + 10 {
            for row in -10..grid.height() as i64 + 10 {
                assert_eq!(padded.value(column, row), grid.value(column, row));
            }
        }
        // A long thin grid whose padding would exceed the limits pads less, and its levels
        // still build.
        let long = [[0.0, 0.0], [400.0, 0.0]];
        let long = ProbabilityGrid::with_kernel(&long, 0.25, Kernel::Hit { cells: 1 }).unwrap();
        let padded = long.padded(4000, 7);
        assert!(
            (1..4000).contains(&padded.level.offset),
            "{}",
            padded.level.offset
        );
        assert!(MultiResolutionGrid::new(padded, 7).is_ok());
    }

    #[test]
    fn grid_values_peak_at_a_point_and_fall_off_with_distance() {
        // The grid starts 3σ = 0.6 m below the lowest point: cells [−0.6 + 0.1 k, …).
        let grid = ProbabilityGrid::new(&[[0.0, 0.0], [0.37, 0.12]], 0.1, 0.2).unwrap();
        let origin_m = grid.origin_m();
        assert!((origin_m[0] + 0.6).abs() < 1e-12 && (origin_m[1] + 0.6).abs() < 1e-12);
        // A point's own cell is worth 1 wherever the point lies in it.
        assert_eq!(grid.value_at_m([0.37, 0.12]), 1.0);
        assert_eq!(grid.value_at_m([0.31, 0.19]), 1.0);
        // The cell [0.6, 0.7) × [0.1, 0.2) is 0.23 m from (0.37, 0.12), along x, and out of
        // reach of (0, 0): worth exp(−d²/2σ²).
        let expected = (-0.23f64.powi(2) / (2.0 * 0.04)).exp();
        assert!((grid.value_at_m([0.65, 0.15]) - expected).abs() < 1e-4);
        assert!((grid.value(12, 7) - expected).abs() < 1e-4);
        // Beyond 3σ, nothing; outside the grid, nothing.
        assert_eq!(grid.value_at_m([0.37 + 0.75, 0.12]), 0.0);
        assert_eq!(grid.value_at_m([50.0, 0.12]), 0.0);
        assert_eq!(grid.value(-1, 0), 0.0);
        // The points' extent plus 3σ either side: (0.97 + 0.6) / 0.1 and (0.72 + 0.6) / 0.1
        // cells, plus the partial cell.
        assert_eq!((grid.width(), grid.height()), (16, 14));
    }

    #[test]
    fn the_hit_kernel_marks_the_cells_around_a_point() {
        let grid = ProbabilityGrid::with_kernel(
            &[[0.0, 0.0], [1.02, 0.51]],
            0.1,
            Kernel::Hit { cells: 1 },
        )
        .unwrap();
        assert_eq!(grid.kernel(), Kernel::Hit { cells: 1 });
        // The grid starts two cells below (0, 0), so (1.02, 0.51) lies in the cell
        // [1.0, 1.1) × [0.5, 0.6): that cell and its eight neighbours are hit, the next ring is
        // not. (Cell centres are probed.)
        for (x, y) in [(1.05, 0.55), (0.95, 0.45), (1.15, 0.65), (0.95, 0.65)] {
            assert_eq!(grid.value_at_m([x, y]), 1.0, "({x}, {y})");
        }
        for (x, y) in [(1.25, 0.55), (0.85, 0.55), (1.05, 0.35), (1.05, 0.75)] {
            assert_eq!(grid.value_at_m([x, y]), 0.0, "({x}, {y})");
        }
        let hits = (0..grid.height() as i64)
            .flat_map(|r| (0..grid.width() as i64).map(move |c| (c, r)))
            .filter(|&(c, r)| grid.value(c, r) == 1.0)
            .count();
        assert_eq!(hits, 18);
        assert!(matches!(
            ProbabilityGrid::with_kernel(&[[0.0, 0.0]], 0.1, Kernel::Hit { cells: 1001 }),
            Err(CorrelativeError::InvalidParameter { .. })
        ));
    }

    #[test]
    fn max_grids_are_the_block_maxima_so_never_underestimate() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let points: Vec<[f64; 2]> = (0..60)
            .map(|_| [rng.random_range(-2.0..3.0), rng.random_range(-1.0..2.0)])
            .collect();
        let grids = grids(&points, 0.1, 0.07, 5);
        let base = grids.grid();
        let (w, h) = (base.width() as i64, base.height() as i64);
        for depth in 0..=5u32 {
            let size = 1i64 << depth;
            for y in -size - 1..h + 2 {
                for x in -size - 1..w + 2 {
                    let mut block_max = 0.0f64;
                    for dy in 0..size {
                        for dx in 0..size {
                            block_max = block_max.max(base.value(x + dx, y + dy));
                        }
                    }
                    let stored = grids.max_value(depth, x, y).unwrap();
                    assert!(stored >= block_max, "depth {depth} ({x}, {y})");
                    assert_eq!(stored, block_max, "depth {depth} ({x}, {y})");
                }
            }
        }
        assert_eq!(grids.max_value(6, 0, 0), None);
        // Some block maxima are below 1 and above 0: the comparison above tested something.
        let some = grids.max_value(2, 3, 3).unwrap();
        assert!(grids.max_value(5, 0, 0).unwrap() > 0.0 && some.is_finite());
    }

    #[test]
    fn a_shifted_and_rotated_scan_is_recovered_within_a_cell_and_a_step() {
        let points = scene(0.1);
        let truth = Pose2::new(1.3, 0.4, 0.25);
        let scan: Vec<[f64; 2]> = seen_from(&truth, &points).into_iter().step_by(3).collect();
        let initial = Pose2::new(truth.x_m + 0.83, truth.y_m - 1.17, truth.yaw_rad + 0.09);
        let window = SearchWindow {
            linear_m: 2.0,
            angular_rad: 0.2,
        };
        for cell_m in [0.1, 0.25] {
            let grids = grids(&points, cell_m, 0.1, 4);
            let found = search(&grids, &scan, initial, &window, 0.5)
                .unwrap()
                .unwrap();
            assert!((found.pose.x_m - truth.x_m).abs() <= cell_m, "{found:?}");
            assert!((found.pose.y_m - truth.y_m).abs() <= cell_m, "{found:?}");
            assert!(found.pose.rotation_to_rad(&truth) <= found.angular_step_rad);
            assert!(found.mean_value > 0.8, "{found:?}");
            // Hess et al.'s step for this scan: the farthest point is ~17 m away.
            assert!(found.angular_step_rad < 0.02 && found.angular_step_rad > 0.004);
        }
    }

    /// A blob 2 m across, a point every 0.1 m, scattered as a metre-scatter radar's outlines
    /// are, and a scan: a ring of radius 0.2 m. The ring lies on hit cells wherever it sits
    /// inside the blob, so every translation of up to ~0.8 m scores the best.
    fn blob_and_ring() -> (MultiResolutionGrid, Vec<[f64; 2]>) {
        let mut blob = Vec::new();
        for i in -10..=10 {
            for j in -10..=10 {
                blob.push([f64::from(i) * 0.1, f64::from(j) * 0.1]);
            }
        }
        let ring: Vec<[f64; 2]> = (0..16)
            .map(|k| {
                let a = f64::from(k) * PI / 8.0;
                [0.2 * a.cos(), 0.2 * a.sin()]
            })
            .collect();
        let grids = crate::fixtures::build_grids(&blob, 0.25, Kernel::Hit { cells: 1 }, 0, 3);
        (grids, ring)
    }

    #[test]
    fn the_plateau_centre_does_not_depend_on_where_the_search_starts() {
        let (grids, ring) = blob_and_ring();
        let (window, options) = stepped(2.5, 0.0, 1f64.to_radians());
        for start in [
            Pose2::new(0.5, 0.25, 0.0),
            Pose2::new(-0.4, 0.3, 0.0),
            Pose2::new(0.1, -0.6, 0.0),
        ] {
            // The arg-max is one point of the flat: ties go to the smallest offset, at its edge.
            let best = exhaustive_search(grids.grid(), &ring, start, &window, &options, 0.0)
                .unwrap()
                .unwrap();
            assert!(best.pose.x_m.hypot(best.pose.y_m) > 0.5, "{best:?}");
            let (centre, motions) =
                plateau_centre(grids.grid(), &ring, start, &window, &options, 0.03)
                    .unwrap()
                    .unwrap();
            assert!(motions > 20, "{motions}");
            // Within a cell: the lattice's steps from the start and the grid's cells need not
            // line up, which skews the flat by up to a cell.
            assert!(
                centre.x_m.hypot(centre.y_m) < 0.25,
                "from {start:?}: {centre:?}"
            );
            assert_eq!(centre.yaw_rad, start.yaw_rad);
        }
    }

    #[test]
    fn on_a_sharp_peak_the_plateau_centre_is_the_best_motion() {
        let points = scene(0.1);
        let truth = Pose2::new(1.3, 0.4, 0.25);
        let scan: Vec<[f64; 2]> = seen_from(&truth, &points).into_iter().step_by(3).collect();
        let initial = Pose2::new(truth.x_m + 0.5, truth.y_m - 0.5, truth.yaw_rad + 0.03);
        // A likelihood field: the hit raster's scores tie between neighbours.
        let grids = grids(&points, 0.25, 0.1, 3);
        let (window, options) = stepped(1.5, 3f64.to_radians(), 1f64.to_radians());
        let best = exhaustive_search(grids.grid(), &scan, initial, &window, &options, 0.0)
            .unwrap()
            .unwrap();
        // Fraction 0 averages the motions tied with the best: here the best alone.
        let (centre, motions) =
            plateau_centre(grids.grid(), &scan, initial, &window, &options, 0.0)
                .unwrap()
                .unwrap();
        assert_eq!(motions, 1);
        assert!(centre.distance_m(&best.pose) < 1e-12, "{centre:?} {best:?}");
        assert!(
            centre.rotation_to_rad(&best.pose) < 1e-12,
            "{centre:?} {best:?}"
        );
        assert!(centre.distance_m(&truth) <= 0.25 * 2f64.sqrt() + 1e-9);
        // A wider fraction takes in the neighbours, which lie around the peak, not to one side.
        let (wider, motions) = plateau_centre(grids.grid(), &scan, initial, &window, &options, 0.3)
            .unwrap()
            .unwrap();
        assert!(motions > 1);
        assert!(wider.distance_m(&truth) < 0.3, "{wider:?}");
    }

    #[test]
    fn a_second_peak_is_not_part_of_the_plateau() {
        let (_, ring) = blob_and_ring();
        // The ring's own points at two places 3 m apart: two equal peaks, nothing between.
        let twice: Vec<[f64; 2]> = ring
            .iter()
            .flat_map(|p| [[p[0] - 1.5, p[1]], [p[0] + 1.5, p[1]]])
            .collect();
        let grids = crate::fixtures::build_grids(&twice, 0.25, Kernel::Hit { cells: 1 }, 0, 3);
        let (window, options) = stepped(2.5, 0.0, 0.1);
        let start = Pose2::new(0.1, 0.05, 0.0);
        let best = exhaustive_search(grids.grid(), &ring, start, &window, &options, 0.0)
            .unwrap()
            .unwrap();
        let (centre, _) = plateau_centre(grids.grid(), &ring, start, &window, &options, 0.03)
            .unwrap()
            .unwrap();
        // The mean of both peaks would be near the start, where the ring fits neither.
        assert!(centre.x_m.abs() > 1.0, "{centre:?}");
        // The best's peak: the one the first of the tied motions lies on.
        assert_eq!(centre.x_m.signum(), best.pose.x_m.signum(), "{best:?}");
        assert!(
            (centre.x_m.abs() - 1.5).hypot(centre.y_m) < 0.25,
            "{centre:?}"
        );
    }

    #[test]
    fn a_plateau_fraction_outside_0_to_1_or_an_empty_window_is_handled() {
        let (grids, ring) = blob_and_ring();
        let (window, options) = stepped(1.0, 0.0, 0.1);
        for fraction in [-0.1, 1.5, f64::NAN] {
            assert!(matches!(
                plateau_centre(
                    grids.grid(),
                    &ring,
                    Pose2::default(),
                    &window,
                    &options,
                    fraction
                ),
                Err(CorrelativeError::InvalidParameter { .. })
            ));
        }
        // Far from the blob nothing scores: no centre, not a NaN one.
        let away = Pose2::new(50.0, 50.0, 0.0);
        assert_eq!(
            plateau_centre(grids.grid(), &ring, away, &window, &options, 0.03).unwrap(),
            None
        );
    }

    #[test]
    fn branch_and_bound_scores_a_small_part_of_the_lattice() {
        let points = scene(0.1);
        let truth = Pose2::new(1.3, 0.4, 0.25);
        let scan: Vec<[f64; 2]> = seen_from(&truth, &points).into_iter().step_by(4).collect();
        let initial = Pose2::new(truth.x_m - 2.1, truth.y_m + 3.3, truth.yaw_rad - 0.1);
        let (window, options) = stepped(6.0, 12f64.to_radians(), 1f64.to_radians());
        let grids = grids(&points, 0.25, 0.25, 4);
        let (found, scored) = counted(&grids, &scan, initial, &window, &options, 0.0);
        let exhaustive =
            exhaustive_search(grids.grid(), &scan, initial, &window, &options, 0.0).unwrap();
        assert_eq!(found, exhaustive);
        // 25 rotations × ~1810 translations in the disc.
        let lattice = 25 * 1810;
        assert!(scored * 20 < lattice, "{scored} of {lattice}");
        assert!(found.unwrap().pose.distance_m(&truth) <= 0.25 * 2f64.sqrt());
    }

    #[test]
    fn ties_go_to_the_smallest_rotation_then_offset() {
        // A line of points along y = 0 from x = 0 to 3 m; one scan point at the scan's origin.
        // Every rotation puts it in the same cell, and every cell on the line is worth 1.
        let line: Vec<[f64; 2]> = (0..=30).map(|i| [f64::from(i) * 0.1, 0.0]).collect();
        let grids = grids(&line, 0.1, 0.05, 3);
        let initial = Pose2::new(1.52, 0.41, 0.0);
        let (window, options) = stepped(1.0, 0.1, 0.05);
        let scan = [[0.0, 0.0]];
        let found = search_with(&grids, &scan, initial, &window, &options, 0.0)
            .unwrap()
            .unwrap();
        let exhaustive = exhaustive_search(grids.grid(), &scan, initial, &window, &options, 0.0)
            .unwrap()
            .unwrap();
        assert_eq!(found, exhaustive);
        assert_eq!(found.rotation_steps, -2);
        assert_eq!(found.score, 1.0);
        // y = 0.41 − 0.4 = 0.01 lies in the line's cells' row; the smallest x offset inside the
        // 1 m disc at dy = −4 cells is −9 (9² + 4² = 97 ≤ 100).
        assert_eq!(found.offset_cells, [-9, -4]);

        // Two leaves worth 1 under the depth-2 root over offsets [−2, 1]², in different children:
        // (−1, −2) in the child visited first, (−2, 0), the smaller key, in a later one whose
        // bound only ties the best found. The search must still descend into it.
        let pair = self::grids(&[[-0.1, -0.2], [-0.2, 0.0]], 0.1, 0.01, 2);
        let window = SearchWindow {
            linear_m: 0.6,
            angular_rad: 0.0,
        };
        let (found, _) = counted(&pair, &scan, Pose2::IDENTITY, &window, &options, 0.0);
        assert_eq!(found.unwrap().offset_cells, [-2, 0]);
        assert_eq!(found.unwrap().score, 1.0);
        let exhaustive =
            exhaustive_search(pair.grid(), &scan, Pose2::IDENTITY, &window, &options, 0.0);
        assert_eq!(found, exhaustive.unwrap());
    }

    #[test]
    fn the_runner_up_tells_a_repetitive_row_from_a_distinct_scene() {
        // Identical boxes every 4 m along x: one pitch away the query fits as well.
        let mut row = Vec::new();
        for k in 0..8 {
            let x0 = 4.0 * f64::from(k);
            for i in 0..10 {
                let s = f64::from(i) * 0.2;
                row.extend([[x0 + s, 0.0], [x0 + s, 2.0], [x0, s], [x0 + 2.0, s]]);
            }
        }
        let query: Vec<[f64; 2]> = row
            .iter()
            .filter(|p| p[0] > 8.0 && p[0] < 20.0)
            .copied()
            .collect();
        let (window, options) = stepped(6.0, 0.1, 0.02);
        let check = |map: &[[f64; 2]], query: &[[f64; 2]], initial: Pose2| {
            let grids = grids(map, 0.25, 0.2, 4);
            let best = search_with(&grids, query, initial, &window, &options, 0.0)
                .unwrap()
                .unwrap();
            let above = |min_score| {
                runner_up(
                    &grids,
                    query,
                    initial,
                    &window,
                    &options,
                    Exclusion::around(&best, 2.0),
                    min_score,
                )
                .unwrap()
            };
            let second = above(0.0).unwrap();
            // Asked only for a runner-up above its own score, the search finds the same one,
            // and just above it, none.
            assert_eq!(above(second.score), Some(second));
            assert_eq!(above(second.score * (1.0 + 1e-9) + 1e-12), None);
            assert!(second.pose.distance_m(&best.pose) >= 2.0);
            let exclude = Exclusion::around(&best, 2.0);
            let reference = exhaustive_search(
                grids.grid(),
                query,
                initial,
                &window,
                &SearchOptions {
                    exclude: Some(exclude),
                    ..options
                },
                0.0,
            )
            .unwrap();
            assert_eq!(Some(second), reference);
            second.score / best.score
        };
        let repetitive = check(&row, &query, Pose2::new(2.0, 0.0, 0.0));
        assert!(repetitive > 0.95, "{repetitive}");
        let points = scene(0.2);
        let truth = Pose2::new(0.5, -0.5, 0.1);
        let distinct = check(&points, &seen_from(&truth, &points), truth);
        assert!(distinct < 0.6, "{distinct}");
    }

    #[test]
    fn bad_inputs_are_errors_not_panics() {
        let points = scene(0.2);
        assert_eq!(
            ProbabilityGrid::new(&[], 0.1, 0.1).unwrap_err(),
            CorrelativeError::EmptyMap
        );
        assert!(matches!(
            ProbabilityGrid::new(&[[0.0, f64::NAN]], 0.1, 0.1),
            Err(CorrelativeError::NonFinite(_))
        ));
        for (cell_m, sigma_m) in [(0.0, 0.1), (-0.1, 0.1), (f64::NAN, 0.1), (0.1, 0.0)] {
            assert!(matches!(
                ProbabilityGrid::new(&points, cell_m, sigma_m),
                Err(CorrelativeError::InvalidParameter { .. })
            ));
        }
        let grid = ProbabilityGrid::new(&points, 0.25, 0.2).unwrap();
        assert!(matches!(
            MultiResolutionGrid::new(grid.clone(), MAX_DEPTH + 1),
            Err(CorrelativeError::InvalidParameter { name: "depth", .. })
        ));
        let grids = MultiResolutionGrid::new(grid, 3).unwrap();
        let window = SearchWindow {
            linear_m: 1.0,
            angular_rad: 0.1,
        };
        let run = |scan: &[[f64; 2]], initial: Pose2, window: SearchWindow, min_score: f64| {
            search(&grids, scan, initial, &window, min_score)
        };
        let id = Pose2::IDENTITY;
        assert_eq!(
            run(&[], id, window, 0.0).unwrap_err(),
            CorrelativeError::EmptyScan
        );
        assert!(matches!(
            run(&[[1.0, 1.0], [f64::NAN, 0.0]], id, window, 0.0),
            Err(CorrelativeError::NonFinite(_))
        ));
        assert!(matches!(
            run(&points, Pose2::new(f64::INFINITY, 0.0, 0.0), window, 0.0),
            Err(CorrelativeError::NonFinite(_))
        ));
        for bad in [
            SearchWindow {
                linear_m: f64::NAN,
                angular_rad: 0.1,
            },
            SearchWindow {
                linear_m: -1.0,
                angular_rad: 0.1,
            },
            SearchWindow {
                linear_m: 1.0,
                angular_rad: 4.0,
            },
        ] {
            assert!(matches!(
                run(&points, id, bad, 0.0),
                Err(CorrelativeError::InvalidParameter { .. })
            ));
        }
        assert!(matches!(
            run(&points, id, window, f64::NAN),
            Err(CorrelativeError::InvalidParameter { .. })
        ));
        for options in [
            SearchOptions {
                prior_sigma_m: Some(0.0),
                ..SearchOptions::default()
            },
            SearchOptions {
                angular_step_rad: Some(f64::NAN),
                ..SearchOptions::default()
            },
            SearchOptions {
                exclude: Some(Exclusion {
                    center_m: [0.0, 0.0],
                    radius_m: f64::NAN,
                }),
                ..SearchOptions::default()
            },
        ] {
            assert!(matches!(
                search_with(&grids, &points, id, &window, &options, 0.0),
                Err(CorrelativeError::InvalidParameter { .. })
            ));
        }
        // A score nobody reaches is no match, not an error.
        assert_eq!(run(&points, id, window, 1.5), Ok(None));
        assert!(angular_step_rad(&[], 0.1).is_nan());
        assert_eq!(suggested_depth(f64::NAN, 0.1), 1);
        assert_eq!(suggested_depth(1e300, 1e-300), 1);
        assert_eq!(suggested_depth(1e6, 0.1), 7);
        // ±6 m on 0.25 m cells: 49 cells wide, blocks of 16.
        assert_eq!(suggested_depth(6.0, 0.25), 4);
        // A scan all at its origin: rotation does not matter, the step is π.
        assert_eq!(angular_step_rad(&[[0.0, 0.0]], 0.1), PI);
    }

    #[test]
    fn huge_coordinates_are_refused_or_handled_without_huge_allocations() {
        // Points 2e9 m apart would need ~10^20 cells: refused before allocating.
        assert!(matches!(
            ProbabilityGrid::new(&[[-1e9, -1e9], [1e9, 1e9]], 0.1, 0.1),
            Err(CorrelativeError::TooLarge { .. })
        ));
        // A blur of a kilometre at 1 cm cells, likewise.
        assert!(matches!(
            ProbabilityGrid::new(&[[0.0, 0.0]], 0.01, 1e3),
            Err(CorrelativeError::TooLarge { .. })
        ));
        // A compact scene far from the origin is an ordinary grid and search.
        let far = Pose2::new(1e9, -1e9, 0.0);
        let points: Vec<[f64; 2]> = scene(0.2).iter().map(|p| far.transform_point(*p)).collect();
        let grids = grids(&points, 0.25, 0.2, 4);
        assert!(grids.grid().width() * grids.grid().height() < 1_000_000);
        let truth = far.compose(&Pose2::new(0.5, 0.5, 0.05));
        let scan = seen_from(&truth, &points);
        let initial = Pose2::new(truth.x_m + 0.6, truth.y_m - 0.4, truth.yaw_rad);
        let window = SearchWindow {
            linear_m: 1.5,
            angular_rad: 0.1,
        };
        let found = search(&grids, &scan, initial, &window, 0.5)
            .unwrap()
            .unwrap();
        assert!(
            found.pose.distance_m(&truth) <= 0.25 * 2f64.sqrt(),
            "{found:?}"
        );
        // A scan a billion metres from the map scores nothing anywhere.
        let lost = Pose2::new(-1e9, 1e9, 0.0);
        assert_eq!(search(&grids, &scan, lost, &window, 0.01), Ok(None));
        let zero = search(&grids, &scan, lost, &window, 0.0).unwrap().unwrap();
        assert_eq!(zero.score, 0.0);
        // Windows that cannot be enumerated are refused.
        let wide = SearchWindow {
            linear_m: 1e9,
            angular_rad: 0.1,
        };
        assert!(matches!(
            search(&grids, &scan, initial, &wide, 0.0),
            Err(CorrelativeError::TooLarge { .. })
        ));
        let fine = SearchOptions {
            angular_step_rad: Some(1e-12),
            ..SearchOptions::default()
        };
        assert!(matches!(
            search_with(&grids, &scan, initial, &window, &fine, 0.0),
            Err(CorrelativeError::TooLarge { .. })
        ));
    }

    /// A random scene: clustered points (so that the grid has structure), a scan of some of them
    /// seen from a random pose plus outliers, an initial pose off the truth, a window, options.
    #[allow(clippy::type_complexity)]
    fn case() -> impl Strategy<
        Value = (
            Vec<[f64; 2]>,
            Vec<[f64; 2]>,
            Pose2,
            f64,
            Kernel,
            SearchWindow,
            SearchOptions,
            u32,
            f64,
        ),
    > {
        (
            prop::collection::vec((-3.0..3.0f64, -3.0..3.0f64), 1..40),
            prop::collection::vec((-4.0..4.0f64, -4.0..4.0f64), 0..5),
            (-0.5..0.5f64, -0.5..0.5f64, -0.5..0.5f64),
            (-1.0..1.0f64, -1.0..1.0f64, -0.2..0.2f64),
            prop::sample::select(vec![0.1, 0.2, 0.3]),
            prop_oneof![
                (0.03..0.4f64).prop_map(|sigma_m| Kernel::Gaussian { sigma_m }),
                (0..3u32).prop_map(|cells| Kernel::Hit { cells }),
            ],
            (0.0..1.5f64, 0.0..0.3f64),
            (
                prop::option::of(0.02..0.1f64),
                prop::option::of(0.2..2.0f64),
                prop::option::of((-1.0..1.0f64, -1.0..1.0f64, 0.0..1.2f64)),
            ),
            0..6u32,
            prop::sample::select(vec![0.0, 0.0, 0.2, 0.5, 0.9]),
        )
            .prop_map(
                |(map, outliers, truth, offset, cell_m, kernel, window, options, depth, min)| {
                    let map: Vec<[f64; 2]> = map.into_iter().map(|(x, y)| [x, y]).collect();
                    let truth = Pose2::new(truth.0, truth.1, truth.2);
                    let mut scan = seen_from(&truth, &map);
                    scan.extend(outliers.into_iter().map(|(x, y)| [x, y]));
                    let initial = Pose2::new(
                        truth.x_m + offset.0,
                        truth.y_m + offset.1,
                        truth.yaw_rad + offset.2,
                    );
                    let window = SearchWindow {
                        linear_m: window.0,
                        angular_rad: window.1,
                    };
                    let (step, prior, exclude) = options;
                    let options = SearchOptions {
                        angular_step_rad: step,
                        prior_sigma_m: prior,
                        exclude: exclude.map(|(dx, dy, radius_m)| Exclusion {
                            center_m: [initial.x_m + dx, initial.y_m + dy],
                            radius_m,
                        }),
                    };
                    (
                        map, scan, initial, cell_m, kernel, window, options, depth, min,
                    )
                },
            )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        /// Stopping at the first motion above a threshold answers "is any motion above it?" as
        /// the full search does: a motion above it exactly when the best is, and the best itself
        /// when none is.
        #[test]
        fn the_first_motion_above_a_threshold_answers_as_the_best_does(
            (map, scan, initial, cell_m, kernel, window, options, depth, min_score) in case(),
            fraction in 0.0..1.2f64,
        ) {
            let grids = crate::fixtures::build_grids(&map, cell_m, kernel, 0, depth);
            let Ok(mut search) = PreparedSearch::new(&grids, &scan, initial, &window, &options)
            else {
                return Ok(());
            };
            let best = search.best_outside(options.exclude, min_score).unwrap();
            let threshold = fraction * best.map_or(1.0, |m| m.score);
            let first = search
                .first_outside_where(options.exclude, min_score, |s| s > threshold)
                .unwrap();
            let above = |m: &Option<Match>| m.is_some_and(|m| m.score > threshold);
            prop_assert_eq!(above(&first), above(&best));
            if !above(&best) {
                prop_assert_eq!(first, best);
            } else {
                prop_assert!(first.unwrap().score <= best.unwrap().score);
            }
        }

        /// Whatever the padding (none, part of the window, or all of it as `for_window` pads):
        /// the same best motion as the exhaustive search of the grid without padding.
        #[test]
        fn branch_and_bound_equals_the_exhaustive_search(
            (map, scan, initial, cell_m, kernel, window, options, depth, min_score) in case(),
            pad_windows in prop::sample::select(vec![0.0, 0.5, 1.0, 2.0]),
        ) {
            let build = |pad| crate::fixtures::build_grids(&map, cell_m, kernel, pad, depth);
            let plain = build(0);
            let slow =
                exhaustive_search(plain.grid(), &scan, initial, &window, &options, min_score);
            let padded = build((pad_windows * window.linear_m / cell_m).ceil() as usize);
            for grids in [&plain, &padded] {
                let fast = search_with(grids, &scan, initial, &window, &options, min_score);
                prop_assert_eq!(fast, slow.clone());
            }
            let padded_slow =
                exhaustive_search(padded.grid(), &scan, initial, &window, &options, min_score);
            prop_assert_eq!(padded_slow, slow);
        }

        /// The cell index by truncation equals the floor, clamped, everywhere: negative and
        /// positive values, integers, the clamp's ends and beyond.
        #[test]
        fn a_cell_index_is_the_clamped_floor(
            value in prop_oneof![
                -1e10..1e10f64,
                -3.0..3.0f64,
                (-5i64..5).prop_map(|k| k as f64),
                Just(CELL_LIMIT),
                Just(-CELL_LIMIT),
                Just(CELL_LIMIT + 0.5),
                Just(-CELL_LIMIT - 0.5),
                Just(-0.0),
                Just(f64::INFINITY),
                Just(f64::NEG_INFINITY),
            ],
        ) {
            let expected = value.floor().clamp(-CELL_LIMIT, CELL_LIMIT) as i32;
            prop_assert_eq!(clamp_cell(value), expected);
        }

        /// A lattice's leaf sums are the grid's values at every scan point's cell moved by the
        /// translation (those it drops included), and a node's sum at depth h is at least every
        /// leaf's of its block: with or without padding, inner cells or rim.
        #[test]
        fn a_lattice_scores_every_cell_and_bounds_its_leaves(
            (map, scan, initial, cell_m, kernel, window, options, depth, _) in case(),
            pad in 0..40usize,
            probes in prop::collection::vec((0.0..1.0f64, 0.0..1.0f64, 0.0..1.0f64), 8),
        ) {
            let grids = crate::fixtures::build_grids(&map, cell_m, kernel, pad, depth);
            let levels = grids.levels_from_base();
            let Ok(lattice) =
                Lattice::new(grids.grid(), &levels, &scan, initial, &window, &options, 0.0)
            else {
                return Ok(());
            };
            let steps = lattice.linear_steps;
            let origin = grids.grid().origin_m();
            let base_m = [initial.x_m - origin[0], initial.y_m - origin[1]];
            let pick = |u: f64, n: i64| ((u * n as f64) as i64).min(n - 1);
            for (u, v, w) in probes {
                let rotation = pick(w, lattice.rotations() as i64) as usize;
                let (x, y) = (pick(u, 2 * steps + 1) - steps, pick(v, 2 * steps + 1) - steps);
                let yaw = initial.yaw_rad
                    + (rotation as i64 - lattice.angular_steps) as f64 * lattice.angular_step_rad;
                let (sin, cos) = yaw.sin_cos();
                let leaf = |x: i64, y: i64| -> u64 {
                    scan.iter()
                        .map(|p| {
                            let column = clamp_cell((cos * p[0] - sin * p[1] + base_m[0]) / cell_m);
                            let row = clamp_cell((sin * p[0] + cos * p[1] + base_m[1]) / cell_m);
                            u64::from(levels[0].get(i64::from(column) + x, i64::from(row) + y))
                        })
                        .sum()
                };
                prop_assert_eq!(lattice.sum_at(levels[0], 0, rotation, x, y), leaf(x, y));
                for (h, level) in levels.iter().enumerate().skip(1) {
                    let bound = lattice.sum_at(level, h as u32, rotation, x, y);
                    for dx in 0..(1i64 << h).min(steps - x + 1) {
                        for dy in 0..(1i64 << h).min(steps - y + 1) {
                            prop_assert!(bound >= leaf(x + dx, y + dy));
                        }
                    }
                }
            }
        }

        #[test]
        fn a_nodes_sum_is_the_sum_of_its_cells_values_inside_and_outside_the_grid(
            points in prop::collection::vec((-2.0..2.0f64, -2.0..2.0f64), 1..20),
            cells in prop::collection::vec((-60..60i32, -60..60i32), 0..40),
            depth in 0..4u32,
            x0 in -30..30i64,
            y0 in -30..30i64,
        ) {
            let points: Vec<[f64; 2]> = points.into_iter().map(|(x, y)| [x, y]).collect();
            let cells: Vec<[i32; 2]> = cells.into_iter().map(|(x, y)| [x, y]).collect();
            let grids = grids(&points, 0.1, 0.1, depth);
            let level = grids.level(depth);
            let expected: u64 = cells
                .iter()
                .map(|c| u64::from(level.get(i64::from(c[0]) + x0, i64::from(c[1]) + y0)))
                .sum();
            prop_assert_eq!(level.sum_at(&cells, x0, y0), expected);
        }

        #[test]
        fn max_grids_are_the_block_maxima_of_random_grids(
            points in prop::collection::vec((-2.0..2.0f64, -2.0..2.0f64), 1..20),
            cell_m in 0.05..0.5f64,
            sigma_m in 0.01..0.5f64,
            depth in 0..4u32,
            x in -20..40i64,
            y in -20..40i64,
        ) {
            let points: Vec<[f64; 2]> = points.into_iter().map(|(x, y)| [x, y]).collect();
            let grids = grids(&points, cell_m, sigma_m, depth);
            let size = 1i64 << depth;
            let mut block_max = 0.0f64;
            for dy in 0..size {
                for dx in 0..size {
                    block_max = block_max.max(grids.grid().value(x + dx, y + dy));
                }
            }
            // Exact, not only an upper bound: a looser bound would prune less, never wrongly.
            prop_assert_eq!(grids.max_value(depth, x, y).unwrap(), block_max);
        }
    }
}
