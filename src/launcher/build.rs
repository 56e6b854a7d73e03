//! Building and wiring the nodes of a launch.

use crate::registry;
use anyhow::{anyhow, bail, Result};
use nrslam_msgs::topics;
use nrslam_runtime::launch::Launch;
use nrslam_runtime::{Node, NodeContext};

/// The nodes of a launch, built and wired.
pub(crate) struct Built {
    /// (instance name, node) in launch order.
    pub nodes: Vec<(String, Box<dyn Node>)>,
    /// Frames the radar will produce, when known.
    pub expected_frames: Option<u64>,
}

/// Builds every node of the launch (validating all parameters) and checks the wiring against the
/// topic catalogue.
pub(crate) fn build_all(launch: &Launch, seed: u64) -> Result<Built> {
    let mut nodes = Vec::new();
    let mut expected_frames = None;
    for decl in &launch.nodes {
        let ctx = NodeContext {
            name: decl.name.clone(),
            seed,
            base_dir: decl.base_dir.clone(),
        };
        let node = registry::build(&decl.kind, decl.params.clone(), &ctx).map_err(|e| {
            anyhow!(
                "{}: {}: {e}",
                launch.path.display(),
                decl.describe(&launch.path)
            )
        })?;
        expected_frames =
            expected_frames.or_else(|| registry::expected_frames(&decl.kind, &decl.params, &ctx));
        nodes.push((decl.name.clone(), node));
    }
    for (name, node) in &nodes {
        for topic in node.inputs().into_iter().chain(node.outputs()) {
            if topics::spec(topic).is_none() {
                bail!(
                    "{}: node {name}: topic {topic} is not in the catalogue",
                    launch.path.display()
                );
            }
        }
        for topic in node.inputs() {
            if !nodes
                .iter()
                .any(|(_, other)| other.outputs().contains(&topic))
            {
                bail!(
                    "{}: node {name} subscribes to {topic}, which no node of the launch publishes",
                    launch.path.display()
                );
            }
        }
    }
    Ok(Built {
        nodes,
        expected_frames,
    })
}
