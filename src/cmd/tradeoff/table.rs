//! The results table: trials summarised into one row per setting, the Pareto flags, and the
//! row's two renderings, `tradeoff.csv` and the summary lines on standard output.

use super::knobs::{Setting, TRIAL_COUNTS};
use anyhow::{Context, Result};
use std::path::Path;

/// Per-trial results of one setting.
#[derive(Debug, Clone, Copy)]
pub(super) struct Trial {
    pub(super) seconds: f64,
    pub(super) frames: u64,
    pub(super) final_etgospa: f64,
    pub(super) pose_rmse_m: f64,
}

/// One row of tradeoff.csv.
#[derive(Debug, Clone)]
pub(super) struct Row {
    pub(super) setting: Setting,
    pub(super) trials: usize,
    pub(super) frames: u64,
    pub(super) time_per_frame_ms: f64,
    pub(super) time_per_trial_s: f64,
    pub(super) range_rmse_m: f64,
    pub(super) angle_rmse_deg: f64,
    pub(super) final_etgospa: f64,
    pub(super) final_etgospa_sem: f64,
    pub(super) pose_rmse_m: f64,
    pub(super) pareto: bool,
}

/// Mean, standard error of the mean (NaN below two values) and count.
fn mean(values: impl Iterator<Item = f64>) -> (f64, f64, usize) {
    let values: Vec<f64> = values.collect();
    let n = values.len();
    if n == 0 {
        return (f64::NAN, f64::NAN, 0);
    }
    let m = values.iter().sum::<f64>() / n as f64;
    let sem = if n > 1 {
        (values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1) as f64 / n as f64).sqrt()
    } else {
        f64::NAN
    };
    (m, sem, n)
}

/// The row of one setting from its trials and its sensing errors (range m, angle °).
pub(super) fn row(setting: Setting, trials: &[Trial], sensing: (f64, f64)) -> Row {
    let seconds: f64 = trials.iter().map(|t| t.seconds).sum();
    let frames: u64 = trials.iter().map(|t| t.frames).sum();
    let (final_etgospa, final_etgospa_sem, n) = mean(trials.iter().map(|t| t.final_etgospa));
    Row {
        setting,
        trials: n,
        frames: frames / n.max(1) as u64,
        time_per_frame_ms: 1e3 * seconds / frames.max(1) as f64,
        time_per_trial_s: seconds / n.max(1) as f64,
        range_rmse_m: sensing.0,
        angle_rmse_deg: sensing.1,
        final_etgospa,
        final_etgospa_sem,
        pose_rmse_m: mean(trials.iter().map(|t| t.pose_rmse_m)).0,
        pareto: false,
    }
}

/// The `trials` knob's rows: the first n of the baseline's runs for every n of
/// [`TRIAL_COUNTS`], each timed as a whole study of n trials.
pub(super) fn trials_knob_rows(
    baseline: &Setting,
    baseline_runs: &[Trial],
    errors: (f64, f64),
) -> Vec<Row> {
    TRIAL_COUNTS
        .iter()
        .map(|&n| {
            let mut r = row(
                Setting {
                    knob: "trials",
                    label: format!("{n} trials"),
                    ..baseline.clone()
                },
                &baseline_runs[..n.min(baseline_runs.len())],
                errors,
            );
            // A study's cost: n trials at the baseline's mean time per trial.
            r.time_per_trial_s = n as f64 * mean(baseline_runs.iter().map(|t| t.seconds)).0;
            r
        })
        .collect()
}

/// Marks the rows no other row beats on both time per frame and final ET-GOPSA (the `trials`
/// knob's rows share the baseline's per-frame time and are left out).
pub(super) fn mark_pareto(rows: &mut [Row]) {
    let on_axes = |r: &Row| {
        r.setting.knob != "trials" && r.time_per_frame_ms.is_finite() && r.final_etgospa.is_finite()
    };
    let candidates: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| on_axes(r))
        .map(|r| (r.time_per_frame_ms, r.final_etgospa))
        .collect();
    for r in rows.iter_mut() {
        let (t, e) = (r.time_per_frame_ms, r.final_etgospa);
        r.pareto = on_axes(r)
            && !candidates
                .iter()
                .any(|&(t2, e2)| t2 <= t && e2 <= e && (t2 < t || e2 < e));
    }
}

/// tradeoff.csv's columns.
pub const COLUMNS: [&str; 21] = [
    "knob",
    "setting",
    "fidelity",
    "subcarriers",
    "subcarrier_spacing_hz",
    "symbols",
    "antennas",
    "refinement",
    "resolution_m",
    "scatterer_spacing_m",
    "trials",
    "frames",
    "time_per_frame_ms",
    "time_per_trial_s",
    "range_rmse_m",
    "angle_rmse_deg",
    "final_etgospa",
    "final_etgospa_sem",
    "pose_rmse_m",
    "pareto",
    "time_per_study_s",
];

/// Writes tradeoff.csv: a header of [`COLUMNS`], then one record per row.
pub(super) fn write_csv(path: &Path, rows: &[Row]) -> Result<()> {
    let mut writer =
        csv::Writer::from_path(path).with_context(|| format!("cannot write {}", path.display()))?;
    writer.write_record(COLUMNS)?;
    for r in rows {
        let s = &r.setting;
        let study_s = if s.knob == "trials" {
            r.time_per_trial_s
        } else {
            r.time_per_trial_s * r.trials as f64
        };
        writer.write_record([
            s.knob.to_string(),
            s.label.clone(),
            s.fidelity.to_string(),
            s.subcarriers.to_string(),
            s.subcarrier_spacing_hz.to_string(),
            s.symbols.to_string(),
            s.antennas.to_string(),
            s.refinement.to_string(),
            s.resolution_m.to_string(),
            s.scatterer_spacing_m.to_string(),
            r.trials.to_string(),
            r.frames.to_string(),
            r.time_per_frame_ms.to_string(),
            r.time_per_trial_s.to_string(),
            r.range_rmse_m.to_string(),
            r.angle_rmse_deg.to_string(),
            r.final_etgospa.to_string(),
            r.final_etgospa_sem.to_string(),
            r.pose_rmse_m.to_string(),
            r.pareto.to_string(),
            study_s.to_string(),
        ])?;
    }
    writer.flush()?;
    Ok(())
}

/// Prints one line per row on standard output.
pub(super) fn print_rows(rows: &[Row]) {
    for r in rows {
        outln!(
            "{:<10} {:<24} {:>9.3} ms/frame {:>8.2} s/trial  range {:.4} m  angle {:.2}°  ET-GOPSA {:>6.1} ± {:<5.1} pose RMSE {:.2} m{}",
            r.setting.knob,
            r.setting.label,
            r.time_per_frame_ms,
            r.time_per_trial_s,
            r.range_rmse_m,
            r.angle_rmse_deg,
            r.final_etgospa,
            r.final_etgospa_sem,
            r.pose_rmse_m,
            if r.pareto { "  (Pareto)" } else { "" }
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(knob: &'static str, time_ms: f64, etgospa: f64) -> Row {
        Row {
            setting: Setting {
                knob,
                ..Setting::baseline()
            },
            trials: 1,
            frames: 1,
            time_per_frame_ms: time_ms,
            time_per_trial_s: time_ms,
            range_rmse_m: 0.0,
            angle_rmse_deg: 0.0,
            final_etgospa: etgospa,
            final_etgospa_sem: 0.0,
            pose_rmse_m: 0.0,
            pareto: false,
        }
    }

    #[test]
    fn pareto_keeps_exactly_the_undominated_rows() {
        let mut rows = vec![
            at("baseline", 1.0, 50.0),
            at("stride", 0.5, 60.0),
            at("stride", 2.0, 55.0), // dominated by the baseline
            at("refinement", 1.5, 40.0),
            at("fidelity", 1.0, 50.0), // equal to the baseline: neither dominates
            at("trials", 0.1, 1.0),    // another axis: never on the front
            at("density", f64::NAN, 10.0),
        ];
        mark_pareto(&mut rows);
        let flags: Vec<bool> = rows.iter().map(|r| r.pareto).collect();
        assert_eq!(flags, [true, true, false, true, true, false, false]);
    }

    #[test]
    fn the_standard_error_shrinks_as_one_over_root_n() {
        let (m, sem, n) = mean([1.0, 3.0].into_iter());
        assert_eq!((m, n), (2.0, 2));
        // sample std √2, over √2
        assert!((sem - 1.0).abs() < 1e-12);
        assert!(mean(std::iter::once(4.0)).1.is_nan());
    }
}
