//! `nrslam tradeoff`: what each knob that trades speed for accuracy costs and buys.
//!
//! One knob at a time is moved away from the baseline, `launch/paper-5g.toml` at its defaults
//! (spectral front end, Table I with M = 1, no refinement, 0.1 m grid, the scene's 0.25 m
//! scatterer spacing). For every setting:
//!
//! - the SLAM graph runs `--trials` times in-process, one trial after another, each timed on its
//!   thread's CPU clock so that the time is the setting's own even on a shared machine (trial i is seeded from (seed, i),
//!   the same seeds for every setting: common random numbers make the settings' differences less
//!   noisy than their spreads);
//! - the single-scatterer range and angle RMSE of the sensing chain at the setting (as
//!   `nrslam accuracy`, at the launch's 10 dB SNR) comes from `--sensing-trials` frames; the
//!   `ideal` level reports the standard deviations it draws its errors from;
//! - the `trials` knob reuses the baseline's runs: the mean of the first n trials, its standard
//!   error, and the time a study of n trials takes.
//!
//! A subcarrier stride s keeps every s-th subcarrier: N/s subcarriers at s·Δf, the same 1.23 GHz
//! bandwidth and range resolution, an unambiguous range c/(2sΔf) s times shorter. Stride and
//! symbols are swept at the `waveform` level, the only one whose cost depends on them (the
//! `spectral` map is closed-form in the occupied cells); their references are the `waveform`
//! row of the fidelity knob and the stride-16 row.
//!
//! Output: `tradeoff.csv` (one row per setting), `pareto.png` (final ET-GOPSA against time per
//! frame, the settings no other beats on both marked and joined).

use crate::accuracy::{parse_refinement, single_scatterer_trials};
use crate::flags::{self, Real, Whole};
use crate::montecarlo::{run_trial, TrialRows};
use anyhow::{anyhow, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_ofdm::OfdmParams;
use nrslam_runtime::launch::Launch;
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// CPU time of the calling thread (s), where the platform has a per-thread clock. The in-process
/// graph runs on one thread, so this is a trial's own cost, unaffected by other processes
/// sharing the cores; on an idle core it equals the wall-clock time.
fn thread_cpu_s() -> Option<f64> {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid, writable timespec; the call only writes it.
        if unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0 {
            return Some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9);
        }
    }
    None
}

/// Measures `work` on the thread CPU clock, or the wall clock where there is none.
fn timed<T>(work: impl FnOnce() -> T) -> (T, f64) {
    let (cpu, wall) = (thread_cpu_s(), Instant::now());
    let value = work();
    let seconds = match (cpu, thread_cpu_s()) {
        (Some(start), Some(end)) => end - start,
        _ => wall.elapsed().as_secs_f64(),
    };
    (value, seconds)
}

/// The knobs, in sweep order.
pub const KNOBS: [&str; 8] = [
    "fidelity",
    "stride",
    "symbols",
    "antennas",
    "refinement",
    "resolution",
    "density",
    "trials",
];

/// Trial counts reported by the `trials` knob.
const TRIAL_COUNTS: [usize; 5] = [1, 2, 5, 10, 20];

/// Error standard deviations of the launch's `ideal` level (its argument defaults).
const IDEAL_RANGE_STD_M: f64 = 0.035;
const IDEAL_ANGLE_STD_DEG: f64 = 1.04;

/// `nrslam tradeoff`.
#[derive(Args, Debug)]
pub struct TradeoffArgs {
    /// Output folder: tradeoff.csv and pareto.png.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// SLAM trials per setting, 1 to 1000 (one after another; each timed on its thread's CPU
    /// clock, which on an idle core is the wall-clock time).
    #[arg(long, default_value_t = 5, value_parser = TRIALS.parser::<usize>(), allow_hyphen_values = true)]
    pub trials: usize,
    /// Radar frames per SLAM trial, 0 to 1000000 (0: the whole 294-frame lap).
    #[arg(long, default_value_t = 100, value_parser = crate::reproduce::FRAMES.parser::<u32>(), allow_hyphen_values = true)]
    pub frames: u32,
    /// Single-scatterer frames per setting for the range and angle RMSE, 1 to 1000000.
    #[arg(long, default_value_t = 100, value_parser = SENSING_TRIALS.parser::<u32>(), allow_hyphen_values = true)]
    pub sensing_trials: u32,
    /// Per-element SNR of every echo (dB), for the SLAM runs and the sensing errors alike. At
    /// the paper's 10 dB the 1.23 GHz chain is grid-limited whatever N, M or the stride; below
    /// about −25 dB their processing gain starts to show. −100 to 100 dB.
    #[arg(long, default_value_t = 10.0, value_parser = SNR_DB.parser(), allow_hyphen_values = true)]
    pub snr_db: f64,
    /// Base seed (0 to 2^64 − 1).
    #[arg(long, default_value_t = 1, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: u64,
    /// Knobs to sweep, comma-separated (default: all): fidelity, stride, symbols, antennas,
    /// refinement, resolution, density, trials.
    #[arg(long, value_delimiter = ',', value_name = "KNOB,...")]
    pub knobs: Vec<String>,
    /// Folder holding paper-5g.toml.
    #[arg(long, default_value = "launch", value_name = "DIR")]
    pub launch_dir: PathBuf,
}

/// `--trials`.
const TRIALS: Whole = Whole::new(1, 1000, "1 to 1000 trials");
/// `--sensing-trials`.
const SENSING_TRIALS: Whole = Whole::new(1, 1_000_000, "1 to 1000000 frames");
/// `--snr-db`.
const SNR_DB: Real = Real::closed(-100.0, 100.0, "-100 to 100 dB");

impl TradeoffArgs {
    /// Checks every numeric flag; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check("--trials", TRIALS.check(self.trials as u64))?;
        flags::check("--frames", crate::reproduce::FRAMES.check(self.frames))?;
        flags::check(
            "--sensing-trials",
            SENSING_TRIALS.check(self.sensing_trials),
        )?;
        flags::check("--snr-db", SNR_DB.check(self.snr_db))?;
        Ok(())
    }
}

/// One point of the sweep: every knob's value.
#[derive(Debug, Clone, PartialEq)]
struct Setting {
    knob: &'static str,
    label: String,
    fidelity: &'static str,
    subcarriers: usize,
    subcarrier_spacing_hz: f64,
    symbols: usize,
    antennas: usize,
    refinement: &'static str,
    resolution_m: f64,
    scatterer_spacing_m: f64,
}

impl Setting {
    fn baseline() -> Self {
        Self {
            knob: "baseline",
            label: "paper-5g defaults".to_owned(),
            fidelity: "spectral",
            subcarriers: 10240,
            subcarrier_spacing_hz: 120e3,
            symbols: 1,
            antennas: 32,
            refinement: "none",
            resolution_m: 0.1,
            scatterer_spacing_m: 0.25,
        }
    }

    fn assignments(&self, frames: u32, snr_db: f64) -> Vec<String> {
        vec![
            format!("snr_db:={snr_db:?}"),
            format!("fidelity:={}", self.fidelity),
            format!("subcarriers:={}", self.subcarriers),
            format!("subcarrier_spacing_hz:={:?}", self.subcarrier_spacing_hz),
            format!("symbols:={}", self.symbols),
            format!("antennas:={}", self.antennas),
            format!("refinement:={}", self.refinement),
            format!("resolution_m:={:?}", self.resolution_m),
            format!("scatterer_spacing_m:={:?}", self.scatterer_spacing_m),
            format!("frames:={frames}"),
        ]
    }

    /// What the sensing chain's errors depend on.
    fn sensing_key(&self) -> String {
        format!(
            "{}/{}/{}/{}/{}/{}",
            self.fidelity,
            self.subcarriers,
            self.subcarrier_spacing_hz,
            self.symbols,
            self.antennas,
            self.refinement
        )
    }
}

/// The settings of one knob (the baseline itself is swept once, as its own row).
fn settings(knob: &str) -> Vec<Setting> {
    let base = Setting::baseline();
    let with = |label: String, change: &dyn Fn(&mut Setting)| {
        let mut s = Setting {
            knob: KNOBS
                .iter()
                .find(|k| **k == knob)
                .copied()
                .unwrap_or("baseline"),
            label,
            ..base.clone()
        };
        change(&mut s);
        s
    };
    match knob {
        "fidelity" => vec![
            with("ideal".into(), &|s| s.fidelity = "ideal"),
            with("waveform".into(), &|s| s.fidelity = "waveform"),
        ],
        // The stride and symbols only cost time where the resource grid is built: swept at
        // `waveform` (the spectral map is closed-form and its cost does not depend on N or M).
        "stride" => [2usize, 4, 8, 16]
            .iter()
            .map(|&stride| {
                with(format!("waveform, stride {stride}"), &|s| {
                    s.fidelity = "waveform";
                    s.subcarriers = 10240 / stride;
                    s.subcarrier_spacing_hz = 120e3 * stride as f64;
                })
            })
            .collect(),
        "symbols" => [4usize, 16]
            .iter()
            .map(|&m| {
                with(format!("waveform, stride 16, M = {m}"), &|s| {
                    s.fidelity = "waveform";
                    s.subcarriers = 10240 / 16;
                    s.subcarrier_spacing_hz = 120e3 * 16.0;
                    s.symbols = m;
                })
            })
            .collect(),
        "antennas" => [8usize, 16, 64]
            .iter()
            .map(|&k| with(format!("K = {k}"), &|s| s.antennas = k))
            .collect(),
        "refinement" => vec![with("interpolation".into(), &|s| {
            s.refinement = "interpolation"
        })],
        "resolution" => [0.05, 0.2, 0.4]
            .iter()
            .map(|&r| with(format!("grid {r} m"), &|s| s.resolution_m = r))
            .collect(),
        "density" => [0.5, 1.0, 2.0]
            .iter()
            .map(|&d| {
                with(format!("scatterers every {d} m"), &|s| {
                    s.scatterer_spacing_m = d
                })
            })
            .collect(),
        _ => Vec::new(),
    }
}

/// One row of tradeoff.csv.
#[derive(Debug, Clone)]
struct Row {
    setting: Setting,
    trials: usize,
    frames: u64,
    time_per_frame_ms: f64,
    time_per_trial_s: f64,
    range_rmse_m: f64,
    angle_rmse_deg: f64,
    final_etgospa: f64,
    final_etgospa_sem: f64,
    pose_rmse_m: f64,
    pareto: bool,
}

/// Per-trial results of one setting.
#[derive(Debug, Clone, Copy)]
struct Trial {
    seconds: f64,
    frames: u64,
    final_etgospa: f64,
    pose_rmse_m: f64,
}

fn summarise(rows: &TrialRows, seconds: f64) -> Trial {
    let n = rows.len().max(1) as f64;
    Trial {
        seconds,
        frames: rows.len() as u64,
        final_etgospa: rows.last().map_or(f64::NAN, |r| r.1[0]),
        pose_rmse_m: (rows.iter().map(|r| r.1[2] * r.1[2]).sum::<f64>() / n).sqrt(),
    }
}

fn mean(values: impl Iterator<Item = f64>) -> (f64, f64, usize) {
    let values: Vec<f64> = values.collect();
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN, 0);
    }
    let m = values.iter().sum::<f64>() / n as f64;
    let sem = if n > 1 {
        (values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1) as f64 / n as f64).sqrt()
    } else {
        f64::NAN
    };
    (m, sem, n)
}

fn row(setting: Setting, trials: &[Trial], sensing: (f64, f64)) -> Row {
    let seconds: f64 = trials.iter().map(|t| t.seconds).sum();
    let frames: u64 = trials.iter().map(|t| t.frames).sum();
    let (final_etgospa, final_etgospa_sem, n) = mean(trials.iter().map(|t| t.final_etgospa));
    Row {
        setting,
        trials: n,
        frames: frames / n.max(1) as u64,
        time_per_frame_ms: 1e3 * seconds / frames.max(1) as f64,
        time_per_trial_s: seconds / n.max(1) as f64,
        range_rmse_m: sensing.0,
        angle_rmse_deg: sensing.1,
        final_etgospa,
        final_etgospa_sem,
        pose_rmse_m: mean(trials.iter().map(|t| t.pose_rmse_m)).0,
        pareto: false,
    }
}

/// Marks the rows no other row beats on both time per frame and final ET-GOPSA (the `trials`
/// knob's rows share the baseline's per-frame time and are left out).
fn mark_pareto(rows: &mut [Row]) {
    let on_axes = |r: &Row| {
        r.setting.knob != "trials" && r.time_per_frame_ms.is_finite() && r.final_etgospa.is_finite()
    };
    let candidates: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| on_axes(r))
        .map(|r| (r.time_per_frame_ms, r.final_etgospa))
        .collect();
    for r in rows.iter_mut() {
        let (t, e) = (r.time_per_frame_ms, r.final_etgospa);
        r.pareto = on_axes(r)
            && !candidates
                .iter()
                .any(|&(t2, e2)| t2 <= t && e2 <= e && (t2 < t || e2 < e));
    }
}

/// `nrslam tradeoff`.
pub fn tradeoff(args: TradeoffArgs) -> Result<()> {
    args.validate()?;
    let knobs: Vec<&'static str> = if args.knobs.is_empty() {
        KNOBS.to_vec()
    } else {
        args.knobs
            .iter()
            .map(|k| {
                KNOBS
                    .iter()
                    .find(|known| **known == k.trim())
                    .copied()
                    .ok_or_else(|| {
                        anyhow!(
                            "--knobs: {k:?} is not a knob (allowed: {})",
                            KNOBS.join(", ")
                        )
                    })
            })
            .collect::<Result<_>>()?
    };
    let file = args.launch_dir.join("paper-5g.toml");
    let mut plan = vec![Setting::baseline()];
    for knob in &knobs {
        plan.extend(settings(knob));
    }
    // Check every setting's launch before spending any time.
    let mut launches = Vec::new();
    for setting in &plan {
        let launch = Launch::load(&file, &setting.assignments(args.frames, args.snr_db))
            .with_context(|| format!("setting {:?}", setting.label))?;
        crate::launcher::build_all(&launch, args.seed)
            .with_context(|| format!("setting {:?}", setting.label))?;
        launches.push(launch);
    }
    let baseline_trials = if knobs.contains(&"trials") {
        args.trials.max(*TRIAL_COUNTS.iter().max().unwrap_or(&1))
    } else {
        args.trials
    };
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

    let mut sensing: BTreeMap<String, (f64, f64)> = BTreeMap::new();
    let mut rows = Vec::new();
    for (setting, launch) in plan.iter().zip(&launches) {
        bar.set_message(format!("{}: {}", setting.knob, setting.label));
        let errors = if setting.fidelity == "ideal" {
            (IDEAL_RANGE_STD_M, IDEAL_ANGLE_STD_DEG)
        } else if let Some(e) = sensing.get(&setting.sensing_key()) {
            *e
        } else {
            let params = OfdmParams {
                subcarriers: setting.subcarriers,
                subcarrier_spacing_hz: setting.subcarrier_spacing_hz,
                symbols: setting.symbols,
                antennas: setting.antennas,
                snr_db: args.snr_db,
                ..OfdmParams::default()
            };
            let (refinement, padding) = parse_refinement(setting.refinement)?;
            let tally = single_scatterer_trials(
                &params,
                setting.fidelity == "waveform",
                refinement,
                padding,
                args.sensing_trials,
                args.seed,
                "tradeoff",
                &|| bar.inc(1),
            )
            .with_context(|| format!("sensing errors of {:?}", setting.label))?;
            let e = (tally.range_rmse_m(), tally.angle_rmse_rad().to_degrees());
            sensing.insert(setting.sensing_key(), e);
            e
        };
        let count = if setting.knob == "baseline" {
            baseline_trials
        } else {
            args.trials
        };
        let mut trials = Vec::with_capacity(count);
        for i in 0..count {
            let (rows, seconds) =
                timed(|| run_trial(launch, nrslam_runtime::seed::trial(args.seed, i as u64)));
            let rows = rows.with_context(|| format!("setting {:?}, trial {i}", setting.label))?;
            trials.push(summarise(&rows, seconds));
            bar.inc(1);
        }
        if setting.knob == "baseline" {
            let baseline_runs = &trials;
            rows.push(row(
                setting.clone(),
                &trials[..args.trials.min(count)],
                errors,
            ));
            if knobs.contains(&"trials") {
                for n in TRIAL_COUNTS {
                    let mut r = row(
                        Setting {
                            knob: "trials",
                            label: format!("{n} trials"),
                            ..setting.clone()
                        },
                        &baseline_runs[..n.min(baseline_runs.len())],
                        errors,
                    );
                    // A study's cost: n trials at the baseline's mean time per trial.
                    r.time_per_trial_s = n as f64 * mean(baseline_runs.iter().map(|t| t.seconds)).0;
                    rows.push(r);
                }
            }
        } else {
            rows.push(row(setting.clone(), &trials, errors));
        }
    }
    bar.finish_and_clear();
    mark_pareto(&mut rows);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    write_csv(&args.out.join("tradeoff.csv"), &rows)?;
    plot(&args.out.join("pareto.png"), &rows)?;
    for r in &rows {
        outln!(
            "{:<10} {:<24} {:>9.3} ms/frame {:>8.2} s/trial  range {:.4} m  angle {:.2}°  ET-GOPSA {:>6.1} ± {:<5.1} pose RMSE {:.2} m{}",
            r.setting.knob,
            r.setting.label,
            r.time_per_frame_ms,
            r.time_per_trial_s,
            r.range_rmse_m,
            r.angle_rmse_deg,
            r.final_etgospa,
            r.final_etgospa_sem,
            r.pose_rmse_m,
            if r.pareto { "  (Pareto)" } else { "" }
        );
    }
    outln!("wrote {}", args.out.display());
    Ok(())
}

/// tradeoff.csv's columns.
pub const COLUMNS: [&str; 21] = [
    "knob",
    "setting",
    "fidelity",
    "subcarriers",
    "subcarrier_spacing_hz",
    "symbols",
    "antennas",
    "refinement",
    "resolution_m",
    "scatterer_spacing_m",
    "trials",
    "frames",
    "time_per_frame_ms",
    "time_per_trial_s",
    "range_rmse_m",
    "angle_rmse_deg",
    "final_etgospa",
    "final_etgospa_sem",
    "pose_rmse_m",
    "pareto",
    "time_per_study_s",
];

fn write_csv(path: &Path, rows: &[Row]) -> Result<()> {
    let mut writer =
        csv::Writer::from_path(path).with_context(|| format!("cannot write {}", path.display()))?;
    writer.write_record(COLUMNS)?;
    for r in rows {
        let s = &r.setting;
        let study_s = if s.knob == "trials" {
            r.time_per_trial_s
        } else {
            r.time_per_trial_s * r.trials as f64
        };
        writer.write_record([
            s.knob.to_string(),
            s.label.clone(),
            s.fidelity.to_string(),
            s.subcarriers.to_string(),
            s.subcarrier_spacing_hz.to_string(),
            s.symbols.to_string(),
            s.antennas.to_string(),
            s.refinement.to_string(),
            s.resolution_m.to_string(),
            s.scatterer_spacing_m.to_string(),
            r.trials.to_string(),
            r.frames.to_string(),
            r.time_per_frame_ms.to_string(),
            r.time_per_trial_s.to_string(),
            r.range_rmse_m.to_string(),
            r.angle_rmse_deg.to_string(),
            r.final_etgospa.to_string(),
            r.final_etgospa_sem.to_string(),
            r.pose_rmse_m.to_string(),
            r.pareto.to_string(),
            study_s.to_string(),
        ])?;
    }
    writer.flush()?;
    Ok(())
}

fn plot(path: &Path, rows: &[Row]) -> Result<()> {
    crate::plot::register_font();
    let err = |e: &dyn std::fmt::Display| anyhow!("plotting failed: {e}");
    let points: Vec<&Row> = rows
        .iter()
        .filter(|r| {
            r.setting.knob != "trials"
                && r.time_per_frame_ms.is_finite()
                && r.time_per_frame_ms > 0.0
                && r.final_etgospa.is_finite()
        })
        .collect();
    let root = BitMapBackend::new(path, (1100, 700)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let t_min = points
        .iter()
        .map(|r| r.time_per_frame_ms)
        .fold(f64::INFINITY, f64::min)
        .min(1.0)
        / 1.5;
    let t_max = points
        .iter()
        .map(|r| r.time_per_frame_ms)
        .fold(1.0, f64::max)
        * 1.5;
    let e_max = points
        .iter()
        .map(|r| r.final_etgospa + r.final_etgospa_sem.max(0.0))
        .filter(|v| v.is_finite())
        .fold(1.0, f64::max)
        * 1.1;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "Speed against accuracy: one knob at a time from the paper-5g baseline",
            ("sans-serif", 22),
        )
        .margin(14)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d((t_min..t_max).log_scale(), 0.0..e_max)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc("time per radar frame, whole graph (ms, log scale)")
        .y_desc("final ET-GOPSA (mean over trials)")
        .draw()
        .map_err(|e| err(&e))?;
    let mut front: Vec<(f64, f64)> = points
        .iter()
        .filter(|r| r.pareto)
        .map(|r| (r.time_per_frame_ms, r.final_etgospa))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart
        .draw_series(LineSeries::new(front, BLACK.mix(0.5).stroke_width(2)))
        .map_err(|e| err(&e))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.mix(0.5).stroke_width(2)));
    for (index, knob) in std::iter::once("baseline").chain(KNOBS).enumerate() {
        let color = Palette99::pick(index).to_rgba();
        let mine: Vec<&&Row> = points.iter().filter(|r| r.setting.knob == knob).collect();
        if mine.is_empty() {
            continue;
        }
        chart
            .draw_series(mine.iter().map(|r| {
                let at = (r.time_per_frame_ms, r.final_etgospa);
                EmptyElement::at(at)
                    + Circle::new((0, 0), if r.pareto { 7 } else { 5 }, color.filled())
                    + Text::new(r.setting.label.clone(), (8, -6), ("sans-serif", 13))
            }))
            .map_err(|e| err(&e))?
            .label(knob)
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(knob: &'static str, time_ms: f64, etgospa: f64) -> Row {
        Row {
            setting: Setting {
                knob,
                ..Setting::baseline()
            },
            trials: 1,
            frames: 1,
            time_per_frame_ms: time_ms,
            time_per_trial_s: time_ms,
            range_rmse_m: 0.0,
            angle_rmse_deg: 0.0,
            final_etgospa: etgospa,
            final_etgospa_sem: 0.0,
            pose_rmse_m: 0.0,
            pareto: false,
        }
    }

    #[test]
    fn pareto_keeps_exactly_the_undominated_rows() {
        let mut rows = vec![
            at("baseline", 1.0, 50.0),
            at("stride", 0.5, 60.0),
            at("stride", 2.0, 55.0), // dominated by the baseline
            at("refinement", 1.5, 40.0),
            at("fidelity", 1.0, 50.0), // equal to the baseline: neither dominates
            at("trials", 0.1, 1.0),    // another axis: never on the front
            at("density", f64::NAN, 10.0),
        ];
        mark_pareto(&mut rows);
        let flags: Vec<bool> = rows.iter().map(|r| r.pareto).collect();
        assert_eq!(flags, [true, true, false, true, true, false, false]);
    }

    #[test]
    fn every_knob_has_settings_that_differ_from_the_baseline() {
        for knob in KNOBS.iter().filter(|k| **k != "trials") {
            let settings = settings(knob);
            assert!(!settings.is_empty(), "{knob}");
            for s in settings {
                assert_eq!(s.knob, *knob);
                assert_ne!(
                    Setting {
                        knob: "baseline",
                        label: String::new(),
                        ..s.clone()
                    },
                    Setting {
                        label: String::new(),
                        ..Setting::baseline()
                    },
                    "{knob}: {}",
                    s.label
                );
            }
        }
    }

    #[test]
    fn a_stride_keeps_the_bandwidth() {
        for s in settings("stride") {
            let bandwidth_hz = s.subcarriers as f64 * s.subcarrier_spacing_hz;
            assert!((bandwidth_hz - 10240.0 * 120e3).abs() < 1.0, "{}", s.label);
        }
    }

    #[test]
    fn the_standard_error_shrinks_as_one_over_root_n() {
        let (m, sem, n) = mean([1.0, 3.0].into_iter());
        assert_eq!((m, n), (2.0, 2));
        // sample std √2, over √2
        assert!((sem - 1.0).abs() < 1e-12);
        assert!(mean(std::iter::once(4.0)).1.is_nan());
    }
}
