//! Topics fed into an in-process graph from outside it (a launch file's `[[external]]`): a source
//! node that blocks on an [`Inbox`], so what arrives over zenoh (from ROS 2 publishers on
//! rmw_zenoh keys, `nrslam run`, `nrslam bag play`) enters the graph through the same mergers as
//! every other message, and a node sees it in (stamp, input order) whatever its arrival order.
//!
//! ROS 2 publishers never mark the end of a stream, so the source ends when every topic has
//! received nrslam's end-of-stream marker or, failing that, once nothing arrived for an idle
//! period after the first message. Before the first message, a start timeout applies and its
//! expiry is an error: a run that received nothing has nothing to report.

use crate::node::{Node, NodeError, Outbox, Tick};
use crate::receive::{Delivery, Drops, Inbox};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// How long one wait on the inbox lasts at most, so timeouts are noticed.
const POLL: Duration = Duration::from_millis(200);

/// When an [`ExternalSource`] gives up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExternalTimeouts {
    /// Before the first message: how long to wait for it (an error when it passes).
    pub first: Duration,
    /// After a message: how long without another before the source ends (ROS 2 publishers send
    /// no end-of-stream marker).
    pub idle: Duration,
}

/// The source node of a graph's external topics.
pub struct ExternalSource {
    inbox: Inbox,
    topics: Vec<&'static str>,
    open: Vec<&'static str>,
    timeouts: ExternalTimeouts,
    started: Option<Instant>,
    last: Option<Instant>,
    /// Topics that delivered at least one message.
    heard: Vec<&'static str>,
    drops: Arc<Mutex<Drops>>,
}

impl ExternalSource {
    /// A source publishing into the graph what `inbox` (subscribed to exactly `topics`) receives.
    pub fn new(inbox: Inbox, topics: Vec<&'static str>, timeouts: ExternalTimeouts) -> Self {
        Self {
            inbox,
            open: topics.clone(),
            topics,
            timeouts,
            started: None,
            last: None,
            heard: Vec::new(),
            drops: Arc::default(),
        }
    }

    /// What the inbox dropped so far, readable after the node has moved into the graph.
    pub fn drops(&self) -> Arc<Mutex<Drops>> {
        Arc::clone(&self.drops)
    }

    fn note_drops(&self) {
        if let Ok(mut drops) = self.drops.lock() {
            if *drops != *self.inbox.drops() {
                *drops = self.inbox.drops().clone();
            }
        }
    }
}

impl ExternalSource {
    /// An external topic that has delivered nothing, and has not ended, a start timeout after the
    /// first wait while others deliver: every node waiting on it would hold the other topics'
    /// messages in memory for as long as the run lasts, so the run stops and names it.
    fn silent_topic(&self, started: Instant) -> Option<&'static str> {
        if self.heard.is_empty() || started.elapsed() < self.timeouts.first {
            return None;
        }
        self.open
            .iter()
            .copied()
            .find(|topic| !self.heard.contains(topic))
    }
}

impl Node for ExternalSource {
    fn inputs(&self) -> Vec<&'static str> {
        Vec::new()
    }

    fn outputs(&self) -> Vec<&'static str> {
        self.topics.clone()
    }

    fn on_message(
        &mut self,
        topic: &str,
        message: &nrslam_msgs::Message,
        _: &mut Outbox,
    ) -> crate::NodeResult {
        Err(NodeError::unexpected(topic, message))
    }

    /// Publishes the next external message, waiting for it; done when every topic ended or the
    /// idle period passed.
    fn tick(&mut self, outbox: &mut Outbox) -> Result<Tick, NodeError> {
        let started = *self.started.get_or_insert_with(Instant::now);
        // Idle time is time spent waiting here: while the graph computed (a loop closure, say),
        // messages queued up, and the run must not end with them unread.
        let entered = Instant::now();
        loop {
            if let Some(silent) = self.silent_topic(started) {
                return Err(NodeError::algorithm(TopicNeverArrived {
                    topic: silent,
                    seconds: self.timeouts.first.as_secs_f64(),
                    heard: self.heard.join(", "),
                }));
            }
            let left = match self.last {
                Some(last) => self
                    .timeouts
                    .idle
                    .saturating_sub(last.max(entered).elapsed()),
                None => self.timeouts.first.saturating_sub(started.elapsed()),
            };
            if left.is_zero() {
                if self.last.is_none() {
                    return Err(NodeError::algorithm(NothingArrived {
                        topics: self.open.join(", "),
                        seconds: self.timeouts.first.as_secs_f64(),
                    }));
                }
                tracing::info!(
                    "no external message for {} s: the external topics end",
                    self.timeouts.idle.as_secs_f64()
                );
                return Ok(Tick::Done);
            }
            let delivery = self.inbox.recv_timeout(left.min(POLL));
            self.note_drops();
            match delivery.map_err(NodeError::algorithm)? {
                Some(Delivery::Message { topic, message, .. }) => {
                    self.last = Some(Instant::now());
                    if !self.heard.contains(&topic) {
                        self.heard.push(topic);
                    }
                    outbox.publish(topic, message);
                    return Ok(Tick::More);
                }
                Some(Delivery::End { topic }) => {
                    self.open.retain(|t| *t != topic);
                    if self.open.is_empty() {
                        return Ok(Tick::Done);
                    }
                }
                None => {}
            }
        }
    }
}

/// No external message arrived before the start timeout.
#[derive(Debug, thiserror::Error)]
#[error(
    "no message on the external topics ({topics}) within {seconds} s: is the publisher running, \
     in the same ROS domain (--ros-domain-id), reachable (--listen, --connect, --ros-router), and \
     publishing the catalogue's type (`nrslam topics`; another type's hash is counted as \
     type_hash_mismatch)?"
)]
struct NothingArrived {
    topics: String,
    seconds: f64,
}

/// One external topic stayed silent while others delivered.
#[derive(Debug, thiserror::Error)]
#[error(
    "external topic {topic} delivered nothing within {seconds} s while {heard} did: the nodes \
     that need it would hold every other message; is it published, with the catalogue's type \
     (`nrslam topics`), in the same ROS domain?"
)]
struct TopicNeverArrived {
    topic: &'static str,
    seconds: f64,
    heard: String,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compose::Graph;
    use crate::receive::InboxOptions;
    use crate::transport::{self, TransportConfig};
    use nrslam_msgs::{topics, Clock, Message, Time};
    use zenoh::Wait;

    fn clock(sec: i32) -> Vec<u8> {
        Message::from(Clock {
            clock: Time { sec, nanosec: 0 },
        })
        .encode()
        .unwrap()
    }

    /// Records the stamps it is given.
    struct Sink(Arc<Mutex<Vec<i32>>>);

    impl Node for Sink {
        fn inputs(&self) -> Vec<&'static str> {
            vec![topics::CLOCK]
        }
        fn outputs(&self) -> Vec<&'static str> {
            Vec::new()
        }
        fn on_message(&mut self, _: &str, message: &Message, _: &mut Outbox) -> crate::NodeResult {
            self.0.lock().unwrap().push(message.stamp().sec);
            Ok(())
        }
    }

    fn source(session: &zenoh::Session, idle_ms: u64) -> ExternalSource {
        let inbox =
            Inbox::subscribe(session, "", &[topics::CLOCK], InboxOptions::default()).unwrap();
        ExternalSource::new(
            inbox,
            vec![topics::CLOCK],
            ExternalTimeouts {
                first: Duration::from_secs(5),
                idle: Duration::from_millis(idle_ms),
            },
        )
    }

    #[test]
    fn external_messages_reach_the_graph_until_the_idle_period_passes() {
        let session = transport::open(&TransportConfig::default()).unwrap();
        let source = source(&session, 300);
        let drops = source.drops();
        for bytes in [clock(1), clock(2), vec![0, 1, 0, 0, 9], clock(3)] {
            session.put("clock", bytes).wait().unwrap();
        }
        let seen = Arc::new(Mutex::new(Vec::new()));
        let nodes: Vec<(String, Box<dyn Node>)> = vec![
            ("external".into(), Box::new(source)),
            ("sink".into(), Box::new(Sink(seen.clone()))),
        ];
        let started = Instant::now();
        Graph::new(nodes)
            .run(&mut |_: &'static str, _: &Message| {})
            .unwrap();
        assert_eq!(*seen.lock().unwrap(), vec![1, 2, 3]);
        assert!(started.elapsed() >= Duration::from_millis(300));
        assert_eq!(drops.lock().unwrap().get(topics::CLOCK, "bad_cdr"), 1);
    }

    #[test]
    fn an_end_of_stream_marker_ends_at_once_and_silence_is_an_error() {
        let session = transport::open(&TransportConfig::default()).unwrap();
        let mut ended = source(&session, 60_000);
        session.put("clock", clock(1)).wait().unwrap();
        session.put("clock", Vec::<u8>::new()).wait().unwrap();
        let mut outbox = Outbox::new();
        assert_eq!(ended.tick(&mut outbox).unwrap(), Tick::More);
        let started = Instant::now();
        assert_eq!(ended.tick(&mut outbox).unwrap(), Tick::Done);
        assert!(started.elapsed() < Duration::from_secs(5));

        let inbox =
            Inbox::subscribe(&session, "", &[topics::ODOM], InboxOptions::default()).unwrap();
        let mut silent = ExternalSource::new(
            inbox,
            vec![topics::ODOM],
            ExternalTimeouts {
                first: Duration::from_millis(200),
                idle: Duration::from_secs(60),
            },
        );
        let error = silent.tick(&mut outbox).unwrap_err().to_string();
        assert!(
            error.contains("no message on the external topics (/odom) within 0.2 s"),
            "{error}"
        );
    }

    #[test]
    fn time_spent_outside_the_source_is_not_idle_time() {
        // A downstream step longer than the idle period: the queued message is still read.
        let session = transport::open(&TransportConfig::default()).unwrap();
        let mut source = source(&session, 200);
        session.put("clock", clock(1)).wait().unwrap();
        let mut outbox = Outbox::new();
        assert_eq!(source.tick(&mut outbox).unwrap(), Tick::More);
        session.put("clock", clock(2)).wait().unwrap();
        std::thread::sleep(Duration::from_millis(400));
        assert_eq!(source.tick(&mut outbox).unwrap(), Tick::More);
        assert_eq!(source.tick(&mut outbox).unwrap(), Tick::Done);
        let stamps: Vec<i32> = outbox.drain().map(|(_, m)| m.stamp().sec).collect();
        assert_eq!(stamps, vec![1, 2]);
    }

    #[test]
    fn a_topic_silent_while_others_deliver_stops_the_run_by_name() {
        let session = transport::open(&TransportConfig::default()).unwrap();
        let inbox = Inbox::subscribe(
            &session,
            "",
            &[topics::CLOCK, topics::ODOM],
            InboxOptions::default(),
        )
        .unwrap();
        let mut source = ExternalSource::new(
            inbox,
            vec![topics::CLOCK, topics::ODOM],
            ExternalTimeouts {
                first: Duration::from_millis(300),
                idle: Duration::from_secs(60),
            },
        );
        let mut outbox = Outbox::new();
        let mut error = None;
        for sec in 1..100 {
            session.put("clock", clock(sec)).wait().unwrap();
            match source.tick(&mut outbox) {
                Ok(Tick::More) => std::thread::sleep(Duration::from_millis(20)),
                Ok(Tick::Done) => panic!("ended without /odom"),
                Err(e) => {
                    error = Some(e.to_string());
                    break;
                }
            }
        }
        let error = error.expect("the silent /odom stops the run");
        assert!(
            error.contains("external topic /odom delivered nothing") && error.contains("/clock"),
            "{error}"
        );
    }
}
