//! `launch --record DIR`: the bag a run is recorded into.

use super::build::Built;
use super::replay::run_identity;
use super::LaunchArgs;
use anyhow::{Context, Result};
use nrslam_msgs::{topics, Message};
use nrslam_runtime::bag::{BagWriter, WriterOptions};
use nrslam_runtime::launch::Launch;
use std::path::Path;

/// A bag being recorded from a run, with the topics it takes.
pub(crate) struct Recorder {
    writer: BagWriter,
    pub(super) topics: Vec<&'static str>,
}

impl Recorder {
    pub(super) fn take(&mut self, topic: &'static str, message: &Message) -> Result<()> {
        if self.topics.contains(&topic) {
            self.writer.write_message(topic, message)?;
        }
        Ok(())
    }

    pub(super) fn finish(self) -> Result<()> {
        let dir = self.writer.dir().to_owned();
        let info = self.writer.finish()?;
        eprintln!(
            "recorded {} messages on {} topic(s) into {}",
            info.message_count,
            info.topics_with_message_count.len(),
            dir.display()
        );
        Ok(())
    }
}

/// A recorder for `launch --record DIR`: the topics asked for (default: every topic the launch
/// publishes) and the run's identity in `custom_data`.
pub(super) fn recorder(
    args: &LaunchArgs,
    launch: &Launch,
    built: &Built,
    dir: &Path,
) -> Result<Recorder> {
    let published = published_topics(built);
    let topics = if args.record_topics.is_empty() {
        published
    } else {
        crate::cmd::bag::catalogue_topics(&args.record_topics)?
    };
    let writer = BagWriter::create_with(
        dir,
        WriterOptions {
            chunk_size_bytes: args.chunk.bytes()?,
            custom_data: run_identity(launch, args.seed())?,
        },
        args.storage.options()?,
    )
    .context("--record")?;
    Ok(Recorder { writer, topics })
}

/// Every topic the launch's nodes publish, in catalogue order (a topic under a namespace,
/// `/agv1/odom`, beside its catalogue topic, namespaces in name order): for a launch without
/// namespaces, exactly the catalogue topics it publishes, in the order they were always recorded.
pub(super) fn published_topics(built: &Built) -> Vec<&'static str> {
    let mut published: Vec<&'static str> = Vec::new();
    for (_, node) in &built.nodes {
        for topic in node.outputs() {
            if !published.contains(&topic) {
                published.push(topic);
            }
        }
    }
    let rank = |topic: &str| {
        let base = topics::base_name(topic).unwrap_or(topic);
        topics::CATALOGUE
            .iter()
            .position(|t| t.name == base)
            .unwrap_or(usize::MAX)
    };
    published.sort_by(|a, b| rank(a).cmp(&rank(b)).then_with(|| a.cmp(b)));
    published
}
