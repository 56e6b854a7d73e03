//! Occupancy grid mapping from keyframes.
//!
//! The paper's SLAM (Sec. III-A, Fig. 2) builds an occupancy grid map (OGM, Sec. I) from the range
//! and angle estimates of selected keyframes (Sec. III-A, "Data association") placed at the AGV's
//! estimated pose ("Location & mapping"). This crate is that mapping module:
//!
//! - [`OccupancyMap`]: a log-odds grid with OctoMap's sensor model and clamping, updated once per
//!   keyframe with hits at the detections and, optionally, free space along each beam;
//! - [`Params`]: resolution, extent and sensor model, each with units and range;
//! - [`node`]: the adapter that turns each `/slam/keyframe` into a full `/map` ([`build`],
//!   [`MapperNode`]).
//!
//! ```
//! use nrslam_mapper::{OccupancyMap, Params, Pose2};
//! use nrslam_msgs::Detection;
//! let mut map = OccupancyMap::new(&Params::default()).unwrap();
//! // AGV at (10, 10) facing +x, array along the heading; one echo 3 m ahead.
//! let echo = Detection { range_m: 3.0, angle_rad: 0.0, ..Detection::default() };
//! let pose = Pose2 { x_m: 10.0, y_m: 10.0, yaw_rad: 0.0 };
//! map.integrate_detections(pose, 0.0, &[echo]).unwrap();
//! let (column, row) = map.cell_of(13.0, 10.0).unwrap();
//! assert!(map.probability(column, row).unwrap() > 0.5);
//! let (column, row) = map.cell_of(11.5, 10.0).unwrap();
//! assert!(map.probability(column, row).unwrap() < 0.5);
//! ```
#![warn(missing_docs)]

mod map;
pub mod node;
mod params;
mod raycast;

pub use map::{
    detection_point, occupancy_percent, occupancy_percent_from, percent_thresholds,
    IntegrationReport, OccupancyMap, Pose2,
};
pub use node::{build, MapperNode};
pub use params::{Params, MAX_CELLS};

/// Why a keyframe could not be integrated. The map is unchanged when one is returned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MapError {
    /// The AGV pose or the boresight is NaN or infinite.
    #[error(
        "non-finite pose ({x_m} m, {y_m} m, {yaw_rad} rad) or boresight ({boresight_rad} rad)"
    )]
    NonFinitePose {
        /// x, metres.
        x_m: f64,
        /// y, metres.
        y_m: f64,
        /// Yaw, radians.
        yaw_rad: f64,
        /// Boresight relative to the heading, radians.
        boresight_rad: f64,
    },
    /// A detection's range is NaN, infinite or negative, or its angle NaN or infinite.
    #[error("detection {index}: range {range_m} m, angle {angle_rad} rad (need a finite range >= 0 and a finite angle)")]
    InvalidDetection {
        /// Index of the first offending detection in the keyframe.
        index: usize,
        /// Its range, metres.
        range_m: f64,
        /// Its angle from boresight, radians.
        angle_rad: f64,
    },
    /// A map point (or the sensor position) is NaN or infinite.
    #[error("{what} at non-finite point ({x_m}, {y_m})")]
    NonFinitePoint {
        /// "sensor" or "detection N" (N its index).
        what: String,
        /// x, metres.
        x_m: f64,
        /// y, metres.
        y_m: f64,
    },
}
