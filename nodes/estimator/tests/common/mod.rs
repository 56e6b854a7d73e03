//! Test-signal generator for the estimator's tests and benchmark.
//!
//! Y(k, m, n) = Σ a · X(m, n) · e^(−j2π nΔf · 2r/c) · e^(+j2π (d/λ) k sin θ) · e^(−j2π m T 2v f_c/c)
//!            + Z(k, m, n),
//! the signs of `nrslam_ofdm` (range as the paper prints it, array phase e^(+j2π (d/λ) k sin θ)).
//! Phases are computed per subcarrier from the exact product n · (Δf 2r/c) in turns (FMA error
//! term, reduced modulo 1): no cumulative products. Z is complex white Gaussian with variance
//! 1/SNR (the per-element SNR of a unit echo), seeded ChaCha8.
#![allow(dead_code)]

use nrslam_ofdm::{OfdmParams, ResourceGrid, SPEED_OF_LIGHT_M_PER_S};
use num_complex::Complex64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use std::f64::consts::PI;

/// One point echo.
#[derive(Debug, Clone, Copy)]
pub struct Echo {
    pub range_m: f64,
    pub angle_rad: f64,
    pub velocity_mps: f64,
    pub amplitude: Complex64,
}

impl Echo {
    pub fn new(range_m: f64, angle_rad: f64) -> Self {
        Self {
            range_m,
            angle_rad,
            velocity_mps: 0.0,
            amplitude: Complex64::new(1.0, 0.0),
        }
    }

    pub fn at_sine(range_m: f64, sine: f64) -> Self {
        Self::new(range_m, sine.clamp(-1.0, 1.0).asin())
    }
}

/// Table I with other sizes.
pub fn params(n: usize, k: usize, m: usize) -> OfdmParams {
    OfdmParams {
        subcarriers: n,
        antennas: k,
        symbols: m,
        ..OfdmParams::default()
    }
}

/// `index · rate` in turns, reduced to [−½, ½], exact up to the rounding of `rate`.
pub fn turns(index: usize, rate: f64) -> f64 {
    let x = index as f64;
    let p = x * rate;
    let e = x.mul_add(rate, -p);
    let r = p - p.round() + e;
    r - r.round()
}

pub fn cis(turns: f64) -> Complex64 {
    let (s, c) = (2.0 * PI * turns).sin_cos();
    Complex64::new(c, s)
}

/// Transmitted symbols: unit-power 16-QAM (amplitudes vary, so Y/X is exercised), seeded.
pub fn qam16(len: usize, rng: &mut ChaCha8Rng) -> Vec<Complex64> {
    let lv = [-3.0, -1.0, 1.0, 3.0];
    let s = 1.0 / 10f64.sqrt();
    (0..len)
        .map(|_| {
            Complex64::new(
                lv[rng.random_range(0..4)] * s,
                lv[rng.random_range(0..4)] * s,
            )
        })
        .collect()
}

/// A frame with `echoes` and, for `snr_db = Some(s)`, AWGN of variance 10^(−s/10).
pub fn grid(p: &OfdmParams, echoes: &[Echo], snr_db: Option<f64>, seed: u64) -> ResourceGrid {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (n_n, k_n, m_n) = (p.subcarriers, p.antennas, p.symbols);
    let x = qam16(m_n * n_n, &mut rng);
    let c = SPEED_OF_LIGHT_M_PER_S;
    let mut y = vec![Complex64::new(0.0, 0.0); k_n * m_n * n_n];
    for e in echoes {
        let range_rate = -p.subcarrier_spacing_hz * 2.0 * e.range_m / c;
        let array_rate = p.antenna_spacing_wavelengths * e.angle_rad.sin();
        let doppler_rate = -p.symbol_duration_s * 2.0 * e.velocity_mps * p.carrier_frequency_hz / c;
        let range: Vec<Complex64> = (0..n_n).map(|n| cis(turns(n, range_rate))).collect();
        for k in 0..k_n {
            for m in 0..m_n {
                let g = e.amplitude * cis(turns(k, array_rate) + turns(m, doppler_rate));
                let row = &mut y[(k * m_n + m) * n_n..(k * m_n + m + 1) * n_n];
                for (n, v) in row.iter_mut().enumerate() {
                    *v += g * range[n] * x[m * n_n + n];
                }
            }
        }
    }
    if let Some(snr) = snr_db {
        let sigma = (10f64.powf(-snr / 10.0) / 2.0).sqrt();
        for v in &mut y {
            let re: f64 = rng.sample(StandardNormal);
            let im: f64 = rng.sample(StandardNormal);
            *v += Complex64::new(re, im) * sigma;
        }
    }
    ResourceGrid {
        antennas: k_n,
        symbols: m_n,
        subcarriers: n_n,
        received: y,
        transmitted: x,
    }
}

/// Twenty echoes spread over range bins 12 to 151 of `p` (the first 20 m at Table I) and over
/// the sines of angle from −0.9 to +0.81: the benches' and timing examples' scene.
pub fn twenty_echoes(p: &OfdmParams) -> Vec<Echo> {
    let dr = p.range_bin_m();
    (0..20)
        .map(|i| Echo::at_sine((12.0 + 7.3 * i as f64) * dr, -0.9 + 0.09 * i as f64))
        .collect()
}

/// The benches' and timing examples' frame: Table I sizes with one symbol (N 10240, K 32, M 1)
/// and [`twenty_echoes`] at the Table I SNR, noise seed 1.
pub fn table_one_frame() -> (OfdmParams, ResourceGrid) {
    let p = params(10240, 32, 1);
    let g = grid(&p, &twenty_echoes(&p), Some(p.snr_db), 1);
    (p, g)
}

/// Wraps a sine difference into [−1/(d/λ)/2, …) for d = λ/2: [−1, 1).
pub fn sine_error(est_rad: f64, true_rad: f64) -> f64 {
    let d = est_rad.sin() - true_rad.sin();
    (d + 1.0).rem_euclid(2.0) - 1.0
}
