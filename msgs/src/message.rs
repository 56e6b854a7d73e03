//! The one enum the runtime moves between nodes, with its encoding by ROS 2 type name.

use crate::cdr::{self, CdrError};
use crate::nrslam::*;
use crate::ros::*;

/// Why a message could not be decoded for a type name.
#[derive(Debug, thiserror::Error)]
pub enum MessageError {
    /// No variant of [`Message`] has this ROS 2 type name.
    #[error("unknown message type {0:?}")]
    UnknownType(String),
    /// The bytes are not valid CDR for the type.
    #[error("{type_name}: {source}")]
    Cdr {
        /// The ROS 2 type name decoded.
        type_name: String,
        /// What went wrong.
        source: CdrError,
    },
}

macro_rules! messages {
    ($($variant:ident => $type_name:literal, $stamp:expr;)*) => {
        /// A message of any type the graph carries.
        // Odometry carries two 6×6 covariances (≈740 bytes); boxing it would cost an allocation
        // per message on the hot path for no measured gain.
        #[allow(clippy::large_enum_variant)]
        #[derive(Debug, Clone, PartialEq)]
        pub enum Message {
            $(
                #[doc = concat!("`", $type_name, "`")]
                $variant($variant),
            )*
        }

        impl Message {
            /// The ROS 2 type name, e.g. `nav_msgs/msg/OccupancyGrid`.
            pub fn type_name(&self) -> &'static str {
                match self { $(Message::$variant(_) => $type_name,)* }
            }

            /// Every ROS 2 type name a [`Message`] can carry.
            pub const TYPE_NAMES: &'static [&'static str] = &[$($type_name,)*];

            /// The time of validity of the message (header stamp, or the clock value).
            pub fn stamp(&self) -> Time {
                match self { $(Message::$variant(m) => ($stamp)(m),)* }
            }

            /// Little-endian CDR with the encapsulation header.
            pub fn encode(&self) -> Result<Vec<u8>, CdrError> {
                match self { $(Message::$variant(m) => cdr::encode(m),)* }
            }

            /// Decodes CDR bytes of the ROS 2 type `type_name`.
            pub fn decode(type_name: &str, bytes: &[u8]) -> Result<Message, MessageError> {
                match type_name {
                    $($type_name => cdr::decode::<$variant>(bytes)
                        .map(Message::$variant)
                        .map_err(|source| MessageError::Cdr { type_name: type_name.to_owned(), source }),)*
                    other => Err(MessageError::UnknownType(other.to_owned())),
                }
            }
        }

        $(
            impl From<$variant> for Message {
                fn from(m: $variant) -> Self { Message::$variant(m) }
            }
        )*
    };
}

messages! {
    Clock => "rosgraph_msgs/msg/Clock", |m: &Clock| m.clock;
    Odometry => "nav_msgs/msg/Odometry", |m: &Odometry| m.header.stamp;
    PoseStamped => "geometry_msgs/msg/PoseStamped", |m: &PoseStamped| m.header.stamp;
    OccupancyGrid => "nav_msgs/msg/OccupancyGrid", |m: &OccupancyGrid| m.header.stamp;
    Detections => "nrslam_msgs/msg/Detections", |m: &Detections| m.header.stamp;
    Keyframe => "nrslam_msgs/msg/Keyframe", |m: &Keyframe| m.header.stamp;
    Segments => "nrslam_msgs/msg/Segments", |m: &Segments| m.header.stamp;
    TargetSet => "nrslam_msgs/msg/TargetSet", |m: &TargetSet| m.header.stamp;
    Metrics => "nrslam_msgs/msg/Metrics", |m: &Metrics| m.header.stamp;
    RadarEcho => "nrslam_msgs/msg/RadarEcho", |m: &RadarEcho| m.header.stamp;
    RadarSpectrum => "nrslam_msgs/msg/RadarSpectrum", |m: &RadarSpectrum| m.header.stamp;
    KeyframePoses => "nrslam_msgs/msg/KeyframePoses", |m: &KeyframePoses| m.header.stamp;
    AssociationStats => "nrslam_msgs/msg/AssociationStats", |m: &AssociationStats| m.header.stamp;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_has_a_schema() {
        for name in Message::TYPE_NAMES {
            assert!(crate::schema::ros2msg(name).is_some(), "{name}");
        }
    }

    #[test]
    fn decoding_with_the_wrong_type_name_is_an_error_not_a_panic() {
        let bytes = Message::Clock(Clock {
            clock: Time::from_seconds(2.0),
        })
        .encode()
        .unwrap();
        assert!(Message::decode("nav_msgs/msg/OccupancyGrid", &bytes).is_err());
        assert!(matches!(
            Message::decode("foo/msg/Bar", &bytes),
            Err(MessageError::UnknownType(_))
        ));
    }
}
