//! Decoding hostile bytes: for every catalogue type, random byte strings and mutated valid
//! encodings (bit flips, truncation, length fields overwritten with huge values, insertions,
//! deletions) decode to `Ok` or `Err`, never a panic, and whatever decodes can be checked with
//! `check_usable` without a panic. `examples/fuzz_decode.rs` runs the same inputs by the million.

mod common;

use common::{fuzz_input, mutate_once, random_message, receive, Rng};
use nrslam_msgs::*;
use proptest::prelude::*;

fn type_name() -> impl Strategy<Value = &'static str> {
    proptest::sample::select(Message::TYPE_NAMES)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1500, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(name in type_name(), mut bytes in proptest::collection::vec(any::<u8>(), 0..300), with_header in any::<bool>()) {
        if with_header && bytes.len() >= 4 {
            bytes[..4].copy_from_slice(&[0, 1, 0, 0]);
        }
        receive(name, &bytes);
    }

    #[test]
    fn mutated_encodings_never_panic(name in type_name(), seed in any::<u64>(), mutations in 1usize..6) {
        let mut rng = Rng::new(seed);
        let mut bytes = random_message(name, &mut rng).encode().unwrap();
        for _ in 0..mutations {
            mutate_once(&mut bytes, &mut rng);
        }
        receive(name, &bytes);
    }
}

/// Every prefix of every type's encoding is refused (the message is not complete), and every
/// 4-aligned word overwritten with u32::MAX either decodes or is an error: the exhaustive
/// version of the two mutations that broke the `cdr` crate.
#[test]
fn every_truncation_and_every_huge_word_of_every_type() {
    let mut rng = Rng::new(13);
    for name in Message::TYPE_NAMES {
        for _ in 0..10 {
            let bytes = random_message(name, &mut rng).encode().unwrap();
            for len in 0..bytes.len() {
                assert!(
                    Message::decode(name, &bytes[..len]).is_err(),
                    "{name}: prefix of {len} of {} bytes decoded",
                    bytes.len()
                );
            }
            for at in (4..bytes.len().saturating_sub(3)).step_by(4) {
                let mut spoiled = bytes.clone();
                spoiled[at..at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
                receive(name, &spoiled);
            }
        }
    }
}

/// A fixed-seed slice of the long run, so that `cargo test` covers its input mix too; most
/// mutated inputs must be refused and some must still decode (else the mutations would be
/// testing nothing but the header check, or nothing at all).
#[test]
fn seeded_mix_of_inputs() {
    let mut rng = Rng::new(0x5eed);
    let (mut ok, mut err) = (0, 0);
    for _ in 0..5000 {
        let (name, bytes) = fuzz_input(&mut rng);
        if receive(name, &bytes) {
            ok += 1;
        } else {
            err += 1;
        }
    }
    assert!(ok > 250, "only {ok} of 5000 decoded");
    assert!(err > 2500, "only {err} of 5000 refused");
}

/// The issue-13 payload: 19 bytes whose frame_id length claims 4 GiB.
#[test]
fn the_19_byte_grid_is_refused_at_once() {
    let payload: [u8; 19] = [
        0x00, 0x01, 0x00, 0x00, 0x64, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff, b'm', b'a', b'p',
    ];
    let started = std::time::Instant::now();
    let result = Message::decode("nav_msgs/msg/OccupancyGrid", &payload);
    assert!(started.elapsed() < std::time::Duration::from_millis(50));
    let Err(MessageError::Cdr { source, .. }) = result else {
        panic!("{result:?}")
    };
    assert!(
        matches!(source, cdr::CdrError::Malformed { offset: 12, .. }),
        "{source}"
    );
}
