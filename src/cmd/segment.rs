//! `nrslam segment`: DBSCAN (`nrslam_segmenter::dbscan`) on a CSV of points `x,y`, writing every
//! row back as `x,y,label` (label -1: noise), to --output or standard output.
//!
//! The input is read here, not by the evaluator's CSV reader (`nrslam_evaluator::csv_io`), which
//! `nrslam metric` uses: the two accept different files. This reader matches the header names
//! exactly (after trimming) and takes the first of a repeated column, and the csv crate refuses
//! rows whose length differs from the header's; the evaluator's matches case-insensitively,
//! refuses a repeated column and ignores extra fields. Both share the size limits
//! ([`MAX_CSV_BYTES`], [`MAX_CSV_ROWS`]).

use crate::flags::{self, Real, Whole};
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use nrslam_evaluator::csv_io::{MAX_CSV_BYTES, MAX_CSV_ROWS};
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

/// The points of a CSV file with columns `x` and `y`, in file order. Errors name the file, and
/// the line and column of a bad value.
fn read_points(path: &Path) -> Result<Vec<[f64; 2]>> {
    // Streamed, and refused past the limits `nrslam metric` has, before reading it whole.
    let file =
        std::fs::File::open(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
    if size > MAX_CSV_BYTES {
        bail!(
            "{}: {size} bytes is more than the limit of {MAX_CSV_BYTES} bytes",
            path.display()
        );
    }
    // (A pipe has no size: it is cut at the limit.)
    let mut reader = csv::Reader::from_reader(std::io::Read::take(file, MAX_CSV_BYTES));
    let headers = reader
        .headers()
        .with_context(|| format!("{}: no header row", path.display()))?
        .clone();
    let column = |name: &str| {
        headers
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| {
                anyhow!(
                    "{}: no column {name:?} in header (expected x,y)",
                    path.display()
                )
            })
    };
    let (x_column, y_column) = (column("x")?, column("y")?);
    let mut points = Vec::new();
    for (index, record) in reader.records().enumerate() {
        let line = index + 2;
        let record = record.with_context(|| format!("{}: line {line}", path.display()))?;
        let value = |column: usize, name: &str| -> Result<f64> {
            let text = record.get(column).unwrap_or("").trim();
            let value: f64 = text.parse().map_err(|_| {
                anyhow!(
                    "{}: line {line}, column {name}: {text:?} is not a number",
                    path.display()
                )
            })?;
            if !value.is_finite() {
                bail!(
                    "{}: line {line}, column {name}: {text:?} is not finite",
                    path.display()
                );
            }
            Ok(value)
        };
        if points.len() as u64 >= MAX_CSV_ROWS {
            bail!(
                "{}: more than {MAX_CSV_ROWS} rows (the limit of `nrslam segment`)",
                path.display()
            );
        }
        points.push([value(x_column, "x")?, value(y_column, "y")?]);
    }
    Ok(points)
}
