//! `nrslam metric`: GOSPA and ET-GOPSA of an estimated point map against true extended targets,
//! both read from CSV files by the evaluator (`nrslam_evaluator::evaluate_files`), printed as a
//! table or, with --json, as the evaluator's report.

use crate::flags::{self, Real};
use anyhow::{anyhow, bail, Result};
use clap::Args;
use nrslam_evaluator::{DistanceMode, EtGospaParams};
use std::path::PathBuf;

/// `nrslam metric`.
#[derive(Args, Debug)]
pub struct MetricArgs {
    /// Truth CSV with header `target,x,y`: one row per sample point (slot) of each extended target
    /// (each file at most 1 GiB and 16777216 rows). Only pairs within the cut-off c interact, so
    /// the assignment splits into connected components; each must have at most 2^26 truth points ×
    /// estimates.
    #[arg(long, value_name = "FILE")]
    pub truth: PathBuf,
    /// Estimates CSV with header `x,y`: one row per estimated point (m).
    #[arg(long, value_name = "FILE")]
    pub estimates: PathBuf,
    /// Cut-off distance c (m; m² with --squared-distance): the largest error counted per point,
    /// 1e-12 to 1e12 (and c^p between 1e-100 and 1e100).
    #[arg(
        long = "c",
        value_name = "C",
        default_value_t = 5.0,
        value_parser = CUTOFF.parser(),
        allow_hyphen_values = true
    )]
    pub c: f64,
    /// Order 1 ≤ p ≤ 1000, or `inf` for p = ∞ (c^p must stay between 1e-100 and 1e100): larger
    /// p penalises outliers more.
    #[arg(
        long = "p",
        value_name = "P",
        default_value = "1",
        allow_hyphen_values = true
    )]
    pub p: String,
    /// Cardinality penalty 0 < α ≤ 2: a missed slot or false estimate costs c^p/α.
    #[arg(
        long = "alpha",
        value_name = "A",
        default_value_t = 2.0,
        value_parser = ALPHA.parser(),
        allow_hyphen_values = true
    )]
    pub alpha: f64,
    /// ET-GOPSA distance to a target: to its nearest sample point (`samples`, the paper) or to the
    /// polygon through its samples in file order (`outline`).
    #[arg(long, default_value = "samples", value_name = "MODE")]
    pub distance: String,
    /// Use squared distances inside the cut-off, as the paper's formula literally writes.
    #[arg(long)]
    pub squared_distance: bool,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// `metric --c`.
const CUTOFF: Real = Real::closed(1e-12, 1e12, "1e-12 to 1e12 m (m² with --squared-distance)");
/// `metric --p` (finite values; `inf` is allowed too).
const ORDER: Real = Real::closed(1.0, 1000.0, "1 to 1000, or inf");
/// `metric --alpha`.
const ALPHA: Real = Real {
    min: 0.0,
    max: 2.0,
    open_min: true,
    zero: false,
    allowed: "0 < alpha ≤ 2",
};

impl MetricArgs {
    /// The metric parameters the flags give, each checked; the error names the flag.
    pub fn params(&self) -> Result<EtGospaParams> {
        let c = flags::check("--c", CUTOFF.check(self.c))?;
        let p = match self.p.trim() {
            "inf" | "∞" | "infinity" => f64::INFINITY,
            text => flags::check("--p", ORDER.parse(text))?,
        };
        let alpha = flags::check("--alpha", ALPHA.check(self.alpha))?;
        let distance = match self.distance.as_str() {
            "samples" => DistanceMode::Samples,
            "outline" => DistanceMode::Outline,
            other => bail!("--distance: {other:?} is not a mode (allowed: samples, outline)"),
        };
        let params = EtGospaParams {
            c,
            p,
            alpha,
            distance,
            squared_distance: self.squared_distance,
        };
        // The joint limits (c^p, c^p/α), named by the metric's field: `--c`, `--p` or `--alpha`.
        params
            .validate()
            .map_err(|e| anyhow!("--{}: {} (allowed: {})", e.field, e.problem, e.allowed))?;
        Ok(params)
    }

    /// Checks every flag; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        self.params().map(drop)
    }
}

/// `nrslam metric`.
pub fn metric(args: MetricArgs) -> Result<()> {
    let params = args.params()?;
    let report = nrslam_evaluator::evaluate_files(&args.truth, &args.estimates, &params)?;
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_table(&report);
    }
    Ok(())
}

/// The report as a table: counts, then one row per metric with its terms.
fn print_table(report: &nrslam_evaluator::MetricReport) {
    outln!(
        "targets {}, truth points {}, estimates {}",
        report.target_count,
        report.truth_point_count,
        report.estimate_count
    );
    outln!(
        "{:<10} {:>12} {:>14} {:>12} {:>12} {:>12}",
        "metric",
        "total",
        "localisation",
        "confusion",
        "missed",
        "false"
    );
    let g = &report.gospa;
    outln!(
        "{:<10} {:>12.6} {:>14.6} {:>12} {:>12.6} {:>12.6}",
        "GOSPA",
        g.total,
        g.localisation,
        "-",
        g.missed,
        g.false_estimates
    );
    let e = &report.etgospa;
    outln!(
        "{:<10} {:>12.6} {:>14.6} {:>12.6} {:>12.6} {:>12.6}",
        "ET-GOPSA",
        e.total,
        e.localisation,
        e.confusion,
        e.missed,
        e.false_estimates
    );
    outln!("(terms are summed p-th powers; total = (sum of terms)^(1/p))");
}
