//! The node abstraction: a pure algorithm behind one small trait.
//!
//! A node turns input messages into output messages and never sees a transport. The runtime
//! delivers each node's inputs merged in (stamp, input order) (see [`crate::merge`]), so a node is a
//! deterministic function of its input streams and runs identically over zenoh, in one process, or
//! in a Monte Carlo batch.

use nrslam_msgs::Message;
use std::path::PathBuf;

/// What a node asks of the runtime after a tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tick {
    /// Tick again: more frames follow.
    More,
    /// The source is exhausted; its outputs end.
    Done,
}

/// Messages a node publishes while handling one event, in publication order.
#[derive(Debug, Default)]
pub struct Outbox {
    messages: Vec<(&'static str, Message)>,
}

impl Outbox {
    /// An empty outbox.
    pub fn new() -> Self {
        Self::default()
    }

    /// Publishes `message` on `topic`.
    pub fn publish(&mut self, topic: &'static str, message: impl Into<Message>) {
        self.messages.push((topic, message.into()));
    }

    /// Takes the published messages, leaving the outbox empty.
    pub fn drain(&mut self) -> std::vec::Drain<'_, (&'static str, Message)> {
        self.messages.drain(..)
    }

    /// Number of messages waiting.
    pub fn len(&self) -> usize {
        self.messages.len()
    }

    /// No message waiting.
    pub fn is_empty(&self) -> bool {
        self.messages.is_empty()
    }
}

/// Why a node failed. The supervisor reports it with the node's name and stops the graph.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// A message the node cannot use (wrong type on a topic, NaN where a number is needed, ...).
    #[error("invalid input on {topic}: {reason}")]
    InvalidInput {
        /// Topic of the offending message.
        topic: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The algorithm failed.
    #[error("{0}")]
    Algorithm(Box<dyn std::error::Error + Send + Sync + 'static>),
    /// The node's parameters are invalid.
    #[error(transparent)]
    Params(#[from] crate::config::InvalidParam),
}

impl NodeError {
    /// A message on `topic` the node cannot use.
    pub fn invalid_input(topic: &str, reason: impl Into<String>) -> Self {
        Self::InvalidInput {
            topic: topic.to_owned(),
            reason: reason.into(),
        }
    }

    /// A message the node has no use for: a type it does not take, or a topic it does not
    /// subscribe. The reason names what the catalogue carries on `topic`, so a user who wired a
    /// launch file wrongly sees both types.
    pub fn unexpected(topic: &str, message: &nrslam_msgs::Message) -> Self {
        let expected = match nrslam_msgs::topics::spec(topic) {
            Some(spec) => format!("{topic} carries {}", spec.type_name),
            None => format!("{topic} is not a topic of the catalogue"),
        };
        Self::invalid_input(
            topic,
            format!("unexpected {} ({expected})", message.type_name()),
        )
    }

    /// Wraps an algorithm's error.
    pub fn algorithm(error: impl std::error::Error + Send + Sync + 'static) -> Self {
        Self::Algorithm(Box::new(error))
    }
}

/// What a node's handlers return: nothing, or why the node failed.
pub type NodeResult<T = ()> = Result<T, NodeError>;

/// A stage of the graph.
pub trait Node: Send {
    /// Topics subscribed, in the order ties in stamp are broken (earlier is delivered first).
    fn inputs(&self) -> Vec<&'static str>;

    /// Topics published.
    fn outputs(&self) -> Vec<&'static str>;

    /// Handles one input message; results go to `outbox`.
    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult;

    /// Sources (nodes without inputs) are ticked until they return [`Tick::Done`].
    fn tick(&mut self, _outbox: &mut Outbox) -> Result<Tick, NodeError> {
        Ok(Tick::Done)
    }

    /// Every input has ended: publish anything still pending.
    fn on_end(&mut self, _outbox: &mut Outbox) -> Result<(), NodeError> {
        Ok(())
    }
}

/// What a node is told when it is built.
#[derive(Debug, Clone)]
pub struct NodeContext {
    /// The node's instance name in the launch file.
    pub name: String,
    /// The run's seed.
    pub seed: u64,
    /// Directory against which relative paths in the node's parameters are resolved.
    pub base_dir: PathBuf,
    /// The namespace the node runs in (`agv1`, `site/agv1`; empty: none). Its topics are
    /// renamed outside it ([`crate::remap::Remapped`]); the node itself sees catalogue names and
    /// uses the namespace only for its random streams ([`NodeContext::seed_for`]).
    pub namespace: String,
}

impl NodeContext {
    /// A context for tests and tools: name "node", the given seed, the current directory.
    pub fn for_tests(seed: u64) -> Self {
        Self {
            name: "node".into(),
            seed,
            base_dir: PathBuf::from("."),
            namespace: String::new(),
        }
    }

    /// A seed for the random stream called `stream`, derived from the run seed so that each
    /// stream is independent of the others and of how nodes are spread over processes. Under a
    /// namespace the stream is `<namespace>/<stream>`, so two agents running the same node kind
    /// draw independent noise; without one it is `stream` alone, so that runs without namespaces
    /// keep their bytes.
    pub fn seed_for(&self, stream: &str) -> u64 {
        if self.namespace.is_empty() {
            crate::seed::derive(self.seed, stream)
        } else {
            crate::seed::derive(self.seed, &format!("{}/{stream}", self.namespace))
        }
    }

    /// `path` resolved against [`Self::base_dir`] when relative.
    pub fn resolve(&self, path: &std::path::Path) -> PathBuf {
        if path.is_absolute() {
            path.to_owned()
        } else {
            self.base_dir.join(path)
        }
    }
}

impl Outbox {
    /// The waiting messages, in publication order.
    pub fn iter(&self) -> impl Iterator<Item = &(&'static str, Message)> {
        self.messages.iter()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{topics, Message, Odometry};

    #[test]
    fn a_namespace_gives_its_own_seed_streams_and_none_keeps_the_old_ones() {
        let plain = NodeContext::for_tests(7);
        // Without a namespace: exactly the stream's seed of every run so far.
        assert_eq!(plain.seed_for("radar"), crate::seed::derive(7, "radar"));
        let agv = |namespace: &str| NodeContext {
            namespace: namespace.into(),
            ..NodeContext::for_tests(7)
        };
        assert_eq!(
            agv("agv1").seed_for("radar"),
            crate::seed::derive(7, "agv1/radar")
        );
        assert_ne!(agv("agv1").seed_for("radar"), agv("agv2").seed_for("radar"));
        assert_ne!(agv("agv1").seed_for("radar"), plain.seed_for("radar"));
    }

    #[test]
    fn an_unexpected_message_names_what_it_is_and_what_the_topic_carries() {
        let odometry = Message::Odometry(Odometry::default());
        let error = NodeError::unexpected(topics::MAP, &odometry).to_string();
        assert_eq!(
            error,
            "invalid input on /map: unexpected nav_msgs/msg/Odometry (/map carries \
             nav_msgs/msg/OccupancyGrid)"
        );
        let error = NodeError::unexpected("/elsewhere", &odometry).to_string();
        assert!(
            error.ends_with("(/elsewhere is not a topic of the catalogue)"),
            "{error}"
        );
    }
}
