//! `nrslam bag play`: a bag's messages onto a graph over zenoh, paced by their log times, with
//! `ros2 bag play`'s topic selection (`--topics`, `--regex`, `--exclude-regex`,
//! `--exclude-topics`), `--remap`, `--start-offset` and `--clock`. Topics of any type are
//! published as recorded (raw CDR); with `--ros-domain-id`, under the type hash the bag recorded.

use super::selection::{endpoint, select, PlayTopic};
use super::{byte_progress, interrupted, open_bag, print_losses};
use crate::args::TransportArgs;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use nrslam_msgs::{topics, Clock, Message, Time};
use nrslam_runtime::transport::{KeyStyle, Pacer, RosEndpoint, TopicPublisher};
use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// Highest `--clock` rate (Hz) and longest `--start-offset` (s, a year).
const MAX_CLOCK_HZ: f64 = 10_000.0;
const MAX_START_OFFSET_S: f64 = 365.0 * 86_400.0;

/// `nrslam bag play`.
#[derive(Args, Debug)]
pub struct PlayArgs {
    /// Bag folder (a split bag's files are played in metadata.yaml's order).
    pub dir: PathBuf,
    #[command(flatten)]
    pub pacing: crate::args::RateArgs,
    /// Play again from the start when the bag ends, until Ctrl-C (no end-of-stream is sent).
    #[arg(long = "loop")]
    pub repeat: bool,
    /// Topics to play, by exact name (with --regex: those and the matches). Default: every
    /// topic of the bag.
    #[arg(long, value_name = "TOPIC", num_args = 1..)]
    pub topics: Vec<String>,
    /// Play the topics whose name matches this regular expression (Rust `regex` syntax,
    /// unanchored, as `ros2 bag play -e`).
    #[arg(short = 'e', long, value_name = "REGEX")]
    pub regex: Option<String>,
    /// Leave out the topics whose name matches this regular expression (as `ros2 bag play -x`);
    /// applied after --topics and --regex.
    #[arg(short = 'x', long, visible_alias = "exclude", value_name = "REGEX")]
    pub exclude_regex: Option<String>,
    /// Leave out these topics, by exact name.
    #[arg(long, value_name = "TOPIC", num_args = 1..)]
    pub exclude_topics: Vec<String>,
    /// Publish each recorded topic FROM under the name TO (repeatable; `--remap /a:=/b /c:=/d`).
    #[arg(short = 'm', long, value_name = "FROM:=TO", num_args = 1..)]
    pub remap: Vec<String>,
    /// Start this many seconds (of recorded time) after the bag's first message; earlier
    /// messages are skipped. 0 to 31536000 s.
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, value_parser = crate::flags::Real::closed(0.0, MAX_START_OFFSET_S, "0 to 31536000 s").parser(), allow_hyphen_values = true)]
    pub start_offset: f64,
    /// Publish /clock (rosgraph_msgs/msg/Clock) at HZ wall-clock ticks per second with the
    /// playback time, as `ros2 bag play --clock` (at --rate 0: every 1/HZ s of recorded time).
    /// Without a value: 40 Hz. 0.001 to 10000 Hz. The bag's own /clock messages are then left
    /// out.
    #[arg(long, value_name = "HZ", num_args = 0..=1, default_missing_value = "40", value_parser = crate::flags::Real::closed(0.001, MAX_CLOCK_HZ, "0.001 to 10000 Hz").parser())]
    pub clock: Option<f64>,
    /// Read a bag whose recorder was killed or that is damaged, up to its last complete chunk,
    /// skipping damaged chunks (each loss is printed).
    #[arg(long)]
    pub recover: bool,
    /// Seconds to wait for every played topic to have a subscriber before publishing (topics
    /// still without one are published anyway), 0 to 3600.
    #[arg(long, value_name = "SECONDS", default_value_t = 5.0)]
    pub match_timeout_s: f64,
    /// Publish as rmw_zenoh does in this ROS domain (key `<domain>/<topic>/<type>/<RIHS01 hash>`,
    /// rmw_zenoh's attachment and liveliness tokens), so ROS 2 nodes on rmw_zenoh receive the
    /// messages without a bridge. 0 to 232, ROS 2's range.
    #[arg(long, value_name = "DOMAIN_ID", value_parser = crate::cmd::launch::ROS_DOMAIN_ID.parser::<u32>(), allow_hyphen_values = true)]
    pub ros_domain_id: Option<u32>,
    #[command(flatten)]
    pub transport: TransportArgs,
}

impl PlayArgs {
    fn validate(&self) -> Result<()> {
        self.pacing.validate()?;
        if !(self.match_timeout_s.is_finite() && (0.0..=3600.0).contains(&self.match_timeout_s)) {
            bail!(
                "--match-timeout-s: {} is out of range (allowed: 0 to 3600 s)",
                self.match_timeout_s
            );
        }
        let s = self.start_offset;
        if !(s.is_finite() && (0.0..=MAX_START_OFFSET_S).contains(&s)) {
            bail!("--start-offset: {s} is out of range (allowed: 0 to {MAX_START_OFFSET_S} s)");
        }
        if let Some(hz) = self.clock {
            if !(hz.is_finite() && (0.001..=MAX_CLOCK_HZ).contains(&hz)) {
                bail!("--clock: {hz} is out of range (allowed: 0.001 to {MAX_CLOCK_HZ} Hz)");
            }
        }
        Ok(())
    }
}

/// Declares every played topic whose key is known before its first message, and `/clock` when
/// it is published; returns the declared targets. With rmw_zenoh keys a topic needs its type hash:
/// metadata.yaml's, else the catalogue's (computed), else the channel's `topic_type_hash`, known
/// only at its first message (declared then).
fn declare_known_topics(
    publisher: &mut TopicPublisher,
    played: &[PlayTopic],
    style: KeyStyle,
    clock: bool,
) -> Result<BTreeSet<String>> {
    let mut declared: BTreeSet<String> = BTreeSet::new();
    for topic in played {
        let known = topic.hash.is_some()
            || style == KeyStyle::Nrslam
            || nrslam_runtime::type_hash::rihs01(&topic.type_name).is_ok();
        if known && !declared.contains(&topic.target) {
            publisher
                .declare_raw(&endpoint(topic, topic.hash.clone()))
                .with_context(|| format!("declaring {}", topic.target))?;
            declared.insert(topic.target.clone());
        }
    }
    if clock {
        publisher.declare_raw(&RosEndpoint::catalogue(topics::CLOCK)?)?;
    }
    Ok(declared)
}

/// Sends each played target's end-of-stream mark once (and `/clock`'s).
fn end_streams(publisher: &mut TopicPublisher, played: &[PlayTopic], clock: bool) -> Result<()> {
    let mut ended = BTreeSet::new();
    for topic in played {
        if ended.insert(topic.target.as_str()) {
            publisher.end(&topic.target)?;
        }
    }
    if clock {
        publisher.end(topics::CLOCK)?;
    }
    Ok(())
}

/// `nrslam bag play`.
pub fn play(args: PlayArgs) -> Result<()> {
    args.validate()?;
    let bag = open_bag(&args.dir, args.recover)?;
    // The topics to play, known before publishing: from the summary or metadata.yaml, else (a
    // recovered recording) from one pass over the file.
    let recorded = bag.known_topics()?;
    let played = select(&args, &bag, &recorded)?;
    let session = args.transport.peer_session()?;
    let style = match args.ros_domain_id {
        Some(domain_id) => KeyStyle::RmwZenoh { domain_id },
        None => KeyStyle::Nrslam,
    };
    let mut publisher =
        TopicPublisher::with_style(&session, &args.transport.namespace, &[], style)?;
    let mut declared = declare_known_topics(&mut publisher, &played, style, args.clock.is_some())?;
    let deadline = Instant::now() + Duration::from_secs_f64(args.match_timeout_s);
    while !publisher.all_matched() && Instant::now() < deadline {
        std::thread::sleep(Duration::from_millis(20));
    }
    let stop = interrupted();
    let by_source: BTreeMap<&str, &PlayTopic> =
        played.iter().map(|p| (p.source.as_str(), p)).collect();
    let selected: Vec<String> = played.iter().map(|p| p.source.clone()).collect();
    let offset_ns = (args.start_offset * 1e9).round() as u64;
    let known_start = bag
        .summary()
        .and_then(|s| s.time_range_ns)
        .map(|(first, _)| first)
        .or_else(|| {
            bag.metadata()
                .map(|m| m.starting_time.nanoseconds_since_epoch)
        });
    // Clock ticks every `period_ns` of recorded time: 1/HZ wall seconds at the played rate.
    let period_ns = args.clock.map(|hz| {
        let scale = if args.pacing.rate > 0.0 {
            args.pacing.rate
        } else {
            1.0
        };
        ((scale / hz) * 1e9).max(1.0) as u64
    });
    let mut published = 0u64;
    'outer: loop {
        let mut pacer = Pacer::new(args.pacing.rate);
        let mut from_ns = known_start.map(|s| s.saturating_add(offset_ns));
        let mut next_tick = from_ns;
        let bar = byte_progress(bag.file_bytes(), "playing");
        let mut stream = bag.messages_on(&selected)?;
        while let Some(message) = stream.next() {
            if stop.load(Ordering::SeqCst) {
                break 'outer;
            }
            let message = message?;
            let from = *from_ns.get_or_insert(message.log_time_ns.saturating_add(offset_ns));
            if message.log_time_ns < from {
                continue;
            }
            if let Some(period) = period_ns {
                let tick = next_tick.get_or_insert(from);
                while *tick <= message.log_time_ns {
                    pacer.pace(*tick as f64 * 1e-9);
                    let clock = Message::Clock(Clock {
                        clock: Time::from_nanos(*tick),
                    });
                    publisher.publish_raw(topics::CLOCK, clock.encode()?)?;
                    *tick = tick.saturating_add(period);
                }
            }
            let topic = by_source.get(message.topic.as_str()).ok_or_else(|| {
                anyhow!("{}: unexpected topic {}", args.dir.display(), message.topic)
            })?;
            if !declared.contains(&topic.target) {
                let hash = message.recorded.type_hash().map(str::to_owned).ok_or_else(|| {
                    anyhow!(
                        "{}: topic {} ({}) has no recorded type hash, which rmw_zenoh keys need (leave it out with --exclude-topics)",
                        args.dir.display(),
                        topic.source,
                        topic.type_name
                    )
                })?;
                publisher.declare_raw(&endpoint(topic, Some(hash)))?;
                declared.insert(topic.target.clone());
            }
            pacer.pace(message.log_time_ns as f64 * 1e-9);
            publisher.publish_raw(&topic.target, message.data)?;
            published += 1;
            if published.is_multiple_of(256) {
                bar.set_position(stream.position());
            }
        }
        bar.finish_and_clear();
        print_losses(&bag, stream.report());
        if !args.repeat {
            break;
        }
    }
    if !stop.load(Ordering::SeqCst) {
        end_streams(&mut publisher, &played, args.clock.is_some())?;
    }
    // Let the last publications leave before the session closes.
    std::thread::sleep(Duration::from_millis(200));
    let _ = session.close().wait();
    let targets: BTreeSet<&str> = played.iter().map(|p| p.target.as_str()).collect();
    outln!("played {published} messages on {} topic(s)", targets.len());
    Ok(())
}
