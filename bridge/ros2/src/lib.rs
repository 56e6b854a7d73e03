//! The ROS 2 bridge of the nrslam graph, on r2r (rcl bindings): it publishes graph topics as
//! ROS 2 topics of the same name and type, and feeds ROS 2 topics (typically `/odom` from a real
//! robot and `/radar/detections` from a real radar) into the graph.
//!
//! The payloads are not converted: the graph already speaks ROS 2 CDR, so samples go through
//! r2r's raw (serialised-message) publishers and subscriptions unchanged. Standard types
//! (`nav_msgs`, `geometry_msgs`, `rosgraph_msgs`) need nothing but a sourced ROS 2; project types
//! (`nrslam_msgs/msg/*`) need the `nrslam_msgs` interface package built in a sourced workspace
//! (see `docs/ros2.md`).
//!
//! Build (a sourced ROS 2 is required by r2r's build script): `cargo build --release --features
//! ros2`; run: `nrslam ros2-bridge --connect tcp/127.0.0.1:7447`.

use anyhow::{anyhow, bail, Context, Result};
use futures::StreamExt;
use nrslam_msgs::topics;
use nrslam_runtime::transport::{self, Session, TopicPublisher};
use r2r::QosProfile;
use std::sync::mpsc;
use std::time::Duration;

/// Topics published to ROS 2 by default: the graph's outputs with standard ROS 2 types.
pub const DEFAULT_TO_ROS: &[&str] = &[
    topics::CLOCK,
    topics::MAP,
    topics::SLAM_POSE,
    topics::GROUND_TRUTH_POSE,
];

/// What the bridge carries.
#[derive(Debug, Clone)]
pub struct BridgeConfig {
    /// ROS 2 node name.
    pub node_name: String,
    /// Graph topics published to ROS 2.
    pub to_ros: Vec<&'static str>,
    /// ROS 2 topics fed into the graph.
    pub from_ros: Vec<&'static str>,
    /// zenoh key prefix of the graph's topics.
    pub namespace: String,
}

fn qos(topic: &str) -> QosProfile {
    let latched =
        topics::spec(topic).is_some_and(|s| s.qos.durability == topics::Durability::TransientLocal);
    let profile = QosProfile::default().reliable().keep_last(100);
    if latched {
        profile.transient_local()
    } else {
        profile.volatile()
    }
}

/// Runs the bridge on the graph reachable through `session` until the graph's streams end (all
/// `to_ros` topics ended) or, with nothing to forward to ROS 2, forever.
pub fn run(session: &Session, config: &BridgeConfig) -> Result<()> {
    for topic in &config.to_ros {
        if config.from_ros.contains(topic) {
            bail!("topic {topic} cannot go both to and from ROS 2 (it would loop)");
        }
    }
    let context = r2r::Context::create().context("initialising ROS 2 (rcl)")?;
    let mut node =
        r2r::Node::create(context, &config.node_name, "").context("creating the ROS 2 node")?;

    // Graph -> ROS 2: zenoh samples into a channel, published from the spin loop.
    let mut ros_publishers = Vec::new();
    for &topic in &config.to_ros {
        let spec = topics::spec(topic).ok_or_else(|| anyhow!("unknown topic {topic}"))?;
        let publisher = node
            .create_publisher_untyped(topic, spec.type_name, qos(topic))
            .with_context(|| format!("ROS 2 publisher {topic} ({})", spec.type_name))?;
        ros_publishers.push((topic, publisher));
    }
    let (_subscribers, from_graph) =
        transport::subscribe(session, &config.namespace, &config.to_ros)?;

    // ROS 2 -> graph: raw subscriptions, republished on the graph's key expressions.
    let mut graph_publisher = TopicPublisher::new(session, &config.namespace, &config.from_ros)?;
    let (to_graph, from_ros) = mpsc::channel::<(&'static str, Vec<u8>)>();
    let mut pool = futures::executor::LocalPool::new();
    for &topic in &config.from_ros {
        let spec = topics::spec(topic).ok_or_else(|| anyhow!("unknown topic {topic}"))?;
        let stream = node
            .subscribe_raw(topic, spec.type_name, qos(topic))
            .with_context(|| format!("ROS 2 subscription {topic} ({})", spec.type_name))?;
        let sender = to_graph.clone();
        futures::task::LocalSpawnExt::spawn_local(
            &pool.spawner(),
            stream.for_each(move |bytes| {
                let _ = sender.send((topic, bytes));
                futures::future::ready(())
            }),
        )
        .map_err(|e| anyhow!("spawning the {topic} subscription: {e:?}"))?;
    }

    let mut open: Vec<&'static str> = config.to_ros.clone();
    loop {
        node.spin_once(Duration::from_millis(5));
        pool.run_until_stalled();
        while let Ok((topic, bytes)) = from_ros.try_recv() {
            // A decodable message only: the graph's nodes reject malformed CDR anyway.
            transport::decode(topic, &bytes)?;
            graph_publisher.publish_cdr(topic, bytes)?;
        }
        while let Ok((topic, bytes)) = from_graph.try_recv() {
            if bytes.is_empty() {
                open.retain(|t| *t != topic);
                continue;
            }
            if let Some((_, publisher)) = ros_publishers.iter().find(|(t, _)| *t == topic) {
                publisher
                    .publish_raw(&bytes)
                    .with_context(|| format!("publishing {topic} to ROS 2"))?;
            }
        }
        if !config.to_ros.is_empty() && open.is_empty() {
            return Ok(());
        }
    }
}
