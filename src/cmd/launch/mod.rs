//! `nrslam launch`: a launch file's graph in one process, or one process per node supervised by
//! the runtime; optionally mirrored over zenoh, recorded into a bag, or replayed from one.

mod args;
mod build;
mod in_process;
mod processes;
mod recorder;
mod replay;

pub use self::args::LaunchArgs;
pub(crate) use self::args::ROS_DOMAIN_ID;
pub(crate) use self::build::build_all;

use self::in_process::run_in_process;
use self::processes::run_processes;
use self::recorder::recorder;
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_runtime::launch::{Launch, Mode};
use std::path::PathBuf;
use std::time::Instant;

/// The progress bar of a run of `frames` frames (a spinner when unknown).
fn progress(frames: Option<u64>) -> ProgressBar {
    let bar = match frames {
        Some(n) => ProgressBar::new(n),
        None => ProgressBar::new_spinner(),
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} frames  ETA {eta}  {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// `nrslam launch`.
pub fn launch(mut args: LaunchArgs) -> Result<()> {
    args.validate()?;
    let launch = Launch::load(&args.file, &args.assignments)?;
    let (launch, replayed) = replay::prepare(launch, &args)?;
    if let Some(replay) = &replayed {
        // Node processes and the recorder take the replay's seed from here.
        args.seed = Some(replay.seed);
    }
    let mode = args.mode.unwrap_or(launch.mode);
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("out").join(
            args.file
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "run".into()),
        )
    });
    let built = build_all(&launch, args.seed())?;
    let recorder = match &args.record {
        Some(dir) => Some(recorder(&args, &launch, &built, dir)?),
        None => None,
    };
    let started = Instant::now();
    let mut reporter = match mode {
        Mode::InProcess => run_in_process(&args, built, recorder)?,
        Mode::Processes => run_processes(&args, &launch, built, &out, recorder)?,
    };
    reporter.score_as(&launch);
    let mut summary = reporter.summary(
        &launch.arguments,
        args.seed(),
        &launch.path.display().to_string(),
    );
    if let Some(replay) = &replayed {
        replay.apply(&mut summary);
    }
    reporter.write_all(&out, &summary)?;
    let mut run_info = serde_json::json!({
        "mode": match mode { Mode::InProcess => "in-process", Mode::Processes => "processes" },
        "wall_time_s": started.elapsed().as_secs_f64(),
        "rate": args.pacing.rate,
    });
    if let Some(replay) = &replayed {
        run_info["replayed_bag"] = serde_json::Value::from(replay.bag.display().to_string());
        run_info["replay_launch"] = serde_json::Value::from(launch.path.display().to_string());
    }
    std::fs::write(
        out.join("run.json"),
        serde_json::to_string_pretty(&run_info)? + "\n",
    )
    .with_context(|| format!("cannot write {}", out.join("run.json").display()))?;
    if summary.metric_steps == 0 && summary.keyframes == 0 && !summary.agents.is_empty() {
        // An agent's chain alone (launch/cooperative-agent.toml): its keyframes are namespaced
        // and scored where they are fused; say how its own SLAM did.
        let agents: Vec<String> = summary
            .agents
            .iter()
            .map(|(name, a)| match a.own_pose_rmse_m {
                Some(rmse_m) => format!("{name}: {} frames, own pose RMSE {rmse_m:.3} m", a.frames),
                None => format!("{name}: {} frames", a.frames),
            })
            .collect();
        outln!(
            "{} (scored where they are fused); wrote {}",
            agents.join(", "),
            out.display()
        );
        return Ok(());
    }
    if summary.metric_steps == 0 {
        // No evaluator (a real sensor's bag): say what was built rather than a row of n/a.
        outln!(
            "{} keyframes, {} occupied map cells, no /metrics (no ground truth to score against); wrote {}",
            summary.keyframes,
            summary.occupied_cells.unwrap_or(0),
            out.display()
        );
        return Ok(());
    }
    outln!(
        "{} frames, final ET-GOPSA {}, GOSPA {}, pose RMSE {} m (final keyframe trajectory {} m); wrote {}",
        summary.frames,
        fmt_opt(summary.etgospa),
        fmt_opt(summary.gospa),
        fmt_opt(summary.pose_rmse_m),
        fmt_opt(summary.keyframe_rmse_m),
        out.display()
    );
    Ok(())
}

fn fmt_opt(value: Option<f64>) -> String {
    value.map_or_else(|| "n/a".into(), |v| format!("{v:.3}"))
}
