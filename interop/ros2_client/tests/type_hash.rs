//! Why nrslam accepts the all-zero type hash: ros2-client 0.12.1 computes RIHS01 hashes only for a
//! fixed table of types (std_msgs scalars and String, rcl_interfaces, action types; its
//! `zenoh_backend/type_hash.rs`) and publishes every other type, PointCloud2, Odometry,
//! PoseStamped and nrslam_msgs included, under `RIHS01_000…0`. An rmw_zenoh subscriber that
//! matches the exact hash (rmw_zenoh_cpp does) never receives those. This pins that behaviour of
//! the version this crate locks, with no nrslam involved: if a later ros2-client sends real
//! hashes, this fails and the inbound test then exercises the exact-hash path.

mod common;

use std::time::Duration;

use ros2_client::zenoh::{Context, ContextOptions, Publisher};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
use zenoh::Wait;

use common::msgs::{Odometry, PointCloud2, PoseStamped, TargetSet};

const PLACEHOLDER: &str = "RIHS01_0000000000000000000000000000000000000000000000000000000000000000";

#[test]
fn ros2_client_publishes_types_outside_its_table_under_the_zero_hash() {
    let mut config = zenoh::Config::default();
    for (key, value) in [
        ("mode", "\"peer\""),
        ("scouting/multicast/enabled", "false"),
        ("listen/endpoints", "[]"),
    ] {
        config.insert_json5(key, value).expect("zenoh config");
    }
    let ctx = Context::with_options(ContextOptions::new().domain_id(0).zenoh_config(config))
        .expect("a ros2-client context");
    let node = ctx
        .new_node(
            NodeName::new("/", "hash_probe").unwrap(),
            NodeOptions::new()
                .enable_rosout(false)
                .start_parameter_services(false),
        )
        .unwrap();
    let topic = |name: &str, pkg: &str, ty: &str| {
        node.create_topic(
            &Name::parse(name).unwrap(),
            MessageTypeName::new(pkg, ty),
            &QosProfile::publisher_default(),
        )
    };
    let _points: Publisher<PointCloud2> = node
        .create_publisher(&topic("/radar/points", "sensor_msgs", "PointCloud2"), None)
        .unwrap();
    let _odom: Publisher<Odometry> = node
        .create_publisher(&topic("/odom", "nav_msgs", "Odometry"), None)
        .unwrap();
    let _pose: Publisher<PoseStamped> = node
        .create_publisher(
            &topic("/ground_truth/pose", "geometry_msgs", "PoseStamped"),
            None,
        )
        .unwrap();
    let _targets: Publisher<TargetSet> = node
        .create_publisher(
            &topic("/ground_truth/targets", "nrslam_msgs", "TargetSet"),
            None,
        )
        .unwrap();
    // And a type in its table, for contrast: std_msgs/String's published Jazzy hash.
    let _string: Publisher<String> = node
        .create_publisher(&topic("/chatter", "std_msgs", "String"), None)
        .unwrap();

    // The publisher (MP) tokens, as any rmw_zenoh graph cache reads them.
    let replies = ctx
        .session()
        .liveliness()
        .get("@ros2_lv/0/**")
        .timeout(Duration::from_secs(5))
        .wait()
        .expect("liveliness query");
    let mut hashes = std::collections::BTreeMap::new();
    // The query ends (channel closed) when every reply is in; the timeout only bounds it.
    while let Ok(Some(reply)) = replies.recv_timeout(Duration::from_secs(5)) {
        let Ok(sample) = reply.result() else { continue };
        let chunks: Vec<&str> = sample.key_expr().as_str().split('/').collect();
        // @ros2_lv/<domain>/<zid>/<node id>/<entity id>/MP/<enclave>/<ns>/<node>/<topic>/<type>/<hash>/<qos>
        if chunks.get(5) == Some(&"MP") && chunks.len() >= 13 {
            hashes.insert(chunks[10].to_owned(), chunks[11].to_owned());
        }
    }
    for ty in [
        "sensor_msgs::msg::dds_::PointCloud2_",
        "nav_msgs::msg::dds_::Odometry_",
        "geometry_msgs::msg::dds_::PoseStamped_",
        "nrslam_msgs::msg::dds_::TargetSet_",
    ] {
        assert_eq!(
            hashes.get(ty).map(String::as_str),
            Some(PLACEHOLDER),
            "{ty}: ros2-client's MP token hash (all tokens: {hashes:#?})"
        );
    }
    assert_eq!(
        hashes
            .get("std_msgs::msg::dds_::String_")
            .map(String::as_str),
        Some("RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"),
        "std_msgs/String's MP token hash"
    );
}
