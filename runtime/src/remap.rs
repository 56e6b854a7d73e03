//! Namespaces and topic remapping, as ROS 2 gives them to a node (`__ns:=/agv1`,
//! `/from:=/to`): the node's own code keeps its catalogue topic names, and [`Remapped`] renames
//! them at its boundary.
//!
//! Several agents run the same node kinds (a radar, an association, ...) side by side; under
//! namespace `agv1` every topic of the node becomes `/agv1<topic>` (`/odom` → `/agv1/odom`),
//! except the topics remapped, which take their remap's absolute name verbatim (e.g. one shared
//! `/ground_truth/targets`). A graph without namespaces or remaps never builds a [`Remapped`]
//! ([`wrap`] returns the node itself), so its runs are untouched.

use crate::node::{Node, NodeError, NodeResult, Outbox, Tick};
use nrslam_msgs::{topics, Message};
use std::collections::BTreeMap;

/// A namespace or remap that cannot be applied to a node.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RemapError {
    /// The namespace is not segments of letters, digits and `_` separated by `/`.
    #[error("namespace {0}")]
    Namespace(String),
    /// A remap key that the node neither subscribes nor publishes.
    #[error("remap {from}: not a topic of this node (its topics: {topics})")]
    NotATopic {
        /// The remap key.
        from: String,
        /// The node's inputs and outputs, comma-separated.
        topics: String,
    },
    /// A remap value that cannot carry the key's messages.
    #[error("remap {from} = {to}: {problem}")]
    Target {
        /// The remap key.
        from: String,
        /// The remap value.
        to: String,
        /// What is wrong.
        problem: String,
    },
    /// Two of the node's topics renamed to one name: its inputs could not be told apart.
    #[error("{first} and {second} would both be {to} (each topic of a node needs its own name)")]
    Collision {
        /// One topic of the node.
        first: String,
        /// Another.
        second: String,
        /// The name both would get.
        to: String,
    },
}

/// Why `to` cannot be the value of a remap (`None`: it can): it must be an absolute topic name
/// that is a catalogue topic, or one under a namespace ([`topics::spec`]).
pub fn target_problem(to: &str) -> Option<String> {
    if !to.starts_with('/') {
        return Some("the new name must be absolute, starting with '/' (e.g. \"/odom\")".into());
    }
    if topics::spec(to).is_none() {
        return Some(
            "not a catalogue topic (`nrslam topics`), nor one under a namespace (e.g. \
             /agv1/odom)"
                .into(),
        );
    }
    None
}

/// A node under a namespace and/or with remapped topics: the inner node's topic names mapped to
/// the external ones for [`Node::inputs`] and [`Node::outputs`], incoming topics mapped back
/// before the inner node sees them, and what it publishes renamed on the way out.
pub struct Remapped {
    inner: Box<dyn Node>,
    namespace: String,
    /// Inner name → external name, for the topics remapped explicitly.
    remap: BTreeMap<&'static str, &'static str>,
    inputs: Vec<&'static str>,
    outputs: Vec<&'static str>,
    /// External name → inner name, for every input and output.
    inner_of: BTreeMap<&'static str, &'static str>,
    /// What the inner node publishes, before it is renamed.
    scratch: Outbox,
}

impl std::fmt::Debug for Remapped {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Remapped")
            .field("namespace", &self.namespace)
            .field("inputs", &self.inputs)
            .field("outputs", &self.outputs)
            .finish_non_exhaustive()
    }
}

impl Remapped {
    /// `inner` under `namespace` (empty: none) with `remap` (the node's own topic names → the
    /// absolute names they take). Refused: an invalid namespace, a key that is not one of the
    /// node's topics (the error lists them), a value that is not a catalogue topic (under a
    /// namespace or not) of the key's type, two topics of the node ending up with one name.
    pub fn new(
        inner: Box<dyn Node>,
        namespace: &str,
        remap: &BTreeMap<String, String>,
    ) -> Result<Self, RemapError> {
        if let Some(problem) = topics::namespace_problem(namespace) {
            return Err(RemapError::Namespace(problem));
        }
        let inner_inputs = inner.inputs();
        let inner_outputs = inner.outputs();
        let mut own: Vec<&'static str> = inner_inputs.clone();
        for &topic in &inner_outputs {
            if !own.contains(&topic) {
                own.push(topic);
            }
        }
        let mut explicit = BTreeMap::new();
        for (from, to) in remap {
            let Some(&key) = own.iter().find(|t| **t == from.as_str()) else {
                return Err(RemapError::NotATopic {
                    from: from.clone(),
                    topics: own.join(", "),
                });
            };
            let target = |problem: String| RemapError::Target {
                from: from.clone(),
                to: to.clone(),
                problem,
            };
            if let Some(problem) = target_problem(to) {
                return Err(target(problem));
            }
            if let (Some(a), Some(b)) = (topics::spec(key), topics::spec(to)) {
                if a.type_name != b.type_name {
                    return Err(target(format!(
                        "{from} carries {}, {to} {}",
                        a.type_name, b.type_name
                    )));
                }
            }
            explicit.insert(key, topics::intern(to));
        }
        let mut remapped = Self {
            inner,
            namespace: namespace.to_owned(),
            remap: explicit,
            inputs: Vec::new(),
            outputs: Vec::new(),
            inner_of: BTreeMap::new(),
            scratch: Outbox::new(),
        };
        for &topic in &own {
            let external = remapped.external(topic);
            if let Some(&first) = remapped.inner_of.get(external) {
                return Err(RemapError::Collision {
                    first: first.to_owned(),
                    second: topic.to_owned(),
                    to: external.to_owned(),
                });
            }
            remapped.inner_of.insert(external, topic);
        }
        remapped.inputs = inner_inputs.iter().map(|t| remapped.external(t)).collect();
        remapped.outputs = inner_outputs.iter().map(|t| remapped.external(t)).collect();
        Ok(remapped)
    }

    /// The external name of the inner node's topic `topic`.
    fn external(&self, topic: &str) -> &'static str {
        match self.remap.get(topic) {
            Some(to) => to,
            None => topics::intern(&topics::namespaced(&self.namespace, topic)),
        }
    }

    /// Moves what the inner node published into `outbox`, renamed, in publication order.
    fn forward(&mut self, outbox: &mut Outbox) {
        let published: Vec<(&'static str, Message)> = self.scratch.drain().collect();
        for (topic, message) in published {
            let external = self.external(topic);
            outbox.publish(external, message);
        }
    }

    /// The inner node's error, with an input topic named as the graph knows it.
    fn outside(&self, error: NodeError) -> NodeError {
        match error {
            NodeError::InvalidInput { topic, reason } => NodeError::InvalidInput {
                topic: self.external(&topic).to_owned(),
                reason,
            },
            other => other,
        }
    }
}

impl Node for Remapped {
    fn inputs(&self) -> Vec<&'static str> {
        self.inputs.clone()
    }

    fn outputs(&self) -> Vec<&'static str> {
        self.outputs.clone()
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        // A topic that is not one of ours goes through as is: the inner node refuses it by name.
        let inner_topic = self.inner_of.get(topic).copied().unwrap_or(topic);
        let result = self
            .inner
            .on_message(inner_topic, message, &mut self.scratch);
        self.forward(outbox);
        result.map_err(|e| self.outside(e))
    }

    fn tick(&mut self, outbox: &mut Outbox) -> Result<Tick, NodeError> {
        let result = self.inner.tick(&mut self.scratch);
        self.forward(outbox);
        result.map_err(|e| self.outside(e))
    }

    fn on_end(&mut self, outbox: &mut Outbox) -> Result<(), NodeError> {
        let result = self.inner.on_end(&mut self.scratch);
        self.forward(outbox);
        result.map_err(|e| self.outside(e))
    }
}

/// `node` under `namespace` with `remap` ([`Remapped`]); the node itself when both are empty, so
/// that a graph without namespaces runs exactly the nodes it always ran.
pub fn wrap(
    node: Box<dyn Node>,
    namespace: &str,
    remap: &BTreeMap<String, String>,
) -> Result<Box<dyn Node>, RemapError> {
    if namespace.is_empty() && remap.is_empty() {
        return Ok(node);
    }
    Ok(Box::new(Remapped::new(node, namespace, remap)?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{Clock, Odometry};

    /// Subscribes /odom, publishes /slam/pose and /clock; echoes each input as a clock message on
    /// /clock and records the topic names it was handed.
    struct Echo {
        seen: std::sync::Arc<std::sync::Mutex<Vec<String>>>,
    }

    impl Node for Echo {
        fn inputs(&self) -> Vec<&'static str> {
            vec![topics::ODOM]
        }
        fn outputs(&self) -> Vec<&'static str> {
            vec![topics::CLOCK, topics::SLAM_POSE, topics::GROUND_TRUTH_POSE]
        }
        fn on_message(
            &mut self,
            topic: &str,
            message: &Message,
            outbox: &mut Outbox,
        ) -> NodeResult {
            self.seen.lock().unwrap().push(topic.to_owned());
            if topic != topics::ODOM {
                return Err(NodeError::unexpected(topic, message));
            }
            outbox.publish(
                topics::CLOCK,
                Clock {
                    clock: message.stamp(),
                },
            );
            Ok(())
        }
        fn on_end(&mut self, outbox: &mut Outbox) -> NodeResult {
            outbox.publish(topics::CLOCK, Clock::default());
            Ok(())
        }
    }

    fn echo() -> (Box<dyn Node>, std::sync::Arc<std::sync::Mutex<Vec<String>>>) {
        let seen = std::sync::Arc::default();
        (
            Box::new(Echo {
                seen: std::sync::Arc::clone(&seen),
            }),
            seen,
        )
    }

    fn remap(pairs: &[(&str, &str)]) -> BTreeMap<String, String> {
        pairs
            .iter()
            .map(|(a, b)| (a.to_string(), b.to_string()))
            .collect()
    }

    #[test]
    fn a_namespace_renames_every_topic_both_ways_and_a_remap_takes_its_value() {
        let (inner, seen) = echo();
        let mut node =
            Remapped::new(inner, "agv1", &remap(&[("/clock", "/clock")])).expect("valid");
        assert_eq!(node.inputs(), ["/agv1/odom"]);
        assert_eq!(
            node.outputs(),
            ["/clock", "/agv1/slam/pose", "/agv1/ground_truth/pose"]
        );
        let mut outbox = Outbox::new();
        let odometry = Message::Odometry(Odometry::default());
        node.on_message("/agv1/odom", &odometry, &mut outbox)
            .unwrap();
        node.on_end(&mut outbox).unwrap();
        assert_eq!(*seen.lock().unwrap(), ["/odom"]);
        let published: Vec<&str> = outbox.drain().map(|(t, _)| t).collect();
        assert_eq!(published, ["/clock", "/clock"]);
        // An input error names the topic as the graph knows it.
        let clock = Message::Clock(Clock::default());
        let error = node.on_message("/agv1/odom", &clock, &mut outbox).map(drop);
        assert!(error.is_ok(), "a clock on /odom is forwarded as a clock");
        let error = node
            .on_message("/agv1/slam/pose", &odometry, &mut outbox)
            .unwrap_err()
            .to_string();
        assert!(
            error.starts_with("invalid input on /agv1/slam/pose"),
            "{error}"
        );
    }

    #[test]
    fn without_namespace_or_remap_the_node_is_not_wrapped() {
        let (inner, _) = echo();
        let node = wrap(inner, "", &BTreeMap::new()).unwrap();
        assert_eq!(node.inputs(), [topics::ODOM]);
        assert_eq!(
            node.outputs(),
            [topics::CLOCK, topics::SLAM_POSE, topics::GROUND_TRUTH_POSE]
        );
        let (inner, _) = echo();
        let node = wrap(inner, "", &remap(&[("/slam/pose", "/agv9/slam/pose")])).unwrap();
        assert_eq!(node.inputs(), [topics::ODOM]);
        assert_eq!(
            node.outputs(),
            ["/clock", "/agv9/slam/pose", "/ground_truth/pose"]
        );
    }

    #[test]
    fn bad_namespaces_and_remaps_are_refused_by_name() {
        let refused = |namespace: &str, pairs: &[(&str, &str)]| {
            let (inner, _) = echo();
            Remapped::new(inner, namespace, &remap(pairs))
                .unwrap_err()
                .to_string()
        };
        let error = refused("agv 1", &[]);
        assert!(error.starts_with("namespace \"agv 1\""), "{error}");
        assert_eq!(
            refused("a1", &[("/map", "/map")]),
            "remap /map: not a topic of this node (its topics: /odom, /clock, /slam/pose, \
             /ground_truth/pose)"
        );
        let error = refused("a1", &[("/odom", "odom")]);
        assert!(error.contains("must be absolute"), "{error}");
        let error = refused("a1", &[("/odom", "/a1/nothing")]);
        assert!(error.contains("not a catalogue topic"), "{error}");
        let error = refused("a1", &[("/odom", "/a1/map")]);
        assert!(
            error.contains(
                "/odom carries nav_msgs/msg/Odometry, /a1/map nav_msgs/msg/OccupancyGrid"
            ),
            "{error}"
        );
        // Same type: accepted, unless two topics of the node end up with one name.
        let (inner, _) = echo();
        let pairs = remap(&[("/slam/pose", "/b2/ground_truth/pose")]);
        assert!(Remapped::new(inner, "a1", &pairs).is_ok());
        assert_eq!(
            refused("a1", &[("/slam/pose", "/a1/ground_truth/pose")]),
            "/slam/pose and /ground_truth/pose would both be /a1/ground_truth/pose (each topic of \
             a node needs its own name)"
        );
    }
}
