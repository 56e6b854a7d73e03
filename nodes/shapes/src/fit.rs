//! Fitting one segment: both models, then model selection by BIC.
//!
//! **Model selection.** Both a rectangle ([`crate::rectangle`](mod@crate::rectangle)) and a circle
//! ([`crate::circle`](mod@crate::circle)) are fitted; each scores the Bayesian information
//! criterion (G. Schwarz, "Estimating the dimension of a model", Ann. Stat. 6(2), 1978) of a
//! Gaussian residual model with unknown variance,
//!
//! BIC = N ln(RSS / N) + k ln N,
//!
//! N points, RSS the squared distances to the model's outline (the rectangle's four sides as
//! segments; the circle), RSS/N floored at `min_point_std_m²`, k the parameters the points
//! determine: 5 for a rectangle (centre, size, yaw: offsets of seen sides and ends of the seen
//! extents alike), 4 when one side is seen (the depth comes from the prior), 3 for a circle.
//! Counting the extents matters: with a noise band as thick as an arc's sagitta, an L of two
//! lines fits an arc about as well as the circle does, and only its extra parameters tell them
//! apart. The lower BIC wins; `circle_probability` = 1 / (1 + exp((BIC_c − BIC_r)/2)) is
//! the posterior of the circle under equal prior odds (the BIC approximation to the Bayes
//! factor). A circle is not a candidate when its radius leaves `[min_radius_m, max_radius_m]`
//! (a straight side fits a circle of huge radius) or when the arc is concave toward the
//! viewpoints (an outline is seen from outside, so the centre lies beyond the arc); an arc of a
//! circle seen from one side, an L of two sides and one straight side then come out a circle, a
//! rectangle and a rectangle.
//!
//! Points are shifted to their centroid before fitting (map coordinates of tens of metres would
//! otherwise cost digits in the normal equations) and exact duplicates are merged.

use crate::circle::fit_circle;
use crate::geometry::distance_to_boundary;
use crate::rectangle::{bic, fit_rectangle};
use crate::shape::{FittedShape, ShapeKind};
use crate::Params;

/// Why a segment could not be fitted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    /// The parameters are out of range.
    #[error("invalid parameters: {0}")]
    InvalidParams(#[from] nrslam_runtime::InvalidParam),
    /// A point has a NaN or infinite coordinate.
    #[error("point {index} has a non-finite coordinate")]
    NonFinitePoint {
        /// Index of the first offending point.
        index: usize,
    },
    /// A viewpoint has a NaN or infinite coordinate.
    #[error("viewpoint {index} has a non-finite coordinate")]
    NonFiniteViewpoint {
        /// Index of the first offending viewpoint.
        index: usize,
    },
    /// Fewer distinct points than `min_points` (coincident points count once).
    #[error("{distinct} distinct points, at least {min} needed")]
    TooFewPoints {
        /// Distinct points given.
        distinct: usize,
        /// `min_points`.
        min: usize,
    },
    /// Neither model could be fitted (e.g. the points span less than a rounding error).
    #[error("no rectangle or circle fits the {points} points")]
    NoShape {
        /// Distinct points given.
        points: usize,
    },
}

/// Both models' fits of one segment and the selected kind.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidates {
    /// The rectangle fit, if any.
    pub rectangle: Option<FittedShape>,
    /// The circle fit, if a plausible circle exists.
    pub circle: Option<FittedShape>,
    /// The kind with the lower BIC (the only one present, if one is missing).
    pub selected: ShapeKind,
}

impl Candidates {
    /// The selected fit.
    pub fn best(&self) -> &FittedShape {
        self.get(self.selected)
            .expect("the selected kind is always present")
    }

    /// The fit of `kind`, if present.
    pub fn get(&self, kind: ShapeKind) -> Option<&FittedShape> {
        match kind {
            ShapeKind::Rectangle => self.rectangle.as_ref(),
            ShapeKind::Circle => self.circle.as_ref(),
        }
    }
}

/// Fits one segment: the selected model of [`fit_candidates`].
///
/// `points` are the segment's occupied-cell centres, `viewpoints` the sensor positions it was
/// seen from (map frame; may be empty), both in metres.
pub fn fit(
    points: &[[f64; 2]],
    viewpoints: &[[f64; 2]],
    params: &Params,
) -> Result<FittedShape, FitError> {
    fit_candidates(points, viewpoints, params).map(|c| c.best().clone())
}

/// Distinct points shifted to their centroid, and the centroid.
fn centred(points: &[[f64; 2]]) -> (Vec<[f64; 2]>, [f64; 2]) {
    let mut distinct = points.to_vec();
    distinct.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    distinct.dedup();
    let n = distinct.len().max(1) as f64;
    let c = distinct
        .iter()
        .fold([0.0, 0.0], |s, p| [s[0] + p[0] / n, s[1] + p[1] / n]);
    let shifted = distinct
        .iter()
        .map(|p| [p[0] - c[0], p[1] - c[1]])
        .collect();
    (shifted, c)
}

/// Weighted vote on which side of a line through `anchor` with normal `normal` the viewpoints
/// lie: Σ w·sign((v − anchor)·normal), w = 1 / max(|v − anchor|, 1 m)², so the keyframes that
/// were close (and could see the side) count most. > 0: on the normal's side.
fn viewpoint_vote(viewpoints: &[[f64; 2]], anchor: [f64; 2], normal: [f64; 2]) -> f64 {
    viewpoints
        .iter()
        .map(|v| {
            let d = [v[0] - anchor[0], v[1] - anchor[1]];
            let w = 1.0 / (d[0] * d[0] + d[1] * d[1]).max(1.0);
            w * (d[0] * normal[0] + d[1] * normal[1]).signum()
        })
        .sum()
}

/// Fits both models to one segment and selects one (module doc).
pub fn fit_candidates(
    points: &[[f64; 2]],
    viewpoints: &[[f64; 2]],
    params: &Params,
) -> Result<Candidates, FitError> {
    params.validate()?;
    if let Some(index) = points
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(FitError::NonFinitePoint { index });
    }
    if let Some(index) = viewpoints
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(FitError::NonFiniteViewpoint { index });
    }
    let (local, centroid) = centred(points);
    let n = local.len();
    if n < params.min_points as usize {
        return Err(FitError::TooFewPoints {
            distinct: n,
            min: params.min_points as usize,
        });
    }
    let local_viewpoints: Vec<[f64; 2]> = if viewpoints.is_empty() {
        // Without viewpoints the map origin, where the run starts, stands in for the sensor.
        vec![[-centroid[0], -centroid[1]]]
    } else {
        viewpoints
            .iter()
            .map(|v| [v[0] - centroid[0], v[1] - centroid[1]])
            .collect()
    };
    let vote =
        |anchor: [f64; 2], normal: [f64; 2]| viewpoint_vote(&local_viewpoints, anchor, normal);
    let rectangle = fit_rectangle(&local, params, &vote);
    let circle = fit_circle(&local, params).filter(|c| {
        // Concave toward the sensor: the centre lies on the viewpoints' side of the points.
        // Undecidable (and skipped) when the points surround the centre or nothing was given.
        let offset = c.center_m;
        let norm = offset[0].hypot(offset[1]);
        viewpoints.is_empty() || norm < 0.5 * c.radius_m || vote([0.0, 0.0], offset) <= 0.0
    });
    let floor = params.min_point_std_m;
    // The rectangle's residuals are distances to its whole outline, whose 5 parameters all come
    // from the points except a depth set by the prior (one side seen).
    // (Against the bands themselves: the surface correction is not evidence for either model.)
    let rectangle_rss = rectangle.as_ref().map(|r| {
        local
            .iter()
            .map(|&p| distance_to_boundary(p, &r.band_outline_m).powi(2))
            .sum::<f64>()
    });
    let bic_rectangle = rectangle.as_ref().zip(rectangle_rss).map(|(r, rss)| {
        let parameters = if r.sides_seen == 1 { 4 } else { 5 };
        bic(rss, n, parameters, floor)
    });
    let bic_circle = circle.as_ref().map(|c| bic(c.rss_m2, n, 3, floor));
    let circle_probability = match (bic_rectangle, bic_circle) {
        (Some(br), Some(bc)) => 1.0 / (1.0 + ((bc - br) / 2.0).clamp(-700.0, 700.0).exp()),
        (None, Some(_)) => 1.0,
        _ => 0.0,
    };
    let shift = |p: [f64; 2]| [p[0] + centroid[0], p[1] + centroid[1]];
    let rectangle = rectangle.map(|r| FittedShape {
        kind: ShapeKind::Rectangle,
        center_m: shift(r.center_m),
        size_m: r.size_m,
        yaw_rad: r.yaw_rad,
        radius_m: 0.0,
        covariance: r.covariance,
        sides_seen: r.sides_seen,
        support: n,
        rms_residual_m: (rectangle_rss.unwrap_or(r.rss_m2) / n as f64).sqrt(),
        bic_rectangle,
        bic_circle,
        circle_probability,
    });
    let circle = circle.map(|c| FittedShape {
        kind: ShapeKind::Circle,
        center_m: shift(c.center_m),
        size_m: [2.0 * c.radius_m; 2],
        yaw_rad: 0.0,
        radius_m: c.radius_m,
        covariance: c.covariance,
        sides_seen: 0,
        support: n,
        rms_residual_m: (c.rss_m2 / n as f64).sqrt(),
        bic_rectangle,
        bic_circle,
        circle_probability,
    });
    let selected = match (&rectangle, &circle) {
        (Some(_), Some(_)) if circle_probability > 0.5 => ShapeKind::Circle,
        (Some(_), _) => ShapeKind::Rectangle,
        (None, Some(_)) => ShapeKind::Circle,
        (None, None) => return Err(FitError::NoShape { points: n }),
    };
    Ok(Candidates {
        rectangle,
        circle,
        selected,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn finite(shape: &FittedShape) -> bool {
        shape
            .center_m
            .iter()
            .chain(&shape.size_m)
            .chain(&shape.covariance)
            .all(|v| v.is_finite())
            && shape.yaw_rad.is_finite()
            && shape.radius_m.is_finite()
            && shape.rms_residual_m.is_finite()
            && shape.circle_probability.is_finite()
    }

    #[test]
    fn too_few_and_coincident_points_are_refused() {
        let p = Params::default();
        assert_eq!(
            fit(&[], &[], &p).unwrap_err(),
            FitError::TooFewPoints {
                distinct: 0,
                min: 4
            }
        );
        let two = [[0.0, 0.0], [1.0, 0.0]];
        assert!(matches!(
            fit(&two, &[], &p),
            Err(FitError::TooFewPoints { distinct: 2, .. })
        ));
        let coincident = [[3.0, 4.0]; 50];
        assert!(matches!(
            fit(&coincident, &[], &p),
            Err(FitError::TooFewPoints { distinct: 1, .. })
        ));
    }

    #[test]
    fn non_finite_input_and_bad_params_are_named() {
        let p = Params::default();
        let mut points: Vec<[f64; 2]> = (0..10).map(|k| [k as f64 * 0.1, 0.0]).collect();
        points[3][1] = f64::NAN;
        assert_eq!(
            fit(&points, &[], &p).unwrap_err(),
            FitError::NonFinitePoint { index: 3 }
        );
        points[3][1] = 0.0;
        assert_eq!(
            fit(&points, &[[0.0, 0.0], [f64::INFINITY, 0.0]], &p).unwrap_err(),
            FitError::NonFiniteViewpoint { index: 1 }
        );
        let bad = Params {
            gate_m: -1.0,
            ..Params::default()
        };
        assert!(fit(&points, &[], &bad)
            .unwrap_err()
            .to_string()
            .contains("gate_m"));
    }

    #[test]
    fn a_straight_line_is_a_one_sided_rectangle_away_from_the_sensor() {
        // Exactly collinear: the circle fit has no solution, the rectangle is the limiting shape.
        let points: Vec<[f64; 2]> = (0..30).map(|k| [10.0 + k as f64 * 0.1, 5.0]).collect();
        let p = Params::default();
        for (viewpoint, side) in [([11.5, 0.0], 1.0), ([11.5, 10.0], -1.0)] {
            let shape = fit(&points, &[viewpoint], &p).unwrap();
            assert_eq!(shape.kind, ShapeKind::Rectangle);
            assert_eq!(shape.sides_seen, 1);
            assert!(finite(&shape));
            // The seen length is 2.9 m, the depth prior clamps it to [1, 4]: 2.9 m deep, on the
            // far side from the viewpoint.
            let depth = if shape.yaw_rad.abs() < 0.1 {
                shape.size_m[1]
            } else {
                shape.size_m[0]
            };
            assert!((depth - 2.9).abs() < 0.05, "{shape:?}");
            assert!(
                ((shape.center_m[1] - 5.0) * side - 1.45).abs() < 0.05,
                "{shape:?}"
            );
            // The depth prior's 1 m standard deviation shows in the centre's variance.
            let c = shape.center_covariance();
            assert!(c[0][0].max(c[1][1]) > 0.2, "{c:?}");
        }
    }

    #[test]
    fn a_full_circle_of_points_is_a_circle() {
        let points: Vec<[f64; 2]> = (0..64)
            .map(|k| {
                let phi = std::f64::consts::TAU * k as f64 / 64.0;
                [5.0 + 1.5 * phi.cos(), -2.0 + 1.5 * phi.sin()]
            })
            .collect();
        let shape = fit(&points, &[], &crate::synthetic::unbiased_params()).unwrap();
        assert_eq!(shape.kind, ShapeKind::Circle);
        assert!((shape.radius_m - 1.5).abs() < 1e-6 && finite(&shape));
        assert_eq!(shape.samples().len(), 4);
    }

    #[test]
    fn the_surface_offset_moves_every_side_and_radius_out_by_its_multiple_of_the_band_spread() {
        use crate::synthetic::{arc_samples, cells, rectangle_samples, unbiased_params};
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let sigma_m = 0.1;
        let square = cells(
            &rectangle_samples([3.0, 4.0], [4.0, 3.0], 0.3, &[0, 1, 2, 3]),
            sigma_m,
            &mut rng,
        );
        let ring = cells(
            &arc_samples([3.0, 4.0], 1.5, 0.0, std::f64::consts::TAU),
            sigma_m,
            &mut rng,
        );
        let kappa = 0.6;
        let with = Params {
            surface_offset_per_std: kappa,
            ..unbiased_params()
        };
        for points in [&square, &ring] {
            let (band, out) = (
                fit(points, &[], &unbiased_params()).unwrap(),
                fit(points, &[], &with).unwrap(),
            );
            // The band's spread σ̂ is close to the points' RMS distance to the band's outline.
            let expected_m = kappa * band.rms_residual_m;
            for axis in 0..2 {
                let grown_m = (out.size_m[axis] - band.size_m[axis]) / 2.0;
                assert!(
                    (grown_m - expected_m).abs() < 0.15 * expected_m,
                    "{:?}: grew {grown_m} m, expected {expected_m} m",
                    band.kind
                );
                // All sides (the whole circle) move out alike: the centre stays.
                assert!((out.center_m[axis] - band.center_m[axis]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn far_from_the_origin_is_as_good_as_near_it() {
        let square: Vec<[f64; 2]> =
            crate::synthetic::rectangle_samples([0.0, 0.0], [2.0, 1.0], 0.3, &[0, 1, 2, 3]);
        let far: Vec<[f64; 2]> = square.iter().map(|p| [p[0] + 1e5, p[1] - 1e5]).collect();
        let (a, b) = (
            fit(&square, &[], &Params::default()).unwrap(),
            fit(&far, &[], &Params::default()).unwrap(),
        );
        assert!((a.center_m[0] + 1e5 - b.center_m[0]).abs() < 1e-6);
        assert!((a.size_m[0] - b.size_m[0]).abs() < 1e-6 && (a.yaw_rad - b.yaw_rad).abs() < 1e-6);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Whatever the points (clusters, lines, tiny spreads, duplicates), the fit returns a
        /// finite shape with a positive semi-definite centre covariance, or an error.
        #[test]
        fn never_nan_never_panic(
            points in proptest::collection::vec((-1e3..1e3f64, -1e3..1e3f64), 0..40),
            scale in prop_oneof![Just(1e-9), Just(1e-3), Just(1.0)],
            line in any::<bool>(),
            viewpoints in proptest::collection::vec((-50.0..50.0f64, -50.0..50.0f64), 0..3),
        ) {
            let points: Vec<[f64; 2]> = points
                .iter()
                .map(|&(x, y)| if line { [x * scale, 2.0 * x * scale] } else { [x * scale, y * scale] })
                .collect();
            let viewpoints: Vec<[f64; 2]> = viewpoints.iter().map(|&(x, y)| [x, y]).collect();
            if let Ok(shape) = fit(&points, &viewpoints, &Params::default()) {
                prop_assert!(finite(&shape), "{shape:?}");
                let c = shape.center_covariance();
                prop_assert!(c[0][0] >= 0.0 && c[1][1] >= 0.0);
                prop_assert!(c[0][0] * c[1][1] - c[0][1] * c[1][0] >= -1e-9 * (c[0][0] * c[1][1]).max(1e-300));
                prop_assert!(shape.size_m[0] > 0.0 && shape.size_m[1] > 0.0);
                prop_assert!((0.0..std::f64::consts::FRAC_PI_2).contains(&shape.yaw_rad));
                prop_assert!(shape.outline().iter().all(|v| v[0].is_finite() && v[1].is_finite()));
            }
        }
    }
}
