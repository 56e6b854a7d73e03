//! Figs. 6 and 7 from the trials' `montecarlo.csv`: one CSV and one plot of a metric's mean
//! against time, one curve per condition, and with `--oracle` the same conditions mapped at the
//! true poses (dashed) and `oracle.csv`, the final ET-GOPSA of each beside its oracle's.

use super::{oracle_dir, trials_dir, Condition};
use crate::plot::{canvas, draw_axes, draw_legend, framed, line_key, plot_error};
use anyhow::{anyhow, bail, Context, Result};
use plotters::prelude::*;
use std::path::Path;

/// One curve: its CSV column, legend, whether it is an oracle (drawn dashed in its condition's
/// colour) and its (time s, value) points.
pub(super) struct Curve {
    column: String,
    legend: String,
    oracle: bool,
    color_index: usize,
    points: Vec<(f64, f64)>,
}

/// Reads `column` of each condition's montecarlo.csv (and its oracle's when `oracle`) into
/// `<name>.csv` (time_s, then one column per curve; an oracle's is `<condition>_true_poses`) and
/// `<name>.png`; the curves, for [`oracle_table`].
pub(super) fn curves(
    out: &Path,
    conditions: &[Condition],
    column: &str,
    name: &str,
    (y_label, caption): (&str, &str),
    oracle: bool,
) -> Result<Vec<Curve>> {
    let mut series = Vec::new();
    for (index, (condition, _, _, legend)) in conditions.iter().enumerate() {
        series.push(Curve {
            column: condition.to_string(),
            legend: legend.to_string(),
            oracle: false,
            color_index: index,
            points: read_column(&trials_dir(out, condition), column)?,
        });
        if oracle {
            series.push(Curve {
                column: oracle_column(condition),
                legend: format!("{legend}, true poses (dashed)"),
                oracle: true,
                color_index: index,
                points: read_column(&oracle_dir(out, condition), column)?,
            });
        }
    }
    let mut writer = csv::Writer::from_path(out.join(format!("{name}.csv")))?;
    let mut header = vec!["time_s".to_owned()];
    header.extend(series.iter().map(|c| c.column.clone()));
    writer.write_record(&header)?;
    let steps = series.iter().map(|c| c.points.len()).min().unwrap_or(0);
    for step in 0..steps {
        let mut row = vec![series[0].points[step].0.to_string()];
        row.extend(series.iter().map(|c| c.points[step].1.to_string()));
        writer.write_record(&row)?;
    }
    writer.flush()?;
    plot(&out.join(format!("{name}.png")), &series, y_label, caption)?;
    Ok(series)
}

/// The CSV column of `condition`'s oracle.
fn oracle_column(condition: &str) -> String {
    format!("{condition}_true_poses")
}

/// (time s, `column`) of `dir`/montecarlo.csv.
fn read_column(dir: &Path, column: &str) -> Result<Vec<(f64, f64)>> {
    let path = dir.join("montecarlo.csv");
    let mut reader = csv::Reader::from_path(&path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let headers = reader.headers()?.clone();
    let index = |h: &str| {
        headers
            .iter()
            .position(|x| x == h)
            .ok_or_else(|| anyhow!("{}: no column {h}", path.display()))
    };
    let (time, value) = (index("time_s")?, index(column)?);
    let mut points = Vec::new();
    for record in reader.records() {
        let record = record?;
        let parse = |i: usize| {
            record
                .get(i)
                .and_then(|t| t.parse::<f64>().ok())
                .ok_or_else(|| anyhow!("{}: bad number", path.display()))
        };
        points.push((parse(time)?, parse(value)?));
    }
    Ok(points)
}

fn plot(path: &Path, series: &[Curve], y_label: &str, caption: &str) -> Result<()> {
    let root = canvas(path, (1000, 640))?;
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|c| c.points.iter().copied())
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .collect();
    let t_max = all.iter().map(|p| p.0).fold(1.0, f64::max);
    let v_max = all.iter().map(|p| p.1).fold(1e-9, f64::max) * 1.1;
    let mut chart = framed(&root, caption, 22, 12, (40, 60))
        .build_cartesian_2d(0.0..t_max, 0.0..v_max)
        .map_err(plot_error)?;
    draw_axes(&mut chart, "time (s)", y_label, true)?;
    for curve in series {
        let color = Palette99::pick(curve.color_index).to_rgba();
        let points = curve.points.iter().copied();
        let drawn = if curve.oracle {
            chart.draw_series(DashedLineSeries::new(points, 6, 5, color.stroke_width(2)))
        } else {
            chart.draw_series(LineSeries::new(points, color.stroke_width(2)))
        };
        let key = color.stroke_width(if curve.oracle { 1 } else { 2 });
        drawn
            .map_err(plot_error)?
            .label(curve.legend.as_str())
            .legend(line_key(key));
    }
    draw_legend(&mut chart, SeriesLabelPosition::MiddleRight)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// One condition's final mean ET-GOPSA through the back end and at the true poses.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct OracleRow {
    pub condition: &'static str,
    pub slam: f64,
    pub true_poses: f64,
}

impl OracleRow {
    /// SLAM over the oracle: what the back end costs (near 1: little; over few trials a ratio
    /// of means can fall below 1 by chance).
    pub fn ratio(&self) -> f64 {
        self.slam / self.true_poses
    }
}

/// `oracle.csv` (condition, final ET-GOPSA of SLAM and of the oracle, their ratio) in `out`,
/// from the last step of each condition's curve and its oracle's in `fig6` (the curves
/// [`curves`] drew with the oracles); the rows, for the terminal.
pub(super) fn oracle_table(
    out: &Path,
    conditions: &[Condition],
    fig6: &[Curve],
) -> Result<Vec<OracleRow>> {
    let last = |column: &str| -> Result<f64> {
        let curve = fig6.iter().find(|c| c.column == column);
        match curve.and_then(|c| c.points.last()) {
            Some(&(_, value)) => Ok(value),
            None => bail!("Fig. 6 has no step of {column}"),
        }
    };
    let mut rows = Vec::new();
    for &(condition, _, _, _) in conditions {
        rows.push(OracleRow {
            condition,
            slam: last(condition)?,
            true_poses: last(&oracle_column(condition))?,
        });
    }
    let path = out.join("oracle.csv");
    let mut writer = csv::Writer::from_path(&path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    writer.write_record([
        "condition",
        "final_etgospa",
        "final_etgospa_true_poses",
        "ratio",
    ])?;
    for row in &rows {
        writer.write_record([
            row.condition.to_owned(),
            row.slam.to_string(),
            row.true_poses.to_string(),
            row.ratio().to_string(),
        ])?;
    }
    writer.flush()?;
    Ok(rows)
}
