//! DBSCAN (Ester, Kriegel, Sander and Xu, KDD 1996) on planar points.
//!
//! The paper (Sec. IV-A, "Mapping error", Fig. 3 right) separates the occupied cells of the map into
//! extended targets with DBSCAN \[DBSCAN\]; this module is that step. The semantics are those of the
//! standard algorithm as implemented by scikit-learn (`sklearn.cluster.DBSCAN`):
//!
//! - the ε-neighbourhood of a point is every point at Euclidean distance `≤ eps_m`, the point itself
//!   included;
//! - a point is a *core* point when its neighbourhood holds at least `min_samples` points (so
//!   `min_samples` counts the point itself, and `min_samples = 1` makes every point a core point);
//! - points are visited in index order; each core point not yet labelled seeds a new cluster, which
//!   is grown through its core points until no core point can reach further; clusters are numbered
//!   `0, 1, …` in that order of discovery;
//! - a *border* point (not core, but within `eps_m` of a core point) joins the first cluster that
//!   reaches it, which is the cluster with the lowest number among those having a core point within
//!   `eps_m` of it;
//! - every other point is noise, labelled [`NOISE`] (−1).
//!
//! With these rules the labels depend only on the input order, never on the order in which the
//! neighbour search returns points, so the grid implementation [`dbscan`] and the O(n²) oracle
//! [`dbscan_brute_force`] agree label for label (a property test checks it).
//!
//! Distances are compared squared (`dx² + dy² ≤ eps_m²`, computed as `dx*dx + dy*dy`) by both
//! implementations, so points lying exactly at `eps_m` are classified identically.
//!
//! # Cost
//! [`dbscan`] sorts the points into square cells at least ε wide (O(n log n), [`crate::cells`])
//! and runs at most two neighbourhood scans per point over the nine cells around it: one that
//! stops at `min_samples` neighbours to decide whether the point is core, and one full scan for
//! each core point when its cluster is grown. Neighbour lists are not stored, so memory stays O(n).
//! Time is O(n log n + Σ points in the nine cells around each core point); with all n points inside
//! one ε-ball (e.g. all identical) that sum is n², as in every DBSCAN that labels border points.

use crate::cells::{squared_distance, CellIndex};
use crate::SegmentError;

/// Label of a noise point (not reachable from any core point).
pub const NOISE: i32 = -1;

/// Result of a DBSCAN run: one label per input point, in input order.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Clustering {
    /// Cluster label of each point: `0..cluster_count`, or [`NOISE`].
    pub labels: Vec<i32>,
    /// Whether each point is a core point (its ε-neighbourhood holds `≥ min_samples` points).
    pub is_core: Vec<bool>,
    /// Number of clusters found.
    pub cluster_count: usize,
}

impl Clustering {
    /// Number of points labelled [`NOISE`].
    pub fn noise_count(&self) -> usize {
        self.labels.iter().filter(|&&l| l == NOISE).count()
    }

    /// Size of each cluster, indexed by label.
    pub fn cluster_sizes(&self) -> Vec<usize> {
        let mut sizes = vec![0usize; self.cluster_count];
        for &label in &self.labels {
            if let Ok(cluster) = usize::try_from(label) {
                sizes[cluster] += 1;
            }
        }
        sizes
    }
}

/// DBSCAN parameters, checked once at construction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dbscan {
    eps_m: f64,
    min_samples: usize,
}

impl Dbscan {
    /// Checks the parameters.
    ///
    /// `eps_m` must be finite and `≥ 0` (0 groups only coincident points); `min_samples` must be
    /// `≥ 1`.
    pub fn new(eps_m: f64, min_samples: usize) -> Result<Self, SegmentError> {
        if !(eps_m.is_finite() && eps_m >= 0.0) {
            return Err(SegmentError::InvalidEps { eps_m });
        }
        if min_samples == 0 {
            return Err(SegmentError::ZeroMinSamples);
        }
        Ok(Self { eps_m, min_samples })
    }

    /// Neighbourhood radius, metres.
    pub fn eps_m(&self) -> f64 {
        self.eps_m
    }

    /// Minimum neighbourhood size (the point included) of a core point.
    pub fn min_samples(&self) -> usize {
        self.min_samples
    }

    /// Clusters `points` (x, y in metres) over a grid of ε-cells; see the module docs for the
    /// semantics.
    ///
    /// # Errors
    /// [`SegmentError::NonFinitePoint`] if any coordinate is NaN or infinite (checked before any work,
    /// so no partial result exists), [`SegmentError::TooManyPoints`] beyond `i32::MAX` points.
    pub fn fit(&self, points: &[[f64; 2]]) -> Result<Clustering, SegmentError> {
        check_points(points)?;
        if points.is_empty() {
            return Ok(Clustering::default());
        }
        let n = points.len();
        if self.min_samples > n {
            // No neighbourhood can be that large: all noise, and no query allocates a result
            // buffer of min_samples entries.
            return Ok(Clustering {
                labels: vec![NOISE; n],
                is_core: vec![false; n],
                cluster_count: 0,
            });
        }
        let index = CellIndex::new(points, self.eps_m);
        // Being core only needs min_samples neighbours, not all of them: the count stops there,
        // which keeps dense regions cheap. It includes the point itself (distance 0 ≤ eps²).
        let is_core = index.core_points(self.min_samples);
        let (labels, cluster_count) = index.expand_clusters(&is_core, NOISE);
        Ok(Clustering {
            labels,
            is_core,
            cluster_count,
        })
    }
}

/// Clusters `points`: `Dbscan::new(eps_m, min_samples)?.fit(points)`.
pub fn dbscan(
    points: &[[f64; 2]],
    eps_m: f64,
    min_samples: usize,
) -> Result<Clustering, SegmentError> {
    Dbscan::new(eps_m, min_samples)?.fit(points)
}

/// The O(n²) oracle: every pair compared, neighbour lists stored sorted by index, and the cluster
/// expansion written as scikit-learn's `dbscan_inner` (depth-first, labelling on pop).
///
/// Kept public so that tests and benchmarks elsewhere can compare against it; use [`dbscan`] for
/// real work.
pub fn dbscan_brute_force(
    points: &[[f64; 2]],
    eps_m: f64,
    min_samples: usize,
) -> Result<Clustering, SegmentError> {
    let params = Dbscan::new(eps_m, min_samples)?;
    check_points(points)?;
    let eps_sq = params.eps_m * params.eps_m;
    let n = points.len();
    let neighbourhoods: Vec<Vec<usize>> = (0..n)
        .map(|i| {
            (0..n)
                .filter(|&j| squared_distance(points[i], points[j]) <= eps_sq)
                .collect()
        })
        .collect();
    let is_core: Vec<bool> = neighbourhoods
        .iter()
        .map(|neighbourhood| neighbourhood.len() >= params.min_samples)
        .collect();

    let mut labels = vec![NOISE; n];
    let mut cluster = 0i32;
    let mut stack = Vec::new();
    for seed in 0..n {
        if labels[seed] != NOISE || !is_core[seed] {
            continue;
        }
        let mut i = seed;
        loop {
            if labels[i] == NOISE {
                labels[i] = cluster;
                if is_core[i] {
                    stack.extend(
                        neighbourhoods[i]
                            .iter()
                            .copied()
                            .filter(|&v| labels[v] == NOISE),
                    );
                }
            }
            match stack.pop() {
                Some(next) => i = next,
                None => break,
            }
        }
        cluster += 1;
    }
    Ok(Clustering {
        labels,
        is_core,
        cluster_count: cluster as usize,
    })
}

fn check_points(points: &[[f64; 2]]) -> Result<(), SegmentError> {
    // Labels are i32 (the Segments message's type); cluster numbers must fit.
    if points.len() > i32::MAX as usize {
        return Err(SegmentError::TooManyPoints {
            count: points.len(),
        });
    }
    match points
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        Some(index) => Err(SegmentError::NonFinitePoint {
            index,
            x_m: points[index][0],
            y_m: points[index][1],
        }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn both(points: &[[f64; 2]], eps_m: f64, min_samples: usize) -> Clustering {
        let fast = dbscan(points, eps_m, min_samples).unwrap();
        let slow = dbscan_brute_force(points, eps_m, min_samples).unwrap();
        assert_eq!(fast, slow, "grid and brute force disagree");
        fast
    }

    #[test]
    fn empty_input_gives_no_clusters() {
        let c = both(&[], 0.5, 4);
        assert!(c.labels.is_empty());
        assert_eq!(c.cluster_count, 0);
    }

    #[test]
    fn one_point_is_noise_unless_min_samples_is_one() {
        assert_eq!(both(&[[1.0, 2.0]], 0.5, 2).labels, vec![NOISE]);
        let c = both(&[[1.0, 2.0]], 0.5, 1);
        assert_eq!(c.labels, vec![0]);
        assert_eq!(c.cluster_count, 1);
    }

    #[test]
    fn identical_points_form_one_cluster_even_with_eps_zero() {
        // 100 coincident points: all in one cell, sharing every coordinate.
        let points = vec![[3.25, -1.5]; 100];
        for eps_m in [0.0, 0.5] {
            let c = both(&points, eps_m, 100);
            assert_eq!(c.cluster_count, 1);
            assert!(c.labels.iter().all(|&l| l == 0));
            // One more than the neighbourhood holds: all noise.
            let c = both(&points, eps_m, 101);
            assert_eq!(c.noise_count(), 100);
        }
    }

    #[test]
    fn eps_zero_groups_only_coincident_points() {
        let points = [[0.0, 0.0], [1e-12, 0.0], [0.0, 0.0], [5.0, 5.0], [5.0, 5.0]];
        let c = both(&points, 0.0, 2);
        assert_eq!(c.labels, vec![0, NOISE, 0, 1, 1]);
    }

    #[test]
    fn min_samples_one_makes_every_point_core() {
        let points = [[0.0, 0.0], [10.0, 0.0], [0.3, 0.0], [20.0, 0.0]];
        let c = both(&points, 0.5, 1);
        assert!(c.is_core.iter().all(|&core| core));
        assert_eq!(c.labels, vec![0, 1, 0, 2]);
    }

    #[test]
    fn distance_exactly_eps_is_a_neighbour() {
        // 0.5 and 0.25 are exact in binary, so the squared distance equals eps² exactly.
        let points = [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]];
        let c = both(&points, 0.5, 3);
        assert_eq!(c.is_core, vec![false, true, false]);
        assert_eq!(c.labels, vec![0, 0, 0]);
        let c = both(&points, 0.499_999, 2);
        assert_eq!(c.labels, vec![NOISE; 3]);
    }

    #[test]
    fn border_point_joins_the_first_cluster_to_reach_it() {
        // Two dense groups whose edges are 1.0 apart, and a border point midway that is within eps of
        // a core point of each. Group B comes first in the input, so it is cluster 0 and wins the
        // border point although group A's seed point reaches it along a shorter path.
        let mut points = vec![
            [2.0, 0.0],
            [2.1, 0.0],
            [2.2, 0.0],
            [2.0, 0.1], // group B, core at (2.0, 0.0)
            [1.0, 0.0], // border point
            [0.0, 0.0],
            [-0.1, 0.0],
            [-0.2, 0.0],
            [0.0, 0.1], // group A, core at (0.0, 0.0)
        ];
        let c = both(&points, 1.0, 4);
        assert!(!c.is_core[4]);
        assert_eq!(c.labels[4], 0);
        assert_eq!(c.labels[5], 1);
        // Swap the groups' order: the border point follows.
        points.rotate_left(5);
        let c = both(&points, 1.0, 4);
        assert_eq!(c.labels[0], 0);
        assert_eq!(c.labels[8], 0, "border point now goes to group A");
    }

    #[test]
    fn clusters_are_numbered_by_first_core_point_index() {
        // A noise point first, then a point of cluster "far", then cluster "near".
        let points = [
            [100.0, 100.0],
            [10.0, 0.0],
            [0.0, 0.0],
            [0.1, 0.0],
            [10.1, 0.0],
        ];
        let c = both(&points, 0.2, 2);
        assert_eq!(c.labels, vec![NOISE, 0, 1, 1, 0]);
        assert_eq!(c.cluster_sizes(), vec![2, 2]);
        assert_eq!(c.noise_count(), 1);
    }

    #[test]
    fn min_samples_above_the_point_count_gives_all_noise_without_allocating_it() {
        let points = [[0.0, 0.0], [0.0, 0.0], [0.1, 0.0]];
        let c = both(&points, 1.0, 4);
        assert_eq!(c.labels, vec![NOISE; 3]);
        // A buffer of usize::MAX / 2 entries would abort the process.
        let c = dbscan(&points, 1.0, usize::MAX / 2).unwrap();
        assert_eq!(c.noise_count(), 3);
    }

    #[test]
    fn non_finite_coordinates_are_refused() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let points = [[0.0, 0.0], [1.0, bad]];
            for result in [dbscan(&points, 0.5, 2), dbscan_brute_force(&points, 0.5, 2)] {
                match result {
                    Err(SegmentError::NonFinitePoint { index: 1, .. }) => {}
                    other => panic!("expected NonFinitePoint, got {other:?}"),
                }
            }
        }
    }

    #[test]
    fn invalid_parameters_are_refused() {
        for eps_m in [-0.1, f64::NAN, f64::INFINITY] {
            assert!(matches!(
                Dbscan::new(eps_m, 4),
                Err(SegmentError::InvalidEps { .. })
            ));
        }
        assert_eq!(Dbscan::new(0.5, 0), Err(SegmentError::ZeroMinSamples));
    }

    #[test]
    fn huge_but_finite_coordinates_do_not_break_the_grid() {
        // Differences overflow to infinity, which is never ≤ eps²: these points are each other's
        // strangers, but each is its own neighbour.
        let points = [[f64::MAX, 0.0], [-f64::MAX, 0.0], [f64::MAX, 0.0]];
        let c = both(&points, 1.0, 2);
        assert_eq!(c.labels, vec![0, NOISE, 0]);
    }
}
