//! Writing a bag: MCAP chunks cut and flushed at a fixed size (optionally zstd or lz4
//! compressed), a new storage file when the current one reaches a size or a duration (as
//! `ros2 bag record --max-bag-size / --max-bag-duration` split), `metadata.yaml` version 9 at
//! the end listing every file.

use super::decompress::Compression;
use super::metadata::{
    qos_yaml, BagInfo, FileInfo, MetadataFile, Nanoseconds, QosProfile, StartingTime,
    TopicMetadata, TopicWithCount, VERSION,
};
use super::reader::RecordedType;
use super::{offered_qos_profiles, BagError, MCAP_METADATA_NAME};
use nrslam_msgs::{schema, topics, Message};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// How a bag is written.
#[derive(Debug, Clone)]
pub struct WriterOptions {
    /// Message bytes per chunk: a chunk is closed and flushed to the operating system once it holds
    /// this much, so a killed recorder loses at most this much. rosbag2's MCAP default: 768 KiB.
    pub chunk_size_bytes: u64,
    /// `custom_data` of metadata.yaml (also written as MCAP metadata record `nrslam`).
    pub custom_data: BTreeMap<String, String>,
}

impl Default for WriterOptions {
    fn default() -> Self {
        Self {
            chunk_size_bytes: 768 * 1024,
            custom_data: BTreeMap::new(),
        }
    }
}

/// Chunk compression and file splitting ([`BagWriter::create_with`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StorageOptions {
    /// MCAP chunk compression (rosbag2's `zstd_fast` / `zstd_small` presets write zstd chunks).
    pub compression: Compression,
    /// Start a new storage file once the current one holds this many bytes (its size on disk plus
    /// the message bytes of the chunk being filled); 0: no limit. Checked before each message, so
    /// a file exceeds it by at most one message.
    pub max_file_bytes: u64,
    /// Start a new storage file once a message's log time is this far (ns) past the first of the
    /// current file; 0: no limit.
    pub max_file_duration_ns: u64,
}

/// The writer's sink: a buffered file that tracks its size (the furthest byte written), readable
/// from outside the `mcap::Writer` that owns it.
struct CountingFile {
    inner: BufWriter<File>,
    pos: u64,
    written: Arc<AtomicU64>,
}

impl Write for CountingFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.pos += n as u64;
        self.written.fetch_max(self.pos, Ordering::Relaxed);
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl Seek for CountingFile {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.pos = self.inner.seek(pos)?;
        Ok(self.pos)
    }
}

struct Topic {
    recorded: RecordedType,
    qos: Vec<QosProfile>,
    hash: String,
    sequence: u32,
    count: u64,
    /// Channel id in the current file, once declared there.
    channel: Option<u16>,
}

/// The storage file being written.
struct OpenFile {
    name: String,
    mcap: mcap::Writer<CountingFile>,
    written: Arc<AtomicU64>,
    first_ns: Option<u64>,
    last_ns: u64,
    count: u64,
}

/// Writes one bag folder. Call [`BagWriter::finish`]; a writer dropped without it leaves a bag
/// without metadata.yaml, readable with [`super::ReadMode::Recover`].
pub struct BagWriter {
    dir: PathBuf,
    stem: String,
    file: Option<OpenFile>,
    closed: Vec<FileInfo>,
    topics: BTreeMap<String, Topic>,
    options: WriterOptions,
    storage: StorageOptions,
    chunk_bytes: u64,
    first_ns: Option<u64>,
    last_ns: u64,
    message_count: u64,
}

fn mcap_error(path: &Path, error: mcap::McapError) -> BagError {
    BagError::Corrupt {
        path: path.to_owned(),
        reason: format!("MCAP write failed: {error}"),
    }
}

impl BagWriter {
    /// Creates the bag folder `dir` (which must not exist, or be empty) and its first MCAP file,
    /// uncompressed and unsplit.
    pub fn create(dir: &Path, options: WriterOptions) -> Result<Self, BagError> {
        Self::create_with(dir, options, StorageOptions::default())
    }

    /// [`BagWriter::create`] with chunk compression and file splitting.
    pub fn create_with(
        dir: &Path,
        options: WriterOptions,
        storage: StorageOptions,
    ) -> Result<Self, BagError> {
        if let Ok(mut entries) = std::fs::read_dir(dir) {
            if entries.next().is_some() {
                return Err(BagError::Exists {
                    path: dir.to_owned(),
                });
            }
        }
        std::fs::create_dir_all(dir).map_err(|source| BagError::Io {
            path: dir.to_owned(),
            source,
        })?;
        let stem = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .filter(|n| !n.is_empty() && n != "." && n != "..")
            .unwrap_or_else(|| "bag".to_owned());
        let mut writer = Self {
            dir: dir.to_owned(),
            stem,
            file: None,
            closed: Vec::new(),
            topics: BTreeMap::new(),
            options,
            storage,
            chunk_bytes: 0,
            first_ns: None,
            last_ns: 0,
            message_count: 0,
        };
        writer.open_file()?;
        Ok(writer)
    }

    fn open_file(&mut self) -> Result<(), BagError> {
        let name = format!("{}_{}.mcap", self.stem, self.closed.len());
        let path = self.dir.join(&name);
        let file = File::create(&path).map_err(|source| BagError::Io {
            path: path.clone(),
            source,
        })?;
        let written = Arc::new(AtomicU64::new(0));
        let compression = match self.storage.compression {
            Compression::None => None,
            Compression::Zstd => Some(mcap::Compression::Zstd),
            Compression::Lz4 => Some(mcap::Compression::Lz4),
        };
        let mut mcap = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("nrslam ", env!("CARGO_PKG_VERSION")))
            .compression(compression)
            .chunk_size(None)
            .create(CountingFile {
                inner: BufWriter::new(file),
                pos: 0,
                written: written.clone(),
            })
            .map_err(|e| mcap_error(&path, e))?;
        if !self.options.custom_data.is_empty() {
            mcap.write_metadata(&mcap::records::Metadata {
                name: MCAP_METADATA_NAME.to_owned(),
                metadata: self.options.custom_data.clone(),
            })
            .map_err(|e| mcap_error(&path, e))?;
        }
        for topic in self.topics.values_mut() {
            topic.channel = None;
        }
        self.chunk_bytes = 0;
        self.file = Some(OpenFile {
            name,
            mcap,
            written,
            first_ns: None,
            last_ns: 0,
            count: 0,
        });
        Ok(())
    }

    /// Closes the current file: its summary, and rosbag2's `serialized_metadata` record (the bag's
    /// metadata as known now), which `ros2 bag reindex` and rosbags read.
    fn close_file(&mut self) -> Result<(), BagError> {
        let Some(mut file) = self.file.take() else {
            return Ok(());
        };
        let path = self.dir.join(&file.name);
        let start = file.first_ns.unwrap_or(0);
        self.closed.push(FileInfo {
            path: file.name.clone(),
            starting_time: StartingTime {
                nanoseconds_since_epoch: start,
            },
            duration: Nanoseconds {
                nanoseconds: file.last_ns.saturating_sub(start),
            },
            message_count: file.count,
        });
        let info_yaml = serde_yaml::to_string(&self.info()).unwrap_or_default();
        file.mcap
            .write_metadata(&mcap::records::Metadata {
                name: "rosbag2".to_owned(),
                metadata: BTreeMap::from([(
                    "serialized_metadata".to_owned(),
                    info_yaml.trim_end().to_owned(),
                )]),
            })
            .map_err(|e| mcap_error(&path, e))?;
        file.mcap.finish().map_err(|e| mcap_error(&path, e))?;
        let mut inner = file.mcap.into_inner();
        inner
            .flush()
            .map_err(|source| BagError::Io { path, source })?;
        Ok(())
    }

    /// The bag folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The MCAP file being written.
    pub fn mcap_path(&self) -> PathBuf {
        let name = match &self.file {
            Some(file) => file.name.clone(),
            None => format!("{}_{}.mcap", self.stem, self.closed.len().saturating_sub(1)),
        };
        self.dir.join(name)
    }

    /// Messages written so far.
    pub fn message_count(&self) -> u64 {
        self.message_count
    }

    /// Storage files started so far.
    pub fn file_count(&self) -> usize {
        self.closed.len() + usize::from(self.file.is_some())
    }

    /// Writes `message` on `topic` (a catalogue topic), log time = its header stamp.
    pub fn write_message(&mut self, topic: &str, message: &Message) -> Result<(), BagError> {
        let data = message.encode().map_err(|e| BagError::Message {
            topic: topic.to_owned(),
            reason: e.to_string(),
        })?;
        self.write_cdr(
            topic,
            message.type_name(),
            message.stamp().as_nanos(),
            &data,
        )
    }

    /// Writes CDR bytes (with encapsulation header) of catalogue type `type_name` on `topic` at
    /// `log_time_ns`; the schema and type hash come from the catalogue.
    pub fn write_cdr(
        &mut self,
        topic: &str,
        type_name: &str,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), BagError> {
        if !self.topics.contains_key(topic) {
            let error = |reason: String| BagError::Message {
                topic: topic.to_owned(),
                reason,
            };
            let text = schema::ros2msg(type_name)
                .ok_or_else(|| error(format!("no ros2msg schema for type {type_name}")))?;
            let hash = crate::type_hash::rihs01(type_name).map_err(|e| error(e.to_string()))?;
            let qos = offered_qos_profiles(&topics::spec(topic).map_or(
                topics::Qos {
                    reliability: topics::Reliability::Reliable,
                    durability: topics::Durability::Volatile,
                    depth: 64,
                },
                |spec| spec.qos,
            ));
            let recorded = RecordedType {
                type_name: type_name.to_owned(),
                schema_encoding: "ros2msg".into(),
                schema: text.into_bytes(),
                message_encoding: "cdr".into(),
                channel_metadata: BTreeMap::new(),
            };
            self.add_topic(topic, recorded, qos, hash);
        }
        self.write_raw_checked(topic, type_name, log_time_ns, data)
    }

    /// Writes a message of any type, as recorded elsewhere: its schema, encoding, type hash and
    /// QoS are taken from `recorded` (a topic's first message fixes them; `qos` and `type_hash`
    /// as metadata.yaml listed them, when known).
    pub fn write_raw(
        &mut self,
        topic: &str,
        recorded: &RecordedType,
        qos: &[QosProfile],
        type_hash: &str,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), BagError> {
        if !self.topics.contains_key(topic) {
            let hash = if type_hash.is_empty() {
                recorded.type_hash().unwrap_or_default().to_owned()
            } else {
                type_hash.to_owned()
            };
            self.add_topic(topic, recorded.clone(), qos.to_vec(), hash);
        }
        self.write_raw_checked(topic, &recorded.type_name, log_time_ns, data)
    }

    fn add_topic(
        &mut self,
        topic: &str,
        mut recorded: RecordedType,
        qos: Vec<QosProfile>,
        hash: String,
    ) {
        // What rosbag2 puts in the channel metadata.
        recorded
            .channel_metadata
            .insert("offered_qos_profiles".into(), qos_yaml(&qos));
        if !hash.is_empty() {
            recorded
                .channel_metadata
                .insert("topic_type_hash".into(), hash.clone());
        }
        self.topics.insert(
            topic.to_owned(),
            Topic {
                recorded,
                qos,
                hash,
                sequence: 0,
                count: 0,
                channel: None,
            },
        );
    }

    fn write_raw_checked(
        &mut self,
        topic: &str,
        type_name: &str,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), BagError> {
        let recorded_type = &self.topics[topic].recorded.type_name;
        if recorded_type != type_name {
            return Err(BagError::Message {
                topic: topic.to_owned(),
                reason: format!(
                    "type {type_name} differs from the topic's recorded type {recorded_type}"
                ),
            });
        }
        if self.file.is_none() {
            return Err(BagError::Message {
                topic: topic.to_owned(),
                reason: "bag already finished".into(),
            });
        }
        if self.split_due(log_time_ns) {
            self.close_file()?;
            self.open_file()?;
        }
        let path = self.mcap_path();
        let file = self.file.as_mut().expect("opened above");
        let entry = self.topics.get_mut(topic).expect("added above");
        let channel = match entry.channel {
            Some(id) => id,
            None => {
                let r = &entry.recorded;
                let schema_id = file
                    .mcap
                    .add_schema(&r.type_name, &r.schema_encoding, &r.schema)
                    .map_err(|e| mcap_error(&path, e))?;
                let id = file
                    .mcap
                    .add_channel(schema_id, topic, &r.message_encoding, &r.channel_metadata)
                    .map_err(|e| mcap_error(&path, e))?;
                entry.channel = Some(id);
                id
            }
        };
        entry.sequence = entry.sequence.wrapping_add(1);
        entry.count += 1;
        file.mcap
            .write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: channel,
                    sequence: entry.sequence,
                    log_time: log_time_ns,
                    publish_time: log_time_ns,
                },
                data,
            )
            .map_err(|e| mcap_error(&path, e))?;
        file.first_ns = Some(file.first_ns.map_or(log_time_ns, |t| t.min(log_time_ns)));
        file.last_ns = file.last_ns.max(log_time_ns);
        file.count += 1;
        self.first_ns = Some(self.first_ns.map_or(log_time_ns, |t| t.min(log_time_ns)));
        self.last_ns = self.last_ns.max(log_time_ns);
        self.message_count += 1;
        // Record overhead: opcode, length, channel, sequence, two times.
        self.chunk_bytes += data.len() as u64 + 31;
        if self.chunk_bytes >= self.options.chunk_size_bytes {
            // Closes the chunk (with its message index) and flushes it to the file.
            file.mcap.flush().map_err(|e| mcap_error(&path, e))?;
            self.chunk_bytes = 0;
        }
        Ok(())
    }

    /// Whether the current file is full (size or duration) before a message at `log_time_ns`.
    fn split_due(&self, log_time_ns: u64) -> bool {
        let Some(file) = &self.file else {
            return false;
        };
        if file.count == 0 {
            return false;
        }
        let size = self.storage.max_file_bytes;
        if size > 0 && file.written.load(Ordering::Relaxed) + self.chunk_bytes >= size {
            return true;
        }
        let duration = self.storage.max_file_duration_ns;
        duration > 0
            && file
                .first_ns
                .is_some_and(|first| log_time_ns.saturating_sub(first) >= duration)
    }

    /// metadata.yaml's content for what was written and closed so far.
    fn info(&self) -> BagInfo {
        let start = self.first_ns.unwrap_or(0);
        BagInfo {
            version: VERSION,
            storage_identifier: "mcap".into(),
            duration: Nanoseconds {
                nanoseconds: self.last_ns.saturating_sub(start),
            },
            starting_time: StartingTime {
                nanoseconds_since_epoch: start,
            },
            message_count: self.message_count,
            topics_with_message_count: self
                .topics
                .iter()
                .map(|(name, topic)| TopicWithCount {
                    topic_metadata: TopicMetadata {
                        name: name.clone(),
                        type_name: topic.recorded.type_name.clone(),
                        serialization_format: topic.recorded.message_encoding.clone(),
                        offered_qos_profiles: topic.qos.clone(),
                        type_description_hash: topic.hash.clone(),
                    },
                    message_count: topic.count,
                })
                .collect(),
            // MCAP chunk compression is recorded in the storage file; rosbag2 leaves these empty
            // for it (they describe its own file or message compression).
            compression_format: String::new(),
            compression_mode: String::new(),
            relative_file_paths: self.closed.iter().map(|f| f.path.clone()).collect(),
            files: self.closed.clone(),
            custom_data: self.options.custom_data.clone(),
            ros_distro: "nrslam".into(),
        }
    }

    /// Closes the last MCAP file (summary, footer) and writes metadata.yaml.
    pub fn finish(mut self) -> Result<BagInfo, BagError> {
        self.close_file()?;
        let info = self.info();
        let metadata_path = self.dir.join("metadata.yaml");
        let yaml = MetadataFile {
            rosbag2_bagfile_information: info.clone(),
        }
        .to_yaml()
        .map_err(|e| BagError::Corrupt {
            path: metadata_path.clone(),
            reason: e.to_string(),
        })?;
        std::fs::write(&metadata_path, yaml).map_err(|source| BagError::Io {
            path: metadata_path,
            source,
        })?;
        Ok(info)
    }
}

impl Drop for BagWriter {
    fn drop(&mut self) {
        // Without finish(): flush what was written (the open chunk too) but write no metadata.yaml.
        if let Some(file) = self.file.as_mut() {
            let _ = file.mcap.flush();
        }
    }
}
