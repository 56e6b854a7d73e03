//! Decoding allocates O(payload length): a counting global allocator (in this test binary only)
//! sums every byte allocated on the decoding thread while one payload decodes, and that sum must
//! stay under 64 × payload length + 4 KiB for hostile payloads of every catalogue type: the
//! issue-13 grid, valid encodings with each length-sized word overwritten with huge or
//! just-plausible values, truncations, and the seeded fuzz mix. Before the decoder was replaced,
//! the 19-byte grid alone asked for 4.1 GB.

mod common;

use common::{fuzz_input, random_message, Rng};
use nrslam_msgs::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

struct Counting;

thread_local! {
    /// Bytes allocated (and grown by realloc) on this thread so far.
    static ALLOCATED: Cell<usize> = const { Cell::new(0) };
}

fn count(bytes: usize) {
    // try_with: the thread-local may be gone while a thread exits.
    let _ = ALLOCATED.try_with(|total| total.set(total.get().saturating_add(bytes)));
}

// SAFETY: every call forwards to the system allocator with the same arguments; the counting
// touches only a const-initialised thread-local Cell, which never allocates.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// Bytes allocated while decoding `bytes` as `type_name` (the message is dropped inside).
fn allocated_by_decode(type_name: &str, bytes: &[u8]) -> usize {
    let before = ALLOCATED.with(Cell::get);
    let decoded = Message::decode(type_name, bytes);
    let after = ALLOCATED.with(Cell::get);
    drop(decoded);
    after - before
}

fn bound(payload_len: usize) -> usize {
    64 * payload_len + 4096
}

fn assert_bounded(type_name: &str, bytes: &[u8], worst: &mut f64) {
    let allocated = allocated_by_decode(type_name, bytes);
    assert!(
        allocated <= bound(bytes.len()),
        "{type_name}: {allocated} bytes allocated decoding {} bytes",
        bytes.len()
    );
    *worst = worst.max(allocated.saturating_sub(4096) as f64 / bytes.len().max(1) as f64);
}

#[test]
fn the_counter_sees_allocations() {
    // A decode that must allocate: a 1000-cell grid.
    let grid = OccupancyGrid {
        data: vec![0; 1000],
        ..Default::default()
    };
    let bytes = cdr::encode(&grid).unwrap();
    assert!(allocated_by_decode("nav_msgs/msg/OccupancyGrid", &bytes) >= 1000);
}

#[test]
fn the_issue_13_grid_allocates_almost_nothing() {
    let payload: [u8; 19] = [
        0x00, 0x01, 0x00, 0x00, 0x64, 0, 0, 0, 0, 0, 0, 0, 0xff, 0xff, 0xff, 0xff, b'm', b'a', b'p',
    ];
    let allocated = allocated_by_decode("nav_msgs/msg/OccupancyGrid", &payload);
    // The error message and the type name it carries, nothing for the claimed string.
    assert!(allocated < 1024, "{allocated} bytes");
}

#[test]
fn hostile_payloads_of_every_type_allocate_linearly() {
    let mut rng = Rng::new(64);
    let mut worst_per_byte = 0.0f64;
    for name in Message::TYPE_NAMES {
        for round in 0..20 {
            let mut bytes = random_message(name, &mut rng).encode().unwrap();
            if round % 4 == 0 {
                // Some larger payloads, where a multiple of the length matters more than 4 KiB.
                let copy = bytes.clone();
                for _ in 0..50 {
                    bytes.extend_from_slice(&copy[4..]);
                }
            }
            assert_bounded(name, &bytes, &mut worst_per_byte);
            for at in (4..bytes.len().saturating_sub(3)).step_by(4) {
                let left = (bytes.len() - at - 4) as u32;
                for value in [u32::MAX, 0x8000_0000, left, left / 2, left / 8] {
                    let mut spoiled = bytes.clone();
                    spoiled[at..at + 4].copy_from_slice(&value.to_le_bytes());
                    assert_bounded(name, &spoiled, &mut worst_per_byte);
                }
            }
            for len in (0..bytes.len()).step_by(3) {
                assert_bounded(name, &bytes[..len], &mut worst_per_byte);
            }
        }
    }
    let mut rng = Rng::new(0x5eed);
    for _ in 0..3000 {
        let (name, bytes) = fuzz_input(&mut rng);
        assert_bounded(name, &bytes, &mut worst_per_byte);
    }
    eprintln!("worst: {worst_per_byte:.1} bytes allocated per payload byte (beyond 4 KiB)");
}

/// The worst shape for the bound: a TargetSet (the largest element in memory, 80 bytes for 16
/// on the wire) whose count claims one target per byte left, each target's outline claiming the
/// same, over a long payload of zeros.
#[test]
fn sequences_claiming_one_element_per_byte_left_stay_bounded() {
    for payload_len in [64usize, 1024, 65_536, 1 << 20] {
        let mut bytes = vec![0u8; payload_len];
        bytes[1] = 1;
        // header(4) stamp(8) frame_id length 0 (4) → targets count at 16.
        let left = (payload_len - 20) as u32;
        bytes[16..20].copy_from_slice(&left.to_le_bytes());
        // First target: id, shape "" (length 0), outline count.
        let outline_left = (payload_len - 32) as u32;
        bytes[28..32].copy_from_slice(&outline_left.to_le_bytes());
        let allocated = allocated_by_decode("nrslam_msgs/msg/TargetSet", &bytes);
        assert!(
            allocated <= bound(payload_len),
            "{allocated} bytes for {payload_len}"
        );
    }
}

/// A MarkerArray (a Marker is about 450 bytes in memory, the largest element of the catalogue)
/// whose count claims one marker per byte left, over zeros (each zero marker decodes, about 190
/// bytes on the wire): the markers are not reserved from the count.
#[test]
fn marker_arrays_claiming_one_marker_per_byte_left_stay_bounded() {
    for payload_len in [64usize, 1024, 65_536, 1 << 20] {
        let mut bytes = vec![0u8; payload_len];
        bytes[1] = 1;
        let left = (payload_len - 8) as u32;
        bytes[4..8].copy_from_slice(&left.to_le_bytes());
        let allocated = allocated_by_decode("visualization_msgs/msg/MarkerArray", &bytes);
        assert!(
            allocated <= 8 * payload_len + 4096,
            "{allocated} bytes for {payload_len}"
        );
    }
}
