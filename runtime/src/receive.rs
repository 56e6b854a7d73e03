//! The one receive path: every subscriber in nrslam (a node process, the launcher of a
//! processes-mode graph, `run`, `echo`, `bag record`) takes its samples from an [`Inbox`].
//!
//! Anything on the network may be truncated, malicious or from another program's bug, so a sample
//! that cannot be used is **dropped and counted**, never fatal by default:
//!
//! | reason            | what                                                              |
//! |-------------------|-------------------------------------------------------------------|
//! | `bad_cdr`         | the payload does not decode as the topic's catalogue type          |
//! | `non_finite`, ... | decoded, but refused by [`Message::check_usable`] (NaN, absurd sizes, ...) |
//! | `stamp_backwards` | older than the last message accepted on the same topic (not on     |
//! |                   | `/diagnostics`, where every process reports at its own time)       |
//! | `queue_full`      | a best-effort topic's queue overflowed: the oldest sample went     |
//! | `type_hash_mismatch` | ROS mode: the key's RIHS01 hash is neither the catalogue type's |
//! |                   | nor the all-zero placeholder (another type on the topic's name)    |
//!
//! Key styles ([`KeyStyle`]): nrslam's own keys (`map`, an empty payload ends the stream), or,
//! with `--ros-domain-id`, rmw_zenoh's: each topic is subscribed on
//! `<domain>/<topic>/<DDS type>/*` and the last chunk judged by
//! [`crate::rmw_zenoh::judge_hash`]: the catalogue type's RIHS01 hash and the all-zero
//! placeholder that clients without the hash send (the `ros2-client` crate for Odometry,
//! RadarScan, ...) are taken and then decoded and checked like any sample, nrslam's
//! end-of-stream key ends the stream, and any other hash is dropped unread and counted as
//! `type_hash_mismatch`. The attachment is not required (not every client sends one). A
//! transient-local topic is an `AdvancedSubscriber` with history and late-publisher detection, as
//! rmw_zenoh subscribes to it, so a latched message published before we joined still arrives.
//!
//! Counts are kept per topic and reason ([`Drops`]); the first drop on a topic is logged at once
//! and later ones at most every [`LOG_INTERVAL`]. With [`BadInput::Fail`] the first unusable
//! sample is an error instead (for replaying a trusted bag, say).
//!
//! Memory stays bounded under overload: each topic has a queue of its catalogue depth
//! ([`nrslam_msgs::topics::Qos::depth`]). On a reliable topic a full queue blocks zenoh's receive
//! callback, so the publisher (congestion control `Block`) slows down and nothing is lost; on a
//! best-effort topic the oldest sample is dropped and counted. Samples are delivered in arrival
//! order across topics.

use crate::rmw_zenoh::{self, HashVerdict};
pub use crate::transport::KeyStyle;
use nrslam_msgs::topics::{self, Durability, Reliability};
use nrslam_msgs::{Message, Time};
use std::collections::{BTreeMap, VecDeque};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};
use zenoh::Wait;

/// How often, at most, drops on one topic are logged after the first.
pub const LOG_INTERVAL: Duration = Duration::from_secs(5);

/// What to do with a sample that cannot be used.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BadInput {
    /// Drop it, count it, go on (the default on live inputs).
    #[default]
    Drop,
    /// Stop with an error naming the topic and the reason.
    Fail,
}

impl std::str::FromStr for BadInput {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "drop" => Ok(BadInput::Drop),
            "fail" => Ok(BadInput::Fail),
            other => Err(format!("{other:?} is not a policy (allowed: drop, fail)")),
        }
    }
}

/// What a full queue does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Overload {
    /// Hold the publisher back (a node of the graph, a recorder: nothing may be lost). The
    /// queue's depth is the topic's catalogue depth.
    #[default]
    BackPressure,
    /// Keep the newest `n` samples per topic and count the evicted ones as `queue_full` (an
    /// observer such as `echo`, which must never slow the graph down).
    KeepNewest(usize),
}

/// How an [`Inbox`] treats unusable samples and overload.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InboxOptions {
    /// Unusable samples: drop and count, or fail.
    pub bad_input: BadInput,
    /// Full queues: back-pressure or keep the newest.
    pub overload: Overload,
    /// Drop a message older than the last on its topic (`stamp_backwards`). A node needs its
    /// streams in order; an observer (`echo` of a bag played in a loop) may not.
    pub in_order: bool,
}

impl Default for InboxOptions {
    fn default() -> Self {
        Self {
            bad_input: BadInput::default(),
            overload: Overload::default(),
            in_order: true,
        }
    }
}

/// Samples dropped, per topic and reason.
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize)]
#[serde(transparent)]
pub struct Drops {
    counts: BTreeMap<String, BTreeMap<String, u64>>,
}

impl Drops {
    /// Counts one sample dropped on `topic` for `reason`.
    pub fn count(&mut self, topic: &str, reason: &str) {
        self.add(topic, reason, 1);
    }

    /// Adds `n` drops on `topic` for `reason`.
    pub fn add(&mut self, topic: &str, reason: &str, n: u64) {
        if n == 0 {
            return;
        }
        let slot = self
            .counts
            .entry(topic.to_owned())
            .or_default()
            .entry(reason.to_owned())
            .or_default();
        *slot = slot.saturating_add(n);
    }

    /// Drops on `topic` for `reason`.
    pub fn get(&self, topic: &str, reason: &str) -> u64 {
        self.counts
            .get(topic)
            .and_then(|r| r.get(reason))
            .copied()
            .unwrap_or(0)
    }

    /// All drops.
    pub fn total(&self) -> u64 {
        self.counts
            .values()
            .flat_map(|r| r.values())
            .fold(0u64, |a, b| a.saturating_add(*b))
    }

    /// (topic, reason, count) for every nonzero count, in order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &str, u64)> {
        self.counts.iter().flat_map(|(topic, reasons)| {
            reasons
                .iter()
                .map(move |(reason, n)| (topic.as_str(), reason.as_str(), *n))
        })
    }

    /// Nothing dropped.
    pub fn is_empty(&self) -> bool {
        self.counts.is_empty()
    }
}

/// The `/diagnostics` report of what `component` (e.g. `nrslam/mapper/receive`) dropped, at
/// simulated time `stamp`: one status, WARN when anything was dropped, one value per topic and
/// reason (key `"<topic> <reason>"`, value the count).
pub fn diagnostics(component: &str, drops: &Drops, stamp: Time) -> nrslam_msgs::DiagnosticArray {
    use nrslam_msgs::{DiagnosticArray, DiagnosticStatus, Header, KeyValue};
    let total = drops.total();
    DiagnosticArray {
        header: Header {
            stamp,
            frame_id: String::new(),
        },
        status: vec![DiagnosticStatus {
            level: if total > 0 {
                DiagnosticStatus::WARN
            } else {
                DiagnosticStatus::OK
            },
            name: component.to_owned(),
            message: format!("dropped {total} unusable samples"),
            hardware_id: String::new(),
            values: drops
                .iter()
                .map(|(topic, reason, n)| KeyValue {
                    key: format!("{topic} {reason}"),
                    value: n.to_string(),
                })
                .collect(),
        }],
    }
}

/// The drops of each component in a `/diagnostics` report written by [`diagnostics`] (other
/// statuses and values that are not counts are skipped).
pub fn drops_in(report: &nrslam_msgs::DiagnosticArray) -> BTreeMap<String, Drops> {
    let mut out = BTreeMap::new();
    for status in &report.status {
        let mut drops = Drops::default();
        for value in &status.values {
            if let (Some((topic, reason)), Ok(n)) =
                (value.key.rsplit_once(' '), value.value.parse::<u64>())
            {
                drops.add(topic, reason, n);
            }
        }
        out.insert(status.name.clone(), drops);
    }
    out
}

/// What [`Inbox::recv_timeout`] delivers.
// A message is delivered by value, once; boxing it would cost an allocation per sample for
// nothing (the `End` variant is rare).
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, PartialEq)]
pub enum Delivery {
    /// A message that decoded and passed its checks.
    Message {
        /// Topic.
        topic: &'static str,
        /// The message.
        message: Message,
        /// The CDR bytes it was decoded from (for a recorder, which keeps them as sent).
        payload: Vec<u8>,
    },
    /// The publisher marked the end of the topic's stream (an empty payload).
    End {
        /// Topic.
        topic: &'static str,
    },
}

/// Why receiving stopped.
#[derive(Debug, thiserror::Error)]
pub enum ReceiveError {
    /// zenoh refused a subscription.
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// The topic is not in the catalogue.
    #[error("{0}: not in the topic catalogue")]
    UnknownTopic(String),
    /// A topic's type has no RIHS01 hash to subscribe by (ROS mode).
    #[error("{topic}: {reason}")]
    TypeHash {
        /// Topic.
        topic: String,
        /// Why.
        reason: String,
    },
    /// Under [`BadInput::Fail`]: the first unusable sample.
    #[error("{topic}: unusable sample ({reason}): {detail}")]
    Unusable {
        /// Topic.
        topic: String,
        /// Counter key, e.g. `bad_cdr`.
        reason: &'static str,
        /// What exactly.
        detail: String,
    },
    /// Every subscription was closed (the session went away).
    #[error("the zenoh session closed")]
    Closed,
}

/// One topic's queue of raw payloads, with their arrival numbers.
#[derive(Debug)]
struct TopicQueue {
    samples: VecDeque<(u64, Vec<u8>)>,
    depth: usize,
    reliable: bool,
    overflowed: u64,
}

#[derive(Debug, Default)]
struct Queues {
    topics: BTreeMap<&'static str, TopicQueue>,
    arrivals: u64,
    closed: bool,
    /// Samples refused before queueing (by their key), per (topic, reason): count and the last
    /// one's detail, taken by the next pop.
    refused: BTreeMap<(&'static str, &'static str), (u64, String)>,
}

#[derive(Debug, Default)]
struct Shared {
    queues: Mutex<Queues>,
    /// Signalled when a sample arrives.
    arrived: Condvar,
    /// Signalled when a sample is taken (a reliable topic's callback may be waiting for room).
    taken: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Queues> {
        self.queues.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Queues `payload` on `topic`: waits for room on a reliable topic, evicts the oldest on a
    /// best-effort one.
    fn push(&self, topic: &'static str, payload: Vec<u8>) {
        let mut queues = self.lock();
        loop {
            if queues.closed {
                return;
            }
            let Some(queue) = queues.topics.get(topic) else {
                return;
            };
            if queue.samples.len() < queue.depth || !queue.reliable {
                break;
            }
            queues = self.taken.wait(queues).unwrap_or_else(|e| e.into_inner());
        }
        queues.arrivals += 1;
        let arrival = queues.arrivals;
        if let Some(queue) = queues.topics.get_mut(topic) {
            if queue.samples.len() >= queue.depth {
                queue.samples.pop_front();
                queue.overflowed += 1;
            }
            queue.samples.push_back((arrival, payload));
        }
        drop(queues);
        self.arrived.notify_all();
    }

    /// Counts a sample on `topic` refused by its key (not queued, its payload never copied).
    fn refuse(&self, topic: &'static str, reason: &'static str, detail: String) {
        let mut queues = self.lock();
        if queues.closed || !queues.topics.contains_key(topic) {
            return;
        }
        let slot = queues.refused.entry((topic, reason)).or_default();
        slot.0 = slot.0.saturating_add(1);
        slot.1 = detail;
        drop(queues);
        self.arrived.notify_all();
    }

    /// The oldest sample over all topics, with the overflow and refusal counts taken since the
    /// last call.
    fn pop(&self, timeout: Duration) -> Popped {
        let deadline = Instant::now().checked_add(timeout);
        let mut queues = self.lock();
        loop {
            let overflowed: Vec<(&'static str, u64)> = queues
                .topics
                .iter_mut()
                .filter(|(_, q)| q.overflowed > 0)
                .map(|(t, q)| (*t, std::mem::take(&mut q.overflowed)))
                .collect();
            let refused: Vec<Refused> = std::mem::take(&mut queues.refused)
                .into_iter()
                .map(|((topic, reason), (count, detail))| Refused {
                    topic,
                    reason,
                    count,
                    detail,
                })
                .collect();
            let oldest = queues
                .topics
                .iter()
                .filter_map(|(t, q)| q.samples.front().map(|(a, _)| (*a, *t)))
                .min();
            if let Some((_, topic)) = oldest {
                let sample = queues
                    .topics
                    .get_mut(topic)
                    .and_then(|q| q.samples.pop_front())
                    .map(|(_, bytes)| (topic, bytes));
                drop(queues);
                self.taken.notify_all();
                return Popped {
                    sample,
                    overflowed,
                    refused,
                };
            }
            if !overflowed.is_empty() || !refused.is_empty() || queues.closed {
                return Popped {
                    sample: None,
                    overflowed,
                    refused,
                };
            }
            let now = Instant::now();
            let wait = match deadline {
                Some(deadline) if deadline <= now => {
                    return Popped {
                        sample: None,
                        overflowed,
                        refused,
                    }
                }
                Some(deadline) => deadline - now,
                None => Duration::from_secs(3600),
            };
            queues = self
                .arrived
                .wait_timeout(queues, wait)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }

    fn close(&self) {
        self.lock().closed = true;
        self.taken.notify_all();
        self.arrived.notify_all();
    }
}

struct Popped {
    sample: Option<(&'static str, Vec<u8>)>,
    overflowed: Vec<(&'static str, u64)>,
    refused: Vec<Refused>,
}

/// Samples on one topic refused for one reason by their key.
struct Refused {
    topic: &'static str,
    reason: &'static str,
    count: u64,
    detail: String,
}

/// A declared subscription, kept alive as long as the inbox.
enum Subscription {
    Plain(#[allow(dead_code)] zenoh::pubsub::Subscriber<()>),
    /// A transient-local topic in ROS mode (history, late-publisher detection).
    Advanced(#[allow(dead_code)] zenoh_ext::AdvancedSubscriber<()>),
    /// A topic in ROS mode: its data subscription and the one on nrslam's end-of-stream key
    /// ([`rmw_zenoh::END_OF_STREAM_CHUNK`], a verbatim chunk no wildcard matches).
    WithEnd(
        #[allow(dead_code)] Box<Subscription>,
        #[allow(dead_code)] zenoh::pubsub::Subscriber<()>,
    ),
}

/// The subscriptions of one receiver, with their bounded queues, checks and drop counts.
pub struct Inbox {
    shared: Arc<Shared>,
    _subscribers: Vec<Subscription>,
    policy: BadInput,
    in_order: bool,
    drops: Drops,
    last_stamp: BTreeMap<&'static str, Time>,
    last_logged: BTreeMap<&'static str, Instant>,
    /// Drops since the last [`Inbox::take_changed`].
    changed: bool,
}

impl std::fmt::Debug for Inbox {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Inbox")
            .field("policy", &self.policy)
            .field("drops", &self.drops)
            .finish_non_exhaustive()
    }
}

impl Inbox {
    /// Subscribes to `topics` (catalogue names) under `namespace`, on nrslam's keys.
    pub fn subscribe(
        session: &zenoh::Session,
        namespace: &str,
        topics: &[&'static str],
        options: InboxOptions,
    ) -> Result<Self, ReceiveError> {
        Self::subscribe_styled(session, namespace, topics, options, KeyStyle::Nrslam)
    }

    /// Subscribes to `topics` (catalogue names) under `namespace` (with [`KeyStyle::RmwZenoh`]:
    /// the ROS namespace), on the keys of `style` (see the module's documentation).
    pub fn subscribe_styled(
        session: &zenoh::Session,
        namespace: &str,
        topics: &[&'static str],
        options: InboxOptions,
        style: KeyStyle,
    ) -> Result<Self, ReceiveError> {
        let shared = Arc::new(Shared::default());
        {
            let mut queues = shared.lock();
            for &topic in topics {
                let spec =
                    topics::spec(topic).ok_or_else(|| ReceiveError::UnknownTopic(topic.into()))?;
                let (depth, reliable) = match options.overload {
                    Overload::BackPressure => (
                        spec.qos.depth,
                        spec.qos.reliability == Reliability::Reliable,
                    ),
                    Overload::KeepNewest(n) => (n, false),
                };
                queues.topics.insert(
                    topic,
                    TopicQueue {
                        samples: VecDeque::new(),
                        depth: depth.max(1),
                        reliable,
                        overflowed: 0,
                    },
                );
            }
        }
        let mut subscribers = Vec::new();
        for &topic in topics {
            let shared = shared.clone();
            let subscriber = match style {
                KeyStyle::Nrslam => session
                    .declare_subscriber(topics::key_expr(namespace, topic))
                    .callback(move |sample| {
                        shared.push(topic, sample.payload().to_bytes().into_owned())
                    })
                    .wait()
                    .map(Subscription::Plain)
                    .map_err(|e| ReceiveError::Zenoh(format!("subscribing to {topic}: {e}")))?,
                KeyStyle::RmwZenoh { domain_id } => {
                    ros_subscription(session, namespace, domain_id, topic, shared)?
                }
            };
            subscribers.push(subscriber);
        }
        Ok(Self {
            shared,
            _subscribers: subscribers,
            policy: options.bad_input,
            in_order: options.in_order,
            drops: Drops::default(),
            last_stamp: BTreeMap::new(),
            last_logged: BTreeMap::new(),
            changed: false,
        })
    }

    /// The next usable sample, waiting at most `timeout`; `Ok(None)` on timeout. Unusable
    /// samples are counted and skipped (or, under [`BadInput::Fail`], returned as the error).
    pub fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<Delivery>, ReceiveError> {
        let deadline = Instant::now().checked_add(timeout);
        loop {
            let left = deadline.map_or(timeout, |d| d.saturating_duration_since(Instant::now()));
            let popped = self.shared.pop(left);
            for (topic, n) in popped.overflowed {
                self.drops.add(topic, "queue_full", n);
                self.changed = true;
                self.log(topic, "queue_full", &format!("{n} oldest samples evicted"));
            }
            for refused in popped.refused {
                self.drops.add(refused.topic, refused.reason, refused.count);
                self.changed = true;
                if self.policy == BadInput::Fail {
                    return Err(ReceiveError::Unusable {
                        topic: refused.topic.into(),
                        reason: refused.reason,
                        detail: refused.detail,
                    });
                }
                self.log(refused.topic, refused.reason, &refused.detail);
            }
            let Some((topic, bytes)) = popped.sample else {
                if self.shared.lock().closed {
                    return Err(ReceiveError::Closed);
                }
                if deadline.is_some_and(|d| Instant::now() >= d) {
                    return Ok(None);
                }
                continue;
            };
            if bytes.is_empty() {
                return Ok(Some(Delivery::End { topic }));
            }
            match self.accept(topic, &bytes) {
                Ok(message) => {
                    return Ok(Some(Delivery::Message {
                        topic,
                        message,
                        payload: bytes,
                    }))
                }
                Err((reason, detail)) => {
                    self.drops.count(topic, reason);
                    self.changed = true;
                    if self.policy == BadInput::Fail {
                        return Err(ReceiveError::Unusable {
                            topic: topic.into(),
                            reason,
                            detail,
                        });
                    }
                    self.log(topic, reason, &detail);
                }
            }
        }
    }

    /// Decodes and checks one payload.
    fn accept(
        &mut self,
        topic: &'static str,
        bytes: &[u8],
    ) -> Result<Message, (&'static str, String)> {
        let message =
            crate::transport::decode(topic, bytes).map_err(|e| ("bad_cdr", e.to_string()))?;
        message
            .check_usable()
            .map_err(|unusable| (unusable.reason(), unusable.to_string()))?;
        let stamp = message.stamp();
        // Every process reports on /diagnostics at its own simulated time: no order to keep.
        if topic == topics::DIAGNOSTICS || !self.in_order {
            return Ok(message);
        }
        if let Some(last) = self.last_stamp.get(topic) {
            if (stamp.sec, stamp.nanosec) < (last.sec, last.nanosec) {
                return Err((
                    "stamp_backwards",
                    format!(
                        "stamp {} s after {} s",
                        stamp.as_seconds(),
                        last.as_seconds()
                    ),
                ));
            }
        }
        self.last_stamp.insert(topic, stamp);
        Ok(message)
    }

    fn log(&mut self, topic: &'static str, reason: &str, detail: &str) {
        let now = Instant::now();
        let due = self
            .last_logged
            .get(topic)
            .is_none_or(|last| now.duration_since(*last) >= LOG_INTERVAL);
        if due {
            self.last_logged.insert(topic, now);
            let total: u64 = self
                .drops
                .iter()
                .filter(|(t, _, _)| *t == topic)
                .map(|(_, _, n)| n)
                .sum();
            tracing::warn!(
                topic,
                reason,
                dropped_on_topic = total,
                "dropped an unusable sample: {detail}"
            );
        }
    }

    /// Everything dropped so far.
    pub fn drops(&self) -> &Drops {
        &self.drops
    }

    /// Whether anything was dropped since the last call (to report diagnostics only when there
    /// is something new).
    pub fn take_changed(&mut self) -> bool {
        std::mem::take(&mut self.changed)
    }
}

/// The subscription of catalogue topic `topic` on rmw_zenoh's keys in ROS domain `domain_id`:
/// the hash chunk matched by `*` and judged per sample; declared as rmw_zenoh's
/// `SubscriptionData::init` does (an `AdvancedSubscriber` with history of `depth` samples,
/// late-publisher detection and, when reliable, heartbeat-based miss recovery for a
/// transient-local topic).
fn ros_subscription(
    session: &zenoh::Session,
    namespace: &str,
    domain_id: u32,
    topic: &'static str,
    shared: Arc<Shared>,
) -> Result<Subscription, ReceiveError> {
    let spec = topics::spec(topic).ok_or_else(|| ReceiveError::UnknownTopic(topic.into()))?;
    let expected =
        crate::type_hash::rihs01(spec.type_name).map_err(|e| ReceiveError::TypeHash {
            topic: topic.into(),
            reason: e.to_string(),
        })?;
    let key = rmw_zenoh::key_expr_with_hash(
        domain_id,
        &rmw_zenoh::qualified_topic(namespace, topic),
        spec.type_name,
        "*",
    );
    let end_shared = shared.clone();
    let callback = move |sample: zenoh::sample::Sample| {
        let chunk = sample.key_expr().as_str().rsplit('/').next().unwrap_or("");
        match rmw_zenoh::judge_hash(chunk, &expected) {
            HashVerdict::Accept if sample.payload().is_empty() => {
                // Empty is nrslam's end marker only on its own key: here it is no CDR at all.
                shared.refuse(topic, "bad_cdr", "empty payload".into());
            }
            HashVerdict::Accept => shared.push(topic, sample.payload().to_bytes().into_owned()),
            // The end marker's verbatim key never matches `*`: only a publisher that puts it
            // in the hash chunk by hand gets here. Its own subscriber (below) handles it.
            HashVerdict::EndOfStream => shared.push(topic, Vec::new()),
            HashVerdict::Mismatch => shared.refuse(
                topic,
                "type_hash_mismatch",
                format!(
                    "key hash {chunk:?} is neither {}'s {expected} nor the zero placeholder",
                    spec.type_name
                ),
            ),
        }
    };
    let end_key = rmw_zenoh::key_expr_with_hash(
        domain_id,
        &rmw_zenoh::qualified_topic(namespace, topic),
        spec.type_name,
        rmw_zenoh::END_OF_STREAM_CHUNK,
    );
    let end = session
        .declare_subscriber(end_key.clone())
        .callback(move |_| end_shared.push(topic, Vec::new()))
        .wait()
        .map_err(|e| ReceiveError::Zenoh(format!("subscribing to {end_key}: {e}")))?;
    let data = ros_data_subscription(session, key, spec, callback)?;
    Ok(Subscription::WithEnd(Box::new(data), end))
}

/// The data subscription of a topic in ROS mode on `key`, as rmw_zenoh declares it for the
/// topic's QoS.
fn ros_data_subscription(
    session: &zenoh::Session,
    key: String,
    spec: &topics::TopicSpec,
    callback: impl Fn(zenoh::sample::Sample) + Send + Sync + 'static,
) -> Result<Subscription, ReceiveError> {
    let zerr = |e: zenoh::Error| ReceiveError::Zenoh(format!("subscribing to {key}: {e}"));
    let qos = rmw_zenoh::EntityQos::from(spec.qos);
    if spec.qos.durability != Durability::TransientLocal {
        return session
            .declare_subscriber(key.clone())
            .callback(callback)
            .wait()
            .map(Subscription::Plain)
            .map_err(zerr);
    }
    use zenoh_ext::{AdvancedSubscriberBuilderExt, HistoryConfig, RecoveryConfig};
    let depth = rmw_zenoh::advanced_publisher_options(&qos).map_or(1, |(depth, _)| depth);
    let mut builder = session
        .declare_subscriber(key.clone())
        .history(
            HistoryConfig::default()
                .detect_late_publishers()
                .max_samples(depth),
        )
        .subscriber_detection();
    if spec.qos.reliability == Reliability::Reliable {
        builder = builder.recovery(RecoveryConfig::default().heartbeat());
    }
    builder
        .callback(callback)
        .wait()
        .map(Subscription::Advanced)
        .map_err(zerr)
}

impl Drop for Inbox {
    fn drop(&mut self) {
        // Wakes a reliable topic's callback that waits for room, so zenoh can undeclare.
        self.shared.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transport::{self, SessionMode, TransportConfig};
    use nrslam_msgs::{topics, Clock, Time};

    fn session() -> zenoh::Session {
        transport::open(&TransportConfig {
            mode: SessionMode::Peer,
            listen: Vec::new(),
            connect: Vec::new(),
            namespace: String::new(),
            config_file: None,
        })
        .expect("a peer session on nothing")
    }

    fn clock(sec: i32) -> Vec<u8> {
        Message::from(Clock {
            clock: Time { sec, nanosec: 0 },
        })
        .encode()
        .unwrap()
    }

    fn put(session: &zenoh::Session, topic: &str, bytes: Vec<u8>) {
        session
            .put(topics::key_expr("", topic), bytes)
            .congestion_control(zenoh::qos::CongestionControl::Block)
            .wait()
            .unwrap();
    }

    fn next(inbox: &mut Inbox) -> Option<Delivery> {
        inbox.recv_timeout(Duration::from_secs(5)).unwrap()
    }

    fn seconds(delivery: Option<Delivery>) -> i32 {
        match delivery {
            Some(Delivery::Message {
                message: Message::Clock(c),
                ..
            }) => c.clock.sec,
            other => panic!("expected a clock, got {other:?}"),
        }
    }

    #[test]
    fn unusable_samples_are_dropped_counted_and_skipped() {
        let session = session();
        let mut inbox =
            Inbox::subscribe(&session, "", &[topics::CLOCK], InboxOptions::default()).unwrap();
        put(&session, topics::CLOCK, clock(5));
        // A length prefix of 0xffffffff after a stamp, and a foreign encapsulation.
        put(&session, topics::CLOCK, vec![0, 1, 0, 0, 0xff, 0xff, 0xff]);
        put(
            &session,
            topics::CLOCK,
            vec![0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0],
        );
        put(&session, topics::CLOCK, clock(4));
        put(&session, topics::CLOCK, clock(6));
        put(&session, topics::CLOCK, Vec::new());
        assert_eq!(seconds(next(&mut inbox)), 5);
        assert_eq!(seconds(next(&mut inbox)), 6);
        assert_eq!(
            next(&mut inbox),
            Some(Delivery::End {
                topic: topics::CLOCK
            })
        );
        let drops = inbox.drops();
        assert_eq!(drops.get(topics::CLOCK, "bad_cdr"), 2, "{drops:?}");
        assert_eq!(drops.get(topics::CLOCK, "stamp_backwards"), 1, "{drops:?}");
        assert_eq!(drops.total(), 3);
        assert!(inbox.take_changed() && !inbox.take_changed());
    }

    #[test]
    fn under_fail_the_first_unusable_sample_is_the_error() {
        let session = session();
        let options = InboxOptions {
            bad_input: BadInput::Fail,
            ..InboxOptions::default()
        };
        let mut inbox = Inbox::subscribe(&session, "", &[topics::CLOCK], options).unwrap();
        put(&session, topics::CLOCK, vec![0, 1, 0, 0, 9]);
        let error = inbox.recv_timeout(Duration::from_secs(5)).unwrap_err();
        assert!(
            matches!(
                error,
                ReceiveError::Unusable {
                    reason: "bad_cdr",
                    ..
                }
            ),
            "{error}"
        );
        assert!(error
            .to_string()
            .starts_with("/clock: unusable sample (bad_cdr)"));
    }

    #[test]
    fn an_observer_keeps_the_newest_samples_and_counts_the_rest() {
        let session = session();
        let options = InboxOptions {
            overload: Overload::KeepNewest(2),
            ..InboxOptions::default()
        };
        let mut inbox = Inbox::subscribe(&session, "", &[topics::CLOCK], options).unwrap();
        for sec in 1..=5 {
            put(&session, topics::CLOCK, clock(sec));
        }
        assert_eq!(seconds(next(&mut inbox)), 4);
        assert_eq!(seconds(next(&mut inbox)), 5);
        assert_eq!(inbox.drops().get(topics::CLOCK, "queue_full"), 3);
        assert_eq!(inbox.recv_timeout(Duration::from_millis(50)).unwrap(), None);
    }

    #[test]
    fn a_slow_reader_holds_a_reliable_publisher_back_and_loses_nothing() {
        let session = session();
        let mut inbox =
            Inbox::subscribe(&session, "", &[topics::CLOCK], InboxOptions::default()).unwrap();
        let depth = topics::spec(topics::CLOCK).unwrap().qos.depth;
        let total = 3 * depth as i32;
        let publisher = {
            let session = session.clone();
            std::thread::spawn(move || {
                for sec in 1..=total {
                    put(&session, topics::CLOCK, clock(sec));
                }
            })
        };
        // While nobody reads, the publisher gets no further than the queue's depth.
        std::thread::sleep(Duration::from_millis(300));
        assert!(!publisher.is_finished());
        assert!(inbox.shared.lock().topics[topics::CLOCK].samples.len() <= depth);
        for sec in 1..=total {
            assert_eq!(seconds(next(&mut inbox)), sec);
        }
        publisher.join().unwrap();
        assert!(inbox.drops().is_empty());
    }

    /// The key rmw_zenoh (or another client) publishes `topic` on in domain 0, with `hash`.
    fn ros_key(topic: &str, hash: &str) -> String {
        let spec = topics::spec(topic).unwrap();
        crate::rmw_zenoh::key_expr_with_hash(0, topic, spec.type_name, hash)
    }

    fn odometry(sec: i32) -> Vec<u8> {
        let mut odometry = nrslam_msgs::Odometry::default();
        odometry.header.stamp = Time { sec, nanosec: 0 };
        Message::from(odometry).encode().unwrap()
    }

    fn put_key(session: &zenoh::Session, key: &str, bytes: Vec<u8>, attachment: bool) {
        let put = session
            .put(key.to_owned(), bytes)
            .congestion_control(zenoh::qos::CongestionControl::Block);
        let put = match attachment {
            true => put.attachment(crate::rmw_zenoh::attachment(1, 0, &[7; 16])),
            false => put,
        };
        put.wait().unwrap();
    }

    #[test]
    fn ros_keys_take_the_real_and_the_zero_hash_and_count_any_other() {
        let session = session();
        let style = KeyStyle::RmwZenoh { domain_id: 0 };
        let mut inbox = Inbox::subscribe_styled(
            &session,
            "",
            &[topics::ODOM],
            InboxOptions::default(),
            style,
        )
        .unwrap();
        let real = crate::type_hash::rihs01("nav_msgs/msg/Odometry").unwrap();
        let wrong = crate::type_hash::rihs01("geometry_msgs/msg/PoseStamped").unwrap();
        let zero = crate::rmw_zenoh::PLACEHOLDER_TYPE_HASH;
        put_key(&session, &ros_key(topics::ODOM, &real), odometry(1), true);
        put_key(&session, &ros_key(topics::ODOM, zero), odometry(2), false);
        put_key(&session, &ros_key(topics::ODOM, &wrong), odometry(3), true);
        put_key(
            &session,
            &ros_key(topics::ODOM, "RIHS01_ab"),
            odometry(4),
            true,
        );
        // Another domain, and nrslam's own key: not subscribed in domain 0's ROS mode.
        let other_domain =
            crate::rmw_zenoh::key_expr_with_hash(1, topics::ODOM, "nav_msgs/msg/Odometry", &real);
        put_key(&session, &other_domain, odometry(5), true);
        put(&session, topics::ODOM, odometry(6));
        put_key(&session, &ros_key(topics::ODOM, &real), Vec::new(), true);
        put_key(&session, &ros_key(topics::ODOM, &real), odometry(7), true);
        put_key(
            &session,
            &ros_key(topics::ODOM, crate::rmw_zenoh::END_OF_STREAM_CHUNK),
            Vec::new(),
            false,
        );
        let stamp = |delivery: Option<Delivery>| match delivery {
            Some(Delivery::Message {
                message: Message::Odometry(o),
                ..
            }) => o.header.stamp.sec,
            other => panic!("expected odometry, got {other:?}"),
        };
        assert_eq!(stamp(next(&mut inbox)), 1);
        assert_eq!(stamp(next(&mut inbox)), 2);
        assert_eq!(stamp(next(&mut inbox)), 7);
        assert_eq!(
            next(&mut inbox),
            Some(Delivery::End {
                topic: topics::ODOM
            })
        );
        let drops = inbox.drops();
        assert_eq!(
            drops.get(topics::ODOM, "type_hash_mismatch"),
            2,
            "{drops:?}"
        );
        assert_eq!(drops.get(topics::ODOM, "bad_cdr"), 1, "{drops:?}");
        assert_eq!(drops.total(), 3, "{drops:?}");
    }

    #[test]
    fn under_fail_a_wrong_type_hash_is_the_error() {
        let session = session();
        let options = InboxOptions {
            bad_input: BadInput::Fail,
            ..InboxOptions::default()
        };
        let style = KeyStyle::RmwZenoh { domain_id: 0 };
        let mut inbox =
            Inbox::subscribe_styled(&session, "", &[topics::ODOM], options, style).unwrap();
        put_key(
            &session,
            &ros_key(topics::ODOM, "RIHS01_ab"),
            odometry(1),
            true,
        );
        let error = inbox.recv_timeout(Duration::from_secs(5)).unwrap_err();
        assert!(
            matches!(
                error,
                ReceiveError::Unusable {
                    reason: "type_hash_mismatch",
                    ..
                }
            ),
            "{error}"
        );
    }

    #[test]
    fn a_latched_ros_topic_published_before_the_subscription_still_arrives() {
        let session = session();
        let node = crate::transport::RosNode::from_catalogue(
            "radar",
            &[topics::GROUND_TRUTH_TARGETS],
            &[],
        )
        .unwrap();
        let mut publisher =
            crate::transport::TopicPublisher::with_ros_nodes(&session, "", 0, &[node]).unwrap();
        let targets = nrslam_msgs::TargetSet {
            header: nrslam_msgs::Header::new(Time { sec: 3, nanosec: 0 }, "map"),
            ..Default::default()
        };
        publisher
            .publish(topics::GROUND_TRUTH_TARGETS, &targets.into())
            .unwrap();
        let style = KeyStyle::RmwZenoh { domain_id: 0 };
        let mut inbox = Inbox::subscribe_styled(
            &session,
            "",
            &[topics::GROUND_TRUTH_TARGETS],
            InboxOptions::default(),
            style,
        )
        .unwrap();
        match next(&mut inbox) {
            Some(Delivery::Message {
                message: Message::TargetSet(t),
                ..
            }) => assert_eq!(t.header.stamp.sec, 3),
            other => panic!("expected the latched target set, got {other:?}"),
        }
    }

    #[test]
    fn diagnostics_carry_the_drops_and_read_back() {
        let mut drops = Drops::default();
        drops.add("/map", "bad_cdr", 3);
        drops.count("/clock", "stamp_backwards");
        let report = diagnostics("nrslam/mapper/receive", &drops, Time { sec: 7, nanosec: 0 });
        assert_eq!(report.status[0].level, nrslam_msgs::DiagnosticStatus::WARN);
        assert_eq!(report.status[0].message, "dropped 4 unusable samples");
        let back = drops_in(&report);
        assert_eq!(back["nrslam/mapper/receive"], drops);
        let quiet = diagnostics("x", &Drops::default(), Time::default());
        assert_eq!(quiet.status[0].level, nrslam_msgs::DiagnosticStatus::OK);
    }

    #[test]
    fn policies_parse_from_their_flag_values() {
        assert_eq!("drop".parse::<BadInput>(), Ok(BadInput::Drop));
        assert_eq!("fail".parse::<BadInput>(), Ok(BadInput::Fail));
        assert!("ignore"
            .parse::<BadInput>()
            .unwrap_err()
            .contains("drop, fail"));
    }
}
