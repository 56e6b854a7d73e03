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
//!
//! The files, in the order the command uses them:
//!
//! - `args.rs`: the flags, their ranges and the `--knobs` names;
//! - `knobs.rs`: the baseline, each knob's settings and the sweep plan;
//! - `run.rs`: loading every setting's launch, then its sensing errors and timed SLAM trials;
//! - `clock.rs`: the per-thread CPU clock the trials are timed on;
//! - `table.rs`: the rows (means, standard errors, Pareto flags), tradeoff.csv and the summary
//!   printed on standard output;
//! - `plot.rs`: pareto.png.

mod args;
mod clock;
mod knobs;
mod plot;
mod run;
mod table;

pub use args::TradeoffArgs;

use anyhow::Result;

/// `nrslam tradeoff`.
pub fn tradeoff(args: TradeoffArgs) -> Result<()> {
    args.validate()?;
    let knobs = args.selected_knobs()?;
    let plan = knobs::plan(&knobs);
    let launches = run::load_launches(&args, &plan)?;
    let mut rows = run::sweep(&args, &knobs, &plan, &launches)?;
    table::mark_pareto(&mut rows);
    args.out.create()?;
    table::write_csv(&args.out.join("tradeoff.csv"), &rows)?;
    plot::write_pareto_png(&args.out.join("pareto.png"), &rows)?;
    table::print_rows(&rows);
    outln!("wrote {}", args.out.dir.display());
    Ok(())
}
