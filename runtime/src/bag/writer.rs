//! Writing a bag: MCAP chunks cut and flushed at a fixed size, `metadata.yaml` at the end.

use super::metadata::{
    BagInfo, FileInfo, MetadataFile, Nanoseconds, StartingTime, TopicMetadata, TopicWithCount,
    VERSION,
};
use super::{offered_qos_profiles, BagError, MCAP_METADATA_NAME};
use nrslam_msgs::{schema, topics, Message};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

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

struct Channel {
    id: u16,
    type_name: String,
    qos: String,
    hash: String,
    sequence: u32,
    count: u64,
}

/// Writes one bag folder. Call [`BagWriter::finish`]; a writer dropped without it leaves a bag
/// without metadata.yaml, readable with [`super::ReadMode::Recover`].
pub struct BagWriter {
    dir: PathBuf,
    file_name: String,
    mcap: Option<mcap::Writer<BufWriter<File>>>,
    channels: BTreeMap<String, Channel>,
    options: WriterOptions,
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
    /// Creates the bag folder `dir` (which must not exist, or be empty) and its MCAP file.
    pub fn create(dir: &Path, options: WriterOptions) -> Result<Self, BagError> {
        if let Ok(mut entries) = std::fs::read_dir(dir) {
            if entries.next().is_some() {
                return Err(BagError::Exists {
                    path: dir.to_owned(),
                });
            }
        }
        let io = |source| BagError::Io {
            path: dir.to_owned(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(io)?;
        let stem = dir
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .filter(|n| !n.is_empty() && n != "." && n != "..")
            .unwrap_or_else(|| "bag".to_owned());
        let file_name = format!("{stem}_0.mcap");
        let path = dir.join(&file_name);
        let file = File::create(&path).map_err(|source| BagError::Io {
            path: path.clone(),
            source,
        })?;
        let mut mcap = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("nrslam ", env!("CARGO_PKG_VERSION")))
            .compression(None)
            .chunk_size(None)
            .create(BufWriter::new(file))
            .map_err(|e| mcap_error(&path, e))?;
        if !options.custom_data.is_empty() {
            mcap.write_metadata(&mcap::records::Metadata {
                name: MCAP_METADATA_NAME.to_owned(),
                metadata: options.custom_data.clone(),
            })
            .map_err(|e| mcap_error(&path, e))?;
        }
        Ok(Self {
            dir: dir.to_owned(),
            file_name,
            mcap: Some(mcap),
            channels: BTreeMap::new(),
            options,
            chunk_bytes: 0,
            first_ns: None,
            last_ns: 0,
            message_count: 0,
        })
    }

    /// The bag folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The MCAP file's path.
    pub fn mcap_path(&self) -> PathBuf {
        self.dir.join(&self.file_name)
    }

    /// Messages written so far.
    pub fn message_count(&self) -> u64 {
        self.message_count
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

    /// Writes CDR bytes (with encapsulation header) of type `type_name` on `topic` at `log_time_ns`.
    pub fn write_cdr(
        &mut self,
        topic: &str,
        type_name: &str,
        log_time_ns: u64,
        data: &[u8],
    ) -> Result<(), BagError> {
        let path = self.mcap_path();
        let Some(mcap) = self.mcap.as_mut() else {
            return Err(BagError::Message {
                topic: topic.to_owned(),
                reason: "bag already finished".into(),
            });
        };
        if !self.channels.contains_key(topic) {
            let text = schema::ros2msg(type_name).ok_or_else(|| BagError::Message {
                topic: topic.to_owned(),
                reason: format!("no ros2msg schema for type {type_name}"),
            })?;
            let hash = crate::type_hash::rihs01(type_name).map_err(|e| BagError::Message {
                topic: topic.to_owned(),
                reason: e.to_string(),
            })?;
            let qos = topics::spec(topic)
                .map(|spec| offered_qos_profiles(&spec.qos))
                .unwrap_or_else(|| {
                    offered_qos_profiles(&topics::Qos {
                        reliability: topics::Reliability::Reliable,
                        durability: topics::Durability::Volatile,
                        depth: 64,
                    })
                });
            let schema_id = mcap
                .add_schema(type_name, "ros2msg", text.as_bytes())
                .map_err(|e| mcap_error(&path, e))?;
            let metadata = BTreeMap::from([
                ("offered_qos_profiles".to_owned(), qos.clone()),
                ("topic_type_hash".to_owned(), hash.clone()),
            ]);
            let id = mcap
                .add_channel(schema_id, topic, "cdr", &metadata)
                .map_err(|e| mcap_error(&path, e))?;
            self.channels.insert(
                topic.to_owned(),
                Channel {
                    id,
                    type_name: type_name.to_owned(),
                    qos,
                    hash,
                    sequence: 0,
                    count: 0,
                },
            );
        }
        let channel = self.channels.get_mut(topic).expect("inserted above");
        if channel.type_name != type_name {
            return Err(BagError::Message {
                topic: topic.to_owned(),
                reason: format!(
                    "type {type_name} differs from the topic's recorded type {}",
                    channel.type_name
                ),
            });
        }
        channel.sequence = channel.sequence.wrapping_add(1);
        channel.count += 1;
        mcap.write_to_known_channel(
            &mcap::records::MessageHeader {
                channel_id: channel.id,
                sequence: channel.sequence,
                log_time: log_time_ns,
                publish_time: log_time_ns,
            },
            data,
        )
        .map_err(|e| mcap_error(&path, e))?;
        self.first_ns = Some(self.first_ns.map_or(log_time_ns, |t| t.min(log_time_ns)));
        self.last_ns = self.last_ns.max(log_time_ns);
        self.message_count += 1;
        // Record overhead: opcode, length, channel, sequence, two times.
        self.chunk_bytes += data.len() as u64 + 31;
        if self.chunk_bytes >= self.options.chunk_size_bytes {
            // Closes the chunk (with its message index) and flushes it to the file.
            mcap.flush().map_err(|e| mcap_error(&path, e))?;
            self.chunk_bytes = 0;
        }
        Ok(())
    }

    /// Closes the MCAP file (summary, footer) and writes metadata.yaml.
    pub fn finish(mut self) -> Result<BagInfo, BagError> {
        let path = self.mcap_path();
        if let Some(mut mcap) = self.mcap.take() {
            mcap.finish().map_err(|e| mcap_error(&path, e))?;
            let mut inner = mcap.into_inner();
            std::io::Write::flush(&mut inner).map_err(|source| BagError::Io {
                path: path.clone(),
                source,
            })?;
        }
        let start = self.first_ns.unwrap_or(0);
        let duration = Nanoseconds {
            nanoseconds: self.last_ns.saturating_sub(start),
        };
        let starting_time = StartingTime {
            nanoseconds_since_epoch: start,
        };
        let info = BagInfo {
            version: VERSION,
            storage_identifier: "mcap".into(),
            duration,
            starting_time,
            message_count: self.message_count,
            topics_with_message_count: self
                .channels
                .iter()
                .map(|(name, channel)| TopicWithCount {
                    topic_metadata: TopicMetadata {
                        name: name.clone(),
                        type_name: channel.type_name.clone(),
                        serialization_format: "cdr".into(),
                        offered_qos_profiles: channel.qos.clone(),
                        type_description_hash: channel.hash.clone(),
                    },
                    message_count: channel.count,
                })
                .collect(),
            compression_format: String::new(),
            compression_mode: String::new(),
            relative_file_paths: vec![self.file_name.clone()],
            files: vec![FileInfo {
                path: self.file_name.clone(),
                starting_time,
                duration,
                message_count: self.message_count,
            }],
            custom_data: self.options.custom_data.clone(),
            ros_distro: "nrslam".into(),
        };
        let yaml = MetadataFile {
            rosbag2_bagfile_information: info.clone(),
        }
        .to_yaml()
        .map_err(|e| BagError::Corrupt {
            path: self.dir.join("metadata.yaml"),
            reason: e.to_string(),
        })?;
        let metadata_path = self.dir.join("metadata.yaml");
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
        if let Some(mcap) = self.mcap.as_mut() {
            let _ = mcap.flush();
        }
    }
}
