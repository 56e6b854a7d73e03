//! The command line of `nrslam tradeoff`: its flags, their allowed ranges, and the checks that
//! run before any work (numeric ranges, then the `--knobs` names).

use super::knobs::KNOBS;
use crate::flags::{self, Real, Whole};
use anyhow::{anyhow, Result};
use clap::Args;
use std::path::PathBuf;

/// `nrslam tradeoff`.
#[derive(Args, Debug)]
pub struct TradeoffArgs {
    #[command(flatten)]
    pub out: crate::args::OutputDirArgs,
    /// SLAM trials per setting, 1 to 1000 (one after another; each timed on its thread's CPU
    /// clock, which on an idle core is the wall-clock time).
    #[arg(long, default_value_t = 5, value_parser = TRIALS.parser::<usize>(), allow_hyphen_values = true)]
    pub trials: usize,
    /// Radar frames per SLAM trial, 0 to 1000000 (0: the whole 294-frame lap).
    #[arg(long, default_value_t = 100, value_parser = crate::cmd::reproduce::FRAMES.parser::<u32>(), allow_hyphen_values = true)]
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
        flags::check("--frames", crate::cmd::reproduce::FRAMES.check(self.frames))?;
        flags::check(
            "--sensing-trials",
            SENSING_TRIALS.check(self.sensing_trials),
        )?;
        flags::check("--snr-db", SNR_DB.check(self.snr_db))?;
        Ok(())
    }

    /// The knobs to sweep, in the order given (all of [`KNOBS`] when `--knobs` is absent); an
    /// unknown name is refused with the allowed list.
    pub(super) fn selected_knobs(&self) -> Result<Vec<&'static str>> {
        if self.knobs.is_empty() {
            return Ok(KNOBS.to_vec());
        }
        self.knobs
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
            .collect()
    }
}
