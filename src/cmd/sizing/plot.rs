//! `frontier.png`: one panel per estimator (and per SNR, symbols, spacing and loop closure when
//! the study varies them), bandwidth across and antennas up, each cell coloured by its
//! configuration's outcome; the cheapest met cell of each panel is framed and the paper's Table I
//! point ringed.

use super::frontier::Row;
use super::space::paper;
use crate::plot::{canvas, plot_error};
use anyhow::Result;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

const MET: RGBColor = RGBColor(120, 190, 120);
const NOT_MET: RGBColor = RGBColor(225, 120, 110);
const UNDECIDED: RGBColor = RGBColor(240, 210, 100);
const SCREENED: RGBColor = RGBColor(190, 190, 190);

const CELL_W: i32 = 62;
const CELL_H: i32 = 34;
const LEFT: i32 = 70;
const TOP: i32 = 46;
const BOTTOM: i32 = 56;
const GAP: i32 = 24;

/// What a panel groups by: everything but bandwidth and antennas.
fn panel_key(row: &Row) -> String {
    let c = &row.config;
    format!(
        "{}, {} dB, M = {}, Δf {} kHz, loop closure {}",
        c.estimator,
        c.snr_db,
        c.symbols,
        c.subcarrier_spacing_khz,
        if c.loop_closure { "on" } else { "off" }
    )
}

fn colour(row: &Row) -> RGBColor {
    match row.status() {
        "met" => MET,
        "not met" => NOT_MET,
        "undecided" => UNDECIDED,
        _ => SCREENED,
    }
}

/// Draws `rows` to `path`.
pub fn write_png(path: &Path, rows: &[Row]) -> Result<()> {
    let mut bandwidths: Vec<f64> = rows.iter().map(|r| r.config.bandwidth_mhz()).collect();
    bandwidths.sort_by(f64::total_cmp);
    bandwidths.dedup();
    let mut antennas: Vec<usize> = rows.iter().map(|r| r.config.antennas).collect();
    antennas.sort_unstable();
    antennas.dedup();
    let mut panels: Vec<String> = Vec::new();
    for row in rows {
        let key = panel_key(row);
        if !panels.contains(&key) {
            panels.push(key);
        }
    }
    let columns = (panels.len() as f64).sqrt().ceil().max(1.0) as i32;
    let panel_rows = (panels.len() as i32 + columns - 1) / columns;
    let panel_w = LEFT + CELL_W * bandwidths.len() as i32 + GAP;
    let panel_h = TOP + CELL_H * antennas.len() as i32 + BOTTOM;
    let size = (
        (panel_w * columns + 20).max(760) as u32,
        (panel_h * panel_rows + 90) as u32,
    );
    let root = canvas(path, size)?;
    let text = |size: i32| ("sans-serif", size).into_font().color(&BLACK);
    let centred = Pos::new(HPos::Center, VPos::Center);
    let paper_id = paper().id();
    for (p, key) in panels.iter().enumerate() {
        let x0 = 10 + (p as i32 % columns) * panel_w;
        let y0 = 10 + (p as i32 / columns) * panel_h;
        root.draw(&Text::new(key.clone(), (x0 + LEFT, y0 + 8), text(15)))
            .map_err(plot_error)?;
        let in_panel: Vec<&Row> = rows.iter().filter(|r| panel_key(r) == *key).collect();
        let cheapest = super::frontier::cheapest(in_panel.iter().copied()).map(|r| r.config.id());
        let cell = |b: f64, k: usize| {
            let i = bandwidths.iter().position(|x| *x == b).unwrap_or(0) as i32;
            let j = antennas.iter().position(|x| *x == k).unwrap_or(0) as i32;
            let x = x0 + LEFT + i * CELL_W;
            let y = y0 + TOP + (antennas.len() as i32 - 1 - j) * CELL_H;
            (x, y)
        };
        for row in &in_panel {
            let (x, y) = cell(row.config.bandwidth_mhz(), row.config.antennas);
            root.draw(&Rectangle::new(
                [(x + 1, y + 1), (x + CELL_W - 1, y + CELL_H - 1)],
                colour(row).filled(),
            ))
            .map_err(plot_error)?;
            if let Some(d) = &row.decision {
                root.draw(&Text::new(
                    format!("{}", d.trials),
                    (x + CELL_W / 2, y + CELL_H / 2),
                    text(11).pos(centred),
                ))
                .map_err(plot_error)?;
            }
            if cheapest.as_deref() == Some(row.config.id().as_str()) {
                root.draw(&Rectangle::new(
                    [(x + 2, y + 2), (x + CELL_W - 2, y + CELL_H - 2)],
                    BLACK.stroke_width(3),
                ))
                .map_err(plot_error)?;
            }
            if row.config.id() == paper_id {
                root.draw(&Circle::new(
                    (x + CELL_W / 2, y + CELL_H / 2),
                    CELL_H / 2 - 3,
                    BLUE.stroke_width(2),
                ))
                .map_err(plot_error)?;
            }
        }
        for (i, b) in bandwidths.iter().enumerate() {
            let x = x0 + LEFT + i as i32 * CELL_W + CELL_W / 2;
            let y = y0 + TOP + antennas.len() as i32 * CELL_H + 12;
            let label = format!("{}", (b * 10.0).round() / 10.0);
            root.draw(&Text::new(label, (x, y), text(12).pos(centred)))
                .map_err(plot_error)?;
        }
        let label_y = y0 + TOP + antennas.len() as i32 * CELL_H + 32;
        root.draw(&Text::new(
            "bandwidth (MHz)",
            (x0 + LEFT + CELL_W * bandwidths.len() as i32 / 2, label_y),
            text(13).pos(centred),
        ))
        .map_err(plot_error)?;
        for (j, k) in antennas.iter().enumerate() {
            let y = y0 + TOP + (antennas.len() as i32 - 1 - j as i32) * CELL_H + CELL_H / 2;
            root.draw(&Text::new(
                format!("K = {k}"),
                (x0 + LEFT - 8, y),
                text(12).pos(Pos::new(HPos::Right, VPos::Center)),
            ))
            .map_err(plot_error)?;
        }
    }
    // The legend, along the bottom.
    let y = size.1 as i32 - 40;
    let mut x = 20;
    for (label, fill) in [
        ("met", MET),
        ("not met", NOT_MET),
        ("undecided (budget spent)", UNDECIDED),
        ("screened out (closed-form bound)", SCREENED),
    ] {
        root.draw(&Rectangle::new([(x, y), (x + 18, y + 18)], fill.filled()))
            .map_err(plot_error)?;
        root.draw(&Text::new(label, (x + 24, y + 2), text(13)))
            .map_err(plot_error)?;
        x += 34 + 8 * label.len() as i32;
    }
    let note = "number: trials spent; black frame: cheapest met in the panel; blue ring: the paper's Table I point";
    root.draw(&Text::new(note, (20, y + 22), text(12)))
        .map_err(plot_error)?;
    root.present().map_err(plot_error)?;
    Ok(())
}
