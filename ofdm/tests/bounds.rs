//! Cramér–Rao bounds and grid limits against hand-computed Table I figures.

use nrslam_ofdm::bounds::*;
use nrslam_ofdm::OfdmParams;
use std::f64::consts::PI;

#[test]
fn table_i_figures() {
    let p = OfdmParams::default();
    let c = 299_792_458.0f64;
    let (n, m, snr) = (10240.0f64, 256.0f64, 10.0f64);
    let var_r = 3.0 * c * c / (8.0 * PI * PI * 120e3f64.powi(2) * snr * m * n * (n * n - 1.0));
    assert!((range_variance_bound_m2(&p) / var_r - 1.0).abs() < 1e-12);
    assert!(
        (range_std_bound_m(&p) - 9.3e-6).abs() < 0.1e-6,
        "{}",
        range_std_bound_m(&p)
    );
    assert!((range_variance_bound_array_m2(&p) * 32.0 / var_r - 1.0).abs() < 1e-12);
    // Angle at broadside: 6 / (SNR N M · K(K²−1) · π²).
    let var_t = 6.0 / (snr * n * m * 32.0 * 1023.0 * PI * PI);
    assert!((angle_variance_bound_rad2(&p, 0.0) / var_t - 1.0).abs() < 1e-12);
    // cos θ = 0.5 at 60°: four times the variance.
    let r = angle_variance_bound_rad2(&p, 60f64.to_radians()) / var_t;
    assert!((r - 4.0).abs() < 1e-9, "{r}");
    assert!(angle_variance_bound_rad2(&p, PI / 2.0) > 1e20);
    // Grid limits: 0.122 m / √12 = 3.52 cm; sin-θ bin 1/16 / √12.
    assert!((range_grid_rms_m(&p, 1) - 0.0352).abs() < 1e-4);
    assert!((range_grid_rms_m(&p, 4) - 0.0088).abs() < 1e-4);
    assert!((sine_grid_rms(&p, 1) - 0.0625 / 12f64.sqrt()).abs() < 1e-15);
    assert!((angle_grid_rms_rad(&p, 0.0, 1).to_degrees() - 1.034).abs() < 1e-3);
    assert!(angle_grid_rms_rad(&p, PI / 2.0, 1) > 1e10);
    // The grid, not noise, limits accuracy at Table I.
    assert!(range_grid_rms_m(&p, 1) > 1000.0 * range_std_bound_m(&p));
    assert!(angle_grid_rms_rad(&p, 0.0, 1) > 1000.0 * angle_std_bound_rad(&p, 0.0));
}

#[test]
fn bounds_scale_inversely_with_snr() {
    let p = OfdmParams::default();
    let q = OfdmParams { snr_db: 20.0, ..p };
    assert!((range_variance_bound_m2(&p) / range_variance_bound_m2(&q) - 10.0).abs() < 1e-9);
    assert!(
        (angle_variance_bound_rad2(&p, 0.3) / angle_variance_bound_rad2(&q, 0.3) - 10.0).abs()
            < 1e-9
    );
    let single = OfdmParams { antennas: 1, ..p };
    assert!(angle_variance_bound_rad2(&single, 0.0).is_infinite());
}
