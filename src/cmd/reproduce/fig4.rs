//! Fig. 4: the GOSPA-versus-ET-GOPSA scenario (the paper's eq. GOPSA_10): two extended targets,
//! estimates y1 and y2 equally far from x1, y2 farther from x2.

use crate::plot::{canvas, draw_axes, framed, plot_error};
use anyhow::{anyhow, Result};
use nrslam_evaluator::{etgospa, gospa, EtGospaParams, ExtendedTarget, Point2};
use plotters::prelude::*;
use std::path::Path;

/// Fig. 4: x1 a 2 m square at the origin, x2 the same 4 m to its right; y1 1 m right of x1 (toward
/// x2), y2 1 m left of x1: equally far from x1, y2 farther from x2.
pub(super) fn fig4(out: &Path) -> Result<()> {
    let square = |cx: f64| {
        vec![
            Point2::new(cx - 1.0, -1.0),
            Point2::new(cx + 1.0, -1.0),
            Point2::new(cx + 1.0, 1.0),
            Point2::new(cx - 1.0, 1.0),
        ]
    };
    let (x1, x2) = (square(0.0), square(5.0));
    let (y1, y2) = (Point2::new(2.0, 0.0), Point2::new(-2.0, 0.0));
    let targets = [
        ExtendedTarget::from_samples(x1.clone()),
        ExtendedTarget::from_samples(x2.clone()),
    ];
    let params = EtGospaParams::default();
    let truth: Vec<Point2> = x1.iter().chain(&x2).copied().collect();
    let mut writer = csv::Writer::from_path(out.join("fig4.csv"))?;
    writer.write_record([
        "estimates",
        "gospa",
        "etgospa",
        "etgospa_localisation",
        "etgospa_confusion",
        "etgospa_missed",
        "etgospa_false",
    ])?;
    for (label, estimates) in [
        ("{y1}", vec![y1]),
        ("{y2}", vec![y2]),
        ("{y1,y2}", vec![y1, y2]),
    ] {
        let g = gospa(&truth, &estimates, &params.gospa()).map_err(|e| anyhow!("{e}"))?;
        let e = etgospa(&targets, &estimates, &params).map_err(|e| anyhow!("{e}"))?;
        writer.write_record([
            label.to_owned(),
            g.total.to_string(),
            e.total.to_string(),
            e.localisation.to_string(),
            e.confusion.to_string(),
            e.missed.to_string(),
            e.false_estimates.to_string(),
        ])?;
    }
    writer.flush()?;
    let path = out.join("fig4.png");
    let root = canvas(&path, (800, 420))?;
    let caption = "Fig. 4: extended targets x1, x2 and estimates y1, y2 (values in fig4.csv)";
    let mut chart = framed(&root, caption, 18, 12, (30, 40))
        .build_cartesian_2d(-4.0..8.0, -3.0..3.0)
        .map_err(plot_error)?;
    draw_axes(&mut chart, "x (m)", "y (m)", true)?;
    for (target, name) in [(&x1, "x1"), (&x2, "x2")] {
        let mut ring: Vec<(f64, f64)> = target.iter().map(|p| (p.x_m, p.y_m)).collect();
        ring.push(ring[0]);
        chart
            .draw_series(LineSeries::new(ring, BLUE.stroke_width(2)))
            .map_err(plot_error)?;
        chart
            .draw_series(
                target
                    .iter()
                    .map(|p| Circle::new((p.x_m, p.y_m), 4, BLUE.filled())),
            )
            .map_err(plot_error)?;
        let c = target
            .iter()
            .fold((0.0, 0.0), |a, p| (a.0 + p.x_m / 4.0, a.1 + p.y_m / 4.0));
        chart
            .draw_series(std::iter::once(Text::new(name, c, ("sans-serif", 18))))
            .map_err(plot_error)?;
    }
    for (point, name) in [(y1, "y1"), (y2, "y2")] {
        chart
            .draw_series(std::iter::once(Circle::new(
                (point.x_m, point.y_m),
                6,
                RED.filled(),
            )))
            .map_err(plot_error)?;
        chart
            .draw_series(std::iter::once(Text::new(
                name,
                (point.x_m + 0.2, point.y_m + 0.3),
                ("sans-serif", 18),
            )))
            .map_err(plot_error)?;
    }
    root.present().map_err(plot_error)?;
    Ok(())
}
