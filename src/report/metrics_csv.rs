//! `metrics.csv`: one row per metrics step.

use super::Reporter;
use anyhow::{Context, Result};
use std::path::Path;

impl Reporter {
    /// Writes `metrics.csv`.
    pub fn write_metrics_csv(&self, path: &Path) -> Result<()> {
        let mut writer = csv::Writer::from_path(path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        writer.write_record([
            "step",
            "time_s",
            "etgospa",
            "etgospa_localisation",
            "etgospa_confusion",
            "etgospa_missed",
            "etgospa_false",
            "gospa",
            "gospa_localisation",
            "gospa_missed",
            "gospa_false",
            "position_error_m",
            "estimated_targets",
            "estimate_points",
        ])?;
        for (step, m) in self.metrics.iter().enumerate() {
            writer.write_record([
                step.to_string(),
                m.header.stamp.as_seconds().to_string(),
                m.etgospa.to_string(),
                m.etgospa_localisation.to_string(),
                m.etgospa_confusion.to_string(),
                m.etgospa_missed.to_string(),
                m.etgospa_false.to_string(),
                m.gospa.to_string(),
                m.gospa_localisation.to_string(),
                m.gospa_missed.to_string(),
                m.gospa_false.to_string(),
                m.position_error_m.to_string(),
                m.estimated_targets.to_string(),
                m.estimate_points.to_string(),
            ])?;
        }
        writer
            .flush()
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(())
    }
}
