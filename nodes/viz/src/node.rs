//! The viz node: the graph's topics in, what RViz and Foxglove draw out.
//!
//! | input | output |
//! |---|---|
//! | `/ground_truth/targets` (latched) | `/ground_truth/markers` (latched): outlines, samples |
//! | `/odom` | kept: `odom → base_link` of the next `/tf` |
//! | `/ground_truth/pose` | `/ground_truth/path` |
//! | `/slam/pose` | `/tf` (`map → odom`, `odom → base_link`), `/slam/path` |
//! | `/radar/detections` | `/radar/detections_cloud`; the first, and any boresight change, `/tf_static` (`base_link → radar`) |
//! | `/map/segments` | `/map/clusters`: cells by cluster, representative points, noise |
//!
//! Inputs are declared odometry before the SLAM pose, so that at one stamp `map → odom` is the
//! SLAM pose composed with the inverse of that frame's odometry (REP-105: `map → odom` absorbs
//! the drift, `odom → base_link` stays continuous).

use std::collections::VecDeque;

use nrslam_evaluator::segment_representatives;
use nrslam_msgs::topics::{
    CLUSTER_MARKERS, DETECTIONS, DETECTIONS_CLOUD, GROUND_TRUTH_MARKERS, GROUND_TRUTH_PATH,
    GROUND_TRUTH_POSE, GROUND_TRUTH_TARGETS, ODOM, SEGMENTS, SLAM_PATH, SLAM_POSE, TF, TF_STATIC,
};
use nrslam_msgs::{Header, Message, Path, PoseStamped, Segments, TFMessage};
use nrslam_runtime::{Node, NodeContext, NodeError, NodeResult, Outbox};

use crate::draw::{self, Planar, BASE_FRAME, MAP_FRAME, ODOM_FRAME, RADAR_FRAME};
use crate::Params;

/// A path kept to at most `max` poses.
#[derive(Debug)]
struct Trail {
    poses: VecDeque<PoseStamped>,
    max: usize,
}

impl Trail {
    fn push(&mut self, pose: &PoseStamped) -> Path {
        if self.poses.len() == self.max {
            self.poses.pop_front();
        }
        self.poses.push_back(PoseStamped {
            header: Header::new(pose.header.stamp, MAP_FRAME),
            pose: pose.pose,
        });
        Path {
            header: Header::new(pose.header.stamp, MAP_FRAME),
            poses: self.poses.iter().cloned().collect(),
        }
    }
}

/// The viz node's state.
#[derive(Debug)]
pub struct VizNode {
    params: Params,
    odometry: Option<Planar>,
    boresight_rad: Option<f64>,
    slam_trail: Trail,
    true_trail: Trail,
}

/// Builds the viz node from `params` (validated here); `ctx` is not used.
pub fn build(params: Params, _ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    Ok(Box::new(VizNode::new(params)?))
}

fn planar(pose: &nrslam_msgs::Pose, topic: &str) -> Result<Planar, NodeError> {
    let p = pose.planar();
    if p.0.is_finite() && p.1.is_finite() && p.2.is_finite() {
        Ok(p)
    } else {
        Err(NodeError::invalid_input(
            topic,
            format!("non-finite pose {p:?}"),
        ))
    }
}

impl VizNode {
    /// A node with `params`, which must pass [`Params::validate`].
    pub fn new(params: Params) -> Result<Self, NodeError> {
        params.validate()?;
        let trail = || Trail {
            poses: VecDeque::new(),
            max: params.path_max_poses as usize,
        };
        Ok(Self {
            odometry: None,
            boresight_rad: None,
            slam_trail: trail(),
            true_trail: trail(),
            params,
        })
    }

    fn on_slam_pose(&mut self, pose: &PoseStamped, outbox: &mut Outbox) -> Result<(), NodeError> {
        let slam = planar(&pose.pose, SLAM_POSE)?;
        let stamp = pose.header.stamp;
        // Without odometry the whole pose is odom → base_link and map → odom is the identity.
        let odom = if self.params.odometry {
            self.odometry.unwrap_or(slam)
        } else {
            slam
        };
        let map_to_odom = draw::compose(slam, draw::inverse(odom));
        outbox.publish(
            TF,
            TFMessage {
                transforms: vec![
                    draw::transform(MAP_FRAME, ODOM_FRAME, stamp, map_to_odom),
                    draw::transform(ODOM_FRAME, BASE_FRAME, stamp, odom),
                ],
            },
        );
        outbox.publish(SLAM_PATH, self.slam_trail.push(pose));
        Ok(())
    }

    fn on_detections(&mut self, detections: &nrslam_msgs::Detections, outbox: &mut Outbox) {
        if self.boresight_rad != Some(detections.boresight_rad) {
            self.boresight_rad = Some(detections.boresight_rad);
            outbox.publish(
                TF_STATIC,
                TFMessage {
                    transforms: vec![draw::transform(
                        BASE_FRAME,
                        RADAR_FRAME,
                        detections.header.stamp,
                        (0.0, 0.0, detections.boresight_rad),
                    )],
                },
            );
        }
        outbox.publish(DETECTIONS_CLOUD, draw::detections_cloud(detections));
    }

    fn on_segments(&self, segments: &Segments, outbox: &mut Outbox) -> Result<(), NodeError> {
        let clusters = segment_representatives(
            segments,
            self.params.points_per_estimate as usize,
            self.params.representatives,
        )?;
        outbox.publish(
            CLUSTER_MARKERS,
            draw::cluster_markers(
                segments,
                &clusters,
                self.params.cell_size_m,
                self.params.point_size_m,
            ),
        );
        Ok(())
    }
}

impl Node for VizNode {
    fn inputs(&self) -> Vec<&'static str> {
        let p = &self.params;
        let mut inputs = Vec::new();
        if p.ground_truth {
            inputs.push(GROUND_TRUTH_TARGETS);
        }
        if p.odometry {
            inputs.push(ODOM);
        }
        if p.ground_truth {
            inputs.push(GROUND_TRUTH_POSE);
        }
        inputs.push(SLAM_POSE);
        if p.detections {
            inputs.push(DETECTIONS);
        }
        if p.clusters {
            inputs.push(SEGMENTS);
        }
        inputs
    }

    fn outputs(&self) -> Vec<&'static str> {
        let p = &self.params;
        let mut outputs = vec![TF, SLAM_PATH];
        if p.ground_truth {
            outputs.extend([GROUND_TRUTH_MARKERS, GROUND_TRUTH_PATH]);
        }
        if p.detections {
            outputs.extend([TF_STATIC, DETECTIONS_CLOUD]);
        }
        if p.clusters {
            outputs.push(CLUSTER_MARKERS);
        }
        outputs
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        match (topic, message) {
            (GROUND_TRUTH_TARGETS, Message::TargetSet(targets)) => outbox.publish(
                GROUND_TRUTH_MARKERS,
                draw::target_markers(targets, self.params.line_width_m, self.params.point_size_m),
            ),
            (ODOM, Message::Odometry(odometry)) => {
                self.odometry = Some(planar(&odometry.pose.pose, ODOM)?);
            }
            (GROUND_TRUTH_POSE, Message::PoseStamped(pose)) => {
                planar(&pose.pose, GROUND_TRUTH_POSE)?;
                outbox.publish(GROUND_TRUTH_PATH, self.true_trail.push(pose));
            }
            (SLAM_POSE, Message::PoseStamped(pose)) => self.on_slam_pose(pose, outbox)?,
            (DETECTIONS, Message::Detections(detections)) => self.on_detections(detections, outbox),
            (SEGMENTS, Message::Segments(segments)) => self.on_segments(segments, outbox)?,
            (topic, other) => return Err(NodeError::unexpected(topic, other)),
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{Detection, Detections, Odometry, Pose, PoseWithCovariance, Time};

    fn pose_at(stamp_s: f64, x: f64, y: f64, yaw: f64) -> PoseStamped {
        PoseStamped {
            header: Header::new(Time::from_seconds(stamp_s), "map"),
            pose: Pose::from_planar(x, y, yaw),
        }
    }

    fn run(node: &mut VizNode, inputs: Vec<(&str, Message)>) -> Vec<(&'static str, Message)> {
        let mut outbox = Outbox::new();
        for (topic, message) in inputs {
            node.on_message(topic, &message, &mut outbox).unwrap();
        }
        outbox.drain().collect()
    }

    #[test]
    fn map_to_odom_is_the_slam_correction_of_the_odometry() {
        let mut node = VizNode::new(Params::default()).unwrap();
        let odometry = Odometry {
            header: Header::new(Time::from_seconds(1.0), "odom"),
            pose: PoseWithCovariance {
                pose: Pose::from_planar(2.0, 0.0, 0.1),
                ..PoseWithCovariance::default()
            },
            ..Odometry::default()
        };
        let slam = pose_at(1.0, 2.0, 0.5, 0.3);
        let out = run(
            &mut node,
            vec![(ODOM, odometry.into()), (SLAM_POSE, slam.clone().into())],
        );
        let topics: Vec<_> = out.iter().map(|(t, _)| *t).collect();
        assert_eq!(topics, [TF, SLAM_PATH]);
        let Message::TFMessage(tf) = &out[0].1 else {
            panic!()
        };
        let frames: Vec<_> = tf
            .transforms
            .iter()
            .map(|t| (t.header.frame_id.as_str(), t.child_frame_id.as_str()))
            .collect();
        assert_eq!(frames, [("map", "odom"), ("odom", "base_link")]);
        // Chaining the two gives the SLAM pose back.
        let as_planar = |t: &nrslam_msgs::TransformStamped| {
            let tr = &t.transform;
            (tr.translation.x, tr.translation.y, tr.rotation.yaw())
        };
        let chained = draw::compose(as_planar(&tf.transforms[0]), as_planar(&tf.transforms[1]));
        let expected = slam.pose.planar();
        assert!(
            (chained.0 - expected.0).abs() < 1e-12
                && (chained.1 - expected.1).abs() < 1e-12
                && (chained.2 - expected.2).abs() < 1e-12,
            "{chained:?}"
        );
        assert!((tf.transforms[1].transform.translation.x - 2.0).abs() < 1e-12);
    }

    #[test]
    fn paths_grow_to_their_bound_and_detections_fix_the_radar_once() {
        let mut node = VizNode::new(Params {
            path_max_poses: 2,
            ..Params::default()
        })
        .unwrap();
        let out = run(
            &mut node,
            (0..3)
                .map(|k| {
                    (
                        GROUND_TRUTH_POSE,
                        pose_at(1.0 + k as f64, k as f64, 0.0, 0.0).into(),
                    )
                })
                .collect(),
        );
        let Message::Path(last) = &out[2].1 else {
            panic!()
        };
        let xs: Vec<f64> = last.poses.iter().map(|p| p.pose.position.x).collect();
        assert_eq!(xs, [1.0, 2.0]);
        assert_eq!(last.header.frame_id, "map");
        let detections = |stamp_s: f64, boresight_rad: f64| Detections {
            header: Header::new(Time::from_seconds(stamp_s), "radar"),
            boresight_rad,
            detections: vec![Detection {
                range_m: 3.0,
                ..Detection::default()
            }],
        };
        let out = run(
            &mut node,
            vec![
                (DETECTIONS, detections(1.0, 1.5).into()),
                (DETECTIONS, detections(2.0, 1.5).into()),
                (DETECTIONS, detections(3.0, -1.5).into()),
            ],
        );
        let topics: Vec<_> = out.iter().map(|(t, _)| *t).collect();
        assert_eq!(
            topics,
            [
                TF_STATIC,
                DETECTIONS_CLOUD,
                DETECTIONS_CLOUD,
                TF_STATIC,
                DETECTIONS_CLOUD
            ]
        );
        let Message::TFMessage(fixed) = &out[0].1 else {
            panic!()
        };
        assert_eq!(
            (
                fixed.transforms[0].header.frame_id.as_str(),
                fixed.transforms[0].child_frame_id.as_str()
            ),
            ("base_link", "radar")
        );
        assert!((fixed.transforms[0].transform.rotation.yaw() - 1.5).abs() < 1e-12);
    }

    #[test]
    fn inputs_follow_the_params_and_bad_segments_are_invalid_input() {
        let node = VizNode::new(Params {
            ground_truth: false,
            odometry: false,
            detections: false,
            ..Params::default()
        })
        .unwrap();
        assert_eq!(node.inputs(), [SLAM_POSE, SEGMENTS]);
        assert_eq!(node.outputs(), [TF, SLAM_PATH, CLUSTER_MARKERS]);
        let all = VizNode::new(Params::default()).unwrap();
        assert_eq!(
            all.inputs(),
            [
                GROUND_TRUTH_TARGETS,
                ODOM,
                GROUND_TRUTH_POSE,
                SLAM_POSE,
                DETECTIONS,
                SEGMENTS
            ]
        );
        let mut node = node;
        let bad = Segments {
            points: vec![nrslam_msgs::Point::planar(0.0, 0.0)],
            labels: vec![-2],
            ..Segments::default()
        };
        let err = node
            .on_message(SEGMENTS, &bad.into(), &mut Outbox::new())
            .unwrap_err();
        assert!(matches!(err, NodeError::InvalidInput { .. }), "{err}");
        let err = node
            .on_message(
                SLAM_POSE,
                &Message::Clock(Default::default()),
                &mut Outbox::new(),
            )
            .unwrap_err();
        assert!(err.to_string().contains("rosgraph_msgs/msg/Clock"), "{err}");
    }
}
