//! The knobs and their settings: what the sweep changes, one knob at a time, and how a setting
//! becomes `paper-5g.toml` assignments.
//!
//! [`Setting::baseline`] is the launch at its defaults; [`settings`] lists one knob's departures
//! from it and [`plan`] the whole sweep, baseline first. The `trials` knob has no settings of its
//! own: it reuses the baseline's runs (see [`super::table::trials_knob_rows`]).

/// The knobs, in sweep order.
pub const KNOBS: [&str; 8] = [
    "fidelity",
    "stride",
    "symbols",
    "antennas",
    "refinement",
    "resolution",
    "density",
    "trials",
];

/// Trial counts reported by the `trials` knob.
pub(super) const TRIAL_COUNTS: [usize; 5] = [1, 2, 5, 10, 20];

/// One point of the sweep: every knob's value.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Setting {
    pub(super) knob: &'static str,
    pub(super) label: String,
    pub(super) fidelity: &'static str,
    pub(super) subcarriers: usize,
    pub(super) subcarrier_spacing_hz: f64,
    pub(super) symbols: usize,
    pub(super) antennas: usize,
    pub(super) refinement: &'static str,
    pub(super) resolution_m: f64,
    pub(super) scatterer_spacing_m: f64,
}

impl Setting {
    pub(super) fn baseline() -> Self {
        Self {
            knob: "baseline",
            label: "paper-5g defaults".to_owned(),
            fidelity: "spectral",
            subcarriers: 10240,
            subcarrier_spacing_hz: 120e3,
            symbols: 1,
            antennas: 32,
            refinement: "none",
            resolution_m: 0.1,
            scatterer_spacing_m: 0.25,
        }
    }

    /// The `name:=value` overrides that turn `paper-5g.toml` into this setting.
    pub(super) fn assignments(&self, frames: u32, snr_db: f64) -> Vec<String> {
        vec![
            format!("snr_db:={snr_db:?}"),
            format!("fidelity:={}", self.fidelity),
            format!("subcarriers:={}", self.subcarriers),
            format!("subcarrier_spacing_hz:={:?}", self.subcarrier_spacing_hz),
            format!("symbols:={}", self.symbols),
            format!("antennas:={}", self.antennas),
            format!("refinement:={}", self.refinement),
            format!("angle_window_cells:={}", self.angle_window_cells()),
            format!("resolution_m:={:?}", self.resolution_m),
            format!("scatterer_spacing_m:={:?}", self.scatterer_spacing_m),
            format!("frames:={frames}"),
        ]
    }

    /// Half-width in angle of the spectral synthesis: every angle bin (K/2) for a
    /// super-resolution method, which reads array rows back into the elements' samples; else
    /// paper-5g.toml's default.
    pub(super) fn angle_window_cells(&self) -> usize {
        if matches!(self.refinement, "music" | "esprit" | "nomp") {
            self.antennas.div_ceil(2)
        } else {
            8
        }
    }

    /// What the sensing chain's errors depend on.
    pub(super) fn sensing_key(&self) -> String {
        format!(
            "{}/{}/{}/{}/{}/{}",
            self.fidelity,
            self.subcarriers,
            self.subcarrier_spacing_hz,
            self.symbols,
            self.antennas,
            self.refinement
        )
    }
}

/// The whole sweep: the baseline, then every chosen knob's settings in the order given.
pub(super) fn plan(knobs: &[&'static str]) -> Vec<Setting> {
    let mut plan = vec![Setting::baseline()];
    for knob in knobs {
        plan.extend(settings(knob));
    }
    plan
}

/// The settings of one knob (the baseline itself is swept once, as its own row).
pub(super) fn settings(knob: &str) -> Vec<Setting> {
    let base = Setting::baseline();
    let with = |label: String, change: &dyn Fn(&mut Setting)| {
        let mut s = Setting {
            knob: KNOBS
                .iter()
                .find(|k| **k == knob)
                .copied()
                .unwrap_or("baseline"),
            label,
            ..base.clone()
        };
        change(&mut s);
        s
    };
    match knob {
        "fidelity" => vec![
            with("ideal".into(), &|s| s.fidelity = "ideal"),
            with("waveform".into(), &|s| s.fidelity = "waveform"),
        ],
        // The stride and symbols only cost time where the resource grid is built: swept at
        // `waveform` (the spectral map is closed-form and its cost does not depend on N or M).
        "stride" => [2usize, 4, 8, 16]
            .iter()
            .map(|&stride| {
                with(format!("waveform, stride {stride}"), &|s| {
                    s.fidelity = "waveform";
                    s.subcarriers = 10240 / stride;
                    s.subcarrier_spacing_hz = 120e3 * stride as f64;
                })
            })
            .collect(),
        "symbols" => [4usize, 16]
            .iter()
            .map(|&m| {
                with(format!("waveform, stride 16, M = {m}"), &|s| {
                    s.fidelity = "waveform";
                    s.subcarriers = 10240 / 16;
                    s.subcarrier_spacing_hz = 120e3 * 16.0;
                    s.symbols = m;
                })
            })
            .collect(),
        "antennas" => [8usize, 16, 64]
            .iter()
            .map(|&k| with(format!("K = {k}"), &|s| s.antennas = k))
            .collect(),
        "refinement" => vec![
            with("interpolation".into(), &|s| s.refinement = "interpolation"),
            with("MUSIC".into(), &|s| s.refinement = "music"),
            with("ESPRIT".into(), &|s| s.refinement = "esprit"),
            with("NOMP".into(), &|s| s.refinement = "nomp"),
        ],
        "resolution" => [0.05, 0.2, 0.4]
            .iter()
            .map(|&r| with(format!("grid {r} m"), &|s| s.resolution_m = r))
            .collect(),
        "density" => [0.5, 1.0, 2.0]
            .iter()
            .map(|&d| {
                with(format!("scatterers every {d} m"), &|s| {
                    s.scatterer_spacing_m = d
                })
            })
            .collect(),
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_knob_has_settings_that_differ_from_the_baseline() {
        for knob in KNOBS.iter().filter(|k| **k != "trials") {
            let settings = settings(knob);
            assert!(!settings.is_empty(), "{knob}");
            for s in settings {
                assert_eq!(s.knob, *knob);
                assert_ne!(
                    Setting {
                        knob: "baseline",
                        label: String::new(),
                        ..s.clone()
                    },
                    Setting {
                        label: String::new(),
                        ..Setting::baseline()
                    },
                    "{knob}: {}",
                    s.label
                );
            }
        }
    }

    #[test]
    fn a_stride_keeps_the_bandwidth() {
        for s in settings("stride") {
            let bandwidth_hz = s.subcarriers as f64 * s.subcarrier_spacing_hz;
            assert!((bandwidth_hz - 10240.0 * 120e3).abs() < 1.0, "{}", s.label);
        }
    }
}
