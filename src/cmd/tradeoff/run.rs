//! Running the sweep: every setting's launch loaded and built up front, then per setting its
//! sensing errors (measured once per distinct sensing chain) and its timed SLAM trials, under
//! one progress bar. The result is the table's rows in plan order.

use super::args::TradeoffArgs;
use super::clock::timed;
use super::knobs::{Setting, TRIAL_COUNTS};
use super::table::{row, trials_knob_rows, Row, Trial};
use crate::cmd::accuracy::{parse_refinement, single_scatterer_trials};
use crate::cmd::montecarlo::{run_trial, TrialRows};
use anyhow::{Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_ofdm::OfdmParams;
use nrslam_runtime::launch::Launch;
use std::collections::BTreeMap;

/// Error standard deviations of the launch's `ideal` level (its argument defaults).
const IDEAL_RANGE_STD_M: f64 = 0.035;
const IDEAL_ANGLE_STD_DEG: f64 = 1.04;

/// Loads and builds every setting's launch, so that a bad setting fails before any time is spent.
pub(super) fn load_launches(args: &TradeoffArgs, plan: &[Setting]) -> Result<Vec<Launch>> {
    let file = args.launch_dir.join("paper-5g.toml");
    let mut launches = Vec::new();
    for setting in plan {
        let launch = Launch::load(&file, &setting.assignments(args.frames, args.snr_db))
            .with_context(|| format!("setting {:?}", setting.label))?;
        crate::cmd::launch::build_all(&launch, args.seed)
            .with_context(|| format!("setting {:?}", setting.label))?;
        launches.push(launch);
    }
    Ok(launches)
}

/// Runs every setting of `plan` (baseline first, `launches` in the same order) and returns the
/// rows: the baseline's, then the `trials` knob's if it is among `knobs`, then one per setting.
pub(super) fn sweep(
    args: &TradeoffArgs,
    knobs: &[&'static str],
    plan: &[Setting],
    launches: &[Launch],
) -> Result<Vec<Row>> {
    let baseline_trials = baseline_trial_count(args, knobs);
    let bar = progress_bar(args, plan, baseline_trials);
    let mut sensing = SensingErrors::new(args, &bar);
    let mut rows = Vec::new();
    for (setting, launch) in plan.iter().zip(launches) {
        bar.set_message(format!("{}: {}", setting.knob, setting.label));
        let errors = sensing.of(setting)?;
        let count = if setting.knob == "baseline" {
            baseline_trials
        } else {
            args.trials
        };
        let trials = run_trials(launch, setting, count, args.seed, &bar)?;
        if setting.knob == "baseline" {
            rows.push(row(
                setting.clone(),
                &trials[..args.trials.min(count)],
                errors,
            ));
            if knobs.contains(&"trials") {
                rows.extend(trials_knob_rows(setting, &trials, errors));
            }
        } else {
            rows.push(row(setting.clone(), &trials, errors));
        }
    }
    bar.finish_and_clear();
    Ok(rows)
}

/// SLAM trials of the baseline: `--trials`, or more when the `trials` knob needs them.
fn baseline_trial_count(args: &TradeoffArgs, knobs: &[&'static str]) -> usize {
    if knobs.contains(&"trials") {
        args.trials.max(*TRIAL_COUNTS.iter().max().unwrap_or(&1))
    } else {
        args.trials
    }
}

/// A bar counting every SLAM trial and every single-scatterer sensing frame of the sweep.
fn progress_bar(args: &TradeoffArgs, plan: &[Setting], baseline_trials: usize) -> ProgressBar {
    let sensing_count: u64 = {
        let mut keys: Vec<String> = plan
            .iter()
            .filter(|s| s.fidelity != "ideal")
            .map(Setting::sensing_key)
            .collect();
        keys.sort();
        keys.dedup();
        keys.len() as u64 * args.sensing_trials as u64
    };
    let slam_count = (baseline_trials + (plan.len() - 1) * args.trials) as u64;
    let bar = ProgressBar::new(slam_count + sensing_count);
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} trials and frames  {elapsed_precise} ETA {eta}  {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// The single-scatterer range and angle RMSE of each sensing chain, measured on first use.
struct SensingErrors<'a> {
    args: &'a TradeoffArgs,
    bar: &'a ProgressBar,
    measured: BTreeMap<String, (f64, f64)>,
}

impl<'a> SensingErrors<'a> {
    fn new(args: &'a TradeoffArgs, bar: &'a ProgressBar) -> Self {
        Self {
            args,
            bar,
            measured: BTreeMap::new(),
        }
    }

    /// The setting's (range RMSE m, angle RMSE °); the `ideal` level's are the standard
    /// deviations it draws its errors from.
    fn of(&mut self, setting: &Setting) -> Result<(f64, f64)> {
        if setting.fidelity == "ideal" {
            return Ok((IDEAL_RANGE_STD_M, IDEAL_ANGLE_STD_DEG));
        }
        if let Some(e) = self.measured.get(&setting.sensing_key()) {
            return Ok(*e);
        }
        let params = OfdmParams {
            subcarriers: setting.subcarriers,
            subcarrier_spacing_hz: setting.subcarrier_spacing_hz,
            symbols: setting.symbols,
            antennas: setting.antennas,
            snr_db: self.args.snr_db,
            ..OfdmParams::default()
        };
        let (refinement, padding) = parse_refinement(setting.refinement)?;
        let bar = self.bar;
        let tally = single_scatterer_trials(
            &params,
            setting.fidelity == "waveform",
            refinement,
            padding,
            self.args.sensing_trials,
            self.args.seed,
            "tradeoff",
            &|| bar.inc(1),
        )
        .with_context(|| format!("sensing errors of {:?}", setting.label))?;
        let e = (tally.range_rmse_m(), tally.angle_rmse_rad().to_degrees());
        self.measured.insert(setting.sensing_key(), e);
        Ok(e)
    }
}

/// Runs `count` SLAM trials of one setting, one after another, trial i seeded from (seed, i).
fn run_trials(
    launch: &Launch,
    setting: &Setting,
    count: usize,
    seed: u64,
    bar: &ProgressBar,
) -> Result<Vec<Trial>> {
    let mut trials = Vec::with_capacity(count);
    for i in 0..count {
        let (rows, seconds) =
            timed(|| run_trial(launch, nrslam_runtime::seed::trial(seed, i as u64)));
        let rows = rows.with_context(|| format!("setting {:?}, trial {i}", setting.label))?;
        trials.push(summarise(&rows, seconds));
        bar.inc(1);
    }
    Ok(trials)
}

/// One trial's final ET-GOPSA and pose RMSE over its frames.
fn summarise(rows: &TrialRows, seconds: f64) -> Trial {
    let n = rows.len().max(1) as f64;
    Trial {
        seconds,
        frames: rows.len() as u64,
        final_etgospa: rows.last().map_or(f64::NAN, |r| r.1[0]),
        pose_rmse_m: (rows.iter().map(|r| r.1[2] * r.1[2]).sum::<f64>() / n).sqrt(),
    }
}
