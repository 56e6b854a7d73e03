//! Property-test generators shared by the oracle and sparse-solver tests; each test file brings
//! its own point distribution and sizes.

use nrslam_evaluator::{DistanceMode, EtGospaParams, ExtendedTarget, GospaParams, Point2};
use proptest::prelude::*;

/// p = 1, 2, a continuous 1 ≤ p < 4, or ∞.
pub fn p_value() -> impl Strategy<Value = f64> {
    prop_oneof![Just(1.0), Just(2.0), 1.0..4.0f64, Just(f64::INFINITY)]
}

/// ET-GOPSA parameters: c, p and α from `gospa`, either distance mode, squared or not.
pub fn etgospa_params(
    gospa: impl Strategy<Value = GospaParams>,
) -> impl Strategy<Value = EtGospaParams> {
    (
        gospa,
        prop_oneof![Just(DistanceMode::Samples), Just(DistanceMode::Outline)],
        any::<bool>(),
    )
        .prop_map(|(g, distance, squared_distance)| EtGospaParams {
            c: g.c,
            p: g.p,
            alpha: g.alpha,
            distance,
            squared_distance,
        })
}

/// A target of 1 to `max_samples` samples from `point` and an outline of 1 to 4 vertices, with
/// the default slots (one per sample) or 0 to `max_slots`.
pub fn target<S: Strategy<Value = Point2>>(
    point: impl Fn() -> S,
    max_samples: usize,
    max_slots: usize,
) -> impl Strategy<Value = ExtendedTarget> {
    (
        prop::collection::vec(point(), 1..=max_samples),
        prop::collection::vec(point(), 1..=4),
        prop::option::of(0usize..=max_slots),
    )
        .prop_map(|(samples, outline, slots)| {
            let t = ExtendedTarget::from_samples(samples).with_outline(outline);
            match slots {
                Some(s) => t.with_slots(s),
                None => t,
            }
        })
}
