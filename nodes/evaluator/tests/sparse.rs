//! The component (sparse) solvers of both metrics against the dense solver and against
//! brute-force enumeration of the definitions, on random cases built to be hard for the split:
//! clustered points (large components), coincident points, points exactly at the cut-off
//! distance (integer grids with integer c), far-apart clusters (many components), empty sets.

mod common;

use common::{
    close, etgospa_oracle, gospa_oracle, scatter::scatter, strategies, strategies::p_value,
};
use nrslam_evaluator::{
    etgospa, etgospa_dense, etgospa_sparse, gospa, gospa_dense, gospa_sparse, EtGospaParams,
    EtGospaResult, ExtendedTarget, GospaParams, GospaResult, Point2,
};
use proptest::prelude::*;

/// A point: continuous, on an integer grid (coincident points, distances exactly c), or near one
/// of a few cluster centres spread far apart (several components, each a cluster).
fn point() -> impl Strategy<Value = Point2> {
    prop_oneof![
        (-12.0..12.0f64, -12.0..12.0f64).prop_map(|(x, y)| Point2::new(x, y)),
        (-4i32..=4, -4i32..=4).prop_map(|(x, y)| Point2::new(f64::from(x), f64::from(y))),
        (0usize..4, -1.5..1.5f64, -1.5..1.5f64).prop_map(|(k, dx, dy)| {
            let centre = [(0.0, 0.0), (30.0, 0.0), (0.0, -40.0), (31.0, 2.0)][k];
            Point2::new(centre.0 + dx, centre.1 + dy)
        }),
    ]
}

fn points(max: usize) -> impl Strategy<Value = Vec<Point2>> {
    prop::collection::vec(point(), 0..=max)
}

/// c = 1, 2, 3 (integers: grid points exactly c apart) or continuous; α = 2 (the paper) or any.
fn gospa_params() -> impl Strategy<Value = GospaParams> {
    (
        prop_oneof![Just(1.0), Just(2.0), Just(3.0), 0.5..5.0f64],
        p_value(),
        prop_oneof![3 => Just(2.0), 1 => 0.05..2.0f64],
    )
        .prop_map(|(c, p, alpha)| GospaParams { c, p, alpha })
}

fn target() -> impl Strategy<Value = ExtendedTarget> {
    strategies::target(point, 4, 4)
}

/// The same optimum: equal totals, and (p < ∞) equal p-th-power parts, to 1e-9 relative.
fn check_gospa(sparse: &GospaResult, dense: &GospaResult, x: &[Point2], y: &[Point2]) {
    assert!(
        close(sparse.total, dense.total, 1e-9),
        "total: sparse {} dense {} ({x:?} {y:?})",
        sparse.total,
        dense.total
    );
    let parts = |r: &GospaResult| r.localisation + r.missed + r.false_estimates;
    assert!(close(parts(sparse), parts(dense), 1e-9));
    assert_eq!(sparse.assigned_count, sparse.pairs.len());
    assert_eq!(sparse.missed_count, x.len() - sparse.assigned_count);
    assert_eq!(sparse.false_count, y.len() - sparse.assigned_count);
}

fn check_etgospa(sparse: &EtGospaResult, dense: &EtGospaResult) {
    assert!(
        close(sparse.total, dense.total, 1e-9),
        "total: sparse {} dense {}",
        sparse.total,
        dense.total
    );
    let parts = |r: &EtGospaResult| r.localisation + r.confusion + r.missed + r.false_estimates;
    assert!(close(parts(sparse), parts(dense), 1e-9));
    assert_eq!(sparse.slot_count, dense.slot_count);
    assert_eq!(sparse.assigned_count, sparse.pairs.len());
}

/// The decomposition is that of one optimal assignment; when several optimal assignments differ in
/// their number of pairs (exact ties, only on grids and coincident points) the parts may differ
/// between solvers, so they are compared where the points are in general position.
fn general_position(x: &[Point2], y: &[Point2]) -> bool {
    let fractional = |v: f64| v.fract() != 0.0;
    let all: Vec<&Point2> = x.iter().chain(y).collect();
    all.iter().all(|p| fractional(p.x_m) && fractional(p.y_m))
        && (0..all.len()).all(|a| (a + 1..all.len()).all(|b| all[a] != all[b]))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 600, ..ProptestConfig::default() })]

    #[test]
    fn gospa_sparse_equals_dense(x in points(40), y in points(40), params in gospa_params()) {
        let sparse = gospa_sparse(&x, &y, &params).unwrap();
        let dense = gospa_dense(&x, &y, &params).unwrap();
        check_gospa(&sparse, &dense, &x, &y);
        let public = gospa(&x, &y, &params).unwrap();
        check_gospa(&public, &dense, &x, &y);
        if general_position(&x, &y) {
            let tol = 1e-9;
            prop_assert!(close(sparse.localisation, dense.localisation, tol));
            prop_assert!(close(sparse.missed, dense.missed, tol));
            prop_assert!(close(sparse.false_estimates, dense.false_estimates, tol));
            prop_assert_eq!(sparse.assigned_count, dense.assigned_count);
        }
    }

    #[test]
    fn gospa_sparse_equals_enumeration(x in points(5), y in points(5), params in gospa_params()) {
        let sparse = gospa_sparse(&x, &y, &params).unwrap();
        let oracle = gospa_oracle(&x, &y, &params);
        prop_assert!(close(sparse.total, oracle, 1e-9), "sparse {} oracle {oracle}", sparse.total);
    }

    #[test]
    fn etgospa_sparse_equals_dense(
        ts in prop::collection::vec(target(), 0..=8),
        y in points(30),
        params in strategies::etgospa_params(gospa_params()),
    ) {
        let sparse = etgospa_sparse(&ts, &y, &params).unwrap();
        let dense = etgospa_dense(&ts, &y, &params).unwrap();
        check_etgospa(&sparse, &dense);
        let public = etgospa(&ts, &y, &params).unwrap();
        check_etgospa(&public, &dense);
        let truth: Vec<Point2> = ts.iter().flat_map(|t| t.samples.iter().copied()).collect();
        if general_position(&truth, &y) {
            let tol = 1e-9;
            prop_assert!(close(sparse.localisation, dense.localisation, tol));
            prop_assert!(close(sparse.confusion, dense.confusion, tol));
            prop_assert!(close(sparse.missed, dense.missed, tol));
            prop_assert!(close(sparse.false_estimates, dense.false_estimates, tol));
            prop_assert_eq!(sparse.assigned_count, dense.assigned_count);
        }
    }

    #[test]
    fn etgospa_sparse_equals_enumeration(
        ts in prop::collection::vec(target(), 0..=3)
            .prop_filter("at most 7 slots", |ts| ts.iter().map(|t| t.slots).sum::<usize>() <= 7),
        y in points(4),
        params in strategies::etgospa_params(gospa_params()),
    ) {
        let sparse = etgospa_sparse(&ts, &y, &params).unwrap();
        let oracle = etgospa_oracle(&ts, &y, &params);
        prop_assert!(close(sparse.total, oracle, 1e-9), "sparse {} oracle {oracle}", sparse.total);
    }
}

#[test]
fn large_spread_sets_equal_the_dense_solver() {
    for (n, extent, seed) in [(1000, 300.0, 1), (2000, 300.0, 2), (1500, 60.0, 3)] {
        let x = scatter(n, extent, seed);
        let y = scatter(n, extent, seed + 100);
        for p in [1.0, 2.0, f64::INFINITY] {
            for alpha in [2.0, 1.0] {
                let params = GospaParams { c: 5.0, p, alpha };
                let sparse = gospa_sparse(&x, &y, &params).unwrap();
                let dense = gospa_dense(&x, &y, &params).unwrap();
                check_gospa(&sparse, &dense, &x, &y);
                let tol = 1e-9;
                assert!(close(sparse.localisation, dense.localisation, tol));
                assert_eq!(sparse.missed_count, dense.missed_count);
            }
        }
        // ET-GOPSA: targets of 4 samples within 1 m.
        let targets: Vec<ExtendedTarget> = x
            .chunks(4)
            .map(|c| {
                let o = c[0];
                ExtendedTarget::from_samples(
                    c.iter()
                        .map(|p| Point2::new(o.x_m + p.x_m / extent, o.y_m + p.y_m / extent))
                        .collect(),
                )
            })
            .collect();
        for p in [1.0, 2.0, f64::INFINITY] {
            let params = EtGospaParams {
                c: 5.0,
                p,
                ..EtGospaParams::default()
            };
            let sparse = etgospa_sparse(&targets, &y, &params).unwrap();
            let dense = etgospa_dense(&targets, &y, &params).unwrap();
            check_etgospa(&sparse, &dense);
        }
    }
}

#[test]
fn a_hundred_thousand_spread_points_are_scored_past_the_dense_limit() {
    // 1e5 × 1e5 = 1e10 cells, far past the dense limit; the components are small.
    let x = scatter(100_000, 3000.0, 7);
    let y = scatter(100_000, 3000.0, 8);
    let params = GospaParams::default();
    assert!(gospa_dense(&x, &y, &params).is_err());
    let r = gospa(&x, &y, &params).unwrap();
    assert_eq!(r.missed_count + r.assigned_count, 100_000);
    assert!(r.assigned_count > 10_000 && r.assigned_count < 90_000);
}

#[test]
fn one_component_past_the_dense_limit_is_still_refused() {
    // 9000 × 9000 points within 1 m of each other: one component of 8.1e7 > 2^26 cells.
    let x = scatter(9000, 1.0, 11);
    let y = scatter(9000, 1.0, 12);
    let e = gospa(&x, &y, &GospaParams::default()).unwrap_err();
    assert!(e.is_too_large());
    assert_eq!(
        e.to_string(),
        "scoring 9000 truth points or slots against 9000 estimates: 9000 × 9000 of them are \
         linked by pairs closer than c, and their dense assignment of 9000 × 9000 = 81000000 \
         cells is more than the limit of 67108864 cells (512 MiB); score fewer points or use a \
         smaller c"
    );
    // The same points with far-away ones added: the error names the component and the input.
    let mut far_x = x.clone();
    far_x.extend(
        scatter(20_000, 3000.0, 13)
            .iter()
            .map(|p| Point2::new(p.x_m + 10.0, p.y_m)),
    );
    let e = gospa(&far_x, &y, &GospaParams::default()).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("scoring 29000 truth points or slots against 9000 estimates: 9000 × 9000"),
        "{e}"
    );
    // ET-GOPSA: one target of 9000 samples (slots) within 1 m.
    let target = ExtendedTarget::from_samples(x.clone());
    let e = etgospa(&[target], &y, &EtGospaParams::default()).unwrap_err();
    assert!(
        e.is_too_large() && e.to_string().contains("9000 × 9000 = 81000000"),
        "{e}"
    );
}

#[test]
fn empty_and_one_sided_sets() {
    let x = scatter(300, 100.0, 5);
    for params in [
        GospaParams::default(),
        GospaParams {
            p: f64::INFINITY,
            ..GospaParams::default()
        },
        GospaParams {
            alpha: 1.0,
            ..GospaParams::default()
        },
    ] {
        for (a, b) in [(&x[..], &[][..]), (&[][..], &x[..]), (&[][..], &[][..])] {
            let sparse = gospa_sparse(a, b, &params).unwrap();
            let dense = gospa_dense(a, b, &params).unwrap();
            assert_eq!(sparse, dense);
        }
    }
}
