//! An AGV's path, driven at constant speed and sampled once per radar frame: the scene's loop (a
//! rounded rectangle, counter-clockwise or clockwise) or a polyline through waypoints (closed or
//! open).
//!
//! The paper (Sec. II-A) has "an AGV that loops around to detect environmental extended targets";
//! the loop's shape is not given, so ours is a rounded rectangle (straight aisles joined by
//! quarter-circle turns, as AGVs follow floor tracks). Frame k is at arc length
//! `speed_mps · frame_period_s · k` from the start point (the middle of the bottom straight,
//! plus `start_offset_m` along the direction of travel), stamped `T0_S + k · frame_period_s` with
//! `T0_S` = 1 s (docs/conventions.md: simulated time never starts at 0).
//!
//! A waypoint path is a polyline of straight pieces: the heading is along the piece the AGV is
//! on and turns on the spot at a waypoint (at a waypoint exactly, the heading is already the next
//! piece's). A closed path joins the last waypoint to the first and may be driven several laps;
//! an open one is driven once, first waypoint to last, and its last frame may be the last
//! waypoint itself.

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

/// Most waypoints a path may have: a bound on the work of validating it.
pub const MAX_WAYPOINTS: usize = 10_000;

/// The `[trajectory]` table of the scene file (and an `[[agv]]` entry's `trajectory`).
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
    /// Arc length from the middle of the bottom straight to the start point, along the direction
    /// of travel (m).
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
    /// Drive the loop clockwise (the inside is then to the AGV's right: a sensor looking at the
    /// targets inside needs `boresight_deg = -90`). Left out of written files when false, so
    /// single-AGV scenes are written as before.
    #[serde(default, skip_serializing_if = "is_false")]
    pub clockwise: bool,
}

fn is_false(value: &bool) -> bool {
    !*value
}

pub(crate) fn default_speed() -> f64 {
    1.0
}
pub(crate) fn default_period() -> f64 {
    0.5
}
pub(crate) fn default_laps() -> f64 {
    1.0
}
pub(crate) fn default_agv_radius() -> f64 {
    0.5
}

/// A path through waypoints (an `[[agv]]` entry with `waypoints_m`), defaults filled in.
#[derive(Debug, Clone, PartialEq)]
pub struct WaypointsSpec {
    /// The waypoints (m), map frame, in driving order.
    pub waypoints_m: Vec<[f64; 2]>,
    /// Whether the last waypoint joins the first (a loop, driven `laps` times) or the path ends
    /// at the last waypoint (driven once).
    pub closed: bool,
    /// Arc length from the first waypoint to the start point (m), closed paths only.
    pub start_offset_m: f64,
    /// Constant speed along the path (m/s).
    pub speed_mps: f64,
    /// Time between radar frames (s).
    pub frame_period_s: f64,
    /// Number of laps driven (closed paths; may be fractional).
    pub laps: f64,
    /// Radius of the AGV's footprint (m): the clearance from targets and walls.
    pub agv_radius_m: f64,
}

/// One piece of a path.
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

/// What a path was built from.
#[derive(Debug, Clone, PartialEq)]
enum Source {
    Loop(TrajectorySpec),
    Waypoints(WaypointsSpec),
}

/// A validated path, sampled per frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Trajectory {
    source: Source,
    pieces: Vec<Piece>,
    /// A closed path's lap, an open path's whole length (m).
    lap_length_m: f64,
    /// Arc length, from the first piece's start, of frame 0 (always counted along the pieces,
    /// which run counter-clockwise for a loop).
    start_s_m: f64,
    closed: bool,
    /// Driven against the pieces' direction (a clockwise loop).
    reversed: bool,
    speed_mps: f64,
    frame_period_s: f64,
    agv_radius_m: f64,
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
        let frame_count =
            closed_frame_count(spec.laps, lap_length_m, spec.speed_mps, spec.frame_period_s)
                .map_err(|problem| FieldError::new(field("laps"), problem))?;
        // A clockwise AGV goes the other way along the same pieces: its offset is subtracted.
        let start_s_m = if spec.clockwise {
            straight_x / 2.0 - spec.start_offset_m
        } else {
            straight_x / 2.0 + spec.start_offset_m
        };
        Ok(Self {
            source: Source::Loop(spec.clone()),
            start_s_m,
            pieces,
            lap_length_m,
            closed: true,
            reversed: spec.clockwise,
            speed_mps: spec.speed_mps,
            frame_period_s: spec.frame_period_s,
            agv_radius_m: spec.agv_radius_m,
            frame_count,
        })
    }

    /// Validates a waypoint path and builds it. Errors name the field relative to the `[[agv]]`
    /// entry (`waypoints_m[2]`, `speed_mps`, ...).
    pub fn from_waypoints(spec: &WaypointsSpec) -> Result<Self, FieldError> {
        let points = &spec.waypoints_m;
        if points.len() < 2 || points.len() > MAX_WAYPOINTS {
            return Err(FieldError::new(
                "waypoints_m",
                format!(
                    "has {} waypoints; a path needs 2 to {MAX_WAYPOINTS}",
                    points.len()
                ),
            ));
        }
        for (i, p) in points.iter().enumerate() {
            if !(p[0].is_finite() && p[1].is_finite()) {
                return Err(FieldError::new(
                    format!("waypoints_m[{i}]"),
                    format!("must be finite, got [{}, {}]", p[0], p[1]),
                ));
            }
        }
        if !spec.start_offset_m.is_finite() {
            return Err(FieldError::new("start_offset_m", "must be finite"));
        }
        if !(spec.agv_radius_m.is_finite() && spec.agv_radius_m >= 0.0) {
            return Err(FieldError::new(
                "agv_radius_m",
                format!("must be finite and ≥ 0, got {}", spec.agv_radius_m),
            ));
        }
        positive("speed_mps", spec.speed_mps)?;
        positive("frame_period_s", spec.frame_period_s)?;
        positive("laps", spec.laps)?;
        if !spec.closed && (spec.laps != 1.0 || spec.start_offset_m != 0.0) {
            let field = if spec.laps != 1.0 {
                "laps"
            } else {
                "start_offset_m"
            };
            return Err(FieldError::new(
                field,
                "is for closed paths; an open path (closed = false) is driven once, from the \
                 first waypoint to the last",
            ));
        }
        let mut ends: Vec<(usize, usize)> = (1..points.len()).map(|i| (i - 1, i)).collect();
        // A closed path whose last waypoint repeats the first needs no closing piece.
        if spec.closed && points[points.len() - 1] != points[0] {
            ends.push((points.len() - 1, 0));
        }
        let mut pieces = Vec::with_capacity(ends.len());
        for (from, to) in ends {
            let a = Vec2::new(points[from][0], points[from][1]);
            let b = Vec2::new(points[to][0], points[to][1]);
            let d = b - a;
            let length_m = d.norm();
            // Zero-length pieces would have no heading; a repeated waypoint is a typo.
            if !(length_m > 0.0 && length_m.is_finite()) {
                return Err(FieldError::new(
                    format!("waypoints_m[{to}]"),
                    format!(
                        "repeats waypoints_m[{from}] (or is too far from it); consecutive \
                         waypoints must differ"
                    ),
                ));
            }
            pieces.push(Piece::Line {
                start: a,
                heading_rad: d.y.atan2(d.x),
                length_m,
            });
        }
        let lap_length_m: f64 = pieces.iter().map(Piece::length_m).sum();
        if !lap_length_m.is_finite() {
            return Err(FieldError::new("waypoints_m", "the path is too long"));
        }
        let frame_count = if spec.closed {
            closed_frame_count(spec.laps, lap_length_m, spec.speed_mps, spec.frame_period_s)
                .map_err(|problem| FieldError::new("laps", problem))?
        } else {
            // Frames at s = 0, step, … up to and including the end (the tolerance keeps an
            // exact multiple's last frame).
            let step_m = spec.speed_mps * spec.frame_period_s;
            let frames = (lap_length_m / step_m + 1e-9).floor() + 1.0;
            if !frames.is_finite() || frames > MAX_FRAMES as f64 {
                return Err(FieldError::new(
                    "waypoints_m",
                    format!(
                        "{lap_length_m:.1} m at {step_m} m per frame is more than {MAX_FRAMES} \
                         frames"
                    ),
                ));
            }
            frames as usize
        };
        Ok(Self {
            source: Source::Waypoints(spec.clone()),
            start_s_m: spec.start_offset_m,
            pieces,
            lap_length_m,
            closed: spec.closed,
            reversed: false,
            speed_mps: spec.speed_mps,
            frame_period_s: spec.frame_period_s,
            agv_radius_m: spec.agv_radius_m,
            frame_count,
        })
    }

    /// The loop's spec, if this is a rounded-rectangle loop (`None` for a waypoint path).
    pub fn loop_spec(&self) -> Option<&TrajectorySpec> {
        match &self.source {
            Source::Loop(spec) => Some(spec),
            Source::Waypoints(_) => None,
        }
    }

    /// The waypoint path's spec, if this is one.
    pub fn waypoints_spec(&self) -> Option<&WaypointsSpec> {
        match &self.source {
            Source::Waypoints(spec) => Some(spec),
            Source::Loop(_) => None,
        }
    }

    /// Whether the path is closed (a loop, driven lap after lap).
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    /// Length of one lap (m); an open path's whole length.
    pub fn lap_length_m(&self) -> f64 {
        self.lap_length_m
    }

    /// Number of frames of the whole run (all laps).
    pub fn frame_count(&self) -> usize {
        self.frame_count
    }

    /// Time between frames (s).
    pub fn frame_period_s(&self) -> f64 {
        self.frame_period_s
    }

    /// Constant speed along the path (m/s).
    pub fn speed_mps(&self) -> f64 {
        self.speed_mps
    }

    /// Radius of the AGV's footprint (m).
    pub fn agv_radius_m(&self) -> f64 {
        self.agv_radius_m
    }

    /// Simulated time of frame `k` (s): `T0_S + k · frame_period_s`.
    pub fn stamp_s(&self, k: usize) -> f64 {
        T0_S + k as f64 * self.frame_period_s
    }

    /// Distance driven at frame `k` (m).
    pub fn distance_at_frame_m(&self, k: usize) -> f64 {
        k as f64 * self.speed_mps * self.frame_period_s
    }

    /// True pose at frame `k`.
    pub fn pose_at_frame(&self, k: usize) -> Pose2 {
        self.pose_at_distance(self.distance_at_frame_m(k))
    }

    /// True pose after driving `s_m` metres from the start point (an open path stays at its
    /// ends beyond them).
    pub fn pose_at_distance(&self, s_m: f64) -> Pose2 {
        self.locate(s_m).0
    }

    /// True yaw rate after driving `s_m` metres (rad/s): ± speed / corner radius in a turn of
    /// the loop (negative clockwise), 0 on a straight and on a waypoint path (it turns on the
    /// spot).
    pub fn yaw_rate_at_distance(&self, s_m: f64) -> f64 {
        self.locate(s_m).1 * self.speed_mps
    }

    fn locate(&self, s_m: f64) -> (Pose2, f64) {
        if self.reversed {
            return self.locate_reversed(s_m);
        }
        let mut u = if self.closed {
            (self.start_s_m + s_m).rem_euclid(self.lap_length_m)
        } else {
            (self.start_s_m + s_m).clamp(0.0, self.lap_length_m)
        };
        for piece in &self.pieces {
            // Zero-length pieces (sharp corners, a square loop's straights) are never chosen.
            if u < piece.length_m() {
                return piece.pose_at(u);
            }
            u -= piece.length_m();
        }
        if let (false, Some(Piece::Line { heading_rad, .. }), Source::Waypoints(spec)) =
            (self.closed, self.pieces.last(), &self.source)
        {
            // The end of an open path: the last waypoint exactly (not start + heading · length,
            // which rounds), heading along the last piece.
            if let Some(&[x, y]) = spec.waypoints_m.last() {
                return (Pose2::new(x, y, *heading_rad), 0.0);
            }
        }
        // Rounding left u at the very end of the lap: that is the start of the first piece.
        self.pieces
            .iter()
            .find(|p| p.length_m() > 0.0)
            .map_or((Pose2::new(0.0, 0.0, 0.0), 0.0), |p| p.pose_at(0.0))
    }

    /// A closed path driven against its pieces: at arc coordinate u the AGV is about to drive
    /// back along the piece ending at u, so the piece is chosen with u in (start, end] (the
    /// outgoing heading at a sharp corner, as forwards), and the heading is turned by π.
    fn locate_reversed(&self, s_m: f64) -> (Pose2, f64) {
        let mut u = (self.start_s_m - s_m).rem_euclid(self.lap_length_m);
        if u <= 0.0 {
            u = self.lap_length_m;
        }
        for piece in &self.pieces {
            let length_m = piece.length_m();
            if length_m > 0.0 && u <= length_m {
                let (pose, curvature) = piece.pose_at(u);
                return (
                    Pose2::new(pose.x_m, pose.y_m, pose.yaw_rad + PI),
                    -curvature,
                );
            }
            u -= length_m;
        }
        // Rounding left u beyond the lap: the end of the last piece.
        self.pieces
            .iter()
            .rev()
            .find(|p| p.length_m() > 0.0)
            .map_or((Pose2::new(0.0, 0.0, 0.0), 0.0), |p| {
                let (pose, curvature) = p.pose_at(p.length_m());
                (
                    Pose2::new(pose.x_m, pose.y_m, pose.yaw_rad + PI),
                    -curvature,
                )
            })
    }

    /// The path as straight chords: each straight whole, each turn cut into chords of at most
    /// `max_arc_step_rad`. Used to check the path's clearance from targets.
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

/// Frames of a closed path: at s = 0, step, 2·step, … strictly before the end of the last lap;
/// the tolerance keeps an exact multiple from adding a frame that repeats frame 0.
fn closed_frame_count(
    laps: f64,
    lap_length_m: f64,
    speed_mps: f64,
    frame_period_s: f64,
) -> Result<usize, String> {
    let step_m = speed_mps * frame_period_s;
    let frames = ((laps * lap_length_m / step_m) - 1e-9).ceil().max(1.0);
    if !frames.is_finite() || frames > MAX_FRAMES as f64 {
        return Err(format!(
            "{laps} laps of {lap_length_m:.1} m at {step_m} m per frame is more than \
             {MAX_FRAMES} frames"
        ));
    }
    Ok(frames as usize)
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
            clockwise: false,
        }
    }

    fn waypoints(points: &[[f64; 2]], closed: bool) -> WaypointsSpec {
        WaypointsSpec {
            waypoints_m: points.to_vec(),
            closed,
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

    #[test]
    fn clockwise_loop_is_the_same_path_driven_backwards() {
        let ccw = Trajectory::new(&spec()).unwrap();
        let cw = Trajectory::new(&TrajectorySpec {
            clockwise: true,
            ..spec()
        })
        .unwrap();
        assert_eq!(cw.frame_count(), ccw.frame_count());
        // Same start point, heading −x; after s metres it is where the counter-clockwise AGV
        // is after lap − s metres, facing the other way.
        let p0 = cw.pose_at_frame(0);
        assert_eq!((p0.x_m, p0.y_m), (20.0, 5.0));
        assert!((p0.yaw_rad.abs() - PI).abs() < 1e-12);
        let lap = ccw.lap_length_m();
        for s in [0.3, 13.0, 14.5, 40.0, 77.7, lap - 0.1] {
            let a = cw.pose_at_distance(s);
            let b = ccw.pose_at_distance(lap - s);
            assert!((a.position() - b.position()).norm() < 1e-9, "{s}");
            assert!(
                (crate::geometry::wrap_angle(a.yaw_rad - b.yaw_rad).abs() - PI).abs() < 1e-9,
                "{s}"
            );
        }
        // The heading follows the motion and the turns are to the right.
        for k in 0..cw.frame_count() {
            let s = cw.distance_at_frame_m(k);
            let a = cw.pose_at_distance(s);
            let b = cw.pose_at_distance(s + 1e-6);
            let d = b.position() - a.position();
            assert!(crate::geometry::wrap_angle(d.y.atan2(d.x) - a.yaw_rad).abs() < 1e-4);
        }
        // 13 m to the turn at the bottom left, then a right turn.
        assert!((cw.yaw_rate_at_distance(14.0) + 1.0 / 3.0).abs() < 1e-12);
        // The start offset runs along the direction of travel: 13 m clockwise is the end of the
        // bottom straight's left half.
        let offset = Trajectory::new(&TrajectorySpec {
            clockwise: true,
            start_offset_m: 13.0,
            ..spec()
        })
        .unwrap();
        let p = offset.pose_at_frame(0);
        assert!((p.position() - Vec2::new(7.0, 5.0)).norm() < 1e-9);
    }

    #[test]
    fn sharp_clockwise_corners_turn_to_the_outgoing_heading() {
        let square = TrajectorySpec {
            x_min_m: 0.0,
            y_min_m: 0.0,
            x_max_m: 10.0,
            y_max_m: 10.0,
            corner_radius_m: 0.0,
            clockwise: true,
            ..spec()
        };
        let t = Trajectory::new(&square).unwrap();
        // 5 m from (5, 0) heading −x is the corner (0, 0); the next side goes up (+y).
        let corner = t.pose_at_distance(5.0);
        assert!((corner.position() - Vec2::new(0.0, 0.0)).norm() < 1e-12);
        assert!((corner.yaw_rad - FRAC_PI_2).abs() < 1e-12);
        // A whole lap later it is back at the start heading −x.
        let back = t.pose_at_distance(40.0);
        assert!((back.position() - Vec2::new(5.0, 0.0)).norm() < 1e-9);
        assert!((back.yaw_rad.abs() - PI).abs() < 1e-12);
    }

    #[test]
    fn closed_waypoint_path() {
        // A 10 m × 4 m rectangle, counter-clockwise: 28 m, 56 frames.
        let t = Trajectory::from_waypoints(&waypoints(
            &[[0.0, 0.0], [10.0, 0.0], [10.0, 4.0], [0.0, 4.0]],
            true,
        ))
        .unwrap();
        assert!(t.is_closed() && t.loop_spec().is_none());
        assert_eq!(t.lap_length_m(), 28.0);
        assert_eq!(t.frame_count(), 56);
        let p = t.pose_at_frame(0);
        assert_eq!((p.x_m, p.y_m, p.yaw_rad), (0.0, 0.0, 0.0));
        // On a piece the heading is along it; at a waypoint it is already the next piece's.
        assert_eq!(t.pose_at_distance(9.5).yaw_rad, 0.0);
        let corner = t.pose_at_distance(10.0);
        assert_eq!((corner.x_m, corner.y_m), (10.0, 0.0));
        assert!((corner.yaw_rad - FRAC_PI_2).abs() < 1e-15);
        assert_eq!(t.yaw_rate_at_distance(10.0), 0.0);
        // The closing piece runs back down to the first waypoint.
        let closing = t.pose_at_distance(26.0);
        assert!((closing.position() - Vec2::new(0.0, 2.0)).norm() < 1e-12);
        assert!((closing.yaw_rad + FRAC_PI_2).abs() < 1e-15);
        // Repeating the first waypoint at the end is the same path; a start offset moves
        // frame 0 along it.
        let repeated = Trajectory::from_waypoints(&waypoints(
            &[[0.0, 0.0], [10.0, 0.0], [10.0, 4.0], [0.0, 4.0], [0.0, 0.0]],
            true,
        ))
        .unwrap();
        assert_eq!(repeated.lap_length_m(), 28.0);
        let offset = Trajectory::from_waypoints(&WaypointsSpec {
            start_offset_m: 12.0,
            laps: 2.0,
            ..waypoints(&[[0.0, 0.0], [10.0, 0.0], [10.0, 4.0], [0.0, 4.0]], true)
        })
        .unwrap();
        assert_eq!(offset.frame_count(), 112);
        assert!((offset.pose_at_frame(0).position() - Vec2::new(10.0, 2.0)).norm() < 1e-12);
    }

    #[test]
    fn open_waypoint_path_ends_at_its_last_waypoint() {
        let t =
            Trajectory::from_waypoints(&waypoints(&[[0.0, 0.0], [3.0, 4.0], [3.0, 10.0]], false))
                .unwrap();
        assert!(!t.is_closed());
        assert_eq!(t.lap_length_m(), 11.0);
        // s = 0, 0.5, …, 11: the end is a frame.
        assert_eq!(t.frame_count(), 23);
        let end = t.pose_at_frame(22);
        assert_eq!((end.x_m, end.y_m), (3.0, 10.0));
        assert!((end.yaw_rad - FRAC_PI_2).abs() < 1e-15);
        // Beyond the end it stays there.
        assert_eq!(t.pose_at_distance(50.0), end);
        let first = t.pose_at_frame(1);
        assert!((first.position() - Vec2::new(0.3, 0.4)).norm() < 1e-12);
    }

    #[test]
    fn bad_waypoints_are_refused_by_name() {
        let good = waypoints(&[[0.0, 0.0], [10.0, 0.0], [10.0, 4.0]], true);
        let cases: Vec<(WaypointsSpec, &str)> = vec![
            (waypoints(&[[0.0, 0.0]], true), "waypoints_m"),
            (
                waypoints(&[[0.0, 0.0], [f64::NAN, 1.0], [3.0, 3.0]], true),
                "waypoints_m[1]",
            ),
            (
                waypoints(&[[0.0, 0.0], [1.0, 1.0], [1.0, 1.0]], true),
                "waypoints_m[2]",
            ),
            (
                WaypointsSpec {
                    speed_mps: 0.0,
                    ..good.clone()
                },
                "speed_mps",
            ),
            (
                WaypointsSpec {
                    frame_period_s: -1.0,
                    ..good.clone()
                },
                "frame_period_s",
            ),
            (
                WaypointsSpec {
                    closed: false,
                    laps: 2.0,
                    ..good.clone()
                },
                "laps",
            ),
            (
                WaypointsSpec {
                    closed: false,
                    start_offset_m: 1.0,
                    ..good.clone()
                },
                "start_offset_m",
            ),
            (
                WaypointsSpec {
                    agv_radius_m: f64::INFINITY,
                    ..good.clone()
                },
                "agv_radius_m",
            ),
            (
                WaypointsSpec {
                    laps: 1e12,
                    ..good.clone()
                },
                "laps",
            ),
            (
                waypoints(&[[0.0, 0.0], [1e308, 0.0], [0.0, 0.0]], false),
                "waypoints_m",
            ),
        ];
        for (spec, field) in cases {
            assert_eq!(
                Trajectory::from_waypoints(&spec).unwrap_err().field,
                field,
                "{spec:?}"
            );
        }
    }
}
