//! Drift-free phasors: phases are carried in turns (cycles) and reduced modulo 1 before the
//! trigonometry, never accumulated by repeated multiplication.

use num_complex::Complex64;
use std::f64::consts::PI;

/// The fractional part of `turns` in [−0.5, 0.5]. Exact in floating point for |turns| < 2^52
/// (subtracting the nearest integer loses nothing).
pub(crate) fn reduce_turns(turns: f64) -> f64 {
    turns - turns.round()
}

/// e^{j2π·turns}, with `turns` reduced modulo 1 first so sin/cos see an argument in [−π, π].
pub(crate) fn cis_turns(turns: f64) -> Complex64 {
    let (s, c) = (2.0 * PI * reduce_turns(turns)).sin_cos();
    Complex64::new(c, s)
}

/// `index · rate` in turns reduced modulo 1, computing the product exactly with an FMA
/// (index is an exact integer in f64 below 2^53) so the only error left is that of `rate`.
pub(crate) fn product_turns(index: usize, rate: f64) -> f64 {
    let n = index as f64;
    let p = n * rate;
    let e = n.mul_add(rate, -p); // exact rounding error of the product
    reduce_turns(reduce_turns(p) + e)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_turns_is_exact_for_integer_rates() {
        // 10239 · 0.8006... has a product rounding error that the FMA recovers: compare against
        // rate = 0.25 + 2^-40 whose products are exact binary fractions.
        let rate = 0.25 + 2f64.powi(-40);
        for n in [0usize, 1, 3, 10239, 1 << 30] {
            let exact = ((n as u128 * ((1u128 << 38) + 1)) % (1u128 << 40)) as f64 / 2f64.powi(40);
            let exact = exact - exact.round();
            assert!((product_turns(n, rate) - exact).abs() < 1e-15, "n = {n}");
        }
    }

    #[test]
    fn cis_turns_reduces_large_arguments() {
        let a = cis_turns(1e9 + 0.25);
        assert!((a - Complex64::new(0.0, 1.0)).norm() < 1e-6);
        assert!((cis_turns(-0.5) - Complex64::new(-1.0, 0.0)).norm() < 1e-15);
        assert_eq!(reduce_turns(2.75), -0.25);
    }
}
