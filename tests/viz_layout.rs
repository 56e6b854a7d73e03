//! docs/foxglove-layout.json names only topics the graph publishes, each with the type its panel
//! draws, and plots only fields `/metrics` has: a renamed topic or field breaks this test, not a
//! user's layout.

mod common;

use common::root;
use nrslam_msgs::topics;
use serde_json::Value;

/// The types the 3D panel can draw, per topic kind.
const DRAWABLE: &[&str] = &[
    "nav_msgs/msg/OccupancyGrid",
    "nav_msgs/msg/Path",
    "visualization_msgs/msg/MarkerArray",
    "sensor_msgs/msg/PointCloud2",
];

fn layout() -> Value {
    let text = std::fs::read_to_string(root().join("docs/foxglove-layout.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

#[test]
fn every_topic_of_the_layout_is_published_with_a_type_its_panel_draws() {
    let layout = layout();
    let panels = layout["configById"].as_object().unwrap();
    let mut drawn = Vec::new();
    for (id, config) in panels {
        if id.starts_with("3D!") {
            for topic in config["topics"].as_object().unwrap().keys() {
                let spec = topics::spec(topic).unwrap_or_else(|| panic!("{topic}: not published"));
                assert!(
                    DRAWABLE.contains(&spec.type_name),
                    "{topic}: {} is not drawn by the 3D panel",
                    spec.type_name
                );
                drawn.push(topic.clone());
            }
        }
    }
    for wanted in [
        topics::MAP,
        topics::SLAM_PATH,
        topics::GROUND_TRUTH_PATH,
        topics::GROUND_TRUTH_MARKERS,
        topics::CLUSTER_MARKERS,
        topics::DETECTIONS_CLOUD,
    ] {
        assert!(drawn.iter().any(|t| t == wanted), "{wanted} not drawn");
    }
    // The layout's panels are the ones its tree arranges.
    let tree = layout["layout"].to_string();
    for id in panels.keys() {
        assert!(tree.contains(&format!("\"{id}\"")), "{id} not placed");
    }
}

#[test]
fn every_plotted_field_is_a_field_of_metrics() {
    let layout = layout();
    let metrics = serde_json::to_value(nrslam_msgs::Metrics::default()).unwrap();
    let mut plotted = 0;
    for (id, config) in layout["configById"].as_object().unwrap() {
        if id.starts_with("Plot!") {
            for path in config["paths"].as_array().unwrap() {
                let value = path["value"].as_str().unwrap();
                let field = value
                    .strip_prefix("/metrics.")
                    .unwrap_or_else(|| panic!("{value}: not a /metrics field"));
                assert!(metrics.get(field).is_some(), "{field} is not in Metrics");
                assert_eq!(
                    topics::spec(topics::METRICS).unwrap().type_name,
                    "nrslam_msgs/msg/Metrics"
                );
                plotted += 1;
            }
        }
        if id.starts_with("RawMessages!") {
            let topic = config["topicPath"].as_str().unwrap();
            assert!(topics::spec(topic).is_some(), "{topic}: not published");
        }
    }
    assert!(plotted >= 2);
}
