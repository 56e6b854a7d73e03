//! `nrslam`: SLAM for multiple extended targets with 5G OFDM sensing, as a node graph over zenoh.
//!
//! Thin entry point: parse the command line, check every flag's range ([`Command::validate`],
//! before any work), hand each verb to its module, turn errors into one line on stderr and a
//! non-zero exit. A flag value clap refuses gets the same one line (`error: --flag: ...`, status
//! 1); help, version and usage errors keep clap's own output.

/// `println!` for command output that may be piped: when the reader has gone (`nrslam bag info
/// DIR | head`) the process ends quietly with status 0, as Unix tools do, instead of panicking on
/// the broken pipe.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(error) = writeln!(std::io::stdout().lock(), $($arg)*) {
            if error.kind() == std::io::ErrorKind::BrokenPipe {
                std::process::exit(0);
            }
            eprintln!("error: cannot write to standard output: {error}");
            std::process::exit(1);
        }
    }};
}

mod args;
#[cfg(test)]
mod cli_tests;
mod cmd;
mod flags;
mod plot;
mod registry;
mod report;

use clap::{Parser, Subcommand};
#[cfg(feature = "ros2")]
use cmd::ros2;
use cmd::{accuracy, bag, launch, montecarlo, reproduce, run, scene, tradeoff};

/// SLAM for multiple extended targets with 5G OFDM sensing: a ROS-style node graph over zenoh.
#[derive(Parser, Debug)]
#[command(name = "nrslam", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run a launch file's graph to its end and write summary.json, metrics.csv, map.png, segments.png.
    Launch(launch::LaunchArgs),
    /// Run one node as its own process, talking over zenoh.
    Run(run::RunArgs),
    /// List the topics of the catalogue and, with --connect, what a live graph publishes.
    Topics(cmd::topics::TopicsArgs),
    /// Print the messages of one topic of a live graph, one JSON object per line.
    Echo(cmd::echo::EchoArgs),
    /// GOSPA and ET-GOPSA of an estimated point map against true extended targets (CSV files).
    Metric(cmd::metric::MetricArgs),
    /// DBSCAN on a CSV of points `x,y`, writing `x,y,label` (label -1: noise).
    Segment(cmd::segment::SegmentArgs),
    /// Single-scatterer range and angle RMSE against SNR, beside the Cramér–Rao bounds and grid limits: accuracy.csv and accuracy.png in --out.
    Accuracy(accuracy::AccuracyArgs),
    /// Probability that two equal scatterers are both found against their separation in angle and in range, per estimator: resolution.csv and resolution-{angle,range}.png in --out.
    Resolution(cmd::resolution::ResolutionArgs),
    /// Monte Carlo trials of a launch in parallel: trials.csv (raw), montecarlo.csv (per-step mean and spread of every metric) and study.json in --out.
    Montecarlo(montecarlo::MonteCarloArgs),
    /// Merge `montecarlo --shard` folders into the result of one unsharded run, in --out.
    Merge(montecarlo::MergeArgs),
    /// The paper's figures (3, 4, 5, 6, 7) as PNG with CSV beside each, in --out.
    Reproduce(reproduce::ReproduceArgs),
    /// Sweep the knobs that trade speed for accuracy: tradeoff.csv and a Pareto plot (pareto.png) in --out.
    Tradeoff(tradeoff::TradeoffArgs),
    /// The cheapest bandwidth, antennas, SNR and estimator that meet an accuracy requirement: closed-form screen, sequential Monte Carlo, resumable and shardable; frontier.csv, frontier.png and sizing.md in --out.
    Sizing(cmd::sizing::SizingArgs),
    /// Write a random scene file (irregular rectangles and circles, a randomised loop) for scene:=FILE.
    Scene(scene::SceneArgs),
    /// rosbag2 bags (metadata.yaml + MCAP): record a live graph, print a bag's contents, play it back.
    Bag(bag::BagArgs),
    /// Bridge the graph and ROS 2 (r2r; built with `--features ros2` and a sourced ROS 2).
    #[cfg(feature = "ros2")]
    Ros2Bridge(ros2::Ros2BridgeArgs),
}

impl Command {
    /// Checks the verb's flags against their ranges (what each verb also does first), so a bad
    /// value is refused before anything starts. The error names the flag.
    fn validate(&self) -> anyhow::Result<()> {
        match self {
            Command::Launch(args) => args.validate(),
            Command::Run(args) => args.validate(),
            Command::Topics(args) => args.validate(),
            Command::Echo(args) => args.validate(),
            Command::Metric(args) => args.validate(),
            Command::Segment(args) => args.validate(),
            Command::Accuracy(args) => args.validate(),
            Command::Resolution(args) => args.validate(),
            Command::Montecarlo(args) => args.validate(),
            Command::Merge(_) => Ok(()),
            Command::Reproduce(args) => args.validate(),
            Command::Tradeoff(args) => args.validate(),
            Command::Sizing(args) => args.validate(),
            Command::Scene(args) => args.validate(),
            // `nrslam bag` checks its own flags (src/cmd/bag/).
            Command::Bag(_) => Ok(()),
            #[cfg(feature = "ros2")]
            Command::Ros2Bridge(_) => Ok(()),
        }
    }
}

/// Parses `args` (program name first) and checks the flags' ranges: the whole of what happens
/// before a verb starts, as one call for the tests. `Err` holds the one-line message, or clap's
/// own error for help, version and usage.
fn parse_and_validate<I, T>(args: I) -> Result<Cli, Refused>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = Cli::try_parse_from(args).map_err(|error| match flags::clap_error_line(&error) {
        Some(line) => Refused::Line(line),
        None => Refused::Clap(error),
    })?;
    cli.command
        .validate()
        .map_err(|error| Refused::Line(one_line(&error)))?;
    Ok(cli)
}

/// Why the command line was not run.
#[derive(Debug)]
enum Refused {
    /// A flag's value, in one line (`--flag: ...`).
    Line(String),
    /// Help, version or a usage error, printed by clap.
    Clap(clap::Error),
}

/// glibc's allocator hands the top of the heap back to the kernel whenever more than its trim
/// threshold is free there, and raises its mmap threshold as large blocks are freed. A waveform
/// frame allocates and frees a few 5 MB buffers: with the defaults the freed pair at the top of
/// the heap crosses the threshold and is returned and re-faulted every frame (12 % of the run's
/// CPU, ~150,000 page faults in 60 frames). Fixed thresholds keep such buffers in the heap for
/// reuse; memory held beyond the live set stays under 128 MB.
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn keep_freed_buffers_for_reuse() {
    // SAFETY: mallopt only changes the allocator's tuning parameters; it is called before any
    // other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 32 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 128 << 20);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn keep_freed_buffers_for_reuse() {}

fn main() -> std::process::ExitCode {
    keep_freed_buffers_for_reuse();
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("NRSLAM_LOG")
                .unwrap_or_else(|_| "warn".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let cli = match parse_and_validate(std::env::args_os()) {
        Ok(cli) => cli,
        Err(Refused::Line(line)) => {
            eprintln!("error: {line}");
            return std::process::ExitCode::FAILURE;
        }
        Err(Refused::Clap(error)) => error.exit(),
    };
    let result = match cli.command {
        Command::Launch(args) => launch::launch(args),
        Command::Run(args) => run::run(args),
        Command::Topics(args) => cmd::topics::topics(args),
        Command::Echo(args) => cmd::echo::echo(args),
        Command::Metric(args) => cmd::metric::metric(args),
        Command::Segment(args) => cmd::segment::segment(args),
        Command::Accuracy(args) => accuracy::accuracy(args),
        Command::Resolution(args) => cmd::resolution::resolution(args),
        Command::Montecarlo(args) => montecarlo::montecarlo(args),
        Command::Merge(args) => montecarlo::merge(args),
        Command::Reproduce(args) => reproduce::reproduce(args),
        Command::Tradeoff(args) => tradeoff::tradeoff(args),
        Command::Sizing(args) => cmd::sizing::sizing(args),
        Command::Scene(args) => scene::scene(args),
        Command::Bag(args) => bag::bag(args),
        #[cfg(feature = "ros2")]
        Command::Ros2Bridge(args) => ros2::bridge(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {}", one_line(&error));
            std::process::ExitCode::FAILURE
        }
    }
}

/// The error chain on one line: `context: cause: cause`. A cause whose text already ends its
/// effect's (errors that print their source and also return it as `source()`) is said once.
fn one_line(error: &anyhow::Error) -> String {
    let mut parts: Vec<String> = Vec::new();
    for cause in error.chain().map(|e| e.to_string()) {
        if !parts.last().is_some_and(|effect| effect.ends_with(&cause)) {
            parts.push(cause);
        }
    }
    parts.join(": ")
}

#[cfg(test)]
mod error_line_tests {
    use super::one_line;

    /// An error that prints its source and returns it too, as several library errors do.
    #[derive(Debug, thiserror::Error)]
    #[error("launch/true-poses.toml: cannot read: {source}")]
    struct Read {
        source: std::io::Error,
    }

    #[test]
    fn a_cause_its_effect_already_printed_is_said_once() {
        let gone = std::io::Error::new(std::io::ErrorKind::NotFound, "no such file");
        let error =
            anyhow::Error::new(Read { source: gone }).context("5g: trials at the true poses");
        assert_eq!(
            one_line(&error),
            "5g: trials at the true poses: launch/true-poses.toml: cannot read: no such file"
        );
        let distinct = anyhow::anyhow!("no such file").context("cannot read x");
        assert_eq!(one_line(&distinct), "cannot read x: no such file");
    }
}
