//! The front end as a frame generator: trajectory → true pose → visibility → measurement model,
//! plus wheel odometry. Pure: no transport, no wall time; a function of (scene, params, seed).
//!
//! Geometry ([`crate::visibility::observe`]) is kept apart from the measurement model so that the
//! later `spectral` and `waveform` fidelity levels reuse it: they will take the same sightings and
//! produce spectra or echoes instead of detections.

use std::path::Path;

use nrslam_msgs::Detection;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::error::RadarError;
use crate::geometry::Pose2;
use crate::ideal::IdealModel;
use crate::odometry::{OdometryReading, WheelOdometry};
use crate::params::{Fidelity, Params};
use crate::scene::Scene;
use crate::visibility::{observe, Sighting};
use nrslam_ofdm::{OfdmParams, RangeAngleSpectrum, ResourceGrid, Scatterer};
use num_complex::Complex64;
use rand::Rng;

/// ChaCha stream of the measurement noise; the odometry uses [`ODOMETRY_STREAM`]. Separate
/// streams keep the odometry noise identical when the measurement parameters change.
pub const MEASUREMENT_STREAM: u64 = 0;
/// ChaCha stream of the odometry noise.
pub const ODOMETRY_STREAM: u64 = 1;

/// Everything the front end produces for one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    /// Frame number from 0.
    pub index: usize,
    /// Simulated time (s): `T0_S + index · frame_period_s`.
    pub stamp_s: f64,
    /// True AGV pose (map frame).
    pub true_pose: Pose2,
    /// Wheel odometry (frame "odom", equal to "map" at t0).
    pub odometry: OdometryReading,
    /// Number of scatterers seen (before measurement drops).
    pub seen_scatterers: usize,
    /// Detections in the sensor frame (`ideal`; empty at the other levels).
    pub detections: Vec<Detection>,
    /// The processed range × angle map (`spectral`).
    pub spectrum: Option<RangeAngleSpectrum>,
    /// The resource grids (`waveform`).
    pub echo: Option<ResourceGrid>,
}

/// The measurement model of the chosen fidelity level. New levels add variants.
#[derive(Debug, Clone)]
enum Model {
    Ideal(IdealModel),
    Spectral {
        ofdm: OfdmParams,
        config: nrslam_ofdm::spectral::SpectralConfig,
        rng: ChaCha8Rng,
    },
    Waveform {
        ofdm: OfdmParams,
        config: nrslam_ofdm::waveform::WaveformConfig,
        rng: ChaCha8Rng,
    },
}

/// The OFDM view of the sightings: every scatterer echoes with unit amplitude, i.e. at the
/// per-element SNR of `ofdm.snr_db` (the paper's "SNR of the received signal", Sec. IV), with an
/// independent uniformly random phase (distinct reflectors), and the radial velocity of a static
/// point seen from the moving AGV: −v cos(boresight + angle).
fn scatterers(
    sightings: &[Sighting],
    speed_mps: f64,
    boresight_rad: f64,
    rng: &mut ChaCha8Rng,
) -> Vec<Scatterer> {
    sightings
        .iter()
        .map(|s| Scatterer {
            range_m: s.range_m,
            angle_rad: s.angle_rad,
            radial_velocity_mps: -speed_mps * (boresight_rad + s.angle_rad).cos(),
            amplitude: Complex64::from_polar(1.0, rng.random_range(0.0..std::f64::consts::TAU)),
        })
        .collect()
}

fn measurement_rng(seed: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(MEASUREMENT_STREAM);
    rng
}

/// Generates the frames of one run.
#[derive(Debug, Clone)]
pub struct Simulator {
    fidelity: Fidelity,
    scene: Scene,
    model: Model,
    odometry: WheelOdometry,
    frame_count: usize,
    next_frame: usize,
}

impl Simulator {
    /// Loads the scene named by `params` (relative to `base_dir`) and sets up a run seeded by
    /// `seed` (the node's seed, e.g. `ctx.seed_for("radar")`).
    pub fn from_params(params: &Params, base_dir: &Path, seed: u64) -> Result<Self, RadarError> {
        params.validate()?;
        let scene =
            Scene::load_with_spacing(&params.scene_path(base_dir), params.scatterer_spacing())?;
        Self::new(scene, params, seed)
    }

    /// Sets up a run on an already loaded scene.
    pub fn new(scene: Scene, params: &Params, seed: u64) -> Result<Self, RadarError> {
        params.validate()?;
        let model = match params.fidelity {
            Fidelity::Ideal => {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                rng.set_stream(MEASUREMENT_STREAM);
                Model::Ideal(IdealModel::new(
                    params.range_std_m,
                    params.angle_std_rad(),
                    rng,
                ))
            }
            Fidelity::Spectral => Model::Spectral {
                ofdm: params.ofdm,
                config: params.spectral,
                rng: measurement_rng(seed),
            },
            Fidelity::Waveform => Model::Waveform {
                ofdm: params.ofdm,
                config: params.waveform,
                rng: measurement_rng(seed),
            },
        };
        let mut odometry_rng = ChaCha8Rng::seed_from_u64(seed);
        odometry_rng.set_stream(ODOMETRY_STREAM);
        let start = scene.trajectory.pose_at_frame(0);
        let odometry = WheelOdometry::new(start, params.odometry_noise(), odometry_rng);
        let whole = scene.trajectory.frame_count();
        let frame_count = match params.frames {
            0 => whole,
            cap => whole.min(cap as usize),
        };
        Ok(Self {
            fidelity: params.fidelity,
            scene,
            model,
            odometry,
            frame_count,
            next_frame: 0,
        })
    }

    /// The fidelity level.
    pub fn fidelity(&self) -> Fidelity {
        self.fidelity
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Number of frames this run produces.
    pub fn frame_count(&self) -> usize {
        self.frame_count
    }

    /// The next frame, or `None` after the last; an error only if the OFDM synthesis refuses
    /// its input (e.g. the waveform's memory cap).
    pub fn try_next_frame(&mut self) -> Result<Option<Frame>, nrslam_ofdm::OfdmError> {
        let k = self.next_frame;
        if k >= self.frame_count {
            return Ok(None);
        }
        self.next_frame += 1;
        let trajectory = &self.scene.trajectory;
        let true_pose = trajectory.pose_at_frame(k);
        let odometry = if k == 0 {
            // Frame 0 has no increment: report the truth and the true velocities.
            let s = trajectory.distance_at_frame_m(0);
            self.odometry.initial_reading(
                trajectory.spec().speed_mps,
                trajectory.yaw_rate_at_distance(s),
            )
        } else {
            self.odometry.step(true_pose, trajectory.frame_period_s())
        };
        let sightings = observe(&self.scene.targets, &self.scene.sensor, true_pose);
        let speed_mps = trajectory.spec().speed_mps;
        let boresight_rad = self.scene.sensor.boresight_rad;
        let (mut detections, mut spectrum, mut echo) = (Vec::new(), None, None);
        match &mut self.model {
            Model::Ideal(model) => detections = model.measure(&sightings),
            Model::Spectral { ofdm, config, rng } => {
                let scatterers = scatterers(&sightings, speed_mps, boresight_rad, rng);
                spectrum = Some(nrslam_ofdm::spectral::synthesize(
                    ofdm,
                    &scatterers,
                    config,
                    rng,
                )?);
            }
            Model::Waveform { ofdm, config, rng } => {
                let scatterers = scatterers(&sightings, speed_mps, boresight_rad, rng);
                echo = Some(nrslam_ofdm::waveform::synthesize(
                    ofdm,
                    &scatterers,
                    config,
                    rng,
                )?);
            }
        }
        Ok(Some(Frame {
            index: k,
            stamp_s: trajectory.stamp_s(k),
            true_pose,
            odometry,
            seen_scatterers: sightings.len(),
            detections,
            spectrum,
            echo,
        }))
    }

    /// The next frame, or `None` after the last (or if the OFDM synthesis fails; use
    /// [`Self::try_next_frame`] to see why).
    pub fn next_frame(&mut self) -> Option<Frame> {
        self.try_next_frame().ok().flatten()
    }
}

impl Iterator for Simulator {
    type Item = Frame;

    fn next(&mut self) -> Option<Frame> {
        self.next_frame()
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let left = self.frame_count - self.next_frame;
        (left, Some(left))
    }
}
