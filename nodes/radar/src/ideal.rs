//! The `ideal` measurement model: each seen scatterer becomes one detection at its true range and
//! angle plus independent Gaussian errors of standard deviation ΔR and Δθ.
//!
//! These are the conditions of the paper's Fig. 3 (Sec. IV-A: ΔR ∈ {0, 0.1 m}, Δθ ∈ {1°, 5°}),
//! which stand in for the DFT range and angle estimates of Sec. III-B. No resolution limit is
//! modelled: two scatterers 1 cm apart give two detections.
//!
//! Power: a point scatterer's echo falls as 1/R⁴ (radar equation, free space, equal radar cross
//! sections), so `power_db = −40 · log10(R / 1 m)` relative to a scatterer at 1 m, from the true
//! range. It carries no information the range does not; consumers may weight by it.
//!
//! A detection whose noisy range is negative is dropped (no physical radar reports one), and so
//! is one whose noisy angle leaves (−90°, 90°), outside which a linear array's angle is
//! ambiguous (docs/conventions.md). Both only happen with large errors.
//!
//! Randomness: two standard normals are drawn per seen scatterer, in [`crate::visibility::observe`]
//! order, whatever the standard deviations (even 0). So a run is a function of the seed alone, and
//! changing ΔR does not reshuffle which normal goes to which scatterer.

use std::f64::consts::FRAC_PI_2;

use nrslam_msgs::Detection;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::visibility::Sighting;

/// Power of an echo from `range_m` relative to one from 1 m (dB): −40·log10(R/1 m), the 1/R⁴
/// radar equation.
pub fn relative_power_db(range_m: f64) -> f64 {
    -40.0 * range_m.log10()
}

/// The ideal measurement model with its own random stream.
#[derive(Debug, Clone)]
pub struct IdealModel {
    range_std_m: f64,
    angle_std_rad: f64,
    rng: ChaCha8Rng,
}

impl IdealModel {
    /// A model with range error std `range_std_m` (m) and angle error std `angle_std_rad`
    /// (rad), both ≥ 0 (the caller validates), drawing from `rng`.
    pub fn new(range_std_m: f64, angle_std_rad: f64, rng: ChaCha8Rng) -> Self {
        Self {
            range_std_m,
            angle_std_rad,
            rng,
        }
    }

    /// Range error standard deviation (m).
    pub fn range_std_m(&self) -> f64 {
        self.range_std_m
    }

    /// Angle error standard deviation (rad).
    pub fn angle_std_rad(&self) -> f64 {
        self.angle_std_rad
    }

    /// Detections of one frame: one per sighting, in sighting order, minus the dropped ones.
    pub fn measure(&mut self, sightings: &[Sighting]) -> Vec<Detection> {
        let mut out = Vec::with_capacity(sightings.len());
        for s in sightings {
            let range_noise: f64 = self.rng.sample(StandardNormal);
            let angle_noise: f64 = self.rng.sample(StandardNormal);
            let range_m = s.range_m + self.range_std_m * range_noise;
            let angle_rad = s.angle_rad + self.angle_std_rad * angle_noise;
            if range_m < 0.0 || angle_rad.abs() >= FRAC_PI_2 {
                continue;
            }
            out.push(Detection {
                range_m,
                angle_rad,
                range_std_m: self.range_std_m,
                angle_std_rad: self.angle_std_rad,
                power_db: relative_power_db(s.range_m),
            });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Vec2;
    use rand::SeedableRng;

    fn sighting(range_m: f64, angle_rad: f64) -> Sighting {
        Sighting {
            target_index: 0,
            scatterer_index: 0,
            position: Vec2::zeros(),
            range_m,
            angle_rad,
        }
    }

    #[test]
    fn zero_noise_is_exact() {
        let mut m = IdealModel::new(0.0, 0.0, ChaCha8Rng::seed_from_u64(1));
        let d = m.measure(&[sighting(3.5, 0.25)]);
        assert_eq!(d.len(), 1);
        assert_eq!((d[0].range_m, d[0].angle_rad), (3.5, 0.25));
        assert!((d[0].power_db - -40.0 * 3.5f64.log10()).abs() < 1e-12);
    }

    #[test]
    fn angle_noise_statistics() {
        let std_rad = 1f64.to_radians();
        let mut m = IdealModel::new(0.1, std_rad, ChaCha8Rng::seed_from_u64(7));
        let n = 20_000;
        let sightings = vec![sighting(10.0, 0.0); n];
        let d = m.measure(&sightings);
        assert_eq!(d.len(), n);
        let mean = d.iter().map(|x| x.angle_rad).sum::<f64>() / n as f64;
        let var = d.iter().map(|x| (x.angle_rad - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        // Standard error of the mean: σ/√n ≈ 1.2e-4 rad; of the std: σ/√(2n) ≈ 0.5 %.
        assert!(
            mean.abs() < 5.0 * std_rad / (n as f64).sqrt(),
            "mean {mean}"
        );
        assert!(
            (var.sqrt() / std_rad - 1.0).abs() < 0.03,
            "std {}",
            var.sqrt()
        );
        let r_mean = d.iter().map(|x| x.range_m).sum::<f64>() / n as f64;
        let r_std =
            (d.iter().map(|x| (x.range_m - r_mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        assert!((r_mean - 10.0).abs() < 5.0 * 0.1 / (n as f64).sqrt());
        assert!((r_std / 0.1 - 1.0).abs() < 0.03);
        assert!(d
            .iter()
            .all(|x| x.range_std_m == 0.1 && x.angle_std_rad == std_rad));
    }

    #[test]
    fn negative_range_and_ambiguous_angle_dropped() {
        // Range 0.01 m with 1 m error: about half the draws go negative and are dropped.
        let mut m = IdealModel::new(1.0, 0.0, ChaCha8Rng::seed_from_u64(3));
        let d = m.measure(&vec![sighting(0.01, 0.0); 1000]);
        assert!(d.len() > 400 && d.len() < 600, "{}", d.len());
        assert!(d.iter().all(|x| x.range_m >= 0.0));
        // Angle 89° with 5° error: many leave (−90°, 90°).
        let mut m = IdealModel::new(0.0, 5f64.to_radians(), ChaCha8Rng::seed_from_u64(3));
        let d = m.measure(&vec![sighting(5.0, 89f64.to_radians()); 1000]);
        assert!(d.len() < 800);
        assert!(d.iter().all(|x| x.angle_rad.abs() < FRAC_PI_2));
    }
}
