//! `nrslam ros2-bridge` (cargo feature `ros2`, needs a sourced ROS 2 to build): graph topics to
//! ROS 2 and back, through `nrslam-ros2-bridge` (r2r). See docs/ros2.md.

use crate::args::TransportArgs;
use anyhow::{Context, Result};
use clap::Args;
use nrslam_runtime::transport::{self, SessionMode, TransportConfig};

/// `nrslam ros2-bridge`.
#[derive(Args, Debug)]
pub struct Ros2BridgeArgs {
    /// Graph topics to publish as ROS 2 topics (default: /clock /map /slam/pose /ground_truth/pose,
    /// the standard-typed outputs; project-typed topics need the nrslam_msgs ROS package).
    #[arg(long, value_name = "TOPIC", num_args = 1..)]
    pub to_ros: Vec<String>,
    /// ROS 2 topics to feed into the graph, e.g. --from-ros /odom /radar/detections (default: none).
    #[arg(long, value_name = "TOPIC", num_args = 1..)]
    pub from_ros: Vec<String>,
    /// ROS 2 node name.
    #[arg(long, default_value = "nrslam_bridge")]
    pub node_name: String,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `nrslam ros2-bridge`.
pub fn bridge(args: Ros2BridgeArgs) -> Result<()> {
    let to_ros = if args.to_ros.is_empty() {
        nrslam_ros2_bridge::DEFAULT_TO_ROS.to_vec()
    } else {
        crate::cmd::bag::catalogue_topics(&args.to_ros)?
    };
    let from_ros = if args.from_ros.is_empty() {
        Vec::new()
    } else {
        crate::cmd::bag::catalogue_topics(&args.from_ros)?
    };
    let session = transport::open(&TransportConfig {
        mode: SessionMode::Peer,
        listen: args.transport.listen.clone(),
        connect: args.transport.connect.clone(),
        namespace: args.transport.namespace.clone(),
    })
    .context("opening the zenoh session")?;
    nrslam_ros2_bridge::run(
        &session,
        &nrslam_ros2_bridge::BridgeConfig {
            node_name: args.node_name,
            to_ros,
            from_ros,
            namespace: args.transport.namespace,
        },
    )
}
