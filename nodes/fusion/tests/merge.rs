//! The fusion algorithm on synthetic point scenes: an AGV whose start is unknown is merged into
//! the map frame at its true frame, and agents that never see the same targets are never merged.

use nrslam_association::Pose2;
use nrslam_fusion::{Fusion, Params};

#[path = "../benches/common/mod.rs"]
mod common;
use common::{lap, observe, scene};

/// Feeds two AGVs' keyframes alternately; the second's poses in a frame `start` unknown to it.
fn run(fusion: &mut Fusion, scene: &[[f64; 2]], first: &[Pose2], second: &[Pose2], start: Pose2) {
    let to_local = start.inverse();
    for k in 0..first.len().max(second.len()) {
        if let Some(pose) = first.get(k) {
            fusion
                .add_keyframe(0, k as u32, *pose, observe(scene, pose))
                .unwrap();
        }
        if let Some(pose) = second.get(k) {
            fusion
                .add_keyframe(1, k as u32, to_local.compose(pose), observe(scene, pose))
                .unwrap();
        }
    }
}

/// Asserts that each keyframe of `agent` has a fused pose within `tolerance_m` of `truths`'.
fn assert_fused_near(fusion: &Fusion, agent: usize, truths: &[Pose2], tolerance_m: f64) {
    for (k, truth) in truths.iter().enumerate() {
        let (_, fused) = fusion.fused_keyframe(agent, k).expect("published");
        assert!(
            fused.distance_m(truth) < tolerance_m,
            "agent {agent}, keyframe {k}: {fused:?} vs {truth:?}"
        );
    }
}

fn two_agvs() -> Params {
    Params {
        agvs: 2,
        ..Params::default()
    }
}

#[test]
fn an_agv_with_an_unknown_start_is_merged_at_its_true_frame() {
    let scene = scene(0.0);
    let path = lap(5.0, 4.0, 36.0, 27.0, 1.5);
    let half = path.len() / 2;
    let second: Vec<Pose2> = path[half..].iter().chain(&path[..half]).copied().collect();
    let start = second[0];
    let mut fusion = Fusion::new(two_agvs());
    run(&mut fusion, &scene, &path, &second, start);
    let frame = fusion.frame_of(1).expect("the second AGV is merged");
    // The frame is judged at the start, up to 30 m from where the matches were made: a heading
    // error of 0.6° moves it by 0.3 m there.
    assert!(
        frame.distance_m(&start) < 0.5 && frame.rotation_to_rad(&start) < 1f64.to_radians(),
        "merged at {frame:?}, true start {start:?}"
    );
    // Every fused keyframe of the second AGV near its true pose.
    assert_fused_near(&fusion, 1, &second, 0.5);
    assert!(fusion.stats().merges == 1);
    assert!(!fusion.inter_edges().is_empty());
}

#[test]
fn agents_that_never_see_the_same_targets_are_never_merged() {
    // Two copies of the layout 100 m apart, one AGV around each: nothing in common but the
    // layout itself, which is exactly the risk (a repeated structure).
    let mut scene = scene(0.0);
    scene.extend(common::scene(100.0));
    let first = lap(5.0, 4.0, 36.0, 27.0, 1.5);
    let second: Vec<Pose2> = first
        .iter()
        .map(|p| Pose2::new(p.x_m + 100.0, p.y_m, p.yaw_rad))
        .collect();
    // Both starts known: the second AGV's frame is the map's, so the map is the union.
    let mut fusion = Fusion::new(Params {
        known_starts: 2,
        ..two_agvs()
    });
    run(
        &mut fusion,
        &scene,
        &first,
        &second,
        Pose2::new(0.0, 0.0, 0.0),
    );
    assert_eq!(
        fusion.inter_edges(),
        &[],
        "no inter-agent edge may be accepted"
    );
    assert_eq!(
        fusion.fused_poses().len(),
        first.len() + second.len(),
        "the fused map is the union of both"
    );
}

#[test]
fn bad_input_is_refused_without_changing_the_state() {
    let mut fusion = Fusion::new(two_agvs());
    assert!(fusion
        .add_keyframe(0, 0, Pose2::new(f64::NAN, 0.0, 0.0), vec![])
        .is_err());
    assert!(fusion
        .add_keyframe(0, 0, Pose2::new(0.0, 0.0, 0.0), vec![[f64::INFINITY, 0.0]])
        .is_err());
    fusion
        .add_keyframe(0, 3, Pose2::new(0.0, 0.0, 0.0), vec![[1.0, 0.0]])
        .unwrap();
    assert!(fusion
        .add_keyframe(0, 3, Pose2::new(0.0, 0.0, 0.0), vec![])
        .is_err());
    assert!(fusion
        .add_keyframe(7, 0, Pose2::new(0.0, 0.0, 0.0), vec![])
        .is_err());
    assert!(fusion
        .add_station_frame(0, Pose2::new(0.0, 0.0, 0.0), vec![])
        .is_err());
    assert_eq!(fusion.fused_poses().len(), 1);
}

#[test]
fn an_agents_own_loop_edges_are_counted_again_only_when_asked() {
    // One AGV, its frame the map's: four keyframes on a square, and an own loop edge between the
    // first and the last that disagrees with its poses by 0.5 m (as a loop edge does before the
    // agent's own graph has absorbed it).
    let poses = [
        Pose2::new(0.0, 0.0, 0.0),
        Pose2::new(4.0, 0.0, 0.0),
        Pose2::new(4.0, 4.0, 0.0),
        Pose2::new(0.0, 4.0, 0.0),
    ];
    let fused_after_loop = |own_loop_edges: bool| {
        let mut fusion = Fusion::new(Params {
            own_loop_edges,
            ..Params::default()
        });
        for (k, pose) in poses.iter().enumerate() {
            fusion
                .add_keyframe(0, k as u32, *pose, vec![[1.0, 1.0]])
                .unwrap();
        }
        let local: Vec<(u32, Pose2)> = poses
            .iter()
            .enumerate()
            .map(|(k, p)| (k as u32, *p))
            .collect();
        let loops = [(0, 3, Pose2::new(0.5, 4.0, 0.0))];
        fusion.set_local_poses(0, &local, &loops).unwrap();
        fusion.fused_keyframe(0, 3).unwrap().1
    };
    // Without them the fused poses are the agent's own: its chain already holds its loops.
    assert!(fused_after_loop(false).distance_m(&poses[3]) < 1e-6);
    // With them the loop pulls the last keyframe toward its measurement a second time.
    assert!(fused_after_loop(true).distance_m(&poses[3]) > 0.05);
}

#[test]
fn agents_that_see_opposite_faces_of_a_row_are_not_matched_face_to_face() {
    // A row of boxes 1.2 m deep; agv1 drives east along its south side and sees only the south
    // faces, agv2 west along its north side and sees only the north faces (a 5G detection is
    // the near face). Both starts known: every match between them would pull one row of faces
    // onto the other, 1.2 m off.
    let boxes = [
        (0.0, 3.0),
        (6.0, 1.5),
        (11.0, 3.0),
        (17.0, 2.0),
        (22.0, 1.0),
        (27.0, 3.0),
    ];
    let face = |y_m: f64| -> Vec<[f64; 2]> {
        boxes
            .iter()
            .flat_map(|&(x0, width_m)| {
                let n = (width_m / 0.25) as usize;
                (0..=n).map(move |i| [x0 + width_m * i as f64 / n as f64, y_m])
            })
            .collect()
    };
    let (south, north) = (face(9.4), face(10.6));
    let east: Vec<Pose2> = (0..30).map(|k| Pose2::new(k as f64, 5.0, 0.0)).collect();
    let west: Vec<Pose2> = (0..30)
        .map(|k| Pose2::new(29.0 - k as f64, 15.0, std::f64::consts::PI))
        .collect();
    let edges = |max_opposite_ratio: f64| {
        let mut fusion = Fusion::new(Params {
            known_starts: 2,
            max_opposite_ratio,
            ..two_agvs()
        });
        for (k, (a, b)) in east.iter().zip(&west).enumerate() {
            let k = k as u32;
            fusion.add_keyframe(0, k, *a, observe(&south, a)).unwrap();
            fusion.add_keyframe(1, k, *b, observe(&north, b)).unwrap();
        }
        (fusion.inter_edges().len(), fusion.stats().opposite_views)
    };
    let (unchecked, _) = edges(1.0);
    assert!(
        unchecked > 0,
        "without the rule the faces are matched: {unchecked}"
    );
    let (checked, refused) = edges(0.6);
    assert_eq!(checked, 0, "with it no face-to-face edge is accepted");
    assert!(refused > 0);
}

#[test]
fn an_agv_merged_at_a_look_alike_is_moved_to_its_place_once_it_sees_the_difference() {
    // Two copies of one layout 40 m apart (west, east), a box in the middle both AGVs see, and
    // a box beside the west copy only, where agv2 looks through the east copy's free floor. agv1 loops round the west copy and the middle, its start
    // known; agv2 round the east copy and the middle, its start unknown, starting on its east
    // side: what it sees first is the east copy, the twin of what agv1 mapped.
    let mut scene = scene(0.0);
    scene.extend(common::scene(40.0));
    scene.extend(common::box_outline(40.5, 15.5, 2.0, 3.0, 0.25));
    scene.extend(common::box_outline(34.0, 9.0, 1.0, 1.5, 0.25));
    let first = lap(5.0, 4.0, 44.0, 27.0, 1.0);
    let east = lap(37.0, 4.0, 76.0, 27.0, 1.0);
    let start = east
        .iter()
        .position(|p| p.x_m >= 76.0)
        .expect("an east side");
    let mut second = east.clone();
    second.rotate_left(start);
    let truth = second[0];
    let twin = Pose2::new(truth.x_m - 40.0, truth.y_m, truth.yaw_rad);
    let run_with = |verify_every_keyframes: u32| {
        let mut fusion = Fusion::new(Params {
            verify_every_keyframes,
            ..two_agvs()
        });
        // agv1's lap first: agv2's first matches are against the whole west copy.
        for (k, pose) in first.iter().enumerate() {
            fusion
                .add_keyframe(0, k as u32, *pose, first_returns(&scene, pose))
                .unwrap();
        }
        let to_local = truth.inverse();
        for (k, pose) in second.iter().enumerate() {
            let local = to_local.compose(pose);
            fusion
                .add_keyframe(1, k as u32, local, first_returns(&scene, pose))
                .unwrap();
        }
        fusion
    };
    let near = |frame: Pose2, to: &Pose2| frame.distance_m(to) < 1.0;
    // NRSLAM_LOG=nrslam_fusion=debug shows the matches and the re-checks' verdicts.
    let _ = tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_env("NRSLAM_LOG"))
        .with_test_writer()
        .try_init();
    let unchecked = run_with(0);
    let frame = unchecked.frame_of(1).expect("merged");
    assert!(
        near(frame, &twin),
        "without re-checks agv2 stays where its first matches put it, the twin: {frame:?}"
    );
    let checked = run_with(Params::default().verify_every_keyframes);
    let frame = checked.frame_of(1).expect("merged");
    assert!(
        near(frame, &truth),
        "re-checked, agv2 ends at its true frame {truth:?}: {frame:?} ({:?})",
        checked.stats()
    );
    assert_eq!(checked.stats().remerges, 1);
    // Every inter-agent edge left is a true one.
    for e in checked.inter_edges() {
        let (from, to) = (first.get(e.from.1), second.get(e.to.1));
        if let (Some(from), Some(to)) = (from, to) {
            let error = from.compose(&e.relative).distance_m(to);
            assert!(error < 0.5, "edge {e:?} is {error} m off");
        }
    }
}

/// What an AGV at `pose` sees of `scene` when a target hides what is behind it: of the points
/// [`observe`] keeps, the nearest in each 1° of bearing (body frame).
fn first_returns(scene: &[[f64; 2]], pose: &Pose2) -> Vec<[f64; 2]> {
    let mut nearest: std::collections::BTreeMap<i64, [f64; 2]> = Default::default();
    for p in observe(scene, pose) {
        let bin = p[1].atan2(p[0]).to_degrees().floor() as i64;
        let range = p[0].hypot(p[1]);
        let kept = nearest.entry(bin).or_insert(p);
        if range < kept[0].hypot(kept[1]) {
            *kept = p;
        }
    }
    nearest.into_values().collect()
}

#[test]
fn an_agv_whose_back_end_restarts_keeps_its_earlier_session_and_is_merged_again() {
    // One AGV, its start known. Its SLAM dies two thirds round the lap and starts over: keyframe
    // ids from 0 again, its poses in the frame of wherever its odometry then was (unknown to
    // fusion). It drives on round the lap and past its start again.
    let scene = scene(0.0);
    let path = lap(5.0, 4.0, 36.0, 27.0, 1.5);
    let split = 2 * path.len() / 3;
    let before = &path[..split];
    let mut after = path.clone();
    after.rotate_left(split);
    let restart_at = after[0];
    // Where the restarted SLAM thinks it starts: 3 m and 20° from the truth.
    let local_start = Pose2::new(restart_at.x_m + 3.0, restart_at.y_m - 2.0, 0.35);
    let to_local = local_start.compose(&restart_at.inverse());
    let mut fusion = Fusion::new(Params {
        agvs: 1,
        ..Params::default()
    });
    for (k, pose) in before.iter().enumerate() {
        fusion
            .add_keyframe(0, k as u32, *pose, observe(&scene, pose))
            .unwrap();
    }
    // Within a session an id going back is refused.
    assert!(matches!(
        fusion.add_keyframe(0, 0, before[0], observe(&scene, &before[0])),
        Err(nrslam_fusion::FusionError::OutOfOrder { id: 0, .. })
    ));
    // The node saw keyframe 0 again at a later stamp: a new session.
    assert_eq!(fusion.start_new_session(0), Ok(Some(1)));
    for (k, pose) in after.iter().enumerate() {
        fusion
            .add_keyframe(0, k as u32, to_local.compose(pose), observe(&scene, pose))
            .unwrap();
    }
    assert_eq!(fusion.stats().restarts, 1);
    assert_eq!(
        fusion.agent_count(),
        2,
        "the earlier session is an agent of its own"
    );
    // The earlier session keeps its place in the map.
    assert_fused_near(&fusion, 1, before, 0.3);
    // The new session is merged at its true frame, against the map its earlier session made.
    // The frame judged where the new session started (its origin is 47 m off the hall).
    let frame = fusion
        .frame_of(0)
        .expect("the restarted AGV is merged again");
    let placed = frame.compose(&local_start);
    assert!(
        placed.distance_m(&restart_at) < 0.5
            && placed.rotation_to_rad(&restart_at) < 1f64.to_radians(),
        "its restart placed at {placed:?}, truly at {restart_at:?}"
    );
    // Merged, it publishes every keyframe it held, each near its true pose.
    assert_fused_near(&fusion, 0, &after, 0.5);
    assert_eq!(fusion.fused_poses().len(), before.len() + after.len());
    assert!(
        fusion.inter_edges().iter().any(|e| e.from.0 != e.to.0),
        "edges join the two sessions"
    );
}

#[test]
fn an_agv_that_keeps_starting_over_is_refused_after_max_restarts() {
    let mut fusion = Fusion::new(Params {
        agvs: 1,
        ..Params::default()
    });
    let pose = Pose2::new(0.0, 0.0, 0.0);
    // Nothing to keep before its first keyframe.
    assert_eq!(fusion.start_new_session(0), Ok(None));
    for restart in 0..=nrslam_fusion::MAX_RESTARTS {
        if restart > 0 {
            assert_eq!(fusion.start_new_session(0), Ok(Some(restart as usize)));
        }
        fusion.add_keyframe(0, 0, pose, vec![[1.0, 1.0]]).unwrap();
        fusion.add_keyframe(0, 1, pose, vec![[1.0, 1.0]]).unwrap();
        assert_eq!(fusion.stats().restarts, u64::from(restart));
    }
    let refused = nrslam_fusion::FusionError::TooManyRestarts(0);
    assert_eq!(fusion.start_new_session(0), Err(refused.clone()));
    assert_eq!(
        fusion.agent_count(),
        1 + nrslam_fusion::MAX_RESTARTS as usize
    );
    // Cut off: nothing more of it is taken, and it has no corrected pose.
    assert_eq!(
        fusion.add_keyframe(0, 2, pose, vec![[1.0, 1.0]]).err(),
        Some(refused.clone())
    );
    assert_eq!(
        fusion
            .set_local_poses(0, &[(0, pose), (1, pose)], &[])
            .err(),
        Some(refused)
    );
    assert_eq!(fusion.corrected_pose(0, pose), None);
}

#[test]
fn an_estimate_that_ends_before_the_agents_newest_keyframe_is_refused() {
    // What a back end that started over sends when its keyframe 0 was lost: poses of its new
    // ids, which are not this session's.
    let mut fusion = Fusion::new(Params {
        agvs: 1,
        ..Params::default()
    });
    for k in 0..3 {
        fusion
            .add_keyframe(0, k, Pose2::new(f64::from(k), 0.0, 0.0), vec![[1.0, 1.0]])
            .unwrap();
    }
    let moved = [(0, Pose2::new(30.0, 0.0, 0.0))];
    assert!(matches!(
        fusion.set_local_poses(0, &moved, &[]),
        Err(nrslam_fusion::FusionError::OutOfOrder { id: 0, last: 2 })
    ));
    assert_eq!(
        fusion.fused_keyframe(0, 0).unwrap().1,
        Pose2::new(0.0, 0.0, 0.0)
    );
}
