//! The radar node's parameters (`[nodes.radar.params]` of a launch file, or code).
//!
//! Defaults reproduce the paper's Fig. 3(a) conditions: ΔR = 0 m, Δθ = 1° (Sec. IV-A). The scene
//! (hall, targets, loop, sensor mounting) lives in its own file, `scene`.

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
    /// Standard deviation ΔR of the range error (m).
    pub range_std_m: f64,
    /// Standard deviation Δθ of the angle error (degrees).
    pub angle_std_deg: f64,
    /// Stop after this many frames; 0 runs the whole trajectory.
    pub frames: u32,
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
            range_std_m: 0.0,
            angle_std_deg: 1.0,
            frames: 0,
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
        ] {
            let p: Params = toml::from_str(text).unwrap();
            assert_eq!(p.validate().unwrap_err().field, field, "{text}");
        }
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
