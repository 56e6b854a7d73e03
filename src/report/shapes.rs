//! The `shapes` record of `summary.json`: the map's fitted shapes (`/map/targets`) against the
//! true targets, and the final ET-GOPSA of the same map with each choice of representatives.
//!
//! Fitted shapes are paired with true targets one-to-one on centre distance, within
//! [`MATCH_GATE_M`] ([`nrslam_shapes::match_to_truth`]); each pair is scored by
//! [`nrslam_shapes::evaluate`] (IoU with the true outline, centre, size and yaw errors, kind,
//! centre NEES). The three ET-GOPSA values take the final segments (`box-corners`,
//! `farthest-point`) or the final shapes (`shape`) against the true targets with the run's
//! evaluator parameters, so a run compares the representatives on one and the same map.

use super::Reporter;
use anyhow::{Context, Result};
use nrslam_evaluator::{
    etgospa, extended_targets, segment_representatives, shape_samples, RepresentativeMode,
};
use nrslam_shapes::node::{shape_from_message, truth_from_target};
use serde::Serialize;

/// Fitted shapes farther than this from every true target's centre are not matched (m): half
/// the paper's ET-GOPSA cut-off c = 5 m, beyond which ET-GOPSA counts an estimate as false.
pub const MATCH_GATE_M: f64 = 2.5;

/// Shapes against the truth, at the end of the run.
#[derive(Debug, Serialize, PartialEq)]
pub struct ShapeSummary {
    /// Shapes in the last `/map/targets`.
    pub fitted: u32,
    /// Of those, rectangles.
    pub rectangles: u32,
    /// Of those, circles.
    pub circles: u32,
    /// True targets.
    pub true_targets: u32,
    /// Fitted shapes paired with a true target.
    pub matched: u32,
    /// Mean IoU of the matched shapes with their true outlines.
    pub mean_iou: Option<f64>,
    /// Mean centre error of the matched shapes (m).
    pub mean_center_error_m: Option<f64>,
    /// Mean size error (m): the distance between (width, height) fitted and true, in the pairing
    /// of sides closest in yaw.
    pub mean_size_error_m: Option<f64>,
    /// Mean yaw error over matched rectangles fitted as rectangles (degrees, modulo 90°).
    pub mean_yaw_error_deg: Option<f64>,
    /// Matched shapes of the right kind (rectangle or circle).
    pub kind_correct: u32,
    /// Mean normalised estimation error squared of the centres under their published
    /// covariance (2 if the covariance is honest).
    pub mean_center_nees: Option<f64>,
    /// Final ET-GOPSA with the segments' principal-axis box corners as representatives.
    pub etgospa_box_corners: Option<f64>,
    /// Final ET-GOPSA with farthest-point samples of the segments.
    pub etgospa_farthest_point: Option<f64>,
    /// Final ET-GOPSA with the fitted shapes' samples.
    pub etgospa_shape: Option<f64>,
}

fn mean(values: &[f64]) -> Option<f64> {
    (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
}

/// One fitted shape of the final map and, if matched, its true target and errors.
struct ScoredShape {
    /// Track id.
    id: u32,
    fitted: nrslam_shapes::FittedShape,
    /// Index of the true target and the true shape, when matched.
    truth: Option<(usize, nrslam_shapes::TruthShape)>,
    errors: Option<nrslam_shapes::ShapeErrors>,
}

impl Reporter {
    /// Every fitted shape of the last `/map/targets` (those whose message is well formed),
    /// matched to the true targets; and the number of true targets.
    fn scored_shapes(&self) -> Option<(Vec<ScoredShape>, usize)> {
        let shapes = self.map_targets.as_ref()?;
        let fitted: Vec<_> = shapes
            .targets
            .iter()
            .filter_map(|t| Some((t.id, shape_from_message(t)?)))
            .collect();
        let truth: Vec<_> = self
            .targets
            .iter()
            .flat_map(|set| &set.targets)
            .filter_map(truth_from_target)
            .collect();
        let pairs = nrslam_shapes::match_to_truth(
            &fitted.iter().map(|(_, f)| f.center_m).collect::<Vec<_>>(),
            &truth.iter().map(|t| t.center_m).collect::<Vec<_>>(),
            MATCH_GATE_M,
        );
        let scored = fitted
            .into_iter()
            .enumerate()
            .map(|(index, (id, fitted))| {
                let truth = pairs
                    .iter()
                    .find(|(f, _)| *f == index)
                    .map(|&(_, t)| (t, truth[t].clone()));
                let errors = truth
                    .as_ref()
                    .map(|(_, t)| nrslam_shapes::evaluate(&fitted, t));
                ScoredShape {
                    id,
                    fitted,
                    truth,
                    errors,
                }
            })
            .collect();
        Some((scored, truth.len()))
    }

    /// `shapes.csv`: one row per fitted shape of the final map, with its true target and errors
    /// when matched (empty cells otherwise).
    pub fn write_shapes_csv(&self, path: &std::path::Path) -> Result<()> {
        let Some((scored, _)) = self.scored_shapes() else {
            return Ok(());
        };
        let mut writer = csv::Writer::from_path(path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        writer.write_record([
            "id",
            "kind",
            "center_x_m",
            "center_y_m",
            "width_m",
            "height_m",
            "yaw_rad",
            "radius_m",
            "sides_seen",
            "support",
            "rms_residual_m",
            "center_std_x_m",
            "center_std_y_m",
            "true_target",
            "true_kind",
            "true_width_m",
            "true_height_m",
            "true_radius_m",
            "iou",
            "center_error_m",
            "size_error_m",
            "yaw_error_deg",
            "center_nees",
        ])?;
        let kind = |k: nrslam_shapes::ShapeKind| match k {
            nrslam_shapes::ShapeKind::Rectangle => "rectangle",
            nrslam_shapes::ShapeKind::Circle => "circle",
        };
        let optional = |v: Option<f64>| v.map_or_else(String::new, |v| v.to_string());
        for s in &scored {
            let f = &s.fitted;
            let c = f.center_covariance();
            let e = s.errors.as_ref();
            writer.write_record([
                s.id.to_string(),
                kind(f.kind).to_owned(),
                f.center_m[0].to_string(),
                f.center_m[1].to_string(),
                f.size_m[0].to_string(),
                f.size_m[1].to_string(),
                f.yaw_rad.to_string(),
                f.radius_m.to_string(),
                f.sides_seen.to_string(),
                f.support.to_string(),
                f.rms_residual_m.to_string(),
                c[0][0].sqrt().to_string(),
                c[1][1].sqrt().to_string(),
                s.truth
                    .as_ref()
                    .map_or_else(String::new, |(t, _)| t.to_string()),
                s.truth
                    .as_ref()
                    .map_or_else(String::new, |(_, t)| kind(t.kind).to_owned()),
                optional(s.truth.as_ref().map(|(_, t)| t.size_m[0])),
                optional(s.truth.as_ref().map(|(_, t)| t.size_m[1])),
                optional(s.truth.as_ref().map(|(_, t)| t.radius_m)),
                optional(e.map(|e| e.iou)),
                optional(e.map(|e| e.center_error_m)),
                optional(e.map(|e| e.size_error_m)),
                optional(e.and_then(|e| e.yaw_error_rad.map(f64::to_degrees))),
                optional(e.map(|e| e.center_nees)),
            ])?;
        }
        writer.flush()?;
        Ok(())
    }

    /// The shape record; `None` when the run published no `/map/targets`.
    pub fn shape_summary(&self) -> Option<ShapeSummary> {
        let shapes = self.map_targets.as_ref()?;
        let (scored, true_targets) = self.scored_shapes()?;
        let errors: Vec<_> = scored.iter().filter_map(|s| s.errors.clone()).collect();
        let of = |get: fn(&nrslam_shapes::ShapeErrors) -> Option<f64>| {
            mean(&errors.iter().filter_map(get).collect::<Vec<_>>())
        };
        let circles = shapes
            .targets
            .iter()
            .filter(|t| t.shape == "circle")
            .count();
        let count = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
        Some(ShapeSummary {
            fitted: count(shapes.targets.len()),
            rectangles: count(shapes.targets.len() - circles),
            circles: count(circles),
            true_targets: count(true_targets),
            matched: count(errors.len()),
            mean_iou: of(|e| Some(e.iou)),
            mean_center_error_m: of(|e| Some(e.center_error_m)),
            mean_size_error_m: of(|e| Some(e.size_error_m)),
            mean_yaw_error_deg: of(|e| e.yaw_error_rad.map(f64::to_degrees)),
            kind_correct: count(errors.iter().filter(|e| e.kind_correct).count()),
            mean_center_nees: of(|e| e.center_nees.is_finite().then_some(e.center_nees)),
            etgospa_box_corners: self.final_etgospa(Some(RepresentativeMode::BoxCorners)),
            etgospa_farthest_point: self.final_etgospa(Some(RepresentativeMode::FarthestPoint)),
            etgospa_shape: self.final_etgospa(None),
        })
    }

    /// Final ET-GOPSA of the true targets against the representatives of the last segments
    /// (`Some(mode)`) or the samples of the last shapes (`None`), with the run's evaluator
    /// parameters; `None` if either input is missing or cannot be scored.
    fn final_etgospa(&self, mode: Option<RepresentativeMode>) -> Option<f64> {
        let targets = extended_targets(self.targets.as_ref()?);
        let estimates = match mode {
            Some(mode) => {
                let k = self.evaluator.points_per_estimate as usize;
                let clusters = segment_representatives(self.segments.as_ref()?, k, mode).ok()?;
                nrslam_evaluator::flatten(&clusters)
            }
            None => shape_samples(self.map_targets.as_ref()?),
        };
        etgospa(&targets, &estimates, &self.evaluator.metric_params())
            .ok()
            .map(|r| r.total)
    }
}
