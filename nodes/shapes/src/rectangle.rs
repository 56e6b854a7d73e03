//! Rectangle fit with partial visibility: the L-shape fit of lidar vehicle detection, generalised
//! to one to four seen sides and made least squares so that a thick band of noisy cells is fitted
//! through its middle rather than at its outer edge.
//!
//! **Yaw search.** As in X. Zhang, W. Xu, C. Dong, J. M. Dolan, "Efficient L-shape fitting for
//! vehicle detection using laser scanners" (IEEE IV 2017), candidate yaws θ ∈ [0, π/2) are
//! searched (2° steps): in the frame (u, v) turned by θ each point is given to the nearest of
//! the four sides of the bounding box; each side's offset is then the mean coordinate of its
//! points and the points are reassigned until nothing changes. The yaw with the lowest BIC wins.
//! Zhang et al. score the points' closeness to the box edges; with angle noise of a degree the
//! outline is a band several cells thick, the box edges lie at the band's outer edge, and a
//! least-squares offset is the unbiased choice.
//!
//! **Which sides are seen.** A side is kept only with `min_side_points` points spanning
//! `min_side_length_m` outside the bands (±2.5 σ̂) of the perpendicular sides (so the thick end
//! of a band is not a side), two opposite sides only when at least `min_opposite_sides_m` apart (otherwise a
//! thick band would be split into two thin "sides"), and only when dropping it (its points going
//! to the other sides) makes the BIC worse.
//!
//! **Refinement.** Gauss–Newton on (θ, offsets of the seen sides) minimising the squared signed
//! distances of the points to their sides; the least-squares covariance is σ̂²(JᵀJ)⁻¹ with σ̂ from
//! the residuals (floored at `min_point_std_m`), and each offset gets `offset_std_m²` on top (an
//! error all the side's cells share, e.g. the quantisation of an edge parallel to the grid, does
//! not average out).
//!
//! **Unseen sides.** A side whose neighbour is seen ends where that neighbour's points end (the
//! extent along the seen side, variance `extent_std_m² + σ̂²`). With one side seen the depth is
//! unobservable: the rectangle extends away from the viewpoints (the side is seen from outside)
//! by a prior depth, the seen length clamped to `[unseen_depth_min_m, unseen_depth_max_m]` with
//! standard deviation `unseen_depth_std_m`, which enters the covariance. Without viewpoints, the
//! map origin stands in for the sensor.
//!
//! **Covariance of (cx, cy, w, h, yaw).** Every output is a function of the primitive estimates
//! z = (θ, seen offsets, extent errors, depth); its covariance is J Σ_z Jᵀ with J by central
//! differences (the extents are maxima of projections, piecewise linear in θ).

use std::f64::consts::FRAC_PI_2;

use nalgebra::{DMatrix, DVector};

use crate::Params;

/// Yaw steps of the coarse search over [0, π/2).
const YAW_STEPS: usize = 45;
/// Gauss–Newton iterations at most.
const MAX_ITERATIONS: usize = 30;

/// A rectangle fitted in a frame centred on the points' centroid.
#[derive(Debug, Clone)]
pub(crate) struct RectangleFit {
    /// Centre, the centred frame (m).
    pub center_m: [f64; 2],
    /// Sizes along the own axes (m).
    pub size_m: [f64; 2],
    /// Yaw of the own x axis, [0, π/2).
    pub yaw_rad: f64,
    /// Row-major 5×5 covariance of (cx, cy, w, h, yaw).
    pub covariance: Vec<f64>,
    /// Sides fitted by least squares.
    pub sides_seen: u8,
    /// Sum of squared residuals (m²).
    pub rss_m2: f64,
    /// The outline through the fitted bands themselves, before `surface_offset_m` moves the
    /// sides out (the centred frame): what the points' residuals are measured against.
    pub band_outline_m: [[f64; 2]; 4],
}

fn axes(theta: f64) -> ([f64; 2], [f64; 2]) {
    let (s, c) = theta.sin_cos();
    ([c, s], [-s, c])
}

fn dot(a: [f64; 2], b: [f64; 2]) -> f64 {
    a[0] * b[0] + a[1] * b[1]
}

/// (u, v) coordinates of the points in the frame turned by θ.
fn project(points: &[[f64; 2]], theta: f64) -> Vec<[f64; 2]> {
    let (e1, e2) = axes(theta);
    points.iter().map(|&p| [dot(e1, p), dot(e2, p)]).collect()
}

/// Sides are 0 = low u, 1 = high u, 2 = low v, 3 = high v; a side's offset is its coordinate on
/// axis `k / 2`.
type Offsets = [Option<f64>; 4];

/// The nearest present side of a point and its signed residual.
fn nearest_side(uv: [f64; 2], offsets: &Offsets) -> (usize, f64) {
    let mut best = (usize::MAX, f64::INFINITY);
    for (k, c) in offsets.iter().enumerate() {
        if let Some(c) = c {
            let r = uv[k / 2] - c;
            if r.abs() < best.1.abs() {
                best = (k, r);
            }
        }
    }
    best
}

fn assign(uv: &[[f64; 2]], offsets: &Offsets) -> (Vec<usize>, f64) {
    let mut labels = Vec::with_capacity(uv.len());
    let rss = assign_into(uv, offsets, &mut labels);
    (labels, rss)
}

/// [`assign`] into `labels` (cleared first), returning the RSS, so that [`settle`]'s iterations
/// reuse one vector.
fn assign_into(uv: &[[f64; 2]], offsets: &Offsets, labels: &mut Vec<usize>) -> f64 {
    labels.clear();
    let mut rss = 0.0;
    labels.extend(uv.iter().map(|&p| {
        let (k, r) = nearest_side(p, offsets);
        rss += r * r;
        k
    }));
    rss
}

/// Points of each side: count, mean offset, span along the side.
fn side_stats(uv: &[[f64; 2]], labels: &[usize]) -> [(usize, f64, f64); 4] {
    let mut sum = [0.0; 4];
    let mut count = [0usize; 4];
    let mut lo = [f64::INFINITY; 4];
    let mut hi = [f64::NEG_INFINITY; 4];
    for (p, &k) in uv.iter().zip(labels) {
        count[k] += 1;
        sum[k] += p[k / 2];
        let along = p[1 - k / 2];
        lo[k] = lo[k].min(along);
        hi[k] = hi[k].max(along);
    }
    std::array::from_fn(|k| {
        if count[k] == 0 {
            (0, 0.0, 0.0)
        } else {
            (count[k], sum[k] / count[k] as f64, hi[k] - lo[k])
        }
    })
}

/// BIC of a side model: N ln(RSS/N) + k ln N, the RSS floored at the point noise floor.
pub(crate) fn bic(rss_m2: f64, n: usize, parameters: usize, min_std_m: f64) -> f64 {
    let n_f = n as f64;
    let variance = (rss_m2 / n_f).max(min_std_m * min_std_m);
    n_f * variance.ln() + parameters as f64 * n_f.ln()
}

/// Iterates assignment and mean offsets from `offsets` until the assignment settles, dropping
/// sides that lose their support and the weaker of two opposite sides that come too close.
fn settle(uv: &[[f64; 2]], mut offsets: Offsets, params: &Params) -> (Offsets, Vec<usize>, f64) {
    let mut previous: Vec<usize> = Vec::new();
    let mut labels: Vec<usize> = Vec::with_capacity(uv.len());
    for _ in 0..MAX_ITERATIONS {
        let rss = assign_into(uv, &offsets, &mut labels);
        if labels == previous {
            // Settled: these offsets' assignment is the answer.
            return (offsets, labels, rss);
        }
        let stats = side_stats(uv, &labels);
        let present = offsets.iter().filter(|o| o.is_some()).count();
        let strongest = (0..4).max_by_key(|&k| stats[k].0).unwrap_or(0);
        for k in 0..4 {
            offsets[k] = offsets[k].map(|_| stats[k].1);
            let weak = stats[k].0 < params.min_side_points as usize;
            if offsets[k].is_some() && weak && present > 1 && k != strongest {
                offsets[k] = None;
            }
        }
        for axis in 0..2 {
            let (a, b) = (2 * axis, 2 * axis + 1);
            if let (Some(lo), Some(hi)) = (offsets[a], offsets[b]) {
                if hi - lo < params.min_opposite_sides_m {
                    let drop = if stats[a].0 < stats[b].0 { a } else { b };
                    offsets[drop] = None;
                }
            }
        }
        std::mem::swap(&mut previous, &mut labels);
    }
    let rss = assign_into(uv, &offsets, &mut labels);
    (offsets, labels, rss)
}

/// Sides at yaw θ: the bounding box's four sides, settled.
fn sides_at_yaw(uv: &[[f64; 2]], params: &Params) -> (Offsets, Vec<usize>, f64) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in uv {
        for a in 0..2 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    settle(
        uv,
        [Some(lo[0]), Some(hi[0]), Some(lo[1]), Some(hi[1])],
        params,
    )
}

fn present_count(offsets: &Offsets) -> usize {
    offsets.iter().filter(|o| o.is_some()).count()
}

/// Drops sides too short to be sides, then, one at a time, any side whose removal does not
/// worsen the BIC.
///
/// A side counts only by its points outside the bands of the perpendicular sides (farther than
/// 2.5 σ̂ from their lines): the end of a thick band is closer to a perpendicular "side" at the
/// band's end than to the band's middle line, but it lies entirely within the band.
fn prune_sides(uv: &[[f64; 2]], mut offsets: Offsets, params: &Params) -> Offsets {
    let n = uv.len();
    let (_, labels, rss) = settle(uv, offsets, params);
    let band_m = 2.5 * (rss / n as f64).sqrt().max(params.min_point_std_m);
    let mut spans = [0.0f64; 4];
    for k in (0..4).filter(|&k| offsets[k].is_some()) {
        let along = 1 - k / 2;
        let perpendicular: Vec<f64> = (0..4)
            .filter(|&j| j / 2 != k / 2)
            .filter_map(|j| offsets[j])
            .collect();
        // The perpendicular lines cut the axis into intervals; a real side lies in one of them
        // (the tails of a thick band fall on both sides of its line and do not add up).
        let mut cuts = perpendicular.clone();
        cuts.sort_by(f64::total_cmp);
        let mut lo = vec![f64::INFINITY; cuts.len() + 1];
        let mut hi = vec![f64::NEG_INFINITY; cuts.len() + 1];
        let mut count = vec![0usize; cuts.len() + 1];
        for (p, _) in uv.iter().zip(&labels).filter(|(_, &l)| l == k) {
            if cuts.iter().all(|c| (p[along] - c).abs() > band_m) {
                let interval = cuts.iter().filter(|&&c| p[along] > c).count();
                lo[interval] = lo[interval].min(p[along]);
                hi[interval] = hi[interval].max(p[along]);
                count[interval] += 1;
            }
        }
        for i in 0..count.len() {
            if count[i] >= params.min_side_points as usize {
                spans[k] = spans[k].max(hi[i] - lo[i]);
            }
        }
    }
    let longest = (0..4)
        .filter(|&k| offsets[k].is_some())
        .max_by(|&a, &b| spans[a].total_cmp(&spans[b]));
    for k in 0..4 {
        if Some(k) != longest && spans[k] < params.min_side_length_m {
            offsets[k] = None;
        }
    }
    loop {
        let (settled, _, rss) = settle(uv, offsets, params);
        offsets = settled;
        if present_count(&offsets) <= 1 {
            return offsets;
        }
        let current = bic(rss, n, 1 + present_count(&offsets), params.min_point_std_m);
        let mut best: Option<(f64, Offsets)> = None;
        for k in (0..4).filter(|&k| offsets[k].is_some()) {
            let mut trial = offsets;
            trial[k] = None;
            let (trial, _, rss) = settle(uv, trial, params);
            let score = bic(rss, n, 1 + present_count(&trial), params.min_point_std_m);
            if score <= current && best.as_ref().is_none_or(|(s, _)| score < *s) {
                best = Some((score, trial));
            }
        }
        match best {
            Some((_, trial)) => offsets = trial,
            None => return offsets,
        }
    }
}

/// Gauss–Newton on (θ, offsets of the present sides). Returns θ, the offsets, the final
/// assignment, the RSS and the least-squares information matrix JᵀJ.
fn refine(
    points: &[[f64; 2]],
    mut theta: f64,
    mut offsets: Offsets,
) -> (f64, Offsets, Vec<usize>, f64, DMatrix<f64>) {
    let present: Vec<usize> = (0..4).filter(|&k| offsets[k].is_some()).collect();
    let m = 1 + present.len();
    let mut info = DMatrix::zeros(m, m);
    for _ in 0..MAX_ITERATIONS {
        let uv = project(points, theta);
        let (labels, _) = assign(&uv, &offsets);
        let mut jtj = DMatrix::<f64>::zeros(m, m);
        let mut jtr = DVector::<f64>::zeros(m);
        for (p, &k) in uv.iter().zip(&labels) {
            let r = p[k / 2] - offsets[k].unwrap_or(0.0);
            // d(e1·p)/dθ = e2·p = v; d(e2·p)/dθ = −e1·p = −u.
            let d_theta = if k / 2 == 0 { p[1] } else { -p[0] };
            let j_index = 1 + present.iter().position(|&q| q == k).unwrap_or(0);
            let mut row = DVector::<f64>::zeros(m);
            row[0] = d_theta;
            row[j_index] = -1.0;
            jtj += &row * row.transpose();
            jtr += &row * r;
        }
        info = jtj.clone();
        let Some(step) = jtj.clone().cholesky().map(|c| c.solve(&(-jtr))) else {
            break;
        };
        if !step.iter().all(|s| s.is_finite()) {
            break;
        }
        theta += step[0];
        for (i, &k) in present.iter().enumerate() {
            offsets[k] = offsets[k].map(|c| c + step[1 + i]);
        }
        if step.amax() < 1e-10 {
            break;
        }
    }
    let uv = project(points, theta);
    let (labels, rss) = assign(&uv, &offsets);
    (theta, offsets, labels, rss, info)
}

/// Fits a rectangle to `points` (centred on their centroid; at least 3 distinct). `sensor_side`
/// decides, for a single seen side, whether the viewpoints lie on its +normal side: it gets the
/// side's midpoint and unit normal and returns a weighted vote (> 0: the viewpoints are on the
/// normal's side).
pub(crate) fn fit_rectangle(
    points: &[[f64; 2]],
    params: &Params,
    sensor_side: &dyn Fn([f64; 2], [f64; 2]) -> f64,
) -> Option<RectangleFit> {
    let n = points.len();
    let mut best: Option<(f64, f64)> = None;
    for step in 0..YAW_STEPS {
        let theta = FRAC_PI_2 * step as f64 / YAW_STEPS as f64;
        let uv = project(points, theta);
        let (offsets, _, rss) = sides_at_yaw(&uv, params);
        let score = bic(rss, n, 1 + present_count(&offsets), params.min_point_std_m);
        if best.is_none_or(|(s, _)| score < s) {
            best = Some((score, theta));
        }
    }
    let (_, theta0) = best?;
    let uv = project(points, theta0);
    let (offsets, _, _) = sides_at_yaw(&uv, params);
    let offsets = prune_sides(&uv, offsets, params);
    let (theta, offsets, labels, rss, info) = refine(points, theta0, offsets);
    if !(theta.is_finite() && rss.is_finite()) {
        return None;
    }
    let sigma_m = (rss / n as f64).sqrt().max(params.min_point_std_m);
    let layout = Layout::new(
        points,
        theta,
        offsets,
        &labels,
        params,
        sigma_m,
        sensor_side,
    );
    let parameters = 1 + present_count(&layout.offsets);
    let dof = n.saturating_sub(parameters);
    let sigma2 = if dof > 0 { rss / dof as f64 } else { 0.0 }.max(params.min_point_std_m.powi(2));
    let (center_m, size_m, yaw_rad, covariance) = layout.estimate(&info, sigma2, params)?;
    let [cx, cy, w, h, band_theta] = layout.outputs(&layout.z, params.cell_size_m, 0.0);
    Some(RectangleFit {
        center_m,
        size_m,
        yaw_rad,
        covariance,
        sides_seen: present_count(&layout.offsets) as u8,
        rss_m2: rss,
        band_outline_m: crate::shape::rectangle_corners([cx, cy], [w, h], band_theta),
    })
}

/// Which order statistic of the points' projections on `axis` (0 = u, 1 = v, at yaw θ) estimates
/// where the outline ends: noise of standard deviation σ along the side pushes about
/// λσ/√(2π) ≈ 0.4 λσ of the points (λ per metre) beyond the true end, so the extreme point is
/// biased outward and the point that many in is not. σ along the side is taken equal to the
/// residuals' σ̂ across it (isotropic noise).
fn extent_rank(points: &[[f64; 2]], axis: usize, theta: f64, sigma_m: f64) -> usize {
    let (e1, e2) = axes(theta);
    let e = if axis == 0 { e1 } else { e2 };
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &p| {
            let t = dot(e, p);
            (l.min(t), h.max(t))
        });
    let span = hi - lo;
    // Also catches a NaN span.
    if span.is_nan() || span <= 0.0 {
        return 0;
    }
    let per_m = points.len() as f64 / span;
    ((0.4 * per_m * sigma_m).floor() as usize).min(points.len() / 4)
}

/// How each of the four side positions follows from the primitive estimates z.
#[derive(Debug, Clone)]
enum Position {
    /// A seen side: z[index] is its offset.
    Seen(usize),
    /// An unseen side ending where the given points end along its axis (max or min), plus the
    /// extent error z[index].
    Extent {
        points: Vec<[f64; 2]>,
        high: bool,
        index: usize,
        /// Which extreme: 0 the outermost projection, k the (k+1)-th (see [`extent_rank`]).
        rank: usize,
    },
    /// The single seen side `from` moved by `sign`·z[index] (the prior depth).
    Depth {
        from: usize,
        sign: f64,
        index: usize,
    },
}

/// Centre, size, yaw and the row-major 5×5 covariance.
type Estimate = ([f64; 2], [f64; 2], f64, Vec<f64>);

/// The primitive estimates and how the rectangle follows from them.
struct Layout {
    offsets: Offsets,
    positions: Vec<Position>,
    /// Mean of z; z[0] = θ.
    z: Vec<f64>,
    /// Variances of the extent errors and the depth, by index in z (0 for the least-squares
    /// block, whose covariance comes from the information matrix).
    prior_variance: Vec<f64>,
}

impl Layout {
    /// The primitive estimates: θ, the seen offsets, then extent errors and the depth.
    fn new(
        points: &[[f64; 2]],
        theta: f64,
        mut offsets: Offsets,
        labels: &[usize],
        params: &Params,
        sigma_m: f64,
        sensor_side: &dyn Fn([f64; 2], [f64; 2]) -> f64,
    ) -> Self {
        let extent_variance = params.extent_std_m.powi(2) + sigma_m.powi(2);
        let uv = project(points, theta);
        let mut z = vec![theta];
        let mut prior_variance = vec![0.0];
        let mut positions: Vec<Option<Position>> = vec![None; 4];
        if present_count(&offsets) == 1 {
            let seen = (0..4).find(|&k| offsets[k].is_some()).unwrap_or(0);
            let (a, b) = (seen / 2, 1 - seen / 2);
            let c = offsets[seen].unwrap_or(0.0);
            let (lo, hi) = uv
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
                    (l.min(p[b]), h.max(p[b]))
                });
            let (e1, e2) = axes(theta);
            let (ea, eb) = if a == 0 { (e1, e2) } else { (e2, e1) };
            let mid = (lo + hi) / 2.0;
            let anchor = [c * ea[0] + mid * eb[0], c * ea[1] + mid * eb[1]];
            // The side is seen from outside: viewpoints on its +normal side make it the high side
            // of the rectangle, which then extends towards −normal.
            let high = sensor_side(anchor, ea) > 0.0;
            let seen_side = 2 * a + usize::from(high);
            offsets = [None; 4];
            offsets[seen_side] = Some(c);
            z.push(c);
            prior_variance.push(0.0);
            positions[seen_side] = Some(Position::Seen(1));
            let depth_m = (hi - lo).clamp(params.unseen_depth_min_m, params.unseen_depth_max_m);
            positions[2 * a + 1 - usize::from(high)] = Some(Position::Depth {
                from: seen_side,
                sign: if high { -1.0 } else { 1.0 },
                index: z.len(),
            });
            z.push(depth_m);
            prior_variance.push(params.unseen_depth_std_m.powi(2));
            for (side, high_end) in [(2 * b, false), (2 * b + 1, true)] {
                positions[side] = Some(Position::Extent {
                    points: points.to_vec(),
                    high: high_end,
                    index: z.len(),
                    rank: extent_rank(points, b, theta, sigma_m),
                });
                z.push(0.0);
                prior_variance.push(extent_variance);
            }
        } else {
            for k in (0..4).filter(|&k| offsets[k].is_some()) {
                positions[k] = Some(Position::Seen(z.len()));
                z.push(offsets[k].unwrap_or(0.0));
                prior_variance.push(0.0);
            }
            for k in (0..4).filter(|&k| offsets[k].is_none()) {
                // Where the seen sides of the other axis end along this side's axis.
                let other_axis = 1 - k / 2;
                let adjacent: Vec<[f64; 2]> = points
                    .iter()
                    .zip(labels)
                    .filter(|(_, &l)| l / 2 == other_axis)
                    .map(|(p, _)| *p)
                    .collect();
                let rank = extent_rank(&adjacent, k / 2, theta, sigma_m);
                positions[k] = Some(Position::Extent {
                    points: adjacent,
                    high: k % 2 == 1,
                    index: z.len(),
                    rank,
                });
                z.push(0.0);
                prior_variance.push(extent_variance);
            }
        }
        Self {
            offsets,
            positions: positions
                .into_iter()
                .map(|p| p.expect("every side placed"))
                .collect(),
            z,
            prior_variance,
        }
    }

    /// (cx, cy, w, h, yaw) in the centred frame for primitive estimates `z`.
    fn outputs(&self, z: &[f64], min_size_m: f64, surface_offset_m: f64) -> [f64; 5] {
        let theta = z[0];
        let (e1, e2) = axes(theta);
        let mut pos = [0.0; 4];
        for (k, position) in self.positions.iter().enumerate() {
            pos[k] = match position {
                // Sides 1 and 3 are the high ones: outward is +.
                Position::Seen(i) if k % 2 == 1 => z[*i] + surface_offset_m,
                Position::Seen(i) => z[*i] - surface_offset_m,
                Position::Extent {
                    points,
                    high,
                    index,
                    rank,
                } => {
                    let axis = if k / 2 == 0 { e1 } else { e2 };
                    let mut projections: Vec<f64> = points.iter().map(|&p| dot(axis, p)).collect();
                    projections.sort_by(f64::total_cmp);
                    let i = (*rank).min(projections.len().saturating_sub(1));
                    let end = if *high {
                        projections[projections.len() - 1 - i]
                    } else {
                        projections[i]
                    };
                    end + z[*index]
                }
                Position::Depth { .. } => 0.0,
            };
        }
        for (k, position) in self.positions.iter().enumerate() {
            if let Position::Depth { from, sign, index } = position {
                pos[k] = pos[*from] + sign * z[*index];
            }
        }
        let (cu, cv) = ((pos[0] + pos[1]) / 2.0, (pos[2] + pos[3]) / 2.0);
        let w = (pos[1] - pos[0]).max(min_size_m);
        let h = (pos[3] - pos[2]).max(min_size_m);
        [
            cu * e1[0] + cv * e2[0],
            cu * e1[1] + cv * e2[1],
            w,
            h,
            theta,
        ]
    }

    /// Centre, size, yaw in [0, π/2) and the 5×5 covariance, from the least-squares information
    /// matrix (θ and the seen offsets) scaled by the point variance `sigma2`.
    fn estimate(&self, info: &DMatrix<f64>, sigma2: f64, params: &Params) -> Option<Estimate> {
        let m = info.nrows();
        let nz = self.z.len();
        let lsq = info.clone().try_inverse()? * sigma2;
        let shared = params.offset_std_m.powi(2) + params.offset_std_per_std.powi(2) * sigma2;
        let mut sigma_z = DMatrix::<f64>::zeros(nz, nz);
        for i in 0..nz {
            sigma_z[(i, i)] = self.prior_variance[i];
        }
        // With one seen side, z's least-squares block is (θ, offset) = info's, at 0..m too.
        sigma_z.view_mut((0, 0), (m, m)).copy_from(&lsq);
        for i in 1..m {
            sigma_z[(i, i)] += shared;
        }
        let (min_size_m, surface_m) = (
            params.cell_size_m,
            params.surface_offset_per_std * sigma2.sqrt(),
        );
        let mean = self.outputs(&self.z, min_size_m, surface_m);
        let mut jacobian = DMatrix::<f64>::zeros(5, nz);
        for i in 0..nz {
            let h = 1e-6 * self.z[i].abs().max(1.0);
            let (mut plus, mut minus) = (self.z.clone(), self.z.clone());
            plus[i] += h;
            minus[i] -= h;
            let (fp, fm) = (
                self.outputs(&plus, min_size_m, surface_m),
                self.outputs(&minus, min_size_m, surface_m),
            );
            for r in 0..5 {
                jacobian[(r, i)] = (fp[r] - fm[r]) / (2.0 * h);
            }
        }
        let mut cov = &jacobian * sigma_z * jacobian.transpose();
        let [cx, cy, mut w, mut h, theta] = mean;
        let mut quarter_turns = (theta / FRAC_PI_2).floor();
        let mut yaw = theta - quarter_turns * FRAC_PI_2;
        // Rounding can leave θ = −ε at exactly π/2: that is one more quarter turn, to yaw 0.
        if yaw >= FRAC_PI_2 {
            yaw -= FRAC_PI_2;
            quarter_turns += 1.0;
        }
        let yaw = yaw.max(0.0);
        if (quarter_turns as i64).rem_euclid(2) == 1 {
            std::mem::swap(&mut w, &mut h);
            cov.swap_rows(2, 3);
            cov.swap_columns(2, 3);
        }
        let flat: Vec<f64> = (0..5)
            .flat_map(|r| (0..5).map(move |c| (r, c)))
            .map(|(r, c)| {
                // Symmetrise: the product is symmetric only up to rounding.
                (cov[(r, c)] + cov[(c, r)]) / 2.0
            })
            .collect();
        if !(flat.iter().all(|v| v.is_finite())
            && [cx, cy, w, h, yaw].iter().all(|v| v.is_finite()))
        {
            return None;
        }
        Some(([cx, cy], [w, h], yaw, flat))
    }
}
