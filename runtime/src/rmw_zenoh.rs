//! What a ROS 2 node on `rmw_zenoh_cpp` (Jazzy and later) expects on the wire, so the graph can
//! publish its topics directly to ROS 2 without a bridge.
//!
//! - Key expression: `<domain id>/<topic without leading and trailing '/'>/<DDS type name>/<RIHS01
//!   hash>`, e.g. `0/map/nav_msgs::msg::dds_::OccupancyGrid_/RIHS01_8d34...`
//!   (rmw_zenoh `TopicInfo`); a subscriber matches only the exact type hash.
//! - Payload: the message in CDR with its 4-byte encapsulation header (what the graph sends anyway).
//! - Attachment (33 bytes, zenoh-ext serialisation of rmw_zenoh's `AttachmentData`): sequence
//!   number (i64 LE, from 1 per publisher), source timestamp (i64 LE, ns since the UNIX epoch),
//!   then the 16-byte publisher GID as a sequence (LEB128 length `0x10`, then the bytes).
//!   rmw_zenoh drops samples without it.
//!
//! Liveliness tokens (graph discovery for `ros2 topic list`) are not declared: data flows without
//! them, since rmw_zenoh subscribers match on the key expression alone.

use crate::type_hash::{self, TypeHashError};

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

/// A GID for a publisher: 16 bytes derived (FNV-1a, twice) from a name unique in the graph, e.g.
/// `<session id>/<topic>`. rmw_zenoh only compares GIDs for equality.
pub fn gid_for(name: &str) -> [u8; GID_LEN] {
    let fnv = |seed: u64| {
        name.bytes().fold(seed, |hash, byte| {
            (hash ^ byte as u64).wrapping_mul(0x0000_0100_0000_01b3)
        })
    };
    let mut gid = [0u8; GID_LEN];
    gid[..8].copy_from_slice(&fnv(0xcbf2_9ce4_8422_2325).to_le_bytes());
    gid[8..].copy_from_slice(&fnv(0x6c62_272e_07bb_0142).to_le_bytes());
    gid
}

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

    #[test]
    fn gids_differ_between_publishers_and_are_stable() {
        assert_eq!(gid_for("a/map"), gid_for("a/map"));
        assert_ne!(gid_for("a/map"), gid_for("a/odom"));
    }
}
