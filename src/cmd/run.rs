//! `nrslam run`: one node as its own process over zenoh.

use super::{transport_config, RunArgs};
use crate::flags;
use crate::registry;
use anyhow::{anyhow, bail, Context, Result};
use nrslam_msgs::topics;
use nrslam_runtime::transport::{self, SessionMode};
use nrslam_runtime::NodeContext;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// `nrslam run`.
pub fn run(args: RunArgs) -> Result<()> {
    args.validate()?;
    let table: toml::Table = match &args.params {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            toml::from_str(&text).map_err(|e| anyhow!("{}: {}", path.display(), e.message()))?
        }
        None => toml::Table::new(),
    };
    let base_dir = args
        .base_dir
        .clone()
        .or_else(|| {
            args.params
                .as_ref()
                .and_then(|p| p.parent().map(Path::to_owned))
        })
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or_else(|| PathBuf::from("."));
    let name = args.name.clone().unwrap_or_else(|| args.kind.clone());
    let ctx = NodeContext {
        name: name.clone(),
        seed: args.seed,
        base_dir,
    };
    let source = args
        .params
        .as_ref()
        .map_or_else(|| "defaults".to_owned(), |p| p.display().to_string());
    let node = registry::build(&args.kind, table, &ctx)
        .map_err(|e| anyhow!("{source}: node {name}: {e}"))?;
    let mode = match args.zenoh_mode.as_str() {
        "peer" => SessionMode::Peer,
        "client" => SessionMode::Client,
        other => bail!("--zenoh-mode: unknown role {other:?} (allowed: peer, client)"),
    };
    let session = transport::open(&transport_config(mode, &args.transport))
        .context("opening the zenoh session")?;
    if node.inputs().is_empty() && !args.start_barrier && args.startup_delay_s > 0.0 {
        std::thread::sleep(flags::seconds("--startup-delay-s", args.startup_delay_s)?);
    }
    // run_node adds the timeout to the clock: check here that it can.
    let start_timeout = Duration::from_secs(args.start_timeout_s);
    flags::deadline("--start-timeout-s", start_timeout)?;
    let ended = args
        .ended
        .iter()
        .map(|t| {
            topics::spec(t)
                .map(|s| s.name)
                .ok_or_else(|| anyhow!("--ended: {t} is not in the topic catalogue"))
        })
        .collect::<Result<Vec<_>>>()?;
    let run = transport::NodeRun {
        wait_for_start: args.start_barrier,
        start_timeout,
        rate: args.rate,
        inbox: args.transport.inbox_options()?,
        ended,
    };
    let drops = transport::run_node_with(&session, &args.transport.namespace, &name, node, run)
        .map_err(|e| anyhow!("node '{name}' failed: {e}"))?;
    if !drops.is_empty() {
        tracing::warn!(
            node = name,
            dropped = drops.total(),
            "unusable input samples were dropped"
        );
    }
    // Let the last publications leave before the session closes.
    std::thread::sleep(Duration::from_millis(200));
    let _ = zenoh::Wait::wait(session.close());
    Ok(())
}
