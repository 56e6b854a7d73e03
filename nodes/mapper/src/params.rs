//! Parameters of the occupancy mapper.
//!
//! The paper builds an occupancy grid map (Sec. I and III-A) without stating its sensor model or
//! cell size; the sensor model defaults are OctoMap's (Hornung et al., Auton. Robots 2013:
//! hit 0.7, miss 0.4, clamping 0.1192..0.971, rounded here to 0.12..0.97), the cell size is the
//! 0.1 m the range resolution of Table I (0.122 m) suggests, and the extent, 60 m × 50 m from
//! (−3, −3), covers the 54 m × 44 m hall of docs/scene.md (x 0..54 m, y 0..44 m) with a 3 m margin
//! on every side.

use serde::{Deserialize, Serialize};

/// Largest grid accepted, in cells: 25 million cells (e.g. 500 m × 500 m at 0.1 m) take 225 MB
/// (an f64 log-odds and a flag per cell) and 25 MB per published map. Beyond that a typo in
/// `resolution_m` is more likely than intent.
pub const MAX_CELLS: u64 = 25_000_000;

/// Mapper parameters (TOML table of the node in the launch file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Cell edge, metres. Finite, > 0, and small enough that the grid has at most [`MAX_CELLS`]
    /// cells. Default 0.1.
    pub resolution_m: f64,
    /// Map-frame x of the grid's lower-left corner, metres. Finite. Default −3.
    pub origin_x_m: f64,
    /// Map-frame y of the grid's lower-left corner, metres. Finite. Default −3.
    pub origin_y_m: f64,
    /// Extent along x, metres; the grid has ⌈width_m / resolution_m⌉ columns. Finite, > 0.
    /// Default 60 (the 54 m hall and 3 m either side).
    pub width_m: f64,
    /// Extent along y, metres; ⌈height_m / resolution_m⌉ rows. Finite, > 0. Default 50 (the
    /// 44 m hall and 3 m either side).
    pub height_m: f64,
    /// P(occupied | a detection ends in the cell). In (0.5, 1). Default 0.7.
    pub hit_probability: f64,
    /// P(occupied | a beam crosses the cell). In (0, 0.5). Default 0.4.
    pub miss_probability: f64,
    /// Lower clamp of a cell's occupancy probability, so a cell seen free many times can still turn
    /// occupied within a few hits. In (0, 0.5]. Default 0.12.
    pub clamp_min_probability: f64,
    /// Upper clamp of a cell's occupancy probability, so a cell seen occupied many times can still
    /// turn free within a few misses. In [0.5, 1). Default 0.97.
    pub clamp_max_probability: f64,
    /// Lower the occupancy of the cells each beam crosses before its hit. Default true.
    ///
    /// With it, clutter and cells wrongly hit because of pose or angle error fade when later beams
    /// cross them, and the map tells free from unknown. The cost: a walk of range / resolution
    /// cells per detection (≈ 300 cells for a 30 m echo at 0.1 m), and beams that graze a target at
    /// a shallow angle erode its outline when the angle error exceeds a cell at that range; the
    /// paper's raw maps (Fig. 3) keep every hit. Without it, only hit cells are ever observed.
    pub free_space: bool,
    /// Keep every keyframe and rebuild the grid when `/slam/keyframe_poses` reports a new
    /// pose-graph revision (loop closure). Default true. False subscribes to `/slam/keyframe`
    /// only and keeps no keyframes.
    pub rebuild_on_correction: bool,
    /// Mark the whole radar resolution cell of each detection as hit, not just the cell of its
    /// point: `range_resolution_m` along the beam × the beam width across it, which grows with
    /// range (and with 1/cos of the angle off boresight, as a ULA's beam does). Default false: on
    /// the paper runs the footprint widens far outlines into arcs (measured in docs/slam.md).
    pub footprint: bool,
    /// Range extent of a resolution cell, metres. Default 0.122 (c / (2 N Δf), Table I).
    pub range_resolution_m: f64,
    /// Beam width at boresight, degrees. Default 3.58 (2/32 in sin θ: a 32-element λ/2 ULA).
    pub beamwidth_deg: f64,
    /// Publish the grid after every this many keyframes (1–1000), and always after a rebuild and
    /// at the end. Default 1: every keyframe, as the paper's per-step metrics need. Each
    /// published grid costs the segmenter, shapes and evaluator a whole pass, so a graph that
    /// fuses several agents' keyframes trades the metrics' time resolution for CPU here.
    pub publish_every_keyframes: u32,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            resolution_m: 0.1,
            origin_x_m: -3.0,
            origin_y_m: -3.0,
            width_m: 60.0,
            height_m: 50.0,
            hit_probability: 0.7,
            miss_probability: 0.4,
            clamp_min_probability: 0.12,
            clamp_max_probability: 0.97,
            free_space: true,
            rebuild_on_correction: true,
            footprint: false,
            range_resolution_m: 0.122,
            beamwidth_deg: 3.58,
            publish_every_keyframes: 1,
        }
    }
}

impl Params {
    /// Checks every field against its allowed range; the error names the field.
    pub fn validate(&self) -> Result<(), nrslam_runtime::InvalidParam> {
        use nrslam_runtime::InvalidParam;
        let positive = |field: &'static str, value: f64| {
            if value.is_finite() && value > 0.0 {
                InvalidParam::check_count(
                    "publish_every_keyframes",
                    self.publish_every_keyframes,
                    1,
                    1000,
                )?;
                Ok(())
            } else {
                Err(InvalidParam::new(
                    field,
                    format!("{value} m"),
                    "finite and > 0 (metres)",
                ))
            }
        };
        positive("resolution_m", self.resolution_m)?;
        positive("width_m", self.width_m)?;
        positive("height_m", self.height_m)?;
        for (field, value) in [
            ("origin_x_m", self.origin_x_m),
            ("origin_y_m", self.origin_y_m),
        ] {
            if !value.is_finite() {
                return Err(InvalidParam::new(
                    field,
                    format!("{value} m"),
                    "finite (metres)",
                ));
            }
        }
        positive("range_resolution_m", self.range_resolution_m)?;
        if !(self.beamwidth_deg.is_finite()
            && self.beamwidth_deg > 0.0
            && self.beamwidth_deg <= 90.0)
        {
            return Err(InvalidParam::new(
                "beamwidth_deg",
                format!("{} deg", self.beamwidth_deg),
                "0 < value <= 90 (degrees)",
            ));
        }
        let (columns, rows) = (self.width_cells(), self.height_cells());
        if columns.saturating_mul(rows) > MAX_CELLS {
            return Err(InvalidParam::new(
                "resolution_m",
                format!(
                    "{} m gives {columns} × {rows} cells for {} m × {} m",
                    self.resolution_m, self.width_m, self.height_m
                ),
                format!("at most {MAX_CELLS} cells: a coarser resolution or a smaller extent"),
            ));
        }
        let probability = |field: &'static str,
                           value: f64,
                           low: f64,
                           low_closed: bool,
                           high: f64,
                           high_closed: bool,
                           allowed: &'static str| {
            let above = if low_closed {
                value >= low
            } else {
                value > low
            };
            let below = if high_closed {
                value <= high
            } else {
                value < high
            };
            if above && below {
                Ok(())
            } else {
                Err(InvalidParam::new(field, value.to_string(), allowed))
            }
        };
        probability(
            "hit_probability",
            self.hit_probability,
            0.5,
            false,
            1.0,
            false,
            "(0.5, 1): a hit must raise occupancy",
        )?;
        probability(
            "miss_probability",
            self.miss_probability,
            0.0,
            false,
            0.5,
            false,
            "(0, 0.5): a miss must lower occupancy",
        )?;
        probability(
            "clamp_min_probability",
            self.clamp_min_probability,
            0.0,
            false,
            0.5,
            true,
            "(0, 0.5]",
        )?;
        probability(
            "clamp_max_probability",
            self.clamp_max_probability,
            0.5,
            true,
            1.0,
            false,
            "[0.5, 1)",
        )?;
        Ok(())
    }

    /// Columns of the grid, ⌈width_m / resolution_m⌉ (0 if the parameters are invalid).
    pub fn width_cells(&self) -> u64 {
        cells_for(self.width_m, self.resolution_m)
    }

    /// Rows of the grid, ⌈height_m / resolution_m⌉ (0 if the parameters are invalid).
    pub fn height_cells(&self) -> u64 {
        cells_for(self.height_m, self.resolution_m)
    }
}

/// ⌈extent / resolution⌉, forgiving a quotient within 1e-9 of an integer: 2.1 m at 0.3 m is
/// 7.000000000000001 in f64 and must give 7 cells, not 8.
fn cells_for(extent_m: f64, resolution_m: f64) -> u64 {
    let quotient = extent_m / resolution_m;
    if !(quotient.is_finite() && quotient > 0.0) {
        return 0;
    }
    let nearest = quotient.round();
    let cells = if (quotient - nearest).abs() <= 1e-9 * nearest.max(1.0) {
        nearest
    } else {
        quotient.ceil()
    };
    // Saturates for absurd values, which validate() then refuses.
    cells as u64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_cover_the_hall_with_margin() {
        let p = Params::default();
        p.validate().unwrap();
        assert_eq!((p.width_cells(), p.height_cells()), (600, 500));
        // Hall corners (0, 0) and (54, 44) (docs/scene.md) are inside with 3 m to spare.
        assert!(p.origin_x_m <= -3.0 && p.origin_x_m + p.width_m >= 57.0);
        assert!(p.origin_y_m <= -3.0 && p.origin_y_m + p.height_m >= 47.0);
    }

    #[test]
    fn cell_counts_round_up_but_forgive_float_noise() {
        let p = Params {
            width_m: 1.05,
            height_m: 0.3,
            ..Params::default()
        };
        assert_eq!((p.width_cells(), p.height_cells()), (11, 3));
        let p = Params {
            resolution_m: 0.3,
            width_m: 2.1,
            height_m: 2.15,
            ..Params::default()
        };
        assert_eq!((p.width_cells(), p.height_cells()), (7, 8));
    }

    #[test]
    fn each_bad_field_is_named() {
        let cases = nrslam_runtime::one_bad_field!(Params {
            resolution_m: [0.0, 1e-4],
            width_m: [-1.0],
            height_m: [f64::INFINITY],
            origin_x_m: [f64::NAN],
            origin_y_m: [f64::NEG_INFINITY],
            hit_probability: [0.5, 1.0],
            miss_probability: [0.5, 0.0],
            clamp_min_probability: [0.0],
            clamp_max_probability: [1.0, f64::NAN],
        });
        nrslam_runtime::config::assert_each_refused_by_name(cases, Params::validate);
    }

    #[test]
    fn toml_fills_defaults_and_refuses_unknown_fields() {
        let expected = Params {
            resolution_m: 0.2,
            free_space: false,
            ..Params::default()
        };
        let table = "resolution_m = 0.2\nfree_space = false";
        nrslam_runtime::config::assert_toml_fills_defaults(table, &expected, "resolution = 0.2");
    }
}
