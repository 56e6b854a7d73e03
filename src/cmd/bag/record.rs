//! `nrslam bag record`: a live graph's catalogue topics into a new bag, with `ros2 bag record`'s
//! chunk compression and file splitting.

use super::{catalogue_topics, interrupted, ChunkArgs};
use crate::args::TransportArgs;
use anyhow::{bail, Result};
use clap::Args;
use nrslam_runtime::bag::{BagWriter, Compression, StorageOptions, WriterOptions};
use nrslam_runtime::receive::{Delivery, Inbox};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// Largest `--max-bag-size` (1 PiB) and longest `--max-bag-duration` (a week, in seconds).
const MAX_BAG_BYTES: u64 = 1 << 50;
const MAX_BAG_DURATION_S: f64 = crate::flags::WEEK_S as f64;
const MAX_BAG_DURATION: crate::flags::Real = crate::flags::Real {
    min: 0.0,
    max: MAX_BAG_DURATION_S,
    open_min: false,
    zero: true,
    allowed: "0 for no limit, or up to 604800 s",
};

/// Chunk compression and file splitting of a recording.
#[derive(Args, Debug, Clone)]
pub struct StorageArgs {
    /// MCAP chunk compression: none (default, as `ros2 bag record`), zstd (what rosbag2's
    /// `zstd_fast`/`zstd_small` storage presets write) or lz4. Every chunk's CRC covers its
    /// uncompressed records.
    #[arg(long, value_name = "none|zstd|lz4", default_value = "none")]
    pub compression: Compression,
    /// Split the bag into files `<name>_0.mcap`, `<name>_1.mcap`, ... of at most about this many
    /// bytes each (a file is closed once its size on disk plus the message bytes of the chunk
    /// being filled reaches it; checked before each message). 0 (default): one file. Otherwise
    /// 1024 to 2^50 bytes.
    #[arg(long, value_name = "BYTES", default_value_t = 0)]
    pub max_bag_size: u64,
    /// Split the bag into a new file once a message's log time is this many seconds past the
    /// first message of the current file. 0 (default): no limit. Otherwise up to 604800 s.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, value_parser = MAX_BAG_DURATION.parser(), allow_hyphen_values = true)]
    pub max_bag_duration: f64,
}

impl StorageArgs {
    /// The writer's options, validated.
    pub fn options(&self) -> Result<StorageOptions> {
        if self.max_bag_size != 0 && !(1024..=MAX_BAG_BYTES).contains(&self.max_bag_size) {
            bail!(
                "--max-bag-size: {} is out of range (allowed: 0 for one file, or 1024 to {MAX_BAG_BYTES} bytes)",
                self.max_bag_size
            );
        }
        let d = self.max_bag_duration;
        if !(d.is_finite() && (0.0..=MAX_BAG_DURATION_S).contains(&d)) {
            bail!(
                "--max-bag-duration: {d} is out of range (allowed: 0 for no limit, or up to {MAX_BAG_DURATION_S} s)"
            );
        }
        Ok(StorageOptions {
            compression: self.compression,
            max_file_bytes: self.max_bag_size,
            max_file_duration_ns: (d * 1e9).round() as u64,
        })
    }
}

/// `nrslam bag record`.
#[derive(Args, Debug)]
pub struct RecordArgs {
    /// Bag folder to create (must not exist, or be empty).
    pub dir: PathBuf,
    /// Topics to record (default: every catalogue topic, see `nrslam topics`).
    #[arg(long, value_name = "TOPIC", num_args = 1..)]
    pub topics: Vec<String>,
    /// Stop after this many wall-clock seconds (0: only when the topics end or on Ctrl-C).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0)]
    pub duration_s: f64,
    #[command(flatten)]
    pub chunk: ChunkArgs,
    #[command(flatten)]
    pub storage: StorageArgs,
    #[command(flatten)]
    pub ros: crate::args::RosDomainArgs,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `nrslam bag record`.
pub fn record(args: RecordArgs) -> Result<()> {
    if !(args.duration_s.is_finite() && (0.0..=MAX_BAG_DURATION_S).contains(&args.duration_s)) {
        bail!(
            "--duration-s: {} is out of range (allowed: 0 for no limit, or up to {MAX_BAG_DURATION_S} s)",
            args.duration_s
        );
    }
    args.ros.validate()?;
    let wanted = catalogue_topics(&args.topics)?;
    let chunk_size_bytes = args.chunk.bytes()?;
    let storage = args.storage.options()?;
    let session = args.transport.peer_session()?;
    let mut inbox = Inbox::subscribe_styled(
        &session,
        &args.transport.namespace,
        &wanted,
        args.transport.inbox_options()?,
        args.ros.key_style(),
    )?;
    let mut writer = BagWriter::create_with(
        &args.dir,
        WriterOptions {
            chunk_size_bytes,
            custom_data: BTreeMap::new(),
        },
        storage,
    )?;
    let stop = interrupted();
    let started = Instant::now();
    let mut seen: Vec<&'static str> = Vec::new();
    let mut ended: Vec<&'static str> = Vec::new();
    eprintln!(
        "recording {} topic(s) into {} (Ctrl-C to stop)",
        wanted.len(),
        args.dir.display()
    );
    loop {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        if args.duration_s > 0.0 && started.elapsed().as_secs_f64() >= args.duration_s {
            break;
        }
        match inbox.recv_timeout(Duration::from_millis(100))? {
            Some(Delivery::End { topic }) => {
                if !ended.contains(&topic) {
                    ended.push(topic);
                }
                if !seen.is_empty() && seen.iter().all(|t| ended.contains(t)) {
                    break;
                }
            }
            Some(Delivery::Message {
                topic,
                message,
                payload,
            }) => {
                if !seen.contains(&topic) {
                    seen.push(topic);
                }
                writer.write_cdr(
                    topic,
                    message.type_name(),
                    message.stamp().as_nanos(),
                    &payload,
                )?;
            }
            None => {}
        }
    }
    for (topic, reason, n) in inbox.drops().iter() {
        eprintln!("warning: {topic}: {n} samples dropped ({reason}), not recorded");
    }
    let info = writer.finish()?;
    let _ = session.close().wait();
    outln!(
        "recorded {} messages on {} topic(s) into {} ({} file(s), compression {})",
        info.message_count,
        info.topics_with_message_count.len(),
        args.dir.display(),
        info.files.len(),
        storage.compression
    );
    Ok(())
}
