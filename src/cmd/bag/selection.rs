//! `nrslam bag play`'s choice of topics: the filters (`--topics`, `--exclude-topics`, `--regex`,
//! `--exclude-regex`), the `--remap` renames, each topic's QoS and type hash, and the endpoint a
//! topic is published on.

use super::play::PlayArgs;
use anyhow::{anyhow, bail, Result};
use nrslam_msgs::topics;
use nrslam_runtime::bag::{Bag, TopicSummary};
use nrslam_runtime::transport::RosEndpoint;
use regex::Regex;
use std::collections::BTreeMap;

/// One topic to play.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct PlayTopic {
    /// Name in the bag.
    pub(super) source: String,
    /// Name published (after --remap).
    pub(super) target: String,
    pub(super) type_name: String,
    /// metadata.yaml's type_description_hash, when it has one.
    pub(super) hash: Option<String>,
    pub(super) qos: topics::Qos,
}

/// `--remap` pairs, checked: `FROM:=TO`, both topic names.
fn remaps(args: &[String]) -> Result<BTreeMap<String, String>> {
    let mut out = BTreeMap::new();
    for pair in args {
        let (from, to) = pair
            .split_once(":=")
            .ok_or_else(|| anyhow!("--remap: {pair:?} is not FROM:=TO"))?;
        for name in [from, to] {
            if !name.starts_with('/') || name.len() < 2 || name.contains(char::is_whitespace) {
                bail!("--remap: {name:?} in {pair:?} is not a topic name (/name)");
            }
        }
        if out.insert(from.to_owned(), to.to_owned()).is_some() {
            bail!("--remap: {from} is remapped twice");
        }
    }
    Ok(out)
}

/// QoS to offer for a played topic: the catalogue's when it is a catalogue topic of the same
/// type, else reliable and volatile, or transient local when the recording says so.
fn qos_of(bag: &Bag, topic: &TopicSummary) -> topics::Qos {
    if let Some(spec) = topics::spec(&topic.name).filter(|s| s.type_name == topic.type_name) {
        return spec.qos;
    }
    let latched = bag.metadata().is_some_and(|m| {
        m.topics_with_message_count.iter().any(|t| {
            t.topic_metadata.name == topic.name
                && t.topic_metadata
                    .offered_qos_profiles
                    .iter()
                    .any(|q| q.durability == "transient_local")
        })
    });
    topics::Qos {
        reliability: topics::Reliability::Reliable,
        durability: if latched {
            topics::Durability::TransientLocal
        } else {
            topics::Durability::Volatile
        },
        depth: if latched { 1 } else { 64 },
    }
}

/// The topics to play, in the bag's order, as `ros2 bag play` selects them.
pub(super) fn select(
    args: &PlayArgs,
    bag: &Bag,
    recorded: &[TopicSummary],
) -> Result<Vec<PlayTopic>> {
    let compile = |flag: &str, re: &Option<String>| -> Result<Option<Regex>> {
        re.as_deref()
            .map(|r| Regex::new(r).map_err(|e| anyhow!("{flag}: {e}")))
            .transpose()
    };
    let regex = compile("--regex", &args.regex)?;
    let exclude = compile("--exclude-regex", &args.exclude_regex)?;
    let names: Vec<&str> = recorded.iter().map(|t| t.name.as_str()).collect();
    for (flag, list) in [
        ("--topics", &args.topics),
        ("--exclude-topics", &args.exclude_topics),
    ] {
        for topic in list {
            if !names.contains(&topic.as_str()) {
                bail!(
                    "{}: {flag}: topic {topic} is not in the bag (recorded: {})",
                    args.dir.display(),
                    names.join(", ")
                );
            }
        }
    }
    let remap = remaps(&args.remap)?;
    for from in remap.keys() {
        if !names.contains(&from.as_str()) {
            bail!(
                "--remap: topic {from} is not in the bag (recorded: {})",
                names.join(", ")
            );
        }
    }
    let hashes: BTreeMap<&str, &str> = bag
        .metadata()
        .map(|m| {
            m.topics_with_message_count
                .iter()
                .filter(|t| !t.topic_metadata.type_description_hash.is_empty())
                .map(|t| {
                    (
                        t.topic_metadata.name.as_str(),
                        t.topic_metadata.type_description_hash.as_str(),
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    let everything = args.topics.is_empty() && regex.is_none();
    let mut out: Vec<PlayTopic> = Vec::new();
    for topic in recorded {
        let name = topic.name.as_str();
        let chosen = everything
            || args.topics.iter().any(|t| t == name)
            || regex.as_ref().is_some_and(|r| r.is_match(name));
        let excluded = args.exclude_topics.iter().any(|t| t == name)
            || exclude.as_ref().is_some_and(|r| r.is_match(name))
            || (args.clock.is_some() && name == topics::CLOCK);
        if !chosen || excluded {
            continue;
        }
        let target = remap.get(name).cloned().unwrap_or_else(|| name.to_owned());
        if let Some(other) = out.iter().find(|p| p.target == target) {
            if other.type_name != topic.type_name {
                bail!(
                    "--remap: {name} ({}) and {} ({}) would both be published as {target}",
                    topic.type_name,
                    other.source,
                    other.type_name
                );
            }
        }
        out.push(PlayTopic {
            source: topic.name.clone(),
            target,
            type_name: topic.type_name.clone(),
            hash: hashes.get(name).map(|h| (*h).to_owned()),
            qos: qos_of(bag, topic),
        });
    }
    if out.is_empty() {
        bail!(
            "{}: no topic selected (recorded: {})",
            args.dir.display(),
            names.join(", ")
        );
    }
    Ok(out)
}

pub(super) fn endpoint(topic: &PlayTopic, hash: Option<String>) -> RosEndpoint {
    RosEndpoint {
        topic: topic.target.clone(),
        type_name: topic.type_name.clone(),
        type_hash: hash,
        qos: topic.qos,
    }
}
