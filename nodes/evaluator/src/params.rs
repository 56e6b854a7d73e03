//! Parameters of the evaluator node (docs/design.md "Metrics"; paper Table I).

use serde::{Deserialize, Serialize};

use crate::etgospa::{DistanceMode, EtGospaParams};
use crate::InvalidParam;

/// Evaluator parameters (TOML table of the node in the launch file). `Default` is the paper.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// ET-GOPSA/GOSPA cut-off c, metres (square metres with `squared_distance`). Finite, > 0.
    /// Default 5 (Table I; the text uses 10 for Fig. 6).
    pub c_m: f64,
    /// Order p: 1 ≤ p < ∞, or `inf` (TOML) for p = ∞. Default 1 (Table I).
    pub p: f64,
    /// Cardinality parameter α: 0 < α ≤ 2. Default 2 (Table I), which gives the
    /// localisation/missed/false decomposition.
    pub alpha: f64,
    /// D_i measured to the target's sample points (`"samples"`, the paper) or to its outline
    /// (`"outline"`). Default `"samples"`.
    pub distance: DistanceMode,
    /// Use the squared distance inside d^(c), as the paper's eq. (GOPSA_55) literally writes.
    /// Default false.
    pub squared_distance: bool,
    /// Estimate points taken from each map cluster by farthest-point sampling, ≥ 1. Default 4,
    /// matching the paper's 4 sample points per target (Sec. IV-C).
    pub points_per_estimate: u32,
    /// How each map cluster becomes estimate points: `box-corners` (default: the 4 corners of
    /// its principal-axis bounding box), `farthest-point` (`points_per_estimate` points) or
    /// `shape` (the samples of the fitted shapes on `/map/targets`: run a `shapes` node).
    pub representatives: crate::representatives::RepresentativeMode,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            c_m: 5.0,
            p: 1.0,
            alpha: 2.0,
            distance: DistanceMode::Samples,
            squared_distance: false,
            points_per_estimate: 4,
            representatives: crate::representatives::RepresentativeMode::BoxCorners,
        }
    }
}

impl Params {
    /// The metric parameters these give (GOSPA takes c, p, α from them).
    pub fn metric_params(&self) -> EtGospaParams {
        EtGospaParams {
            c: self.c_m,
            p: self.p,
            alpha: self.alpha,
            distance: self.distance,
            squared_distance: self.squared_distance,
        }
    }

    /// Checks every field against its allowed range; the error names the field.
    ///
    /// # Errors
    /// [`InvalidParam`] naming the first bad field (`c_m`, `p`, `alpha`, `points_per_estimate`)
    /// and its allowed range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        if let Err(e) = self.metric_params().validate() {
            // The metric names its own field `c`; the node's is `c_m`.
            let field = if e.field == "c" { "c_m" } else { e.field };
            return Err(InvalidParam::new(field, e.problem, e.allowed));
        }
        if self.points_per_estimate == 0 {
            return Err(InvalidParam::new(
                "points_per_estimate",
                "0",
                ">= 1 (points per map cluster)",
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_paper_and_valid() {
        let p = Params::default();
        assert_eq!((p.c_m, p.p, p.alpha), (5.0, 1.0, 2.0));
        assert_eq!(p.distance, DistanceMode::Samples);
        assert!(!p.squared_distance);
        assert_eq!(p.points_per_estimate, 4);
        p.validate().unwrap();
        // An empty TOML table is the default.
        let parsed: Params = toml::from_str("").unwrap();
        assert_eq!(parsed, p);
    }

    #[test]
    fn toml_fields_and_infinite_p() {
        let parsed: Params = toml::from_str(
            "c_m = 10.0\np = inf\nalpha = 1.0\ndistance = \"outline\"\nsquared_distance = true\npoints_per_estimate = 6",
        )
        .unwrap();
        assert_eq!(parsed.c_m, 10.0);
        assert!(parsed.p.is_infinite());
        assert_eq!(parsed.distance, DistanceMode::Outline);
        parsed.validate().unwrap();
        assert!(
            toml::from_str::<Params>("c = 5.0").is_err(),
            "unknown field accepted"
        );
        assert!(toml::from_str::<Params>("distance = \"hull\"").is_err());
    }

    #[test]
    fn each_bad_field_is_named() {
        let cases = nrslam_runtime::one_bad_field!(Params {
            c_m: [0.0, f64::NAN],
            p: [0.5, f64::NAN, 400.0],
            alpha: [0.0, 2.5],
            points_per_estimate: [0],
        });
        nrslam_runtime::config::assert_each_refused_by_name(cases, Params::validate);
    }
}
