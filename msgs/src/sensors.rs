//! Standard ROS 2 sensor messages a real radar driver publishes, field for field as in ROS 2 Jazzy:
//! `sensor_msgs/msg/PointCloud2` (with `PointField`) and `radar_msgs/msg/RadarScan` (with
//! `RadarReturn`, package `ros-perception/radar_msgs`). The graph takes them in through the
//! `sensor_adapter` node, which turns them into [`crate::Detections`].
//!
//! Field order is the wire order (see [`crate::ros`]).

use crate::ros::Header;
use serde::{Deserialize, Serialize};

/// `sensor_msgs/msg/PointField`: where one named field of a point lies in a point's bytes.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct PointField {
    /// Field name, e.g. `x`, `y`, `z`, `intensity`.
    pub name: String,
    /// Byte offset from the start of the point.
    pub offset: u32,
    /// [`PointField::INT8`] … [`PointField::FLOAT64`].
    pub datatype: u8,
    /// Elements in the field (1 for a scalar).
    pub count: u32,
}

impl PointField {
    /// `datatype`: signed 8-bit integer.
    pub const INT8: u8 = 1;
    /// `datatype`: unsigned 8-bit integer.
    pub const UINT8: u8 = 2;
    /// `datatype`: signed 16-bit integer.
    pub const INT16: u8 = 3;
    /// `datatype`: unsigned 16-bit integer.
    pub const UINT16: u8 = 4;
    /// `datatype`: signed 32-bit integer.
    pub const INT32: u8 = 5;
    /// `datatype`: unsigned 32-bit integer.
    pub const UINT32: u8 = 6;
    /// `datatype`: IEEE 754 single.
    pub const FLOAT32: u8 = 7;
    /// `datatype`: IEEE 754 double.
    pub const FLOAT64: u8 = 8;

    /// Bytes of one element of `datatype`, `None` for a value outside 1..=8.
    pub fn datatype_size(datatype: u8) -> Option<u32> {
        match datatype {
            Self::INT8 | Self::UINT8 => Some(1),
            Self::INT16 | Self::UINT16 => Some(2),
            Self::INT32 | Self::UINT32 | Self::FLOAT32 => Some(4),
            Self::FLOAT64 => Some(8),
            _ => None,
        }
    }

    /// A scalar field.
    pub fn scalar(name: &str, offset: u32, datatype: u8) -> Self {
        Self {
            name: name.to_owned(),
            offset,
            datatype,
            count: 1,
        }
    }
}

/// `sensor_msgs/msg/PointCloud2`: points as rows of `point_step` bytes each.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PointCloud2 {
    /// Stamp and the frame the points are in.
    pub header: Header,
    /// Rows (1 for an unordered cloud).
    pub height: u32,
    /// Points per row.
    pub width: u32,
    /// Layout of a point.
    pub fields: Vec<PointField>,
    /// Multi-byte values are big-endian.
    pub is_bigendian: bool,
    /// Bytes of one point.
    pub point_step: u32,
    /// Bytes of one row.
    pub row_step: u32,
    /// `row_step × height` bytes.
    pub data: Vec<u8>,
    /// No invalid (NaN) points.
    pub is_dense: bool,
}

/// `radar_msgs/msg/RadarReturn`: one return in the radar's frame (REP-103: x forward, azimuth
/// counter-clockwise positive).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct RadarReturn {
    /// Distance from the sensor (m).
    pub range: f32,
    /// Azimuth from the sensor's x axis, counter-clockwise positive (rad).
    pub azimuth: f32,
    /// Elevation above the sensor's xy plane (rad).
    pub elevation: f32,
    /// Radial velocity, positive away from the sensor (m/s).
    pub doppler_velocity: f32,
    /// Return strength (dB).
    pub amplitude: f32,
}

/// `radar_msgs/msg/RadarScan`: the returns of one radar frame.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct RadarScan {
    /// Stamp and the radar's frame.
    pub header: Header,
    /// The returns.
    pub returns: Vec<RadarReturn>,
}
