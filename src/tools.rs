//! Inspection and scoring verbs: `topics`, `echo`, `metric`, `segment`.

use crate::flags::{self, Real, Whole};
use crate::TransportArgs;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use nrslam_evaluator::csv_io::{MAX_CSV_BYTES, MAX_CSV_ROWS};
use nrslam_evaluator::{DistanceMode, EtGospaParams};
use nrslam_msgs::topics;
use nrslam_runtime::receive::{Delivery, Inbox, InboxOptions, Overload, ReceiveError};
use nrslam_runtime::transport::{self, SessionMode};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// `nrslam topics`.
#[derive(Args, Debug)]
pub struct TopicsArgs {
    /// Seconds to listen to a live graph (with --connect or --listen) before listing what it
    /// publishes, 0.001 to 3600 s.
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0, value_parser = LISTEN_S.parser(), allow_hyphen_values = true)]
    pub duration_s: f64,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `nrslam echo`.
#[derive(Args, Debug)]
pub struct EchoArgs {
    /// Topic name, e.g. /slam/pose.
    pub topic: String,
    /// Stop after this many messages, 0 to 2^64 − 1 (0: until the topic's stream ends or Ctrl-C).
    #[arg(long, default_value_t = 0, value_parser = COUNT.parser::<u64>(), allow_hyphen_values = true)]
    pub count: u64,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `nrslam metric`.
#[derive(Args, Debug)]
pub struct MetricArgs {
    /// Truth CSV with header `target,x,y`: one row per sample point (slot) of each extended target
    /// (each file at most 1 GiB and 16777216 rows). Only pairs within the cut-off c interact, so
    /// the assignment splits into connected components; each must have at most 2^26 truth points ×
    /// estimates.
    #[arg(long, value_name = "FILE")]
    pub truth: PathBuf,
    /// Estimates CSV with header `x,y`: one row per estimated point (m).
    #[arg(long, value_name = "FILE")]
    pub estimates: PathBuf,
    /// Cut-off distance c (m; m² with --squared-distance): the largest error counted per point,
    /// 1e-12 to 1e12 (and c^p between 1e-100 and 1e100).
    #[arg(
        long = "c",
        value_name = "C",
        default_value_t = 5.0,
        value_parser = CUTOFF.parser(),
        allow_hyphen_values = true
    )]
    pub c: f64,
    /// Order 1 ≤ p ≤ 1000, or `inf` for p = ∞ (c^p must stay between 1e-100 and 1e100): larger
    /// p penalises outliers more.
    #[arg(
        long = "p",
        value_name = "P",
        default_value = "1",
        allow_hyphen_values = true
    )]
    pub p: String,
    /// Cardinality penalty 0 < α ≤ 2: a missed slot or false estimate costs c^p/α.
    #[arg(
        long = "alpha",
        value_name = "A",
        default_value_t = 2.0,
        value_parser = ALPHA.parser(),
        allow_hyphen_values = true
    )]
    pub alpha: f64,
    /// ET-GOPSA distance to a target: to its nearest sample point (`samples`, the paper) or to the
    /// polygon through its samples in file order (`outline`).
    #[arg(long, default_value = "samples", value_name = "MODE")]
    pub distance: String,
    /// Use squared distances inside the cut-off, as the paper's formula literally writes.
    #[arg(long)]
    pub squared_distance: bool,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// `nrslam segment`.
#[derive(Args, Debug)]
pub struct SegmentArgs {
    /// Input CSV with header `x,y` (m); at most 1 GiB and 16777216 rows.
    #[arg(long, value_name = "FILE")]
    pub input: PathBuf,
    /// DBSCAN neighbourhood radius (m): points within eps are neighbours, 0 to 1e9 m.
    #[arg(long, value_name = "M", value_parser = EPS_M.parser(), allow_hyphen_values = true)]
    pub eps: f64,
    /// DBSCAN minimum neighbourhood size, the point itself included, 1 to 4294967295.
    #[arg(long, value_name = "K", value_parser = MIN_SAMPLES.parser::<usize>(), allow_hyphen_values = true)]
    pub min_samples: usize,
    /// Output CSV `x,y,label` (label -1: noise). Default: standard output.
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

/// `topics --duration-s`.
const LISTEN_S: Real = Real::closed(1e-3, 3600.0, "0.001 to 3600 s");
/// `echo --count`.
const COUNT: Whole = Whole::new(0, u64::MAX, "0 to 18446744073709551615 messages");
/// `metric --c`.
const CUTOFF: Real = Real::closed(1e-12, 1e12, "1e-12 to 1e12 m (m² with --squared-distance)");
/// `metric --p` (finite values; `inf` is allowed too).
const ORDER: Real = Real::closed(1.0, 1000.0, "1 to 1000, or inf");
/// `metric --alpha`.
const ALPHA: Real = Real {
    min: 0.0,
    max: 2.0,
    open_min: true,
    zero: false,
    allowed: "0 < alpha ≤ 2",
};
/// `segment --eps`.
const EPS_M: Real = Real::closed(0.0, 1e9, "0 to 1e9 m");
/// `segment --min-samples`.
const MIN_SAMPLES: Whole = Whole::new(1, u32::MAX as u64, "1 to 4294967295 points");

impl TopicsArgs {
    /// Checks `--duration-s`; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check("--duration-s", LISTEN_S.check(self.duration_s)).map(drop)
    }
}

impl EchoArgs {
    /// Every `--count` is allowed (clap refuses what is not a u64).
    pub fn validate(&self) -> Result<()> {
        flags::check("--count", COUNT.check(self.count)).map(drop)
    }
}

impl MetricArgs {
    /// The metric parameters the flags give, each checked; the error names the flag.
    pub fn params(&self) -> Result<EtGospaParams> {
        let c = flags::check("--c", CUTOFF.check(self.c))?;
        let p = match self.p.trim() {
            "inf" | "∞" | "infinity" => f64::INFINITY,
            text => flags::check("--p", ORDER.parse(text))?,
        };
        let alpha = flags::check("--alpha", ALPHA.check(self.alpha))?;
        let distance = match self.distance.as_str() {
            "samples" => DistanceMode::Samples,
            "outline" => DistanceMode::Outline,
            other => bail!("--distance: {other:?} is not a mode (allowed: samples, outline)"),
        };
        let params = EtGospaParams {
            c,
            p,
            alpha,
            distance,
            squared_distance: self.squared_distance,
        };
        // The joint limits (c^p, c^p/α), named by the metric's field: `--c`, `--p` or `--alpha`.
        params
            .validate()
            .map_err(|e| anyhow!("--{}: {} (allowed: {})", e.field, e.problem, e.allowed))?;
        Ok(params)
    }

    /// Checks every flag; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        self.params().map(drop)
    }
}

impl SegmentArgs {
    /// Checks `--eps` and `--min-samples`; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check("--eps", EPS_M.check(self.eps))?;
        flags::check("--min-samples", MIN_SAMPLES.check(self.min_samples as u64))?;
        Ok(())
    }
}

fn session_for(args: &TransportArgs) -> Result<zenoh::Session> {
    if args.listen.is_empty() && args.connect.is_empty() {
        bail!("give --connect ENDPOINT (e.g. the --listen endpoint of a running `nrslam launch`) or --listen ENDPOINT");
    }
    let config = args.config(SessionMode::Peer);
    transport::open(&config).context("opening the zenoh session")
}

/// `nrslam topics`.
pub fn topics(args: TopicsArgs) -> Result<()> {
    args.validate()?;
    if args.transport.listen.is_empty() && args.transport.connect.is_empty() {
        outln!(
            "{:<24} {:<32} {:<16} description",
            "topic",
            "type",
            "durability"
        );
        for spec in topics::CATALOGUE {
            let durability = match spec.qos.durability {
                topics::Durability::Volatile => "volatile",
                topics::Durability::TransientLocal => "transient-local",
            };
            outln!(
                "{:<24} {:<32} {:<16} {}",
                spec.name,
                spec.type_name,
                durability,
                spec.description
            );
        }
        return Ok(());
    }
    let listen = flags::seconds("--duration-s", args.duration_s)?;
    flags::deadline("--duration-s", listen)?;
    let session = session_for(&args.transport)?;
    let names: Vec<&'static str> = topics::CATALOGUE.iter().map(|t| t.name).collect();
    let mut inbox = Inbox::subscribe(
        &session,
        &args.transport.namespace,
        &names,
        observer_options(&args.transport)?,
    )?;
    let deadline = flags::deadline("--duration-s", listen)?;
    let mut counts: BTreeMap<&'static str, u64> = BTreeMap::new();
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        if let Some(Delivery::Message { topic, .. }) = inbox.recv_timeout(left)? {
            *counts.entry(topic).or_default() += 1;
        }
    }
    report_drops(&inbox);
    outln!(
        "{:<24} {:<32} messages in {} s",
        "topic",
        "type",
        args.duration_s
    );
    for spec in topics::CATALOGUE {
        if let Some(count) = counts.get(spec.name) {
            outln!("{:<24} {:<32} {count}", spec.name, spec.type_name);
        }
    }
    let _ = session.close().wait();
    Ok(())
}

/// `nrslam echo`.
pub fn echo(args: EchoArgs) -> Result<()> {
    args.validate()?;
    let spec = topics::spec(&args.topic).ok_or_else(|| {
        anyhow!(
            "unknown topic {:?} (known: {})",
            args.topic,
            topics::CATALOGUE
                .iter()
                .map(|t| t.name)
                .collect::<Vec<_>>()
                .join(", ")
        )
    })?;
    let session = session_for(&args.transport)?;
    let mut inbox = Inbox::subscribe(
        &session,
        &args.transport.namespace,
        &[spec.name],
        observer_options(&args.transport)?,
    )?;
    let mut seen = 0u64;
    let stop = crate::bag::interrupted();
    while !stop.load(std::sync::atomic::Ordering::SeqCst) {
        match inbox.recv_timeout(Duration::from_millis(200)) {
            Ok(Some(Delivery::End { .. })) | Err(ReceiveError::Closed) => break,
            Ok(Some(Delivery::Message { message, .. })) => {
                outln!("{}", message_json(&message)?);
                seen += 1;
                if args.count > 0 && seen >= args.count {
                    break;
                }
            }
            Ok(None) => {}
            Err(error) => return Err(error.into()),
        }
    }
    report_drops(&inbox);
    let _ = session.close().wait();
    Ok(())
}

/// An observer keeps the newest samples rather than slow the graph down, and shows them in
/// arrival order (a bag played in a loop starts its stamps over).
fn observer_options(transport: &TransportArgs) -> Result<InboxOptions> {
    Ok(InboxOptions {
        overload: Overload::KeepNewest(OBSERVER_QUEUE),
        in_order: false,
        ..transport.inbox_options()?
    })
}

/// Samples an observer queues per topic before it drops the oldest.
const OBSERVER_QUEUE: usize = 256;

/// One line on stderr per topic and reason dropped, if any.
fn report_drops(inbox: &Inbox) {
    for (topic, reason, n) in inbox.drops().iter() {
        eprintln!("warning: {topic}: {n} samples dropped ({reason})");
    }
}

fn message_json(message: &nrslam_msgs::Message) -> Result<String> {
    use nrslam_msgs::Message as M;
    Ok(match message {
        M::Clock(m) => serde_json::to_string(m)?,
        M::Odometry(m) => serde_json::to_string(m)?,
        M::PoseStamped(m) => serde_json::to_string(m)?,
        M::OccupancyGrid(m) => serde_json::to_string(m)?,
        M::Detections(m) => serde_json::to_string(m)?,
        M::Keyframe(m) => serde_json::to_string(m)?,
        M::Segments(m) => serde_json::to_string(m)?,
        M::TargetSet(m) => serde_json::to_string(m)?,
        M::Metrics(m) => serde_json::to_string(m)?,
        M::RadarEcho(m) => serde_json::to_string(m)?,
        M::RadarSpectrum(m) => serde_json::to_string(m)?,
        M::KeyframePoses(m) => serde_json::to_string(m)?,
        M::AssociationStats(m) => serde_json::to_string(m)?,
        M::DiagnosticArray(m) => serde_json::to_string(m)?,
        M::RadarScan(m) => serde_json::to_string(m)?,
        M::PointCloud2(m) => serde_json::to_string(m)?,
        M::TFMessage(m) => serde_json::to_string(m)?,
        M::Path(m) => serde_json::to_string(m)?,
        M::MarkerArray(m) => serde_json::to_string(m)?,
    })
}

/// `nrslam metric`.
pub fn metric(args: MetricArgs) -> Result<()> {
    let params = args.params()?;
    let report = nrslam_evaluator::evaluate_files(&args.truth, &args.estimates, &params)?;
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        outln!(
            "targets {}, truth points {}, estimates {}",
            report.target_count,
            report.truth_point_count,
            report.estimate_count
        );
        outln!(
            "{:<10} {:>12} {:>14} {:>12} {:>12} {:>12}",
            "metric",
            "total",
            "localisation",
            "confusion",
            "missed",
            "false"
        );
        let g = &report.gospa;
        outln!(
            "{:<10} {:>12.6} {:>14.6} {:>12} {:>12.6} {:>12.6}",
            "GOSPA",
            g.total,
            g.localisation,
            "-",
            g.missed,
            g.false_estimates
        );
        let e = &report.etgospa;
        outln!(
            "{:<10} {:>12.6} {:>14.6} {:>12.6} {:>12.6} {:>12.6}",
            "ET-GOPSA",
            e.total,
            e.localisation,
            e.confusion,
            e.missed,
            e.false_estimates
        );
        outln!("(terms are summed p-th powers; total = (sum of terms)^(1/p))");
    }
    Ok(())
}

/// `nrslam segment`.
pub fn segment(args: SegmentArgs) -> Result<()> {
    args.validate()?;
    let path = &args.input;
    // Streamed, and refused past the limits `nrslam metric` has, before reading it whole.
    let file =
        std::fs::File::open(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
    if size > MAX_CSV_BYTES {
        bail!(
            "{}: {size} bytes is more than the limit of {MAX_CSV_BYTES} bytes",
            path.display()
        );
    }
    // (A pipe has no size: it is cut at the limit.)
    let mut reader = csv::Reader::from_reader(std::io::Read::take(file, MAX_CSV_BYTES));
    let headers = reader
        .headers()
        .with_context(|| format!("{}: no header row", path.display()))?
        .clone();
    let column = |name: &str| {
        headers
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| {
                anyhow!(
                    "{}: no column {name:?} in header (expected x,y)",
                    path.display()
                )
            })
    };
    let (x_column, y_column) = (column("x")?, column("y")?);
    let mut points = Vec::new();
    for (index, record) in reader.records().enumerate() {
        let line = index + 2;
        let record = record.with_context(|| format!("{}: line {line}", path.display()))?;
        let value = |column: usize, name: &str| -> Result<f64> {
            let text = record.get(column).unwrap_or("").trim();
            let value: f64 = text.parse().map_err(|_| {
                anyhow!(
                    "{}: line {line}, column {name}: {text:?} is not a number",
                    path.display()
                )
            })?;
            if !value.is_finite() {
                bail!(
                    "{}: line {line}, column {name}: {text:?} is not finite",
                    path.display()
                );
            }
            Ok(value)
        };
        if points.len() as u64 >= MAX_CSV_ROWS {
            bail!(
                "{}: more than {MAX_CSV_ROWS} rows (the limit of `nrslam segment`)",
                path.display()
            );
        }
        points.push([value(x_column, "x")?, value(y_column, "y")?]);
    }
    let clustering = nrslam_segmenter::dbscan(&points, args.eps, args.min_samples)
        .map_err(|e| anyhow!("--eps/--min-samples: {e}"))?;
    let sink: Box<dyn std::io::Write> = match &args.output {
        Some(out) => Box::new(
            std::fs::File::create(out)
                .with_context(|| format!("{}: cannot create", out.display()))?,
        ),
        None => Box::new(std::io::stdout().lock()),
    };
    let mut writer = csv::Writer::from_writer(sink);
    writer.write_record(["x", "y", "label"])?;
    for (point, label) in points.iter().zip(&clustering.labels) {
        writer.write_record([
            point[0].to_string(),
            point[1].to_string(),
            label.to_string(),
        ])?;
    }
    writer.flush()?;
    if args.output.is_some() {
        eprintln!(
            "{} points, {} clusters, {} noise",
            points.len(),
            clustering.cluster_count,
            clustering.noise_count()
        );
    }
    Ok(())
}
