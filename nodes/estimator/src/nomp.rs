//! Newtonized orthogonal matching pursuit (NOMP; Mamandipoor, Ramasamy and Madhow, 2016),
//! gridless and joint in range and angle, for the single-snapshot frame.
//!
//! The data are the range-transformed array samples of a patch of range bins (each bin's K
//! elements, `crate::estimator`'s snapshots). One scatterer at fractional range bin t and phase
//! step ω per element contributes
//!
//! ```text
//! x(i, k) = α · g(i − t) · e^{jωk},   g(u) = D_N(u/N) / N   (g(0) = 1)
//! ```
//!
//! to bin i, element k: the range kernel of the 1/N-scaled N-point IDFT (paper eq.
//! (OFDM_signal_33)) times the array's steering vector (eq. (AOA_1_1_2)). NOMP adds one such atom
//! at a time:
//!
//! 1. **Detect.** The strongest cell of the residual, over the patch's bins and an angle grid 4 ×
//!    finer than the array's DFT.
//! 2. **Stop** when that cell's power |Σ_k r(i, k) e^{−jωk}|² is under the detector's threshold,
//!    `threshold_db` (or the CFAR factor) over the frame's noise floor. This is the stated
//!    false-alarm rule: at K·G cells per bin instead of K, the design rate per bin is about
//!    (1 + ln 4) times the DFT detector's.
//! 3. **Refine the new atom** (t, ω) by alternating Newton steps in ω (`superres::beam_peak`) and
//!    golden-section search in t, on |⟨r, x(t, ω)⟩|² / ‖x(t, ω)‖².
//! 4. **Refine the atoms near it cyclically** (within 2 · `PATCH_BINS` bins): add each back to
//!    the residual, refine it, take it out again; 10 rounds, and at the end rounds over all atoms
//!    until none moves by 10⁻⁷ (at most 30).
//!    An atom is refined on the bins within `PATCH_BINS` + 1 of it, and added to or taken out
//!    of every bin of the patch.
//!
//! The patch is the range bins within ±`PATCH_BINS` of the DFT detector's peaks, so only where
//! something was detected is searched. An atom is subtracted from every bin of the patch; its
//! range side lobes beyond the patch are not, which the DFT path's blanking already accepts.

use crate::superres::{beam_peak, golden_minimum};
use num_complex::Complex64;
use std::f64::consts::PI;

const ZERO: Complex64 = Complex64 { re: 0.0, im: 0.0 };

/// Range bins on each side of a DFT peak that the patch holds.
pub(crate) const PATCH_BINS: usize = 4;

/// Cyclic refinement rounds of the atoms near a new one (NOMP's R_c): 3 left two atoms half a
/// beam apart unconverged when the next was sought (resolved from 0.73 beams instead of 0.56).
const CYCLES_PER_ATOM: usize = 10;

/// Most rounds of the final refinement of all atoms (until nothing moves by 10⁻⁷): atoms closer
/// than a cell in both range and angle are coupled, and each round moves them part way.
const CYCLES: usize = 30;

/// Angle grid of the detection step: this many points per array element.
const ANGLE_OVERSAMPLING: usize = 4;

/// One atom: fractional range bin, phase step per element (rad), amplitude (a unit echo: 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Atom {
    pub range_bin: f64,
    pub omega: f64,
    pub amplitude: Complex64,
}

/// The range kernel g(u) = D_N(u/N)/N of an N-point transform, `u` bins from the peak.
fn kernel(n: usize, u: f64) -> Complex64 {
    nrslam_ofdm::spectral::dirichlet(n, u / n as f64) / n as f64
}

/// The residual of a patch: its bins (absolute indices, ascending) and their K samples each.
pub(crate) struct Patch {
    pub rows: Vec<usize>,
    pub k: usize,
    pub n: usize,
    pub samples: Vec<Complex64>,
}

impl Patch {
    fn row(&self, index: usize) -> &[Complex64] {
        &self.samples[index * self.k..(index + 1) * self.k]
    }

    /// The indices of the bins within `reach` bins of range bin `t`.
    fn near(&self, t: f64, reach: usize) -> std::ops::Range<usize> {
        let lo = self
            .rows
            .partition_point(|&r| (r as f64) < t - reach as f64);
        let hi = self
            .rows
            .partition_point(|&r| (r as f64) <= t + reach as f64);
        lo..hi
    }

    /// Adds `scale` × the atom's contribution to every bin.
    fn add(&mut self, atom: &Atom, scale: f64) {
        let k = self.k;
        let step = Complex64::from_polar(1.0, atom.omega);
        for (index, &row) in self.rows.iter().enumerate() {
            let g = kernel(self.n, row as f64 - atom.range_bin) * atom.amplitude * scale;
            let mut w = g;
            for v in &mut self.samples[index * k..(index + 1) * k] {
                *v += w;
                w *= step;
            }
        }
    }

    /// ⟨r, x(t, ω)⟩ / ‖x(t, ω)‖² (the least-squares amplitude) and |⟨r, x⟩|² / ‖x‖² (the fit),
    /// from each bin's beam output `beams[i]` = Σ_k r(i, k) e^{−jωk}.
    fn fit(&self, near: std::ops::Range<usize>, beams: &[Complex64], t: f64) -> (Complex64, f64) {
        let (mut dot, mut energy) = (ZERO, 0.0);
        for (&row, b) in self.rows[near].iter().zip(beams) {
            let g = kernel(self.n, row as f64 - t);
            dot += b * g.conj();
            energy += g.norm_sqr();
        }
        let energy = energy * self.k as f64;
        if energy > 0.0 {
            (dot / energy, dot.norm_sqr() / energy)
        } else {
            (ZERO, 0.0)
        }
    }

    /// The beam output at ω of each bin in `near`.
    fn beams(&self, near: std::ops::Range<usize>, omega: f64) -> Vec<Complex64> {
        let step = Complex64::from_polar(1.0, -omega);
        near.map(|index| {
            let mut w = Complex64::new(1.0, 0.0);
            let mut acc = ZERO;
            for v in self.row(index) {
                acc += v * w;
                w *= step;
            }
            acc
        })
        .collect()
    }

    /// The strongest cell of the residual on the bins × fine angle grid: (bin index, ω, power
    /// |Σ_k r e^{−jωk}|²).
    fn strongest_cell(
        &self,
        fft: &dyn rustfft::Fft<f64>,
        buf: &mut [Complex64],
    ) -> Option<(usize, f64, f64)> {
        let grid = buf.len();
        let mut best: Option<(usize, f64, f64)> = None;
        for index in 0..self.rows.len() {
            buf.fill(ZERO);
            buf[..self.k].copy_from_slice(self.row(index));
            // Bin q is Σ_k r e^{−j2π qk/G}: the beam at ω = 2π q/G.
            fft.process(buf);
            for (q, v) in buf.iter().enumerate() {
                let p = v.norm_sqr();
                if best.is_none_or(|b| p > b.2) {
                    best = Some((index, 2.0 * PI * q as f64 / grid as f64, p));
                }
            }
        }
        best
    }

    /// Refines `atom` against the residual (which must not hold it): alternating ω (Newton) and
    /// t (golden section within half a bin), then its amplitude.
    /// Only the bins within `PATCH_BINS` of the atom take part: its kernel beyond holds under
    /// 1/(π · 4) of its peak.
    fn refine(&self, atom: &mut Atom) {
        let half_bin = PI / self.k as f64;
        let near = self.near(atom.range_bin, PATCH_BINS + 1);
        for _ in 0..3 {
            // ω: the beam of the range-matched sum Σ_i conj(g(i − t)) r(i, ·).
            let mut matched = vec![ZERO; self.k];
            for index in near.clone() {
                let g = kernel(self.n, self.rows[index] as f64 - atom.range_bin).conj();
                for (m, v) in matched.iter_mut().zip(self.row(index)) {
                    *m += g * v;
                }
            }
            atom.omega = beam_peak(&[&matched], atom.omega, half_bin);
            let beams = self.beams(near.clone(), atom.omega);
            let t0 = atom.range_bin;
            atom.range_bin = golden_minimum(|t| -self.fit(near.clone(), &beams, t).1, t0, 0.5);
        }
        let beams = self.beams(near.clone(), atom.omega);
        atom.amplitude = self.fit(near, &beams, atom.range_bin).0;
    }
}

/// Up to `rounds` rounds of cyclic refinement of the atoms (those within 2 · `PATCH_BINS` bins of
/// range bin `near`, or all), until none moves by 10⁻⁷.
fn cycle(patch: &mut Patch, atoms: &mut [Atom], near: Option<f64>, rounds: usize) {
    for _ in 0..rounds {
        let mut moved = 0.0f64;
        for atom in atoms
            .iter_mut()
            .filter(|a| near.is_none_or(|t| (a.range_bin - t).abs() <= (2 * PATCH_BINS) as f64))
        {
            let mut other = *atom;
            patch.add(&other, 1.0);
            patch.refine(&mut other);
            patch.add(&other, -1.0);
            moved = moved
                .max((other.range_bin - atom.range_bin).abs())
                .max((other.omega - atom.omega).abs());
            *atom = other;
        }
        if moved < 1e-7 {
            break;
        }
    }
}

/// NOMP on `patch` (consumed as the residual): atoms strongest first, at most `max_atoms`, each
/// with |amplitude|²·K² ≥ `min_power` (map units) when found.
pub(crate) fn nomp(mut patch: Patch, min_power: f64, max_atoms: usize) -> Vec<Atom> {
    let kk = (patch.k as f64).powi(2);
    let grid = ANGLE_OVERSAMPLING * patch.k;
    let fft = rustfft::FftPlanner::<f64>::new().plan_fft_forward(grid);
    let mut buf = vec![ZERO; grid];
    let mut atoms: Vec<Atom> = Vec::new();
    while atoms.len() < max_atoms {
        let Some((index, omega, power)) = patch.strongest_cell(fft.as_ref(), &mut buf) else {
            break;
        };
        if power.is_nan() || power < min_power {
            break;
        }
        let mut atom = Atom {
            range_bin: patch.rows[index] as f64,
            omega,
            amplitude: ZERO,
        };
        patch.refine(&mut atom);
        let kept = atom.amplitude.norm_sqr() * kk;
        if kept.is_nan() || kept < min_power * 0.25 {
            // The refined fit kept less than a quarter of the cell's power: the cell was a
            // side lobe of what is already taken out, not a new scatterer.
            break;
        }
        patch.add(&atom, -1.0);
        atoms.push(atom);
        let newest = atom.range_bin;
        cycle(&mut patch, &mut atoms, Some(newest), CYCLES_PER_ATOM);
    }
    cycle(&mut patch, &mut atoms, None, CYCLES);
    atoms.retain(|a| a.amplitude.norm_sqr() * kk >= min_power);
    atoms.sort_by(|a, b| b.amplitude.norm_sqr().total_cmp(&a.amplitude.norm_sqr()));
    atoms
}

#[cfg(test)]
mod tests {
    use super::*;

    fn patch_with(atoms: &[Atom], rows: std::ops::Range<usize>, k: usize, n: usize) -> Patch {
        let rows: Vec<usize> = rows.collect();
        let mut patch = Patch {
            samples: vec![ZERO; rows.len() * k],
            rows,
            k,
            n,
        };
        for a in atoms {
            patch.add(a, 1.0);
        }
        patch
    }

    #[test]
    fn two_scatterers_closer_than_a_range_bin_and_a_beam_are_both_found() {
        let (k, n) = (32, 1024);
        let truth = [
            Atom {
                range_bin: 20.3,
                omega: 0.4,
                amplitude: Complex64::new(1.0, 0.0),
            },
            Atom {
                range_bin: 20.8,
                omega: 0.4 + PI / k as f64,
                amplitude: Complex64::new(0.0, 0.9),
            },
        ];
        let patch = patch_with(&truth, 14..28, k, n);
        let found = nomp(patch, 1e-6, 8);
        assert!(found.len() >= 2, "{found:?}");
        for t in &truth {
            assert!(
                found
                    .iter()
                    .any(|f| (f.range_bin - t.range_bin).abs() < 0.02
                        && (f.omega - t.omega).abs() < 0.005),
                "{t:?} not in {found:?}"
            );
        }
    }

    #[test]
    fn nothing_above_the_threshold_gives_no_atom() {
        let patch = patch_with(&[], 0..9, 8, 64);
        assert!(nomp(patch, 1.0, 8).is_empty());
    }
}
