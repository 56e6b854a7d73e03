//! The evaluator node: scores the segmented SLAM map and the SLAM pose against ground truth.
//!
//! Inputs, in tie-breaking order: `/ground_truth/targets` (latched, first), `/map/segments`
//! (`/map/targets`, the fitted shapes, with `representatives = "shape"`), `/ground_truth/pose`,
//! `/slam/pose`. It keeps the latest targets, estimates and true pose; on
//! each `/slam/pose` it publishes one [`Metrics`] on `/metrics` with the same stamp:
//! - ET-GOPSA (the targets against the representatives of the latest segments, see
//!   [`crate::representatives()`]) and GOSPA (all target sample points against the same
//!   representatives), with their decompositions; before any segments the estimate set is empty;
//! - `position_error_m`: planar distance between the SLAM position and the latest true position
//!   (docs/design.md "Metrics", pose error; the true pose of the same stamp is delivered first since
//!   `/ground_truth/pose` precedes `/slam/pose` in the input order).
//!
//! The metrics change only when targets or segments do (once per keyframe), while poses come every
//! frame, so the last metric result is cached and reused until one of them changes.
//!
//! **Maps too large to score.** The metrics split their assignment into independent components
//! (the points closer than c to each other) and solve each with a dense assignment of at most
//! [`MAX_CELLS`](crate::assignment::MAX_CELLS) cells (target slots or truth points × estimate
//! points). A map whose estimates would need more in one component is not scored: the evaluator publishes no
//! `/metrics` for those poses, counts them ([`EvaluatorNode::skipped_steps`]) and logs a warning
//! when it starts and stops skipping, so the graph runs on (its other outputs, the map and the
//! poses, are still good) and the run's summary shows fewer metric steps than frames. Any other
//! metric error stops the graph, as before.

use nrslam_msgs::topics::{
    GROUND_TRUTH_POSE, GROUND_TRUTH_TARGETS, MAP_TARGETS, METRICS, SEGMENTS, SLAM_POSE,
};
use nrslam_msgs::{Header, MapTargets, Message, Metrics, PoseStamped, Segments, TargetSet};
use nrslam_runtime::{Node, NodeContext, NodeError, NodeResult, Outbox};

use crate::error::MetricError;
use crate::etgospa::{etgospa, EtGospaParams, EtGospaResult, ExtendedTarget};
use crate::gospa::{gospa, GospaResult};
use crate::params::Params;
use crate::point::Point2;
use crate::representatives::{
    flatten, representatives_with, ClusterRepresentatives, RepresentativeMode,
};

/// The evaluator's state between messages.
#[derive(Debug)]
pub struct EvaluatorNode {
    params: Params,
    metric: EtGospaParams,
    targets: Vec<ExtendedTarget>,
    /// All sample points of all targets: the GOSPA truth set.
    truth_points: Vec<Point2>,
    /// Representatives of the latest segments: the estimate set.
    estimates: Vec<Point2>,
    /// Clusters in the latest segments.
    estimated_targets: u32,
    /// Latest true AGV position (x_m, y_m).
    true_position_m: Option<(f64, f64)>,
    /// Metrics of the current targets and estimates, computed on first need; `Err` when the
    /// inputs are too large to score (the message says the sizes).
    cached: Option<Result<(GospaResult, EtGospaResult), String>>,
    /// `/slam/pose` messages for which no metrics were published (inputs too large to score).
    skipped_steps: u64,
}

/// The representatives of the clusters of a `/map/segments` message (`k` points per cluster for
/// farthest-point sampling): the estimate set the evaluator scores and the viewer draws.
///
/// # Errors
/// [`NodeError`] (invalid input on `/map/segments`) when the labels do not fit the points.
pub fn segment_representatives(
    segments: &Segments,
    k: usize,
    mode: RepresentativeMode,
) -> Result<Vec<ClusterRepresentatives>, NodeError> {
    representatives_with(&planar(&segments.points), &segments.labels, k, mode)
        .map_err(|e| NodeError::invalid_input(SEGMENTS, e.to_string()))
}

/// The true targets of a `/ground_truth/targets` message as the metric takes them: each its
/// sample points (the slots) and its outline.
pub fn extended_targets(set: &TargetSet) -> Vec<ExtendedTarget> {
    set.targets
        .iter()
        .map(|t| ExtendedTarget::from_samples(planar(&t.samples)).with_outline(planar(&t.outline)))
        .collect()
}

/// The sample points of every fitted shape of a `/map/targets` message, in message order: the
/// estimate set with `representatives = "shape"`.
pub fn shape_samples(shapes: &MapTargets) -> Vec<Point2> {
    shapes
        .targets
        .iter()
        .flat_map(|t| planar(&t.samples))
        .collect()
}

fn planar(points: &[nrslam_msgs::Point]) -> Vec<Point2> {
    points.iter().map(|p| Point2::new(p.x, p.y)).collect()
}

/// Builds the evaluator node from validated parameters.
///
/// # Errors
/// [`NodeError::Params`] naming the bad parameter.
pub fn build(params: Params, _ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    Ok(Box::new(EvaluatorNode::new(params)?))
}

impl EvaluatorNode {
    /// A node with no targets, segments or pose yet.
    ///
    /// # Errors
    /// [`NodeError::Params`] naming the bad parameter.
    pub fn new(params: Params) -> Result<Self, NodeError> {
        params.validate()?;
        Ok(Self {
            params,
            metric: params.metric_params(),
            targets: Vec::new(),
            truth_points: Vec::new(),
            estimates: Vec::new(),
            estimated_targets: 0,
            true_position_m: None,
            cached: None,
            skipped_steps: 0,
        })
    }

    /// Poses for which no metrics were published because the map was too large to score (see
    /// the module doc).
    pub fn skipped_steps(&self) -> u64 {
        self.skipped_steps
    }

    /// Both metrics of the current inputs; `Ok(Err(message))` when they are too large to score.
    fn score(&self) -> Result<Result<(GospaResult, EtGospaResult), String>, NodeError> {
        let too_large = |e: &MetricError| e.is_too_large();
        let g = match gospa(&self.truth_points, &self.estimates, &self.metric.gospa()) {
            Ok(g) => g,
            Err(e) if too_large(&e) => return Ok(Err(format!("GOSPA: {e}"))),
            Err(e) => return Err(NodeError::algorithm(e)),
        };
        let e = match etgospa(&self.targets, &self.estimates, &self.metric) {
            Ok(e) => e,
            Err(e) if too_large(&e) => return Ok(Err(format!("ET-GOPSA: {e}"))),
            Err(e) => return Err(NodeError::algorithm(e)),
        };
        Ok(Ok((g, e)))
    }

    fn on_targets(&mut self, set: &TargetSet) -> Result<(), NodeError> {
        let targets = extended_targets(set);
        // Score nothing once now so bad targets (NaN, missing outline) are reported on the topic
        // that carried them, not later on /slam/pose.
        etgospa(&targets, &[], &self.metric)
            .map_err(|e| NodeError::invalid_input(GROUND_TRUTH_TARGETS, e.to_string()))?;
        self.truth_points = targets
            .iter()
            .flat_map(|t| t.samples.iter().copied())
            .collect();
        self.targets = targets;
        self.cached = None;
        Ok(())
    }

    fn on_segments(&mut self, segments: &Segments) -> Result<(), NodeError> {
        let clusters = segment_representatives(
            segments,
            self.params.points_per_estimate as usize,
            self.params.representatives,
        )?;
        self.estimated_targets = u32::try_from(clusters.len())
            .map_err(|_| NodeError::invalid_input(SEGMENTS, "more than u32::MAX clusters"))?;
        self.estimates = flatten(&clusters);
        self.cached = None;
        Ok(())
    }

    /// The fitted shapes' samples are the estimate set (`representatives = "shape"`).
    fn on_map_targets(&mut self, shapes: &MapTargets) -> Result<(), NodeError> {
        self.estimated_targets = u32::try_from(shapes.targets.len())
            .map_err(|_| NodeError::invalid_input(MAP_TARGETS, "more than u32::MAX targets"))?;
        self.estimates = shape_samples(shapes);
        self.cached = None;
        Ok(())
    }

    /// Where the estimate set comes from: the segments, or the fitted shapes.
    fn estimate_topic(&self) -> &'static str {
        match self.params.representatives {
            RepresentativeMode::Shape => MAP_TARGETS,
            RepresentativeMode::BoxCorners | RepresentativeMode::FarthestPoint => SEGMENTS,
        }
    }

    fn on_true_pose(&mut self, pose: &PoseStamped) -> Result<(), NodeError> {
        let (x_m, y_m, _) = pose.pose.planar();
        if !(x_m.is_finite() && y_m.is_finite()) {
            return Err(NodeError::invalid_input(
                GROUND_TRUTH_POSE,
                format!("non-finite position ({x_m}, {y_m})"),
            ));
        }
        self.true_position_m = Some((x_m, y_m));
        Ok(())
    }

    fn on_slam_pose(&mut self, pose: &PoseStamped, outbox: &mut Outbox) -> Result<(), NodeError> {
        let (x_m, y_m, _) = pose.pose.planar();
        if !(x_m.is_finite() && y_m.is_finite()) {
            return Err(NodeError::invalid_input(
                SLAM_POSE,
                format!("non-finite position ({x_m}, {y_m})"),
            ));
        }
        let (true_x_m, true_y_m) = self.true_position_m.ok_or_else(|| {
            NodeError::invalid_input(
                SLAM_POSE,
                format!("no {GROUND_TRUTH_POSE} received before this SLAM pose"),
            )
        })?;
        if self.cached.is_none() {
            let scored = self.score()?;
            match (&scored, self.skipped_steps > 0) {
                (Err(why), _) => tracing::warn!(
                    "evaluator: not scoring the map of {} estimate points from t = {} s on: {why}",
                    self.estimates.len(),
                    pose.header.stamp.as_seconds()
                ),
                (Ok(_), true) => tracing::warn!(
                    "evaluator: scoring again from t = {} s ({} poses unscored so far)",
                    pose.header.stamp.as_seconds(),
                    self.skipped_steps
                ),
                (Ok(_), false) => {}
            }
            self.cached = Some(scored);
        }
        let (g, e) = match &self.cached {
            Some(Ok((g, e))) => (g, e),
            _ => {
                self.skipped_steps += 1;
                return Ok(());
            }
        };
        let estimate_points = u32::try_from(self.estimates.len()).map_err(|_| {
            NodeError::invalid_input(self.estimate_topic(), "more than u32::MAX estimate points")
        })?;
        outbox.publish(
            METRICS,
            Metrics {
                header: Header {
                    stamp: pose.header.stamp,
                    frame_id: "map".to_owned(),
                },
                etgospa: e.total,
                etgospa_localisation: e.localisation,
                etgospa_confusion: e.confusion,
                etgospa_missed: e.missed,
                etgospa_false: e.false_estimates,
                gospa: g.total,
                gospa_localisation: g.localisation,
                gospa_missed: g.missed,
                gospa_false: g.false_estimates,
                position_error_m: (x_m - true_x_m).hypot(y_m - true_y_m),
                estimated_targets: self.estimated_targets,
                estimate_points,
            },
        );
        Ok(())
    }
}

impl Node for EvaluatorNode {
    fn inputs(&self) -> Vec<&'static str> {
        vec![
            GROUND_TRUTH_TARGETS,
            self.estimate_topic(),
            GROUND_TRUTH_POSE,
            SLAM_POSE,
        ]
    }

    fn outputs(&self) -> Vec<&'static str> {
        vec![METRICS]
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        match (topic, message) {
            (GROUND_TRUTH_TARGETS, Message::TargetSet(set)) => self.on_targets(set),
            (SEGMENTS, Message::Segments(segments)) if self.estimate_topic() == SEGMENTS => {
                self.on_segments(segments)
            }
            (MAP_TARGETS, Message::MapTargets(shapes)) if self.estimate_topic() == MAP_TARGETS => {
                self.on_map_targets(shapes)
            }
            (GROUND_TRUTH_POSE, Message::PoseStamped(pose)) => self.on_true_pose(pose),
            (SLAM_POSE, Message::PoseStamped(pose)) => self.on_slam_pose(pose, outbox),
            (topic, message) => Err(NodeError::unexpected(topic, message)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{Point, Pose, Target, Time};

    fn stamped(t_s: f64, x_m: f64, y_m: f64) -> Message {
        Message::PoseStamped(PoseStamped {
            header: Header {
                stamp: Time::from_seconds(t_s),
                frame_id: "map".into(),
            },
            pose: Pose::from_planar(x_m, y_m, 0.3),
        })
    }

    fn square(id: u32, x0: f64) -> Target {
        let corners: Vec<Point> = [(x0, 0.0), (x0 + 2.0, 0.0), (x0 + 2.0, 2.0), (x0, 2.0)]
            .iter()
            .map(|&(x, y)| Point::planar(x, y))
            .collect();
        Target {
            id,
            shape: "rectangle".into(),
            outline: corners.clone(),
            samples: corners,
        }
    }

    fn targets() -> Message {
        Message::TargetSet(TargetSet {
            header: Header::default(),
            targets: vec![square(0, 0.0), square(1, 20.0)],
        })
    }

    fn metrics(outbox: &mut Outbox) -> Vec<Metrics> {
        outbox
            .drain()
            .map(|(topic, m)| {
                assert_eq!(topic, METRICS);
                match m {
                    Message::Metrics(m) => m,
                    other => panic!("published {}", other.type_name()),
                }
            })
            .collect()
    }

    #[test]
    fn publishes_metrics_with_the_slam_pose_stamp() {
        let mut node = EvaluatorNode::new(Params::default()).unwrap();
        assert_eq!(
            node.inputs(),
            vec![GROUND_TRUTH_TARGETS, SEGMENTS, GROUND_TRUTH_POSE, SLAM_POSE]
        );
        assert_eq!(node.outputs(), vec![METRICS]);
        let mut outbox = Outbox::new();
        node.on_message(GROUND_TRUTH_TARGETS, &targets(), &mut outbox)
            .unwrap();
        node.on_message(GROUND_TRUTH_POSE, &stamped(1.0, 1.0, 1.0), &mut outbox)
            .unwrap();
        assert!(outbox.is_empty());
        node.on_message(SLAM_POSE, &stamped(1.0, 4.0, 5.0), &mut outbox)
            .unwrap();
        let m = metrics(&mut outbox);
        assert_eq!(m.len(), 1);
        assert_eq!(m[0].header.stamp, Time::from_seconds(1.0));
        assert!((m[0].position_error_m - 5.0).abs() < 1e-12);
        // No segments yet: every one of the 8 slots is missed, at c/2 = 2.5 each.
        assert_eq!(
            (m[0].etgospa, m[0].etgospa_missed, m[0].gospa),
            (20.0, 20.0, 20.0)
        );
        assert_eq!((m[0].estimated_targets, m[0].estimate_points), (0, 0));

        // Segments: one cluster on target 0's corners (plus an inner point), one noise point.
        let mut points: Vec<Point> = square(0, 0.0).samples;
        points.push(Point::planar(1.0, 1.0));
        points.push(Point::planar(50.0, 50.0));
        let segments = Message::Segments(Segments {
            header: Header::default(),
            eps_m: 0.5,
            min_samples: 4,
            cluster_count: 1,
            points,
            labels: vec![0, 0, 0, 0, 0, -1],
        });
        node.on_message(SEGMENTS, &segments, &mut outbox).unwrap();
        node.on_message(GROUND_TRUTH_POSE, &stamped(2.0, 0.0, 0.0), &mut outbox)
            .unwrap();
        node.on_message(SLAM_POSE, &stamped(2.0, 0.0, 0.0), &mut outbox)
            .unwrap();
        let m = metrics(&mut outbox);
        assert_eq!(m[0].header.stamp, Time::from_seconds(2.0));
        assert_eq!(m[0].position_error_m, 0.0);
        // The 4 representatives are the corners: target 0 fully matched, target 1's 4 slots
        // missed.
        assert_eq!((m[0].estimated_targets, m[0].estimate_points), (1, 4));
        assert_eq!(
            (m[0].etgospa_localisation, m[0].etgospa_missed),
            (0.0, 10.0)
        );
        assert_eq!((m[0].etgospa, m[0].gospa), (10.0, 10.0));
    }

    #[test]
    fn bad_input_is_an_error_naming_the_topic() {
        let mut node = EvaluatorNode::new(Params::default()).unwrap();
        let mut outbox = Outbox::new();
        let e = node
            .on_message(SLAM_POSE, &stamped(1.0, 0.0, 0.0), &mut outbox)
            .unwrap_err();
        assert!(
            e.to_string().contains(SLAM_POSE) && e.to_string().contains(GROUND_TRUTH_POSE),
            "{e}"
        );
        let e = node
            .on_message(SEGMENTS, &stamped(1.0, 0.0, 0.0), &mut outbox)
            .unwrap_err();
        assert!(e.to_string().contains("PoseStamped"), "{e}");
        let mut bad = square(0, 0.0);
        bad.samples[2].y = f64::NAN;
        let set = Message::TargetSet(TargetSet {
            header: Header::default(),
            targets: vec![bad],
        });
        let e = node
            .on_message(GROUND_TRUTH_TARGETS, &set, &mut outbox)
            .unwrap_err();
        assert!(e.to_string().contains(GROUND_TRUTH_TARGETS), "{e}");
        let segments = Message::Segments(Segments {
            points: vec![Point::planar(0.0, 0.0)],
            labels: vec![0, 0],
            ..Segments::default()
        });
        let e = node
            .on_message(SEGMENTS, &segments, &mut outbox)
            .unwrap_err();
        assert!(e.to_string().contains(SEGMENTS), "{e}");
        assert!(outbox.is_empty());
    }

    #[test]
    fn a_map_too_large_to_score_skips_its_steps_instead_of_failing() {
        let mut node = EvaluatorNode::new(Params::default()).unwrap();
        let mut outbox = Outbox::new();
        // One target with 2^20 sample points (slots) along 1 m, and 17 overlapping square
        // clusters: 68 estimates, all within c of each other, so GOSPA's one component has
        // 2^20 × 68 > 2^26 cells.
        let samples: Vec<Point> = (0..1 << 20)
            .map(|k| Point::planar(f64::from(k) * 1e-6, 0.0))
            .collect();
        let big = Message::TargetSet(TargetSet {
            header: Header::default(),
            targets: vec![Target {
                samples,
                ..square(0, 0.0)
            }],
        });
        node.on_message(GROUND_TRUTH_TARGETS, &big, &mut outbox)
            .unwrap();
        let clusters = |count: i32| {
            let mut points = Vec::new();
            let mut labels = Vec::new();
            for c in 0..count {
                points.extend(square(0, f64::from(c) * 0.01).samples);
                labels.extend([c; 4]);
            }
            Message::Segments(Segments {
                cluster_count: count as u32,
                points,
                labels,
                ..Segments::default()
            })
        };
        node.on_message(SEGMENTS, &clusters(17), &mut outbox)
            .unwrap();
        for t_s in [1.0, 2.0] {
            node.on_message(GROUND_TRUTH_POSE, &stamped(t_s, 0.0, 0.0), &mut outbox)
                .unwrap();
            node.on_message(SLAM_POSE, &stamped(t_s, 0.0, 0.0), &mut outbox)
                .unwrap();
        }
        assert!(outbox.is_empty(), "a too-large map was scored");
        assert_eq!(node.skipped_steps(), 2);
        // A map that fits is scored again.
        node.on_message(SEGMENTS, &clusters(1), &mut outbox)
            .unwrap();
        node.on_message(SLAM_POSE, &stamped(3.0, 0.0, 0.0), &mut outbox)
            .unwrap();
        let m = metrics(&mut outbox);
        assert_eq!((m.len(), m[0].estimate_points), (1, 4));
        assert_eq!(node.skipped_steps(), 2);
    }

    #[test]
    fn shape_mode_scores_the_fitted_shapes_samples_and_ignores_segments() {
        let params = Params {
            representatives: RepresentativeMode::Shape,
            ..Params::default()
        };
        let mut node = EvaluatorNode::new(params).unwrap();
        assert_eq!(
            node.inputs(),
            vec![
                GROUND_TRUTH_TARGETS,
                MAP_TARGETS,
                GROUND_TRUTH_POSE,
                SLAM_POSE
            ]
        );
        let mut outbox = Outbox::new();
        node.on_message(GROUND_TRUTH_TARGETS, &targets(), &mut outbox)
            .unwrap();
        // Segments are not this mode's input.
        let segments = Message::Segments(Segments::default());
        assert!(node.on_message(SEGMENTS, &segments, &mut outbox).is_err());
        // One shape on target 0's corners, shifted 0.5 m in x.
        let shifted: Vec<Point> = square(0, 0.5).samples;
        let shapes = Message::MapTargets(MapTargets {
            header: Header::default(),
            targets: vec![nrslam_msgs::MapTarget {
                shape: "rectangle".into(),
                samples: shifted,
                covariance: vec![0.0; 25],
                ..Default::default()
            }],
        });
        node.on_message(MAP_TARGETS, &shapes, &mut outbox).unwrap();
        node.on_message(GROUND_TRUTH_POSE, &stamped(1.0, 0.0, 0.0), &mut outbox)
            .unwrap();
        node.on_message(SLAM_POSE, &stamped(1.0, 0.0, 0.0), &mut outbox)
            .unwrap();
        let m = metrics(&mut outbox);
        assert_eq!((m[0].estimated_targets, m[0].estimate_points), (1, 4));
        // Target 0: 4 slots at 0.5 m (p = 1); target 1 missed: 4 × c/2.
        assert!((m[0].etgospa_localisation - 2.0).abs() < 1e-12, "{m:?}");
        assert!((m[0].etgospa_missed - 10.0).abs() < 1e-12, "{m:?}");
    }

    #[test]
    fn build_refuses_invalid_params() {
        let ctx = NodeContext::for_tests(1);
        assert!(build(Params::default(), &ctx).is_ok());
        let bad = Params {
            alpha: 3.0,
            ..Params::default()
        };
        let e = build(bad, &ctx).err().expect("alpha = 3 accepted");
        assert!(e.to_string().contains("alpha"), "{e}");
    }
}
