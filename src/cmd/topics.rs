//! `nrslam topics`: what can be listened to. Without endpoints, the catalogue of topics (name,
//! message type, durability, description); with --connect or --listen, the topics a live graph
//! publishes during --duration-s and how many messages each carried.

use super::{observer_options, report_drops};
use crate::args::TransportArgs;
use crate::flags::{self, Real};
use anyhow::Result;
use clap::Args;
use nrslam_msgs::topics;
use nrslam_runtime::receive::{Delivery, Inbox};
use std::collections::BTreeMap;
use std::time::Instant;
use zenoh::Wait;

/// `nrslam topics`.
#[derive(Args, Debug)]
pub struct TopicsArgs {
    /// Seconds to listen to a live graph (with --connect or --listen) before listing what it
    /// publishes, 0.001 to 3600 s.
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0, value_parser = LISTEN_S.parser(), allow_hyphen_values = true)]
    pub duration_s: f64,
    #[command(flatten)]
    pub ros: crate::args::RosDomainArgs,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `topics --duration-s`.
const LISTEN_S: Real = Real::closed(1e-3, 3600.0, "0.001 to 3600 s");

impl TopicsArgs {
    /// Checks `--duration-s`; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check("--duration-s", LISTEN_S.check(self.duration_s))?;
        self.ros.validate()
    }
}

/// `nrslam topics`.
pub fn topics(args: TopicsArgs) -> Result<()> {
    args.validate()?;
    if args.transport.listen.is_empty()
        && args.transport.connect.is_empty()
        && args.transport.ros_router.is_none()
    {
        print_catalogue();
        return Ok(());
    }
    let listen = flags::seconds("--duration-s", args.duration_s)?;
    flags::deadline("--duration-s", listen)?;
    let session = args.transport.peer_session()?;
    let names: Vec<&'static str> = topics::CATALOGUE.iter().map(|t| t.name).collect();
    let mut inbox = Inbox::subscribe_styled(
        &session,
        &args.transport.namespace,
        &names,
        observer_options(&args.transport)?,
        args.ros.key_style(),
    )?;
    let deadline = flags::deadline("--duration-s", listen)?;
    let mut counts: BTreeMap<&'static str, u64> = BTreeMap::new();
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        if let Some(Delivery::Message { topic, .. }) = inbox.recv_timeout(left)? {
            *counts.entry(topic).or_default() += 1;
        }
    }
    report_drops(&inbox);
    outln!(
        "{:<24} {:<32} messages in {} s",
        "topic",
        "type",
        args.duration_s
    );
    for spec in topics::CATALOGUE {
        if let Some(count) = counts.get(spec.name) {
            outln!("{:<24} {:<32} {count}", spec.name, spec.type_name);
        }
    }
    let _ = session.close().wait();
    Ok(())
}

/// The catalogue as a table: topic, type, durability, description.
fn print_catalogue() {
    outln!(
        "{:<24} {:<32} {:<16} description",
        "topic",
        "type",
        "durability"
    );
    for spec in topics::CATALOGUE {
        let durability = match spec.qos.durability {
            topics::Durability::Volatile => "volatile",
            topics::Durability::TransientLocal => "transient-local",
        };
        outln!(
            "{:<24} {:<32} {:<16} {}",
            spec.name,
            spec.type_name,
            durability,
            spec.description
        );
    }
}
