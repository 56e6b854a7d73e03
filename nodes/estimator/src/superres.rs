//! Super-resolution angle estimation in one range cell: the array snapshot(s) of a range bin that
//! holds a detection are resolved into several plane waves, beyond the array DFT's grid and its
//! Rayleigh limit 2/K in sin θ (paper Sec. III-B's angle DFT, eq. (AOA_1_1_2), is the baseline).
//!
//! - **Covariance.** The scatterers of one extended target are coherent (one frame, one symbol at
//!   the default M = 1), so the sample covariance of a single snapshot has rank one. Spatial
//!   smoothing over the K − L + 1 subarrays of length L and forward–backward averaging
//!   (R ← (R + J R* J)/2) restore the rank up to min(L, 2(K − L + 1)); a diagonal loading of
//!   10⁻⁹ · tr(R)/L keeps noise-free inputs positive definite.
//! - **Model order** in two steps. The signal subspace holds the eigenvalues above the largest
//!   that noise alone gives (the frame's noise floor is known; `signal_dimension`) and above a
//!   tenth of what a wave at the publication threshold gives (L · its power): the range side
//!   lobes of strong echoes in other bins are real waves here, 30–60 dB over the noise at
//!   Table I, and would otherwise fill the subspace (and the time). Of the waves
//!   it yields, each must then pass the threshold the DFT path's peaks obey (`threshold_db`, or
//!   the CFAR factor of `cfar_pfa`, over the floor) on its least-squares power: the stated
//!   false-alarm probability decides what is published. MDL was tried first and counted L − 1
//!   waves in pure noise: the K − L + 1 overlapping subarrays are far from independent
//!   snapshots, so its penalty is too small. Taking the largest order whose waves all pass
//!   failed on the closest pairs, whose one-wave fit falls between them and cancels.
//! - **MUSIC**: the noise-subspace projection 1 − ‖E_sᴴ a(ω)‖²/L on a grid of 16 L points (one FFT
//!   per signal eigenvector, shared by every order tried), its d deepest local minima placed by a
//!   parabola, then by Newton's method on the projection.
//! - **ESPRIT** (total least squares, Roy and Kailath): the rotation between the signal subspace's
//!   first and last L − 1 rows, Ψ = −V₁₂ V₂₂⁻¹, whose eigenvalues are e^{jω}.
//!
//! ω = 2π (d/λ) sin θ is the phase step per element of a(ω)_k = e^{jωk} (the estimator's sign
//! convention, `crate::estimator`). Amplitudes are the least-squares fit of a(ω₁..ω_d) to the
//! mean snapshot.
//!
//! Each wave's standard deviation (`crb_std`) is the Cramér–Rao bound of one tone in white noise,
//! var(ω̂) = 6 / (SNR (L² − 1)), at the SNR its power shows in the map (the map's coherent gain
//! is already in it), combined with a stated model floor (`EstimatorConfig::interpolated_std_fraction`
//! of the resolution cell) for what the single-tone bound cannot see: several scatterers of an
//! extended target inside one cell.

use nalgebra::{DMatrix, DVector};
use num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use std::f64::consts::PI;
use std::sync::Arc;

const ZERO: Complex64 = Complex64 { re: 0.0, im: 0.0 };

/// Which subspace method resolves a range cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Subspace {
    Music,
    Esprit,
}

/// The default subarray length of spatial smoothing: ⌈2K/3⌉, within 2 ..= K. Two thirds of the
/// aperture keeps most of its resolution and leaves K/3 + 1 subarrays (doubled by
/// forward–backward averaging) to decorrelate coherent waves.
pub(crate) fn default_subarray(k: usize) -> usize {
    (2 * k).div_ceil(3).clamp(2, k.max(2))
}

/// Reusable state of the per-cell solver for arrays of `k` elements and subarrays of `l`.
pub(crate) struct CellSolver {
    k: usize,
    l: usize,
    grid: usize,
    fft: Arc<dyn Fft<f64>>,
    buf: Vec<Complex64>,
    projection: Vec<f64>,
}

impl std::fmt::Debug for CellSolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CellSolver")
            .field("antennas", &self.k)
            .field("subarray", &self.l)
            .finish_non_exhaustive()
    }
}

/// One resolved plane wave: its phase step per element ω (rad, in (−π, π]) and its least-squares
/// amplitude in the mean snapshot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Wave {
    pub omega: f64,
    pub amplitude: Complex64,
}

impl CellSolver {
    /// A solver for `k` ≥ 2 elements with subarrays of `l` (clamped to 2 ..= k).
    pub fn new(k: usize, l: usize) -> Self {
        let l = l.clamp(2, k.max(2));
        let grid = (16 * l).next_power_of_two();
        let fft = FftPlanner::<f64>::new().plan_fft_forward(grid);
        Self {
            k,
            l,
            grid,
            fft,
            buf: vec![ZERO; grid],
            projection: vec![0.0; grid],
        }
    }

    /// The waves of one range cell. `snapshots` holds `snapshots.len() / k` array snapshots of
    /// `k` elements each (one per symbol), with noise power `noise_power` per element; `mean` is
    /// their mean. The order d is the number of the covariance's eigenvalues above the noise's
    /// (`signal_dimension`), at most L − 1; of the d waves found, those whose least-squares power
    /// |amplitude|² is under `min_power` (the detector's threshold, in the snapshot's units) are
    /// dropped and the rest refitted. Empty when the input is degenerate (all zero, or not
    /// finite) or no wave passes.
    pub fn solve(
        &mut self,
        method: Subspace,
        snapshots: &[Complex64],
        mean: &[Complex64],
        min_power: f64,
        noise_power: f64,
    ) -> Vec<Wave> {
        let (k, l) = (self.k, self.l);
        if k < 2 || snapshots.len() < k || mean.len() != k {
            return Vec::new();
        }
        if !snapshots
            .iter()
            .chain(mean)
            .all(|v| v.re.is_finite() && v.im.is_finite())
        {
            return Vec::new();
        }
        let r = smoothed_covariance(snapshots, k, l);
        let trace: f64 = (0..l).map(|i| r[(i, i)].re).sum();
        if !(trace.is_finite() && trace > 0.0) {
            return Vec::new();
        }
        let eig = r.symmetric_eigen();
        let mut order: Vec<usize> = (0..l).collect();
        order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
        let values: Vec<f64> = order.iter().map(|&i| eig.eigenvalues[i]).collect();
        // A wave at the threshold gives an eigenvalue of about L · min_power; a pair closer than
        // a beam splits it unevenly, so the subspace keeps eigenvalues down to a tenth of that.
        let least = (values
            .iter()
            .filter(|&&v| v > 0.1 * l as f64 * min_power)
            .count())
        .max(1);
        let d = signal_dimension(&values, noise_power, k, l, snapshots.len() / k).min(least);
        let signal = DMatrix::from_fn(l, d, |row, col| eig.eigenvectors[(row, order[col])]);
        let mut omegas = match method {
            Subspace::Music => {
                self.projection.fill(1.0);
                for col in 0..d {
                    self.add_to_projection(&signal, col);
                }
                let step = 2.0 * PI / self.grid as f64;
                let columns: Vec<&[Complex64]> = (0..d)
                    .map(|c| &signal.as_slice()[c * l..(c + 1) * l])
                    .collect();
                self.music_minima(d)
                    .into_iter()
                    .map(|w| wrap(beam_peak(&columns, w, step)))
                    .collect()
            }
            Subspace::Esprit => esprit(&signal),
        };
        let tolerance = PI / (64.0 * k as f64);
        // Drop what fails the threshold (weakest first, refitting), refine, drop again.
        for pass in 0..2 {
            omegas = distinct(omegas, tolerance);
            loop {
                let Some(amplitudes) = least_squares_amplitudes(mean, &omegas) else {
                    return Vec::new();
                };
                let weakest = amplitudes
                    .iter()
                    .enumerate()
                    .min_by(|a, b| a.1.norm_sqr().total_cmp(&b.1.norm_sqr()));
                match weakest {
                    Some((i, a)) if a.norm_sqr().is_nan() || a.norm_sqr() < min_power => {
                        omegas.remove(i);
                    }
                    _ if pass == 1 => {
                        return omegas
                            .into_iter()
                            .zip(amplitudes)
                            .map(|(omega, amplitude)| Wave { omega, amplitude })
                            .collect();
                    }
                    _ => break,
                }
            }
            refine_full_aperture(mean, &mut omegas);
        }
        Vec::new()
    }

    /// Takes eigenvector `col` of `vectors` out of the noise-subspace projection
    /// 1 − Σ |a(ω_q)ᴴ e|² / L on the grid ω_q = 2π q/G (one FFT: bin q is Σ e_l e^{−j2π q l/G}).
    fn add_to_projection(&mut self, vectors: &DMatrix<Complex64>, col: usize) {
        let l = self.l;
        self.buf.fill(ZERO);
        for row in 0..l {
            self.buf[row] = vectors[(row, col)];
        }
        self.fft.process(&mut self.buf);
        for (p, v) in self.projection.iter_mut().zip(&self.buf) {
            *p -= v.norm_sqr() / l as f64;
        }
    }

    /// MUSIC: the `d` deepest local minima of the projection, each placed by a parabola through
    /// its grid point and their neighbours (the full-aperture refinement follows).
    fn music_minima(&self, d: usize) -> Vec<f64> {
        let g = self.grid;
        let p = &self.projection;
        let mut minima: Vec<(f64, usize)> = (0..g)
            .filter(|&q| p[q] < p[(q + g - 1) % g] && p[q] <= p[(q + 1) % g])
            .map(|q| (p[q], q))
            .collect();
        minima.sort_by(|a, b| a.0.total_cmp(&b.0));
        let step = 2.0 * PI / g as f64;
        minima
            .into_iter()
            .take(d)
            .map(|(_, q)| {
                let (pm, p0, pp) = (p[(q + g - 1) % g], p[q], p[(q + 1) % g]);
                let den = pm - 2.0 * p0 + pp;
                let offset = if den > 0.0 {
                    (0.5 * (pm - pp) / den).clamp(-0.5, 0.5)
                } else {
                    0.0
                };
                wrap((q as f64 + offset) * step)
            })
            .collect()
    }
}

/// How many of `values` (the smoothed covariance's eigenvalues, descending) belong to waves:
/// those above (1 + √(L / S))² · 2 times the element noise `noise_power`, S = (K − L + 1) times
/// the `snapshots` (the largest eigenvalue noise alone gives, by the Marchenko–Pastur edge for
/// S subarray snapshots of L elements, with a factor 2 for the overlap of the subarrays), and
/// above 10⁻⁶ of the largest (what rounding leaves in a noise-free cell); at most L − 1, at
/// least 1.
pub(crate) fn signal_dimension(
    values: &[f64],
    noise_power: f64,
    k: usize,
    l: usize,
    snapshots: usize,
) -> usize {
    let subarrays = ((k + 1).saturating_sub(l).max(1) * snapshots.max(1)) as f64;
    let edge = (1.0 + (l as f64 / subarrays).sqrt()).powi(2) * 2.0;
    let largest = values.first().copied().unwrap_or(0.0);
    let threshold = (edge * noise_power).max(1e-6 * largest);
    values
        .iter()
        .take(l.saturating_sub(1))
        .filter(|&&v| v > threshold)
        .count()
        .max(1)
}

/// Forward–backward spatially smoothed covariance (L × L) of `snapshots` (each `k` long), with
/// the diagonal loading of the module docs.
pub(crate) fn smoothed_covariance(
    snapshots: &[Complex64],
    k: usize,
    l: usize,
) -> DMatrix<Complex64> {
    let mut r = DMatrix::<Complex64>::zeros(l, l);
    let mut terms = 0usize;
    for x in snapshots.chunks_exact(k) {
        for start in 0..=k - l {
            let sub = &x[start..start + l];
            for i in 0..l {
                for j in i..l {
                    r[(i, j)] += sub[i] * sub[j].conj();
                }
            }
            terms += 1;
        }
    }
    for i in 0..l {
        for j in 0..i {
            r[(i, j)] = r[(j, i)].conj();
        }
    }
    // Backward: J R* J, i.e. entry (i, j) ← conj(R[(l−1−i, l−1−j)]).
    let mut fb = DMatrix::<Complex64>::zeros(l, l);
    let scale = 0.5 / terms.max(1) as f64;
    for i in 0..l {
        for j in 0..l {
            fb[(i, j)] = (r[(i, j)] + r[(l - 1 - i, l - 1 - j)].conj()) * scale;
        }
    }
    let trace: f64 = (0..l).map(|i| fb[(i, i)].re).sum();
    let loading = 1e-9 * trace / l as f64;
    for i in 0..l {
        fb[(i, i)] += loading;
    }
    fb
}

/// TLS-ESPRIT on the signal subspace `signal` (L × d): the phases of the eigenvalues of
/// Ψ = −V₁₂ V₂₂⁻¹, from the eigenvectors V of [E₁ E₂]ᴴ[E₁ E₂] sorted by decreasing eigenvalue.
pub(crate) fn esprit(signal: &DMatrix<Complex64>) -> Vec<f64> {
    let (l, d) = (signal.nrows(), signal.ncols());
    if l < 2 || d == 0 || d > l - 1 {
        return Vec::new();
    }
    let mut both = DMatrix::<Complex64>::zeros(l - 1, 2 * d);
    for c in 0..d {
        for r in 0..l - 1 {
            both[(r, c)] = signal[(r, c)];
            both[(r, d + c)] = signal[(r + 1, c)];
        }
    }
    let c = both.adjoint() * &both;
    let eig = c.symmetric_eigen();
    let mut order: Vec<usize> = (0..2 * d).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let v12 = DMatrix::from_fn(d, d, |r, c| eig.eigenvectors[(r, order[d + c])]);
    let v22 = DMatrix::from_fn(d, d, |r, c| eig.eigenvectors[(d + r, order[d + c])]);
    let Some(inv) = v22.try_inverse() else {
        return Vec::new();
    };
    let psi = -(v12 * inv);
    if !psi.iter().all(|v| v.re.is_finite() && v.im.is_finite()) {
        return Vec::new();
    }
    match nalgebra::linalg::Schur::new(psi).eigenvalues() {
        Some(z) => z
            .iter()
            .filter(|v| v.norm() > 0.0)
            .map(|v| v.arg())
            .collect(),
        None => Vec::new(),
    }
}

/// Full-aperture refinement, cycled until no wave moves by 10⁻⁹ rad: each wave's ω moved to the maximum of |a(ω)ᴴ r|² within
/// half a DFT bin, r being the mean snapshot less the other waves' least-squares fit. The
/// subspace estimate uses L of the K elements; this step is the single-tone maximum-likelihood
/// estimate on all K (Newtonized OMP's cyclic refinement), so an isolated wave reaches the
/// full array's Cramér–Rao bound.
fn refine_full_aperture(x: &[Complex64], omegas: &mut [f64]) {
    let k = x.len();
    let half_bin = PI / k as f64;
    let mut residual = vec![ZERO; k];
    let mut model = vec![ZERO; k];
    for _ in 0..REFINE_CYCLES {
        let before = omegas.to_vec();
        let Some(amplitudes) = least_squares_amplitudes(x, omegas) else {
            return;
        };
        let mut steering: Vec<Vec<Complex64>> = omegas.iter().map(|&w| steer(k, w)).collect();
        model.fill(ZERO);
        for (a, v) in amplitudes.iter().zip(&steering) {
            for (m, s) in model.iter_mut().zip(v) {
                *m += a * s;
            }
        }
        for j in 0..omegas.len() {
            let a = amplitudes[j];
            for ((r, (&xv, m)), s) in residual
                .iter_mut()
                .zip(x.iter().zip(&model))
                .zip(&steering[j])
            {
                *r = xv - m + a * s;
            }
            let moved = wrap(beam_peak(&[&residual], omegas[j], half_bin));
            let fresh = steer(k, moved);
            for ((m, old), new) in model.iter_mut().zip(&steering[j]).zip(&fresh) {
                *m += a * (new - old);
            }
            steering[j] = fresh;
            omegas[j] = moved;
        }
        let moved = before
            .iter()
            .zip(omegas.iter())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if moved < 1e-9 {
            return;
        }
    }
}

/// The steering vector a(ω)_k = e^{jωk}, k < `len`.
fn steer(len: usize, omega: f64) -> Vec<Complex64> {
    let step = Complex64::from_polar(1.0, omega);
    let mut w = Complex64::new(1.0, 0.0);
    (0..len)
        .map(|_| {
            let v = w;
            w *= step;
            v
        })
        .collect()
}

/// The maximum of Σ_v |a(ω)ᴴ v|² over `vectors` within `half_width` of `start`: Newton's method
/// on its first and second derivatives (NOMP's step), checked to stay in the interval and to
/// gain; else golden-section search. One vector: the beam's peak; the signal eigenvectors: the
/// MUSIC projection's minimum.
pub(crate) fn beam_peak(vectors: &[&[Complex64]], start: f64, half_width: f64) -> f64 {
    let power = |w: f64| vectors.iter().map(|v| beam_power(v, w)).sum::<f64>();
    let mut w = start;
    let mut newton_ok = true;
    for _ in 0..6 {
        let step = Complex64::from_polar(1.0, -w);
        let (mut f1, mut f2) = (0.0, 0.0);
        for v in vectors {
            let mut turn = Complex64::new(1.0, 0.0);
            let (mut c, mut c1, mut c2) = (ZERO, ZERO, ZERO);
            for (index, x) in v.iter().enumerate() {
                let e = x * turn;
                let kk = index as f64;
                c += e;
                c1 += e * Complex64::new(0.0, -kk);
                c2 += e * (-kk * kk);
                turn *= step;
            }
            f1 += 2.0 * (c.conj() * c1).re;
            f2 += 2.0 * (c1.norm_sqr() + (c.conj() * c2).re);
        }
        if !(f2 < 0.0 && f1.is_finite()) {
            newton_ok = false;
            break;
        }
        let delta = -f1 / f2;
        w += delta;
        if (w - start).abs() > half_width {
            newton_ok = false;
            break;
        }
        if delta.abs() < 1e-12 {
            break;
        }
    }
    if newton_ok && power(w) >= power(start) {
        w
    } else {
        golden_minimum(|x| -power(x), start, half_width)
    }
}

/// Most cycles of [`refine_full_aperture`]: waves closer than a DFT bin are coupled, and each
/// cycle moves them only part of the way (two waves half a bin apart need about ten).
const REFINE_CYCLES: usize = 20;

/// |a(ω)ᴴ x|² for the steering vector a(ω)_k = e^{jωk}.
fn beam_power(x: &[Complex64], omega: f64) -> f64 {
    let step = Complex64::from_polar(1.0, -omega);
    let mut w = Complex64::new(1.0, 0.0);
    let mut acc = ZERO;
    for v in x {
        acc += v * w;
        w *= step;
    }
    acc.norm_sqr()
}

/// The minimum of `f` in [x − h, x + h] by golden-section search to 10⁻¹⁰.
pub(crate) fn golden_minimum(f: impl Fn(f64) -> f64, x: f64, h: f64) -> f64 {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (x - h, x + h);
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    while b - a > 1e-10 {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - ratio * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + ratio * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

/// ω wrapped into (−π, π].
fn wrap(omega: f64) -> f64 {
    let w = (omega + PI).rem_euclid(2.0 * PI) - PI;
    if w <= -PI {
        w + 2.0 * PI
    } else {
        w
    }
}

/// The phases, wrapped, with any closer than `tolerance` (circularly) to an earlier one dropped:
/// two equal columns would make the least-squares fit singular.
fn distinct(omegas: Vec<f64>, tolerance: f64) -> Vec<f64> {
    let mut kept: Vec<f64> = Vec::with_capacity(omegas.len());
    for w in omegas.into_iter().filter(|w| w.is_finite()).map(wrap) {
        let near = kept.iter().any(|&v| {
            let diff = (w - v).abs();
            diff.min(2.0 * PI - diff) < tolerance
        });
        if !near {
            kept.push(w);
        }
    }
    kept
}

/// Least-squares amplitudes of the waves a(ω_i) in `x`: (AᴴA)⁻¹ Aᴴ x; `None` when AᴴA is singular.
pub(crate) fn least_squares_amplitudes(x: &[Complex64], omegas: &[f64]) -> Option<Vec<Complex64>> {
    WaveFit::new(x.len(), omegas)?.amplitudes(x)
}

/// The least-squares fit of fixed waves a(ω_i), factored once for many snapshots.
pub(crate) struct WaveFit {
    steering: DMatrix<Complex64>,
    lu: nalgebra::linalg::LU<Complex64, nalgebra::Dyn, nalgebra::Dyn>,
}

impl WaveFit {
    /// The fit of the waves `omegas` on `len` elements; `None` when they are too close for AᴴA
    /// to be inverted.
    pub(crate) fn new(len: usize, omegas: &[f64]) -> Option<Self> {
        let mut steering = DMatrix::<Complex64>::zeros(len, omegas.len());
        for (i, &w) in omegas.iter().enumerate() {
            for (k, v) in steer(len, w).into_iter().enumerate() {
                steering[(k, i)] = v;
            }
        }
        let lu = (steering.adjoint() * &steering).lu();
        (omegas.is_empty() || lu.is_invertible()).then_some(Self { steering, lu })
    }

    /// The amplitudes of the waves in `x` (`len` elements); `None` if not finite.
    pub(crate) fn amplitudes(&self, x: &[Complex64]) -> Option<Vec<Complex64>> {
        if self.steering.ncols() == 0 {
            return Some(Vec::new());
        }
        let rhs = self.steering.adjoint() * DVector::from_column_slice(x);
        let solution = self.lu.solve(&rhs)?;
        solution
            .iter()
            .all(|v| v.re.is_finite() && v.im.is_finite())
            .then(|| solution.iter().copied().collect())
    }
}

/// The Cramér–Rao bound's standard deviation of one tone's frequency (rad per sample) over `len`
/// samples at processed SNR `snr` (the tone's power in the transform over the noise power there,
/// so the coherent gain is already in it): √(6 / (snr (len² − 1))). Infinite when snr ≤ 0 or
/// len < 2.
pub(crate) fn crb_std(snr: f64, len: usize) -> f64 {
    if snr.is_nan() || snr <= 0.0 || len < 2 {
        return f64::INFINITY;
    }
    let l = len as f64;
    (6.0 / (snr * (l * l - 1.0))).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use rand_distr::StandardNormal;

    fn tones(k: usize, waves: &[(f64, Complex64)]) -> Vec<Complex64> {
        (0..k)
            .map(|e| {
                waves
                    .iter()
                    .map(|(w, a)| a * Complex64::from_polar(1.0, w * e as f64))
                    .sum()
            })
            .collect()
    }

    fn sorted(mut v: Vec<f64>) -> Vec<f64> {
        v.sort_by(f64::total_cmp);
        v
    }

    #[test]
    fn both_methods_resolve_two_coherent_waves_closer_than_the_dft_bin() {
        let k = 32;
        // Half a DFT bin apart (the bin is 2π/K in ω), equal power, coherent, noise-free.
        let (w1, w2) = (0.3, 0.3 + PI / k as f64);
        let x = tones(
            k,
            &[
                (w1, Complex64::new(1.0, 0.0)),
                (w2, Complex64::new(0.0, 1.0)),
            ],
        );
        for method in [Subspace::Music, Subspace::Esprit] {
            let mut solver = CellSolver::new(k, default_subarray(k));
            let waves = solver.solve(method, &x, &x, 0.01, 0.0);
            let found = sorted(waves.iter().map(|w| w.omega).collect());
            assert_eq!(found.len(), 2, "{method:?}: {found:?}");
            assert!(
                (found[0] - w1).abs() < 1e-6 && (found[1] - w2).abs() < 1e-6,
                "{method:?}: {found:?}"
            );
            for w in &waves {
                assert!((w.amplitude.norm() - 1.0).abs() < 1e-5, "{method:?}: {w:?}");
            }
        }
    }

    #[test]
    fn one_noisy_wave_is_found_once_near_its_crb() {
        let k = 32;
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let sigma = 0.3; // per element; SNR 10.5 dB per element
        let truth = -0.8;
        let mut errors = Vec::new();
        for method in [Subspace::Music, Subspace::Esprit] {
            let mut solver = CellSolver::new(k, default_subarray(k));
            let mut sq = 0.0;
            let trials = 200;
            for _ in 0..trials {
                let mut x = tones(k, &[(truth, Complex64::new(1.0, 0.0))]);
                for v in &mut x {
                    let (re, im): (f64, f64) =
                        (rng.sample(StandardNormal), rng.sample(StandardNormal));
                    *v += Complex64::new(re, im) * (sigma / 2f64.sqrt());
                }
                // The detector's 13 dB over the element noise.
                let waves = solver.solve(
                    method,
                    &x,
                    &x,
                    sigma * sigma * 20.0 / k as f64,
                    sigma * sigma,
                );
                assert_eq!(waves.len(), 1, "{method:?}: {waves:?}");
                sq += (waves[0].omega - truth).powi(2);
            }
            errors.push((sq / trials as f64).sqrt());
        }
        // The map SNR of a unit tone: K² / (K σ²).
        let crb = crb_std(k as f64 / (sigma * sigma), k);
        for e in errors {
            assert!(e < 2.0 * crb && e > 0.5 * crb, "rmse {e}, crb {crb}");
        }
    }

    #[test]
    fn the_signal_dimension_counts_eigenvalues_above_the_noise_edge() {
        // K = 32, L = 22: the edge is (1 + √2)² · 2 ≈ 11.7 σ².
        let values = [500.0, 40.0, 12.5, 11.0, 3.0, 1.0, 0.5];
        assert_eq!(signal_dimension(&values, 1.0, 32, 22, 1), 3);
        assert_eq!(signal_dimension(&values, 0.1, 32, 22, 1), 5);
        // 256 snapshots: the edge falls to (1 + √(22/2816))² · 2 ≈ 2.4 σ².
        assert_eq!(signal_dimension(&values, 1.0, 32, 22, 256), 5);
        // Noise-free: what rounding leaves (under 1e-6 of the largest) is no wave.
        assert_eq!(signal_dimension(&[4.0, 1e-12, 1e-13], 0.0, 32, 22, 1), 1);
        // At least one, at most L − 1.
        assert_eq!(signal_dimension(&[1.0, 1.0], 10.0, 4, 2, 1), 1);
        assert_eq!(signal_dimension(&[9.0; 4], 0.0, 8, 4, 1), 3);
    }

    #[test]
    fn degenerate_snapshots_give_no_wave() {
        let mut solver = CellSolver::new(8, 6);
        let zero = vec![ZERO; 8];
        assert!(solver
            .solve(Subspace::Music, &zero, &zero, 0.0, 0.0)
            .is_empty());
        let mut nan = vec![Complex64::new(1.0, 0.0); 8];
        nan[3] = Complex64::new(f64::NAN, 0.0);
        assert!(solver
            .solve(Subspace::Esprit, &nan, &nan, 0.0, 0.0)
            .is_empty());
        assert!(solver
            .solve(Subspace::Esprit, &zero[..4], &zero[..4], 0.0, 0.0)
            .is_empty());
    }

    #[test]
    fn crb_falls_with_snr_and_aperture() {
        assert!(crb_std(100.0, 32) < crb_std(10.0, 32));
        assert!(crb_std(10.0, 64) < crb_std(10.0, 32));
        assert_eq!(crb_std(0.0, 32), f64::INFINITY);
        assert_eq!(crb_std(10.0, 1), f64::INFINITY);
        assert!((crb_std(6.0, 2) - (1.0f64 / 3.0).sqrt()).abs() < 1e-15);
    }
}
