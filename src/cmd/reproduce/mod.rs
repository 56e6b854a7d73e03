//! `nrslam reproduce`: the paper's figures as PNG with CSV beside each.
//!
//! - Fig. 3 (a–d) and Fig. 5: one run per condition (maps and DBSCAN segments), in `fig3/<condition>/`
//!   and `fig5/`.
//! - Fig. 4: the GOSPA-versus-ET-GOPSA scenario: two extended targets, estimates y1 and y2 equally
//!   far from x1, y2 farther from x2; both metrics for {y1}, {y2}, {y1, y2} (`fig4.csv`, `fig4.png`).
//! - Figs. 6 and 7: Monte Carlo means over `--trials` of ET-GOPSA and of the AGV position MSE
//!   against time for 5G and the four ideal conditions (`fig6.csv`/`.png`, `fig7.csv`/`.png`;
//!   raw trials in `montecarlo/<condition>/`); with `--super-resolution` also 5G with ESPRIT
//!   (`fig5-esprit/`, `montecarlo/5g_esprit/`).
//! - With `--oracle`, every condition's trials again at the true AGV poses
//!   (`launch/true-poses.toml`: the same seeds give the same detections), dashed in Fig. 6, and
//!   `oracle.csv`: the final ET-GOPSA of each condition, its oracle's and their ratio, i.e. what
//!   the SLAM back end costs over mapping the same detections at the true poses (near 1: little;
//!   a ratio of means can fall below 1 by chance over few trials).

mod curves;
mod fig4;

use crate::args::TransportArgs;
use crate::cmd::launch::{self, LaunchArgs};
use crate::cmd::montecarlo::{self, MonteCarloArgs};
use crate::flags::{self, Whole};
use anyhow::{Context, Result};
use clap::Args;
use curves::{curves, oracle_table};
use std::path::{Path, PathBuf};

/// `nrslam reproduce`.
#[derive(Args, Debug)]
pub struct ReproduceArgs {
    #[command(flatten)]
    pub out: crate::args::OutputDirArgs,
    /// Monte Carlo trials per condition for Figs. 6 and 7 (the paper: 500), 1 to 100000.
    #[arg(long, default_value_t = 500, value_parser = crate::cmd::montecarlo::TRIALS.parser::<u64>(), allow_hyphen_values = true)]
    pub trials: u64,
    /// Base seed (0 to 2^64 − 1).
    #[arg(long, default_value_t = 1, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: u64,
    /// Radar frames per run, 0 to 1000000 (0: the whole lap); fewer for a quick look.
    #[arg(long, default_value_t = 0, value_parser = FRAMES.parser::<u32>(), allow_hyphen_values = true)]
    pub frames: u32,
    /// Close loops (pose graph and map rebuild, docs/slam.md). Off by default: the paper's SLAM
    /// is open-loop, and loop closure roughly doubles a trial's cost.
    #[arg(long)]
    pub loop_closure: bool,
    /// Also run every condition's trials mapped at the true AGV poses (true-poses.toml in
    /// --launch-dir; same seeds, same detections) and write oracle.csv: each condition's final
    /// ET-GOPSA, its oracle's and their ratio (what the SLAM back end costs); Fig. 6 draws the
    /// oracles dashed. The oracle's trials take less time than the SLAM trials (no scan
    /// matching, no loop search).
    #[arg(long)]
    pub oracle: bool,
    /// Also run 5G with the ESPRIT super-resolution estimator (refinement:=esprit, every array
    /// row exact) and draw it in Figs. 6 and 7 beside 5G DFT (docs/superresolution.md). Its
    /// trials cost several times the DFT's: about 4 ms more per frame at Table I.
    #[arg(long)]
    pub super_resolution: bool,
    /// Folder holding paper-ideal.toml and paper-5g.toml (and true-poses.toml for --oracle).
    #[arg(long, default_value = "launch", value_name = "DIR")]
    pub launch_dir: PathBuf,
}

/// The pose oracle's launch file in `--launch-dir`: it takes every argument of the paper's two.
const ORACLE_LAUNCH: &str = "true-poses.toml";

/// Where a condition's Monte Carlo trials go.
fn trials_dir(out: &Path, condition: &str) -> PathBuf {
    out.join("montecarlo").join(condition)
}

/// Where a condition's trials at the true poses go (`--oracle`).
fn oracle_dir(out: &Path, condition: &str) -> PathBuf {
    out.join("montecarlo")
        .join(format!("{condition}_true_poses"))
}

/// `--frames` (also `nrslam tradeoff --frames`).
pub(crate) const FRAMES: Whole = Whole::new(0, 1_000_000, "0 to 1000000 frames");

impl ReproduceArgs {
    /// Checks every numeric flag; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check(
            "--trials",
            crate::cmd::montecarlo::TRIALS.check(self.trials),
        )?;
        flags::check("--frames", FRAMES.check(self.frames))?;
        // Checked before any trial runs: the oracle's trials come after each condition's.
        let oracle = self.launch_dir.join(ORACLE_LAUNCH);
        if self.oracle && !oracle.is_file() {
            anyhow::bail!(
                "--oracle: no {} (--launch-dir must hold {ORACLE_LAUNCH} beside the paper's \
                 launch files)",
                oracle.display()
            );
        }
        Ok(())
    }
}

/// One condition: (name, launch file, arguments, legend).
type Condition = (
    &'static str,
    &'static str,
    &'static [&'static str],
    &'static str,
);

/// The super-resolution condition `--super-resolution` adds: 5G with ESPRIT, every array row
/// exact (docs/superresolution.md).
const SUPER_RESOLUTION: Condition = (
    "5g_esprit",
    "paper-5g.toml",
    &[
        "fidelity:=spectral",
        "snr_db:=10",
        "refinement:=esprit",
        "angle_window_cells:=16",
    ],
    "5G ESPRIT, SNR 10 dB",
);

/// The conditions of a run: the paper's five, and with `super_resolution` 5G with ESPRIT.
fn conditions(super_resolution: bool) -> Vec<Condition> {
    let mut all = CONDITIONS.to_vec();
    if super_resolution {
        all.insert(1, SUPER_RESOLUTION);
    }
    all
}

/// The paper's conditions: (name, launch file, arguments, legend).
const CONDITIONS: [Condition; 5] = [
    (
        "5g",
        "paper-5g.toml",
        &["fidelity:=spectral", "snr_db:=10"],
        "5G, SNR 10 dB",
    ),
    (
        "r0_a1",
        "paper-ideal.toml",
        &["range_std_m:=0", "angle_std_deg:=1"],
        "ΔR = 0 m, Δθ = 1°",
    ),
    (
        "r0.1_a1",
        "paper-ideal.toml",
        &["range_std_m:=0.1", "angle_std_deg:=1"],
        "ΔR = 0.1 m, Δθ = 1°",
    ),
    (
        "r0_a5",
        "paper-ideal.toml",
        &["range_std_m:=0", "angle_std_deg:=5"],
        "ΔR = 0 m, Δθ = 5°",
    ),
    (
        "r0.1_a5",
        "paper-ideal.toml",
        &["range_std_m:=0.1", "angle_std_deg:=5"],
        "ΔR = 0.1 m, Δθ = 5°",
    ),
];

/// `nrslam reproduce`.
pub fn reproduce(args: ReproduceArgs) -> Result<()> {
    args.validate()?;
    args.out.create()?;
    let started = std::time::Instant::now();
    let (mut timings, mut oracle_timings) = (serde_json::Map::new(), serde_json::Map::new());
    fig4::fig4(&args.out.dir)?;
    let conditions = conditions(args.super_resolution);
    for &(name, file, assignments, legend) in &conditions {
        let condition_started = std::time::Instant::now();
        eprintln!("{legend}: one run, then {} Monte Carlo trials", args.trials);
        let mut assignments: Vec<String> = assignments.iter().map(|s| s.to_string()).collect();
        assignments.push(format!("frames:={}", args.frames));
        // The paper's SLAM has no loop closure; `--loop-closure` runs the project's back end.
        assignments.push(format!("loop_closure:={}", args.loop_closure));
        let out = if name == "5g" {
            args.out.join("fig5")
        } else if name == SUPER_RESOLUTION.0 {
            args.out.join("fig5-esprit")
        } else {
            args.out.join("fig3").join(name)
        };
        launch::launch(LaunchArgs {
            file: args.launch_dir.join(file),
            assignments: assignments.clone(),
            seed: Some(args.seed),
            out: Some(out),
            mode: None,
            pacing: crate::args::RateArgs::default(),
            start_timeout_s: 30,
            record: None,
            record_topics: Vec::new(),
            chunk: crate::cmd::bag::ChunkArgs {
                chunk_size_kib: 768,
            },
            storage: crate::cmd::bag::StorageArgs {
                compression: nrslam_runtime::bag::Compression::None,
                max_bag_size: 0,
                max_bag_duration: 0.0,
            },
            ros_domain_id: None,
            external_idle_s: 10.0,
            transport: TransportArgs::default(),
        })?;
        // Figs. 6 and 7 need the metrics only: the trials skip the shapes and the viewers'
        // topics, which feed no metric (the box corners are the paper's representatives).
        assignments.extend(["shapes:=false".to_owned(), "viz:=false".to_owned()]);
        trials(&args, file, &assignments, trials_dir(&args.out.dir, name))?;
        timings.insert(
            name.to_owned(),
            serde_json::json!(condition_started.elapsed().as_secs_f64()),
        );
        if args.oracle {
            let oracle_started = std::time::Instant::now();
            eprintln!("{legend}: the same trials at the true poses");
            // The same arguments: true-poses.toml takes every argument of the paper's two.
            let dir = oracle_dir(&args.out.dir, name);
            trials(&args, ORACLE_LAUNCH, &assignments, dir)
                .with_context(|| format!("{name}: trials at the true poses"))?;
            oracle_timings.insert(
                name.to_owned(),
                serde_json::json!(oracle_started.elapsed().as_secs_f64()),
            );
        }
    }
    let fig6 = (
        "ET-GOPSA (mean over trials)",
        "Fig. 6: mapping error against time",
    );
    let fig6 = curves(
        &args.out.dir,
        &conditions,
        "etgospa_mean",
        "fig6",
        fig6,
        args.oracle,
    )?;
    // At the true poses the position error is 0 (up to rounding): Fig. 7 has no oracle curves.
    let fig7 = (
        "AGV position MSE (m²)",
        "Fig. 7: MSE of the AGV location against time",
    );
    curves(
        &args.out.dir,
        &conditions,
        "position_mse_m2",
        "fig7",
        fig7,
        false,
    )?;
    if args.oracle {
        outln!("final ET-GOPSA (mean over trials): SLAM, at the true poses, ratio");
        for row in oracle_table(&args.out.dir, &conditions, &fig6)? {
            outln!(
                "  {:<8} {:>8.2} {:>8.2} {:>6.2}",
                row.condition,
                row.slam,
                row.true_poses,
                row.ratio()
            );
        }
    }
    // Wall-clock times, kept apart from the figures' CSV so that those stay comparable.
    let run = serde_json::json!({
        "trials": args.trials,
        "seed": args.seed,
        "frames": args.frames,
        "threads": rayon::current_num_threads(),
        "wall_time_s": started.elapsed().as_secs_f64(),
        "wall_time_per_condition_s": timings,
        "oracle": args.oracle,
        "oracle_wall_time_per_condition_s": oracle_timings,
    });
    std::fs::write(
        args.out.join("reproduce.json"),
        serde_json::to_string_pretty(&run)? + "\n",
    )
    .with_context(|| format!("cannot write {}", args.out.join("reproduce.json").display()))?;
    outln!(
        "wrote {} in {:.1} s",
        args.out.dir.display(),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The Monte Carlo trials of `file` (in `--launch-dir`) with `assignments`, into `dir`.
fn trials(args: &ReproduceArgs, file: &str, assignments: &[String], dir: PathBuf) -> Result<()> {
    montecarlo::montecarlo(MonteCarloArgs {
        file: args.launch_dir.join(file),
        assignments: assignments.to_vec(),
        trials: args.trials,
        seed: args.seed,
        shard: None,
        threads: None,
        out: crate::args::OutputDirArgs { dir },
    })
}
