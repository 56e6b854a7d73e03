//! The radar node's parameters (`[nodes.radar.params]` of a launch file, or code).
//!
//! Defaults reproduce the paper's Fig. 3(a) conditions: ΔR = 0 m, Δθ = 1° (Sec. IV-A). The scene
//! (hall, targets, paths, sensor mountings, stations) lives in its own file, `scene`; `sensor`
//! picks which of the scene's sensors this node is (docs/scene.md, "Several AGVs and stations").

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::odometry::OdometryNoise;
use nrslam_runtime::InvalidParam;

/// How the front end turns the scene into data (docs/design.md, "Fidelity levels").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Fidelity {
    /// Each seen scatterer's true range and angle plus Gaussian errors ΔR, Δθ ([`crate::ideal`]).
    #[default]
    Ideal,
    /// Closed-form post-FFT range × angle response of each scatterer plus the processed noise
    /// ([`nrslam_ofdm::spectral`]), published on `/radar/spectrum`.
    Spectral,
    /// The OFDM resource grids of Table I with AWGN ([`nrslam_ofdm::waveform`]), published on
    /// `/radar/echo`.
    Waveform,
}

/// Which of the scene's sensors a radar node simulates (the `sensor` parameter, parsed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The AGV at this index of the scene's list (0 = agv1; `""` and `"agvN"`).
    Agv(usize),
    /// The fixed station at this index (0 = station1; `"stationN"`).
    Station(usize),
    /// No sensor (`"none"`): only the run's clock and the ground-truth targets.
    NoSensor,
}

impl Role {
    /// The role as the `sensor` parameter writes it (`agv1` for the default).
    pub fn name(self) -> String {
        match self {
            Role::Agv(index) => format!("agv{}", index + 1),
            Role::Station(index) => format!("station{}", index + 1),
            Role::NoSensor => "none".to_owned(),
        }
    }
}

/// What the odometry pose is relative to (`odom_origin`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OdomOrigin {
    /// The map frame: the dead-reckoned pose equals the true pose at frame 0.
    #[default]
    Map,
    /// The AGV's own start pose: identity at frame 0 (an AGV whose start is unknown to others).
    Start,
}

impl Fidelity {
    /// The name as written in a launch file.
    pub fn name(self) -> &'static str {
        match self {
            Fidelity::Ideal => "ideal",
            Fidelity::Spectral => "spectral",
            Fidelity::Waveform => "waveform",
        }
    }
}

/// Parameters of the radar front end.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// Fidelity level: `ideal` (detections), `spectral` (range × angle maps) or `waveform`
    /// (resource grids); the last two need an estimator node downstream.
    pub fidelity: Fidelity,
    /// Scene file (TOML), relative paths resolved against the launch's base directory.
    pub scene: PathBuf,
    /// Which of the scene's sensors this node is: `""` (agv1, as before there were several),
    /// `"agvN"` (the scene's N-th AGV, N ≥ 1), `"stationN"` (its N-th fixed station) or
    /// `"none"` (only `/clock` and `/ground_truth/targets`, for as many frames as agv1 drives).
    pub sensor: String,
    /// Frame of the published odometry pose: `map` (the dead-reckoned pose starts at the true
    /// pose) or `start` (it starts at the identity: the AGV's start pose is unknown). AGVs only:
    /// `start` with a station or `none` is refused.
    pub odom_origin: OdomOrigin,
    /// Standard deviation ΔR of the range error (m).
    pub range_std_m: f64,
    /// Standard deviation Δθ of the angle error (degrees).
    pub angle_std_deg: f64,
    /// Stop after this many frames; 0 runs the whole trajectory.
    pub frames: u32,
    /// The sensor is switched on at this frame (counted from 0, on the run's clock): the frames
    /// before it publish nothing (no `/clock`, pose, odometry or measurement), as if the AGV or
    /// station were switched on later, and an AGV's odometry starts there, at its true pose then
    /// (`odom_origin = "map"`) or at the identity (`"start"`). The ground-truth targets are
    /// still published first. 0 (the default): from the first frame. Must be before the last
    /// frame; not with `sensor = "none"`, which is the run's clock.
    pub start_frame: u32,
    /// Spacing of the point scatterers along each target's outline (m), overriding the scene
    /// file's `scatterer_spacing_m`; 0 keeps the scene's. Scatterer density trades frame cost
    /// (echoes per frame) against how densely the outlines are sampled.
    pub scatterer_spacing_m: f64,
    /// Std of the odometry's distance error per metre driven (fraction: 0.02 = 2 %).
    pub odom_translation_noise: f64,
    /// Std of the odometry's heading error per metre driven (degrees per metre).
    pub odom_rotation_noise_deg_per_m: f64,
    /// Systematic distance scale error of the odometry (fraction; 0.01 over-reports by 1 %).
    pub odom_scale_bias: f64,
    /// Systematic heading drift of the odometry (degrees per metre, counter-clockwise positive).
    pub odom_rotation_bias_deg_per_m: f64,
    /// OFDM radar parameters for `spectral` and `waveform` (Table I; `symbols` defaults to 1,
    /// which is all a static scene needs: Table I's M = 256 adds Doppler resolution only, and at
    /// `waveform` 256 symbols × 10240 subcarriers × 32 antennas is 1.3 GB per frame).
    pub ofdm: nrslam_ofdm::OfdmParams,
    /// Knobs of the `spectral` synthesis (kept range, zero padding, evaluation window).
    pub spectral: nrslam_ofdm::spectral::SpectralConfig,
    /// Knobs of the `waveform` synthesis (modulation, noise, memory cap).
    pub waveform: nrslam_ofdm::waveform::WaveformConfig,
    /// Faults injected into the published data, to test what a back end does with real-world
    /// defects. None by default.
    pub faults: Faults,
}

/// Faults the radar node injects into what it publishes (frame indices count from 0). For tests
/// of the SLAM back end's robustness; the simulation itself (noise draws, ground truth) is
/// unchanged, so a run with faults differs from one without only where the faults are.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Faults {
    /// Frames whose measurement (`/radar/detections`, `/radar/spectrum` or `/radar/echo`) is not
    /// published, as if lost; their clock, ground truth and odometry still are.
    pub drop_frames: Vec<u32>,
    /// Frames published with no detections (`ideal` fidelity only).
    pub empty_frames: Vec<u32>,
    /// Frames whose odometry pose is displaced by `odometry_spike_m` along the AGV heading, for
    /// that frame only (a glitch of the wheel encoders' integration).
    pub odometry_spike_frames: Vec<u32>,
    /// Size of the odometry spike, metres.
    pub odometry_spike_m: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            fidelity: Fidelity::Ideal,
            scene: PathBuf::from("config/hall.toml"),
            sensor: String::new(),
            odom_origin: OdomOrigin::Map,
            range_std_m: 0.0,
            angle_std_deg: 1.0,
            frames: 0,
            start_frame: 0,
            scatterer_spacing_m: 0.0,
            odom_translation_noise: 0.02,
            odom_rotation_noise_deg_per_m: 0.5,
            odom_scale_bias: 0.0,
            odom_rotation_bias_deg_per_m: 0.0,
            ofdm: nrslam_ofdm::OfdmParams {
                symbols: 1,
                ..nrslam_ofdm::OfdmParams::default()
            },
            spectral: nrslam_ofdm::spectral::SpectralConfig::default(),
            waveform: nrslam_ofdm::waveform::WaveformConfig::default(),
            faults: Faults::default(),
        }
    }
}

impl Params {
    /// Checks every parameter; the error names the field, the problem and the allowed range.
    /// Never panics. (The scene file is checked when it is loaded.)
    pub fn validate(&self) -> Result<(), InvalidParam> {
        if self.fidelity != Fidelity::Ideal {
            let ofdm = |e: nrslam_ofdm::OfdmError| {
                InvalidParam::new("ofdm", e.to_string(), "see the field named")
            };
            self.ofdm.validate().map_err(ofdm)?;
            if self.fidelity == Fidelity::Spectral {
                self.spectral.validate().map_err(ofdm)?;
            }
        }
        if self.scene.as_os_str().is_empty() {
            return Err(InvalidParam::new(
                "scene",
                "the path is empty",
                "a path to a scene TOML file",
            ));
        }
        let role = self.role()?;
        if self.odom_origin == OdomOrigin::Start && !matches!(role, Role::Agv(_)) {
            return Err(InvalidParam::new(
                "odom_origin",
                format!(
                    "is \"start\" with sensor = {:?}: only an AGV has odometry from an unknown \
                     start (a station's pose is surveyed in the map, \"none\" has no pose)",
                    self.sensor
                ),
                "\"map\", or \"start\" with sensor \"\" or \"agvN\"",
            ));
        }
        if self.start_frame > 0 && role == Role::NoSensor {
            return Err(InvalidParam::new(
                "start_frame",
                format!(
                    "is {} with sensor = \"none\", the run's clock, which starts at frame 0",
                    self.start_frame
                ),
                "0 with sensor \"none\"; an AGV or station may start later",
            ));
        }
        if self.frames > 0 && self.start_frame >= self.frames {
            return Err(InvalidParam::new(
                "start_frame",
                format!(
                    "is {} with frames = {}: the sensor would never be switched on",
                    self.start_frame, self.frames
                ),
                "below frames (and below the path's frame count)",
            ));
        }
        if self.scatterer_spacing_m != 0.0 {
            InvalidParam::check_range("scatterer_spacing_m", self.scatterer_spacing_m, 0.01, 100.0)
                .map_err(|e| {
                    InvalidParam::new(
                        "scatterer_spacing_m",
                        e.problem,
                        "0 (the scene's) or 0.01 to 100 m",
                    )
                })?;
        }
        InvalidParam::check_range("range_std_m", self.range_std_m, 0.0, 100.0)?;
        InvalidParam::check_range("angle_std_deg", self.angle_std_deg, 0.0, 90.0)?;
        InvalidParam::check_range(
            "odom_translation_noise",
            self.odom_translation_noise,
            0.0,
            1.0,
        )?;
        InvalidParam::check_range(
            "odom_rotation_noise_deg_per_m",
            self.odom_rotation_noise_deg_per_m,
            0.0,
            90.0,
        )?;
        InvalidParam::check_range("odom_scale_bias", self.odom_scale_bias, -0.5, 0.5)?;
        InvalidParam::check_range(
            "odom_rotation_bias_deg_per_m",
            self.odom_rotation_bias_deg_per_m,
            -90.0,
            90.0,
        )?;
        InvalidParam::check_range(
            "faults.odometry_spike_m",
            self.faults.odometry_spike_m,
            -1e4,
            1e4,
        )?;
        if self.fidelity != Fidelity::Ideal && !self.faults.empty_frames.is_empty() {
            return Err(InvalidParam::new(
                "faults.empty_frames",
                format!("is set with fidelity {}", self.fidelity.name()),
                "empty at fidelity ideal only",
            ));
        }
        Ok(())
    }

    /// The role `sensor` names (`""` is agv1). Whether the scene has that AGV or station is
    /// checked when the scene is loaded.
    pub fn role(&self) -> Result<Role, InvalidParam> {
        const ALLOWED: &str = "\"\" (agv1), \"agvN\" or \"stationN\" with N ≥ 1, or \"none\"";
        let number = |digits: &str| -> Option<usize> {
            // Plain decimal digits only: "agv+1" and "agv 1" are typos, not agv1.
            if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
                return None;
            }
            digits.parse::<usize>().ok().filter(|&n| n >= 1)
        };
        let sensor = self.sensor.as_str();
        let role = if sensor.is_empty() {
            Some(Role::Agv(0))
        } else if sensor == "none" {
            Some(Role::NoSensor)
        } else if let Some(digits) = sensor.strip_prefix("agv") {
            number(digits).map(|n| Role::Agv(n - 1))
        } else if let Some(digits) = sensor.strip_prefix("station") {
            number(digits).map(|n| Role::Station(n - 1))
        } else {
            None
        };
        role.ok_or_else(|| {
            InvalidParam::new("sensor", format!("{sensor:?} names no sensor"), ALLOWED)
        })
    }

    /// The scatterer spacing overriding the scene's (m), if any.
    pub fn scatterer_spacing(&self) -> Option<f64> {
        (self.scatterer_spacing_m != 0.0).then_some(self.scatterer_spacing_m)
    }

    /// The scene file's path: `scene` if absolute, else `base_dir`/`scene`.
    pub fn scene_path(&self, base_dir: &Path) -> PathBuf {
        base_dir.join(&self.scene)
    }

    /// Δθ in radians.
    pub fn angle_std_rad(&self) -> f64 {
        self.angle_std_deg.to_radians()
    }

    /// The odometry error model in SI units.
    pub fn odometry_noise(&self) -> OdometryNoise {
        OdometryNoise {
            translation_fraction: self.odom_translation_noise,
            rotation_rad_per_m: self.odom_rotation_noise_deg_per_m.to_radians(),
            scale_bias: self.odom_scale_bias,
            rotation_bias_rad_per_m: self.odom_rotation_bias_deg_per_m.to_radians(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_paper_and_valid() {
        let p = Params::default();
        assert!(p.validate().is_ok());
        assert_eq!(p.range_std_m, 0.0);
        assert_eq!(p.angle_std_deg, 1.0);
        // An empty table gives the defaults.
        let parsed: Params = toml::from_str("").unwrap();
        assert_eq!(parsed, p);
    }

    #[test]
    fn parse_and_reject() {
        let p: Params =
            toml::from_str("range_std_m = 0.1\nangle_std_deg = 5.0\nframes = 20").unwrap();
        assert_eq!((p.range_std_m, p.angle_std_deg, p.frames), (0.1, 5.0, 20));
        assert!(toml::from_str::<Params>("range_std = 0.1").is_err());
        assert!(toml::from_str::<Params>("fidelity = \"magic\"").is_err());
        let spectral: Params = toml::from_str("fidelity = \"spectral\"").unwrap();
        spectral.validate().unwrap();
        let bad: Params = toml::from_str("fidelity = \"spectral\"\n[ofdm]\nsnr_db = nan").unwrap();
        let err = bad.validate().unwrap_err();
        assert_eq!(err.field, "ofdm");
        assert!(err.problem.contains("snr_db"), "{}", err.problem);
        let table_i: Params = toml::from_str("[ofdm]\nsymbols = 256").unwrap();
        assert_eq!(
            (table_i.ofdm.subcarriers, table_i.ofdm.symbols),
            (10240, 256)
        );
        for (text, field) in [
            ("range_std_m = -0.1", "range_std_m"),
            ("angle_std_deg = nan", "angle_std_deg"),
            ("odom_translation_noise = 2.0", "odom_translation_noise"),
            (
                "odom_rotation_noise_deg_per_m = -1.0",
                "odom_rotation_noise_deg_per_m",
            ),
            ("odom_scale_bias = 0.9", "odom_scale_bias"),
            (
                "odom_rotation_bias_deg_per_m = inf",
                "odom_rotation_bias_deg_per_m",
            ),
            ("scene = \"\"", "scene"),
            ("sensor = \"agv0\"", "sensor"),
            ("sensor = \"agv\"", "sensor"),
            ("sensor = \"agv+1\"", "sensor"),
            ("sensor = \"station-1\"", "sensor"),
            ("sensor = \"radar\"", "sensor"),
            ("sensor = \"agv99999999999999999999999\"", "sensor"),
            (
                "sensor = \"station1\"\nodom_origin = \"start\"",
                "odom_origin",
            ),
            ("sensor = \"none\"\nodom_origin = \"start\"", "odom_origin"),
            ("sensor = \"none\"\nstart_frame = 3", "start_frame"),
            ("frames = 10\nstart_frame = 10", "start_frame"),
        ] {
            let p: Params = toml::from_str(text).unwrap();
            assert_eq!(p.validate().unwrap_err().field, field, "{text}");
        }
    }

    #[test]
    fn sensor_roles() {
        for (text, role) in [
            ("", Role::Agv(0)),
            ("sensor = \"agv1\"", Role::Agv(0)),
            ("sensor = \"agv12\"", Role::Agv(11)),
            ("sensor = \"station3\"", Role::Station(2)),
            ("sensor = \"none\"", Role::NoSensor),
        ] {
            let p: Params = toml::from_str(text).unwrap();
            p.validate().unwrap();
            assert_eq!(p.role().unwrap(), role, "{text}");
        }
        let start: Params = toml::from_str("sensor = \"agv2\"\nodom_origin = \"start\"").unwrap();
        start.validate().unwrap();
        assert_eq!(start.odom_origin, OdomOrigin::Start);
        assert!(toml::from_str::<Params>("odom_origin = \"odom\"").is_err());
        let error = Params {
            sensor: "agv0".into(),
            ..Params::default()
        }
        .validate()
        .unwrap_err();
        assert!(error.allowed.contains("agvN"), "{error:?}");
    }

    #[test]
    fn scene_path_resolution() {
        let p = Params::default();
        assert_eq!(
            p.scene_path(Path::new("/work/main")),
            PathBuf::from("/work/main/config/hall.toml")
        );
        let abs = Params {
            scene: "/etc/scene.toml".into(),
            ..Params::default()
        };
        assert_eq!(
            abs.scene_path(Path::new("/x")),
            PathBuf::from("/etc/scene.toml")
        );
    }
}
