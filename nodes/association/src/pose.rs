//! Planar rigid-body poses, SE(2).
//!
//! The paper's "location" task (Sec. III-A, *Location & mapping*) estimates the AGV pose in the
//! plane of the factory floor: a position in metres and a heading in radians, in the map frame of
//! `docs/conventions.md` (x right, y up, yaw counter-clockwise from +x). [`Pose2`] is that pose and
//! also the rigid transform from the body frame it describes to its parent frame, so odometry
//! increments, scan-matching corrections and keyframe offsets are all `Pose2` values combined with
//! [`Pose2::compose`], [`Pose2::inverse`] and [`Pose2::between`].

use std::f64::consts::{PI, TAU};

/// Wraps an angle to (−π, π].
///
/// Angles already in range are returned bit-for-bit unchanged, so wrapping is idempotent and does
/// not perturb values that need no wrapping. A non-finite input is returned as is (NaN stays NaN),
/// so callers that must never produce a NaN check finiteness at their inputs.
///
/// ```
/// use nrslam_association::wrap_angle_rad;
/// use std::f64::consts::PI;
/// assert_eq!(wrap_angle_rad(-PI), PI);
/// assert!((wrap_angle_rad(3.0 * PI / 2.0) + PI / 2.0).abs() < 1e-12);
/// ```
pub fn wrap_angle_rad(angle_rad: f64) -> f64 {
    if !angle_rad.is_finite() || (angle_rad > -PI && angle_rad <= PI) {
        return angle_rad;
    }
    // rem_euclid lands in [0, 2π] (2π itself can appear by rounding of a tiny negative input),
    // so the shifted value lies in [−π, π]; −π is folded onto π to make the interval half-open.
    let wrapped = (angle_rad + PI).rem_euclid(TAU) - PI;
    if wrapped <= -PI {
        PI
    } else {
        wrapped
    }
}

/// A pose in the plane: the AGV (or any body) at (`x_m`, `y_m`) with heading `yaw_rad`.
///
/// Read as a transform, `Pose2` maps points from the body frame into the parent frame:
/// `p_parent = R(yaw) · p_body + (x, y)`. `yaw_rad` is kept in (−π, π] by every constructor and
/// operation of this type.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose2 {
    /// Position along the parent frame's x axis, metres.
    pub x_m: f64,
    /// Position along the parent frame's y axis, metres.
    pub y_m: f64,
    /// Heading counter-clockwise from the parent frame's +x axis, radians in (−π, π].
    pub yaw_rad: f64,
}

impl Pose2 {
    /// The identity transform (origin, heading 0).
    pub const IDENTITY: Pose2 = Pose2 {
        x_m: 0.0,
        y_m: 0.0,
        yaw_rad: 0.0,
    };

    /// A pose from its components; the heading is wrapped to (−π, π].
    pub fn new(x_m: f64, y_m: f64, yaw_rad: f64) -> Self {
        Pose2 {
            x_m,
            y_m,
            yaw_rad: wrap_angle_rad(yaw_rad),
        }
    }

    /// True when all three components are finite.
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite() && self.yaw_rad.is_finite()
    }

    /// `self ⊕ other`: `other` expressed in `self`'s body frame, mapped into `self`'s parent frame.
    ///
    /// With `a` the pose of frame A in the world and `b` the pose of frame B in A,
    /// `a.compose(&b)` is the pose of B in the world.
    pub fn compose(&self, other: &Pose2) -> Pose2 {
        let (sin, cos) = self.yaw_rad.sin_cos();
        Pose2::new(
            self.x_m + cos * other.x_m - sin * other.y_m,
            self.y_m + sin * other.x_m + cos * other.y_m,
            self.yaw_rad + other.yaw_rad,
        )
    }

    /// The inverse transform: `self.compose(&self.inverse())` is the identity.
    pub fn inverse(&self) -> Pose2 {
        let (sin, cos) = self.yaw_rad.sin_cos();
        Pose2::new(
            -cos * self.x_m - sin * self.y_m,
            sin * self.x_m - cos * self.y_m,
            -self.yaw_rad,
        )
    }

    /// The relative pose `self⁻¹ ⊕ other`: `other` expressed in `self`'s body frame.
    ///
    /// This is the odometry increment between two consecutive odometry poses, and
    /// `self.compose(&self.between(&other)) == other` up to rounding.
    pub fn between(&self, other: &Pose2) -> Pose2 {
        self.inverse().compose(other)
    }

    /// Maps a point from this pose's body frame into its parent frame, metres.
    pub fn transform_point(&self, point_m: [f64; 2]) -> [f64; 2] {
        let (sin, cos) = self.yaw_rad.sin_cos();
        [
            self.x_m + cos * point_m[0] - sin * point_m[1],
            self.y_m + sin * point_m[0] + cos * point_m[1],
        ]
    }

    /// Distance between the positions of two poses, metres (headings ignored).
    pub fn distance_m(&self, other: &Pose2) -> f64 {
        (self.x_m - other.x_m).hypot(self.y_m - other.y_m)
    }

    /// Absolute heading difference between two poses, radians in [0, π].
    pub fn rotation_to_rad(&self, other: &Pose2) -> f64 {
        wrap_angle_rad(other.yaw_rad - self.yaw_rad).abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const TOL: f64 = 1e-9;

    fn close(a: &Pose2, b: &Pose2, tol: f64) -> bool {
        (a.x_m - b.x_m).abs() < tol
            && (a.y_m - b.y_m).abs() < tol
            && wrap_angle_rad(a.yaw_rad - b.yaw_rad).abs() < tol
    }

    fn pose() -> impl Strategy<Value = Pose2> {
        (-1e3..1e3f64, -1e3..1e3f64, -10.0..10.0f64).prop_map(|(x, y, t)| Pose2::new(x, y, t))
    }

    #[test]
    fn wrap_edges() {
        assert_eq!(wrap_angle_rad(PI), PI);
        assert_eq!(wrap_angle_rad(-PI), PI);
        assert_eq!(wrap_angle_rad(0.0), 0.0);
        assert_eq!(wrap_angle_rad(3.0 * PI), PI);
        assert_eq!(wrap_angle_rad(-3.0 * PI), PI);
        assert!((wrap_angle_rad(TAU + 0.5) - 0.5).abs() < 1e-12);
        assert!(wrap_angle_rad(f64::NAN).is_nan());
        // A tiny negative multiple of 2π must not escape the interval through rounding.
        let w = wrap_angle_rad(-TAU - 1e-300);
        assert!(w > -PI && w <= PI);
    }

    #[test]
    fn compose_known_values() {
        let a = Pose2::new(1.0, 2.0, PI / 2.0);
        let b = Pose2::new(1.0, 0.0, PI / 2.0);
        let c = a.compose(&b);
        assert!(close(&c, &Pose2::new(1.0, 3.0, PI), TOL), "{c:?}");
        assert!(close(&a.between(&c), &b, TOL));
        let p = a.transform_point([1.0, 0.0]);
        assert!((p[0] - 1.0).abs() < TOL && (p[1] - 3.0).abs() < TOL);
    }

    proptest! {
        #[test]
        fn wrap_is_in_half_open_interval(a in -1e6..1e6f64) {
            let w = wrap_angle_rad(a);
            prop_assert!(w > -PI && w <= PI, "{a} -> {w}");
            // Same direction as the input (tolerance grows with |a| through rounding of a + π).
            prop_assert!((w.sin() - a.sin()).abs() < 1e-9 && (w.cos() - a.cos()).abs() < 1e-9);
            prop_assert_eq!(wrap_angle_rad(w).to_bits(), w.to_bits());
        }

        #[test]
        fn compose_with_inverse_is_identity(p in pose()) {
            prop_assert!(close(&p.compose(&p.inverse()), &Pose2::IDENTITY, TOL));
            prop_assert!(close(&p.inverse().compose(&p), &Pose2::IDENTITY, TOL));
            prop_assert!(close(&p.inverse().inverse(), &p, TOL));
        }

        #[test]
        fn compose_is_associative(a in pose(), b in pose(), c in pose()) {
            let left = a.compose(&b).compose(&c);
            let right = a.compose(&b.compose(&c));
            prop_assert!(close(&left, &right, 1e-8), "{left:?} vs {right:?}");
        }

        #[test]
        fn between_recovers_the_increment(a in pose(), d in pose()) {
            let b = a.compose(&d);
            prop_assert!(close(&a.between(&b), &d, 1e-8));
            prop_assert!(close(&a.compose(&a.between(&b)), &b, 1e-8));
        }

        #[test]
        fn transform_point_matches_compose(p in pose(), x in -50.0..50.0f64, y in -50.0..50.0f64) {
            let q = p.transform_point([x, y]);
            let c = p.compose(&Pose2::new(x, y, 0.0));
            prop_assert!((q[0] - c.x_m).abs() < TOL && (q[1] - c.y_m).abs() < TOL);
        }
    }
}
