//! A graph published as rmw_zenoh does, seen by another zenoh session the way an rmw_zenoh
//! context sees it (design.md, "Graph Cache"): a liveliness get on `@ros2_lv/<domain>/**`, a
//! subscriber on the data key expression, and, for a transient-local topic, a zenoh-ext
//! `AdvancedSubscriber` with history and late-publisher detection as `SubscriptionData::init`
//! declares it. Loopback only.

use nrslam_msgs::topics;
use nrslam_runtime::rmw_zenoh::{self, parse_attachment};
use nrslam_runtime::transport::{
    self, RosNode, Session, SessionMode, TopicPublisher, TransportConfig,
};
use std::collections::BTreeSet;
use std::sync::mpsc;
use std::time::{Duration, Instant};
use zenoh::Wait;
use zenoh_ext::{AdvancedSubscriberBuilderExt, HistoryConfig};

/// nav_msgs/msg/OccupancyGrid's hash as a Jazzy installation prints it (`ros2 topic info -v`).
const OCCUPANCY_GRID_HASH: &str =
    "RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7";
const MAP_KEY: &str = "0/map/nav_msgs::msg::dds_::OccupancyGrid_/RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7";

fn free_endpoint() -> String {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    format!("tcp/127.0.0.1:{port}")
}

fn open(mode: SessionMode, listen: &[&str], connect: &[&str]) -> Session {
    transport::open(&TransportConfig {
        mode,
        listen: listen.iter().map(|s| s.to_string()).collect(),
        connect: connect.iter().map(|s| s.to_string()).collect(),
        ..TransportConfig::default()
    })
    .unwrap()
}

/// The paper graph's shape: a source of ground truth (latched targets), a mapper, an evaluator.
fn nodes() -> Vec<RosNode> {
    vec![
        RosNode::from_catalogue(
            "world",
            &[topics::GROUND_TRUTH_TARGETS, topics::GROUND_TRUTH_POSE],
            &[],
        )
        .unwrap(),
        RosNode::from_catalogue("mapper", &[topics::MAP], &[topics::KEYFRAME_POSES]).unwrap(),
        RosNode::from_catalogue(
            "evaluator",
            &[topics::METRICS],
            &[topics::GROUND_TRUTH_TARGETS, topics::MAP],
        )
        .unwrap(),
    ]
}

/// The key expressions of every liveliness token matching `selector`, as rmw_zenoh's context
/// reads them at start-up, retried until `expected` are there (or 10 s).
fn tokens(session: &Session, selector: &str, expected: usize) -> Vec<String> {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let replies = session.liveliness().get(selector).wait().unwrap();
        let mut found = Vec::new();
        while let Ok(reply) = replies.recv() {
            if let Ok(sample) = reply.result() {
                found.push(sample.key_expr().as_str().to_owned());
            }
        }
        if found.len() >= expected || Instant::now() > deadline {
            found.sort();
            return found;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// (key expression, attachment) of each sample, through a channel.
type Received = mpsc::Receiver<(String, Option<Vec<u8>>)>;

fn subscribe(session: &Session, key: &str) -> (zenoh::pubsub::Subscriber<()>, Received) {
    let (sender, receiver) = mpsc::channel();
    let subscriber = session
        .declare_subscriber(key)
        .callback(move |sample| {
            let _ = sender.send((
                sample.key_expr().as_str().to_owned(),
                sample.attachment().map(|a| a.to_bytes().into_owned()),
            ));
        })
        .wait()
        .unwrap();
    (subscriber, receiver)
}

/// Checks the discovered tokens of `nodes()` published by session `zid` in domain 0, and returns
/// the `/map` publisher's token.
fn check_tokens(found: &[String], zid: &str) -> String {
    let parts: Vec<Vec<&str>> = found.iter().map(|t| t.split('/').collect()).collect();
    for p in &parts {
        assert_eq!(&p[..3], ["@ros2_lv", "0", zid], "{p:?}");
        assert_eq!(&p[6..8], ["%", "%"], "enclave and namespace: {p:?}");
    }
    let of_kind = |kind: &str| -> BTreeSet<String> {
        parts
            .iter()
            .filter(|p| p[5] == kind)
            .map(|p| match p.len() {
                9 => p[8].to_owned(),
                _ => format!("{} {} {} {}", p[8], p[9], p[10], p[12]),
            })
            .collect()
    };
    assert_eq!(
        of_kind("NN"),
        BTreeSet::from(["world", "mapper", "evaluator"].map(String::from))
    );
    let publishers = of_kind("MP");
    assert!(
        publishers.contains("mapper %map nav_msgs::msg::dds_::OccupancyGrid_ ::,8:,:,:,,"),
        "{publishers:?}"
    );
    assert!(
        publishers.contains(
            "world %ground_truth%targets nrslam_msgs::msg::dds_::TargetSet_ :1:,1:,:,:,,"
        ),
        "{publishers:?}"
    );
    assert_eq!(publishers.len(), 4, "{publishers:?}");
    let subscriptions = of_kind("MS");
    assert!(
        subscriptions.contains(
            "evaluator %ground_truth%targets nrslam_msgs::msg::dds_::TargetSet_ :1:,1:,:,:,,"
        ),
        "{subscriptions:?}"
    );
    assert_eq!(subscriptions.len(), 3, "{subscriptions:?}");
    // A node's token repeats its id; entity ids are unique in the session.
    let ids: BTreeSet<&str> = parts.iter().map(|p| p[4]).collect();
    assert_eq!(ids.len(), found.len());
    for p in parts.iter().filter(|p| p[5] == "NN") {
        assert_eq!(p[3], p[4]);
    }
    let map = found
        .iter()
        .find(|t| t.contains("/MP/") && t.contains("/%map/"))
        .unwrap();
    assert!(map.contains(&format!("/{OCCUPANCY_GRID_HASH}/")));
    map.clone()
}

#[test]
fn tokens_data_and_attachment_are_rmw_zenohs() {
    let endpoint = free_endpoint();
    let graph_session = open(SessionMode::Peer, &[&endpoint], &[]);
    let mut publisher = TopicPublisher::with_ros_nodes(&graph_session, "", 0, &nodes()).unwrap();
    let observer = open(SessionMode::Client, &[], &[&endpoint]);
    let found = tokens(&observer, "@ros2_lv/0/**", 10);
    assert_eq!(found.len(), 10, "{found:#?}");
    let map_token = check_tokens(&found, &graph_session.zid().to_string());
    // Another domain sees nothing.
    assert!(tokens(&observer, "@ros2_lv/1/**", 0).is_empty());

    let (_subscriber, received) = subscribe(&observer, MAP_KEY);
    let deadline = Instant::now() + Duration::from_secs(10);
    while !publisher.all_matched() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    for _ in 0..2 {
        publisher
            .publish_raw(topics::MAP, vec![0, 1, 0, 0, 7])
            .unwrap();
    }
    for sequence in 1..=2 {
        let (key, attachment) = received.recv_timeout(Duration::from_secs(10)).unwrap();
        assert_eq!(key, MAP_KEY);
        let attachment = attachment.expect("rmw_zenoh drops samples without an attachment");
        assert_eq!(attachment.len(), 33);
        let (seq, stamp_ns, gid) = parse_attachment(&attachment).unwrap();
        assert_eq!(seq, sequence);
        assert!(stamp_ns > 1_600_000_000_000_000_000);
        assert_eq!(gid, rmw_zenoh::gid(&map_token), "the GID of the MP token");
    }
}

#[test]
fn a_late_advanced_subscriber_gets_the_latched_message() {
    let endpoint = free_endpoint();
    let graph_session = open(SessionMode::Peer, &[&endpoint], &[]);
    let mut publisher = TopicPublisher::with_ros_nodes(&graph_session, "", 0, &nodes()).unwrap();
    publisher
        .publish_raw(topics::GROUND_TRUTH_TARGETS, vec![0, 1, 0, 0, 42])
        .unwrap();
    let (key, gid) = publisher
        .ros_graph()
        .unwrap()
        .publisher_of(topics::GROUND_TRUTH_TARGETS)
        .unwrap();
    let key = key.to_owned();
    assert!(key.starts_with("0/ground_truth/targets/nrslam_msgs::msg::dds_::TargetSet_/RIHS01_"));

    // Joins after the publication, as rmw_zenoh's transient-local subscription does.
    let late = open(SessionMode::Client, &[], &[&endpoint]);
    let (sender, received) = mpsc::channel();
    let _subscriber = late
        .declare_subscriber(key.clone())
        .history(
            HistoryConfig::default()
                .detect_late_publishers()
                .max_samples(1),
        )
        .subscriber_detection()
        .query_timeout(Duration::from_secs(10))
        .callback(move |sample| {
            let _ = sender.send((
                sample.payload().to_bytes().into_owned(),
                sample.attachment().map(|a| a.to_bytes().into_owned()),
            ));
        })
        .wait()
        .unwrap();
    let (payload, attachment) = received.recv_timeout(Duration::from_secs(10)).unwrap();
    assert_eq!(payload, [0, 1, 0, 0, 42]);
    let (seq, _, their_gid) = parse_attachment(&attachment.unwrap()).unwrap();
    assert_eq!((seq, their_gid), (1, gid));
    // A plain subscriber joining late gets nothing: the cache is what serves late joiners.
    let (_plain, plain) = subscribe(&late, &key);
    assert!(plain.recv_timeout(Duration::from_millis(500)).is_err());
}

#[test]
fn through_a_router_as_its_client() {
    // Stands in for rmw_zenohd: a zenoh router, with a ROS-side session as its peer.
    let router_endpoint = free_endpoint();
    let _router = open(SessionMode::Router, &[&router_endpoint], &[]);
    let ros_side = open(SessionMode::Peer, &[], &[&router_endpoint]);
    let config = TransportConfig::default().via_ros_router(&router_endpoint);
    assert_eq!(config.mode, SessionMode::Client);
    assert_eq!(config.connect, std::slice::from_ref(&router_endpoint));
    let graph_session = transport::open(&config).unwrap();
    let mut publisher = TopicPublisher::with_ros_nodes(&graph_session, "", 0, &nodes()).unwrap();
    let found = tokens(&ros_side, "@ros2_lv/0/**", 10);
    let map_token = check_tokens(&found, &graph_session.zid().to_string());
    let (_subscriber, received) = subscribe(&ros_side, MAP_KEY);
    let deadline = Instant::now() + Duration::from_secs(10);
    while !publisher.all_matched() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    publisher
        .publish_raw(topics::MAP, vec![0, 1, 0, 0])
        .unwrap();
    let (_, attachment) = received.recv_timeout(Duration::from_secs(10)).unwrap();
    let (_, _, gid) = parse_attachment(&attachment.unwrap()).unwrap();
    assert_eq!(gid, rmw_zenoh::gid(&map_token));
}

#[test]
fn namespaces_prefix_topics_and_node_tokens() {
    let endpoint = free_endpoint();
    let graph_session = open(SessionMode::Peer, &[&endpoint], &[]);
    let node = RosNode::from_catalogue("bad-name", &[topics::MAP], &[]).unwrap();
    let publisher = TopicPublisher::with_ros_nodes(&graph_session, "robot1", 3, &[node]).unwrap();
    let graph = publisher.ros_graph().unwrap();
    let tokens: Vec<&str> = graph.tokens().collect();
    let zid = graph_session.zid().to_string();
    assert_eq!(
        tokens[0],
        format!("@ros2_lv/3/{zid}/0/0/NN/%/%robot1/bad_name")
    );
    assert_eq!(
        tokens[1],
        format!("@ros2_lv/3/{zid}/0/1/MP/%/%robot1/bad_name/%robot1%map/nav_msgs::msg::dds_::OccupancyGrid_/{OCCUPANCY_GRID_HASH}/::,8:,:,:,,")
    );
    let (key, _) = graph.publisher_of(topics::MAP).unwrap();
    assert_eq!(
        key,
        format!("3/robot1/map/nav_msgs::msg::dds_::OccupancyGrid_/{OCCUPANCY_GRID_HASH}")
    );
}
