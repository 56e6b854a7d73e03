//! Pictures out: the graph's state as the standard ROS 2 messages RViz and Foxglove draw.
//!
//! - `/tf` and `/tf_static`: `map → odom → base_link → radar` (REP-105);
//! - `/slam/path` and `/ground_truth/path` (`nav_msgs/msg/Path`): the estimated and true
//!   trajectories;
//! - `/ground_truth/markers` and `/map/clusters` (`visualization_msgs/msg/MarkerArray`): the true
//!   outlines with their sample points; the map's DBSCAN clusters with their representative
//!   points (as the evaluator scores them);
//! - `/radar/detections_cloud` (`sensor_msgs/msg/PointCloud2`): each frame's detections in the
//!   radar frame.
//!
//! [`draw`] builds the messages (pure functions); [`node`] is the graph node (`kind = "viz"`);
//! [`Params`] chooses what is drawn. docs/visualisation.md shows them in Foxglove.
#![warn(missing_docs)]

pub mod draw;
pub mod node;
mod params;

pub use node::{build, VizNode};
pub use params::Params;
