//! Keyframe and loop-edge scoring.

use super::Reporter;
use nrslam_msgs::{
    topics, Header, Keyframe, KeyframePoses, Message, Point, Pose, PoseStamped, Time,
};
use std::collections::BTreeMap;
use std::f64::consts::FRAC_PI_2;

fn header(seconds: f64) -> Header {
    Header {
        stamp: Time::from_seconds(seconds),
        frame_id: "map".into(),
    }
}

fn pose(x: f64, y: f64) -> Pose {
    Pose {
        position: Point { x, y, z: 0.0 },
        ..Pose::default()
    }
}

/// Keyframes at t = 1, 2 first published 1 m and 2 m off the truth; the truth at t = 3 has no
/// keyframe and must not count.
fn reporter() -> Reporter {
    let mut r = Reporter::default();
    for (t, x) in [(1.0, 0.0), (2.0, 10.0), (3.0, 20.0)] {
        let truth = PoseStamped {
            header: header(t),
            pose: pose(x, 0.0),
        };
        r.take(topics::GROUND_TRUTH_POSE, &Message::PoseStamped(truth));
    }
    for (id, t, x) in [(0, 1.0, 1.0), (1, 2.0, 12.0)] {
        let keyframe = Keyframe {
            header: header(t),
            id,
            pose: pose(x, 0.0),
            ..Keyframe::default()
        };
        r.take(topics::KEYFRAME, &Message::Keyframe(keyframe));
    }
    r
}

#[test]
fn keyframe_rmse_scores_keyframes_as_published_without_corrections() {
    let rmse = reporter().keyframe_rmse_m().unwrap();
    assert!((rmse - (2.5f64).sqrt()).abs() < 1e-12, "{rmse}");
}

#[test]
fn keyframe_rmse_takes_the_latest_corrected_poses() {
    let mut r = reporter();
    for (revision, second_x) in [(1, 11.0), (2, 10.0)] {
        let corrected = KeyframePoses {
            header: header(2.0),
            revision,
            ids: vec![0, 1],
            poses: vec![pose(0.0, 0.0), pose(second_x, 0.0)],
            ..KeyframePoses::default()
        };
        r.take(topics::KEYFRAME_POSES, &Message::KeyframePoses(corrected));
    }
    assert_eq!(r.keyframe_rmse_m(), Some(0.0));
    // Ids and poses that do not pair up leave the keyframes as first published.
    let unpaired = KeyframePoses {
        header: header(2.0),
        revision: 3,
        ids: vec![0, 1],
        poses: vec![pose(0.0, 0.0)],
        ..KeyframePoses::default()
    };
    r.take(topics::KEYFRAME_POSES, &Message::KeyframePoses(unpaired));
    let rmse = r.keyframe_rmse_m().unwrap();
    assert!((rmse - (2.5f64).sqrt()).abs() < 1e-12, "{rmse}");
}

/// Keyframes 0 and 1, stamped 1 s and 2 s, with true poses `truths` (x m, y m, yaw rad).
fn two_keyframes_truly_at(truths: [(f64, f64, f64); 2]) -> Reporter {
    let mut r = Reporter::default();
    for (id, (x, y, yaw)) in (0u32..).zip(truths) {
        let t = f64::from(id + 1);
        let truth = PoseStamped {
            header: header(t),
            pose: Pose::from_planar(x, y, yaw),
        };
        r.take(topics::GROUND_TRUTH_POSE, &Message::PoseStamped(truth));
        let keyframe = Keyframe {
            header: header(t),
            id,
            ..Keyframe::default()
        };
        r.take(topics::KEYFRAME, &Message::Keyframe(keyframe));
    }
    r
}

#[test]
fn loop_edges_are_scored_in_the_older_keyframes_true_frame() {
    // Keyframe 0 truly at (1, 1) facing +y; keyframe 1 truly at (1, 4): 3 m ahead of it.
    let mut r = two_keyframes_truly_at([(1.0, 1.0, FRAC_PI_2), (1.0, 4.0, 0.0)]);
    let r_with_truth = r.clone();
    // One right loop, one 0.6 m off sideways, one naming a keyframe never seen (not scored),
    // and an excess relative pose without ids (ignored).
    let poses = KeyframePoses {
        header: header(2.0),
        loop_from_ids: vec![0, 0, 0],
        loop_to_ids: vec![1, 1, 7],
        loop_relatives: vec![
            Pose::from_planar(3.0, 0.0, -FRAC_PI_2),
            Pose::from_planar(3.0, 0.6, -FRAC_PI_2),
            Pose::from_planar(0.0, 0.0, 0.0),
            Pose::from_planar(9.0, 9.0, 0.0),
        ],
        ..KeyframePoses::default()
    };
    // The same edges saying they pin down (0.1 m std) only the measurement frame's x, then
    // only its y: the 0.6 m sideways error (along the older keyframe's y, which is the
    // measurement frame's x after its -90° turn) is inconsistent with the first and not with
    // the second.
    let sure_of = |axis: usize| {
        let mut omega = vec![0.0; 9];
        omega[4 * axis] = 100.0;
        omega[8] = 1.0;
        omega
    };
    for (axis, inconsistent) in [(0, 1), (1, 0)] {
        let mut informed = poses.clone();
        informed.loop_informations = [sure_of(axis), sure_of(axis)].concat();
        let mut r = r_with_truth.clone();
        r.take(topics::KEYFRAME_POSES, &Message::KeyframePoses(informed));
        let summary = r.summary(&BTreeMap::new(), 1, "x.toml");
        assert_eq!(summary.loop_edges_inconsistent, inconsistent, "axis {axis}");
    }
    r.take(topics::KEYFRAME_POSES, &Message::KeyframePoses(poses));
    let errors: Vec<f64> = r.scored_loop_edges().iter().map(|e| e.error_m).collect();
    assert_eq!(errors.len(), 2, "{errors:?}");
    assert!(
        errors[0] < 1e-9 && (errors[1] - 0.6).abs() < 1e-9,
        "{errors:?}"
    );
    let summary = r.summary(&BTreeMap::new(), 1, "x.toml");
    assert_eq!(
        (summary.loop_edges_scored, summary.loop_edges_wrong),
        (2, 1)
    );
}

#[test]
fn a_loop_edges_graph_error_is_the_final_graphs_relative_pose_against_the_truth() {
    use std::f64::consts::PI;
    // Keyframe 0 truly at the origin facing +y; keyframe 1 truly 3 m ahead of it, at (0, 3).
    let mut r = two_keyframes_truly_at([(0.0, 0.0, FRAC_PI_2), (0.0, 3.0, 0.0)]);
    // The edge measured 0.6 m off sideways. The graph holds keyframe 0 elsewhere, facing 120°,
    // and keyframe 1 2.8 m straight ahead of it: 0.2 m short, whatever the map frame. (Without
    // the rotation into keyframe 0's frame, or with the wrong sign or keyframe 1's heading, the
    // error would be 4–5 m.)
    let ahead_m = |distance_m: f64| {
        let yaw = 2.0 * PI / 3.0;
        Pose::from_planar(
            5.0 + distance_m * yaw.cos(),
            5.0 + distance_m * yaw.sin(),
            PI / 6.0,
        )
    };
    let poses = |ahead: Pose| KeyframePoses {
        header: header(2.0),
        ids: vec![0, 1],
        poses: vec![Pose::from_planar(5.0, 5.0, 2.0 * PI / 3.0), ahead],
        loop_from_ids: vec![0],
        loop_to_ids: vec![1],
        loop_relatives: vec![Pose::from_planar(3.0, 0.6, -FRAC_PI_2)],
        ..KeyframePoses::default()
    };
    let take = |r: &mut Reporter, k: KeyframePoses| {
        r.take(topics::KEYFRAME_POSES, &Message::KeyframePoses(k));
        let summary = r.summary(&BTreeMap::new(), 1, "x.toml");
        (r.scored_loop_edges(), summary)
    };
    let (edges, summary) = take(&mut r, poses(ahead_m(2.8)));
    assert_eq!(edges.len(), 1);
    assert!((edges[0].error_m - 0.6).abs() < 1e-9, "{edges:?}");
    let graph_error_m = edges[0].graph_error_m.expect("both keyframes in the graph");
    assert!((graph_error_m - 0.2).abs() < 1e-9, "{graph_error_m}");
    assert_eq!(
        (summary.loop_edges_wrong, summary.loop_edges_off_in_graph),
        (1, Some(0))
    );
    // A graph that holds keyframe 1 0.7 m short is off at this loop too.
    let (_, summary) = take(&mut r, poses(ahead_m(2.3)));
    assert_eq!(summary.loop_edges_off_in_graph, Some(1));
    // A graph that cannot say: keyframe 0 or 1 missing, ids and poses that do not pair up, a
    // pose that is not finite. The edge is still scored; the graph's count is unknown.
    let mut without_older = poses(ahead_m(2.8));
    without_older.ids.remove(0);
    without_older.poses.remove(0);
    let mut without_newer = poses(ahead_m(2.8));
    without_newer.ids.pop();
    without_newer.poses.pop();
    let mut unpaired = poses(ahead_m(2.8));
    unpaired.ids.push(2);
    let nan = poses(Pose::from_planar(f64::NAN, 5.0, 0.0));
    for k in [without_older, without_newer, unpaired, nan] {
        let (edges, summary) = take(&mut r, k);
        assert_eq!(edges.len(), 1);
        assert_eq!(edges[0].graph_error_m, None, "{edges:?}");
        assert_eq!(summary.loop_edges_off_in_graph, None);
    }
}

#[test]
fn keyframe_rmse_is_none_without_truth_at_the_keyframe_stamps() {
    let mut r = Reporter::default();
    let keyframe = Keyframe {
        header: header(5.0),
        ..Keyframe::default()
    };
    r.take(topics::KEYFRAME, &Message::Keyframe(keyframe));
    assert_eq!(r.keyframe_rmse_m(), None);
}
