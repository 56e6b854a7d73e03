//! Shared by the bag tests (`tests/bag_*.rs`; the unit tests as `crate::bag_common`) and the
//! `bag_fuzz` example: small bags, mutations of their MCAP file, and a global allocator that
//! records the largest single allocation of the current thread while armed (so a reader that
//! trusts a length read from the file is caught even when the operating system would have let the
//! allocation through).

#![allow(dead_code)]

use nrslam_msgs::{topics, Clock, Header, Message, PoseStamped, Time};
use nrslam_runtime::bag::{self, BagInfo, BagMessage, BagWriter, ReadMode, WriterOptions};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::{Path, PathBuf};

/// Records the largest allocation made by an armed thread.
pub struct Watch;

thread_local! {
    static ARMED: Cell<bool> = const { Cell::new(false) };
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let armed = ARMED.try_with(|a| a.get()).unwrap_or(false);
    if armed {
        let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
    }
}

unsafe impl GlobalAlloc for Watch {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc(layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Runs `f` and returns its result with the largest single allocation it made on this thread.
pub fn largest_allocation<T>(f: impl FnOnce() -> T) -> (T, usize) {
    LARGEST.with(|l| l.set(0));
    ARMED.with(|a| a.set(true));
    let out = f();
    ARMED.with(|a| a.set(false));
    (out, LARGEST.with(|l| l.get()))
}

/// Writes a bag of `frames` frames (a clock and a pose each) with chunks of `chunk_size_bytes`.
pub fn write_bag(dir: &Path, frames: u32, chunk_size_bytes: u64) -> BagInfo {
    let mut writer = BagWriter::create(
        dir,
        WriterOptions {
            chunk_size_bytes,
            custom_data: [("nrslam.seed".to_owned(), "3".to_owned())].into(),
        },
    )
    .unwrap();
    for k in 1..=frames {
        let stamp = Time::from_seconds(k as f64 * 0.5);
        writer
            .write_message(topics::CLOCK, &Message::Clock(Clock { clock: stamp }))
            .unwrap();
        let pose = PoseStamped {
            header: Header::new(stamp, "map"),
            ..Default::default()
        };
        writer
            .write_message(topics::SLAM_POSE, &Message::PoseStamped(pose))
            .unwrap();
    }
    writer.finish().unwrap()
}

/// A bag of exactly `chunks` chunks (the last one may be short) in `dir`/`name`, read back.
pub fn bag_with_chunks(dir: &Path, name: &str, chunks: usize) -> bag::BagContents {
    for frames in 4.. {
        let path = dir.join(format!("{name}-{frames}"));
        write_bag(&path, frames, 600);
        let contents = bag::open(&path, ReadMode::Strict).unwrap();
        if contents.chunks.len() == chunks {
            let target = dir.join(name);
            std::fs::rename(&path, &target).unwrap();
            return bag::open(&target, ReadMode::Strict).unwrap();
        }
        std::fs::remove_dir_all(&path).unwrap();
        assert!(frames < 1000, "no bag of {chunks} chunks");
    }
    unreachable!()
}

/// A small deterministic random generator (xorshift64*), so the fuzz example needs no crate.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    pub fn below(&mut self, n: u64) -> u64 {
        if n == 0 {
            0
        } else {
            self.next() % n
        }
    }
}

/// Lengths a corrupted field might hold.
pub const HUGE: [u64; 6] = [
    u64::MAX,
    u64::MAX / 2,
    1 << 40,
    u32::MAX as u64,
    (u32::MAX as u64) << 8,
    0x7FFF_FFFF,
];

/// One mutation of `bytes`, chosen by `rng`: flips, a truncation, a huge value over 4 or 8
/// bytes, or a run of garbage. Returns what was done.
pub fn mutate(bytes: &mut Vec<u8>, rng: &mut Rng) -> String {
    let len = bytes.len() as u64;
    match rng.below(5) {
        0 => {
            let n = 1 + rng.below(8);
            for _ in 0..n {
                let at = rng.below(len) as usize;
                bytes[at] ^= 1 << rng.below(8);
            }
            format!("{n} bit flips")
        }
        1 => {
            let at = rng.below(len) as usize;
            bytes.truncate(at);
            format!("truncated at {at}")
        }
        2 | 3 => {
            let value = HUGE[rng.below(HUGE.len() as u64) as usize];
            let width = if rng.below(2) == 0 { 8 } else { 4 };
            let at = rng.below(len.saturating_sub(width)) as usize;
            let le = value.to_le_bytes();
            bytes[at..at + width as usize].copy_from_slice(&le[..width as usize]);
            format!("{value:#x} over {width} bytes at {at}")
        }
        _ => {
            let at = rng.below(len) as usize;
            let n = (1 + rng.below(64) as usize).min(bytes.len() - at);
            for b in &mut bytes[at..at + n] {
                *b = rng.next() as u8;
            }
            format!("{n} garbage bytes at {at}")
        }
    }
}

/// What reading a mutated bag gave.
#[derive(Debug, Default, Clone, Copy)]
pub struct Outcome {
    pub strict_ok: bool,
    pub recover_ok: bool,
    pub losses: usize,
    pub largest_allocation: usize,
}

/// Reads `dir` strictly and recovering, checking what must hold whatever the damage: a strict
/// read that succeeds gives exactly `original`; a recovering read gives a subsequence of it (the
/// chunk CRCs keep altered messages out). Returns an error text when a property fails.
pub fn check_mutated(dir: &Path, original: &[BagMessage]) -> Result<Outcome, String> {
    let mut outcome = Outcome::default();
    let ((strict, recover, streamed), largest) = largest_allocation(|| {
        let strict = bag::open(dir, ReadMode::Strict);
        let recover = bag::open(dir, ReadMode::Recover);
        // The record-by-record path for big chunks, too.
        let streamed = bag::Bag::open(dir, ReadMode::Recover).and_then(|mut b| {
            b.set_in_memory_chunk_bytes(64);
            b.read_all()
        });
        (strict, recover, streamed)
    });
    outcome.largest_allocation = largest;
    if let Ok(contents) = strict {
        outcome.strict_ok = true;
        if contents.messages != original {
            return Err("strict read succeeded with other messages".into());
        }
    }
    if let Ok(contents) = recover {
        outcome.recover_ok = true;
        outcome.losses = contents.losses.len();
        if !is_subsequence(&contents.messages, original) {
            return Err("recovered messages are not a subsequence of the original".into());
        }
    }
    if let Ok(contents) = streamed {
        if !is_subsequence(&contents.messages, original) {
            return Err("record-by-record messages are not a subsequence of the original".into());
        }
    }
    Ok(outcome)
}

fn is_subsequence(part: &[BagMessage], whole: &[BagMessage]) -> bool {
    let mut it = whole.iter();
    part.iter().all(|m| it.any(|w| w == m))
}

/// Copies a bag folder (metadata.yaml and MCAP file) to `to`, with `mcap` as its MCAP bytes.
pub fn copy_with(from: &bag::BagContents, to: &Path, mcap: &[u8]) -> PathBuf {
    std::fs::create_dir_all(to).unwrap();
    let name = from.mcap_path.file_name().unwrap();
    std::fs::copy(from.dir.join("metadata.yaml"), to.join("metadata.yaml")).unwrap();
    let path = to.join(name);
    std::fs::write(&path, mcap).unwrap();
    path
}
