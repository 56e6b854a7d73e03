//! Deterministic delivery: a node's input streams merged in (stamp, input order).
//!
//! Over a network, messages on different topics arrive interleaved at the whim of scheduling; on
//! one topic they arrive in order. The merger holds each input's queue and releases the message
//! with the smallest (stamp, input index) only once every open input has something queued, so
//! the order a node sees depends on the streams alone and never on arrival timing. This is what
//! makes the zenoh graph and the in-process composition agree bit for bit. Latched inputs (QoS
//! transient local, e.g. `/ground_truth/targets`) are delivered before anything else.

use nrslam_msgs::topics::{self, Durability};
use nrslam_msgs::Message;
use std::collections::VecDeque;

#[derive(Debug)]
struct InputQueue {
    topic: &'static str,
    latched: bool,
    queue: VecDeque<Message>,
    received: bool,
    closed: bool,
}

/// A message pushed for a topic the node does not subscribe to.
#[derive(Debug, thiserror::Error)]
#[error("topic {0} is not an input of this node")]
pub struct NotAnInput(pub String);

/// Merges a node's inputs; see the module docs.
#[derive(Debug)]
pub struct Merger {
    inputs: Vec<InputQueue>,
}

impl Merger {
    /// A merger over `inputs`, in tie-breaking order. Latched-ness comes from the catalogue.
    pub fn new(inputs: &[&'static str]) -> Self {
        let inputs = inputs
            .iter()
            .map(|&topic| InputQueue {
                topic,
                latched: topics::spec(topic)
                    .is_some_and(|s| s.qos.durability == Durability::TransientLocal),
                queue: VecDeque::new(),
                received: false,
                closed: false,
            })
            .collect();
        Self { inputs }
    }

    fn input_mut(&mut self, topic: &str) -> Result<&mut InputQueue, NotAnInput> {
        self.inputs
            .iter_mut()
            .find(|i| i.topic == topic)
            .ok_or_else(|| NotAnInput(topic.to_owned()))
    }

    /// Queues a message that arrived on `topic`.
    pub fn push(&mut self, topic: &str, message: Message) -> Result<(), NotAnInput> {
        let input = self.input_mut(topic)?;
        input.received = true;
        input.queue.push_back(message);
        Ok(())
    }

    /// Marks `topic` as ended: nothing more will arrive on it.
    pub fn close(&mut self, topic: &str) -> Result<(), NotAnInput> {
        self.input_mut(topic)?.closed = true;
        Ok(())
    }

    /// The next message to deliver, if it can be decided yet.
    pub fn pop_ready(&mut self) -> Option<(&'static str, Message)> {
        // Latched inputs first: nothing else moves until each has delivered or ended.
        for input in self.inputs.iter_mut().filter(|i| i.latched) {
            if let Some(message) = input.queue.pop_front() {
                return Some((input.topic, message));
            }
            if !input.received && !input.closed {
                return None;
            }
        }
        let mut best: Option<(usize, nrslam_msgs::Time)> = None;
        for (index, input) in self.inputs.iter().enumerate().filter(|(_, i)| !i.latched) {
            match input.queue.front() {
                None if input.closed => continue,
                None => return None,
                Some(message) => {
                    let stamp = message.stamp();
                    if best.is_none_or(|(_, best_stamp)| stamp < best_stamp) {
                        best = Some((index, stamp));
                    }
                }
            }
        }
        let (index, _) = best?;
        let input = &mut self.inputs[index];
        input
            .queue
            .pop_front()
            .map(|message| (input.topic, message))
    }

    /// Every input has ended and everything queued has been delivered.
    pub fn finished(&self) -> bool {
        self.inputs.iter().all(|i| i.closed && i.queue.is_empty())
    }

    /// Messages waiting, over all inputs.
    pub fn queued(&self) -> usize {
        self.inputs.iter().map(|i| i.queue.len()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{Clock, Header, PoseStamped, TargetSet, Time};
    use proptest::prelude::*;

    fn pose(t: f64) -> Message {
        Message::PoseStamped(PoseStamped {
            header: Header::new(Time::from_seconds(t), "map"),
            ..Default::default()
        })
    }

    fn clock(t: f64) -> Message {
        Message::Clock(Clock {
            clock: Time::from_seconds(t),
        })
    }

    fn drain(merger: &mut Merger) -> Vec<(&'static str, Time)> {
        std::iter::from_fn(|| merger.pop_ready())
            .map(|(t, m)| (t, m.stamp()))
            .collect()
    }

    #[test]
    fn waits_until_every_open_input_has_something() {
        let mut merger = Merger::new(&[topics::ODOM, topics::DETECTIONS]);
        merger.push(topics::DETECTIONS, clock(1.0)).unwrap();
        assert!(merger.pop_ready().is_none());
        merger.push(topics::ODOM, clock(1.0)).unwrap();
        // Equal stamps: the earlier input goes first.
        assert_eq!(merger.pop_ready().unwrap().0, topics::ODOM);
        assert!(merger.pop_ready().is_none(), "odom queue is empty and open");
        merger.close(topics::ODOM).unwrap();
        assert_eq!(merger.pop_ready().unwrap().0, topics::DETECTIONS);
        assert!(!merger.finished());
        merger.close(topics::DETECTIONS).unwrap();
        assert!(merger.finished());
    }

    #[test]
    fn latched_inputs_come_first_and_block_until_seen() {
        let mut merger = Merger::new(&[topics::GROUND_TRUTH_TARGETS, topics::SLAM_POSE]);
        merger.push(topics::SLAM_POSE, pose(1.0)).unwrap();
        assert!(merger.pop_ready().is_none());
        merger
            .push(
                topics::GROUND_TRUTH_TARGETS,
                Message::TargetSet(TargetSet::default()),
            )
            .unwrap();
        assert_eq!(merger.pop_ready().unwrap().0, topics::GROUND_TRUTH_TARGETS);
        assert_eq!(merger.pop_ready().unwrap().0, topics::SLAM_POSE);
    }

    #[test]
    fn unknown_topics_are_refused() {
        let mut merger = Merger::new(&[topics::ODOM]);
        assert!(merger.push(topics::MAP, clock(1.0)).is_err());
    }

    proptest! {
        /// Whatever order the messages of two streams arrive in (each stream in its own order),
        /// the delivered sequence is the same.
        #[test]
        fn delivery_order_does_not_depend_on_arrival_order(
            a in proptest::collection::vec(0u32..20, 0..15),
            b in proptest::collection::vec(0u32..20, 0..15),
            interleave in proptest::collection::vec(any::<bool>(), 0..40),
        ) {
            let mut a = a; a.sort();
            let mut b = b; b.sort();
            let run = |choices: &[bool]| {
                let mut merger = Merger::new(&[topics::ODOM, topics::DETECTIONS]);
                let (mut i, mut j, mut out) = (0, 0, Vec::new());
                let mut choice = choices.iter().copied().chain(std::iter::repeat(true));
                while i < a.len() || j < b.len() {
                    let take_a = (choice.next().unwrap() && i < a.len()) || j >= b.len();
                    if take_a { merger.push(topics::ODOM, clock(a[i] as f64)).unwrap(); i += 1; if i == a.len() { merger.close(topics::ODOM).unwrap(); } }
                    else { merger.push(topics::DETECTIONS, clock(b[j] as f64)).unwrap(); j += 1; if j == b.len() { merger.close(topics::DETECTIONS).unwrap(); } }
                    out.extend(drain(&mut merger));
                }
                if a.is_empty() { merger.close(topics::ODOM).unwrap(); }
                if b.is_empty() { merger.close(topics::DETECTIONS).unwrap(); }
                out.extend(drain(&mut merger));
                prop_assert!(merger.finished());
                Ok(out)
            };
            let reference = run(&[])?;
            prop_assert_eq!(reference.len(), a.len() + b.len());
            prop_assert_eq!(run(&interleave)?, reference.clone());
            // And the delivered stamps never go backwards.
            prop_assert!(reference.windows(2).all(|w| w[0].1 <= w[1].1));
        }
    }
}
