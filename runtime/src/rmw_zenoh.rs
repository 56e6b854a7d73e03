//! What a ROS 2 node on `rmw_zenoh_cpp` (Jazzy and later) expects on the wire and in its graph
//! cache, so the graph is seen and heard by ROS 2 without a bridge: `ros2 node list`,
//! `ros2 topic list`, `ros2 topic echo`, `ros2 bag record` (docs/ros2.md).
//!
//! Followed: rmw_zenoh's `docs/design.md` (commit `99a6a2bd10b949052f4f12c5854825dc005e95a5`) and,
//! where it is silent, its source at `rmw_zenoh_cpp/src/detail/`: `liveliness_utils.cpp`
//! (commit `3411fdec149fe0c932f24d4d79ef908eb81d7482`: token layout, mangling, `qos_to_keyexpr`,
//! GIDs), `qos.cpp` (`7efeee2b9009b816a4bd4a3148af3cca40f753d5`: the defaults `qos_to_keyexpr`
//! leaves out), `rmw_publisher_data.cpp` (`3e19ec730c529035a648aec80c0ae0a056943b8c`: advanced
//! publisher options, attachment), `rmw_node_data.cpp` (node tokens).
//!
//! - Data key expression: `<domain id>/<topic without leading and trailing '/'>/<DDS type
//!   name>/<RIHS01 hash>`, e.g. `0/map/nav_msgs::msg::dds_::OccupancyGrid_/RIHS01_8d34...`
//!   (`TopicInfo`); a subscriber matches only the exact type hash.
//! - Payload: the message in CDR with its 4-byte encapsulation header (what the graph sends anyway).
//! - Attachment (33 bytes, zenoh-ext serialisation of `AttachmentData`): sequence number (i64 LE,
//!   from 1 per publisher), source timestamp (i64 LE, ns since the UNIX epoch), then the 16-byte
//!   publisher GID as a sequence (LEB128 length `0x10`, then the bytes). rmw_zenoh drops samples
//!   without it.
//! - Liveliness tokens (the graph cache; [`liveliness_token`]):
//!   `@ros2_lv/<domain>/<session zid>/<node id>/<entity id>/<NN|MP|MS|SS|SC>/<enclave>/<namespace>/<node name>`
//!   then, for all but nodes, `/<topic>/<DDS type>/<type hash>/<qos>`; enclave, namespace and topic
//!   with every `/` mangled to `%`; ids from one counter per session (a node's own id twice).
//! - GIDs ([`gid`]): XXH3-128 (seed 0) of the entity's token, low 64 bits then high 64 bits,
//!   each little-endian: what a subscriber reads in the attachment and `ros2 topic info -v` shows.
//! - Transient-local topics: zenoh-ext `AdvancedPublisher` with a cache of `depth` samples and
//!   publisher detection, plus sporadic heartbeats (500 ms) for sample-miss detection when
//!   reliable, so an rmw_zenoh subscriber's `AdvancedSubscriber` (history with late-publisher
//!   detection) gets the latched message however late it joins ([`advanced_publisher_options`]).

use crate::type_hash::{self, TypeHashError};

#[cfg(feature = "zenoh")]
pub mod graph;

/// Bytes of an rmw GID (`RMW_GID_STORAGE_SIZE`).
pub const GID_LEN: usize = 16;

/// The DDS-mangled type name rmw_zenoh uses: `nav_msgs/msg/OccupancyGrid` →
/// `nav_msgs::msg::dds_::OccupancyGrid_`.
pub fn dds_type_name(type_name: &str) -> String {
    let mut parts: Vec<&str> = type_name.split('/').collect();
    let name = parts.pop().unwrap_or_default();
    format!("{}::dds_::{name}_", parts.join("::"))
}

/// The key expression of `topic` (e.g. `/slam/pose`) carrying `type_name`, whose type hash is
/// `type_hash`, in ROS domain `domain_id`.
pub fn key_expr_with_hash(domain_id: u32, topic: &str, type_name: &str, type_hash: &str) -> String {
    format!(
        "{domain_id}/{}/{}/{type_hash}",
        topic.trim_matches('/'),
        dds_type_name(type_name)
    )
}

/// The type hash the `ros2-client` crate's zenoh backend (and other clients that cannot compute
/// one) puts in the key of a type it has no hash for: `RIHS01_` and 64 zeros.
pub const PLACEHOLDER_TYPE_HASH: &str =
    "RIHS01_0000000000000000000000000000000000000000000000000000000000000000";

/// The last chunk of nrslam's end-of-stream key in ROS mode, where the type hash would be: an
/// empty payload on `<domain>/<topic>/<DDS type>/@nrslam_end` ends the topic's stream for nrslam
/// subscribers. It is a zenoh *verbatim* chunk (it starts with `@`): only a key expression with
/// that very chunk matches it, never `*` or `**`. So neither rmw_zenoh_cpp's subscribers (exact
/// type hash) nor the `ros2-client` crate's (`*` in the hash chunk) ever receive it, while
/// nrslam's subscribers declare a second subscriber on exactly that key.
pub const END_OF_STREAM_CHUNK: &str = "@nrslam_end";

/// How a receiver judges the hash chunk of a sample's key against the type it expects.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HashVerdict {
    /// The expected RIHS01 hash, or the all-zero placeholder: the payload is the type's CDR (the
    /// receive path still decodes and checks it).
    Accept,
    /// nrslam's end-of-stream key ([`END_OF_STREAM_CHUNK`]).
    EndOfStream,
    /// Another type's hash (or no hash): not this type's data.
    Mismatch,
}

/// Judges `chunk`, the last chunk of a data key, for a subscriber of the type whose hash is
/// `expected`. The placeholder is accepted because publishers that lack the hash of a standard
/// type (Odometry, RadarScan, ...) send it with the right CDR; the decoder refuses the payload
/// if the type is not what the topic carries.
pub fn judge_hash(chunk: &str, expected: &str) -> HashVerdict {
    if chunk == expected || chunk == PLACEHOLDER_TYPE_HASH {
        HashVerdict::Accept
    } else if chunk == END_OF_STREAM_CHUNK {
        HashVerdict::EndOfStream
    } else {
        HashVerdict::Mismatch
    }
}

/// The fully qualified ROS name of graph topic `topic` in the ROS namespace of zenoh key prefix
/// `namespace` (`robot1`, `/map` → `/robot1/map`; no namespace: `/map`).
pub fn qualified_topic(namespace: &str, topic: &str) -> String {
    let topic = topic.trim_matches('/');
    match namespace.trim_matches('/') {
        "" => format!("/{topic}"),
        ns => format!("/{ns}/{topic}"),
    }
}

/// The data key expression of `topic` in ROS domain `domain_id` (`TopicInfo::topic_keyexpr_`).
pub fn data_key_expr(domain_id: u32, topic: &TopicInfo) -> String {
    format!(
        "{domain_id}/{}/{}/{}",
        topic.name.trim_matches('/'),
        topic.dds_type,
        topic.type_hash
    )
}

/// The key expression of `topic` of type `type_name`, hash computed from the definitions.
pub fn key_expr(domain_id: u32, topic: &str, type_name: &str) -> Result<String, TypeHashError> {
    Ok(key_expr_with_hash(
        domain_id,
        topic,
        type_name,
        &type_hash::rihs01(type_name)?,
    ))
}

/// The attachment rmw_zenoh reads from every sample.
pub fn attachment(sequence_number: i64, source_timestamp_ns: i64, gid: &[u8; GID_LEN]) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(8 + 8 + 1 + GID_LEN);
    bytes.extend_from_slice(&sequence_number.to_le_bytes());
    bytes.extend_from_slice(&source_timestamp_ns.to_le_bytes());
    bytes.push(GID_LEN as u8); // LEB128 of 16: one byte
    bytes.extend_from_slice(gid);
    bytes
}

/// The fields of an attachment, or `None` if `bytes` is not one.
pub fn parse_attachment(bytes: &[u8]) -> Option<(i64, i64, [u8; GID_LEN])> {
    if bytes.len() != 8 + 8 + 1 + GID_LEN || bytes[16] != GID_LEN as u8 {
        return None;
    }
    let sequence = i64::from_le_bytes(bytes[0..8].try_into().ok()?);
    let timestamp = i64::from_le_bytes(bytes[8..16].try_into().ok()?);
    let gid = bytes[17..].try_into().ok()?;
    Some((sequence, timestamp, gid))
}

/// rmw's QoS reliability policy (`rmw_qos_reliability_policy_e`, rmw/types.h).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReliabilityPolicy {
    /// `RMW_QOS_POLICY_RELIABILITY_RELIABLE` (1).
    Reliable = 1,
    /// `RMW_QOS_POLICY_RELIABILITY_BEST_EFFORT` (2).
    BestEffort = 2,
}

/// rmw's QoS durability policy (`rmw_qos_durability_policy_e`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DurabilityPolicy {
    /// `RMW_QOS_POLICY_DURABILITY_TRANSIENT_LOCAL` (1): late joiners get the last `depth` samples.
    TransientLocal = 1,
    /// `RMW_QOS_POLICY_DURABILITY_VOLATILE` (2).
    Volatile = 2,
}

/// rmw's QoS history policy (`rmw_qos_history_policy_e`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HistoryPolicy {
    /// `RMW_QOS_POLICY_HISTORY_KEEP_LAST` (1).
    KeepLast = 1,
    /// `RMW_QOS_POLICY_HISTORY_KEEP_ALL` (2).
    KeepAll = 2,
}

/// The QoS of an entity as its token carries it. Deadline, lifespan and liveliness are always
/// rmw_zenoh's defaults (infinite, automatic): rmw_zenoh implements no other.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EntityQos {
    /// Reliability.
    pub reliability: ReliabilityPolicy,
    /// Durability.
    pub durability: DurabilityPolicy,
    /// History.
    pub history: HistoryPolicy,
    /// History depth in messages (0 is rmw_zenoh's "choose": 42).
    pub depth: usize,
}

/// rmw_zenoh's default QoS (`qos.cpp`): what [`qos_to_keyexpr`] leaves out.
pub const DEFAULT_QOS: EntityQos = EntityQos {
    reliability: ReliabilityPolicy::Reliable,
    durability: DurabilityPolicy::Volatile,
    history: HistoryPolicy::KeepLast,
    depth: 42,
};

impl From<nrslam_msgs::topics::Qos> for EntityQos {
    /// A catalogue QoS: every topic is reliable and keep-last; latched ones transient local.
    fn from(qos: nrslam_msgs::topics::Qos) -> Self {
        use nrslam_msgs::topics::{Durability, Reliability};
        Self {
            reliability: match qos.reliability {
                Reliability::Reliable => ReliabilityPolicy::Reliable,
            },
            durability: match qos.durability {
                Durability::Volatile => DurabilityPolicy::Volatile,
                Durability::TransientLocal => DurabilityPolicy::TransientLocal,
            },
            history: HistoryPolicy::KeepLast,
            depth: qos.depth,
        }
    }
}

/// rmw_zenoh's compact QoS string (`qos_to_keyexpr`): `reliability:durability:history,depth:
/// deadline_s,deadline_ns:lifespan_s,lifespan_ns:liveliness,lease_s,lease_ns`, each value left
/// empty when it is the default, e.g. `::,10:,:,:,,` for reliable, volatile, keep last 10.
pub fn qos_to_keyexpr(qos: &EntityQos) -> String {
    let differs = |value: u64, default: u64| {
        if value == default {
            String::new()
        } else {
            value.to_string()
        }
    };
    let depth = if qos.depth == 0 {
        DEFAULT_QOS.depth
    } else {
        qos.depth
    };
    format!(
        "{}:{}:{},{}:,:,:,,",
        differs(qos.reliability as u64, DEFAULT_QOS.reliability as u64),
        differs(qos.durability as u64, DEFAULT_QOS.durability as u64),
        differs(qos.history as u64, DEFAULT_QOS.history as u64),
        differs(depth as u64, DEFAULT_QOS.depth as u64),
    )
}

/// rmw_zenoh's `mangle_name`: every `/` becomes `%` (so `/` alone, the empty namespace, is `%`).
pub fn mangle_name(name: &str) -> String {
    name.replace('/', "%")
}

/// The kind of a graph entity, as its token names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EntityKind {
    /// `NN`: a node.
    Node,
    /// `MP`: a message publisher.
    Publisher,
    /// `MS`: a message subscription.
    Subscription,
    /// `SS`: a service server.
    ServiceServer,
    /// `SC`: a service client.
    ServiceClient,
}

impl EntityKind {
    /// The two letters in the token.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Node => "NN",
            Self::Publisher => "MP",
            Self::Subscription => "MS",
            Self::ServiceServer => "SS",
            Self::ServiceClient => "SC",
        }
    }
}

/// The node an entity belongs to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct NodeInfo {
    /// ROS domain id.
    pub domain_id: u32,
    /// The zenoh session's id as zenoh prints it (`ZenohId`'s `Display`: lower-case hex).
    pub zid: String,
    /// The node's id within the session.
    pub node_id: usize,
    /// SROS enclave, `/` when none.
    pub enclave: String,
    /// Namespace, `/` when none (e.g. `/robot1`).
    pub namespace: String,
    /// Node name (e.g. `talker`).
    pub name: String,
}

/// The topic of a publisher or subscription.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicInfo {
    /// Fully qualified topic name, e.g. `/chatter`.
    pub name: String,
    /// DDS type name, e.g. `std_msgs::msg::dds_::String_` ([`dds_type_name`]).
    pub dds_type: String,
    /// `RIHS01_<hex>`.
    pub type_hash: String,
    /// QoS.
    pub qos: EntityQos,
}

/// The liveliness token key expression of entity `entity_id` of kind `kind` on `node`
/// (`Entity::Entity` in liveliness_utils.cpp). A node's token is `NodeInfo::node_id` twice and has
/// no topic; every other kind needs its `topic`.
pub fn liveliness_token(
    node: &NodeInfo,
    entity_id: usize,
    kind: EntityKind,
    topic: Option<&TopicInfo>,
) -> String {
    let mut token = format!(
        "@ros2_lv/{}/{}/{}/{entity_id}/{}/{}/{}/{}",
        node.domain_id,
        node.zid,
        node.node_id,
        kind.as_str(),
        mangle_name(&node.enclave),
        mangle_name(&node.namespace),
        mangle_name(&node.name),
    );
    if let Some(topic) = topic {
        token.push_str(&format!(
            "/{}/{}/{}/{}",
            mangle_name(&topic.name),
            mangle_name(&topic.dds_type),
            mangle_name(&topic.type_hash),
            qos_to_keyexpr(&topic.qos)
        ));
    }
    token
}

/// The GID rmw_zenoh gives the entity whose token is `token`: `simplified_XXH3_128bits` of the
/// token's bytes, low 64 bits then high 64 bits, each little-endian (= the u128, little-endian).
pub fn gid(token: &str) -> [u8; GID_LEN] {
    xxhash_rust::xxh3::xxh3_128(token.as_bytes()).to_le_bytes()
}

/// Whether `name` is a valid ROS 2 node name (`[A-Za-z_][A-Za-z0-9_]*`, rcl's rule).
pub fn is_valid_node_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars
        .next()
        .is_some_and(|c| c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// How rmw_zenoh declares the zenoh-ext `AdvancedPublisher` of a publisher with `qos`
/// (`PublisherData::make`): `None` for a plain publisher (volatile), else the cache size in
/// samples and whether sample-miss heartbeats are on (reliable and transient local).
pub fn advanced_publisher_options(qos: &EntityQos) -> Option<(usize, bool)> {
    (qos.durability == DurabilityPolicy::TransientLocal).then(|| {
        let depth = if qos.depth == 0 {
            DEFAULT_QOS.depth
        } else {
            qos.depth
        };
        (depth, qos.reliability == ReliabilityPolicy::Reliable)
    })
}

/// Period of the sporadic heartbeat of a reliable transient-local publisher
/// (`SAMPLE_MISS_DETECTION_HEARTBEAT_PERIOD`, rmw_publisher_data.cpp).
pub const SAMPLE_MISS_HEARTBEAT_PERIOD: std::time::Duration = std::time::Duration::from_millis(500);
#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn occupancy_grid_key_expression_is_byte_exact() {
        assert_eq!(
            key_expr(0, "/map", "nav_msgs/msg/OccupancyGrid").unwrap(),
            "0/map/nav_msgs::msg::dds_::OccupancyGrid_/RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7"
        );
    }

    #[test]
    fn hashes_are_judged_real_placeholder_end_or_mismatch() {
        let real = type_hash::rihs01("nav_msgs/msg/Odometry").unwrap();
        assert_eq!(PLACEHOLDER_TYPE_HASH.len(), "RIHS01_".len() + 64);
        assert_eq!(judge_hash(&real, &real), HashVerdict::Accept);
        assert_eq!(
            judge_hash(PLACEHOLDER_TYPE_HASH, &real),
            HashVerdict::Accept
        );
        assert_eq!(
            judge_hash(END_OF_STREAM_CHUNK, &real),
            HashVerdict::EndOfStream
        );
        let other = type_hash::rihs01("nav_msgs/msg/OccupancyGrid").unwrap();
        assert_eq!(judge_hash(&other, &real), HashVerdict::Mismatch);
        assert_eq!(judge_hash("RIHS01_00", &real), HashVerdict::Mismatch);
        assert_eq!(qualified_topic("", "/odom"), "/odom");
        assert_eq!(
            qualified_topic("/robot1/", "/radar/points"),
            "/robot1/radar/points"
        );
    }

    #[test]
    fn nested_topics_and_domains_keep_their_slashes() {
        let key = key_expr_with_hash(42, "/slam/pose/", "geometry_msgs/msg/PoseStamped", "H");
        assert_eq!(key, "42/slam/pose/geometry_msgs::msg::dds_::PoseStamped_/H");
    }

    #[test]
    fn attachment_is_the_33_bytes_rmw_zenoh_serialises() {
        let gid: [u8; 16] = std::array::from_fn(|i| i as u8 + 0xa0);
        let bytes = attachment(1, 1_700_000_000_123_456_789, &gid);
        let mut golden = vec![1, 0, 0, 0, 0, 0, 0, 0];
        golden.extend_from_slice(&1_700_000_000_123_456_789i64.to_le_bytes());
        golden.extend_from_slice(&[
            0x10, 0xa0, 0xa1, 0xa2, 0xa3, 0xa4, 0xa5, 0xa6, 0xa7, 0xa8, 0xa9, 0xaa, 0xab, 0xac,
            0xad, 0xae, 0xaf,
        ]);
        assert_eq!(bytes, golden);
        assert_eq!(bytes.len(), 33);
        assert_eq!(
            parse_attachment(&bytes),
            Some((1, 1_700_000_000_123_456_789, gid))
        );
        assert_eq!(parse_attachment(&bytes[..32]), None);
    }
}
