//! Message types of the nrslam graph, their ROS 2 CDR encoding, `ros2msg` schemas and the topic
//! catalogue.
//!
//! Every topic of the graph (docs/design.md, "The graph") carries one of the types here. Where a
//! standard ROS 2 type fits it is used with its exact field layout ([`ros`]), so the bytes on the
//! wire are the bytes a ROS 2 node would send ([`sensors`]: what radar drivers publish; [`visual`]:
//! what RViz and Foxglove draw); project types ([`nrslam`]) have `.msg` definitions
//! under `msgs/msg/` (package `nrslam_msgs`). [`Message`] is the one enum the runtime moves around;
//! [`cdr`] encodes and decodes it; [`topics`] says which topic carries which type with which QoS;
//! [`schema`] gives each type's `ros2msg` text with its dependencies appended, as rosbag2 records it.
//! A received message goes through [`Message::decode`] (the wire format, bounded: see [`cdr`])
//! then [`Message::check_usable`] (the values: finite, sizes consistent), whose [`Unusable`]
//! reason is a counter key.
//!
//! ```
//! use nrslam_msgs::{Message, PoseStamped, Header, Pose, Time};
//! let pose = PoseStamped {
//!     header: Header { stamp: Time::from_seconds(1.5), frame_id: "map".into() },
//!     pose: Pose::from_planar(1.0, 2.0, 0.5),
//! };
//! let bytes = nrslam_msgs::cdr::encode(&pose).unwrap();
//! let back: PoseStamped = nrslam_msgs::cdr::decode(&bytes).unwrap();
//! assert_eq!(pose, back);
//! let message = Message::PoseStamped(pose);
//! assert_eq!(message.stamp(), Time::from_seconds(1.5));
//! ```
#![warn(missing_docs)]

pub mod cdr;
mod message;
pub mod nrslam;
pub mod ros;
pub mod schema;
pub mod sensors;
pub mod topics;
pub mod usable;
pub mod visual;

pub use message::{Message, MessageError};
pub use nrslam::*;
pub use ros::*;
pub use sensors::*;
pub use usable::Unusable;
pub use visual::*;
