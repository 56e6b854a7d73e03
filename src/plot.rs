//! PNG figures: the occupancy map with truth outlines and both AGV paths (the paper's Fig. 3/5
//! left panels), and the DBSCAN segments (their right panels).

use crate::report::Reporter;
use anyhow::{anyhow, Result};
use plotters::coord::ranged1d::ValueFormatter;
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

static FONT: Once = Once::new();

/// Registers the embedded DejaVu Sans as plotters' sans-serif (no system fonts needed).
pub fn register_font() {
    FONT.call_once(|| {
        let bytes: &'static [u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, bytes);
    });
}

/// Why a figure could not be drawn, for `map_err` on any plotters call.
pub(crate) fn plot_error(error: impl std::fmt::Display) -> anyhow::Error {
    anyhow!("plotting failed: {error}")
}

/// A white canvas of `size_px` that writes a PNG to `path`, the embedded font registered.
pub(crate) fn canvas(
    path: &Path,
    size_px: (u32, u32),
) -> Result<DrawingArea<BitMapBackend<'_>, Shift>> {
    register_font();
    let root = BitMapBackend::new(path, size_px).into_drawing_area();
    root.fill(&WHITE).map_err(plot_error)?;
    Ok(root)
}

/// The frame every figure draws its chart in: a sans-serif caption of `caption_px`, a margin of
/// `margin_px` and label areas of `label_px` (x axis, y axis).
pub(crate) fn framed<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    caption: impl AsRef<str>,
    caption_px: u32,
    margin_px: u32,
    label_px: (u32, u32),
) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(caption, ("sans-serif", caption_px))
        .margin(margin_px)
        .x_label_area_size(label_px.0)
        .y_label_area_size(label_px.1);
    builder
}

/// Axes described by `x_desc` and `y_desc`; `grid` draws the mesh lines as well.
pub(crate) fn draw_axes<DB, X, Y, XT, YT>(
    chart: &mut ChartContext<'_, DB, Cartesian2d<X, Y>>,
    x_desc: impl Into<String>,
    y_desc: impl Into<String>,
    grid: bool,
) -> Result<()>
where
    DB: DrawingBackend,
    X: Ranged<ValueType = XT> + ValueFormatter<XT>,
    Y: Ranged<ValueType = YT> + ValueFormatter<YT>,
{
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_desc).y_desc(y_desc);
    if !grid {
        mesh.disable_mesh();
    }
    mesh.draw().map_err(plot_error)
}

/// The legend box (translucent white, black border) at `position`.
pub(crate) fn draw_legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    position: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(plot_error)
}

/// A legend key for a line series: a 20-pixel stroke in `style`.
pub(crate) fn line_key(style: ShapeStyle) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new([(x, y), (x + 20, y)], style)
}

/// Bounds of everything drawn: targets and paths, with a margin (m).
fn bounds(report: &Reporter) -> (std::ops::Range<f64>, std::ops::Range<f64>) {
    let mut xs: Vec<f64> = report
        .true_path
        .iter()
        .chain(&report.slam_path)
        .map(|p| p.0)
        .collect();
    let mut ys: Vec<f64> = report
        .true_path
        .iter()
        .chain(&report.slam_path)
        .map(|p| p.1)
        .collect();
    if let Some(targets) = &report.targets {
        for point in targets.targets.iter().flat_map(|t| &t.outline) {
            xs.push(point.x);
            ys.push(point.y);
        }
    }
    // Occupied cells too: a bag of a real sensor has no truth, and its walls lie far from the path.
    if let Some(grid) = &report.map {
        let (x0, y0, yaw) = grid.info.origin.planar();
        let (sin, cos) = yaw.sin_cos();
        let resolution = f64::from(grid.info.resolution);
        let width = (grid.info.width as usize).max(1);
        for (index, _) in grid.data.iter().enumerate().filter(|(_, &v)| v >= 65) {
            let u = ((index % width) as f64 + 0.5) * resolution;
            let v = ((index / width) as f64 + 0.5) * resolution;
            xs.push(x0 + cos * u - sin * v);
            ys.push(y0 + sin * u + cos * v);
        }
    }
    let range = |values: &[f64]| {
        let lo = values
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(f64::INFINITY, f64::min);
        let hi = values
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(f64::NEG_INFINITY, f64::max);
        if lo.is_finite() && hi.is_finite() {
            (lo - 2.0)..(hi + 2.0)
        } else {
            0.0..1.0
        }
    };
    (range(&xs), range(&ys))
}

const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(127, 127, 127),
];

/// A chart over map coordinates (x m, y m), as `map.png` and `segments.png` draw.
type MapChart<'a, DB> = ChartContext<
    'a,
    DB,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

fn draw_outlines<DB: DrawingBackend>(
    chart: &mut MapChart<'_, DB>,
    report: &Reporter,
    color: RGBColor,
) -> Result<()> {
    let Some(targets) = &report.targets else {
        return Ok(());
    };
    for (index, target) in targets.targets.iter().enumerate() {
        let mut points: Vec<(f64, f64)> = target.outline.iter().map(|p| (p.x, p.y)).collect();
        if let Some(first) = points.first().copied() {
            points.push(first);
        }
        let series = chart
            .draw_series(LineSeries::new(points, color.stroke_width(2)))
            .map_err(plot_error)?;
        if index == 0 {
            series
                .label("true outlines")
                .legend(line_key(color.stroke_width(2)));
        }
    }
    Ok(())
}

/// `map.png`: grid (free white, occupied black, unknown grey), truth outlines, true path (green,
/// dashed), SLAM path as published (red), the final keyframe path (orange) and the loop edges.
pub fn map_png(path: &Path, report: &Reporter) -> Result<()> {
    let root = canvas(path, (1100, 850))?;
    let (x_range, y_range) = bounds(report);
    let mut chart = framed(
        &root,
        "Occupancy map, truth outlines, AGV paths",
        24,
        12,
        (40, 50),
    )
    .build_cartesian_2d(x_range.clone(), y_range.clone())
    .map_err(plot_error)?;
    draw_axes(&mut chart, "x (m)", "y (m)", false)?;
    chart
        .draw_series(std::iter::once(Rectangle::new(
            [(x_range.start, y_range.start), (x_range.end, y_range.end)],
            RGBColor(205, 205, 205).filled(),
        )))
        .map_err(plot_error)?;
    if let Some(grid) = &report.map {
        let resolution = grid.info.resolution as f64;
        let (origin_x, origin_y, _) = grid.info.origin.planar();
        let width = grid.info.width as usize;
        let cells =
            grid.data
                .iter()
                .enumerate()
                .filter(|(_, v)| **v >= 0)
                .map(|(index, &value)| {
                    let (column, row) = (index % width, index / width);
                    let x = origin_x + column as f64 * resolution;
                    let y = origin_y + row as f64 * resolution;
                    let shade = (255.0 * (1.0 - value as f64 / 100.0)).round() as u8;
                    Rectangle::new(
                        [(x, y), (x + resolution, y + resolution)],
                        RGBColor(shade, shade, shade).filled(),
                    )
                });
        chart.draw_series(cells).map_err(plot_error)?;
    }
    draw_outlines(&mut chart, report, RGBColor(31, 119, 180))?;
    let green = RGBColor(0, 150, 0);
    chart
        .draw_series(DashedLineSeries::new(
            report.true_path.iter().copied(),
            8,
            5,
            green.stroke_width(2),
        ))
        .map_err(plot_error)?
        .label("true AGV path")
        .legend(line_key(green.stroke_width(2)));
    chart
        .draw_series(LineSeries::new(
            report.slam_path.iter().copied(),
            RED.stroke_width(2),
        ))
        .map_err(plot_error)?
        .label("SLAM AGV path")
        .legend(line_key(RED.stroke_width(2)));
    draw_keyframes_and_loops(&mut chart, report)?;
    draw_legend(&mut chart, SeriesLabelPosition::MiddleRight)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// The back end's final keyframe path (every loop closure applied, the last
/// `/slam/keyframe_poses`), where the published path above shows each pose as it was first
/// published, and its loop edges between the keyframes they join: those off by more than
/// [`crate::report::LOOP_EDGE_WRONG_M`] against the truth drawn apart, so a wrong closure shows
/// where it happened.
fn draw_keyframes_and_loops<DB: DrawingBackend>(
    chart: &mut MapChart<'_, DB>,
    report: &Reporter,
) -> Result<()> {
    let Some(keyframes) = &report.keyframe_poses else {
        return Ok(());
    };
    let at: std::collections::HashMap<u32, (f64, f64)> = keyframes
        .ids
        .iter()
        .zip(&keyframes.poses)
        .map(|(id, pose)| (*id, (pose.position.x, pose.position.y)))
        .filter(|(_, (x, y))| x.is_finite() && y.is_finite())
        .collect();
    let mut path: Vec<(u32, (f64, f64))> = at.iter().map(|(id, p)| (*id, *p)).collect();
    path.sort_by_key(|(id, _)| *id);
    let orange = RGBColor(255, 140, 0);
    chart
        .draw_series(LineSeries::new(
            path.into_iter().map(|(_, p)| p),
            orange.stroke_width(1),
        ))
        .map_err(plot_error)?
        .label("SLAM keyframes, final")
        .legend(line_key(orange.stroke_width(2)));
    let wrong: std::collections::HashSet<(u32, u32)> = report
        .scored_loop_edges()
        .iter()
        .filter(|e| e.error_m > crate::report::LOOP_EDGE_WRONG_M)
        .map(|e| (e.from, e.to))
        .collect();
    // (older keyframe's position, newer's, off by more than the limit)
    type Drawn = ((f64, f64), (f64, f64), bool);
    let edges: Vec<Drawn> = keyframes
        .loop_from_ids
        .iter()
        .zip(&keyframes.loop_to_ids)
        .filter_map(|(from, to)| {
            Some((*at.get(from)?, *at.get(to)?, wrong.contains(&(*from, *to))))
        })
        .collect();
    let purple = RGBColor(120, 60, 200);
    let magenta = RGBColor(230, 0, 180);
    let wrong_label = format!(
        "loop edges > {} m off the truth",
        crate::report::LOOP_EDGE_WRONG_M
    );
    for (is_wrong, color, width, label) in [
        (false, purple, 1, "loop edges".to_owned()),
        (true, magenta, 3, wrong_label),
    ] {
        let mine: Vec<_> = edges.iter().filter(|e| e.2 == is_wrong).collect();
        if mine.is_empty() {
            continue;
        }
        chart
            .draw_series(
                mine.iter()
                    .map(|(a, b, _)| PathElement::new(vec![*a, *b], color.stroke_width(width))),
            )
            .map_err(plot_error)?
            .label(label)
            .legend(line_key(color.stroke_width(width)));
    }
    Ok(())
}

/// `segments.png`: occupied cells coloured by DBSCAN cluster (noise grey), truth outlines.
pub fn segments_png(path: &Path, report: &Reporter) -> Result<()> {
    let root = canvas(path, (1100, 850))?;
    let (x_range, y_range) = bounds(report);
    let clusters = report.segments.as_ref().map_or(0, |s| s.cluster_count);
    let caption = format!("DBSCAN segments: {clusters} clusters");
    let mut chart = framed(&root, caption, 24, 12, (40, 50))
        .build_cartesian_2d(x_range, y_range)
        .map_err(plot_error)?;
    draw_axes(&mut chart, "x (m)", "y (m)", true)?;
    if let Some(segments) = &report.segments {
        let points = segments
            .points
            .iter()
            .zip(&segments.labels)
            .map(|(p, &label)| {
                let (color, size) = if label < 0 {
                    (RGBColor(170, 170, 170), 1)
                } else {
                    (PALETTE[label as usize % PALETTE.len()], 2)
                };
                Circle::new((p.x, p.y), size, color.filled())
            });
        chart.draw_series(points).map_err(plot_error)?;
    }
    draw_outlines(&mut chart, report, RGBColor(0, 0, 0))?;
    draw_legend(&mut chart, SeriesLabelPosition::MiddleRight)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// `shapes.png`: the fitted shapes (`/map/targets`: rectangles orange, circles blue, each with the
/// 2σ ellipse of its centre and its sample points) over the segmented cells (grey) and the truth
/// outlines (black).
pub fn shapes_png(path: &Path, report: &Reporter) -> Result<()> {
    let root = canvas(path, (1100, 850))?;
    let (x_range, y_range) = bounds(report);
    let shapes = report
        .map_targets
        .as_ref()
        .map_or(&[][..], |t| &t.targets[..]);
    let circles = shapes.iter().filter(|t| t.shape == "circle").count();
    let caption = format!(
        "Fitted shapes: {} rectangles, {circles} circles",
        shapes.len() - circles
    );
    let mut chart = framed(&root, caption, 24, 12, (40, 50))
        .build_cartesian_2d(x_range, y_range)
        .map_err(plot_error)?;
    draw_axes(&mut chart, "x (m)", "y (m)", true)?;
    if let Some(segments) = &report.segments {
        let cells = segments
            .points
            .iter()
            .zip(&segments.labels)
            .filter(|(_, &label)| label >= 0)
            .map(|(p, _)| Circle::new((p.x, p.y), 1, RGBColor(170, 170, 170).filled()));
        chart.draw_series(cells).map_err(plot_error)?;
    }
    draw_outlines(&mut chart, report, RGBColor(0, 0, 0))?;
    let (orange, blue) = (RGBColor(255, 127, 14), RGBColor(31, 119, 180));
    for (index, shape) in shapes.iter().enumerate() {
        let color = if shape.shape == "circle" {
            blue
        } else {
            orange
        };
        let mut outline: Vec<(f64, f64)> = shape.outline.iter().map(|p| (p.x, p.y)).collect();
        outline.extend(outline.first().copied());
        let series = chart
            .draw_series(LineSeries::new(outline, color.stroke_width(2)))
            .map_err(plot_error)?;
        if index == 0 {
            series
                .label("fitted shapes")
                .legend(line_key(orange.stroke_width(2)));
        }
        let ellipse = centre_ellipse_2sigma(shape);
        chart
            .draw_series(LineSeries::new(ellipse, color.stroke_width(1)))
            .map_err(plot_error)?;
        chart
            .draw_series(
                shape
                    .samples
                    .iter()
                    .map(|p| Circle::new((p.x, p.y), 3, color.filled())),
            )
            .map_err(plot_error)?;
    }
    draw_legend(&mut chart, SeriesLabelPosition::MiddleRight)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// The 2σ ellipse of a fitted shape's centre (its covariance's upper-left 2 × 2 block), as a
/// closed 48-gon; a single point when the covariance is missing or not positive semi-definite.
fn centre_ellipse_2sigma(shape: &nrslam_msgs::MapTarget) -> Vec<(f64, f64)> {
    let centre = (shape.center_x_m, shape.center_y_m);
    let Some(fitted) = nrslam_shapes::node::shape_from_message(shape) else {
        return vec![centre];
    };
    let (major, minor, axis) =
        nrslam_association::loop_closure::symmetric_eigen_2x2(&fitted.center_covariance());
    if !(minor >= 0.0 && major.is_finite()) {
        return vec![centre];
    }
    let angle = axis[1].atan2(axis[0]);
    let (sin, cos) = angle.sin_cos();
    (0..=48)
        .map(|k| {
            let phi = std::f64::consts::TAU * f64::from(k) / 48.0;
            let (u, v) = (
                2.0 * major.sqrt() * phi.cos(),
                2.0 * minor.sqrt() * phi.sin(),
            );
            (centre.0 + cos * u - sin * v, centre.1 + sin * u + cos * v)
        })
        .collect()
}
