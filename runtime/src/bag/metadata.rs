//! `metadata.yaml` of a rosbag2 directory (version 8), as rosbag2's `MetadataIo` writes it.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// The version written. Version 8 (Iron, read by Humble's successors and by Jazzy) is the first
/// with `type_description_hash` and `custom_data`; QoS profiles are a YAML string.
pub const VERSION: u32 = 8;

/// The whole file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetadataFile {
    /// Its single top-level key.
    pub rosbag2_bagfile_information: BagInfo,
}

/// `rosbag2_bagfile_information`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BagInfo {
    /// Format version.
    pub version: u32,
    /// Storage plugin: `mcap`.
    pub storage_identifier: String,
    /// Last log time minus first.
    pub duration: Nanoseconds,
    /// First log time.
    pub starting_time: StartingTime,
    /// Messages over all topics.
    pub message_count: u64,
    /// Per topic: metadata and count.
    pub topics_with_message_count: Vec<TopicWithCount>,
    /// Empty: no compression.
    #[serde(default)]
    pub compression_format: String,
    /// Empty: no compression.
    #[serde(default)]
    pub compression_mode: String,
    /// Storage files, relative to the bag folder.
    pub relative_file_paths: Vec<String>,
    /// Per storage file: path, start, duration, count.
    #[serde(default)]
    pub files: Vec<FileInfo>,
    /// Free key/value pairs; nrslam keeps the recorded run's identity here.
    #[serde(default, deserialize_with = "null_as_empty")]
    pub custom_data: BTreeMap<String, String>,
    /// Who wrote the bag.
    #[serde(default)]
    pub ros_distro: String,
}

fn null_as_empty<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> Result<BTreeMap<String, String>, D::Error> {
    Ok(Option::<BTreeMap<String, String>>::deserialize(deserializer)?.unwrap_or_default())
}

/// `{nanoseconds: N}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub struct Nanoseconds {
    /// Nanoseconds.
    pub nanoseconds: u64,
}

/// `{nanoseconds_since_epoch: N}`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub struct StartingTime {
    /// Nanoseconds since the epoch (simulated clock).
    pub nanoseconds_since_epoch: u64,
}

/// One entry of `topics_with_message_count`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TopicWithCount {
    /// The topic.
    pub topic_metadata: TopicMetadata,
    /// Messages on it.
    pub message_count: u64,
}

/// `topic_metadata`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TopicMetadata {
    /// Topic name, e.g. `/map`.
    pub name: String,
    /// ROS 2 type, e.g. `nav_msgs/msg/OccupancyGrid`.
    #[serde(rename = "type")]
    pub type_name: String,
    /// `cdr`.
    pub serialization_format: String,
    /// QoS of the publisher, a YAML list in a string (version 8).
    #[serde(default)]
    pub offered_qos_profiles: String,
    /// `RIHS01_<sha256>` of the type description.
    #[serde(default)]
    pub type_description_hash: String,
}

/// One entry of `files`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FileInfo {
    /// Relative path.
    pub path: String,
    /// First log time in the file.
    pub starting_time: StartingTime,
    /// Its duration.
    pub duration: Nanoseconds,
    /// Its messages.
    pub message_count: u64,
}

impl MetadataFile {
    /// The YAML text.
    pub fn to_yaml(&self) -> Result<String, serde_yaml::Error> {
        serde_yaml::to_string(self)
    }

    /// Parses YAML text.
    pub fn from_yaml(text: &str) -> Result<Self, serde_yaml::Error> {
        serde_yaml::from_str(text)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> MetadataFile {
        MetadataFile {
            rosbag2_bagfile_information: BagInfo {
                version: VERSION,
                storage_identifier: "mcap".into(),
                duration: Nanoseconds { nanoseconds: 5 },
                starting_time: StartingTime {
                    nanoseconds_since_epoch: 1_000_000_000,
                },
                message_count: 2,
                topics_with_message_count: vec![TopicWithCount {
                    topic_metadata: TopicMetadata {
                        name: "/clock".into(),
                        type_name: "rosgraph_msgs/msg/Clock".into(),
                        serialization_format: "cdr".into(),
                        offered_qos_profiles: "- history: 2\n  depth: 0".into(),
                        type_description_hash: "RIHS01_00".into(),
                    },
                    message_count: 2,
                }],
                compression_format: String::new(),
                compression_mode: String::new(),
                relative_file_paths: vec!["b_0.mcap".into()],
                files: vec![],
                custom_data: [("nrslam.seed".to_owned(), "7".to_owned())].into(),
                ros_distro: "nrslam".into(),
            },
        }
    }

    #[test]
    fn yaml_round_trips_and_uses_rosbag2_field_names() {
        let yaml = sample().to_yaml().unwrap();
        for key in [
            "rosbag2_bagfile_information:",
            "storage_identifier: mcap",
            "nanoseconds_since_epoch: 1000000000",
            "type: rosgraph_msgs/msg/Clock",
            "serialization_format: cdr",
            "type_description_hash: RIHS01_00",
            "version: 8",
        ] {
            assert!(yaml.contains(key), "{key} missing in\n{yaml}");
        }
        assert_eq!(MetadataFile::from_yaml(&yaml).unwrap(), sample());
    }

    #[test]
    fn null_custom_data_reads_as_empty() {
        let yaml = sample()
            .to_yaml()
            .unwrap()
            .replace("custom_data:\n    nrslam.seed: '7'", "custom_data: null");
        assert!(yaml.contains("custom_data: null"), "{yaml}");
        let back = MetadataFile::from_yaml(&yaml).unwrap();
        assert!(back.rosbag2_bagfile_information.custom_data.is_empty());
    }
}
