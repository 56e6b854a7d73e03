//! Random scenes: irregular layouts of rectangles (any yaw) and circles inside a randomised AGV
//! loop, so that the SLAM back end is tuned and tested on many scenes, never on the hall alone.
//!
//! [`generate`] turns [`RandomSceneParams`] and a seed into a [`SceneSpec`], the type
//! `config/hall.toml` deserialises to, which [`Scene::from_spec`] accepts; [`to_toml`] writes it
//! as a scene file that [`Scene::load`] reads back to the same scene. The same seed and
//! parameters give the same scene on every machine: every draw comes from one ChaCha8 stream
//! seeded with the seed, in a fixed order.
//!
//! What is randomised, per seed:
//!
//! - the hall's width and height, and the loop's distance from each of the four walls (drawn
//!   separately, so the loop is not centred), its corner radius and its start point;
//! - the number of laps (a whole number, so that every run ends where it started and a study's
//!   runs cover their loops evenly);
//! - the number of targets and each one's shape (circle with probability `circle_fraction`) and
//!   size, drawn once per seed; then each one's yaw (any, for rectangles) and position, by
//!   rejection sampling anywhere inside the loop (no grid of stations), largest target first.
//!   Retries move and turn a target but never swap it for a smaller one, so the scenes follow
//!   the count, shape and size distributions asked for rather than whatever fits most easily.
//!
//! The rules every generated scene follows are those of the hall (`docs/scene.md`):
//!
//! - every two targets' outlines are at least `target_gap_m` apart (default 5.5 m), so every
//!   sample point and every point of an outline is farther than ET-GOPSA's cut-off c = 5 m from
//!   the other targets: an estimate on its target then pays no confusion term, and an accurate
//!   map scores clearly better than an empty one;
//! - the loop keeps `agv_radius_m + loop_margin_m` from every target and `agv_radius_m` from the
//!   walls; targets stand inside the loop, where the radar looks (boresight to the AGV's left on
//!   a counter-clockwise loop);
//! - every target comes within `max_path_distance_m` of the loop, and from some frame of the
//!   first lap the radar sees at least [`MIN_SCATTERERS_SEEN`] of its scatterers (range, field of
//!   view, facing and occlusion, [`crate::visibility`]).
//!
//! Several AGVs and fixed stations (`agvs`, `stations`; default one AGV, no station, which
//! draws and writes exactly what the generator wrote before they existed): the extra AGVs drive
//! agv1's loop, in the same direction, started evenly spaced along it (agv k of N at k/N of a
//! lap ahead of agv1), so every path overlaps every other everywhere and the AGVs see the same
//! targets from different places at the same time. Stations stand on the walls: of the wall
//! points every metre, each aimed at the centre of the targets within its range, the one whose
//! view holds the most scatterers is taken first, then the best of those at least a
//! 1/(2·stations) share of the perimeter (along the walls) from every station taken, and so on.
//! Neither draws from the random stream: they are a function of the scene.
//!
//! When a layout (hall and loop) cannot hold the drawn number of targets within
//! `placement_attempts` draws per target, a new layout is drawn, at most `layout_attempts`
//! times; then [`generate`] fails with [`RandomSceneError::Crowded`]. It never returns fewer
//! targets than it drew: a study asking for 6 to 12 targets gets 6 to 12. Every loop is
//! bounded, nothing panics on bad parameters ([`RandomSceneParams::validate`] names the field).
//!
//! Positions and sizes are rounded to 1 cm and yaws to 0.1° before any check, so the file holds
//! short decimals and the geometry checked is the geometry written.

use std::f64::consts::PI;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use nrslam_runtime::InvalidParam;

use crate::error::FieldError;
use crate::geometry::{point_in_convex_polygon, Pose2, Vec2};
use crate::scene::{
    AgvSpec, HallSpec, Scene, SceneSpec, SensorSpec, Shape, ShapeKind, StationSpec, TargetSpec,
};
use crate::trajectory::{Trajectory, TrajectorySpec};
use crate::visibility;

/// Fewest scatterers of a target that one frame must see for the target to count as seen: the
/// segmenter of the launch files keeps a DBSCAN cluster from `min_samples` = 4 points, so a
/// target never seen by 4 scatterers at once could never be mapped as a cluster.
pub const MIN_SCATTERERS_SEEN: usize = 4;

/// Arc step (rad) of the chords the loop's clearance is measured on: the same as scene
/// validation uses, so a scene accepted here is accepted on load.
const CHORD_STEP_RAD: f64 = PI / 180.0;

/// How the random scenes are drawn. Ranges are `[min, max]`, inclusive; every field has a
/// default, unknown fields are refused.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RandomSceneParams {
    /// Hall width along x (m). The mapper's default grid covers [−3, 57] m in x: wider halls
    /// need its `width_m` raised.
    pub hall_width_m: [f64; 2],
    /// Hall height along y (m). The mapper's default grid covers [−3, 47] m in y.
    pub hall_height_m: [f64; 2],
    /// Distance from each wall to the loop's straight along it (m), drawn for each wall
    /// separately; at least `agv_radius_m`.
    pub wall_margin_m: [f64; 2],
    /// Radius of the loop's four quarter-circle turns (m); capped at half the loop's smaller
    /// side.
    pub corner_radius_m: [f64; 2],
    /// Number of laps driven (whole laps, 1 to 3).
    pub laps: [u32; 2],
    /// Number of targets. The hall has 10; with the default sizes, gap and hall, 11 or 12 fit in
    /// only a few layouts in a hundred, and some sets of 12 targets in none.
    pub targets: [u32; 2],
    /// Probability that a target is a circle (the rest are rectangles); the hall has 0.2.
    pub circle_fraction: f64,
    /// A rectangle's longer side (m).
    pub rect_long_side_m: [f64; 2],
    /// A rectangle's shorter side (m), drawn at most as long as its longer side.
    pub rect_short_side_m: [f64; 2],
    /// A circle's radius (m).
    pub circle_radius_m: [f64; 2],
    /// Least distance between two targets' outlines (m): more than ET-GOPSA's cut-off c = 5 m
    /// keeps estimates on one target out of the others' confusion terms (docs/scene.md).
    pub target_gap_m: f64,
    /// Radius of the AGV's footprint (m), written to the trajectory: the loop keeps it from the
    /// walls.
    pub agv_radius_m: f64,
    /// Clearance beyond `agv_radius_m` that the loop keeps from every target (m).
    pub loop_margin_m: f64,
    /// Farthest a target's outline may lie from the loop (m), so that the radar (20 m range)
    /// sees a good part of it from the nearest stretch.
    pub max_path_distance_m: f64,
    /// Scatterer spacing written to the scene (m).
    pub scatterer_spacing_m: f64,
    /// Draws per target before a layout counts as full.
    pub placement_attempts: u32,
    /// Layouts (hall and loop) tried before giving up.
    pub layout_attempts: u32,
    /// Number of AGVs, 1 to 16: the extra ones drive agv1's loop from evenly spaced starts.
    /// Written to the parameters only when not 1.
    #[serde(skip_serializing_if = "is_one")]
    pub agvs: u32,
    /// Number of fixed sensing stations on the walls, 0 to 16. Written to the parameters only
    /// when not 0.
    #[serde(skip_serializing_if = "is_zero")]
    pub stations: u32,
}

fn is_one(value: &u32) -> bool {
    *value == 1
}

fn is_zero(value: &u32) -> bool {
    *value == 0
}

/// Most AGVs and most stations a random scene holds.
pub const MAX_AGENTS: u32 = 16;

/// Spacing of the wall points tried as station positions (m).
const STATION_CANDIDATE_STEP_M: f64 = 1.0;

impl Default for RandomSceneParams {
    fn default() -> Self {
        Self {
            hall_width_m: [42.0, 56.0],
            hall_height_m: [34.0, 46.0],
            wall_margin_m: [3.0, 6.0],
            corner_radius_m: [2.0, 4.0],
            laps: [1, 3],
            targets: [6, 10],
            circle_fraction: 0.25,
            rect_long_side_m: [2.0, 8.0],
            rect_short_side_m: [1.0, 4.0],
            circle_radius_m: [0.75, 2.0],
            target_gap_m: 5.5,
            agv_radius_m: 0.5,
            loop_margin_m: 2.5,
            max_path_distance_m: 16.0,
            scatterer_spacing_m: crate::scene::DEFAULT_SCATTERER_SPACING_M,
            placement_attempts: 1000,
            layout_attempts: 300,
            agvs: 1,
            stations: 0,
        }
    }
}

/// Why no scene was generated.
#[derive(Debug, thiserror::Error)]
pub enum RandomSceneError {
    /// A parameter is out of range. (Not a `source`: the message already holds it, and error
    /// chains printed on one line would repeat it.)
    #[error("random scene parameter {0}")]
    Param(InvalidParam),
    /// Rejection sampling could not fit the drawn number of targets.
    #[error(
        "could not place {requested} targets: {layouts} layouts (hall and loop) tried with \
         {attempts} draws per target, at most {best_placed} fitted; ask for fewer or smaller \
         targets, a larger hall or a smaller target_gap_m"
    )]
    Crowded {
        /// Targets drawn for this seed.
        requested: u32,
        /// Most targets any layout held.
        best_placed: u32,
        /// Layouts tried (`layout_attempts`).
        layouts: u32,
        /// Draws per target (`placement_attempts`).
        attempts: u32,
    },
    /// Too few wall points see enough of the targets for the stations asked for.
    #[error(
        "could place only {placed} of {requested} stations on the walls seeing at least \
         {MIN_SCATTERERS_SEEN} scatterers each; ask for fewer stations"
    )]
    Stations {
        /// Stations asked for.
        requested: u32,
        /// Stations that found a place.
        placed: u32,
    },
    /// The generated scene failed the scene's own validation: a bug of the generator, reported
    /// rather than written.
    #[error("the generated scene is invalid (a generator bug): {0}")]
    Invalid(FieldError),
    /// The scene could not be written as TOML.
    #[error("cannot write the scene as TOML: {0}")]
    Toml(String),
}

/// `[min, max]` with `lower ≤ min ≤ max ≤ upper`, all finite.
fn check_interval(
    field: &str,
    range: [f64; 2],
    lower: f64,
    upper: f64,
) -> Result<(), InvalidParam> {
    let allowed = format!("[min, max] with {lower} ≤ min ≤ max ≤ {upper}");
    for (k, value) in range.iter().enumerate() {
        if !(value.is_finite() && *value >= lower && *value <= upper) {
            return Err(InvalidParam::new(
                format!("{field}[{k}]"),
                format!("{value} is out of range"),
                allowed,
            ));
        }
    }
    if range[0] > range[1] {
        return Err(InvalidParam::new(
            field,
            format!("minimum {} is above maximum {}", range[0], range[1]),
            allowed,
        ));
    }
    Ok(())
}

/// As [`check_interval`] for whole numbers.
fn check_count_interval(
    field: &str,
    range: [u32; 2],
    lower: u32,
    upper: u32,
) -> Result<(), InvalidParam> {
    check_interval(
        field,
        [f64::from(range[0]), f64::from(range[1])],
        f64::from(lower),
        f64::from(upper),
    )
}

impl RandomSceneParams {
    /// Checks every parameter; the error names the field, the problem and the allowed range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        check_interval("hall_width_m", self.hall_width_m, 5.0, 1000.0)?;
        check_interval("hall_height_m", self.hall_height_m, 5.0, 1000.0)?;
        InvalidParam::check_range("agv_radius_m", self.agv_radius_m, 0.0, 10.0)?;
        check_interval("wall_margin_m", self.wall_margin_m, 0.0, 500.0)?;
        if self.wall_margin_m[0] < self.agv_radius_m {
            return Err(InvalidParam::new(
                "wall_margin_m[0]",
                format!(
                    "{} is below agv_radius_m = {}: the AGV would touch the wall",
                    self.wall_margin_m[0], self.agv_radius_m
                ),
                "at least agv_radius_m",
            ));
        }
        for (field, hall) in [
            ("hall_width_m[0]", self.hall_width_m[0]),
            ("hall_height_m[0]", self.hall_height_m[0]),
        ] {
            if hall - 2.0 * self.wall_margin_m[1] <= 0.0 {
                return Err(InvalidParam::new(
                    field,
                    format!(
                        "{hall} m leaves no loop inside two wall margins of up to {} m",
                        self.wall_margin_m[1]
                    ),
                    "more than 2 · wall_margin_m[1]",
                ));
            }
        }
        check_interval("corner_radius_m", self.corner_radius_m, 0.0, 500.0)?;
        check_count_interval("laps", self.laps, 1, 3)?;
        check_count_interval("targets", self.targets, 1, 100)?;
        InvalidParam::check_count("agvs", self.agvs, 1, MAX_AGENTS)?;
        InvalidParam::check_count("stations", self.stations, 0, MAX_AGENTS)?;
        InvalidParam::check_range("circle_fraction", self.circle_fraction, 0.0, 1.0)?;
        check_interval("rect_long_side_m", self.rect_long_side_m, 0.1, 100.0)?;
        check_interval("rect_short_side_m", self.rect_short_side_m, 0.1, 100.0)?;
        if self.rect_short_side_m[0] > self.rect_long_side_m[0] {
            return Err(InvalidParam::new(
                "rect_short_side_m[0]",
                format!(
                    "{} is longer than the shortest long side, rect_long_side_m[0] = {}",
                    self.rect_short_side_m[0], self.rect_long_side_m[0]
                ),
                "at most rect_long_side_m[0]",
            ));
        }
        check_interval("circle_radius_m", self.circle_radius_m, 0.05, 50.0)?;
        InvalidParam::check_range("target_gap_m", self.target_gap_m, 0.1, 100.0)?;
        // A strictly positive clearance: the scene refuses a loop touching a target.
        InvalidParam::check_range("loop_margin_m", self.loop_margin_m, 0.01, 100.0)?;
        let max_range_m = SensorSpec::default().max_range_m;
        let clearance_m = self.agv_radius_m + self.loop_margin_m;
        if !(self.max_path_distance_m.is_finite()
            && self.max_path_distance_m >= clearance_m
            && self.max_path_distance_m <= max_range_m)
        {
            return Err(InvalidParam::new(
                "max_path_distance_m",
                format!("{} is out of range", self.max_path_distance_m),
                format!(
                    "agv_radius_m + loop_margin_m = {clearance_m} to the radar's range \
                     {max_range_m} m"
                ),
            ));
        }
        InvalidParam::check_range("scatterer_spacing_m", self.scatterer_spacing_m, 0.01, 10.0)?;
        InvalidParam::check_count("placement_attempts", self.placement_attempts, 1, 100_000)?;
        InvalidParam::check_count("layout_attempts", self.layout_attempts, 1, 10_000)?;
        Ok(())
    }

    /// Least distance the loop keeps from every target (m): `agv_radius_m + loop_margin_m`.
    pub fn loop_clearance_m(&self) -> f64 {
        self.agv_radius_m + self.loop_margin_m
    }
}

/// `value` rounded to a multiple of `1 / per_unit` (100: centimetres); dividing the rounded
/// integer gives the double nearest the short decimal, so the file shows `12.34`.
fn round_to(value: f64, per_unit: f64) -> f64 {
    (value * per_unit).round() / per_unit
}

/// A uniform draw from `[min, max]`, rounded to `1 / per_unit` and kept inside the range.
fn draw(rng: &mut ChaCha8Rng, range: [f64; 2], per_unit: f64) -> f64 {
    let value = if range[1] > range[0] {
        rng.random_range(range[0]..=range[1])
    } else {
        range[0]
    };
    round_to(value, per_unit).clamp(range[0], range[1])
}

/// A uniform whole number from `[min, max]`.
fn draw_count(rng: &mut ChaCha8Rng, range: [u32; 2]) -> u32 {
    if range[1] > range[0] {
        rng.random_range(range[0]..=range[1])
    } else {
        range[0]
    }
}

/// A hall and a loop inside it.
struct Layout {
    hall: HallSpec,
    trajectory: TrajectorySpec,
    /// The loop as chords (turns cut every 1°), for clearance: the same chords as validation.
    chords: Vec<(Vec2, Vec2)>,
    /// The chords' start points: the loop as a convex polygon, counter-clockwise.
    polygon: Vec<Vec2>,
}

fn draw_layout(
    rng: &mut ChaCha8Rng,
    params: &RandomSceneParams,
    laps: u32,
) -> Result<Layout, RandomSceneError> {
    const CM: f64 = 100.0;
    let width_m = draw(rng, params.hall_width_m, CM);
    let height_m = draw(rng, params.hall_height_m, CM);
    let [left_m, right_m, bottom_m, top_m] =
        std::array::from_fn(|_| draw(rng, params.wall_margin_m, CM));
    let (x_min_m, x_max_m) = (left_m, width_m - right_m);
    let (y_min_m, y_max_m) = (bottom_m, height_m - top_m);
    // Floored to the centimetre so the cap at half the smaller side survives the rounding.
    let cap_m = ((x_max_m - x_min_m).min(y_max_m - y_min_m) / 2.0 * CM).floor() / CM;
    let corner_radius_m = draw(rng, params.corner_radius_m, CM).min(cap_m);
    let mut trajectory = TrajectorySpec {
        x_min_m,
        y_min_m,
        x_max_m,
        y_max_m,
        corner_radius_m,
        start_offset_m: 0.0,
        speed_mps: 1.0,
        frame_period_s: 0.5,
        laps: f64::from(laps),
        agv_radius_m: params.agv_radius_m,
        clockwise: false,
    };
    let lap_length_m = Trajectory::new(&trajectory)
        .map_err(RandomSceneError::Invalid)?
        .lap_length_m();
    // Anywhere on the loop, rounded down so it stays below one lap.
    trajectory.start_offset_m = (rng.random_range(0.0..lap_length_m) * CM).floor() / CM;
    let built = Trajectory::new(&trajectory).map_err(RandomSceneError::Invalid)?;
    let chords = built.chords(CHORD_STEP_RAD);
    let polygon = chords.iter().map(|(a, _)| *a).collect();
    Ok(Layout {
        hall: HallSpec { width_m, height_m },
        trajectory,
        chords,
        polygon,
    })
}

/// A target's kind and size, drawn once per seed: retries then move it and turn it but never
/// swap it for a smaller one, so the scenes follow `circle_fraction` and the size ranges instead
/// of drifting toward whatever fits most easily.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Body {
    Circle { radius_m: f64 },
    Rectangle { long_m: f64, short_m: f64 },
}

impl Body {
    /// Radius of the smallest disc about the centre holding the target (m): placement order.
    fn circumradius_m(&self) -> f64 {
        match *self {
            Body::Circle { radius_m } => radius_m,
            Body::Rectangle { long_m, short_m } => long_m.hypot(short_m) / 2.0,
        }
    }
}

fn draw_body(rng: &mut ChaCha8Rng, params: &RandomSceneParams) -> Body {
    const CM: f64 = 100.0;
    if rng.random_bool(params.circle_fraction) {
        Body::Circle {
            radius_m: draw(rng, params.circle_radius_m, CM),
        }
    } else {
        let long_m = draw(rng, params.rect_long_side_m, CM);
        let short_range = [
            params.rect_short_side_m[0],
            params.rect_short_side_m[1].min(long_m),
        ];
        Body::Rectangle {
            long_m,
            short_m: draw(rng, short_range, CM),
        }
    }
}

/// A candidate placement of `body`: any yaw, centre uniform in the loop's bounding box shrunk
/// by the clearance. `None` when that box is empty (the loop is too small for any target).
fn draw_placement(
    rng: &mut ChaCha8Rng,
    params: &RandomSceneParams,
    layout: &Layout,
    body: Body,
    index: usize,
) -> Option<(TargetSpec, Shape)> {
    const CM: f64 = 100.0;
    let clearance_m = params.loop_clearance_m();
    let t = &layout.trajectory;
    let x_range = [t.x_min_m + clearance_m, t.x_max_m - clearance_m];
    let y_range = [t.y_min_m + clearance_m, t.y_max_m - clearance_m];
    if x_range[0] > x_range[1] || y_range[0] > y_range[1] {
        return None;
    }
    match body {
        Body::Circle { radius_m } => {
            let center = Vec2::new(draw(rng, x_range, CM), draw(rng, y_range, CM));
            Some((
                TargetSpec {
                    name: format!("circle_{index}"),
                    shape: ShapeKind::Circle,
                    center_m: [center.x, center.y],
                    size_m: None,
                    yaw_deg: None,
                    radius_m: Some(radius_m),
                },
                Shape::circle(center, radius_m),
            ))
        }
        Body::Rectangle { long_m, short_m } => {
            // Any yaw; a rectangle turned by 180° is the same rectangle.
            let yaw_deg = round_to(rng.random_range(0.0..180.0), 10.0);
            let center = Vec2::new(draw(rng, x_range, CM), draw(rng, y_range, CM));
            Some((
                TargetSpec {
                    name: format!("rectangle_{index}"),
                    shape: ShapeKind::Rectangle,
                    center_m: [center.x, center.y],
                    size_m: Some([long_m, short_m]),
                    yaw_deg: Some(yaw_deg),
                    radius_m: None,
                },
                Shape::rectangle(center, long_m, short_m, yaw_deg.to_radians()),
            ))
        }
    }
}

/// Least distance from `shape` to the loop (m), on the chords scene validation uses.
fn path_distance_m(shape: &Shape, chords: &[(Vec2, Vec2)]) -> f64 {
    chords
        .iter()
        .map(|(a, b)| shape.distance_to_segment(*a, *b))
        .fold(f64::INFINITY, f64::min)
}

/// Whether a candidate keeps the rules against the loop and the targets already placed.
fn fits(
    params: &RandomSceneParams,
    layout: &Layout,
    placed: &[Shape],
    center: Vec2,
    shape: &Shape,
) -> bool {
    // Cheapest first: the other targets (few), then inside the loop, then the loop's chords.
    if placed
        .iter()
        .any(|other| shape.distance_to_shape(other) < params.target_gap_m)
    {
        return false;
    }
    if !point_in_convex_polygon(&layout.polygon, center) {
        return false;
    }
    let distance_m = path_distance_m(shape, &layout.chords);
    distance_m >= params.loop_clearance_m() && distance_m <= params.max_path_distance_m
}

/// For each target, the most of its scatterers that one frame of the first lap sees (range,
/// field of view, facing, occlusion), counted up to `enough` (the search for a target stops
/// there).
pub fn scatterers_seen(scene: &Scene, enough: usize) -> Vec<usize> {
    let trajectory = &scene.trajectory;
    let step_m = trajectory.speed_mps() * trajectory.frame_period_s();
    let frames_per_lap = (trajectory.lap_length_m() / step_m).ceil() as usize;
    let frames = trajectory.frame_count().min(frames_per_lap);
    let mut best = vec![0usize; scene.targets.len()];
    for k in 0..frames {
        let pose = trajectory.pose_at_frame(k);
        for (index, target) in scene.targets.iter().enumerate() {
            if best[index] >= enough {
                continue;
            }
            let mut seen = 0;
            for scatterer in &target.scatterers {
                if visibility::sight(&scene.targets, &scene.sensor, pose, index, scatterer)
                    .is_some()
                {
                    seen += 1;
                    if seen >= enough {
                        break;
                    }
                }
            }
            best[index] = best[index].max(seen);
        }
        if best.iter().all(|&n| n >= enough) {
            break;
        }
    }
    best
}

/// Places `bodies` in `layout` by rejection sampling, largest first (big targets need the room
/// small ones would fragment); returns them in the bodies' order (the target ids), or `Err`
/// with how many fitted.
fn place_targets(
    rng: &mut ChaCha8Rng,
    params: &RandomSceneParams,
    layout: &Layout,
    bodies: &[Body],
) -> Result<Vec<TargetSpec>, usize> {
    let mut order: Vec<usize> = (0..bodies.len()).collect();
    // Stable and total: equal sizes keep their id order, so the sequence is reproducible.
    order.sort_by(|&a, &b| {
        bodies[b]
            .circumradius_m()
            .total_cmp(&bodies[a].circumradius_m())
    });
    let mut placed: Vec<Option<TargetSpec>> = vec![None; bodies.len()];
    let mut shapes = Vec::with_capacity(bodies.len());
    for (fitted, &index) in order.iter().enumerate() {
        let mut found = None;
        for _ in 0..params.placement_attempts {
            let Some((spec, shape)) = draw_placement(rng, params, layout, bodies[index], index)
            else {
                break;
            };
            let center = Vec2::new(spec.center_m[0], spec.center_m[1]);
            if fits(params, layout, &shapes, center, &shape) {
                found = Some((spec, shape));
                break;
            }
        }
        let Some((spec, shape)) = found else {
            return Err(fitted);
        };
        placed[index] = Some(spec);
        shapes.push(shape);
    }
    Ok(placed.into_iter().flatten().collect())
}

/// A random scene for `seed`: see the module documentation for what is drawn and the rules it
/// keeps. Fails on bad parameters (naming the field) and when no layout holds the drawn number
/// of targets ([`RandomSceneError::Crowded`]); never panics, every search is bounded.
pub fn generate(params: &RandomSceneParams, seed: u64) -> Result<SceneSpec, RandomSceneError> {
    generate_counting_layouts(params, seed).map(|(spec, _)| spec)
}

/// As [`generate`], with the number of layouts drawn until one held the targets.
fn generate_counting_layouts(
    params: &RandomSceneParams,
    seed: u64,
) -> Result<(SceneSpec, u32), RandomSceneError> {
    params.validate().map_err(RandomSceneError::Param)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    // Drawn once, before any layout: retrying a crowded layout must not bias the count, shapes
    // or sizes toward what fits most easily.
    let laps = draw_count(&mut rng, params.laps);
    let count = draw_count(&mut rng, params.targets);
    let bodies: Vec<Body> = (0..count).map(|_| draw_body(&mut rng, params)).collect();
    let mut best_placed = 0;
    for layout_index in 0..params.layout_attempts {
        let layout = draw_layout(&mut rng, params, laps)?;
        let targets = match place_targets(&mut rng, params, &layout, &bodies) {
            Ok(targets) => targets,
            Err(fitted) => {
                best_placed = best_placed.max(fitted as u32);
                continue;
            }
        };
        best_placed = count;
        let spec = SceneSpec {
            scatterer_spacing_m: params.scatterer_spacing_m,
            hall: layout.hall,
            sensor: SensorSpec::default(),
            trajectory: Some(layout.trajectory),
            agv: Vec::new(),
            station: Vec::new(),
            targets,
        };
        let scene = Scene::from_spec(&spec).map_err(RandomSceneError::Invalid)?;
        // Rare (a target hidden behind others from every frame, or too thin to show 4
        // scatterers): draw another layout rather than ship a target nobody can map.
        if scatterers_seen(&scene, MIN_SCATTERERS_SEEN)
            .iter()
            .all(|&n| n >= MIN_SCATTERERS_SEEN)
        {
            let spec = add_agents(params, spec, &scene)?;
            return Ok((spec, layout_index + 1));
        }
    }
    Err(RandomSceneError::Crowded {
        requested: count,
        best_placed,
        layouts: params.layout_attempts,
        attempts: params.placement_attempts,
    })
}

/// The scene with `params.agvs` AGVs and `params.stations` stations (unchanged for one AGV and
/// no station). `scene` is `spec` built.
fn add_agents(
    params: &RandomSceneParams,
    mut spec: SceneSpec,
    scene: &Scene,
) -> Result<SceneSpec, RandomSceneError> {
    if params.agvs > 1 {
        if let Some(first) = spec.trajectory.take() {
            let lap_m = scene.trajectory.lap_length_m();
            spec.agv = (0..params.agvs)
                .map(|k| {
                    let ahead_m = lap_m * f64::from(k) / f64::from(params.agvs);
                    // Floored to the centimetre and kept below a lap, as agv1's offset is.
                    let offset_m = ((first.start_offset_m + ahead_m).rem_euclid(lap_m) * 100.0)
                        .floor()
                        / 100.0;
                    AgvSpec {
                        name: format!("agv{}", k + 1),
                        trajectory: Some(TrajectorySpec {
                            start_offset_m: offset_m,
                            ..first.clone()
                        }),
                        ..AgvSpec::default()
                    }
                })
                .collect();
        }
    }
    if params.stations > 0 {
        spec.station = place_stations(params.stations, &spec, scene)?;
    }
    if params.agvs > 1 || params.stations > 0 {
        Scene::from_spec(&spec).map_err(RandomSceneError::Invalid)?;
    }
    Ok(spec)
}

/// A wall point a station could stand on, aimed at the targets in its range.
struct StationCandidate {
    /// Distance along the walls from the origin, counter-clockwise (m).
    along_m: f64,
    spec: StationSpec,
    /// Scatterers it sees.
    seen: usize,
}

/// `count` stations on the walls, greedily: the wall point (every metre, corners left out)
/// seeing the most scatterers first, then the best one at least a 1/(2·count) share of the
/// perimeter away from every station placed (so they spread around the hall), and so on.
/// Each aims at the centre of the targets that come within its range, which lie inward.
fn place_stations(
    count: u32,
    spec: &SceneSpec,
    scene: &Scene,
) -> Result<Vec<StationSpec>, RandomSceneError> {
    let (w, h) = (spec.hall.width_m, spec.hall.height_m);
    let sensor = &spec.sensor;
    let perimeter_m = 2.0 * (w + h);
    // (start, direction along the wall, length) of the four walls, counter-clockwise.
    let walls = [
        (Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), w),
        (Vec2::new(w, 0.0), Vec2::new(0.0, 1.0), h),
        (Vec2::new(w, h), Vec2::new(-1.0, 0.0), w),
        (Vec2::new(0.0, h), Vec2::new(0.0, -1.0), h),
    ];
    let mut candidates = Vec::new();
    let mut wall_start_m = 0.0;
    for (start, direction, length_m) in walls {
        let pieces = (length_m / STATION_CANDIDATE_STEP_M).ceil() as usize;
        for j in 1..pieces {
            let along_wall_m = length_m * j as f64 / pieces as f64;
            let p = start + direction * along_wall_m;
            let position = Vec2::new(round_to(p.x, 100.0), round_to(p.y, 100.0));
            let near: Vec<Vec2> = scene
                .targets
                .iter()
                .filter(|t| t.shape.distance_to_segment(position, position) <= sensor.max_range_m)
                .map(|t| {
                    let (min, max) = t.shape.bounding_box();
                    (min + max) / 2.0
                })
                .collect();
            if near.is_empty() {
                continue;
            }
            let aim = near.iter().fold(Vec2::zeros(), |sum, c| sum + *c) / near.len() as f64;
            let d = aim - position;
            let boresight_deg = round_to(d.y.atan2(d.x).to_degrees(), 10.0);
            let station_sensor = crate::visibility::Sensor {
                boresight_rad: 0.0,
                max_range_m: sensor.max_range_m,
                half_fov_rad: sensor.half_fov_deg.to_radians(),
            };
            let pose = Pose2::new(position.x, position.y, boresight_deg.to_radians());
            let seen = visibility::observe(&scene.targets, &station_sensor, pose).len();
            candidates.push(StationCandidate {
                along_m: wall_start_m + along_wall_m,
                spec: StationSpec {
                    name: String::new(),
                    position_m: [position.x, position.y],
                    boresight_deg,
                    half_fov_deg: Some(sensor.half_fov_deg),
                    max_range_m: Some(sensor.max_range_m),
                },
                seen,
            });
        }
        wall_start_m += length_m;
    }
    let separation_m = perimeter_m / (2.0 * f64::from(count));
    let along_walls = |a: f64, b: f64| {
        let d = (a - b).rem_euclid(perimeter_m);
        d.min(perimeter_m - d)
    };
    let mut chosen: Vec<&StationCandidate> = Vec::new();
    while chosen.len() < count as usize {
        // The first best in wall order on ties: deterministic.
        let best = candidates
            .iter()
            .filter(|c| c.seen >= MIN_SCATTERERS_SEEN)
            .filter(|c| {
                chosen
                    .iter()
                    .all(|s| along_walls(s.along_m, c.along_m) >= separation_m)
            })
            .fold(None::<&StationCandidate>, |best, c| match best {
                Some(b) if b.seen >= c.seen => Some(b),
                _ => Some(c),
            });
        let Some(best) = best else {
            return Err(RandomSceneError::Stations {
                requested: count,
                placed: chosen.len() as u32,
            });
        };
        chosen.push(best);
    }
    // In wall order, so station1 is the first one counter-clockwise from the origin.
    chosen.sort_by(|a, b| a.along_m.total_cmp(&b.along_m));
    Ok(chosen
        .into_iter()
        .enumerate()
        .map(|(j, c)| StationSpec {
            name: format!("station{}", j + 1),
            ..c.spec.clone()
        })
        .collect())
}

/// The scene as a scene file: `header` as `#` comment lines (say how to regenerate it), a blank
/// line, then the TOML that [`Scene::load`] reads back to the same [`SceneSpec`].
pub fn to_toml(spec: &SceneSpec, header: &str) -> Result<String, RandomSceneError> {
    let body = toml::to_string(spec).map_err(|e| RandomSceneError::Toml(e.to_string()))?;
    let mut out = String::new();
    for line in header.lines() {
        if line.is_empty() {
            out.push_str("#\n");
        } else {
            out.push_str("# ");
            out.push_str(line);
            out.push('\n');
        }
    }
    if !out.is_empty() {
        out.push('\n');
    }
    out.push_str(&body);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::cross;

    const SEEDS: u64 = 200;

    fn params() -> RandomSceneParams {
        RandomSceneParams::default()
    }

    #[test]
    fn same_seed_same_scene_and_seeds_differ() {
        let p = params();
        let a = generate(&p, 7).unwrap();
        assert_eq!(a, generate(&p, 7).unwrap());
        let specs: Vec<SceneSpec> = (0..20).map(|seed| generate(&p, seed).unwrap()).collect();
        for i in 0..specs.len() {
            for j in 0..i {
                assert_ne!(specs[i], specs[j], "seeds {i} and {j} gave the same scene");
                assert_ne!(
                    specs[i].targets[0].center_m, specs[j].targets[0].center_m,
                    "seeds {i} and {j}: same first target"
                );
            }
        }
    }

    /// The rules, measured from the generated geometry without the generator's helpers: the
    /// path is walked every 5 cm, outlines are compared point to shape.
    fn check_rules(p: &RandomSceneParams, seed: u64, spec: &SceneSpec) -> Scene {
        let scene = Scene::from_spec(spec)
            .unwrap_or_else(|e| panic!("seed {seed}: the scene does not validate: {e}"));
        let n = scene.targets.len();
        assert!(
            (p.targets[0] as usize..=p.targets[1] as usize).contains(&n),
            "seed {seed}: {n} targets"
        );
        let laps = spec.trajectory.as_ref().unwrap().laps;
        assert!(
            laps.fract() == 0.0 && (1.0..=3.0).contains(&laps),
            "seed {seed}: {laps} laps"
        );
        let (w, h) = (spec.hall.width_m, spec.hall.height_m);
        assert!(
            (p.hall_width_m[0]..=p.hall_width_m[1]).contains(&w),
            "seed {seed}"
        );
        assert!(
            (p.hall_height_m[0]..=p.hall_height_m[1]).contains(&h),
            "seed {seed}"
        );

        let trajectory = &scene.trajectory;
        let step_m = 0.05;
        let walk: Vec<_> = (0..(trajectory.lap_length_m() / step_m) as usize)
            .map(|k| trajectory.pose_at_distance(k as f64 * step_m))
            .collect();
        for pose in &walk {
            let q = pose.position();
            let r = p.agv_radius_m - 1e-9;
            assert!(q.x - r >= 0.0 && q.y - r >= 0.0 && q.x + r <= w && q.y + r <= h);
        }
        for (i, target) in scene.targets.iter().enumerate() {
            let t = &spec.targets[i];
            match t.shape {
                ShapeKind::Rectangle => {
                    let [long, short] = t.size_m.unwrap();
                    assert!(short <= long);
                    assert!((p.rect_long_side_m[0]..=p.rect_long_side_m[1]).contains(&long));
                    assert!((p.rect_short_side_m[0]..=p.rect_short_side_m[1]).contains(&short));
                }
                ShapeKind::Circle => {
                    let r = t.radius_m.unwrap();
                    assert!((p.circle_radius_m[0]..=p.circle_radius_m[1]).contains(&r));
                }
            }
            // Clearance from the walked loop, and inside it: the target's centre is to the
            // left of the nearest pose's heading (the loop is counter-clockwise and convex).
            let center = Vec2::new(t.center_m[0], t.center_m[1]);
            let (nearest, distance_m) = walk
                .iter()
                .map(|pose| {
                    (
                        pose,
                        target
                            .shape
                            .distance_to_segment(pose.position(), pose.position()),
                    )
                })
                .fold((&walk[0], f64::INFINITY), |best, x| {
                    if x.1 < best.1 {
                        x
                    } else {
                        best
                    }
                });
            assert!(
                distance_m >= p.loop_clearance_m() - 1e-6,
                "seed {seed}: target {i} is {distance_m} m from the loop"
            );
            assert!(
                distance_m <= p.max_path_distance_m + step_m,
                "seed {seed}: target {i} is {distance_m} m from the loop, out of reach"
            );
            let heading = Vec2::new(nearest.yaw_rad.cos(), nearest.yaw_rad.sin());
            assert!(
                cross(heading, center - nearest.position()) > 0.0,
                "seed {seed}: target {i} is outside the loop"
            );
            // Gaps: outline to outline, and sample points farther than ET-GOPSA's c = 5 m from
            // every point of the other outlines.
            for j in 0..i {
                let other = &scene.targets[j];
                let gap_m = target.shape.distance_to_shape(&other.shape);
                assert!(
                    gap_m >= p.target_gap_m - 1e-9,
                    "seed {seed}: targets {i}, {j}: {gap_m} m"
                );
                for s in target.shape.samples() {
                    for o in other.shape.samples() {
                        assert!((s - o).norm() > 5.0, "seed {seed}: samples of {i}, {j}");
                    }
                    assert!(other.shape.distance_to_segment(s, s) > 5.0, "seed {seed}");
                }
            }
        }
        scene
    }

    #[test]
    fn two_hundred_seeds_keep_the_rules() {
        let p = params();
        let mut laps_seen = [0usize; 4];
        let (mut circles, mut rectangles, mut turned) = (0usize, 0usize, 0usize);
        for seed in 0..SEEDS {
            let spec = generate(&p, seed).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
            check_rules(&p, seed, &spec);
            laps_seen[spec.trajectory.as_ref().unwrap().laps as usize] += 1;
            for t in &spec.targets {
                match t.shape {
                    ShapeKind::Circle => circles += 1,
                    ShapeKind::Rectangle => {
                        rectangles += 1;
                        if t.yaw_deg.unwrap() % 90.0 != 0.0 {
                            turned += 1;
                        }
                    }
                }
            }
        }
        // Every lap count drawn; circles near their fraction; rectangles at any yaw.
        assert!(laps_seen[1..].iter().all(|&n| n > 40), "{laps_seen:?}");
        let fraction = circles as f64 / (circles + rectangles) as f64;
        assert!(
            (0.18..0.32).contains(&fraction),
            "circle fraction {fraction}"
        );
        assert!(
            turned as f64 > 0.9 * rectangles as f64,
            "{turned} of {rectangles} turned"
        );
    }

    #[test]
    fn every_target_is_seen_from_the_loop() {
        // The full visibility rules (range, field of view, facing, occlusion) over the first
        // lap, on fewer seeds: this one runs the radar's geometry for every frame.
        let p = params();
        for seed in 0..20 {
            let scene = Scene::from_spec(&generate(&p, seed).unwrap()).unwrap();
            let frames = (scene.trajectory.lap_length_m() / 0.5).ceil() as usize;
            let mut seen = vec![0usize; scene.targets.len()];
            for k in 0..frames {
                let pose = scene.trajectory.pose_at_frame(k);
                let mut in_frame = vec![0usize; scene.targets.len()];
                for s in visibility::observe(&scene.targets, &scene.sensor, pose) {
                    in_frame[s.target_index] += 1;
                }
                for (best, now) in seen.iter_mut().zip(in_frame) {
                    *best = (*best).max(now);
                }
            }
            assert!(
                seen.iter().all(|&n| n >= MIN_SCATTERERS_SEEN),
                "seed {seed}: most scatterers seen per target in one frame {seen:?}"
            );
        }
    }

    #[test]
    fn laps_and_counts_follow_the_params() {
        for laps in 1..=3 {
            let p = RandomSceneParams {
                laps: [laps, laps],
                targets: [8, 8],
                ..params()
            };
            for seed in 0..5 {
                let spec = generate(&p, seed).unwrap();
                assert_eq!(spec.trajectory.as_ref().unwrap().laps, f64::from(laps));
                assert_eq!(spec.targets.len(), 8);
                let scene = Scene::from_spec(&spec).unwrap();
                let frames_per_lap = scene.trajectory.lap_length_m() / 0.5;
                let frames = scene.trajectory.frame_count() as f64;
                assert!((frames - f64::from(laps) * frames_per_lap).abs() <= 1.0);
            }
        }
        let only_circles = RandomSceneParams {
            circle_fraction: 1.0,
            ..params()
        };
        let spec = generate(&only_circles, 3).unwrap();
        assert!(spec.targets.iter().all(|t| t.shape == ShapeKind::Circle));
    }

    #[test]
    fn written_file_loads_to_the_same_scene() {
        let p = params();
        for seed in [0, 1, 42] {
            let spec = generate(&p, seed).unwrap();
            let text = to_toml(&spec, "a random scene\n\nseed 42").unwrap();
            assert!(
                text.starts_with("# a random scene\n#\n# seed 42\n\n"),
                "{text}"
            );
            let parsed: SceneSpec = toml::from_str(&text).unwrap();
            assert_eq!(parsed, spec);
            let dir = std::env::temp_dir()
                .join(format!("nrslam-random-scene-{}-{seed}", std::process::id()));
            std::fs::create_dir_all(&dir).unwrap();
            let path = dir.join("scene.toml");
            std::fs::write(&path, &text).unwrap();
            let loaded = Scene::load(&path).unwrap();
            std::fs::remove_dir_all(&dir).unwrap();
            assert_eq!(loaded, Scene::from_spec(&spec).unwrap());
        }
    }

    #[test]
    fn crowded_requests_fail_with_a_clear_error_quickly() {
        let p = RandomSceneParams {
            hall_width_m: [30.0, 30.0],
            hall_height_m: [25.0, 25.0],
            targets: [30, 30],
            placement_attempts: 50,
            layout_attempts: 5,
            ..params()
        };
        let error = generate(&p, 1).unwrap_err();
        match &error {
            RandomSceneError::Crowded {
                requested,
                best_placed,
                ..
            } => {
                assert_eq!(*requested, 30);
                assert!(*best_placed < 30);
            }
            other => panic!("expected Crowded, got {other:?}"),
        }
        assert!(
            error.to_string().contains("could not place 30 targets"),
            "{error}"
        );
    }

    /// How many layouts each target count needs with the default parameters (the cost of
    /// `generate`, and how close a count is to failing): `cargo test --release -p nrslam-radar
    /// --lib layouts_needed -- --ignored --nocapture`. Figures in docs/scene.md.
    #[test]
    #[ignore]
    fn layouts_needed_per_target_count() {
        for count in 6..=12 {
            let p = RandomSceneParams {
                targets: [count, count],
                layout_attempts: 1000,
                ..params()
            };
            let started = std::time::Instant::now();
            let mut layouts = Vec::new();
            let mut failures = 0;
            for seed in 0..50 {
                match generate_counting_layouts(&p, seed) {
                    Ok((_, n)) => layouts.push(n),
                    Err(_) => failures += 1,
                }
            }
            layouts.sort();
            let at = |q: f64| {
                layouts
                    .get(((layouts.len() as f64 * q) as usize).min(layouts.len().saturating_sub(1)))
                    .copied()
                    .unwrap_or(0)
            };
            println!(
                "{count} targets: layouts median {} p95 {} max {}; failures (1000 layouts) {failures} of 50; {:.2} s per scene",
                at(0.5),
                at(0.95),
                at(1.0),
                started.elapsed().as_secs_f64() / 50.0
            );
        }
    }

    #[test]
    fn bad_params_are_refused_by_name() {
        // Each case changes the defaults and names the field that must be refused.
        type Change = fn(&mut RandomSceneParams);
        let cases: [(Change, &str); 19] = [
            (|p| p.hall_width_m = [60.0, 40.0], "hall_width_m"),
            (|p| p.hall_height_m = [f64::NAN, 40.0], "hall_height_m[0]"),
            (|p| p.wall_margin_m = [0.2, 5.0], "wall_margin_m[0]"),
            (|p| p.wall_margin_m = [3.0, 30.0], "hall_width_m[0]"),
            (|p| p.laps = [0, 2], "laps[0]"),
            (|p| p.laps = [1, 4], "laps[1]"),
            (|p| p.targets = [5, 3], "targets"),
            (|p| p.circle_fraction = 1.5, "circle_fraction"),
            (
                |p| {
                    p.rect_short_side_m = [3.0, 4.0];
                    p.rect_long_side_m = [2.0, 8.0];
                },
                "rect_short_side_m[0]",
            ),
            (|p| p.circle_radius_m = [0.0, 1.0], "circle_radius_m[0]"),
            (|p| p.target_gap_m = -1.0, "target_gap_m"),
            (|p| p.loop_margin_m = 0.0, "loop_margin_m"),
            (|p| p.max_path_distance_m = 25.0, "max_path_distance_m"),
            (|p| p.max_path_distance_m = 2.0, "max_path_distance_m"),
            (|p| p.placement_attempts = 0, "placement_attempts"),
            (|p| p.layout_attempts = 0, "layout_attempts"),
            (|p| p.agvs = 0, "agvs"),
            (|p| p.agvs = 17, "agvs"),
            (|p| p.stations = 17, "stations"),
        ];
        for (change, field) in cases {
            let mut p = params();
            change(&mut p);
            let error = p.validate().unwrap_err();
            assert_eq!(error.field, field, "{error}");
            assert!(!error.allowed.is_empty());
            assert!(matches!(generate(&p, 1), Err(RandomSceneError::Param(_))));
        }
        assert!(params().validate().is_ok());
        // Defaults from an empty table; unknown fields refused.
        assert_eq!(toml::from_str::<RandomSceneParams>("").unwrap(), params());
        assert!(toml::from_str::<RandomSceneParams>("hall_width = [40.0, 50.0]").is_err());
        let parsed: RandomSceneParams = toml::from_str("laps = [2, 2]").unwrap();
        assert_eq!(parsed.laps, [2, 2]);
    }

    #[test]
    fn one_agv_and_no_station_are_written_as_before() {
        // The defaults add no key to the parameters or the scene.
        let text = toml::to_string(&params()).unwrap();
        assert!(
            !text.contains("agvs") && !text.contains("stations"),
            "{text}"
        );
        let spec = generate(&params(), 3).unwrap();
        assert!(spec.trajectory.is_some() && spec.agv.is_empty() && spec.station.is_empty());
        let parsed: RandomSceneParams = toml::from_str("agvs = 2\nstations = 3").unwrap();
        assert_eq!((parsed.agvs, parsed.stations), (2, 3));
        assert!(toml::to_string(&parsed).unwrap().contains("agvs = 2"));
        // Asking for agents changes no draw: the same targets and agv1's loop.
        let more = generate(
            &RandomSceneParams {
                agvs: 3,
                stations: 2,
                ..params()
            },
            3,
        )
        .unwrap();
        assert_eq!(more.targets, spec.targets);
        assert_eq!(more.hall, spec.hall);
        assert_eq!(more.agv[0].trajectory, spec.trajectory);
    }

    #[test]
    fn agvs_share_the_loop_and_stations_stand_on_the_walls() {
        let p = RandomSceneParams {
            agvs: 3,
            stations: 4,
            ..params()
        };
        for seed in 0..4 {
            let spec = generate(&p, seed).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
            let scene = Scene::from_spec(&spec).unwrap();
            assert!(spec.trajectory.is_none());
            assert_eq!(scene.agvs.len(), 3);
            let agv1 = &scene.agvs[0].trajectory;
            let lap_m = agv1.lap_length_m();
            for (k, agv) in scene.agvs.iter().enumerate() {
                assert_eq!(agv.sensor, scene.sensor);
                assert_eq!(agv.trajectory.frame_count(), agv1.frame_count());
                assert_eq!(
                    agv.trajectory.chords(CHORD_STEP_RAD),
                    agv1.chords(CHORD_STEP_RAD)
                );
                // k/3 of a lap ahead of agv1 (to the centimetre).
                let ahead = agv1.pose_at_distance(lap_m * k as f64 / 3.0);
                let start = agv.trajectory.pose_at_frame(0);
                assert!(
                    (start.position() - ahead.position()).norm() < 0.011,
                    "seed {seed}, agv{}",
                    k + 1
                );
            }
            assert_eq!(scene.stations.len(), 4);
            let (w, h) = (scene.hall_width_m, scene.hall_height_m);
            let perimeter_m = 2.0 * (w + h);
            let along = |pose: &crate::geometry::Pose2| {
                if pose.y_m == 0.0 {
                    pose.x_m
                } else if pose.x_m == w {
                    w + pose.y_m
                } else if pose.y_m == h {
                    w + h + (w - pose.x_m)
                } else {
                    assert_eq!(pose.x_m, 0.0, "seed {seed}: not on a wall: {pose:?}");
                    2.0 * w + h + (h - pose.y_m)
                }
            };
            let mut previous: Vec<f64> = Vec::new();
            for station in &scene.stations {
                let pose = station.pose;
                let at = along(&pose);
                // Facing into the hall, toward the middle.
                let middle = Vec2::new(w / 2.0, h / 2.0) - pose.position();
                let facing = Vec2::new(pose.yaw_rad.cos(), pose.yaw_rad.sin());
                assert!(facing.dot(&middle) > 0.0, "seed {seed}: {pose:?}");
                let seen = visibility::observe(&scene.targets, &station.sensor, pose).len();
                assert!(seen >= MIN_SCATTERERS_SEEN, "seed {seed}: {seen}");
                for other in &previous {
                    let d = (at - other).rem_euclid(perimeter_m);
                    assert!(d.min(perimeter_m - d) >= perimeter_m / 8.0 - 1e-9);
                }
                previous.push(at);
            }
            // Written and read back: the same scene.
            let text = to_toml(&spec, "agents").unwrap();
            assert_eq!(toml::from_str::<SceneSpec>(&text).unwrap(), spec);
        }
    }
}
