//! The `bag` source node: publishes a recorded bag's messages onto the graph, in recorded order,
//! one frame (all messages of one log time) per tick. `launch/replay.toml` feeds the back end with
//! it; the back end's nodes see the same per-topic streams as in the recorded run, so (their
//! inputs being merged by (stamp, input order)) they compute the same results.

use super::{Bag, BagError, Messages, ReadMode};
use crate::node::{Node, NodeError, Outbox, Tick};
use nrslam_msgs::{topics, Message};
use serde::Deserialize;
use std::path::PathBuf;

/// Parameters of a `bag` node.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceParams {
    /// The bag folder. A relative path resolves against the current directory (it is usually given
    /// on the command line, `bag:=DIR`), not against the launch file.
    pub path: PathBuf,
    /// Topics to publish (each must be in the bag and in the topic catalogue); empty: every topic
    /// of the bag.
    #[serde(default)]
    pub topics: Vec<String>,
    /// Read a bag whose recorder was killed, up to its last complete chunk, skipping damaged
    /// chunks (each loss is logged).
    #[serde(default)]
    pub recover: bool,
    /// This bag stands in for a recorded run's front end: the launcher replaces the launch's
    /// other nodes by the back end recorded in the bag's `nrslam.nodes` (`launch/replay.toml`).
    /// The node itself plays the same either way.
    #[serde(default)]
    pub rebuild_recorded_back_end: bool,
}

/// Publishes a bag's messages; see the module docs. The messages are streamed from the file (one
/// chunk in memory at a time) and decoded as they are published.
pub struct BagSource {
    outputs: Vec<&'static str>,
    messages: Messages,
    pending: Option<(&'static str, Message)>,
}

impl BagSource {
    /// Opens the bag named by `params` and checks its topics (from the MCAP summary or
    /// metadata.yaml; a recovered bag without either is surveyed in one pass first).
    pub fn new(params: &SourceParams) -> Result<Self, BagError> {
        if params.path.as_os_str().is_empty() {
            return Err(BagError::NoPath);
        }
        let mode = if params.recover {
            ReadMode::Recover
        } else {
            ReadMode::Strict
        };
        let bag = Bag::open(&params.path, mode)?;
        let recorded = bag.known_topics()?;
        super::reader::check_topics(&params.topics, &recorded)?;
        let mut outputs: Vec<&'static str> = Vec::new();
        for topic in &recorded {
            if !params.topics.is_empty() && !params.topics.contains(&topic.name) {
                continue;
            }
            let spec = topics::spec(&topic.name).ok_or_else(|| BagError::Message {
                topic: topic.name.clone(),
                reason: "not a topic of the nrslam graph (see `nrslam topics`)".into(),
            })?;
            if spec.type_name != topic.type_name {
                return Err(BagError::Message {
                    topic: topic.name.clone(),
                    reason: format!(
                        "recorded as {}, the graph carries {}",
                        topic.type_name, spec.type_name
                    ),
                });
            }
            // The recorded name, under its namespace if any (/agv1/odom): the spec only
            // vouches for its type.
            let name = topics::intern(&topic.name);
            if !outputs.contains(&name) {
                outputs.push(name);
            }
        }
        let messages = bag.messages_on(&params.topics)?;
        Ok(Self {
            outputs,
            messages,
            pending: None,
        })
    }

    /// The next message, decoded; `None` at the end of the bag.
    fn next_message(&mut self) -> Result<Option<(&'static str, Message)>, NodeError> {
        let Some(read) = self.messages.next() else {
            return Ok(None);
        };
        let message = read.map_err(NodeError::algorithm)?;
        let name = self
            .outputs
            .iter()
            .copied()
            .find(|name| *name == message.topic)
            .ok_or_else(|| {
                NodeError::invalid_input(&message.topic, "not among the topics checked at start")
            })?;
        let decoded = message
            .decode()
            .map_err(|e| NodeError::invalid_input(name, e.to_string()))?;
        Ok(Some((name, decoded)))
    }
}

impl Node for BagSource {
    fn inputs(&self) -> Vec<&'static str> {
        Vec::new()
    }

    fn outputs(&self) -> Vec<&'static str> {
        self.outputs.clone()
    }

    fn on_message(&mut self, topic: &str, _: &Message, _: &mut Outbox) -> Result<(), NodeError> {
        Err(NodeError::invalid_input(
            topic,
            "a bag source has no inputs",
        ))
    }

    fn tick(&mut self, outbox: &mut Outbox) -> Result<Tick, NodeError> {
        let first = match self.pending.take() {
            Some(pending) => pending,
            None => match self.next_message()? {
                Some(message) => message,
                None => return Ok(Tick::Done),
            },
        };
        let stamp = first.1.stamp();
        outbox.publish(first.0, first.1);
        while let Some((topic, message)) = self.next_message()? {
            if message.stamp() != stamp {
                self.pending = Some((topic, message));
                return Ok(Tick::More);
            }
            outbox.publish(topic, message);
        }
        Ok(Tick::Done)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bag::{BagWriter, WriterOptions};
    use nrslam_msgs::{Clock, Header, Odometry, Time};

    #[test]
    fn publishes_one_frame_per_tick_in_recorded_order() {
        let dir = tempfile::tempdir().unwrap();
        let bag = dir.path().join("b");
        let mut writer = BagWriter::create(&bag, WriterOptions::default()).unwrap();
        for k in 1..=3 {
            let stamp = Time::from_seconds(k as f64);
            writer
                .write_message(topics::CLOCK, &Message::Clock(Clock { clock: stamp }))
                .unwrap();
            let odom = Odometry {
                header: Header::new(stamp, "odom"),
                ..Default::default()
            };
            writer
                .write_message(topics::ODOM, &Message::Odometry(odom))
                .unwrap();
        }
        writer.finish().unwrap();
        let mut source = BagSource::new(&SourceParams {
            path: bag.clone(),
            topics: vec![],
            recover: false,
            rebuild_recorded_back_end: false,
        })
        .unwrap();
        assert_eq!(source.outputs(), [topics::CLOCK, topics::ODOM]);
        let mut outbox = Outbox::new();
        let mut frames = Vec::new();
        loop {
            let tick = source.tick(&mut outbox).unwrap();
            let frame: Vec<(&str, f64)> = outbox
                .drain()
                .map(|(t, m)| (t, m.stamp().as_seconds()))
                .collect();
            if !frame.is_empty() {
                frames.push(frame);
            }
            if tick == Tick::Done {
                break;
            }
        }
        assert_eq!(frames.len(), 3);
        assert_eq!(frames[1], [(topics::CLOCK, 2.0), (topics::ODOM, 2.0)]);
        let only_odom = BagSource::new(&SourceParams {
            path: bag,
            topics: vec![topics::ODOM.into()],
            recover: false,
            rebuild_recorded_back_end: false,
        })
        .unwrap();
        assert_eq!(only_odom.outputs(), [topics::ODOM]);
    }
}
