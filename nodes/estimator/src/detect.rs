//! Detection on a range × angle power map: noise floor, peak picking, CA-CFAR, dynamic range.
//!
//! The map is `rows` × `cols`, row-major (a row is one range bin, its cells the angle bins in
//! storage order). Angle is circular (the array DFT is periodic in sin θ); range is circular only
//! when the map holds the whole unambiguous range. Local maxima are taken over the 8-neighbourhood
//! with a strict/non-strict tie-break by storage order, so a plateau of equal cells (a noise-free
//! echo exactly between two bins) gives exactly one peak.

use crate::config::{Detector, EstimatorConfig};

/// A read-only view of a power map and what the detector needs to know about it.
pub(crate) struct MapView<'a> {
    pub power: &'a [f64],
    pub row_max: &'a [f64],
    pub rows: usize,
    pub cols: usize,
    /// Rows `0..search_rows` are searched; later rows are only neighbours.
    pub search_rows: usize,
    pub circular_range: bool,
    /// Per storage column: whether sin θ of the column is within [−1, 1].
    pub visible: &'a [bool],
}

/// One peak: storage row and column, power.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Peak {
    pub row: usize,
    pub col: usize,
    pub power: f64,
}

/// Shape of the transforms behind a map, for the side-lobe envelope.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Lobes {
    /// Range bins of the whole (padded) unambiguous range: the range period of the map.
    pub range_period: usize,
    /// Unpadded range transform length N and the zero-padding factor.
    pub range_len: usize,
    pub range_pad: f64,
    /// Unpadded angle transform length K and the zero-padding factor.
    pub angle_len: usize,
    pub angle_pad: f64,
}

/// Rectangular-window side-lobe bound relative to the peak bin, `dist` padded bins away from it:
/// the echo lies within ½ (padded) bin of the peak bin, so at least u = dist/pad − ½/pad
/// unpadded bins from the cell; inside the main lobe (u < 1) nothing can be told apart (1);
/// beyond, a side lobe peaks at most at 1/(L sin(π max(u, 1.43)/L))² of the echo's true peak
/// (−13.3 dB for the first), and the peak bin holds at least the scalloped fraction
/// (sin(πh)/(L sin(πh/L)))², h = ½/pad, of it.
pub(crate) fn envelope(dist: usize, pad: f64, len: usize) -> f64 {
    let u = (dist as f64 - 0.5) / pad;
    if u < 1.0 {
        return 1.0;
    }
    let l = len.max(2) as f64;
    let a = std::f64::consts::PI / l;
    let side = (l * (u.max(1.43) * a).sin()).powi(-2);
    let h = 0.5 / pad;
    let scallop = ((std::f64::consts::PI * h).sin() / (l * (h * a).sin())).powi(2);
    let g = side / scallop;
    if g.is_finite() {
        g.min(1.0)
    } else {
        1.0
    }
}

pub(crate) fn circular(a: usize, b: usize, period: usize) -> usize {
    let d = a.abs_diff(b);
    if period > 0 {
        let d = d % period;
        d.min(period - d)
    } else {
        d
    }
}

/// CA-CFAR's threshold factor α = n (Pfa^(−1/n) − 1) for `n_train` training cells: exact for
/// exponential (noise-only, M = 1) cells.
pub(crate) fn cfar_factor(n_train: usize, pfa: f64) -> f64 {
    let n = n_train as f64;
    n * (pfa.powf(-1.0 / n) - 1.0)
}

/// Training cells of a full (not clipped by a map edge) CFAR window.
pub(crate) fn full_training_cells(config: &EstimatorConfig) -> usize {
    let (gr, ga) = (config.cfar_guard_range, config.cfar_guard_angle);
    let (hr, ha) = (gr + config.cfar_train_range, ga + config.cfar_train_angle);
    (2 * hr + 1) * (2 * ha + 1) - (2 * gr + 1) * (2 * ga + 1)
}

/// [`envelope`] by distance for one (pad, len), filled as distances are asked for: the
/// side-lobe blanking compares every candidate with every kept peak, three sines each, at
/// integer distances that repeat from pair to pair and frame to frame.
#[derive(Debug, Default)]
struct EnvelopeMemo {
    /// The pad's bits and the length the values are for.
    key: Option<(u64, usize)>,
    /// By distance; NaN where not computed yet ([`envelope`] is never NaN).
    values: Vec<f64>,
}

impl EnvelopeMemo {
    /// Distances kept; beyond, the envelope is computed every time.
    const MAX_DISTANCE: usize = 1 << 16;

    fn envelope(&mut self, dist: usize, pad: f64, len: usize) -> f64 {
        let key = (pad.to_bits(), len);
        if self.key != Some(key) {
            self.key = Some(key);
            self.values.clear();
        }
        if dist >= Self::MAX_DISTANCE {
            return envelope(dist, pad, len);
        }
        if dist >= self.values.len() {
            self.values.resize(dist + 1, f64::NAN);
        }
        if self.values[dist].is_nan() {
            self.values[dist] = envelope(dist, pad, len);
        }
        self.values[dist]
    }
}

/// Scratch reused from frame to frame.
#[derive(Debug, Default)]
pub(crate) struct DetectScratch {
    sample: Vec<f64>,
    peaks: Vec<Peak>,
    alpha: Vec<f64>,
    /// The range and the angle side-lobe envelopes.
    envelopes: [EnvelopeMemo; 2],
}

/// Cells sampled for the median noise floor.
const FLOOR_SAMPLES: usize = 4096;

impl MapView<'_> {
    #[inline]
    fn at(&self, row: usize, col: usize) -> f64 {
        self.power[row * self.cols + col]
    }

    /// Whether (row, col) with power `p` is a local maximum of its 8-neighbourhood.
    ///
    /// Neighbours wrap in angle (and in range when `circular_range`); the wrapped indices are
    /// picked by comparison, not `rem_euclid` (an integer division per neighbour). The same-row
    /// neighbours are tested first: most cells above the threshold lie on a side-lobe ridge and
    /// fail there. The order of the tests does not change the result (all must pass).
    #[inline]
    fn is_local_max(&self, row: usize, col: usize, p: f64) -> bool {
        let cols = self.cols;
        let own = row * cols + col;
        let left = if col == 0 { cols - 1 } else { col - 1 };
        let right = if col + 1 == cols { 0 } else { col + 1 };
        // A neighbour at storage index `key` beats the cell when it is at least as strong and
        // earlier, or stronger and later (a plateau keeps exactly its first cell).
        let beaten = |key: usize| {
            let q = self.power[key];
            (key < own && p <= q) || (key > own && p < q)
        };
        if beaten(row * cols + left) || beaten(row * cols + right) {
            return false;
        }
        let above = if row > 0 {
            Some(row - 1)
        } else if self.circular_range {
            Some(self.rows - 1)
        } else {
            None
        };
        let below = if row + 1 < self.rows {
            Some(row + 1)
        } else if self.circular_range {
            Some(0)
        } else {
            None
        };
        for r in [above, below].into_iter().flatten() {
            let base = r * cols;
            if beaten(base + left) || beaten(base + col) || beaten(base + right) {
                return false;
            }
        }
        true
    }
}

impl DetectScratch {
    /// Median of (a sample of) the searched cells' powers divided by ln 2: the mean of
    /// exponentially distributed noise cells, robust to a sparse set of echoes.
    pub fn noise_floor(&mut self, v: &MapView) -> f64 {
        let total = v.search_rows * v.cols;
        if total == 0 {
            return 0.0;
        }
        // An odd stride walks through every column of a power-of-two-wide map.
        let stride = (total / FLOOR_SAMPLES).max(1) | 1;
        self.sample.clear();
        self.sample
            .extend((0..total).step_by(stride).map(|i| v.power[i]));
        let mid = self.sample.len() / 2;
        let (_, median, _) = self.sample.select_nth_unstable_by(mid, f64::total_cmp);
        *median / std::f64::consts::LN_2
    }

    /// The detections of one map, strongest first, at most `config.max_detections`.
    pub fn detect(
        &mut self,
        v: &MapView,
        config: &EstimatorConfig,
        floor: f64,
        lobes: Lobes,
    ) -> &[Peak] {
        self.peaks.clear();
        match config.detector {
            Detector::PeakPicking => {
                let thr = floor * 10f64.powf(config.threshold_db / 10.0);
                for row in 0..v.search_rows {
                    if v.row_max[row] <= thr {
                        continue;
                    }
                    let line = &v.power[row * v.cols..(row + 1) * v.cols];
                    for (col, &p) in line.iter().enumerate() {
                        if p > thr && v.visible[col] && v.is_local_max(row, col, p) {
                            self.peaks.push(Peak { row, col, power: p });
                        }
                    }
                }
            }
            Detector::Cfar => self.cfar(v, config, floor),
        }
        if let Some(strongest) = self.peaks.iter().map(|p| p.power).reduce(f64::max) {
            let keep = strongest * 10f64.powf(-config.dynamic_range_db / 10.0);
            self.peaks.retain(|p| p.power >= keep);
        }
        self.peaks
            .sort_unstable_by(|a, b| b.power.total_cmp(&a.power));
        let max = config.max_detections;
        match config.sidelobe_margin_db {
            None => self.peaks.truncate(max),
            Some(margin) => {
                let margin = 10f64.powf(margin / 10.0);
                let mut kept = 0;
                let [range_envelope, angle_envelope] = &mut self.envelopes;
                for idx in 0..self.peaks.len() {
                    if kept == max {
                        break;
                    }
                    let q = self.peaks[idx];
                    let blanked = self.peaks[..kept].iter().any(|s| {
                        let dr = circular(q.row, s.row, lobes.range_period);
                        let da = circular(q.col, s.col, v.cols);
                        let g = range_envelope.envelope(dr, lobes.range_pad, lobes.range_len)
                            * angle_envelope.envelope(da, lobes.angle_pad, lobes.angle_len);
                        q.power <= s.power * g * margin
                    });
                    if !blanked {
                        self.peaks[kept] = q;
                        kept += 1;
                    }
                }
                self.peaks.truncate(kept);
            }
        }
        &self.peaks
    }

    fn alpha(&mut self, n_train: usize, pfa: f64) -> f64 {
        if self.alpha.len() <= n_train {
            self.alpha.resize(n_train + 1, f64::NAN);
        }
        if self.alpha[n_train].is_nan() {
            self.alpha[n_train] = cfar_factor(n_train, pfa);
        }
        self.alpha[n_train]
    }

    /// 2-D CA-CFAR at the local maxima. Training sums are direct (no summed-area table: its
    /// differences of prefix sums lose weak cells next to echoes 300 dB stronger). Cells more
    /// than 6 dB below α·floor are not tested: they could only pass in a training window whose
    /// mean is under a quarter of the frame's median-based floor.
    fn cfar(&mut self, v: &MapView, config: &EstimatorConfig, floor: f64) {
        let (gr, ga) = (config.cfar_guard_range, config.cfar_guard_angle);
        let (hr, ha) = (gr + config.cfar_train_range, ga + config.cfar_train_angle);
        let full = full_training_cells(config);
        let pre = self.alpha(full, config.cfar_pfa) * floor / 4.0;
        let rows = v.rows as isize;
        let cols = v.cols as isize;
        for row in 0..v.search_rows {
            if v.row_max[row] <= pre {
                continue;
            }
            for col in 0..v.cols {
                let p = v.at(row, col);
                if p <= pre || !v.visible[col] || !v.is_local_max(row, col, p) {
                    continue;
                }
                let mut sum = 0.0;
                let mut n = 0usize;
                for dr in -(hr as isize)..=hr as isize {
                    let r = row as isize + dr;
                    let r = if r < 0 || r >= rows {
                        if !v.circular_range || 2 * hr as isize + 1 > rows {
                            continue;
                        }
                        r.rem_euclid(rows)
                    } else {
                        r
                    } as usize;
                    let in_guard_r = dr.unsigned_abs() <= gr;
                    let line = &v.power[r * v.cols..(r + 1) * v.cols];
                    for dc in -(ha as isize)..=ha as isize {
                        if in_guard_r && dc.unsigned_abs() <= ga {
                            continue;
                        }
                        sum += line[(col as isize + dc).rem_euclid(cols) as usize];
                        n += 1;
                    }
                }
                if n == 0 {
                    continue;
                }
                if p > self.alpha(n, config.cfar_pfa) * sum / n as f64 {
                    self.peaks.push(Peak { row, col, power: p });
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_envelope_memo_answers_as_the_envelope() {
        let mut memo = EnvelopeMemo::default();
        // Two shapes in turn (the memo starts over for each), distances in any order, some
        // beyond what it keeps.
        for (pad, len) in [(1.0, 10240), (4.0, 32), (1.0, 10240)] {
            for dist in [
                0,
                1,
                2,
                7,
                3,
                2,
                500,
                5119,
                1,
                EnvelopeMemo::MAX_DISTANCE + 3,
            ] {
                assert_eq!(
                    memo.envelope(dist, pad, len).to_bits(),
                    envelope(dist, pad, len).to_bits(),
                    "dist {dist}, pad {pad}, len {len}"
                );
            }
        }
    }
}
