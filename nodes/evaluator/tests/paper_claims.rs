//! The paper's claims on ET-GOPSA (Sec. IV-B) on explicit geometries, as docs/design.md asks.
//!
//! Fig. 4 scenario: two square targets x1 = [0,2]², x2 = [6,8]×[0,2] with their 4 corners as
//! sample points (4 slots each). y1 = (2, −0.5) and y2 = (0, −0.5) are both 0.5 m from x1's
//! nearest corner, but y1 is 4.03 m from x2 (within c = 5 m: confusable) and y2 6.02 m (not).

use nrslam_evaluator::{etgospa, gospa, DistanceMode, EtGospaParams, ExtendedTarget, Point2};

fn square(x0: f64) -> ExtendedTarget {
    let corners = vec![
        Point2::new(x0, 0.0),
        Point2::new(x0 + 2.0, 0.0),
        Point2::new(x0 + 2.0, 2.0),
        Point2::new(x0, 2.0),
    ];
    ExtendedTarget::from_samples(corners.clone()).with_outline(corners)
}

fn scene() -> [ExtendedTarget; 2] {
    [square(0.0), square(6.0)]
}

const Y1: Point2 = Point2::new(2.0, -0.5);
const Y2: Point2 = Point2::new(0.0, -0.5);

fn d(estimates: &[Point2], params: &EtGospaParams) -> f64 {
    etgospa(&scene(), estimates, params).unwrap().total
}

fn params_to_check() -> Vec<EtGospaParams> {
    let mut all = Vec::new();
    for distance in [DistanceMode::Samples, DistanceMode::Outline] {
        for p in [1.0, 2.0, 3.0] {
            all.push(EtGospaParams {
                p,
                distance,
                ..EtGospaParams::default()
            });
        }
    }
    all
}

#[test]
fn explicit_values_of_the_fig4_scenario() {
    // c = 5, p = 1, α = 2. y1: D_1 = 0.5, D_{−1} = √(16 + 0.25), E = 0.5 + 5 − 4.0311 = 1.4689,
    // plus 7 missed slots at 2.5.
    let params = EtGospaParams::default();
    let r = etgospa(&scene(), &[Y1], &params).unwrap();
    let d_other = 16.25f64.sqrt();
    assert!((r.localisation - 0.5).abs() < 1e-12);
    assert!((r.confusion - (5.0 - d_other)).abs() < 1e-12);
    assert_eq!((r.missed, r.false_estimates), (17.5, 0.0));
    assert!((r.total - (0.5 + 5.0 - d_other + 17.5)).abs() < 1e-12);
    assert_eq!(r.pairs, vec![(0, 0)]);
    // y2 is farther than c from x2: no confusion at all.
    let r = etgospa(&scene(), &[Y2], &params).unwrap();
    assert_eq!((r.localisation, r.confusion, r.total), (0.5, 0.0, 18.0));
}

#[test]
fn farther_from_the_other_target_scores_better_eq_gopsa_10() {
    for params in params_to_check() {
        assert!(d(&[Y1], &params) > d(&[Y2], &params), "{params:?}");
    }
}

#[test]
fn gospa_cannot_tell_y1_from_y2_but_etgospa_can() {
    // GOSPA of all 8 corner points sees two estimates 0.5 m from a corner: identical.
    let corners: Vec<Point2> = scene().iter().flat_map(|t| t.samples.clone()).collect();
    let params = EtGospaParams::default();
    let g1 = gospa(&corners, &[Y1], &params.gospa()).unwrap().total;
    let g2 = gospa(&corners, &[Y2], &params.gospa()).unwrap().total;
    assert_eq!(g1, g2);
    assert!(d(&[Y1], &params) > d(&[Y2], &params));
}

#[test]
fn an_estimate_filling_a_free_slot_lowers_the_metric_eq_gopsa_11() {
    for params in params_to_check() {
        let both = d(&[Y1, Y2], &params);
        assert!(d(&[Y1], &params) > both, "{params:?}");
        assert!(d(&[Y2], &params) > both, "{params:?}");
    }
}

#[test]
fn a_confusable_estimate_that_fills_no_slot_well_does_not_lower_it() {
    // docs/design.md's condition: only an estimate with E < c^p/α lowers the metric. y3 sits midway
    // between the targets, √4.25 = 2.06 m from x1's corner (2, 0) and from x2's corner (6, 0):
    // E = 2.06 + (5 − 2.06) = 5 ≥ c^p/α = 2.5 for either target.
    let params = EtGospaParams::default();
    let y3 = Point2::new(4.0, -0.5);
    let r = etgospa(&scene(), &[Y2, y3], &params).unwrap();
    assert_eq!(
        r.assigned_count, 1,
        "the ambiguous estimate must stay unassigned"
    );
    assert!(d(&[Y2, y3], &params) > d(&[Y2], &params));
}

#[test]
fn closer_to_the_matched_target_scores_better() {
    // y below the middle of x1's bottom edge, moving away; always ≥ 5 m from x2's corners.
    let params = EtGospaParams::default();
    let values: Vec<f64> = (1..=8)
        .map(|k| d(&[Point2::new(1.0, -0.25 * f64::from(k))], &params))
        .collect();
    for pair in values.windows(2) {
        assert!(pair[0] < pair[1], "{values:?}");
    }
}

#[test]
fn more_matched_estimates_score_better_until_the_slots_are_full() {
    // Estimates 0.1 m outside each corner of x1, then a fifth one: x1 has only 4 slots.
    let params = EtGospaParams::default();
    let near_corners = [
        Point2::new(-0.1, 0.0),
        Point2::new(2.0, -0.1),
        Point2::new(2.0, 2.1),
        Point2::new(-0.1, 2.0),
        Point2::new(1.0, 2.1),
    ];
    let values: Vec<f64> = (0..=5).map(|k| d(&near_corners[..k], &params)).collect();
    for k in 0..4 {
        assert!(values[k + 1] < values[k], "{values:?}");
    }
    assert!(
        values[5] > values[4],
        "a fifth estimate on a 4-slot target is false: {values:?}"
    );
}

#[test]
fn squared_distance_is_the_paper_literal() {
    // With squared_distance the cut-off is in m²: y2 at 0.5 m costs 0.25.
    let params = EtGospaParams {
        squared_distance: true,
        ..EtGospaParams::default()
    };
    let r = etgospa(&scene(), &[Y2], &params).unwrap();
    assert!((r.localisation - 0.25).abs() < 1e-12);
    assert!((r.total - (0.25 + 17.5)).abs() < 1e-12);
}

#[test]
fn outline_distance_sees_the_edges_not_just_the_corners() {
    // (1, −0.5) is 0.5 m from x1's bottom edge but 1.118 m from its nearest corner.
    let y = [Point2::new(1.0, -0.5)];
    let samples = etgospa(&scene(), &y, &EtGospaParams::default()).unwrap();
    let outline = etgospa(
        &scene(),
        &y,
        &EtGospaParams {
            distance: DistanceMode::Outline,
            ..EtGospaParams::default()
        },
    )
    .unwrap();
    assert!((samples.localisation - 1.25f64.sqrt()).abs() < 1e-12);
    assert!((outline.localisation - 0.5).abs() < 1e-12);
}
