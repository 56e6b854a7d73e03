//! Geometric circle fit: the algebraic fit of I. Kåsa ("A circle fitting procedure and its error
//! analysis", IEEE Trans. Instrum. Meas. 25(1), 1976) as the start, then Levenberg–Marquardt on
//! the geometric distances |p − c| − r (N. Chernov, "Circular and Linear Regression: Fitting
//! Circles and Lines by Least Squares", CRC 2010, ch. 4), which removes the algebraic fit's bias
//! toward small radii on short arcs.
//!
//! The covariance of (cx, cy, r) is σ̂²(JᵀJ)⁻¹ at the solution, σ̂ from the residuals (floored at
//! `min_point_std_m`).
//! Points on a line make the algebraic system singular or the radius huge: no circle then
//! (radius outside `[min_radius_m, max_radius_m]`), which model selection reads as "not a circle";
//! so does a radius whose standard deviation exceeds `max_radius_relative_std` times itself: the
//! curvature 1/r is then not significantly above zero (a noisy straight side bends either way).

use nalgebra::{Matrix3, Vector3};

use crate::Params;

/// Levenberg–Marquardt iterations at most.
const MAX_ITERATIONS: usize = 100;

/// A circle fitted in a frame centred on the points' centroid.
#[derive(Debug, Clone)]
pub(crate) struct CircleFit {
    /// Centre, centred frame (m).
    pub center_m: [f64; 2],
    /// Radius (m).
    pub radius_m: f64,
    /// Row-major 3×3 covariance of (cx, cy, r).
    pub covariance: Vec<f64>,
    /// Sum of squared geometric residuals (m²).
    pub rss_m2: f64,
}

/// Kåsa's fit: least squares of x² + y² + D x + E y + F = 0. None when the points are collinear
/// (singular system) or the solution is not a real circle.
fn kasa(points: &[[f64; 2]]) -> Option<(f64, f64, f64)> {
    let mut ata = Matrix3::<f64>::zeros();
    let mut atb = Vector3::<f64>::zeros();
    for p in points {
        let row = Vector3::new(p[0], p[1], 1.0);
        ata += row * row.transpose();
        atb -= row * (p[0] * p[0] + p[1] * p[1]);
    }
    let sol = ata.cholesky()?.solve(&atb);
    let (a, b) = (-sol[0] / 2.0, -sol[1] / 2.0);
    let r2 = a * a + b * b - sol[2];
    (r2 > 0.0 && r2.is_finite()).then(|| (a, b, r2.sqrt()))
}

/// Residuals' sum of squares and normal equations of the geometric fit at (a, b, r); None when a
/// point sits on the centre (the distance's gradient is undefined there).
fn normal_equations(
    points: &[[f64; 2]],
    x: &Vector3<f64>,
) -> Option<(f64, Matrix3<f64>, Vector3<f64>)> {
    let mut jtj = Matrix3::zeros();
    let mut jtr = Vector3::zeros();
    let mut rss = 0.0;
    for p in points {
        let (dx, dy) = (p[0] - x[0], p[1] - x[1]);
        let d = dx.hypot(dy);
        if d <= 0.0 {
            return None;
        }
        let r = d - x[2];
        let j = Vector3::new(-dx / d, -dy / d, -1.0);
        jtj += j * j.transpose();
        jtr += j * r;
        rss += r * r;
    }
    Some((rss, jtj, jtr))
}

/// Fits a circle to `points` (centred on their centroid). None when no circle with a radius in
/// `[min_radius_m, max_radius_m]` fits.
pub(crate) fn fit_circle(points: &[[f64; 2]], params: &Params) -> Option<CircleFit> {
    let (a, b, r) = kasa(points)?;
    let mut x = Vector3::new(a, b, r);
    let (mut rss, mut jtj, mut jtr) = normal_equations(points, &x)?;
    let mut lambda = 1e-3;
    for _ in 0..MAX_ITERATIONS {
        let mut damped = jtj;
        for i in 0..3 {
            damped[(i, i)] *= 1.0 + lambda;
        }
        let Some(step) = damped.cholesky().map(|c| c.solve(&(-jtr))) else {
            break;
        };
        let candidate = x + step;
        match normal_equations(points, &candidate) {
            Some((new_rss, new_jtj, new_jtr)) if new_rss <= rss => {
                let converged = step.amax() < 1e-10 * (1.0 + x.amax());
                x = candidate;
                (rss, jtj, jtr) = (new_rss, new_jtj, new_jtr);
                lambda = (lambda / 10.0).max(1e-12);
                if converged {
                    break;
                }
            }
            _ => {
                lambda *= 10.0;
                if lambda > 1e12 {
                    break;
                }
            }
        }
        // A radius running away is a line: stop early, it will be refused below.
        if x[2] > 10.0 * params.max_radius_m {
            break;
        }
    }
    let radius_m = x[2];
    if !(radius_m.is_finite() && radius_m >= params.min_radius_m && radius_m <= params.max_radius_m)
    {
        return None;
    }
    let n = points.len();
    let dof = n.saturating_sub(3);
    let sigma2 = if dof > 0 { rss / dof as f64 } else { 0.0 }.max(params.min_point_std_m.powi(2));
    // The error all the cells share (`offset_std_m`, `offset_std_per_std`: how far inside the
    // surface the band lies) goes to the radius only: moving every point of an arc along its
    // radius by the same amount is a change of radius about the same centre.
    let mut cov = jtj.try_inverse()? * sigma2;
    let shared = params.offset_std_m.powi(2) + params.offset_std_per_std.powi(2) * sigma2;
    cov[(2, 2)] += shared;
    // The offset is not the same along a partial arc (the near end of an arc is seen along
    // its normal, the far end at a glancing angle), and that moves the centre of the arc's fit
    // along its axis. The mean resultant length of the points' directions from the centre is
    // 0 for a full circle and tends to 1 for a short arc: the share of the shared error that
    // reaches the centre.
    let (sum_cos, sum_sin) = points.iter().fold((0.0, 0.0), |(c, s), p| {
        let (dx, dy) = (p[0] - x[0], p[1] - x[1]);
        let r = dx.hypot(dy).max(f64::MIN_POSITIVE);
        (c + dx / r, s + dy / r)
    });
    let resultant = sum_cos.hypot(sum_sin) / points.len() as f64;
    cov[(0, 0)] += resultant.powi(2) * shared;
    cov[(1, 1)] += resultant.powi(2) * shared;
    let covariance: Vec<f64> = (0..3)
        .flat_map(|r| (0..3).map(move |c| (r, c)))
        .map(|(r, c)| (cov[(r, c)] + cov[(c, r)]) / 2.0)
        .collect();
    if !(covariance.iter().all(|v| v.is_finite()) && x.iter().all(|v| v.is_finite())) {
        return None;
    }
    // A curvature not significantly above zero is a straight side with noise, not an arc.
    if covariance[8].sqrt() > params.max_radius_relative_std * radius_m {
        return None;
    }
    Some(CircleFit {
        center_m: [x[0], x[1]],
        // Out from the band's middle to the surface (`surface_offset_per_std`); `rss_m2` stays
        // the band's, for model selection.
        radius_m: radius_m + params.surface_offset_per_std * sigma2.sqrt(),
        covariance,
        rss_m2: rss,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_arc_is_recovered() {
        let points: Vec<[f64; 2]> = (0..20)
            .map(|k| {
                let phi = -1.0 + 2.0 * k as f64 / 19.0;
                [0.3 + 1.5 * phi.cos(), -0.2 + 1.5 * phi.sin()]
            })
            .collect();
        let fit = fit_circle(&points, &crate::synthetic::unbiased_params()).unwrap();
        assert!((fit.center_m[0] - 0.3).abs() < 1e-8, "{fit:?}");
        assert!((fit.center_m[1] + 0.2).abs() < 1e-8);
        assert!((fit.radius_m - 1.5).abs() < 1e-8);
    }

    #[test]
    fn collinear_points_are_no_circle() {
        let points: Vec<[f64; 2]> = (0..10).map(|k| [k as f64 * 0.1 - 0.45, 0.0]).collect();
        assert!(fit_circle(&points, &Params::default()).is_none());
    }
}
