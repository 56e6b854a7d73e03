//! Inspection and scoring verbs: `topics`, `echo`, `metric`, `segment`.

use crate::TransportArgs;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use nrslam_evaluator::{DistanceMode, EtGospaParams};
use nrslam_msgs::topics;
use nrslam_runtime::transport::{self, SessionMode, TransportConfig};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// `nrslam topics`.
#[derive(Args, Debug)]
pub struct TopicsArgs {
    /// Seconds to listen to a live graph (with --connect or --listen) before listing what it publishes.
    #[arg(long, value_name = "SECONDS", default_value_t = 2.0)]
    pub duration_s: f64,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `nrslam echo`.
#[derive(Args, Debug)]
pub struct EchoArgs {
    /// Topic name, e.g. /slam/pose.
    pub topic: String,
    /// Stop after this many messages (0: until the topic's stream ends or Ctrl-C).
    #[arg(long, default_value_t = 0)]
    pub count: u64,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `nrslam metric`.
#[derive(Args, Debug)]
pub struct MetricArgs {
    /// Truth CSV with header `target,x,y`: one row per sample point (slot) of each extended target.
    #[arg(long, value_name = "FILE")]
    pub truth: PathBuf,
    /// Estimates CSV with header `x,y`: one row per estimated point (m).
    #[arg(long, value_name = "FILE")]
    pub estimates: PathBuf,
    /// Cut-off distance c (m; m² with --squared-distance): the largest error counted per point.
    #[arg(
        long = "c",
        value_name = "C",
        default_value_t = 5.0,
        allow_negative_numbers = true
    )]
    pub c: f64,
    /// Order p ≥ 1 (`inf` for p = ∞): larger p penalises outliers more.
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
        allow_negative_numbers = true
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
    /// Input CSV with header `x,y` (m).
    #[arg(long, value_name = "FILE")]
    pub input: PathBuf,
    /// DBSCAN neighbourhood radius (m): points within eps are neighbours.
    #[arg(long, value_name = "M", allow_negative_numbers = true)]
    pub eps: f64,
    /// DBSCAN minimum neighbourhood size, the point itself included (≥ 1).
    #[arg(long, value_name = "K")]
    pub min_samples: usize,
    /// Output CSV `x,y,label` (label -1: noise). Default: standard output.
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

fn session_for(args: &TransportArgs) -> Result<zenoh::Session> {
    if args.listen.is_empty() && args.connect.is_empty() {
        bail!("give --connect ENDPOINT (e.g. the --listen endpoint of a running `nrslam launch`) or --listen ENDPOINT");
    }
    let config = TransportConfig {
        mode: SessionMode::Peer,
        listen: args.listen.clone(),
        connect: args.connect.clone(),
        namespace: args.namespace.clone(),
    };
    transport::open(&config).context("opening the zenoh session")
}

/// `nrslam topics`.
pub fn topics(args: TopicsArgs) -> Result<()> {
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
    if !(args.duration_s.is_finite() && args.duration_s > 0.0 && args.duration_s <= 3600.0) {
        bail!(
            "--duration-s: {} is out of range (allowed: 0 < seconds ≤ 3600)",
            args.duration_s
        );
    }
    let session = session_for(&args.transport)?;
    let names: Vec<&'static str> = topics::CATALOGUE.iter().map(|t| t.name).collect();
    let (_subscribers, received) =
        transport::subscribe(&session, &args.transport.namespace, &names)?;
    let deadline = Instant::now() + Duration::from_secs_f64(args.duration_s);
    let mut counts: BTreeMap<&'static str, u64> = BTreeMap::new();
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        if let Ok((topic, bytes)) = received.recv_timeout(left) {
            if !bytes.is_empty() {
                *counts.entry(topic).or_default() += 1;
            }
        }
    }
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
    let (_subscribers, received) =
        transport::subscribe(&session, &args.transport.namespace, &[spec.name])?;
    let mut seen = 0u64;
    while let Ok((_, bytes)) = received.recv() {
        if bytes.is_empty() {
            break;
        }
        let message = transport::decode(spec.name, &bytes)?;
        outln!("{}", message_json(&message)?);
        seen += 1;
        if args.count > 0 && seen >= args.count {
            break;
        }
    }
    let _ = session.close().wait();
    Ok(())
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
    })
}

/// `nrslam metric`.
pub fn metric(args: MetricArgs) -> Result<()> {
    let p = match args.p.trim() {
        "inf" | "∞" | "infinity" => f64::INFINITY,
        text => text
            .parse::<f64>()
            .map_err(|_| anyhow!("--p: {text:?} is not a number (allowed: 1 ≤ p, or inf)"))?,
    };
    let distance = match args.distance.as_str() {
        "samples" => DistanceMode::Samples,
        "outline" => DistanceMode::Outline,
        other => bail!("--distance: {other:?} is not a mode (allowed: samples, outline)"),
    };
    let params = EtGospaParams {
        c: args.c,
        p,
        alpha: args.alpha,
        distance,
        squared_distance: args.squared_distance,
    };
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
    let path = &args.input;
    let mut reader =
        csv::Reader::from_path(path).with_context(|| format!("{}: cannot read", path.display()))?;
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
