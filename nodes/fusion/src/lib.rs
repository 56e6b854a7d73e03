#![warn(missing_docs)]
//! # nrslam-fusion
//!
//! Data fusion, the fourth module of the SLAM system in "SLAM for Multiple Extended Targets using
//! 5G Signal" (its Fig. 2), which the paper leaves to future work: several AGVs and fixed 5G
//! sensing stations, each sensing on its own, fused into one map.
//!
//! - [`fusion`]: the algorithm ([`Fusion`]): agents' frames found by place recognition with the
//!   single-AGV back end's matcher, one pose graph over every agent's keyframes;
//! - [`Params`]: the node's parameters;
//! - [`node`]: the graph node ([`build`], [`FusionNode`]).
//!
//! The matcher, its verification and the pose graph are `nrslam-association`'s, used as a
//! library: one implementation serves the single-AGV back end and fusion.

pub mod fusion;
pub mod node;
mod params;

pub use fusion::{AgentKind, Fusion, FusionError, FusionStats, InterEdge, Update, MAX_RESTARTS};
pub use node::{build, FusionNode};
pub use params::{Params, MAX_AGENTS};
