//! The estimator's typed configuration (`serde(deny_unknown_fields)`; defaults = the paper where it
//! says something, otherwise a documented choice of ours).

use nrslam_runtime::InvalidParam;
use serde::{Deserialize, Serialize};

/// How peaks of the range × angle power map become detections.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Detector {
    /// Local maxima (8-neighbourhood, angle circular) more than `threshold_db` above the frame's
    /// noise floor. The paper's "index of the peak", generalised to several targets.
    #[default]
    PeakPicking,
    /// 2-D cell-averaging CFAR tested at local maxima: power > α · mean(training cells),
    /// α = N_train (Pfa^(−1/N_train) − 1), exact for exponential (M = 1, noise-only) cells.
    Cfar,
}

/// Sub-bin refinement of a detected peak.
///
/// TOML: `refinement = { kind = "none" }`, `{ kind = "zero_padding", factor = 4 }`,
/// `{ kind = "interpolation" }`, `{ kind = "music" }`, `{ kind = "esprit", subarray = 20 }`,
/// `{ kind = "nomp" }`.
///
/// `music` and `esprit` are super-resolution methods (`crate::superres`): each range bin that
/// holds a detection is resolved into as many plane waves as MDL finds and the detector's
/// threshold accepts, gridless in angle, interpolated in range. They replace that bin's DFT
/// peaks; a bin where no wave passes keeps its DFT peaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Refinement {
    /// The bin centre (the paper): grid-limited, RMS error Δr/√12 for uniformly placed targets.
    #[default]
    None,
    /// Range IDFT of length `factor` · N (zeros appended to each subcarrier row); bins shrink by
    /// `factor`. Costs `factor` × the range transforms and map.
    ZeroPadding {
        /// Zero-padding factor of the range IDFT, 1 to 64.
        factor: usize,
    },
    /// Three-point interpolation in range and in angle around the peak bin: Jacobsen's complex
    /// estimator with Candan's tan(π/N)/(π/N) bias correction in an unpadded dimension, parabolic
    /// interpolation of the log power in a zero-padded one (angle with `zero_padding_angle` > 1),
    /// and the exact two-point (Rife) magnitude ratio at a non-circular map edge.
    Interpolation,
    /// MUSIC on the forward–backward spatially smoothed covariance of each detected range bin.
    Music {
        /// Subarray length L of spatial smoothing, 2 to K; 0 (default) = ⌈2K/3⌉.
        #[serde(default)]
        subarray: usize,
    },
    /// TLS-ESPRIT on the same covariance.
    Esprit {
        /// Subarray length L of spatial smoothing, 2 to K; 0 (default) = ⌈2K/3⌉.
        #[serde(default)]
        subarray: usize,
    },
    /// Newtonized OMP (`crate::nomp`): gridless atoms jointly in range and angle on the range
    /// bins around the DFT peaks, added while the strongest residual cell passes the
    /// detector's threshold.
    Nomp,
}

impl Refinement {
    /// The refinement named `name` (`none`, `interpolation`, `music`, `esprit`, `nomp`, or
    /// `zero-padding:F`), with its parameters at their defaults.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "none" => Some(Self::None),
            "interpolation" => Some(Self::Interpolation),
            "music" => Some(Self::Music { subarray: 0 }),
            "esprit" => Some(Self::Esprit { subarray: 0 }),
            "nomp" => Some(Self::Nomp),
            _ => {
                let factor = name.strip_prefix("zero-padding:")?.parse().ok()?;
                Some(Self::ZeroPadding { factor })
            }
        }
    }

    /// The names [`Refinement::from_name`] takes, for help texts.
    pub const NAMES: &'static str =
        "none, interpolation, zero-padding:F (1 ≤ F ≤ 64), music, esprit, nomp";

    /// Whether this is a super-resolution method (`music`, `esprit`, `nomp`).
    pub fn is_super_resolution(&self) -> bool {
        matches!(self, Self::Music { .. } | Self::Esprit { .. } | Self::Nomp)
    }
}

/// Parameters of the estimator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EstimatorConfig {
    /// Peak picking (default, the paper) or CA-CFAR.
    pub detector: Detector,
    /// At most this many detections per frame, strongest first; 1 to 65 536.
    pub max_detections: usize,
    /// Peak picking: a peak must exceed the frame's noise floor by this much (dB), 0 to 300.
    /// 13 dB is a per-cell false-alarm probability of e^(−20) ≈ 2·10⁻⁹ on exponential noise.
    pub threshold_db: f64,
    /// Both detectors: peaks weaker than the frame's strongest peak by more than this (dB) are
    /// dropped, 0 to 400. Not in the paper: it removes FFT round-off peaks of noise-free inputs
    /// and the side-lobe peaks the rectangular window leaves around strong echoes (at −13 dB
    /// with zero padding). Default 40 dB.
    pub dynamic_range_db: f64,
    /// Both detectors: side-lobe blanking. A peak is dropped when its power is within this margin
    /// (dB) of the rectangular-window side-lobe bound of a stronger kept detection, g(Δr)·g(Δa):
    /// 1 inside the main lobe, else the Dirichlet side-lobe peak level (−13.3 dB for the first)
    /// at the nearest distance the echo can be, over the worst-case scalloping of the stronger
    /// peak's bin; 0 to 60; absent = no blanking. Not in the paper:
    /// without it every strong echo brings noise-rippled side-lobe peaks 20–30 dB down along
    /// its range row and angle column. Default 6 dB.
    pub sidelobe_margin_db: Option<f64>,
    /// CFAR guard cells on each side in range, 0 to 64.
    pub cfar_guard_range: usize,
    /// CFAR guard cells on each side in angle, 0 to 64.
    pub cfar_guard_angle: usize,
    /// CFAR training cells on each side (beyond the guard cells) in range, 0 to 256.
    pub cfar_train_range: usize,
    /// CFAR training cells on each side (beyond the guard cells) in angle, 0 to 256.
    pub cfar_train_angle: usize,
    /// CFAR false-alarm probability per tested cell, 1e-300 to 0.5.
    pub cfar_pfa: f64,
    /// Sub-bin refinement (default none, the paper).
    pub refinement: Refinement,
    /// Only range bins up to this range (m) are searched, and only they and one more get the
    /// angle transform; absent = the whole unambiguous range c/(2Δf) (the paper). 0 < r ≤ 10⁷.
    pub max_range_m: Option<f64>,
    /// Zero-padding factor of the array DFT (angle bins = K · factor), 1 to 1024; 1 = the paper.
    pub zero_padding_angle: usize,
    /// With `refinement` = interpolation, the range and angle std a detection is published with
    /// (`/radar/detections`), as a fraction of its resolution cell's (Δr/√12, Δ(sin θ)/√12),
    /// 0.01 to 1. With `music`, `esprit` or `nomp`, the model floor added (in quadrature) to
    /// each wave's Cramér–Rao bound, in the same unit. A lone echo's interpolated peak lies within
    /// a thousandth of a bin of it (`nrslam accuracy --refine interpolation`), but on extended
    /// targets several scatterers share a cell and pull the peak. Default 0.3, measured through
    /// SLAM on the study's 5G runs with interpolation (docs/slam.md): the cell's own std weighed
    /// refined detections as if they sat on the grid. Without refinement, or with zero padding,
    /// the cell's std stands.
    pub interpolated_std_fraction: f64,
}

impl Default for EstimatorConfig {
    fn default() -> Self {
        Self {
            detector: Detector::PeakPicking,
            max_detections: 128,
            threshold_db: 13.0,
            dynamic_range_db: 40.0,
            sidelobe_margin_db: Some(6.0),
            cfar_guard_range: 2,
            cfar_guard_angle: 1,
            cfar_train_range: 8,
            cfar_train_angle: 2,
            cfar_pfa: 1e-6,
            refinement: Refinement::None,
            max_range_m: None,
            zero_padding_angle: 1,
            interpolated_std_fraction: 0.3,
        }
    }
}

impl EstimatorConfig {
    /// Checks every field; the error names the field and its allowed range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        InvalidParam::check_count("max_detections", self.max_detections, 1, 65_536)?;
        InvalidParam::check_range("threshold_db", self.threshold_db, 0.0, 300.0)?;
        InvalidParam::check_range("dynamic_range_db", self.dynamic_range_db, 0.0, 400.0)?;
        if let Some(m) = self.sidelobe_margin_db {
            InvalidParam::check_range("sidelobe_margin_db", m, 0.0, 60.0)?;
        }
        InvalidParam::check_count("cfar_guard_range", self.cfar_guard_range, 0, 64)?;
        InvalidParam::check_count("cfar_guard_angle", self.cfar_guard_angle, 0, 64)?;
        InvalidParam::check_count("cfar_train_range", self.cfar_train_range, 0, 256)?;
        InvalidParam::check_count("cfar_train_angle", self.cfar_train_angle, 0, 256)?;
        if self.detector == Detector::Cfar && self.cfar_train_range + self.cfar_train_angle == 0 {
            return Err(InvalidParam::new(
                "cfar_train_range",
                "no training cells (cfar_train_range = cfar_train_angle = 0)",
                "cfar_train_range + cfar_train_angle >= 1",
            ));
        }
        InvalidParam::check_range("cfar_pfa", self.cfar_pfa, 1e-300, 0.5)?;
        match self.refinement {
            Refinement::ZeroPadding { factor } => {
                InvalidParam::check_count("refinement.factor", factor, 1, 64)?;
            }
            Refinement::Music { subarray } | Refinement::Esprit { subarray } if subarray != 0 => {
                // The upper bound, K, is checked against the radar by `Estimator::new`.
                InvalidParam::check_count("refinement.subarray", subarray, 2, 1 << 16)?;
            }
            _ => {}
        }
        if let Some(r) = self.max_range_m {
            if !(r.is_finite() && r > 0.0 && r <= 1e7) {
                return Err(InvalidParam::new(
                    "max_range_m",
                    format!("{r} is out of range"),
                    "greater than 0 and at most 1e7 m, or absent",
                ));
            }
        }
        InvalidParam::check_count("zero_padding_angle", self.zero_padding_angle, 1, 1024)?;
        InvalidParam::check_range(
            "interpolated_std_fraction",
            self.interpolated_std_fraction,
            0.01,
            1.0,
        )?;
        Ok(())
    }

    /// The fraction of its resolution cell's std a detection is published with
    /// (`interpolated_std_fraction` after interpolation, else 1).
    pub fn published_std_fraction(&self) -> f64 {
        match self.refinement {
            Refinement::Interpolation => self.interpolated_std_fraction,
            // A super-resolved detection carries its own std; what reaches this is a DFT peak
            // kept at its bin centre where no wave passed, with its cell's spread.
            Refinement::None
            | Refinement::ZeroPadding { .. }
            | Refinement::Music { .. }
            | Refinement::Esprit { .. }
            | Refinement::Nomp => 1.0,
        }
    }

    /// Zero-padding factor of the range IDFT this configuration implies.
    pub fn range_padding(&self) -> usize {
        match self.refinement {
            Refinement::ZeroPadding { factor } => factor,
            _ => 1,
        }
    }
}
