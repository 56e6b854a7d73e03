//! Parameters of the viz node: which parts of the graph it draws and how big.

use nrslam_evaluator::RepresentativeMode;
use nrslam_runtime::InvalidParam;
use serde::{Deserialize, Serialize};

/// Viz parameters (the node's TOML table in a launch file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Draw the truth: subscribe to `/ground_truth/pose` and `/ground_truth/targets` (which a
    /// graph fed by a real robot does not have) for `/ground_truth/path` and
    /// `/ground_truth/markers`. Default true.
    pub ground_truth: bool,
    /// Take `odom → base_link` from `/odom` (REP-105: `map → odom` is then the SLAM correction).
    /// False: `map → odom` is the identity and `odom → base_link` the SLAM pose. Default true.
    pub odometry: bool,
    /// Publish each frame's `/radar/detections` as `/radar/detections_cloud` and the radar's
    /// mounting on `/tf_static`. Default true.
    pub detections: bool,
    /// Publish `/map/segments` as `/map/clusters` markers. Default true.
    pub clusters: bool,
    /// Most poses a path keeps (the oldest are dropped), 1..=1000000. Default 100000.
    pub path_max_poses: u32,
    /// Edge of a drawn map cell (m): the mapper's resolution. Finite, > 0, ≤ 10. Default 0.1.
    pub cell_size_m: f64,
    /// Diameter of a drawn representative point or target sample (m). Finite, > 0, ≤ 10.
    /// Default 0.3.
    pub point_size_m: f64,
    /// Width of a drawn target outline (m). Finite, > 0, ≤ 10. Default 0.05.
    pub line_width_m: f64,
    /// How clusters become representative points, as the evaluator's `representatives`
    /// (`box-corners` or `farthest-point`). Default box-corners.
    pub representatives: RepresentativeMode,
    /// Points per cluster for `farthest-point`, as the evaluator's `points_per_estimate`,
    /// 1..=64. Default 4.
    pub points_per_estimate: u32,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            ground_truth: true,
            odometry: true,
            detections: true,
            clusters: true,
            path_max_poses: 100_000,
            cell_size_m: 0.1,
            point_size_m: 0.3,
            line_width_m: 0.05,
            representatives: RepresentativeMode::default(),
            points_per_estimate: 4,
        }
    }
}

impl Params {
    /// Checks every field against its allowed range; the error names the field.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        if !(1..=1_000_000).contains(&self.path_max_poses) {
            return Err(InvalidParam::new(
                "path_max_poses",
                self.path_max_poses.to_string(),
                "1..=1000000",
            ));
        }
        for (field, value) in [
            ("cell_size_m", self.cell_size_m),
            ("point_size_m", self.point_size_m),
            ("line_width_m", self.line_width_m),
        ] {
            if !(value.is_finite() && value > 0.0 && value <= 10.0) {
                return Err(InvalidParam::new(
                    field,
                    format!("{value} m"),
                    "finite, > 0 and <= 10 (metres)",
                ));
            }
        }
        if !(1..=64).contains(&self.points_per_estimate) {
            return Err(InvalidParam::new(
                "points_per_estimate",
                self.points_per_estimate.to_string(),
                "1..=64",
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_each_bad_field_is_named() {
        Params::default().validate().unwrap();
        let cases = nrslam_runtime::one_bad_field!(Params {
            path_max_poses: [0],
            cell_size_m: [0.0],
            point_size_m: [f64::NAN],
            line_width_m: [11.0],
            points_per_estimate: [65],
        });
        nrslam_runtime::config::assert_each_refused_by_name(cases, Params::validate);
        assert!(toml::from_str::<Params>("ground_truth = false\nfoo = 1").is_err());
        let p: Params = toml::from_str("representatives = \"farthest-point\"").unwrap();
        assert_eq!(p.representatives, RepresentativeMode::FarthestPoint);
    }
}
