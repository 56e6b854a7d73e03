//! Parameters of the shape fit and of the tracker.
//!
//! The defaults suit the mapper's 0.1 m cells and the scenes of nrslam (the hall of the paper
//! "Simultaneous Localization and Mapping of Multiple Extended Targets with 5G OFDM sensing" and
//! the random scenes: rectangles with sides of 1–8 m, circles of radius 0.75–2 m). Nothing below
//! is tuned to one layout: the depth prior covers the random scenes' range of short sides.

use serde::{Deserialize, Serialize};

/// Shape-fit and tracker parameters (TOML table of the node in the launch file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Fewest distinct points a segment needs to be fitted. ≥ 3 (two points fix no shape).
    /// Default 4 (the segmenter's `min_samples`).
    pub min_points: u32,
    /// Side of the map's cells, metres: the smallest size a fitted rectangle is given.
    /// Finite, 0.001..=10. Default 0.1.
    pub cell_size_m: f64,
    /// Standard deviation of an error shared by all the cells of one rectangle side, metres,
    /// added to each side offset's variance: the residuals average out independent errors but
    /// not a shared one, such as the quantisation of an edge parallel to the grid. Finite, 0..=10. Default 0.003.
    pub offset_std_m: f64,
    /// How far inside the true outline the occupied cells lie on average, as a multiple of the
    /// band's own spread σ̂ (the RMS distance of the cells to the fitted outline): the mapper's
    /// free-space walks clear the outer half of a band of noisy hits (beams to the hits beyond
    /// the surface cross it) more often than the inner half, so a band fitted through its middle
    /// lies inside the surface, the more so the thicker the band. Every fitted side, and a
    /// circle's radius, is moved out by this × σ̂. Finite, 0..=3. Default 0.6: measured at the
    /// true poses over the hall and random scenes, 0.4–0.8 for the ideal radar at Δθ = 1° and
    /// both 5G chains (docs/shapes.md).
    pub surface_offset_per_std: f64,
    /// Standard deviation of that inward offset from side to side, as a multiple of σ̂: an error
    /// the cells of one side share, which their number does not average out; added to each
    /// side offset's (and a circle radius's) variance with `offset_std_m`. Finite, 0..=3.
    /// Default 0.4 (docs/shapes.md: what makes the centre NEES 2 at the true poses).
    pub offset_std_per_std: f64,
    /// Smallest standard deviation of a point's distance to the outline that the residuals may
    /// claim, metres: a noiseless, perfectly quantised outline would otherwise give a zero
    /// covariance. Finite, 0.001..=10. Default 0.03 (≈ 0.1 m / √12).
    pub min_point_std_m: f64,
    /// Standard deviation of where a seen side ends along its own direction, beyond the point
    /// noise (whose σ̂ is added in quadrature), metres: the end cell lies up to half a cell from
    /// the true corner. Finite, 0..=10. Default 0.03.
    pub extent_std_m: f64,
    /// A side of a rectangle counts as seen when the points closest to it span at least this
    /// along it outside the perpendicular sides' bands (±2.5 point-noise standard deviations),
    /// metres, so that the thick end of a noisy band is not mistaken for a side. Finite,
    /// 0..=100. Default 0.4.
    pub min_side_length_m: f64,
    /// Fewest points on a seen side. ≥ 2. Default 4.
    pub min_side_points: u32,
    /// Two opposite sides closer than this are one thick side, metres: the fit would otherwise
    /// split a noisy band into two thin "sides". Targets thinner than this are fitted from one
    /// side. Finite, 0..=100. Default 0.8 (the scenes' thinnest rectangles are 1 m).
    pub min_opposite_sides_m: f64,
    /// Depth prior for a rectangle seen from one side only: the unseen depth is the seen side's
    /// length clamped to `[unseen_depth_min_m, unseen_depth_max_m]`, metres. Finite,
    /// 0.01..=100, min ≤ max. Default 1.0 (the random scenes' shortest side).
    pub unseen_depth_min_m: f64,
    /// Upper clamp of the depth prior, metres (see `unseen_depth_min_m`). Default 4.0 (the
    /// random scenes' longest short side).
    pub unseen_depth_max_m: f64,
    /// Standard deviation of the depth prior, metres; enters the covariance so that a one-sided
    /// rectangle's centre is not claimed more certain than it is. Finite, 0.01..=100.
    /// Default 1.0 (the short sides of the random scenes span 1–4 m: ±1.5 m around the middle).
    pub unseen_depth_std_m: f64,
    /// A circle fit with a radius above this is "not a circle" (a straight side fitted by a
    /// circle degenerates to a huge radius), metres. Finite, > `min_radius_m`, ≤ 1000.
    /// Default 5.0 (the largest circles of the scenes have 2 m).
    pub max_radius_m: f64,
    /// A circle fit whose radius standard deviation exceeds this fraction of the radius is
    /// refused: its curvature is not significant (a noisy straight side). Finite, > 0, ≤ 100.
    /// Default 0.5 (curvature above zero by two standard deviations).
    pub max_radius_relative_std: f64,
    /// A circle fit with a radius below this is refused, metres. Finite, ≥ 0. Default 0.1.
    pub min_radius_m: f64,
    /// Tracker: a segment is associated with a track only when their centres are at most this
    /// far apart, metres. Finite, > 0, ≤ 1000. Default 3.0 (well under the 5.5 m gap the
    /// scenes keep between targets, well over a centre's shift when a second side is seen).
    pub gate_m: f64,
    /// Tracker: weight of the past in the smoothed circle probability,
    /// `p ← a·p + (1 − a)·p_fit`. 0..=1 (0 follows every fit). Default 0.6.
    pub kind_smoothing: f64,
    /// Tracker: a track changes kind only when the smoothed probability of the other kind
    /// exceeds this (hysteresis). 0.5..=1. Default 0.75.
    pub kind_switch_probability: f64,
    /// Tracker: a track missed in this many successive updates is dropped; until then it keeps
    /// its id (so a target whose segment vanishes for an update or two, e.g. while the map is
    /// rebuilt, keeps it) but is not reported. ≥ 0. Default 3.
    pub max_missed_updates: u32,
    /// Keyframes within this distance of a shape's centre are the ones whose pose errors moved
    /// it: their published pose covariance is added to the shape's (module
    /// [`pose_uncertainty`](crate::pose_uncertainty)), metres. Finite, 0..=1000 (0: only a
    /// keyframe exactly at the centre, i.e. in practice none). Default 20 (the paper's radar
    /// sees scatterers up to 20 m).
    pub pose_support_m: f64,
    /// How much of the supporting keyframes' pose error a fitted shape keeps (module
    /// [`pose_uncertainty`](crate::pose_uncertainty)): 1 if their errors were one error, less
    /// as the fit averages partly independent ones. 0..=1. Default 0.25, measured through SLAM
    /// on the hall and random scenes (docs/shapes.md).
    pub pose_covariance_share: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            min_points: 4,
            cell_size_m: 0.1,
            offset_std_m: 0.003,
            surface_offset_per_std: 0.6,
            offset_std_per_std: 0.4,
            min_point_std_m: 0.03,
            extent_std_m: 0.03,
            min_side_length_m: 0.4,
            min_side_points: 4,
            min_opposite_sides_m: 0.8,
            unseen_depth_min_m: 1.0,
            unseen_depth_max_m: 4.0,
            unseen_depth_std_m: 1.0,
            max_radius_m: 5.0,
            min_radius_m: 0.1,
            max_radius_relative_std: 0.5,
            gate_m: 3.0,
            kind_smoothing: 0.6,
            kind_switch_probability: 0.75,
            max_missed_updates: 3,
            pose_support_m: 20.0,
            pose_covariance_share: 0.25,
        }
    }
}

impl Params {
    /// Checks every field against its allowed range; the error names the field.
    pub fn validate(&self) -> Result<(), nrslam_runtime::InvalidParam> {
        use nrslam_runtime::InvalidParam;
        if self.min_points < 3 {
            return Err(InvalidParam::new(
                "min_points",
                self.min_points.to_string(),
                ">= 3",
            ));
        }
        if self.min_side_points < 2 {
            return Err(InvalidParam::new(
                "min_side_points",
                self.min_side_points.to_string(),
                ">= 2",
            ));
        }
        InvalidParam::check_range("cell_size_m", self.cell_size_m, 0.001, 10.0)?;
        InvalidParam::check_range("offset_std_m", self.offset_std_m, 0.0, 10.0)?;
        InvalidParam::check_range(
            "surface_offset_per_std",
            self.surface_offset_per_std,
            0.0,
            3.0,
        )?;
        InvalidParam::check_range("offset_std_per_std", self.offset_std_per_std, 0.0, 3.0)?;
        InvalidParam::check_range("min_point_std_m", self.min_point_std_m, 0.001, 10.0)?;
        InvalidParam::check_range("extent_std_m", self.extent_std_m, 0.0, 10.0)?;
        InvalidParam::check_range("min_side_length_m", self.min_side_length_m, 0.0, 100.0)?;
        InvalidParam::check_range(
            "min_opposite_sides_m",
            self.min_opposite_sides_m,
            0.0,
            100.0,
        )?;
        InvalidParam::check_range("unseen_depth_min_m", self.unseen_depth_min_m, 0.01, 100.0)?;
        InvalidParam::check_range(
            "unseen_depth_max_m",
            self.unseen_depth_max_m,
            self.unseen_depth_min_m,
            100.0,
        )?;
        InvalidParam::check_range("unseen_depth_std_m", self.unseen_depth_std_m, 0.01, 100.0)?;
        InvalidParam::check_range("min_radius_m", self.min_radius_m, 0.0, 1000.0)?;
        // Equal bounds would leave no radius to accept.
        if !(self.max_radius_m.is_finite()
            && self.max_radius_m > self.min_radius_m
            && self.max_radius_m <= 1000.0)
        {
            return Err(InvalidParam::new(
                "max_radius_m",
                format!("{} m", self.max_radius_m),
                format!(
                    "> min_radius_m = {} and <= 1000 (metres)",
                    self.min_radius_m
                ),
            ));
        }
        if !(self.max_radius_relative_std.is_finite()
            && self.max_radius_relative_std > 0.0
            && self.max_radius_relative_std <= 100.0)
        {
            return Err(InvalidParam::new(
                "max_radius_relative_std",
                self.max_radius_relative_std.to_string(),
                "> 0 and <= 100",
            ));
        }
        if !(self.gate_m.is_finite() && self.gate_m > 0.0 && self.gate_m <= 1000.0) {
            return Err(InvalidParam::new(
                "gate_m",
                format!("{} m", self.gate_m),
                "> 0 and <= 1000 (metres)",
            ));
        }
        InvalidParam::check_range("kind_smoothing", self.kind_smoothing, 0.0, 1.0)?;
        InvalidParam::check_range(
            "kind_switch_probability",
            self.kind_switch_probability,
            0.5,
            1.0,
        )?;
        InvalidParam::check_range("pose_support_m", self.pose_support_m, 0.0, 1000.0)?;
        InvalidParam::check_range(
            "pose_covariance_share",
            self.pose_covariance_share,
            0.0,
            1.0,
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        Params::default().validate().unwrap();
    }

    #[test]
    fn each_bad_field_is_named() {
        let d = Params::default;
        let cases = [
            (
                Params {
                    min_points: 2,
                    ..d()
                },
                "min_points",
            ),
            (
                Params {
                    min_side_points: 1,
                    ..d()
                },
                "min_side_points",
            ),
            (
                Params {
                    cell_size_m: 0.0,
                    ..d()
                },
                "cell_size_m",
            ),
            (
                Params {
                    min_point_std_m: f64::NAN,
                    ..d()
                },
                "min_point_std_m",
            ),
            (
                Params {
                    pose_support_m: f64::INFINITY,
                    ..d()
                },
                "pose_support_m",
            ),
            (
                Params {
                    pose_covariance_share: 1.5,
                    ..d()
                },
                "pose_covariance_share",
            ),
            (
                Params {
                    extent_std_m: -1.0,
                    ..d()
                },
                "extent_std_m",
            ),
            (
                Params {
                    min_side_length_m: f64::INFINITY,
                    ..d()
                },
                "min_side_length_m",
            ),
            (
                Params {
                    min_opposite_sides_m: -1.0,
                    ..d()
                },
                "min_opposite_sides_m",
            ),
            (
                Params {
                    unseen_depth_min_m: 0.0,
                    ..d()
                },
                "unseen_depth_min_m",
            ),
            (
                Params {
                    unseen_depth_max_m: 0.5,
                    ..d()
                },
                "unseen_depth_max_m",
            ),
            (
                Params {
                    unseen_depth_std_m: 0.0,
                    ..d()
                },
                "unseen_depth_std_m",
            ),
            (
                Params {
                    min_radius_m: -0.1,
                    ..d()
                },
                "min_radius_m",
            ),
            (
                Params {
                    max_radius_m: 0.1,
                    ..d()
                },
                "max_radius_m",
            ),
            (Params { gate_m: 0.0, ..d() }, "gate_m"),
            (
                Params {
                    max_radius_relative_std: 0.0,
                    ..d()
                },
                "max_radius_relative_std",
            ),
            (
                Params {
                    kind_smoothing: 1.5,
                    ..d()
                },
                "kind_smoothing",
            ),
            (
                Params {
                    kind_switch_probability: 0.4,
                    ..d()
                },
                "kind_switch_probability",
            ),
        ];
        for (params, field) in cases {
            let err = params.validate().unwrap_err();
            assert!(err.to_string().contains(field), "{err} should name {field}");
        }
    }

    #[test]
    fn toml_fills_defaults_and_refuses_unknown_fields() {
        let p: Params = toml::from_str("gate_m = 2.5").unwrap();
        assert_eq!(
            p,
            Params {
                gate_m: 2.5,
                ..Params::default()
            }
        );
        let err = toml::from_str::<Params>("gate = 2.5").unwrap_err();
        assert!(err.to_string().contains("gate"));
    }
}
