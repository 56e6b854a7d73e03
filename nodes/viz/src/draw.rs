//! The standard messages viewers draw, built from the graph's own (pure functions).
//!
//! Frames follow REP-105: `map` (the SLAM map, equal to the world at the start), `odom` (where
//! the wheel odometry says the vehicle is), `base_link` (the vehicle), `radar` (the sensor, at the
//! vehicle's centre turned by the boresight: docs/conventions.md).

use nrslam_evaluator::ClusterRepresentatives;
use nrslam_msgs::{
    ColorRGBA, Detections, Header, Marker, MarkerArray, Point, PointCloud2, PointField, Segments,
    TargetSet, Time, Transform, TransformStamped,
};

/// The fixed frame.
pub const MAP_FRAME: &str = "map";
/// The odometry frame.
pub const ODOM_FRAME: &str = "odom";
/// The vehicle.
pub const BASE_FRAME: &str = "base_link";
/// The sensor.
pub const RADAR_FRAME: &str = "radar";

/// A planar pose (x m, y m, yaw rad).
pub type Planar = (f64, f64, f64);

/// `a ∘ b`: `b` expressed in `a`'s frame, then in `a`'s parent.
pub fn compose(a: Planar, b: Planar) -> Planar {
    let (sin, cos) = a.2.sin_cos();
    (
        a.0 + cos * b.0 - sin * b.1,
        a.1 + sin * b.0 + cos * b.1,
        a.2 + b.2,
    )
}

/// The inverse transform of `a`.
pub fn inverse(a: Planar) -> Planar {
    let (sin, cos) = a.2.sin_cos();
    (-(cos * a.0 + sin * a.1), sin * a.0 - cos * a.1, -a.2)
}

/// `parent → child` at `stamp`.
pub fn transform(parent: &str, child: &str, stamp: Time, pose: Planar) -> TransformStamped {
    TransformStamped {
        header: Header::new(stamp, parent),
        child_frame_id: child.to_owned(),
        transform: Transform::from_planar(pose.0, pose.1, pose.2),
    }
}

/// One frame's detections as `x`, `y`, `z`, `power_db` float32 points (little-endian, 16 bytes
/// each) in the radar frame: x along the boresight, y to its left.
pub fn detections_cloud(detections: &Detections) -> PointCloud2 {
    let mut data = Vec::with_capacity(16 * detections.detections.len());
    let mut dense = true;
    for d in &detections.detections {
        let (sin, cos) = d.angle_rad.sin_cos();
        let values = [
            (d.range_m * cos) as f32,
            (d.range_m * sin) as f32,
            0.0,
            d.power_db as f32,
        ];
        dense &= values.iter().all(|v| v.is_finite());
        for v in values {
            data.extend_from_slice(&v.to_le_bytes());
        }
    }
    let width = u32::try_from(detections.detections.len()).unwrap_or(u32::MAX);
    PointCloud2 {
        header: Header::new(detections.header.stamp, RADAR_FRAME),
        height: 1,
        width,
        fields: ["x", "y", "z", "power_db"]
            .iter()
            .zip([0, 4, 8, 12])
            .map(|(name, offset)| PointField::scalar(name, offset, PointField::FLOAT32))
            .collect(),
        is_bigendian: false,
        point_step: 16,
        row_step: width.saturating_mul(16),
        data,
        is_dense: dense,
    }
}

/// Ten distinct colours (matplotlib's tab10), for clusters by label.
const PALETTE: [(f32, f32, f32); 10] = [
    (0.12, 0.47, 0.71),
    (1.00, 0.50, 0.05),
    (0.17, 0.63, 0.17),
    (0.84, 0.15, 0.16),
    (0.58, 0.40, 0.74),
    (0.55, 0.34, 0.29),
    (0.89, 0.47, 0.76),
    (0.50, 0.50, 0.50),
    (0.74, 0.74, 0.13),
    (0.09, 0.75, 0.81),
];

fn colour(index: usize, alpha: f32) -> ColorRGBA {
    let (r, g, b) = PALETTE[index % PALETTE.len()];
    ColorRGBA { r, g, b, a: alpha }
}

/// The true targets: each outline as a closed line (ns `targets`, id = target id) and its
/// ET-GOPSA sample points as spheres (ns `target_samples`).
pub fn target_markers(targets: &TargetSet, line_width_m: f64, point_size_m: f64) -> MarkerArray {
    let header = Header::new(targets.header.stamp, MAP_FRAME);
    let green = |a| ColorRGBA {
        r: 0.1,
        g: 0.8,
        b: 0.1,
        a,
    };
    let mut markers = vec![Marker::delete_all(header.clone())];
    for target in &targets.targets {
        let id = Marker::id_of(target.id);
        markers.push(Marker::closed_line(
            header.clone(),
            ("targets", id),
            &target.outline,
            line_width_m,
            green(1.0),
        ));
        markers.push(Marker::spheres(
            header.clone(),
            ("target_samples", id),
            &target.samples,
            point_size_m,
            green(0.6),
        ));
    }
    MarkerArray { markers }
}

/// The segmented map: each cluster's cells as cubes coloured by label (ns `clusters`, id =
/// label), noise cells grey (ns `noise`), each cluster's representative points as spheres
/// (ns `representatives`, id = label), after a DELETEALL.
pub fn cluster_markers(
    segments: &Segments,
    representatives: &[ClusterRepresentatives],
    cell_size_m: f64,
    point_size_m: f64,
) -> MarkerArray {
    let header = Header::new(segments.header.stamp, MAP_FRAME);
    let cells_labelled = |wanted: &dyn Fn(i32) -> bool| -> Vec<Point> {
        let labelled = segments.points.iter().zip(&segments.labels);
        labelled
            .filter(|(_, &l)| wanted(l))
            .map(|(p, _)| *p)
            .collect()
    };
    let mut markers = vec![Marker::delete_all(header.clone())];
    for cluster in representatives {
        let label = cluster.label;
        let cells = cells_labelled(&|l| l == label);
        let in_colour = |alpha| colour(label.unsigned_abs() as usize, alpha);
        let at = ("clusters", label);
        markers.push(Marker::cubes(
            header.clone(),
            at,
            &cells,
            cell_size_m,
            in_colour(0.8),
        ));
        let points: Vec<Point> = cluster
            .points
            .iter()
            .map(|p| Point::planar(p.x_m, p.y_m))
            .collect();
        let at = ("representatives", label);
        markers.push(Marker::spheres(
            header.clone(),
            at,
            &points,
            point_size_m,
            in_colour(1.0),
        ));
    }
    let grey = ColorRGBA {
        r: 0.6,
        g: 0.6,
        b: 0.6,
        a: 0.5,
    };
    let noise = cells_labelled(&|l| l < 0);
    markers.push(Marker::cubes(
        header,
        ("noise", 0),
        &noise,
        cell_size_m,
        grey,
    ));
    MarkerArray { markers }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_evaluator::Point2;
    use nrslam_msgs::{Detection, Target};

    fn close(a: Planar, b: Planar) -> bool {
        (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12 && (a.2 - b.2).abs() < 1e-12
    }

    #[test]
    fn compose_and_inverse_undo_each_other() {
        let a = (1.0, -2.0, 0.7);
        let b = (0.5, 3.0, -1.2);
        assert!(close(compose(a, inverse(a)), (0.0, 0.0, 0.0)));
        assert!(close(compose(inverse(a), compose(a, b)), b));
        // A quarter turn maps +x to +y.
        assert!(close(
            compose((0.0, 0.0, std::f64::consts::FRAC_PI_2), (1.0, 0.0, 0.0)),
            (6.123233995736766e-17, 1.0, std::f64::consts::FRAC_PI_2)
        ));
    }

    #[test]
    fn detections_become_points_in_the_radar_frame() {
        let d = Detections {
            header: Header::new(Time::from_seconds(2.0), "radar"),
            boresight_rad: 1.0,
            detections: vec![
                Detection {
                    range_m: 2.0,
                    angle_rad: 0.0,
                    power_db: -3.0,
                    ..Detection::default()
                },
                Detection {
                    range_m: 4.0,
                    angle_rad: std::f64::consts::FRAC_PI_2,
                    power_db: f64::INFINITY,
                    ..Detection::default()
                },
            ],
        };
        let cloud = detections_cloud(&d);
        assert_eq!(
            cloud.header,
            Header::new(Time::from_seconds(2.0), RADAR_FRAME)
        );
        assert_eq!(
            (cloud.width, cloud.height, cloud.point_step, cloud.row_step),
            (2, 1, 16, 32)
        );
        assert_eq!(
            nrslam_msgs::Message::from(cloud.clone()).check_usable(),
            Ok(())
        );
        let f = |i: usize| f32::from_le_bytes(cloud.data[4 * i..4 * i + 4].try_into().unwrap());
        assert_eq!((f(0), f(1), f(2), f(3)), (2.0, 0.0, 0.0, -3.0));
        assert!((f(4)).abs() < 1e-6 && (f(5) - 4.0).abs() < 1e-6);
        assert!(!cloud.is_dense, "an infinite power is not a dense cloud");
    }

    #[test]
    fn targets_are_closed_outlines_and_sample_spheres() {
        let targets = TargetSet {
            header: Header::new(Time::from_seconds(1.0), "map"),
            targets: vec![Target {
                id: 7,
                shape: "rectangle".into(),
                outline: vec![
                    Point::planar(0.0, 0.0),
                    Point::planar(1.0, 0.0),
                    Point::planar(1.0, 1.0),
                ],
                samples: vec![Point::planar(0.5, 0.5)],
            }],
        };
        let array = target_markers(&targets, 0.05, 0.3);
        assert_eq!(array.markers.len(), 3);
        assert_eq!(array.markers[0].action, Marker::DELETEALL);
        let outline = &array.markers[1];
        assert_eq!(
            (outline.ns.as_str(), outline.id, outline.marker_type),
            ("targets", 7, Marker::LINE_STRIP)
        );
        assert_eq!(outline.points.len(), 4);
        assert_eq!(outline.points[3], outline.points[0]);
        assert_eq!(array.markers[2].points, targets.targets[0].samples);
    }

    #[test]
    fn clusters_are_cells_by_label_with_representatives_and_grey_noise() {
        let segments = Segments {
            header: Header::new(Time::from_seconds(3.0), "map"),
            points: vec![
                Point::planar(0.0, 0.0),
                Point::planar(5.0, 5.0),
                Point::planar(0.1, 0.0),
                Point::planar(9.0, 9.0),
            ],
            labels: vec![0, 1, 0, -1],
            cluster_count: 2,
            ..Segments::default()
        };
        let reps = vec![
            ClusterRepresentatives {
                label: 0,
                size: 2,
                points: vec![Point2::new(0.0, 0.0)],
            },
            ClusterRepresentatives {
                label: 1,
                size: 1,
                points: vec![Point2::new(5.0, 5.0)],
            },
        ];
        let array = cluster_markers(&segments, &reps, 0.1, 0.3);
        let names: Vec<(&str, i32, usize)> = array
            .markers
            .iter()
            .map(|m| (m.ns.as_str(), m.id, m.points.len()))
            .collect();
        assert_eq!(
            names,
            [
                ("", 0, 0),
                ("clusters", 0, 2),
                ("representatives", 0, 1),
                ("clusters", 1, 1),
                ("representatives", 1, 1),
                ("noise", 0, 1)
            ]
        );
        assert_ne!(array.markers[1].color, array.markers[3].color);
        assert_eq!(nrslam_msgs::Message::from(array).check_usable(), Ok(()));
    }
}
