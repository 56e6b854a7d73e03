//! ROS 2 CDR encoding: a 4-byte encapsulation header (`00 01 00 00`: CDR, little-endian,
//! options 0), then the fields in declaration order, each aligned to its own size counted from
//! after the header; strings as a u32 length that counts the trailing NUL, then the bytes and the
//! NUL; sequences as a u32 count then the elements; fixed arrays without a count.

use serde::{de::DeserializeOwned, Serialize};

/// Why bytes could not be encoded or decoded.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    /// The payload is shorter than the 4-byte encapsulation header.
    #[error("CDR payload of {0} bytes is shorter than the 4-byte encapsulation header")]
    TooShort(usize),
    /// The encapsulation header is not plain little-endian CDR.
    #[error("unsupported CDR encapsulation {0:02x?} (expected 00 01 for little-endian CDR)")]
    Encapsulation([u8; 2]),
    /// The bytes do not decode as the expected type.
    #[error("malformed CDR: {0}")]
    Malformed(String),
}

/// Encodes `value` as little-endian CDR with the encapsulation header.
pub fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>, CdrError> {
    ::cdr::serialize::<_, _, ::cdr::CdrLe>(value, ::cdr::Infinite)
        .map_err(|e| CdrError::Malformed(e.to_string()))
}

/// Decodes little-endian CDR with its encapsulation header into `T`.
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, CdrError> {
    if bytes.len() < 4 {
        return Err(CdrError::TooShort(bytes.len()));
    }
    if bytes[0..2] != [0x00, 0x01] {
        return Err(CdrError::Encapsulation([bytes[0], bytes[1]]));
    }
    ::cdr::deserialize::<T>(bytes).map_err(|e| CdrError::Malformed(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::*;

    fn hex(bytes: &[u8]) -> String {
        bytes.iter().map(|b| format!("{b:02x}")).collect()
    }

    fn golden(name: &str) -> String {
        // The hex string is the indented line of the fixture README after "bytes of CDR:" for `name`.
        let readme = include_str!("../tests/fixtures/README.md");
        let start = readme.find(name).expect("fixture named");
        readme[start..]
            .lines()
            .find(|line| line.starts_with("    ") && !line.trim().is_empty())
            .expect("hex line")
            .trim()
            .to_owned()
    }

    #[test]
    fn pose_stamped_bytes_match_ros2() {
        let message = PoseStamped {
            header: Header {
                stamp: Time {
                    sec: 100,
                    nanosec: 500,
                },
                frame_id: "map".into(),
            },
            pose: Pose {
                position: Point {
                    x: 1.0,
                    y: 2.0,
                    z: 3.0,
                },
                orientation: Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.0,
                    w: 1.0,
                },
            },
        };
        let bytes = encode(&message).unwrap();
        assert_eq!(bytes.len(), 76);
        assert_eq!(hex(&bytes), golden("geometry_msgs/msg/PoseStamped, header"));
        assert_eq!(decode::<PoseStamped>(&bytes).unwrap(), message);
    }

    #[test]
    fn occupancy_grid_bytes_match_ros2() {
        let message = OccupancyGrid {
            header: Header {
                stamp: Time {
                    sec: 100,
                    nanosec: 0,
                },
                frame_id: "map".into(),
            },
            info: MapMetaData {
                map_load_time: Time { sec: 1, nanosec: 2 },
                resolution: 0.05,
                width: 3,
                height: 2,
                origin: Pose {
                    position: Point {
                        x: -1.0,
                        y: -2.0,
                        z: 0.0,
                    },
                    orientation: Quaternion::default(),
                },
            },
            data: vec![0, 100, -1, 50, 0, 100],
        };
        let bytes = encode(&message).unwrap();
        assert_eq!(bytes.len(), 110);
        assert_eq!(hex(&bytes), golden("nav_msgs/msg/OccupancyGrid, header"));
        assert_eq!(decode::<OccupancyGrid>(&bytes).unwrap(), message);
    }

    #[test]
    fn short_or_foreign_payloads_are_refused() {
        assert!(matches!(
            decode::<Clock>(&[0, 1]),
            Err(CdrError::TooShort(2))
        ));
        assert!(matches!(
            decode::<Clock>(&[0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0]),
            Err(CdrError::Encapsulation(_))
        ));
        assert!(matches!(
            decode::<PoseStamped>(&[0, 1, 0, 0, 1]),
            Err(CdrError::Malformed(_))
        ));
    }
}
