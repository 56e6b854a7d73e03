//! Whether a graph's nodes fit together before anything runs: every topic a node names is in the
//! catalogue, every input has a publisher among the nodes, and a node declared respawnable can
//! pick its streams up halfway.

use crate::node::Node;
use nrslam_msgs::topics;

/// A graph that cannot run as declared, naming the node and the topic.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum WiringError {
    /// A node subscribes or publishes a topic the catalogue does not have.
    #[error("node {node}: topic {topic} is not in the catalogue")]
    UnknownTopic {
        /// Node instance name.
        node: String,
        /// The topic.
        topic: String,
    },
    /// A node subscribes a topic that no node of the graph publishes.
    #[error("node {node} subscribes to {topic}, which no node of the launch publishes")]
    NoPublisher {
        /// Node instance name.
        node: String,
        /// The topic.
        topic: String,
    },
    /// A source declared respawnable: restarted, it would start its stream over.
    #[error(
        "node {node}: respawn = true, but it is a source: a respawned source would start its \
         stream over"
    )]
    RespawnedSource {
        /// Node instance name.
        node: String,
    },
    /// A respawnable node with a latched input, published once at the start.
    #[error(
        "node {node}: respawn = true, but its input {topic} is published once at the start: a \
         respawned node would wait for it forever"
    )]
    RespawnedLatchedInput {
        /// Node instance name.
        node: String,
        /// The latched input.
        topic: String,
    },
}

/// Checks every node's topics against the catalogue, then every input against the outputs of
/// the graph's nodes; the first problem in node order is the error.
pub fn check_wiring(nodes: &[(String, Box<dyn Node>)]) -> Result<(), WiringError> {
    for (name, node) in nodes {
        for topic in node.inputs().into_iter().chain(node.outputs()) {
            if topics::spec(topic).is_none() {
                return Err(WiringError::UnknownTopic {
                    node: name.clone(),
                    topic: topic.to_owned(),
                });
            }
        }
        for topic in node.inputs() {
            if !nodes
                .iter()
                .any(|(_, other)| other.outputs().contains(&topic))
            {
                return Err(WiringError::NoPublisher {
                    node: name.clone(),
                    topic: topic.to_owned(),
                });
            }
        }
    }
    Ok(())
}

/// Checks that node `name` can be respawned: it is not a source, and none of its inputs is
/// latched (transient-local, published once at the start).
pub fn check_respawnable(name: &str, node: &dyn Node) -> Result<(), WiringError> {
    let inputs = node.inputs();
    if inputs.is_empty() {
        return Err(WiringError::RespawnedSource {
            node: name.to_owned(),
        });
    }
    let latched = inputs.into_iter().find(|t| {
        topics::spec(t).is_some_and(|s| s.qos.durability == topics::Durability::TransientLocal)
    });
    match latched {
        Some(topic) => Err(WiringError::RespawnedLatchedInput {
            node: name.to_owned(),
            topic: topic.to_owned(),
        }),
        None => Ok(()),
    }
}
