//! The study's answer: one row per configuration (`frontier.csv`), the cheapest configurations
//! that meet the requirement, per estimator and overall, and the verdict on the paper's own
//! configuration (`sizing.md` and standard output). Computed from the kept trials alone, so an
//! interrupted and resumed study writes the same bytes as an uninterrupted one.

use super::requirement::Requirement;
use super::screen::Verdict;
use super::sequential::{decide, Decision, Status};
use super::space::{paper, Config};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::Path;

/// A configuration's outcome.
#[derive(Debug, Clone)]
pub struct Row {
    pub config: Config,
    pub cost: f64,
    pub verdict: Verdict,
    /// `None` when the screen dropped it and it was not simulated.
    pub decision: Option<Decision>,
}

impl Row {
    /// met, not met, undecided, or screened (dropped by the screen, not simulated).
    pub fn status(&self) -> &'static str {
        match &self.decision {
            Some(d) => d.status.name(),
            None => "screened",
        }
    }

    pub fn met(&self) -> bool {
        matches!(&self.decision, Some(d) if d.status == Status::Met)
    }
}

/// The rows of every configuration from its kept trials.
pub fn rows(
    requirement: &Requirement,
    configs: &[Config],
    verdicts: &[Verdict],
    trials: &[Option<Vec<[f64; 5]>>],
) -> Vec<Row> {
    configs
        .iter()
        .zip(verdicts)
        .zip(trials)
        .map(|((config, verdict), trials)| Row {
            config: config.clone(),
            cost: config.cost(requirement),
            verdict: verdict.clone(),
            decision: trials
                .as_ref()
                .map(|t| decide(&requirement.requirements, &requirement.trials, t)),
        })
        .collect()
}

/// Writes `frontier.csv`: every configuration, its cost, bounds, screen, trials and per
/// requirement the mean with its one-sided confidence bounds and status.
pub fn write_csv(path: &Path, requirement: &Requirement, rows: &[Row]) -> Result<()> {
    let mut writer =
        csv::Writer::from_path(path).with_context(|| format!("cannot write {}", path.display()))?;
    let mut header: Vec<String> = [
        "config",
        "estimator",
        "bandwidth_mhz",
        "subcarriers",
        "subcarrier_spacing_khz",
        "antennas",
        "snr_db",
        "symbols",
        "loop_closure",
        "cost",
        "range_floor_m",
        "angle_floor_deg",
        "range_resolution_m",
        "angle_resolution_deg",
        "peak_snr_db",
        "screen",
        "trials",
    ]
    .map(str::to_owned)
    .to_vec();
    for r in &requirement.requirements {
        let name = r.metric.name();
        header.extend([
            format!("{name}_mean"),
            format!("{name}_low"),
            format!("{name}_high"),
            format!("{name}_status"),
        ]);
    }
    header.push("status".to_owned());
    writer.write_record(&header)?;
    for row in rows {
        let c = &row.config;
        let b = &row.verdict.bounds;
        let mut record = vec![
            c.id(),
            c.estimator.clone(),
            c.bandwidth_mhz().to_string(),
            c.subcarriers.to_string(),
            c.subcarrier_spacing_khz.to_string(),
            c.antennas.to_string(),
            c.snr_db.to_string(),
            c.symbols.to_string(),
            c.loop_closure.to_string(),
            row.cost.to_string(),
            b.range_floor_m.to_string(),
            b.angle_floor_deg.to_string(),
            b.range_resolution_m.to_string(),
            b.angle_resolution_deg.to_string(),
            b.peak_snr_db.to_string(),
            row.verdict
                .drop
                .clone()
                .map_or_else(|| "keep".to_owned(), |why| format!("drop: {why}")),
        ];
        match &row.decision {
            Some(d) => {
                record.push(d.trials.to_string());
                for e in &d.estimates {
                    record.extend([
                        e.mean.to_string(),
                        e.low.to_string(),
                        e.high.to_string(),
                        e.status.name().to_owned(),
                    ]);
                }
            }
            None => {
                record.push("0".to_owned());
                for _ in &requirement.requirements {
                    record.extend(["", "", "", ""].map(str::to_owned));
                }
            }
        }
        record.push(row.status().to_owned());
        writer.write_record(&record)?;
    }
    writer.flush()?;
    Ok(())
}

/// The cheapest met configuration among `rows` (ties: the first in study order).
pub fn cheapest<'a>(rows: impl Iterator<Item = &'a Row>) -> Option<&'a Row> {
    rows.filter(|r| r.met())
        .fold(None, |best: Option<&Row>, r| match best {
            Some(b) if b.cost <= r.cost => Some(b),
            _ => Some(r),
        })
}

/// The answer in words: the paper's verdict, the cheapest per estimator and overall, counts.
pub fn summary(requirement: &Requirement, rows: &[Row]) -> String {
    let mut text = String::new();
    let needs: Vec<String> = requirement
        .requirements
        .iter()
        .map(|r| {
            format!(
                "mean {} ≤ {} at {} % confidence",
                r.metric.name(),
                r.threshold,
                r.confidence * 100.0
            )
        })
        .collect();
    let _ = writeln!(text, "Requirement: {}.", needs.join(" and "));
    let count = |status: &str| rows.iter().filter(|r| r.status() == status).count();
    let trials: u32 = rows
        .iter()
        .filter_map(|r| r.decision.as_ref().map(|d| d.trials))
        .sum();
    let _ = writeln!(
        text,
        "{} configurations: {} met, {} not met, {} undecided, {} screened out; {trials} trials.",
        rows.len(),
        count("met"),
        count("not met"),
        count("undecided"),
        count("screened")
    );
    let paper_id = paper().id();
    if let Some(row) = rows.iter().find(|r| r.config.id() == paper_id) {
        let _ = writeln!(
            text,
            "The paper's configuration ({}): {}{}.",
            describe(&row.config),
            row.status(),
            estimates(requirement, row)
        );
    }
    let mut estimators: Vec<&str> = Vec::new();
    for row in rows {
        if !estimators.contains(&row.config.estimator.as_str()) {
            estimators.push(&row.config.estimator);
        }
    }
    let _ = writeln!(text, "Cheapest configuration that meets it:");
    for estimator in estimators {
        match cheapest(rows.iter().filter(|r| r.config.estimator == estimator)) {
            Some(row) => {
                let _ = writeln!(
                    text,
                    "  {estimator:<13} {} (cost {}){}",
                    describe(&row.config),
                    row.cost,
                    estimates(requirement, row)
                );
            }
            None => {
                let _ = writeln!(text, "  {estimator:<13} none in the search space");
            }
        }
    }
    if let Some(row) = cheapest(rows.iter()) {
        let _ = writeln!(
            text,
            "  overall       {} with {} (cost {})",
            describe(&row.config),
            row.config.estimator,
            row.cost
        );
    }
    text
}

/// "1228.8 MHz (10240 × 120 kHz), 32 antennas, 10 dB, M = 1, loop closure off".
pub fn describe(c: &Config) -> String {
    format!(
        "{} MHz ({} × {} kHz), {} antennas, {} dB, M = {}, loop closure {}",
        c.bandwidth_label(),
        c.subcarriers,
        c.subcarrier_spacing_khz,
        c.antennas,
        c.snr_db,
        c.symbols,
        if c.loop_closure { "on" } else { "off" }
    )
}

/// ": position_error_p95_m 0.31 [0.27, 0.35], … over N trials", or "" when not simulated.
fn estimates(requirement: &Requirement, row: &Row) -> String {
    let Some(d) = &row.decision else {
        return String::new();
    };
    let parts: Vec<String> = requirement
        .requirements
        .iter()
        .zip(&d.estimates)
        .map(|(r, e)| {
            format!(
                "{} {:.3} [{:.3}, {:.3}]",
                r.metric.name(),
                e.mean,
                e.low,
                e.high
            )
        })
        .collect();
    format!(": {} over {} trials", parts.join(", "), d.trials)
}
