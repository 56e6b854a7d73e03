//! The AGV's loop: a counter-clockwise rounded rectangle driven at constant speed, sampled once
//! per radar frame.
//!
//! The paper (Sec. II-A) has "an AGV that loops around to detect environmental extended targets";
//! the loop's shape is not given, so ours is a rounded rectangle (straight aisles joined by
//! quarter-circle turns, as AGVs follow floor tracks). Frame k is at arc length
//! `speed_mps · frame_period_s · k` from the start point (the middle of the bottom straight,
//! plus `start_offset_m`), stamped `T0_S + k · frame_period_s` with `T0_S` = 1 s
//! (docs/conventions.md: simulated time never starts at 0).

use std::f64::consts::{FRAC_PI_2, PI};

use serde::{Deserialize, Serialize};

use crate::error::FieldError;
use crate::geometry::{Pose2, Vec2};
use crate::scene::positive;

/// Simulated time of frame 0 (s).
pub const T0_S: f64 = 1.0;

/// Largest number of frames a trajectory may produce (about 58 days at 0.5 s); guards against
/// absurd `laps` or `frame_period_s` values.
pub const MAX_FRAMES: usize = 10_000_000;

/// The `[trajectory]` table of the scene file.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TrajectorySpec {
    /// Left straight's x (m).
    pub x_min_m: f64,
    /// Bottom straight's y (m).
    pub y_min_m: f64,
    /// Right straight's x (m).
    pub x_max_m: f64,
    /// Top straight's y (m).
    pub y_max_m: f64,
    /// Radius of the four quarter-circle turns (m); 0 gives sharp corners (turn on the spot).
    pub corner_radius_m: f64,
    /// Arc length from the middle of the bottom straight to the start point, counter-clockwise
    /// (m).
    #[serde(default)]
    pub start_offset_m: f64,
    /// Constant speed along the loop (m/s).
    #[serde(default = "default_speed")]
    pub speed_mps: f64,
    /// Time between radar frames (s).
    #[serde(default = "default_period")]
    pub frame_period_s: f64,
    /// Number of laps driven (may be fractional).
    #[serde(default = "default_laps")]
    pub laps: f64,
    /// Radius of the AGV's footprint (m): the loop must keep this clearance from every target
    /// and from the hall's walls.
    #[serde(default = "default_agv_radius")]
    pub agv_radius_m: f64,
}

fn default_speed() -> f64 {
    1.0
}
fn default_period() -> f64 {
    0.5
}
fn default_laps() -> f64 {
    1.0
}
fn default_agv_radius() -> f64 {
    0.5
}

/// One piece of the loop.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Piece {
    /// A straight from `start` along `heading_rad`.
    Line {
        start: Vec2,
        heading_rad: f64,
        length_m: f64,
    },
    /// A counter-clockwise arc about `center`, starting at polar angle `start_angle_rad`.
    Arc {
        center: Vec2,
        radius_m: f64,
        start_angle_rad: f64,
        length_m: f64,
    },
}

impl Piece {
    fn length_m(&self) -> f64 {
        match self {
            Piece::Line { length_m, .. } | Piece::Arc { length_m, .. } => *length_m,
        }
    }

    /// Pose at arc length `u` into the piece, and the yaw rate per metre (curvature).
    fn pose_at(&self, u: f64) -> (Pose2, f64) {
        match *self {
            Piece::Line {
                start, heading_rad, ..
            } => {
                let p = start + Vec2::new(heading_rad.cos(), heading_rad.sin()) * u;
                (Pose2::new(p.x, p.y, heading_rad), 0.0)
            }
            Piece::Arc {
                center,
                radius_m,
                start_angle_rad,
                ..
            } => {
                let phi = start_angle_rad + u / radius_m;
                let p = center + Vec2::new(phi.cos(), phi.sin()) * radius_m;
                // Counter-clockwise: the heading leads the polar angle by 90°.
                (Pose2::new(p.x, p.y, phi + FRAC_PI_2), 1.0 / radius_m)
            }
        }
    }
}

/// A validated loop, sampled per frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    spec: TrajectorySpec,
    pieces: Vec<Piece>,
    lap_length_m: f64,
    /// Arc length, from the first piece's start, of frame 0.
    start_s_m: f64,
    frame_count: usize,
}

impl Trajectory {
    /// Validates the spec and builds the loop. Refuses a zero-length loop, zero speed, zero
    /// laps and a corner radius larger than half the loop's width or height; errors name the
    /// field (`trajectory.<name>`).
    pub fn new(spec: &TrajectorySpec) -> Result<Self, FieldError> {
        let field = |name: &str| format!("trajectory.{name}");
        for (name, value) in [
            ("x_min_m", spec.x_min_m),
            ("y_min_m", spec.y_min_m),
            ("x_max_m", spec.x_max_m),
            ("y_max_m", spec.y_max_m),
            ("start_offset_m", spec.start_offset_m),
        ] {
            if !value.is_finite() {
                return Err(FieldError::new(field(name), "must be finite"));
            }
        }
        if !(spec.corner_radius_m.is_finite() && spec.corner_radius_m >= 0.0) {
            return Err(FieldError::new(
                field("corner_radius_m"),
                format!("must be finite and ≥ 0, got {}", spec.corner_radius_m),
            ));
        }
        if !(spec.agv_radius_m.is_finite() && spec.agv_radius_m >= 0.0) {
            return Err(FieldError::new(
                field("agv_radius_m"),
                format!("must be finite and ≥ 0, got {}", spec.agv_radius_m),
            ));
        }
        positive(&field("speed_mps"), spec.speed_mps)?;
        positive(&field("frame_period_s"), spec.frame_period_s)?;
        positive(&field("laps"), spec.laps)?;
        let r = spec.corner_radius_m;
        let width_m = spec.x_max_m - spec.x_min_m;
        let height_m = spec.y_max_m - spec.y_min_m;
        if width_m < 2.0 * r {
            return Err(FieldError::new(
                field("x_max_m"),
                format!(
                    "x_max_m − x_min_m = {width_m} m must be ≥ 2 · corner_radius_m = {} m",
                    2.0 * r
                ),
            ));
        }
        if height_m < 2.0 * r {
            return Err(FieldError::new(
                field("y_max_m"),
                format!(
                    "y_max_m − y_min_m = {height_m} m must be ≥ 2 · corner_radius_m = {} m",
                    2.0 * r
                ),
            ));
        }
        let straight_x = width_m - 2.0 * r;
        let straight_y = height_m - 2.0 * r;
        let quarter = FRAC_PI_2 * r;
        let (x0, y0, x1, y1) = (spec.x_min_m, spec.y_min_m, spec.x_max_m, spec.y_max_m);
        let line = |x: f64, y: f64, heading_rad: f64, length_m: f64| Piece::Line {
            start: Vec2::new(x, y),
            heading_rad,
            length_m,
        };
        let arc = |x: f64, y: f64, start_angle_rad: f64| Piece::Arc {
            center: Vec2::new(x, y),
            radius_m: r,
            start_angle_rad,
            length_m: quarter,
        };
        let pieces = vec![
            line(x0 + r, y0, 0.0, straight_x),
            arc(x1 - r, y0 + r, -FRAC_PI_2),
            line(x1, y0 + r, FRAC_PI_2, straight_y),
            arc(x1 - r, y1 - r, 0.0),
            line(x1 - r, y1, PI, straight_x),
            arc(x0 + r, y1 - r, FRAC_PI_2),
            line(x0, y1 - r, -FRAC_PI_2, straight_y),
            arc(x0 + r, y0 + r, PI),
        ];
        let lap_length_m: f64 = pieces.iter().map(Piece::length_m).sum();
        if lap_length_m <= 0.0 {
            return Err(FieldError::new(
                "trajectory",
                "the loop has zero length (x_min_m = x_max_m, y_min_m = y_max_m and \
                 corner_radius_m = 0); a trajectory must move",
            ));
        }
        let step_m = spec.speed_mps * spec.frame_period_s;
        // Frames at s = 0, step, 2·step, … strictly before the end of the last lap; the
        // tolerance keeps an exact multiple from adding a frame that repeats frame 0.
        let frames = ((spec.laps * lap_length_m / step_m) - 1e-9).ceil().max(1.0);
        if !frames.is_finite() || frames > MAX_FRAMES as f64 {
            return Err(FieldError::new(
                field("laps"),
                format!(
                    "{} laps of {lap_length_m:.1} m at {step_m} m per frame is more than \
                     {MAX_FRAMES} frames",
                    spec.laps
                ),
            ));
        }
        Ok(Self {
            spec: spec.clone(),
            start_s_m: straight_x / 2.0 + spec.start_offset_m,
            pieces,
            lap_length_m,
            frame_count: frames as usize,
        })
    }

    /// The validated spec.
    pub fn spec(&self) -> &TrajectorySpec {
        &self.spec
    }

    /// Length of one lap (m).
    pub fn lap_length_m(&self) -> f64 {
        self.lap_length_m
    }

    /// Number of frames of the whole run (all laps).
    pub fn frame_count(&self) -> usize {
        self.frame_count
    }

    /// Time between frames (s).
    pub fn frame_period_s(&self) -> f64 {
        self.spec.frame_period_s
    }

    /// Simulated time of frame `k` (s): `T0_S + k · frame_period_s`.
    pub fn stamp_s(&self, k: usize) -> f64 {
        T0_S + k as f64 * self.spec.frame_period_s
    }

    /// Distance driven at frame `k` (m).
    pub fn distance_at_frame_m(&self, k: usize) -> f64 {
        k as f64 * self.spec.speed_mps * self.spec.frame_period_s
    }

    /// True pose at frame `k`.
    pub fn pose_at_frame(&self, k: usize) -> Pose2 {
        self.pose_at_distance(self.distance_at_frame_m(k))
    }

    /// True pose after driving `s_m` metres from the start point.
    pub fn pose_at_distance(&self, s_m: f64) -> Pose2 {
        self.locate(s_m).0
    }

    /// True yaw rate after driving `s_m` metres (rad/s): speed / corner radius in a turn,
    /// 0 on a straight.
    pub fn yaw_rate_at_distance(&self, s_m: f64) -> f64 {
        self.locate(s_m).1 * self.spec.speed_mps
    }

    fn locate(&self, s_m: f64) -> (Pose2, f64) {
        let mut u = (self.start_s_m + s_m).rem_euclid(self.lap_length_m);
        for piece in &self.pieces {
            // Zero-length pieces (sharp corners, a square loop's straights) are never chosen.
            if u < piece.length_m() {
                return piece.pose_at(u);
            }
            u -= piece.length_m();
        }
        // Rounding left u at the very end of the lap: that is the start of the first piece.
        self.pieces
            .iter()
            .find(|p| p.length_m() > 0.0)
            .map_or((Pose2::new(0.0, 0.0, 0.0), 0.0), |p| p.pose_at(0.0))
    }

    /// The loop as straight chords: each straight whole, each turn cut into chords of at most
    /// `max_arc_step_rad`. Used to check the loop's clearance from targets.
    pub fn chords(&self, max_arc_step_rad: f64) -> Vec<(Vec2, Vec2)> {
        let mut out = Vec::new();
        for piece in &self.pieces {
            let length_m = piece.length_m();
            if length_m <= 0.0 {
                continue;
            }
            let steps = match piece {
                Piece::Line { .. } => 1,
                Piece::Arc { radius_m, .. } => {
                    ((length_m / radius_m) / max_arc_step_rad).ceil().max(1.0) as usize
                }
            };
            for i in 0..steps {
                let a = piece.pose_at(length_m * i as f64 / steps as f64).0;
                let b = piece.pose_at(length_m * (i + 1) as f64 / steps as f64).0;
                out.push((a.position(), b.position()));
            }
        }
        out
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A one-lap loop of a 40 m × 30 m hall, the trajectory the module tests share.
    pub(crate) fn spec() -> TrajectorySpec {
        TrajectorySpec {
            x_min_m: 4.0,
            y_min_m: 5.0,
            x_max_m: 36.0,
            y_max_m: 25.0,
            corner_radius_m: 3.0,
            start_offset_m: 0.0,
            speed_mps: 1.0,
            frame_period_s: 0.5,
            laps: 1.0,
            agv_radius_m: 0.5,
        }
    }

    #[test]
    fn lap_length_and_frames() {
        let t = Trajectory::new(&spec()).unwrap();
        let expected = 2.0 * (26.0 + 14.0) + 2.0 * PI * 3.0;
        assert!((t.lap_length_m() - expected).abs() < 1e-9);
        assert_eq!(t.frame_count(), (expected / 0.5).ceil() as usize);
        assert_eq!(t.stamp_s(0), 1.0);
        assert_eq!(t.stamp_s(2), 2.0);
    }

    #[test]
    fn exact_multiple_does_not_repeat_frame_zero() {
        // A 10 m × 10 m square with sharp corners: 40 m, 80 frames at 0.5 m.
        let s = TrajectorySpec {
            x_min_m: 0.0,
            y_min_m: 0.0,
            x_max_m: 10.0,
            y_max_m: 10.0,
            corner_radius_m: 0.0,
            ..spec()
        };
        assert_eq!(Trajectory::new(&s).unwrap().frame_count(), 80);
    }

    #[test]
    fn start_pose_and_continuity() {
        let t = Trajectory::new(&spec()).unwrap();
        let p0 = t.pose_at_frame(0);
        assert_eq!((p0.x_m, p0.y_m, p0.yaw_rad), (20.0, 5.0, 0.0));
        // Walk the lap finely: steps never jump, the heading turns by 2π in total.
        let step = 0.01;
        let n = (t.lap_length_m() / step) as usize;
        let mut total_turn = 0.0;
        let mut prev = t.pose_at_distance(0.0);
        for i in 1..=n {
            let p = t.pose_at_distance(i as f64 * step);
            assert!((p.position() - prev.position()).norm() <= step + 1e-9);
            total_turn += crate::geometry::wrap_angle(p.yaw_rad - prev.yaw_rad);
            prev = p;
        }
        assert!((total_turn - 2.0 * PI).abs() < 0.01);
        // The loop closes.
        let end = t.pose_at_distance(t.lap_length_m());
        assert!((end.position() - p0.position()).norm() < 1e-9);
    }

    #[test]
    fn heading_matches_direction_of_motion() {
        let t = Trajectory::new(&spec()).unwrap();
        for k in 0..t.frame_count() {
            let s = t.distance_at_frame_m(k);
            let a = t.pose_at_distance(s);
            let b = t.pose_at_distance(s + 1e-6);
            let d = b.position() - a.position();
            let heading = d.y.atan2(d.x);
            assert!(crate::geometry::wrap_angle(heading - a.yaw_rad).abs() < 1e-4);
        }
    }

    #[test]
    fn yaw_rate_in_turns() {
        let t = Trajectory::new(&spec()).unwrap();
        assert_eq!(t.yaw_rate_at_distance(0.0), 0.0);
        // The first turn starts 13 m after the start (half of the 26 m bottom straight).
        assert!((t.yaw_rate_at_distance(14.0) - 1.0 / 3.0).abs() < 1e-12);
    }

    #[test]
    fn zero_length_and_bad_values_refused() {
        let degenerate = TrajectorySpec {
            x_max_m: 4.0,
            y_max_m: 5.0,
            corner_radius_m: 0.0,
            ..spec()
        };
        assert_eq!(
            Trajectory::new(&degenerate).unwrap_err().field,
            "trajectory"
        );
        let cases = [
            (
                TrajectorySpec {
                    speed_mps: 0.0,
                    ..spec()
                },
                "trajectory.speed_mps",
            ),
            (
                TrajectorySpec {
                    laps: 0.0,
                    ..spec()
                },
                "trajectory.laps",
            ),
            (
                TrajectorySpec {
                    frame_period_s: f64::NAN,
                    ..spec()
                },
                "trajectory.frame_period_s",
            ),
            (
                TrajectorySpec {
                    corner_radius_m: 11.0,
                    ..spec()
                },
                "trajectory.y_max_m",
            ),
            (
                TrajectorySpec {
                    laps: 1e12,
                    ..spec()
                },
                "trajectory.laps",
            ),
        ];
        for (s, field) in cases {
            assert_eq!(Trajectory::new(&s).unwrap_err().field, field);
        }
    }
}
