//! Parameters of the segmenter node.
//!
//! The paper does not state its DBSCAN parameters (Sec. IV-A only names the method); the defaults
//! below suit the mapper's 0.1 m cells: a 0.5 m radius spans five cells, so a target's outline
//! with gaps of a few cells still forms one cluster, while targets a metre apart stay separate.

use serde::{Deserialize, Serialize};

/// Segmenter parameters (TOML table of the node in the launch file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// DBSCAN neighbourhood radius, metres (distance ≤ eps_m is a neighbour). Finite, > 0.
    /// Default 0.5.
    pub eps_m: f64,
    /// DBSCAN minimum neighbourhood size of a core point, the point itself included. ≥ 1
    /// (1 makes every occupied cell a core point). Default 4.
    pub min_samples: u32,
    /// A cell is occupied when its value is ≥ this, in percent (the OccupancyGrid's unit). 1..=100.
    /// Default 65 (ROS map_server's `occupied_thresh` 0.65).
    pub occupied_threshold: u8,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            eps_m: 0.5,
            min_samples: 4,
            occupied_threshold: 65,
        }
    }
}

impl Params {
    /// Checks every field against its allowed range; the error names the field.
    pub fn validate(&self) -> Result<(), nrslam_runtime::InvalidParam> {
        use nrslam_runtime::InvalidParam;
        // eps_m = 0 is valid for the DBSCAN library (coincident points), but occupied-cell centres
        // are never coincident, so on a map it would only produce noise or singletons.
        if !(self.eps_m.is_finite() && self.eps_m > 0.0) {
            return Err(InvalidParam::new(
                "eps_m",
                format!("{} m", self.eps_m),
                "finite and > 0 (metres)",
            ));
        }
        if self.min_samples == 0 {
            return Err(InvalidParam::new("min_samples", "0", ">= 1"));
        }
        // 0 would make every observed cell occupied, including the ones known to be free.
        if !(1..=100).contains(&self.occupied_threshold) {
            return Err(InvalidParam::new(
                "occupied_threshold",
                format!("{} %", self.occupied_threshold),
                "1..=100 (percent)",
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_documented_values() {
        let p = Params::default();
        assert_eq!((p.eps_m, p.min_samples, p.occupied_threshold), (0.5, 4, 65));
        p.validate().unwrap();
    }

    #[test]
    fn each_bad_field_is_named() {
        let cases = nrslam_runtime::one_bad_field!(Params {
            eps_m: [0.0, f64::NAN],
            min_samples: [0],
            occupied_threshold: [0, 101],
        });
        nrslam_runtime::config::assert_each_refused_by_name(cases, Params::validate);
    }

    #[test]
    fn toml_fills_defaults_and_refuses_unknown_fields() {
        let expected = Params {
            eps_m: 0.8,
            ..Params::default()
        };
        nrslam_runtime::config::assert_toml_fills_defaults(
            "eps_m = 0.8",
            &expected,
            "epsilon = 0.8",
        );
    }
}
