//! Both metrics against brute-force enumeration of their definitions, and their metric properties,
//! on random small sets (proptest).

mod common;

use common::{
    close, etgospa_oracle, gospa_fusion2017, gospa_oracle, strategies, strategies::p_value,
};
use nrslam_evaluator::{
    etgospa, gospa, DistanceMode, EtGospaParams, ExtendedTarget, GospaParams, Point2,
};
use proptest::prelude::*;

/// Points either continuous or on a coarse integer grid (the grid makes equal distances, ties in
/// the assignment and distances exactly equal to c frequent).
fn point() -> impl Strategy<Value = Point2> {
    prop_oneof![
        (-6.0..6.0f64, -6.0..6.0f64).prop_map(|(x, y)| Point2::new(x, y)),
        (-3i32..=3, -3i32..=3).prop_map(|(x, y)| Point2::new(f64::from(x), f64::from(y))),
    ]
}

fn points(max: usize) -> impl Strategy<Value = Vec<Point2>> {
    prop::collection::vec(point(), 0..=max)
}

fn gospa_params() -> impl Strategy<Value = GospaParams> {
    (
        prop_oneof![Just(2.0), 0.5..5.0f64],
        p_value(),
        prop_oneof![Just(2.0), 0.05..2.0f64],
    )
        .prop_map(|(c, p, alpha)| GospaParams { c, p, alpha })
}

fn target() -> impl Strategy<Value = ExtendedTarget> {
    strategies::target(point, 3, 3)
}

/// Targets whose total slot count stays small enough to enumerate.
fn targets() -> impl Strategy<Value = Vec<ExtendedTarget>> {
    prop::collection::vec(target(), 0..=3).prop_filter("at most 7 slots", |ts| {
        ts.iter().map(|t| t.slots).sum::<usize>() <= 7
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn gospa_equals_enumeration(x in points(5), y in points(5), params in gospa_params()) {
        let r = gospa(&x, &y, &params).unwrap();
        let oracle = gospa_oracle(&x, &y, &params);
        prop_assert!(close(r.total, oracle, 1e-9), "solver {} oracle {oracle}", r.total);
    }

    #[test]
    fn gospa_equals_the_fusion2017_definition_for_every_alpha(
        x in points(5), y in points(5), params in gospa_params()
    ) {
        prop_assume!(params.p.is_finite());
        let r = gospa(&x, &y, &params).unwrap();
        let fusion = gospa_fusion2017(&x, &y, &params);
        prop_assert!(close(r.total, fusion, 1e-9), "solver {} FUSION 2017 {fusion}", r.total);
    }

    #[test]
    fn gospa_decomposition_adds_up(x in points(6), y in points(6), params in gospa_params()) {
        let r = gospa(&x, &y, &params).unwrap();
        prop_assert_eq!(r.assigned_count, r.pairs.len());
        prop_assert_eq!(r.missed_count, x.len() - r.assigned_count);
        prop_assert_eq!(r.false_count, y.len() - r.assigned_count);
        if params.p.is_finite() {
            let unit = params.c.powf(params.p) / params.alpha;
            prop_assert!(close(r.missed, unit * r.missed_count as f64, 1e-12));
            prop_assert!(close(r.false_estimates, unit * r.false_count as f64, 1e-12));
            let loc: f64 = r.pairs.iter()
                .map(|&(i, j)| x[i].distance_m(&y[j]).min(params.c).powf(params.p))
                .sum();
            prop_assert!(close(r.localisation, loc, 1e-12));
            let sum = r.localisation + r.missed + r.false_estimates;
            prop_assert!(close(r.total, sum.powf(1.0 / params.p), 1e-12));
            if params.alpha == 2.0 {
                // α = 2: only pairs closer than c are assigned.
                for &(i, j) in &r.pairs {
                    prop_assert!(x[i].distance_m(&y[j]) < params.c);
                }
            }
        } else {
            prop_assert_eq!(r.total, r.localisation.max(r.missed).max(r.false_estimates));
            for &(i, j) in &r.pairs {
                prop_assert!(x[i].distance_m(&y[j]) <= r.localisation);
            }
        }
    }

    #[test]
    fn gospa_is_nonnegative_and_symmetric(x in points(6), y in points(6), params in gospa_params()) {
        let xy = gospa(&x, &y, &params).unwrap();
        let yx = gospa(&y, &x, &params).unwrap();
        prop_assert!(xy.total >= 0.0);
        prop_assert!(close(xy.total, yx.total, 1e-9), "{} vs {}", xy.total, yx.total);
        prop_assert_eq!(xy.missed_count, yx.false_count);
        prop_assert_eq!(xy.false_count, yx.missed_count);
        // Identity of indiscernibles: d(X, X) = 0.
        prop_assert_eq!(gospa(&x, &x, &params).unwrap().total, 0.0);
    }

    #[test]
    fn gospa_triangle_inequality(
        x in points(5), y in points(5), z in points(5), params in gospa_params()
    ) {
        let xz = gospa(&x, &z, &params).unwrap().total;
        let xy = gospa(&x, &y, &params).unwrap().total;
        let yz = gospa(&y, &z, &params).unwrap().total;
        prop_assert!(xz <= xy + yz + 1e-9 * (1.0 + xz), "d(X,Z) {xz} > d(X,Y) {xy} + d(Y,Z) {yz}");
    }

    #[test]
    fn etgospa_equals_enumeration(ts in targets(), y in points(4), params in strategies::etgospa_params(gospa_params())) {
        let r = etgospa(&ts, &y, &params).unwrap();
        let oracle = etgospa_oracle(&ts, &y, &params);
        prop_assert!(close(r.total, oracle, 1e-9), "solver {} oracle {oracle}", r.total);
        prop_assert!(r.total >= 0.0);
    }

    #[test]
    fn etgospa_decomposition_adds_up(ts in targets(), y in points(6), params in strategies::etgospa_params(gospa_params())) {
        let r = etgospa(&ts, &y, &params).unwrap();
        let slots: usize = ts.iter().map(|t| t.slots).sum();
        prop_assert_eq!(r.slot_count, slots);
        prop_assert_eq!(r.assigned_count, r.pairs.len());
        prop_assert_eq!(r.missed_count, slots - r.assigned_count);
        prop_assert_eq!(r.false_count, y.len() - r.assigned_count);
        // Each estimate fills at most one slot; each target at most its slots.
        let mut estimates: Vec<usize> = r.pairs.iter().map(|p| p.1).collect();
        estimates.sort_unstable();
        estimates.dedup();
        prop_assert_eq!(estimates.len(), r.pairs.len());
        for (i, t) in ts.iter().enumerate() {
            prop_assert!(r.pairs.iter().filter(|p| p.0 == i).count() <= t.slots);
        }
        prop_assert!(r.localisation >= 0.0 && r.confusion >= 0.0);
        if params.p.is_finite() {
            let unit = params.c.powf(params.p) / params.alpha;
            prop_assert!(close(r.missed, unit * r.missed_count as f64, 1e-12));
            prop_assert!(close(r.false_estimates, unit * r.false_count as f64, 1e-12));
            let loc: f64 = r.pairs.iter()
                .map(|&(i, j)| common::base_distance(&ts[i], &y[j], &params).min(params.c).powf(params.p))
                .sum();
            prop_assert!(close(r.localisation, loc, 1e-9));
            let sum = r.localisation + r.confusion + r.missed + r.false_estimates;
            prop_assert!(close(r.total, sum.powf(1.0 / params.p), 1e-12));
        } else {
            prop_assert_eq!(r.confusion, 0.0);
            prop_assert_eq!(r.total, r.localisation.max(r.missed).max(r.false_estimates));
        }
    }

    /// docs/design.md: with α = 2, one slot per target and no estimate within c of more than one
    /// target, ET-GOPSA is GOSPA of the targets' points — exactly, to the last bit.
    #[test]
    fn etgospa_reduces_to_gospa(
        c in 0.5..3.0f64,
        p in p_value(),
        grid in prop::collection::vec(any::<bool>(), 9),
        raw in prop::collection::vec((0.0..1.0f64, 0.0..1.0f64), 0..8),
    ) {
        // Targets on a grid spaced more than 2c apart: no point is within c of two of them.
        let spacing = 2.0 * c + 0.01;
        let truth: Vec<Point2> = grid.iter().enumerate().filter(|(_, &on)| on)
            .map(|(k, _)| Point2::new((k % 3) as f64 * spacing, (k / 3) as f64 * spacing))
            .collect();
        let extent = 2.0 * spacing + 2.0 * c;
        let estimates: Vec<Point2> = raw.iter()
            .map(|&(u, v)| Point2::new(u * extent - c, v * extent - c))
            .collect();
        let targets: Vec<ExtendedTarget> =
            truth.iter().map(|&t| ExtendedTarget::from_samples(vec![t])).collect();
        let params = EtGospaParams { c, p, alpha: 2.0, ..EtGospaParams::default() };
        let et = etgospa(&targets, &estimates, &params).unwrap();
        let g = gospa(&truth, &estimates, &params.gospa()).unwrap();
        prop_assert_eq!(et.total, g.total);
        prop_assert_eq!(et.localisation, g.localisation);
        prop_assert_eq!(et.confusion, 0.0);
        prop_assert_eq!(et.missed, g.missed);
        prop_assert_eq!(et.false_estimates, g.false_estimates);
        prop_assert_eq!(et.pairs, g.pairs);
    }
}

/// p = ∞ is the limit p → ∞: on a scene with one clearly best assignment, the finite-p values
/// approach the p = ∞ value (c = 1 m keeps c^p = 1 for every p).
#[test]
fn infinite_p_is_the_limit() {
    let square = |x0: f64| {
        let v = vec![
            Point2::new(x0, 0.0),
            Point2::new(x0 + 0.5, 0.0),
            Point2::new(x0 + 0.5, 0.5),
            Point2::new(x0, 0.5),
        ];
        ExtendedTarget::from_samples(v.clone()).with_outline(v)
    };
    let targets = [square(0.0), square(1.2)];
    // Four estimates 0.1–0.3 m from target 0's corners, four near target 1's, one stray.
    let estimates: Vec<Point2> = [
        (-0.1, 0.0),
        (0.5, -0.2),
        (0.7, 0.5),
        (0.0, 0.8),
        (1.1, 0.0),
        (1.7, -0.1),
        (1.9, 0.5),
        (1.2, 0.7),
        (5.0, 5.0),
    ]
    .iter()
    .map(|&(x, y)| Point2::new(x, y))
    .collect();
    let truth: Vec<Point2> = targets.iter().flat_map(|t| t.samples.clone()).collect();
    for distance in [DistanceMode::Samples, DistanceMode::Outline] {
        let at = |p: f64| {
            let params = EtGospaParams {
                c: 1.0,
                p,
                alpha: 2.0,
                distance,
                squared_distance: false,
            };
            let et = etgospa(&targets, &estimates, &params).unwrap().total;
            let g = gospa(&truth, &estimates, &params.gospa()).unwrap().total;
            (et, g)
        };
        let (et_inf, g_inf) = at(f64::INFINITY);
        let mut previous = (f64::INFINITY, f64::INFINITY);
        for p in [4.0, 16.0, 64.0, 256.0] {
            let (et, g) = at(p);
            let gaps = ((et - et_inf).abs(), (g - g_inf).abs());
            assert!(
                gaps.0 < previous.0 && gaps.1 < previous.1,
                "{distance:?} p = {p}: {gaps:?}"
            );
            previous = gaps;
        }
        assert!(
            previous.0 < 0.02 && previous.1 < 0.02,
            "{distance:?}: {previous:?}"
        );
    }
}

/// Huge p with distances below 1: the p-th powers underflow, the total must not.
#[test]
fn huge_p_does_not_underflow_the_total() {
    let params = GospaParams {
        c: 1.0,
        p: 2000.0,
        alpha: 2.0,
    };
    let r = gospa(&[Point2::new(0.0, 0.0)], &[Point2::new(0.4, 0.0)], &params).unwrap();
    assert_eq!(
        r.localisation, 0.0,
        "0.4^2000 underflows in the p-th-power part"
    );
    assert!((r.total - 0.4).abs() < 1e-12, "total {}", r.total);
    let target = ExtendedTarget::from_samples(vec![Point2::new(0.0, 0.0)]);
    let other = ExtendedTarget::from_samples(vec![Point2::new(1.3, 0.0)]);
    let et = EtGospaParams {
        c: 1.0,
        p: 2000.0,
        ..EtGospaParams::default()
    };
    // 0.4 m from its target, 0.9 m from the other: confusion base (1 − 0.9^2000)^{1/2000} ≈ 1.
    let r = etgospa(&[target, other], &[Point2::new(0.4, 0.0)], &et).unwrap();
    // One pair (its confusion term dominates) and one missed slot, c·2^{-1/2000}.
    let expected = (1.0f64 + 0.5).powf(1.0 / 2000.0);
    assert!(
        (r.total - expected).abs() < 1e-9,
        "total {} expected {expected}",
        r.total
    );
}
