//! `pareto.png`: final ET-GOPSA against time per radar frame (log scale), one colour per knob,
//! each setting with its ± standard error, the Pareto front's settings drawn larger and joined by
//! a line. Settings crowd near the baseline, so each label goes where it overlaps no earlier label
//! or point, or is left out (the Pareto front's first): `tradeoff.csv` names every point.

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
    // The Pareto front's settings claim their label places first, then the baseline.
    let mut ordered = points.clone();
    ordered.sort_by_key(|r| (!r.pareto, r.setting.knob != "baseline"));
    let at_px: Vec<(i32, i32)> = ordered
        .iter()
        .map(|r| chart.backend_coord(&(r.time_per_frame_ms, r.final_etgospa)))
        .collect();
    let widths_px: Vec<i32> = ordered
        .iter()
        .map(|r| label_width_px(&r.setting.label))
        .collect();
    let (x_px, y_px) = chart.plotting_area().get_pixel_range();
    let inside = (x_px.start, y_px.start, x_px.end, y_px.end);
    let offsets = place_labels(&at_px, &widths_px, inside);
    for (index, knob) in std::iter::once("baseline").chain(KNOBS).enumerate() {
        let color = Palette99::pick(index).to_rgba();
        let mine: Vec<(&Row, Option<(i32, i32)>)> = ordered
            .iter()
            .zip(&offsets)
            .filter(|(r, _)| r.setting.knob == knob)
            .map(|(r, offset)| (*r, *offset))
            .collect();
        if mine.is_empty() {
            continue;
        }
        chart
            .draw_series(mine.iter().filter_map(|(r, _)| {
                let sem = r.final_etgospa_sem;
                (sem.is_finite() && sem > 0.0).then(|| {
                    let t = r.time_per_frame_ms;
                    PathElement::new(
                        vec![(t, r.final_etgospa - sem), (t, r.final_etgospa + sem)],
                        color.stroke_width(2),
                    )
                })
            }))
            .map_err(plot_error)?;
        chart
            .draw_series(mine.iter().map(|(r, offset)| {
                let at = (r.time_per_frame_ms, r.final_etgospa);
                let label = offset.map_or(String::new(), |_| r.setting.label.clone());
                // A label set apart from its point gets a leader line to it.
                let leader = offset
                    .map(|o| leader_px(o, label_width_px(&r.setting.label)))
                    .filter(|&(x, y)| x * x + y * y > LEADER_MIN_PX * LEADER_MIN_PX)
                    .map_or_else(Vec::new, |end| vec![(0, 0), end]);
                EmptyElement::at(at)
                    + PathElement::new(leader, BLACK.mix(0.4))
                    + Circle::new((0, 0), if r.pareto { 7 } else { 5 }, color.filled())
                    + Text::new(label, offset.unwrap_or((0, 0)), ("sans-serif", LABEL_PX))
            }))
            .map_err(plot_error)?
            .label(knob)
            .legend(move |(x, y)| Circle::new((x + 10, y), 5, color.filled()));
    }
    draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present().map_err(plot_error)?;
    Ok(())
}

/// Height of a label's text (px).
const LABEL_PX: i32 = 13;

/// Half the side of the box a label keeps clear around each point (px): the largest marker's
/// radius.
const MARKER_PX: i32 = 7;

/// Labels farther than this from their point (px) get a leader line.
const LEADER_MIN_PX: i32 = 12;

/// The point of a label's box (top-left corner `offset` from its point, `width_px` wide)
/// nearest its point, relative to the point (px): where its leader line ends.
fn leader_px(offset: (i32, i32), width_px: i32) -> (i32, i32) {
    (
        0.clamp(offset.0, offset.0 + width_px),
        0.clamp(offset.1, offset.1 + LABEL_PX),
    )
}

/// A box in pixels: left, top, right, bottom.
type Rect = (i32, i32, i32, i32);

/// The box of a label `width_px` wide whose top-left corner is `offset` from the point `at`.
fn label_box(at: (i32, i32), offset: (i32, i32), width_px: i32) -> Rect {
    let (x, y) = (at.0 + offset.0, at.1 + offset.1);
    (x, y, x + width_px, y + LABEL_PX)
}

/// Whether two boxes share any area.
fn overlaps(a: &Rect, b: &Rect) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// The box a label keeps clear around a point's marker.
fn marker_box((x, y): (i32, i32)) -> Rect {
    (x - MARKER_PX, y - MARKER_PX, x + MARKER_PX, y + MARKER_PX)
}

/// A label's width (px), from its length: the plots' sans-serif averages about 6 px a character
/// at [`LABEL_PX`] (19 characters measured 112 px).
fn label_width_px(label: &str) -> i32 {
    6 * label.chars().count() as i32
}

/// Where each point's label goes, as an offset of its top-left corner from the point (px), in
/// order: the first of a few places around the point whose box lies within `inside` (left, top,
/// right, bottom; px) and overlaps no earlier label and no point's marker, or `None` (the label
/// is left out).
fn place_labels(at_px: &[(i32, i32)], widths_px: &[i32], inside: Rect) -> Vec<Option<(i32, i32)>> {
    let markers: Vec<Rect> = at_px.iter().copied().map(marker_box).collect();
    let mut taken: Vec<Rect> = Vec::new();
    at_px
        .iter()
        .zip(widths_px)
        .map(|(&(x, y), &width)| {
            let places = [
                (9, -LABEL_PX - 2),
                (9, 2),
                (-9 - width, -LABEL_PX - 2),
                (-9 - width, 2),
                (-width / 2, -LABEL_PX - 10),
                (-width / 2, 10),
                (9, -2 * LABEL_PX - 6),
                (9, LABEL_PX + 6),
                (-9 - width, -2 * LABEL_PX - 6),
                (-9 - width, LABEL_PX + 6),
            ];
            let (free, label) = places.into_iter().find_map(|offset| {
                let label = label_box((x, y), offset, width);
                let within = inside.0 <= label.0
                    && inside.1 <= label.1
                    && label.2 <= inside.2
                    && label.3 <= inside.3;
                (within && !taken.iter().chain(&markers).any(|b| overlaps(&label, b)))
                    .then_some((offset, label))
            })?;
            taken.push(label);
            Some(free)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The label boxes `offsets` puts at the points `at_px`: none overlaps another or any
    /// point's marker.
    fn assert_clear(at_px: &[(i32, i32)], widths_px: &[i32], offsets: &[Option<(i32, i32)>]) {
        let boxes: Vec<Rect> = at_px
            .iter()
            .zip(offsets)
            .zip(widths_px)
            .filter_map(|((&at, offset), &w)| offset.map(|o| label_box(at, o, w)))
            .collect();
        for (i, a) in boxes.iter().enumerate() {
            for b in &boxes[i + 1..] {
                assert!(!overlaps(a, b), "{a:?} overlaps {b:?}");
            }
            for &at in at_px {
                let marker = marker_box(at);
                assert!(!overlaps(a, &marker), "{a:?} covers the marker at {at:?}");
            }
        }
    }

    #[test]
    fn labels_of_crowded_points_do_not_overlap_and_a_lone_point_keeps_its_label() {
        let at_px = [(100, 100), (102, 101), (104, 99), (106, 100), (400, 300)];
        let widths_px = [70; 5];
        let page = (0, 0, 1000, 1000);
        let offsets = place_labels(&at_px, &widths_px, page);
        assert_eq!(
            offsets[4],
            Some((9, -LABEL_PX - 2)),
            "a point far from the others is labelled at the first place"
        );
        assert!(offsets[0].is_some(), "the first of a crowd is labelled");
        assert_clear(&at_px, &widths_px, &offsets);
        // More points at one place than there are places around it.
        let crowd_px = [(50, 50); 16];
        let crowd = place_labels(&crowd_px, &[70; 16], page);
        let labelled = crowd.iter().flatten().count();
        assert!(
            (1..16).contains(&labelled),
            "sixteen points at one place: {labelled} labelled"
        );
        assert_clear(&crowd_px, &[70; 16], &crowd);
        // A leader line ends on the label's box, at its point nearest the point.
        assert_eq!(leader_px((9, -15), 70), (9, -2));
        assert_eq!(leader_px((-79, 20), 70), (-9, 20));
        assert_eq!(leader_px((-35, -23), 70), (0, -10));
        // A point at the right edge is labelled to its left.
        let edge = place_labels(&[(980, 500)], &[70], page);
        assert_eq!(edge, vec![Some((-9 - 70, -LABEL_PX - 2))]);
    }
}
