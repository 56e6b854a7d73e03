//! The log-odds occupancy grid and its keyframe update.
//!
//! The paper's mapping module (Sec. III-A, "Location & mapping", and the OGM of Sec. I) fuses the
//! detections of each keyframe into an occupancy grid map. Each cell holds the log-odds
//! `l = ln(p / (1 − p))` of being occupied, starting at 0 (p = 0.5) and marked unknown until some
//! beam observes it. A keyframe's update follows OctoMap's `insertPointCloud`:
//!
//! 1. every detection becomes a world point (docs/conventions.md: `(x + r cos(yaw + boresight + θ),
//!    y + r sin(yaw + boresight + θ))`); a point outside the grid is ignored and counted;
//! 2. the cells holding the points form the *hit* set; with `free_space`, the cells each beam
//!    crosses from the sensor (the AGV centre) up to, not including, its hit cell form the *free*
//!    set, minus the hit set: a cell hit by one beam and crossed by another in the same keyframe
//!    counts as hit, because the crossing beam may have passed beside the object within the cell;
//! 3. each cell of the sets is updated once per keyframe (several echoes from one cell are one
//!    observation, not several): `l ← min(l + l_hit, l_max)` for hits,
//!    `l ← max(l + l_miss, l_min)` for free cells.
//!
//! With `footprint`, step 1 places not one point per detection but samples (every half grid cell)
//! of its radar resolution cell: `range_resolution_m` along the beam × the beam width across it,
//! `beamwidth_deg / |cos θ|` (θ from boresight, capped at 4×), so the hit region grows with range
//! as the radar's uncertainty does (fine in range, coarse in angle; paper Sec. III-B). The samples
//! then go through steps 2–3 like points (each covered cell hit once; free space up to each).
//! `out_of_grid` then counts samples.
//!
//! The clamps bound how confident a cell gets, so the map can change its mind in a few keyframes
//! (with the defaults, a cell at 0.97 falls below 0.5 after 9 misses).
//!
//! The whole keyframe is checked before any cell changes: a NaN detection is an error and leaves
//! the map as it was.

use nrslam_msgs::{Detection, Header, Keyframe, MapMetaData, OccupancyGrid, Pose, Time};

use crate::raycast::{clip_to_box, walk_cells};
use crate::{MapError, Params};

/// A planar pose in the map frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose2 {
    /// x, metres.
    pub x_m: f64,
    /// y, metres.
    pub y_m: f64,
    /// Heading, radians counter-clockwise from +x.
    pub yaw_rad: f64,
}

/// What one keyframe did to the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct IntegrationReport {
    /// Detections in the keyframe.
    pub detections: usize,
    /// Detections whose point fell outside the grid, ignored.
    pub out_of_grid: usize,
    /// Distinct cells updated as hit.
    pub hit_cells: usize,
    /// Distinct cells updated as free.
    pub free_cells: usize,
}

/// The world point of a detection at (`range_m`, `angle_rad` from boresight) seen from an AGV at
/// `pose` whose array boresight is `boresight_rad` from its heading (docs/conventions.md).
pub fn detection_point(pose: Pose2, boresight_rad: f64, range_m: f64, angle_rad: f64) -> [f64; 2] {
    let bearing_rad = pose.yaw_rad + boresight_rad + angle_rad;
    [
        pose.x_m + range_m * bearing_rad.cos(),
        pose.y_m + range_m * bearing_rad.sin(),
    ]
}

/// Log-odds of probability `p`.
/// The ROS occupancy of a cell of log-odds `log_odds`: the percentage `round(100 p)` of
/// `p = 1 / (1 + e^(−l))`, in 0..=100 (0 for NaN). The definition; [`OccupancyMap::occupancy_data`]
/// gets the same values from [`percent_thresholds`] without an `exp` per cell.
pub fn occupancy_percent(log_odds: f64) -> i8 {
    let p = 1.0 / (1.0 + (-log_odds).exp());
    (100.0 * p).round() as i8
}

/// For k = 1..=100, the smallest log-odds whose [`occupancy_percent`] is at least k, found by
/// bisection over the ordered f64 values with `occupancy_percent` itself, so that counting the
/// thresholds at or below a log-odds gives exactly its percentage. Computed once per process.
pub fn percent_thresholds() -> &'static [f64; 100] {
    static THRESHOLDS: std::sync::OnceLock<[f64; 100]> = std::sync::OnceLock::new();
    THRESHOLDS.get_or_init(|| {
        // f64 ↔ i64 keys in f64::total_cmp order (an involution).
        let key = |x: f64| {
            let bits = x.to_bits() as i64;
            bits ^ (((bits >> 63) as u64) >> 1) as i64
        };
        let value = |k: i64| f64::from_bits((k ^ (((k >> 63) as u64) >> 1) as i64) as u64);
        let mut thresholds = [0.0; 100];
        for (slot, percent) in thresholds.iter_mut().zip(1i8..=100) {
            let (mut low, mut high) = (i128::from(key(-1000.0)), i128::from(key(1000.0)));
            while low < high {
                let middle = low + (high - low) / 2;
                if occupancy_percent(value(middle as i64)) >= percent {
                    high = middle;
                } else {
                    low = middle + 1;
                }
            }
            *slot = value(low as i64);
        }
        thresholds
    })
}

/// The `percent` of a cell whose log-odds changed in a batch not yet converted.
const STALE_PERCENT: i8 = i8::MIN;

/// Marks `index` for conversion at the end of the batch, once.
fn mark_stale(percent: &mut [i8], stale: &mut Vec<usize>, index: usize) {
    if percent[index] != STALE_PERCENT {
        percent[index] = STALE_PERCENT;
        stale.push(index);
    }
}

/// [`occupancy_percent`] by counting `thresholds` (from [`percent_thresholds`]).
pub fn occupancy_percent_from(thresholds: &[f64; 100], log_odds: f64) -> i8 {
    thresholds.partition_point(|&t| t <= log_odds) as i8
}

/// Slots of a [`PercentCache`].
const PERCENT_CACHE_SLOTS: usize = 1024;

/// [`occupancy_percent_from`] of recently converted log-odds, by their bits (direct-mapped):
/// the updates from 0 by the same hit and miss steps between the same clamps reach the same
/// few hundred values over and over, and a hit here costs a multiply and a load against the
/// seven dependent steps of the thresholds' binary search.
#[derive(Debug, Clone)]
struct PercentCache {
    /// The log-odds' bits per slot; initially a NaN's, whose percentage (0) `values` holds,
    /// so an empty slot answers correctly too.
    keys: Box<[u64; PERCENT_CACHE_SLOTS]>,
    values: Box<[i8; PERCENT_CACHE_SLOTS]>,
}

impl PercentCache {
    const EMPTY: u64 = u64::MAX;

    fn new(thresholds: &[f64; 100]) -> Self {
        let empty = occupancy_percent_from(thresholds, f64::from_bits(Self::EMPTY));
        PercentCache {
            keys: Box::new([Self::EMPTY; PERCENT_CACHE_SLOTS]),
            values: Box::new([empty; PERCENT_CACHE_SLOTS]),
        }
    }

    #[inline]
    fn percent(&mut self, thresholds: &[f64; 100], log_odds: f64) -> i8 {
        let bits = log_odds.to_bits();
        let slot = (bits.wrapping_mul(0x9e37_79b9_7f4a_7c15) >> 54) as usize;
        if self.keys[slot] != bits {
            self.keys[slot] = bits;
            self.values[slot] = occupancy_percent_from(thresholds, log_odds);
        }
        self.values[slot]
    }
}

fn logit(p: f64) -> f64 {
    (p / (1.0 - p)).ln()
}

/// A log-odds occupancy grid over a fixed rectangle of the map frame.
///
/// Cells are stored row-major from the origin corner, x fastest, the layout of
/// `nav_msgs/OccupancyGrid`: cell (column i, row j) covers
/// `[origin_x + i·r, origin_x + (i+1)·r) × [origin_y + j·r, origin_y + (j+1)·r)`.
#[derive(Debug, Clone)]
pub struct OccupancyMap {
    resolution_m: f64,
    origin_x_m: f64,
    origin_y_m: f64,
    width_cells: usize,
    height_cells: usize,
    hit_log_odds: f64,
    miss_log_odds: f64,
    min_log_odds: f64,
    max_log_odds: f64,
    free_space: bool,
    /// Resolution-cell footprint: (range extent m, boresight beam width rad), if enabled.
    footprint: Option<(f64, f64)>,
    log_odds: Vec<f64>,
    /// Per cell, what the published grid says: −1 never observed, else round(100·p) of
    /// `log_odds`, or [`STALE_PERCENT`] while a batch of updates is under way. Kept up to date
    /// by every update, so publishing copies it rather than converting every cell of the grid
    /// per keyframe (most cells do not change between two).
    percent: Vec<i8>,
    /// Cells whose `percent` is [`STALE_PERCENT`], each once: converted when the batch ends, so
    /// that a rebuild from hundreds of keyframes converts each cell once, not once per keyframe
    /// whose beams cross it.
    stale: Vec<usize>,
    /// True while [`Self::integrate_keyframes`] defers the conversion to its end.
    deferring: bool,
    thresholds: &'static [f64; 100],
    /// Recent conversions of log-odds to percentages.
    percent_cache: PercentCache,
    /// Per cell, the last update that touched it: `3·update + 1` in the hit set, `+ 2` in the free
    /// set, `+ 3` hit and already applied. Membership tests for the per-keyframe sets in O(1),
    /// without sorting or a hash set; the stride of 3 keeps one update's marks apart from the
    /// next's. A byte per cell: the beam walks read a mark at every cell they cross, and bytes
    /// keep the marks of a 300,000-cell grid in the core's cache (u32 marks took 4 × the memory
    /// and a cache miss per crossed cell); before the marks would wrap (after 84 updates) they
    /// are cleared and counting restarts.
    set_mark: Vec<u8>,
    updates: u8,
    out_of_grid_total: u64,
    /// Scratch: the keyframe's hit cells, reused between keyframes.
    hit_scratch: Vec<(usize, [f64; 2], [i64; 2])>,
}

impl OccupancyMap {
    /// An all-unknown grid as `params` describe it.
    pub fn new(params: &Params) -> Result<Self, nrslam_runtime::InvalidParam> {
        params.validate()?;
        // validate() bounds the cell count by MAX_CELLS, so both fit in usize.
        let width_cells = params.width_cells() as usize;
        let height_cells = params.height_cells() as usize;
        let cells = width_cells * height_cells;
        Ok(Self {
            resolution_m: params.resolution_m,
            origin_x_m: params.origin_x_m,
            origin_y_m: params.origin_y_m,
            width_cells,
            height_cells,
            hit_log_odds: logit(params.hit_probability),
            miss_log_odds: logit(params.miss_probability),
            min_log_odds: logit(params.clamp_min_probability),
            max_log_odds: logit(params.clamp_max_probability),
            free_space: params.free_space,
            footprint: params
                .footprint
                .then(|| (params.range_resolution_m, params.beamwidth_deg.to_radians())),
            log_odds: vec![0.0; cells],
            percent: vec![-1; cells],
            stale: Vec::new(),
            deferring: false,
            thresholds: percent_thresholds(),
            percent_cache: PercentCache::new(percent_thresholds()),
            set_mark: vec![0; cells],
            updates: 0,
            out_of_grid_total: 0,
            hit_scratch: Vec::new(),
        })
    }

    /// Cell edge, metres.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// Map-frame (x, y) of the grid's lower-left corner, metres.
    pub fn origin_m(&self) -> [f64; 2] {
        [self.origin_x_m, self.origin_y_m]
    }

    /// Columns (cells along x).
    pub fn width_cells(&self) -> usize {
        self.width_cells
    }

    /// Rows (cells along y).
    pub fn height_cells(&self) -> usize {
        self.height_cells
    }

    /// Detections ignored because their point fell outside the grid, over all keyframes.
    pub fn out_of_grid_detections(&self) -> u64 {
        self.out_of_grid_total
    }

    /// (column, row) of the cell holding map point (`x_m`, `y_m`), or None outside the grid.
    pub fn cell_of(&self, x_m: f64, y_m: f64) -> Option<(usize, usize)> {
        let [u, v] = self.to_cell_units([x_m, y_m]);
        // Written so that NaN fails every comparison and lands in None.
        let inside =
            u >= 0.0 && u < self.width_cells as f64 && v >= 0.0 && v < self.height_cells as f64;
        // The casts truncate towards zero, which is floor for u, v ≥ 0; min() guards the case
        // where u rounds up to width within the last cell.
        inside.then(|| {
            (
                (u as usize).min(self.width_cells - 1),
                (v as usize).min(self.height_cells - 1),
            )
        })
    }

    /// Map-frame centre of cell (`column`, `row`), metres.
    pub fn cell_centre(&self, column: usize, row: usize) -> [f64; 2] {
        [
            self.origin_x_m + (column as f64 + 0.5) * self.resolution_m,
            self.origin_y_m + (row as f64 + 0.5) * self.resolution_m,
        ]
    }

    /// Occupancy probability of cell (`column`, `row`); None if never observed or outside the grid.
    pub fn probability(&self, column: usize, row: usize) -> Option<f64> {
        self.log_odds_at(column, row)
            .map(|l| 1.0 / (1.0 + (-l).exp()))
    }

    /// Log-odds of cell (`column`, `row`); None if never observed or outside the grid.
    pub fn log_odds_at(&self, column: usize, row: usize) -> Option<f64> {
        if column >= self.width_cells || row >= self.height_cells {
            return None;
        }
        let index = row * self.width_cells + column;
        (self.percent[index] != -1).then(|| self.log_odds[index])
    }

    /// Integrates one keyframe: the AGV pose estimate, the array boresight and the detections.
    pub fn integrate_keyframe(
        &mut self,
        keyframe: &Keyframe,
    ) -> Result<IntegrationReport, MapError> {
        let (x_m, y_m, yaw_rad) = keyframe.pose.planar();
        self.integrate_detections(
            Pose2 { x_m, y_m, yaw_rad },
            keyframe.boresight_rad,
            &keyframe.detections,
        )
    }

    /// Integrates detections (range, angle from boresight) taken from `pose`, the sensor at the AGV
    /// centre.
    ///
    /// # Errors
    /// [`MapError::NonFinitePose`] or [`MapError::InvalidDetection`] (NaN or infinite range or
    /// angle, or a negative range); the map is then unchanged. A zero range is valid: the hit is the
    /// sensor's own cell and no cell is free.
    pub fn integrate_detections(
        &mut self,
        pose: Pose2,
        boresight_rad: f64,
        detections: &[Detection],
    ) -> Result<IntegrationReport, MapError> {
        if !(pose.x_m.is_finite()
            && pose.y_m.is_finite()
            && pose.yaw_rad.is_finite()
            && boresight_rad.is_finite())
        {
            return Err(MapError::NonFinitePose {
                x_m: pose.x_m,
                y_m: pose.y_m,
                yaw_rad: pose.yaw_rad,
                boresight_rad,
            });
        }
        if let Some((index, d)) = detections
            .iter()
            .enumerate()
            .find(|(_, d)| !(d.range_m.is_finite() && d.range_m >= 0.0 && d.angle_rad.is_finite()))
        {
            return Err(MapError::InvalidDetection {
                index,
                range_m: d.range_m,
                angle_rad: d.angle_rad,
            });
        }
        let mut points: Vec<[f64; 2]> = Vec::with_capacity(detections.len());
        for d in detections {
            match self.footprint {
                None => points.push(detection_point(pose, boresight_rad, d.range_m, d.angle_rad)),
                Some((range_extent_m, beamwidth_rad)) => {
                    // Sample the polar resolution cell at about half a grid cell, so that every
                    // grid cell it covers receives a sample; the beam widens off boresight as
                    // 1/cos(angle) (capped at 4×, near endfire the ULA has no usable beam).
                    let width_rad = beamwidth_rad / d.angle_rad.cos().abs().max(0.25);
                    let step_m = 0.5 * self.resolution_m;
                    let range_steps = (range_extent_m / step_m).ceil().max(1.0) as usize;
                    let arc_m = d.range_m * width_rad;
                    let angle_steps = (arc_m / step_m).ceil().clamp(1.0, 1000.0) as usize;
                    for i in 0..=range_steps {
                        let r = d.range_m + range_extent_m * (i as f64 / range_steps as f64 - 0.5);
                        for j in 0..=angle_steps {
                            let a = d.angle_rad + width_rad * (j as f64 / angle_steps as f64 - 0.5);
                            points.push(detection_point(pose, boresight_rad, r.max(0.0), a));
                        }
                    }
                }
            }
        }
        let mut report = self.integrate_points([pose.x_m, pose.y_m], &points)?;
        report.detections = detections.len();
        Ok(report)
    }

    /// Integrates hits at map points `points` seen from `sensor` (map frame, metres): the update
    /// of the module docs. Sensor-agnostic; [`Self::integrate_detections`] feeds it.
    ///
    /// # Errors
    /// [`MapError::NonFinitePoint`] if the sensor or any point is NaN or infinite (a finite
    /// detection can still overflow to an infinite point); the map is then unchanged.
    pub fn integrate_points(
        &mut self,
        sensor: [f64; 2],
        points: &[[f64; 2]],
    ) -> Result<IntegrationReport, MapError> {
        let finite = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
        if !finite(&sensor) {
            return Err(MapError::NonFinitePoint {
                what: "sensor".into(),
                x_m: sensor[0],
                y_m: sensor[1],
            });
        }
        if let Some((index, p)) = points.iter().enumerate().find(|(_, p)| !finite(p)) {
            return Err(MapError::NonFinitePoint {
                what: format!("detection {index}"),
                x_m: p[0],
                y_m: p[1],
            });
        }

        if self.updates >= u8::MAX / 3 - 1 {
            self.set_mark.fill(0);
            self.updates = 0;
        }
        self.updates += 1;
        let hit_mark = 3 * self.updates + 1;
        let free_mark = 3 * self.updates + 2;
        let applied_mark = 3 * self.updates + 3;
        let mut report = IntegrationReport {
            detections: points.len(),
            ..IntegrationReport::default()
        };

        // Hit set first, so that the free walks can skip hit cells.
        let mut hits = std::mem::take(&mut self.hit_scratch);
        hits.clear();
        for point in points {
            match self.cell_of(point[0], point[1]) {
                None => report.out_of_grid += 1,
                Some((column, row)) => {
                    let index = row * self.width_cells + column;
                    hits.push((
                        index,
                        self.to_cell_units(*point),
                        [column as i64, row as i64],
                    ));
                    if self.set_mark[index] != hit_mark {
                        self.set_mark[index] = hit_mark;
                        report.hit_cells += 1;
                    }
                }
            }
        }
        self.out_of_grid_total += report.out_of_grid as u64;

        if self.free_space {
            let sensor_cells = self.to_cell_units(sensor);
            let (width, height) = (self.width_cells as f64, self.height_cells as f64);
            for &(_, end, end_cell) in &hits {
                // Sensor outside the grid: start the walk where the beam enters it.
                let Some((t0, _)) = clip_to_box(sensor_cells, end, width, height) else {
                    continue;
                };
                let start = [
                    sensor_cells[0] + t0 * (end[0] - sensor_cells[0]),
                    sensor_cells[1] + t0 * (end[1] - sensor_cells[1]),
                ];
                // Clamped, because a start on the far edge (u = width) floors to one past the
                // last column.
                let start_cell = [
                    (start[0].floor() as i64).clamp(0, self.width_cells as i64 - 1),
                    (start[1].floor() as i64).clamp(0, self.height_cells as i64 - 1),
                ];
                // The closure owns copies of the scalars and the slices themselves (not
                // references to them, which the compiler reloaded at every cell, unable to tell
                // them from the cells being written).
                let width_cells = self.width_cells;
                let (set_mark, log_odds, percent, stale) = (
                    &mut self.set_mark[..],
                    &mut self.log_odds[..],
                    &mut self.percent[..],
                    &mut self.stale,
                );
                let (miss, floor) = (self.miss_log_odds, self.min_log_odds);
                let mut free_cells = 0;
                let counted = &mut free_cells;
                walk_cells(start, end, start_cell, end_cell, move |column, row| {
                    // The walk stays within the box spanned by two in-grid cells.
                    let index = row as usize * width_cells + column as usize;
                    if set_mark[index] != hit_mark && set_mark[index] != free_mark {
                        set_mark[index] = free_mark;
                        log_odds[index] = (log_odds[index] + miss).max(floor);
                        mark_stale(percent, stale, index);
                        *counted += 1;
                    }
                });
                report.free_cells += free_cells;
            }
        }

        for &(index, _, _) in &hits {
            // Each hit cell once, however many detections fell in it.
            if self.set_mark[index] == hit_mark {
                self.set_mark[index] = applied_mark;
                self.log_odds[index] =
                    (self.log_odds[index] + self.hit_log_odds).min(self.max_log_odds);
                mark_stale(&mut self.percent, &mut self.stale, index);
            }
        }
        self.hit_scratch = hits;
        if !self.deferring {
            self.convert_stale();
        }
        Ok(report)
    }

    /// Integrates keyframes in order, as [`Self::integrate_keyframe`] on each, converting the
    /// published percentages once at the end (the rebuild after a pose-graph correction).
    ///
    /// # Errors
    /// The first keyframe's error, with its index in `keyframes`; the keyframes before it stay
    /// integrated, and the map is consistent.
    pub fn integrate_keyframes<'a>(
        &mut self,
        keyframes: impl IntoIterator<Item = &'a Keyframe>,
    ) -> Result<(), (usize, MapError)> {
        self.deferring = true;
        let result = keyframes
            .into_iter()
            .enumerate()
            .try_for_each(|(index, keyframe)| {
                self.integrate_keyframe(keyframe)
                    .map(|_| ())
                    .map_err(|e| (index, e))
            });
        self.deferring = false;
        self.convert_stale();
        result
    }

    fn convert_stale(&mut self) {
        for &index in &self.stale {
            self.percent[index] = self
                .percent_cache
                .percent(self.thresholds, self.log_odds[index]);
        }
        self.stale.clear();
    }

    /// The grid as `nav_msgs/OccupancyGrid` data: row-major from the origin cell, x fastest;
    /// −1 for never observed cells, else round(100·p).
    pub fn occupancy_data(&self) -> Vec<i8> {
        self.percent.clone()
    }

    /// The whole grid as a message: frame "map", `map_load_time = stamp`, origin at the grid's
    /// corner with zero yaw.
    pub fn to_occupancy_grid(&self, stamp: Time) -> OccupancyGrid {
        OccupancyGrid {
            header: Header::new(stamp, "map"),
            info: MapMetaData {
                map_load_time: stamp,
                // The message's field is f32 (ROS); the grid itself keeps the f64 value.
                resolution: self.resolution_m as f32,
                // validate() bounds width × height by MAX_CELLS < u32::MAX.
                width: self.width_cells as u32,
                height: self.height_cells as u32,
                origin: Pose::from_planar(self.origin_x_m, self.origin_y_m, 0.0),
            },
            data: self.occupancy_data(),
        }
    }

    /// Map point → continuous cell coordinates (the grid corner at (0, 0), one unit per cell).
    fn to_cell_units(&self, point: [f64; 2]) -> [f64; 2] {
        [
            (point[0] - self.origin_x_m) / self.resolution_m,
            (point[1] - self.origin_y_m) / self.resolution_m,
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_threshold_table_agrees_with_the_definition_at_and_around_every_threshold() {
        let thresholds = percent_thresholds();
        assert!(thresholds.windows(2).all(|w| w[0] <= w[1]));
        let special = [
            f64::NEG_INFINITY,
            -1e300,
            -700.0,
            -0.0,
            0.0,
            f64::MIN_POSITIVE,
            700.0,
            1e300,
            f64::INFINITY,
            f64::NAN,
        ];
        let around = thresholds.iter().flat_map(|&t| {
            let up = f64::from_bits(t.to_bits().wrapping_add(1));
            let down = f64::from_bits(t.to_bits().wrapping_sub(1));
            [t, up, down, -t]
        });
        for l in special.into_iter().chain(around) {
            assert_eq!(
                occupancy_percent_from(thresholds, l),
                occupancy_percent(l),
                "log-odds {l:e}"
            );
        }
        // Percentages step by one: 50 % at log-odds 0, 0 and 100 at the ends.
        assert_eq!(occupancy_percent_from(thresholds, 0.0), 50);
        assert_eq!(occupancy_percent_from(thresholds, -50.0), 0);
        assert_eq!(occupancy_percent_from(thresholds, 50.0), 100);
    }

    #[test]
    fn the_percent_cache_answers_as_the_thresholds_do() {
        let thresholds = percent_thresholds();
        let mut cache = PercentCache::new(thresholds);
        // Many values per slot (2000 values, 1024 slots), each asked twice, NaN and the
        // empty slots' key among them.
        let values: Vec<f64> = (0..2000)
            .map(|i| -8.0 + 0.008 * f64::from(i))
            .chain([f64::NAN, f64::from_bits(PercentCache::EMPTY), 0.0, -0.0])
            .collect();
        for _ in 0..2 {
            for &l in &values {
                assert_eq!(cache.percent(thresholds, l), occupancy_percent(l), "{l}");
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(20_000))]
        #[test]
        fn the_threshold_table_agrees_with_the_definition(l in -60.0f64..60.0) {
            prop_assert_eq!(occupancy_percent_from(percent_thresholds(), l), occupancy_percent(l));
        }

        #[test]
        fn the_threshold_table_agrees_for_any_bits(bits in any::<u64>()) {
            let l = f64::from_bits(bits);
            prop_assert_eq!(occupancy_percent_from(percent_thresholds(), l), occupancy_percent(l));
        }
    }
}
