//! `pareto.png`: final ET-GOPSA against time per radar frame (log scale), one colour per knob,
//! the Pareto front's settings drawn larger and joined by a line.

use super::knobs::KNOBS;
use super::table::Row;
use crate::plot::{canvas, draw_axes, draw_legend, framed, line_key, plot_error};
use anyhow::Result;
use plotters::prelude::*;
use std::path::Path;

/// Draws the rows with a finite, positive time per frame and a finite ET-GOPSA (the `trials`
/// knob's rows, which share the baseline's time per frame, are left out) into `path`.
pub(super) fn write_pareto_png(path: &Path, rows: &[Row]) -> Result<()> {
    let points: Vec<&Row> = rows
        .iter()
        .filter(|r| {
            r.setting.knob != "trials"
                && r.time_per_frame_ms.is_finite()
                && r.time_per_frame_ms > 0.0
                && r.final_etgospa.is_finite()
        })
        .collect();
    let root = canvas(path, (1100, 700))?;
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
    let caption = "Speed against accuracy: one knob at a time from the paper-5g baseline";
    let mut chart = framed(&root, caption, 22, 14, (44, 64))
        .build_cartesian_2d((t_min..t_max).log_scale(), 0.0..e_max)
        .map_err(plot_error)?;
    draw_axes(
        &mut chart,
        "time per radar frame, whole graph (ms, log scale)",
        "final ET-GOPSA (mean over trials)",
        true,
    )?;
    let mut front: Vec<(f64, f64)> = points
        .iter()
        .filter(|r| r.pareto)
        .map(|r| (r.time_per_frame_ms, r.final_etgospa))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    chart
        .draw_series(LineSeries::new(front, BLACK.mix(0.5).stroke_width(2)))
        .map_err(plot_error)?
        .label("Pareto front")
        .legend(line_key(BLACK.mix(0.5).stroke_width(2)));
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
            .map_err(plot_error)?
            .label(knob)
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    }
    draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(plot_error)?;
    Ok(())
}
