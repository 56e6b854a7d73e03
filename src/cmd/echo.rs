//! `nrslam echo TOPIC`: the messages of one topic of a live graph, one JSON object per line on
//! standard output, until --count messages, the topic's end-of-stream, or Ctrl-C.

use super::{observer_options, report_drops};
use crate::args::TransportArgs;
use crate::flags::{self, Whole};
use anyhow::{anyhow, Result};
use clap::Args;
use nrslam_msgs::topics;
use nrslam_runtime::receive::{Delivery, Inbox, ReceiveError};
use std::time::Duration;
use zenoh::Wait;

/// `nrslam echo`.
#[derive(Args, Debug)]
pub struct EchoArgs {
    /// Topic name, e.g. /slam/pose.
    pub topic: String,
    /// Stop after this many messages, 0 to 2^64 − 1 (0: until the topic's stream ends or Ctrl-C).
    #[arg(long, default_value_t = 0, value_parser = COUNT.parser::<u64>(), allow_hyphen_values = true)]
    pub count: u64,
    #[command(flatten)]
    pub ros: crate::args::RosDomainArgs,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `echo --count`.
const COUNT: Whole = Whole::new(0, u64::MAX, "0 to 18446744073709551615 messages");

impl EchoArgs {
    /// Every `--count` is allowed (clap refuses what is not a u64).
    pub fn validate(&self) -> Result<()> {
        flags::check("--count", COUNT.check(self.count))?;
        self.ros.validate()
    }
}

/// `nrslam echo`.
pub fn echo(args: EchoArgs) -> Result<()> {
    args.validate()?;
    topics::spec(&args.topic).ok_or_else(|| {
        anyhow!(
            "unknown topic {:?} (known, also under a namespace as /agv1/odom: {})",
            args.topic,
            topics::CATALOGUE
                .iter()
                .map(|t| t.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })?;
    let session = args.transport.peer_session()?;
    let mut inbox = Inbox::subscribe_styled(
        &session,
        &args.transport.namespace,
        // As named: /agv1/odom is not /odom.
        &[topics::intern(&args.topic)],
        observer_options(&args.transport)?,
        args.ros.key_style(),
    )?;
    let mut seen = 0u64;
    let stop = crate::cmd::bag::interrupted();
    while !stop.load(std::sync::atomic::Ordering::SeqCst) {
        match inbox.recv_timeout(Duration::from_millis(200)) {
            Ok(Some(Delivery::End { .. })) | Err(ReceiveError::Closed) => break,
            Ok(Some(Delivery::Message { message, .. })) => {
                outln!("{}", message_json(&message)?);
                seen += 1;
                if args.count > 0 && seen >= args.count {
                    break;
                }
            }
            Ok(None) => {}
            Err(error) => return Err(error.into()),
        }
    }
    report_drops(&inbox);
    let _ = session.close().wait();
    Ok(())
}

/// One message as a JSON object.
fn message_json(message: &nrslam_msgs::Message) -> Result<String> {
    use nrslam_msgs::Message as M;
    Ok(match message {
        M::Clock(m) => serde_json::to_string(m)?,
        M::Odometry(m) => serde_json::to_string(m)?,
        M::PoseStamped(m) => serde_json::to_string(m)?,
        M::OccupancyGrid(m) => serde_json::to_string(m)?,
        M::Detections(m) => serde_json::to_string(m)?,
        M::Keyframe(m) => serde_json::to_string(m)?,
        M::Segments(m) => serde_json::to_string(m)?,
        M::TargetSet(m) => serde_json::to_string(m)?,
        M::MapTargets(m) => serde_json::to_string(m)?,
        M::Metrics(m) => serde_json::to_string(m)?,
        M::RadarEcho(m) => serde_json::to_string(m)?,
        M::RadarSpectrum(m) => serde_json::to_string(m)?,
        M::KeyframePoses(m) => serde_json::to_string(m)?,
        M::AssociationStats(m) => serde_json::to_string(m)?,
        M::DiagnosticArray(m) => serde_json::to_string(m)?,
        M::RadarScan(m) => serde_json::to_string(m)?,
        M::PointCloud2(m) => serde_json::to_string(m)?,
        M::TFMessage(m) => serde_json::to_string(m)?,
        M::Path(m) => serde_json::to_string(m)?,
        M::MarkerArray(m) => serde_json::to_string(m)?,
    })
}
