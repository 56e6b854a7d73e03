//! Sub-bin interpolation formulas. Each returns the offset δ of the true peak from the peak bin,
//! in bins, clamped to [−½, ½]; `None` when the neighbours give no usable answer (then the caller
//! keeps the bin centre).

use num_complex::Complex64;
use std::f64::consts::PI;

/// Jacobsen's three-point estimator on complex DFT values with Candan's bias correction for the
/// rectangular window: δ = tan(π/L)/(π/L) · Re[(X₋ − X₊) / (2X₀ − X₋ − X₊)], L the (unpadded)
/// transform length. Exact to first order for one tone; invariant under conjugation, so it serves
/// the IDFT (range) and the DFT (angle) alike.
pub fn candan(xm: Complex64, x0: Complex64, xp: Complex64, len: usize) -> Option<f64> {
    let den = x0 * 2.0 - xm - xp;
    if den.norm_sqr() == 0.0 {
        return None;
    }
    let raw = ((xm - xp) / den).re;
    let a = PI / len.max(2) as f64;
    let delta = raw * a.tan() / a;
    delta.is_finite().then(|| delta.clamp(-0.5, 0.5))
}

/// Parabola through the log powers of three neighbouring bins (Gaussian interpolation); meant for
/// zero-padded dimensions, where the main lobe spans several bins.
pub fn parabolic_log(pm: f64, p0: f64, pp: f64) -> Option<f64> {
    if !(pm > 0.0 && p0 > 0.0 && pp > 0.0) {
        return None;
    }
    let (lm, l0, lp) = (pm.ln(), p0.ln(), pp.ln());
    let den = lm - 2.0 * l0 + lp;
    if den >= 0.0 {
        return None;
    }
    let delta = 0.5 * (lm - lp) / den;
    delta.is_finite().then(|| delta.clamp(-0.5, 0.5))
}

/// Exact two-point (Rife) estimator for a rectangular window of length `len`, from the powers of
/// the peak bin and one neighbour on `side` (+1 or −1): a single tone at offset δ gives
/// |X₁|/|X₀| = sin(πδ/L) / sin(π(1−δ)/L), solved for δ. Used where the other neighbour does not
/// exist (edge of a non-circular range window).
pub fn rife(p0: f64, p_side: f64, side: f64, len: usize) -> Option<f64> {
    if !(p0 > 0.0 && p_side >= 0.0) {
        return None;
    }
    let r = (p_side / p0).sqrt().min(1.0);
    let a = PI / len.max(2) as f64;
    let t = (r * a.sin()).atan2(1.0 + r * a.cos());
    let delta = side * t / a;
    delta.is_finite().then(|| delta.clamp(-0.5, 0.5))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dft_tone(len: usize, f: f64, bin: usize) -> Complex64 {
        (0..len)
            .map(|n| {
                let ph = 2.0 * PI * (n as f64 * (f - bin as f64) / len as f64).rem_euclid(1.0);
                Complex64::from_polar(1.0, ph)
            })
            .sum()
    }

    #[test]
    fn candan_recovers_a_tone() {
        for &len in &[8usize, 64, 1023] {
            for &d in &[-0.49, -0.3, 0.0, 0.1, 0.25, 0.45] {
                let f = 5.0 + d;
                let x = |b| dft_tone(len, f, b);
                let est = candan(x(4), x(5), x(6), len).unwrap();
                assert!((est - d).abs() < 0.02, "len {len} d {d} est {est}");
            }
        }
    }

    #[test]
    fn rife_is_exact_for_a_tone() {
        for &len in &[8usize, 64, 1024] {
            for &d in &[0.01, 0.2, 0.49] {
                let x = |b| dft_tone(len, 5.0 + d, b).norm_sqr();
                let est = rife(x(5), x(6), 1.0, len).unwrap();
                assert!((est - d).abs() < 1e-9, "len {len} d {d} est {est}");
                let x = |b| dft_tone(len, 5.0 - d, b).norm_sqr();
                let est = rife(x(5), x(4), -1.0, len).unwrap();
                assert!((est + d).abs() < 1e-9, "len {len} d {d} est {est}");
            }
        }
    }

    #[test]
    fn degenerate_neighbours_give_none() {
        let z = Complex64::new(0.0, 0.0);
        assert_eq!(candan(z, z, z, 8), None);
        assert_eq!(parabolic_log(0.0, 1.0, 0.5), None);
        assert_eq!(parabolic_log(1.0, 1.0, 1.0), None);
        assert_eq!(rife(0.0, 0.0, 1.0, 8), None);
    }
}
