//! `metadata.yaml` of a rosbag2 directory, as rosbag2's `MetadataIo` and rosbags write it.
//!
//! Versions read: 4 to 9. What each added (rosbag2's history, also rosbags' reader docs): 4 QoS
//! metadata per topic and relative file paths, 5 per-file information (`files`), 6
//! `custom_data`, 7 `type_description_hash`, 8 `ros_distro`, 9 `offered_qos_profiles` as a YAML
//! list with enum names (`keep_last`, `reliable`, `transient_local`, `automatic`) where 4 to 8
//! wrote a YAML document inside a string with rmw's enum numbers. Fields a version lacks read as
//! empty. Version written: 9 (what Jazzy, Rolling and rosbags 0.11 write).

use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;

/// The version written.
pub const VERSION: u32 = 9;
/// Oldest version read.
pub const OLDEST_VERSION: u32 = 4;

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
    /// rosbag2's file or message compression (`zstd`); empty when none, and for MCAP chunk
    /// compression, which the storage file itself records.
    #[serde(default, deserialize_with = "null_as_default")]
    pub compression_format: String,
    /// `FILE`, `MESSAGE`, or empty (none, or MCAP chunk compression).
    #[serde(default, deserialize_with = "null_as_default")]
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
    #[serde(default, deserialize_with = "null_as_default")]
    pub ros_distro: String,
}

fn null_as_empty<'de, D: Deserializer<'de>>(
    deserializer: D,
) -> Result<BTreeMap<String, String>, D::Error> {
    Ok(Option::<BTreeMap<String, String>>::deserialize(deserializer)?.unwrap_or_default())
}

fn null_as_default<'de, D: Deserializer<'de>, T: Deserialize<'de> + Default>(
    deserializer: D,
) -> Result<T, D::Error> {
    Ok(Option::<T>::deserialize(deserializer)?.unwrap_or_default())
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
    /// QoS of the publishers: a YAML list (version 9), read also from versions 4 to 8's string.
    #[serde(default, deserialize_with = "qos_list_or_string")]
    pub offered_qos_profiles: Vec<QosProfile>,
    /// `RIHS01_<sha256>` of the type description (version 7 on; empty before).
    #[serde(default, deserialize_with = "null_as_default")]
    pub type_description_hash: String,
}

/// One offered QoS profile, as version 9 writes it (enum names, durations as `sec`/`nsec`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct QosProfile {
    /// `keep_last`, `keep_all`, `system_default`, `unknown`.
    #[serde(deserialize_with = "history")]
    pub history: String,
    /// History depth (0 with `keep_all`).
    pub depth: u64,
    /// `reliable`, `best_effort`, `system_default`, `best_available`, `unknown`.
    #[serde(deserialize_with = "reliability")]
    pub reliability: String,
    /// `volatile`, `transient_local`, `system_default`, `best_available`, `unknown`.
    #[serde(deserialize_with = "durability")]
    pub durability: String,
    /// Deadline (infinite: `sec: 9223372036, nsec: 854775807`).
    pub deadline: QosTime,
    /// Lifespan.
    pub lifespan: QosTime,
    /// `automatic`, `manual_by_topic`, `system_default`, `best_available`, `unknown`.
    #[serde(deserialize_with = "liveliness")]
    pub liveliness: String,
    /// Liveliness lease duration.
    pub liveliness_lease_duration: QosTime,
    /// Whether ROS namespace conventions are bypassed.
    pub avoid_ros_namespace_conventions: bool,
}

/// A QoS duration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct QosTime {
    /// Seconds.
    pub sec: i64,
    /// Nanoseconds.
    pub nsec: i64,
}

impl QosTime {
    /// rmw's infinite duration as rosbag2 writes it.
    pub const INFINITE: QosTime = QosTime {
        sec: 9_223_372_036,
        nsec: 854_775_807,
    };
}

/// An rmw QoS enum written as its number (versions 4 to 8) or its name (version 9).
#[derive(Deserialize)]
#[serde(untagged)]
enum EnumValue {
    Number(i64),
    Name(String),
}

fn enum_name<'de, D: Deserializer<'de>>(
    deserializer: D,
    names: &[&str],
) -> Result<String, D::Error> {
    match EnumValue::deserialize(deserializer)? {
        EnumValue::Name(name) => Ok(name.to_ascii_lowercase()),
        EnumValue::Number(n) => Ok(usize::try_from(n)
            .ok()
            .and_then(|i| names.get(i))
            .copied()
            .unwrap_or("unknown")
            .to_owned()),
    }
}

// rmw's enum numbering (rmw/types.h), index = value.
fn history<'de, D: Deserializer<'de>>(d: D) -> Result<String, D::Error> {
    enum_name(d, &["system_default", "keep_last", "keep_all", "unknown"])
}
fn reliability<'de, D: Deserializer<'de>>(d: D) -> Result<String, D::Error> {
    enum_name(
        d,
        &[
            "system_default",
            "reliable",
            "best_effort",
            "unknown",
            "best_available",
        ],
    )
}
fn durability<'de, D: Deserializer<'de>>(d: D) -> Result<String, D::Error> {
    enum_name(
        d,
        &[
            "system_default",
            "transient_local",
            "volatile",
            "unknown",
            "best_available",
        ],
    )
}
fn liveliness<'de, D: Deserializer<'de>>(d: D) -> Result<String, D::Error> {
    enum_name(
        d,
        &[
            "system_default",
            "automatic",
            "manual_by_node",
            "manual_by_topic",
            "unknown",
            "best_available",
        ],
    )
}

#[derive(Deserialize)]
#[serde(untagged)]
enum QosField {
    List(Vec<QosProfile>),
    Text(String),
}

fn qos_list_or_string<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<QosProfile>, D::Error> {
    match Option::<QosField>::deserialize(d)? {
        None => Ok(Vec::new()),
        Some(QosField::List(list)) => Ok(list),
        Some(QosField::Text(text)) if text.trim().is_empty() => Ok(Vec::new()),
        Some(QosField::Text(text)) => serde_yaml::from_str(&text).map_err(|e| {
            serde::de::Error::custom(format!(
                "offered_qos_profiles string is not a QoS list: {e}"
            ))
        }),
    }
}

/// The YAML text of `profiles` as version 9 writes it in a list, for the MCAP channel metadata
/// `offered_qos_profiles` (a string there in every version).
pub fn qos_yaml(profiles: &[QosProfile]) -> String {
    if profiles.is_empty() {
        return String::new();
    }
    serde_yaml::to_string(profiles)
        .map(|s| s.trim_end().to_owned())
        .unwrap_or_default()
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

    /// Parses YAML text of versions 4 to 9 (another version is an error naming it).
    pub fn from_yaml(text: &str) -> Result<Self, String> {
        #[derive(Deserialize)]
        struct Probe {
            rosbag2_bagfile_information: VersionOnly,
        }
        #[derive(Deserialize)]
        struct VersionOnly {
            version: u32,
        }
        let probe: Probe = serde_yaml::from_str(text).map_err(|e| e.to_string())?;
        let version = probe.rosbag2_bagfile_information.version;
        if !(OLDEST_VERSION..=VERSION).contains(&version) {
            return Err(format!(
                "metadata version {version} is not supported (read: {OLDEST_VERSION} to {VERSION})"
            ));
        }
        serde_yaml::from_str(text).map_err(|e| format!("version {version}: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn qos() -> QosProfile {
        QosProfile {
            history: "keep_all".into(),
            depth: 0,
            reliability: "reliable".into(),
            durability: "transient_local".into(),
            deadline: QosTime::INFINITE,
            lifespan: QosTime::INFINITE,
            liveliness: "automatic".into(),
            liveliness_lease_duration: QosTime::INFINITE,
            avoid_ros_namespace_conventions: false,
        }
    }

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
                        offered_qos_profiles: vec![qos()],
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
            "version: 9",
            // Version 9: QoS is a YAML list with enum names, not a string.
            "offered_qos_profiles:\n      - history: keep_all\n        depth: 0\n        reliability: reliable\n        durability: transient_local\n        deadline:\n          sec: 9223372036\n          nsec: 854775807",
            "liveliness: automatic",
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

    /// Version 5 as Humble's rosbag2 writes it: QoS as a YAML string with rmw enum numbers, no
    /// custom_data, type_description_hash nor ros_distro.
    const HUMBLE_V5: &str = r#"
rosbag2_bagfile_information:
  version: 5
  storage_identifier: sqlite3
  duration:
    nanoseconds: 2000000000
  starting_time:
    nanoseconds_since_epoch: 1600000000000000000
  message_count: 3
  topics_with_message_count:
    - topic_metadata:
        name: /chatter
        type: std_msgs/msg/String
        serialization_format: cdr
        offered_qos_profiles: "- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n  deadline:\n    sec: 9223372036\n    nsec: 854775807\n  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: 1\n  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n  avoid_ros_namespace_conventions: false"
      message_count: 3
  compression_format: ""
  compression_mode: ""
  relative_file_paths:
    - b_0.db3
  files:
    - path: b_0.db3
      starting_time:
        nanoseconds_since_epoch: 1600000000000000000
      duration:
        nanoseconds: 2000000000
      message_count: 3
"#;

    #[test]
    fn versions_4_to_8_read_with_numeric_qos_in_a_string() {
        let file = MetadataFile::from_yaml(HUMBLE_V5).unwrap();
        let info = &file.rosbag2_bagfile_information;
        let qos = &info.topics_with_message_count[0]
            .topic_metadata
            .offered_qos_profiles;
        assert_eq!(qos.len(), 1);
        assert_eq!(qos[0].history, "unknown");
        assert_eq!(qos[0].reliability, "reliable");
        assert_eq!(qos[0].durability, "volatile");
        assert_eq!(qos[0].liveliness, "automatic");
        assert_eq!(qos[0].deadline, QosTime::INFINITE);
        assert!(info.custom_data.is_empty() && info.ros_distro.is_empty());
        assert_eq!(info.files[0].message_count, 3);
        // Version 4: no `files`; an empty QoS string.
        let v4 = HUMBLE_V5
            .replace("version: 5", "version: 4")
            .split("  files:")
            .next()
            .unwrap()
            .to_owned();
        let v4 = MetadataFile::from_yaml(&v4).unwrap();
        assert!(v4.rosbag2_bagfile_information.files.is_empty());
        for version in [6, 7, 8] {
            let text = HUMBLE_V5.replace("version: 5", &format!("version: {version}"));
            assert!(MetadataFile::from_yaml(&text).is_ok(), "version {version}");
        }
        for version in [3, 10] {
            let text = HUMBLE_V5.replace("version: 5", &format!("version: {version}"));
            let error = MetadataFile::from_yaml(&text).unwrap_err();
            assert!(
                error.contains(&format!("version {version} is not supported")),
                "{error}"
            );
        }
        let broken = HUMBLE_V5.replace("history: 3", "history: [");
        assert!(MetadataFile::from_yaml(&broken).is_err());
    }

    #[test]
    fn rosbags_version_9_reads() {
        // As rosbags 0.11.9 writes it (keys sorted, QoS list with names, custom_data null).
        let text = r#"
rosbag2_bagfile_information:
  compression_format: ''
  compression_mode: ''
  custom_data: null
  duration:
    nanoseconds: 9500000000
  files:
  - duration:
      nanoseconds: 9500000000
    message_count: 60
    path: v9_plain.mcap
    starting_time:
      nanoseconds_since_epoch: 100000000000
  message_count: 60
  relative_file_paths:
  - v9_plain.mcap
  ros_distro: rosbags
  starting_time:
    nanoseconds_since_epoch: 100000000000
  storage_identifier: mcap
  topics_with_message_count:
  - message_count: 20
    topic_metadata:
      name: /slam/pose
      offered_qos_profiles:
      - avoid_ros_namespace_conventions: false
        deadline: {nsec: 0, sec: 0}
        depth: 10
        durability: volatile
        history: keep_last
        lifespan: {nsec: 0, sec: 0}
        liveliness: automatic
        liveliness_lease_duration: {nsec: 0, sec: 0}
        reliability: best_effort
      serialization_format: cdr
      type: geometry_msgs/msg/PoseStamped
      type_description_hash: 
        RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8
  version: 9
"#;
        let info = MetadataFile::from_yaml(text)
            .unwrap()
            .rosbag2_bagfile_information;
        let topic = &info.topics_with_message_count[0].topic_metadata;
        assert_eq!(topic.offered_qos_profiles[0].reliability, "best_effort");
        assert_eq!(topic.offered_qos_profiles[0].depth, 10);
        assert!(topic.type_description_hash.starts_with("RIHS01_10f3"));
        assert_eq!(info.ros_distro, "rosbags");
    }
}
