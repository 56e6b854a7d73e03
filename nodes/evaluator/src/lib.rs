//! Metrics of nrslam: GOSPA and ET-GOPSA, the exact assignment behind them, the estimate points
//! taken from a segmented map, CSV input for `nrslam metric`, and the evaluator node.
//!
//! The paper (Sec. IV-B) scores the SLAM map against the true extended targets with ET-GOPSA, its
//! extension of GOSPA; docs/design.md ("Metrics") states the well-posed form implemented here.
//!
//! - [`assignment`]: exact rectangular linear sum assignment (shortest augmenting path, O(n²m))
//!   and bottleneck matching (for p = ∞);
//! - [`gospa`](mod@gospa): GOSPA of two point sets with its α = 2 decomposition; both metrics
//!   split the assignment into the connected components of the pairs closer than c (a uniform
//!   grid of c-sized cells finds them) and solve each component exactly, so points spread far
//!   wider than c cost about linear time and memory (100 000 × 100 000 points in well under a
//!   second) while the result is that of the dense assignment over all pairs
//!   ([`gospa_dense`], [`etgospa_dense`]);
//! - [`etgospa`](mod@etgospa): ET-GOPSA of extended targets and estimate points, with its
//!   localisation / confusion / missed / false decomposition;
//! - [`representatives`](mod@representatives): the points of each map cluster ET-GOPSA scores:
//!   the 4 corners of its principal-axis box (the default) or k farthest-point samples;
//! - [`csv_io`]: both metrics from user CSV files;
//! - [`Params`]: the evaluator node's parameters; [`node`]: the node itself ([`build`]).
//!
//! Every function refuses NaN or infinite input with an error; none panics on user data.
//!
//! ```
//! use nrslam_evaluator::{etgospa, gospa, EtGospaParams, ExtendedTarget, Point2};
//! let target = ExtendedTarget::from_samples(vec![Point2::new(0.0, 0.0), Point2::new(1.0, 0.0)]);
//! let estimates = [Point2::new(0.0, 0.5)];
//! let params = EtGospaParams::default(); // c = 5, p = 1, α = 2 (Table I)
//! let r = etgospa(&[target.clone()], &estimates, &params).unwrap();
//! // One slot filled at 0.5 m, one slot missed at c^p/2 = 2.5; a lone target confuses nothing.
//! assert_eq!((r.localisation, r.confusion, r.missed, r.false_estimates), (0.5, 0.0, 2.5, 0.0));
//! assert_eq!(r.total, 3.0);
//! // With one target, ET-GOPSA equals GOSPA of its sample points.
//! assert_eq!(gospa(&target.samples, &estimates, &params.gospa()).unwrap().total, 3.0);
//! ```
#![warn(missing_docs)]

pub mod assignment;
pub mod csv_io;
mod error;
pub mod etgospa;
pub mod gospa;
mod inputs;
pub mod node;
mod params;
mod point;
pub mod representatives;
mod sparse;
mod unassigned;

pub use csv_io::{
    evaluate, evaluate_files, EvaluatorError, MetricParams, MetricReport, TruthTarget,
};
pub use error::{InvalidMetricParam, MetricError};
pub use etgospa::{
    etgospa, etgospa_dense, etgospa_sparse, DistanceMode, EtGospaParams, EtGospaResult,
    ExtendedTarget,
};
pub use gospa::{gospa, gospa_dense, gospa_sparse, GospaParams, GospaResult};
pub use node::{build, extended_targets, segment_representatives, shape_samples, EvaluatorNode};
pub use params::Params;
pub use point::{distance_to_outline_m, Point2};
pub use representatives::{
    box_corners, flatten, representatives, representatives_with, ClusterRepresentatives,
    RepresentativeMode, RepresentativesError,
};

/// A node parameter outside its allowed range (the runtime's shared type).
pub use nrslam_runtime::InvalidParam;
