//! `nrslam bag info`: what `ros2 bag info` prints (files, size, storage, duration, start, end,
//! messages, per-topic type, count and serialization format) plus the chunk compression, the
//! chunks and, for a recovered bag, what was lost.

use super::{byte_progress, open_bag, print_losses};
use anyhow::{anyhow, Result};
use clap::Args;
use nrslam_msgs::MessageError;
use nrslam_runtime::bag::{Bag, TopicSummary};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// `nrslam bag info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Bag folder (or one .mcap file).
    pub dir: PathBuf,
    /// Read a bag whose recorder was killed or that is damaged: without metadata.yaml or the MCAP
    /// summary, up to the last complete chunk, skipping damaged chunks (each loss is printed).
    #[arg(long)]
    pub recover: bool,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Print the figures of the MCAP summary sections (statistics, channels, chunk indexes)
    /// without reading the messages: instant, but nothing is checked or decoded. Needs intact
    /// summaries.
    #[arg(long, conflicts_with = "recover")]
    pub summary_only: bool,
}

/// `YYYY-MM-DD HH:MM:SS.nnnnnnnnn` (UTC) of `ns` since the UNIX epoch.
fn utc(ns: u64) -> String {
    let secs = ns / 1_000_000_000;
    let (days, rem) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02}.{:09}",
        rem / 3600,
        rem / 60 % 60,
        rem % 60,
        ns % 1_000_000_000
    )
}

fn compression_names(names: &[String]) -> String {
    if names.is_empty() {
        return "none (no chunks)".into();
    }
    names
        .iter()
        .map(|c| if c.is_empty() { "none" } else { c.as_str() })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Serialization format per topic: what the channels recorded, else metadata.yaml's.
fn formats(bag: &Bag, seen: &BTreeMap<String, String>, topic: &str) -> String {
    if let Some(format) = seen.get(topic) {
        return format.clone();
    }
    bag.metadata()
        .and_then(|m| {
            m.topics_with_message_count
                .iter()
                .find(|t| t.topic_metadata.name == topic)
        })
        .map_or_else(
            || "cdr".to_owned(),
            |t| t.topic_metadata.serialization_format.clone(),
        )
}

/// Counts gathered while reading every message.
#[derive(Default)]
struct Pass {
    undecodable: u64,
    /// Messages of types outside nrslam's catalogue (not decoded, played as recorded).
    raw: u64,
    formats: BTreeMap<String, String>,
}

/// `nrslam bag info`.
pub fn info(args: InfoArgs) -> Result<()> {
    let bag = open_bag(&args.dir, args.recover)?;
    if args.summary_only {
        return info_from_summary(&bag, args.json);
    }
    let bar = byte_progress(bag.file_bytes(), "reading");
    let mut stream = bag.messages()?;
    let mut pass = Pass::default();
    let mut count = 0u64;
    while let Some(message) = stream.next() {
        let message = message?;
        match message.decode() {
            Ok(_) => {}
            Err(MessageError::UnknownType(_)) => pass.raw += 1,
            Err(_) => pass.undecodable += 1,
        }
        if !pass.formats.contains_key(&message.topic) {
            pass.formats.insert(
                message.topic.clone(),
                message.recorded.message_encoding.clone(),
            );
        }
        count += 1;
        if count.is_multiple_of(256) {
            bar.set_position(stream.position());
        }
    }
    bar.finish_and_clear();
    let report = stream.into_report();
    print_losses(&bag, &report);
    let mut custom_data = bag.custom_data().clone();
    if custom_data.is_empty() {
        custom_data = report.custom_data.clone();
    }
    let (start_ns, end_ns) = report.time_range_ns.unwrap_or((0, 0));
    let complete = report.stopped.is_none() && report.losses.is_empty();
    let files: Vec<String> = bag
        .mcap_paths()
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    if args.json {
        let json = serde_json::json!({
            "path": bag.dir().display().to_string(),
            "file": bag.mcap_path().display().to_string(),
            "files": files,
            "file_sizes": bag.file_sizes(),
            "file_bytes": bag.file_bytes(),
            "storage_id": "mcap",
            "metadata_version": bag.metadata().map(|m| m.version),
            "ros_distro": bag.metadata().map(|m| m.ros_distro.clone()),
            "compression": report.compressions.iter().map(|c| if c.is_empty() { "none" } else { c.as_str() }).collect::<Vec<_>>(),
            "messages": report.messages,
            "chunks": report.chunks.len(),
            "complete_bytes": report.complete_bytes(),
            "start_ns": start_ns,
            "end_ns": end_ns,
            "duration_ns": end_ns - start_ns,
            "undecodable": pass.undecodable,
            "raw": pass.raw,
            "complete": complete,
            "stopped": report.stopped,
            "losses": report.losses.iter().map(|l| serde_json::json!({
                "file": l.file, "start_byte": l.start_byte, "end_byte": l.end_byte,
                "messages": l.messages, "reason": l.reason,
            })).collect::<Vec<_>>(),
            "lost_messages": report.lost_messages(),
            "summary": bag.summary().is_some(),
            "topics": report.topics.iter().map(|t| serde_json::json!({
                "name": t.name, "type": t.type_name, "count": t.count,
                "serialization_format": formats(&bag, &pass.formats, &t.name),
            })).collect::<Vec<_>>(),
            "custom_data": custom_data,
        });
        outln!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    print_header(&bag, report.chunks.len(), &report.compressions);
    print_span(start_ns, end_ns);
    outln!("Messages:    {}", report.messages);
    if !report.losses.is_empty() {
        let unknown = report.losses.iter().any(|l| l.messages.is_none());
        outln!(
            "Recovered:   skipped {} damaged part(s), {} messages lost{}",
            report.losses.len(),
            report.lost_messages(),
            if unknown {
                " (plus some not counted)"
            } else {
                ""
            }
        );
    }
    if let Some(stopped) = &report.stopped {
        outln!("Recovered:   read up to the last complete chunk ({stopped})");
    }
    if pass.raw > 0 {
        outln!(
            "Raw:         {} messages of types outside nrslam's catalogue (played as recorded)",
            pass.raw
        );
    }
    if pass.undecodable > 0 {
        outln!("Undecodable: {} messages", pass.undecodable);
    }
    print_topics(&bag, &report.topics, &pass.formats);
    Ok(())
}

/// The recording's duration, start and end (UTC and seconds since the epoch).
fn print_span(start_ns: u64, end_ns: u64) {
    outln!("Duration:    {:.9} s", (end_ns - start_ns) as f64 * 1e-9);
    outln!(
        "Start:       {} UTC ({:.9} s)",
        utc(start_ns),
        start_ns as f64 * 1e-9
    );
    outln!(
        "End:         {} UTC ({:.9} s)",
        utc(end_ns),
        end_ns as f64 * 1e-9
    );
}

fn print_header(bag: &Bag, chunks: usize, compressions: &[String]) {
    let paths = bag.mcap_paths();
    let sizes = bag.file_sizes();
    for (i, (path, size)) in paths.iter().zip(&sizes).enumerate() {
        let label = if i == 0 { "Files:" } else { "" };
        outln!("{label:<12} {} ({size} bytes)", path.display());
    }
    outln!(
        "Bag size:    {} bytes ({:.1} KiB)",
        bag.file_bytes(),
        bag.file_bytes() as f64 / 1024.0
    );
    outln!("Storage id:  mcap");
    if let Some(m) = bag.metadata() {
        outln!(
            "Metadata:    version {}, ROS distro {:?}",
            m.version,
            m.ros_distro
        );
    }
    outln!(
        "Chunks:      {chunks} (compression {})",
        compression_names(compressions)
    );
}

fn print_topics(bag: &Bag, topics: &[TopicSummary], seen: &BTreeMap<String, String>) {
    outln!("Topic information:");
    for topic in topics {
        outln!(
            "  Topic: {} | Type: {} | Count: {} | Serialization Format: {}",
            topic.name,
            topic.type_name,
            topic.count,
            formats(bag, seen, &topic.name)
        );
    }
}

/// `bag info --summary-only`.
fn info_from_summary(bag: &Bag, json: bool) -> Result<()> {
    let summary = bag.summary().ok_or_else(|| {
        anyhow!(
            "{}: no usable MCAP summary ({}); run `bag info` without --summary-only",
            bag.mcap_path().display(),
            bag.summary_note().unwrap_or("none")
        )
    })?;
    let (start_ns, end_ns) = summary.time_range_ns.unwrap_or((0, 0));
    let messages = summary
        .message_count
        .unwrap_or_else(|| summary.topics.iter().map(|t| t.count).sum());
    let none = BTreeMap::new();
    if json {
        let json = serde_json::json!({
            "path": bag.dir().display().to_string(),
            "file": bag.mcap_path().display().to_string(),
            "files": bag.mcap_paths().iter().map(|p| p.display().to_string()).collect::<Vec<_>>(),
            "file_sizes": bag.file_sizes(),
            "file_bytes": bag.file_bytes(),
            "storage_id": "mcap",
            "compression": summary.compressions.iter().map(|c| if c.is_empty() { "none" } else { c.as_str() }).collect::<Vec<_>>(),
            "messages": messages,
            "chunks": summary.chunk_count,
            "start_ns": start_ns,
            "end_ns": end_ns,
            "duration_ns": end_ns - start_ns,
            "undecodable": null,
            "summary": true,
            "topics": summary.topics.iter().map(|t| serde_json::json!({
                "name": t.name, "type": t.type_name, "count": t.count,
                "serialization_format": formats(bag, &none, &t.name),
            })).collect::<Vec<_>>(),
            "custom_data": bag.custom_data(),
        });
        outln!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    print_header(bag, summary.chunk_count, &summary.compressions);
    print_span(start_ns, end_ns);
    outln!("Messages:    {messages} (from the MCAP summaries, not read)");
    print_topics(bag, &summary.topics, &none);
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn utc_dates_match_known_instants() {
        assert_eq!(super::utc(0), "1970-01-01 00:00:00.000000000");
        assert_eq!(super::utc(100_500_000_000), "1970-01-01 00:01:40.500000000");
        // 2024-02-29 12:34:56 UTC = 1709210096 s.
        assert_eq!(
            super::utc(1_709_210_096_000_000_001),
            "2024-02-29 12:34:56.000000001"
        );
    }
}
