//! Writes a large bag for memory and speed measurements of `nrslam bag info|play`: 1000 x 1000
//! occupancy grids (1 MB each) on /map with a /clock message per frame, until the MCAP file holds
//! SIZE_MB megabytes, with the ordinary writer (768 KiB chunks).
//!
//!   cargo run --release -p nrslam-runtime --example bag_write_large -- DIR [SIZE_MB=2048]

use nrslam_msgs::{topics, Clock, Header, MapMetaData, Message, OccupancyGrid, Time};
use nrslam_runtime::bag::{BagWriter, WriterOptions};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = std::path::PathBuf::from(args.next().ok_or("usage: bag_write_large DIR [SIZE_MB]")?);
    let size_mb: u64 = args.next().map(|a| a.parse()).transpose()?.unwrap_or(2048);
    let mut writer = BagWriter::create(&dir, WriterOptions::default())?;
    let (width, height) = (1000u32, 1000u32);
    let mut frame = 0u64;
    let started = std::time::Instant::now();
    while std::fs::metadata(writer.mcap_path())?.len() < size_mb * 1_000_000 {
        frame += 1;
        let stamp = Time::from_seconds(frame as f64 * 0.1);
        writer.write_message(topics::CLOCK, &Message::Clock(Clock { clock: stamp }))?;
        let grid = OccupancyGrid {
            header: Header::new(stamp, "map"),
            info: MapMetaData {
                map_load_time: stamp,
                resolution: 0.05,
                width,
                height,
                ..Default::default()
            },
            data: (0..width * height)
                .map(|i| match (i as u64 + frame) % 7 {
                    0 => 100,
                    1 => 0,
                    _ => -1,
                })
                .collect(),
        };
        writer.write_message(topics::MAP, &Message::OccupancyGrid(grid))?;
    }
    let info = writer.finish()?;
    println!(
        "{}: {} messages, {} frames, {:.1} s",
        dir.display(),
        info.message_count,
        frame,
        started.elapsed().as_secs_f64()
    );
    Ok(())
}
