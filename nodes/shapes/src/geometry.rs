//! Plane geometry for shapes: polygon area, convex clipping and the intersection over union of
//! two convex polygons.
//!
//! The intersection of two convex polygons is computed by Sutherland–Hodgman clipping
//! (I. E. Sutherland, G. W. Hodgman, "Reentrant polygon clipping", Commun. ACM 17(1), 1974):
//! the subject polygon is clipped in turn by each edge's half-plane of the (convex) clip polygon.
//! Areas are the shoelace formula. Both are exact up to rounding for convex inputs; IoU is what
//! the evaluator reports between a fitted outline and the true one.

/// Signed area (m²) of a simple polygon: positive when its vertices run counter-clockwise.
pub fn signed_area(polygon: &[[f64; 2]]) -> f64 {
    let n = polygon.len();
    if n < 3 {
        return 0.0;
    }
    (0..n)
        .map(|i| {
            let (a, b) = (polygon[i], polygon[(i + 1) % n]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        / 2.0
}

/// Area (m²) of a simple polygon, whichever way it runs.
pub fn area(polygon: &[[f64; 2]]) -> f64 {
    signed_area(polygon).abs()
}

/// The polygon counter-clockwise (reversed when it runs clockwise).
fn counter_clockwise(polygon: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut out = polygon.to_vec();
    if signed_area(polygon) < 0.0 {
        out.reverse();
    }
    out
}

/// z of (b − a) × (p − a): > 0 when p is left of the directed line a → b.
fn side(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Intersection of the segment p → q with the line a → b (p and q on different sides).
fn intersect(p: [f64; 2], q: [f64; 2], a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    let (sp, sq) = (side(a, b, p), side(a, b, q));
    let t = sp / (sp - sq);
    [p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]
}

/// The part of `subject` inside the convex polygon `clip` (Sutherland–Hodgman), counter-clockwise.
/// Empty when they do not overlap. Both must be convex; either orientation is accepted.
pub fn clip_convex(subject: &[[f64; 2]], clip: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let clip = counter_clockwise(clip);
    let mut output = counter_clockwise(subject);
    let n = clip.len();
    for i in 0..n {
        if output.is_empty() {
            break;
        }
        let (a, b) = (clip[i], clip[(i + 1) % n]);
        let input = std::mem::take(&mut output);
        let m = input.len();
        for j in 0..m {
            let (p, q) = (input[j], input[(j + 1) % m]);
            let (p_in, q_in) = (side(a, b, p) >= 0.0, side(a, b, q) >= 0.0);
            if p_in {
                output.push(p);
                if !q_in {
                    output.push(intersect(p, q, a, b));
                }
            } else if q_in {
                output.push(intersect(p, q, a, b));
            }
        }
    }
    output
}

/// Distance (m) from `p` to the boundary of a closed polygon (its edges, last vertex joined to the
/// first). +∞ for an empty polygon.
pub fn distance_to_boundary(p: [f64; 2], polygon: &[[f64; 2]]) -> f64 {
    let n = polygon.len();
    let mut best = f64::INFINITY;
    for i in 0..n {
        let (a, b) = (polygon[i], polygon[(i + 1) % n]);
        let d = [b[0] - a[0], b[1] - a[1]];
        let len2 = d[0] * d[0] + d[1] * d[1];
        let t = if len2 > 0.0 {
            (((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let q = [a[0] + t * d[0] - p[0], a[1] + t * d[1] - p[1]];
        best = best.min(q[0].hypot(q[1]));
    }
    best
}

/// Intersection over union of two convex polygons, in [0, 1]. 0 when either has zero area, a
/// non-finite vertex or fewer than 3 vertices (nothing to overlap), 1 for identical polygons.
pub fn convex_polygon_iou(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    let finite = |p: &[[f64; 2]]| p.iter().all(|v| v[0].is_finite() && v[1].is_finite());
    if a.len() < 3 || b.len() < 3 || !finite(a) || !finite(b) {
        return 0.0;
    }
    let (area_a, area_b) = (area(a), area(b));
    if area_a <= 0.0 || area_b <= 0.0 {
        return 0.0;
    }
    let inter = area(&clip_convex(a, b));
    let union = area_a + area_b - inter;
    if union <= 0.0 {
        return 0.0;
    }
    // Rounding can push the ratio a hair outside [0, 1].
    (inter / union).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn rect(cx: f64, cy: f64, w: f64, h: f64, yaw: f64) -> Vec<[f64; 2]> {
        let (s, c) = yaw.sin_cos();
        [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
            .iter()
            .map(|(u, v)| {
                let (x, y) = (u * w / 2.0, v * h / 2.0);
                [cx + c * x - s * y, cy + s * x + c * y]
            })
            .collect()
    }

    #[test]
    fn analytic_cases() {
        let a = rect(0.0, 0.0, 2.0, 2.0, 0.0);
        // Shifted by half its width: overlap 1×2 = 2, union 6.
        let b = rect(1.0, 0.0, 2.0, 2.0, 0.0);
        assert!((convex_polygon_iou(&a, &b) - 2.0 / 6.0).abs() < 1e-12);
        // A square and the same square turned 45°: the overlap is a regular octagon of area
        // 8(√2 − 1) for unit half-side, union 2·4 − that.
        let c = rect(0.0, 0.0, 2.0, 2.0, std::f64::consts::FRAC_PI_4);
        let octagon = 8.0 * (2f64.sqrt() - 1.0);
        let expected = octagon / (8.0 - octagon);
        assert!((convex_polygon_iou(&a, &c) - expected).abs() < 1e-12);
        // Nested: inner 1×1 inside 2×2.
        let d = rect(0.0, 0.0, 1.0, 1.0, 0.3);
        assert!((convex_polygon_iou(&a, &d) - 0.25).abs() < 1e-12);
        // Clockwise input is accepted.
        let mut cw = a.clone();
        cw.reverse();
        assert!((convex_polygon_iou(&cw, &b) - 2.0 / 6.0).abs() < 1e-12);
    }

    #[test]
    fn distance_to_a_square_boundary() {
        let a = rect(0.0, 0.0, 2.0, 2.0, 0.0);
        assert!((distance_to_boundary([0.0, 0.0], &a) - 1.0).abs() < 1e-12);
        assert!((distance_to_boundary([0.5, 3.0], &a) - 2.0).abs() < 1e-12);
        assert!((distance_to_boundary([2.0, 2.0], &a) - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(distance_to_boundary([0.0, 0.0], &[]), f64::INFINITY);
    }

    #[test]
    fn degenerate_polygons_give_zero() {
        let a = rect(0.0, 0.0, 2.0, 2.0, 0.0);
        assert_eq!(convex_polygon_iou(&a, &[]), 0.0);
        assert_eq!(convex_polygon_iou(&a, &[[0.0, 0.0], [1.0, 1.0]]), 0.0);
        assert_eq!(
            convex_polygon_iou(&a, &[[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]]),
            0.0
        );
        assert_eq!(
            convex_polygon_iou(&a, &[[f64::NAN, 0.0], [1.0, 0.0], [1.0, 1.0]]),
            0.0
        );
    }

    proptest! {
        #[test]
        fn iou_properties(
            (cx, cy, w, h, yaw) in (-5.0..5.0f64, -5.0..5.0f64, 0.1..4.0f64, 0.1..4.0f64, -3.2..3.2f64),
            (dx, dy, w2, h2, yaw2) in (-5.0..5.0f64, -5.0..5.0f64, 0.1..4.0f64, 0.1..4.0f64, -3.2..3.2f64),
        ) {
            let a = rect(cx, cy, w, h, yaw);
            let b = rect(cx + dx, cy + dy, w2, h2, yaw2);
            let ab = convex_polygon_iou(&a, &b);
            let ba = convex_polygon_iou(&b, &a);
            prop_assert!((0.0..=1.0).contains(&ab));
            prop_assert!((ab - ba).abs() < 1e-9, "{ab} vs {ba}");
            prop_assert!((convex_polygon_iou(&a, &a) - 1.0).abs() < 1e-9);
            // The overlap never exceeds the smaller area.
            let inter = area(&clip_convex(&a, &b));
            prop_assert!(inter <= area(&a).min(area(&b)) + 1e-9);
            // Far apart (beyond both circumradii): disjoint.
            let far = rect(cx + 20.0, cy, w2, h2, yaw2);
            prop_assert_eq!(convex_polygon_iou(&a, &far), 0.0);
        }
    }
}
