//! The sensor adapter: lets a real sensor replace nrslam's simulated front end.
//!
//! A ROS 2 radar driver publishes `radar_msgs/msg/RadarScan` (range, azimuth, elevation,
//! amplitude per return) or `sensor_msgs/msg/PointCloud2` (points with `x`, `y`, `z` fields); the
//! back end (association, mapper) takes `nrslam_msgs/msg/Detections` on `/radar/detections`. This
//! crate converts one into the other:
//!
//! - [`Params`]: which input (`input = "radar_scan" | "point_cloud2"`) on which topic, the
//!   sensor's mounting pose on the vehicle (`x_m`, `y_m`, `yaw_rad`), the noise to attach, and an
//!   optional `pose_topic` (a `PoseStamped` of the vehicle, republished as `/odom`, for bags that
//!   carry poses rather than wheel odometry);
//! - [`cloud`]: bounded reading of PointCloud2 fields (any layout, datatype and byte order);
//! - [`convert`]: returns → detections about the vehicle's centre (pure functions);
//! - [`node`]: the graph node (`kind = "sensor_adapter"` in launch files);
//! - [`remap`]: renaming a source's outputs (a bag's `/slam/pose` as `/ground_truth/pose`).
//!
//! `launch/standard-input.toml` runs the back end on a bag of such messages.
//!
//! ```
//! use nrslam_msgs::{Header, RadarReturn, RadarScan, Time};
//! use nrslam_sensor_adapter::{Converter, Params};
//! // A radar looking left (+y of the vehicle), one return 8 m straight ahead of it.
//! let params = Params { yaw_rad: std::f64::consts::FRAC_PI_2, ..Params::default() };
//! params.validate().unwrap();
//! let scan = RadarScan {
//!     header: Header::new(Time::from_seconds(100.0), "radar"),
//!     returns: vec![RadarReturn { range: 8.0, amplitude: 20.0, ..RadarReturn::default() }],
//! };
//! let (detections, _) = Converter::new(&params).radar_scan(&scan);
//! assert_eq!(detections.boresight_rad, std::f64::consts::FRAC_PI_2);
//! assert!((detections.detections[0].range_m - 8.0).abs() < 1e-9);
//! ```
#![warn(missing_docs)]

pub mod cloud;
pub mod convert;
pub mod node;
mod params;
pub mod remap;

pub use cloud::{CloudError, CloudReader};
pub use convert::{Converter, Counts};
pub use node::{build, odometry_of, SensorAdapterNode};
pub use params::{Input, Params};
pub use remap::RemapOutputs;
