//! The benches' shared scene: the outlines of a few rectangles and circles.

use std::f64::consts::PI;

/// Outlines of rectangles and circles over about 20 m × 20 m, a point every `spacing_m`.
pub fn scene(spacing_m: f64) -> Vec<[f64; 2]> {
    let mut points = Vec::new();
    for &(x0, y0, w, h) in &[
        (-8.0, -7.0, 3.0, 2.0),
        (-2.0, -8.0, 5.0, 1.5),
        (5.0, -6.0, 2.0, 4.0),
        (-9.0, 1.0, 1.5, 5.0),
        (-3.0, 4.0, 4.0, 2.0),
        (6.0, 5.0, 3.0, 3.0),
    ] {
        let corners = [[x0, y0], [x0 + w, y0], [x0 + w, y0 + h], [x0, y0 + h]];
        for i in 0..4 {
            let (a, b): ([f64; 2], [f64; 2]) = (corners[i], corners[(i + 1) % 4]);
            let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / spacing_m).round() as usize;
            for k in 0..n {
                let s = k as f64 / n as f64;
                points.push([a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])]);
            }
        }
    }
    for &(cx, cy, r) in &[(0.0, 0.0, 1.2), (3.0, 1.5, 0.6), (-5.5, -2.0, 0.9)] {
        let n = (2.0 * PI * r / spacing_m).round() as usize;
        for k in 0..n {
            let a = 2.0 * PI * k as f64 / n as f64;
            points.push([cx + r * a.cos(), cy + r * a.sin()]);
        }
    }
    points
}
