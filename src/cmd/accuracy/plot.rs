//! accuracy.png: RMSE, Cramér–Rao bound and grid limit against SNR, range and angle panels.

use super::Row;
use crate::plot::{canvas, draw_axes, draw_legend, framed, line_key, plot_error};
use anyhow::Result;
use plotters::prelude::*;

/// Reads one quantity of a row.
type Column = fn(&Row) -> f64;

pub(super) fn plot(
    path: &std::path::Path,
    rows: &[Row],
    fidelity: &str,
    refine: &str,
) -> Result<()> {
    let root = canvas(path, (1200, 520))?;
    let panels = root.split_evenly((1, 2));
    let snr_lo = rows.first().map_or(0.0, |r| r.snr_db);
    let snr_hi = rows.last().map_or(1.0, |r| r.snr_db).max(snr_lo + 1.0);
    let series: [(&str, [Column; 3]); 2] = [
        (
            "range (m)",
            [|r| r.range_rmse_m, |r| r.range_crb_m, |r| r.range_grid_m],
        ),
        (
            "angle (deg)",
            [
                |r| r.angle_rmse_deg,
                |r| r.angle_crb_deg,
                |r| r.angle_grid_deg,
            ],
        ),
    ];
    for (panel, (label, getters)) in panels.iter().zip(series) {
        let values: Vec<f64> = rows
            .iter()
            .flat_map(|r| getters.iter().map(move |g| g(r)))
            .filter(|v| v.is_finite() && *v > 0.0)
            .collect();
        let lo = values
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)
            .max(1e-12)
            / 2.0;
        let hi = values.iter().copied().fold(0.0, f64::max).max(lo * 10.0) * 2.0;
        let caption = format!("{label} error, {fidelity}, refine {refine}");
        let mut chart = framed(panel, caption, 20, 12, (40, 70))
            .build_cartesian_2d(snr_lo..snr_hi, (lo..hi).log_scale())
            .map_err(plot_error)?;
        draw_axes(
            &mut chart,
            "per-element SNR (dB)",
            format!("RMSE {label}"),
            true,
        )?;
        for (index, (name, color)) in [
            ("RMSE", RED),
            ("Cramér–Rao bound", BLUE),
            ("grid limit bin/√12", BLACK),
        ]
        .into_iter()
        .enumerate()
        {
            let getter = getters[index];
            let points: Vec<(f64, f64)> = rows
                .iter()
                .map(|r| (r.snr_db, getter(r)))
                .filter(|(_, v)| v.is_finite() && *v > 0.0)
                .collect();
            chart
                .draw_series(LineSeries::new(points, color.stroke_width(2)))
                .map_err(plot_error)?
                .label(name)
                .legend(line_key(color.stroke_width(2)));
        }
        draw_legend(&mut chart, SeriesLabelPosition::MiddleRight)?;
    }
    root.present().map_err(plot_error)?;
    Ok(())
}
