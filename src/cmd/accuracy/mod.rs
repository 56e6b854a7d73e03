//! `nrslam accuracy`: single-scatterer range and angle RMSE of the 5G sensing chain against SNR,
//! beside the Cramér–Rao bounds and the DFT grid limits (docs/design.md, "Fidelity levels of the front end").
//!
//! Each trial draws one scatterer, uniform in range over [2, 20] m and in angle over ±60°, with a
//! unit echo of random phase; the front end synthesises the frame at the chosen fidelity and the
//! estimator keeps its strongest detection. Trial t at SNR index s is seeded from
//! (seed, s, t), so the numbers do not depend on the order trials run in.
//!
//! The range bound is docs/design.md's single-antenna var(R) divided by K (the estimator sums the K
//! antennas coherently); the angle bound already uses SNR·N·M.

mod plot;
mod trials;

pub(crate) use trials::{parse_refinement, single_scatterer_trials};

use crate::flags::{self, Whole};
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_ofdm::{bounds, OfdmParams};
use plot::plot;

/// `nrslam accuracy`.
#[derive(Args, Debug)]
pub struct AccuracyArgs {
    /// Front end: spectral (closed-form processed map) or waveform (resource grids + FFTs).
    #[arg(long, default_value = "spectral", value_name = "F")]
    pub fidelity: String,
    /// Sub-bin refinement: none (the paper), interpolation, zero-padding:F (range IDFT and
    /// array DFT F times longer), or a super-resolution method: music or esprit (angle resolved
    /// per range bin) or nomp (gridless, joint in range and angle); docs/superresolution.md.
    #[arg(long, default_value = "none", value_name = "R")]
    pub refine: String,
    /// Per-element SNR sweep in dB, FROM:TO:STEP.
    #[arg(
        long,
        default_value = "-10:30:5",
        value_name = "FROM:TO:STEP",
        allow_hyphen_values = true
    )]
    pub snr_db: String,
    /// Trials per SNR, 1 to 1000000.
    #[arg(long, default_value_t = 200, value_parser = TRIALS.parser::<u32>(), allow_hyphen_values = true)]
    pub trials: u32,
    /// Seed of the trials (0 to 2^64 − 1).
    #[arg(long, default_value_t = 1, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: u64,
    /// Subcarriers N (Table I: 10240), 1 to 16777216; N × K at most 2^28.
    #[arg(long, default_value_t = 10240, value_parser = SUBCARRIERS.parser::<usize>(), allow_hyphen_values = true)]
    pub subcarriers: usize,
    /// Antennas K (Table I: 32), 1 to 4096; N × K at most 2^28.
    #[arg(long, default_value_t = 32, value_parser = ANTENNAS.parser::<usize>(), allow_hyphen_values = true)]
    pub antennas: usize,
    #[command(flatten)]
    pub out: crate::args::OutputDirArgs,
}

/// `--trials`.
const TRIALS: Whole = Whole::new(1, 1_000_000, "1 to 1000000 trials per SNR");
/// `--subcarriers` (the OFDM model's own limit).
const SUBCARRIERS: Whole = Whole::new(1, 16_777_216, "1 to 16777216 subcarriers");
/// `--antennas`.
const ANTENNAS: Whole = Whole::new(1, 4096, "1 to 4096 antennas");
/// Largest N × K: a frame holds N × K complex samples (16 bytes each), so 4 GiB at the limit.
const MAX_GRID_CELLS: u64 = 1 << 28;

impl AccuracyArgs {
    /// Checks every numeric flag (and the `--snr-db` sweep, `--refine`); the error names the flag.
    pub fn validate(&self) -> Result<()> {
        sweep(&self.snr_db)?;
        parse_refinement(&self.refine)?;
        flags::check("--trials", TRIALS.check(self.trials))?;
        flags::check("--subcarriers", SUBCARRIERS.check(self.subcarriers as u64))?;
        flags::check("--antennas", ANTENNAS.check(self.antennas as u64))?;
        let cells = self.subcarriers as u64 * self.antennas as u64;
        if cells > MAX_GRID_CELLS {
            bail!(
                "--subcarriers/--antennas: N × K = {} × {} = {cells} is out of range (allowed: at most {MAX_GRID_CELLS} samples per frame, 4 GiB)",
                self.subcarriers,
                self.antennas
            );
        }
        Ok(())
    }
}

fn sweep(text: &str) -> Result<Vec<f64>> {
    let parts: Vec<f64> = text
        .split(':')
        .map(|p| {
            p.trim()
                .parse::<f64>()
                .map_err(|_| anyhow!("--snr-db: {p:?} is not a number (expected FROM:TO:STEP, dB)"))
        })
        .collect::<Result<_>>()?;
    let [from, to, step] = parts[..] else {
        bail!("--snr-db: expected FROM:TO:STEP, got {text:?}")
    };
    if !(from.is_finite()
        && to.is_finite()
        && step.is_finite()
        && step > 0.0
        && to >= from
        && (to - from) / step <= 1000.0)
    {
        bail!("--snr-db: {text:?} is out of range (allowed: finite FROM ≤ TO, STEP > 0, at most 1000 points)");
    }
    let count = ((to - from) / step + 1e-9).floor() as usize + 1;
    Ok((0..count).map(|i| from + i as f64 * step).collect())
}

/// One row of accuracy.csv.
struct Row {
    snr_db: f64,
    range_rmse_m: f64,
    range_crb_m: f64,
    range_grid_m: f64,
    angle_rmse_deg: f64,
    angle_crb_deg: f64,
    angle_grid_deg: f64,
    misses: u32,
}

/// `nrslam accuracy`.
pub fn accuracy(args: AccuracyArgs) -> Result<()> {
    args.validate()?;
    let snrs = sweep(&args.snr_db)?;
    let waveform_level = match args.fidelity.as_str() {
        "spectral" => false,
        "waveform" => true,
        other => bail!("--fidelity: {other:?} is not a level (allowed: spectral, waveform)"),
    };
    let (refinement, padding) = parse_refinement(&args.refine)?;
    let base = OfdmParams {
        subcarriers: args.subcarriers,
        antennas: args.antennas,
        symbols: 1,
        ..OfdmParams::default()
    };
    base.validate()
        .map_err(|e| anyhow!("--subcarriers/--antennas: {e}"))?;
    args.out.create()?;
    let bar = ProgressBar::new(snrs.len() as u64 * args.trials as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} trials  ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut rows = Vec::new();
    for (snr_index, &snr_db) in snrs.iter().enumerate() {
        let params = OfdmParams { snr_db, ..base };
        let tally = single_scatterer_trials(
            &params,
            waveform_level,
            refinement,
            padding,
            args.trials,
            args.seed,
            &format!("accuracy/{snr_index}"),
            &|| bar.inc(1),
        )?;
        let n = args.trials as f64;
        rows.push(Row {
            snr_db,
            range_rmse_m: tally.range_rmse_m(),
            // The estimator integrates all K antennas: the single-antenna bound of docs/design.md / K.
            range_crb_m: bounds::range_variance_bound_array_m2(&params).sqrt(),
            range_grid_m: bounds::range_grid_rms_m(&params, padding),
            angle_rmse_deg: tally.angle_rmse_rad().to_degrees(),
            angle_crb_deg: (tally.crb_angle_sq / n).sqrt().to_degrees(),
            angle_grid_deg: (tally.grid_angle_sq / n).sqrt().to_degrees(),
            misses: tally.misses,
        });
    }
    bar.finish_and_clear();
    let csv_path = args.out.join("accuracy.csv");
    let mut writer = csv::Writer::from_path(&csv_path)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    writer.write_record([
        "snr_db",
        "range_rmse_m",
        "range_crb_m",
        "range_grid_m",
        "angle_rmse_deg",
        "angle_crb_deg",
        "angle_grid_deg",
        "missed_trials",
    ])?;
    for r in &rows {
        writer.write_record([
            r.snr_db.to_string(),
            r.range_rmse_m.to_string(),
            r.range_crb_m.to_string(),
            r.range_grid_m.to_string(),
            r.angle_rmse_deg.to_string(),
            r.angle_crb_deg.to_string(),
            r.angle_grid_deg.to_string(),
            r.misses.to_string(),
        ])?;
    }
    writer.flush()?;
    plot(
        &args.out.join("accuracy.png"),
        &rows,
        &args.fidelity,
        &args.refine,
    )?;
    for r in &rows {
        outln!(
            "SNR {:>6.1} dB: range RMSE {:.4} m (CRB {:.2e}, grid {:.4}), angle RMSE {:.3}° (CRB {:.2e}, grid {:.3}), missed {}",
            r.snr_db, r.range_rmse_m, r.range_crb_m, r.range_grid_m, r.angle_rmse_deg, r.angle_crb_deg, r.angle_grid_deg, r.misses
        );
    }
    outln!("wrote {} and accuracy.png", csv_path.display());
    Ok(())
}
/// Sums over the single-scatterer trials of one setting.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct Tally {
    range_sq_m2: f64,
    angle_sq_rad2: f64,
    crb_angle_sq: f64,
    grid_angle_sq: f64,
    hits: u32,
    /// Trials in which the estimator reported nothing.
    pub misses: u32,
}

impl Tally {
    /// Range RMSE over the trials with a detection (m); NaN when there were none.
    pub fn range_rmse_m(&self) -> f64 {
        self.rmse(self.range_sq_m2)
    }

    /// Angle RMSE over the trials with a detection (rad); NaN when there were none.
    pub fn angle_rmse_rad(&self) -> f64 {
        self.rmse(self.angle_sq_rad2)
    }

    fn rmse(&self, sum: f64) -> f64 {
        if self.hits > 0 {
            (sum / self.hits as f64).sqrt()
        } else {
            f64::NAN
        }
    }
}
