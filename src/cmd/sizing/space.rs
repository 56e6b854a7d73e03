//! The configurations of a sizing study: every combination of the search space's lists, plus the
//! paper's own (Table I at 10 dB with the DFT estimator) when it is not among them, each with its
//! cost and the launch arguments that set it.

use super::requirement::{refinement_of, Requirement};
use std::fmt::Write as _;

/// One configuration of the radio and the back end.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Subcarriers N; the bandwidth is N·Δf.
    pub subcarriers: usize,
    pub subcarrier_spacing_khz: f64,
    pub antennas: usize,
    pub snr_db: f64,
    pub symbols: usize,
    /// One of [`super::requirement::ESTIMATORS`]' names.
    pub estimator: String,
    pub loop_closure: bool,
}

/// The paper's configuration (Table I with M = 1, 10 dB, peak picking, no loop closure).
pub fn paper() -> Config {
    Config {
        subcarriers: 10240,
        subcarrier_spacing_khz: 120.0,
        antennas: 32,
        snr_db: 10.0,
        symbols: 1,
        estimator: "dft".to_owned(),
        loop_closure: false,
    }
}

impl Config {
    /// Occupied bandwidth N·Δf (MHz).
    pub fn bandwidth_mhz(&self) -> f64 {
        self.subcarriers as f64 * self.subcarrier_spacing_khz / 1e3
    }

    /// The bandwidth to 0.1 MHz, as people name it: `100` for 833 × 120 kHz, `1228.8` for Table I.
    pub fn bandwidth_label(&self) -> String {
        let tenths = (self.bandwidth_mhz() * 10.0).round() / 10.0;
        format!("{tenths}")
    }

    /// A name unique in the study, safe as a file name, e.g. `dft-b1228.8-n10240-df120-k32-snr10-m1-lc0`
    /// (bandwidth to 0.1 MHz: two bandwidths that close are the same subcarrier count or
    /// nearly).
    pub fn id(&self) -> String {
        let mut id = String::new();
        let _ = write!(
            id,
            "{}-b{}-n{}-df{}-k{}-snr{}-m{}-lc{}",
            self.estimator,
            self.bandwidth_label(),
            self.subcarriers,
            self.subcarrier_spacing_khz,
            self.antennas,
            self.snr_db,
            self.symbols,
            u8::from(self.loop_closure)
        );
        id
    }

    /// What the configuration costs under `requirement`'s prices.
    pub fn cost(&self, requirement: &Requirement) -> f64 {
        let c = &requirement.cost;
        c.per_mhz * self.bandwidth_mhz()
            + c.per_antenna * self.antennas as f64
            + c.per_snr_db * (self.snr_db - lowest(&requirement.search.snr_db)).max(0.0)
            + c.per_symbol * self.symbols as f64
            + c.per_estimator.get(&self.estimator).copied().unwrap_or(0.0)
            + if self.loop_closure {
                c.loop_closure
            } else {
                0.0
            }
    }

    /// The `name:=value` arguments that set this configuration on a paper-5g.toml-like launch.
    pub fn assignments(&self, frames: u32) -> Vec<String> {
        let refinement = refinement_of(&self.estimator).unwrap_or("none");
        // A super-resolution method reads the array rows back into the K elements' samples:
        // every angle bin must be synthesised (docs/superresolution.md).
        let angle_window_cells = if matches!(refinement, "music" | "esprit" | "nomp") {
            self.antennas.div_ceil(2)
        } else {
            8
        };
        vec![
            "fidelity:=spectral".to_owned(),
            format!("subcarriers:={}", self.subcarriers),
            format!(
                "subcarrier_spacing_hz:={:?}",
                self.subcarrier_spacing_khz * 1e3
            ),
            format!("antennas:={}", self.antennas),
            format!("snr_db:={:?}", self.snr_db),
            format!("symbols:={}", self.symbols),
            format!("refinement:={refinement}"),
            format!("angle_window_cells:={angle_window_cells}"),
            format!("loop_closure:={}", self.loop_closure),
            format!("frames:={frames}"),
            "shapes:=false".to_owned(),
            "viz:=false".to_owned(),
        ]
    }
}

/// The lowest of `values` (the cost of SNR counts from it).
fn lowest(values: &[f64]) -> f64 {
    values.iter().copied().fold(f64::INFINITY, f64::min)
}

/// Every configuration of the search space in a fixed order (estimator, loop closure, SNR,
/// symbols, spacing, bandwidth, antennas), then the paper's if it is not among them.
pub fn configurations(requirement: &Requirement) -> Vec<Config> {
    let s = &requirement.search;
    let mut all = Vec::new();
    for estimator in &s.estimators {
        for &loop_closure in &s.loop_closure {
            for &snr_db in &s.snr_db {
                for &symbols in &s.symbols {
                    for &spacing in &s.subcarrier_spacing_khz {
                        for &bandwidth in &s.bandwidth_mhz {
                            for &antennas in s.antennas_of(estimator) {
                                let config = Config {
                                    subcarriers: (bandwidth * 1e3 / spacing).round() as usize,
                                    subcarrier_spacing_khz: spacing,
                                    antennas,
                                    snr_db,
                                    symbols,
                                    estimator: estimator.clone(),
                                    loop_closure,
                                };
                                if !all.iter().any(|c: &Config| c.id() == config.id()) {
                                    all.push(config);
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    let paper = paper();
    if !all.iter().any(|c| c.id() == paper.id()) {
        all.push(paper);
    }
    all
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_paper_is_table_one() {
        let p = paper();
        assert!((p.bandwidth_mhz() - 1228.8).abs() < 1e-9);
        assert_eq!(p.id(), "dft-b1228.8-n10240-df120-k32-snr10-m1-lc0");
        assert!(p.assignments(0).contains(&"refinement:=none".to_owned()));
    }

    #[test]
    fn super_resolution_synthesises_every_angle_bin() {
        let c = Config {
            estimator: "esprit".to_owned(),
            antennas: 64,
            ..paper()
        };
        assert!(c
            .assignments(0)
            .contains(&"angle_window_cells:=32".to_owned()));
        assert!(c.assignments(0).contains(&"refinement:=esprit".to_owned()));
    }
}
