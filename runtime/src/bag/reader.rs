//! Reading a bag as a stream: messages in file (recorded) order, one chunk at a time.
//!
//! # Memory bound
//!
//! [`Bag::open`] reads `metadata.yaml`, the MCAP magic and, when the file is complete, its summary
//! section (schemas, channels, statistics, one chunk index per chunk: tens of bytes per chunk,
//! refused past [`MAX_SUMMARY_BYTES`]). [`Bag::messages`] then walks the data section through a
//! 1 MiB buffered file reader and holds at most one chunk at a time: a chunk up to
//! [`IN_MEMORY_CHUNK_BYTES`] is read whole, checked (CRC, then every record's framing) and its
//! messages handed out; a larger one is read twice, once to check its CRC through the buffer, once
//! record by record. So memory does not grow with the file: a 2 GB bag of 768 KiB chunks plays
//! in a few tens of MB. The file is never read whole nor mapped.
//!
//! Every length read from the file (record lengths, a chunk's sizes, string and map lengths) is
//! checked against the bytes actually present (what is left of the file, of the chunk, of the
//! record) before anything is allocated for it; a single record (a message, a schema) may not
//! exceed [`MAX_RECORD_BYTES`]. The `mcap` crate writes bags here but does not read them: its
//! parsers reserve a string's declared length before reading it (see `format.rs`).
//!
//! # Damage
//!
//! [`ReadMode::Strict`] needs `metadata.yaml` and a complete MCAP file (summary, footer, end
//! magic); any damage (a chunk whose CRC does not match, a length that runs past its container, a
//! record that does not parse, a message on an unknown channel, a schema, channel or message
//! outside the chunks of a chunked file, where no CRC covers it, a message count that disagrees
//! with the summary's statistics) is a [`BagError::Corrupt`] naming the byte offset and
//! suggesting `--recover`.
//!
//! [`ReadMode::Recover`] reads what it can. A damaged chunk is skipped whole (a chunk's messages
//! are handed out only once the whole chunk checks, so no message of a damaged chunk is used) and
//! reading resumes at the next good record: the next chunk of the summary's chunk index when the
//! summary is intact, else just past the damaged chunk when its length is plausible and is
//! followed by a record, else at the next position holding a chunk whose header is consistent and
//! whose CRC matches (a scan). Each skip is a [`ChunkLoss`] in the [`ReadReport`]: its byte range,
//! the messages lost when the message indexes tell (from the chunk index, or from the Message
//! Index records that follow the skipped chunk) and why; it is also logged. A file cut off
//! mid-write (a recorder that was killed: no summary, no end magic, no metadata.yaml) loses its
//! last, partial chunk the same way, with [`ReadReport::stopped`] set.
//!
//! Not checked: the data-section CRC (chunk CRCs cover every message; message indexes are only
//! used to count losses).
//!
//! # Compression
//!
//! zstd and lz4 chunks are read whole: the compressed bytes (at most [`MAX_RECORD_BYTES`]) and
//! the decompressed records, whose declared size is checked against
//! [`super::MAX_DECOMPRESSED_CHUNK_BYTES`] and against what the decompressor produces (see the
//! `decompress` module: a decompression bomb is an error after at most the declared size). Their
//! CRC covers the decompressed records. Another compression is damage, as above.

use super::crc::{crc32, Crc32};
use super::format::{self, op, ChunkIndex, CHUNK_FIXED, MAGIC, RECORD_PREFIX};
use super::metadata::BagInfo;
use super::open::Bag;
use super::{BagError, MCAP_METADATA_NAME};
use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Largest single record accepted (a message, a schema, a metadata record), and largest
/// decompressed size a compressed chunk may declare.
pub const MAX_RECORD_BYTES: u64 = 256 << 20;
/// Largest summary section read (chunk indexes and the like; a 2 GB bag of 768 KiB chunks has
/// about 250 KB). A larger one is not used: reading falls back to the data section alone.
pub const MAX_SUMMARY_BYTES: u64 = 64 << 20;
/// Chunks up to this size are read whole; larger ones record by record.
pub const IN_MEMORY_CHUNK_BYTES: u64 = 64 << 20;
/// Buffer of the file reader.
const READ_BUFFER: usize = 1 << 20;

/// How strictly to read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadMode {
    /// metadata.yaml and a complete MCAP file (end magic) are required; any damage is an error.
    Strict,
    /// For a recorder that was killed or a damaged file: metadata.yaml is optional; damaged or
    /// cut-off chunks are skipped whole and reported (see the module docs).
    Recover,
}

/// What the bag recorded about a channel's type: enough to play its messages as raw bytes and to
/// record them again as they were, whether or not the type is in nrslam's catalogue.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RecordedType {
    /// ROS 2 type name (the MCAP schema name), e.g. `radar_msgs/msg/RadarScan`.
    pub type_name: String,
    /// Schema encoding: `ros2msg` or `ros2idl`.
    pub schema_encoding: String,
    /// The schema: the type's definition with its dependencies.
    pub schema: Vec<u8>,
    /// Message encoding: `cdr`.
    pub message_encoding: String,
    /// The channel's metadata (`offered_qos_profiles`, `topic_type_hash`, ...).
    pub channel_metadata: BTreeMap<String, String>,
}

impl RecordedType {
    /// The RIHS01 type hash the recorder wrote in the channel metadata (`topic_type_hash`), if any.
    pub fn type_hash(&self) -> Option<&str> {
        self.channel_metadata
            .get("topic_type_hash")
            .map(String::as_str)
            .filter(|h| !h.is_empty())
    }
}

/// One recorded message.
#[derive(Debug, Clone, PartialEq)]
pub struct BagMessage {
    /// Topic name.
    pub topic: String,
    /// ROS 2 type name.
    pub type_name: String,
    /// Log time (ns, simulated clock).
    pub log_time_ns: u64,
    /// CDR bytes with the encapsulation header.
    pub data: Vec<u8>,
    /// The channel's recorded type and schema (shared by its messages).
    pub recorded: Arc<RecordedType>,
}

impl BagMessage {
    /// Decodes the CDR bytes.
    pub fn decode(&self) -> Result<nrslam_msgs::Message, nrslam_msgs::MessageError> {
        nrslam_msgs::Message::decode(&self.type_name, &self.data)
    }
}

/// Per-topic figures.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicSummary {
    /// Topic name.
    pub name: String,
    /// ROS 2 type.
    pub type_name: String,
    /// Messages (read, or recorded according to the summary).
    pub count: u64,
}

/// Where a chunk ends in the MCAP file and how many messages it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChunkSpan {
    /// Index of its storage file among the bag's ([`Bag::mcap_paths`]).
    pub file: usize,
    /// Byte offset just past the chunk record.
    pub end_byte: u64,
    /// Messages in it.
    pub messages: u64,
}

/// A part of the file skipped by [`ReadMode::Recover`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChunkLoss {
    /// Index of its storage file among the bag's ([`Bag::mcap_paths`]).
    pub file: usize,
    /// First byte skipped (the damaged record's start).
    pub start_byte: u64,
    /// Where reading resumed (the end of the file if it did not).
    pub end_byte: u64,
    /// Messages lost, when the message indexes tell.
    pub messages: Option<u64>,
    /// What was wrong.
    pub reason: String,
}

impl std::fmt::Display for ChunkLoss {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "skipped bytes {}..{} ({} bytes, ",
            self.start_byte,
            self.end_byte,
            self.end_byte.saturating_sub(self.start_byte)
        )?;
        match self.messages {
            Some(n) => write!(f, "{n} messages lost")?,
            None => write!(f, "messages lost unknown")?,
        }
        write!(f, "): {}", self.reason)
    }
}

/// What a pass over the messages found (complete once the stream has ended).
#[derive(Debug, Clone, Default)]
pub struct ReadReport {
    /// Complete chunks read, in file order.
    pub chunks: Vec<ChunkSpan>,
    /// Parts skipped (Recover mode).
    pub losses: Vec<ChunkLoss>,
    /// Why reading stopped before the end of the file (Recover mode), if it did.
    pub stopped: Option<String>,
    /// Topics of the messages read (all of them, also those a topic filter left out), in order of
    /// first appearance, with counts.
    pub topics: Vec<TopicSummary>,
    /// Messages handed out.
    pub messages: u64,
    /// First and last log time (ns) of the messages read.
    pub time_range_ns: Option<(u64, u64)>,
    /// The MCAP `nrslam` metadata record, if one was read.
    pub custom_data: BTreeMap<String, String>,
    /// Chunk compressions met (`""` for uncompressed chunks, `zstd`, `lz4`), in order of first
    /// appearance.
    pub compressions: Vec<String>,
}

impl ReadReport {
    /// Bytes of the MCAP file up to the end of the last complete chunk.
    pub fn complete_bytes(&self) -> u64 {
        self.chunks.last().map_or(0, |c| c.end_byte)
    }

    /// Messages known lost (losses whose count is unknown count as 0).
    pub fn lost_messages(&self) -> u64 {
        self.losses.iter().filter_map(|l| l.messages).sum()
    }

    fn count(&mut self, topic: &str, type_name: &str, log_time: u64) {
        match self.topics.iter_mut().find(|t| t.name == topic) {
            Some(t) => t.count += 1,
            None => self.topics.push(TopicSummary {
                name: topic.to_owned(),
                type_name: type_name.to_owned(),
                count: 1,
            }),
        }
        self.time_range_ns = Some(match self.time_range_ns {
            None => (log_time, log_time),
            Some((a, b)) => (a.min(log_time), b.max(log_time)),
        });
    }
}

/// The MCAP summary section, when present and intact.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Topics in channel order, with the statistics' counts (0 without statistics).
    pub topics: Vec<TopicSummary>,
    /// Messages according to the statistics record.
    pub message_count: Option<u64>,
    /// First and last log time according to the statistics record.
    pub time_range_ns: Option<(u64, u64)>,
    /// Chunks according to the chunk indexes.
    pub chunk_count: usize,
    /// Chunk compressions according to the chunk indexes (`""`: uncompressed), each once.
    pub compressions: Vec<String>,
    channels: HashMap<u16, ChannelInfo>,
    chunk_indexes: Vec<ChunkIndex>,
    metadata: Vec<(u64, u64, String)>,
    start: u64,
}

/// What was read from a bag folder, every message in memory: a convenience for tests and small
/// bags ([`open`]). [`Bag::messages`] streams instead.
#[derive(Debug, Clone)]
pub struct BagContents {
    /// The folder.
    pub dir: PathBuf,
    /// The MCAP file read.
    pub mcap_path: PathBuf,
    /// metadata.yaml, when present.
    pub metadata: Option<BagInfo>,
    /// Messages in file order.
    pub messages: Vec<BagMessage>,
    /// Topics in order of first appearance, with counts of the messages read.
    pub topics: Vec<TopicSummary>,
    /// Complete chunks read, in file order.
    pub chunks: Vec<ChunkSpan>,
    /// Parts skipped (Recover mode).
    pub losses: Vec<ChunkLoss>,
    /// The recorded run's identity (metadata.yaml `custom_data`, or the MCAP metadata record).
    pub custom_data: BTreeMap<String, String>,
    /// Size of the MCAP file (bytes).
    pub file_bytes: u64,
    /// Why reading stopped before the end of the file (Recover mode), if it did.
    pub stopped: Option<String>,
}

impl BagContents {
    /// Bytes of the MCAP file up to the end of the last complete chunk (what a recovery keeps).
    pub fn complete_bytes(&self) -> u64 {
        self.chunks.last().map_or(0, |c| c.end_byte)
    }

    /// Messages in the complete chunks that end at or before byte `end` of the MCAP file: what
    /// a recovery of the file cut at `end` keeps.
    pub fn messages_in_chunks_ending_by(&self, end: u64) -> u64 {
        let complete = self.chunks.iter().filter(|c| c.end_byte <= end);
        complete.map(|c| c.messages).sum()
    }

    /// First and last log time (ns), if any message was read.
    pub fn time_range_ns(&self) -> Option<(u64, u64)> {
        let first = self.messages.iter().map(|m| m.log_time_ns).min()?;
        let last = self.messages.iter().map(|m| m.log_time_ns).max()?;
        Some((first, last))
    }

    /// Keeps only the messages of `topics` (all if empty); a topic that is not in the bag is an
    /// error.
    pub fn retain_topics(&mut self, topics: &[String]) -> Result<(), BagError> {
        check_topics(topics, &self.topics)?;
        if topics.is_empty() {
            return Ok(());
        }
        self.messages.retain(|m| topics.contains(&m.topic));
        self.topics.retain(|t| topics.contains(&t.name));
        Ok(())
    }
}

/// Every name of `wanted` must be one of `recorded`.
pub(crate) fn check_topics(wanted: &[String], recorded: &[TopicSummary]) -> Result<(), BagError> {
    for topic in wanted {
        if !recorded.iter().any(|t| &t.name == topic) {
            return Err(BagError::UnknownTopic {
                topic: topic.clone(),
                recorded: recorded
                    .iter()
                    .map(|t| t.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        }
    }
    Ok(())
}

/// Reads the bag folder `dir` (or, if `dir` is an `.mcap` file, that file alone) with every
/// message in memory. Prefer [`Bag::open`] and [`Bag::messages`] for anything large.
pub fn open(dir: &Path, mode: ReadMode) -> Result<BagContents, BagError> {
    Bag::open(dir, mode)?.read_all()
}

#[derive(Debug, Clone)]
struct ChannelInfo {
    topic: String,
    recorded: Arc<RecordedType>,
}

/// A schema record's content, by id, until channels refer to it.
#[derive(Debug, Clone)]
struct SchemaInfo {
    name: String,
    encoding: String,
    data: Vec<u8>,
}

impl SchemaInfo {
    fn from_record(s: &format::Schema<'_>) -> Self {
        Self {
            name: s.name.to_owned(),
            encoding: s.encoding.to_owned(),
            data: s.data.to_vec(),
        }
    }
}

fn channel_info(ch: format::Channel<'_>, schema: &SchemaInfo) -> ChannelInfo {
    ChannelInfo {
        topic: ch.topic.to_owned(),
        recorded: Arc::new(RecordedType {
            type_name: schema.name.clone(),
            schema_encoding: schema.encoding.clone(),
            schema: schema.data.clone(),
            message_encoding: ch.message_encoding.to_owned(),
            channel_metadata: ch.metadata,
        }),
    }
}

/// Damage found at a byte offset.
#[derive(Debug)]
struct Damage {
    offset: u64,
    reason: String,
}

enum Fail {
    Damage(Damage),
    Io(std::io::Error),
}

impl From<Damage> for Fail {
    fn from(d: Damage) -> Self {
        Fail::Damage(d)
    }
}

fn damage(offset: u64, reason: impl Into<String>) -> Fail {
    Fail::Damage(Damage {
        offset,
        reason: reason.into(),
    })
}

/// The MCAP file behind a buffered reader, with its length fixed when opened.
struct Source {
    reader: BufReader<File>,
    pos: u64,
    len: u64,
}

impl Source {
    fn open(path: &Path) -> std::io::Result<Self> {
        let file = File::open(path)?;
        let len = file.metadata()?.len();
        Ok(Self {
            reader: BufReader::with_capacity(READ_BUFFER, file),
            pos: 0,
            len,
        })
    }

    fn seek(&mut self, offset: u64) -> std::io::Result<()> {
        if offset != self.pos {
            let delta = i64::try_from(i128::from(offset) - i128::from(self.pos))
                .map_err(|_| std::io::Error::other("seek out of range"))?;
            self.reader.seek_relative(delta)?;
            self.pos = offset;
        }
        Ok(())
    }

    /// Reads `buf.len()` bytes at `offset`; bytes missing (the file shrank) are damage there.
    fn read_at(&mut self, offset: u64, buf: &mut [u8]) -> Result<(), Fail> {
        if offset.saturating_add(buf.len() as u64) > self.len {
            return Err(damage(
                offset,
                format!(
                    "{} bytes needed, {} left in the file (cut off?)",
                    buf.len(),
                    self.len.saturating_sub(offset)
                ),
            ));
        }
        self.seek(offset).map_err(Fail::Io)?;
        match self.reader.read_exact(buf) {
            Ok(()) => {
                self.pos += buf.len() as u64;
                Ok(())
            }
            Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
                // Where the reader stands is unknown now; force a real seek next time.
                self.pos = u64::MAX;
                let _ = self.reader.seek_relative(0);
                Err(damage(
                    offset,
                    "the file is shorter than when it was opened",
                ))
            }
            Err(e) => Err(Fail::Io(e)),
        }
    }

    /// Reads `n` bytes at `offset` into `buf` (resized), after checking they are in the file.
    fn read_into(&mut self, offset: u64, n: u64, buf: &mut Vec<u8>) -> Result<(), Fail> {
        if offset.saturating_add(n) > self.len {
            return Err(damage(
                offset,
                format!(
                    "{n} bytes declared, {} left in the file",
                    self.len.saturating_sub(offset)
                ),
            ));
        }
        buf.clear();
        buf.resize(n as usize, 0);
        self.read_at(offset, buf)
    }

    /// Opcode and length of the record at `offset`.
    fn record_header(&mut self, offset: u64) -> Result<(u8, u64), Fail> {
        let mut head = [0u8; RECORD_PREFIX as usize];
        self.read_at(offset, &mut head)?;
        let mut len = [0u8; 8];
        len.copy_from_slice(&head[1..]);
        Ok((head[0], u64::from_le_bytes(len)))
    }

    /// Length of the record at `offset` after checking it ends by `limit`.
    fn record_within(&mut self, offset: u64, limit: u64) -> Result<(u8, u64), Fail> {
        let (opcode, len) = self.record_header(offset)?;
        let end = offset
            .checked_add(RECORD_PREFIX)
            .and_then(|o| o.checked_add(len));
        match end {
            Some(end) if end <= limit => Ok((opcode, len)),
            _ => Err(damage(
                offset,
                format!(
                    "record 0x{opcode:02x} declares {len} bytes, {} left{}",
                    limit.saturating_sub(offset + RECORD_PREFIX),
                    if limit == self.len {
                        " in the file (cut off, or a garbage length)"
                    } else {
                        ""
                    }
                ),
            )),
        }
    }
}

/// One MCAP file of a bag, opened: its length, its summary when intact (or why not).
#[derive(Debug, Clone)]
pub(super) struct FilePart {
    pub path: PathBuf,
    pub bytes: u64,
    pub summary: Option<Summary>,
    pub note: Option<String>,
}

impl FilePart {
    /// Opens `path`: checks the MCAP magic and reads the summary section (Strict mode: it must be
    /// intact; Recover mode: a damaged or missing one is noted and not used). Also returns the
    /// `nrslam` metadata record, if the file has one.
    pub fn open(
        path: &Path,
        mode: ReadMode,
    ) -> Result<(Self, Option<BTreeMap<String, String>>), BagError> {
        let io = |source| BagError::Io {
            path: path.to_owned(),
            source,
        };
        let mut src = Source::open(path).map_err(io)?;
        let mut magic = [0u8; 8];
        if src.read_at(0, &mut magic).is_err() || &magic != MAGIC {
            return Err(BagError::Corrupt {
                path: path.to_owned(),
                reason: "not an MCAP file (no MCAP magic at its start)".into(),
            });
        }
        let (summary, note) = match read_summary(&mut src) {
            Ok(Ok(summary)) => (Some(summary), None),
            Ok(Err(note)) => (None, Some(note)),
            Err(Fail::Io(e)) => return Err(io(e)),
            Err(Fail::Damage(d)) if mode == ReadMode::Strict => {
                return Err(corrupt(path, mode, &d))
            }
            Err(Fail::Damage(d)) => (None, Some(format!("at byte {}: {}", d.offset, d.reason))),
        };
        let custom = first_metadata_record(&mut src, summary.as_ref());
        Ok((
            Self {
                path: path.to_owned(),
                bytes: src.len,
                summary,
                note,
            },
            custom,
        ))
    }

    /// Streams this file's messages.
    pub fn messages(
        &self,
        mode: ReadMode,
        filter: Option<Vec<String>>,
        count_only: bool,
        in_memory_chunk_bytes: u64,
    ) -> Result<FileMessages, BagError> {
        let src = Source::open(&self.path).map_err(|source| BagError::Io {
            path: self.path.clone(),
            source,
        })?;
        let (channels, chunk_indexes, data_end, expected) = match &self.summary {
            Some(s) => (
                s.channels.clone(),
                s.chunk_indexes.clone(),
                s.start,
                s.message_count,
            ),
            None => (HashMap::new(), Vec::new(), src.len, None),
        };
        Ok(FileMessages {
            src,
            path: self.path.clone(),
            mode,
            filter,
            count_only,
            schemas: HashMap::new(),
            channels,
            chunk_indexes,
            data_end,
            expected_messages: expected,
            seen_messages: 0,
            pos: 8,
            chunk: None,
            done: false,
            open_loss: None,
            in_memory_chunk_bytes,
            scratch: Vec::new(),
            partial: 0,
            chunked: self.summary.as_ref().is_some_and(|s| s.chunk_count > 0),
            report: ReadReport::default(),
        })
    }
}

impl Summary {
    /// The figures of several files' summaries together (per-file indexes left out).
    pub(super) fn merged<'a>(parts: impl IntoIterator<Item = &'a Summary>) -> Summary {
        let mut out = Summary {
            topics: Vec::new(),
            message_count: Some(0),
            time_range_ns: None,
            chunk_count: 0,
            compressions: Vec::new(),
            channels: HashMap::new(),
            chunk_indexes: Vec::new(),
            metadata: Vec::new(),
            start: 0,
        };
        for s in parts {
            for topic in &s.topics {
                match out.topics.iter_mut().find(|t| t.name == topic.name) {
                    Some(t) => t.count += topic.count,
                    None => out.topics.push(topic.clone()),
                }
            }
            out.message_count = out.message_count.zip(s.message_count).map(|(a, b)| a + b);
            out.time_range_ns = match (out.time_range_ns, s.time_range_ns) {
                (Some((a, b)), Some((c, d))) => Some((a.min(c), b.max(d))),
                (a, b) => a.or(b),
            };
            out.chunk_count += s.chunk_count;
            for c in &s.compressions {
                if !out.compressions.contains(c) {
                    out.compressions.push(c.clone());
                }
            }
        }
        out
    }
}

/// A chunk's records (uncompressed) against the CRC its header records (0: none recorded).
fn check_crc(at: u64, header: &format::ChunkHeader, records: &[u8]) -> Result<(), Fail> {
    check_crc_with(at, header, || Ok(crc32(records)))
}

/// As [`check_crc`], the records' CRC from `crc`, called only when the header records one (for
/// records streamed from the file rather than held in memory).
fn check_crc_with(
    at: u64,
    header: &format::ChunkHeader,
    crc: impl FnOnce() -> Result<u32, Fail>,
) -> Result<(), Fail> {
    if header.uncompressed_crc == 0 {
        return Ok(());
    }
    let crc = crc()?;
    if crc != header.uncompressed_crc {
        return Err(damage(
            at,
            format!(
                "chunk CRC mismatch (recorded {:08x}, computed {crc:08x})",
                header.uncompressed_crc
            ),
        ));
    }
    Ok(())
}

fn corrupt(path: &Path, mode: ReadMode, d: &Damage) -> BagError {
    BagError::Corrupt {
        path: path.to_owned(),
        reason: match mode {
            ReadMode::Strict => format!(
                "damaged at byte {}: {} (a recording cut off or damaged? try --recover, which skips damaged chunks)",
                d.offset, d.reason
            ),
            ReadMode::Recover => format!("damaged at byte {}: {}", d.offset, d.reason),
        },
    }
}

/// Sorts the summary's chunk indexes by offset and checks that they neither overlap nor leave the
/// data section (which ends where the summary starts).
fn check_chunk_indexes(chunk_indexes: &mut [ChunkIndex], summary_start: u64) -> Result<(), Fail> {
    chunk_indexes.sort_by_key(|c| c.start_offset);
    let mut previous_end = 8;
    for index in chunk_indexes.iter() {
        let end = index.start_offset.checked_add(index.length);
        if index.start_offset < previous_end || end.is_none_or(|e| e > summary_start) {
            return Err(damage(
                summary_start,
                format!(
                    "summary: chunk index {}+{} overlaps or leaves the data section",
                    index.start_offset, index.length
                ),
            ));
        }
        previous_end = end.unwrap_or(summary_start);
    }
    Ok(())
}

/// The channels by id, and one [`TopicSummary`] per topic (channels of one topic summed), in
/// channel id order, with the statistics' message counts.
fn topic_summaries(
    mut channels: Vec<(u16, ChannelInfo)>,
    statistics: Option<&format::Statistics>,
) -> (HashMap<u16, ChannelInfo>, Vec<TopicSummary>) {
    channels.sort_by_key(|c| c.0);
    let mut infos = HashMap::new();
    let mut topics: Vec<TopicSummary> = Vec::new();
    for (id, info) in channels {
        let (topic, type_name) = (info.topic.clone(), info.recorded.type_name.clone());
        let count = statistics.map_or(0, |s| {
            s.channel_message_counts
                .iter()
                .filter(|(c, _)| *c == id)
                .map(|(_, n)| *n)
                .sum()
        });
        match topics.iter_mut().find(|t| t.name == topic) {
            Some(t) => t.count += count,
            None => topics.push(TopicSummary {
                name: topic.clone(),
                type_name: type_name.clone(),
                count,
            }),
        }
        infos.insert(id, info);
    }
    (infos, topics)
}

/// The summary section through the footer at the end of the file: `Ok(Err(note))` when there is
/// none to use, damage when the end of the file is not a valid footer and end magic.
fn read_summary(src: &mut Source) -> Result<Result<Summary, String>, Fail> {
    let tail = RECORD_PREFIX + format::FOOTER_BODY + 8;
    let len = src.len;
    if len < 8 + tail {
        return Err(damage(len, "no footer (the file is cut off)"));
    }
    let footer_at = len - tail;
    let mut end = [0u8; (RECORD_PREFIX + format::FOOTER_BODY + 8) as usize];
    src.read_at(footer_at, &mut end)?;
    if &end[end.len() - 8..] != MAGIC {
        return Err(damage(
            len - 8,
            "no MCAP magic at the end (the file is cut off)",
        ));
    }
    if end[0] != op::FOOTER || end[1..9] != format::FOOTER_BODY.to_le_bytes() {
        return Err(damage(footer_at, "no footer record before the end magic"));
    }
    let (summary_start, _, summary_crc) =
        format::footer(&end[9..29]).map_err(|e| damage(footer_at, e))?;
    if summary_start == 0 {
        return Ok(Err("the file has no summary section".into()));
    }
    if !(8..=footer_at).contains(&summary_start) {
        return Err(damage(
            footer_at,
            format!("footer points the summary at byte {summary_start}, outside the file"),
        ));
    }
    let section_len = footer_at - summary_start;
    if section_len > MAX_SUMMARY_BYTES {
        return Ok(Err(format!(
            "summary section of {section_len} bytes is over the {MAX_SUMMARY_BYTES}-byte limit"
        )));
    }
    let mut section = Vec::new();
    src.read_into(summary_start, section_len, &mut section)?;
    if summary_crc != 0 {
        let mut crc = Crc32::default();
        crc.update(&section);
        crc.update(&end[..9 + 16]);
        if crc.finish() != summary_crc {
            return Err(damage(summary_start, "summary section CRC mismatch"));
        }
    }
    let mut schemas: HashMap<u16, SchemaInfo> = HashMap::new();
    let mut channels: Vec<(u16, ChannelInfo)> = Vec::new();
    let mut statistics = None;
    let mut chunk_indexes = Vec::new();
    let mut metadata = Vec::new();
    let mut c = format::Cursor::new(&section);
    while !c.is_empty() {
        let at = summary_start + c.position() as u64;
        let bad = |e: String| damage(at, format!("summary: {e}"));
        let opcode = c.u8("record opcode").map_err(bad)?;
        let len = c.u64("record length").map_err(bad)?;
        let body = c.take(len, "summary record").map_err(bad)?;
        match opcode {
            op::SCHEMA => {
                let s = format::schema(body).map_err(bad)?;
                schemas.insert(s.id, SchemaInfo::from_record(&s));
            }
            op::CHANNEL => {
                let ch = format::channel(body).map_err(bad)?;
                let (id, topic) = (ch.id, ch.topic.to_owned());
                let schema = schemas.get(&ch.schema_id).ok_or_else(|| {
                    damage(
                        summary_start,
                        format!("summary: channel {topic} has no schema"),
                    )
                })?;
                channels.push((id, channel_info(ch, schema)));
            }
            op::STATISTICS => statistics = Some(format::statistics(body).map_err(bad)?),
            op::CHUNK_INDEX => chunk_indexes.push(format::chunk_index(body).map_err(bad)?),
            op::METADATA_INDEX => metadata.push(format::metadata_index(body).map_err(bad)?),
            _ => {}
        }
    }
    check_chunk_indexes(&mut chunk_indexes, summary_start)?;
    let (infos, topics) = topic_summaries(channels, statistics.as_ref());
    Ok(Ok(Summary {
        topics,
        message_count: statistics.as_ref().map(|s| s.message_count),
        time_range_ns: statistics
            .as_ref()
            .filter(|s| s.message_count > 0)
            .map(|s| (s.message_start_time, s.message_end_time)),
        chunk_count: chunk_indexes.len(),
        compressions: chunk_indexes.iter().fold(Vec::new(), |mut out, c| {
            if !out.contains(&c.compression) {
                out.push(c.compression.clone());
            }
            out
        }),
        channels: infos,
        chunk_indexes,
        metadata,
        start: summary_start,
    }))
}

/// The `nrslam` metadata record: through the summary's metadata index, else the first one among
/// the records before the first chunk (where the writer puts it).
fn first_metadata_record(
    src: &mut Source,
    summary: Option<&Summary>,
) -> Option<BTreeMap<String, String>> {
    let mut body = Vec::new();
    let mut read = |src: &mut Source, offset: u64| -> Option<BTreeMap<String, String>> {
        let (opcode, len) = src.record_within(offset, src.len).ok()?;
        if opcode != op::METADATA || len > MAX_RECORD_BYTES {
            return None;
        }
        src.read_into(offset + RECORD_PREFIX, len, &mut body).ok()?;
        let (name, map) = format::metadata(&body).ok()?;
        (name == MCAP_METADATA_NAME).then_some(map)
    };
    if let Some(summary) = summary {
        let (offset, _, _) = summary
            .metadata
            .iter()
            .find(|(_, _, name)| name == MCAP_METADATA_NAME)?;
        return read(src, *offset);
    }
    let mut offset = 8;
    for _ in 0..64 {
        let (opcode, len) = src.record_within(offset, src.len).ok()?;
        match opcode {
            op::METADATA => {
                if let Some(map) = read(src, offset) {
                    return Some(map);
                }
            }
            op::CHUNK | op::DATA_END | op::FOOTER => return None,
            _ => {}
        }
        offset += RECORD_PREFIX + len;
    }
    None
}

/// A chunk being handed out.
enum OpenChunk {
    /// Read whole and checked: message records as (channel, log time, data range in `buf`).
    Memory {
        buf: Vec<u8>,
        messages: Vec<(u16, u64, std::ops::Range<usize>)>,
        next: usize,
    },
    /// Too large to hold: its CRC is checked, its records are read one by one.
    File {
        start: u64,
        next: u64,
        end: u64,
        end_byte: u64,
        count: u64,
    },
}

/// The messages of one MCAP file, streamed in file order (see the module docs); an error ends the
/// stream. [`FileMessages::report`] tells what was read, skipped and lost.
pub(super) struct FileMessages {
    src: Source,
    path: PathBuf,
    mode: ReadMode,
    filter: Option<Vec<String>>,
    count_only: bool,
    schemas: HashMap<u16, SchemaInfo>,
    channels: HashMap<u16, ChannelInfo>,
    chunk_indexes: Vec<ChunkIndex>,
    data_end: u64,
    expected_messages: Option<u64>,
    seen_messages: u64,
    pos: u64,
    chunk: Option<OpenChunk>,
    done: bool,
    open_loss: Option<usize>,
    in_memory_chunk_bytes: u64,
    scratch: Vec<u8>,
    /// Messages already handed out from the chunk being read record by record.
    partial: u64,
    /// Whether the file has chunks (a chunk was met, or the summary indexes some): schemas,
    /// channels and messages are then taken from inside chunks only.
    chunked: bool,
    report: ReadReport,
}

/// What the top level of the data section yielded.
enum Step {
    Message(BagMessage),
    Continue,
    End,
}

impl Iterator for FileMessages {
    type Item = Result<BagMessage, BagError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if self.done {
                return None;
            }
            let step = match self.chunk.take() {
                Some(chunk) => self.chunk_step(chunk),
                None => self.top_level_step(),
            };
            match step {
                Ok(Step::Message(message)) => return Some(Ok(message)),
                Ok(Step::Continue) => {}
                Ok(Step::End) => {
                    self.done = true;
                    return self.final_check().err().map(Err);
                }
                Err(Fail::Io(source)) => {
                    self.done = true;
                    return Some(Err(BagError::Io {
                        path: self.path.clone(),
                        source,
                    }));
                }
                Err(Fail::Damage(d)) => {
                    self.chunk = None;
                    if let Err(e) = self.recover_from(d) {
                        self.done = true;
                        return Some(Err(e));
                    }
                }
            }
        }
    }
}

impl FileMessages {
    /// The report, once done.
    pub fn into_report(self) -> ReadReport {
        self.report
    }

    /// Bytes of the file passed so far (for progress).
    pub fn position(&self) -> u64 {
        self.pos
    }

    fn wanted(&self, topic: &str) -> bool {
        !self.count_only
            && self
                .filter
                .as_ref()
                .is_none_or(|f| f.iter().any(|t| t == topic))
    }

    /// Counts a message and makes it, if it is wanted.
    fn take_message(&mut self, channel: u16, log_time: u64, data: &[u8]) -> Option<BagMessage> {
        let info = self.channels.get(&channel)?;
        self.seen_messages += 1;
        self.report
            .count(&info.topic, &info.recorded.type_name, log_time);
        if !self.wanted(&info.topic) {
            return None;
        }
        self.report.messages += 1;
        Some(BagMessage {
            topic: info.topic.clone(),
            type_name: info.recorded.type_name.clone(),
            log_time_ns: log_time,
            data: data.to_vec(),
            recorded: info.recorded.clone(),
        })
    }

    fn register_schema(&mut self, body: &[u8]) -> Result<(), String> {
        let s = format::schema(body)?;
        self.schemas.insert(s.id, SchemaInfo::from_record(&s));
        Ok(())
    }

    fn register_channel(&mut self, body: &[u8]) -> Result<(), String> {
        let ch = format::channel(body)?;
        if self.channels.contains_key(&ch.id) {
            return Ok(());
        }
        let schema = self
            .schemas
            .get(&ch.schema_id)
            .ok_or_else(|| format!("channel {} has no schema", ch.topic))?;
        let id = ch.id;
        let info = channel_info(ch, schema);
        self.channels.insert(id, info);
        Ok(())
    }

    fn top_level_step(&mut self) -> Result<Step, Fail> {
        let at = self.pos;
        if at >= self.data_end {
            if self.mode == ReadMode::Recover && self.data_end == self.src.len {
                self.report.stopped = Some("file ends without a summary".into());
            }
            return if self.mode == ReadMode::Strict {
                Err(damage(
                    at,
                    "the data section ends without a Data End record",
                ))
            } else {
                Ok(Step::End)
            };
        }
        let (opcode, len) = self.src.record_within(at, self.data_end)?;
        let next = at + RECORD_PREFIX + len;
        let body_at = at + RECORD_PREFIX;
        let bounded = |len: u64| {
            if len > MAX_RECORD_BYTES {
                Err(damage(
                    at,
                    format!("record 0x{opcode:02x} of {len} bytes is over the {MAX_RECORD_BYTES}-byte limit"),
                ))
            } else {
                Ok(())
            }
        };
        match opcode {
            op::CHUNK => {
                self.chunked = true;
                let chunk = self.open_chunk(at, len)?;
                self.open_loss = None;
                self.pos = next;
                self.chunk = Some(chunk);
                return Ok(Step::Continue);
            }
            op::DATA_END | op::FOOTER => return Ok(Step::End),
            op::SCHEMA | op::CHANNEL | op::MESSAGE if self.chunked => {
                // Outside chunks these records have no CRC: in a chunked file one here is a damaged
                // record (a Message Index whose opcode lost a bit reads as a Message).
                return Err(damage(
                    at,
                    format!("record 0x{opcode:02x} outside the chunks of a chunked file"),
                ));
            }
            op::SCHEMA | op::CHANNEL | op::MESSAGE | op::METADATA | op::MESSAGE_INDEX => {
                bounded(len)?;
                let mut body = std::mem::take(&mut self.scratch);
                self.src.read_into(body_at, len, &mut body)?;
                let result = self.top_level_record(opcode, &body);
                self.scratch = body;
                let message = result.map_err(|e| damage(at, e))?;
                self.pos = next;
                if let Some(message) = message {
                    return Ok(Step::Message(message));
                }
            }
            0 => return Err(damage(at, "record with opcode 0x00")),
            _ => self.pos = next,
        }
        Ok(Step::Continue)
    }

    fn top_level_record(&mut self, opcode: u8, body: &[u8]) -> Result<Option<BagMessage>, String> {
        match opcode {
            op::SCHEMA => self.register_schema(body)?,
            op::CHANNEL => self.register_channel(body)?,
            op::MESSAGE => {
                let m = format::message(body)?;
                if !self.channels.contains_key(&m.channel_id) {
                    return Err(format!("message on unknown channel {}", m.channel_id));
                }
                return Ok(self.take_message(m.channel_id, m.log_time, m.data));
            }
            op::METADATA => {
                let (name, map) = format::metadata(body)?;
                if name == MCAP_METADATA_NAME {
                    self.report.custom_data = map;
                }
            }
            op::MESSAGE_INDEX => {
                let entries = format::message_index_entries(body)?;
                if let Some(loss) = self.open_loss.and_then(|i| self.report.losses.get_mut(i)) {
                    loss.messages = Some(loss.messages.unwrap_or(0) + entries);
                }
            }
            _ => {}
        }
        Ok(None)
    }

    /// Reads and checks the chunk record at `at` (body of `len` bytes, inside the data section).
    fn open_chunk(&mut self, at: u64, len: u64) -> Result<OpenChunk, Fail> {
        let body_at = at + RECORD_PREFIX;
        let end_byte = body_at + len;
        let header = self.chunk_header(at, len)?;
        if !self.report.compressions.contains(&header.compression) {
            self.report.compressions.push(header.compression.clone());
        }
        let records_at = body_at + header.header_len;
        let records_len = header.records_len;
        if !header.compression.is_empty() {
            let buf = self.decompressed_chunk(at, &header)?;
            return self.parse_chunk(at, end_byte, buf);
        }
        if records_len > self.in_memory_chunk_bytes {
            check_crc_with(at, &header, || self.crc_of(records_at, records_len))?;
            return Ok(OpenChunk::File {
                start: at,
                next: records_at,
                end: records_at + records_len,
                end_byte,
                count: 0,
            });
        }
        let mut buf = Vec::new();
        self.src.read_into(records_at, records_len, &mut buf)?;
        check_crc(at, &header, &buf)?;
        self.parse_chunk(at, end_byte, buf)
    }

    /// A compressed chunk's records: the compressed bytes (at most [`MAX_RECORD_BYTES`]) read
    /// whole, decompressed within the declared size (see the `decompress` module), CRC checked.
    fn decompressed_chunk(
        &mut self,
        at: u64,
        header: &format::ChunkHeader,
    ) -> Result<Vec<u8>, Fail> {
        let records_at = at + RECORD_PREFIX + header.header_len;
        if header.records_len > MAX_RECORD_BYTES {
            return Err(damage(
                at,
                format!(
                    "compressed chunk of {} bytes is over the {MAX_RECORD_BYTES}-byte limit",
                    header.records_len
                ),
            ));
        }
        let mut compressed = std::mem::take(&mut self.scratch);
        let read = self
            .src
            .read_into(records_at, header.records_len, &mut compressed);
        let mut buf = Vec::new();
        let result = read.and_then(|()| {
            super::decompress::decompress(
                &header.compression,
                &compressed,
                header.uncompressed_size,
                &mut buf,
            )
            .map_err(|e| damage(at, e))
        });
        compressed.clear();
        self.scratch = compressed;
        result?;
        check_crc(at, header, &buf)?;
        Ok(buf)
    }

    /// Parses a chunk's records (read whole and checked) and makes it the open chunk.
    fn parse_chunk(&mut self, at: u64, end_byte: u64, buf: Vec<u8>) -> Result<OpenChunk, Fail> {
        // Every record must parse before any message is handed out; schemas and channels are
        // taken only then.
        let mut schemas = Vec::new();
        let mut channels = Vec::new();
        let mut messages = Vec::new();
        let mut c = format::Cursor::new(&buf);
        while !c.is_empty() {
            let inner = c.position();
            let fail = |e: String| damage(at, format!("record at byte {inner} of the chunk: {e}"));
            let opcode = c.u8("record opcode").map_err(fail)?;
            let len = c.u64("record length").map_err(fail)?;
            let body_start = c.position();
            let body = c.take(len, "record").map_err(fail)?;
            match opcode {
                op::SCHEMA => {
                    let s = format::schema(body).map_err(fail)?;
                    schemas.push((s.id, SchemaInfo::from_record(&s)));
                }
                op::CHANNEL => {
                    let ch = format::channel(body).map_err(fail)?;
                    let known = self.channels.contains_key(&ch.id)
                        || channels.iter().any(|(id, _)| *id == ch.id);
                    if !known {
                        let schema = schemas
                            .iter()
                            .rev()
                            .find(|(id, _)| *id == ch.schema_id)
                            .map(|(_, n)| n)
                            .or_else(|| self.schemas.get(&ch.schema_id))
                            .ok_or_else(|| fail(format!("channel {} has no schema", ch.topic)))?;
                        let id = ch.id;
                        let info = channel_info(ch, schema);
                        channels.push((id, info));
                    }
                }
                op::MESSAGE => {
                    let m = format::message(body).map_err(fail)?;
                    let known = self.channels.contains_key(&m.channel_id)
                        || channels.iter().any(|(id, _)| *id == m.channel_id);
                    if !known {
                        return Err(fail(format!(
                            "message on unknown channel {} (its definition was lost?)",
                            m.channel_id
                        )));
                    }
                    let data_start = body_start + (body.len() - m.data.len());
                    messages.push((
                        m.channel_id,
                        m.log_time,
                        data_start..body_start + body.len(),
                    ));
                }
                0 => return Err(fail("record with opcode 0x00".into())),
                _ => {}
            }
        }
        self.schemas.extend(schemas);
        self.channels.extend(channels);
        self.report.chunks.push(ChunkSpan {
            file: 0,
            end_byte,
            messages: messages.len() as u64,
        });
        Ok(OpenChunk::Memory {
            buf,
            messages,
            next: 0,
        })
    }

    fn chunk_header(&mut self, at: u64, len: u64) -> Result<format::ChunkHeader, Fail> {
        let head_len = len.min(CHUNK_FIXED + u64::from(format::MAX_COMPRESSION_NAME));
        let mut head = std::mem::take(&mut self.scratch);
        let read = self.src.read_into(at + RECORD_PREFIX, head_len, &mut head);
        let parsed = read.and_then(|()| {
            format::chunk_header(&head, len).map_err(|e| damage(at, format!("chunk header: {e}")))
        });
        self.scratch = head;
        parsed
    }

    /// CRC of `len` bytes at `offset`, read through a bounded buffer.
    fn crc_of(&mut self, offset: u64, len: u64) -> Result<u32, Fail> {
        let mut crc = Crc32::default();
        let mut buf = vec![0u8; READ_BUFFER];
        let mut done = 0;
        while done < len {
            let n = (len - done).min(READ_BUFFER as u64) as usize;
            self.src.read_at(offset + done, &mut buf[..n])?;
            crc.update(&buf[..n]);
            done += n as u64;
        }
        Ok(crc.finish())
    }

    fn chunk_step(&mut self, mut chunk: OpenChunk) -> Result<Step, Fail> {
        match &mut chunk {
            OpenChunk::Memory {
                buf,
                messages,
                next,
            } => {
                while let Some((channel, log_time, range)) = messages.get(*next).cloned() {
                    *next += 1;
                    if let Some(message) = self.take_message(channel, log_time, &buf[range]) {
                        self.chunk = Some(chunk);
                        return Ok(Step::Message(message));
                    }
                }
                Ok(Step::Continue)
            }
            OpenChunk::File {
                start,
                next,
                end,
                end_byte,
                count,
            } => {
                while *next < *end {
                    self.partial = *count;
                    let at = *next;
                    let inner = at - *start;
                    let chunk_start = *start;
                    let fail = |e: String| {
                        damage(
                            chunk_start,
                            format!("record at byte {inner} of the chunk: {e}"),
                        )
                    };
                    let (opcode, len) = self.src.record_within(at, *end).map_err(|f| match f {
                        Fail::Damage(d) => fail(d.reason),
                        io => io,
                    })?;
                    if len > MAX_RECORD_BYTES {
                        return Err(fail(format!("record of {len} bytes is over the limit")));
                    }
                    let mut body = std::mem::take(&mut self.scratch);
                    self.src.read_into(at + RECORD_PREFIX, len, &mut body)?;
                    *next = at + RECORD_PREFIX + len;
                    let result = match opcode {
                        op::SCHEMA => self.register_schema(&body).map(|()| None),
                        op::CHANNEL => self.register_channel(&body).map(|()| None),
                        op::MESSAGE => format::message(&body).and_then(|m| {
                            if !self.channels.contains_key(&m.channel_id) {
                                return Err(format!("message on unknown channel {}", m.channel_id));
                            }
                            *count += 1;
                            Ok(self.take_message(m.channel_id, m.log_time, m.data))
                        }),
                        0 => Err("record with opcode 0x00".into()),
                        _ => Ok(None),
                    };
                    self.scratch = body;
                    if let Some(message) = result.map_err(fail)? {
                        self.chunk = Some(chunk);
                        return Ok(Step::Message(message));
                    }
                }
                self.partial = 0;
                self.report.chunks.push(ChunkSpan {
                    file: 0,
                    end_byte: *end_byte,
                    messages: *count,
                });
                Ok(Step::Continue)
            }
        }
    }

    /// Strict mode: the messages read must be the statistics' count.
    fn final_check(&self) -> Result<(), BagError> {
        if self.mode == ReadMode::Strict {
            if let Some(expected) = self.expected_messages {
                if expected != self.seen_messages {
                    return Err(corrupt(
                        &self.path,
                        self.mode,
                        &Damage {
                            offset: self.data_end,
                            reason: format!(
                                "the summary counts {expected} messages, the chunks hold {}",
                                self.seen_messages
                            ),
                        },
                    ));
                }
            }
        }
        Ok(())
    }

    /// Recover mode: notes the loss and moves to the next good record; Strict mode: the error.
    fn recover_from(&mut self, d: Damage) -> Result<(), BagError> {
        if self.mode == ReadMode::Strict {
            return Err(corrupt(&self.path, self.mode, &d));
        }
        // Messages of a chunk read record by record that were already handed out are not lost.
        let handed_out = std::mem::take(&mut self.partial);
        let (resume, messages, follow_indexes) = match self.resume_after(&d) {
            Ok(found) => found,
            Err(Fail::Io(source)) => {
                return Err(BagError::Io {
                    path: self.path.clone(),
                    source,
                })
            }
            Err(Fail::Damage(_)) => (None, None, false),
        };
        let end_byte = resume.unwrap_or(self.src.len);
        let loss = ChunkLoss {
            file: 0,
            start_byte: d.offset,
            end_byte,
            messages: messages.map(|m| m.saturating_sub(handed_out)),
            reason: d.reason,
        };
        tracing::warn!("{}: {loss}", self.path.display());
        self.report.losses.push(loss);
        self.open_loss = follow_indexes.then(|| self.report.losses.len() - 1);
        match resume {
            Some(at) if at < self.data_end => self.pos = at,
            _ => {
                let last = self.report.losses.last().map(|l| l.to_string());
                self.report.stopped = Some(format!(
                    "damaged or cut off from byte {} to the end: {}",
                    d.offset,
                    last.unwrap_or_default()
                ));
                self.done = true;
            }
        }
        Ok(())
    }

    /// Where to resume after damage at `d.offset`, the messages lost if known, and whether the
    /// Message Index records that follow should be counted as lost.
    fn resume_after(&mut self, d: &Damage) -> Result<(Option<u64>, Option<u64>, bool), Fail> {
        // 1. The summary's chunk index.
        if !self.chunk_indexes.is_empty() {
            let next = self
                .chunk_indexes
                .iter()
                .map(|c| c.start_offset)
                .find(|&s| s > d.offset);
            let until = next.unwrap_or(self.data_end);
            let lost: Vec<ChunkIndex> = self
                .chunk_indexes
                .iter()
                .filter(|c| c.start_offset >= d.offset && c.start_offset < until)
                .cloned()
                .collect();
            let mut messages = Some(0u64);
            for index in &lost {
                for &offset in &index.message_index_offsets {
                    let entries = self.message_index_at(offset);
                    messages = messages.zip(entries).map(|(a, b)| a + b);
                }
            }
            // A damaged record between chunks loses no message.
            return Ok((next, messages, false));
        }
        // 2. Just past a damaged chunk whose length is plausible.
        if let Ok((op::CHUNK, len)) = self.src.record_within(d.offset, self.data_end) {
            let end = d.offset + RECORD_PREFIX + len;
            if end == self.src.len || self.plausible_record_at(end) {
                return Ok((Some(end), None, true));
            }
        }
        // 3. The next chunk (or the Data End record) that checks.
        Ok((self.scan(d.offset + 1)?, None, false))
    }

    fn message_index_at(&mut self, offset: u64) -> Option<u64> {
        let (opcode, len) = self.src.record_within(offset, self.data_end).ok()?;
        if opcode != op::MESSAGE_INDEX || len > MAX_RECORD_BYTES {
            return None;
        }
        let mut body = Vec::new();
        self.src
            .read_into(offset + RECORD_PREFIX, len, &mut body)
            .ok()?;
        format::message_index_entries(&body).ok()
    }

    fn plausible_record_at(&mut self, at: u64) -> bool {
        match self.src.record_within(at, self.data_end) {
            Ok((opcode, _)) => format::known_opcode(opcode),
            Err(_) => false,
        }
    }

    /// The first offset from `from` holding a chunk whose header is consistent and whose CRC
    /// matches, or a Data End record followed by a record or the end of the file.
    fn scan(&mut self, from: u64) -> Result<Option<u64>, Fail> {
        let limit = self.data_end;
        let mut window = vec![0u8; READ_BUFFER];
        let head = (RECORD_PREFIX + CHUNK_FIXED) as usize;
        let mut offset = from;
        while offset < limit {
            let n = (limit - offset).min(READ_BUFFER as u64) as usize;
            self.src.read_at(offset, &mut window[..n])?;
            for i in 0..n {
                let at = offset + i as u64;
                match window[i] {
                    op::CHUNK => {
                        // Cheap checks on the window first, when the header is in it.
                        if i + head <= n {
                            let mut len = [0u8; 8];
                            len.copy_from_slice(&window[i + 1..i + 9]);
                            let len = u64::from_le_bytes(len);
                            if at
                                .checked_add(RECORD_PREFIX)
                                .and_then(|e| e.checked_add(len))
                                .is_none_or(|e| e > limit)
                            {
                                continue;
                            }
                        }
                        if self.chunk_checks(at, limit)? {
                            return Ok(Some(at));
                        }
                    }
                    op::DATA_END => {
                        if let Ok((op::DATA_END, 4)) = self.src.record_within(at, limit) {
                            let next = at + RECORD_PREFIX + 4;
                            if next == self.src.len || self.plausible_record_at(next) {
                                return Ok(Some(at));
                            }
                        }
                    }
                    _ => {}
                }
            }
            offset += n as u64;
        }
        Ok(None)
    }

    /// Whether a chunk at `at` has a consistent header and a matching CRC (records parsing is
    /// left to reading it); a compressed one must also decompress to its declared size.
    fn chunk_checks(&mut self, at: u64, limit: u64) -> Result<bool, Fail> {
        let Ok((op::CHUNK, len)) = self.src.record_within(at, limit) else {
            return Ok(false);
        };
        let Ok(header) = self.chunk_header(at, len) else {
            return Ok(false);
        };
        if !header.compression.is_empty() {
            return match self.decompressed_chunk(at, &header) {
                Ok(_) => Ok(true),
                Err(Fail::Damage(_)) => Ok(false),
                Err(io) => Err(io),
            };
        }
        if header.uncompressed_crc == 0 {
            return Ok(true);
        }
        let records_at = at + RECORD_PREFIX + header.header_len;
        match self.crc_of(records_at, header.records_len) {
            Ok(crc) => Ok(crc == header.uncompressed_crc),
            Err(Fail::Damage(_)) => Ok(false),
            Err(io) => Err(io),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{BagWriter, WriterOptions};
    use super::*;
    use crate::bag_common::write_bag;
    use nrslam_msgs::{topics, Time};
    use tempfile::TempDir;

    /// [`write_bag`] into `run` in a new temporary folder, which lives as long as the `TempDir`.
    fn written_bag(frames: u32, chunk_size_bytes: u64) -> (TempDir, PathBuf, BagInfo) {
        let dir = tempfile::tempdir().unwrap();
        let bag = dir.path().join("run");
        let info = write_bag(&bag, frames, chunk_size_bytes);
        (dir, bag, info)
    }

    #[test]
    fn a_written_bag_reads_back_message_for_message() {
        let (_dir, bag, info) = written_bag(20, 1024);
        assert_eq!(info.message_count, 40);
        assert_eq!(info.starting_time.nanoseconds_since_epoch, 500_000_000);
        assert_eq!(info.duration.nanoseconds, 9_500_000_000);
        let contents = open(&bag, ReadMode::Strict).unwrap();
        assert_eq!(contents.messages.len(), 40);
        assert!(contents.chunks.len() > 1, "{:?}", contents.chunks);
        let in_chunks: u64 = contents.chunks.iter().map(|c| c.messages).sum();
        assert_eq!(in_chunks, 40);
        assert!(
            contents.complete_bytes() < contents.file_bytes,
            "the summary follows"
        );
        assert_eq!(contents.custom_data["nrslam.seed"], "3");
        assert_eq!(contents.topics[0].name, topics::CLOCK);
        assert_eq!(contents.topics[1].count, 20);
        let first = contents.messages[0].decode().unwrap();
        assert_eq!(first.stamp(), Time::from_seconds(0.5));
        assert!(contents.stopped.is_none());
        assert!(contents.losses.is_empty());
        // The summary agrees without reading the messages.
        let opened = Bag::open(&bag, ReadMode::Strict).unwrap();
        let summary = opened.summary().unwrap();
        assert_eq!(summary.message_count, Some(40));
        assert_eq!(summary.chunk_count, contents.chunks.len());
        assert_eq!(summary.topics, contents.topics);
        assert_eq!(
            summary.time_range_ns,
            Some((500_000_000, 10_000_000_000)),
            "statistics' time range"
        );
    }

    #[test]
    fn chunks_read_record_by_record_give_the_same_messages() {
        let (_dir, bag, _) = written_bag(30, 700);
        let whole = open(&bag, ReadMode::Strict).unwrap();
        let mut opened = Bag::open(&bag, ReadMode::Strict).unwrap();
        opened.set_in_memory_chunk_bytes(100);
        let streamed = opened.read_all().unwrap();
        assert_eq!(streamed.messages, whole.messages);
        assert_eq!(streamed.chunks, whole.chunks);
        // A damaged big chunk is detected by its CRC before any of its messages is handed out.
        let mut bytes = std::fs::read(&whole.mcap_path).unwrap();
        let second = whole.chunks[0].end_byte as usize;
        let flip = (second + whole.chunks[1].end_byte as usize) / 2;
        bytes[flip] ^= 0xFF;
        std::fs::write(&whole.mcap_path, &bytes).unwrap();
        let error = opened.read_all().unwrap_err().to_string();
        assert!(
            error.contains("CRC mismatch") && error.contains("--recover"),
            "{error}"
        );
    }

    #[test]
    fn a_cut_off_file_is_an_error_strictly_and_loses_at_most_one_chunk_when_recovered() {
        let (_dir, bag, _) = written_bag(50, 512);
        let full = open(&bag, ReadMode::Strict).unwrap();
        let path = full.mcap_path.clone();
        let bytes = std::fs::read(&path).unwrap();
        // Cuts inside the data section (the summary follows the last chunk).
        let data = full.complete_bytes() as usize;
        for cut in [data / 3, data / 2, data * 9 / 10] {
            std::fs::write(&path, &bytes[..cut]).unwrap();
            let error = open(&bag, ReadMode::Strict).unwrap_err().to_string();
            assert!(error.contains("--recover"), "{error}");
            let recovered = open(&bag, ReadMode::Recover).unwrap();
            assert!(recovered.stopped.is_some(), "cut {cut}");
            assert_eq!(
                recovered.messages[..],
                full.messages[..recovered.messages.len()],
                "a prefix of the recording"
            );
            // Exactly the chunks that end before the cut survive: the one being cut is lost.
            let expected = full.messages_in_chunks_ending_by(cut as u64);
            assert_eq!(recovered.messages.len() as u64, expected, "cut at {cut}");
            assert!(recovered.complete_bytes() <= cut as u64);
            assert_eq!(recovered.losses.len(), 1, "{:?}", recovered.losses);
            assert_eq!(recovered.losses[0].end_byte, cut as u64);
        }
    }

    #[test]
    fn missing_or_foreign_folders_are_clear_errors() {
        let dir = tempfile::tempdir().unwrap();
        let error = open(&dir.path().join("nope"), ReadMode::Strict)
            .unwrap_err()
            .to_string();
        assert!(error.contains("nope"), "{error}");
        let error = open(dir.path(), ReadMode::Strict).unwrap_err().to_string();
        assert!(error.contains("no metadata.yaml"), "{error}");
        std::fs::write(dir.path().join("x.mcap"), b"not an mcap").unwrap();
        let error = open(dir.path(), ReadMode::Recover).unwrap_err().to_string();
        assert!(error.contains("x.mcap"), "{error}");
    }

    #[test]
    fn an_existing_non_empty_folder_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("keep"), b"x").unwrap();
        assert!(matches!(
            BagWriter::create(dir.path(), WriterOptions::default()),
            Err(BagError::Exists { .. })
        ));
    }

    #[test]
    fn unknown_topics_are_refused_by_name() {
        let (_dir, bag, _) = written_bag(2, 1024);
        let mut contents = open(&bag, ReadMode::Strict).unwrap();
        let error = contents
            .retain_topics(&["/nope".to_owned()])
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("/nope") && error.contains("/clock, /slam/pose"),
            "{error}"
        );
        contents.retain_topics(&["/clock".to_owned()]).unwrap();
        assert_eq!(contents.messages.len(), 2);
        let opened = Bag::open(&bag, ReadMode::Strict).unwrap();
        assert!(opened.messages_on(&["/nope".to_owned()]).is_err());
        let clock: Vec<BagMessage> = opened
            .messages_on(&["/clock".to_owned()])
            .unwrap()
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(clock, contents.messages);
    }
}
