//! Map-like synthetic segments for the tests: detections along the seen parts of a true outline,
//! each with isotropic Gaussian noise, reduced to the distinct centres of the 0.1 m cells they
//! fall in, as the occupancy map and the segmenter deliver them.

use std::collections::BTreeSet;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Map cell side (m).
pub const CELL_M: f64 = 0.1;
/// Detections per metre of seen outline.
const DETECTIONS_PER_M: f64 = 30.0;

/// Distinct cell centres of `samples` after noise of standard deviation `sigma_m`.
pub fn cells(samples: &[[f64; 2]], sigma_m: f64, rng: &mut ChaCha8Rng) -> Vec<[f64; 2]> {
    let noise = Normal::new(0.0, sigma_m.max(1e-12)).expect("valid sigma");
    let mut set = BTreeSet::new();
    for p in samples {
        let x = p[0] + noise.sample(rng);
        let y = p[1] + noise.sample(rng);
        set.insert(((x / CELL_M).floor() as i64, (y / CELL_M).floor() as i64));
    }
    set.into_iter()
        .map(|(i, j)| [(i as f64 + 0.5) * CELL_M, (j as f64 + 0.5) * CELL_M])
        .collect()
}

/// Detections along the listed sides of a rectangle. Side k runs from corner k to corner k + 1
/// (corners counter-clockwise from local (−w/2, −h/2)): 0 = low v, 1 = high u, 2 = high v,
/// 3 = low u.
pub fn rectangle_samples(
    center: [f64; 2],
    size: [f64; 2],
    yaw: f64,
    sides: &[usize],
) -> Vec<[f64; 2]> {
    let corners = crate::shape::rectangle_corners(center, size, yaw);
    let mut out = Vec::new();
    for &k in sides {
        let (a, b) = (corners[k], corners[(k + 1) % 4]);
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        let n = (len * DETECTIONS_PER_M).ceil() as usize;
        for i in 0..=n {
            let t = i as f64 / n as f64;
            out.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    out
}

/// Detections along the arc of a circle from `from_rad` to `to_rad` (counter-clockwise).
pub fn arc_samples(center: [f64; 2], radius: f64, from_rad: f64, to_rad: f64) -> Vec<[f64; 2]> {
    let n = (radius * (to_rad - from_rad) * DETECTIONS_PER_M)
        .ceil()
        .max(2.0) as usize;
    (0..=n)
        .map(|i| {
            let phi = from_rad + (to_rad - from_rad) * i as f64 / n as f64;
            [
                center[0] + radius * phi.cos(),
                center[1] + radius * phi.sin(),
            ]
        })
        .collect()
}

/// A point uniformly inside one cell around `base`, so the truth is not aligned to the grid.
pub fn jitter(base: [f64; 2], rng: &mut ChaCha8Rng) -> [f64; 2] {
    [
        base[0] + rng.random_range(0.0..CELL_M),
        base[1] + rng.random_range(0.0..CELL_M),
    ]
}

/// Mean and the fraction of values in [lo, hi].
pub fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len().max(1) as f64
}

/// The parameters for these segments: their cells come from independent noise, not from an
/// occupancy map, so there is no free-space carving and no inward offset to undo or allow for
/// (`surface_offset_per_std` and `offset_std_per_std` 0).
pub fn unbiased_params() -> crate::Params {
    crate::Params {
        surface_offset_per_std: 0.0,
        offset_std_per_std: 0.0,
        ..crate::Params::default()
    }
}
