//! The shapes stage as a graph node: `/map/segments` and `/slam/keyframe_poses` in,
//! `/map/targets` and `/map/targets/markers` out.
//!
//! Each segmentation of the map (one per keyframe) is grouped by cluster label and handed to the
//! [`ShapeTracker`]; its targets are published as [`MapTargets`] with the segments' stamp, and
//! drawn as a [`MarkerArray`] (each fitted outline as a closed line, namespace `shapes`, id =
//! target id, and its sample points as spheres, namespace `shape_samples`, after a DELETEALL).
//! The keyframe positions of the latest `/slam/keyframe_poses` are the viewpoints that tell a
//! one-sided rectangle which way it extends (away from where it was seen from), and their pose
//! covariances, where the back end publishes them, are added to each published shape's
//! covariance (module [`pose_uncertainty`](crate::pose_uncertainty)): the fit knows only the
//! cells' scatter, not how far the poses that placed them were off.

use nrslam_msgs::topics::{KEYFRAME_POSES, MAP_TARGETS, MAP_TARGET_MARKERS, SEGMENTS};
use nrslam_msgs::{
    ColorRGBA, Header, KeyframePoses, MapTarget, MapTargets, Marker, MarkerArray, Message, Point,
    Segments, Time,
};
use nrslam_runtime::{Node, NodeContext, NodeError, NodeResult, Outbox};
use std::collections::BTreeMap;

use crate::evaluate::TruthShape;
use crate::pose_uncertainty::{pose_covariance, Viewpoint};
use crate::{FittedShape, Params, ShapeKind, ShapeTracker, TrackedTarget};

/// Frame of everything published.
pub const MAP_FRAME: &str = "map";

/// Width of the drawn outlines and diameter of the drawn samples (m).
const LINE_WIDTH_M: f64 = 0.08;
const SAMPLE_SIZE_M: f64 = 0.3;

/// The shape tracker, bound to the node API.
#[derive(Debug)]
pub struct ShapesNode {
    tracker: ShapeTracker,
    viewpoints: Vec<Viewpoint>,
    pose_support_m: f64,
    pose_covariance_share: f64,
}

/// Builds the node from `params` (validated here). It draws no random numbers and reads no
/// files, so `ctx` is not used.
pub fn build(params: Params, _ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    params.validate()?;
    Ok(Box::new(ShapesNode {
        pose_support_m: params.pose_support_m,
        pose_covariance_share: params.pose_covariance_share,
        tracker: ShapeTracker::new(params),
        viewpoints: Vec::new(),
    }))
}

impl ShapesNode {
    fn on_keyframe_poses(&mut self, poses: &KeyframePoses) {
        // Nine values per keyframe, or none (a back end that does not say adds no uncertainty).
        let covariances = &poses.pose_covariances;
        let known = covariances.len() == 9 * poses.poses.len();
        let covariance_of = |k: usize| {
            covariances
                .get(9 * k..9 * k + 9)
                .filter(|_| known)
                .map_or([[0.0; 3]; 3], |c| {
                    [[c[0], c[1], c[2]], [c[3], c[4], c[5]], [c[6], c[7], c[8]]]
                })
        };
        self.viewpoints = poses
            .poses
            .iter()
            .enumerate()
            .map(|(k, p)| Viewpoint {
                position_m: [p.position.x, p.position.y],
                covariance: covariance_of(k),
            })
            .collect();
    }

    fn on_segments(&mut self, segments: &Segments, outbox: &mut Outbox) -> Result<(), NodeError> {
        if segments.labels.len() != segments.points.len() {
            return Err(NodeError::invalid_input(
                SEGMENTS,
                format!(
                    "{} labels for {} points",
                    segments.labels.len(),
                    segments.points.len()
                ),
            ));
        }
        let mut clusters: BTreeMap<i32, Vec<[f64; 2]>> = BTreeMap::new();
        for (p, &label) in segments.points.iter().zip(&segments.labels) {
            if label >= 0 {
                clusters.entry(label).or_default().push([p.x, p.y]);
            }
        }
        let clusters: Vec<Vec<[f64; 2]>> = clusters.into_values().collect();
        let positions_m: Vec<[f64; 2]> = self.viewpoints.iter().map(|v| v.position_m).collect();
        let mut targets = self.tracker.update(&clusters, &positions_m);
        targets.sort_by_key(|t| t.id);
        for target in &mut targets {
            let shape = &mut target.shape;
            let pose = pose_covariance(
                shape.center_m,
                &self.viewpoints,
                self.pose_support_m,
                self.pose_covariance_share,
            );
            add_pose_covariance(shape, pose);
        }
        let stamp = segments.header.stamp;
        let message = MapTargets {
            header: Header::new(stamp, MAP_FRAME),
            targets: targets
                .iter()
                .map(|t| map_target(t, clusters.get(t.segment).map_or(&[][..], |c| &c[..])))
                .collect(),
        };
        outbox.publish(MAP_TARGET_MARKERS, markers(&message, stamp));
        outbox.publish(MAP_TARGETS, message);
        Ok(())
    }
}

/// Adds the pose errors' covariance over (centre x m, centre y m, yaw rad) to the shape's own:
/// the centre block, and for a rectangle the yaw variance and the centre–yaw cross terms. A
/// shape without a full covariance is left as it is.
fn add_pose_covariance(shape: &mut FittedShape, pose: [[f64; 3]; 3]) {
    let n = shape.parameter_count();
    if shape.covariance.len() != n * n {
        return;
    }
    // Where (centre x, centre y, yaw) sit among the shape's parameters.
    let index: &[usize] = match shape.kind {
        ShapeKind::Rectangle => &[0, 1, 4],
        ShapeKind::Circle => &[0, 1],
    };
    for (r, &row) in index.iter().enumerate() {
        for (c, &column) in index.iter().enumerate() {
            shape.covariance[row * n + column] += pose[r][c];
        }
    }
}

fn points(xy: &[[f64; 2]]) -> Vec<Point> {
    xy.iter().map(|p| Point::planar(p[0], p[1])).collect()
}

/// One tracked target as its message; `support_m` are the cells it was fitted to.
pub fn map_target(target: &TrackedTarget, support_m: &[[f64; 2]]) -> MapTarget {
    let shape = &target.shape;
    MapTarget {
        id: target.id,
        shape: match shape.kind {
            ShapeKind::Rectangle => "rectangle",
            ShapeKind::Circle => "circle",
        }
        .to_owned(),
        center_x_m: shape.center_m[0],
        center_y_m: shape.center_m[1],
        width_m: shape.size_m[0],
        height_m: shape.size_m[1],
        yaw_rad: shape.yaw_rad,
        radius_m: shape.radius_m,
        covariance: shape.covariance.clone(),
        sides_seen: u32::from(shape.sides_seen),
        updates: target.updates,
        rms_residual_m: shape.rms_residual_m,
        outline: points(&shape.outline()),
        samples: points(&shape.samples()),
        supporting_cells: points(support_m),
    }
}

/// A received target as a [`FittedShape`] (for evaluation): `None` for an unknown shape name or
/// a covariance of the wrong size. Fields the message does not carry (the model-selection
/// criteria) are left empty; `support` counts the supporting cells.
pub fn shape_from_message(target: &MapTarget) -> Option<FittedShape> {
    let (kind, parameters) = match target.shape.as_str() {
        "rectangle" => (ShapeKind::Rectangle, 5),
        "circle" => (ShapeKind::Circle, 3),
        _ => return None,
    };
    if target.covariance.len() != parameters * parameters {
        return None;
    }
    Some(FittedShape {
        kind,
        center_m: [target.center_x_m, target.center_y_m],
        size_m: [target.width_m, target.height_m],
        yaw_rad: target.yaw_rad,
        radius_m: target.radius_m,
        covariance: target.covariance.clone(),
        sides_seen: u8::try_from(target.sides_seen).unwrap_or(u8::MAX),
        support: target.supporting_cells.len(),
        rms_residual_m: target.rms_residual_m,
        bic_rectangle: None,
        bic_circle: None,
        circle_probability: if kind == ShapeKind::Circle { 1.0 } else { 0.0 },
    })
}

/// A true target (`/ground_truth/targets`) as a [`TruthShape`], from its outline: a rectangle's 4
/// corners (counter-clockwise from its local (−w/2, −h/2), as the simulator writes them), a
/// circle's polygon (centre = vertex mean, radius = mean vertex distance). `None` for another
/// shape name, a rectangle without 4 corners or a circle without vertices.
pub fn truth_from_target(target: &nrslam_msgs::Target) -> Option<TruthShape> {
    let outline: Vec<[f64; 2]> = target.outline.iter().map(|p| [p.x, p.y]).collect();
    let n = outline.len() as f64;
    let centre = |points: &[[f64; 2]]| {
        let (x, y) = points
            .iter()
            .fold((0.0, 0.0), |(x, y), p| (x + p[0], y + p[1]));
        [x / n, y / n]
    };
    match target.shape.as_str() {
        "rectangle" if outline.len() == 4 => {
            let [a, b, c, _] = [outline[0], outline[1], outline[2], outline[3]];
            let width_m = (b[0] - a[0]).hypot(b[1] - a[1]);
            let height_m = (c[0] - b[0]).hypot(c[1] - b[1]);
            let yaw_rad = (b[1] - a[1]).atan2(b[0] - a[0]);
            Some(TruthShape::rectangle(
                centre(&outline),
                [width_m, height_m],
                yaw_rad,
            ))
        }
        "circle" if !outline.is_empty() => {
            let c = centre(&outline);
            let radius_m = outline
                .iter()
                .map(|p| (p[0] - c[0]).hypot(p[1] - c[1]))
                .sum::<f64>()
                / n;
            Some(TruthShape::circle(c, radius_m))
        }
        _ => None,
    }
}

/// The fitted shapes for viewers: orange rectangles, blue circles.
pub fn markers(targets: &MapTargets, stamp: Time) -> MarkerArray {
    let header = Header::new(stamp, MAP_FRAME);
    let mut out = vec![Marker::delete_all(header.clone())];
    for target in &targets.targets {
        let (r, g, b) = if target.shape == "circle" {
            (0.2, 0.4, 1.0)
        } else {
            (1.0, 0.5, 0.0)
        };
        let id = Marker::id_of(target.id);
        out.push(Marker::closed_line(
            header.clone(),
            ("shapes", id),
            &target.outline,
            LINE_WIDTH_M,
            ColorRGBA { r, g, b, a: 1.0 },
        ));
        out.push(Marker::spheres(
            header.clone(),
            ("shape_samples", id),
            &target.samples,
            SAMPLE_SIZE_M,
            ColorRGBA { r, g, b, a: 0.7 },
        ));
    }
    MarkerArray { markers: out }
}

impl Node for ShapesNode {
    fn inputs(&self) -> Vec<&'static str> {
        // Keyframe poses first: at a shared stamp the viewpoints are current when the segments
        // of that keyframe's map arrive.
        vec![KEYFRAME_POSES, SEGMENTS]
    }

    fn outputs(&self) -> Vec<&'static str> {
        vec![MAP_TARGETS, MAP_TARGET_MARKERS]
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        match (topic, message) {
            (KEYFRAME_POSES, Message::KeyframePoses(poses)) => {
                self.on_keyframe_poses(poses);
                Ok(())
            }
            (SEGMENTS, Message::Segments(segments)) => self.on_segments(segments, outbox),
            (topic, message) => Err(NodeError::unexpected(topic, message)),
        }
    }
}
