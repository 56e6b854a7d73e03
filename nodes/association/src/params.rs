//! Parameters of the association node, with their validation.
//!
//! The paper (Sec. III-A) names the steps, data association against key frames and location, but
//! gives no numbers for them, so every default here is ours. The correspondence distance (1 m)
//! matches the detection errors of the paper's conditions (ΔR = 0.1 m, Δθ = 1°, i.e. 0.35 m
//! across the beam at 20 m). The metric and the robust scale were chosen on simulated runs like
//! those of `tests/slam.rs` (five scenarios × six seeds, point-to-point and point-to-line, scales
//! 0 to 0.3 m): point-to-line with a 0.1 m scale was best or within 1 cm of the best mean
//! position error on each scenario, and without the kernel (scale 0) every variant was several
//! times worse.

use nrslam_runtime::InvalidParam;
use serde::{Deserialize, Serialize};

/// What a scan point is matched to (see [`crate::icp`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IcpMetric {
    /// The nearest map point.
    PointToPoint,
    /// The foot of the perpendicular on the line fitted around the nearest map point (the point
    /// itself where its neighbourhood is not a line).
    PointToLine,
}

/// Parameters of odometry prediction, scan-to-map ICP and keyframe selection.
///
/// Deserialised from the node's TOML table; unknown keys are an error, missing keys take the
/// default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Run scan-to-map matching. `false` gives pure odometry dead reckoning (a baseline).
    pub scan_matching: bool,
    /// ICP metric: `"point_to_point"` or `"point_to_line"`.
    pub metric: IcpMetric,
    /// Point-to-line only: map neighbours (the point included) a local line is fitted to; only
    /// those within `max_correspondence_m` count.
    pub line_neighbours: u32,
    /// A scan point and its nearest map point form a correspondence only if they are at most this
    /// far apart, metres.
    pub max_correspondence_m: f64,
    /// Maximum ICP iterations per scan.
    pub max_iterations: u32,
    /// ICP has converged when an iteration moves the matched scan points' centroid by less than
    /// this, metres…
    pub convergence_translation_m: f64,
    /// …and by less than this rotation, degrees.
    pub convergence_rotation_deg: f64,
    /// Scale of the Cauchy kernel that down-weights correspondences with large residuals,
    /// metres: a pair whose residual is this large counts half. Widened, within an ICP run, to
    /// the residuals' median-based spread while that is larger (far from the solution); 0 weights
    /// every pair equally (plain least squares).
    pub robust_scale_m: f64,
    /// Fewer correspondences than this in any ICP iteration: keep the odometry prediction.
    pub min_correspondences: u32,
    /// A scan-matching correction that moves the predicted position farther than this is rejected
    /// (the prediction is kept), metres.
    pub max_correction_m: f64,
    /// A scan-matching correction that turns the predicted heading by more than this is rejected
    /// (the prediction is kept), degrees.
    pub max_correction_deg: f64,
    /// Matched scan points whose spread has a smaller-to-larger eigenvalue ratio below this are
    /// treated as collinear (a straight wall or corridor): the translation along the line, which
    /// point-to-point matching cannot observe, is left to odometry. 0 disables the check.
    pub degeneracy_ratio: f64,
    /// A new keyframe when the SLAM position is at least this far from the last keyframe's,
    /// metres.
    pub keyframe_distance_m: f64,
    /// A new keyframe when the SLAM heading differs from the last keyframe's by at least this,
    /// degrees.
    pub keyframe_rotation_deg: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            scan_matching: true,
            metric: IcpMetric::PointToLine,
            line_neighbours: 6,
            max_correspondence_m: 1.0,
            max_iterations: 20,
            convergence_translation_m: 1e-4,
            convergence_rotation_deg: 1e-3,
            robust_scale_m: 0.1,
            min_correspondences: 8,
            max_correction_m: 0.5,
            max_correction_deg: 10.0,
            degeneracy_ratio: 0.01,
            keyframe_distance_m: 1.0,
            keyframe_rotation_deg: 15.0,
        }
    }
}

/// `Ok` when `value` is finite and inside `[min, max]` (or `(min, max]` when `min_exclusive`).
fn check_range(
    field: &'static str,
    value: f64,
    min: f64,
    min_exclusive: bool,
    max: f64,
    allowed: &'static str,
) -> Result<(), InvalidParam> {
    let above_min = if min_exclusive {
        value > min
    } else {
        value >= min
    };
    if value.is_finite() && above_min && value <= max {
        Ok(())
    } else {
        Err(InvalidParam::new(field, format!("is {value}"), allowed))
    }
}

impl Params {
    /// Checks every field; the error names the first offending field and its allowed range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        check_range(
            "max_correspondence_m",
            self.max_correspondence_m,
            0.0,
            true,
            1e3,
            "0 < value <= 1000 (metres)",
        )?;
        // A line needs at least three points to be told from a pair.
        if !(3..=64).contains(&self.line_neighbours) {
            return Err(InvalidParam::new(
                "line_neighbours",
                format!("is {}", self.line_neighbours),
                "3..=64",
            ));
        }
        if !(1..=10_000).contains(&self.max_iterations) {
            return Err(InvalidParam::new(
                "max_iterations",
                format!("is {}", self.max_iterations),
                "1..=10000",
            ));
        }
        check_range(
            "convergence_translation_m",
            self.convergence_translation_m,
            0.0,
            true,
            1.0,
            "0 < value <= 1 (metres)",
        )?;
        check_range(
            "convergence_rotation_deg",
            self.convergence_rotation_deg,
            0.0,
            true,
            10.0,
            "0 < value <= 10 (degrees)",
        )?;
        check_range(
            "robust_scale_m",
            self.robust_scale_m,
            0.0,
            false,
            1e3,
            "0 <= value <= 1000 (metres; 0 disables the kernel)",
        )?;
        // Two distinct correspondences determine a planar rigid transform; fewer never can.
        if !(2..=1_000_000).contains(&self.min_correspondences) {
            return Err(InvalidParam::new(
                "min_correspondences",
                format!("is {}", self.min_correspondences),
                "2..=1000000",
            ));
        }
        check_range(
            "max_correction_m",
            self.max_correction_m,
            0.0,
            true,
            1e3,
            "0 < value <= 1000 (metres)",
        )?;
        check_range(
            "max_correction_deg",
            self.max_correction_deg,
            0.0,
            true,
            180.0,
            "0 < value <= 180 (degrees)",
        )?;
        check_range(
            "degeneracy_ratio",
            self.degeneracy_ratio,
            0.0,
            false,
            0.5,
            "0 <= value <= 0.5 (0 disables the check)",
        )?;
        check_range(
            "keyframe_distance_m",
            self.keyframe_distance_m,
            0.0,
            false,
            1e6,
            "0 <= value <= 1e6 (metres; 0 makes every frame a keyframe)",
        )?;
        check_range(
            "keyframe_rotation_deg",
            self.keyframe_rotation_deg,
            0.0,
            false,
            180.0,
            "0 <= value <= 180 (degrees)",
        )?;
        Ok(())
    }

    /// `convergence_rotation_deg` in radians.
    pub fn convergence_rotation_rad(&self) -> f64 {
        self.convergence_rotation_deg.to_radians()
    }

    /// `max_correction_deg` in radians.
    pub fn max_correction_rad(&self) -> f64 {
        self.max_correction_deg.to_radians()
    }

    /// `keyframe_rotation_deg` in radians.
    pub fn keyframe_rotation_rad(&self) -> f64 {
        self.keyframe_rotation_deg.to_radians()
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
        type Mutation = fn(&mut Params);
        let cases: Vec<(&str, Mutation)> = vec![
            ("max_correspondence_m", |p| p.max_correspondence_m = 0.0),
            ("max_correspondence_m", |p| {
                p.max_correspondence_m = f64::NAN
            }),
            ("max_iterations", |p| p.max_iterations = 0),
            ("line_neighbours", |p| p.line_neighbours = 2),
            ("convergence_translation_m", |p| {
                p.convergence_translation_m = -1.0
            }),
            ("convergence_rotation_deg", |p| {
                p.convergence_rotation_deg = f64::INFINITY
            }),
            ("min_correspondences", |p| p.min_correspondences = 1),
            ("robust_scale_m", |p| p.robust_scale_m = -0.1),
            ("max_correction_m", |p| p.max_correction_m = 0.0),
            ("max_correction_deg", |p| p.max_correction_deg = 181.0),
            ("degeneracy_ratio", |p| p.degeneracy_ratio = 0.9),
            ("keyframe_distance_m", |p| p.keyframe_distance_m = -0.1),
            ("keyframe_rotation_deg", |p| p.keyframe_rotation_deg = 200.0),
        ];
        for (field, mutate) in cases {
            let mut p = Params::default();
            mutate(&mut p);
            let err = p.validate().expect_err(field);
            assert!(err.to_string().contains(field), "{field}: {err}");
        }
    }

    #[test]
    fn parses_from_toml() {
        let parse = |text: &str| {
            nrslam_runtime::parse_params::<Params>(text.parse::<toml::Table>().unwrap())
        };
        let p = parse("metric = \"point_to_point\"\nkeyframe_distance_m = 2.0").unwrap();
        assert_eq!(p.metric, IcpMetric::PointToPoint);
        assert_eq!(p.keyframe_distance_m, 2.0);
        assert_eq!(p.max_iterations, Params::default().max_iterations);
        assert_eq!(parse("").unwrap(), Params::default());
        let err = parse("keyframe_distance = 2.0").unwrap_err().to_string();
        assert!(err.contains("keyframe_distance"), "{err}");
        assert!(parse("metric = \"point_to_plane\"").is_err());
    }

    #[test]
    fn zero_keyframe_thresholds_are_allowed() {
        let p = Params {
            keyframe_distance_m: 0.0,
            keyframe_rotation_deg: 0.0,
            degeneracy_ratio: 0.0,
            ..Params::default()
        };
        p.validate().unwrap();
    }
}
