//! Planar geometry shared by the scene, the trajectory and the visibility test.
//!
//! Everything is `f64`, metres and radians, in the world ("map") frame of
//! `docs/conventions.md`: x right, y up, angles counter-clockwise from +x. The extended targets
//! of the paper (Sec. II-A: eight rectangles and two circles) are convex, which the visibility
//! and overlap tests below rely on.

use std::f64::consts::PI;

/// A 2-D point or vector in metres.
///
/// A plain struct rather than `nalgebra::Vector2`: visibility runs these operations millions of
/// times per lap, and generic nalgebra code instantiated here is compiled at this crate's
/// optimisation level: the tests ran over 10× slower with it in debug builds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Vec2 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
}

impl Vec2 {
    /// The vector (x, y).
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// The zero vector.
    pub const fn zeros() -> Self {
        Self::new(0.0, 0.0)
    }

    /// (v, v).
    pub const fn repeat(v: f64) -> Self {
        Self::new(v, v)
    }

    /// Dot product.
    pub fn dot(&self, other: &Vec2) -> f64 {
        self.x * other.x + self.y * other.y
    }

    /// Squared Euclidean length.
    pub fn norm_squared(&self) -> f64 {
        self.dot(self)
    }

    /// Euclidean length.
    pub fn norm(&self) -> f64 {
        self.x.hypot(self.y)
    }

    /// The unit vector in the same direction (NaN for the zero vector).
    pub fn normalize(&self) -> Vec2 {
        *self / self.norm()
    }

    /// Component-wise minimum.
    pub fn inf(&self, other: &Vec2) -> Vec2 {
        Vec2::new(self.x.min(other.x), self.y.min(other.y))
    }

    /// Component-wise maximum.
    pub fn sup(&self, other: &Vec2) -> Vec2 {
        Vec2::new(self.x.max(other.x), self.y.max(other.y))
    }
}

macro_rules! vec2_binary_ops {
    ($($lhs:ty, $rhs:ty;)*) => {$(
        impl std::ops::Add<$rhs> for $lhs {
            type Output = Vec2;
            fn add(self, rhs: $rhs) -> Vec2 {
                Vec2::new(self.x + rhs.x, self.y + rhs.y)
            }
        }
        impl std::ops::Sub<$rhs> for $lhs {
            type Output = Vec2;
            fn sub(self, rhs: $rhs) -> Vec2 {
                Vec2::new(self.x - rhs.x, self.y - rhs.y)
            }
        }
    )*};
}

vec2_binary_ops! {
    Vec2, Vec2;
    Vec2, &Vec2;
    &Vec2, Vec2;
    &Vec2, &Vec2;
}

impl std::ops::Mul<f64> for Vec2 {
    type Output = Vec2;
    fn mul(self, k: f64) -> Vec2 {
        Vec2::new(self.x * k, self.y * k)
    }
}

impl std::ops::Div<f64> for Vec2 {
    type Output = Vec2;
    fn div(self, k: f64) -> Vec2 {
        Vec2::new(self.x / k, self.y / k)
    }
}

impl std::ops::Neg for Vec2 {
    type Output = Vec2;
    fn neg(self) -> Vec2 {
        Vec2::new(-self.x, -self.y)
    }
}

/// A planar pose: position in metres, heading (yaw) in radians counter-clockwise from +x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose2 {
    /// x position, metres.
    pub x_m: f64,
    /// y position, metres.
    pub y_m: f64,
    /// Heading, radians; [`Pose2::new`] wraps it to (−π, π].
    pub yaw_rad: f64,
}

impl Pose2 {
    /// A pose; the heading is wrapped to (−π, π].
    pub fn new(x_m: f64, y_m: f64, yaw_rad: f64) -> Self {
        Self {
            x_m,
            y_m,
            yaw_rad: wrap_angle(yaw_rad),
        }
    }

    /// The position as a vector.
    pub fn position(&self) -> Vec2 {
        Vec2::new(self.x_m, self.y_m)
    }

    /// This pose seen from `origin`: `origin⁻¹ ∘ self` (the identity when they are equal).
    pub fn relative_to(&self, origin: Pose2) -> Pose2 {
        let d = self.position() - origin.position();
        let (sin, cos) = origin.yaw_rad.sin_cos();
        Pose2::new(
            cos * d.x + sin * d.y,
            -sin * d.x + cos * d.y,
            self.yaw_rad - origin.yaw_rad,
        )
    }
}

/// Wraps an angle to (−π, π].
pub fn wrap_angle(angle_rad: f64) -> f64 {
    let wrapped = angle_rad.rem_euclid(2.0 * PI); // [0, 2π)
    if wrapped > PI {
        wrapped - 2.0 * PI
    } else {
        wrapped
    }
}

/// z component of the cross product a × b.
pub fn cross(a: Vec2, b: Vec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Whether the closed segments [p1, p2] and [q1, q2] share at least one point (touching counts).
pub fn segments_intersect(p1: Vec2, p2: Vec2, q1: Vec2, q2: Vec2) -> bool {
    let d1 = cross(q2 - q1, p1 - q1);
    let d2 = cross(q2 - q1, p2 - q1);
    let d3 = cross(p2 - p1, q1 - p1);
    let d4 = cross(p2 - p1, q2 - p1);
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return true;
    }
    // Collinear or touching cases: an endpoint lies on the other segment.
    (d1 == 0.0 && on_segment(q1, q2, p1))
        || (d2 == 0.0 && on_segment(q1, q2, p2))
        || (d3 == 0.0 && on_segment(p1, p2, q1))
        || (d4 == 0.0 && on_segment(p1, p2, q2))
}

/// For a point `p` known to be collinear with [a, b]: whether it lies within the segment's box.
fn on_segment(a: Vec2, b: Vec2, p: Vec2) -> bool {
    p.x >= a.x.min(b.x) && p.x <= a.x.max(b.x) && p.y >= a.y.min(b.y) && p.y <= a.y.max(b.y)
}

/// Euclidean distance from point `p` to the closed segment [a, b].
pub fn point_segment_distance(a: Vec2, b: Vec2, p: Vec2) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    if len2 == 0.0 {
        return (p - a).norm();
    }
    let t = ((p - a).dot(&ab) / len2).clamp(0.0, 1.0);
    (p - (a + ab * t)).norm()
}

/// Distance between two closed segments (0 if they intersect).
pub fn segment_segment_distance(p1: Vec2, p2: Vec2, q1: Vec2, q2: Vec2) -> f64 {
    if segments_intersect(p1, p2, q1, q2) {
        return 0.0;
    }
    point_segment_distance(q1, q2, p1)
        .min(point_segment_distance(q1, q2, p2))
        .min(point_segment_distance(p1, p2, q1))
        .min(point_segment_distance(p1, p2, q2))
}

/// Whether `p` lies inside or on the convex polygon `vertices` (counter-clockwise).
pub fn point_in_convex_polygon(vertices: &[Vec2], p: Vec2) -> bool {
    let n = vertices.len();
    (0..n).all(|i| cross(vertices[(i + 1) % n] - vertices[i], p - vertices[i]) >= 0.0)
}

/// Distance from `p` to the closed convex polygon `vertices` (0 inside or on it).
pub fn point_convex_polygon_distance(vertices: &[Vec2], p: Vec2) -> f64 {
    if point_in_convex_polygon(vertices, p) {
        return 0.0;
    }
    edges(vertices)
        .map(|(a, b)| point_segment_distance(a, b, p))
        .fold(f64::INFINITY, f64::min)
}

/// Distance from the segment [a, b] to the closed convex polygon `vertices` (0 if they meet).
pub fn segment_convex_polygon_distance(vertices: &[Vec2], a: Vec2, b: Vec2) -> f64 {
    if point_in_convex_polygon(vertices, a) || point_in_convex_polygon(vertices, b) {
        return 0.0;
    }
    edges(vertices)
        .map(|(p, q)| segment_segment_distance(a, b, p, q))
        .fold(f64::INFINITY, f64::min)
}

/// Whether the closed segment [a, b] meets the closed convex polygon `vertices` (touching
/// counts). Cheaper than [`segment_convex_polygon_distance`]: no square roots.
pub fn segment_meets_convex_polygon(vertices: &[Vec2], a: Vec2, b: Vec2) -> bool {
    point_in_convex_polygon(vertices, a)
        || point_in_convex_polygon(vertices, b)
        || edges(vertices).any(|(p, q)| segments_intersect(a, b, p, q))
}

/// Distance between two closed convex polygons (0 if they overlap or touch).
pub fn convex_polygons_distance(first: &[Vec2], second: &[Vec2]) -> f64 {
    // Both directions: a polygon strictly inside the other has no edge crossing, only its
    // vertices inside the other reveal the overlap.
    let one_way = |p: &[Vec2], q: &[Vec2]| {
        edges(p)
            .map(|(a, b)| segment_convex_polygon_distance(q, a, b))
            .fold(f64::INFINITY, f64::min)
    };
    one_way(first, second).min(one_way(second, first))
}

/// The edges (vᵢ, vᵢ₊₁) of a closed polygon, last vertex joined to the first.
pub fn edges(vertices: &[Vec2]) -> impl Iterator<Item = (Vec2, Vec2)> + '_ {
    let n = vertices.len();
    (0..n).map(move |i| (vertices[i], vertices[(i + 1) % n]))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64, y: f64) -> Vec2 {
        Vec2::new(x, y)
    }

    #[test]
    fn wrap_angle_range() {
        assert_eq!(wrap_angle(PI), PI);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-15);
        assert!((wrap_angle(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-15);
        assert_eq!(wrap_angle(0.25), 0.25);
    }

    #[test]
    fn segment_intersection_cases() {
        assert!(segments_intersect(
            v(0., 0.),
            v(2., 2.),
            v(0., 2.),
            v(2., 0.)
        ));
        assert!(!segments_intersect(
            v(0., 0.),
            v(1., 0.),
            v(0., 1.),
            v(1., 1.)
        ));
        // Touching at an endpoint counts.
        assert!(segments_intersect(
            v(0., 0.),
            v(1., 0.),
            v(1., 0.),
            v(1., 1.)
        ));
        // Collinear overlap counts, collinear disjoint does not.
        assert!(segments_intersect(
            v(0., 0.),
            v(2., 0.),
            v(1., 0.),
            v(3., 0.)
        ));
        assert!(!segments_intersect(
            v(0., 0.),
            v(1., 0.),
            v(2., 0.),
            v(3., 0.)
        ));
    }

    #[test]
    fn polygon_distances() {
        let square = [v(0., 0.), v(1., 0.), v(1., 1.), v(0., 1.)];
        assert!(point_in_convex_polygon(&square, v(0.5, 0.5)));
        assert!(point_in_convex_polygon(&square, v(1.0, 0.5)));
        assert!(!point_in_convex_polygon(&square, v(1.5, 0.5)));
        assert!((point_convex_polygon_distance(&square, v(3., 0.5)) - 2.0).abs() < 1e-12);
        let other = [v(2., 0.), v(3., 0.), v(3., 1.), v(2., 1.)];
        assert!((convex_polygons_distance(&square, &other) - 1.0).abs() < 1e-12);
        let overlapping = [v(0.5, 0.5), v(2., 0.5), v(2., 2.), v(0.5, 2.)];
        assert_eq!(convex_polygons_distance(&square, &overlapping), 0.0);
        // One polygon strictly inside the other: no edges cross, distance still 0.
        let inner = [v(0.25, 0.25), v(0.75, 0.25), v(0.75, 0.75), v(0.25, 0.75)];
        assert_eq!(convex_polygons_distance(&square, &inner), 0.0);
        assert_eq!(convex_polygons_distance(&inner, &square), 0.0);
    }
}
