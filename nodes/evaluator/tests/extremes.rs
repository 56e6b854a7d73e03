//! Extreme inputs: empty sets, one side empty, coincident points, a map-sized problem, and
//! non-finite input (always an error, never a panic or a silent answer).

use nrslam_evaluator::{
    etgospa, gospa, DistanceMode, EtGospaParams, ExtendedTarget, GospaParams, MetricError, Point2,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const ALL_P: [f64; 4] = [1.0, 2.0, 3.5, f64::INFINITY];

fn et(p: f64) -> EtGospaParams {
    EtGospaParams {
        p,
        ..EtGospaParams::default()
    }
}

fn g(p: f64) -> GospaParams {
    GospaParams {
        p,
        ..GospaParams::default()
    }
}

fn pt(x: f64, y: f64) -> Point2 {
    Point2::new(x, y)
}

#[test]
fn empty_both_sides_is_zero() {
    for p in ALL_P {
        let r = gospa(&[], &[], &g(p)).unwrap();
        assert_eq!((r.total, r.assigned_count), (0.0, 0));
        let r = etgospa(&[], &[], &et(p)).unwrap();
        assert_eq!((r.total, r.slot_count), (0.0, 0));
        // Targets with zero slots offer nothing to fill: still zero.
        let t = ExtendedTarget::from_samples(vec![pt(0.0, 0.0)]).with_slots(0);
        assert_eq!(etgospa(&[t], &[], &et(p)).unwrap().total, 0.0);
    }
}

#[test]
fn one_side_empty_costs_c_p_over_alpha_per_point() {
    let points = [pt(0.0, 0.0), pt(1.0, 1.0), pt(5.0, 5.0)];
    for (p, alpha) in [(1.0, 2.0), (2.0, 2.0), (1.0, 1.0), (3.0, 0.5)] {
        let params = GospaParams { c: 5.0, p, alpha };
        let expected = (3.0 * 5f64.powf(p) / alpha).powf(1.0 / p);
        let a = gospa(&points, &[], &params).unwrap();
        let b = gospa(&[], &points, &params).unwrap();
        assert!((a.total - expected).abs() < 1e-12 && (b.total - expected).abs() < 1e-12);
        assert_eq!((a.missed_count, a.false_count), (3, 0));
        assert_eq!((b.missed_count, b.false_count), (0, 3));

        let etp = EtGospaParams {
            c: 5.0,
            p,
            alpha,
            ..EtGospaParams::default()
        };
        let target = ExtendedTarget::from_samples(points.to_vec());
        let missed = etgospa(std::slice::from_ref(&target), &[], &etp).unwrap();
        assert!((missed.total - expected).abs() < 1e-12);
        assert_eq!(missed.missed_count, 3);
        let false_only = etgospa(&[], &points, &etp).unwrap();
        assert!((false_only.total - expected).abs() < 1e-12);
        assert_eq!(false_only.false_count, 3);
    }
    // p = ∞: one unassigned point already costs c.
    assert_eq!(gospa(&points, &[], &g(f64::INFINITY)).unwrap().total, 5.0);
    assert_eq!(
        etgospa(&[], &points, &et(f64::INFINITY)).unwrap().total,
        5.0
    );
}

#[test]
fn coincident_points() {
    // More than c = 5 m apart, so an estimate on one target is not confusable with another.
    let points = [pt(1.0, 2.0), pt(-5.0, 0.5), pt(8.0, 8.0)];
    for p in ALL_P {
        assert_eq!(gospa(&points, &points, &g(p)).unwrap().total, 0.0);
        let targets: Vec<ExtendedTarget> = points
            .iter()
            .map(|&q| ExtendedTarget::from_samples(vec![q]))
            .collect();
        let r = etgospa(&targets, &points, &et(p)).unwrap();
        assert_eq!(r.total, 0.0, "p = {p}");
    }
    // Two estimates on the same spot of a one-slot target: one fills it, the other is false.
    let target = ExtendedTarget::from_samples(vec![pt(0.0, 0.0)]);
    let r = etgospa(&[target], &[pt(0.0, 0.0), pt(0.0, 0.0)], &et(1.0)).unwrap();
    assert_eq!((r.assigned_count, r.false_count, r.total), (1, 1, 2.5));
    // Two targets sharing a sample point: an estimate on it is fully confused (E = 0 + c^p − 0).
    let a = ExtendedTarget::from_samples(vec![pt(0.0, 0.0)]);
    let b = ExtendedTarget::from_samples(vec![pt(0.0, 0.0)]);
    let r = etgospa(&[a, b], &[pt(0.0, 0.0)], &et(1.0)).unwrap();
    assert_eq!(r.assigned_count, 0);
    assert_eq!(r.total, 7.5);
}

/// Ten 2 m × 1 m rectangles of 4 corner samples, in two rows of five, `spacing_m` apart.
fn rectangles(spacing_m: f64) -> Vec<ExtendedTarget> {
    (0..10)
        .map(|k| {
            let (x, y) = (f64::from(k % 5) * spacing_m, f64::from(k / 5) * spacing_m);
            ExtendedTarget::from_samples(vec![
                pt(x, y),
                pt(x + 2.0, y),
                pt(x + 2.0, y + 1.0),
                pt(x, y + 1.0),
            ])
        })
        .collect()
}

/// 10 targets × 4 samples = 40 slots against 5000 estimates, with a known answer: 4 estimates
/// exactly on each target's samples, 4960 farther than c from every target.
#[test]
fn map_sized_problem_has_the_known_answer() {
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let targets = rectangles(40.0);
    let mut estimates: Vec<Point2> = targets.iter().flat_map(|t| t.samples.clone()).collect();
    while estimates.len() < 5000 {
        let q = pt(
            rng.random_range(-50.0..250.0),
            rng.random_range(-50.0..100.0),
        );
        let far = targets
            .iter()
            .flat_map(|t| &t.samples)
            .all(|s| s.distance_m(&q) > 5.0);
        if far {
            estimates.push(q);
        }
    }
    // Shuffle so the matches are not at the front.
    for i in (1..estimates.len()).rev() {
        let j = rng.random_range(0..=i);
        estimates.swap(i, j);
    }
    let r = etgospa(&targets, &estimates, &et(1.0)).unwrap();
    assert_eq!(r.slot_count, 40);
    assert_eq!(r.assigned_count, 40);
    assert_eq!(r.localisation, 0.0);
    assert_eq!(r.confusion, 0.0);
    assert_eq!(r.false_count, 4960);
    assert_eq!(r.total, 4960.0 * 2.5);
    let r = etgospa(&targets, &estimates, &et(f64::INFINITY)).unwrap();
    assert_eq!((r.assigned_count, r.localisation, r.total), (40, 0.0, 5.0));
}

/// The same size with estimates scattered near the targets (dense, non-trivial assignment).
#[test]
fn map_sized_problem_with_noisy_estimates_is_consistent() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let targets = rectangles(6.0);
    let estimates: Vec<Point2> = (0..5000)
        .map(|_| pt(rng.random_range(-3.0..30.0), rng.random_range(-3.0..10.0)))
        .collect();
    for distance in [DistanceMode::Samples, DistanceMode::Outline] {
        let params = EtGospaParams {
            distance,
            ..et(1.0)
        };
        let targets: Vec<ExtendedTarget> = targets
            .iter()
            .map(|t| t.clone().with_outline(t.samples.clone()))
            .collect();
        let r = etgospa(&targets, &estimates, &params).unwrap();
        assert_eq!(r.slot_count, 40);
        assert_eq!(r.assigned_count + r.false_count, 5000);
        let sum = r.localisation + r.confusion + r.missed + r.false_estimates;
        assert!((r.total - sum).abs() < 1e-9 * sum);
        // 5000 points over 33 m × 13 m: every slot finds an estimate that fills it well.
        assert_eq!(r.assigned_count, 40);
    }
}

#[test]
fn non_finite_input_is_refused() {
    let good = [pt(0.0, 0.0), pt(1.0, 1.0)];
    for bad_value in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        let bad = [pt(0.0, 0.0), pt(1.0, bad_value)];
        for p in ALL_P {
            let e = gospa(&bad, &good, &g(p)).unwrap_err();
            assert!(
                matches!(&e, MetricError::NonFiniteInput { set, index: 1, .. } if set == "truth"),
                "{e}"
            );
            let e = gospa(&good, &bad, &g(p)).unwrap_err();
            assert!(matches!(&e, MetricError::NonFiniteInput { set, .. } if set == "estimates"));

            let target = ExtendedTarget::from_samples(good.to_vec());
            let e = etgospa(std::slice::from_ref(&target), &bad, &et(p)).unwrap_err();
            assert!(matches!(&e, MetricError::NonFiniteInput { set, .. } if set == "estimates"));
            let bad_target = ExtendedTarget::from_samples(bad.to_vec());
            let e = etgospa(&[target.clone(), bad_target], &good, &et(p)).unwrap_err();
            assert!(
                matches!(&e, MetricError::NonFiniteInput { set, .. } if set == "target 1 samples"),
                "{e}"
            );
            let bad_outline = target.clone().with_outline(bad.to_vec());
            let e = etgospa(&[bad_outline], &good, &et(p)).unwrap_err();
            assert!(e.to_string().contains("target 0 outline"), "{e}");
        }
    }
}

#[test]
fn bad_parameters_are_refused_naming_the_field() {
    let pts = [pt(0.0, 0.0)];
    let cases = [
        (
            GospaParams {
                c: f64::NAN,
                ..g(1.0)
            },
            "`c`",
        ),
        (GospaParams { c: -1.0, ..g(1.0) }, "`c`"),
        (
            GospaParams {
                c: f64::INFINITY,
                ..g(1.0)
            },
            "`c`",
        ),
        (
            GospaParams {
                p: f64::NAN,
                ..g(1.0)
            },
            "`p`",
        ),
        (GospaParams { p: 0.99, ..g(1.0) }, "`p`"),
        (
            GospaParams {
                p: 1000.0,
                ..g(1.0)
            },
            "`p`",
        ),
        (
            GospaParams {
                alpha: f64::NAN,
                ..g(1.0)
            },
            "`alpha`",
        ),
        (
            GospaParams {
                alpha: 0.0,
                ..g(1.0)
            },
            "`alpha`",
        ),
        (
            GospaParams {
                alpha: 2.000001,
                ..g(1.0)
            },
            "`alpha`",
        ),
    ];
    for (params, field) in cases {
        let e = gospa(&pts, &pts, &params).unwrap_err();
        assert!(matches!(e, MetricError::InvalidParam(_)));
        assert!(e.to_string().contains(field), "{field}: {e}");
        let etp = EtGospaParams {
            c: params.c,
            p: params.p,
            alpha: params.alpha,
            ..EtGospaParams::default()
        };
        let e = etgospa(&[], &pts, &etp).unwrap_err();
        assert!(e.to_string().contains(field), "{field}: {e}");
    }
}

#[test]
fn a_target_without_the_measured_geometry_is_refused() {
    let samples_only = ExtendedTarget::from_samples(vec![pt(0.0, 0.0)]);
    let outline_params = EtGospaParams {
        distance: DistanceMode::Outline,
        ..EtGospaParams::default()
    };
    let e = etgospa(&[samples_only], &[pt(1.0, 0.0)], &outline_params).unwrap_err();
    assert_eq!(
        e,
        MetricError::EmptyGeometry {
            target: 0,
            geometry: "outline"
        }
    );
    let no_samples = ExtendedTarget::default().with_slots(2);
    let e = etgospa(&[no_samples], &[], &EtGospaParams::default()).unwrap_err();
    assert!(matches!(
        e,
        MetricError::EmptyGeometry {
            target: 0,
            geometry: "sample"
        }
    ));
}
