//! Standard ROS 2 message types used by the graph, field for field as in ROS 2 Humble
//! (`builtin_interfaces`, `std_msgs`, `geometry_msgs`, `nav_msgs`, `rosgraph_msgs`).
//!
//! Field order is the wire order: CDR has no field names, so reordering a field here breaks
//! compatibility with every ROS 2 tool.

use serde::{Deserialize, Serialize};
use serde_big_array::BigArray;

/// `builtin_interfaces/msg/Time`: simulated time since the scenario epoch.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default, Serialize, Deserialize,
)]
pub struct Time {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds within the second, 0..1e9.
    pub nanosec: u32,
}

impl Time {
    /// Time from seconds, rounded to the nearest nanosecond. Negative or non-finite input gives 0.
    pub fn from_seconds(seconds: f64) -> Self {
        if !seconds.is_finite() || seconds <= 0.0 {
            return Self::default();
        }
        Self::from_nanos((seconds * 1e9).round() as u64)
    }

    /// Time from nanoseconds.
    pub fn from_nanos(nanos: u64) -> Self {
        Self {
            sec: (nanos / 1_000_000_000).min(i32::MAX as u64) as i32,
            nanosec: (nanos % 1_000_000_000) as u32,
        }
    }

    /// Nanoseconds since the epoch (negative seconds clamp to 0).
    pub fn as_nanos(self) -> u64 {
        (self.sec.max(0) as u64) * 1_000_000_000 + self.nanosec as u64
    }

    /// Seconds since the epoch.
    pub fn as_seconds(self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }
}

/// `std_msgs/msg/Header`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Header {
    /// Time of validity of the data (simulated clock).
    pub stamp: Time,
    /// Coordinate frame: "map", "odom", "base_link" or "radar".
    pub frame_id: String,
}

impl Header {
    /// A header at `stamp` in `frame_id`.
    pub fn new(stamp: Time, frame_id: &str) -> Self {
        Self {
            stamp,
            frame_id: frame_id.to_owned(),
        }
    }
}

/// `geometry_msgs/msg/Point`, metres.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m); 0 in this planar system.
    pub z: f64,
}

impl Point {
    /// A point in the plane z = 0.
    pub fn planar(x_m: f64, y_m: f64) -> Self {
        Self {
            x: x_m,
            y: y_m,
            z: 0.0,
        }
    }
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x component.
    pub x: f64,
    /// y component.
    pub y: f64,
    /// z component.
    pub z: f64,
}

/// `geometry_msgs/msg/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

impl Quaternion {
    /// Rotation about z by `yaw_rad`.
    pub fn from_yaw(yaw_rad: f64) -> Self {
        let half = 0.5 * yaw_rad;
        Self {
            x: 0.0,
            y: 0.0,
            z: half.sin(),
            w: half.cos(),
        }
    }

    /// Yaw (rad, in (−π, π]) of this rotation, assuming it is about z.
    pub fn yaw(&self) -> f64 {
        (2.0 * (self.w * self.z + self.x * self.y))
            .atan2(1.0 - 2.0 * (self.y * self.y + self.z * self.z))
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position (m).
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

impl Pose {
    /// A planar pose: position (m) and yaw (rad, counter-clockwise from +x).
    pub fn from_planar(x_m: f64, y_m: f64, yaw_rad: f64) -> Self {
        Self {
            position: Point::planar(x_m, y_m),
            orientation: Quaternion::from_yaw(yaw_rad),
        }
    }

    /// `(x_m, y_m, yaw_rad)`.
    pub fn planar(&self) -> (f64, f64, f64) {
        (self.position.x, self.position.y, self.orientation.yaw())
    }
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and frame.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

/// `geometry_msgs/msg/PoseWithCovariance`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// The pose.
    pub pose: Pose,
    /// Row-major 6×6 covariance of (x, y, z, roll, pitch, yaw), m² and rad².
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

impl Default for PoseWithCovariance {
    fn default() -> Self {
        Self {
            pose: Pose::default(),
            covariance: [0.0; 36],
        }
    }
}

/// `geometry_msgs/msg/Twist`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Twist {
    /// Linear velocity (m/s).
    pub linear: Vector3,
    /// Angular velocity (rad/s).
    pub angular: Vector3,
}

/// `geometry_msgs/msg/TwistWithCovariance`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    /// The twist.
    pub twist: Twist,
    /// Row-major 6×6 covariance.
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

impl Default for TwistWithCovariance {
    fn default() -> Self {
        Self {
            twist: Twist::default(),
            covariance: [0.0; 36],
        }
    }
}

/// `nav_msgs/msg/Odometry`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Odometry {
    /// Stamp and the frame of `pose` ("odom").
    pub header: Header,
    /// Frame of `twist` ("base_link").
    pub child_frame_id: String,
    /// Dead-reckoned pose.
    pub pose: PoseWithCovariance,
    /// Velocity in the child frame.
    pub twist: TwistWithCovariance,
}

/// `nav_msgs/msg/MapMetaData`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MapMetaData {
    /// When the map was loaded (simulated clock).
    pub map_load_time: Time,
    /// Cell edge (m).
    pub resolution: f32,
    /// Cells along x.
    pub width: u32,
    /// Cells along y.
    pub height: u32,
    /// Pose of cell (0, 0)'s corner in the map frame.
    pub origin: Pose,
}

/// `nav_msgs/msg/OccupancyGrid`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct OccupancyGrid {
    /// Stamp and frame ("map").
    pub header: Header,
    /// Geometry of the grid.
    pub info: MapMetaData,
    /// Row-major cells from the origin, x fastest: occupancy in percent 0..=100, −1 unknown.
    pub data: Vec<i8>,
}

/// `rosgraph_msgs/msg/Clock`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Clock {
    /// The simulated time.
    pub clock: Time,
}

/// `diagnostic_msgs/msg/KeyValue`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct KeyValue {
    /// Label.
    pub key: String,
    /// Value, as text.
    pub value: String,
}

/// `diagnostic_msgs/msg/DiagnosticStatus`: the state of one component.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// [`DiagnosticStatus::OK`], [`DiagnosticStatus::WARN`], [`DiagnosticStatus::ERROR`] or
    /// [`DiagnosticStatus::STALE`].
    pub level: u8,
    /// Component, e.g. `nrslam/association/receive`.
    pub name: String,
    /// Summary, one line.
    pub message: String,
    /// Hardware the component runs on (empty: none in particular).
    pub hardware_id: String,
    /// Figures.
    pub values: Vec<KeyValue>,
}

impl DiagnosticStatus {
    /// Level: all is well.
    pub const OK: u8 = 0;
    /// Level: something needs attention.
    pub const WARN: u8 = 1;
    /// Level: something failed.
    pub const ERROR: u8 = 2;
    /// Level: no recent information.
    pub const STALE: u8 = 3;
}

/// `diagnostic_msgs/msg/DiagnosticArray`: the `/diagnostics` convention of ROS.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Stamp of the report.
    pub header: Header,
    /// One status per component.
    pub status: Vec<DiagnosticStatus>,
}
