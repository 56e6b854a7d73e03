//! The CLI verbs, one module per verb: each holds its clap arguments, their ranges, and a thin
//! run function over the library crates (graph, transport and supervision work is the runtime's).
//!
//! - [`launch`]: a launch file's graph, in one process or one process per node; [`run`]: one node
//!   as its own process (what `launch --mode processes` starts).
//! - [`montecarlo`]: trials of a launch in parallel, and `merge` of sharded studies.
//! - [`reproduce`]: the paper's figures; [`tradeoff`]: the speed/accuracy sweep; [`accuracy`]:
//!   single-scatterer RMSE against the Cramér–Rao bounds; [`resolution`]: two-scatterer
//!   resolution of each estimator; [`scene`]: random scene files; [`sizing`]: the cheapest
//!   configuration that meets a requirement (screen, sequential Monte Carlo, frontier).
//! - [`bag`]: rosbag2 record, info and play.
//! - [`topics`]: the topic catalogue, or what a live graph publishes (zenoh).
//! - [`echo`]: one live topic's messages as JSON lines (zenoh).
//! - [`metric`]: GOSPA and ET-GOPSA of CSV files (offline, `nrslam_evaluator`).
//! - [`segment`]: DBSCAN labels for a CSV of points (offline, `nrslam_segmenter`).
//! - `ros2` (feature `ros2`): the bridge to ROS 2.
//!
//! The two live observers (`topics`, `echo`) share the session and observer-queue helpers below.

pub mod accuracy;
pub mod bag;
pub mod echo;
pub mod launch;
pub mod metric;
pub mod montecarlo;
pub mod reproduce;
pub mod resolution;
#[cfg(feature = "ros2")]
pub mod ros2;
pub mod run;
pub mod scene;
pub mod segment;
pub mod sizing;
pub mod topics;
pub mod tradeoff;

use crate::args::TransportArgs;
use anyhow::Result;
use nrslam_runtime::receive::{Inbox, InboxOptions, Overload};

/// An observer keeps the newest samples rather than slow the graph down, and shows them in
/// arrival order (a bag played in a loop starts its stamps over).
fn observer_options(transport: &TransportArgs) -> Result<InboxOptions> {
    Ok(InboxOptions {
        overload: Overload::KeepNewest(OBSERVER_QUEUE),
        in_order: false,
        ..transport.inbox_options()?
    })
}

/// Samples an observer queues per topic before it drops the oldest.
const OBSERVER_QUEUE: usize = 256;

/// One line on stderr per topic and reason dropped, if any.
fn report_drops(inbox: &Inbox) {
    for (topic, reason, n) in inbox.drops().iter() {
        eprintln!("warning: {topic}: {n} samples dropped ({reason})");
    }
}
