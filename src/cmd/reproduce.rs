//! `nrslam reproduce`: the paper's figures as PNG with CSV beside each.
//!
//! - Fig. 3 (a–d) and Fig. 5: one run per condition (maps and DBSCAN segments), in `fig3/<condition>/`
//!   and `fig5/`.
//! - Fig. 4: the GOSPA-versus-ET-GOPSA scenario: two extended targets, estimates y1 and y2 equally
//!   far from x1, y2 farther from x2; both metrics for {y1}, {y2}, {y1, y2} (`fig4.csv`, `fig4.png`).
//! - Figs. 6 and 7: Monte Carlo means over `--trials` of ET-GOPSA and of the AGV position MSE
//!   against time for 5G and the four ideal conditions (`fig6.csv`/`.png`, `fig7.csv`/`.png`;
//!   raw trials in `montecarlo/<condition>/`).

use crate::args::TransportArgs;
use crate::cmd::launch::{self, LaunchArgs};
use crate::cmd::montecarlo::{self, MonteCarloArgs};
use crate::flags::{self, Whole};
use crate::plot::{canvas, draw_axes, draw_legend, framed, line_key, plot_error};
use anyhow::{anyhow, Context, Result};
use clap::Args;
use nrslam_evaluator::{etgospa, gospa, EtGospaParams, ExtendedTarget, Point2};
use plotters::prelude::*;
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
    /// Folder holding paper-ideal.toml and paper-5g.toml.
    #[arg(long, default_value = "launch", value_name = "DIR")]
    pub launch_dir: PathBuf,
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
        Ok(())
    }
}

/// (name, launch file, arguments, legend)
const CONDITIONS: [(&str, &str, [&str; 2], &str); 5] = [
    (
        "5g",
        "paper-5g.toml",
        ["fidelity:=spectral", "snr_db:=10"],
        "5G, SNR 10 dB",
    ),
    (
        "r0_a1",
        "paper-ideal.toml",
        ["range_std_m:=0", "angle_std_deg:=1"],
        "ΔR = 0 m, Δθ = 1°",
    ),
    (
        "r0.1_a1",
        "paper-ideal.toml",
        ["range_std_m:=0.1", "angle_std_deg:=1"],
        "ΔR = 0.1 m, Δθ = 1°",
    ),
    (
        "r0_a5",
        "paper-ideal.toml",
        ["range_std_m:=0", "angle_std_deg:=5"],
        "ΔR = 0 m, Δθ = 5°",
    ),
    (
        "r0.1_a5",
        "paper-ideal.toml",
        ["range_std_m:=0.1", "angle_std_deg:=5"],
        "ΔR = 0.1 m, Δθ = 5°",
    ),
];

/// `nrslam reproduce`.
pub fn reproduce(args: ReproduceArgs) -> Result<()> {
    args.validate()?;
    args.out.create()?;
    let started = std::time::Instant::now();
    let mut timings = serde_json::Map::new();
    fig4(&args.out.dir)?;
    for (name, file, assignments, legend) in CONDITIONS {
        let condition_started = std::time::Instant::now();
        eprintln!("{legend}: one run, then {} Monte Carlo trials", args.trials);
        let mut assignments: Vec<String> = assignments.iter().map(|s| s.to_string()).collect();
        assignments.push(format!("frames:={}", args.frames));
        // The paper's SLAM has no loop closure; `--loop-closure` runs the project's back end.
        assignments.push(format!("loop_closure:={}", args.loop_closure));
        let out = if name == "5g" {
            args.out.join("fig5")
        } else {
            args.out.join("fig3").join(name)
        };
        launch::launch(LaunchArgs {
            file: args.launch_dir.join(file),
            assignments: assignments.clone(),
            seed: args.seed,
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
            transport: TransportArgs::default(),
        })?;
        // Figs. 6 and 7 need the metrics only: the trials skip the shapes and the viewers'
        // topics, which feed no metric (the box corners are the paper's representatives).
        assignments.extend(["shapes:=false".to_owned(), "viz:=false".to_owned()]);
        montecarlo::montecarlo(MonteCarloArgs {
            file: args.launch_dir.join(file),
            assignments,
            trials: args.trials,
            seed: args.seed,
            shard: None,
            threads: None,
            out: crate::args::OutputDirArgs {
                dir: args.out.join("montecarlo").join(name),
            },
        })?;
        timings.insert(
            name.to_owned(),
            serde_json::json!(condition_started.elapsed().as_secs_f64()),
        );
    }
    curves(
        &args.out.dir,
        "etgospa_mean",
        "fig6",
        "ET-GOPSA (mean over trials)",
        "Fig. 6: mapping error against time",
    )?;
    curves(
        &args.out.dir,
        "position_mse_m2",
        "fig7",
        "AGV position MSE (m²)",
        "Fig. 7: MSE of the AGV location against time",
    )?;
    // Wall-clock times, kept apart from the figures' CSV so that those stay comparable.
    let run = serde_json::json!({
        "trials": args.trials,
        "seed": args.seed,
        "frames": args.frames,
        "threads": rayon::current_num_threads(),
        "wall_time_s": started.elapsed().as_secs_f64(),
        "wall_time_per_condition_s": timings,
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

/// Reads `column` of each condition's montecarlo.csv into one CSV and one plot against time.
fn curves(out: &Path, column: &str, name: &str, y_label: &str, caption: &str) -> Result<()> {
    let mut series = Vec::new();
    for (condition, _, _, legend) in CONDITIONS {
        let path = out
            .join("montecarlo")
            .join(condition)
            .join("montecarlo.csv");
        let mut reader = csv::Reader::from_path(&path)
            .with_context(|| format!("{}: cannot read", path.display()))?;
        let headers = reader.headers()?.clone();
        let index = |h: &str| {
            headers
                .iter()
                .position(|x| x == h)
                .ok_or_else(|| anyhow!("{}: no column {h}", path.display()))
        };
        let (time, value) = (index("time_s")?, index(column)?);
        let mut points = Vec::new();
        for record in reader.records() {
            let record = record?;
            let parse = |i: usize| {
                record
                    .get(i)
                    .and_then(|t| t.parse::<f64>().ok())
                    .ok_or_else(|| anyhow!("{}: bad number", path.display()))
            };
            points.push((parse(time)?, parse(value)?));
        }
        series.push((condition, legend, points));
    }
    let mut writer = csv::Writer::from_path(out.join(format!("{name}.csv")))?;
    let mut header = vec!["time_s".to_owned()];
    header.extend(series.iter().map(|(c, _, _)| c.to_string()));
    writer.write_record(&header)?;
    let steps = series.iter().map(|(_, _, p)| p.len()).min().unwrap_or(0);
    for step in 0..steps {
        let mut row = vec![series[0].2[step].0.to_string()];
        row.extend(series.iter().map(|(_, _, p)| p[step].1.to_string()));
        writer.write_record(&row)?;
    }
    writer.flush()?;
    let path = out.join(format!("{name}.png"));
    let root = canvas(&path, (1000, 640))?;
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|(_, _, p)| p.iter().copied())
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .collect();
    let t_max = all.iter().map(|p| p.0).fold(1.0, f64::max);
    let v_max = all.iter().map(|p| p.1).fold(1e-9, f64::max) * 1.1;
    let mut chart = framed(&root, caption, 22, 12, (40, 60))
        .build_cartesian_2d(0.0..t_max, 0.0..v_max)
        .map_err(plot_error)?;
    draw_axes(&mut chart, "time (s)", y_label, true)?;
    for (index, (_, legend, points)) in series.iter().enumerate() {
        let color = Palette99::pick(index).to_rgba();
        chart
            .draw_series(LineSeries::new(
                points.iter().copied(),
                color.stroke_width(2),
            ))
            .map_err(plot_error)?
            .label(*legend)
            .legend(line_key(color.stroke_width(2)));
    }
    draw_legend(&mut chart, SeriesLabelPosition::MiddleRight)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// Fig. 4: x1 a 2 m square at the origin, x2 the same 4 m to its right; y1 1 m right of x1 (toward
/// x2), y2 1 m left of x1: equally far from x1, y2 farther from x2.
fn fig4(out: &Path) -> Result<()> {
    let square = |cx: f64| {
        vec![
            Point2::new(cx - 1.0, -1.0),
            Point2::new(cx + 1.0, -1.0),
            Point2::new(cx + 1.0, 1.0),
            Point2::new(cx - 1.0, 1.0),
        ]
    };
    let (x1, x2) = (square(0.0), square(5.0));
    let (y1, y2) = (Point2::new(2.0, 0.0), Point2::new(-2.0, 0.0));
    let targets = [
        ExtendedTarget::from_samples(x1.clone()),
        ExtendedTarget::from_samples(x2.clone()),
    ];
    let params = EtGospaParams::default();
    let truth: Vec<Point2> = x1.iter().chain(&x2).copied().collect();
    let mut writer = csv::Writer::from_path(out.join("fig4.csv"))?;
    writer.write_record([
        "estimates",
        "gospa",
        "etgospa",
        "etgospa_localisation",
        "etgospa_confusion",
        "etgospa_missed",
        "etgospa_false",
    ])?;
    for (label, estimates) in [
        ("{y1}", vec![y1]),
        ("{y2}", vec![y2]),
        ("{y1,y2}", vec![y1, y2]),
    ] {
        let g = gospa(&truth, &estimates, &params.gospa()).map_err(|e| anyhow!("{e}"))?;
        let e = etgospa(&targets, &estimates, &params).map_err(|e| anyhow!("{e}"))?;
        writer.write_record([
            label.to_owned(),
            g.total.to_string(),
            e.total.to_string(),
            e.localisation.to_string(),
            e.confusion.to_string(),
            e.missed.to_string(),
            e.false_estimates.to_string(),
        ])?;
    }
    writer.flush()?;
    let path = out.join("fig4.png");
    let root = canvas(&path, (800, 420))?;
    let caption = "Fig. 4: extended targets x1, x2 and estimates y1, y2 (values in fig4.csv)";
    let mut chart = framed(&root, caption, 18, 12, (30, 40))
        .build_cartesian_2d(-4.0..8.0, -3.0..3.0)
        .map_err(plot_error)?;
    draw_axes(&mut chart, "x (m)", "y (m)", true)?;
    for (target, name) in [(&x1, "x1"), (&x2, "x2")] {
        let mut ring: Vec<(f64, f64)> = target.iter().map(|p| (p.x_m, p.y_m)).collect();
        ring.push(ring[0]);
        chart
            .draw_series(LineSeries::new(ring, BLUE.stroke_width(2)))
            .map_err(plot_error)?;
        chart
            .draw_series(
                target
                    .iter()
                    .map(|p| Circle::new((p.x_m, p.y_m), 4, BLUE.filled())),
            )
            .map_err(plot_error)?;
        let c = target
            .iter()
            .fold((0.0, 0.0), |a, p| (a.0 + p.x_m / 4.0, a.1 + p.y_m / 4.0));
        chart
            .draw_series(std::iter::once(Text::new(name, c, ("sans-serif", 18))))
            .map_err(plot_error)?;
    }
    for (point, name) in [(y1, "y1"), (y2, "y2")] {
        chart
            .draw_series(std::iter::once(Circle::new(
                (point.x_m, point.y_m),
                6,
                RED.filled(),
            )))
            .map_err(plot_error)?;
        chart
            .draw_series(std::iter::once(Text::new(
                name,
                (point.x_m + 0.2, point.y_m + 0.3),
                ("sans-serif", 18),
            )))
            .map_err(plot_error)?;
    }
    root.present().map_err(plot_error)?;
    Ok(())
}
