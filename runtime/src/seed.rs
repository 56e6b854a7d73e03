//! Seed derivation: one run seed fans out into independent, named streams.
//!
//! SplitMix64 over the seed and an FNV-1a hash of the stream name: cheap, portable, and the same on
//! every platform and thread count (no `std` hasher, whose output may change between releases).

fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn fnv1a(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |hash, byte| {
        (hash ^ byte as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// The seed of stream `name` under run seed `seed`.
pub fn derive(seed: u64, name: &str) -> u64 {
    splitmix64(splitmix64(seed) ^ fnv1a(name))
}

/// The run seed of Monte Carlo trial `index` under base seed `seed`.
pub fn trial(seed: u64, index: u64) -> u64 {
    splitmix64(seed ^ splitmix64(index.wrapping_add(0x5EED)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_and_seeds_differ() {
        assert_ne!(derive(1, "radar"), derive(1, "odometry"));
        assert_ne!(derive(1, "radar"), derive(2, "radar"));
        assert_eq!(derive(7, "radar"), derive(7, "radar"));
        assert_ne!(trial(1, 0), trial(1, 1));
    }
}
