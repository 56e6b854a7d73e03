//! The nrslam runtime: what every node shares and none re-implements.
//!
//! - [`node`]: the [`Node`] trait (pure algorithm, typed inputs and outputs), [`NodeContext`].
//! - [`merge`]: deterministic (stamp, input order) delivery of a node's inputs.
//! - [`compose`]: the in-process composition used for batch and Monte Carlo runs.
//! - [`config`]: typed parameters and the [`InvalidParam`] error that names the field.
//! - [`launch`]: TOML launch files with `name:=value` arguments.
//! - [`bag`]: rosbag2 bags (metadata.yaml + MCAP): writer, reader with recovery, replay source node.
//! - [`type_hash`]: ROS 2 RIHS01 type description hashes; [`rmw_zenoh`]: rmw_zenoh's key
//!   expressions and attachments.
//! - `transport` (feature `zenoh`): the zenoh session, node adapters and the start barrier.
//! - `receive` (feature `zenoh`): the one receive path: bounded queues, unusable samples dropped
//!   and counted, `/diagnostics`.
//! - `external` (feature `zenoh`): the source node that feeds a launch's `[[external]]` topics
//!   from zenoh into an in-process graph.
//! - `supervisor`: node processes watched and respawned as ROS 2 launch does; `supervised`
//!   (feature `zenoh`): the launcher's receive loop over them, restarting the ones that die.
//! - [`remap`]: a node under a namespace or with remapped topics ([`remap::Remapped`]).
//! - [`wiring`]: the checks that a graph's nodes fit together before it runs.
#![warn(missing_docs)]

// The bag tests' fixtures (tests/bag_common), shared with the unit tests; the file names the
// crate as the integration tests do.
#[cfg(test)]
extern crate self as nrslam_runtime;
#[cfg(test)]
#[path = "../tests/bag_common/mod.rs"]
mod bag_common;

pub mod bag;
pub mod compose;
pub mod config;
pub mod launch;
pub mod merge;
pub mod node;
pub mod remap;
pub mod rmw_zenoh;
pub mod seed;
pub mod supervisor;
pub mod type_hash;
pub mod wiring;

pub use config::{parse_params, InvalidParam, ParamsError};
pub use node::{Node, NodeContext, NodeError, NodeResult, Outbox, Tick};
#[cfg(feature = "zenoh")]
pub mod external;
#[cfg(feature = "zenoh")]
pub mod receive;
#[cfg(feature = "zenoh")]
pub mod supervised;
#[cfg(feature = "zenoh")]
pub mod transport;
