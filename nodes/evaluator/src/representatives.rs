//! Estimate points from a segmented map: the y_j that ET-GOPSA scores.
//!
//! The paper (Sec. IV-B) scores each extended target through 4 sample points and the SLAM map
//! through the DBSCAN clusters of its occupied points (Sec. IV-A). A cluster can hold hundreds of
//! map points; scoring all of them would drown the metric in false estimates, so each cluster
//! (label ≥ 0; noise, label −1, is left out) is represented by k points spread over it, k = 4 by
//! default to match the 4 slots per target.
//!
//! Two ways to choose them ([`RepresentativeMode`]):
//! - `box-corners` (default): the 4 corners of the cluster's principal-axis bounding box (axes
//!   from the eigenvectors of the points' 2×2 covariance). A cluster that covers a rectangle's
//!   whole outline gives its corners, which are the rectangle's sample points, so the metric
//!   rewards a map that fills in; a partial view gives a smaller box and costs localisation.
//! - `farthest-point`: farthest-point sampling, below.
//! - `shape`: the points sampled, as the truth's are, from the shape fitted to each target
//!   (`/map/targets`, nrslam-shapes): a rectangle's 4 corners, a circle's points at 0°, 90°,
//!   180° and 270°. The evaluator node then reads the fitted shapes instead of the segments;
//!   [`representatives_with`] refuses this mode, as segments alone do not carry the shapes.
//!
//! The spread is farthest-point sampling: start at the point farthest from the cluster centroid,
//! then repeatedly add the point farthest from those already chosen. Ties go to the lowest index,
//! distances are compared squared (exact for the comparisons), clusters come out in increasing
//! label order: the result is a deterministic function of the input. A cluster with fewer than k
//! distinct points gives all its distinct points (an exact duplicate of a chosen point adds no
//! information and would fill a second slot for free).

use std::collections::BTreeMap;

use serde::Serialize;
use thiserror::Error;

use crate::point::Point2;

/// Label of a noise point in [`nrslam_msgs::Segments`].
pub const NOISE_LABEL: i32 = -1;

/// How a cluster becomes estimate points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum RepresentativeMode {
    /// The 4 corners of the principal-axis bounding box.
    #[default]
    BoxCorners,
    /// k points by farthest-point sampling.
    FarthestPoint,
    /// The samples of the fitted shapes (`/map/targets`), not computed from segments.
    Shape,
}

/// The representatives of one cluster.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ClusterRepresentatives {
    /// The cluster's label (≥ 0).
    pub label: i32,
    /// Number of map points in the cluster.
    pub size: usize,
    /// The chosen points, in the order farthest-point sampling picked them.
    pub points: Vec<Point2>,
}

/// Segmented map points refused by [`representatives`].
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RepresentativesError {
    /// Points and labels differ in length.
    #[error("{points} points but {labels} labels")]
    LengthMismatch {
        /// Number of points.
        points: usize,
        /// Number of labels.
        labels: usize,
    },
    /// A label below −1.
    #[error("point {index} has label {label}: labels are -1 (noise) or >= 0")]
    InvalidLabel {
        /// Index of the point.
        index: usize,
        /// Its label.
        label: i32,
    },
    /// [`RepresentativeMode::Shape`] asked of segments: the fitted shapes carry their samples.
    #[error(
        "representatives = \"shape\" come from the fitted shapes (/map/targets), not from segments"
    )]
    ShapeModeNeedsShapes,
    /// A clustered point with a NaN or infinite coordinate.
    #[error("point {index} has a non-finite coordinate ({x_m}, {y_m})")]
    NonFinitePoint {
        /// Index of the point.
        index: usize,
        /// Its x, metres.
        x_m: f64,
        /// Its y, metres.
        y_m: f64,
    },
}

/// Up to `k` representatives per cluster, clusters in increasing label order (see the module
/// doc). Noise points are ignored, including their coordinates.
///
/// # Errors
/// [`RepresentativesError`] for mismatched lengths, a label below −1, or a non-finite coordinate
/// of a clustered point.
///
/// ```
/// use nrslam_evaluator::{representatives, Point2};
/// let points: Vec<Point2> = (0..5).map(|i| Point2::new(i as f64, 0.0)).collect();
/// let labels = [0, 0, 0, 0, 0];
/// let clusters = representatives(&points, &labels, 2).unwrap();
/// // Centroid x = 2: the farthest points are x = 0 and x = 4; ties go to the lower index.
/// assert_eq!(clusters[0].points, vec![Point2::new(0.0, 0.0), Point2::new(4.0, 0.0)]);
/// ```
pub fn representatives(
    points: &[Point2],
    labels: &[i32],
    k: usize,
) -> Result<Vec<ClusterRepresentatives>, RepresentativesError> {
    representatives_with(points, labels, k, RepresentativeMode::FarthestPoint)
}

/// As [`representatives`], choosing the points by `mode` (`k` is used by farthest-point
/// sampling only; box corners are always 4, fewer when corners coincide).
///
/// # Errors
/// As [`representatives`].
pub fn representatives_with(
    points: &[Point2],
    labels: &[i32],
    k: usize,
    mode: RepresentativeMode,
) -> Result<Vec<ClusterRepresentatives>, RepresentativesError> {
    let choose: fn(&[Point2], usize) -> Vec<Point2> = match mode {
        RepresentativeMode::FarthestPoint => |cluster, k| {
            farthest_point_sampling(cluster, k)
                .into_iter()
                .map(|i| cluster[i])
                .collect()
        },
        RepresentativeMode::BoxCorners => |cluster, _| box_corners(cluster),
        RepresentativeMode::Shape => return Err(RepresentativesError::ShapeModeNeedsShapes),
    };
    if points.len() != labels.len() {
        return Err(RepresentativesError::LengthMismatch {
            points: points.len(),
            labels: labels.len(),
        });
    }
    // BTreeMap: clusters in label order whatever the labels' order of appearance.
    let mut members: BTreeMap<i32, Vec<usize>> = BTreeMap::new();
    for (index, (&label, point)) in labels.iter().zip(points).enumerate() {
        if label < NOISE_LABEL {
            return Err(RepresentativesError::InvalidLabel { index, label });
        }
        if label == NOISE_LABEL {
            continue;
        }
        if !point.is_finite() {
            return Err(RepresentativesError::NonFinitePoint {
                index,
                x_m: point.x_m,
                y_m: point.y_m,
            });
        }
        members.entry(label).or_default().push(index);
    }
    Ok(members
        .into_iter()
        .map(|(label, indices)| {
            let cluster: Vec<Point2> = indices.iter().map(|&i| points[i]).collect();
            ClusterRepresentatives {
                label,
                size: cluster.len(),
                points: choose(&cluster, k),
            }
        })
        .collect())
}

/// All representatives of all clusters, flattened in cluster order: the estimate set Y.
pub fn flatten(clusters: &[ClusterRepresentatives]) -> Vec<Point2> {
    clusters
        .iter()
        .flat_map(|c| c.points.iter().copied())
        .collect()
}

/// Corners of the principal-axis bounding box of `cluster` (counter-clockwise from the
/// (min, min) corner in the box frame), duplicates removed.
pub fn box_corners(cluster: &[Point2]) -> Vec<Point2> {
    if cluster.is_empty() {
        return Vec::new();
    }
    let n = cluster.len() as f64;
    let (mean_x, mean_y) = cluster
        .iter()
        .fold((0.0, 0.0), |(x, y), p| (x + p.x_m / n, y + p.y_m / n));
    let (mut sxx, mut syy, mut sxy) = (0.0, 0.0, 0.0);
    for p in cluster {
        let (dx, dy) = (p.x_m - mean_x, p.y_m - mean_y);
        sxx += dx * dx;
        syy += dy * dy;
        sxy += dx * dy;
    }
    // Orientation of the major axis of the covariance ellipse.
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let (u, v) = ((angle.cos(), angle.sin()), (-angle.sin(), angle.cos()));
    let (mut lo_u, mut hi_u, mut lo_v, mut hi_v) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in cluster {
        let (dx, dy) = (p.x_m - mean_x, p.y_m - mean_y);
        let (a, b) = (dx * u.0 + dy * u.1, dx * v.0 + dy * v.1);
        lo_u = lo_u.min(a);
        hi_u = hi_u.max(a);
        lo_v = lo_v.min(b);
        hi_v = hi_v.max(b);
    }
    let corner =
        |a: f64, b: f64| Point2::new(mean_x + a * u.0 + b * v.0, mean_y + a * u.1 + b * v.1);
    let mut corners: Vec<Point2> = Vec::with_capacity(4);
    for candidate in [
        corner(lo_u, lo_v),
        corner(hi_u, lo_v),
        corner(hi_u, hi_v),
        corner(lo_u, hi_v),
    ] {
        if !corners.iter().any(|c| c.distance_sq_m2(&candidate) < 1e-18) {
            corners.push(candidate);
        }
    }
    corners
}

/// Indices of up to `k` points of `cluster` chosen by farthest-point sampling.
fn farthest_point_sampling(cluster: &[Point2], k: usize) -> Vec<usize> {
    if cluster.is_empty() || k == 0 {
        return Vec::new();
    }
    let n = cluster.len() as f64;
    let centroid = Point2::new(
        cluster.iter().map(|p| p.x_m).sum::<f64>() / n,
        cluster.iter().map(|p| p.y_m).sum::<f64>() / n,
    );
    // `max_by` keeps the last maximum; scanning with strict `>` keeps the first (lowest index).
    let argmax = |score: &dyn Fn(usize) -> f64| -> (usize, f64) {
        let mut best = (0, score(0));
        for i in 1..cluster.len() {
            let s = score(i);
            if s > best.1 {
                best = (i, s);
            }
        }
        best
    };
    let (first, _) = argmax(&|i| cluster[i].distance_sq_m2(&centroid));
    let mut chosen = vec![first];
    // Squared distance from each point to the nearest chosen point.
    let mut nearest_sq: Vec<f64> = cluster
        .iter()
        .map(|p| p.distance_sq_m2(&cluster[first]))
        .collect();
    while chosen.len() < k {
        let (next, farthest_sq) = argmax(&|i| nearest_sq[i]);
        if farthest_sq == 0.0 {
            // Every remaining point coincides with a chosen one.
            break;
        }
        chosen.push(next);
        for (d, p) in nearest_sq.iter_mut().zip(cluster) {
            *d = d.min(p.distance_sq_m2(&cluster[next]));
        }
    }
    chosen
}

#[cfg(test)]
mod box_tests {
    use super::*;

    #[test]
    fn box_corners_of_a_rotated_rectangle_outline_are_its_corners() {
        let (w, h, yaw) = (4.0f64, 1.0f64, 0.35f64);
        let mut outline = Vec::new();
        for i in 0..=40 {
            let t = i as f64 / 40.0;
            for (a, b) in [(t * w, 0.0), (t * w, h), (0.0, t * h), (w, t * h)] {
                outline.push(Point2::new(
                    10.0 + a * yaw.cos() - b * yaw.sin(),
                    5.0 + a * yaw.sin() + b * yaw.cos(),
                ));
            }
        }
        let corners = box_corners(&outline);
        assert_eq!(corners.len(), 4);
        for (a, b) in [(0.0, 0.0), (w, 0.0), (w, h), (0.0, h)] {
            let truth = Point2::new(
                10.0 + a * yaw.cos() - b * yaw.sin(),
                5.0 + a * yaw.sin() + b * yaw.cos(),
            );
            let nearest = corners
                .iter()
                .map(|c| c.distance_m(&truth))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest < 1e-9, "corner {truth:?} off by {nearest}");
        }
    }

    #[test]
    fn degenerate_clusters_give_fewer_corners() {
        assert_eq!(box_corners(&[Point2::new(1.0, 1.0)]).len(), 1);
        assert_eq!(
            box_corners(&[Point2::new(0.0, 0.0), Point2::new(2.0, 0.0)]).len(),
            2
        );
        assert!(box_corners(&[]).is_empty());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_cluster_gives_its_corners_and_noise_is_ignored() {
        // A 3×3 grid of points; FPS with k = 4 must pick the four corners.
        let mut points = Vec::new();
        let mut labels = Vec::new();
        for i in 0..3 {
            for j in 0..3 {
                points.push(Point2::new(f64::from(i), f64::from(j)));
                labels.push(0);
            }
        }
        points.push(Point2::new(100.0, 100.0));
        labels.push(NOISE_LABEL);
        let clusters = representatives(&points, &labels, 4).unwrap();
        assert_eq!(clusters.len(), 1);
        assert_eq!(clusters[0].size, 9);
        // Farthest from the centroid (1, 1): the corners at equal distance, lowest index first
        // (0, 0); then the farthest from it, (2, 2); then (0, 2) and (2, 0) tie at distance 2 and
        // the lower index (0, 2) wins, then (2, 0).
        assert_eq!(
            clusters[0].points,
            vec![
                Point2::new(0.0, 0.0),
                Point2::new(2.0, 2.0),
                Point2::new(0.0, 2.0),
                Point2::new(2.0, 0.0)
            ]
        );
    }

    #[test]
    fn small_and_duplicate_clusters_give_fewer_points() {
        let points = [
            Point2::new(0.0, 0.0),
            Point2::new(1.0, 0.0),
            Point2::new(5.0, 5.0),
            Point2::new(5.0, 5.0),
            Point2::new(5.0, 5.0),
        ];
        let labels = [3, 3, 1, 1, 1];
        let clusters = representatives(&points, &labels, 4).unwrap();
        // Label order, not appearance order.
        assert_eq!(
            clusters.iter().map(|c| c.label).collect::<Vec<_>>(),
            vec![1, 3]
        );
        assert_eq!(clusters[0].points, vec![Point2::new(5.0, 5.0)]);
        assert_eq!(clusters[1].points.len(), 2);
        assert_eq!(flatten(&clusters).len(), 3);
    }

    #[test]
    fn refuses_bad_input() {
        let p = [Point2::new(0.0, 0.0), Point2::new(f64::NAN, 0.0)];
        assert!(matches!(
            representatives(&p, &[0], 4),
            Err(RepresentativesError::LengthMismatch {
                points: 2,
                labels: 1
            })
        ));
        assert!(matches!(
            representatives(&p, &[0, 0], 4),
            Err(RepresentativesError::NonFinitePoint { index: 1, .. })
        ));
        // A NaN noise point is not used, so it is not an error.
        assert_eq!(representatives(&p, &[0, NOISE_LABEL], 4).unwrap().len(), 1);
        assert!(matches!(
            representatives(&p[..1], &[-2], 4),
            Err(RepresentativesError::InvalidLabel {
                index: 0,
                label: -2
            })
        ));
        assert!(representatives(&[], &[], 4).unwrap().is_empty());
        assert!(representatives(&p[..1], &[0], 0).unwrap()[0]
            .points
            .is_empty());
    }

    #[test]
    fn deterministic_under_relabelling_order() {
        // The same clusters listed in another order give the same representatives per label.
        let a = [
            Point2::new(0.0, 0.0),
            Point2::new(3.0, 0.0),
            Point2::new(10.0, 0.0),
            Point2::new(10.0, 4.0),
        ];
        let la = [0, 0, 1, 1];
        let b = [a[2], a[0], a[3], a[1]];
        let lb = [1, 0, 1, 0];
        assert_eq!(
            representatives(&a, &la, 4).unwrap(),
            representatives(&b, &lb, 4).unwrap()
        );
    }
}
