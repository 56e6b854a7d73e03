//! The adapter as a graph node: a sensor topic (and optionally a pose topic) in, `/radar/detections`
//! (and `/odom`) out.
//!
//! Inputs are declared pose first, so that for a frame whose pose and scan share a stamp the
//! association gets the odometry before the detections, as from the simulated radar.
//!
//! The pose comes as a `PoseStamped` topic or from `/tf`: a ROS 2 robot's localisation publishes
//! `odom → base_link` there (REP 105), and each transform to `tf_child_frame` is one pose.

use nrslam_msgs::topics::{DETECTIONS, ODOM};
use nrslam_msgs::{
    Header, Message, Odometry, Point, Pose, PoseStamped, PoseWithCovariance, TransformStamped,
};
use nrslam_runtime::{Node, NodeContext, NodeError, NodeResult, Outbox};

use crate::convert::{Converter, Counts};
use crate::params::{Input, Params};

/// Frame of the republished odometry and its child frame (REP-105).
pub const ODOM_FRAME: &str = "odom";
/// The vehicle's frame.
pub const BASE_FRAME: &str = "base_link";

/// The sensor adapter bound to the node API.
#[derive(Debug)]
pub struct SensorAdapterNode {
    input: Input,
    topic: &'static str,
    pose_topic: Option<&'static str>,
    tf_child_frame: String,
    converter: Converter,
    totals: Counts,
}

/// Builds the adapter from `params` (validated here). It draws no random numbers and reads no
/// files, so `ctx` is not used.
pub fn build(params: Params, _ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    Ok(Box::new(SensorAdapterNode::new(&params)?))
}

impl SensorAdapterNode {
    /// A node with `params`, which must pass [`Params::validate`].
    pub fn new(params: &Params) -> Result<Self, NodeError> {
        params.validate()?;
        Ok(Self {
            input: params.input,
            topic: params.input_topic()?,
            pose_topic: params.pose_input()?,
            tf_child_frame: params.tf_child_frame.clone(),
            converter: Converter::new(params),
            totals: Counts::default(),
        })
    }

    /// Returns seen and dropped so far.
    pub fn totals(&self) -> Counts {
        self.totals
    }

    fn add(&mut self, counts: Counts) {
        self.totals.returns += counts.returns;
        self.totals.non_finite += counts.non_finite;
        self.totals.out_of_range += counts.out_of_range;
    }
}

/// The odometry a pose stands for: the pose itself in frame "odom" (which equals "map" at the
/// start), unknown covariances zero, no twist.
pub fn odometry_of(pose: &PoseStamped) -> Odometry {
    Odometry {
        header: Header::new(pose.header.stamp, ODOM_FRAME),
        child_frame_id: BASE_FRAME.to_owned(),
        pose: PoseWithCovariance {
            pose: pose.pose,
            covariance: [0.0; 36],
        },
        ..Odometry::default()
    }
}

/// The pose a transform stands for: the child frame's origin and orientation in the parent's,
/// stamped as the transform.
pub fn pose_of(transform: &TransformStamped) -> PoseStamped {
    let t = &transform.transform;
    PoseStamped {
        header: transform.header.clone(),
        pose: Pose {
            position: Point {
                x: t.translation.x,
                y: t.translation.y,
                z: t.translation.z,
            },
            orientation: t.rotation,
        },
    }
}

impl Node for SensorAdapterNode {
    fn inputs(&self) -> Vec<&'static str> {
        self.pose_topic.into_iter().chain([self.topic]).collect()
    }

    fn outputs(&self) -> Vec<&'static str> {
        self.pose_topic
            .map(|_| ODOM)
            .into_iter()
            .chain([DETECTIONS])
            .collect()
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        let (detections, counts) = match (message, self.input) {
            (Message::PoseStamped(pose), _) if Some(topic) == self.pose_topic => {
                outbox.publish(ODOM, odometry_of(pose));
                return Ok(());
            }
            (Message::TFMessage(tf), _) if Some(topic) == self.pose_topic => {
                // Other transforms on /tf (map → odom, the sensor's mount) are not the pose.
                for transform in &tf.transforms {
                    if transform.child_frame_id == self.tf_child_frame {
                        outbox.publish(ODOM, odometry_of(&pose_of(transform)));
                    }
                }
                return Ok(());
            }
            (Message::RadarScan(scan), Input::RadarScan) if topic == self.topic => {
                self.converter.radar_scan(scan)
            }
            (Message::PointCloud2(cloud), Input::PointCloud2) if topic == self.topic => self
                .converter
                .point_cloud(cloud)
                .map_err(|e| NodeError::invalid_input(topic, e.to_string()))?,
            (other, input) => {
                return Err(NodeError::invalid_input(
                    topic,
                    format!(
                        "the sensor adapter takes {} on {}, got {}",
                        input.type_name(),
                        self.topic,
                        other.type_name()
                    ),
                ))
            }
        };
        if counts.non_finite + counts.out_of_range > 0 {
            tracing::debug!(
                stamp_s = detections.header.stamp.as_seconds(),
                returns = counts.returns,
                non_finite = counts.non_finite,
                out_of_range = counts.out_of_range,
                "returns dropped"
            );
        }
        self.add(counts);
        outbox.publish(DETECTIONS, detections);
        Ok(())
    }

    fn on_end(&mut self, _outbox: &mut Outbox) -> Result<(), NodeError> {
        let t = self.totals;
        tracing::info!(
            returns = t.returns,
            non_finite = t.non_finite,
            out_of_range = t.out_of_range,
            "sensor adapter done"
        );
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::topics::{GROUND_TRUTH_POSE, RADAR_POINTS, RADAR_SCAN};
    use nrslam_msgs::{PointCloud2, Pose, RadarReturn, RadarScan, Time};

    fn params(input: Input, pose_topic: &str) -> Params {
        Params {
            input,
            pose_topic: pose_topic.into(),
            ..Params::default()
        }
    }

    #[test]
    fn declares_pose_first_and_publishes_odometry_then_detections() {
        let mut node =
            SensorAdapterNode::new(&params(Input::RadarScan, GROUND_TRUTH_POSE)).unwrap();
        assert_eq!(node.inputs(), vec![GROUND_TRUTH_POSE, RADAR_SCAN]);
        assert_eq!(node.outputs(), vec![ODOM, DETECTIONS]);
        let stamp = Time::from_seconds(100.0);
        let pose = PoseStamped {
            header: Header::new(stamp, "map"),
            pose: Pose::from_planar(1.0, 2.0, 0.5),
        };
        let scan = RadarScan {
            header: Header::new(stamp, "radar"),
            returns: vec![RadarReturn {
                range: 4.0,
                ..RadarReturn::default()
            }],
        };
        let mut outbox = Outbox::new();
        node.on_message(GROUND_TRUTH_POSE, &pose.clone().into(), &mut outbox)
            .unwrap();
        node.on_message(RADAR_SCAN, &scan.into(), &mut outbox)
            .unwrap();
        let out: Vec<_> = outbox.drain().collect();
        assert_eq!(out.len(), 2);
        let (ODOM, Message::Odometry(odom)) = &out[0] else {
            panic!("{:?}", out[0])
        };
        assert_eq!(
            (odom.header.frame_id.as_str(), odom.child_frame_id.as_str()),
            ("odom", "base_link")
        );
        assert_eq!((odom.header.stamp, odom.pose.pose), (stamp, pose.pose));
        let (DETECTIONS, Message::Detections(d)) = &out[1] else {
            panic!("{:?}", out[1])
        };
        assert_eq!(d.detections.len(), 1);
        assert_eq!(node.totals().returns, 1);
    }

    #[test]
    fn without_a_pose_topic_only_detections() {
        let node = SensorAdapterNode::new(&params(Input::PointCloud2, "")).unwrap();
        assert_eq!(node.inputs(), vec![RADAR_POINTS]);
        assert_eq!(node.outputs(), vec![DETECTIONS]);
    }

    #[test]
    fn a_wrong_type_or_an_unreadable_cloud_is_invalid_input() {
        let mut node = SensorAdapterNode::new(&params(Input::PointCloud2, "")).unwrap();
        let mut outbox = Outbox::new();
        let err = node
            .on_message(RADAR_POINTS, &RadarScan::default().into(), &mut outbox)
            .unwrap_err();
        assert!(
            err.to_string().contains("sensor_msgs/msg/PointCloud2"),
            "{err}"
        );
        let cloud = PointCloud2 {
            width: 1,
            height: 1,
            ..PointCloud2::default()
        };
        let err = node
            .on_message(RADAR_POINTS, &cloud.into(), &mut outbox)
            .unwrap_err();
        assert!(
            matches!(err, NodeError::InvalidInput { .. }) && err.to_string().contains("\"x\""),
            "{err}"
        );
        assert!(outbox.is_empty());
    }

    #[test]
    fn build_refuses_invalid_params() {
        let ctx = NodeContext::for_tests(1);
        let bad = Params {
            yaw_rad: 7.0,
            ..Params::default()
        };
        let err = build(bad, &ctx).err().expect("refused");
        assert!(err.to_string().contains("yaw_rad"), "{err}");
    }

    #[test]
    fn tf_transforms_to_the_vehicle_frame_are_its_poses_and_others_are_not() {
        use nrslam_msgs::topics::TF;
        use nrslam_msgs::{TFMessage, Transform};
        let mut node = SensorAdapterNode::new(&params(Input::PointCloud2, TF)).unwrap();
        assert_eq!(node.inputs(), vec![TF, RADAR_POINTS]);
        assert_eq!(node.outputs(), vec![ODOM, DETECTIONS]);
        let stamp = Time::from_seconds(3.0);
        let transform = |parent: &str, child: &str, x_m: f64, yaw_rad: f64| TransformStamped {
            header: Header::new(stamp, parent),
            child_frame_id: child.into(),
            transform: Transform::from_planar(x_m, -1.0, yaw_rad),
        };
        let tf = TFMessage {
            transforms: vec![
                transform("map", "odom", 5.0, 0.1),
                transform("odom", "base_link", 2.0, 0.3),
                transform("base_link", "radar", 0.4, 0.0),
            ],
        };
        let mut outbox = Outbox::new();
        node.on_message(TF, &tf.into(), &mut outbox).unwrap();
        let out: Vec<_> = outbox.drain().collect();
        assert_eq!(out.len(), 1, "only odom -> base_link is the pose: {out:?}");
        let (ODOM, Message::Odometry(odom)) = &out[0] else {
            panic!("{:?}", out[0])
        };
        let (x, y, yaw) = odom.pose.pose.planar();
        assert_eq!((x, y), (2.0, -1.0));
        assert!((yaw - 0.3).abs() < 1e-12, "{yaw}");
        assert_eq!(odom.header.stamp, stamp);

        let mut other = params(Input::PointCloud2, TF);
        other.tf_child_frame = "radar".into();
        let mut node = SensorAdapterNode::new(&other).unwrap();
        node.on_message(
            TF,
            &Message::TFMessage(TFMessage {
                transforms: vec![transform("base_link", "radar", 0.4, 0.0)],
            }),
            &mut outbox,
        )
        .unwrap();
        assert_eq!(outbox.drain().count(), 1);
        other.tf_child_frame = String::new();
        assert!(SensorAdapterNode::new(&other).is_err());
    }
}
