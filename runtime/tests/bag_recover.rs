//! Damaged bags: a corrupt chunk in the middle of a file is skipped whole by `ReadMode::Recover`
//! (and reported with its byte range and message count) and is an error naming its offset in
//! `ReadMode::Strict`; huge length fields are refused without allocating; random mutations of a
//! small bag never panic (proptest) and never let an altered message through.

mod bag_common;
use bag_common::*;
use nrslam_runtime::bag::{self, Bag, BagContents, ReadMode};
use proptest::prelude::*;

#[global_allocator]
static WATCH: Watch = Watch;

/// Byte offset where the chunk `k` (0-based) starts: after the previous chunk and its message
/// indexes, found from the next chunk opcode with a matching length.
fn chunk_start(full: &BagContents, bytes: &[u8], k: usize) -> usize {
    let from = if k == 0 {
        8
    } else {
        full.chunks[k - 1].end_byte as usize
    };
    let end = full.chunks[k].end_byte as usize;
    (from..end)
        .find(|&at| {
            bytes[at] == 0x06
                && u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) + 9
                    == (end - at) as u64
        })
        .expect("chunk start")
}

fn without(full: &BagContents, k: usize) -> Vec<bag::BagMessage> {
    let before: u64 = full.chunks[..k].iter().map(|c| c.messages).sum();
    let lost = full.chunks[k].messages;
    let mut kept = full.messages.clone();
    kept.drain(before as usize..(before + lost) as usize);
    kept
}

#[test]
fn a_bag_with_a_corrupt_middle_chunk_loses_exactly_its_messages_when_recovered_and_is_an_error_strictly(
) {
    let dir = tempfile::tempdir().unwrap();
    let full = bag_with_chunks(dir.path(), "full", 4);
    let bytes = std::fs::read(&full.mcap_path).unwrap();
    let start = chunk_start(&full, &bytes, 1);
    let end = full.chunks[1].end_byte as usize;
    assert!(full.chunks[1].messages > 0);
    let expected = without(&full, 1);

    // Flipped bytes inside the 2nd chunk's records: its CRC no longer matches.
    let mut flipped = bytes.clone();
    for at in [end - 40, end - 20, (start + end) / 2] {
        flipped[at] ^= 0x5A;
    }
    let damaged = dir.path().join("flipped");
    copy_with(&full, &damaged, &flipped);
    let error = bag::open(&damaged, ReadMode::Strict)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains(&format!("byte {start}"))
            && error.contains("CRC mismatch")
            && error.contains("--recover"),
        "{error}"
    );
    let recovered = bag::open(&damaged, ReadMode::Recover).unwrap();
    assert_eq!(recovered.messages, expected);
    assert_eq!(recovered.losses.len(), 1, "{:?}", recovered.losses);
    let loss = &recovered.losses[0];
    assert_eq!(loss.start_byte, start as u64);
    assert_eq!(
        loss.messages,
        Some(full.chunks[1].messages),
        "counted from the chunk's message indexes"
    );
    assert!(loss.end_byte >= end as u64 && loss.end_byte < full.chunks[2].end_byte);
    assert!(recovered.stopped.is_none(), "{:?}", recovered.stopped);
    assert_eq!(recovered.chunks.len(), 3);
    let shown = loss.to_string();
    assert!(
        shown.contains(&format!("{start}..")) && shown.contains("messages lost"),
        "{shown}"
    );

    // The same damage in a recording without summary or metadata.yaml (a recorder killed after
    // the 4th chunk): resumes just past the chunk, counts from the Message Index records after it.
    let cut = dir.path().join("cut");
    std::fs::create_dir(&cut).unwrap();
    let last = full.chunks[3].end_byte as usize;
    std::fs::write(cut.join("cut_0.mcap"), &flipped[..last]).unwrap();
    let recovered = bag::open(&cut, ReadMode::Recover).unwrap();
    assert_eq!(recovered.messages, expected);
    assert_eq!(recovered.losses.len(), 1, "{:?}", recovered.losses);
    assert_eq!(recovered.losses[0].messages, Some(full.chunks[1].messages));
    assert_eq!(recovered.losses[0].end_byte, end as u64);
    assert_eq!(recovered.custom_data["nrslam.seed"], "3");

    // A garbage length in the 2nd chunk's record: with the summary, the chunk index says where the
    // 3rd chunk starts; without, a scan finds it (by its header and CRC).
    let mut garbage = bytes.clone();
    garbage[start + 1..start + 9].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let damaged = dir.path().join("garbage");
    copy_with(&full, &damaged, &garbage);
    let error = bag::open(&damaged, ReadMode::Strict)
        .unwrap_err()
        .to_string();
    assert!(error.contains(&format!("byte {start}")), "{error}");
    let ((recovered, cut_recovered), largest) = largest_allocation(|| {
        let with_summary = bag::open(&damaged, ReadMode::Recover).unwrap();
        let cut = dir.path().join("garbage-cut");
        std::fs::create_dir(&cut).unwrap();
        std::fs::write(cut.join("g_0.mcap"), &garbage[..last]).unwrap();
        (with_summary, bag::open(&cut, ReadMode::Recover).unwrap())
    });
    assert!(largest <= 2 << 20, "largest allocation {largest} bytes");
    assert_eq!(recovered.messages, expected);
    assert_eq!(recovered.losses[0].messages, Some(full.chunks[1].messages));
    assert_eq!(cut_recovered.messages, expected);
    assert_eq!(cut_recovered.losses.len(), 1);
    assert_eq!(
        cut_recovered.losses[0].messages, None,
        "the scan cannot count"
    );
    assert!(cut_recovered.losses[0].end_byte > end as u64);
}

#[test]
fn a_bag_whose_message_index_opcode_lost_a_bit_yields_no_bogus_message() {
    // Found by the bag_fuzz example: 0x07 (Message Index) -> 0x05 (Message) is one bit, and a
    // Message outside chunks has no CRC.
    let dir = tempfile::tempdir().unwrap();
    let full = bag_with_chunks(dir.path(), "full", 3);
    let mut bytes = std::fs::read(&full.mcap_path).unwrap();
    let at = full.chunks[0].end_byte as usize;
    assert_eq!(bytes[at], 0x07, "a message index follows the chunk");
    bytes[at] = 0x05;
    let damaged = dir.path().join("d");
    copy_with(&full, &damaged, &bytes);
    let error = bag::open(&damaged, ReadMode::Strict)
        .unwrap_err()
        .to_string();
    assert!(error.contains(&format!("byte {at}")), "{error}");
    let recovered = bag::open(&damaged, ReadMode::Recover).unwrap();
    assert_eq!(recovered.messages, full.messages, "no chunk is lost");
    assert_eq!(recovered.losses.len(), 1);
    assert_eq!(recovered.losses[0].messages, Some(0));
}

#[test]
fn a_bag_with_a_damaged_summary_is_an_error_strictly_and_read_without_it_when_recovering() {
    let dir = tempfile::tempdir().unwrap();
    let full = bag_with_chunks(dir.path(), "full", 3);
    let mut bytes = std::fs::read(&full.mcap_path).unwrap();
    // The footer (before the 8-byte end magic) points at the summary section.
    let footer = bytes.len() - 8 - 29;
    let summary_start = u64::from_le_bytes(bytes[footer + 9..footer + 17].try_into().unwrap());
    assert!(summary_start > full.complete_bytes());
    let at = summary_start as usize + 10;
    bytes[at] ^= 0x01;
    let damaged = dir.path().join("d");
    copy_with(&full, &damaged, &bytes);
    let error = Bag::open(&damaged, ReadMode::Strict)
        .unwrap_err()
        .to_string();
    assert!(
        error.contains("summary") && error.contains("--recover"),
        "{error}"
    );
    let opened = Bag::open(&damaged, ReadMode::Recover).unwrap();
    assert!(opened.summary().is_none());
    assert!(opened.summary_note().unwrap().contains("summary"));
    let recovered = opened.read_all().unwrap();
    assert_eq!(recovered.messages, full.messages);
}

#[test]
fn huge_lengths_anywhere_in_a_bag_are_refused_without_allocating_them() {
    let dir = tempfile::tempdir().unwrap();
    let full = bag_with_chunks(dir.path(), "full", 3);
    let bytes = std::fs::read(&full.mcap_path).unwrap();
    // Every 8-byte and 4-byte window in turn (stride 3, to stay quick) set to a huge value.
    let mut case = 0;
    for at in (0..bytes.len() - 8).step_by(3) {
        for (value, width) in [(u64::MAX, 8), (1 << 40, 8), (u32::MAX as u64, 4)] {
            let mut mutated = bytes.clone();
            mutated[at..at + width].copy_from_slice(&value.to_le_bytes()[..width]);
            let target = dir.path().join(format!("m{case}"));
            case += 1;
            copy_with(&full, &target, &mutated);
            let outcome = check_mutated(&target, &full.messages)
                .unwrap_or_else(|e| panic!("{value:#x} at {at}: {e}"));
            assert!(
                outcome.largest_allocation <= (1 << 20) + 4096,
                "{value:#x} at {at}: an allocation of {} bytes",
                outcome.largest_allocation
            );
            std::fs::remove_dir_all(&target).unwrap();
        }
    }
    assert!(case > 1000);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn mutated_bags_never_panic_nor_let_altered_messages_through(seed in any::<u64>(), n in 1u32..4) {
        let dir = tempfile::tempdir().unwrap();
        let full = bag_with_chunks(dir.path(), "full", 3);
        let mut bytes = std::fs::read(&full.mcap_path).unwrap();
        let mut rng = Rng(seed | 1);
        let mut done = Vec::new();
        for _ in 0..n {
            if bytes.len() > 16 {
                done.push(mutate(&mut bytes, &mut rng));
            }
        }
        let target = dir.path().join("m");
        copy_with(&full, &target, &bytes);
        let outcome = check_mutated(&target, &full.messages);
        prop_assert!(outcome.is_ok(), "{:?}: {:?}", done, outcome);
        let outcome = outcome.unwrap();
        prop_assert!(outcome.largest_allocation <= (1 << 20) + 4096, "{:?}: {} bytes", done, outcome.largest_allocation);
    }
}
