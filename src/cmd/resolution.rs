//! `nrslam resolution`: the probability that two equal-power point scatterers are both found,
//! against their separation, for each estimator (DFT, interpolation, the super-resolution
//! methods), in angle (one range, angles θ₀ ± Δ/2) and in range (one angle, ranges r₀ ± Δ/2).
//!
//! A trial resolves the pair when two different detections lie each within Δ/2 of one scatterer
//! in the separated coordinate (and within 0.5 m in range, or 3 DFT beams in sin θ, in the other).
//! Each trial draws the common coordinate (range 5–15 m; angle within ±2° of broadside) and
//! the two scatterers' phases independently (they are coherent within the frame); trial t of
//! separation s is seeded from (seed, method, axis, s, t), so results do not depend on threads.
//! The Rayleigh separations are 2/K in sin θ (3.58° at K = 32 near broadside) and c/(2NΔf) in
//! range (0.122 m at Table I).

use crate::args::OutputDirArgs;
use crate::flags::{self, Real, Whole};
use crate::plot::{canvas, draw_axes, draw_legend, framed, line_key, plot_error};
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_estimator::{Estimator, EstimatorConfig, RangeAngleDetection, Refinement};
use nrslam_ofdm::{spectral, waveform, OfdmParams, Scatterer};
use num_complex::Complex64;
use plotters::prelude::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// `nrslam resolution`.
#[derive(Args, Debug)]
pub struct ResolutionArgs {
    /// Estimators to compare, comma-separated: none (the DFT grid), interpolation, music, esprit,
    /// nomp, zero-padding:F.
    #[arg(
        long,
        default_value = "none,interpolation,music,esprit",
        value_name = "LIST"
    )]
    pub refine: String,
    /// Which separation: angle, range, or both.
    #[arg(long, default_value = "both", value_name = "AXIS")]
    pub axis: String,
    /// Front end: spectral (closed-form processed map, every angle bin evaluated) or waveform
    /// (resource grids + FFTs).
    #[arg(long, default_value = "spectral", value_name = "F")]
    pub fidelity: String,
    /// Per-element SNR of each scatterer (dB), −50 to 100.
    #[arg(
        long,
        default_value_t = 10.0,
        value_name = "DB",
        allow_hyphen_values = true
    )]
    pub snr_db: f64,
    /// Trials per separation, 1 to 100000.
    #[arg(long, default_value_t = 200, value_parser = TRIALS.parser::<u32>(), allow_hyphen_values = true)]
    pub trials: u32,
    /// Separations tried, from 1/20 to 2 Rayleigh separations: this many points, 2 to 200.
    #[arg(long, default_value_t = 24, value_parser = POINTS.parser::<u32>(), allow_hyphen_values = true)]
    pub points: u32,
    /// Seed of the trials (0 to 2^64 − 1).
    #[arg(long, default_value_t = 1, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: u64,
    /// Subcarriers N (Table I: 10240), 16 to 65536.
    #[arg(long, default_value_t = 10240, value_parser = SUBCARRIERS.parser::<usize>(), allow_hyphen_values = true)]
    pub subcarriers: usize,
    /// Antennas K (Table I: 32), 2 to 1024.
    #[arg(long, default_value_t = 32, value_parser = ANTENNAS.parser::<usize>(), allow_hyphen_values = true)]
    pub antennas: usize,
    #[command(flatten)]
    pub out: OutputDirArgs,
}

const SNR_DB: Real = Real::closed(-50.0, 100.0, "-50 to 100 dB");
const TRIALS: Whole = Whole::new(1, 100_000, "1 to 100000 trials per separation");
const POINTS: Whole = Whole::new(2, 200, "2 to 200 separations");
const SUBCARRIERS: Whole = Whole::new(16, 65_536, "16 to 65536 subcarriers");
const ANTENNAS: Whole = Whole::new(2, 1024, "2 to 1024 antennas");

/// The separated coordinate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Axis {
    Angle,
    Range,
}

impl Axis {
    fn name(self) -> &'static str {
        match self {
            Axis::Angle => "angle",
            Axis::Range => "range",
        }
    }
}

impl ResolutionArgs {
    /// Checks every flag; the error names it.
    pub fn validate(&self) -> Result<()> {
        methods(&self.refine)?;
        axes(&self.axis)?;
        if !["spectral", "waveform"].contains(&self.fidelity.as_str()) {
            bail!(
                "--fidelity: {:?} is not a level (allowed: spectral, waveform)",
                self.fidelity
            );
        }
        flags::check("--snr-db", SNR_DB.check(self.snr_db))?;
        flags::check("--trials", TRIALS.check(self.trials))?;
        flags::check("--points", POINTS.check(self.points))?;
        flags::check("--subcarriers", SUBCARRIERS.check(self.subcarriers as u64))?;
        flags::check("--antennas", ANTENNAS.check(self.antennas as u64))?;
        Ok(())
    }
}

fn methods(text: &str) -> Result<Vec<(String, Refinement)>> {
    let list: Vec<(String, Refinement)> = text
        .split(',')
        .map(str::trim)
        .map(|name| match Refinement::from_name(name) {
            Some(Refinement::ZeroPadding { factor }) if !(1..=64).contains(&factor) => None,
            other => other.map(|r| (name.to_string(), r)),
        })
        .collect::<Option<_>>()
        .ok_or_else(|| {
            anyhow!(
                "--refine: {text:?} is not a list of estimators (allowed: {})",
                Refinement::NAMES
            )
        })?;
    if list.is_empty() {
        bail!("--refine: no estimator named");
    }
    Ok(list)
}

fn axes(text: &str) -> Result<Vec<Axis>> {
    Ok(match text {
        "angle" => vec![Axis::Angle],
        "range" => vec![Axis::Range],
        "both" => vec![Axis::Angle, Axis::Range],
        other => bail!("--axis: {other:?} is not an axis (allowed: angle, range, both)"),
    })
}

/// One point of a curve.
struct Point {
    method: String,
    axis: Axis,
    /// Separation in Rayleigh units (sin θ: 2/K; range: c/(2NΔf)).
    rayleigh: f64,
    /// The separation in its own unit (deg at broadside; m).
    separation: f64,
    resolved: u32,
    trials: u32,
}

/// `nrslam resolution`.
pub fn resolution(args: ResolutionArgs) -> Result<()> {
    args.validate()?;
    let methods = methods(&args.refine)?;
    let axes = axes(&args.axis)?;
    let params = OfdmParams {
        subcarriers: args.subcarriers,
        antennas: args.antennas,
        symbols: 1,
        snr_db: args.snr_db,
        ..OfdmParams::default()
    };
    params
        .validate()
        .map_err(|e| anyhow!("--subcarriers/--antennas: {e}"))?;
    args.out.create()?;
    let steps: Vec<f64> = (0..args.points)
        .map(|i| 0.05 + (2.0 - 0.05) * i as f64 / (args.points - 1) as f64)
        .collect();
    let count = steps.len();
    let jobs: Vec<(usize, Axis, usize)> = (0..methods.len())
        .flat_map(|m| {
            axes.iter()
                .flat_map(move |&a| (0..count).map(move |s| (m, a, s)))
        })
        .collect();
    let bar = ProgressBar::new(jobs.len() as u64 * args.trials as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} trials  ETA {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let waveform_level = args.fidelity == "waveform";
    let points: Vec<Point> = jobs
        .par_iter()
        .map(|&(m, axis, s)| {
            let (name, refinement) = &methods[m];
            let resolved = pair_trials(
                &params,
                *refinement,
                waveform_level,
                axis,
                steps[s],
                args.trials,
                nrslam_runtime::seed::derive(args.seed, &format!("{name}/{}/{s}", axis.name())),
                &|| bar.inc(1),
            )?;
            Ok(Point {
                method: name.clone(),
                axis,
                rayleigh: steps[s],
                separation: separation(&params, axis, steps[s]),
                resolved,
                trials: args.trials,
            })
        })
        .collect::<Result<_>>()?;
    bar.finish_and_clear();
    let csv_path = args.out.join("resolution.csv");
    let mut writer = csv::Writer::from_path(&csv_path)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    writer.write_record([
        "method",
        "axis",
        "separation_rayleigh",
        "separation",
        "unit",
        "p_resolved",
        "resolved",
        "trials",
    ])?;
    for p in &points {
        writer.write_record([
            p.method.clone(),
            p.axis.name().to_string(),
            format!("{:.4}", p.rayleigh),
            format!("{:.5}", p.separation),
            if p.axis == Axis::Angle { "deg" } else { "m" }.to_string(),
            format!("{:.4}", p.resolved as f64 / p.trials as f64),
            p.resolved.to_string(),
            p.trials.to_string(),
        ])?;
    }
    writer.flush()?;
    for &axis in &axes {
        let path = args.out.join(format!("resolution-{}.png", axis.name()));
        plot(&path, &points, axis, &params, &args.fidelity)?;
        for (name, _) in &methods {
            let first = points
                .iter()
                .filter(|p| p.axis == axis && &p.method == name)
                .find(|p| p.resolved as f64 >= 0.9 * p.trials as f64);
            match first {
                Some(p) => outln!(
                    "{name:>14} {}: P(resolved) ≥ 0.9 from {:.3} Rayleigh ({:.4} {})",
                    axis.name(),
                    p.rayleigh,
                    p.separation,
                    if axis == Axis::Angle { "deg" } else { "m" }
                ),
                None => outln!(
                    "{name:>14} {}: P(resolved) < 0.9 at every separation",
                    axis.name()
                ),
            }
        }
    }
    outln!("wrote {} and resolution-*.png", csv_path.display());
    Ok(())
}

/// `rayleigh` Rayleigh separations in the axis's own unit: degrees near broadside (asin of
/// rayleigh · 2/K for d = λ/2), or metres.
fn separation(params: &OfdmParams, axis: Axis, rayleigh: f64) -> f64 {
    match axis {
        Axis::Angle => (rayleigh * params.sine_bin()).asin().to_degrees(),
        Axis::Range => rayleigh * params.range_bin_m(),
    }
}

/// How many of `trials` pairs separated by `rayleigh` Rayleigh units are resolved.
#[allow(clippy::too_many_arguments)]
fn pair_trials(
    params: &OfdmParams,
    refinement: Refinement,
    waveform_level: bool,
    axis: Axis,
    rayleigh: f64,
    trials: u32,
    seed: u64,
    tick: &(dyn Fn() + Sync),
) -> Result<u32> {
    let config = EstimatorConfig {
        refinement,
        zero_padding_angle: match refinement {
            Refinement::ZeroPadding { factor } => factor,
            _ => 1,
        },
        max_range_m: Some(20.0),
        max_detections: 16,
        ..EstimatorConfig::default()
    };
    let padding = config.zero_padding_angle;
    let spectral_config = spectral::SpectralConfig {
        max_range_m: 20.0,
        range_zero_padding: padding,
        angle_zero_padding: padding,
        angle_window_cells: Some(params.antennas.div_ceil(2)),
        ..spectral::SpectralConfig::default()
    };
    let mut estimator = Estimator::new(params, config).map_err(|e| anyhow!("estimator: {e}"))?;
    let sine_step = rayleigh * params.sine_bin();
    let range_step = rayleigh * params.range_bin_m();
    let mut resolved = 0;
    for trial in 0..trials {
        let mut rng =
            ChaCha8Rng::seed_from_u64(nrslam_runtime::seed::derive(seed, &trial.to_string()));
        let range_m = rng.random_range(5.0..15.0);
        let sine = rng
            .random_range(-2f64.to_radians()..2f64.to_radians())
            .sin();
        let pair: [(f64, f64); 2] = match axis {
            Axis::Angle => [
                (range_m, (sine - sine_step / 2.0).asin()),
                (range_m, (sine + sine_step / 2.0).asin()),
            ],
            Axis::Range => [
                (range_m - range_step / 2.0, sine.asin()),
                (range_m + range_step / 2.0, sine.asin()),
            ],
        };
        let scatterers: Vec<Scatterer> = pair
            .iter()
            .map(|&(range_m, angle_rad)| Scatterer {
                range_m,
                angle_rad,
                radial_velocity_mps: 0.0,
                amplitude: Complex64::from_polar(1.0, rng.random_range(0.0..std::f64::consts::TAU)),
            })
            .collect();
        let found = if waveform_level {
            let grid = waveform::synthesize(
                params,
                &scatterers,
                &waveform::WaveformConfig::default(),
                &mut rng,
            )?;
            estimator.process_grid(&grid)
        } else {
            let map = spectral::synthesize(params, &scatterers, &spectral_config, &mut rng)?;
            estimator.process_spectrum(&map)
        }
        .map_err(|e| anyhow!("estimator: {e}"))?;
        if is_resolved(&found, &pair, axis, sine_step, range_step, params) {
            resolved += 1;
        }
        tick();
    }
    Ok(resolved)
}

/// Two different detections, each within half the separation of one scatterer in the separated
/// coordinate, and near it in the other.
fn is_resolved(
    found: &[RangeAngleDetection],
    pair: &[(f64, f64); 2],
    axis: Axis,
    sine_step: f64,
    range_step: f64,
    params: &OfdmParams,
) -> bool {
    let near = |d: &RangeAngleDetection, (range_m, angle_rad): (f64, f64)| {
        let dr = (d.range_m - range_m).abs();
        let ds = (d.angle_rad.sin() - angle_rad.sin()).abs();
        match axis {
            Axis::Angle => ds <= sine_step / 2.0 && dr <= 0.5,
            Axis::Range => dr <= range_step / 2.0 && ds <= 3.0 * params.sine_bin(),
        }
    };
    found.iter().enumerate().any(|(i, a)| {
        near(a, pair[0])
            && found
                .iter()
                .enumerate()
                .any(|(j, b)| j != i && near(b, pair[1]))
    })
}

fn plot(
    path: &std::path::Path,
    points: &[Point],
    axis: Axis,
    params: &OfdmParams,
    fidelity: &str,
) -> Result<()> {
    let root = canvas(path, (900, 560))?;
    let hi = points
        .iter()
        .filter(|p| p.axis == axis)
        .map(|p| p.separation)
        .fold(0.0, f64::max)
        * 1.02;
    let (unit, rayleigh) = match axis {
        Axis::Angle => ("deg", separation(params, axis, 1.0)),
        Axis::Range => ("m", params.range_bin_m()),
    };
    let caption = format!(
        "two equal scatterers separated in {}: K = {}, N = {}, SNR {} dB, {fidelity}",
        axis.name(),
        params.antennas,
        params.subcarriers,
        params.snr_db
    );
    let mut chart = framed(&root, caption, 20, 12, (40, 70))
        .build_cartesian_2d(0.0..hi, 0.0..1.02)
        .map_err(plot_error)?;
    draw_axes(
        &mut chart,
        format!("separation ({unit}); Rayleigh {rayleigh:.3} {unit}"),
        "P(both found, each within half the separation)",
        false,
    )?;
    let colours = [BLACK, BLUE, RED, GREEN, MAGENTA, CYAN];
    let mut names: Vec<&str> = Vec::new();
    for p in points.iter().filter(|p| p.axis == axis) {
        if !names.contains(&p.method.as_str()) {
            names.push(&p.method);
        }
    }
    for (index, name) in names.iter().enumerate() {
        let colour = colours[index % colours.len()];
        let series: Vec<(f64, f64)> = points
            .iter()
            .filter(|p| p.axis == axis && p.method == *name)
            .map(|p| (p.separation, p.resolved as f64 / p.trials as f64))
            .collect();
        chart
            .draw_series(LineSeries::new(series, colour.stroke_width(2)))
            .map_err(plot_error)?
            .label(*name)
            .legend(line_key(colour.stroke_width(2)));
    }
    for (x, style) in [(rayleigh, BLACK.mix(0.4)), (rayleigh / 2.0, RED.mix(0.4))] {
        chart
            .draw_series(LineSeries::new(
                vec![(x, 0.0), (x, 1.02)],
                style.stroke_width(1),
            ))
            .map_err(plot_error)?;
    }
    draw_legend(&mut chart, SeriesLabelPosition::LowerRight)?;
    root.present().map_err(plot_error)?;
    Ok(())
}
