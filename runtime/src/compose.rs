//! In-process composition: the nodes of a graph wired directly, one thread, no transport.
//!
//! This is how batch and Monte Carlo runs execute, and, because every node's inputs go through the
//! same [`Merger`] as over zenoh, it produces exactly what the zenoh graph produces for a seed.
//!
//! A published message is moved into one [`Arc`] and shared by the observer and every subscriber:
//! nothing is copied per subscriber (a waveform echo is megabytes). Nodes read it by reference
//! ([`Node::on_message`] takes `&Message`), so a node copies only what it decides to keep.

use crate::merge::Merger;
use crate::node::{Node, NodeError, Outbox, Tick};
use nrslam_msgs::{Clock, Message};
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

/// A node failed while the graph ran.
#[derive(Debug, thiserror::Error)]
#[error("node '{node}' failed: {error}")]
pub struct GraphError {
    /// Instance name of the node.
    pub node: String,
    /// Its error.
    pub error: NodeError,
}

struct Slot {
    name: String,
    node: Box<dyn Node>,
    /// Decides the delivery order. It holds a stand-in per message (see [`stand_in`]); the
    /// messages themselves wait, shared, in `pending`.
    merger: Merger,
    /// Per input topic, in the merger's input order: the shared messages not yet delivered,
    /// in arrival order (the merger delivers one topic's messages in arrival order too).
    pending: Vec<(&'static str, VecDeque<Arc<Message>>)>,
    is_source: bool,
    ended: bool,
}

/// What the merger queues in place of `message`: a clock message with the same stamp.
///
/// The merger orders by (stamp, input order) and tells latched inputs by topic, so a stand-in
/// with the message's stamp is ordered exactly as the message itself would be, and costs no copy
/// of the payload whatever its size.
fn stand_in(message: &Message) -> Message {
    Message::Clock(Clock {
        clock: message.stamp(),
    })
}

impl Slot {
    /// Queues a shared message that arrived on `topic`.
    fn push(&mut self, topic: &'static str, message: Arc<Message>) {
        // Wiring comes from the node's own inputs, so the topic is always known.
        if self.merger.push(topic, stand_in(&message)).is_ok() {
            if let Some((_, queue)) = self.pending.iter_mut().find(|(t, _)| *t == topic) {
                queue.push_back(message);
            }
        }
    }

    /// The next message to deliver, in the merger's order.
    fn pop_ready(&mut self) -> Option<(&'static str, Arc<Message>)> {
        let (topic, stand_in) = self.merger.pop_ready()?;
        let message = self
            .pending
            .iter_mut()
            .find(|(t, _)| *t == topic)
            .and_then(|(_, queue)| queue.pop_front())
            .expect("the merger released a message that was queued on its topic");
        debug_assert_eq!(stand_in.stamp(), message.stamp());
        Some((topic, message))
    }
}

/// Nodes wired by topic name.
pub struct Graph {
    slots: Vec<Slot>,
    subscribers: BTreeMap<&'static str, Vec<usize>>,
}

/// Called for every message published in the graph, in publication order per topic.
pub trait Observer {
    /// `message` was published on `topic`.
    fn observe(&mut self, topic: &'static str, message: &Message) -> anyhow_free::Result;
    /// `topic` has ended.
    fn end(&mut self, _topic: &'static str) {}
}

/// Observer results without pulling anyhow into the runtime.
pub mod anyhow_free {
    /// An observer failure (e.g. a full disk while writing), boxed.
    pub type Result = std::result::Result<(), Box<dyn std::error::Error + Send + Sync>>;
}

impl<F: FnMut(&'static str, &Message)> Observer for F {
    fn observe(&mut self, topic: &'static str, message: &Message) -> anyhow_free::Result {
        self(topic, message);
        Ok(())
    }
}

impl Graph {
    /// A graph of `(instance name, node)`, wired by the nodes' declared inputs and outputs.
    pub fn new(nodes: Vec<(String, Box<dyn Node>)>) -> Self {
        let mut subscribers: BTreeMap<&'static str, Vec<usize>> = BTreeMap::new();
        let slots = nodes
            .into_iter()
            .enumerate()
            .map(|(index, (name, node))| {
                let inputs = node.inputs();
                for topic in &inputs {
                    subscribers.entry(topic).or_default().push(index);
                }
                Slot {
                    name,
                    merger: Merger::new(&inputs),
                    pending: inputs.iter().map(|&t| (t, VecDeque::new())).collect(),
                    is_source: inputs.is_empty(),
                    node,
                    ended: false,
                }
            })
            .collect();
        Self { slots, subscribers }
    }

    /// Runs the graph to the end of every source, handing every published message to `observer`.
    pub fn run(&mut self, observer: &mut dyn Observer) -> Result<(), GraphError> {
        let mut outbox = Outbox::new();
        loop {
            let mut any_source = false;
            for index in 0..self.slots.len() {
                if !self.slots[index].is_source || self.slots[index].ended {
                    continue;
                }
                any_source = true;
                let tick = self.slots[index]
                    .node
                    .tick(&mut outbox)
                    .map_err(|error| self.failure(index, error))?;
                self.route(&mut outbox, observer)?;
                if tick == Tick::Done {
                    self.end_node(index, observer)?;
                }
            }
            self.drain(observer)?;
            if !any_source {
                break;
            }
        }
        self.drain(observer)?;
        Ok(())
    }

    fn failure(&self, index: usize, error: NodeError) -> GraphError {
        GraphError {
            node: self.slots[index].name.clone(),
            error,
        }
    }

    fn route(
        &mut self,
        outbox: &mut Outbox,
        observer: &mut dyn Observer,
    ) -> Result<(), GraphError> {
        for (topic, message) in outbox.drain() {
            // Moved, not copied: the observer and every subscriber share this one allocation.
            let message = Arc::new(message);
            observer.observe(topic, &message).map_err(|e| GraphError {
                node: "observer".into(),
                error: NodeError::Algorithm(e),
            })?;
            if let Some(indices) = self.subscribers.get(topic) {
                for &index in indices {
                    self.slots[index].push(topic, Arc::clone(&message));
                }
            }
        }
        Ok(())
    }

    fn end_node(&mut self, index: usize, observer: &mut dyn Observer) -> Result<(), GraphError> {
        self.slots[index].ended = true;
        for topic in self.slots[index].node.outputs() {
            observer.end(topic);
            if let Some(indices) = self.subscribers.get(topic) {
                for &subscriber in indices {
                    let _ = self.slots[subscriber].merger.close(topic);
                }
            }
        }
        Ok(())
    }

    /// Delivers every ready message until nothing moves, ending nodes whose inputs are done.
    fn drain(&mut self, observer: &mut dyn Observer) -> Result<(), GraphError> {
        let mut outbox = Outbox::new();
        loop {
            let mut progressed = false;
            for index in 0..self.slots.len() {
                if self.slots[index].ended || self.slots[index].is_source {
                    continue;
                }
                while let Some((topic, message)) = self.slots[index].pop_ready() {
                    progressed = true;
                    self.slots[index]
                        .node
                        .on_message(topic, &message, &mut outbox)
                        .map_err(|error| self.failure(index, error))?;
                    self.route(&mut outbox, observer)?;
                }
                if self.slots[index].merger.finished() {
                    debug_assert!(self.slots[index].pending.iter().all(|(_, q)| q.is_empty()));
                    progressed = true;
                    self.slots[index]
                        .node
                        .on_end(&mut outbox)
                        .map_err(|error| self.failure(index, error))?;
                    self.route(&mut outbox, observer)?;
                    self.end_node(index, observer)?;
                }
            }
            if !progressed {
                return Ok(());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{topics, Clock, Time};

    struct Ticker {
        left: u32,
    }

    impl Node for Ticker {
        fn inputs(&self) -> Vec<&'static str> {
            vec![]
        }
        fn outputs(&self) -> Vec<&'static str> {
            vec![topics::CLOCK]
        }
        fn on_message(&mut self, _: &str, _: &Message, _: &mut Outbox) -> Result<(), NodeError> {
            Ok(())
        }
        fn tick(&mut self, outbox: &mut Outbox) -> Result<Tick, NodeError> {
            self.left -= 1;
            outbox.publish(
                topics::CLOCK,
                Clock {
                    clock: Time::from_seconds(10.0 - self.left as f64),
                },
            );
            Ok(if self.left == 0 {
                Tick::Done
            } else {
                Tick::More
            })
        }
    }

    /// Fails on its `fail_at`-th message; counts what it saw and whether it was told the end.
    struct Counter {
        seen: std::sync::Arc<std::sync::Mutex<(u32, bool)>>,
        fail_at: u32,
    }

    impl Node for Counter {
        fn inputs(&self) -> Vec<&'static str> {
            vec![topics::CLOCK]
        }
        fn outputs(&self) -> Vec<&'static str> {
            vec![]
        }
        fn on_message(
            &mut self,
            topic: &str,
            _: &Message,
            _: &mut Outbox,
        ) -> crate::node::NodeResult {
            let mut seen = self.seen.lock().unwrap();
            seen.0 += 1;
            if seen.0 == self.fail_at {
                return Err(NodeError::invalid_input(topic, "boom"));
            }
            Ok(())
        }
        fn on_end(&mut self, _: &mut Outbox) -> Result<(), NodeError> {
            self.seen.lock().unwrap().1 = true;
            Ok(())
        }
    }

    fn graph(fail_at: u32) -> (Graph, std::sync::Arc<std::sync::Mutex<(u32, bool)>>) {
        let seen = std::sync::Arc::new(std::sync::Mutex::new((0, false)));
        let nodes: Vec<(String, Box<dyn Node>)> = vec![
            ("ticker".into(), Box::new(Ticker { left: 5 })),
            (
                "counter".into(),
                Box::new(Counter {
                    seen: seen.clone(),
                    fail_at,
                }),
            ),
        ];
        (Graph::new(nodes), seen)
    }

    #[test]
    fn every_message_is_delivered_and_the_end_is_signalled() {
        let (mut graph, seen) = graph(u32::MAX);
        let mut published = 0;
        graph
            .run(&mut |_: &'static str, _: &Message| published += 1)
            .unwrap();
        assert_eq!(published, 5);
        assert_eq!(*seen.lock().unwrap(), (5, true));
    }

    #[test]
    fn a_failing_node_stops_the_graph_with_its_name_and_error() {
        let (mut graph, seen) = graph(3);
        let error = graph
            .run(&mut |_: &'static str, _: &Message| {})
            .unwrap_err();
        assert_eq!(error.node, "counter");
        assert!(
            error.to_string().contains("node 'counter' failed")
                && error.to_string().contains("boom"),
            "{error}"
        );
        assert_eq!(
            *seen.lock().unwrap(),
            (3, false),
            "nothing after the failure"
        );
    }
}
