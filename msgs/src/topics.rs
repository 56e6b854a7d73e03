//! The topic catalogue: every topic of the graph with its ROS 2 type and QoS (docs/design.md, "The graph").
//! Launch files are checked against it before anything starts.

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
];

/// The catalogue entry of `name`.
pub fn spec(name: &str) -> Option<&'static TopicSpec> {
    CATALOGUE.iter().find(|t| t.name == name)
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
    fn key_expressions_drop_the_leading_slash() {
        assert_eq!(key_expr("", "/map/segments"), "map/segments");
        assert_eq!(key_expr("/robot1/", "/map"), "robot1/map");
    }
}
