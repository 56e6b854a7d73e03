//! The zenoh transport: session configuration, a node adapter that runs any [`Node`] over zenoh,
//! and the start barrier that keeps a multi-process graph from losing its first messages.
//!
//! Wire format: each topic is the key expression [`topics::key_expr`] (`/map` → `map`, under an
//! optional namespace); each sample's payload is the message in ROS 2 CDR (little-endian, 4-byte
//! encapsulation header); an **empty payload** marks the end of a topic's stream (CDR is never
//! empty). Publications are reliable with congestion control `Block`: nothing is dropped.
//!
//! Start barrier (docs/design.md, "Traps known"): every node declares its subscribers and publishers, then a
//! liveliness token `nrslam/ready/<node>`; the launcher waits for all tokens and puts
//! `nrslam/start`; sources tick only after it. Declarations travel ahead of the token on the same
//! link, so by then every subscriber is known to the router.

use crate::merge::Merger;
use crate::node::{Node, NodeError, Outbox, Tick};
use crate::receive::{diagnostics, Delivery, Drops, Inbox, InboxOptions, ReceiveError};
pub use crate::rmw_zenoh::graph::{RosEndpoint, RosGraph, RosNode};
use nrslam_msgs::{topics, Message};
use std::collections::BTreeMap;
use std::sync::mpsc;
use std::time::{Duration, Instant};
use zenoh::qos::CongestionControl;
use zenoh::Wait;

pub use zenoh::Session;

/// Role of the session in the zenoh network.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionMode {
    /// Peer: the default for a launcher that mirrors topics.
    Peer,
    /// Client of a router or peer: node processes of a launch.
    Client,
    /// Router: the launcher of a multi-process graph, routing between its node processes.
    Router,
}

/// How to open a session.
///
/// Defaults (no `config_file`): multicast and gossip scouting off; a session listens only on
/// `listen` and connects only to `connect`, so nothing leaves the machine unless an endpoint on
/// another host is named (docs/security.md).
///
/// With `config_file`, the file is the base (TLS, mutual TLS, access control, anything zenoh
/// accepts) and nrslam's settings go on top of it, by these rules:
///
/// | setting | result |
/// |---|---|
/// | `mode` | always [`TransportConfig::mode`]: the graph depends on its roles (router launcher, client node processes); a different `mode` in the file is overridden, with a warning |
/// | `scouting/multicast/enabled`, `scouting/gossip/enabled` | off, unless the file sets them `true` itself |
/// | `listen/endpoints` | the file's (for the mode), then [`TransportConfig::listen`], without duplicates; a client ignores the file's: nrslam's clients never accept connections, so one file can serve a launcher and its node processes |
/// | `connect/endpoints` | [`TransportConfig::connect`] when it is not empty (it **replaces** the file's); otherwise the file's |
/// | `connect/timeout_ms` (client) | 10 s unless the file sets it |
/// | everything else | the file's, or zenoh's default |
///
/// A list of endpoints the file leaves out is nrslam's alone, never zenoh's default (which would
/// listen on every interface).
#[derive(Debug, Clone)]
pub struct TransportConfig {
    /// Role.
    pub mode: SessionMode,
    /// Endpoints to listen on, e.g. `tcp/127.0.0.1:7447`.
    pub listen: Vec<String>,
    /// Endpoints to connect to.
    pub connect: Vec<String>,
    /// Key prefix for every topic (empty: none).
    pub namespace: String,
    /// A zenoh configuration file (`.json5`, `.json`, `.yaml`/`.yml`; `--zenoh-config`) to start
    /// from, e.g. for mutual TLS or access control: see the rules above and docs/security.md.
    pub config_file: Option<std::path::PathBuf>,
}

impl Default for TransportConfig {
    /// A peer that listens nowhere, connects nowhere, without namespace or configuration file.
    fn default() -> Self {
        Self {
            mode: SessionMode::Peer,
            listen: Vec::new(),
            connect: Vec::new(),
            namespace: String::new(),
            config_file: None,
        }
    }
}

impl TransportConfig {
    /// This configuration joined to an `rmw_zenohd` router at `endpoint` (`--ros-router`): the
    /// router first among the endpoints to connect to and, for a peer, the client role.
    ///
    /// Why a client: rmw_zenoh's sessions are peers that learn each other from the router by
    /// gossip and then talk peer to peer, and its router does not forward data between peers
    /// (rmw_zenoh README, "Connecting to the Zenoh router on another host": "switch the remote
    /// node into the client mode to make Zenoh router forward messages"). A client's
    /// publications, subscriptions and liveliness tokens are routed by the router to every ROS
    /// node, with no listening port and no gossip on nrslam's side. A router or client session
    /// (a processes-mode launcher, its node processes) keeps its role and also connects.
    pub fn via_ros_router(mut self, endpoint: &str) -> Self {
        if self.mode == SessionMode::Peer {
            self.mode = SessionMode::Client;
        }
        self.connect.retain(|e| e != endpoint);
        self.connect.insert(0, endpoint.to_owned());
        self
    }
}

/// A transport failure.
#[derive(Debug, thiserror::Error)]
pub enum TransportError {
    /// zenoh refused the configuration or an operation.
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// The start barrier did not complete.
    #[error("start barrier: {0}")]
    Barrier(String),
    /// A received payload could not be decoded.
    #[error("{topic}: {reason}")]
    Decode {
        /// Topic.
        topic: String,
        /// Why.
        reason: String,
    },
    /// The node failed.
    #[error(transparent)]
    Node(#[from] NodeError),
    /// Receiving stopped (the session closed, or an unusable sample under `fail`).
    #[error(transparent)]
    Receive(#[from] ReceiveError),
}

fn zerr(error: impl std::fmt::Display) -> TransportError {
    TransportError::Zenoh(error.to_string())
}

/// The zenoh configuration for `config`: [`TransportConfig::config_file`] (if any) with nrslam's
/// settings on top, by the rules in [`TransportConfig`]'s documentation.
pub fn zenoh_config(config: &TransportConfig) -> Result<zenoh::Config, TransportError> {
    let mode = match config.mode {
        SessionMode::Peer => "peer",
        SessionMode::Client => "client",
        SessionMode::Router => "router",
    };
    let (mut z, named) = match &config.config_file {
        None => (zenoh::Config::default(), serde_json::Value::Null),
        Some(path) => {
            let named = config_file_settings(path)?;
            let z = zenoh::Config::from_file(path).map_err(|e| file_error(path, e))?;
            if let Some(theirs) = named.pointer("/mode").and_then(|m| m.as_str()) {
                if theirs != mode {
                    tracing::warn!(
                        "{}: mode {theirs:?} overridden by nrslam's {mode:?} (the graph needs it)",
                        path.display()
                    );
                }
            }
            (z, named)
        }
    };
    let set = |z: &mut zenoh::Config, key: &str, value: &str| {
        z.insert_json5(key, value)
            .map_err(|e| match &config.config_file {
                Some(path) => file_error(path, format!("{key}: {e}")),
                None => zerr(e),
            })
    };
    set(&mut z, "mode", &format!("{mode:?}"))?;
    for scouting in ["multicast", "gossip"] {
        let enabled = named.pointer(&format!("/scouting/{scouting}/enabled"));
        if enabled != Some(&serde_json::Value::Bool(true)) {
            set(&mut z, &format!("scouting/{scouting}/enabled"), "false")?;
        }
    }
    let mut listen = if config.mode == SessionMode::Client {
        Vec::new()
    } else {
        named_endpoints(&named, "listen", mode)
    };
    for endpoint in &config.listen {
        let endpoint = serde_json::Value::String(endpoint.clone());
        if !listen.contains(&endpoint) {
            listen.push(endpoint);
        }
    }
    let connect = if config.connect.is_empty() {
        named_endpoints(&named, "connect", mode)
    } else {
        config
            .connect
            .iter()
            .map(|e| serde_json::Value::String(e.clone()))
            .collect()
    };
    set(
        &mut z,
        "listen/endpoints",
        &serde_json::Value::from(listen).to_string(),
    )?;
    set(
        &mut z,
        "connect/endpoints",
        &serde_json::Value::from(connect).to_string(),
    )?;
    // A node process must not start before it reaches its launcher.
    if config.mode == SessionMode::Client && named.pointer("/connect/timeout_ms").is_none() {
        set(&mut z, "connect/timeout_ms", "10000")?;
    }
    Ok(z)
}

/// An error about the configuration file `path`.
fn file_error(path: &std::path::Path, error: impl std::fmt::Display) -> TransportError {
    TransportError::Zenoh(format!("configuration file {}: {error}", path.display()))
}

/// The settings the configuration file `path` names itself (zenoh's defaults left out), parsed as
/// zenoh parses it (by extension), to tell "set by the file" from "zenoh's default".
fn config_file_settings(path: &std::path::Path) -> Result<serde_json::Value, TransportError> {
    let text = std::fs::read_to_string(path).map_err(|e| file_error(path, e))?;
    match path.extension().and_then(|e| e.to_str()) {
        Some("json5" | "json") => json5::from_str(&text).map_err(|e| file_error(path, e)),
        Some("yaml" | "yml") => serde_yaml::from_str(&text).map_err(|e| file_error(path, e)),
        _ => Err(file_error(
            path,
            "unsupported extension (.json5, .json, .yaml and .yml are)",
        )),
    }
}

/// The `listen` or `connect` endpoints (`which`) the file names for `mode`: a list, or the
/// entry of a per-mode object (`{ router: [...], peer: [...], client: [...] }`).
fn named_endpoints(named: &serde_json::Value, which: &str, mode: &str) -> Vec<serde_json::Value> {
    let endpoints = named.pointer(&format!("/{which}/endpoints"));
    let list = match endpoints {
        Some(serde_json::Value::Object(per_mode)) => per_mode.get(mode),
        other => other,
    };
    list.and_then(|l| l.as_array()).cloned().unwrap_or_default()
}

/// Opens a session with [`zenoh_config`]`(config)`.
pub fn open(config: &TransportConfig) -> Result<Session, TransportError> {
    zenoh::open(zenoh_config(config)?)
        .wait()
        .map_err(|e| match &config.config_file {
            Some(path) => file_error(path, format!("opening the session: {e}")),
            None => zerr(e),
        })
}

/// Key of the start signal.
pub fn start_key(namespace: &str) -> String {
    topics::key_expr(namespace, "/nrslam/start")
}

/// Liveliness key of node `name`'s readiness (`nrslam/ready/agv1/radar` for a node under a
/// namespace).
pub fn ready_key(namespace: &str, name: &str) -> String {
    topics::key_expr(namespace, &format!("/nrslam/ready/{name}"))
}

/// Publishes messages of a graph onto zenoh; used by node adapters and by the launcher to mirror
/// an in-process graph for outside subscribers. Topics are named as the graph names them
/// (`/map`); any type can be published as CDR bytes ([`TopicPublisher::declare_raw`],
/// [`TopicPublisher::publish_raw`]).
pub struct TopicPublisher {
    session: Session,
    namespace: String,
    publishers: BTreeMap<String, zenoh::pubsub::Publisher<'static>>,
    /// With [`KeyStyle::RmwZenoh`]: the ROS 2 graph (tokens and data publishers) instead.
    ros: Option<RosGraph>,
}

/// The node that owns topics published through a [`TopicPublisher`] of style
/// [`KeyStyle::RmwZenoh`] that no declared node publishes (e.g. `bag play`'s).
pub const DEFAULT_ROS_NODE: &str = "nrslam";

/// How topics map to key expressions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum KeyStyle {
    /// nrslam's own: the topic name without its leading '/', under the namespace; empty payload at
    /// the end of each stream.
    #[default]
    Nrslam,
    /// rmw_zenoh's, in ROS domain `domain_id` ([`crate::rmw_zenoh`]): data on
    /// `<domain>/<topic>/<DDS type>/<RIHS01 hash>` with rmw_zenoh's attachment, liveliness tokens
    /// for the nodes and their publishers, transient-local topics cached for late joiners; the
    /// end of a stream is an empty payload on `<domain>/<topic>/<DDS type>/@nrslam_end`, a key
    /// only nrslam's subscribers match (ROS 2 has no end-of-stream). Received by
    /// [`Inbox::subscribe_styled`] on `<domain>/<topic>/<DDS type>/*`, the hash judged by
    /// [`crate::rmw_zenoh::judge_hash`].
    RmwZenoh {
        /// ROS domain id (`ROS_DOMAIN_ID`).
        domain_id: u32,
    },
}

impl TopicPublisher {
    /// Declares one publisher per topic.
    pub fn new(
        session: &Session,
        namespace: &str,
        topics: &[&'static str],
    ) -> Result<Self, TransportError> {
        Self::with_style(session, namespace, topics, KeyStyle::Nrslam)
    }

    /// Declares one publisher per catalogue topic, with key expressions in `style`. With
    /// [`KeyStyle::RmwZenoh`] they are the publishers of one ROS node, [`DEFAULT_ROS_NODE`].
    pub fn with_style(
        session: &Session,
        namespace: &str,
        topics: &[&'static str],
        style: KeyStyle,
    ) -> Result<Self, TransportError> {
        match style {
            KeyStyle::Nrslam => {
                let mut publisher = Self {
                    session: session.clone(),
                    namespace: namespace.to_owned(),
                    publishers: BTreeMap::new(),
                    ros: None,
                };
                for &topic in topics {
                    publisher.declare(topic)?;
                }
                Ok(publisher)
            }
            KeyStyle::RmwZenoh { domain_id } => {
                let node = RosNode::from_catalogue(DEFAULT_ROS_NODE, topics, &[])?;
                Self::with_ros_nodes(session, namespace, domain_id, &[node])
            }
        }
    }

    /// The publishers of a graph of ROS 2 `nodes` on rmw_zenoh in ROS domain `domain_id`: each
    /// node's liveliness tokens (`NN`, `MP` per published topic, `MS` per subscribed topic) and
    /// one data publisher per published topic ([`RosGraph`]). `namespace` is the nodes' ROS
    /// namespace (`robot1` → `/robot1`).
    pub fn with_ros_nodes(
        session: &Session,
        namespace: &str,
        domain_id: u32,
        nodes: &[RosNode],
    ) -> Result<Self, TransportError> {
        let mut graph = RosGraph::new(session, domain_id, namespace);
        for node in nodes {
            graph.declare_node(node)?;
        }
        Ok(Self {
            session: session.clone(),
            namespace: namespace.to_owned(),
            publishers: BTreeMap::new(),
            ros: Some(graph),
        })
    }

    /// The ROS 2 graph, with [`KeyStyle::RmwZenoh`].
    pub fn ros_graph(&self) -> Option<&RosGraph> {
        self.ros.as_ref()
    }

    /// Declares a publisher for `endpoint`, of any type (e.g. a bag's topic outside the
    /// catalogue; with [`KeyStyle::RmwZenoh`] its `type_hash` must be given unless the type is
    /// one of `nrslam_msgs::schema`'s). Nothing happens if the topic already has one.
    pub fn declare_raw(&mut self, endpoint: &RosEndpoint) -> Result<(), TransportError> {
        match &mut self.ros {
            Some(graph) if graph.publishes(&endpoint.topic) => Ok(()),
            Some(graph) => graph.declare_node(&RosNode {
                name: DEFAULT_ROS_NODE.into(),
                publishes: vec![endpoint.clone()],
                subscribes: Vec::new(),
            }),
            None => self.declare_key(&endpoint.topic),
        }
    }

    fn declare(&mut self, topic: &str) -> Result<(), TransportError> {
        match &self.ros {
            Some(graph) if graph.publishes(topic) => Ok(()),
            Some(_) => self.declare_raw(&RosEndpoint::catalogue(topic)?),
            None => self.declare_key(topic),
        }
    }

    fn declare_key(&mut self, topic: &str) -> Result<(), TransportError> {
        if !self.publishers.contains_key(topic) {
            let publisher = self
                .session
                .declare_publisher(topics::key_expr(&self.namespace, topic))
                .congestion_control(CongestionControl::Block)
                .wait()
                .map_err(zerr)?;
            self.publishers.insert(topic.to_owned(), publisher);
        }
        Ok(())
    }

    /// Whether every declared publisher has at least one matching subscriber.
    pub fn all_matched(&self) -> bool {
        if let Some(graph) = &self.ros {
            return graph.all_matched();
        }
        self.publishers.values().all(|p| {
            p.matching_status()
                .wait()
                .map(|s| s.matching())
                .unwrap_or(false)
        })
    }

    /// Publishes `message` on `topic` as CDR.
    pub fn publish(
        &mut self,
        topic: &'static str,
        message: &Message,
    ) -> Result<(), TransportError> {
        let bytes = message.encode().map_err(|e| TransportError::Decode {
            topic: topic.into(),
            reason: e.to_string(),
        })?;
        self.put(topic, bytes)
    }

    /// Publishes bytes already in CDR (e.g. read from a bag) on catalogue topic `topic`.
    pub fn publish_cdr(
        &mut self,
        topic: &'static str,
        bytes: Vec<u8>,
    ) -> Result<(), TransportError> {
        self.publish_raw(topic, bytes)
    }

    /// Publishes CDR `bytes` on `topic`: a catalogue topic, or one declared with
    /// [`TopicPublisher::declare_raw`].
    pub fn publish_raw(&mut self, topic: &str, bytes: Vec<u8>) -> Result<(), TransportError> {
        if bytes.is_empty() {
            return Err(TransportError::Decode {
                topic: topic.into(),
                reason: "empty CDR payload (reserved for the end of a stream)".into(),
            });
        }
        self.put(topic, bytes)
    }

    /// Marks the end of `topic`'s stream. With [`KeyStyle::RmwZenoh`] on nrslam's end-of-stream
    /// key ([`crate::rmw_zenoh::END_OF_STREAM_CHUNK`]): ROS 2 has no end-of-stream, and its
    /// subscribers never match that key; nrslam's do, so a chain of nodes in one ROS domain ends.
    pub fn end(&mut self, topic: &str) -> Result<(), TransportError> {
        if let Some(graph) = &self.ros {
            return graph.end(topic);
        }
        self.put(topic, Vec::new())
    }

    fn put(&mut self, topic: &str, bytes: Vec<u8>) -> Result<(), TransportError> {
        self.declare(topic)?;
        match &mut self.ros {
            Some(graph) => graph.put(topic, bytes),
            None => self.publishers[topic].put(bytes).wait().map_err(zerr),
        }
    }
}

/// Decodes a payload received on `topic` by the catalogue's type.
pub fn decode(topic: &str, bytes: &[u8]) -> Result<Message, TransportError> {
    let spec = topics::spec(topic).ok_or_else(|| TransportError::Decode {
        topic: topic.into(),
        reason: "not in the topic catalogue".into(),
    })?;
    Message::decode(spec.type_name, bytes).map_err(|e| TransportError::Decode {
        topic: topic.into(),
        reason: e.to_string(),
    })
}

/// Paces a source at `rate` × real time from the stamps it publishes (`rate` ≤ 0: no pacing).
#[derive(Debug)]
pub struct Pacer {
    rate: f64,
    origin: Option<(Instant, f64)>,
}

impl Pacer {
    /// A pacer at real-time factor `rate`.
    pub fn new(rate: f64) -> Self {
        Self { rate, origin: None }
    }

    /// Sleeps until the wall clock has caught up with simulated time `stamp_s`.
    pub fn pace(&mut self, stamp_s: f64) {
        if self.rate <= 0.0 || !self.rate.is_finite() {
            return;
        }
        let (wall, first) = *self.origin.get_or_insert((Instant::now(), stamp_s));
        // A stamp far ahead at a tiny rate is a wait too long to represent: wait a day at most.
        let due = Duration::try_from_secs_f64(((stamp_s - first) / self.rate).max(0.0))
            .unwrap_or(Duration::MAX)
            .min(Duration::from_secs(86_400));
        if let Some(wait) = due.checked_sub(wall.elapsed()) {
            std::thread::sleep(wait);
        }
    }
}

/// Runs `node` over zenoh until its inputs end (or, for a source, until it is done), dropping
/// and counting unusable input samples ([`run_node_with`] with the default [`InboxOptions`]).
///
/// With `wait_for_start`, the node declares its readiness and a source waits for the launcher's
/// start signal (at most `start_timeout`); without it a source starts at once.
pub fn run_node(
    session: &Session,
    namespace: &str,
    name: &str,
    node: Box<dyn Node>,
    wait_for_start: bool,
    start_timeout: Duration,
    rate: f64,
) -> Result<Drops, TransportError> {
    run_node_with(
        session,
        namespace,
        name,
        node,
        NodeRun {
            wait_for_start,
            start_timeout,
            rate,
            inbox: InboxOptions::default(),
            ended: Vec::new(),
            style: KeyStyle::Nrslam,
        },
    )
}

/// How often, at most, a node reports its receive path's drops on `/diagnostics`.
pub const DIAGNOSTICS_PERIOD: Duration = Duration::from_secs(1);

/// How [`run_node_with`] runs a node.
#[derive(Debug, Clone)]
pub struct NodeRun {
    /// Declare readiness; a source waits for the launcher's start signal.
    pub wait_for_start: bool,
    /// How long a source waits for it.
    pub start_timeout: Duration,
    /// Real-time factor of a source (≤ 0: as fast as possible).
    pub rate: f64,
    /// What the receive path does with unusable samples and overload.
    pub inbox: InboxOptions,
    /// Inputs whose streams ended before the node started (a respawned node is told so by its
    /// launcher): nothing more will arrive on them.
    pub ended: Vec<&'static str>,
    /// Keys of inputs and outputs. With [`KeyStyle::RmwZenoh`] the node is also a ROS 2 node on
    /// rmw_zenoh (its `NN`, `MP` and `MS` tokens) whose subscriptions take what ROS 2 publishers
    /// send; the start barrier stays on nrslam's keys.
    pub style: KeyStyle,
}

/// [`run_node`] with every option. Returns what the receive path dropped.
pub fn run_node_with(
    session: &Session,
    namespace: &str,
    name: &str,
    mut node: Box<dyn Node>,
    run: NodeRun,
) -> Result<Drops, TransportError> {
    let NodeRun {
        wait_for_start,
        start_timeout,
        rate,
        inbox: inbox_options,
        ended,
        style,
    } = run;
    let inputs = node.inputs();
    let outputs = node.outputs();
    let mut publisher = match style {
        KeyStyle::Nrslam => TopicPublisher::new(session, namespace, &outputs)?,
        KeyStyle::RmwZenoh { domain_id } => {
            // /diagnostics is the node's own publisher too, not a second ROS node's.
            let mut published = outputs.clone();
            if !published.contains(&topics::DIAGNOSTICS) {
                published.push(topics::DIAGNOSTICS);
            }
            let ros = RosNode::from_catalogue(name, &published, &inputs)?;
            TopicPublisher::with_ros_nodes(session, namespace, domain_id, &[ros])?
        }
    };
    let mut inbox = Inbox::subscribe_styled(session, namespace, &inputs, inbox_options, style)?;
    let (_start_subscriber, start) = if inputs.is_empty() && wait_for_start {
        let (sender, receiver) = mpsc::channel();
        let subscriber = session
            .declare_subscriber(start_key(namespace))
            .callback(move |_| {
                let _ = sender.send(());
            })
            .wait()
            .map_err(zerr)?;
        (Some(subscriber), Some(receiver))
    } else {
        (None, None)
    };
    let _token = session
        .liveliness()
        .declare_token(ready_key(namespace, name))
        .wait()
        .map_err(zerr)?;
    let mut outbox = Outbox::new();
    let flush =
        |outbox: &mut Outbox, publisher: &mut TopicPublisher| -> Result<(), TransportError> {
            for (topic, message) in outbox.drain() {
                publisher.publish(topic, &message)?;
            }
            Ok(())
        };
    if inputs.is_empty() {
        if let Some(start) = start {
            start.recv_timeout(start_timeout).map_err(|_| {
                TransportError::Barrier(format!(
                    "no start signal within {} s",
                    start_timeout.as_secs()
                ))
            })?;
        }
        let mut pacer = Pacer::new(rate);
        loop {
            let tick = node.tick(&mut outbox)?;
            if let Some(stamp) = outbox_latest_stamp(&outbox) {
                pacer.pace(stamp);
            }
            flush(&mut outbox, &mut publisher)?;
            if tick == Tick::Done {
                break;
            }
        }
    } else {
        let mut merger = Merger::new(&inputs);
        for topic in ended {
            let _ = merger.close(topic);
        }
        let component = format!("nrslam/{name}/receive");
        let mut stamp = nrslam_msgs::Time::default();
        // Drops are reported at most every DIAGNOSTICS_PERIOD (and once more at the end), so a
        // flood of bad samples does not become a flood of reports.
        let mut unreported = false;
        let mut last_report: Option<Instant> = None;
        while !merger.finished() {
            match inbox.recv_timeout(Duration::from_millis(500))? {
                Some(Delivery::End { topic }) => {
                    let _ = merger.close(topic);
                }
                Some(Delivery::Message { topic, message, .. }) => {
                    stamp = message.stamp();
                    let _ = merger.push(topic, message);
                }
                None => {}
            }
            unreported |= inbox.take_changed();
            if unreported && last_report.is_none_or(|t| t.elapsed() >= DIAGNOSTICS_PERIOD) {
                let report = diagnostics(&component, inbox.drops(), stamp);
                publisher.publish(topics::DIAGNOSTICS, &report.into())?;
                unreported = false;
                last_report = Some(Instant::now());
            }
            while let Some((topic, message)) = merger.pop_ready() {
                node.on_message(topic, &message, &mut outbox)?;
                flush(&mut outbox, &mut publisher)?;
            }
        }
        if unreported || inbox.take_changed() {
            let report = diagnostics(&component, inbox.drops(), stamp);
            publisher.publish(topics::DIAGNOSTICS, &report.into())?;
        }
        node.on_end(&mut outbox)?;
        flush(&mut outbox, &mut publisher)?;
    }
    for topic in outputs {
        publisher.end(topic)?;
    }
    Ok(inbox.drops().clone())
}

fn outbox_latest_stamp(outbox: &Outbox) -> Option<f64> {
    outbox
        .iter()
        .map(|(_, m)| m.stamp().as_seconds())
        .reduce(f64::max)
}

/// Waits until every node in `names` has declared readiness, then signals start.
/// `alive` is polled meanwhile so a node that died is reported instead of waited for.
pub fn start_barrier(
    session: &Session,
    namespace: &str,
    names: &[String],
    timeout: Duration,
    mut alive: impl FnMut() -> Result<(), String>,
) -> Result<(), TransportError> {
    let deadline = Instant::now()
        .checked_add(timeout)
        .ok_or_else(|| TransportError::Barrier(format!("a timeout of {timeout:?} is too long")))?;
    loop {
        alive().map_err(TransportError::Barrier)?;
        // `**`, not `*`: a node under a namespace is named `agv1/radar`, two key chunks.
        let replies = session
            .liveliness()
            .get(topics::key_expr(namespace, "/nrslam/ready/**"))
            .wait()
            .map_err(zerr)?;
        let prefix = ready_key(namespace, "");
        let mut ready = Vec::new();
        while let Ok(reply) = replies.recv() {
            if let Ok(sample) = reply.result() {
                if let Some(name) = sample.key_expr().as_str().strip_prefix(&prefix) {
                    ready.push(name.to_owned());
                }
            }
        }
        let missing: Vec<&String> = names.iter().filter(|n| !ready.contains(n)).collect();
        if missing.is_empty() {
            break;
        }
        if Instant::now() > deadline {
            return Err(TransportError::Barrier(format!(
                "nodes not ready after {} s: {}",
                timeout.as_secs(),
                missing
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    session
        .put(start_key(namespace), Vec::<u8>::new())
        .congestion_control(CongestionControl::Block)
        .wait()
        .map_err(zerr)
}
