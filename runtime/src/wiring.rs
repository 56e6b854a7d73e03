//! Whether a graph's nodes fit together before anything runs: every topic a node names is in the
//! catalogue, every input has a publisher among the nodes or is declared external (fed from
//! outside the launch, `[[external]]`), and a node declared respawnable can pick its streams up
//! halfway.

use crate::node::Node;
use nrslam_msgs::topics;

/// A graph that cannot run as declared, naming the node and the topic.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum WiringError {
    /// A node subscribes or publishes a topic the catalogue does not have (under a namespace or
    /// not).
    #[error("node {node}: topic {topic} is not in the catalogue")]
    UnknownTopic {
        /// Node instance name.
        node: String,
        /// The topic.
        topic: String,
    },
    /// A node subscribes a topic that no node of the graph publishes.
    #[error(
        "node {node} subscribes to {topic}, which no node of the launch publishes (declare it \
         [[external]] if it comes from outside)"
    )]
    NoPublisher {
        /// Node instance name.
        node: String,
        /// The topic.
        topic: String,
    },
    /// An `[[external]]` topic the catalogue does not have.
    #[error("external topic {topic} is not in the catalogue")]
    UnknownExternal {
        /// The topic.
        topic: String,
    },
    /// An `[[external]]` topic that a node of the launch publishes as well: two streams would
    /// interleave in one.
    #[error("external topic {topic} is published by node {node} of the launch as well")]
    ExternalPublished {
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

/// The names of `[[external]]` topics, as `&'static str` (interned), refused if one is neither
/// a catalogue topic nor one under a namespace (`/agv1/odom`). The names are kept as given: a
/// namespaced external is a topic of its own.
pub fn external_topics(externals: &[String]) -> Result<Vec<&'static str>, WiringError> {
    externals
        .iter()
        .map(|topic| match topics::spec(topic) {
            Some(_) => Ok(topics::intern(topic)),
            None => Err(WiringError::UnknownExternal {
                topic: topic.clone(),
            }),
        })
        .collect()
}

/// Checks every node's topics against the catalogue (a topic under a namespace, `/agv1/odom`, is
/// checked as the catalogue topic below it, [`topics::spec`]), that no node publishes an `externals`
/// topic, then every input against the outputs of the graph's nodes and `externals`; the first
/// problem in node order is the error.
pub fn check_wiring(
    nodes: &[(String, Box<dyn Node>)],
    externals: &[&'static str],
) -> Result<(), WiringError> {
    for (name, node) in nodes {
        for topic in node.inputs().into_iter().chain(node.outputs()) {
            if topics::spec(topic).is_none() {
                return Err(WiringError::UnknownTopic {
                    node: name.clone(),
                    topic: topic.to_owned(),
                });
            }
        }
        if let Some(topic) = node.outputs().into_iter().find(|t| externals.contains(t)) {
            return Err(WiringError::ExternalPublished {
                node: name.clone(),
                topic: topic.to_owned(),
            });
        }
        for topic in node.inputs() {
            if !externals.contains(&topic)
                && !nodes
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::{NodeResult, Outbox};
    use nrslam_msgs::Message;

    /// A node of given inputs and outputs that does nothing.
    struct Stub(Vec<&'static str>, Vec<&'static str>);

    impl Node for Stub {
        fn inputs(&self) -> Vec<&'static str> {
            self.0.clone()
        }
        fn outputs(&self) -> Vec<&'static str> {
            self.1.clone()
        }
        fn on_message(&mut self, _: &str, _: &Message, _: &mut Outbox) -> NodeResult {
            Ok(())
        }
    }

    fn graph(
        inputs: Vec<&'static str>,
        outputs: Vec<&'static str>,
    ) -> Vec<(String, Box<dyn Node>)> {
        vec![("adapter".to_owned(), Box::new(Stub(inputs, outputs)))]
    }

    #[test]
    fn an_external_topic_counts_as_published_and_only_from_outside() {
        let nodes = graph(vec![topics::ODOM], vec![topics::DETECTIONS]);
        assert_eq!(
            check_wiring(&nodes, &[]),
            Err(WiringError::NoPublisher {
                node: "adapter".into(),
                topic: topics::ODOM.into()
            })
        );
        assert_eq!(check_wiring(&nodes, &[topics::ODOM]), Ok(()));
        assert_eq!(
            check_wiring(&nodes, &[topics::ODOM, topics::DETECTIONS]),
            Err(WiringError::ExternalPublished {
                node: "adapter".into(),
                topic: topics::DETECTIONS.into()
            })
        );
        assert_eq!(external_topics(&["/odom".into()]), Ok(vec![topics::ODOM]));
        assert_eq!(
            external_topics(&["/agv1/odom".into()]),
            Ok(vec!["/agv1/odom"])
        );
        assert_eq!(
            external_topics(&["/nowhere".into()]),
            Err(WiringError::UnknownExternal {
                topic: "/nowhere".into()
            })
        );
    }

    #[test]
    fn namespaced_topics_are_checked_by_their_catalogue_topic_and_named_in_full() {
        let agv = |ns: &str, topic: &str| nrslam_msgs::topics::intern(&format!("/{ns}{topic}"));
        let nodes: Vec<(String, Box<dyn Node>)> = vec![
            (
                "agv1/radar".to_owned(),
                Box::new(Stub(vec![], vec![agv("agv1", topics::ODOM)])),
            ),
            (
                "agv1/association".to_owned(),
                Box::new(Stub(
                    vec![agv("agv1", topics::ODOM)],
                    vec![agv("agv1", topics::SLAM_POSE)],
                )),
            ),
            (
                "agv2/association".to_owned(),
                Box::new(Stub(vec![agv("agv2", topics::ODOM)], vec![])),
            ),
        ];
        assert_eq!(
            check_wiring(&nodes, &[]),
            Err(WiringError::NoPublisher {
                node: "agv2/association".into(),
                topic: "/agv2/odom".into()
            })
        );
        assert_eq!(check_wiring(&nodes[..2], &[]), Ok(()));
        let unknown: Vec<(String, Box<dyn Node>)> = vec![(
            "agv1/x".to_owned(),
            Box::new(Stub(vec![], vec![agv("agv1", "/nothing")])),
        )];
        assert_eq!(
            check_wiring(&unknown, &[]),
            Err(WiringError::UnknownTopic {
                node: "agv1/x".into(),
                topic: "/agv1/nothing".into()
            })
        );
    }
}
