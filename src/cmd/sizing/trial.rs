//! One trial's summary: the per-trial metrics a requirement can name, from the evaluator's
//! per-frame rows (ET-GOPSA, GOSPA, AGV position error).

use crate::cmd::montecarlo::TrialRows;
use serde::{Deserialize, Serialize};

/// A per-trial metric. A requirement bounds its mean over trials.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Metric {
    /// The 95th percentile (nearest rank) of the AGV position error over the trial's frames (m).
    PositionErrorP95M,
    /// The root mean square of the AGV position error over the trial's frames (m).
    PositionErrorRmseM,
    /// The largest AGV position error of the trial (m).
    PositionErrorMaxM,
    /// ET-GOPSA of the map at the last frame.
    FinalEtgospa,
    /// ET-GOPSA averaged over the trial's frames.
    MeanEtgospa,
}

/// Every metric, in `trials/*.csv` column order.
pub const METRICS: [Metric; 5] = [
    Metric::PositionErrorP95M,
    Metric::PositionErrorRmseM,
    Metric::PositionErrorMaxM,
    Metric::FinalEtgospa,
    Metric::MeanEtgospa,
];

impl Metric {
    /// The name in requirement files and CSV headers.
    pub fn name(self) -> &'static str {
        match self {
            Metric::PositionErrorP95M => "position_error_p95_m",
            Metric::PositionErrorRmseM => "position_error_rmse_m",
            Metric::PositionErrorMaxM => "position_error_max_m",
            Metric::FinalEtgospa => "final_etgospa",
            Metric::MeanEtgospa => "mean_etgospa",
        }
    }

    /// Whether the metric measures the AGV's position (else the map).
    pub fn is_position(self) -> bool {
        matches!(
            self,
            Metric::PositionErrorP95M | Metric::PositionErrorRmseM | Metric::PositionErrorMaxM
        )
    }
}

/// Every metric of one trial, in [`METRICS`] order. A trial without a single evaluated frame
/// has NaN for each (and is refused by the caller).
pub fn summarise(rows: &TrialRows) -> [f64; 5] {
    let mut errors: Vec<f64> = rows.iter().map(|r| r.1[2]).collect();
    let n = errors.len();
    if n == 0 {
        return [f64::NAN; 5];
    }
    errors.sort_by(f64::total_cmp);
    // Nearest rank: the smallest error at or above which lie 95 % of the frames.
    let p95 = errors[((0.95 * n as f64).ceil() as usize).clamp(1, n) - 1];
    let rmse = (errors.iter().map(|e| e * e).sum::<f64>() / n as f64).sqrt();
    let max = errors[n - 1];
    let final_etgospa = rows[n - 1].1[0];
    let mean_etgospa = rows.iter().map(|r| r.1[0]).sum::<f64>() / n as f64;
    [p95, rmse, max, final_etgospa, mean_etgospa]
}

/// The value of `metric` in a [`summarise`] array.
pub fn value(summary: &[f64; 5], metric: Metric) -> f64 {
    summary[METRICS.iter().position(|m| *m == metric).unwrap_or(0)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(errors: &[f64]) -> TrialRows {
        errors
            .iter()
            .enumerate()
            .map(|(i, &e)| (i as f64, [10.0 + i as f64, 0.0, e, 1.0]))
            .collect()
    }

    #[test]
    fn the_95th_percentile_is_the_nearest_rank() {
        // 20 frames: rank ceil(19) = 19, the second largest.
        let errors: Vec<f64> = (1..=20).map(f64::from).collect();
        let s = summarise(&rows(&errors));
        assert_eq!(value(&s, Metric::PositionErrorP95M), 19.0);
        assert_eq!(value(&s, Metric::PositionErrorMaxM), 20.0);
        // One frame: its own error.
        assert_eq!(
            value(&summarise(&rows(&[0.3])), Metric::PositionErrorP95M),
            0.3
        );
    }

    #[test]
    fn final_and_mean_etgospa_read_the_first_column() {
        let s = summarise(&rows(&[0.0, 0.0, 0.0]));
        assert_eq!(value(&s, Metric::FinalEtgospa), 12.0);
        assert_eq!(value(&s, Metric::MeanEtgospa), 11.0);
    }

    #[test]
    fn an_empty_trial_is_nan() {
        assert!(summarise(&Vec::new()).iter().all(|v| v.is_nan()));
    }
}
