//! The graph as rmw_zenoh sees it: a zenoh session's ROS 2 nodes, their liveliness tokens and
//! the data publishers of their topics (see the parent module for the formats and sources).
//!
//! One [`RosGraph`] per session, as rmw_zenoh has one per context: node and entity ids come from
//! one counter, so the tokens of two graphs on one session could collide. A topic published by
//! several nodes has one data publisher (the first node's, whose GID its samples carry) and one
//! `MP` token per node, as `ros2 topic info -v` would list them.

use super::{
    advanced_publisher_options, attachment, dds_type_name, gid, is_valid_node_name,
    liveliness_token, EntityKind, EntityQos, NodeInfo, TopicInfo, GID_LEN,
    SAMPLE_MISS_HEARTBEAT_PERIOD,
};
use crate::transport::TransportError;
use nrslam_msgs::topics;
use std::collections::BTreeMap;
use zenoh::qos::CongestionControl;
use zenoh::Wait;
use zenoh_ext::{AdvancedPublisherBuilderExt, CacheConfig, MissDetectionConfig};

/// A publisher or subscription of a node: topic (as the graph names it, e.g. `/map`), ROS type
/// (`pkg/msg/Type`), its RIHS01 hash and QoS.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RosEndpoint {
    /// Topic, e.g. `/map` (the namespace, if any, is added by the graph).
    pub topic: String,
    /// ROS type name, e.g. `nav_msgs/msg/OccupancyGrid`.
    pub type_name: String,
    /// `RIHS01_<hex>`; `None`: computed from the definitions of `nrslam_msgs::schema`.
    pub type_hash: Option<String>,
    /// QoS.
    pub qos: topics::Qos,
}

impl RosEndpoint {
    /// The endpoint of catalogue topic `topic` (or one under a namespace, `/agv1/odom`, which
    /// keeps its name), with its type and QoS.
    pub fn catalogue(topic: &str) -> Result<Self, TransportError> {
        let spec = topics::spec(topic).ok_or_else(|| TransportError::Decode {
            topic: topic.into(),
            reason: "not in the topic catalogue (give its type and hash)".into(),
        })?;
        Ok(Self {
            topic: topic.to_owned(),
            type_name: spec.type_name.to_owned(),
            type_hash: None,
            qos: spec.qos,
        })
    }
}

/// A ROS 2 node of the graph: name and endpoints.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RosNode {
    /// Node name: `[A-Za-z_][A-Za-z0-9_]*` (other characters become `_`).
    pub name: String,
    /// Topics it publishes.
    pub publishes: Vec<RosEndpoint>,
    /// Topics it subscribes to.
    pub subscribes: Vec<RosEndpoint>,
}

impl RosNode {
    /// Node `name` publishing `outputs` and subscribing to `inputs`, all catalogue topics.
    pub fn from_catalogue(
        name: &str,
        outputs: &[&str],
        inputs: &[&str],
    ) -> Result<Self, TransportError> {
        let endpoints = |list: &[&str]| -> Result<Vec<RosEndpoint>, TransportError> {
            list.iter().map(|t| RosEndpoint::catalogue(t)).collect()
        };
        Ok(Self {
            name: name.to_owned(),
            publishes: endpoints(outputs)?,
            subscribes: endpoints(inputs)?,
        })
    }
}

/// `name` made a valid ROS node name: characters outside `[A-Za-z0-9_]` become `_`, and a
/// leading digit gets a `_` in front (rcl refuses anything else).
pub fn ros_node_name(name: &str) -> String {
    if is_valid_node_name(name) {
        return name.to_owned();
    }
    let mut out: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if !out.starts_with(|c: char| c.is_ascii_alphabetic() || c == '_') {
        out.insert(0, '_');
    }
    out
}

/// A data publisher: plain for volatile topics, advanced (cache, detection) for transient local.
enum Outlet {
    Plain(zenoh::pubsub::Publisher<'static>),
    Advanced(zenoh_ext::AdvancedPublisher<'static>),
}

struct Publisher {
    outlet: Outlet,
    key_expr: String,
    gid: [u8; GID_LEN],
    sequence: i64,
}

/// A session's ROS 2 nodes on rmw_zenoh: their tokens, and one data publisher per topic.
pub struct RosGraph {
    session: zenoh::Session,
    domain_id: u32,
    /// ROS namespace of every node, `/` when none (e.g. `/robot1`).
    namespace: String,
    zid: String,
    next_id: usize,
    tokens: Vec<(String, zenoh::liveliness::LivelinessToken)>,
    publishers: BTreeMap<String, Publisher>,
}

impl RosGraph {
    /// An empty graph on `session` in ROS domain `domain_id`, its nodes in `namespace` (a zenoh
    /// key prefix as `--namespace` takes it: `robot1` → ROS namespace `/robot1`; empty: `/`).
    pub fn new(session: &zenoh::Session, domain_id: u32, namespace: &str) -> Self {
        let namespace = namespace.trim_matches('/');
        Self {
            session: session.clone(),
            domain_id,
            namespace: format!("/{namespace}"),
            zid: session.zid().to_string(),
            next_id: 0,
            tokens: Vec::new(),
            publishers: BTreeMap::new(),
        }
    }

    /// The fully qualified ROS name of graph topic `topic` (`/map` → `/robot1/map`).
    pub fn qualified(&self, topic: &str) -> String {
        super::qualified_topic(&self.namespace, topic)
    }

    fn next_id(&mut self) -> usize {
        let id = self.next_id;
        self.next_id += 1;
        id
    }

    fn declare_token(&mut self, token: String) -> Result<(), TransportError> {
        let declared = self
            .session
            .liveliness()
            .declare_token(token.clone())
            .wait()
            .map_err(|e| TransportError::Zenoh(format!("liveliness token {token}: {e}")))?;
        self.tokens.push((token, declared));
        Ok(())
    }

    fn topic_info(&self, endpoint: &RosEndpoint) -> Result<TopicInfo, TransportError> {
        let type_hash = match &endpoint.type_hash {
            Some(hash) => hash.clone(),
            None => crate::type_hash::rihs01(&endpoint.type_name).map_err(|e| {
                TransportError::Decode {
                    topic: endpoint.topic.clone(),
                    reason: e.to_string(),
                }
            })?,
        };
        Ok(TopicInfo {
            name: self.qualified(&endpoint.topic),
            dds_type: dds_type_name(&endpoint.type_name),
            type_hash,
            qos: EntityQos::from(endpoint.qos),
        })
    }

    /// Declares `node`: its `NN` token, an `MP` token and (for the first publisher of a topic) a
    /// data publisher per published topic, an `MS` token per subscribed topic.
    pub fn declare_node(&mut self, node: &RosNode) -> Result<(), TransportError> {
        let node_id = self.next_id();
        let info = NodeInfo {
            domain_id: self.domain_id,
            zid: self.zid.clone(),
            node_id,
            enclave: "/".into(),
            namespace: self.namespace.clone(),
            name: ros_node_name(&node.name),
        };
        self.declare_token(liveliness_token(&info, node_id, EntityKind::Node, None))?;
        for endpoint in &node.publishes {
            let topic = self.topic_info(endpoint)?;
            let id = self.next_id();
            let token = liveliness_token(&info, id, EntityKind::Publisher, Some(&topic));
            if !self.publishers.contains_key(&endpoint.topic) {
                let publisher = self.data_publisher(&topic, gid(&token))?;
                self.publishers.insert(endpoint.topic.clone(), publisher);
            }
            self.declare_token(token)?;
        }
        for endpoint in &node.subscribes {
            let topic = self.topic_info(endpoint)?;
            let id = self.next_id();
            self.declare_token(liveliness_token(
                &info,
                id,
                EntityKind::Subscription,
                Some(&topic),
            ))?;
        }
        Ok(())
    }

    /// The data publisher of `topic`, declared as rmw_zenoh's `PublisherData::make` does. The
    /// congestion control is nrslam's `Block` (back-pressure, nothing dropped) where rmw_zenoh
    /// drops under congestion unless keep-all: a local choice, invisible in discovery.
    fn data_publisher(
        &self,
        topic: &TopicInfo,
        gid: [u8; GID_LEN],
    ) -> Result<Publisher, TransportError> {
        let key_expr = super::data_key_expr(self.domain_id, topic);
        let zerr = |e: zenoh::Error| TransportError::Zenoh(format!("publisher {key_expr}: {e}"));
        let builder = self
            .session
            .declare_publisher(key_expr.clone())
            .congestion_control(CongestionControl::Block);
        let outlet = match advanced_publisher_options(&topic.qos) {
            None => Outlet::Plain(builder.wait().map_err(zerr)?),
            Some((depth, miss_detection)) => {
                let mut advanced = builder
                    .cache(CacheConfig::default().max_samples(depth))
                    .publisher_detection();
                if miss_detection {
                    advanced = advanced.sample_miss_detection(
                        MissDetectionConfig::default()
                            .sporadic_heartbeat(SAMPLE_MISS_HEARTBEAT_PERIOD),
                    );
                }
                Outlet::Advanced(advanced.wait().map_err(zerr)?)
            }
        };
        Ok(Publisher {
            outlet,
            key_expr,
            gid,
            sequence: 0,
        })
    }

    /// Whether graph topic `topic` has a data publisher.
    pub fn publishes(&self, topic: &str) -> bool {
        self.publishers.contains_key(topic)
    }

    /// The data key expression and publisher GID of graph topic `topic`.
    pub fn publisher_of(&self, topic: &str) -> Option<(&str, [u8; GID_LEN])> {
        self.publishers
            .get(topic)
            .map(|p| (p.key_expr.as_str(), p.gid))
    }

    /// Every declared liveliness token, in declaration order.
    pub fn tokens(&self) -> impl Iterator<Item = &str> {
        self.tokens.iter().map(|(t, _)| t.as_str())
    }

    /// Publishes CDR `bytes` on graph topic `topic` with rmw_zenoh's attachment (next sequence
    /// number, wall-clock source timestamp, the publisher's GID).
    pub fn put(&mut self, topic: &str, bytes: Vec<u8>) -> Result<(), TransportError> {
        let publisher = self
            .publishers
            .get_mut(topic)
            .ok_or_else(|| TransportError::Decode {
                topic: topic.into(),
                reason: "no ROS 2 publisher declared for it".into(),
            })?;
        publisher.sequence += 1;
        let now_ns = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .ok()
            .and_then(|d| i64::try_from(d.as_nanos()).ok())
            .unwrap_or(0);
        let attachment = attachment(publisher.sequence, now_ns, &publisher.gid);
        let zerr = |e: zenoh::Error| TransportError::Zenoh(format!("{topic}: {e}"));
        match &publisher.outlet {
            Outlet::Plain(p) => p.put(bytes).attachment(attachment).wait().map_err(zerr),
            Outlet::Advanced(p) => p.put(bytes).attachment(attachment).wait().map_err(zerr),
        }
    }

    /// Marks the end of graph topic `topic`'s stream for nrslam subscribers: an empty payload on
    /// its key with [`super::END_OF_STREAM_CHUNK`] in place of the type hash, which rmw_zenoh
    /// subscribers (exact hash) do not match. Nothing if the topic has no publisher here.
    pub fn end(&self, topic: &str) -> Result<(), TransportError> {
        let Some(publisher) = self.publishers.get(topic) else {
            return Ok(());
        };
        let prefix = publisher
            .key_expr
            .rsplit_once('/')
            .map_or(publisher.key_expr.as_str(), |(prefix, _)| prefix);
        let key = format!("{prefix}/{}", super::END_OF_STREAM_CHUNK);
        self.session
            .put(key, Vec::<u8>::new())
            .congestion_control(CongestionControl::Block)
            .wait()
            .map_err(|e| TransportError::Zenoh(format!("{topic}: end of stream: {e}")))
    }

    /// Whether every data publisher has at least one matching subscriber.
    pub fn all_matched(&self) -> bool {
        self.publishers.values().all(|p| {
            let status = match &p.outlet {
                Outlet::Plain(p) => p.matching_status().wait(),
                Outlet::Advanced(p) => p.matching_status().wait(),
            };
            status.map(|s| s.matching()).unwrap_or(false)
        })
    }
}
