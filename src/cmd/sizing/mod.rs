//! `nrslam sizing`: the cheapest spectrum, antennas, SNR, estimator and back end that meet a
//! factory's accuracy requirement, the inverse of the paper's conclusion (docs/sizing.md).
//!
//! A requirement file names the scene (or a family of random scenes), the requirement (a
//! per-trial metric's mean at or below a threshold, at a confidence), the search space and the
//! price of each resource. Then:
//!
//! 1. every configuration of the search space (and the paper's own) is screened with closed-form
//!    bounds (`screen.rs`): one that cannot meet the requirement is dropped without trials;
//! 2. the others get sequential Monte Carlo trials (`sequential.rs`, `run.rs`): trials go where
//!    a confidence interval still straddles the threshold, until each configuration is decided
//!    or its budget is spent;
//! 3. `frontier.csv`, `frontier.png` and `sizing.md` hold every configuration's outcome, the
//!    cheapest that meet the requirement per estimator, and the verdict on the paper's
//!    configuration (`frontier.rs`, `plot.rs`).
//!
//! Trials are kept as they complete (`store.rs`), so a study killed at any point resumes where
//! it stopped. Trial i of every configuration runs with the seed derived from (seed, i) and
//! scene i mod count: results depend on the seed only, not on threads, shards or restarts.
//! `--shard K/N` runs every N-th configuration into the same folder (a Slurm job array,
//! scripts/cluster/slurm-sizing.sh); a final run without `--shard` finds them decided and
//! writes the answer.
//!
//! The files: `requirement.rs` (the file's types and checks), `trial.rs` (per-trial metrics),
//! `space.rs` (configurations, cost, launch arguments), `screen.rs`, `sequential.rs`, `store.rs`,
//! `run.rs`, `frontier.rs`, `plot.rs`.

mod frontier;
mod plot;
mod requirement;
mod run;
mod screen;
mod sequential;
mod space;
mod store;
mod trial;

use crate::flags::{self, Whole};
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use requirement::Requirement;
use std::path::PathBuf;

/// `nrslam sizing`.
#[derive(Args, Debug)]
pub struct SizingArgs {
    /// Requirement file (TOML): [scene], [[requirement]], [search], [cost], [trials]; every field
    /// and its unit in docs/sizing.md, a worked example in examples/sizing/factory-agv.toml.
    #[arg(value_name = "REQUIREMENT.toml")]
    pub requirement: PathBuf,
    /// Study folder: requirement.toml and trials/ (kept as trials complete, so that the same
    /// command resumes a stopped study), then frontier.csv, frontier.png and sizing.md.
    #[command(flatten)]
    pub out: crate::args::OutputDirArgs,
    /// Run only shard K of N (1-based, e.g. 2/4): configurations K−1, K−1+N, ... of the study,
    /// into the same --out folder. A run without --shard then writes the answer.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<String>,
    /// Worker threads, 1 to 1024 threads (default: all cores). Results do not depend on it.
    #[arg(long, value_parser = THREADS.parser::<usize>(), allow_hyphen_values = true)]
    pub threads: Option<usize>,
    /// Simulate the configurations the closed-form screen drops as well (frontier.csv still
    /// shows the screen's verdict in its `screen` column): how the screen is checked.
    #[arg(long)]
    pub no_screen: bool,
}

/// `--threads`.
const THREADS: Whole = Whole::new(1, 1024, "1 to 1024 threads");

impl SizingArgs {
    /// Checks every numeric flag (and `--shard`); the error names the flag.
    pub fn validate(&self) -> Result<()> {
        if let Some(threads) = self.threads {
            flags::check("--threads", THREADS.check(threads as u64))?;
        }
        if let Some(text) = &self.shard {
            parse_shard(text)?;
        }
        Ok(())
    }
}

/// `K/N` as (K − 1, N).
fn parse_shard(text: &str) -> Result<(usize, usize)> {
    let (k, n) = text
        .split_once('/')
        .ok_or_else(|| anyhow!("--shard: expected K/N, got {text:?}"))?;
    let parse = |part: &str| {
        part.trim()
            .parse::<usize>()
            .map_err(|_| anyhow!("--shard: {part:?} is not a number"))
    };
    let (k, n) = (parse(k)?, parse(n)?);
    if n == 0 || k == 0 || k > n {
        bail!("--shard: {text} is out of range (allowed: 1 ≤ K ≤ N)");
    }
    Ok((k - 1, n))
}

/// The requirement with its paths made absolute: the study's identity, whatever folder the
/// command runs from.
fn canonical(mut requirement: Requirement) -> Result<Requirement> {
    let absolute = |path: &PathBuf| {
        std::fs::canonicalize(path).with_context(|| format!("cannot find {}", path.display()))
    };
    requirement.scene.launch = absolute(&requirement.scene.launch)?;
    if let Some(file) = &requirement.scene.file {
        requirement.scene.file = Some(absolute(file)?);
    }
    Ok(requirement)
}

/// `nrslam sizing`.
pub fn sizing(args: SizingArgs) -> Result<()> {
    args.validate()?;
    let shard = args.shard.as_deref().map(parse_shard).transpose()?;
    let requirement = canonical(Requirement::load(&args.requirement)?)?;
    let identity = toml::to_string(&requirement).context("writing the requirement")?;
    let dir = args.out.create()?;
    let store = store::Store::open(dir, &identity)?;
    let scenes = run::scenes(&requirement, dir)?;
    let fewest_targets = run::fewest_targets(&requirement, &scenes)?;
    let configs = space::configurations(&requirement);
    let verdicts: Vec<screen::Verdict> = configs
        .iter()
        .map(|c| screen::screen(c, &requirement, fewest_targets))
        .collect();
    let simulated = |i: usize| args.no_screen || verdicts[i].drop.is_none();
    let mine = |i: usize| shard.is_none_or(|(k, n)| i % n == k);
    let mut jobs = Vec::new();
    for (i, config) in configs.iter().enumerate() {
        if simulated(i) && mine(i) {
            jobs.push(run::Job {
                config,
                launches: run::load(&requirement, config, &scenes)?,
                trials: store.load(&config.id())?,
            });
        }
    }
    let dropped = (0..configs.len()).filter(|&i| !simulated(i)).count();
    eprintln!(
        "{} configurations: {} screened out by closed-form bounds, {} to simulate{}",
        configs.len(),
        dropped,
        jobs.len(),
        shard.map_or(String::new(), |(k, n)| format!(" in shard {}/{n}", k + 1))
    );
    run::run(&requirement, &store, &mut jobs, args.threads)?;
    if let Some((k, n)) = shard {
        outln!(
            "shard {}/{n}: {} configurations decided or at their budget in {}; `nrslam sizing {} \
             --out {}` without --shard writes the answer once every shard has run",
            k + 1,
            jobs.len(),
            dir.display(),
            args.requirement.display(),
            dir.display()
        );
        return Ok(());
    }
    let trials: Vec<Option<Vec<[f64; 5]>>> = (0..configs.len())
        .map(|i| {
            if simulated(i) {
                store.load(&configs[i].id()).map(Some)
            } else {
                Ok(None)
            }
        })
        .collect::<Result<_>>()?;
    let rows = frontier::rows(&requirement, &configs, &verdicts, &trials);
    frontier::write_csv(&dir.join("frontier.csv"), &requirement, &rows)?;
    plot::write_png(&dir.join("frontier.png"), &rows)?;
    let summary = frontier::summary(&requirement, &rows);
    std::fs::write(
        dir.join("sizing.md"),
        format!(
            "# Sizing study\n\n```\nnrslam sizing {} --out {}\n```\n\n{summary}\nEvery \
             configuration: frontier.csv; at a glance: frontier.png.\n",
            args.requirement.display(),
            dir.display()
        ),
    )
    .with_context(|| format!("cannot write {}", dir.join("sizing.md").display()))?;
    outln!("{summary}wrote {}", dir.display());
    Ok(())
}
