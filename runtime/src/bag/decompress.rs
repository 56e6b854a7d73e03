//! Bounded decompression of MCAP chunks (`zstd`, `lz4` frames, what rosbag2's `zstd_fast` /
//! `zstd_small` presets and the mcap writers produce).
//!
//! A chunk declares its uncompressed size. That size is checked against
//! [`MAX_DECOMPRESSED_CHUNK_BYTES`] before anything is allocated, and the decompressor's output is
//! read through a limit of one byte more than declared into a buffer that grows only as output
//! actually arrives (never past the declared size plus one): a chunk that inflates beyond what it
//! declared (a decompression bomb) is an error after at most that many bytes, a chunk that
//! produces fewer bytes is an error too. The decoders are the reference C libraries (libzstd
//! through the `zstd` crate, liblz4 through `lz4`), the same the `mcap` crate writes with.

use std::io::Read;

/// Largest uncompressed size a compressed chunk may declare (it is held in memory whole).
/// rosbag2 cuts chunks at 768 KiB by default and the mcap libraries at 1 MiB; a chunk holding one
/// very large message may exceed that, hence the margin.
pub const MAX_DECOMPRESSED_CHUNK_BYTES: u64 = 256 << 20;

/// Chunk compressions this reader and the writer support.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    /// Uncompressed chunks (`ros2 bag record`'s default).
    #[default]
    None,
    /// Zstandard frames.
    Zstd,
    /// LZ4 frames.
    Lz4,
}

impl Compression {
    /// The MCAP chunk compression string: `""`, `"zstd"`, `"lz4"`.
    pub fn mcap_name(self) -> &'static str {
        match self {
            Compression::None => "",
            Compression::Zstd => "zstd",
            Compression::Lz4 => "lz4",
        }
    }

    /// Parses an MCAP chunk compression string.
    pub fn from_mcap_name(name: &str) -> Option<Self> {
        match name {
            "" => Some(Compression::None),
            "zstd" => Some(Compression::Zstd),
            "lz4" => Some(Compression::Lz4),
            _ => None,
        }
    }
}

impl std::str::FromStr for Compression {
    type Err = String;

    /// `none`, `zstd` or `lz4` (the command line's spelling).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "none" | "" => Ok(Compression::None),
            "zstd" => Ok(Compression::Zstd),
            "lz4" => Ok(Compression::Lz4),
            other => Err(format!(
                "unknown compression {other:?} (allowed: none, zstd, lz4)"
            )),
        }
    }
}

impl std::fmt::Display for Compression {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Compression::None => "none",
            Compression::Zstd => "zstd",
            Compression::Lz4 => "lz4",
        })
    }
}

/// Decompresses a chunk's records (`compressed`, compression `name`) that declare
/// `declared` bytes uncompressed; `out` is cleared and filled. Errors name what was wrong.
pub(crate) fn decompress(
    name: &str,
    compressed: &[u8],
    declared: u64,
    out: &mut Vec<u8>,
) -> Result<(), String> {
    let compression = Compression::from_mcap_name(name).ok_or_else(|| {
        format!("chunk compressed with {name:?}: only zstd and lz4 are supported")
    })?;
    if declared > MAX_DECOMPRESSED_CHUNK_BYTES {
        return Err(format!(
            "{name} chunk declares {declared} bytes uncompressed, over the \
             {MAX_DECOMPRESSED_CHUNK_BYTES}-byte limit"
        ));
    }
    out.clear();
    match compression {
        Compression::None => {
            return Err("decompress called on an uncompressed chunk".into());
        }
        Compression::Zstd => {
            let mut decoder = zstd::stream::read::Decoder::with_buffer(compressed)
                .map_err(|e| format!("zstd: {e}"))?;
            read_bounded(&mut decoder, declared, out).map_err(|e| format!("zstd: {e}"))?;
        }
        Compression::Lz4 => {
            let mut decoder = lz4::Decoder::new(compressed).map_err(|e| format!("lz4: {e}"))?;
            read_bounded(&mut decoder, declared, out).map_err(|e| format!("lz4: {e}"))?;
            // liblz4 hands out a truncated frame's bytes without complaint; the frame must end.
            if out.len() as u64 == declared {
                decoder
                    .finish()
                    .1
                    .map_err(|_| "lz4: the frame is cut off before its end mark".to_owned())?;
            }
        }
    }
    let produced = out.len() as u64;
    if produced > declared {
        out.clear();
        out.shrink_to_fit();
        return Err(format!(
            "{name} chunk inflates past the {declared} bytes it declares (decompression bomb or \
             damaged size)"
        ));
    }
    if produced < declared {
        return Err(format!(
            "{name} chunk declares {declared} bytes uncompressed, decompresses to {produced}"
        ));
    }
    Ok(())
}

/// Reads at most `declared + 1` bytes from `reader`, growing `out` only as bytes arrive and never
/// beyond that.
fn read_bounded(reader: impl Read, declared: u64, out: &mut Vec<u8>) -> std::io::Result<()> {
    const STEP: usize = 64 * 1024;
    let cap = (declared + 1) as usize;
    let mut limited = reader.take(declared + 1);
    loop {
        if out.len() == out.capacity() {
            // Never `clamp(STEP, cap)`: a chunk smaller than STEP has cap < STEP.
            let want = (out.capacity() * 2).max(STEP).min(cap);
            if want <= out.len() {
                return Ok(());
            }
            out.reserve_exact(want - out.len());
        }
        let start = out.len();
        let room = out.capacity() - start;
        out.resize(start + room, 0);
        let n = loop {
            match limited.read(&mut out[start..]) {
                Ok(n) => break n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
                Err(e) => {
                    out.truncate(start);
                    return Err(e);
                }
            }
        };
        out.truncate(start + n);
        if n == 0 {
            return Ok(());
        }
    }
}

/// Compresses `data` (tests and fixtures).
#[cfg(test)]
pub(crate) fn compress(compression: Compression, data: &[u8]) -> Vec<u8> {
    use std::io::Write;
    match compression {
        Compression::None => data.to_vec(),
        Compression::Zstd => zstd::bulk::compress(data, 3).unwrap(),
        Compression::Lz4 => {
            let mut encoder = lz4::EncoderBuilder::new().build(Vec::new()).unwrap();
            encoder.write_all(data).unwrap();
            let (bytes, result) = encoder.finish();
            result.unwrap();
            bytes
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<u8> {
        (0..100_000u32)
            .flat_map(|i| (i % 251).to_le_bytes())
            .collect()
    }

    #[test]
    fn zstd_and_lz4_round_trip_at_the_declared_size() {
        let data = sample();
        for c in [Compression::Zstd, Compression::Lz4] {
            let packed = compress(c, &data);
            assert!(packed.len() < data.len() / 4, "{c}: {}", packed.len());
            let mut out = Vec::new();
            decompress(c.mcap_name(), &packed, data.len() as u64, &mut out).unwrap();
            assert_eq!(out, data, "{c}");
        }
    }

    #[test]
    fn chunks_of_every_size_round_trip_including_those_under_one_growth_step() {
        let data = sample();
        for len in [0, 1, 2, 100, 4357, 65_535, 65_536, 65_537, 200_001] {
            for c in [Compression::Zstd, Compression::Lz4] {
                let packed = compress(c, &data[..len]);
                let mut out = Vec::new();
                decompress(c.mcap_name(), &packed, len as u64, &mut out).unwrap();
                assert_eq!(out, &data[..len], "{c} {len}");
            }
        }
    }

    #[test]
    fn a_bomb_stops_one_byte_past_its_declared_size() {
        // 64 MiB of zeros packs into a few KiB; declared as 1 MiB it must fail without producing
        // (or allocating) the 64 MiB.
        let zeros = vec![0u8; 64 << 20];
        for c in [Compression::Zstd, Compression::Lz4] {
            let packed = compress(c, &zeros);
            assert!(packed.len() < 1 << 20, "{c}: {}", packed.len());
            let mut out = Vec::new();
            let error = decompress(c.mcap_name(), &packed, 1 << 20, &mut out).unwrap_err();
            assert!(error.contains("inflates past"), "{c}: {error}");
            assert!(out.capacity() <= (1 << 20) + 1, "{c}: {}", out.capacity());
        }
    }

    #[test]
    fn declared_sizes_are_checked_against_the_limit_and_the_output() {
        let data = sample();
        let packed = compress(Compression::Zstd, &data);
        let mut out = Vec::new();
        let error = decompress("zstd", &packed, u64::MAX, &mut out).unwrap_err();
        assert!(error.contains("over the"), "{error}");
        assert_eq!(out.capacity(), 0, "nothing allocated for a garbage size");
        let error = decompress("zstd", &packed, data.len() as u64 + 10, &mut out).unwrap_err();
        assert!(error.contains("decompresses to 400000"), "{error}");
        let error = decompress("brotli", &packed, 10, &mut out).unwrap_err();
        assert!(error.contains("only zstd and lz4"), "{error}");
        // Garbage and truncated input are errors, never a panic.
        for c in [Compression::Zstd, Compression::Lz4] {
            let packed = compress(c, &data);
            for cut in [0, 1, 5, packed.len() / 2, packed.len() - 1] {
                assert!(
                    decompress(c.mcap_name(), &packed[..cut], data.len() as u64, &mut out).is_err(),
                    "{c} cut at {cut}"
                );
            }
            let mut flipped = packed.clone();
            let mid = flipped.len() / 2;
            flipped[mid] ^= 0x5a;
            let result = decompress(c.mcap_name(), &flipped, data.len() as u64, &mut out);
            // A flipped bit either fails or yields different bytes (the chunk CRC catches those).
            assert!(result.is_err() || out != data, "{c}");
        }
    }
}
