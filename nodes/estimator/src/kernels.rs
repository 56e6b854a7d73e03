//! The estimator's loops outside rustfft — the scaled reciprocals 1/X, S = Y·(1/X) per antenna
//! row, the gather of range bins into the angle tile, |S|² with the row maximum — each in a
//! portable form and, on x86_64 CPUs with AVX2 (detected at run time: the build targets plain
//! x86_64, so the portable loops compile to SSE2), a 256-bit form.
//!
//! The AVX2 forms are bit-identical to the portable ones: the same IEEE operations on the same
//! operands in the same order (no FMA contraction; an addition's operands may be swapped, which
//! IEEE 754 addition is exact under), and the same four max/sum lanes. The tests below check
//! this on random data and odd lengths.

use num_complex::Complex64;

/// Which form of the loops to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Isa {
    Portable,
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

impl Isa {
    /// AVX2 when this CPU has it, else the portable loops.
    pub(crate) fn detect() -> Self {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            return Isa::Avx2;
        }
        Isa::Portable
    }
}

/// Complex values ahead of the current one whose cache line is prefetched in `y` (one
/// 512-byte block ahead).
const Y_AHEAD: usize = 32;

/// Complex values ahead (four cache lines) prefetched in each antenna row by the gather.
const GATHER_AHEAD: usize = 16;

/// `dst[i] = y[i] · inv[i]` (complex) over the common length.
#[inline]
pub(crate) fn mul_row(isa: Isa, dst: &mut [Complex64], y: &[Complex64], inv: &[Complex64]) {
    let len = dst.len().min(y.len()).min(inv.len());
    let (dst, y, inv) = (&mut dst[..len], &y[..len], &inv[..len]);
    match isa {
        Isa::Portable => {
            for ((d, y), ix) in dst.iter_mut().zip(y).zip(inv) {
                *d = y * ix;
            }
        }
        // SAFETY: `Isa::Avx2` is only made by `detect` when the CPU has AVX2 (or by the tests,
        // behind the same check).
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { x86::mul_row(dst, y, inv) },
    }
}

/// `dst[i] = scale / x[i]` for the usable `x[i]`, else 0, returning how many were usable; or
/// `Err(i)` at the first non-finite `x[i]`. Usable: s = max(|re|, |im|) > 0 with 1/s finite
/// (zero and subnormal X are skipped). Computed on x·(1/s), whose components are at most about
/// 1 in magnitude, so the squared norm can neither overflow nor underflow:
/// conj(x·(1/s)) · (scale · (1/s) / |x·(1/s)|²).
#[inline]
pub(crate) fn reciprocals(
    isa: Isa,
    x: &[Complex64],
    dst: &mut [Complex64],
    scale: f64,
) -> Result<usize, usize> {
    let len = x.len().min(dst.len());
    let (x, dst) = (&x[..len], &mut dst[..len]);
    let (done, mut usable) = match isa {
        Isa::Portable => (0, 0),
        // SAFETY: as in `mul_row`.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { x86::reciprocals(x, dst, scale) },
    };
    for (i, (d, x)) in dst.iter_mut().zip(x).enumerate().skip(done) {
        if !(x.re.is_finite() && x.im.is_finite()) {
            return Err(i);
        }
        let s = x.re.abs().max(x.im.abs());
        let inv_s = 1.0 / s;
        *d = if s > 0.0 && inv_s.is_finite() {
            let xs = x * inv_s;
            usable += 1;
            xs.conj() * (scale * inv_s / xs.norm_sqr())
        } else {
            Complex64::new(0.0, 0.0)
        };
    }
    Ok(usable)
}

/// `out[i] = |line[i]|²`, returning the maximum, or NaN when any power is not finite (a sum
/// rides along to carry NaN/∞: the max alone would skip NaN). Cell i feeds lane i mod 4 of the
/// max and the sum, in both forms.
#[cfg(test)]
pub(crate) fn norm_sqr_max(isa: Isa, line: &[Complex64], out: &mut [f64]) -> f64 {
    let mut mx = [0.0];
    norm_sqr_max_rows(isa, line, line.len().max(1), out, &mut mx);
    mx[0]
}

/// `norm_sqr_max` of each `cols`-cell line of `lines` (a tile), into the matching line of
/// `out` and entry of `maxes`.
#[inline]
pub(crate) fn norm_sqr_max_rows(
    isa: Isa,
    lines: &[Complex64],
    cols: usize,
    out: &mut [f64],
    maxes: &mut [f64],
) {
    match isa {
        Isa::Portable => {
            for ((line, out), mx) in lines
                .chunks(cols)
                .zip(out.chunks_mut(cols))
                .zip(maxes.iter_mut())
            {
                *mx = norm_tail(line, out, [0.0; 4], [0.0; 4]);
            }
        }
        // SAFETY: as in `mul_row`.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { x86::norm_sqr_max_rows(lines, cols, out, maxes) },
    }
}

/// The portable `norm_sqr_max` of one line, continuing from lanes already accumulated (the
/// cells before `line` were whole groups of four).
#[inline(always)]
fn norm_tail(line: &[Complex64], out: &mut [f64], mut lanes: [f64; 4], mut sums: [f64; 4]) -> f64 {
    let len = line.len().min(out.len());
    let (line, out) = (&line[..len], &mut out[..len]);
    let mut chunks = line.chunks_exact(4);
    let mut outs = out.chunks_exact_mut(4);
    for (c, o) in (&mut chunks).zip(&mut outs) {
        for l in 0..4 {
            let p = c[l].re * c[l].re + c[l].im * c[l].im;
            o[l] = p;
            lanes[l] = if p > lanes[l] { p } else { lanes[l] };
            sums[l] += p;
        }
    }
    for (v, o) in chunks.remainder().iter().zip(outs.into_remainder()) {
        *o = v.norm_sqr();
        lanes[0] = if *o > lanes[0] { *o } else { lanes[0] };
        sums[0] += *o;
    }
    let mx = lanes.into_iter().fold(0.0, f64::max);
    if sums.iter().sum::<f64>().is_finite() {
        mx
    } else {
        f64::NAN
    }
}

/// Gathers range bins `i0..i0 + bb` of the K·M antenna-major work rows into the bin-major tile
/// `t[(b·M + m)·A + k]`: four bins (one cache line of each row) at a time, with the line a few
/// lines ahead in each row prefetched, since K·M concurrent streams outrun the hardware
/// prefetchers.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(crate) fn gather(
    isa: Isa,
    work: &[Complex64],
    t: &mut [Complex64],
    i0: usize,
    bb: usize,
    k: usize,
    m: usize,
    a: usize,
    stride: usize,
) {
    let mut b = 0;
    if m == 1 && bb >= 4 {
        // The Table I case: four bins of each antenna row per step, bounds checked once.
        let rows_end = (k - 1) * stride + i0 + bb;
        assert!(rows_end <= work.len() && bb * a <= t.len() && k <= a);
        b = match isa {
            // SAFETY: the assertion above is `gather_m1`'s contract.
            Isa::Portable => unsafe { gather_m1(work, t, i0, bb, k, a, stride) },
            // SAFETY: the same, and the CPU has AVX2 (see `mul_row`).
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => unsafe { x86::gather_m1(work, t, i0, bb, k, a, stride) },
        };
    }
    while b + 4 <= bb {
        for kk in 0..k {
            for mm in 0..m {
                let base = (kk * m + mm) * stride + i0 + b;
                let src = &work[base..base + 4];
                #[cfg(target_arch = "x86_64")]
                if base + GATHER_AHEAD < work.len() {
                    // SAFETY: prefetch is a hint; the address is inside `work`.
                    unsafe { prefetch(work.as_ptr().add(base + GATHER_AHEAD)) };
                }
                for (j, v) in src.iter().enumerate() {
                    t[((b + j) * m + mm) * a + kk] = *v;
                }
            }
        }
        b += 4;
    }
    for b in b..bb {
        for mm in 0..m {
            for kk in 0..k {
                t[(b * m + mm) * a + kk] = work[(kk * m + mm) * stride + i0 + b];
            }
        }
    }
}

/// Prefetch hint (T0) for the cache line of `p`; never faults.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn prefetch(p: *const Complex64) {
    // SAFETY: prefetch is only a hint and does not fault on any address.
    unsafe {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        _mm_prefetch::<_MM_HINT_T0>(p as *const i8)
    }
}

/// The M = 1 gather, portable; returns the bins done (a multiple of 4).
///
/// # Safety
/// k ≥ 1, (k − 1)·stride + i0 + bb ≤ work.len(), bb·a ≤ t.len(), k ≤ a.
unsafe fn gather_m1(
    work: &[Complex64],
    t: &mut [Complex64],
    i0: usize,
    bb: usize,
    k: usize,
    a: usize,
    stride: usize,
) -> usize {
    let (src, dst) = (work.as_ptr(), t.as_mut_ptr());
    let mut b = 0;
    while b + 4 <= bb {
        for kk in 0..k {
            let base = kk * stride + i0 + b;
            #[cfg(target_arch = "x86_64")]
            prefetch(src.wrapping_add(base + GATHER_AHEAD));
            // SAFETY: base + 3 < (k − 1)·stride + i0 + bb ≤ work.len() and
            // (b + 3)·a + kk < bb·a ≤ t.len() (the caller's contract).
            unsafe {
                let d = dst.add(b * a + kk);
                *d = *src.add(base);
                *d.add(a) = *src.add(base + 1);
                *d.add(2 * a) = *src.add(base + 2);
                *d.add(3 * a) = *src.add(base + 3);
            }
        }
        b += 4;
    }
    b
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{prefetch, GATHER_AHEAD, Y_AHEAD};
    use num_complex::Complex64;
    use std::arch::x86_64::*;

    /// Two complex products: [a0·b0, a1·b1] with re = ar·br − ai·bi, im = ai·br + ar·bi
    /// (`Complex64`'s `Mul` rounds ar·bi + ai·br: the same sum, IEEE addition commutes).
    #[inline(always)]
    unsafe fn cmul(a: __m256d, b: __m256d) -> __m256d {
        let br = _mm256_movedup_pd(b);
        let bi = _mm256_permute_pd::<0b1111>(b);
        let a_swapped = _mm256_permute_pd::<0b0101>(a);
        _mm256_addsub_pd(_mm256_mul_pd(a, br), _mm256_mul_pd(a_swapped, bi))
    }

    /// `super::mul_row` with 256-bit loads and stores; slices of equal length.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn mul_row(dst: &mut [Complex64], y: &[Complex64], inv: &[Complex64]) {
        let len = dst.len();
        assert!(y.len() == len && inv.len() == len);
        // Complex64 is repr(C) {re, im}: two f64 per value.
        let (d, yp, ip) = (
            dst.as_mut_ptr() as *mut f64,
            y.as_ptr() as *const f64,
            inv.as_ptr() as *const f64,
        );
        let mut i = 0;
        while i + 4 <= len {
            // SAFETY: i + 3 < len: values i..i + 4 are inside all three slices.
            unsafe {
                prefetch(y.as_ptr().wrapping_add(i + Y_AHEAD));
                let a0 = _mm256_loadu_pd(yp.add(2 * i));
                let a1 = _mm256_loadu_pd(yp.add(2 * i + 4));
                let b0 = _mm256_loadu_pd(ip.add(2 * i));
                let b1 = _mm256_loadu_pd(ip.add(2 * i + 4));
                _mm256_storeu_pd(d.add(2 * i), cmul(a0, b0));
                _mm256_storeu_pd(d.add(2 * i + 4), cmul(a1, b1));
            }
            i += 4;
        }
        for j in i..len {
            dst[j] = y[j] * inv[j];
        }
    }

    /// `super::reciprocals`, two values per 256-bit vector, the same operations lane by lane
    /// (|x|² by a horizontal add, conj as a sign flip of the product: (−a)·b = −(a·b) exactly).
    /// Stops before the first pair holding a non-finite value; returns (values done, usable).
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn reciprocals(
        x: &[Complex64],
        dst: &mut [Complex64],
        scale: f64,
    ) -> (usize, usize) {
        let len = x.len().min(dst.len());
        let (src, out) = (x.as_ptr() as *const f64, dst.as_mut_ptr() as *mut f64);
        let abs_mask = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
        let conj = _mm256_set_pd(-0.0, 0.0, -0.0, 0.0);
        let (inf, zero, one) = (
            _mm256_set1_pd(f64::INFINITY),
            _mm256_setzero_pd(),
            _mm256_set1_pd(1.0),
        );
        let vscale = _mm256_set1_pd(scale);
        let (mut i, mut usable) = (0, 0);
        while i + 2 <= len {
            // SAFETY: values i, i + 1 are inside both slices.
            unsafe {
                let v = _mm256_loadu_pd(src.add(2 * i));
                let a = _mm256_and_pd(v, abs_mask);
                if _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(a, inf)) != 0b1111 {
                    break;
                }
                // [s0, s0, s1, s1]
                let s = _mm256_max_pd(a, _mm256_permute_pd::<0b0101>(a));
                let inv_s = _mm256_div_pd(one, s);
                let xs = _mm256_mul_pd(v, inv_s);
                let sq = _mm256_mul_pd(xs, xs);
                let nrm = _mm256_hadd_pd(sq, sq);
                let f = _mm256_div_pd(_mm256_mul_pd(vscale, inv_s), nrm);
                let r = _mm256_xor_pd(_mm256_mul_pd(xs, f), conj);
                let ok = _mm256_and_pd(
                    _mm256_cmp_pd::<_CMP_GT_OQ>(s, zero),
                    _mm256_cmp_pd::<_CMP_LT_OQ>(_mm256_and_pd(inv_s, abs_mask), inf),
                );
                _mm256_storeu_pd(out.add(2 * i), _mm256_blendv_pd(zero, r, ok));
                usable += (_mm256_movemask_pd(ok) & 0b0101).count_ones() as usize;
            }
            i += 2;
        }
        (i, usable)
    }

    /// `super::norm_sqr_max_rows`: per line, the whole groups of four with 256-bit vectors
    /// (|v|² = re·re + im·im by a horizontal add of the squares; max as
    /// `if p > lane { p } else { lane }`, MAXPD's definition), the rest by `norm_tail`.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn norm_sqr_max_rows(
        lines: &[Complex64],
        cols: usize,
        out: &mut [f64],
        maxes: &mut [f64],
    ) {
        for ((line, out), mx) in lines
            .chunks(cols)
            .zip(out.chunks_mut(cols))
            .zip(maxes.iter_mut())
        {
            let len = line.len().min(out.len());
            let (src, dst) = (line.as_ptr() as *const f64, out.as_mut_ptr());
            let mut vmax = _mm256_setzero_pd();
            let mut vsum = _mm256_setzero_pd();
            let mut i = 0;
            while i + 4 <= len {
                // SAFETY: cells i..i + 4 are inside `line` and `out`.
                unsafe {
                    // v0 = [c0, c2], v1 = [c1, c3]: the horizontal add of the squares is then
                    // [p0, p1, p2, p3] in cell order.
                    let c = src.add(2 * i);
                    let v0 = _mm256_loadu2_m128d(c.add(4), c);
                    let v1 = _mm256_loadu2_m128d(c.add(6), c.add(2));
                    let p = _mm256_hadd_pd(_mm256_mul_pd(v0, v0), _mm256_mul_pd(v1, v1));
                    _mm256_storeu_pd(dst.add(i), p);
                    vmax = _mm256_max_pd(p, vmax);
                    vsum = _mm256_add_pd(vsum, p);
                }
                i += 4;
            }
            let (mut lanes, mut sums) = ([0.0; 4], [0.0; 4]);
            // SAFETY: four f64 each.
            unsafe {
                _mm256_storeu_pd(lanes.as_mut_ptr(), vmax);
                _mm256_storeu_pd(sums.as_mut_ptr(), vsum);
            }
            *mx = super::norm_tail(&line[i..], &mut out[i..], lanes, sums);
        }
    }

    /// `super::gather_m1` moving 2 × 2 blocks (two bins of two antennas) per 256-bit
    /// load/store pair; an odd last antenna row goes one value at a time.
    ///
    /// # Safety
    /// That of `super::gather_m1`, and AVX2.
    #[target_feature(enable = "avx2")]
    pub(super) unsafe fn gather_m1(
        work: &[Complex64],
        t: &mut [Complex64],
        i0: usize,
        bb: usize,
        k: usize,
        a: usize,
        stride: usize,
    ) -> usize {
        let (src, dst) = (work.as_ptr(), t.as_mut_ptr());
        let (s, d) = (src as *const f64, dst as *mut f64);
        let mut b = 0;
        while b + 4 <= bb {
            let mut kk = 0;
            while kk + 2 <= k {
                let (r0, r1) = (kk * stride + i0 + b, (kk + 1) * stride + i0 + b);
                prefetch(src.wrapping_add(r0 + GATHER_AHEAD));
                prefetch(src.wrapping_add(r1 + GATHER_AHEAD));
                // SAFETY: r1 + 3 < (k − 1)·stride + i0 + bb ≤ work.len(), and
                // (b + 3)·a + kk + 1 < bb·a ≤ t.len() (the caller's contract).
                unsafe {
                    let x0 = _mm256_loadu_pd(s.add(2 * r0)); // (kk, b), (kk, b + 1)
                    let x1 = _mm256_loadu_pd(s.add(2 * r0 + 4)); // (kk, b + 2), (kk, b + 3)
                    let y0 = _mm256_loadu_pd(s.add(2 * r1));
                    let y1 = _mm256_loadu_pd(s.add(2 * r1 + 4));
                    let o = d.add(2 * (b * a + kk));
                    _mm256_storeu_pd(o, _mm256_permute2f128_pd::<0x20>(x0, y0));
                    _mm256_storeu_pd(o.add(2 * a), _mm256_permute2f128_pd::<0x31>(x0, y0));
                    _mm256_storeu_pd(o.add(4 * a), _mm256_permute2f128_pd::<0x20>(x1, y1));
                    _mm256_storeu_pd(o.add(6 * a), _mm256_permute2f128_pd::<0x31>(x1, y1));
                }
                kk += 2;
            }
            if kk < k {
                let base = kk * stride + i0 + b;
                prefetch(src.wrapping_add(base + GATHER_AHEAD));
                // SAFETY: as above for the one row.
                unsafe {
                    let o = dst.add(b * a + kk);
                    *o = *src.add(base);
                    *o.add(a) = *src.add(base + 1);
                    *o.add(2 * a) = *src.add(base + 2);
                    *o.add(3 * a) = *src.add(base + 3);
                }
            }
            b += 4;
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Deterministic values of all magnitudes, with some zeros, negative zeros and huge values.
    fn values(len: usize, seed: u64) -> Vec<Complex64> {
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        let mut next = move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        (0..len)
            .map(|_| {
                let mut f = || {
                    let r = next();
                    match r % 16 {
                        0 => 0.0,
                        1 => -0.0,
                        2 => 1e300 * ((r >> 8) % 1000) as f64,
                        3 => 1e-300 * ((r >> 8) % 1000) as f64,
                        _ => ((r >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 8.0,
                    }
                };
                Complex64::new(f(), f())
            })
            .collect()
    }

    fn isas() -> Vec<Isa> {
        let mut v = vec![Isa::Portable];
        if Isa::detect() != Isa::Portable {
            v.push(Isa::detect());
        }
        v
    }

    fn bits(v: &[Complex64]) -> Vec<(u64, u64)> {
        v.iter().map(|c| (c.re.to_bits(), c.im.to_bits())).collect()
    }

    #[test]
    fn mul_row_forms_are_bit_identical() {
        for len in [0, 1, 2, 3, 4, 5, 7, 8, 9, 63, 64, 65, 1000] {
            let (y, inv) = (values(len, 1 + len as u64), values(len, 1000 + len as u64));
            let reference: Vec<Complex64> = y.iter().zip(&inv).map(|(a, b)| a * b).collect();
            for isa in isas() {
                let mut dst = vec![Complex64::new(7.0, 7.0); len];
                mul_row(isa, &mut dst, &y, &inv);
                // NaN (from ∞·0) may differ in payload only: compare NaN-ness there.
                for (i, (d, r)) in dst.iter().zip(&reference).enumerate() {
                    for (p, q) in [(d.re, r.re), (d.im, r.im)] {
                        assert!(
                            p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan()),
                            "{isa:?} len {len} cell {i}: {p} vs {q}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn reciprocal_forms_are_bit_identical() {
        for len in [0, 1, 2, 3, 4, 5, 9, 64, 1001] {
            let mut x = values(len, 77 + len as u64);
            for (i, v) in x.iter_mut().enumerate() {
                match i % 11 {
                    1 => *v = Complex64::new(f64::MIN_POSITIVE / 8.0, -f64::MIN_POSITIVE / 3.0),
                    2 => *v = Complex64::new(1e308, -1e308),
                    3 => *v = Complex64::new(0.0, -0.0),
                    4 => *v = Complex64::new(f64::MIN_POSITIVE, 0.0),
                    _ => {}
                }
            }
            let mut results = Vec::new();
            for isa in isas() {
                let mut dst = vec![Complex64::new(9.0, 9.0); len];
                let usable = reciprocals(isa, &x, &mut dst, 1.0 / 10240.0);
                results.push((usable, bits(&dst)));
            }
            assert!(results.windows(2).all(|w| w[0] == w[1]), "len {len}");
            for bad in [f64::NAN, f64::INFINITY] {
                if len > 3 {
                    let mut y = x.clone();
                    y[len - 2].im = bad;
                    for isa in isas() {
                        let mut dst = vec![Complex64::new(0.0, 0.0); len];
                        assert_eq!(reciprocals(isa, &y, &mut dst, 1.0), Err(len - 2));
                    }
                }
            }
        }
    }

    #[test]
    fn norm_sqr_max_forms_are_bit_identical() {
        for len in [0, 1, 3, 4, 5, 8, 31, 32, 33, 100] {
            for seed in 0..8 {
                let line = values(len, seed * 100 + len as u64);
                let mut first: Option<(Vec<u64>, u64)> = None;
                for isa in isas() {
                    let mut out = vec![-1.0; len];
                    let mx = norm_sqr_max(isa, &line, &mut out);
                    let got = (out.iter().map(|p| p.to_bits()).collect(), mx.to_bits());
                    match &first {
                        None => first = Some(got),
                        Some(f) => assert_eq!(f, &got, "{isa:?} len {len} seed {seed}"),
                    }
                }
                if let Some((out, _)) = first {
                    for (p, v) in out.iter().zip(&line) {
                        assert_eq!(*p, v.norm_sqr().to_bits());
                    }
                }
            }
        }
    }

    #[test]
    fn gather_forms_are_identical() {
        for (k, m, a, bb, i0) in [
            (32, 1, 32, 64, 0),
            (32, 1, 32, 61, 5),
            (7, 1, 7, 13, 3),
            (7, 1, 14, 8, 0),
            (1, 1, 1, 9, 2),
            (2, 1, 4, 3, 1),
            (4, 3, 8, 10, 1),
        ] {
            let stride = 80;
            let work = values(k * m * stride, (k * 31 + bb) as u64);
            let mut reference = vec![Complex64::new(0.0, 0.0); bb * m * a];
            for b in 0..bb {
                for mm in 0..m {
                    for kk in 0..k {
                        reference[(b * m + mm) * a + kk] = work[(kk * m + mm) * stride + i0 + b];
                    }
                }
            }
            for isa in isas() {
                let mut t = vec![Complex64::new(0.0, 0.0); bb * m * a];
                gather(isa, &work, &mut t, i0, bb, k, m, a, stride);
                assert_eq!(
                    bits(&t),
                    bits(&reference),
                    "{isa:?} k {k} m {m} a {a} bb {bb}"
                );
            }
        }
    }
}
