//! Segmentation of the occupancy map into extended targets with DBSCAN.
//!
//! The paper (Sec. IV-A, Fig. 3 right) recognises the extended targets in the SLAM map with DBSCAN
//! \[DBSCAN\]: the map's occupied points are clustered, each cluster being one target, and the
//! clusters feed ET-GOPSA (Sec. IV-B). In nrslam this crate is that stage:
//!
//! - [`dbscan`](mod@dbscan): DBSCAN with scikit-learn's semantics on a grid of ε-cells, and an O(n²) oracle
//!   [`dbscan_brute_force`] it is tested against;
//! - [`grid`]: the centres of the occupied cells of an occupancy grid, the points to cluster;
//! - [`Params`]: the node's parameters (`eps_m`, `min_samples`, `occupied_threshold`);
//! - [`node`]: the adapter that turns each `/map` into `/map/segments` ([`build`], [`SegmenterNode`]).
//!
//! ```
//! use nrslam_segmenter::{dbscan, NOISE};
//! // Two tight pairs and one stray point.
//! let points = [[0.0, 0.0], [0.1, 0.0], [5.0, 5.0], [5.0, 5.1], [9.0, 0.0]];
//! let clustering = dbscan(&points, 0.5, 2).unwrap();
//! assert_eq!(clustering.labels, vec![0, 0, 1, 1, NOISE]);
//! assert_eq!(clustering.cluster_count, 2);
//! ```
#![warn(missing_docs)]

mod cells;
pub mod dbscan;
pub mod grid;
pub mod node;
mod params;

pub use dbscan::{dbscan, dbscan_brute_force, Clustering, Dbscan, NOISE};
pub use grid::{occupied_cell_centres, GridGeometry};
pub use node::{build, SegmenterNode};
pub use params::Params;

/// Why segmentation refused its input or parameters.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SegmentError {
    /// A point has a NaN or infinite coordinate; DBSCAN's neighbourhoods are undefined for it.
    #[error("point {index} has a non-finite coordinate ({x_m}, {y_m})")]
    NonFinitePoint {
        /// Index of the first offending point.
        index: usize,
        /// Its x, metres.
        x_m: f64,
        /// Its y, metres.
        y_m: f64,
    },
    /// The neighbourhood radius is negative, NaN or infinite.
    #[error("eps_m must be finite and >= 0, got {eps_m}")]
    InvalidEps {
        /// The value given, metres.
        eps_m: f64,
    },
    /// `min_samples` is 0; a neighbourhood always holds the point itself, so use 1 for "every point
    /// is a core point".
    #[error("min_samples must be >= 1, got 0")]
    ZeroMinSamples,
    /// More points than `i32` labels can number.
    #[error("{count} points exceed the i32 label range")]
    TooManyPoints {
        /// Number of points given.
        count: usize,
    },
    /// The occupancy grid's metadata does not describe its data.
    #[error("invalid occupancy grid: {reason}")]
    InvalidGridGeometry {
        /// What is wrong.
        reason: String,
    },
}
