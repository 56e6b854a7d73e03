//! What a run leaves behind: the reporter listens to the graph's topics (in-process or over zenoh,
//! the same messages either way) and writes `summary.json`, `metrics.csv`, `map.png` and
//! `segments.png`.
//!
//! [`Reporter`] (reporter.rs) collects a run's messages; [`Summary`] (summary.rs) is what goes
//! into `summary.json`; loops.rs scores the back end's loop edges against the truth and writes
//! `loops.csv`; metrics_csv.rs writes `metrics.csv`.

use nrslam_msgs::topics;

mod agents;
mod loops;
mod metrics_csv;
mod reporter;
mod shapes;
mod summary;
#[cfg(test)]
mod tests;

pub use agents::{AgentSummary, AgentTrack, InterAgentEdges};
pub use loops::{LOOP_EDGE_CHI2_99, LOOP_EDGE_WRONG_M};
// Kept at its old path, `crate::report::ScoredLoopEdge`, though nothing outside this module
// names it yet.
#[allow(unused_imports)]
pub use loops::ScoredLoopEdge;
pub use reporter::Reporter;
pub use shapes::ShapeSummary;
pub use summary::Summary;

/// Topics the reporter needs.
pub const REPORTED: &[&str] = &[
    topics::CLOCK,
    topics::GROUND_TRUTH_TARGETS,
    topics::GROUND_TRUTH_POSE,
    topics::SLAM_POSE,
    topics::KEYFRAME,
    topics::KEYFRAME_POSES,
    topics::ASSOCIATION_STATS,
    topics::MAP,
    topics::SEGMENTS,
    topics::MAP_TARGETS,
    topics::METRICS,
    topics::FUSION_EDGES,
];

/// A message stamp as (sec, nanosec), exact, for matching keyframes to the truth.
type StampKey = (i32, u32);
/// A planar position (x_m, y_m).
type PositionM = (f64, f64);
