//! The command line of `nrslam launch` and its range checks.

use crate::args::TransportArgs;
use crate::flags::{self, Real};
use anyhow::Result;
use clap::Args;
use nrslam_runtime::launch::Mode;
use std::path::PathBuf;

/// `nrslam launch`.
#[derive(Args, Debug)]
pub struct LaunchArgs {
    /// Launch file (TOML), e.g. launch/paper-ideal.toml.
    pub file: PathBuf,
    /// Launch arguments as name:=value, e.g. range_std_m:=0.1 angle_std_deg:=5, and node
    /// parameters as node.param:=value (nested: node.table.key:=value; the value is read as
    /// TOML, e.g. association.scan_matching:=false mapper.resolution_m:=0.2). See docs/launch.md.
    #[arg(value_name = "NAME:=VALUE")]
    pub assignments: Vec<String>,
    /// Run seed: every random stream of every node derives from it (0 to 2^64 − 1). Default 1;
    /// replaying a bag that carries its launch record (launch/replay.toml): the recorded seed.
    #[arg(long, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: Option<u64>,
    /// Output folder (created): summary.json, metrics.csv, map.png, segments.png, run.json.
    /// Default: out/<launch file name>.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// in-process: all nodes in this process; processes: one OS process per node over zenoh.
    /// Default: the launch file's mode.
    #[arg(long, value_name = "MODE")]
    pub mode: Option<Mode>,
    #[command(flatten)]
    pub pacing: crate::args::RateArgs,
    /// How long node processes may take to come up, in seconds, 1 to 604800 (a week)
    /// (processes mode); in-process with `[[external]]` topics: how long to wait for the first
    /// external message before giving up.
    #[arg(long, value_name = "SECONDS", default_value_t = 30, value_parser = flags::TIMEOUT_S.parser::<u64>(), allow_hyphen_values = true)]
    pub start_timeout_s: u64,
    /// Record the run into this new rosbag2 folder (metadata.yaml + MCAP, log times = simulated
    /// clock); `launch/replay.toml bag:=DIR` replays it.
    #[arg(long, value_name = "DIR")]
    pub record: Option<PathBuf>,
    /// With --record: topics to record (default: every topic the launch publishes).
    #[arg(long, value_name = "TOPIC", num_args = 1..)]
    pub record_topics: Vec<String>,
    #[command(flatten)]
    pub chunk: crate::cmd::bag::ChunkArgs,
    /// With --record: chunk compression and file splitting, as `nrslam bag record`.
    #[command(flatten)]
    pub storage: crate::cmd::bag::StorageArgs,
    /// With --listen/--connect/--ros-router: publish the topics as rmw_zenoh does in this ROS
    /// domain (key `<domain>/<topic>/<type>/<RIHS01 hash>` plus rmw_zenoh's attachment), so ROS 2
    /// nodes on rmw_zenoh receive them without a bridge, and take the launch file's `[[external]]`
    /// topics from ROS 2 publishers (`<domain>/<topic>/<type>/*`, type hash checked); with
    /// --mode processes every node process does both. 0 to 232, ROS 2's range.
    #[arg(long, value_name = "DOMAIN_ID", value_parser = ROS_DOMAIN_ID.parser::<u32>(), allow_hyphen_values = true)]
    pub ros_domain_id: Option<u32>,
    /// In-process with `[[external]]` topics: the run ends this many seconds (0.001 to 86400)
    /// after the last external message when not every external topic was ended by nrslam's
    /// end-of-stream marker (ROS 2 publishers send none). Counted from the first message; before
    /// it, --start-timeout-s applies.
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0, value_parser = EXTERNAL_IDLE_S.parser(), allow_hyphen_values = true)]
    pub external_idle_s: f64,
    #[command(flatten)]
    pub transport: TransportArgs,
}

pub(crate) use crate::args::ROS_DOMAIN_ID;

/// `--external-idle-s`.
pub(crate) const EXTERNAL_IDLE_S: Real = Real::closed(1e-3, 86_400.0, "0.001 to 86400 s");

impl LaunchArgs {
    /// The run seed: `--seed`, else 1.
    pub fn seed(&self) -> u64 {
        self.seed.unwrap_or(1)
    }

    /// Checks every numeric flag against its range (clap's parsers check them too; this covers
    /// `LaunchArgs` built in code, e.g. by `nrslam reproduce`). The error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check_pacing(&self.pacing, self.start_timeout_s)?;
        if let Some(id) = self.ros_domain_id {
            flags::check("--ros-domain-id", ROS_DOMAIN_ID.check(id))?;
        }
        flags::check(
            "--external-idle-s",
            EXTERNAL_IDLE_S.check(self.external_idle_s),
        )?;
        self.chunk.bytes()?;
        Ok(())
    }
}
