//! `nrslam bag record|info|play`: rosbag2 bags (metadata.yaml + MCAP) of a live graph, over zenoh.
//! The bag format itself lives in `nrslam_runtime::bag`; this module is the command line around
//! it (flags as `ros2 bag` names them where it has them).

mod info;
mod play;
mod record;
mod selection;

use anyhow::{anyhow, bail, Result};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_msgs::topics;
use nrslam_runtime::bag::{Bag, ReadMode, ReadReport};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

pub use info::InfoArgs;
pub use play::PlayArgs;
pub use record::{RecordArgs, StorageArgs};

/// `nrslam bag`.
#[derive(Args, Debug)]
pub struct BagArgs {
    #[command(subcommand)]
    pub command: BagCommand,
}

/// The bag verbs.
#[derive(Subcommand, Debug)]
pub enum BagCommand {
    /// Record a live graph's topics into a new rosbag2 folder (MCAP), until every recorded topic's
    /// stream has ended, --duration-s has passed, or Ctrl-C.
    Record(RecordArgs),
    /// Print a bag's files, size, duration, start and end, message count, chunk compression and
    /// per-topic type, count and serialization format (what `ros2 bag info` prints), after
    /// reading (streaming) every message and decoding those of catalogue types; --summary-only
    /// reads the MCAP summaries alone.
    Info(InfoArgs),
    /// Publish a bag's messages onto a graph over zenoh with their original timing scaled by
    /// --rate; topics of any type are published as recorded (raw CDR).
    Play(PlayArgs),
}

/// Chunking of a recording.
#[derive(Args, Debug, Clone)]
pub struct ChunkArgs {
    /// Message data per MCAP chunk, in KiB. A chunk is closed and flushed to disk as soon as it
    /// holds this much, so a recorder that is killed loses at most the chunk it was filling (this
    /// much, plus the message that crossed the limit).
    #[arg(long, value_name = "KIB", default_value_t = 768)]
    pub chunk_size_kib: u64,
}

impl ChunkArgs {
    /// Bytes, validated.
    pub fn bytes(&self) -> Result<u64> {
        if !(1..=1024 * 1024).contains(&self.chunk_size_kib) {
            bail!(
                "--chunk-size-kib: {} is out of range (allowed: 1 to 1048576 KiB)",
                self.chunk_size_kib
            );
        }
        Ok(self.chunk_size_kib * 1024)
    }
}

/// `nrslam bag ...`.
pub fn bag(args: BagArgs) -> Result<()> {
    match args.command {
        BagCommand::Record(args) => record::record(args),
        BagCommand::Info(args) => info::info(args),
        BagCommand::Play(args) => play::play(args),
    }
}

/// Catalogue topics named on the command line (default: the whole catalogue), each as named: a
/// topic under a namespace (`/agv1/odom`) keeps its namespace.
pub fn catalogue_topics(names: &[String]) -> Result<Vec<&'static str>> {
    if names.is_empty() {
        return Ok(topics::CATALOGUE.iter().map(|t| t.name).collect());
    }
    names
        .iter()
        .map(|name| {
            if topics::spec(name).is_some() {
                return Ok(topics::intern(name));
            }
            let known: Vec<&str> = topics::CATALOGUE.iter().map(|t| t.name).collect();
            Err(anyhow!(
                "--topics: unknown topic {name:?} (known, also under a namespace as /agv1/odom: \
                 {})",
                known.join(", ")
            ))
        })
        .collect()
}

/// Sets a flag on Ctrl-C (SIGINT) so a recorder, player or `echo` can finish cleanly.
pub(crate) fn interrupted() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    std::thread::spawn(move || {
        if let Ok(runtime) = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
        {
            if runtime.block_on(tokio::signal::ctrl_c()).is_ok() {
                set.store(true, Ordering::SeqCst);
            }
        }
    });
    flag
}

/// Opens the bag at `dir`, strictly or (`recover`) reading a cut-off or damaged one.
pub(crate) fn open_bag(dir: &Path, recover: bool) -> Result<Bag> {
    let mode = if recover {
        ReadMode::Recover
    } else {
        ReadMode::Strict
    };
    Ok(Bag::open(dir, mode)?)
}

/// A progress bar over the bytes of a bag's MCAP files (drawn only on a terminal).
fn byte_progress(bytes: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(bytes);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {bytes}/{total_bytes}  ETA {eta}  {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(what.to_owned());
    bar
}

/// Prints each part of the files that a recovering read skipped.
fn print_losses(bag: &Bag, report: &ReadReport) {
    let paths = bag.mcap_paths();
    for loss in &report.losses {
        match paths.get(loss.file).filter(|_| paths.len() > 1) {
            Some(path) => eprintln!("warning: {}: {loss}", path.display()),
            None => eprintln!("warning: {loss}"),
        }
    }
}
