//! A bag folder opened for reading: `metadata.yaml` (versions 4 to 9), its storage files in the
//! order metadata.yaml lists them (a bag split by size or duration has several), each file's MCAP
//! summary when intact, and one message stream running through the files in that order.

use super::metadata::{BagInfo, MetadataFile};
use super::reader::{
    check_topics, BagContents, BagMessage, FileMessages, FilePart, ReadMode, ReadReport, Summary,
    TopicSummary, IN_MEMORY_CHUNK_BYTES,
};
use super::BagError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// A bag folder opened for reading: metadata.yaml, each MCAP file's summary when intact, and the
/// recorded run's identity. [`Bag::messages`] streams its messages.
#[derive(Debug, Clone)]
pub struct Bag {
    dir: PathBuf,
    parts: Vec<FilePart>,
    metadata: Option<BagInfo>,
    mode: ReadMode,
    summary: Option<Summary>,
    custom_data: BTreeMap<String, String>,
    in_memory_chunk_bytes: u64,
}

/// The index `N` of a storage file named `<stem>_N.mcap` (rosbag2's split naming).
fn split_index(path: &Path) -> Option<u64> {
    let stem = path.file_stem()?.to_str()?;
    stem.rsplit_once('_')?.1.parse().ok()
}

/// The storage files of `dir`: metadata.yaml's `relative_file_paths` in order (each must exist,
/// except in Recover mode, where a missing one is left out with a warning), else every `.mcap`
/// file, in the order of their split index.
fn find_mcaps(
    dir: &Path,
    metadata: Option<&BagInfo>,
    mode: ReadMode,
) -> Result<Vec<PathBuf>, BagError> {
    if let Some(info) = metadata {
        if info.relative_file_paths.is_empty() {
            return Err(BagError::NotABag {
                path: dir.to_owned(),
                reason: "metadata.yaml lists no storage file".into(),
            });
        }
        let mut paths = Vec::new();
        for relative in &info.relative_file_paths {
            let rel = Path::new(relative);
            if rel.is_absolute() || rel.components().any(|c| c.as_os_str() == "..") {
                return Err(BagError::NotABag {
                    path: dir.to_owned(),
                    reason: format!("metadata.yaml lists {relative:?}, outside the bag folder"),
                });
            }
            let path = dir.join(rel);
            if path.is_file() {
                paths.push(path);
            } else if mode == ReadMode::Recover {
                tracing::warn!("{}: missing, left out", path.display());
            } else {
                return Err(BagError::NotABag {
                    path: dir.to_owned(),
                    reason: format!("metadata.yaml lists {relative}, which is missing"),
                });
            }
        }
        if paths.is_empty() {
            return Err(BagError::NotABag {
                path: dir.to_owned(),
                reason: "none of the storage files metadata.yaml lists is there".into(),
            });
        }
        return Ok(paths);
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|source| BagError::Io {
            path: dir.to_owned(),
            source,
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    found.sort_by(|a, b| (split_index(a), a).cmp(&(split_index(b), b)));
    if found.is_empty() {
        return Err(BagError::NotABag {
            path: dir.to_owned(),
            reason: "no .mcap file in it".into(),
        });
    }
    Ok(found)
}

fn read_metadata(dir: &Path, mode: ReadMode) -> Result<Option<BagInfo>, BagError> {
    let metadata_path = dir.join("metadata.yaml");
    let info = match std::fs::read_to_string(&metadata_path) {
        Ok(text) => {
            MetadataFile::from_yaml(&text)
                .map_err(|e| BagError::Corrupt {
                    path: metadata_path.clone(),
                    reason: format!("not rosbag2 metadata: {e}"),
                })?
                .rosbag2_bagfile_information
        }
        Err(_) if mode == ReadMode::Recover => return Ok(None),
        Err(_) => {
            return Err(BagError::NotABag {
                path: dir.to_owned(),
                reason: "no metadata.yaml (an MCAP file from the mcap tools: name the .mcap \
                         file itself; a recording cut off: try --recover)"
                    .into(),
            })
        }
    };
    if info.storage_identifier != "mcap" {
        return Err(BagError::NotABag {
            path: dir.to_owned(),
            reason: format!(
                "storage {:?} is not supported (only mcap)",
                info.storage_identifier
            ),
        });
    }
    if !info.compression_mode.is_empty() {
        return Err(BagError::NotABag {
            path: dir.to_owned(),
            reason: format!(
                "rosbag2 {} compression ({}) is not supported (MCAP chunk compression is)",
                info.compression_mode, info.compression_format
            ),
        });
    }
    Ok(Some(info))
}

impl Bag {
    /// Opens the bag folder `dir` (or, if `dir` is an `.mcap` file, that file alone): reads
    /// metadata.yaml, checks each storage file's MCAP magic and reads its summary section (Strict
    /// mode: it must be intact; Recover mode: a damaged or missing one is noted and not used).
    pub fn open(dir: &Path, mode: ReadMode) -> Result<Self, BagError> {
        if !dir.exists() {
            return Err(BagError::Io {
                path: dir.to_owned(),
                source: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or folder"),
            });
        }
        let (folder, metadata, paths) = if dir.is_file() {
            let folder = dir.parent().map(Path::to_owned).unwrap_or_default();
            (folder, None, vec![dir.to_owned()])
        } else {
            let metadata = read_metadata(dir, mode)?;
            let paths = find_mcaps(dir, metadata.as_ref(), mode)?;
            (dir.to_owned(), metadata, paths)
        };
        let mut parts = Vec::new();
        let mut file_custom = None;
        for path in &paths {
            let (part, custom) = FilePart::open(path, mode)?;
            if file_custom.is_none() {
                file_custom = custom;
            }
            parts.push(part);
        }
        let summary = if parts.iter().all(|p| p.summary.is_some()) {
            if parts.len() == 1 {
                parts[0].summary.clone()
            } else {
                Some(Summary::merged(
                    parts.iter().filter_map(|p| p.summary.as_ref()),
                ))
            }
        } else {
            None
        };
        let mut custom_data = metadata
            .as_ref()
            .map(|m| m.custom_data.clone())
            .unwrap_or_default();
        if custom_data.is_empty() {
            custom_data = file_custom.unwrap_or_default();
        }
        Ok(Self {
            dir: folder,
            parts,
            metadata,
            mode,
            summary,
            custom_data,
            in_memory_chunk_bytes: IN_MEMORY_CHUNK_BYTES,
        })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The first MCAP file (the only one of an unsplit bag).
    pub fn mcap_path(&self) -> &Path {
        &self.parts[0].path
    }

    /// Every MCAP file, in reading order.
    pub fn mcap_paths(&self) -> Vec<&Path> {
        self.parts.iter().map(|p| p.path.as_path()).collect()
    }

    /// Size of each MCAP file (bytes), in reading order.
    pub fn file_sizes(&self) -> Vec<u64> {
        self.parts.iter().map(|p| p.bytes).collect()
    }

    /// metadata.yaml, when present.
    pub fn metadata(&self) -> Option<&BagInfo> {
        self.metadata.as_ref()
    }

    /// How it is read.
    pub fn mode(&self) -> ReadMode {
        self.mode
    }

    /// Size of the MCAP files together (bytes).
    pub fn file_bytes(&self) -> u64 {
        self.parts.iter().map(|p| p.bytes).sum()
    }

    /// The MCAP summary sections, when every file has an intact one (their figures added up for a
    /// split bag).
    pub fn summary(&self) -> Option<&Summary> {
        self.summary.as_ref()
    }

    /// Why there is no summary (missing, damaged, too large), if there is none.
    pub fn summary_note(&self) -> Option<&str> {
        self.parts.iter().find_map(|p| p.note.as_deref())
    }

    /// The recorded run's identity (metadata.yaml `custom_data`, or the MCAP `nrslam` metadata
    /// record at the start of the first file).
    pub fn custom_data(&self) -> &BTreeMap<String, String> {
        &self.custom_data
    }

    /// The bag's topics without reading its messages: from the summaries' channels and
    /// statistics, else from metadata.yaml; `None` when neither is there (see [`Bag::survey`]).
    pub fn topics(&self) -> Option<Vec<TopicSummary>> {
        if let Some(summary) = &self.summary {
            return Some(summary.topics.clone());
        }
        let info = self.metadata.as_ref()?;
        Some(
            info.topics_with_message_count
                .iter()
                .map(|t| TopicSummary {
                    name: t.topic_metadata.name.clone(),
                    type_name: t.topic_metadata.type_name.clone(),
                    count: t.message_count,
                })
                .collect(),
        )
    }

    /// Sets the size above which chunks are read record by record instead of whole (tests).
    #[doc(hidden)]
    pub fn set_in_memory_chunk_bytes(&mut self, bytes: u64) {
        self.in_memory_chunk_bytes = bytes;
    }

    /// Streams every message, file after file, each in file order.
    pub fn messages(&self) -> Result<Messages, BagError> {
        self.stream(None, false)
    }

    /// Streams the messages of `topics` (all if empty). A topic the bag does not hold is an error
    /// when the bag's topics are known without reading ([`Bag::topics`]).
    pub fn messages_on(&self, topics: &[String]) -> Result<Messages, BagError> {
        if topics.is_empty() {
            return self.messages();
        }
        if let Some(known) = self.topics() {
            check_topics(topics, &known)?;
        }
        self.stream(Some(topics.to_vec()), false)
    }

    /// The bag's topics: [`Bag::topics`] when the summary or metadata.yaml has them, else (a
    /// recovered recording) from one [`Bag::survey`] pass over the files.
    pub fn known_topics(&self) -> Result<Vec<TopicSummary>, BagError> {
        match self.topics() {
            Some(topics) => Ok(topics),
            None => Ok(self.survey()?.topics),
        }
    }

    /// One pass over the files that counts messages per topic without handing them out.
    pub fn survey(&self) -> Result<ReadReport, BagError> {
        let mut stream = self.stream(None, true)?;
        for item in stream.by_ref() {
            item?;
        }
        Ok(stream.into_report())
    }

    /// Every message in memory, with the report of the pass.
    pub fn read_all(&self) -> Result<BagContents, BagError> {
        let mut stream = self.messages()?;
        let mut messages = Vec::new();
        for message in stream.by_ref() {
            messages.push(message?);
        }
        let report = stream.into_report();
        let mut custom_data = self.custom_data.clone();
        if custom_data.is_empty() {
            custom_data = report.custom_data;
        }
        Ok(BagContents {
            dir: self.dir.clone(),
            mcap_path: self.mcap_path().to_owned(),
            metadata: self.metadata.clone(),
            messages,
            topics: report.topics,
            chunks: report.chunks,
            losses: report.losses,
            custom_data,
            file_bytes: self.file_bytes(),
            stopped: report.stopped,
        })
    }

    fn stream(&self, filter: Option<Vec<String>>, count_only: bool) -> Result<Messages, BagError> {
        let mut messages = Messages {
            parts: self.parts.clone(),
            mode: self.mode,
            filter,
            count_only,
            in_memory_chunk_bytes: self.in_memory_chunk_bytes,
            next_part: 0,
            current: None,
            bytes_before: 0,
            report: ReadReport::default(),
            done: false,
        };
        messages.advance()?;
        Ok(messages)
    }
}

/// The messages of a bag, streamed file after file in metadata.yaml's order, each file in its
/// own order (see the `reader` module docs); an error ends the stream. [`Messages::report`] tells
/// what was read, skipped and lost.
pub struct Messages {
    parts: Vec<FilePart>,
    mode: ReadMode,
    filter: Option<Vec<String>>,
    count_only: bool,
    in_memory_chunk_bytes: u64,
    next_part: usize,
    current: Option<FileMessages>,
    /// Bytes of the files finished.
    bytes_before: u64,
    report: ReadReport,
    done: bool,
}

impl Messages {
    /// Moves to the next file, folding the finished one's report into the bag's.
    fn advance(&mut self) -> Result<bool, BagError> {
        if let Some(finished) = self.current.take() {
            let index = self.next_part - 1;
            self.bytes_before += self.parts[index].bytes;
            merge_report(
                &mut self.report,
                finished.into_report(),
                index,
                &self.parts[index].path,
            );
        }
        let Some(part) = self.parts.get(self.next_part) else {
            return Ok(false);
        };
        self.current = Some(part.messages(
            self.mode,
            self.filter.clone(),
            self.count_only,
            self.in_memory_chunk_bytes,
        )?);
        self.next_part += 1;
        Ok(true)
    }

    /// What has been read so far (of the files finished; all of it once the stream has ended).
    pub fn report(&self) -> &ReadReport {
        &self.report
    }

    /// The report, once done.
    pub fn into_report(mut self) -> ReadReport {
        if let Some(current) = self.current.take() {
            let index = self.next_part - 1;
            let path = self.parts[index].path.clone();
            merge_report(&mut self.report, current.into_report(), index, &path);
        }
        self.report
    }

    /// Bytes of the files passed so far (for progress).
    pub fn position(&self) -> u64 {
        self.bytes_before + self.current.as_ref().map_or(0, FileMessages::position)
    }
}

impl Iterator for Messages {
    type Item = Result<BagMessage, BagError>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if self.done {
                return None;
            }
            if let Some(item) = self.current.as_mut().and_then(Iterator::next) {
                if item.is_err() {
                    self.done = true;
                }
                return Some(item);
            }
            match self.advance() {
                Ok(true) => {}
                Ok(false) => {
                    self.done = true;
                    return None;
                }
                Err(e) => {
                    self.done = true;
                    return Some(Err(e));
                }
            }
        }
    }
}

/// Adds file `index`'s report to the bag's.
fn merge_report(into: &mut ReadReport, file: ReadReport, index: usize, path: &Path) {
    into.chunks.extend(
        file.chunks
            .into_iter()
            .map(|c| super::ChunkSpan { file: index, ..c }),
    );
    into.losses.extend(
        file.losses
            .into_iter()
            .map(|l| super::ChunkLoss { file: index, ..l }),
    );
    if let Some(stopped) = file.stopped {
        let line = format!("{}: {stopped}", path.display());
        into.stopped = Some(match into.stopped.take() {
            Some(before) => format!("{before}; {line}"),
            None => line,
        });
    }
    for topic in file.topics {
        match into.topics.iter_mut().find(|t| t.name == topic.name) {
            Some(t) => t.count += topic.count,
            None => into.topics.push(topic),
        }
    }
    into.messages += file.messages;
    into.time_range_ns = match (into.time_range_ns, file.time_range_ns) {
        (Some((a, b)), Some((c, d))) => Some((a.min(c), b.max(d))),
        (a, b) => a.or(b),
    };
    if into.custom_data.is_empty() {
        into.custom_data = file.custom_data;
    }
    for c in file.compressions {
        if !into.compressions.contains(&c) {
            into.compressions.push(c);
        }
    }
}
