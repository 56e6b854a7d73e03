//! End-to-end tests on the project's scene, `config/hall.toml`: the whole lap, seeds, noise
//! statistics, odometry and the node adapter.

use std::path::{Path, PathBuf};

use nrslam_msgs::topics::{CLOCK, DETECTIONS, GROUND_TRUTH_POSE, GROUND_TRUTH_TARGETS, ODOM};
use nrslam_msgs::Message;
use nrslam_radar::geometry::{point_segment_distance, wrap_angle};
use nrslam_radar::visibility::observe;
use nrslam_radar::{build, Params, Scene, SceneError, Shape, Simulator};
use nrslam_runtime::{NodeContext, NodeError, Outbox, Tick};

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn hall() -> Scene {
    Scene::load(&workspace().join("config/hall.toml")).unwrap()
}

fn hall_text() -> String {
    std::fs::read_to_string(workspace().join("config/hall.toml")).unwrap()
}

fn simulate(params: &Params, seed: u64) -> Vec<nrslam_radar::Frame> {
    Simulator::new(hall(), params, seed).unwrap().collect()
}

fn noiseless() -> Params {
    Params {
        range_std_m: 0.0,
        angle_std_deg: 0.0,
        odom_translation_noise: 0.0,
        odom_rotation_noise_deg_per_m: 0.0,
        ..Params::default()
    }
}

/// Distance from `p` to the nearest target outline (exact shapes).
fn distance_to_outlines(scene: &Scene, p: nrslam_radar::Vec2) -> f64 {
    scene
        .targets
        .iter()
        .map(|t| match &t.shape {
            Shape::Rectangle { corners } => (0..4)
                .map(|i| point_segment_distance(corners[i], corners[(i + 1) % 4], p))
                .fold(f64::INFINITY, f64::min),
            Shape::Circle { center, radius_m } => ((p - center).norm() - radius_m).abs(),
        })
        .fold(f64::INFINITY, f64::min)
}

/// Frames of the whole run, worked out from the trajectory spec independently of `Trajectory`:
/// a rounded rectangle of 4 straights and 4 quarter circles, one frame every
/// `speed · period` metres, strictly before the end of the last lap (no pose repeated).
fn expected_frame_count(scene: &Scene) -> usize {
    let t = scene.trajectory.loop_spec().unwrap();
    let r = t.corner_radius_m;
    let lap_m = 2.0 * ((t.x_max_m - t.x_min_m - 2.0 * r) + (t.y_max_m - t.y_min_m - 2.0 * r))
        + std::f64::consts::TAU * r;
    assert!((scene.trajectory.lap_length_m() - lap_m).abs() < 1e-9);
    (t.laps * lap_m / (t.speed_mps * t.frame_period_s)).ceil() as usize
}

/// `text` with `from` replaced by `to`; `from` must occur exactly once, so that a test editing
/// the scene file cannot silently become a no-op when the file changes.
fn replace_once(text: &str, from: &str, to: &str) -> String {
    assert_eq!(
        text.matches(from).count(),
        1,
        "{from:?} in config/hall.toml"
    );
    text.replacen(from, to, 1)
}

#[test]
fn hall_layout_matches_the_paper() {
    let scene = hall();
    let rectangles = scene
        .targets
        .iter()
        .filter(|t| t.shape.kind_name() == "rectangle")
        .count();
    let circles = scene
        .targets
        .iter()
        .filter(|t| t.shape.kind_name() == "circle")
        .count();
    assert_eq!((rectangles, circles), (8, 2));
    assert_eq!(scene.targets.len(), 10);
    assert!(scene.targets.iter().all(|t| t.shape.samples().len() == 4));
    // One lap, one frame every 0.5 m; the last frame falls short of the start.
    let frames = scene.trajectory.frame_count();
    assert_eq!(frames, expected_frame_count(&scene));
    let lap_m = scene.trajectory.lap_length_m() * scene.trajectory.loop_spec().unwrap().laps;
    assert!(scene.trajectory.distance_at_frame_m(frames - 1) < lap_m);
    assert!(scene.trajectory.distance_at_frame_m(frames) >= lap_m);
}

/// The layout's point (docs/scene.md): sample points of different targets are farther apart
/// than ET-GOPSA's cut-off c = 5 m (Table I), so no well-placed estimate pays the confusion term.
#[test]
fn sample_points_of_different_targets_are_more_than_the_cutoff_apart() {
    const ETGOSPA_CUTOFF_M: f64 = 5.0;
    let scene = hall();
    let mut closest = (f64::INFINITY, 0, 0);
    for (i, a) in scene.targets.iter().enumerate() {
        for (j, b) in scene.targets.iter().enumerate().skip(i + 1) {
            for p in a.shape.samples() {
                for q in b.shape.samples() {
                    let d = (p - q).norm();
                    if d < closest.0 {
                        closest = (d, i, j);
                    }
                }
            }
        }
    }
    println!("closest sample points of different targets: {closest:?}");
    assert!(closest.0 > ETGOSPA_CUTOFF_M, "{closest:?}");
}

#[test]
fn every_target_is_seen_during_the_lap() {
    let scene = hall();
    let mut seen_frames = vec![0usize; scene.targets.len()];
    let mut seen_scatterers = vec![vec![false; 0]; scene.targets.len()];
    for (i, t) in scene.targets.iter().enumerate() {
        seen_scatterers[i] = vec![false; t.scatterers.len()];
    }
    let mut total = 0usize;
    let frames = scene.trajectory.frame_count();
    for k in 0..frames {
        let sightings = observe(
            &scene.targets,
            &scene.sensor,
            scene.trajectory.pose_at_frame(k),
        );
        total += sightings.len();
        let mut in_frame = vec![false; scene.targets.len()];
        for s in &sightings {
            in_frame[s.target_index] = true;
            seen_scatterers[s.target_index][s.scatterer_index] = true;
        }
        for (count, seen) in seen_frames.iter_mut().zip(in_frame) {
            *count += seen as usize;
        }
    }
    let mean = total as f64 / frames as f64;
    let coverage: Vec<f64> = seen_scatterers
        .iter()
        .map(|s| s.iter().filter(|x| **x).count() as f64 / s.len() as f64)
        .collect();
    println!("frames {frames}, mean seen scatterers per frame {mean:.1}");
    println!("frames in which each target is seen: {seen_frames:?}");
    println!("fraction of each target's scatterers ever seen: {coverage:.2?}");
    assert!(seen_frames.iter().all(|&n| n > 0), "{seen_frames:?}");
    // Most of every outline is seen at some point of the lap (the loop goes all round).
    assert!(coverage.iter().all(|&c| c > 0.5), "{coverage:?}");
    assert!(mean > 20.0 && mean < 300.0, "{mean}");
}

/// Each frame's detections, for comparing runs.
fn detections(frames: &[nrslam_radar::Frame]) -> Vec<&Vec<nrslam_msgs::Detection>> {
    frames.iter().map(|f| &f.detections).collect()
}

/// Each frame's odometry reading, for comparing runs.
fn odometry(frames: &[nrslam_radar::Frame]) -> Vec<nrslam_radar::odometry::OdometryReading> {
    frames.iter().map(|f| f.odometry).collect()
}

#[test]
fn same_seed_same_detections_different_seed_different() {
    let params = Params {
        range_std_m: 0.1,
        angle_std_deg: 1.0,
        frames: 30,
        ..Params::default()
    };
    let a = simulate(&params, 11);
    let b = simulate(&params, 11);
    let c = simulate(&params, 12);
    assert_eq!(a, b);
    assert_eq!(a.len(), 30);
    assert_ne!(detections(&a), detections(&c));
    assert_ne!(odometry(&a), odometry(&c));
    // The odometry stream is independent of the measurement parameters.
    let d = simulate(
        &Params {
            range_std_m: 0.0,
            angle_std_deg: 5.0,
            ..params.clone()
        },
        11,
    );
    assert_eq!(odometry(&a), odometry(&d));
    // And the detections are independent of the odometry noise: launch/true-poses.toml relies on
    // it to map the same detections as paper-ideal.toml at exact poses.
    let exact_odometry = simulate(
        &Params {
            odom_translation_noise: 0.0,
            odom_rotation_noise_deg_per_m: 0.0,
            odom_scale_bias: 0.0,
            odom_rotation_bias_deg_per_m: 0.0,
            ..params.clone()
        },
        11,
    );
    assert_ne!(odometry(&a), odometry(&exact_odometry));
    assert_eq!(detections(&a), detections(&exact_odometry));
}

#[test]
fn noiseless_detections_lie_on_outlines() {
    let scene = hall();
    let boresight = scene.sensor.boresight_rad;
    let frames = simulate(&noiseless(), 3);
    let mut checked = 0;
    for f in &frames {
        let p = f.true_pose;
        for d in &f.detections {
            let heading = p.yaw_rad + boresight + d.angle_rad;
            let point = nrslam_radar::Vec2::new(
                p.x_m + d.range_m * heading.cos(),
                p.y_m + d.range_m * heading.sin(),
            );
            let off = distance_to_outlines(&scene, point);
            assert!(off < 1e-9, "frame {} detection off by {off} m", f.index);
            checked += 1;
        }
    }
    assert!(checked > 1000);
}

#[test]
fn zero_range_noise_keeps_ranges_exact_and_angle_errors_match_the_std() {
    let scene = hall();
    let angle_std_deg = 1.0;
    let params = Params {
        range_std_m: 0.0,
        angle_std_deg,
        ..Params::default()
    };
    let mut errors = Vec::new();
    for seed in 0..5 {
        for f in simulate(&params, seed) {
            let truth = observe(&scene.targets, &scene.sensor, f.true_pose);
            // |θ| ≤ 60° + a few σ never leaves (−90°, 90°): nothing is dropped.
            assert_eq!(truth.len(), f.detections.len());
            for (s, d) in truth.iter().zip(&f.detections) {
                assert_eq!(d.range_m, s.range_m);
                assert_eq!(d.range_std_m, 0.0);
                assert!((d.angle_std_rad - angle_std_deg.to_radians()).abs() < 1e-15);
                errors.push(wrap_angle(d.angle_rad - s.angle_rad));
            }
        }
    }
    let n = errors.len() as f64;
    let mean = errors.iter().sum::<f64>() / n;
    let std = (errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let sigma = angle_std_deg.to_radians();
    assert!(n > 10_000.0);
    assert!(mean.abs() < 5.0 * sigma / n.sqrt(), "mean {mean}");
    assert!((std / sigma - 1.0).abs() < 0.03, "std {std} vs {sigma}");
}

#[test]
fn noiseless_odometry_equals_truth() {
    for f in simulate(&noiseless(), 9) {
        let (o, t) = (f.odometry.pose, f.true_pose);
        assert!(
            (o.position() - t.position()).norm() < 1e-9,
            "frame {}",
            f.index
        );
        assert!(wrap_angle(o.yaw_rad - t.yaw_rad).abs() < 1e-9);
    }
    // With the default noise it starts at the truth and then drifts.
    let frames = simulate(&Params::default(), 9);
    assert_eq!(frames[0].odometry.pose, frames[0].true_pose);
    let last = frames.last().unwrap();
    assert!((last.odometry.pose.position() - last.true_pose.position()).norm() > 1e-3);
}

#[test]
fn frame_cap_and_stamps() {
    let frames = simulate(
        &Params {
            frames: 7,
            ..Params::default()
        },
        1,
    );
    assert_eq!(frames.len(), 7);
    let period_s = hall().trajectory.frame_period_s();
    for (k, f) in frames.iter().enumerate() {
        assert_eq!(f.index, k);
        assert_eq!(f.stamp_s, 1.0 + period_s * k as f64);
    }
    // A cap beyond the lap runs the lap.
    let all = simulate(
        &Params {
            frames: 100_000,
            ..Params::default()
        },
        1,
    );
    assert_eq!(all.len(), expected_frame_count(&hall()));
}

#[test]
fn zero_length_trajectory_is_refused() {
    // Collapse the loop onto its bottom-left corner: x_max = x_min, y_max = y_min, no rounding.
    let t = hall().trajectory.loop_spec().unwrap().clone();
    let text = replace_once(
        &hall_text(),
        &format!("x_max_m = {:?}", t.x_max_m),
        &format!("x_max_m = {:?}", t.x_min_m),
    );
    let text = replace_once(
        &text,
        &format!("y_max_m = {:?}", t.y_max_m),
        &format!("y_max_m = {:?}", t.y_min_m),
    );
    let text = replace_once(
        &text,
        &format!("corner_radius_m = {:?}", t.corner_radius_m),
        "corner_radius_m = 0.0",
    );
    let err = Scene::from_toml_str(&text, "zero-length").unwrap_err();
    assert_eq!(err.field(), Some("trajectory"), "{err}");
    assert!(err.to_string().contains("zero length"), "{err}");
    let laps = replace_once(&hall_text(), "laps = 1.0", "laps = 0.0");
    let err = Scene::from_toml_str(&laps, "no laps").unwrap_err();
    assert_eq!(err.field(), Some("trajectory.laps"));
}

#[test]
fn trajectory_crossing_a_target_is_refused() {
    // Move the pillar onto the right straight (x = x_max_m), keeping its height.
    let scene = hall();
    let (id, pillar) = scene
        .targets
        .iter()
        .enumerate()
        .find(|(_, t)| t.name == "pillar")
        .unwrap();
    let Shape::Circle { center, .. } = pillar.shape else {
        panic!("the pillar is a {}", pillar.shape.kind_name());
    };
    let x_max = scene.trajectory.loop_spec().unwrap().x_max_m;
    let text = replace_once(
        &hall_text(),
        &format!("center_m = [{:?}, {:?}]", center.x, center.y),
        &format!("center_m = [{:?}, {:?}]", x_max - 0.5, center.y),
    );
    let err = Scene::from_toml_str(&text, "crossing").unwrap_err();
    assert_eq!(err.field(), Some("trajectory"), "{err}");
    assert!(
        err.to_string().contains(&format!("targets[{id}] (pillar)")),
        "{err}"
    );
}

// ---------------------------------------------------------------------------------------------
// Node adapter
// ---------------------------------------------------------------------------------------------

fn context(seed: u64) -> NodeContext {
    let mut ctx = NodeContext::for_tests(seed);
    ctx.name = "radar".into();
    ctx.base_dir = workspace();
    ctx
}

fn run_node(params: Params, seed: u64) -> Vec<(&'static str, Message)> {
    let mut node = build(params, &context(seed)).unwrap();
    assert!(node.inputs().is_empty());
    let mut outbox = Outbox::new();
    let mut published = Vec::new();
    for _ in 0..10_000 {
        let tick = node.tick(&mut outbox).unwrap();
        published.extend(outbox.drain());
        if tick == Tick::Done {
            return published;
        }
    }
    panic!("the radar node never finished");
}

#[test]
fn node_publishes_each_frame_in_order() {
    let scene = hall();
    let spec = scene.trajectory.loop_spec().unwrap();
    // Frame 0 is the middle of the bottom straight, heading +x.
    assert_eq!(spec.start_offset_m, 0.0);
    let start = ((spec.x_min_m + spec.x_max_m) / 2.0, spec.y_min_m, 0.0);
    let published = run_node(
        Params {
            frames: 5,
            ..Params::default()
        },
        4,
    );
    assert_eq!(published.len(), 1 + 4 * 5);
    let Message::TargetSet(targets) = &published[0].1 else {
        panic!("first message is {:?}", published[0].0);
    };
    assert_eq!(published[0].0, GROUND_TRUTH_TARGETS);
    assert_eq!(targets.header.frame_id, "map");
    assert_eq!(targets.header.stamp.as_seconds(), 1.0);
    assert_eq!(targets.targets.len(), 10);
    assert!(targets.targets.iter().all(|t| t.samples.len() == 4));
    let circle = targets
        .targets
        .iter()
        .find(|t| t.shape == "circle")
        .unwrap();
    assert_eq!(circle.outline.len(), 64);

    for (k, chunk) in published[1..].chunks(4).enumerate() {
        let stamp = 1.0 + spec.frame_period_s * k as f64;
        let topics: Vec<_> = chunk.iter().map(|(t, _)| *t).collect();
        assert_eq!(topics, [CLOCK, GROUND_TRUTH_POSE, ODOM, DETECTIONS]);
        assert!(chunk.iter().all(|(_, m)| m.stamp().as_seconds() == stamp));
        match (&chunk[1].1, &chunk[2].1, &chunk[3].1) {
            (Message::PoseStamped(truth), Message::Odometry(odom), Message::Detections(d)) => {
                assert_eq!(truth.header.frame_id, "map");
                assert_eq!(odom.header.frame_id, "odom");
                assert_eq!(odom.child_frame_id, "base_link");
                assert_eq!(d.header.frame_id, "radar");
                assert!((d.boresight_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
                assert!(!d.detections.is_empty());
                // Diagonal covariance only.
                for (i, c) in odom.pose.covariance.iter().enumerate() {
                    if i % 7 != 0 {
                        assert_eq!(*c, 0.0);
                    }
                }
                if k == 0 {
                    assert_eq!(odom.pose.pose, truth.pose);
                    assert_eq!(truth.pose.planar(), start);
                    assert_eq!(odom.twist.twist.linear.x, spec.speed_mps);
                } else {
                    assert!(odom.pose.covariance[0] > 0.0);
                    assert!(odom.pose.covariance[35] > 0.0);
                }
            }
            other => panic!("unexpected messages {other:?}"),
        }
    }
}

#[test]
fn node_runs_the_whole_lap_in_a_graph() {
    let node = build(Params::default(), &context(1)).unwrap();
    let mut graph = nrslam_runtime::compose::Graph::new(vec![("radar".into(), node)]);
    let mut counts = std::collections::BTreeMap::<&str, usize>::new();
    let mut detections = 0usize;
    graph
        .run(&mut |topic: &'static str, message: &Message| {
            *counts.entry(topic).or_default() += 1;
            if let Message::Detections(d) = message {
                detections += d.detections.len();
            }
        })
        .unwrap();
    let frames = expected_frame_count(&hall());
    assert_eq!(counts[GROUND_TRUTH_TARGETS], 1);
    assert_eq!(counts[CLOCK], frames);
    assert_eq!(counts[DETECTIONS], frames);
    println!(
        "mean detections per frame over the lap: {:.1}",
        detections as f64 / frames as f64
    );
}

#[test]
fn node_errors_name_the_problem() {
    let missing = Params {
        scene: "config/no-such-hall.toml".into(),
        ..Params::default()
    };
    let err = build(missing, &context(0)).err().unwrap();
    assert!(err.to_string().contains("no-such-hall.toml"), "{err}");

    let bad = Params {
        angle_std_deg: -1.0,
        ..Params::default()
    };
    match build(bad, &context(0)).err().unwrap() {
        NodeError::Params(p) => assert_eq!(p.field, "angle_std_deg"),
        other => panic!("{other}"),
    }

    let mut spectral = Params {
        fidelity: nrslam_radar::Fidelity::Spectral,
        ..Params::default()
    };
    spectral.ofdm.antennas = 0;
    match build(spectral, &context(0)).err().unwrap() {
        NodeError::Params(p) => {
            assert_eq!(p.field, "ofdm");
            assert!(p.problem.contains("antennas"), "{}", p.problem);
        }
        other => panic!("{other}"),
    }

    // A radar has no inputs: a message sent to it is an error, not a panic.
    let mut node = build(Params::default(), &context(0)).unwrap();
    let message = Message::Clock(nrslam_msgs::Clock::default());
    assert!(node
        .on_message("/clock", &message, &mut Outbox::new())
        .is_err());
}

#[test]
fn missing_scene_file_error_names_the_path() {
    let path = workspace().join("config/absent.toml");
    match Scene::load(&path) {
        Err(SceneError::Read { path: p, .. }) => assert_eq!(p, path),
        other => panic!("{other:?}"),
    }
}
