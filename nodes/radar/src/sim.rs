//! The front end as a frame generator: trajectory → true pose → visibility → measurement model,
//! plus wheel odometry. Pure: no transport, no wall time; a function of (scene, params, seed).
//!
//! The sensor simulated is the one the `sensor` parameter names ([`Role`]): an AGV of the scene
//! (its path, its sensor, wheel odometry), a fixed station (its surveyed pose every frame, no
//! odometry noise, no motion), or none (frames carry only the stamp). A station's and none's
//! frames follow agv1's clock: as many frames, the same stamps.
//!
//! Geometry ([`crate::visibility::observe`]) is kept apart from the measurement model so that the
//! later `spectral` and `waveform` fidelity levels reuse it: they will take the same sightings and
//! produce spectra or echoes instead of detections.

use std::path::Path;
use std::sync::Arc;

use nrslam_msgs::Detection;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use crate::error::RadarError;
use crate::geometry::Pose2;
use crate::ideal::IdealModel;
use crate::memo::SceneMemo;
use crate::odometry::{OdometryReading, WheelOdometry};
use crate::params::{Fidelity, OdomOrigin, Params, Role};
use crate::scene::Scene;
use crate::trajectory::Trajectory;
use crate::visibility::{Sensor, Sighting};
use nrslam_ofdm::{OfdmParams, RangeAngleSpectrum, ResourceGrid, Scatterer};
use nrslam_runtime::InvalidParam;
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
    /// True pose of the sensor's platform (map frame): the AGV's; a station's surveyed pose
    /// (heading = boresight); for `none`, agv1's (not published).
    pub true_pose: Pose2,
    /// Wheel odometry (frame "odom": equal to "map" at t0 with `odom_origin = "map"`, the AGV's
    /// start pose with `"start"`); a station's (and none's) exact `true_pose`, zero variance and
    /// velocity.
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

/// Where the simulated sensor is and how its pose is reported.
#[derive(Debug, Clone)]
enum Platform {
    /// An AGV driving the simulator's trajectory, with wheel odometry; `origin` is its start
    /// pose when the odometry is reported relative to it.
    Agv {
        // Boxed: the odometry's random stream makes it far larger than the other variants.
        odometry: Box<WheelOdometry>,
        origin: Option<Pose2>,
    },
    /// A fixed station at its surveyed pose.
    Station { pose: Pose2 },
    /// No sensor: frames carry the clock only.
    NoSensor,
}

/// An exact, motionless odometry reading at `pose`.
fn surveyed(pose: Pose2) -> OdometryReading {
    OdometryReading {
        pose,
        pose_variance: [0.0; 3],
        linear_mps: 0.0,
        angular_rps: 0.0,
        linear_variance: 0.0,
        angular_variance: 0.0,
    }
}

/// Checks that `scene` (read from the file `origin`, named in the error when given) has the
/// sensor `params.sensor` names.
pub fn resolve_role(
    scene: &Scene,
    params: &Params,
    origin: Option<&str>,
) -> Result<Role, RadarError> {
    let role = params.role()?;
    let (asked, count, kind) = match role {
        Role::Agv(index) => (index, scene.agvs.len(), "agv"),
        Role::Station(index) => (index, scene.stations.len(), "station"),
        Role::NoSensor => return Ok(role),
    };
    if asked < count {
        return Ok(role);
    }
    let plural = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    let names = |names: Vec<&str>| {
        if names.is_empty() {
            String::new()
        } else {
            format!(" ({})", names.join(", "))
        }
    };
    Err(InvalidParam::new(
        "sensor",
        format!(
            "{:?} is not in {}, which has {}{} and {}{}",
            params.sensor,
            origin.map_or("the scene".to_owned(), |path| format!("scene {path}")),
            plural(scene.agvs.len(), "AGV"),
            names(scene.agvs.iter().map(|a| a.name.as_str()).collect()),
            plural(scene.stations.len(), "station"),
            names(scene.stations.iter().map(|s| s.name.as_str()).collect()),
        ),
        match count {
            0 => format!("no {kind}N in this scene"),
            1 => format!("{kind}1"),
            n => format!("{kind}1 to {kind}{n}"),
        },
    )
    .into())
}

/// Frames a run of `params` on `scene` produces: the AGV's path's, or agv1's for a station and
/// none, capped by `frames`.
pub fn frame_count(scene: &Scene, params: &Params) -> Result<usize, RadarError> {
    let whole = match resolve_role(scene, params, None)? {
        Role::Agv(index) => scene.agvs[index].trajectory.frame_count(),
        Role::Station(_) | Role::NoSensor => scene.trajectory.frame_count(),
    };
    Ok(match params.frames {
        0 => whole,
        cap => whole.min(cap as usize),
    })
}

/// Generates the frames of one run.
#[derive(Debug, Clone)]
pub struct Simulator {
    fidelity: Fidelity,
    scene: Scene,
    role: Role,
    /// The AGV's path; for a station or none, agv1's (the run's clock).
    trajectory: Trajectory,
    sensor: Sensor,
    platform: Platform,
    model: Model,
    frame_count: usize,
    /// The frame the sensor is switched on at (`start_frame`): the first this run produces.
    first_frame: usize,
    next_frame: usize,
    /// Sightings and kernel responses by true pose, shared with the process's other runs of
    /// this scene and sensor ([`SceneMemo`]).
    memo: Arc<SceneMemo>,
}

impl Simulator {
    /// Loads the scene named by `params` (relative to `base_dir`) and sets up a run seeded by
    /// `seed` (the node's seed, e.g. `ctx.seed_for("radar")`).
    pub fn from_params(params: &Params, base_dir: &Path, seed: u64) -> Result<Self, RadarError> {
        params.validate()?;
        let path = params.scene_path(base_dir);
        let scene = Scene::load_with_spacing(&path, params.scatterer_spacing())?;
        resolve_role(&scene, params, Some(&path.display().to_string()))?;
        Self::new(scene, params, seed)
    }

    /// Sets up a run on an already loaded scene.
    pub fn new(scene: Scene, params: &Params, seed: u64) -> Result<Self, RadarError> {
        params.validate()?;
        let role = resolve_role(&scene, params, None)?;
        let frame_count = frame_count(&scene, params)?;
        let first_frame = params.start_frame as usize;
        if first_frame >= frame_count {
            return Err(RadarError::Param(nrslam_runtime::InvalidParam::new(
                "start_frame",
                format!(
                    "is {first_frame}, but {} drives {frame_count} frames: it would never be \
                     switched on",
                    role.name()
                ),
                format!("0 to {}", frame_count.saturating_sub(1)),
            )));
        }
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
        let (trajectory, sensor, platform) = match role {
            Role::Agv(index) => {
                let agv = &scene.agvs[index];
                let mut odometry_rng = ChaCha8Rng::seed_from_u64(seed);
                odometry_rng.set_stream(ODOMETRY_STREAM);
                // Switched on at `first_frame`: its odometry starts there.
                let start = agv.trajectory.pose_at_frame(first_frame);
                let odometry = WheelOdometry::new(start, params.odometry_noise(), odometry_rng);
                let origin = (params.odom_origin == OdomOrigin::Start).then_some(start);
                (
                    agv.trajectory.clone(),
                    agv.sensor,
                    Platform::Agv {
                        odometry: Box::new(odometry),
                        origin,
                    },
                )
            }
            Role::Station(index) => {
                let station = &scene.stations[index];
                (
                    scene.trajectory.clone(),
                    station.sensor,
                    Platform::Station { pose: station.pose },
                )
            }
            Role::NoSensor => (scene.trajectory.clone(), scene.sensor, Platform::NoSensor),
        };
        let memo = SceneMemo::open(&scene.targets, &sensor);
        Ok(Self {
            fidelity: params.fidelity,
            memo,
            scene,
            role,
            trajectory,
            sensor,
            platform,
            model,
            frame_count,
            first_frame,
            next_frame: first_frame,
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

    /// Which sensor of the scene this run simulates.
    pub fn role(&self) -> Role {
        self.role
    }

    /// The simulated radar (for a station, boresight 0: its pose's heading is the boresight).
    pub fn sensor(&self) -> &Sensor {
        &self.sensor
    }

    /// The AGV's path, or agv1's for a station and none (their clock).
    pub fn trajectory(&self) -> &Trajectory {
        &self.trajectory
    }

    /// One past the index of the last frame this run produces (it produces the frames from
    /// `start_frame` up to this).
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
        let trajectory = &self.trajectory;
        let (true_pose, odometry, speed_mps) = match &mut self.platform {
            Platform::Agv { odometry, origin } => {
                let true_pose = trajectory.pose_at_frame(k);
                let mut reading = if k == self.first_frame {
                    // The first frame has no increment: report the truth and the true velocities.
                    let s = trajectory.distance_at_frame_m(k);
                    odometry
                        .initial_reading(trajectory.speed_mps(), trajectory.yaw_rate_at_distance(s))
                } else {
                    odometry.step(true_pose, trajectory.frame_period_s())
                };
                if let Some(origin) = origin {
                    reading.pose = reading.pose.relative_to(*origin);
                }
                (true_pose, reading, trajectory.speed_mps())
            }
            Platform::Station { pose } => (*pose, surveyed(*pose), 0.0),
            Platform::NoSensor => {
                let pose = trajectory.pose_at_frame(k);
                (pose, surveyed(pose), 0.0)
            }
        };
        let stamp_s = trajectory.stamp_s(k);
        if matches!(self.platform, Platform::NoSensor) {
            return Ok(Some(Frame {
                index: k,
                stamp_s,
                true_pose,
                odometry,
                seen_scatterers: 0,
                detections: Vec::new(),
                spectrum: None,
                echo: None,
            }));
        }
        let sightings = self.memo.observe(true_pose);
        let boresight_rad = self.sensor.boresight_rad;
        let (mut detections, mut spectrum, mut echo) = (Vec::new(), None, None);
        match &mut self.model {
            Model::Ideal(model) => detections = model.measure(&sightings),
            Model::Spectral { ofdm, config, rng } => {
                let scatterers = scatterers(&sightings, speed_mps, boresight_rad, rng);
                let responses = self.memo.responses(
                    true_pose,
                    (ofdm, config, speed_mps, boresight_rad),
                    &scatterers,
                )?;
                spectrum = Some(nrslam_ofdm::spectral::synthesize_with(
                    ofdm,
                    &scatterers,
                    config,
                    &responses,
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
            stamp_s,
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
