//! Noisy wheel odometry: per-frame motion increments from the true trajectory, corrupted in
//! proportion to the distance driven, integrated into a dead-reckoned pose.
//!
//! The paper's SLAM (Sec. III-A) locates the AGV from the map; it does not describe the AGV's
//! proprioception, so this is the textbook odometry motion model (Thrun, Burgard, Fox,
//! *Probabilistic Robotics*, §5.4): the true motion between two frames is written as a rotation
//! `rot1` toward the direction of travel, a translation `d`, and a rotation `rot2`; the odometry
//! reports
//!
//! - `d' = d · (1 + scale_bias) + N(0, (k_t · d)²)` — wheel-radius error and slip grow with the
//!   distance rolled; `k_t` is `odom_translation_noise` (default 0.02, i.e. 2 % of distance);
//! - a heading error `e = b_r · d + N(0, (k_r · d)²)` split evenly between `rot1` and `rot2` (a
//!   differential drive's heading error accrues along the step, so the direction of travel is off
//!   by half of it); `k_r` is `odom_rotation_noise_deg_per_m` (default 0.5°/m) and `b_r` a
//!   systematic `odom_rotation_bias_deg_per_m` (wheel-base error; default 0).
//!
//! Real odometry has both biases; they default to 0 because the paper models none and a bias
//! makes the Monte Carlo mean error deterministic rather than zero-mean. The dead-reckoned pose
//! equals the truth at t0 (frame 0), and with all noise 0 equals the truth at every frame.
//!
//! The reported covariance is the first-order propagation of the random terms (biases are not in
//! it: they are unknown to the AGV), of which the Odometry message carries the diagonal.

use nalgebra::{Matrix2, Matrix3, Matrix3x2};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

use crate::geometry::{wrap_angle, Pose2};

/// Error model of the wheel odometry (SI units; [`crate::Params`] carries the user-facing ones).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct OdometryNoise {
    /// Std of the translation error per metre driven (fraction, e.g. 0.02).
    pub translation_fraction: f64,
    /// Std of the heading error per metre driven (rad/m).
    pub rotation_rad_per_m: f64,
    /// Systematic scale error of the distance (fraction; +0.01 over-reports by 1 %).
    pub scale_bias: f64,
    /// Systematic heading drift per metre driven (rad/m, counter-clockwise positive).
    pub rotation_bias_rad_per_m: f64,
}

/// The motion between two poses as rotate–translate–rotate.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionIncrement {
    /// Rotation from the start heading to the direction of travel (rad).
    pub rot1_rad: f64,
    /// Distance between the two positions (m).
    pub translation_m: f64,
    /// Rotation from the direction of travel to the end heading (rad).
    pub rot2_rad: f64,
}

impl MotionIncrement {
    /// The increment taking `from` to `to`.
    pub fn between(from: Pose2, to: Pose2) -> Self {
        let d = to.position() - from.position();
        let translation_m = d.norm();
        // With no translation the direction of travel is undefined; put all rotation in rot2.
        let rot1_rad = if translation_m > 0.0 {
            wrap_angle(d.y.atan2(d.x) - from.yaw_rad)
        } else {
            0.0
        };
        let rot2_rad = wrap_angle(to.yaw_rad - from.yaw_rad - rot1_rad);
        Self {
            rot1_rad,
            translation_m,
            rot2_rad,
        }
    }

    /// `pose` moved by this increment.
    pub fn apply(&self, pose: Pose2) -> Pose2 {
        let direction = pose.yaw_rad + self.rot1_rad;
        Pose2::new(
            pose.x_m + self.translation_m * direction.cos(),
            pose.y_m + self.translation_m * direction.sin(),
            pose.yaw_rad + self.rot1_rad + self.rot2_rad,
        )
    }
}

/// One odometry output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OdometryReading {
    /// Dead-reckoned pose (frame "odom" = "map" at t0).
    pub pose: Pose2,
    /// Variances of x (m²), y (m²) and yaw (rad²) of the dead-reckoned pose.
    pub pose_variance: [f64; 3],
    /// Forward speed over the last frame (m/s), as measured.
    pub linear_mps: f64,
    /// Yaw rate over the last frame (rad/s), as measured.
    pub angular_rps: f64,
    /// Variance of `linear_mps` ((m/s)²).
    pub linear_variance: f64,
    /// Variance of `angular_rps` ((rad/s)²).
    pub angular_variance: f64,
}

/// Dead reckoning from noisy wheel increments, with its own random stream.
#[derive(Debug, Clone)]
pub struct WheelOdometry {
    noise: OdometryNoise,
    pose: Pose2,
    covariance: Matrix3<f64>,
    last_true: Pose2,
    rng: ChaCha8Rng,
}

impl WheelOdometry {
    /// Odometry starting at the true pose `start` (its covariance is 0 there).
    pub fn new(start: Pose2, noise: OdometryNoise, rng: ChaCha8Rng) -> Self {
        Self {
            noise,
            pose: start,
            covariance: Matrix3::zeros(),
            last_true: start,
            rng,
        }
    }

    /// The reading at t0: the true pose, exact, with the given (true) velocities.
    pub fn initial_reading(&self, linear_mps: f64, angular_rps: f64) -> OdometryReading {
        OdometryReading {
            pose: self.pose,
            pose_variance: [0.0; 3],
            linear_mps,
            angular_rps,
            linear_variance: 0.0,
            angular_variance: 0.0,
        }
    }

    /// Advances to the next frame, whose true pose is `true_pose`, `dt_s` seconds later.
    /// Always draws two standard normals, so the stream does not depend on the noise levels.
    pub fn step(&mut self, true_pose: Pose2, dt_s: f64) -> OdometryReading {
        let truth = MotionIncrement::between(self.last_true, true_pose);
        self.last_true = true_pose;
        let d = truth.translation_m;
        let z_translation: f64 = self.rng.sample(StandardNormal);
        let z_rotation: f64 = self.rng.sample(StandardNormal);
        let translation_std = self.noise.translation_fraction * d;
        let rotation_std = self.noise.rotation_rad_per_m * d;
        let heading_error = self.noise.rotation_bias_rad_per_m * d + rotation_std * z_rotation;
        let measured = MotionIncrement {
            rot1_rad: truth.rot1_rad + heading_error / 2.0,
            translation_m: d * (1.0 + self.noise.scale_bias) + translation_std * z_translation,
            rot2_rad: truth.rot2_rad + heading_error / 2.0,
        };

        // First-order covariance propagation through `apply`, in the errors of (d, e).
        let direction = self.pose.yaw_rad + measured.rot1_rad;
        let (sin, cos) = direction.sin_cos();
        let dm = measured.translation_m;
        let f = Matrix3::new(1.0, 0.0, -dm * sin, 0.0, 1.0, dm * cos, 0.0, 0.0, 1.0);
        let g = Matrix3x2::new(cos, -dm * sin / 2.0, sin, dm * cos / 2.0, 0.0, 1.0);
        let q = Matrix2::new(translation_std.powi(2), 0.0, 0.0, rotation_std.powi(2));
        self.covariance = f * self.covariance * f.transpose() + g * q * g.transpose();

        self.pose = measured.apply(self.pose);
        OdometryReading {
            pose: self.pose,
            pose_variance: [
                self.covariance[(0, 0)],
                self.covariance[(1, 1)],
                self.covariance[(2, 2)],
            ],
            linear_mps: measured.translation_m / dt_s,
            angular_rps: (measured.rot1_rad + measured.rot2_rad) / dt_s,
            linear_variance: (translation_std / dt_s).powi(2),
            angular_variance: (rotation_std / dt_s).powi(2),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trajectory::Trajectory;
    use rand::SeedableRng;

    fn trajectory() -> Trajectory {
        Trajectory::new(&crate::trajectory::tests::spec()).unwrap()
    }

    fn run(noise: OdometryNoise, seed: u64) -> Vec<(Pose2, OdometryReading)> {
        let t = trajectory();
        let mut odo =
            WheelOdometry::new(t.pose_at_frame(0), noise, ChaCha8Rng::seed_from_u64(seed));
        let mut out = vec![(t.pose_at_frame(0), odo.initial_reading(1.0, 0.0))];
        for k in 1..t.frame_count() {
            let truth = t.pose_at_frame(k);
            out.push((truth, odo.step(truth, t.frame_period_s())));
        }
        out
    }

    #[test]
    fn increment_round_trip() {
        let a = Pose2::new(1.0, 2.0, 0.3);
        let b = Pose2::new(1.5, 2.4, 0.9);
        let back = MotionIncrement::between(a, b).apply(a);
        assert!((back.x_m - b.x_m).abs() < 1e-12);
        assert!((back.y_m - b.y_m).abs() < 1e-12);
        assert!(wrap_angle(back.yaw_rad - b.yaw_rad).abs() < 1e-12);
        // Pure rotation.
        let c = Pose2::new(1.0, 2.0, -2.0);
        let back = MotionIncrement::between(a, c).apply(a);
        assert!(wrap_angle(back.yaw_rad - c.yaw_rad).abs() < 1e-12);
    }

    #[test]
    fn zero_noise_equals_truth() {
        for (truth, reading) in run(OdometryNoise::default(), 5) {
            assert!((reading.pose.position() - truth.position()).norm() < 1e-9);
            assert!(wrap_angle(reading.pose.yaw_rad - truth.yaw_rad).abs() < 1e-9);
            assert_eq!(reading.pose_variance, [0.0; 3]);
        }
    }

    #[test]
    fn noise_drifts_and_covariance_grows() {
        let noise = OdometryNoise {
            translation_fraction: 0.02,
            rotation_rad_per_m: 0.5f64.to_radians(),
            ..OdometryNoise::default()
        };
        let out = run(noise, 5);
        let (truth0, first) = out[0];
        assert_eq!(first.pose, truth0);
        let (truth, last) = out[out.len() - 1];
        let error_m = (last.pose.position() - truth.position()).norm();
        assert!(error_m > 1e-3 && error_m < 10.0, "{error_m}");
        // Position variance grows along the first straight (it may shrink a little later: after
        // a half turn a heading error pushes the AGV back toward the truth), and is larger at
        // the end than early on.
        let total: Vec<f64> = out
            .iter()
            .map(|(_, r)| r.pose_variance[0] + r.pose_variance[1])
            .collect();
        assert!(total[..26].windows(2).all(|w| w[1] > w[0]));
        assert!(total[total.len() - 1] > total[25]);
        // Heading variance after L metres is (k_r)² · L · step (a random walk in heading).
        let lap = trajectory().lap_length_m();
        let expected = (0.5f64.to_radians()).powi(2) * 0.5 * (lap - 0.5);
        assert!((last.pose_variance[2] / expected - 1.0).abs() < 0.02);
        // Different seeds, different drift; same seed, same drift.
        assert_eq!(run(noise, 5), out);
        assert_ne!(run(noise, 6), out);
    }

    #[test]
    fn bias_turns_the_estimate() {
        let noise = OdometryNoise {
            rotation_bias_rad_per_m: 0.01,
            ..OdometryNoise::default()
        };
        let out = run(noise, 1);
        let (truth, last) = out[out.len() - 1];
        let drift = wrap_angle(last.pose.yaw_rad - truth.yaw_rad);
        // The bias accrues per metre of chord between frames.
        let driven_m: f64 = out
            .windows(2)
            .map(|w| MotionIncrement::between(w[0].0, w[1].0).translation_m)
            .sum();
        assert!(
            (drift - wrap_angle(0.01 * driven_m)).abs() < 1e-9,
            "{drift}"
        );
    }

    #[test]
    fn empirical_heading_spread_matches_variance() {
        // 400 independent runs of 40 frames: the spread of the heading error matches the
        // propagated variance.
        let noise = OdometryNoise {
            translation_fraction: 0.0,
            rotation_rad_per_m: 2f64.to_radians(),
            ..OdometryNoise::default()
        };
        let t = trajectory();
        let mut errors = Vec::new();
        let mut predicted = 0.0;
        for seed in 0..400 {
            let mut odo =
                WheelOdometry::new(t.pose_at_frame(0), noise, ChaCha8Rng::seed_from_u64(seed));
            let mut reading = odo.initial_reading(1.0, 0.0);
            for k in 1..40 {
                reading = odo.step(t.pose_at_frame(k), 0.5);
            }
            errors.push(wrap_angle(
                reading.pose.yaw_rad - t.pose_at_frame(39).yaw_rad,
            ));
            predicted = reading.pose_variance[2];
        }
        let var = errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64;
        assert!((var / predicted - 1.0).abs() < 0.2, "{var} vs {predicted}");
    }
}
