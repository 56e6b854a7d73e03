//! `nrslam montecarlo` and `nrslam merge`: the paper's 500-trial curves (Figs. 6, 7).
//!
//! Trial i runs the launch's graph in-process with run seed `seed::trial(seed, i)`, so a trial's
//! result depends on (seed, i) alone: not on the thread count, nor on which shard ran it.
//! Trials run in parallel (rayon) and are collected in trial order. Each output folder keeps the
//! raw per-trial rows (`trials.csv`); the per-step statistics (`montecarlo.csv`) are always
//! computed from the rows sorted by trial, so merging shards reproduces the unsharded files byte
//! for byte.

use crate::cmd::launch::build_all;
use crate::flags;
use crate::flags::Whole;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_runtime::compose::Graph;
use nrslam_runtime::launch::Launch;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Metrics kept per step and trial, in `trials.csv` column order.
const METRICS: [&str; 4] = ["etgospa", "gospa", "position_error_m", "estimated_targets"];

/// `nrslam montecarlo`.
#[derive(Args, Debug)]
pub struct MonteCarloArgs {
    /// Launch file (run in-process for every trial).
    pub file: PathBuf,
    /// Launch arguments as name:=value, and node parameters as node.param:=value (nested:
    /// node.table.key:=value; the value is read as TOML, e.g. association.scan_matching:=false).
    #[arg(value_name = "NAME:=VALUE")]
    pub assignments: Vec<String>,
    /// Number of trials in the whole study (the paper: 500), 1 to 100000: every trial's per-step
    /// rows are held until the end (about 12 KB per 294-frame trial, 1.2 GB at the limit).
    #[arg(long, value_parser = TRIALS.parser::<u64>(), allow_hyphen_values = true)]
    pub trials: u64,
    /// Base seed; trial i runs with a seed derived from (seed, i) (0 to 2^64 − 1).
    #[arg(long, default_value_t = 1, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: u64,
    /// Run only shard K of N (1-based, e.g. 2/4): trials K-1, K-1+N, ... Merge the shards' folders
    /// with `nrslam merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Worker threads, 1 to 1024 (default: all cores). Results do not depend on it.
    #[arg(long, value_parser = THREADS.parser::<usize>(), allow_hyphen_values = true)]
    pub threads: Option<usize>,
    #[command(flatten)]
    pub out: crate::args::OutputDirArgs,
}

/// `nrslam merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// Output folders of `nrslam montecarlo --shard` runs of the same study.
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    #[command(flatten)]
    pub out: crate::args::OutputDirArgs,
}

/// One trial's per-step values: `(time_s, [metric values])`.
pub(crate) type TrialRows = Vec<(f64, [f64; 4])>;

/// `--trials` of a study (also `nrslam reproduce --trials`).
pub(crate) const TRIALS: Whole = Whole::new(1, 100_000, "1 to 100000 trials");
/// `--threads`.
const THREADS: Whole = Whole::new(1, 1024, "1 to 1024 threads");

impl MonteCarloArgs {
    /// Checks every numeric flag (and `--shard`); the error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check("--trials", TRIALS.check(self.trials))?;
        if let Some(threads) = self.threads {
            flags::check("--threads", THREADS.check(threads as u64))?;
        }
        if let Some(text) = &self.shard {
            parse_shard(text)?;
        }
        Ok(())
    }
}

fn parse_shard(text: &str) -> Result<(u64, u64)> {
    let (k, n) = text
        .split_once('/')
        .ok_or_else(|| anyhow!("--shard: expected K/N, got {text:?}"))?;
    let (k, n): (u64, u64) = (
        k.trim()
            .parse()
            .map_err(|_| anyhow!("--shard: {k:?} is not a number"))?,
        n.trim()
            .parse()
            .map_err(|_| anyhow!("--shard: {n:?} is not a number"))?,
    );
    if n == 0 || k == 0 || k > n {
        bail!("--shard: {text} is out of range (allowed: 1 ≤ K ≤ N)");
    }
    Ok((k - 1, n))
}

pub(crate) fn run_trial(launch: &Launch, seed: u64) -> Result<TrialRows> {
    let nodes = build_all(launch, seed)?.nodes;
    // Only the metrics are kept: a whole run's reporter would copy every map and segmentation.
    let mut rows = TrialRows::new();
    Graph::new(nodes).run(&mut |topic: &'static str, message: &nrslam_msgs::Message| {
        if let (nrslam_msgs::topics::METRICS, nrslam_msgs::Message::Metrics(m)) = (topic, message) {
            rows.push((
                m.header.stamp.as_seconds(),
                [
                    m.etgospa,
                    m.gospa,
                    m.position_error_m,
                    m.estimated_targets as f64,
                ],
            ));
        }
    })?;
    Ok(rows)
}

/// `nrslam montecarlo`.
pub fn montecarlo(args: MonteCarloArgs) -> Result<()> {
    args.validate()?;
    let (shard, shards) = match &args.shard {
        Some(text) => parse_shard(text)?,
        None => (0, 1),
    };
    let launch = Launch::load(&args.file, &args.assignments)?;
    // Fail on bad parameters before spending any time.
    build_all(&launch, args.seed)?;
    let indices: Vec<u64> = (0..args.trials).filter(|i| i % shards == shard).collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("starting worker threads")?;
    let bar = ProgressBar::new(indices.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} trials  {elapsed_precise} ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let results: Vec<Result<(u64, TrialRows)>> = pool.install(|| {
        indices
            .par_iter()
            .map(|&i| {
                let rows = run_trial(&launch, nrslam_runtime::seed::trial(args.seed, i))
                    .with_context(|| format!("trial {i}"));
                bar.inc(1);
                rows.map(|rows| (i, rows))
            })
            .collect()
    });
    bar.finish_and_clear();
    let trials: BTreeMap<u64, TrialRows> = results.into_iter().collect::<Result<_>>()?;
    let header = serde_json::json!({
        "launch": launch.path.display().to_string(),
        "arguments": launch.arguments.iter().map(|(k, v)| (k.clone(), v.to_string())).collect::<BTreeMap<_, _>>(),
        "seed": args.seed,
        "trials_in_study": args.trials,
    });
    write_study(&args.out, &header, &trials)?;
    outln!("{} trials; wrote {}", trials.len(), args.out.dir.display());
    Ok(())
}

fn write_study(
    out: &crate::args::OutputDirArgs,
    header: &serde_json::Value,
    trials: &BTreeMap<u64, TrialRows>,
) -> Result<()> {
    let out = out.create()?;
    let path = out.join("trials.csv");
    let mut writer = csv::Writer::from_path(&path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    let mut columns = vec!["trial", "step", "time_s"];
    columns.extend(METRICS);
    writer.write_record(&columns)?;
    for (trial, rows) in trials {
        for (step, (time_s, values)) in rows.iter().enumerate() {
            let mut record = vec![trial.to_string(), step.to_string(), time_s.to_string()];
            record.extend(values.iter().map(|v| v.to_string()));
            writer.write_record(&record)?;
        }
    }
    writer.flush()?;
    // Per-step statistics over trials, in trial order.
    let steps = trials.values().map(Vec::len).max().unwrap_or(0);
    let path = out.join("montecarlo.csv");
    let mut writer = csv::Writer::from_path(&path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    let mut columns = vec!["step".to_owned(), "time_s".to_owned(), "trials".to_owned()];
    for metric in METRICS {
        columns.push(format!("{metric}_mean"));
        columns.push(format!("{metric}_std"));
    }
    columns.push("position_mse_m2".to_owned());
    writer.write_record(&columns)?;
    for step in 0..steps {
        let rows: Vec<&(f64, [f64; 4])> =
            trials.values().filter_map(|rows| rows.get(step)).collect();
        let n = rows.len() as f64;
        let mut record = vec![
            step.to_string(),
            rows[0].0.to_string(),
            rows.len().to_string(),
        ];
        for metric in 0..METRICS.len() {
            let mean = rows.iter().map(|r| r.1[metric]).sum::<f64>() / n;
            let variance = if rows.len() > 1 {
                rows.iter()
                    .map(|r| (r.1[metric] - mean).powi(2))
                    .sum::<f64>()
                    / (n - 1.0)
            } else {
                0.0
            };
            record.push(mean.to_string());
            record.push(variance.sqrt().to_string());
        }
        record.push((rows.iter().map(|r| r.1[2] * r.1[2]).sum::<f64>() / n).to_string());
        writer.write_record(&record)?;
    }
    writer.flush()?;
    let mut summary = header.clone();
    summary["trials"] = serde_json::json!(trials.len());
    summary["trial_indices"] = serde_json::json!(trials.keys().collect::<Vec<_>>());
    std::fs::write(
        out.join("study.json"),
        serde_json::to_string_pretty(&summary)? + "\n",
    )?;
    Ok(())
}

fn read_trials(dir: &Path) -> Result<BTreeMap<u64, TrialRows>> {
    let path = dir.join("trials.csv");
    let mut reader = csv::Reader::from_path(&path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let mut trials: BTreeMap<u64, TrialRows> = BTreeMap::new();
    for (line, record) in reader.records().enumerate() {
        let record = record.with_context(|| format!("{}: line {}", path.display(), line + 2))?;
        let number = |i: usize| -> Result<f64> {
            record.get(i).and_then(|t| t.parse().ok()).ok_or_else(|| {
                anyhow!(
                    "{}: line {}, column {}: not a number",
                    path.display(),
                    line + 2,
                    i + 1
                )
            })
        };
        let trial = number(0)? as u64;
        let values = [number(3)?, number(4)?, number(5)?, number(6)?];
        trials.entry(trial).or_default().push((number(2)?, values));
    }
    Ok(trials)
}

/// `nrslam merge`.
pub fn merge(args: MergeArgs) -> Result<()> {
    let mut all: BTreeMap<u64, TrialRows> = BTreeMap::new();
    let mut header: Option<serde_json::Value> = None;
    for dir in &args.shards {
        let study: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.join("study.json"))
                .with_context(|| format!("{}: no study.json", dir.display()))?,
        )?;
        let this = serde_json::json!({"launch": study["launch"], "arguments": study["arguments"], "seed": study["seed"], "trials_in_study": study["trials_in_study"]});
        match &header {
            Some(first) if *first != this => bail!(
                "{}: a different study (launch, arguments, seed or trial count differ)",
                dir.display()
            ),
            _ => header = Some(this),
        }
        for (trial, rows) in read_trials(dir)? {
            if all.insert(trial, rows).is_some() {
                bail!("{}: trial {trial} appears in two shards", dir.display());
            }
        }
    }
    let header = header.ok_or_else(|| anyhow!("no shard given"))?;
    write_study(&args.out, &header, &all)?;
    outln!(
        "{} trials merged into {}",
        all.len(),
        args.out.dir.display()
    );
    Ok(())
}
