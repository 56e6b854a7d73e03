//! Reading a bag: every message in file (recorded) order, strictly or, for a file cut off
//! mid-write, up to its last complete chunk.

use super::metadata::{BagInfo, MetadataFile};
use super::{BagError, MCAP_METADATA_NAME};
use mcap::read::{ChunkReader, LinearReader, Options};
use mcap::records::Record;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// How strictly to read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadMode {
    /// metadata.yaml and a complete MCAP file (end magic) are required; any damage is an error.
    Strict,
    /// For a recorder that was killed: metadata.yaml is optional, and the MCAP file is read up to
    /// the first record that is cut off or damaged; a partly written chunk is dropped whole.
    Recover,
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
    /// Messages read.
    pub count: u64,
}

/// Where a chunk ends in the MCAP file and how many messages it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChunkSpan {
    /// Byte offset just past the chunk record.
    pub end_byte: u64,
    /// Messages in it.
    pub messages: u64,
}

/// What was read from a bag folder.
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

    /// First and last log time (ns), if any message was read.
    pub fn time_range_ns(&self) -> Option<(u64, u64)> {
        let first = self.messages.iter().map(|m| m.log_time_ns).min()?;
        let last = self.messages.iter().map(|m| m.log_time_ns).max()?;
        Some((first, last))
    }

    /// Keeps only the messages of `topics` (all if empty); a topic that is not in the bag is an
    /// error.
    pub fn retain_topics(&mut self, topics: &[String]) -> Result<(), BagError> {
        if topics.is_empty() {
            return Ok(());
        }
        for topic in topics {
            if !self.topics.iter().any(|t| &t.name == topic) {
                return Err(BagError::UnknownTopic {
                    topic: topic.clone(),
                    recorded: self
                        .topics
                        .iter()
                        .map(|t| t.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", "),
                });
            }
        }
        self.messages.retain(|m| topics.contains(&m.topic));
        self.topics.retain(|t| topics.contains(&t.name));
        Ok(())
    }
}

fn find_mcap(dir: &Path, metadata: Option<&BagInfo>) -> Result<PathBuf, BagError> {
    if let Some(info) = metadata {
        return match info.relative_file_paths.as_slice() {
            [one] => Ok(dir.join(one)),
            [] => Err(BagError::NotABag {
                path: dir.to_owned(),
                reason: "metadata.yaml lists no storage file".into(),
            }),
            _ => Err(BagError::NotABag {
                path: dir.to_owned(),
                reason: "bags split over several files are not supported".into(),
            }),
        };
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|source| BagError::Io {
            path: dir.to_owned(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    found.sort();
    match found.len() {
        1 => Ok(found.remove(0)),
        0 => Err(BagError::NotABag {
            path: dir.to_owned(),
            reason: "no .mcap file in it".into(),
        }),
        _ => Err(BagError::NotABag {
            path: dir.to_owned(),
            reason: "several .mcap files and no metadata.yaml".into(),
        }),
    }
}

/// Reads the bag folder `dir` (or, if `dir` is an `.mcap` file, that file alone).
pub fn open(dir: &Path, mode: ReadMode) -> Result<BagContents, BagError> {
    if !dir.exists() {
        return Err(BagError::Io {
            path: dir.to_owned(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or folder"),
        });
    }
    let (folder, metadata, mcap_path) = if dir.is_file() {
        let folder = dir.parent().map(Path::to_owned).unwrap_or_default();
        (folder, None, dir.to_owned())
    } else {
        let metadata_path = dir.join("metadata.yaml");
        let metadata = match std::fs::read_to_string(&metadata_path) {
            Ok(text) => Some(
                MetadataFile::from_yaml(&text)
                    .map_err(|e| BagError::Corrupt {
                        path: metadata_path.clone(),
                        reason: format!("not rosbag2 metadata: {e}"),
                    })?
                    .rosbag2_bagfile_information,
            ),
            Err(_) if mode == ReadMode::Recover => None,
            Err(_) => {
                return Err(BagError::NotABag {
                    path: dir.to_owned(),
                    reason: "no metadata.yaml (a recording cut off? try --recover)".into(),
                })
            }
        };
        if let Some(info) = &metadata {
            if info.storage_identifier != "mcap" {
                return Err(BagError::NotABag {
                    path: dir.to_owned(),
                    reason: format!(
                        "storage {:?} is not supported (only mcap)",
                        info.storage_identifier
                    ),
                });
            }
        }
        let mcap_path = find_mcap(dir, metadata.as_ref())?;
        (dir.to_owned(), metadata, mcap_path)
    };
    let bytes = std::fs::read(&mcap_path).map_err(|source| BagError::Io {
        path: mcap_path.clone(),
        source,
    })?;
    let mut contents = read_mcap(&bytes, mode).map_err(|reason| BagError::Corrupt {
        path: mcap_path.clone(),
        reason: match mode {
            ReadMode::Strict => format!("{reason} (a recording cut off? try --recover)"),
            ReadMode::Recover => reason,
        },
    })?;
    if let Some(info) = &metadata {
        if !info.custom_data.is_empty() {
            contents.custom_data = info.custom_data.clone();
        }
    }
    contents.dir = folder;
    contents.mcap_path = mcap_path;
    contents.metadata = metadata;
    Ok(contents)
}

#[derive(Clone)]
struct ChannelInfo {
    topic: String,
    schema_id: u16,
}

#[derive(Default)]
struct State {
    schemas: HashMap<u16, String>,
    channels: HashMap<u16, ChannelInfo>,
    messages: Vec<BagMessage>,
    custom_data: BTreeMap<String, String>,
}

impl State {
    /// Takes one record (top level or inside a chunk).
    fn take(&mut self, record: Record<'_>) -> Result<(), String> {
        match record {
            Record::Schema { header, .. } => {
                self.schemas.insert(header.id, header.name);
            }
            Record::Channel(channel) => {
                self.channels.insert(
                    channel.id,
                    ChannelInfo {
                        topic: channel.topic,
                        schema_id: channel.schema_id,
                    },
                );
            }
            Record::Message { header, data } => {
                let channel = self
                    .channels
                    .get(&header.channel_id)
                    .ok_or_else(|| format!("message on unknown channel {}", header.channel_id))?;
                let type_name = self
                    .schemas
                    .get(&channel.schema_id)
                    .ok_or_else(|| format!("channel {} has no schema", channel.topic))?;
                self.messages.push(BagMessage {
                    topic: channel.topic.clone(),
                    type_name: type_name.clone(),
                    log_time_ns: header.log_time,
                    data: data.into_owned(),
                });
            }
            Record::Metadata(metadata) if metadata.name == MCAP_METADATA_NAME => {
                self.custom_data = metadata.metadata;
            }
            _ => {}
        }
        Ok(())
    }
}

/// Reads MCAP bytes; in Recover mode stops quietly at the first damaged or cut-off record.
fn read_mcap(bytes: &[u8], mode: ReadMode) -> Result<BagContents, String> {
    if !bytes.starts_with(mcap::MAGIC) {
        return Err("not an MCAP file (no MCAP magic at its start)".into());
    }
    let reader = match mode {
        ReadMode::Strict => LinearReader::new(bytes),
        ReadMode::Recover => LinearReader::new_with_options(bytes, Options::IgnoreEndMagic.into()),
    }
    .map_err(|e| e.to_string())?;
    let mut state = State::default();
    let mut chunks = Vec::new();
    // Offset of the next record: after the 8 magic bytes, each record is an opcode, a u64 LE
    // length and that many bytes; the reader yields them in file order.
    let mut offset: u64 = 8;
    let mut stopped = None;
    let mut saw_footer = false;
    for record in reader {
        let record = match record {
            Ok(record) => record,
            Err(error) if mode == ReadMode::Recover => {
                stopped = Some(error.to_string());
                break;
            }
            Err(error) => return Err(error.to_string()),
        };
        let start = offset as usize;
        let length = bytes
            .get(start + 1..start + 9)
            .and_then(|b| b.try_into().ok())
            .map(u64::from_le_bytes)
            .unwrap_or(0);
        offset += 9 + length;
        match record {
            Record::Chunk { header, data } => {
                // A chunk's records are taken only if the whole chunk parses.
                let mut inner = State {
                    schemas: state.schemas.clone(),
                    channels: state.channels.clone(),
                    messages: Vec::new(),
                    custom_data: BTreeMap::new(),
                };
                let parsed = ChunkReader::new(header, &data)
                    .map_err(|e| e.to_string())
                    .and_then(|mut records| {
                        records.try_for_each(|r| {
                            r.map_err(|e| e.to_string()).and_then(|r| inner.take(r))
                        })
                    });
                match parsed {
                    Ok(()) => {
                        state.schemas = inner.schemas;
                        state.channels = inner.channels;
                        chunks.push(ChunkSpan {
                            end_byte: offset,
                            messages: inner.messages.len() as u64,
                        });
                        state.messages.extend(inner.messages);
                    }
                    Err(error) if mode == ReadMode::Recover => {
                        stopped = Some(format!("damaged chunk: {error}"));
                        break;
                    }
                    Err(error) => return Err(format!("damaged chunk: {error}")),
                }
            }
            Record::DataEnd(_) if mode == ReadMode::Recover => {
                // The summary section follows; everything is read.
                saw_footer = true;
                break;
            }
            Record::Footer(_) => saw_footer = true,
            other => state.take(other)?,
        }
    }
    let mut topics: Vec<TopicSummary> = Vec::new();
    for message in &state.messages {
        match topics.iter_mut().find(|t| t.name == message.topic) {
            Some(topic) => topic.count += 1,
            None => topics.push(TopicSummary {
                name: message.topic.clone(),
                type_name: message.type_name.clone(),
                count: 1,
            }),
        }
    }
    if mode == ReadMode::Recover && !saw_footer && stopped.is_none() {
        stopped = Some("file ends without a summary".into());
    }
    Ok(BagContents {
        dir: PathBuf::new(),
        mcap_path: PathBuf::new(),
        metadata: None,
        messages: state.messages,
        topics,
        chunks,
        custom_data: state.custom_data,
        file_bytes: bytes.len() as u64,
        stopped,
    })
}

#[cfg(test)]
mod tests {
    use super::super::{BagWriter, WriterOptions};
    use super::*;
    use nrslam_msgs::{topics, Clock, Header, Message, PoseStamped, Time};

    fn write_bag(dir: &Path, frames: u32, chunk_size_bytes: u64) -> BagInfo {
        let mut writer = BagWriter::create(
            dir,
            WriterOptions {
                chunk_size_bytes,
                custom_data: [("nrslam.seed".to_owned(), "3".to_owned())].into(),
            },
        )
        .unwrap();
        for k in 1..=frames {
            let stamp = Time::from_seconds(k as f64 * 0.5);
            writer
                .write_message(topics::CLOCK, &Message::Clock(Clock { clock: stamp }))
                .unwrap();
            let pose = PoseStamped {
                header: Header::new(stamp, "map"),
                ..Default::default()
            };
            writer
                .write_message(topics::SLAM_POSE, &Message::PoseStamped(pose))
                .unwrap();
        }
        writer.finish().unwrap()
    }

    #[test]
    fn a_written_bag_reads_back_message_for_message() {
        let dir = tempfile::tempdir().unwrap();
        let bag = dir.path().join("run");
        let info = write_bag(&bag, 20, 1024);
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
    }

    #[test]
    fn a_cut_off_file_is_an_error_strictly_and_loses_at_most_one_chunk_when_recovered() {
        let dir = tempfile::tempdir().unwrap();
        let bag = dir.path().join("run");
        write_bag(&bag, 50, 512);
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
            let expected: u64 = full
                .chunks
                .iter()
                .filter(|c| c.end_byte <= cut as u64)
                .map(|c| c.messages)
                .sum();
            assert_eq!(recovered.messages.len() as u64, expected, "cut at {cut}");
            assert!(recovered.complete_bytes() <= cut as u64);
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
        let dir = tempfile::tempdir().unwrap();
        let bag = dir.path().join("run");
        write_bag(&bag, 2, 1024);
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
    }
}
