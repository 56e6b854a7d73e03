//! Topic bags: rosbag2 directories with MCAP storage, written and read once here for every verb
//! and node that needs them (`launch --record`, `bag record/info/play`, the `bag` source node of
//! `launch/replay.toml`).
//!
//! A bag is what `ros2 bag record -s mcap` writes, so standard ROS 2 tools open it, and what they
//! write opens here:
//!
//! - `DIR/metadata.yaml`: `rosbag2_bagfile_information` version 9 (storage `mcap`, per-topic
//!   type, `cdr`, QoS as a list, RIHS01 `type_description_hash`, counts, start and duration, one
//!   `files` entry per storage file), written when the recording finishes; versions 4 to 9 are
//!   read. `custom_data` carries the recorded run's identity (launch, arguments, seed, nrslam
//!   version) and its resolved launch (every node's kind and parameters), so a replay rebuilds
//!   the recorded back end and reproduces its `summary.json`.
//! - `DIR/<DIR name>_0.mcap`, `_1.mcap`, ...: profile `ros2`, one schema per type (`ros2msg`,
//!   dependencies appended), channels with message encoding `cdr`, messages in chunks
//!   (uncompressed, zstd or lz4) with message indexes, chunk indexes and statistics in the
//!   summary. A new file starts when one reaches `--max-bag-size` or `--max-bag-duration`; a
//!   split bag is read file after file in metadata.yaml's order. Log and publish times are the
//!   header stamps (simulated clock, which starts at 1 s, never 0).
//! - Topics of types outside nrslam's catalogue are read, played and written again as raw CDR
//!   with the schema they were recorded with ([`RecordedType`]).
//!
//! Crash safety: the writer cuts a chunk every `chunk_size_bytes` of message data and flushes it
//! to the operating system, so a recorder killed mid-run loses at most the chunk it was filling;
//! [`ReadMode::Recover`] reads such a file (no summary, no end magic, no `metadata.yaml`) up to its
//! last complete chunk, and skips a damaged chunk in the middle of a file, reporting each loss.
//!
//! Reading streams ([`Bag::messages`]): memory holds one chunk at a time, whatever the size of the
//! files, and no length read from a file is trusted before it is checked against the bytes
//! present, nor a compressed chunk's declared size before it is checked against a limit and
//! against what the decompressor produces (see the `reader` and `decompress` module docs).

mod crc;
mod decompress;
mod format;
mod metadata;
mod open;
mod reader;
mod source;
mod writer;

pub use decompress::{Compression, MAX_DECOMPRESSED_CHUNK_BYTES};
pub use metadata::{
    qos_yaml, BagInfo, FileInfo, MetadataFile, Nanoseconds, QosProfile, QosTime, StartingTime,
    TopicMetadata, TopicWithCount,
};
pub use open::{Bag, Messages};
pub use reader::{
    open, BagContents, BagMessage, ChunkLoss, ChunkSpan, ReadMode, ReadReport, RecordedType,
    Summary, TopicSummary, IN_MEMORY_CHUNK_BYTES, MAX_RECORD_BYTES, MAX_SUMMARY_BYTES,
};
pub use source::{BagSource, SourceParams};
pub use writer::{BagWriter, StorageOptions, WriterOptions};

use std::path::PathBuf;

/// `custom_data` key: the launch file of the recorded run.
pub const RUN_LAUNCH_KEY: &str = "nrslam.launch";
/// `custom_data` key: the launch arguments of the recorded run, as a JSON object.
pub const RUN_ARGUMENTS_KEY: &str = "nrslam.arguments";
/// `custom_data` key: the seed of the recorded run.
pub const RUN_SEED_KEY: &str = "nrslam.seed";
/// `custom_data` key: the version of nrslam that recorded the run.
pub const RUN_VERSION_KEY: &str = "nrslam.version";
/// `custom_data` key: the recorded run's resolved launch, every node that ran with its kind and
/// its parameters after argument substitution, includes and command-line overrides, as a TOML
/// document of `[[node]]` tables (`name`, `kind`, `params`): what a replay rebuilds its back end
/// from (`launch/replay.toml`; docs/bags.md).
pub const RUN_NODES_KEY: &str = "nrslam.nodes";
/// Name of the MCAP metadata record that repeats `custom_data` at the start of the file (so a
/// recovered bag still knows its run).
pub const MCAP_METADATA_NAME: &str = "nrslam";

/// A bag could not be written or read. Each message names the path.
#[derive(Debug, thiserror::Error)]
pub enum BagError {
    /// A file operation failed.
    #[error("{path}: {source}")]
    Io {
        /// File or folder.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The folder is not a bag (no metadata.yaml, no MCAP file, ...).
    #[error("{path}: not a bag: {reason}")]
    NotABag {
        /// Folder.
        path: PathBuf,
        /// What is missing.
        reason: String,
    },
    /// The MCAP file or metadata.yaml is damaged.
    #[error("{path}: {reason}")]
    Corrupt {
        /// File.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The bag folder exists and is not empty.
    #[error("{path}: already exists and is not empty (choose a new folder)")]
    Exists {
        /// Folder.
        path: PathBuf,
    },
    /// A message could not be written.
    #[error("{topic}: {reason}")]
    Message {
        /// Topic.
        topic: String,
        /// Why.
        reason: String,
    },
    /// No bag folder was given.
    #[error("no bag folder given (e.g. bag:=DIR on the command line)")]
    NoPath,
    /// A topic asked for is not in the bag.
    #[error("topic {topic} is not in the bag (recorded: {recorded})")]
    UnknownTopic {
        /// Topic asked for.
        topic: String,
        /// Topics the bag holds, comma-separated.
        recorded: String,
    },
}

/// rosbag2's offered QoS profile (metadata.yaml version 9) for a catalogue QoS: reliable,
/// keep-all history, volatile or transient-local durability, automatic liveliness, infinite
/// deadline, lifespan and lease.
pub fn offered_qos_profiles(qos: &nrslam_msgs::topics::Qos) -> Vec<QosProfile> {
    use nrslam_msgs::topics::Durability;
    vec![QosProfile {
        history: "keep_all".into(),
        depth: 0,
        // Every topic of the graph is reliable (see `topics::Qos`).
        reliability: "reliable".into(),
        durability: match qos.durability {
            Durability::TransientLocal => "transient_local",
            Durability::Volatile => "volatile",
        }
        .into(),
        deadline: QosTime::INFINITE,
        lifespan: QosTime::INFINITE,
        liveliness: "automatic".into(),
        liveliness_lease_duration: QosTime::INFINITE,
        avoid_ros_namespace_conventions: false,
    }]
}

/// The `custom_data` of a bag (the recorded run's identity), from metadata.yaml without reading
/// the messages, or, when it has none (a recorder that was killed), from the MCAP file's `nrslam`
/// metadata record at its start (`recover` must then be set).
pub fn custom_data(
    dir: &std::path::Path,
    recover: bool,
) -> Result<std::collections::BTreeMap<String, String>, BagError> {
    let metadata_path = dir.join("metadata.yaml");
    if let Ok(text) = std::fs::read_to_string(&metadata_path) {
        let file = MetadataFile::from_yaml(&text).map_err(|e| BagError::Corrupt {
            path: metadata_path.clone(),
            reason: format!("not rosbag2 metadata: {e}"),
        })?;
        return Ok(file.rosbag2_bagfile_information.custom_data);
    }
    let mode = if recover {
        ReadMode::Recover
    } else {
        ReadMode::Strict
    };
    Ok(Bag::open(dir, mode)?.custom_data().clone())
}
