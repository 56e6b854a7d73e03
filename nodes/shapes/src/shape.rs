//! The fitted shape of one extended target: kind, centre, size, yaw or radius, covariance, and
//! the evidence of the model selection.
//!
//! Its sample points and outline follow the conventions of the simulator's true shapes (corners
//! counter-clockwise from local (−w/2, −h/2); a circle's samples at 0°, 90°, 180°, 270° and its
//! outline a 64-gon with a vertex at 0°), so that ET-GOPSA compares like with like, as the paper
//! "Simultaneous Localization and Mapping of Multiple Extended Targets with 5G OFDM sensing"
//! samples 4 points per target.

use std::f64::consts::{FRAC_PI_2, TAU};

use serde::{Deserialize, Serialize};

/// Vertices of a circle's outline polygon (as the simulator's `CIRCLE_OUTLINE_VERTICES`).
pub const CIRCLE_OUTLINE_VERTICES: usize = 64;

/// Which model a target is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShapeKind {
    /// A rectangle of any yaw.
    Rectangle,
    /// A circle.
    Circle,
}

/// One segment's fitted shape.
///
/// **Covariance order.** Row-major; a rectangle's parameters are (cx, cy, w, h, yaw) (5×5), a
/// circle's (cx, cy, r) (3×3). Units m and rad.
///
/// **Yaw.** A rectangle's yaw is that of its own x axis (the side of length `size_m[0]`) from the
/// map's +x, normalised to [0, π/2): the same rectangle turned by π/2 with its sizes swapped is
/// the same set, so every rectangle has exactly one representation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FittedShape {
    /// The selected model.
    pub kind: ShapeKind,
    /// Centre, map frame (m).
    pub center_m: [f64; 2],
    /// Rectangle: lengths along its own x and y axes (m); circle: [2r, 2r].
    pub size_m: [f64; 2],
    /// Rectangle: yaw in [0, π/2) (rad); circle: 0.
    pub yaw_rad: f64,
    /// Circle: radius (m); rectangle: 0.
    pub radius_m: f64,
    /// Row-major covariance of (cx, cy, w, h, yaw) or (cx, cy, r); see the type's doc.
    pub covariance: Vec<f64>,
    /// Rectangle: how many sides the points fix by least squares (1..=4); circle: 0.
    pub sides_seen: u8,
    /// Points used in the fit.
    pub support: usize,
    /// Root mean square of the points' distances to the fitted outline (m).
    pub rms_residual_m: f64,
    /// BIC of the rectangle model (lower is better), when a rectangle could be fitted.
    pub bic_rectangle: Option<f64>,
    /// BIC of the circle model, when a plausible circle could be fitted (see [`mod@crate::fit`]).
    pub bic_circle: Option<f64>,
    /// Posterior probability of the circle model from the two BICs (equal prior odds);
    /// 0 when no circle is plausible, 1 when no rectangle could be fitted.
    pub circle_probability: f64,
}

impl FittedShape {
    /// Number of parameters: 5 for a rectangle, 3 for a circle.
    pub fn parameter_count(&self) -> usize {
        match self.kind {
            ShapeKind::Rectangle => 5,
            ShapeKind::Circle => 3,
        }
    }

    /// The 2×2 covariance of the centre (m²).
    pub fn center_covariance(&self) -> [[f64; 2]; 2] {
        let n = self.parameter_count();
        let c = &self.covariance;
        if c.len() != n * n {
            // Never produced by `fit`; a hand-built shape without covariance has none to give.
            return [[f64::INFINITY, 0.0], [0.0, f64::INFINITY]];
        }
        [[c[0], c[1]], [c[n], c[n + 1]]]
    }

    /// Rectangle corners counter-clockwise from local (−w/2, −h/2); a circle's points at 0°,
    /// 90°, 180°, 270°. The ET-GOPSA representatives.
    pub fn samples(&self) -> Vec<[f64; 2]> {
        match self.kind {
            ShapeKind::Rectangle => {
                rectangle_corners(self.center_m, self.size_m, self.yaw_rad).to_vec()
            }
            ShapeKind::Circle => circle_points(self.center_m, self.radius_m, 4),
        }
    }

    /// Closed outline polygon, counter-clockwise, last vertex not repeated: a rectangle's
    /// corners, a circle as a [`CIRCLE_OUTLINE_VERTICES`]-gon with a vertex at 0°.
    pub fn outline(&self) -> Vec<[f64; 2]> {
        match self.kind {
            ShapeKind::Rectangle => self.samples(),
            ShapeKind::Circle => {
                circle_points(self.center_m, self.radius_m, CIRCLE_OUTLINE_VERTICES)
            }
        }
    }
}

/// Corners of a `size_m[0]` × `size_m[1]` rectangle centred on `center_m` with its x axis at
/// `yaw_rad`, counter-clockwise from local (−w/2, −h/2) (the simulator's order).
pub fn rectangle_corners(center_m: [f64; 2], size_m: [f64; 2], yaw_rad: f64) -> [[f64; 2]; 4] {
    let (s, c) = yaw_rad.sin_cos();
    let (hw, hh) = (size_m[0] / 2.0, size_m[1] / 2.0);
    [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)].map(|(u, v): (f64, f64)| {
        let (x, y) = (u * hw, v * hh);
        [center_m[0] + c * x - s * y, center_m[1] + s * x + c * y]
    })
}

/// `count` points on a circle, evenly from 0°, counter-clockwise.
pub fn circle_points(center_m: [f64; 2], radius_m: f64, count: usize) -> Vec<[f64; 2]> {
    (0..count)
        .map(|k| {
            let phi = if count == 4 {
                // Exactly 0, π/2, π, 3π/2, as the truth's samples.
                FRAC_PI_2 * k as f64
            } else {
                TAU * k as f64 / count as f64
            };
            [
                center_m[0] + radius_m * phi.cos(),
                center_m[1] + radius_m * phi.sin(),
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::signed_area;

    fn shape(kind: ShapeKind) -> FittedShape {
        FittedShape {
            kind,
            center_m: [1.0, 2.0],
            size_m: [4.0, 2.0],
            yaw_rad: 0.0,
            radius_m: 2.0,
            covariance: match kind {
                ShapeKind::Rectangle => (0..25).map(f64::from).collect(),
                ShapeKind::Circle => (0..9).map(f64::from).collect(),
            },
            sides_seen: 4,
            support: 10,
            rms_residual_m: 0.0,
            bic_rectangle: None,
            bic_circle: None,
            circle_probability: 0.0,
        }
    }

    #[test]
    fn samples_and_outline_follow_the_simulator() {
        let rect = shape(ShapeKind::Rectangle);
        let corners = rect.samples();
        // The simulator's own test: Shape::rectangle((1, 2), 4, 2, 0) has corner 0 at (−1, 1)
        // and corner 2 at (3, 3).
        assert_eq!(corners[0], [-1.0, 1.0]);
        assert_eq!(corners[2], [3.0, 3.0]);
        assert!(signed_area(&rect.outline()) > 0.0);
        assert_eq!(rect.center_covariance(), [[0.0, 1.0], [5.0, 6.0]]);
        let circle = shape(ShapeKind::Circle);
        let samples = circle.samples();
        for (s, e) in samples
            .iter()
            .zip([[3.0, 2.0], [1.0, 4.0], [-1.0, 2.0], [1.0, 0.0]])
        {
            assert!((s[0] - e[0]).abs() < 1e-12 && (s[1] - e[1]).abs() < 1e-12);
        }
        let outline = circle.outline();
        assert_eq!(outline.len(), CIRCLE_OUTLINE_VERTICES);
        assert!(signed_area(&outline) > 0.0);
        assert_eq!(circle.center_covariance(), [[0.0, 1.0], [3.0, 4.0]]);
    }
}
