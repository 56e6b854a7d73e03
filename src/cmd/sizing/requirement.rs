//! The requirement file of `nrslam sizing`: the scene, what must be met, the search space, the
//! cost of each resource and the trial budget (docs/sizing.md, "The requirement file").
//!
//! Every table refuses unknown fields; [`Requirement::validate`] names the bad field and its
//! allowed range. Relative paths resolve against the requirement file's folder.

use super::trial::Metric;
use anyhow::{bail, Context, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A whole requirement file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Requirement {
    pub scene: SceneSpec,
    /// Every requirement a configuration must meet (all of them).
    #[serde(rename = "requirement")]
    pub requirements: Vec<MetricRequirement>,
    pub search: SearchSpace,
    #[serde(default)]
    pub cost: Cost,
    #[serde(default)]
    pub trials: TrialBudget,
}

/// Where the trials run: a launch file and either one scene file or a family of random scenes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Launch file the configurations are applied to (relative to the requirement file; it must
    /// take paper-5g.toml's arguments).
    pub launch: PathBuf,
    /// One scene file (relative to the requirement file); absent with `random`: the launch's own.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub file: Option<PathBuf>,
    /// A family of random scenes instead: trial i runs scene i mod count.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub random: Option<RandomScenes>,
    /// Radar frames per trial (0: the whole run; the hall's lap is 294 frames).
    #[serde(default)]
    pub frames: u32,
}

/// `scene.random`: `count` scenes of `nrslam scene --random --seed seed+j`, j = 0..count.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomScenes {
    pub count: u32,
    #[serde(default = "one")]
    pub seed: u64,
}

fn one() -> u64 {
    1
}

/// One requirement: the mean over trials of a per-trial metric at or below `threshold`, decided
/// at one-sided `confidence`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MetricRequirement {
    pub metric: Metric,
    /// In the metric's unit (metres for `position_error_*`, ET-GOPSA's unit for `*_etgospa`).
    pub threshold: f64,
    /// One-sided confidence of the decision, 0.5 to 0.9999 (default 0.95).
    #[serde(default = "default_confidence")]
    pub confidence: f64,
}

fn default_confidence() -> f64 {
    0.95
}

/// The configurations: every combination of the lists.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SearchSpace {
    /// Occupied bandwidths N·Δf (MHz), 1 to 3200 MHz; N = round(B/Δf).
    pub bandwidth_mhz: Vec<f64>,
    /// Subcarrier spacings Δf (kHz), the numerologies: 15·2^µ, 15 to 960 kHz (FR2: 60, 120).
    #[serde(default = "default_spacing")]
    pub subcarrier_spacing_khz: Vec<f64>,
    /// Receive antennas K of the λ/2 array, 2 to 256.
    pub antennas: Vec<usize>,
    /// Other antenna counts for some estimators, by name: e.g. `esprit = [8, 16, 32, 64]`, whose
    /// eigendecompositions cost O(K³) per detected range bin (11 s of CPU per hall lap at
    /// K = 128, 2 s at 64).
    #[serde(default, skip_serializing_if = "std::collections::BTreeMap::is_empty")]
    pub antennas_by_estimator: std::collections::BTreeMap<String, Vec<usize>>,
    /// Per-element SNR of every echo (dB), −40 to 60 dB.
    #[serde(default = "default_snr")]
    pub snr_db: Vec<f64>,
    /// OFDM symbols M per frame, 1 to 256.
    #[serde(default = "default_symbols")]
    pub symbols: Vec<usize>,
    /// Estimators: dft (the paper's peak picking), interpolation, music, esprit, nomp.
    #[serde(default = "default_estimators")]
    pub estimators: Vec<String>,
    /// Loop closure off and/or on.
    #[serde(default = "default_loop_closure")]
    pub loop_closure: Vec<bool>,
}

fn default_spacing() -> Vec<f64> {
    vec![120.0]
}
fn default_snr() -> Vec<f64> {
    vec![10.0]
}
fn default_symbols() -> Vec<usize> {
    vec![1]
}
fn default_estimators() -> Vec<String> {
    vec!["dft".to_owned()]
}
fn default_loop_closure() -> Vec<bool> {
    vec![false]
}

/// What each resource costs, in any one currency (only the ranking matters).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cost {
    /// Per MHz of bandwidth.
    #[serde(default = "unit")]
    pub per_mhz: f64,
    /// Per receive antenna.
    #[serde(default)]
    pub per_antenna: f64,
    /// Per dB of SNR above the lowest SNR searched (transmit power).
    #[serde(default)]
    pub per_snr_db: f64,
    /// Per OFDM symbol per frame (sensing airtime).
    #[serde(default)]
    pub per_symbol: f64,
    /// Per estimator, by name (compute); absent names cost 0.
    #[serde(default)]
    pub per_estimator: std::collections::BTreeMap<String, f64>,
    /// Of loop closure (compute).
    #[serde(default)]
    pub loop_closure: f64,
}

fn unit() -> f64 {
    1.0
}

impl Default for Cost {
    fn default() -> Self {
        Self {
            per_mhz: 1.0,
            per_antenna: 0.0,
            per_snr_db: 0.0,
            per_symbol: 0.0,
            per_estimator: Default::default(),
            loop_closure: 0.0,
        }
    }
}

/// The sequential Monte Carlo budget.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrialBudget {
    /// Base seed: trial i of every configuration runs with the seed derived from (seed, i).
    #[serde(default = "one")]
    pub seed: u64,
    /// Trials before the first decision, 2 to 10000.
    #[serde(default = "default_first")]
    pub first: u32,
    /// Trials added per undecided configuration at each look, 1 to 10000.
    #[serde(default = "default_batch")]
    pub batch: u32,
    /// Most trials per configuration, `first` to 100000; then undecided, with its CI.
    #[serde(default = "default_max")]
    pub max: u32,
}

fn default_first() -> u32 {
    10
}
fn default_batch() -> u32 {
    10
}
fn default_max() -> u32 {
    200
}

impl Default for TrialBudget {
    fn default() -> Self {
        Self {
            seed: 1,
            first: default_first(),
            batch: default_batch(),
            max: default_max(),
        }
    }
}

/// The estimator names and the `refinement:=` each sets.
pub const ESTIMATORS: [(&str, &str); 5] = [
    ("dft", "none"),
    ("interpolation", "interpolation"),
    ("music", "music"),
    ("esprit", "esprit"),
    ("nomp", "nomp"),
];

impl Requirement {
    /// Reads and checks a requirement file; relative paths become relative to its folder.
    pub fn load(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let mut requirement: Requirement = toml::from_str(&text)
            .with_context(|| format!("{}: not a requirement file", path.display()))?;
        let folder = path.parent().unwrap_or(Path::new(""));
        requirement.scene.launch = folder.join(&requirement.scene.launch);
        if let Some(file) = &mut requirement.scene.file {
            *file = folder.join(&*file);
        }
        requirement
            .validate()
            .with_context(|| format!("{}", path.display()))?;
        Ok(requirement)
    }

    /// Checks every field against its allowed range; the error names the field.
    pub fn validate(&self) -> Result<()> {
        let scene = &self.scene;
        if scene.file.is_some() && scene.random.is_some() {
            bail!("scene: give either file or random, not both");
        }
        if let Some(random) = &scene.random {
            check_range(
                "scene.random.count",
                random.count as f64,
                1.0,
                1000.0,
                "1 to 1000 scenes",
            )?;
        }
        if self.requirements.is_empty() {
            bail!("requirement: at least one [[requirement]] table is needed");
        }
        for (i, r) in self.requirements.iter().enumerate() {
            let field = |name: &str| format!("requirement[{i}].{name}");
            if !r.threshold.is_finite() || r.threshold < 0.0 {
                bail!(
                    "{}: {} is out of range (allowed: a finite value ≥ 0)",
                    field("threshold"),
                    r.threshold
                );
            }
            check_range(
                &field("confidence"),
                r.confidence,
                0.5,
                0.9999,
                "0.5 to 0.9999",
            )?;
        }
        let s = &self.search;
        non_empty("search.bandwidth_mhz", s.bandwidth_mhz.len())?;
        for &b in &s.bandwidth_mhz {
            check_range("search.bandwidth_mhz", b, 1.0, 3200.0, "1 to 3200 MHz")?;
        }
        non_empty(
            "search.subcarrier_spacing_khz",
            s.subcarrier_spacing_khz.len(),
        )?;
        for &df in &s.subcarrier_spacing_khz {
            let mu = (df / 15.0).log2();
            if !(0.0..=6.0).contains(&mu) || (mu - mu.round()).abs() > 1e-9 {
                bail!(
                    "search.subcarrier_spacing_khz: {df} is out of range (allowed: 15·2^µ kHz, \
                     µ = 0 to 6: 15, 30, 60, 120, 240, 480, 960)"
                );
            }
        }
        for &b in &s.bandwidth_mhz {
            for &df in &s.subcarrier_spacing_khz {
                let n = (b * 1e3 / df).round();
                if !(16.0..=65536.0).contains(&n) {
                    bail!(
                        "search: {b} MHz at {df} kHz is {n} subcarriers (allowed: 16 to 65536 \
                         subcarriers)"
                    );
                }
            }
        }
        non_empty("search.antennas", s.antennas.len())?;
        for &k in &s.antennas {
            check_range("search.antennas", k as f64, 2.0, 256.0, "2 to 256 antennas")?;
        }
        for (name, list) in &s.antennas_by_estimator {
            let field = format!("search.antennas_by_estimator.{name}");
            if !s.estimators.contains(name) {
                bail!("{field}: {name:?} is not among search.estimators");
            }
            non_empty(&field, list.len())?;
            for &k in list {
                check_range(&field, k as f64, 2.0, 256.0, "2 to 256 antennas")?;
            }
        }
        non_empty("search.snr_db", s.snr_db.len())?;
        for &snr in &s.snr_db {
            check_range("search.snr_db", snr, -40.0, 60.0, "-40 to 60 dB")?;
        }
        non_empty("search.symbols", s.symbols.len())?;
        for &m in &s.symbols {
            check_range("search.symbols", m as f64, 1.0, 256.0, "1 to 256 symbols")?;
        }
        non_empty("search.estimators", s.estimators.len())?;
        for name in &s.estimators {
            if refinement_of(name).is_none() {
                bail!(
                    "search.estimators: {name:?} is not an estimator (allowed: {})",
                    ESTIMATORS.map(|e| e.0).join(", ")
                );
            }
        }
        non_empty("search.loop_closure", s.loop_closure.len())?;
        let c = &self.cost;
        for (name, value) in [
            ("cost.per_mhz", c.per_mhz),
            ("cost.per_antenna", c.per_antenna),
            ("cost.per_snr_db", c.per_snr_db),
            ("cost.per_symbol", c.per_symbol),
            ("cost.loop_closure", c.loop_closure),
        ] {
            check_range(name, value, 0.0, 1e12, "0 to 1e12")?;
        }
        for (name, value) in &c.per_estimator {
            if refinement_of(name).is_none() {
                bail!(
                    "cost.per_estimator: {name:?} is not an estimator (allowed: {})",
                    ESTIMATORS.map(|e| e.0).join(", ")
                );
            }
            check_range(
                &format!("cost.per_estimator.{name}"),
                *value,
                0.0,
                1e12,
                "0 to 1e12",
            )?;
        }
        let t = &self.trials;
        check_range(
            "trials.first",
            t.first as f64,
            2.0,
            10000.0,
            "2 to 10000 trials",
        )?;
        check_range(
            "trials.batch",
            t.batch as f64,
            1.0,
            10000.0,
            "1 to 10000 trials",
        )?;
        check_range(
            "trials.max",
            t.max as f64,
            t.first as f64,
            100000.0,
            &format!("trials.first ({}) to 100000 trials", t.first),
        )?;
        Ok(())
    }
}

impl SearchSpace {
    /// The antenna counts searched with `estimator`.
    pub fn antennas_of(&self, estimator: &str) -> &[usize] {
        self.antennas_by_estimator
            .get(estimator)
            .unwrap_or(&self.antennas)
    }
}

/// The `refinement:=` value of an estimator name.
pub fn refinement_of(estimator: &str) -> Option<&'static str> {
    ESTIMATORS
        .iter()
        .find(|(name, _)| *name == estimator)
        .map(|(_, refinement)| *refinement)
}

fn non_empty(field: &str, len: usize) -> Result<()> {
    if len == 0 {
        bail!("{field}: the list is empty (give at least one value)");
    }
    Ok(())
}

fn check_range(field: &str, value: f64, low: f64, high: f64, allowed: &str) -> Result<()> {
    if !(value.is_finite() && low <= value && value <= high) {
        bail!("{field}: {value} is out of range (allowed: {allowed})");
    }
    Ok(())
}
