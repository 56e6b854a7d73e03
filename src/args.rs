//! The argument structs several verbs flatten into theirs (`#[command(flatten)]`), each defined
//! once: where a zenoh session listens and connects ([`TransportArgs`]), which keys it speaks
//! ([`RosDomainArgs`]: nrslam's or rmw_zenoh's), the real-time factor ([`RateArgs`]) and the
//! output folder of the verbs that write several files ([`OutputDirArgs`]). Their numeric ranges
//! are in [`crate::flags`].

use anyhow::{Context, Result};
use clap::Args;
use std::path::{Path, PathBuf};

use crate::flags::{check, Whole, RATE};
use nrslam_runtime::transport::KeyStyle;

/// ROS 2 domain ids (`ROS_DOMAIN_ID`), for every verb's `--ros-domain-id`.
pub(crate) const ROS_DOMAIN_ID: Whole = Whole::new(0, 232, "0 to 232 (ROS 2 domain ids)");

/// `--ros-domain-id` of the verbs that take or give a live graph's topics without being a
/// launcher: `run`, `echo`, `topics`, `bag record`.
#[derive(Args, Debug, Clone, Copy, Default)]
pub struct RosDomainArgs {
    /// Speak rmw_zenoh in this ROS 2 domain, 0 to 232: subscribe to each topic on
    /// `<domain>/<topic>/<DDS type>/*`, taking samples whose type hash is the topic's RIHS01 or
    /// the all-zero placeholder (others are dropped and counted as type_hash_mismatch), so ROS 2
    /// publishers are heard; `run` also publishes as a ROS 2 node (liveliness tokens, rmw_zenoh's
    /// attachment). Default: nrslam's own keys (`map`).
    #[arg(long, value_name = "DOMAIN_ID", value_parser = ROS_DOMAIN_ID.parser::<u32>(), allow_hyphen_values = true)]
    pub ros_domain_id: Option<u32>,
}

impl RosDomainArgs {
    /// Checks `--ros-domain-id` against its range.
    pub fn validate(&self) -> Result<()> {
        if let Some(id) = self.ros_domain_id {
            check("--ros-domain-id", ROS_DOMAIN_ID.check(id))?;
        }
        Ok(())
    }

    /// The key style these flags ask for.
    pub fn key_style(&self) -> KeyStyle {
        key_style(self.ros_domain_id)
    }
}

/// nrslam's keys, or rmw_zenoh's in ROS domain `ros_domain_id`.
pub fn key_style(ros_domain_id: Option<u32>) -> KeyStyle {
    match ros_domain_id {
        Some(domain_id) => KeyStyle::RmwZenoh { domain_id },
        None => KeyStyle::Nrslam,
    }
}

/// `--rate`, the real-time factor that `launch`, `run` and `bag play` share.
#[derive(Args, Debug, Clone, Copy, Default)]
pub struct RateArgs {
    /// Real-time factor R: simulated (or recorded) seconds per wall-clock second (2 = twice real
    /// time), 1e-6 to 1e6. 0 (default): as fast as the subscribers take the messages. Nothing is
    /// dropped either way (reliable publication that blocks on congestion).
    #[arg(
        long,
        value_name = "R",
        default_value_t = 0.0,
        value_parser = RATE.parser(),
        allow_hyphen_values = true
    )]
    pub rate: f64,
}

impl RateArgs {
    /// Checks `--rate` against its range (clap's parser checks it too; this covers arguments
    /// built in code).
    pub fn validate(&self) -> Result<()> {
        check("--rate", RATE.check(self.rate)).map(drop)
    }
}

/// `--out DIR`, the output folder of `accuracy`, `montecarlo`, `merge`, `reproduce` and
/// `tradeoff`.
#[derive(Args, Debug, Clone)]
pub struct OutputDirArgs {
    /// Output folder, created with its parents if missing (the command's description lists what
    /// it writes there).
    #[arg(long = "out", value_name = "DIR")]
    pub dir: PathBuf,
}

impl OutputDirArgs {
    /// Creates the folder and its parents; the error names it.
    pub fn create(&self) -> Result<&Path> {
        std::fs::create_dir_all(&self.dir)
            .with_context(|| format!("cannot create {}", self.dir.display()))?;
        Ok(&self.dir)
    }

    /// The path of `name` in the folder.
    pub fn join(&self, name: impl AsRef<Path>) -> PathBuf {
        self.dir.join(name)
    }
}

/// Where the zenoh session listens and connects. Multicast scouting is always off; nothing is
/// exposed beyond the endpoints given here.
#[derive(Args, Debug, Clone, Default)]
pub struct TransportArgs {
    /// zenoh endpoint to listen on, e.g. tcp/127.0.0.1:7447 (repeatable). Outside clients connect here.
    #[arg(long = "listen", value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// zenoh endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeatable): a router, or a peer that listens.
    #[arg(long = "connect", value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Prefix of every key expression (e.g. `robot1` → `robot1/map`); empty: none.
    #[arg(long, default_value = "", value_name = "PREFIX")]
    pub namespace: String,
    /// zenoh configuration file (.json5, .json or .yaml) for every session of the run: TLS,
    /// mutual TLS, access control (docs/security.md). Its endpoints come before --listen; a
    /// --connect replaces its connect endpoints; the session's role stays nrslam's.
    #[arg(long = "zenoh-config", value_name = "FILE")]
    pub zenoh_config: Option<std::path::PathBuf>,
    /// Join ROS 2 through this rmw_zenohd router, e.g. tcp/localhost:7447 (`ros2 run
    /// rmw_zenoh_cpp rmw_zenohd`): the session becomes the router's client, as rmw_zenoh asks of
    /// non-ROS sessions (a router forwards a client's data and tokens to its ROS nodes, not a
    /// peer's). With --ros-domain-id: `ros2 topic list` and `ros2 node list` show the graph.
    #[arg(long = "ros-router", value_name = "ENDPOINT")]
    pub ros_router: Option<String>,
    /// What a received sample that cannot be used (bad CDR, NaN where a number is needed, a
    /// stamp older than the last on its topic, ...) does: `drop` counts it (summary.json
    /// "dropped", /diagnostics) and goes on; `fail` stops with an error naming it.
    #[arg(long, default_value = "drop", value_name = "POLICY", value_parser = ["drop", "fail"])]
    pub on_bad_input: String,
}

impl TransportArgs {
    /// A peer session on the endpoints given, for the verbs that observe or feed a running graph;
    /// refused when there is none to listen or connect on.
    pub fn peer_session(&self) -> Result<zenoh::Session> {
        if self.listen.is_empty() && self.connect.is_empty() && self.ros_router.is_none() {
            anyhow::bail!("give --connect ENDPOINT (e.g. the --listen endpoint of a running `nrslam launch`), --listen ENDPOINT or --ros-router ENDPOINT");
        }
        let config = self.config(nrslam_runtime::transport::SessionMode::Peer);
        nrslam_runtime::transport::open(&config).context("opening the zenoh session")
    }

    /// The receive path's options for --on-bad-input (back-pressure on full queues).
    pub fn inbox_options(&self) -> anyhow::Result<nrslam_runtime::receive::InboxOptions> {
        Ok(nrslam_runtime::receive::InboxOptions {
            bad_input: self
                .on_bad_input
                .parse()
                .map_err(|e| anyhow::anyhow!("--on-bad-input: {e}"))?,
            overload: nrslam_runtime::receive::Overload::BackPressure,
            in_order: true,
        })
    }

    /// The session configuration for these flags, in role `mode`.
    pub fn config(
        &self,
        mode: nrslam_runtime::transport::SessionMode,
    ) -> nrslam_runtime::transport::TransportConfig {
        let config = nrslam_runtime::transport::TransportConfig {
            mode,
            listen: self.listen.clone(),
            connect: self.connect.clone(),
            namespace: self.namespace.clone(),
            config_file: self.zenoh_config.clone(),
        };
        match &self.ros_router {
            Some(router) => config.via_ros_router(router),
            None => config,
        }
    }
}
