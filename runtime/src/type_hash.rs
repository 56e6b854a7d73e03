//! ROS 2 type description hashes (REP-2011, `RIHS01_<sha256 hex>`), computed from the `ros2msg`
//! definitions of [`nrslam_msgs::schema`].
//!
//! ROS 2 (Iron and later) identifies a message type by the SHA-256 of a canonical JSON rendering of
//! its type description: the type's fields, then every type it references (transitively), sorted by
//! name; default values are left out. rosbag2 writes the hash into `metadata.yaml`
//! (`type_description_hash`) and rmw_zenoh puts it in every topic's key expression, matching
//! publishers and subscribers only when the hashes are equal. This module renders the same JSON as
//! `rosidl_generator_type_description` (`json.dumps(..., separators=(', ', ': '))`, keys in message
//! order) and hashes it, so the values agree with what a ROS 2 installation computes from its own
//! `.msg` files (tested against published hashes of `nav_msgs/msg/OccupancyGrid` and
//! `std_msgs/msg/String`).

use sha2::{Digest, Sha256};

/// Why a type could not be described.
#[derive(Debug, thiserror::Error)]
pub enum TypeHashError {
    /// A type (or one it references) has no definition.
    #[error("no definition for message type {0:?}")]
    UnknownType(String),
    /// A field line of a definition could not be understood.
    #[error("{type_name}: cannot parse field {line:?}")]
    BadField {
        /// Type whose definition holds the line.
        type_name: String,
        /// The line.
        line: String,
    },
}

/// `FieldType.type_id` of `type_description_interfaces` for a primitive or string type name.
fn primitive_id(name: &str) -> Option<u8> {
    Some(match name {
        "int8" => 2,
        "uint8" => 3,
        "int16" => 4,
        "uint16" => 5,
        "int32" => 6,
        "uint32" => 7,
        "int64" => 8,
        "uint64" => 9,
        "float32" => 10,
        "float64" => 11,
        "char" => 13,
        "wchar" => 14,
        "bool" => 15,
        "byte" => 16,
        "string" => 17,
        "wstring" => 18,
        _ => return None,
    })
}

const NESTED_TYPE: u8 = 1;
const ARRAY_OFFSET: u8 = 48;
const BOUNDED_SEQUENCE_OFFSET: u8 = 96;
const UNBOUNDED_SEQUENCE_OFFSET: u8 = 144;

/// One field of a type description.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Field {
    name: String,
    type_id: u8,
    capacity: u64,
    nested_type_name: String,
}

/// `pkg/Type` (as written inside definitions) → `pkg/msg/Type`.
fn full_name(short: &str) -> String {
    match short.split_once('/') {
        Some((package, name)) if !name.starts_with("msg/") => format!("{package}/msg/{name}"),
        _ => short.to_owned(),
    }
}

/// Parses the fields of a definition. Constants (`TYPE NAME=VALUE`) are not fields.
fn fields(type_name: &str, text: &str) -> Result<Vec<Field>, TypeHashError> {
    let package = type_name.split('/').next().unwrap_or_default();
    let mut out = Vec::new();
    for raw in text.lines() {
        let line = raw.split('#').next().unwrap_or_default().trim();
        if line.is_empty() {
            continue;
        }
        let bad = || TypeHashError::BadField {
            type_name: type_name.to_owned(),
            line: raw.to_owned(),
        };
        let mut parts = line.split_whitespace();
        let (field_type, name) = (parts.next().ok_or_else(bad)?, parts.next().ok_or_else(bad)?);
        if name.contains('=') || parts.next().is_some_and(|p| p.starts_with('=')) {
            continue; // a constant
        }
        let (base, suffix) = match field_type.find('[') {
            Some(open) => (&field_type[..open], Some(&field_type[open..])),
            None => (field_type, None),
        };
        let (offset, capacity) = match suffix {
            None => (0, 0),
            Some("[]") => (UNBOUNDED_SEQUENCE_OFFSET, 0),
            Some(bracket) => {
                let inner = bracket
                    .strip_prefix('[')
                    .and_then(|s| s.strip_suffix(']'))
                    .ok_or_else(bad)?;
                match inner.strip_prefix("<=") {
                    Some(bound) => (BOUNDED_SEQUENCE_OFFSET, bound.parse().map_err(|_| bad())?),
                    None => (ARRAY_OFFSET, inner.parse().map_err(|_| bad())?),
                }
            }
        };
        let (type_id, nested_type_name) = match primitive_id(base) {
            Some(id) => (id, String::new()),
            None if base == "Header" => (NESTED_TYPE, "std_msgs/msg/Header".to_owned()),
            None if base.contains('/') => (NESTED_TYPE, full_name(base)),
            None => (NESTED_TYPE, format!("{package}/msg/{base}")),
        };
        out.push(Field {
            name: name.to_owned(),
            type_id: type_id + offset,
            capacity,
            nested_type_name,
        });
    }
    Ok(out)
}

fn json_fields(fields: &[Field]) -> String {
    let items: Vec<String> = fields
        .iter()
        .map(|f| {
            format!(
                "{{\"name\": \"{}\", \"type\": {{\"type_id\": {}, \"capacity\": {}, \"string_capacity\": 0, \"nested_type_name\": \"{}\"}}}}",
                f.name, f.type_id, f.capacity, f.nested_type_name
            )
        })
        .collect();
    format!("[{}]", items.join(", "))
}

/// The canonical JSON of `type_name`'s type description (the text whose SHA-256 is the hash),
/// looking definitions up with `definition` (by full name `pkg/msg/Type`).
pub fn description_json(
    type_name: &str,
    definition: &dyn Fn(&str) -> Option<String>,
) -> Result<String, TypeHashError> {
    let own = fields(
        type_name,
        &definition(type_name).ok_or_else(|| TypeHashError::UnknownType(type_name.to_owned()))?,
    )?;
    let mut referenced: std::collections::BTreeMap<String, Vec<Field>> = Default::default();
    let mut pending: Vec<String> = own
        .iter()
        .filter(|f| !f.nested_type_name.is_empty())
        .map(|f| f.nested_type_name.clone())
        .collect();
    while let Some(name) = pending.pop() {
        if referenced.contains_key(&name) {
            continue;
        }
        let text = definition(&name).ok_or_else(|| TypeHashError::UnknownType(name.clone()))?;
        let nested = fields(&name, &text)?;
        pending.extend(
            nested
                .iter()
                .filter(|f| !f.nested_type_name.is_empty())
                .map(|f| f.nested_type_name.clone()),
        );
        referenced.insert(name, nested);
    }
    let referenced: Vec<String> = referenced
        .iter()
        .map(|(name, fields)| {
            format!(
                "{{\"type_name\": \"{name}\", \"fields\": {}}}",
                json_fields(fields)
            )
        })
        .collect();
    Ok(format!(
        "{{\"type_description\": {{\"type_name\": \"{type_name}\", \"fields\": {}}}, \"referenced_type_descriptions\": [{}]}}",
        json_fields(&own),
        referenced.join(", ")
    ))
}

/// `RIHS01_<hex>` of the canonical JSON from [`description_json`].
pub fn rihs01_with(
    type_name: &str,
    definition: &dyn Fn(&str) -> Option<String>,
) -> Result<String, TypeHashError> {
    let json = description_json(type_name, definition)?;
    let digest = Sha256::digest(json.as_bytes());
    let hex: String = digest.iter().map(|b| format!("{b:02x}")).collect();
    Ok(format!("RIHS01_{hex}"))
}

/// `RIHS01_<hex>` of a type the graph carries (definitions from [`nrslam_msgs::schema`]).
pub fn rihs01(type_name: &str) -> Result<String, TypeHashError> {
    rihs01_with(type_name, &|name| {
        nrslam_msgs::schema::definition_of(name).map(str::to_owned)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Published by `ros2 topic info -v` of a Jazzy installation for nav_msgs/msg/OccupancyGrid.
    const OCCUPANCY_GRID: &str =
        "RIHS01_8d348150c12913a31ee0ec170fbf25089e4745d17035792a1ba94d6f0bc0cfc7";
    /// The std_msgs/msg/String hash in rmw_zenoh's design document (key expression of `chatter`).
    const STRING: &str = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18";

    #[test]
    fn occupancy_grid_hash_is_the_one_ros2_publishes() {
        assert_eq!(
            rihs01("nav_msgs/msg/OccupancyGrid").unwrap(),
            OCCUPANCY_GRID
        );
    }

    /// roslibrust's generated `ROS2_HASH` of `diagnostic_msgs/KeyValue`, a type whose definition
    /// is the same in ROS 1 and ROS 2 (its other diagnostic hashes come from ROS 1 definitions,
    /// with `seq` in the header, so they cannot be compared).
    const KEY_VALUE: &str =
        "RIHS01_d68081eaa540288c5440753baecef0c4e16e81a5f78ad68902ded5100413bb42";

    /// rosbags' ROS 2 Jazzy type store (`get_typestore(Stores.ROS2_JAZZY).hash_rihs01(...)`,
    /// rosbags 0.11.9), an implementation we did not write, from the Jazzy definitions.
    const DIAGNOSTIC_ARRAY: &str =
        "RIHS01_5a8a36efb05fb25070fa0fb3810290c0e6cd4862b54a8fb975a1ee8dc55a333e";

    #[test]
    fn diagnostic_array_hash_is_the_one_rosbags_computes_for_jazzy() {
        assert_eq!(
            rihs01("diagnostic_msgs/msg/DiagnosticArray").unwrap(),
            DIAGNOSTIC_ARRAY
        );
    }

    #[test]
    fn diagnostics_key_value_hash_is_the_one_roslibrust_generates() {
        assert_eq!(rihs01("diagnostic_msgs/msg/KeyValue").unwrap(), KEY_VALUE);
    }

    #[test]
    fn string_hash_is_the_one_in_the_rmw_zenoh_design() {
        let hash = rihs01_with("std_msgs/msg/String", &|name| {
            (name == "std_msgs/msg/String").then(|| "string data\n".to_owned())
        })
        .unwrap();
        assert_eq!(hash, STRING);
    }

    #[test]
    fn references_are_sorted_and_arrays_carry_their_capacity() {
        let json = description_json("nav_msgs/msg/Odometry", &|name| {
            nrslam_msgs::schema::definition_of(name).map(str::to_owned)
        })
        .unwrap();
        let header = json
            .find("\"type_name\": \"builtin_interfaces/msg/Time\"")
            .unwrap();
        let pose = json
            .find("\"type_name\": \"geometry_msgs/msg/Pose\"")
            .unwrap();
        assert!(header < pose, "{json}");
        assert!(
            json.contains(
                "{\"name\": \"covariance\", \"type\": {\"type_id\": 59, \"capacity\": 36"
            ),
            "{json}"
        );
    }

    #[test]
    fn every_graph_type_has_a_hash_and_unknown_types_are_errors() {
        for name in nrslam_msgs::Message::TYPE_NAMES {
            let hash = rihs01(name).unwrap();
            assert_eq!(hash.len(), 7 + 64, "{name}");
        }
        assert!(matches!(
            rihs01("foo_msgs/msg/Bar"),
            Err(TypeHashError::UnknownType(_))
        ));
    }
}
