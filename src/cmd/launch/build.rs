//! Building and wiring the nodes of a launch.

use crate::registry;
use anyhow::{anyhow, Result};
use nrslam_runtime::launch::Launch;
use nrslam_runtime::wiring::{check_wiring, external_topics};
use nrslam_runtime::{Node, NodeContext};

/// The nodes of a launch, built and wired.
pub(crate) struct Built {
    /// (instance name, node) in launch order.
    pub nodes: Vec<(String, Box<dyn Node>)>,
    /// Frames the radar will produce, when known.
    pub expected_frames: Option<u64>,
    /// Topics fed from outside the launch (`[[external]]`).
    pub externals: Vec<&'static str>,
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
            namespace: decl.namespace.clone(),
        };
        let node = registry::build_node(&decl.kind, decl.params.clone(), &ctx, &decl.remap)
            .map_err(|e| {
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
    let wiring = |e| anyhow!("{}: {e}", launch.path.display());
    let externals = external_topics(&launch.externals).map_err(wiring)?;
    check_wiring(&nodes, &externals).map_err(wiring)?;
    Ok(Built {
        nodes,
        expected_frames,
        externals,
    })
}
