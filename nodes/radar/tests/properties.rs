//! Property tests: geometry against brute force, visibility invariants, odometry increments.

use nrslam_radar::geometry::{wrap_angle, Pose2};
use nrslam_radar::odometry::MotionIncrement;
use nrslam_radar::visibility::{line_of_sight_clear, observe};
use nrslam_radar::{Sensor, Shape, Target, Vec2};
use proptest::prelude::*;

fn rectangle() -> impl Strategy<Value = Shape> {
    (
        -5.0..5.0f64,
        -5.0..5.0f64,
        0.2..4.0f64,
        0.2..4.0f64,
        -3.2..3.2f64,
    )
        .prop_map(|(x, y, w, h, yaw)| Shape::rectangle(Vec2::new(x, y), w, h, yaw))
}

fn circle() -> impl Strategy<Value = Shape> {
    (-5.0..5.0f64, -5.0..5.0f64, 0.1..3.0f64)
        .prop_map(|(x, y, r)| Shape::circle(Vec2::new(x, y), r))
}

fn point() -> impl Strategy<Value = Vec2> {
    (-10.0..10.0f64, -10.0..10.0f64).prop_map(|(x, y)| Vec2::new(x, y))
}

fn target(shape: Shape) -> Target {
    Target {
        id: 0,
        name: String::new(),
        scatterers: shape.scatterers(0.3),
        shape,
    }
}

proptest! {
    /// Brute force: a segment that passes through the interior (some sample strictly inside,
    /// detected with a margin) is blocked; a segment far from the shape is not.
    #[test]
    fn blocking_agrees_with_sampling(shape in prop_oneof![rectangle(), circle()], a in point(), b in point()) {
        let blocked = shape.blocks_segment(a, b);
        let distance = shape.distance_to_segment(a, b);
        prop_assert_eq!(blocked, distance == 0.0);
        let samples = 2000;
        let mut deep_inside = false;
        for i in 0..=samples {
            let p = a + (b - a) * (i as f64 / samples as f64);
            // "Deep": still inside after moving 1e-6 m in every axis direction.
            let probes = [Vec2::new(1e-6, 0.0), Vec2::new(-1e-6, 0.0), Vec2::new(0.0, 1e-6), Vec2::new(0.0, -1e-6)];
            if probes.iter().all(|d| shape.contains(p + *d)) {
                deep_inside = true;
                break;
            }
        }
        if deep_inside {
            prop_assert!(blocked);
        }
        if distance > 1e-6 {
            prop_assert!(!deep_inside);
        }
    }

    /// Every sighting is within range and field of view, faces the sensor, has a clear line of
    /// sight, and its range/angle reconstruct its position.
    #[test]
    fn sightings_are_consistent(
        shapes in prop::collection::vec(prop_oneof![rectangle(), circle()], 1..4),
        x in -12.0..12.0f64, y in -12.0..12.0f64, yaw in -3.2..3.2f64,
    ) {
        let targets: Vec<Target> = shapes.into_iter().map(target).collect();
        let agv = Pose2::new(x, y, yaw);
        prop_assume!(targets.iter().all(|t| !t.shape.contains(agv.position())));
        let sensor = Sensor::default();
        for s in observe(&targets, &sensor, agv) {
            prop_assert!(s.range_m > 0.0 && s.range_m <= sensor.max_range_m);
            prop_assert!(s.angle_rad.abs() <= sensor.half_fov_rad);
            let scatterer = targets[s.target_index].scatterers[s.scatterer_index];
            prop_assert!(scatterer.faces(agv.position()));
            prop_assert!(line_of_sight_clear(&targets, agv.position(), s.position, Some(s.target_index)));
            let heading = agv.yaw_rad + sensor.boresight_rad + s.angle_rad;
            let back = agv.position() + Vec2::new(heading.cos(), heading.sin()) * s.range_m;
            prop_assert!((back - s.position).norm() < 1e-9);
        }
    }

    /// A station (pose heading = boresight, sensor boresight 0) sees exactly the scatterers a
    /// direct map-frame computation says it should: within its range, within its half field of
    /// view of its absolute boresight, facing it, with a clear line of sight; none twice.
    #[test]
    fn station_sightings_match_a_map_frame_check(
        shapes in prop::collection::vec(prop_oneof![rectangle(), circle()], 1..4),
        x in -12.0..12.0f64, y in -12.0..12.0f64, boresight in -3.2..3.2f64,
        half_fov in 0.05..1.55f64, max_range in 0.5..30.0f64,
    ) {
        let targets: Vec<Target> = shapes.into_iter().map(target).collect();
        let station = Pose2::new(x, y, boresight);
        prop_assume!(targets.iter().all(|t| t.shape.distance_to_segment(station.position(), station.position()) > 0.0));
        let sensor = Sensor { boresight_rad: 0.0, max_range_m: max_range, half_fov_rad: half_fov };
        let seen = observe(&targets, &sensor, station);
        let mut expected = Vec::new();
        for (ti, t) in targets.iter().enumerate() {
            for (si, s) in t.scatterers.iter().enumerate() {
                let d = s.position - station.position();
                let range = d.norm();
                let off_boresight = wrap_angle(d.y.atan2(d.x) - station.yaw_rad);
                if range > 0.0 && range <= max_range && off_boresight.abs() <= half_fov
                    && s.faces(station.position())
                    && line_of_sight_clear(&targets, station.position(), s.position, Some(ti))
                {
                    expected.push((ti, si));
                }
            }
        }
        let got: Vec<(usize, usize)> = seen.iter().map(|s| (s.target_index, s.scatterer_index)).collect();
        prop_assert_eq!(got, expected);
        for s in &seen {
            prop_assert!(s.range_m <= max_range && s.angle_rad.abs() <= half_fov);
        }
    }

    /// rotate–translate–rotate reproduces any relative pose.
    #[test]
    fn increments_round_trip(
        x0 in -50.0..50.0f64, y0 in -50.0..50.0f64, a0 in -3.2..3.2f64,
        x1 in -50.0..50.0f64, y1 in -50.0..50.0f64, a1 in -3.2..3.2f64,
    ) {
        let from = Pose2::new(x0, y0, a0);
        let to = Pose2::new(x1, y1, a1);
        let back = MotionIncrement::between(from, to).apply(from);
        prop_assert!((back.position() - to.position()).norm() < 1e-9);
        prop_assert!(wrap_angle(back.yaw_rad - to.yaw_rad).abs() < 1e-12);
    }

    /// A pose seen from itself is the identity, and seen from any origin it composes back.
    #[test]
    fn relative_poses_compose_back(
        x0 in -50.0..50.0f64, y0 in -50.0..50.0f64, a0 in -3.2..3.2f64,
        x1 in -50.0..50.0f64, y1 in -50.0..50.0f64, a1 in -3.2..3.2f64,
    ) {
        let origin = Pose2::new(x0, y0, a0);
        let pose = Pose2::new(x1, y1, a1);
        prop_assert_eq!(origin.relative_to(origin), Pose2::new(0.0, 0.0, 0.0));
        let r = pose.relative_to(origin);
        let (sin, cos) = origin.yaw_rad.sin_cos();
        let back = Vec2::new(x0 + cos * r.x_m - sin * r.y_m, y0 + sin * r.x_m + cos * r.y_m);
        prop_assert!((back - pose.position()).norm() < 1e-9);
        prop_assert!(wrap_angle(origin.yaw_rad + r.yaw_rad - pose.yaw_rad).abs() < 1e-12);
    }
}
