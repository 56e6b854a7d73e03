//! ROS 2 CDR encoding: a 4-byte encapsulation header (`00 01 00 00`: CDR, little-endian,
//! options 0), then the fields in declaration order, each aligned to its own size counted from
//! after the header; strings as a u32 length that counts the trailing NUL, then the bytes and the
//! NUL; sequences as a u32 count then the elements; fixed arrays (serde tuples, `serde-big-array`)
//! without a count; `bool` as one byte 0 or 1; an enum (none in the catalogue) as a u32 variant
//! index then its fields.
//!
//! Encoding goes through the `cdr` crate (its output is checked byte for byte against ROS 2
//! reference bytes in the tests below); decoding is this module's own serde deserializer,
//! because payloads come from the network and the `cdr` crate reserves whatever a length prefix
//! claims before checking that the bytes are there (19 bytes could ask for 4 GB).
//!
//! # What [`decode`] guarantees
//!
//! For a payload of n bytes, whatever the bytes:
//! - it returns `Ok` or `Err`, never panics, and runs in O(n) time;
//! - it allocates O(n) bytes in total: every string length and sequence count is checked against
//!   the bytes left before anything is reserved or read; a string borrows its bytes from the
//!   payload until the value is built (one allocation of its checked length); a sequence's count
//!   must not exceed the bytes left (every element of a catalogue type takes at least one byte),
//!   and the capacity it reserves up front is at most (bytes left) / 8 elements (serde further
//!   caps that at 1 MiB), the rest grows as elements actually decode. With the largest element
//!   of the catalogue reserved so (`Target`, 80 bytes in memory, at least 16 on the wire) a false
//!   count thus reserves at most 10 bytes per payload byte. `MarkerArray`'s markers (about 450
//!   bytes each in memory) and `MapTargets`' targets (about 250) reserve nothing up front and grow
//!   as they decode. `tests/decode_allocation.rs` asserts a total of
//!   at most 64 × n + 4 KiB bytes over hostile payloads of every type (worst seen: about 10 × n);
//! - a string must be valid UTF-8 and end in its NUL: ROS 2 writers always write the NUL, so a
//!   missing one means a corrupt or foreign payload and is an error. A length of 0 (no NUL at
//!   all) is read as the empty string (lenient: no ROS 2 writer produces it). Bytes before the
//!   NUL may include NULs (the encoder writes a Rust string as it is, so they round-trip);
//! - a `bool` must be 0 or 1, a `char` one ASCII byte;
//! - the encapsulation must be `00 01` (plain little-endian CDR); the two option bytes are
//!   ignored (ROS 2 middlewares use them for the count of trailing padding);
//! - bytes left over after the message are accepted and ignored: ROS 2 writers may pad a
//!   message to a multiple of 4, and XCDR1 has no way to tell padding from garbage;
//! - padding bytes before an aligned field are skipped, not checked to be zero (not every
//!   writer clears them).
//!
//! Errors say what was wrong and at which byte offset, counted from the start of the payload
//! (the encapsulation header included, so offset 4 is the first byte of the message).
//!
//! Decoding checks the wire format only; whether the values make sense (finite poses, a grid
//! whose data matches its size) is [`crate::Message::check_usable`].

use serde::de::{self, DeserializeOwned, IntoDeserializer, Visitor};
use serde::Serialize;
use std::fmt;

/// Length of the encapsulation header before the message.
const HEADER_LEN: usize = 4;

/// At most this many bytes of payload per element reserved up front by a sequence (see the module
/// docs): a sequence reserves at most (bytes left) / `RESERVE_BYTES_PER_ELEMENT` elements.
const RESERVE_BYTES_PER_ELEMENT: usize = 8;

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
    #[error("malformed CDR at byte {offset}: {what}")]
    Malformed {
        /// Byte offset from the start of the payload (header included) where decoding failed.
        offset: usize,
        /// What was wrong.
        what: String,
    },
    /// The value cannot be written as CDR (a map, an `Option`, a string longer than 4 GiB…).
    #[error("cannot encode as CDR: {0}")]
    Unencodable(String),
}

/// Encodes `value` as little-endian CDR with the encapsulation header.
pub fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>, CdrError> {
    ::cdr::serialize::<_, _, ::cdr::CdrLe>(value, ::cdr::Infinite)
        .map_err(|e| CdrError::Unencodable(e.to_string()))
}

/// Decodes little-endian CDR with its encapsulation header into `T`, with the guarantees of the
/// module docs (no panic, O(n) time and allocation, every length checked before use).
pub fn decode<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, CdrError> {
    let (header, body) = match bytes.split_first_chunk::<HEADER_LEN>() {
        Some(split) => split,
        None => return Err(CdrError::TooShort(bytes.len())),
    };
    if header[0..2] != [0x00, 0x01] {
        return Err(CdrError::Encapsulation([header[0], header[1]]));
    }
    let mut deserializer = Deserializer { body, pos: 0 };
    T::deserialize(&mut deserializer).map_err(|e| CdrError::Malformed {
        // An error raised by a visitor (e.g. serde's "invalid length") carries no offset: it
        // happened where the reader stands.
        offset: e.offset.unwrap_or(HEADER_LEN + deserializer.pos),
        what: e.what,
    })
}

/// The error inside the deserializer; [`decode`] turns it into [`CdrError::Malformed`].
#[derive(Debug)]
struct DecodeError {
    /// Payload offset (header included), if the deserializer raised it.
    offset: Option<usize>,
    what: String,
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.offset {
            Some(offset) => write!(f, "at byte {offset}: {}", self.what),
            None => f.write_str(&self.what),
        }
    }
}

impl std::error::Error for DecodeError {}

impl de::Error for DecodeError {
    fn custom<M: fmt::Display>(message: M) -> Self {
        Self {
            offset: None,
            what: message.to_string(),
        }
    }
}

type Result<T, E = DecodeError> = std::result::Result<T, E>;

/// A serde deserializer over the message body (the payload after the encapsulation header);
/// `pos` never exceeds `body.len()`.
struct Deserializer<'de> {
    body: &'de [u8],
    pos: usize,
}

impl<'de> Deserializer<'de> {
    /// Payload offset (header included) of the next byte.
    fn offset(&self) -> usize {
        HEADER_LEN + self.pos
    }

    fn remaining(&self) -> usize {
        self.body.len() - self.pos
    }

    fn error_at(offset: usize, what: impl Into<String>) -> DecodeError {
        DecodeError {
            offset: Some(offset),
            what: what.into(),
        }
    }

    /// Skips the padding before a primitive of `size` bytes (1, 2, 4 or 8).
    fn align(&mut self, size: usize) -> Result<()> {
        let padding = (size - self.pos % size) % size;
        if padding > self.remaining() {
            return Err(Self::error_at(
                self.offset(),
                format!(
                    "padding to a {size}-byte boundary needs {padding} bytes, {} left",
                    self.remaining()
                ),
            ));
        }
        self.pos += padding;
        Ok(())
    }

    /// The next `len` bytes, checked to be present.
    fn take(&mut self, len: usize, what: &str) -> Result<&'de [u8]> {
        if len > self.remaining() {
            return Err(Self::error_at(
                self.offset(),
                format!("{what} needs {len} bytes, {} left", self.remaining()),
            ));
        }
        let bytes = &self.body[self.pos..self.pos + len];
        self.pos += len;
        Ok(bytes)
    }

    /// An aligned primitive of `N` bytes.
    fn read<const N: usize>(&mut self, what: &str) -> Result<[u8; N]> {
        self.align(N)?;
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N, what)?);
        Ok(out)
    }

    /// A u32 length or count prefix, checked against the bytes left after it: each of its units
    /// (a byte, an element) takes at least one byte. Returns the value and the prefix's offset.
    fn read_length(&mut self, what: &str) -> Result<(usize, usize)> {
        self.align(4)?;
        let at = self.offset();
        let length = u32::from_le_bytes(self.read::<4>(what)?) as usize;
        if length > self.remaining() {
            return Err(Self::error_at(
                at,
                format!(
                    "{what} of {length} exceeds the {} bytes left",
                    self.remaining()
                ),
            ));
        }
        Ok((length, at))
    }

    fn read_str(&mut self) -> Result<&'de str> {
        let (length, at) = self.read_length("string length")?;
        if length == 0 {
            return Ok("");
        }
        let bytes = self.take(length, "string")?;
        let Some((&last, text)) = bytes.split_last() else {
            return Ok("");
        };
        if last != 0 {
            return Err(Self::error_at(
                at + 4 + length - 1,
                "string does not end in NUL",
            ));
        }
        std::str::from_utf8(text)
            .map_err(|e| Self::error_at(at + 4 + e.valid_up_to(), "string is not valid UTF-8"))
    }

    fn unsupported(&self, what: &str) -> DecodeError {
        Self::error_at(
            self.offset(),
            format!("{what} cannot be decoded from CDR (not self-describing, or no CDR form)"),
        )
    }
}

/// Elements of a sequence, tuple, struct or variant, `left` of them still to read.
struct Elements<'a, 'de> {
    de: &'a mut Deserializer<'de>,
    left: usize,
    /// What to tell serde to reserve: bounded by the bytes left, never by the wire's count alone.
    reserve: usize,
}

impl<'de> de::SeqAccess<'de> for Elements<'_, 'de> {
    type Error = DecodeError;

    fn next_element_seed<S: de::DeserializeSeed<'de>>(
        &mut self,
        seed: S,
    ) -> Result<Option<S::Value>> {
        if self.left == 0 {
            return Ok(None);
        }
        self.left -= 1;
        seed.deserialize(&mut *self.de).map(Some)
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.reserve)
    }
}

impl<'de> Deserializer<'de> {
    /// `count` elements whose count comes from the type (a tuple, a struct), not from the wire.
    fn fixed(&mut self, count: usize) -> Elements<'_, 'de> {
        let reserve = count.min(self.remaining() / RESERVE_BYTES_PER_ELEMENT);
        Elements {
            de: self,
            left: count,
            reserve,
        }
    }
}

macro_rules! primitive {
    ($method:ident, $visit:ident, $ty:ty) => {
        fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
            let bytes = self.read::<{ std::mem::size_of::<$ty>() }>(stringify!($ty))?;
            visitor.$visit(<$ty>::from_le_bytes(bytes))
        }
    };
}

impl<'de> de::Deserializer<'de> for &mut Deserializer<'de> {
    type Error = DecodeError;

    primitive!(deserialize_i8, visit_i8, i8);
    primitive!(deserialize_i16, visit_i16, i16);
    primitive!(deserialize_i32, visit_i32, i32);
    primitive!(deserialize_i64, visit_i64, i64);
    primitive!(deserialize_u8, visit_u8, u8);
    primitive!(deserialize_u16, visit_u16, u16);
    primitive!(deserialize_u32, visit_u32, u32);
    primitive!(deserialize_u64, visit_u64, u64);
    primitive!(deserialize_f32, visit_f32, f32);
    primitive!(deserialize_f64, visit_f64, f64);

    fn deserialize_bool<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let at = self.offset();
        match self.read::<1>("bool")? {
            [0] => visitor.visit_bool(false),
            [1] => visitor.visit_bool(true),
            [other] => Err(Self::Error::custom_at(
                at,
                format!("bool byte is {other}, not 0 or 1"),
            )),
        }
    }

    fn deserialize_char<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let at = self.offset();
        let [byte] = self.read::<1>("char")?;
        if !byte.is_ascii() {
            return Err(Self::Error::custom_at(
                at,
                format!("char byte {byte:#04x} is not ASCII"),
            ));
        }
        visitor.visit_char(char::from(byte))
    }

    fn deserialize_str<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_borrowed_str(self.read_str()?)
    }

    fn deserialize_string<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_borrowed_str(self.read_str()?)
    }

    fn deserialize_bytes<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let (length, _) = self.read_length("byte sequence count")?;
        visitor.visit_borrowed_bytes(self.take(length, "byte sequence")?)
    }

    fn deserialize_byte_buf<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.deserialize_bytes(visitor)
    }

    fn deserialize_unit<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        visitor.visit_unit()
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value> {
        visitor.visit_unit()
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let (count, _) = self.read_length("sequence count")?;
        visitor.visit_seq(self.fixed(count))
    }

    fn deserialize_tuple<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value> {
        visitor.visit_seq(self.fixed(len))
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        len: usize,
        visitor: V,
    ) -> Result<V::Value> {
        visitor.visit_seq(self.fixed(len))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        visitor.visit_seq(self.fixed(fields.len()))
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        visitor.visit_enum(self)
    }

    fn deserialize_option<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(self.unsupported("an Option"))
    }

    fn deserialize_map<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(self.unsupported("a map"))
    }

    fn deserialize_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(self.unsupported("a value of unknown type"))
    }

    fn deserialize_identifier<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(self.unsupported("a field name"))
    }

    fn deserialize_ignored_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(self.unsupported("an ignored value"))
    }

    fn is_human_readable(&self) -> bool {
        false
    }
}

impl DecodeError {
    fn custom_at(offset: usize, what: String) -> Self {
        Deserializer::error_at(offset, what)
    }
}

impl<'de> de::EnumAccess<'de> for &mut Deserializer<'de> {
    type Error = DecodeError;
    type Variant = Self;

    fn variant_seed<S: de::DeserializeSeed<'de>>(self, seed: S) -> Result<(S::Value, Self)> {
        let index = u32::from_le_bytes(self.read::<4>("enum variant index")?);
        let variant =
            seed.deserialize(IntoDeserializer::<DecodeError>::into_deserializer(index))?;
        Ok((variant, self))
    }
}

impl<'de> de::VariantAccess<'de> for &mut Deserializer<'de> {
    type Error = DecodeError;

    fn unit_variant(self) -> Result<()> {
        Ok(())
    }

    fn newtype_variant_seed<S: de::DeserializeSeed<'de>>(self, seed: S) -> Result<S::Value> {
        seed.deserialize(self)
    }

    fn tuple_variant<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value> {
        visitor.visit_seq(self.fixed(len))
    }

    fn struct_variant<V: Visitor<'de>>(
        self,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        visitor.visit_seq(self.fixed(fields.len()))
    }
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
            Err(CdrError::Malformed { offset: 4, .. })
        ));
    }

    /// The `/slam/pose` messages of the rosbags-written bag `v9_plain` (fixture README): 20 poses
    /// at t = 100 + 0.5 k s, x = 0.5 k m, frame "map".
    #[test]
    fn pose_stamped_written_by_rosbags_decode_and_reencode_identically() {
        let lines: Vec<&str> = include_str!("../tests/fixtures/bag_v9_plain_slam_pose.hex")
            .lines()
            .collect();
        assert_eq!(lines.len(), 20);
        for (k, line) in lines.iter().enumerate() {
            let bytes: Vec<u8> = (0..line.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&line[i..i + 2], 16).unwrap())
                .collect();
            let pose: PoseStamped = decode(&bytes).unwrap();
            assert_eq!(
                pose.header.stamp,
                Time::from_seconds(100.0 + 0.5 * k as f64)
            );
            assert_eq!(pose.header.frame_id, "map");
            assert_eq!(pose.pose, Pose::from_planar(0.5 * k as f64, 0.0, 0.0));
            assert_eq!(hex(&encode(&pose).unwrap()), *line);
        }
    }

    /// Issue 13: header, a stamp, then a frame_id length of 0xffffffff. The `cdr` crate reserved
    /// 4.1 GB for it.
    pub(crate) const HUGE_STRING_GRID: [u8; 19] = [
        0x00, 0x01, 0x00, 0x00, 0x64, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff, b'm', b'a', b'p',
    ];

    #[test]
    fn a_string_length_beyond_the_payload_is_refused_where_it_stands() {
        let started = std::time::Instant::now();
        let error = decode::<OccupancyGrid>(&HUGE_STRING_GRID).unwrap_err();
        assert!(started.elapsed() < std::time::Duration::from_millis(100));
        let CdrError::Malformed { offset, what } = &error else {
            panic!("{error}")
        };
        assert_eq!(*offset, 12, "{error}");
        assert!(what.contains("4294967295"), "{error}");
    }

    fn clock_and_more(tail: &[u8]) -> Vec<u8> {
        let mut bytes = encode(&Clock {
            clock: Time { sec: 7, nanosec: 9 },
        })
        .unwrap();
        bytes.extend_from_slice(tail);
        bytes
    }

    #[test]
    fn trailing_bytes_are_ignored() {
        let clock: Clock = decode(&clock_and_more(&[0, 0, 0, 0xaa])).unwrap();
        assert_eq!(clock.clock, Time { sec: 7, nanosec: 9 });
    }

    fn header_bytes(frame_id_field: &[u8]) -> Vec<u8> {
        // Header: stamp (8 bytes) then the string as given.
        let mut bytes = vec![0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0];
        bytes.extend_from_slice(frame_id_field);
        bytes
    }

    #[test]
    fn strings_need_their_nul_and_utf8() {
        let ok: Header = decode(&header_bytes(&[4, 0, 0, 0, b'm', b'a', b'p', 0])).unwrap();
        assert_eq!(ok.frame_id, "map");
        let empty: Header = decode(&header_bytes(&[0, 0, 0, 0])).unwrap();
        assert_eq!(empty.frame_id, "");
        let no_nul = decode::<Header>(&header_bytes(&[4, 0, 0, 0, b'm', b'a', b'p', b'!']));
        assert!(
            matches!(&no_nul, Err(CdrError::Malformed { offset: 19, what }) if what.contains("NUL")),
            "{no_nul:?}"
        );
        let bad_utf8 = decode::<Header>(&header_bytes(&[4, 0, 0, 0, b'm', 0xff, b'p', 0]));
        assert!(
            matches!(&bad_utf8, Err(CdrError::Malformed { offset: 17, what }) if what.contains("UTF-8")),
            "{bad_utf8:?}"
        );
        let short = decode::<Header>(&header_bytes(&[5, 0, 0, 0, b'm', b'a', b'p', 0]));
        assert!(
            matches!(&short, Err(CdrError::Malformed { offset: 12, .. })),
            "{short:?}"
        );
    }

    #[test]
    fn bools_are_zero_or_one() {
        let stats = AssociationStats {
            odometry_rejected: true,
            ..Default::default()
        };
        let mut bytes = encode(&stats).unwrap();
        let back: AssociationStats = decode(&bytes).unwrap();
        assert!(back.odometry_rejected);
        let at = bytes.iter().rposition(|&b| b == 1).unwrap();
        // The last 1 byte written is the bool (loop_closures and the rest are 0).
        bytes[at] = 2;
        let error = decode::<AssociationStats>(&bytes).unwrap_err();
        assert!(
            matches!(&error, CdrError::Malformed { offset, what } if *offset == at && what.contains("bool")),
            "{error}"
        );
    }

    #[test]
    fn a_sequence_count_beyond_the_payload_is_refused_before_reading_elements() {
        let grid = OccupancyGrid {
            data: vec![1, 2, 3],
            ..Default::default()
        };
        let mut bytes = encode(&grid).unwrap();
        let count_at = bytes.len() - 3 - 4;
        assert_eq!(bytes[count_at..count_at + 4], [3, 0, 0, 0]);
        bytes[count_at] = 4;
        let error = decode::<OccupancyGrid>(&bytes).unwrap_err();
        assert!(
            matches!(&error, CdrError::Malformed { offset, .. } if *offset == count_at),
            "{error}"
        );
        // A count within the bytes left, but elements that run out: refused where they do.
        let mut poses = encode(&KeyframePoses {
            poses: vec![Pose::default(); 2],
            ..Default::default()
        })
        .unwrap();
        let len = poses.len();
        poses.truncate(len - 60);
        assert!(matches!(
            decode::<KeyframePoses>(&poses),
            Err(CdrError::Malformed { .. })
        ));
    }

    #[test]
    fn enums_follow_the_encoder() {
        #[derive(Debug, PartialEq, Serialize, serde::Deserialize)]
        enum Shape {
            Dot,
            Circle(f64),
            Box { w: u8, h: u32 },
        }
        for shape in [Shape::Dot, Shape::Circle(2.5), Shape::Box { w: 3, h: 9 }] {
            let bytes = encode(&shape).unwrap();
            assert_eq!(decode::<Shape>(&bytes).unwrap(), shape);
        }
        let error = decode::<Shape>(&[0, 1, 0, 0, 5, 0, 0, 0]).unwrap_err();
        assert!(matches!(error, CdrError::Malformed { .. }), "{error}");
    }

    #[test]
    fn shapes_without_a_cdr_form_are_errors() {
        assert!(matches!(
            decode::<Option<u32>>(&[0, 1, 0, 0, 1, 0, 0, 0]),
            Err(CdrError::Malformed { offset: 4, .. })
        ));
        assert!(matches!(
            decode::<std::collections::BTreeMap<u32, u32>>(&[0, 1, 0, 0, 0, 0, 0, 0]),
            Err(CdrError::Malformed { .. })
        ));
        assert!(matches!(encode(&Some(1u32)), Err(CdrError::Unencodable(_))));
    }
}
