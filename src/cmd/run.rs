//! `nrslam run`: one node as its own process over zenoh.

use crate::args::TransportArgs;
use crate::flags::{self, Real};
use crate::registry;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use nrslam_msgs::topics;
use nrslam_runtime::transport::{self, SessionMode};
use nrslam_runtime::NodeContext;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// `nrslam run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Node kind: radar, estimator, association, mapper, segmenter, shapes, evaluator,
    /// sensor_adapter, viz.
    pub kind: String,
    /// The node's parameters (TOML, the fields of the node's Params at top level). Default: the
    /// paper's defaults.
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Instance name (readiness key nrslam/ready/<name>). Default: the kind, under
    /// --node-namespace if given (agv1/radar).
    #[arg(long)]
    pub name: Option<String>,
    /// Namespace the node runs in, e.g. agv1 or site/agv1: each of its topics not remapped
    /// becomes /<namespace><topic> (/agv1/odom) and its random streams are its own
    /// (docs/launch.md, "Namespaces and remapping"). Not the zenoh key prefix (--namespace).
    #[arg(long, value_name = "NAMESPACE", default_value = "")]
    pub node_namespace: String,
    /// Gives one of the node's topics an absolute name instead: FROM:=TO, FROM its own topic
    /// (/ground_truth/targets), TO a catalogue topic under a namespace or not (repeatable).
    #[arg(long, value_name = "FROM:=TO")]
    pub remap: Vec<String>,
    /// Run seed (must match the other nodes' for reproducible runs; 0 to 2^64 − 1).
    #[arg(long, default_value_t = 1, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: u64,
    /// Folder that relative paths in the parameters resolve against. Default: the params file's folder.
    #[arg(long, value_name = "DIR")]
    pub base_dir: Option<PathBuf>,
    /// zenoh role of this process: peer, or client (of a router or listening peer).
    #[arg(long, default_value = "peer", value_name = "ROLE")]
    pub zenoh_mode: String,
    /// Declare readiness and, for a source, wait for the launcher's start signal (used by `launch --mode processes`).
    #[arg(long)]
    pub start_barrier: bool,
    /// With --start-barrier: how long to wait for the start signal, in seconds, 1 to 604800
    /// (a week).
    #[arg(long, value_name = "SECONDS", default_value_t = 60, value_parser = flags::TIMEOUT_S.parser::<u64>(), allow_hyphen_values = true)]
    pub start_timeout_s: u64,
    /// Without --start-barrier: seconds a source waits before its first frame, so subscribers can
    /// come up, 0 to 3600 s.
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0, value_parser = STARTUP_DELAY_S.parser(), allow_hyphen_values = true)]
    pub startup_delay_s: f64,
    #[command(flatten)]
    pub pacing: crate::args::RateArgs,
    /// An input topic whose stream already ended (repeatable): the launcher passes these when it
    /// respawns a node, so it does not wait for ends it missed.
    #[arg(long, value_name = "TOPIC")]
    pub ended: Vec<String>,
    #[command(flatten)]
    pub ros: crate::args::RosDomainArgs,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// Delay before a source's first frame.
const STARTUP_DELAY_S: Real = Real::closed(0.0, 3600.0, "0 to 3600 s");

impl RunArgs {
    /// Checks every numeric flag against its range; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check_pacing(&self.pacing, self.start_timeout_s)?;
        flags::check(
            "--startup-delay-s",
            STARTUP_DELAY_S.check(self.startup_delay_s),
        )?;
        self.ros.validate()
    }
}

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
    if let Some(problem) = topics::namespace_problem(&args.node_namespace) {
        bail!("--node-namespace: namespace {problem}");
    }
    let remap = remap_pairs(&args.remap)?;
    let name = args.name.clone().unwrap_or_else(|| {
        if args.node_namespace.is_empty() {
            args.kind.clone()
        } else {
            format!("{}/{}", args.node_namespace, args.kind)
        }
    });
    let ctx = NodeContext {
        name: name.clone(),
        seed: args.seed,
        base_dir,
        namespace: args.node_namespace.clone(),
    };
    let source = args
        .params
        .as_ref()
        .map_or_else(|| "defaults".to_owned(), |p| p.display().to_string());
    let node = registry::build_node(&args.kind, table, &ctx, &remap)
        .map_err(|e| anyhow!("{source}: node {name}: {e}"))?;
    let mode = match args.zenoh_mode.as_str() {
        "peer" => SessionMode::Peer,
        "client" => SessionMode::Client,
        other => bail!("--zenoh-mode: unknown role {other:?} (allowed: peer, client)"),
    };
    let session =
        transport::open(&args.transport.config(mode)).context("opening the zenoh session")?;
    if node.inputs().is_empty() && !args.start_barrier && args.startup_delay_s > 0.0 {
        std::thread::sleep(flags::seconds("--startup-delay-s", args.startup_delay_s)?);
    }
    // run_node adds the timeout to the clock: check here that it can.
    let start_timeout = Duration::from_secs(args.start_timeout_s);
    flags::deadline("--start-timeout-s", start_timeout)?;
    // Named as the node's inputs are: under its namespace (/agv1/odom) when it has one.
    let ended = args
        .ended
        .iter()
        .map(|t| match topics::spec(t) {
            Some(_) => Ok(topics::intern(t)),
            None => Err(anyhow!("--ended: {t} is not in the topic catalogue")),
        })
        .collect::<Result<Vec<_>>>()?;
    let run = transport::NodeRun {
        wait_for_start: args.start_barrier,
        start_timeout,
        rate: args.pacing.rate,
        inbox: args.transport.inbox_options()?,
        ended,
        style: args.ros.key_style(),
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

/// `--remap FROM:=TO` pairs, each FROM once.
fn remap_pairs(pairs: &[String]) -> Result<BTreeMap<String, String>> {
    let mut out = BTreeMap::new();
    for pair in pairs {
        let (from, to) = pair
            .split_once(":=")
            .ok_or_else(|| anyhow!("--remap: {pair:?} is not FROM:=TO"))?;
        if out.insert(from.to_owned(), to.to_owned()).is_some() {
            bail!("--remap: {from} is remapped twice");
        }
    }
    Ok(out)
}
