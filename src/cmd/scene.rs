//! `nrslam scene --random`: writes a random scene file (irregular rectangles and circles inside a
//! randomised AGV loop) that any launch file runs with `scene:=FILE`, so the back end is tuned
//! and tested on many scenes rather than on the hall alone. `--agvs` and `--stations` add AGVs
//! on the same loop and fixed sensing stations on the walls, for multi-agent fusion.
//!
//! Thin: the generator is `nrslam_radar::random_scene`; this parses the flags, writes the file
//! with a header saying how to regenerate it, optionally draws it, and prints one line.

use std::path::{Path, PathBuf};

use crate::plot::{canvas, draw_axes, framed, plot_error};
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use plotters::prelude::*;

use crate::flags::{self, Real, Whole};
use nrslam_radar::random_scene::{self, RandomSceneParams};
use nrslam_radar::scene::{Scene, SceneSpec, ShapeKind};

/// `nrslam scene`.
#[derive(Args, Debug)]
pub struct SceneArgs {
    /// Draw a random scene (the only kind of scene this verb makes so far).
    #[arg(long)]
    pub random: bool,
    /// Seed of the generator: the same seed and options give the same scene on every machine
    /// (0 to 2^64 − 1).
    #[arg(long, default_value_t = 1, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: u64,
    /// Scene file to write (TOML, the format of config/hall.toml); missing folders are created.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Generator parameters from a TOML file (every field optional; the names and defaults are
    /// listed in docs/scene.md, "Random scenes"); the flags below override it.
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Whole laps the AGV drives, N or MIN:MAX, each 1 to 3 (default 1:3).
    #[arg(long, value_name = "N|MIN:MAX")]
    pub laps: Option<String>,
    /// Number of targets, N or MIN:MAX (default 6:10; the hall has 10).
    #[arg(long, value_name = "N|MIN:MAX")]
    pub targets: Option<String>,
    /// Probability that a target is a circle rather than a rectangle, 0 to 1 (default 0.25).
    #[arg(long, value_name = "P", value_parser = CIRCLE_FRACTION.parser(), allow_hyphen_values = true)]
    pub circle_fraction: Option<f64>,
    /// Hall width along x in metres, W or MIN:MAX (default 42:56; the mapper's default grid
    /// covers up to 57 m).
    #[arg(long, value_name = "M|MIN:MAX")]
    pub hall_width_m: Option<String>,
    /// Hall height along y in metres, H or MIN:MAX (default 34:46; the mapper's default grid
    /// covers up to 47 m).
    #[arg(long, value_name = "M|MIN:MAX")]
    pub hall_height_m: Option<String>,
    /// Least distance between two targets' outlines in metres (default 5.5: more than
    /// ET-GOPSA's cut-off c = 5 m, as in the hall), 0.1 to 100 m.
    #[arg(long, value_name = "M", value_parser = TARGET_GAP_M.parser(), allow_hyphen_values = true)]
    pub target_gap_m: Option<f64>,
    /// Number of AGVs, 1 to 16 AGVs (default 1): the others drive agv1's loop in the same
    /// direction, started evenly spaced along it (agv k of N at (k − 1)/N of a lap ahead); the
    /// scene then lists them as [[agv]] (docs/scene.md).
    #[arg(long, value_name = "N", value_parser = AGVS.parser::<u32>(), allow_hyphen_values = true)]
    pub agvs: Option<u32>,
    /// Number of fixed 5G sensing stations on the walls, 0 to 16 stations (default 0), spread
    /// around the hall, each aimed at the targets within its 20 m range (±60° field of view).
    #[arg(long, value_name = "M", value_parser = STATIONS.parser::<u32>(), allow_hyphen_values = true)]
    pub stations: Option<u32>,
    /// Also draw the hall, the targets (with their ids) and the loop to this PNG file.
    #[arg(long, value_name = "FILE")]
    pub png: Option<PathBuf>,
}

/// `--circle-fraction` (the generator's range).
const CIRCLE_FRACTION: Real = Real::closed(0.0, 1.0, "0 to 1");
/// `--target-gap-m` (the generator's range).
const TARGET_GAP_M: Real = Real::closed(0.1, 100.0, "0.1 to 100 m");
/// `--agvs` (the generator's range).
const AGVS: Whole = Whole::new(1, random_scene::MAX_AGENTS as u64, "1 to 16 AGVs");
/// `--stations` (the generator's range).
const STATIONS: Whole = Whole::new(0, random_scene::MAX_AGENTS as u64, "0 to 16 stations");

impl SceneArgs {
    /// Checks every numeric flag as far as it is known without the `--params` file (the
    /// generator checks the combination); the error names the flag.
    pub fn validate(&self) -> Result<()> {
        if let Some(value) = self.circle_fraction {
            flags::check("--circle-fraction", CIRCLE_FRACTION.check(value))?;
        }
        if let Some(value) = self.target_gap_m {
            flags::check("--target-gap-m", TARGET_GAP_M.check(value))?;
        }
        if let Some(value) = self.agvs {
            flags::check("--agvs", AGVS.check(value))?;
        }
        if let Some(value) = self.stations {
            flags::check("--stations", STATIONS.check(value))?;
        }
        for (flag, text) in [("--laps", &self.laps), ("--targets", &self.targets)] {
            if let Some(text) = text {
                parse_range::<u32>(flag, text)?;
            }
        }
        for (flag, text) in [
            ("--hall-width-m", &self.hall_width_m),
            ("--hall-height-m", &self.hall_height_m),
        ] {
            if let Some(text) = text {
                for value in parse_range::<f64>(flag, text)? {
                    if !value.is_finite() {
                        bail!("{flag}: {text} is out of range (allowed: finite metres)");
                    }
                }
            }
        }
        Ok(())
    }
}

/// `N` or `MIN:MAX`.
fn parse_range<T: std::str::FromStr + Copy>(flag: &str, text: &str) -> Result<[T; 2]> {
    let parse = |part: &str| {
        part.trim()
            .parse::<T>()
            .map_err(|_| anyhow!("{flag}: {text:?} is not N or MIN:MAX"))
    };
    match text.split_once(':') {
        Some((min, max)) => Ok([parse(min)?, parse(max)?]),
        None => {
            let value = parse(text)?;
            Ok([value, value])
        }
    }
}

/// The generator's parameters: the `--params` file, then the flags.
fn params_from(args: &SceneArgs) -> Result<RandomSceneParams> {
    let mut params = match &args.params {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            toml::from_str(&text).map_err(|e| anyhow!("{}: {}", path.display(), e.message()))?
        }
        None => RandomSceneParams::default(),
    };
    if let Some(text) = &args.laps {
        params.laps = parse_range("--laps", text)?;
    }
    if let Some(text) = &args.targets {
        params.targets = parse_range("--targets", text)?;
    }
    if let Some(value) = args.circle_fraction {
        params.circle_fraction = value;
    }
    if let Some(text) = &args.hall_width_m {
        params.hall_width_m = parse_range("--hall-width-m", text)?;
    }
    if let Some(text) = &args.hall_height_m {
        params.hall_height_m = parse_range("--hall-height-m", text)?;
    }
    if let Some(value) = args.target_gap_m {
        params.target_gap_m = value;
    }
    if let Some(value) = args.agvs {
        params.agvs = value;
    }
    if let Some(value) = args.stations {
        params.stations = value;
    }
    Ok(params)
}

/// The command that regenerates the file, options in a fixed order.
fn command_line(args: &SceneArgs) -> String {
    let mut parts = vec![
        "nrslam scene --random".to_owned(),
        format!("--seed {}", args.seed),
    ];
    let optional = [
        (
            "--params",
            args.params.as_ref().map(|p| p.display().to_string()),
        ),
        ("--laps", args.laps.clone()),
        ("--targets", args.targets.clone()),
        (
            "--circle-fraction",
            args.circle_fraction.map(|v| v.to_string()),
        ),
        ("--hall-width-m", args.hall_width_m.clone()),
        ("--hall-height-m", args.hall_height_m.clone()),
        ("--target-gap-m", args.target_gap_m.map(|v| v.to_string())),
        ("--agvs", args.agvs.map(|v| v.to_string())),
        ("--stations", args.stations.map(|v| v.to_string())),
    ];
    for (flag, value) in optional {
        if let Some(value) = value {
            parts.push(format!("{flag} {value}"));
        }
    }
    parts.push(format!("--out {}", args.out.display()));
    parts.join(" ")
}

/// One line on the scene: targets, hall, lap length, laps, frames; then AGVs and stations when
/// there are more than one AGV or any station.
fn describe(spec: &SceneSpec, scene: &Scene) -> String {
    let circles = spec
        .targets
        .iter()
        .filter(|t| t.shape == ShapeKind::Circle)
        .count();
    let laps = scene
        .trajectory
        .loop_spec()
        .map_or(1.0, |loop_spec| loop_spec.laps);
    let mut line = format!(
        "{} targets ({} rectangles, {circles} circles), hall {} m × {} m, lap {:.2} m × {} = {} \
         frames",
        spec.targets.len(),
        spec.targets.len() - circles,
        spec.hall.width_m,
        spec.hall.height_m,
        scene.trajectory.lap_length_m(),
        if laps == 1.0 {
            "1 lap".to_owned()
        } else {
            format!("{laps} laps")
        },
        scene.trajectory.frame_count()
    );
    if scene.agvs.len() > 1 || !scene.stations.is_empty() {
        let plural = |n: usize| if n == 1 { "" } else { "s" };
        line.push_str(&format!(
            ", {} AGV{} on the loop, {} station{} on the walls",
            scene.agvs.len(),
            plural(scene.agvs.len()),
            scene.stations.len(),
            plural(scene.stations.len())
        ));
    }
    line
}

/// `nrslam scene`.
pub fn scene(args: SceneArgs) -> Result<()> {
    args.validate()?;
    if !args.random {
        bail!("nrslam scene makes random scenes only: add --random (see nrslam scene --help)");
    }
    let params = params_from(&args)?;
    let spec = random_scene::generate(&params, args.seed)
        .with_context(|| format!("random scene for seed {}", args.seed))?;
    let scene = Scene::from_spec(&spec)
        .map_err(|e| anyhow!("the generated scene does not validate (a generator bug): {e}"))?;
    let params_toml = toml::to_string(&params).context("writing the generator parameters")?;
    let mut header = format!(
        "A random scene, written by `nrslam scene`. Regenerate it with\n  {}\n(the same seed \
         and options give the same scene on every machine). Run it with\n  nrslam launch \
         launch/paper-ideal.toml scene:={}\nGenerator parameters (docs/scene.md, \"Random \
         scenes\"):\n",
        command_line(&args),
        args.out.display()
    );
    for line in params_toml.lines() {
        header.push_str("  ");
        header.push_str(line);
        header.push('\n');
    }
    let summary = describe(&spec, &scene);
    header.push_str(&summary);
    header.push('\n');
    let text = random_scene::to_toml(&spec, &header)?;
    if let Some(folder) = args.out.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(folder)
            .with_context(|| format!("cannot create {}", folder.display()))?;
    }
    std::fs::write(&args.out, text)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    if let Some(png) = &args.png {
        draw(png, &spec, &scene, args.seed)
            .with_context(|| format!("drawing {}", png.display()))?;
    }
    outln!("wrote {}: {summary}", args.out.display());
    Ok(())
}

/// The layout: hall walls, targets filled with their ids, the loop dashed, the start marked.
fn draw(path: &Path, spec: &SceneSpec, scene: &Scene, seed: u64) -> Result<()> {
    let (width_m, height_m) = (spec.hall.width_m, spec.hall.height_m);
    // 18 pixels per metre, plus room for the axes.
    let pixels = |m: f64| (m * 18.0).round() as u32;
    let root = canvas(path, (pixels(width_m) + 90, pixels(height_m) + 90))?;
    let caption = if scene.agvs.len() > 1 || !scene.stations.is_empty() {
        format!(
            "Random scene, seed {seed}: {} targets, AGV loop (dashed), {} AGV starts (red), {} \
             stations (purple)",
            spec.targets.len(),
            scene.agvs.len(),
            scene.stations.len()
        )
    } else {
        format!(
            "Random scene, seed {seed}: {} targets, AGV loop (dashed), start (red)",
            spec.targets.len()
        )
    };
    let mut chart = framed(&root, caption, 20, 10, (35, 45))
        .build_cartesian_2d(-0.5..width_m + 0.5, -0.5..height_m + 0.5)
        .map_err(plot_error)?;
    draw_axes(&mut chart, "x (m)", "y (m)", false)?;
    let walls = [
        (0.0, 0.0),
        (width_m, 0.0),
        (width_m, height_m),
        (0.0, height_m),
        (0.0, 0.0),
    ];
    chart
        .draw_series(LineSeries::new(walls, BLACK.stroke_width(2)))
        .map_err(plot_error)?;
    let blue = RGBColor(31, 119, 180);
    for target in &scene.targets {
        let outline: Vec<(f64, f64)> = target.shape.outline().iter().map(|p| (p.x, p.y)).collect();
        chart
            .draw_series(std::iter::once(Polygon::new(
                outline.clone(),
                blue.mix(0.35).filled(),
            )))
            .map_err(plot_error)?;
        let mut closed = outline;
        if let Some(first) = closed.first().copied() {
            closed.push(first);
        }
        chart
            .draw_series(LineSeries::new(closed, blue.stroke_width(2)))
            .map_err(plot_error)?;
        let (min, max) = target.shape.bounding_box();
        chart
            .draw_series(std::iter::once(Text::new(
                target.id.to_string(),
                ((min.x + max.x) / 2.0, (min.y + max.y) / 2.0),
                ("sans-serif", 16).into_font().color(&BLACK),
            )))
            .map_err(plot_error)?;
    }
    let trajectory = &scene.trajectory;
    let step_m = 0.25;
    let samples = (trajectory.lap_length_m() / step_m).ceil() as usize;
    let path_points: Vec<(f64, f64)> = (0..=samples)
        .map(|k| {
            let pose = trajectory.pose_at_distance(k as f64 * step_m);
            (pose.x_m, pose.y_m)
        })
        .collect();
    let green = RGBColor(0, 150, 0);
    chart
        .draw_series(DashedLineSeries::new(
            path_points,
            8,
            5,
            green.stroke_width(2),
        ))
        .map_err(plot_error)?;
    for agv in &scene.agvs {
        let start = agv.trajectory.pose_at_frame(0);
        chart
            .draw_series(std::iter::once(Circle::new(
                (start.x_m, start.y_m),
                6,
                RED.filled(),
            )))
            .map_err(plot_error)?;
    }
    // Each station: a dot and its field of view's two edges, as far as its range.
    let purple = RGBColor(148, 103, 189);
    for station in &scene.stations {
        let pose = station.pose;
        let edge = |side: f64| {
            let angle = pose.yaw_rad + side * station.sensor.half_fov_rad;
            let reach = station.sensor.max_range_m;
            (
                pose.x_m + reach * angle.cos(),
                pose.y_m + reach * angle.sin(),
            )
        };
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![edge(1.0), (pose.x_m, pose.y_m), edge(-1.0)],
                purple.stroke_width(1),
            )))
            .map_err(plot_error)?;
        chart
            .draw_series(std::iter::once(Circle::new(
                (pose.x_m, pose.y_m),
                6,
                purple.filled(),
            )))
            .map_err(plot_error)?;
    }
    root.present().map_err(plot_error)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse_as_one_value_or_min_max() {
        assert_eq!(parse_range::<u32>("--laps", "2").unwrap(), [2, 2]);
        assert_eq!(parse_range::<u32>("--targets", "6:12").unwrap(), [6, 12]);
        assert_eq!(
            parse_range::<f64>("--hall-width-m", "40.5:50").unwrap(),
            [40.5, 50.0]
        );
        let error = parse_range::<u32>("--laps", "two").unwrap_err().to_string();
        assert!(error.contains("--laps") && error.contains("two"), "{error}");
        assert!(parse_range::<u32>("--laps", "1:").is_err());
    }
}
