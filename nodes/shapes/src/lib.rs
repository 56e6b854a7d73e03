//! Extended targets as shapes: a rectangle (any yaw) or a circle fitted to each segment of the
//! occupancy map, with an honest covariance, and a tracker that keeps the targets' identities
//! across map updates.
//!
//! The paper "Simultaneous Localization and Mapping of Multiple Extended Targets with 5G OFDM
//! sensing" segments its SLAM map with DBSCAN and scores the clusters with ET-GOPSA, 4 sample
//! points per target. nrslam goes one step further (issue 16): each cluster of occupied-cell
//! centres is one extended target, truly a rectangle or a circle, and this crate estimates which
//! and its parameters:
//!
//! - [`fit()`] / [`fit_candidates`]: a rectangle with partial visibility (one to four sides seen,
//!   the least-squares generalisation of the L-shape fit of Zhang et al. 2017; module
//!   [`rectangle`](mod@rectangle)) and a geometric circle (Kåsa start, Levenberg–Marquardt; module
//!   [`circle`](mod@circle)), chosen by BIC (module [`fit`](mod@fit));
//! - [`FittedShape`]: centre, size, yaw or radius, covariance, the ET-GOPSA samples and outline;
//! - [`ShapeTracker`]: ids stable across map updates (module [`tracker`](mod@tracker));
//! - [`evaluate()`] and [`match_to_truth`]: errors against the true shapes (IoU, centre, size, yaw,
//!   kind, centre NEES), for the evaluator and the Monte Carlo studies;
//! - [`geometry`]: convex clipping, areas, [`convex_polygon_iou`];
//! - [`Params`]: the parameters, with `validate()`.
//!
//! Everything is plain computation: no zenoh, no I/O; every input is checked (non-finite points
//! and degenerate segments give a [`FitError`], never NaN or a panic).
//!
//! ```
//! use nrslam_shapes::{fit, Params, ShapeKind};
//! // Two sides of a 2 m × 1 m box seen from the south-west: an L.
//! let mut points = Vec::new();
//! for k in 0..=20 { points.push([k as f64 * 0.1, 0.0]); }
//! for k in 1..=10 { points.push([0.0, k as f64 * 0.1]); }
//! let shape = fit(&points, &[[-5.0, -5.0]], &Params::default()).unwrap();
//! assert_eq!(shape.kind, ShapeKind::Rectangle);
//! assert_eq!(shape.sides_seen, 2);
//! assert!((shape.center_m[0] - 1.0).abs() < 0.1 && (shape.center_m[1] - 0.5).abs() < 0.1);
//! ```
#![warn(missing_docs)]

pub mod circle;
pub mod evaluate;
pub mod fit;
pub mod geometry;
pub mod node;
mod params;
pub mod pose_uncertainty;
pub mod rectangle;
pub mod shape;
pub mod tracker;

#[cfg(test)]
mod calibration_tests;
#[cfg(test)]
mod synthetic;

pub use evaluate::{evaluate, match_to_truth, ShapeErrors, TruthShape};
pub use fit::{fit, fit_candidates, Candidates, FitError};
pub use geometry::convex_polygon_iou;
pub use node::{build, ShapesNode};
pub use params::Params;
pub use shape::{FittedShape, ShapeKind};
pub use tracker::{ShapeTracker, TrackedTarget};
