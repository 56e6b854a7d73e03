//! ROS 2 messages as serde structs, field for field in the order of their `.msg` definitions
//! (ROS 2 Jazzy's `std_msgs`, `geometry_msgs`, `nav_msgs`, `sensor_msgs`, `tf2_msgs`, and
//! nrslam's `msgs/msg/*.msg`). ros2-client's zenoh backend (de)serialises them as CDR with
//! `cdr-encoding`; the bag reader below uses the same crate.

use serde::de::{SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// builtin_interfaces/msg/Time
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize,
)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

impl Time {
    pub fn as_seconds(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

/// std_msgs/msg/Header
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

/// geometry_msgs/msg/Point
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// geometry_msgs/msg/Vector3
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

/// geometry_msgs/msg/Quaternion
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Quaternion {
    /// The rotation about z (rad) of a planar quaternion.
    pub fn yaw(&self) -> f64 {
        (2.0 * (self.w * self.z + self.x * self.y))
            .atan2(1.0 - 2.0 * (self.y * self.y + self.z * self.z))
    }

    pub fn norm(&self) -> f64 {
        (self.x * self.x + self.y * self.y + self.z * self.z + self.w * self.w).sqrt()
    }
}

/// geometry_msgs/msg/Pose
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}

impl Pose {
    pub fn is_finite(&self) -> bool {
        let (p, q) = (self.position, self.orientation);
        [p.x, p.y, p.z, q.x, q.y, q.z, q.w]
            .iter()
            .all(|v| v.is_finite())
    }
}

/// geometry_msgs/msg/PoseStamped
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    pub header: Header,
    pub pose: Pose,
}

/// A `float64[36]` covariance: serde derives arrays only up to 32 elements, and CDR writes a
/// fixed-size array as its elements with no length, which is what a tuple serialises to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Self([0.0; 36])
    }
}

impl Serialize for Covariance {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut tuple = serializer.serialize_tuple(36)?;
        for v in &self.0 {
            tuple.serialize_element(v)?;
        }
        tuple.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct Cov;
        impl<'de> Visitor<'de> for Cov {
            type Value = Covariance;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("36 float64")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Covariance, A::Error> {
                let mut out = [0.0; 36];
                for (i, v) in out.iter_mut().enumerate() {
                    *v = seq
                        .next_element()?
                        .ok_or_else(|| serde::de::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(out))
            }
        }
        deserializer.deserialize_tuple(36, Cov)
    }
}

/// geometry_msgs/msg/PoseWithCovariance
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    pub pose: Pose,
    pub covariance: Covariance,
}

/// geometry_msgs/msg/Twist
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    pub linear: Vector3,
    pub angular: Vector3,
}

/// geometry_msgs/msg/TwistWithCovariance
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    pub twist: Twist,
    pub covariance: Covariance,
}

/// nav_msgs/msg/Odometry
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Odometry {
    pub header: Header,
    pub child_frame_id: String,
    pub pose: PoseWithCovariance,
    pub twist: TwistWithCovariance,
}

/// nav_msgs/msg/MapMetaData
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MapMetaData {
    pub map_load_time: Time,
    pub resolution: f32,
    pub width: u32,
    pub height: u32,
    pub origin: Pose,
}

/// nav_msgs/msg/OccupancyGrid
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct OccupancyGrid {
    pub header: Header,
    pub info: MapMetaData,
    pub data: Vec<i8>,
}

/// geometry_msgs/msg/Transform
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    pub translation: Vector3,
    pub rotation: Quaternion,
}

/// geometry_msgs/msg/TransformStamped
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    pub header: Header,
    pub child_frame_id: String,
    pub transform: Transform,
}

/// tf2_msgs/msg/TFMessage
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TFMessage {
    pub transforms: Vec<TransformStamped>,
}

/// sensor_msgs/msg/PointField
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PointField {
    pub name: String,
    pub offset: u32,
    pub datatype: u8,
    pub count: u32,
}

/// sensor_msgs/msg/PointField's FLOAT32.
pub const FLOAT32: u8 = 7;

/// sensor_msgs/msg/PointCloud2
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PointCloud2 {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub fields: Vec<PointField>,
    pub is_bigendian: bool,
    pub point_step: u32,
    pub row_step: u32,
    pub data: Vec<u8>,
    pub is_dense: bool,
}

/// nrslam_msgs/msg/Detection (msgs/msg/Detection.msg)
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Detection {
    pub range_m: f64,
    pub angle_rad: f64,
    pub range_std_m: f64,
    pub angle_std_rad: f64,
    pub power_db: f64,
}

/// nrslam_msgs/msg/Detections (msgs/msg/Detections.msg)
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Detections {
    pub header: Header,
    pub boresight_rad: f64,
    pub detections: Vec<Detection>,
}

/// nrslam_msgs/msg/Target (msgs/msg/Target.msg)
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Target {
    pub id: u32,
    pub shape: String,
    pub outline: Vec<Point>,
    pub samples: Vec<Point>,
}

/// nrslam_msgs/msg/TargetSet (msgs/msg/TargetSet.msg)
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TargetSet {
    pub header: Header,
    pub targets: Vec<Target>,
}

/// Decodes a CDR payload with its 4-byte encapsulation header (little-endian only: what
/// nrslam and rmw_zenoh write).
pub fn from_cdr<T: serde::de::DeserializeOwned>(bytes: &[u8]) -> Result<T, String> {
    match bytes {
        [0x00, 0x01, _, _, body @ ..] => {
            cdr_encoding::from_bytes::<T, byteorder::LittleEndian>(body)
                .map(|(value, _)| value)
                .map_err(|e| e.to_string())
        }
        _ => Err(format!(
            "not a little-endian CDR payload (header {:02x?})",
            &bytes[..bytes.len().min(4)]
        )),
    }
}
