//! `pareto.png`: final ET-GOPSA against time per radar frame (log scale), one colour per knob,
//! the Pareto front's settings drawn larger and joined by a line.

use super::knobs::KNOBS;
use super::table::Row;
use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;

/// Draws the rows with a finite, positive time per frame and a finite ET-GOPSA (the `trials`
/// knob's rows, which share the baseline's time per frame, are left out) into `path`.
pub(super) fn write_pareto_png(path: &Path, rows: &[Row]) -> Result<()> {
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
