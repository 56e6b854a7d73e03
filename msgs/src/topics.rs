//! The topic catalogue: every topic of the graph with its ROS 2 type and QoS (docs/design.md, "The graph").
//! Launch files are checked against it before anything starts.
//!
//! Several agents (AGVs, fixed sensing stations) run the same nodes under a namespace each: their
//! topics are the catalogue's with the namespace in front (`/agv1/odom`), and [`spec`] gives them
//! the catalogue topic's type and QoS.

/// Topic names.
pub const CLOCK: &str = "/clock";
/// Noisy wheel odometry.
pub const ODOM: &str = "/odom";
/// Range/angle detections of one radar frame.
pub const DETECTIONS: &str = "/radar/detections";
/// Raw OFDM resource grids of one frame (`waveform` fidelity).
pub const ECHO: &str = "/radar/echo";
/// Processed range × angle response of one frame (`spectral` fidelity).
pub const SPECTRUM: &str = "/radar/spectrum";
/// True AGV pose.
pub const GROUND_TRUTH_POSE: &str = "/ground_truth/pose";
/// True extended targets (latched).
pub const GROUND_TRUTH_TARGETS: &str = "/ground_truth/targets";
/// SLAM estimate of the AGV pose.
pub const SLAM_POSE: &str = "/slam/pose";
/// Keyframes chosen by data association.
pub const KEYFRAME: &str = "/slam/keyframe";
/// Current pose-graph estimate of every keyframe, one per keyframe.
pub const KEYFRAME_POSES: &str = "/slam/keyframe_poses";
/// Per-frame data-association statistics.
pub const ASSOCIATION_STATS: &str = "/slam/association_stats";
/// Occupancy grid.
pub const MAP: &str = "/map";
/// DBSCAN-labelled occupied cells.
pub const SEGMENTS: &str = "/map/segments";
/// The map's extended targets as fitted shapes, one per map update.
pub const MAP_TARGETS: &str = "/map/targets";
/// The fitted shapes, for viewers.
pub const MAP_TARGET_MARKERS: &str = "/map/targets/markers";
/// Per-step metrics.
pub const METRICS: &str = "/metrics";
/// What each process's receive path dropped (the ROS convention for health reports).
pub const DIAGNOSTICS: &str = "/diagnostics";
/// Returns of a real radar driver (`radar_msgs/msg/RadarScan`), the sensor adapter's input.
pub const RADAR_SCAN: &str = "/radar/scan";
/// Points of a real radar or lidar driver (`sensor_msgs/msg/PointCloud2`), the sensor adapter's
/// input.
pub const RADAR_POINTS: &str = "/radar/points";
/// Moving transforms `map → odom → base_link` (REP-105).
pub const TF: &str = "/tf";
/// Fixed transforms (`base_link → radar`), latched.
pub const TF_STATIC: &str = "/tf_static";
/// The SLAM trajectory so far, for viewers.
pub const SLAM_PATH: &str = "/slam/path";
/// The true trajectory so far, for viewers.
pub const GROUND_TRUTH_PATH: &str = "/ground_truth/path";
/// Outlines and sample points of the true targets, for viewers (latched).
pub const GROUND_TRUTH_MARKERS: &str = "/ground_truth/markers";
/// Clusters of the map and their representative points, for viewers.
pub const CLUSTER_MARKERS: &str = "/map/clusters";
/// One frame's detections as points in the radar frame, for viewers.
pub const DETECTIONS_CLOUD: &str = "/radar/detections_cloud";
/// An agent's pose corrected by the fusion node (published under the agent's namespace).
pub const FUSION_POSE: &str = "/fusion/pose";
/// An agent's corrected keyframe path (under the agent's namespace).
pub const FUSION_PATH: &str = "/fusion/path";
/// Inter-agent edges of the fused pose graph, for viewers.
pub const FUSION_EDGES: &str = "/fusion/edges";

/// Delivery guarantee of a topic.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reliability {
    /// Every message arrives, in order (zenoh reliable, congestion control `Block`).
    Reliable,
}

/// Whether late subscribers get earlier messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// Only messages published after subscribing.
    Volatile,
    /// The last message is kept for late joiners (ROS 2 transient local); published once.
    TransientLocal,
}

/// QoS of a topic, as ROS 2 names it. Every topic of the graph is reliable: a node that falls
/// behind slows its publisher down (back-pressure) instead of losing frames, so a graph gives the
/// same result however its nodes are spread over processes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliability.
    pub reliability: Reliability,
    /// Durability.
    pub durability: Durability,
    /// Messages a subscriber queues before its publisher is held back (ROS 2 history depth):
    /// what bounds a receiver's memory.
    pub depth: usize,
}

const STREAM: Qos = Qos {
    reliability: Reliability::Reliable,
    durability: Durability::Volatile,
    depth: 64,
};
/// Streams of large messages (resource grids, spectra, occupancy grids): a shorter queue.
const BULK: Qos = Qos { depth: 8, ..STREAM };
const LATCHED: Qos = Qos {
    reliability: Reliability::Reliable,
    durability: Durability::TransientLocal,
    depth: 1,
};

/// One catalogue entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TopicSpec {
    /// Topic name, e.g. `/map`.
    pub name: &'static str,
    /// ROS 2 type name, e.g. `nav_msgs/msg/OccupancyGrid`.
    pub type_name: &'static str,
    /// QoS.
    pub qos: Qos,
    /// What it carries.
    pub description: &'static str,
}

/// Every topic of the graph.
pub const CATALOGUE: &[TopicSpec] = &[
    TopicSpec {
        name: CLOCK,
        type_name: "rosgraph_msgs/msg/Clock",
        qos: STREAM,
        description: "simulated clock, one per frame",
    },
    TopicSpec {
        name: ODOM,
        type_name: "nav_msgs/msg/Odometry",
        qos: STREAM,
        description: "noisy wheel odometry, dead-reckoned pose in frame odom",
    },
    TopicSpec {
        name: ECHO,
        type_name: "nrslam_msgs/msg/RadarEcho",
        qos: BULK,
        description: "OFDM resource grids Y and X of one frame (waveform fidelity)",
    },
    TopicSpec {
        name: SPECTRUM,
        type_name: "nrslam_msgs/msg/RadarSpectrum",
        qos: BULK,
        description: "processed range x angle response of one frame (spectral fidelity)",
    },
    TopicSpec {
        name: DETECTIONS,
        type_name: "nrslam_msgs/msg/Detections",
        qos: STREAM,
        description: "range/angle detections of one radar frame",
    },
    TopicSpec {
        name: GROUND_TRUTH_POSE,
        type_name: "geometry_msgs/msg/PoseStamped",
        qos: STREAM,
        description: "true AGV pose",
    },
    TopicSpec {
        name: GROUND_TRUTH_TARGETS,
        type_name: "nrslam_msgs/msg/TargetSet",
        qos: LATCHED,
        description: "true extended targets with their ET-GOPSA sample points",
    },
    TopicSpec {
        name: SLAM_POSE,
        type_name: "geometry_msgs/msg/PoseStamped",
        qos: STREAM,
        description: "SLAM estimate of the AGV pose, one per frame",
    },
    TopicSpec {
        name: KEYFRAME,
        type_name: "nrslam_msgs/msg/Keyframe",
        qos: STREAM,
        description: "keyframes: pose and detections",
    },
    TopicSpec {
        name: KEYFRAME_POSES,
        type_name: "nrslam_msgs/msg/KeyframePoses",
        qos: STREAM,
        description: "pose-graph estimate of every keyframe, one per keyframe (revision changes on loop closure)",
    },
    TopicSpec {
        name: ASSOCIATION_STATS,
        type_name: "nrslam_msgs/msg/AssociationStats",
        qos: STREAM,
        description: "data-association statistics, one per radar frame",
    },
    TopicSpec {
        name: MAP,
        type_name: "nav_msgs/msg/OccupancyGrid",
        qos: BULK,
        description: "log-odds occupancy grid, one per keyframe",
    },
    TopicSpec {
        name: SEGMENTS,
        type_name: "nrslam_msgs/msg/Segments",
        qos: STREAM,
        description: "occupied cells labelled by DBSCAN, one per map",
    },
    TopicSpec {
        name: MAP_TARGETS,
        type_name: "nrslam_msgs/msg/MapTargets",
        qos: STREAM,
        description: "extended targets as fitted rectangles and circles with covariance, one per map",
    },
    TopicSpec {
        name: MAP_TARGET_MARKERS,
        type_name: "visualization_msgs/msg/MarkerArray",
        qos: STREAM,
        description: "the fitted shapes' outlines, for viewers, one per map",
    },
    TopicSpec {
        name: METRICS,
        type_name: "nrslam_msgs/msg/Metrics",
        qos: STREAM,
        description: "ET-GOPSA, GOSPA and position error, one per frame",
    },
    TopicSpec {
        name: DIAGNOSTICS,
        type_name: "diagnostic_msgs/msg/DiagnosticArray",
        qos: STREAM,
        description: "samples each process dropped, per topic and reason (at most once a second while they change, and at the end)",
    },
    TopicSpec {
        name: RADAR_SCAN,
        type_name: "radar_msgs/msg/RadarScan",
        qos: STREAM,
        description: "a radar driver's returns (range, azimuth) in its own frame, for the sensor adapter",
    },
    TopicSpec {
        name: RADAR_POINTS,
        type_name: "sensor_msgs/msg/PointCloud2",
        qos: STREAM,
        description: "a radar driver's points (x, y, z fields) in its own frame, for the sensor adapter",
    },
    TopicSpec {
        name: TF,
        type_name: "tf2_msgs/msg/TFMessage",
        qos: STREAM,
        description: "map -> odom -> base_link transforms (REP-105), one per frame",
    },
    TopicSpec {
        name: TF_STATIC,
        type_name: "tf2_msgs/msg/TFMessage",
        qos: LATCHED,
        description: "base_link -> radar, the sensor's mounting",
    },
    TopicSpec {
        name: SLAM_PATH,
        type_name: "nav_msgs/msg/Path",
        qos: BULK,
        description: "SLAM trajectory so far, frame map, one per frame",
    },
    TopicSpec {
        name: GROUND_TRUTH_PATH,
        type_name: "nav_msgs/msg/Path",
        qos: BULK,
        description: "true trajectory so far, frame map, one per frame",
    },
    TopicSpec {
        name: GROUND_TRUTH_MARKERS,
        type_name: "visualization_msgs/msg/MarkerArray",
        qos: LATCHED,
        description: "outlines and ET-GOPSA sample points of the true targets, for viewers",
    },
    TopicSpec {
        name: CLUSTER_MARKERS,
        type_name: "visualization_msgs/msg/MarkerArray",
        qos: STREAM,
        description: "DBSCAN clusters of the map and their representative points, one per map",
    },
    TopicSpec {
        name: DETECTIONS_CLOUD,
        type_name: "sensor_msgs/msg/PointCloud2",
        qos: STREAM,
        description: "one frame's detections as x, y, z, power_db points in frame radar",
    },
    TopicSpec {
        name: FUSION_POSE,
        type_name: "geometry_msgs/msg/PoseStamped",
        qos: STREAM,
        description: "an agent's pose corrected by the fusion node, in the fused map frame; published under the agent's namespace, e.g. /agv1/fusion/pose",
    },
    TopicSpec {
        name: FUSION_PATH,
        type_name: "nav_msgs/msg/Path",
        qos: STREAM,
        description: "an agent's corrected keyframe path, under its namespace",
    },
    TopicSpec {
        name: FUSION_EDGES,
        type_name: "visualization_msgs/msg/MarkerArray",
        qos: STREAM,
        description: "inter-agent edges of the fused pose graph, for viewers",
    },
];

/// The catalogue entry of `name`: its own, or for a topic under a namespace (`/agv1/odom`,
/// `/site/agv1/radar/detections`) that of the catalogue topic below the namespace (`/odom`,
/// `/radar/detections`), so that several agents' copies of a topic share its type and QoS.
///
/// An exact match comes first (`/map/targets` is a topic of its own, not `/targets` under `map`).
/// Otherwise leading segments are stripped, each a valid namespace segment
/// ([`is_name_segment`]), until the rest is a catalogue topic; `None` when none is
/// (`/agv1/foo`). The returned spec's `name` is the catalogue's: callers that publish, subscribe
/// or record keep the name they were given (see [`intern`]).
pub fn spec(name: &str) -> Option<&'static TopicSpec> {
    exact(name).or_else(|| split_namespace(name).map(|(_, spec)| spec))
}

fn exact(name: &str) -> Option<&'static TopicSpec> {
    CATALOGUE.iter().find(|t| t.name == name)
}

/// `name` split into its namespace (without slashes at either end, e.g. `site/agv1`) and the
/// catalogue topic under it; `None` for a catalogue topic itself or a name that is neither.
pub fn split_namespace(name: &str) -> Option<(&str, &'static TopicSpec)> {
    let mut rest = name.strip_prefix('/')?;
    let mut namespace_len_bytes = 0;
    while let Some((segment, tail)) = rest.split_once('/') {
        if !is_name_segment(segment) {
            return None;
        }
        namespace_len_bytes += segment.len() + 1;
        let below = &name[namespace_len_bytes..];
        if let Some(spec) = exact(below) {
            return Some((&name[1..namespace_len_bytes], spec));
        }
        rest = tail;
    }
    None
}

/// The catalogue name below any namespace (`/agv1/radar/detections` → `/radar/detections`).
pub fn base_name(name: &str) -> Option<&'static str> {
    spec(name).map(|s| s.name)
}

/// Whether `segment` is one segment of a ROS name: a letter, then letters, digits and `_`.
pub fn is_name_segment(segment: &str) -> bool {
    let mut chars = segment.chars();
    chars.next().is_some_and(|c| c.is_ascii_alphabetic())
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// Whether `namespace` is a namespace a node may run in: segments ([`is_name_segment`])
/// separated by `/`, e.g. `agv1` or `site/agv1`. The empty namespace (none) is valid; slashes at
/// either end are not part of it (see [`namespace_problem`] for the reason one is refused).
pub fn is_valid_namespace(namespace: &str) -> bool {
    namespace_problem(namespace).is_none()
}

/// Why `namespace` is not a valid namespace (`None`: it is), for error messages.
pub fn namespace_problem(namespace: &str) -> Option<String> {
    if namespace.is_empty() {
        return None;
    }
    if namespace.starts_with('/') || namespace.ends_with('/') {
        return Some(format!(
            "{namespace:?} starts or ends with '/' (write it without, e.g. \"agv1\" or \"site/agv1\")"
        ));
    }
    namespace
        .split('/')
        .find(|s| !is_name_segment(s))
        .map(|bad| {
            format!(
                "{namespace:?} has segment {bad:?}: each segment is a letter followed by letters, \
             digits and '_' (e.g. \"agv1\" or \"site/agv1\")"
            )
        })
}

/// `topic` under `namespace` (`agv1`, `/odom` → `/agv1/odom`); `topic` itself when the namespace
/// is empty.
pub fn namespaced(namespace: &str, topic: &str) -> String {
    if namespace.is_empty() {
        topic.to_owned()
    } else {
        format!("/{namespace}{topic}")
    }
}

/// A `&'static str` equal to `name`: the catalogue's own constant for a catalogue topic, else a
/// copy leaked once per distinct name for the life of the process. Nodes, outboxes and the
/// transport name topics by `&'static str` (compared and hashed cheaply, shared without
/// lifetimes); namespaced names are made at run time from launch files, and the few distinct ones
/// a process sees are kept rather than freed.
pub fn intern(name: &str) -> &'static str {
    if let Some(spec) = exact(name) {
        return spec.name;
    }
    static INTERNED: std::sync::LazyLock<
        std::sync::Mutex<std::collections::HashSet<&'static str>>,
    > = std::sync::LazyLock::new(Default::default);
    // A panic elsewhere while the lock was held leaves the set consistent (insert is atomic from
    // our side): keep using it.
    let mut set = INTERNED
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if let Some(&known) = set.get(name) {
        return known;
    }
    let leaked: &'static str = Box::leak(name.to_owned().into_boxed_str());
    set.insert(leaked);
    leaked
}

/// The zenoh key expression of a topic: the name without its leading '/' (`/map/segments` →
/// `map/segments`), optionally under a namespace prefix (`robot1` → `robot1/map/segments`).
pub fn key_expr(namespace: &str, name: &str) -> String {
    let topic = name.trim_start_matches('/');
    let namespace = namespace.trim_matches('/');
    if namespace.is_empty() {
        topic.to_owned()
    } else {
        format!("{namespace}/{topic}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Message;

    #[test]
    fn every_topic_type_is_a_message_type_with_a_schema() {
        for topic in CATALOGUE {
            assert!(
                Message::TYPE_NAMES.contains(&topic.type_name),
                "{}",
                topic.name
            );
            assert!(crate::schema::ros2msg(topic.type_name).is_some());
        }
    }

    #[test]
    fn topic_names_are_unique() {
        for (i, a) in CATALOGUE.iter().enumerate() {
            assert!(
                CATALOGUE[i + 1..].iter().all(|b| b.name != a.name),
                "{}",
                a.name
            );
        }
    }

    #[test]
    fn a_namespaced_topic_has_the_spec_of_the_catalogue_topic_below_its_namespace() {
        assert_eq!(spec("/agv1/radar/detections"), spec(DETECTIONS));
        assert_eq!(spec("/site/agv_2/odom").map(|s| s.name), Some(ODOM));
        assert_eq!(base_name("/agv1/fusion/pose"), Some(FUSION_POSE));
        // Exact matches first: /map/targets is its own topic, not /targets under `map`.
        assert_eq!(base_name(MAP_TARGETS), Some(MAP_TARGETS));
        assert_eq!(
            base_name("/agv1/map/targets/markers"),
            Some(MAP_TARGET_MARKERS)
        );
        assert_eq!(
            split_namespace("/site/agv1/map").map(|(ns, s)| (ns, s.name)),
            Some(("site/agv1", MAP))
        );
        assert_eq!(split_namespace(MAP), None);
        for not_a_topic in [
            "/agv1/foo",
            "agv1/odom",
            "/1agv/odom",
            "/agv-1/odom",
            "//odom",
            "/agv1//odom",
            "/",
            "",
            "/agv1/",
        ] {
            assert_eq!(spec(not_a_topic), None, "{not_a_topic}");
        }
    }

    #[test]
    fn namespaces_are_segments_and_namespaced_names_are_absolute() {
        for good in ["", "agv1", "site/agv_2", "A"] {
            assert!(is_valid_namespace(good), "{good}");
        }
        for bad in ["/agv1", "agv1/", "1agv", "agv-1", "a//b", "a b", "_a"] {
            assert!(!is_valid_namespace(bad), "{bad}");
        }
        assert!(namespace_problem("a/2b").unwrap().contains("\"2b\""));
        assert_eq!(namespaced("agv1", ODOM), "/agv1/odom");
        assert_eq!(namespaced("", ODOM), ODOM);
    }

    #[test]
    fn interning_gives_one_static_copy_per_name_and_the_catalogue_its_own() {
        let a = intern("/agv1/odom");
        let b = intern(&String::from("/agv1/odom"));
        assert_eq!(a, "/agv1/odom");
        assert!(std::ptr::eq(a, b), "one copy per distinct name");
        assert_eq!(intern("/odom"), ODOM);
    }

    #[test]
    fn key_expressions_drop_the_leading_slash() {
        assert_eq!(key_expr("", "/map/segments"), "map/segments");
        assert_eq!(key_expr("/robot1/", "/map"), "robot1/map");
    }
}
