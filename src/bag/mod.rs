//! `nrslam bag record|info|play`: rosbag2 bags (metadata.yaml + MCAP) of a live graph, over zenoh.
//! The bag format itself lives in `nrslam_runtime::bag`; this module is the command line around it.

use crate::TransportArgs;
use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_msgs::topics;
use nrslam_runtime::bag::{Bag, BagWriter, ReadMode, ReadReport, WriterOptions};
use nrslam_runtime::receive::{Delivery, Inbox};
use nrslam_runtime::transport::{self, KeyStyle, Pacer, SessionMode, TopicPublisher};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// `nrslam bag`.
#[derive(Args, Debug)]
pub struct BagArgs {
    #[command(subcommand)]
    pub command: BagCommand,
}

/// The bag verbs.
#[derive(Subcommand, Debug)]
pub enum BagCommand {
    /// Record a live graph's topics into a new rosbag2 folder (MCAP), until every recorded topic's
    /// stream has ended, --duration-s has passed, or Ctrl-C.
    Record(RecordArgs),
    /// Print a bag's topics, types, message counts, start and duration, after reading (streaming)
    /// and decoding every message; --summary-only reads the MCAP summary alone.
    Info(InfoArgs),
    /// Publish a bag's messages onto a graph over zenoh with their original timing scaled by --rate.
    Play(PlayArgs),
}

/// Chunking of a recording.
#[derive(Args, Debug, Clone)]
pub struct ChunkArgs {
    /// Message data per MCAP chunk, in KiB. A chunk is closed and flushed to disk as soon as it
    /// holds this much, so a recorder that is killed loses at most the chunk it was filling (this
    /// much, plus the message that crossed the limit).
    #[arg(long, value_name = "KIB", default_value_t = 768)]
    pub chunk_size_kib: u64,
}

impl ChunkArgs {
    /// Bytes, validated.
    pub fn bytes(&self) -> Result<u64> {
        if !(1..=1024 * 1024).contains(&self.chunk_size_kib) {
            bail!(
                "--chunk-size-kib: {} is out of range (allowed: 1 to 1048576 KiB)",
                self.chunk_size_kib
            );
        }
        Ok(self.chunk_size_kib * 1024)
    }
}

/// `nrslam bag record`.
#[derive(Args, Debug)]
pub struct RecordArgs {
    /// Bag folder to create (must not exist, or be empty).
    pub dir: PathBuf,
    /// Topics to record (default: every catalogue topic, see `nrslam topics`).
    #[arg(long, value_name = "TOPIC", num_args = 1..)]
    pub topics: Vec<String>,
    /// Stop after this many wall-clock seconds (0: only when the topics end or on Ctrl-C).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0)]
    pub duration_s: f64,
    #[command(flatten)]
    pub chunk: ChunkArgs,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `nrslam bag info`.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Bag folder (or its .mcap file).
    pub dir: PathBuf,
    /// Read a bag whose recorder was killed or that is damaged: without metadata.yaml or the MCAP
    /// summary, up to the last complete chunk, skipping damaged chunks (each loss is printed).
    #[arg(long)]
    pub recover: bool,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Print the figures of the MCAP summary section (statistics, channels, chunk indexes) without
    /// reading the messages: instant, but nothing is checked or decoded. Needs an intact summary.
    #[arg(long, conflicts_with = "recover")]
    pub summary_only: bool,
}

/// `nrslam bag play`.
#[derive(Args, Debug)]
pub struct PlayArgs {
    /// Bag folder.
    pub dir: PathBuf,
    /// Real-time factor R: recorded seconds per wall-clock second (2 = twice as fast), 1e-6 to
    /// 1e6. 0 (default): as fast as the subscribers take the messages; nothing is dropped either
    /// way (reliable publication that blocks on congestion).
    #[arg(
        long,
        value_name = "R",
        default_value_t = 0.0,
        value_parser = crate::flags::RATE.parser(),
        allow_hyphen_values = true
    )]
    pub rate: f64,
    /// Play again from the start when the bag ends, until Ctrl-C (no end-of-stream is sent).
    #[arg(long = "loop")]
    pub repeat: bool,
    /// Topics to play (default: every topic of the bag).
    #[arg(long, value_name = "TOPIC", num_args = 1..)]
    pub topics: Vec<String>,
    /// Read a bag whose recorder was killed or that is damaged, up to its last complete chunk,
    /// skipping damaged chunks (each loss is printed).
    #[arg(long)]
    pub recover: bool,
    /// Seconds to wait for every played topic to have a subscriber before publishing (topics
    /// still without one are published anyway).
    #[arg(long, value_name = "SECONDS", default_value_t = 5.0)]
    pub match_timeout_s: f64,
    /// Publish as rmw_zenoh does in this ROS domain (key `<domain>/<topic>/<type>/<RIHS01 hash>`,
    /// rmw_zenoh's attachment), so ROS 2 nodes on rmw_zenoh receive the messages without a bridge.
    /// 0 to 232, ROS 2's range.
    #[arg(long, value_name = "DOMAIN_ID", value_parser = crate::launcher::ROS_DOMAIN_ID.parser::<u32>(), allow_hyphen_values = true)]
    pub ros_domain_id: Option<u32>,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `nrslam bag ...`.
pub fn bag(args: BagArgs) -> Result<()> {
    match args.command {
        BagCommand::Record(args) => record(args),
        BagCommand::Info(args) => info(args),
        BagCommand::Play(args) => play(args),
    }
}

/// Catalogue topics named on the command line (default: the whole catalogue).
pub fn catalogue_topics(names: &[String]) -> Result<Vec<&'static str>> {
    if names.is_empty() {
        return Ok(topics::CATALOGUE.iter().map(|t| t.name).collect());
    }
    names
        .iter()
        .map(|name| {
            topics::spec(name).map(|s| s.name).ok_or_else(|| {
                anyhow!(
                    "--topics: unknown topic {name:?} (known: {})",
                    topics::CATALOGUE
                        .iter()
                        .map(|t| t.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })
        })
        .collect()
}

fn session(args: &TransportArgs) -> Result<zenoh::Session> {
    if args.listen.is_empty() && args.connect.is_empty() {
        bail!("give --connect ENDPOINT (e.g. the --listen endpoint of a running `nrslam launch`) or --listen ENDPOINT");
    }
    transport::open(&args.config(SessionMode::Peer)).context("opening the zenoh session")
}

/// Sets a flag on Ctrl-C (SIGINT) so a recorder, player or `echo` can finish cleanly.
pub(crate) fn interrupted() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let set = flag.clone();
    std::thread::spawn(move || {
        if let Ok(runtime) = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
        {
            if runtime.block_on(tokio::signal::ctrl_c()).is_ok() {
                set.store(true, Ordering::SeqCst);
            }
        }
    });
    flag
}

/// `nrslam bag record`.
pub fn record(args: RecordArgs) -> Result<()> {
    if !(args.duration_s.is_finite() && args.duration_s >= 0.0) {
        bail!(
            "--duration-s: {} is out of range (allowed: 0 for no limit, or positive seconds)",
            args.duration_s
        );
    }
    let wanted = catalogue_topics(&args.topics)?;
    let chunk_size_bytes = args.chunk.bytes()?;
    let session = session(&args.transport)?;
    let mut inbox = Inbox::subscribe(
        &session,
        &args.transport.namespace,
        &wanted,
        args.transport.inbox_options()?,
    )?;
    let mut writer = BagWriter::create(
        &args.dir,
        WriterOptions {
            chunk_size_bytes,
            custom_data: BTreeMap::new(),
        },
    )?;
    let stop = interrupted();
    let started = Instant::now();
    let mut seen: Vec<&'static str> = Vec::new();
    let mut ended: Vec<&'static str> = Vec::new();
    eprintln!(
        "recording {} topic(s) into {} (Ctrl-C to stop)",
        wanted.len(),
        args.dir.display()
    );
    loop {
        if stop.load(Ordering::SeqCst) {
            break;
        }
        if args.duration_s > 0.0 && started.elapsed().as_secs_f64() >= args.duration_s {
            break;
        }
        match inbox.recv_timeout(Duration::from_millis(100))? {
            Some(Delivery::End { topic }) => {
                if !ended.contains(&topic) {
                    ended.push(topic);
                }
                if !seen.is_empty() && seen.iter().all(|t| ended.contains(t)) {
                    break;
                }
            }
            Some(Delivery::Message {
                topic,
                message,
                payload,
            }) => {
                if !seen.contains(&topic) {
                    seen.push(topic);
                }
                writer.write_cdr(
                    topic,
                    message.type_name(),
                    message.stamp().as_nanos(),
                    &payload,
                )?;
            }
            None => {}
        }
    }
    for (topic, reason, n) in inbox.drops().iter() {
        eprintln!("warning: {topic}: {n} samples dropped ({reason}), not recorded");
    }
    let info = writer.finish()?;
    let _ = session.close().wait();
    outln!(
        "recorded {} messages on {} topic(s) into {}",
        info.message_count,
        info.topics_with_message_count.len(),
        args.dir.display()
    );
    Ok(())
}

fn open_bag(dir: &Path, recover: bool) -> Result<Bag> {
    let mode = if recover {
        ReadMode::Recover
    } else {
        ReadMode::Strict
    };
    Ok(Bag::open(dir, mode)?)
}

/// A progress bar over the bytes of a bag's MCAP file (drawn only on a terminal).
fn byte_progress(bytes: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(bytes);
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {bytes}/{total_bytes}  ETA {eta}  {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar.set_message(what.to_owned());
    bar
}

/// Prints each part of the file that a recovering read skipped.
fn print_losses(report: &ReadReport) {
    for loss in &report.losses {
        eprintln!("warning: {loss}");
    }
}

/// `nrslam bag info`.
pub fn info(args: InfoArgs) -> Result<()> {
    let bag = open_bag(&args.dir, args.recover)?;
    if args.summary_only {
        return info_from_summary(&bag, args.json);
    }
    let bar = byte_progress(bag.file_bytes(), "reading");
    let mut stream = bag.messages()?;
    let mut undecodable = 0u64;
    let mut count = 0u64;
    while let Some(message) = stream.next() {
        if message?.decode().is_err() {
            undecodable += 1;
        }
        count += 1;
        if count.is_multiple_of(256) {
            bar.set_position(stream.position());
        }
    }
    bar.finish_and_clear();
    let report = stream.into_report();
    print_losses(&report);
    let mut custom_data = bag.custom_data().clone();
    if custom_data.is_empty() {
        custom_data = report.custom_data.clone();
    }
    let (start_ns, end_ns) = report.time_range_ns.unwrap_or((0, 0));
    let duration_s = (end_ns - start_ns) as f64 * 1e-9;
    let complete = report.stopped.is_none() && report.losses.is_empty();
    if args.json {
        let json = serde_json::json!({
            "path": bag.dir().display().to_string(),
            "file": bag.mcap_path().display().to_string(),
            "file_bytes": bag.file_bytes(),
            "messages": report.messages,
            "chunks": report.chunks.len(),
            "complete_bytes": report.complete_bytes(),
            "start_ns": start_ns,
            "duration_ns": end_ns - start_ns,
            "undecodable": undecodable,
            "complete": complete,
            "stopped": report.stopped,
            "losses": report.losses.iter().map(|l| serde_json::json!({
                "start_byte": l.start_byte, "end_byte": l.end_byte,
                "messages": l.messages, "reason": l.reason,
            })).collect::<Vec<_>>(),
            "lost_messages": report.lost_messages(),
            "summary": bag.summary().is_some(),
            "topics": report.topics.iter().map(|t| serde_json::json!({
                "name": t.name, "type": t.type_name, "count": t.count,
            })).collect::<Vec<_>>(),
            "custom_data": custom_data,
        });
        outln!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    outln!("bag:       {}", bag.dir().display());
    outln!(
        "file:      {} ({} bytes, {} chunks)",
        bag.mcap_path().display(),
        bag.file_bytes(),
        report.chunks.len()
    );
    outln!("messages:  {}", report.messages);
    outln!(
        "start:     {:.3} s (simulated clock)",
        start_ns as f64 * 1e-9
    );
    outln!("duration:  {duration_s:.3} s");
    if !report.losses.is_empty() {
        let unknown = report.losses.iter().any(|l| l.messages.is_none());
        outln!(
            "recovered: skipped {} damaged part(s), {} messages lost{}",
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
        outln!("recovered: read up to the last complete chunk ({stopped})");
    }
    if undecodable > 0 {
        outln!("undecodable messages: {undecodable}");
    }
    print_topics(&report.topics);
    Ok(())
}

fn print_topics(topics: &[nrslam_runtime::bag::TopicSummary]) {
    outln!("{:<24} {:<32} {:>8}", "topic", "type", "count");
    for topic in topics {
        outln!(
            "{:<24} {:<32} {:>8}",
            topic.name,
            topic.type_name,
            topic.count
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
    if json {
        let json = serde_json::json!({
            "path": bag.dir().display().to_string(),
            "file": bag.mcap_path().display().to_string(),
            "file_bytes": bag.file_bytes(),
            "messages": messages,
            "chunks": summary.chunk_count,
            "start_ns": start_ns,
            "duration_ns": end_ns - start_ns,
            "undecodable": null,
            "summary": true,
            "topics": summary.topics.iter().map(|t| serde_json::json!({
                "name": t.name, "type": t.type_name, "count": t.count,
            })).collect::<Vec<_>>(),
            "custom_data": bag.custom_data(),
        });
        outln!("{}", serde_json::to_string_pretty(&json)?);
        return Ok(());
    }
    outln!("bag:       {}", bag.dir().display());
    outln!(
        "file:      {} ({} bytes, {} chunks)",
        bag.mcap_path().display(),
        bag.file_bytes(),
        summary.chunk_count
    );
    outln!("messages:  {messages} (from the MCAP summary, not read)");
    outln!(
        "start:     {:.3} s (simulated clock)",
        start_ns as f64 * 1e-9
    );
    outln!("duration:  {:.3} s", (end_ns - start_ns) as f64 * 1e-9);
    print_topics(&summary.topics);
    Ok(())
}

/// `nrslam bag play`.
pub fn play(args: PlayArgs) -> Result<()> {
    crate::flags::check("--rate", crate::flags::RATE.check(args.rate))?;
    if !(args.match_timeout_s.is_finite() && (0.0..=3600.0).contains(&args.match_timeout_s)) {
        bail!(
            "--match-timeout-s: {} is out of range (allowed: 0 to 3600 s)",
            args.match_timeout_s
        );
    }
    let bag = open_bag(&args.dir, args.recover)?;
    // The topics to play, known before publishing: from the summary or metadata.yaml, else (a
    // recovered recording) from one pass over the file.
    let recorded = match bag.topics() {
        Some(topics) => topics,
        None => bag.survey()?.topics,
    };
    for topic in &args.topics {
        if !recorded.iter().any(|t| &t.name == topic) {
            bail!(
                "{}: topic {topic} is not in the bag (recorded: {})",
                args.dir.display(),
                recorded
                    .iter()
                    .map(|t| t.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    let mut played: Vec<&'static str> = Vec::new();
    for topic in &recorded {
        if !args.topics.is_empty() && !args.topics.contains(&topic.name) {
            continue;
        }
        let spec = topics::spec(&topic.name).ok_or_else(|| {
            anyhow!(
                "{}: topic {} is not a topic of the nrslam graph (use --topics to leave it out)",
                args.dir.display(),
                topic.name
            )
        })?;
        if !played.contains(&spec.name) {
            played.push(spec.name);
        }
    }
    let session = session(&args.transport)?;
    let style = match args.ros_domain_id {
        Some(domain_id) => KeyStyle::RmwZenoh { domain_id },
        None => KeyStyle::Nrslam,
    };
    let mut publisher =
        TopicPublisher::with_style(&session, &args.transport.namespace, &played, style)?;
    let deadline = Instant::now() + Duration::from_secs_f64(args.match_timeout_s);
    while !publisher.all_matched() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    let stop = interrupted();
    let mut published = 0u64;
    let selected: Vec<String> = played.iter().map(|t| (*t).to_owned()).collect();
    'outer: loop {
        let mut pacer = Pacer::new(args.rate);
        let bar = byte_progress(bag.file_bytes(), "playing");
        let mut stream = bag.messages_on(&selected)?;
        while let Some(message) = stream.next() {
            if stop.load(Ordering::SeqCst) {
                break 'outer;
            }
            let message = message?;
            let topic = played
                .iter()
                .copied()
                .find(|t| *t == message.topic)
                .ok_or_else(|| {
                    anyhow!("{}: unexpected topic {}", args.dir.display(), message.topic)
                })?;
            pacer.pace(message.log_time_ns as f64 * 1e-9);
            publisher.publish_cdr(topic, message.data)?;
            published += 1;
            if published.is_multiple_of(256) {
                bar.set_position(stream.position());
            }
        }
        bar.finish_and_clear();
        print_losses(stream.report());
        if !args.repeat {
            break;
        }
    }
    if !stop.load(Ordering::SeqCst) {
        for topic in &played {
            publisher.end(topic)?;
        }
    }
    // Let the last publications leave before the session closes.
    std::thread::sleep(Duration::from_millis(200));
    let _ = session.close().wait();
    outln!("played {published} messages on {} topic(s)", played.len());
    Ok(())
}
