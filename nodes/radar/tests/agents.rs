//! Several sensors on one scene: the radar node as any AGV of a scene (`sensor = "agvN"`), as a
//! fixed station (`"stationN"`) or as none (`"none"`), odometry from the AGV's own start
//! (`odom_origin = "start"`), and the shipped multi-agent scenes.

use std::path::{Path, PathBuf};

use nrslam_msgs::topics::{CLOCK, DETECTIONS, GROUND_TRUTH_POSE, GROUND_TRUTH_TARGETS, ODOM};
use nrslam_msgs::{Message, Pose};
use nrslam_radar::geometry::Pose2;
use nrslam_radar::odometry::OdometryReading;
use nrslam_radar::params::OdomOrigin;
use nrslam_radar::visibility::observe;
use nrslam_radar::{build, Params, Scene, Simulator};
use nrslam_runtime::{NodeContext, NodeError, Outbox, Tick};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn scene(name: &str) -> Scene {
    Scene::load(&workspace().join("config").join(name)).unwrap()
}

fn context(seed: u64) -> NodeContext {
    let mut ctx = NodeContext::for_tests(seed);
    ctx.name = "radar".into();
    ctx.base_dir = workspace();
    ctx
}

fn cooperative(sensor: &str) -> Params {
    Params {
        scene: "config/hall-cooperative.toml".into(),
        sensor: sensor.into(),
        ..Params::default()
    }
}

fn noiseless(params: Params) -> Params {
    Params {
        range_std_m: 0.0,
        angle_std_deg: 0.0,
        odom_translation_noise: 0.0,
        odom_rotation_noise_deg_per_m: 0.0,
        ..params
    }
}

/// Every message the node publishes until it is done.
fn run_node(params: Params, seed: u64) -> Vec<(&'static str, Message)> {
    let mut node = build(params, &context(seed)).unwrap();
    let mut outbox = Outbox::new();
    let mut published = Vec::new();
    for _ in 0..100_000 {
        let tick = node.tick(&mut outbox).unwrap();
        published.extend(outbox.drain());
        if tick == Tick::Done {
            return published;
        }
    }
    panic!("the radar node never finished");
}

fn on(published: &[(&'static str, Message)], topic: &str) -> Vec<Message> {
    published
        .iter()
        .filter(|(t, _)| *t == topic)
        .map(|(_, m)| m.clone())
        .collect()
}

fn pose_of(pose: Pose2) -> Pose {
    Pose::from_planar(pose.x_m, pose.y_m, pose.yaw_rad)
}

fn params_error(params: Params) -> nrslam_runtime::InvalidParam {
    match build(params, &context(1)).err().unwrap() {
        NodeError::Params(p) => p,
        other => panic!("expected a parameter error, got {other}"),
    }
}

#[test]
fn single_agv_scenes_are_unchanged_and_agv1_is_the_default() {
    let hall = scene("hall.toml");
    assert_eq!(hall.agvs.len(), 1);
    assert_eq!(hall.agvs[0].name, "agv1");
    assert_eq!(hall.agvs[0].trajectory, hall.trajectory);
    assert!(hall.stations.is_empty());
    // sensor = "" and "agv1" are the same run, message for message.
    let default = run_node(
        Params {
            frames: 6,
            ..Params::default()
        },
        9,
    );
    let agv1 = run_node(
        Params {
            frames: 6,
            sensor: "agv1".into(),
            ..Params::default()
        },
        9,
    );
    assert_eq!(default, agv1);
    // The cooperative hall's agv1 is the hall's AGV on the hall's targets: its run is the
    // hall's run.
    let cooperative = run_node(
        Params {
            frames: 6,
            ..cooperative("agv1")
        },
        9,
    );
    assert_eq!(cooperative, default);
}

#[test]
fn agv2_follows_the_second_agv() {
    let coop = scene("hall-cooperative.toml");
    let agv2 = &coop.agvs[1];
    let published = run_node(
        Params {
            frames: 12,
            ..noiseless(cooperative("agv2"))
        },
        2,
    );
    let truths = on(&published, GROUND_TRUTH_POSE);
    assert_eq!(truths.len(), 12);
    for (k, truth) in truths.iter().enumerate() {
        let Message::PoseStamped(truth) = truth else {
            panic!("{truth:?}")
        };
        assert_eq!(
            truth.pose,
            pose_of(agv2.trajectory.pose_at_frame(k)),
            "frame {k}"
        );
        assert_eq!(truth.header.stamp.as_seconds(), 1.0 + 0.5 * k as f64);
    }
    // Half a lap ahead of agv1: the middle of the top straight, heading −x.
    let start = agv2.trajectory.pose_at_frame(0);
    assert!((start.x_m - 27.0).abs() < 1e-9 && (start.y_m - 38.0).abs() < 1e-12);
    assert!((start.yaw_rad.abs() - std::f64::consts::PI).abs() < 1e-12);
    // Its detections, turned into the map frame, lie on targets.
    for message in on(&published, DETECTIONS) {
        let Message::Detections(d) = message else {
            unreachable!()
        };
        assert!(!d.detections.is_empty());
    }
    // agv3 drives clockwise, its radar to the right.
    let agv3 = run_node(
        Params {
            frames: 2,
            ..cooperative("agv3")
        },
        2,
    );
    let Message::Detections(d) = &on(&agv3, DETECTIONS)[0] else {
        unreachable!()
    };
    assert_eq!(d.boresight_rad, -std::f64::consts::FRAC_PI_2);
}

#[test]
fn a_sensor_the_scene_lacks_is_refused_naming_the_scene() {
    let error = params_error(cooperative("agv5"));
    assert_eq!(error.field, "sensor");
    assert!(
        error.problem.contains("hall-cooperative.toml")
            && error.problem.contains("4 AGVs (agv1, agv2, agv3, agv4)")
            && error.problem.contains("4 stations"),
        "{}",
        error.problem
    );
    assert_eq!(error.allowed, "agv1 to agv4");
    let error = params_error(Params {
        sensor: "station1".into(),
        ..Params::default()
    });
    assert!(
        error.problem.contains("config/hall.toml") && error.problem.contains("0 stations"),
        "{}",
        error.problem
    );
    assert_eq!(error.allowed, "no stationN in this scene");
    let error = params_error(Params {
        sensor: "agv2".into(),
        ..Params::default()
    });
    assert_eq!(error.allowed, "agv1");
    // Not a sensor name at all.
    assert_eq!(params_error(cooperative("lidar")).field, "sensor");
}

#[test]
fn a_station_publishes_its_surveyed_pose_every_frame_on_agv1s_clock() {
    let coop = scene("hall-cooperative.toml");
    let east = &coop.stations[1];
    assert_eq!(east.name, "east");
    let published = run_node(noiseless(cooperative("station2")), 5);
    let node = build(cooperative("station2"), &context(5)).unwrap();
    assert_eq!(
        node.outputs(),
        [
            GROUND_TRUTH_TARGETS,
            CLOCK,
            GROUND_TRUTH_POSE,
            ODOM,
            DETECTIONS
        ]
    );
    let frames = coop.trajectory.frame_count();
    assert_eq!(frames, 294);
    let clocks = on(&published, CLOCK);
    assert_eq!(clocks.len(), frames);
    for (k, clock) in clocks.iter().enumerate() {
        assert_eq!(clock.stamp().as_seconds(), coop.trajectory.stamp_s(k));
    }
    let surveyed = pose_of(east.pose);
    for message in on(&published, ODOM) {
        let Message::Odometry(odom) = message else {
            unreachable!()
        };
        assert_eq!(odom.header.frame_id, "map");
        assert_eq!(odom.child_frame_id, "base_link");
        assert_eq!(odom.pose.pose, surveyed);
        assert_eq!(odom.pose.covariance, [0.0; 36]);
        assert_eq!(odom.twist.covariance, [0.0; 36]);
        assert_eq!(odom.twist.twist.linear.x, 0.0);
        assert_eq!(odom.twist.twist.angular.z, 0.0);
    }
    for message in on(&published, GROUND_TRUTH_POSE) {
        assert!(
            matches!(message, Message::PoseStamped(p) if p.pose == surveyed && p.header.frame_id == "map")
        );
    }
    // The station's boresight is its heading: relative to the body it is 0. Every detection
    // is within its range and field of view, and (no noise) lands on the targets it faces.
    let half_fov = east.sensor.half_fov_rad;
    for message in on(&published, DETECTIONS) {
        let Message::Detections(d) = message else {
            unreachable!()
        };
        assert_eq!(d.boresight_rad, 0.0);
        assert_eq!(d.detections.len(), 79);
        for det in &d.detections {
            assert!(det.range_m > 0.0 && det.range_m <= 20.0);
            assert!(det.angle_rad.abs() <= half_fov);
            let bearing = east.pose.yaw_rad + det.angle_rad;
            let x = east.pose.x_m + det.range_m * bearing.cos();
            let y = east.pose.y_m + det.range_m * bearing.sin();
            let on_target = coop.targets.iter().any(|t| {
                t.scatterers
                    .iter()
                    .any(|s| (s.position - nrslam_radar::Vec2::new(x, y)).norm() < 1e-9)
            });
            assert!(on_target, "({x}, {y})");
        }
    }
    // `frames` caps a station's run too.
    let capped = run_node(
        Params {
            frames: 3,
            ..cooperative("station1")
        },
        5,
    );
    assert_eq!(on(&capped, CLOCK).len(), 3);
}

#[test]
fn station_visibility_is_limited_by_its_field_of_view_and_range() {
    // A station on the west wall at (0, 10) looking +x, ±30°, 12 m: a box ahead at 8 m is
    // seen; a tank 40° off boresight and a drum 15 m away are not.
    let text = r#"
        [hall]
        width_m = 30.0
        height_m = 20.0
        [trajectory]
        x_min_m = 2.0
        y_min_m = 2.0
        x_max_m = 28.0
        y_max_m = 18.0
        corner_radius_m = 1.0
        [[station]]
        position_m = [0.0, 10.0]
        boresight_deg = 0.0
        half_fov_deg = 30.0
        max_range_m = 12.0
        [[targets]]
        name = "ahead"
        shape = "rectangle"
        center_m = [8.5, 10.0]
        size_m = [1.0, 2.0]
        [[targets]]
        name = "aside"
        shape = "circle"
        center_m = [7.66, 16.43]
        radius_m = 0.5
        [[targets]]
        name = "far"
        shape = "circle"
        center_m = [15.5, 12.5]
        radius_m = 0.5
    "#;
    let scene = Scene::from_toml_str(text, "test").unwrap();
    let station = &scene.stations[0];
    let seen = observe(&scene.targets, &station.sensor, station.pose);
    assert!(!seen.is_empty());
    assert!(seen.iter().all(|s| s.target_index == 0), "{seen:?}");
    // The box's near face, 8 m away: 2 m tall at spacing 0.25 m is 9 scatterers.
    assert_eq!(seen.len(), 9);
    // Widened to ±60° and 20 m, the station sees the other two as well.
    let wide = scene.stations[0].sensor;
    let wide = nrslam_radar::Sensor {
        half_fov_rad: 60f64.to_radians(),
        max_range_m: 20.0,
        ..wide
    };
    let seen = observe(&scene.targets, &wide, station.pose);
    for index in 0..3 {
        assert!(seen.iter().any(|s| s.target_index == index), "{index}");
    }
    // Through the simulator: the same sightings, every frame, on agv1's clock.
    let params = Params {
        sensor: "station1".into(),
        ..noiseless(Params::default())
    };
    let frames: Vec<_> = Simulator::new(scene.clone(), &params, 1).unwrap().collect();
    assert_eq!(frames.len(), scene.trajectory.frame_count());
    assert!(frames
        .iter()
        .all(|f| f.seen_scatterers == 9 && f.detections.len() == 9 && f.true_pose == station.pose));
}

#[test]
fn odometry_from_the_start_pose() {
    let coop = scene("hall-cooperative.toml");
    let start = coop.agvs[1].trajectory.pose_at_frame(0);
    let noise_free = |origin| {
        let params = Params {
            odom_origin: origin,
            ..noiseless(cooperative("agv2"))
        };
        Simulator::new(coop.clone(), &params, 3)
            .unwrap()
            .collect::<Vec<_>>()
    };
    let relative = noise_free(OdomOrigin::Start);
    // Identity at frame 0; without noise, the truth's motion relative to the start.
    let first: OdometryReading = relative[0].odometry;
    assert_eq!(first.pose, Pose2::new(0.0, 0.0, 0.0));
    for frame in &relative {
        let expected = frame.true_pose.relative_to(start);
        let got = frame.odometry.pose;
        assert!(
            (got.position() - expected.position()).norm() < 1e-9,
            "frame {}: {got:?} vs {expected:?}",
            frame.index
        );
        assert!(nrslam_radar::geometry::wrap_angle(got.yaw_rad - expected.yaw_rad).abs() < 1e-9);
        // The ground truth stays in the map frame.
        assert_eq!(
            frame.true_pose,
            coop.agvs[1].trajectory.pose_at_frame(frame.index)
        );
    }
    // With noise: the same dead reckoning, moved to the start frame; variances unchanged.
    let noisy = |origin| {
        let params = Params {
            odom_origin: origin,
            ..cooperative("agv2")
        };
        Simulator::new(coop.clone(), &params, 3)
            .unwrap()
            .collect::<Vec<_>>()
    };
    let (map, start_frame) = (noisy(OdomOrigin::Map), noisy(OdomOrigin::Start));
    for (m, s) in map.iter().zip(&start_frame) {
        let moved = m.odometry.pose.relative_to(start);
        assert!((moved.position() - s.odometry.pose.position()).norm() < 1e-9);
        assert_eq!(m.odometry.pose_variance, s.odometry.pose_variance);
        assert_eq!(m.odometry.linear_mps, s.odometry.linear_mps);
        assert_eq!(m.true_pose, s.true_pose);
        assert_eq!(m.detections, s.detections);
    }
    assert!(map.last().unwrap().odometry.pose_variance[0] > 0.0);
    // Through the node: /odom at frame 0 is the identity, frame "odom".
    let published = run_node(
        Params {
            frames: 2,
            odom_origin: OdomOrigin::Start,
            ..cooperative("agv2")
        },
        3,
    );
    let Message::Odometry(odom) = &on(&published, ODOM)[0] else {
        unreachable!()
    };
    assert_eq!(odom.pose.pose, Pose::from_planar(0.0, 0.0, 0.0));
    assert_eq!(odom.header.frame_id, "odom");
    // Refused for a station (a surveyed pose has no unknown start).
    let error = params_error(Params {
        odom_origin: OdomOrigin::Start,
        ..cooperative("station1")
    });
    assert_eq!(error.field, "odom_origin");
}

#[test]
fn none_publishes_only_the_clock_and_the_targets() {
    let node = build(cooperative("none"), &context(1)).unwrap();
    assert_eq!(node.outputs(), [GROUND_TRUTH_TARGETS, CLOCK]);
    let published = run_node(cooperative("none"), 1);
    let coop = scene("hall-cooperative.toml");
    assert_eq!(published.len(), 1 + coop.trajectory.frame_count());
    assert_eq!(published[0].0, GROUND_TRUTH_TARGETS);
    let Message::TargetSet(targets) = &published[0].1 else {
        unreachable!()
    };
    assert_eq!(targets.targets.len(), 10);
    for (k, (topic, message)) in published[1..].iter().enumerate() {
        assert_eq!(*topic, CLOCK);
        assert_eq!(message.stamp().as_seconds(), coop.trajectory.stamp_s(k));
    }
    let capped = run_node(
        Params {
            frames: 4,
            ..Params {
                sensor: "none".into(),
                fidelity: nrslam_radar::Fidelity::Spectral,
                ..Params::default()
            }
        },
        1,
    );
    assert_eq!(capped.len(), 5);
}

// ---------------------------------------------------------------------------------------------
// The shipped multi-agent scenes
// ---------------------------------------------------------------------------------------------

/// For each target, in how many frames `agv` sees at least one of its scatterers.
fn frames_seeing(scene: &Scene, agv: usize) -> Vec<usize> {
    let agv = &scene.agvs[agv];
    let mut counts = vec![0; scene.targets.len()];
    for k in 0..agv.trajectory.frame_count() {
        let mut seen = vec![false; scene.targets.len()];
        for s in observe(&scene.targets, &agv.sensor, agv.trajectory.pose_at_frame(k)) {
            seen[s.target_index] = true;
        }
        for (count, seen) in counts.iter_mut().zip(seen) {
            *count += usize::from(seen);
        }
    }
    counts
}

#[test]
fn the_cooperative_hall_is_the_hall_with_more_sensors() {
    let hall = scene("hall.toml");
    let coop = scene("hall-cooperative.toml");
    assert_eq!(coop.targets, hall.targets);
    assert_eq!((coop.hall_width_m, coop.hall_height_m), (54.0, 44.0));
    assert_eq!(coop.trajectory, hall.trajectory);
    assert_eq!(coop.sensor, hall.sensor);
    let names: Vec<&str> = coop.agvs.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["agv1", "agv2", "agv3", "agv4"]);
    // One clock: every AGV has agv1's 294 frames, 0.5 s apart.
    for agv in &coop.agvs {
        assert_eq!(agv.trajectory.frame_count(), 294, "{}", agv.name);
        assert_eq!(agv.trajectory.frame_period_s(), 0.5);
    }
    // The outer loop's AGVs see every target; agv4 on the inner loop sees the eight around it.
    for agv in 0..3 {
        assert!(
            frames_seeing(&coop, agv).iter().all(|&n| n >= 90),
            "agv{}",
            agv + 1
        );
    }
    let inner = frames_seeing(&coop, 3);
    assert_eq!((inner[5], inner[6]), (0, 0));
    assert_eq!(inner.iter().filter(|&&n| n > 0).count(), 8);
    // Four stations on the walls, ±60°, 20 m, each seeing at least two targets well.
    assert_eq!(coop.stations.len(), 4);
    for station in &coop.stations {
        let p = station.pose;
        assert!(p.x_m == 0.0 || p.x_m == 54.0 || p.y_m == 0.0 || p.y_m == 44.0);
        assert_eq!(station.sensor.max_range_m, 20.0);
        assert!((station.sensor.half_fov_rad - 60f64.to_radians()).abs() < 1e-15);
        let mut per_target = vec![0; coop.targets.len()];
        for s in observe(&coop.targets, &station.sensor, station.pose) {
            per_target[s.target_index] += 1;
        }
        assert!(
            per_target.iter().filter(|&&n| n >= 4).count() >= 2,
            "{}: {per_target:?}",
            station.name
        );
    }
}

#[test]
fn in_two_rooms_no_target_is_seen_by_both_agvs() {
    let rooms = scene("two-rooms.toml");
    assert_eq!(rooms.agvs.len(), 2);
    let (west, east) = (frames_seeing(&rooms, 0), frames_seeing(&rooms, 1));
    for (index, (w, e)) in west.iter().zip(&east).enumerate() {
        assert!(
            (*w > 0) != (*e > 0),
            "target {index}: west sees it in {w} frames, east in {e}"
        );
    }
    // And by a margin: no point of one loop is within 20 m of the other group.
    for (agv, other_group) in [(0, 3..7), (1, 0..3)] {
        let chords = rooms.agvs[agv].trajectory.chords(1f64.to_radians());
        for target in &rooms.targets[other_group] {
            let closest = chords
                .iter()
                .map(|(a, b)| target.shape.distance_to_segment(*a, *b))
                .fold(f64::INFINITY, f64::min);
            assert!(closest > 20.0, "{}: {closest}", target.name);
        }
    }
    assert_eq!(
        rooms.agvs[0].trajectory.frame_count(),
        rooms.agvs[1].trajectory.frame_count()
    );
}

#[test]
fn the_repeated_structure_repeats_but_its_surroundings_differ() {
    let repeated = scene("repeated-structure.toml");
    // Targets 0–2 and 3–5 are the same group, 30 m apart.
    let shift = nrslam_radar::Vec2::new(30.0, 0.0);
    for i in 0..3 {
        let west = repeated.targets[i].shape.outline();
        let east = repeated.targets[i + 3].shape.outline();
        assert_eq!(west.len(), east.len());
        for (w, e) in west.iter().zip(&east) {
            assert!((w + shift - e).norm() < 1e-9);
        }
    }
    let (west, east) = (frames_seeing(&repeated, 0), frames_seeing(&repeated, 1));
    // Each AGV sees its own group throughout and the other side's surroundings never.
    for i in 0..3 {
        assert!(west[i] > 80 && east[i + 3] > 80, "{west:?} {east:?}");
    }
    assert!(west[6] > 0 && west[7] == 0);
    assert!(east[7] > 0 && east[6] == 0);
    // Both see the shared middle.
    assert!(west[8] > 50 && east[8] > 50 && west[9] > 50 && east[9] > 50);
    // The paths share the middle stretch of the bottom and top straights.
    let on_both = |x: f64, y: f64| {
        repeated.agvs.iter().all(|agv| {
            agv.trajectory
                .chords(1f64.to_radians())
                .iter()
                .any(|(a, b)| {
                    nrslam_radar::geometry::point_segment_distance(
                        *a,
                        *b,
                        nrslam_radar::Vec2::new(x, y),
                    ) < 1e-9
                })
        })
    };
    assert!(on_both(28.0, 3.0) && on_both(28.0, 33.0));
}

#[test]
fn the_documented_example_is_a_valid_scene() {
    // docs/scene.md's example, with the hall's targets where it elides them.
    let doc = std::fs::read_to_string(workspace().join("docs/scene.md")).unwrap();
    let section = &doc[doc.find("### Example").unwrap()..];
    let start = section.find("```toml\n").unwrap() + "```toml\n".len();
    let example = &section[start..start + section[start..].find("```").unwrap()];
    let hall = std::fs::read_to_string(workspace().join("config/hall.toml")).unwrap();
    let targets = &hall[hall.find("[[targets]]").unwrap()..];
    let text = example.replace("[[targets]]\n# ... as in config/hall.toml\n", targets);
    let scene = Scene::from_toml_str(&text, "docs/scene.md").unwrap();
    assert_eq!(scene.agvs.len(), 3);
    assert_eq!(scene.agvs[1].name, "cw");
    assert!(!scene.agvs[2].trajectory.is_closed());
    assert_eq!(scene.stations[0].name, "south");
    assert_eq!(scene.targets.len(), 10);
    // The errors the page quotes.
    for (from, to, message) in [
        (
            "clockwise = true,",
            "clockwise = true, speed_mps = 0.0,",
            "agv[1] (cw).trajectory.speed_mps: must be finite and > 0, got 0",
        ),
        (
            "position_m = [27.0, 0.0]",
            "position_m = [54.5, 3.0]",
            "station[0] (south).position_m: [54.5, 3] is outside the hall [0, 54] × [0, 44] m; \
             a station stands inside it or on a wall",
        ),
        (
            "half_fov_deg = 60.0\nmax_range_m = 20.0",
            "half_fov_deg = 90.0\nmax_range_m = 20.0",
            "station[0] (south).half_fov_deg: must lie in (0, 90)",
        ),
        (
            "[46.0, 17.5], [46.0, 27.5]",
            "[nan, 17.5], [46.0, 27.5]",
            "agv[2] (agv3).waypoints_m[1]: must be finite, got [NaN, 17.5]",
        ),
    ] {
        assert_eq!(text.matches(from).count(), 1, "{from}");
        let error = Scene::from_toml_str(&text.replace(from, to), "docs")
            .unwrap_err()
            .to_string();
        assert!(error.contains(message), "{error}");
    }
}

#[test]
fn a_sensor_switched_on_late_publishes_nothing_before_its_start_frame() {
    let coop = scene("hall-cooperative.toml");
    let path = &coop.agvs[1].trajectory;
    let late = |origin, start_frame| Params {
        frames: 12,
        start_frame,
        odom_origin: origin,
        ..cooperative("agv2")
    };
    // Through the node: the targets first, then frames 5 to 11 only, each with its clock, pose,
    // odometry and detections, on the run's clock.
    let published = run_node(late(OdomOrigin::Start, 5), 3);
    assert_eq!(published[0].0, GROUND_TRUTH_TARGETS);
    assert_eq!(published.len(), 1 + 7 * 4);
    let stamps: Vec<f64> = on(&published, CLOCK)
        .iter()
        .map(|m| m.stamp().as_seconds())
        .collect();
    let expected: Vec<f64> = (5..12).map(|k| path.stamp_s(k)).collect();
    assert_eq!(stamps, expected);
    assert_eq!(on(&published, DETECTIONS).len(), 7);
    // Its odometry starts where it is switched on: the identity from an unknown start, its true
    // pose then from a known one.
    let Message::Odometry(odom) = &on(&published, ODOM)[0] else {
        unreachable!()
    };
    assert_eq!(odom.pose.pose, Pose::from_planar(0.0, 0.0, 0.0));
    let published = run_node(late(OdomOrigin::Map, 5), 3);
    let Message::Odometry(odom) = &on(&published, ODOM)[0] else {
        unreachable!()
    };
    assert_eq!(odom.pose.pose, pose_of(path.pose_at_frame(5)));
    let Message::PoseStamped(truth) = &on(&published, GROUND_TRUTH_POSE)[0] else {
        unreachable!()
    };
    assert_eq!(truth.pose, pose_of(path.pose_at_frame(5)));

    // Without noise, the frames it does sense are those of a sensor on from the start, and its
    // odometry is the truth's motion from where it was switched on.
    let frames = |start_frame| {
        Simulator::new(
            coop.clone(),
            &noiseless(late(OdomOrigin::Start, start_frame)),
            3,
        )
        .unwrap()
        .collect::<Vec<_>>()
    };
    let (from_start, from_5) = (frames(0), frames(5));
    assert_eq!(from_5.len(), 7);
    let on_at_5 = path.pose_at_frame(5);
    for (late, early) in from_5.iter().zip(&from_start[5..]) {
        assert_eq!(late.index, early.index);
        assert_eq!(late.stamp_s, early.stamp_s);
        assert_eq!(late.true_pose, early.true_pose);
        assert_eq!(late.detections, early.detections);
        let expected = late.true_pose.relative_to(on_at_5);
        assert!((late.odometry.pose.position() - expected.position()).norm() < 1e-9);
    }

    // Never switched on, or a clock switched on late: refused by name.
    for params in [
        late(OdomOrigin::Start, 12),
        Params {
            frames: 0,
            ..late(OdomOrigin::Start, 294)
        },
        Params {
            start_frame: 1,
            ..cooperative("none")
        },
    ] {
        assert_eq!(params_error(params).field, "start_frame");
    }
    // Just before the last frame: one frame.
    let last = Params {
        frames: 0,
        ..late(OdomOrigin::Map, 293)
    };
    assert_eq!(on(&run_node(last, 3), CLOCK).len(), 1);
}
