//! `nrslam segment`: DBSCAN (`nrslam_segmenter::dbscan`) on a CSV of points `x,y`, writing every
//! row back as `x,y,label` (label -1: noise), to --output or standard output.
//!
//! The input is read by the evaluator's CSV reader (`nrslam_evaluator::csv_io::read_estimates`),
//! as `nrslam metric` reads its estimates: columns found by name (case-insensitive, other columns
//! ignored), errors naming the file, line and column, at most 1 GiB and 16777216 rows, streamed.

use crate::flags::{self, Real, Whole};
use anyhow::{anyhow, Context, Result};
use clap::Args;
use nrslam_evaluator::csv_io::read_estimates;
use std::path::{Path, PathBuf};

/// `nrslam segment`.
#[derive(Args, Debug)]
pub struct SegmentArgs {
    /// Input CSV with header `x,y` (m); at most 1 GiB and 16777216 rows.
    #[arg(long, value_name = "FILE")]
    pub input: PathBuf,
    /// DBSCAN neighbourhood radius (m): points within eps are neighbours, 0 to 1e9 m.
    #[arg(long, value_name = "M", value_parser = EPS_M.parser(), allow_hyphen_values = true)]
    pub eps: f64,
    /// DBSCAN minimum neighbourhood size, the point itself included, 1 to 4294967295.
    #[arg(long, value_name = "K", value_parser = MIN_SAMPLES.parser::<usize>(), allow_hyphen_values = true)]
    pub min_samples: usize,
    /// Output CSV `x,y,label` (label -1: noise). Default: standard output.
    #[arg(long, value_name = "FILE")]
    pub output: Option<PathBuf>,
}

/// `segment --eps`.
const EPS_M: Real = Real::closed(0.0, 1e9, "0 to 1e9 m");
/// `segment --min-samples`.
const MIN_SAMPLES: Whole = Whole::new(1, u32::MAX as u64, "1 to 4294967295 points");

impl SegmentArgs {
    /// Checks `--eps` and `--min-samples`; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check("--eps", EPS_M.check(self.eps))?;
        flags::check("--min-samples", MIN_SAMPLES.check(self.min_samples as u64))?;
        Ok(())
    }
}

/// `nrslam segment`.
pub fn segment(args: SegmentArgs) -> Result<()> {
    args.validate()?;
    let points = read_points(&args.input)?;
    let clustering = nrslam_segmenter::dbscan(&points, args.eps, args.min_samples)
        .map_err(|e| anyhow!("--eps/--min-samples: {e}"))?;
    let sink: Box<dyn std::io::Write> = match &args.output {
        Some(out) => Box::new(
            std::fs::File::create(out)
                .with_context(|| format!("{}: cannot create", out.display()))?,
        ),
        None => Box::new(std::io::stdout().lock()),
    };
    let mut writer = csv::Writer::from_writer(sink);
    writer.write_record(["x", "y", "label"])?;
    for (point, label) in points.iter().zip(&clustering.labels) {
        writer.write_record([
            point[0].to_string(),
            point[1].to_string(),
            label.to_string(),
        ])?;
    }
    writer.flush()?;
    if args.output.is_some() {
        eprintln!(
            "{} points, {} clusters, {} noise",
            points.len(),
            clustering.cluster_count,
            clustering.noise_count()
        );
    }
    Ok(())
}

/// The points of an `x,y` CSV, read as `nrslam metric` reads its estimates.
fn read_points(path: &Path) -> Result<Vec<[f64; 2]>> {
    Ok(read_estimates(path)?
        .into_iter()
        .map(|p| [p.x_m, p.y_m])
        .collect())
}
