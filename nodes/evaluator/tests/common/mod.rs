//! Brute-force oracles: the metrics' definitions (docs/design.md "Metrics") evaluated by enumerating
//! every partial assignment, written independently of the crate's code.
#![allow(dead_code)]

pub mod scatter;
pub mod strategies;

use nrslam_evaluator::{DistanceMode, EtGospaParams, ExtendedTarget, GospaParams, Point2};

fn dist(a: &Point2, b: &Point2) -> f64 {
    ((a.x_m - b.x_m).powi(2) + (a.y_m - b.y_m).powi(2)).sqrt()
}

/// Distance from p to segment ab by sampling-free projection (independent of the crate's).
fn dist_segment(p: &Point2, a: &Point2, b: &Point2) -> f64 {
    let (vx, vy) = (b.x_m - a.x_m, b.y_m - a.y_m);
    let (wx, wy) = (p.x_m - a.x_m, p.y_m - a.y_m);
    let len2 = vx * vx + vy * vy;
    let t = if len2 > 0.0 {
        ((wx * vx + wy * vy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    dist(p, &Point2::new(a.x_m + t * vx, a.y_m + t * vy))
}

/// Visits every partial injective map of `rows` items into `cols` items, calling `visit` with
/// assignment[r] = Some(col) or None.
pub fn for_each_partial_assignment(
    rows: usize,
    cols: usize,
    visit: &mut dyn FnMut(&[Option<usize>]),
) {
    fn rec(
        r: usize,
        rows: usize,
        cols: usize,
        current: &mut Vec<Option<usize>>,
        used: &mut Vec<bool>,
        visit: &mut dyn FnMut(&[Option<usize>]),
    ) {
        if r == rows {
            visit(current);
            return;
        }
        current.push(None);
        rec(r + 1, rows, cols, current, used, visit);
        current.pop();
        for c in 0..cols {
            if !used[c] {
                used[c] = true;
                current.push(Some(c));
                rec(r + 1, rows, cols, current, used, visit);
                current.pop();
                used[c] = false;
            }
        }
    }
    rec(
        0,
        rows,
        cols,
        &mut Vec::new(),
        &mut vec![false; cols],
        visit,
    );
}

/// GOSPA, assignment-set form, by enumeration. p = ∞: max of the pair terms and c per
/// unassigned point.
pub fn gospa_oracle(x: &[Point2], y: &[Point2], params: &GospaParams) -> f64 {
    let GospaParams { c, p, alpha } = *params;
    let mut best = f64::INFINITY;
    for_each_partial_assignment(x.len(), y.len(), &mut |a| {
        let assigned = a.iter().flatten().count();
        let unassigned = x.len() + y.len() - 2 * assigned;
        let value = if p.is_infinite() {
            let mut worst: f64 = if unassigned > 0 { c } else { 0.0 };
            for (i, j) in a.iter().enumerate() {
                if let Some(j) = j {
                    worst = worst.max(dist(&x[i], &y[*j]).min(c));
                }
            }
            worst
        } else {
            let mut sum = unassigned as f64 * c.powf(p) / alpha;
            for (i, j) in a.iter().enumerate() {
                if let Some(j) = j {
                    sum += dist(&x[i], &y[*j]).min(c).powf(p);
                }
            }
            sum.powf(1.0 / p)
        };
        best = best.min(value);
    });
    best
}

/// GOSPA as defined in FUSION 2017 (Definition 1): min over injective maps of the smaller set into
/// the larger, plus c^p/α per point of the cardinality difference. Finite p only.
pub fn gospa_fusion2017(x: &[Point2], y: &[Point2], params: &GospaParams) -> f64 {
    let GospaParams { c, p, alpha } = *params;
    let (small, large) = if x.len() <= y.len() { (x, y) } else { (y, x) };
    let mut best = f64::INFINITY;
    for_each_partial_assignment(small.len(), large.len(), &mut |a| {
        if a.iter().any(Option::is_none) {
            return;
        }
        let pairs: f64 = a
            .iter()
            .enumerate()
            .map(|(i, j)| dist(&small[i], &large[j.unwrap()]).min(c).powf(p))
            .sum();
        best = best.min(pairs);
    });
    (best + c.powf(p) / alpha * (large.len() - small.len()) as f64).powf(1.0 / p)
}

/// δ(y, target i) as the spec says: nearest sample, or nearest point of the closed outline;
/// squared if asked.
pub fn base_distance(target: &ExtendedTarget, y: &Point2, params: &EtGospaParams) -> f64 {
    let d = match params.distance {
        DistanceMode::Samples => target
            .samples
            .iter()
            .map(|s| dist(s, y))
            .fold(f64::INFINITY, f64::min),
        DistanceMode::Outline => {
            let v = &target.outline;
            if v.len() == 1 {
                dist(&v[0], y)
            } else {
                (0..v.len())
                    .map(|k| dist_segment(y, &v[k], &v[(k + 1) % v.len()]))
                    .fold(f64::INFINITY, f64::min)
            }
        }
    };
    if params.squared_distance {
        d * d
    } else {
        d
    }
}

/// ET-GOPSA by enumerating every partial assignment of slots to estimates. Finite p: the DESIGN
/// formula; p = ∞: max over pair terms max(min(c,δ_i), c·[δ_−i < c]) and c per unassigned item.
pub fn etgospa_oracle(targets: &[ExtendedTarget], y: &[Point2], params: &EtGospaParams) -> f64 {
    let (c, p, alpha) = (params.c, params.p, params.alpha);
    let slot_target: Vec<usize> = targets
        .iter()
        .enumerate()
        .flat_map(|(i, t)| std::iter::repeat_n(i, t.slots))
        .collect();
    let delta: Vec<Vec<f64>> = targets
        .iter()
        .map(|t| {
            y.iter()
                .map(|yj| base_distance(t, yj, params).min(c))
                .collect()
        })
        .collect();
    let delta_other = |i: usize, j: usize| {
        (0..targets.len())
            .filter(|&k| k != i)
            .map(|k| delta[k][j])
            .fold(c, f64::min)
    };
    let mut best = f64::INFINITY;
    for_each_partial_assignment(slot_target.len(), y.len(), &mut |a| {
        let assigned = a.iter().flatten().count();
        let unassigned = slot_target.len() + y.len() - 2 * assigned;
        let value = if p.is_infinite() {
            let mut worst: f64 = if unassigned > 0 { c } else { 0.0 };
            for (r, j) in a.iter().enumerate() {
                if let Some(j) = *j {
                    let i = slot_target[r];
                    let confusion = if delta_other(i, j) < c { c } else { 0.0 };
                    worst = worst.max(delta[i][j].max(confusion));
                }
            }
            worst
        } else {
            let cp = c.powf(p);
            let mut sum = unassigned as f64 * cp / alpha;
            for (r, j) in a.iter().enumerate() {
                if let Some(j) = *j {
                    let i = slot_target[r];
                    sum += delta[i][j].powf(p) + (cp - delta_other(i, j).powf(p));
                }
            }
            sum.powf(1.0 / p)
        };
        best = best.min(value);
    });
    best
}

/// |a − b| within a relative and absolute tolerance.
pub fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}
