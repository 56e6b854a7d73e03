//! The MCAP records the reader needs, parsed from byte slices with every length checked against
//! the bytes present. The `mcap` crate writes our bags, but its record parsers reserve a string's
//! declared length (up to 4 GiB) before reading it, so reading untrusted files goes through here.
//!
//! Layout (MCAP v0): after the 8-byte magic, records of `opcode: u8, length: u64 LE, body`.
//! Strings are `u32 length + UTF-8`, maps and arrays are `u32 byte length + entries`.

/// Record opcodes.
pub(crate) mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const MESSAGE_INDEX: u8 = 0x07;
    pub const CHUNK_INDEX: u8 = 0x08;
    pub const STATISTICS: u8 = 0x0B;
    pub const METADATA: u8 = 0x0C;
    pub const METADATA_INDEX: u8 = 0x0D;
    pub const DATA_END: u8 = 0x0F;
}

/// The 8 bytes at both ends of an MCAP file.
pub(crate) const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// Opcode and length in front of every record.
pub(crate) const RECORD_PREFIX: u64 = 9;
/// A chunk's fixed header fields (times, sizes, CRC, compression string length) and, after the
/// compression string, the records length.
pub(crate) const CHUNK_FIXED: u64 = 8 + 8 + 8 + 4 + 4 + 8;
/// A footer record's body.
pub(crate) const FOOTER_BODY: u64 = 8 + 8 + 4;
/// Longest compression name accepted ("zstd", "lz4", "" in practice; others are refused by the
/// reader by name).
pub(crate) const MAX_COMPRESSION_NAME: u32 = 64;

/// Whether `opcode` is one the MCAP specification defines.
pub(crate) fn known_opcode(opcode: u8) -> bool {
    (op::HEADER..=op::DATA_END).contains(&opcode)
}

/// A cursor over a record body; every read checks the bytes left.
pub(crate) struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
}

pub(crate) type ParseResult<T> = Result<T, String>;

impl<'a> Cursor<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, pos: 0 }
    }

    pub(crate) fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    pub(crate) fn position(&self) -> usize {
        self.pos
    }

    pub(crate) fn take(&mut self, n: u64, what: &str) -> ParseResult<&'a [u8]> {
        let left = self.remaining();
        if n > left as u64 {
            return Err(format!(
                "{what}: {n} bytes declared, {left} present at record byte {}",
                self.pos
            ));
        }
        let n = n as usize;
        let out = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(out)
    }

    fn array<const N: usize>(&mut self, what: &str) -> ParseResult<[u8; N]> {
        let bytes = self.take(N as u64, what)?;
        let mut out = [0u8; N];
        out.copy_from_slice(bytes);
        Ok(out)
    }

    pub(crate) fn u8(&mut self, what: &str) -> ParseResult<u8> {
        Ok(self.array::<1>(what)?[0])
    }

    pub(crate) fn u16(&mut self, what: &str) -> ParseResult<u16> {
        Ok(u16::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn u32(&mut self, what: &str) -> ParseResult<u32> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn u64(&mut self, what: &str) -> ParseResult<u64> {
        Ok(u64::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn string(&mut self, what: &str) -> ParseResult<&'a str> {
        let len = self.u32(what)?;
        let bytes = self.take(u64::from(len), what)?;
        std::str::from_utf8(bytes).map_err(|_| format!("{what}: not UTF-8"))
    }

    /// A `u32 byte length` prefixed region, as its own cursor.
    pub(crate) fn region(&mut self, what: &str) -> ParseResult<Cursor<'a>> {
        let len = self.u32(what)?;
        Ok(Cursor::new(self.take(u64::from(len), what)?))
    }

    pub(crate) fn rest(&mut self) -> &'a [u8] {
        let out = &self.bytes[self.pos..];
        self.pos = self.bytes.len();
        out
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.remaining() == 0
    }
}

/// A Schema record: the ROS 2 type name, its encoding (`ros2msg`, `ros2idl`) and definition,
/// kept so a topic of a type outside the catalogue can be played and re-recorded as it was.
pub(crate) struct Schema<'a> {
    pub id: u16,
    pub name: &'a str,
    pub encoding: &'a str,
    pub data: &'a [u8],
}

pub(crate) fn schema(body: &[u8]) -> ParseResult<Schema<'_>> {
    let mut c = Cursor::new(body);
    let id = c.u16("schema id")?;
    let name = c.string("schema name")?;
    let encoding = c.string("schema encoding")?;
    let data_len = c.u32("schema data")?;
    let data = c.take(u64::from(data_len), "schema data")?;
    Ok(Schema {
        id,
        name,
        encoding,
        data,
    })
}

/// A Channel record.
pub(crate) struct Channel<'a> {
    pub id: u16,
    pub schema_id: u16,
    pub topic: &'a str,
    pub message_encoding: &'a str,
    /// `offered_qos_profiles`, `topic_type_hash`, ... as rosbag2 writes them.
    pub metadata: std::collections::BTreeMap<String, String>,
}

pub(crate) fn channel(body: &[u8]) -> ParseResult<Channel<'_>> {
    let mut c = Cursor::new(body);
    let id = c.u16("channel id")?;
    let schema_id = c.u16("channel schema id")?;
    let topic = c.string("channel topic")?;
    let message_encoding = c.string("channel message encoding")?;
    let mut map = c.region("channel metadata")?;
    let mut metadata = std::collections::BTreeMap::new();
    while !map.is_empty() {
        let key = map.string("channel metadata key")?;
        let value = map.string("channel metadata value")?;
        metadata.insert(key.to_owned(), value.to_owned());
    }
    Ok(Channel {
        id,
        schema_id,
        topic,
        message_encoding,
        metadata,
    })
}

/// A Message record.
pub(crate) struct Message<'a> {
    pub channel_id: u16,
    pub log_time: u64,
    pub data: &'a [u8],
}

pub(crate) fn message(body: &[u8]) -> ParseResult<Message<'_>> {
    let mut c = Cursor::new(body);
    let channel_id = c.u16("message channel id")?;
    c.u32("message sequence")?;
    let log_time = c.u64("message log time")?;
    c.u64("message publish time")?;
    Ok(Message {
        channel_id,
        log_time,
        data: c.rest(),
    })
}

/// A Chunk record's header (what precedes its records).
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ChunkHeader {
    pub uncompressed_size: u64,
    pub uncompressed_crc: u32,
    pub compression: String,
    pub records_len: u64,
    /// Bytes of the header within the record body.
    pub header_len: u64,
}

/// Parses a chunk header from the start of a chunk body of `record_len` bytes; `head` holds at
/// least the fixed fields and, if present, the compression string.
pub(crate) fn chunk_header(head: &[u8], record_len: u64) -> ParseResult<ChunkHeader> {
    let mut c = Cursor::new(head);
    let start = c.u64("chunk start time")?;
    let end = c.u64("chunk end time")?;
    let uncompressed_size = c.u64("chunk uncompressed size")?;
    let uncompressed_crc = c.u32("chunk CRC")?;
    let compression_len = c.u32("chunk compression")?;
    if compression_len > MAX_COMPRESSION_NAME {
        return Err(format!(
            "chunk compression name of {compression_len} bytes (garbage length)"
        ));
    }
    let compression = std::str::from_utf8(c.take(u64::from(compression_len), "chunk compression")?)
        .map_err(|_| "chunk compression name is not UTF-8".to_owned())?
        .to_owned();
    let records_len = c.u64("chunk records length")?;
    let header_len = CHUNK_FIXED + u64::from(compression_len);
    if start > end {
        return Err(format!("chunk start time {start} after its end time {end}"));
    }
    if header_len.checked_add(records_len) != Some(record_len) {
        return Err(format!(
            "chunk records length {records_len} does not fit its record length {record_len}"
        ));
    }
    if compression.is_empty() && uncompressed_size != records_len {
        return Err(format!(
            "uncompressed chunk declares {uncompressed_size} bytes but holds {records_len}"
        ));
    }
    Ok(ChunkHeader {
        uncompressed_size,
        uncompressed_crc,
        compression,
        records_len,
        header_len,
    })
}

/// Entries of a Message Index record (16 bytes each).
pub(crate) fn message_index_entries(body: &[u8]) -> ParseResult<u64> {
    let mut c = Cursor::new(body);
    c.u16("message index channel id")?;
    let entries = c.region("message index entries")?;
    if entries.remaining() % 16 != 0 || !c.is_empty() {
        return Err("message index entries are not 16-byte pairs".into());
    }
    Ok(entries.remaining() as u64 / 16)
}

/// A Chunk Index record of the summary.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ChunkIndex {
    pub start_offset: u64,
    pub length: u64,
    /// Offsets of the chunk's Message Index records.
    pub message_index_offsets: Vec<u64>,
    pub message_index_length: u64,
    /// The chunk's compression (`""`, `zstd`, `lz4`).
    pub compression: String,
}

pub(crate) fn chunk_index(body: &[u8]) -> ParseResult<ChunkIndex> {
    let mut c = Cursor::new(body);
    c.u64("chunk index start time")?;
    c.u64("chunk index end time")?;
    let start_offset = c.u64("chunk index offset")?;
    let length = c.u64("chunk index length")?;
    let mut map = c.region("chunk index message index offsets")?;
    let mut message_index_offsets = Vec::new();
    while !map.is_empty() {
        map.u16("chunk index channel")?;
        message_index_offsets.push(map.u64("chunk index message index offset")?);
    }
    let message_index_length = c.u64("chunk index message index length")?;
    let compression = c.string("chunk index compression")?.to_owned();
    c.u64("chunk index compressed size")?;
    c.u64("chunk index uncompressed size")?;
    Ok(ChunkIndex {
        start_offset,
        length,
        message_index_offsets,
        message_index_length,
        compression,
    })
}

/// A Statistics record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Statistics {
    pub message_count: u64,
    pub chunk_count: u32,
    pub message_start_time: u64,
    pub message_end_time: u64,
    pub channel_message_counts: Vec<(u16, u64)>,
}

pub(crate) fn statistics(body: &[u8]) -> ParseResult<Statistics> {
    let mut c = Cursor::new(body);
    let message_count = c.u64("statistics message count")?;
    c.u16("statistics schema count")?;
    c.u32("statistics channel count")?;
    c.u32("statistics attachment count")?;
    c.u32("statistics metadata count")?;
    let chunk_count = c.u32("statistics chunk count")?;
    let message_start_time = c.u64("statistics start time")?;
    let message_end_time = c.u64("statistics end time")?;
    let mut map = c.region("statistics channel message counts")?;
    let mut channel_message_counts = Vec::new();
    while !map.is_empty() {
        let channel = map.u16("statistics channel")?;
        channel_message_counts.push((channel, map.u64("statistics channel count")?));
    }
    Ok(Statistics {
        message_count,
        chunk_count,
        message_start_time,
        message_end_time,
        channel_message_counts,
    })
}

/// A Metadata record: name and key/value pairs.
pub(crate) fn metadata(
    body: &[u8],
) -> ParseResult<(String, std::collections::BTreeMap<String, String>)> {
    let mut c = Cursor::new(body);
    let name = c.string("metadata name")?.to_owned();
    let mut map = c.region("metadata map")?;
    let mut out = std::collections::BTreeMap::new();
    while !map.is_empty() {
        let key = map.string("metadata key")?.to_owned();
        let value = map.string("metadata value")?.to_owned();
        out.insert(key, value);
    }
    Ok((name, out))
}

/// A Metadata Index record: offset, length and name of a Metadata record.
pub(crate) fn metadata_index(body: &[u8]) -> ParseResult<(u64, u64, String)> {
    let mut c = Cursor::new(body);
    let offset = c.u64("metadata index offset")?;
    let length = c.u64("metadata index length")?;
    let name = c.string("metadata index name")?.to_owned();
    Ok((offset, length, name))
}

/// A Footer record: summary start, summary offset start, summary CRC.
pub(crate) fn footer(body: &[u8]) -> ParseResult<(u64, u64, u32)> {
    let mut c = Cursor::new(body);
    Ok((
        c.u64("footer summary start")?,
        c.u64("footer summary offset start")?,
        c.u32("footer summary CRC")?,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn declared_lengths_beyond_the_bytes_present_are_errors_not_allocations() {
        // A schema whose name claims 4 GiB.
        let mut body = vec![1, 0];
        body.extend_from_slice(&u32::MAX.to_le_bytes());
        body.extend_from_slice(b"abc");
        let error = schema(&body).err().unwrap();
        assert!(
            error.contains("4294967295 bytes declared, 3 present"),
            "{error}"
        );
        // A channel whose metadata map claims more than is there.
        let mut body = vec![1, 0, 1, 0, 1, 0, 0, 0, b'/', 3, 0, 0, 0];
        body.extend_from_slice(b"cdr");
        body.extend_from_slice(&1000u32.to_le_bytes());
        assert!(channel(&body).is_err());
        // A chunk header whose records length disagrees with its record.
        let mut head = Vec::new();
        for v in [1u64, 2, 10] {
            head.extend_from_slice(&v.to_le_bytes());
        }
        head.extend_from_slice(&0u32.to_le_bytes());
        head.extend_from_slice(&0u32.to_le_bytes());
        head.extend_from_slice(&10u64.to_le_bytes());
        assert!(chunk_header(&head, CHUNK_FIXED + 10).is_ok());
        assert!(chunk_header(&head, CHUNK_FIXED + 11).is_err());
        assert!(chunk_header(&head, u64::MAX).is_err());
        head[24..28].copy_from_slice(&0u32.to_le_bytes());
        head[28..32].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(chunk_header(&head, CHUNK_FIXED + 10)
            .unwrap_err()
            .contains("garbage length"));
    }
}
