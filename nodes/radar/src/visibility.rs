//! Which scatterers the radar sees from a pose: pure geometry, shared by every fidelity level.
//!
//! A scatterer is seen iff
//! 1. its range is within (0, `max_range_m`] (a scatterer exactly at the array has no direction
//!    of arrival, so it is not seen),
//! 2. its direction is within ±`half_fov_rad` of boresight,
//! 3. the surface it lies on faces the sensor (the far side of a box is hidden), and
//! 4. the line of sight is not blocked by any *other* target (exact segment–rectangle and
//!    segment–circle tests; a grazing ray counts as blocked).
//!
//! Its own target cannot block it: every target is convex, and when the surface at the scatterer
//! faces the sensor the whole segment to the sensor lies strictly outside the supporting line of
//! that surface, hence outside the target. So test 3 covers self-occlusion exactly.
//!
//! The result, a list of [`Sighting`]s with true range and angle, is what a measurement model
//! turns into data: [`crate::ideal`] adds Gaussian errors (the paper's ΔR, Δθ of Sec. IV-A);
//! the later `spectral` and `waveform` levels will synthesise echoes from the same list.

use crate::geometry::{wrap_angle, Pose2, Vec2};
use crate::scene::{Scatterer, Target};

/// The radar's mounting on the AGV and its visibility limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensor {
    /// Array boresight relative to the AGV heading (rad, counter-clockwise; π/2 = left).
    pub boresight_rad: f64,
    /// Farthest range seen (m), inclusive.
    pub max_range_m: f64,
    /// Half field of view about boresight (rad), inclusive.
    pub half_fov_rad: f64,
}

impl Default for Sensor {
    /// Boresight to the left (toward the inside of the counter-clockwise loop), 20 m, ±60°.
    fn default() -> Self {
        Self {
            boresight_rad: std::f64::consts::FRAC_PI_2,
            max_range_m: 20.0,
            half_fov_rad: 60f64.to_radians(),
        }
    }
}

impl Sensor {
    /// Direction of boresight in the map frame for an AGV heading (rad).
    pub fn boresight_in_map_rad(&self, agv_yaw_rad: f64) -> f64 {
        wrap_angle(agv_yaw_rad + self.boresight_rad)
    }

    /// Range (m) and angle from boresight (rad) of `point` from an AGV at `agv`, if it lies in
    /// range and field of view (tests 1 and 2 only).
    pub fn range_and_angle(&self, agv: Pose2, point: Vec2) -> Option<(f64, f64)> {
        let d = point - agv.position();
        let range_m = d.norm();
        if !(range_m > 0.0 && range_m <= self.max_range_m) {
            return None;
        }
        let angle_rad = wrap_angle(d.y.atan2(d.x) - agv.yaw_rad - self.boresight_rad);
        (angle_rad.abs() <= self.half_fov_rad).then_some((range_m, angle_rad))
    }
}

/// A scatterer seen from one pose, with its true range and angle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sighting {
    /// Index of the target in the scene (= its id).
    pub target_index: usize,
    /// Index of the scatterer in its target.
    pub scatterer_index: usize,
    /// Position of the scatterer (m), map frame.
    pub position: Vec2,
    /// True range from the array (m).
    pub range_m: f64,
    /// True angle from boresight, counter-clockwise (rad), within ±`half_fov_rad`.
    pub angle_rad: f64,
}

/// Every scatterer seen from `agv`, in scene order (target, then scatterer along the outline):
/// deterministic, so measurement noise drawn in this order is reproducible from a seed.
pub fn observe(targets: &[Target], sensor: &Sensor, agv: Pose2) -> Vec<Sighting> {
    let mut out = Vec::new();
    for (target_index, target) in targets.iter().enumerate() {
        for (scatterer_index, scatterer) in target.scatterers.iter().enumerate() {
            if let Some((range_m, angle_rad)) = sight(targets, sensor, agv, target_index, scatterer)
            {
                out.push(Sighting {
                    target_index,
                    scatterer_index,
                    position: scatterer.position,
                    range_m,
                    angle_rad,
                });
            }
        }
    }
    out
}

/// Range and angle of `scatterer` (on `targets[target_index]`) if it is seen from `agv`.
pub fn sight(
    targets: &[Target],
    sensor: &Sensor,
    agv: Pose2,
    target_index: usize,
    scatterer: &Scatterer,
) -> Option<(f64, f64)> {
    // Cheapest tests first: range and field of view, then facing, then occlusion.
    let seen = sensor.range_and_angle(agv, scatterer.position)?;
    let sensor_position = agv.position();
    if !scatterer.faces(sensor_position) {
        return None;
    }
    line_of_sight_clear(
        targets,
        sensor_position,
        scatterer.position,
        Some(target_index),
    )
    .then_some(seen)
}

/// Whether the segment `from`–`to` meets no target except `skip` (the target `to` lies on).
pub fn line_of_sight_clear(targets: &[Target], from: Vec2, to: Vec2, skip: Option<usize>) -> bool {
    targets
        .iter()
        .enumerate()
        .filter(|(i, _)| Some(*i) != skip)
        .all(|(_, t)| !t.shape.blocks_segment(from, to))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Shape;
    use std::f64::consts::FRAC_PI_2;

    fn target(id: u32, shape: Shape) -> Target {
        Target {
            id,
            name: String::new(),
            scatterers: shape.scatterers(0.25),
            shape,
        }
    }

    /// AGV at the origin heading +x, radar looking left (+y).
    fn agv() -> Pose2 {
        Pose2::new(0.0, 0.0, 0.0)
    }

    fn seen_of(targets: &[Target], index: usize) -> Vec<Sighting> {
        observe(targets, &Sensor::default(), agv())
            .into_iter()
            .filter(|s| s.target_index == index)
            .collect()
    }

    #[test]
    fn far_side_of_a_box_is_hidden() {
        // A 2 m × 2 m box 5 m ahead of the radar (on boresight): only its bottom face is seen.
        let targets = [target(
            0,
            Shape::rectangle(Vec2::new(0.0, 6.0), 2.0, 2.0, 0.0),
        )];
        let seen = seen_of(&targets, 0);
        assert!(!seen.is_empty());
        for s in &seen {
            assert!((s.position.y - 5.0).abs() < 1e-12, "{:?}", s.position);
        }
        // Both bottom corners are seen (a corner faces the sensor through either edge).
        assert_eq!(seen.len(), 9);
    }

    #[test]
    fn target_behind_another_is_hidden() {
        // A small tank 10 m out, hidden behind a wide wall 5 m out.
        let wall = target(0, Shape::rectangle(Vec2::new(0.0, 5.5), 6.0, 1.0, 0.0));
        let tank = target(1, Shape::circle(Vec2::new(0.0, 10.0), 0.5));
        let targets = [wall, tank.clone()];
        assert!(seen_of(&targets, 1).is_empty());
        assert!(!seen_of(&targets, 0).is_empty());
        // Without the wall the tank's near half is seen (the far half faces away).
        let alone = [tank];
        let seen = seen_of(&alone, 0);
        assert!(!seen.is_empty());
        assert!(seen.iter().all(|s| s.position.y < 10.0));
    }

    #[test]
    fn partial_occlusion_by_a_circle() {
        // A pillar in front of the middle of a long shelf hides only the shelf's middle.
        let shelf = target(0, Shape::rectangle(Vec2::new(0.0, 10.5), 8.0, 1.0, 0.0));
        let pillar = target(1, Shape::circle(Vec2::new(0.0, 5.0), 0.5));
        let targets = [shelf, pillar];
        let seen = seen_of(&targets, 0);
        assert!(seen.iter().any(|s| s.position.x < -2.0));
        assert!(seen.iter().any(|s| s.position.x > 2.0));
        // The pillar subtends ±asin(0.5/5) at the radar: at the shelf (10 m) that is ±1.005 m.
        assert!(seen.iter().all(|s| s.position.x.abs() > 1.0));
    }

    #[test]
    fn out_of_field_of_view_or_range_hidden() {
        // Straight ahead of the AGV = 90° off boresight: outside ±60°.
        let ahead = [target(0, Shape::circle(Vec2::new(5.0, 0.0), 0.5))];
        assert!(seen_of(&ahead, 0).is_empty());
        // Behind the radar (to the right of the AGV).
        let right = [target(0, Shape::circle(Vec2::new(0.0, -5.0), 0.5))];
        assert!(seen_of(&right, 0).is_empty());
        // On boresight but 25 m away, beyond 20 m.
        let far = [target(0, Shape::circle(Vec2::new(0.0, 25.0), 0.5))];
        assert!(seen_of(&far, 0).is_empty());
        // At 59° off boresight it is seen, at 61° not (the circle's near point decides).
        for (deg, expected) in [(59.0f64, true), (61.0, false)] {
            let dir = (90.0 - deg).to_radians();
            let c = Vec2::new(dir.cos(), dir.sin()) * 8.0;
            let tiny = [target(0, Shape::circle(c, 0.01))];
            assert_eq!(!seen_of(&tiny, 0).is_empty(), expected, "{deg}°");
        }
    }

    #[test]
    fn field_of_view_is_relative_to_heading_and_boresight() {
        let t = [target(0, Shape::circle(Vec2::new(5.0, 0.0), 0.5))];
        // Heading −90° (down): left is +x, the target is on boresight.
        let seen = observe(&t, &Sensor::default(), Pose2::new(0.0, 0.0, -FRAC_PI_2));
        assert!(!seen.is_empty());
        assert!(seen.iter().all(|s| s.angle_rad.abs() < 0.2));
        // Forward-looking radar on the AGV heading +x sees it too.
        let forward = Sensor {
            boresight_rad: 0.0,
            ..Sensor::default()
        };
        assert!(!observe(&t, &forward, agv()).is_empty());
    }

    #[test]
    fn range_and_angle_extremes() {
        let sensor = Sensor::default();
        // A point exactly at the array has no direction: not seen, no NaN.
        assert_eq!(sensor.range_and_angle(agv(), Vec2::new(0.0, 0.0)), None);
        // Exactly at max range: seen; a hair beyond: not.
        assert_eq!(
            sensor.range_and_angle(agv(), Vec2::new(0.0, 20.0)),
            Some((20.0, 0.0))
        );
        assert_eq!(
            sensor.range_and_angle(agv(), Vec2::new(0.0, 20.0 + 1e-9)),
            None
        );
        // Counter-clockwise positive: a point up-left is at a positive angle.
        let (_, angle) = sensor.range_and_angle(agv(), Vec2::new(-1.0, 1.0)).unwrap();
        assert!((angle - 45f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn scatterer_at_the_sensor() {
        // A box whose corner is exactly at the array (only possible outside a validated scene):
        // that corner has no direction and is not seen; nothing is NaN.
        let targets = [target(
            0,
            Shape::rectangle(Vec2::new(1.0, 1.0), 2.0, 2.0, 0.0),
        )];
        assert_eq!(targets[0].scatterers[0].position, Vec2::new(0.0, 0.0));
        let seen = observe(&targets, &Sensor::default(), agv());
        assert!(seen.iter().all(|s| s.scatterer_index != 0));
        assert!(seen
            .iter()
            .all(|s| s.range_m > 0.0 && s.range_m.is_finite() && s.angle_rad.is_finite()));
    }

    #[test]
    fn target_touching_max_range() {
        // A box whose near face is exactly at 20 m: the face's centre is seen, its corners are
        // beyond 20 m and hidden.
        let targets = [target(
            0,
            Shape::rectangle(Vec2::new(0.0, 20.5), 2.0, 1.0, 0.0),
        )];
        let seen = seen_of(&targets, 0);
        assert_eq!(seen.len(), 1);
        assert_eq!(seen[0].position, Vec2::new(0.0, 20.0));
        assert_eq!(seen[0].range_m, 20.0);
    }

    #[test]
    fn own_surface_does_not_occlude() {
        // Every scatterer of a lone box that faces the sensor and is in view is seen.
        let t = target(0, Shape::rectangle(Vec2::new(1.0, 6.0), 3.0, 2.0, 0.3));
        let sensor = Sensor::default();
        let facing = t
            .scatterers
            .iter()
            .filter(|s| {
                s.faces(agv().position()) && sensor.range_and_angle(agv(), s.position).is_some()
            })
            .count();
        assert!(facing > 0);
        assert_eq!(seen_of(&[t], 0).len(), facing);
    }

    #[test]
    fn grazing_ray_is_blocked() {
        // The ray to the scatterer just touches the blocker's corner.
        let blocker = target(0, Shape::rectangle(Vec2::new(1.0, 5.0), 2.0, 2.0, 0.0));
        let targets = [blocker];
        assert!(!line_of_sight_clear(
            &targets,
            Vec2::new(0.0, 0.0),
            Vec2::new(0.0, 10.0),
            None
        ));
        assert!(line_of_sight_clear(
            &targets,
            Vec2::new(-0.1, 0.0),
            Vec2::new(-0.1, 10.0),
            None
        ));
    }
}
