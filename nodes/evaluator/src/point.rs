//! Planar points and the input checks every metric runs before it computes anything.

use serde::{Deserialize, Serialize};

use crate::MetricError;

/// A point of the map plane, in metres (world/map frame, docs/conventions.md).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point2 {
    /// x coordinate, metres.
    pub x_m: f64,
    /// y coordinate, metres.
    pub y_m: f64,
}

impl Point2 {
    /// The point (x_m, y_m).
    pub const fn new(x_m: f64, y_m: f64) -> Self {
        Self { x_m, y_m }
    }

    /// Euclidean distance to `other`, metres. (√ of the squared distance rather than `hypot`,
    /// several times faster; it overflows to +∞ only beyond 1e154 m, far past any cut-off c.)
    pub fn distance_m(&self, other: &Point2) -> f64 {
        self.distance_sq_m2(other).sqrt()
    }

    /// Squared Euclidean distance to `other`, square metres.
    pub fn distance_sq_m2(&self, other: &Point2) -> f64 {
        let dx = self.x_m - other.x_m;
        let dy = self.y_m - other.y_m;
        dx * dx + dy * dy
    }

    /// Both coordinates are finite (neither NaN nor infinite).
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite()
    }
}

impl From<[f64; 2]> for Point2 {
    fn from([x_m, y_m]: [f64; 2]) -> Self {
        Self { x_m, y_m }
    }
}

/// Refuses a set holding a NaN or infinite coordinate, naming the set and the point's index:
/// a NaN would otherwise poison every comparison of the assignment and give a silent wrong answer.
pub(crate) fn check_finite(points: &[Point2], set: impl Fn() -> String) -> Result<(), MetricError> {
    match points.iter().position(|p| !p.is_finite()) {
        None => Ok(()),
        Some(index) => Err(MetricError::NonFiniteInput {
            set: set(),
            index,
            x_m: points[index].x_m,
            y_m: points[index].y_m,
        }),
    }
}

/// Distance from `p` to the closed polygon `vertices` (its boundary: the edges v₀v₁, …, vₙ₋₁v₀),
/// metres. One vertex is a point, two a segment. `None` for no vertex.
///
/// The boundary, not the enclosed region: a radar sees the surfaces of a target, so an estimate
/// inside a target is as wrong as one outside at the same distance from the nearest wall.
pub fn distance_to_outline_m(p: &Point2, vertices: &[Point2]) -> Option<f64> {
    match vertices {
        [] => None,
        [only] => Some(p.distance_m(only)),
        _ => {
            let n = vertices.len();
            let best_sq = (0..n)
                .map(|k| distance_sq_to_segment_m2(p, &vertices[k], &vertices[(k + 1) % n]))
                .fold(f64::INFINITY, f64::min);
            Some(best_sq.sqrt())
        }
    }
}

/// Squared distance from `p` to the segment ab, square metres.
fn distance_sq_to_segment_m2(p: &Point2, a: &Point2, b: &Point2) -> f64 {
    let (abx, aby) = (b.x_m - a.x_m, b.y_m - a.y_m);
    let len_sq = abx * abx + aby * aby;
    if len_sq == 0.0 {
        return p.distance_sq_m2(a);
    }
    // Parameter of the orthogonal projection of p on the line ab, clamped onto the segment.
    let t = (((p.x_m - a.x_m) * abx + (p.y_m - a.y_m) * aby) / len_sq).clamp(0.0, 1.0);
    p.distance_sq_m2(&Point2::new(a.x_m + t * abx, a.y_m + t * aby))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outline_distance_of_a_unit_square() {
        let square = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(1.0, 1.0),
            Point2::new(0.0, 1.0),
        ];
        // Outside, facing an edge: the orthogonal distance.
        assert!(
            (distance_to_outline_m(&Point2::new(0.5, -2.0), &square).unwrap() - 2.0).abs() < 1e-12
        );
        // Outside, facing a corner: the distance to the corner.
        let d = distance_to_outline_m(&Point2::new(2.0, 2.0), &square).unwrap();
        assert!((d - 2f64.sqrt()).abs() < 1e-12);
        // Inside: the distance to the nearest wall, not zero.
        let d = distance_to_outline_m(&Point2::new(0.5, 0.25), &square).unwrap();
        assert!((d - 0.25).abs() < 1e-12);
        // The closing edge (last vertex back to the first) counts.
        let d = distance_to_outline_m(&Point2::new(-0.5, 0.5), &square).unwrap();
        assert!((d - 0.5).abs() < 1e-12);
        assert_eq!(distance_to_outline_m(&Point2::new(0.0, 0.0), &[]), None);
        let d = distance_to_outline_m(&Point2::new(3.0, 4.0), &[Point2::new(0.0, 0.0)]).unwrap();
        assert!((d - 5.0).abs() < 1e-12);
    }
}
