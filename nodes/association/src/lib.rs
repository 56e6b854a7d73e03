#![warn(missing_docs)]
//! # nrslam-association
//!
//! The data-association and location stage of nrslam: the paper's "data association" and
//! "location & mapping" modules (Sec. III-A of `paper/slam-multiple-extended-targets-5g.tex`).
//! Wheel odometry predicts the AGV pose; the frame's radar detections, matched against a map made
//! of keyframes ("we select key frames in the sensing data to build the mapping data"), correct
//! it; frames that moved far enough become keyframes and extend the map.
//!
//! - [`pose`]: SE(2) poses ([`Pose2`]) and angle wrapping.
//! - [`scan_matcher`]: tracking's radar-aware scan matching, each detection with its error ellipse
//!   against a map of cell Gaussians ([`scan_matcher::DistributionMap`],
//!   [`scan_matcher::match_scan`]).
//! - [`icp`]: point-to-line ICP ([`PointMap`], [`align`]), which refines loop-closure matches.
//! - [`keyframe`]: keyframe selection ([`KeyframeSelector`]).
//! - [`loop_closure`]: revisit detection and verification ([`match_loop`]).
//! - [`pose_graph`]: SE(2) pose-graph optimisation ([`PoseGraph`]).
//! - [`slam`]: the per-frame loop ([`Association`]).
//! - [`params`]: the node's [`Params`].
//! - [`node`]: the graph node ([`build`], [`AssociationNode`]): inputs `/odom` and
//!   `/radar/detections`, outputs `/slam/pose`, `/slam/keyframe`, `/slam/keyframe_poses` and
//!   `/slam/association_stats`.
//!
//! Everything but [`node`] is a plain library that never sees a transport or a message type.
//!
//! ```
//! use nrslam_association::{Association, Params, Pose2};
//!
//! // Wheels trusted little (a 0.5 m, 5° prior around their prediction), so the scan decides.
//! let params = Params { prior_std_m: 0.5, prior_std_deg: 5.0, ..Params::default() };
//! let mut slam = Association::new(params).unwrap();
//! slam.on_odometry(Pose2::new(1.0, 2.0, 0.0)).unwrap();
//! // A box of points around the AGV: the first frame is a keyframe and seeds the map.
//! let scan: Vec<[f64; 2]> = (0..80)
//!     .map(|i| {
//!         let s = f64::from(i % 20) * 0.2 - 2.0;
//!         [[s, 2.0], [2.0, s], [s, -2.0], [-2.0, s]][(i / 20) as usize]
//!     })
//!     .collect();
//! let first = slam.on_scan(&scan).unwrap();
//! assert_eq!(first.keyframe_id, Some(0));
//! // Odometry claims 0.1 m forward, but the scan is unchanged: scan matching pulls the pose back.
//! slam.on_odometry(Pose2::new(1.1, 2.0, 0.0)).unwrap();
//! let second = slam.on_scan(&scan).unwrap();
//! assert!((second.pose.x_m - 1.0).abs() < 0.02, "{second:?}");
//! ```

// The benches' scenes and graphs, shared with the unit tests; the file names the crate as the
// benches do.
#[cfg(test)]
extern crate self as nrslam_association;
#[cfg(test)]
#[path = "../benches/common/mod.rs"]
mod fixtures;

pub mod correlative;
pub mod icp;
pub mod keyframe;
pub mod loop_closure;
pub mod node;
pub mod params;
pub mod point_grid;
pub mod pose;
pub mod pose_graph;
pub mod scan_matcher;
pub mod slam;

pub use correlative::{CorrelativeError, MultiResolutionGrid, ProbabilityGrid, SearchWindow};
pub use icp::{align, IcpResult, IcpStatus, LineFit, PointMap};
pub use keyframe::KeyframeSelector;
pub use loop_closure::{match_loop, match_loop_with, LoopCache, LoopMatch, LoopRejection};
pub use node::{build, AssociationNode};
pub use params::{IcpMetric, LoopClosureParams, Params};
pub use pose::{wrap_angle_rad, Pose2};
pub use pose_graph::{Edge, EdgeKind, OptimiserSettings, PoseGraph};
pub use slam::{
    detection_to_agv_m, Association, AssociationError, FrameOutcome, FrameStats, KeyframeRecord,
    LoopEdge,
};
