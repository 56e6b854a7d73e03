//! Errors of fitted shapes against the true ones, for the evaluator and the Monte Carlo studies:
//! IoU of the outlines, centre, size, yaw and kind errors, and the centre's normalised estimation
//! error squared (NEES; Y. Bar-Shalom, X. R. Li, T. Kirubarajan, "Estimation with Applications to
//! Tracking and Navigation", Wiley 2001, §5.4), whose mean over runs is 2 (the centre's
//! dimension) when the covariance is honest.
//!
//! **Yaw and size of a rectangle.** (yaw, w, h), (yaw + π/2, h, w) and (yaw + π, w, h) are the
//! same rectangle. The truth is taken in whichever of its representations has the yaw closest to
//! the fit's; the yaw error is that difference, in [0, π/4], and the size error compares the
//! sizes of that representation. A fit turned by a quarter turn with its sizes kept thus shows a
//! small yaw error but a large size error (and a low IoU), as it should.

use std::f64::consts::{FRAC_PI_2, PI};

use serde::{Deserialize, Serialize};

use crate::geometry::convex_polygon_iou;
use crate::shape::{
    circle_points, rectangle_corners, FittedShape, ShapeKind, CIRCLE_OUTLINE_VERTICES,
};

/// A true target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TruthShape {
    /// Rectangle or circle.
    pub kind: ShapeKind,
    /// Centre (m).
    pub center_m: [f64; 2],
    /// Rectangle: sizes along its own x, y axes (m); circle: [2r, 2r].
    pub size_m: [f64; 2],
    /// Rectangle: yaw of its own x axis (rad, any value); circle: 0.
    pub yaw_rad: f64,
    /// Circle: radius (m); rectangle: 0.
    pub radius_m: f64,
}

impl TruthShape {
    /// A rectangle.
    pub fn rectangle(center_m: [f64; 2], size_m: [f64; 2], yaw_rad: f64) -> Self {
        Self {
            kind: ShapeKind::Rectangle,
            center_m,
            size_m,
            yaw_rad,
            radius_m: 0.0,
        }
    }

    /// A circle.
    pub fn circle(center_m: [f64; 2], radius_m: f64) -> Self {
        Self {
            kind: ShapeKind::Circle,
            center_m,
            size_m: [2.0 * radius_m; 2],
            yaw_rad: 0.0,
            radius_m,
        }
    }

    /// Outline, counter-clockwise, as the simulator draws it (a circle as a 64-gon).
    pub fn outline(&self) -> Vec<[f64; 2]> {
        match self.kind {
            ShapeKind::Rectangle => {
                rectangle_corners(self.center_m, self.size_m, self.yaw_rad).to_vec()
            }
            ShapeKind::Circle => {
                circle_points(self.center_m, self.radius_m, CIRCLE_OUTLINE_VERTICES)
            }
        }
    }
}

/// How far a fitted shape is from its true target.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShapeErrors {
    /// Intersection over union of the two outlines, [0, 1].
    pub iou: f64,
    /// Distance between the centres (m).
    pub center_error_m: f64,
    /// Euclidean norm of the difference of the sizes (m), the truth's sizes in the
    /// representation closest in yaw (module doc); a circle's size is [2r, 2r].
    pub size_error_m: f64,
    /// Both rectangles: the yaw difference modulo the quarter turn, [0, π/4] (rad).
    pub yaw_error_rad: Option<f64>,
    /// Both circles: |r − r_true| (m).
    pub radius_error_m: Option<f64>,
    /// The fitted kind is the true kind.
    pub kind_correct: bool,
    /// eᵀ P⁻¹ e of the centre error e with the fit's centre covariance P; +∞ when P is singular.
    pub center_nees: f64,
}

/// `angle` wrapped to (−π, π].
fn wrap(angle: f64) -> f64 {
    let a = angle.rem_euclid(2.0 * PI);
    if a > PI {
        a - 2.0 * PI
    } else {
        a
    }
}

/// eᵀ P⁻¹ e for a 2-vector; +∞ when P is not positive definite or not finite.
pub fn nees_2d(error: [f64; 2], p: [[f64; 2]; 2]) -> f64 {
    let det = p[0][0] * p[1][1] - p[0][1] * p[1][0];
    if !(det.is_finite() && det > 0.0 && p[0][0] > 0.0) {
        return f64::INFINITY;
    }
    let [x, y] = error;
    let value = (p[1][1] * x * x - (p[0][1] + p[1][0]) * x * y + p[0][0] * y * y) / det;
    if value.is_finite() {
        value.max(0.0)
    } else {
        f64::INFINITY
    }
}

/// Errors of `shape` against `truth` (see [`ShapeErrors`]).
pub fn evaluate(shape: &FittedShape, truth: &TruthShape) -> ShapeErrors {
    let e = [
        shape.center_m[0] - truth.center_m[0],
        shape.center_m[1] - truth.center_m[1],
    ];
    // The truth's representation closest in yaw: k quarter turns, sizes swapped for odd k.
    let k = ((shape.yaw_rad - truth.yaw_rad) / FRAC_PI_2).round();
    let yaw_error = wrap(shape.yaw_rad - truth.yaw_rad - k * FRAC_PI_2).abs();
    let swapped = (k as i64).rem_euclid(2) == 1;
    let both_rectangles = shape.kind == ShapeKind::Rectangle && truth.kind == ShapeKind::Rectangle;
    let truth_size = if both_rectangles && swapped {
        [truth.size_m[1], truth.size_m[0]]
    } else if shape.kind != truth.kind {
        // A circle against a rectangle: the rectangle's sizes in the order that fits better.
        let direct = (shape.size_m[0] - truth.size_m[0]).hypot(shape.size_m[1] - truth.size_m[1]);
        let turned = (shape.size_m[0] - truth.size_m[1]).hypot(shape.size_m[1] - truth.size_m[0]);
        if turned < direct {
            [truth.size_m[1], truth.size_m[0]]
        } else {
            truth.size_m
        }
    } else {
        truth.size_m
    };
    let both_circles = shape.kind == ShapeKind::Circle && truth.kind == ShapeKind::Circle;
    ShapeErrors {
        iou: convex_polygon_iou(&shape.outline(), &truth.outline()),
        center_error_m: e[0].hypot(e[1]),
        size_error_m: (shape.size_m[0] - truth_size[0]).hypot(shape.size_m[1] - truth_size[1]),
        yaw_error_rad: both_rectangles.then_some(yaw_error),
        radius_error_m: both_circles.then(|| (shape.radius_m - truth.radius_m).abs()),
        kind_correct: shape.kind == truth.kind,
        center_nees: nees_2d(e, shape.center_covariance()),
    }
}

/// Pairs fitted shapes with true targets by centre distance: one-to-one, only pairs at most
/// `gate_m` apart, greedily by increasing distance (ties by index). Returns (fitted, truth)
/// index pairs sorted by fitted index.
///
/// Greedy is optimal whenever each fit is nearer its own target than any other pair is close,
/// which the scenes guarantee (targets at least 5.5 m apart, gates of a few metres); it avoids
/// depending on the evaluator's Hungarian solver, which depends on this crate.
pub fn match_to_truth(
    fitted_m: &[[f64; 2]],
    truth_m: &[[f64; 2]],
    gate_m: f64,
) -> Vec<(usize, usize)> {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, f) in fitted_m.iter().enumerate() {
        for (j, t) in truth_m.iter().enumerate() {
            let d = (f[0] - t[0]).hypot(f[1] - t[1]);
            // NaN distances fail the gate.
            if d <= gate_m {
                pairs.push((d, i, j));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut fit_used = vec![false; fitted_m.len()];
    let mut truth_used = vec![false; truth_m.len()];
    let mut out = Vec::new();
    for (_, i, j) in pairs {
        if !fit_used[i] && !truth_used[j] {
            fit_used[i] = true;
            truth_used[j] = true;
            out.push((i, j));
        }
    }
    out.sort_unstable();
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fitted_rectangle(center: [f64; 2], size: [f64; 2], yaw: f64) -> FittedShape {
        FittedShape {
            kind: ShapeKind::Rectangle,
            center_m: center,
            size_m: size,
            yaw_rad: yaw,
            radius_m: 0.0,
            covariance: {
                let mut c = vec![0.0; 25];
                for i in 0..5 {
                    c[i * 6] = 0.25;
                }
                c
            },
            sides_seen: 4,
            support: 100,
            rms_residual_m: 0.05,
            bic_rectangle: None,
            bic_circle: None,
            circle_probability: 0.0,
        }
    }

    #[test]
    fn quarter_turn_with_swapped_sizes_is_the_same_rectangle() {
        let truth = TruthShape::rectangle([1.0, 2.0], [4.0, 1.0], 0.1);
        let fit = fitted_rectangle([1.0, 2.0], [1.0, 4.0], 0.1 + FRAC_PI_2);
        let e = evaluate(&fit, &truth);
        assert!((e.iou - 1.0).abs() < 1e-9, "{e:?}");
        assert!(e.yaw_error_rad.unwrap() < 1e-9);
        assert!(e.size_error_m < 1e-9);
        assert_eq!(e.center_nees, 0.0);
        assert!(e.kind_correct);
        // Turned a quarter with sizes kept: small yaw error, large size error, low IoU.
        let wrong = fitted_rectangle([1.0, 2.0], [4.0, 1.0], 0.1 + FRAC_PI_2);
        let e = evaluate(&wrong, &truth);
        assert!(e.yaw_error_rad.unwrap() < 1e-9);
        assert!((e.size_error_m - 18f64.sqrt()).abs() < 1e-9);
        assert!(e.iou < 0.2);
    }

    #[test]
    fn nees_of_a_known_error() {
        let truth = TruthShape::rectangle([0.0, 0.0], [2.0, 2.0], 0.0);
        let fit = fitted_rectangle([0.5, 0.0], [2.0, 2.0], 0.0);
        // e = (0.5, 0), P = 0.25 I: NEES = 0.25 / 0.25 = 1.
        assert!((evaluate(&fit, &truth).center_nees - 1.0).abs() < 1e-12);
        assert_eq!(nees_2d([1.0, 0.0], [[0.0, 0.0], [0.0, 0.0]]), f64::INFINITY);
        assert_eq!(
            nees_2d([1.0, 0.0], [[f64::NAN, 0.0], [0.0, 1.0]]),
            f64::INFINITY
        );
    }

    #[test]
    fn circle_against_circle_and_rectangle() {
        let truth = TruthShape::circle([0.0, 0.0], 1.0);
        let mut fit = fitted_rectangle([0.0, 0.0], [2.0, 2.0], 0.0);
        fit.kind = ShapeKind::Circle;
        fit.radius_m = 1.1;
        fit.size_m = [2.2, 2.2];
        fit.covariance = vec![0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 0.01];
        let e = evaluate(&fit, &truth);
        assert!((e.radius_error_m.unwrap() - 0.1).abs() < 1e-12);
        assert!(e.yaw_error_rad.is_none());
        assert!((e.iou - 1.0 / 1.21).abs() < 1e-3, "{e:?}");
        let rect_truth = TruthShape::rectangle([0.0, 0.0], [2.0, 2.0], 0.0);
        let e = evaluate(&fit, &rect_truth);
        assert!(!e.kind_correct && e.radius_error_m.is_none());
    }

    #[test]
    fn matching_is_one_to_one_and_gated() {
        let fits = [[0.0, 0.0], [10.0, 0.0], [0.5, 0.0], [50.0, 50.0]];
        let truths = [[0.2, 0.0], [10.0, 1.0], [30.0, 0.0]];
        assert_eq!(match_to_truth(&fits, &truths, 3.0), vec![(0, 0), (1, 1)]);
        assert!(match_to_truth(&[[f64::NAN, 0.0]], &truths, 3.0).is_empty());
        assert!(match_to_truth(&[], &truths, 3.0).is_empty());
    }
}
