//! nrslam → ROS 2: a launch with `--ros-domain-id` seen by ros2-client's zenoh backend, an
//! rmw_zenoh implementation nrslam did not write (graph discovery from liveliness tokens, typed
//! subscriptions, rmw_zenoh attachments), and the same launch invisible from another domain.

mod common;

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use common::msgs::{self, OccupancyGrid, PoseStamped, TFMessage, TargetSet};
use common::{context, free_port, Nrslam};
use ros2_client::zenoh::{Context, Node, Subscription};
use ros2_client::{
    EntityKind, GraphEvent, MessageInfo, MessageTypeName, Name, NodeName, NodeOptions, QosProfile,
};
use serde::de::DeserializeOwned;

/// Radar frames of each run (0.5 s apart in the hall: 12 s simulated, about 12 keyframes).
const FRAMES: u32 = 24;
/// Real-time factor: the run lasts about 4 s of wall time, long enough to watch.
const RATE: &str = "3";
/// Longest a run may take (a debug build under load included).
const RUN_LIMIT: Duration = Duration::from_secs(180);

/// The nodes `launch/paper-ideal.toml` declares with its defaults (`shapes` and `viz` are on
/// unless `shapes:=false` / `viz:=false`), as ROS node names.
const PAPER_IDEAL_NODES: [&str; 7] = [
    "/association",
    "/evaluator",
    "/mapper",
    "/radar",
    "/segmenter",
    "/shapes",
    "/viz",
];

/// (topic, ROS type, the node that publishes it) that a ROS 2 user of the paper graph relies on
/// (docs/ros2.md, "What a ROS 2 user sees").
const PUBLISHED: [(&str, &str, &str); 8] = [
    ("/map", "nav_msgs/msg/OccupancyGrid", "/mapper"),
    (
        "/slam/pose",
        "geometry_msgs/msg/PoseStamped",
        "/association",
    ),
    ("/tf", "tf2_msgs/msg/TFMessage", "/viz"),
    ("/odom", "nav_msgs/msg/Odometry", "/radar"),
    ("/radar/detections", "nrslam_msgs/msg/Detections", "/radar"),
    (
        "/ground_truth/pose",
        "geometry_msgs/msg/PoseStamped",
        "/radar",
    ),
    (
        "/ground_truth/targets",
        "nrslam_msgs/msg/TargetSet",
        "/radar",
    ),
    ("/map/segments", "nrslam_msgs/msg/Segments", "/segmenter"),
];

fn probe_node(ctx: &Context) -> Node {
    ctx.new_node(
        NodeName::new("/", "interop_probe").expect("node name"),
        NodeOptions::new()
            .enable_rosout(false)
            .start_parameter_services(false),
    )
    .expect("a ros2-client node")
}

fn subscribe<M: DeserializeOwned>(node: &Node, topic: &str, ros_type: &str) -> Subscription<M> {
    let (package, name) = {
        let parts: Vec<&str> = ros_type.split('/').collect();
        (parts[0], parts[2])
    };
    let topic = node.create_topic(
        &Name::parse(topic).expect("topic name"),
        MessageTypeName::new(package, name),
        &QosProfile::default(),
    );
    node.create_subscription(&topic, None)
        .expect("a ros2-client subscription")
}

/// A sample ros2-client could not take: its topic, how many messages of that topic had been
/// taken before it, and the error.
#[derive(Debug)]
struct TakeError {
    topic: &'static str,
    after: usize,
    #[allow(dead_code)] // read by the failure messages, through Debug
    error: String,
}

/// Takes every message waiting on `sub` into `into`; a sample that does not decode is noted in
/// `errors` (ros2-client hands it out as an error and goes on with the next).
fn drain<M: DeserializeOwned>(
    topic: &'static str,
    sub: &Subscription<M>,
    into: &mut Vec<(M, MessageInfo)>,
    errors: &mut Vec<TakeError>,
) {
    loop {
        match sub.try_take() {
            Ok(Some(m)) => into.push(m),
            Ok(None) => return,
            Err(e) => errors.push(TakeError {
                topic,
                after: into.len(),
                error: format!("{e:?}"),
            }),
        }
    }
}

/// What ros2-client saw of one run.
#[derive(Default)]
struct Seen {
    declared: Vec<ros2_client::GraphEntity>,
    maps: Vec<(OccupancyGrid, MessageInfo)>,
    poses: Vec<(PoseStamped, MessageInfo)>,
    tfs: Vec<(TFMessage, MessageInfo)>,
    targets: Vec<(TargetSet, MessageInfo)>,
    errors: Vec<TakeError>,
    node_names: BTreeSet<String>,
    max_peers: usize,
}

/// Runs paper-ideal on ROS domain 0 with nrslam listening on a fresh loopback port, while a
/// ros2-client context of domain `domain`, made before nrslam starts (so no token or message is
/// missed for lack of a subscriber), watches the graph and takes /map, /slam/pose and /tf.
fn watch_paper_ideal(domain: u16, tmp: &std::path::Path, record: bool) -> Seen {
    let port = free_port();
    let ctx = context(domain, port);
    let events = ctx.graph_event_stream();
    let node = probe_node(&ctx);
    let map_sub = subscribe::<OccupancyGrid>(&node, "/map", "nav_msgs/msg/OccupancyGrid");
    let pose_sub = subscribe::<PoseStamped>(&node, "/slam/pose", "geometry_msgs/msg/PoseStamped");
    let tf_sub = subscribe::<TFMessage>(&node, "/tf", "tf2_msgs/msg/TFMessage");
    // Latched (transient local) on nrslam's side; ros2-client 0.12.1's subscriptions are plain
    // zenoh subscribers whatever their QoS, so this one, made before nrslam starts, takes it live.
    let targets_sub =
        subscribe::<TargetSet>(&node, "/ground_truth/targets", "nrslam_msgs/msg/TargetSet");

    let mut args: Vec<String> = [
        "launch",
        "launch/paper-ideal.toml",
        &format!("frames:={FRAMES}"),
        "--rate",
        RATE,
        "--ros-domain-id",
        "0",
        "--listen",
        &format!("tcp/127.0.0.1:{port}"),
        "--out",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    args.push(tmp.join("out").display().to_string());
    if record {
        args.push("--record".into());
        args.push(tmp.join("bag").display().to_string());
    }
    let mut nrslam = Nrslam::spawn(&args, tmp.join("nrslam.log"));

    let mut seen = Seen::default();
    let deadline = Instant::now() + RUN_LIMIT;
    let collect = |seen: &mut Seen| {
        while let Ok(event) = events.try_recv() {
            if let GraphEvent::EntityDeclared(entity) = event {
                seen.declared.push(entity);
            }
        }
        seen.node_names.extend(ctx.node_names());
        seen.max_peers = seen.max_peers.max(common::connected_peers(&ctx));
        drain("/map", &map_sub, &mut seen.maps, &mut seen.errors);
        drain("/slam/pose", &pose_sub, &mut seen.poses, &mut seen.errors);
        drain("/tf", &tf_sub, &mut seen.tfs, &mut seen.errors);
        drain(
            "/ground_truth/targets",
            &targets_sub,
            &mut seen.targets,
            &mut seen.errors,
        );
    };
    while nrslam.is_running() {
        assert!(
            Instant::now() < deadline,
            "nrslam still running after {RUN_LIMIT:?}; its log ends:\n{}",
            nrslam.log_tail()
        );
        collect(&mut seen);
        std::thread::sleep(Duration::from_millis(20));
    }
    nrslam.wait_success(Duration::from_secs(1));
    // Samples already on their way when nrslam exited.
    let settle = Instant::now() + Duration::from_millis(500);
    while Instant::now() < settle {
        collect(&mut seen);
        std::thread::sleep(Duration::from_millis(20));
    }
    seen
}

/// Checks sequence numbers (from 1, increasing) and the publisher GID (one, not zero) of the
/// rmw_zenoh attachments ros2-client parsed on `topic`.
fn check_attachments<M>(topic: &str, received: &[(M, MessageInfo)]) {
    let gids: BTreeSet<_> = received
        .iter()
        .map(|(_, info)| info.publisher_gid())
        .collect();
    assert_eq!(
        gids.len(),
        1,
        "{topic}: one publisher GID expected, got {gids:?}"
    );
    assert_ne!(
        *gids.iter().next().unwrap(),
        ros2_client::Gid::default(),
        "{topic}: the attachment's GID is zero"
    );
    let seqs: Vec<i64> = received.iter().map(|(_, i)| i.sequence_number()).collect();
    assert!(
        seqs.windows(2).all(|w| w[0] < w[1]) && seqs[0] >= 1,
        "{topic}: sequence numbers not increasing from ≥ 1: {seqs:?}"
    );
    for (_, info) in received {
        let ts = info
            .source_timestamp()
            .expect("source timestamp in the attachment");
        // The attachment's source timestamp is wall-clock ns since the UNIX epoch: after
        // 2020-01-01 (1.577e18 ns) and before 2100.
        let ns = ts.to_nanos();
        assert!(
            (1_577_836_800_000_000_000..4_102_444_800_000_000_000).contains(&ns),
            "{topic}: source timestamp {ns} ns is not a wall-clock time"
        );
    }
}

#[test]
fn ros2_client_discovers_the_graph_and_decodes_map_pose_and_tf() {
    let _serial = common::serial();
    let tmp = tempfile::tempdir().expect("temporary folder");
    let seen = watch_paper_ideal(0, tmp.path(), true);
    assert!(seen.max_peers > 0, "ros2-client never connected to nrslam");

    // Nodes: exactly the launch's (and ros2-client's own), as ros2-client's graph cache names
    // them.
    let nodes: BTreeSet<&str> = seen.node_names.iter().map(String::as_str).collect();
    let expected: BTreeSet<&str> = PAPER_IDEAL_NODES
        .into_iter()
        .chain(["/interop_probe"])
        .collect();
    assert_eq!(
        nodes, expected,
        "ros2-client's node list differs from launch/paper-ideal.toml's nodes"
    );

    // Topics with types and publishing nodes, from the graph events (MP tokens).
    let mut publishers: BTreeMap<&str, BTreeSet<(&str, &str)>> = BTreeMap::new();
    let mut subscribers: BTreeMap<&str, BTreeSet<&str>> = BTreeMap::new();
    for entity in &seen.declared {
        let (Some(topic), Some(ty)) = (entity.name.as_deref(), entity.type_name.as_deref()) else {
            continue;
        };
        match entity.kind {
            EntityKind::Publisher => {
                publishers
                    .entry(topic)
                    .or_default()
                    .insert((ty, entity.node_name.as_str()));
            }
            EntityKind::Subscription => {
                subscribers
                    .entry(topic)
                    .or_default()
                    .insert(entity.node_name.as_str());
            }
            _ => {}
        }
    }
    for (topic, ros_type, node) in PUBLISHED {
        let dds = common::dds_type(ros_type);
        let found = publishers.get(topic).cloned().unwrap_or_default();
        assert!(
            found.contains(&(dds.as_str(), node)),
            "{topic}: expected a publisher of {dds} on node {node}; ros2-client saw {found:?} \
             (all publishers: {publishers:#?})"
        );
    }
    for (topic, node) in [
        ("/radar/detections", "/association"),
        ("/map", "/segmenter"),
        ("/ground_truth/targets", "/evaluator"),
    ] {
        let found = subscribers.get(topic).cloned().unwrap_or_default();
        assert!(
            found.contains(node),
            "{topic}: expected {node} among its subscriptions; ros2-client saw {found:?}"
        );
    }
    // ros2-client's own node shows up too, with its three subscriptions.
    assert!(
        seen.declared
            .iter()
            .any(|e| e.kind == EntityKind::Subscription && e.node_name == "/interop_probe"),
        "ros2-client's graph cache does not show its own subscriptions"
    );

    // Every sample in the middle of a stream decodes. (What comes after a topic's last message
    // is the subject of `no_sample_ros2_client_cannot_decode`.)
    let counts = BTreeMap::from([
        ("/map", seen.maps.len()),
        ("/slam/pose", seen.poses.len()),
        ("/tf", seen.tfs.len()),
        ("/ground_truth/targets", seen.targets.len()),
    ]);
    let mid_stream: Vec<&TakeError> = seen
        .errors
        .iter()
        .filter(|e| e.after < counts[e.topic])
        .collect();
    assert!(
        mid_stream.is_empty(),
        "ros2-client could not decode samples in the middle of a stream: {mid_stream:#?}"
    );

    // The run's own record of what it published: the bag.
    let (bag, types) = common::read_bag(&tmp.path().join("bag"));
    assert_eq!(
        types.get("/slam/pose").map(String::as_str),
        Some("geometry_msgs/msg/PoseStamped")
    );
    let bag_of = |topic: &str| -> Vec<&[u8]> {
        bag.iter()
            .filter(|m| m.topic == topic)
            .map(|m| m.data.as_slice())
            .collect()
    };

    // /map: nav_msgs/OccupancyGrid.
    assert!(!seen.maps.is_empty(), "no /map received by ros2-client");
    for (grid, _) in &seen.maps {
        let info = &grid.info;
        assert_eq!(grid.header.frame_id, "map", "/map frame");
        assert!(info.width > 0 && info.height > 0, "/map is empty: {info:?}");
        assert_eq!(
            info.width as usize * info.height as usize,
            grid.data.len(),
            "/map: width × height ≠ data length"
        );
        // launch/paper-ideal.toml: mapper resolution_m = 0.1.
        assert!(
            (info.resolution - 0.1).abs() < 1e-6,
            "/map resolution {}",
            info.resolution
        );
        assert!(info.origin.is_finite(), "/map origin {:?}", info.origin);
        assert!(
            grid.data.iter().all(|&c| c == -1 || (0..=100).contains(&c)),
            "/map cells outside {{-1}} ∪ [0, 100]"
        );
    }
    let last = &seen.maps.last().unwrap().0;
    let occupied = last.data.iter().filter(|&&c| c > 50).count();
    let free = last.data.iter().filter(|&&c| (0..50).contains(&c)).count();
    assert!(
        occupied > 0 && free > occupied,
        "the last /map has {occupied} occupied and {free} free cells: not a map of the hall"
    );
    // The last map ros2-client decoded is the last the run recorded, cell for cell.
    let bag_maps = bag_of("/map");
    let recorded: OccupancyGrid =
        msgs::from_cdr(bag_maps.last().expect("/map in the bag")).expect("decode the bag's /map");
    assert_eq!(
        (&recorded.header, &recorded.info),
        (&last.header, &last.info),
        "the last /map received differs from the last recorded"
    );
    assert!(
        recorded.data == last.data,
        "the last /map's cells differ from the recorded ones"
    );
    check_attachments("/map", &seen.maps);

    // /slam/pose: geometry_msgs/PoseStamped, each equal to the recorded one of its stamp.
    let recorded_poses: BTreeMap<msgs::Time, PoseStamped> = bag_of("/slam/pose")
        .into_iter()
        .map(|b| {
            let p: PoseStamped = msgs::from_cdr(b).expect("decode the bag's /slam/pose");
            (p.header.stamp, p)
        })
        .collect();
    assert!(
        !seen.poses.is_empty(),
        "no /slam/pose received by ros2-client"
    );
    for (pose, _) in &seen.poses {
        assert_eq!(pose.header.frame_id, "map", "/slam/pose frame");
        assert!(pose.pose.is_finite(), "/slam/pose not finite: {pose:?}");
        assert!(
            (pose.pose.orientation.norm() - 1.0).abs() < 1e-9,
            "/slam/pose orientation is not a unit quaternion: {:?}",
            pose.pose.orientation
        );
        let recorded = recorded_poses.get(&pose.header.stamp).unwrap_or_else(|| {
            panic!(
                "/slam/pose at {:?} is not in the run's bag",
                pose.header.stamp
            )
        });
        assert_eq!(recorded, pose, "/slam/pose differs from the run's record");
    }
    // Everything the run published after ros2-client joined: the last ones at least, and most.
    let received: BTreeSet<msgs::Time> = seen.poses.iter().map(|(p, _)| p.header.stamp).collect();
    assert!(
        received.contains(recorded_poses.keys().last().unwrap()),
        "the run's last /slam/pose never reached ros2-client"
    );
    assert!(
        received.len() * 10 >= recorded_poses.len() * 8,
        "ros2-client got {} of the run's {} /slam/pose messages",
        received.len(),
        recorded_poses.len()
    );
    // The SLAM pose moves along the hall's loop (1 m/s): more than 2 m over the run.
    let (first, last) = (
        &seen.poses[0].0.pose.position,
        &seen.poses.last().unwrap().0.pose.position,
    );
    let moved = (last.x - first.x).hypot(last.y - first.y);
    assert!(moved > 2.0, "/slam/pose moved only {moved:.2} m");
    check_attachments("/slam/pose", &seen.poses);

    // /tf: tf2_msgs/TFMessage, the map → odom → base_link chain.
    assert!(!seen.tfs.is_empty(), "no /tf received by ros2-client");
    let mut pairs = BTreeSet::new();
    for (tf, _) in &seen.tfs {
        assert!(!tf.transforms.is_empty(), "an empty /tf");
        for t in &tf.transforms {
            let (v, q) = (t.transform.translation, t.transform.rotation);
            assert!(
                [v.x, v.y, v.z, q.x, q.y, q.z, q.w]
                    .iter()
                    .all(|x| x.is_finite())
                    && (q.norm() - 1.0).abs() < 1e-9,
                "/tf transform not finite or not unit: {t:?}"
            );
            pairs.insert((t.header.frame_id.clone(), t.child_frame_id.clone()));
        }
    }
    for pair in [("map", "odom"), ("odom", "base_link")] {
        assert!(
            pairs.contains(&(pair.0.to_owned(), pair.1.to_owned())),
            "/tf has no {} → {} transform; it has {pairs:?}",
            pair.0,
            pair.1
        );
    }
    check_attachments("/tf", &seen.tfs);

    // /ground_truth/targets: nrslam_msgs/TargetSet from nrslam's transient-local (zenoh-ext
    // advanced) publisher, decoded with this crate's struct from msgs/msg/*.msg, equal to the
    // recorded one: the hall's 10 targets, each with an outline and samples.
    let recorded: TargetSet = msgs::from_cdr(
        bag_of("/ground_truth/targets")
            .first()
            .expect("/ground_truth/targets in the bag"),
    )
    .expect("decode the bag's /ground_truth/targets");
    assert_eq!(
        seen.targets.len(),
        1,
        "/ground_truth/targets: one latched message expected"
    );
    let targets = &seen.targets[0].0;
    assert_eq!(
        targets, &recorded,
        "/ground_truth/targets differs from the record"
    );
    assert_eq!(targets.targets.len(), 10, "the hall has 10 targets");
    assert!(
        targets
            .targets
            .iter()
            .all(|t| t.outline.len() >= 3 && !t.samples.is_empty()),
        "a target without outline or samples: {targets:?}"
    );
    check_attachments("/ground_truth/targets", &seen.targets);
}

#[test]
fn another_domain_sees_no_node_and_no_message() {
    let _serial = common::serial();
    let tmp = tempfile::tempdir().expect("temporary folder");
    let seen = watch_paper_ideal(1, tmp.path(), false);
    // Connected all along (otherwise seeing nothing proves nothing)...
    assert!(
        seen.max_peers > 0,
        "ros2-client never connected to nrslam: this control would be vacuous"
    );
    // ...the run went through (it published on domain 0)...
    let summary = common::summary(&tmp.path().join("out"));
    assert!(
        summary.get("etgospa").and_then(|v| v.as_f64()).is_some(),
        "the domain-0 run wrote no etgospa: {summary}"
    );
    // ...and domain 1 saw none of it.
    let nodes: BTreeSet<&str> = seen.node_names.iter().map(String::as_str).collect();
    assert_eq!(
        nodes,
        BTreeSet::from(["/interop_probe"]),
        "domain 1 sees nodes other than its own"
    );
    let foreign: Vec<_> = seen
        .declared
        .iter()
        .filter(|e| e.node_name != "/interop_probe")
        .collect();
    assert!(
        foreign.is_empty(),
        "domain 1 sees entities of domain 0: {foreign:#?}"
    );
    assert_eq!(
        (
            seen.maps.len(),
            seen.poses.len(),
            seen.tfs.len(),
            seen.targets.len()
        ),
        (0, 0, 0, 0),
        "domain 1 received domain 0's messages (/map, /slam/pose, /tf, /ground_truth/targets)"
    );
}

/// Nothing nrslam puts on a key a ROS 2 subscription matches may be undecodable to it.
/// ros2-client's subscriptions match any type hash (`<domain>/<topic>/<type>/*`, its "liberal
/// receive"), so they also match a marker nrslam puts where the hash would be (e.g. an
/// end-of-stream `<domain>/<topic>/<type>/nrslam_end` with an empty payload): each such sample
/// reaches the application as a deserialisation error.
#[test]
fn no_sample_ros2_client_cannot_decode() {
    let _serial = common::serial();
    let tmp = tempfile::tempdir().expect("temporary folder");
    let seen = watch_paper_ideal(0, tmp.path(), false);
    assert!(
        !seen.maps.is_empty() && !seen.poses.is_empty() && !seen.tfs.is_empty(),
        "ros2-client received no /map, /slam/pose or /tf at all"
    );
    assert!(
        seen.errors.is_empty(),
        "ros2-client got samples it cannot decode on topics it subscribes to (an empty payload \
         is not CDR: e.g. nrslam's end-of-stream marker on <domain>/<topic>/<type>/nrslam_end, \
         which ros2-client's `*` in the hash chunk matches): {:#?}",
        seen.errors
    );
}
