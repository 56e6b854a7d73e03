//! The industrial hall: extended targets, their scatterers and ET-GOPSA sample points, loaded from
//! a TOML scene file.
//!
//! The paper (Sec. II-A, Fig. 1b) places "eight rectangular and two circular extended targets" in
//! an industrial flexible-manufacturing hall around which an AGV loops; its figure is missing, so
//! the layout in `config/hall.toml` is ours (documented in `docs/scene.md`). Each target carries:
//!
//! - its exact shape ([`Shape`]), used for visibility and occlusion;
//! - an outline polygon for the `/ground_truth/targets` message (a circle as a 64-gon);
//! - 4 sample points, the ET-GOPSA slots of Sec. IV-C ("four point targets are selected"):
//!   a rectangle's corners, a circle's points at 0°, 90°, 180° and 270°;
//! - scatterers along its outline every `scatterer_spacing_m` or closer: the point reflectors the
//!   radar sees (the `L_p` paths of eq. (2)).
//!
//! Besides the targets, a scene holds who senses them: one AGV driving `[trajectory]`, or several
//! AGVs (`[[agv]]`, each a loop or a waypoint path, optionally with its own sensor), and fixed
//! 5G sensing stations (`[[station]]`) on the walls or pillars (docs/scene.md, "Several AGVs and
//! stations").
//!
//! Validation refuses non-positive sizes, targets outside the hall, targets that overlap or
//! touch, a path that passes within the AGV radius of a target or leaves the hall, and a station
//! outside the hall or inside a target; every error names its field.

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::error::{FieldError, SceneError};
use crate::geometry::{
    convex_polygons_distance, point_convex_polygon_distance, point_in_convex_polygon,
    point_segment_distance, segment_convex_polygon_distance, segment_meets_convex_polygon, Pose2,
    Vec2,
};
use crate::trajectory::{
    default_agv_radius, default_laps, default_period, default_speed, Trajectory, TrajectorySpec,
    WaypointsSpec,
};
use crate::visibility::Sensor;

/// Number of vertices of a circle's outline polygon in the ground-truth message.
pub const CIRCLE_OUTLINE_VERTICES: usize = 64;

/// Default distance between neighbouring scatterers along an outline (m).
pub const DEFAULT_SCATTERER_SPACING_M: f64 = 0.25;

/// Most scatterers one target may have: a guard against a spacing so small (or a target so
/// large) that building the scene would exhaust memory instead of failing with a message.
pub const MAX_SCATTERERS_PER_TARGET: f64 = 1e6;

// ---------------------------------------------------------------------------------------------
// File schema
// ---------------------------------------------------------------------------------------------

/// The scene file as written (TOML). See `config/hall.toml` for a commented example.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneSpec {
    /// Distance between neighbouring scatterers along each outline (m); each edge is divided
    /// evenly, so the actual spacing is at most this.
    #[serde(default = "default_spacing")]
    pub scatterer_spacing_m: f64,
    /// The hall's floor.
    pub hall: HallSpec,
    /// The radar's mounting and visibility limits (every AGV's, unless its `[[agv]]` entry
    /// overrides them).
    #[serde(default)]
    pub sensor: SensorSpec,
    /// The AGV's loop when the scene has one AGV; absent when `[[agv]]` lists the AGVs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<TrajectorySpec>,
    /// Every AGV, agv1 first, when there are several (then `[trajectory]` is absent).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub agv: Vec<AgvSpec>,
    /// Fixed sensing stations.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub station: Vec<StationSpec>,
    /// The extended targets, in id order (id = index).
    #[serde(default)]
    pub targets: Vec<TargetSpec>,
}

fn default_spacing() -> f64 {
    DEFAULT_SCATTERER_SPACING_M
}

/// The hall's floor: the rectangle [0, width_m] × [0, height_m] of the map frame.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct HallSpec {
    /// Extent along x (m).
    pub width_m: f64,
    /// Extent along y (m).
    pub height_m: f64,
}

/// The radar as mounted on the AGV (a ULA at the AGV centre, docs/conventions.md).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SensorSpec {
    /// Array boresight relative to the AGV heading, degrees counter-clockwise (90 = left).
    pub boresight_deg: f64,
    /// Farthest range at which a scatterer is detected (m).
    pub max_range_m: f64,
    /// Half field of view about boresight (degrees); a ULA sees at most (−90°, 90°).
    pub half_fov_deg: f64,
}

impl Default for SensorSpec {
    fn default() -> Self {
        Self {
            boresight_deg: 90.0,
            max_range_m: 20.0,
            half_fov_deg: 60.0,
        }
    }
}

/// One AGV of an `[[agv]]` list: either `trajectory` (a rounded-rectangle loop, the fields of
/// `[trajectory]`) or `waypoints_m` with the optional fields that drive it (`closed`,
/// `start_offset_m`, `speed_mps`, `frame_period_s`, `laps`, `agv_radius_m`); optionally its own
/// `sensor` fields.
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct AgvSpec {
    /// Human-readable name (error messages, drawings); default `agvN` for the N-th entry.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub name: String,
    /// A polyline through these points (m), map frame, driven in this order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub waypoints_m: Option<Vec<[f64; 2]>>,
    /// Waypoint paths: whether the last waypoint joins the first (default true).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub closed: Option<bool>,
    /// Waypoint paths: arc length from the first waypoint to the start point (m, default 0;
    /// closed paths only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start_offset_m: Option<f64>,
    /// Waypoint paths: speed (m/s, default 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_mps: Option<f64>,
    /// Waypoint paths: time between frames (s, default 0.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_period_s: Option<f64>,
    /// Waypoint paths: laps driven (default 1; closed paths only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub laps: Option<f64>,
    /// Waypoint paths: the AGV's footprint radius (m, default 0.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub agv_radius_m: Option<f64>,
    /// A loop, as the `[trajectory]` table.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trajectory: Option<TrajectorySpec>,
    /// This AGV's sensor; fields left out are the scene's `[sensor]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sensor: Option<SensorOverride>,
}

/// An `[[agv]]` entry's own sensor: each field left out is the scene's `[sensor]` value.
#[derive(Debug, Clone, PartialEq, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SensorOverride {
    /// Array boresight relative to the AGV heading, degrees counter-clockwise (90 = left).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub boresight_deg: Option<f64>,
    /// Farthest range at which a scatterer is detected (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_range_m: Option<f64>,
    /// Half field of view about boresight (degrees).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_fov_deg: Option<f64>,
}

/// A fixed monostatic 5G sensing station (`[[station]]`): the AGVs' OFDM front end on a wall or
/// a pillar, at a surveyed pose.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct StationSpec {
    /// Human-readable name (error messages, drawings); default `stationN` for the N-th entry.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub name: String,
    /// Position of the array (m), map frame: inside the hall or on a wall, clear of targets.
    pub position_m: [f64; 2],
    /// Direction of boresight in the map frame, degrees counter-clockwise from +x.
    pub boresight_deg: f64,
    /// Half field of view about boresight (degrees, in (0, 90)); default the scene's
    /// `[sensor]` value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_fov_deg: Option<f64>,
    /// Farthest range at which a scatterer is detected (m); default the scene's `[sensor]`
    /// value.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_range_m: Option<f64>,
}

/// Kind of an extended target.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ShapeKind {
    /// A rectangle: `center_m`, `size_m`, optional `yaw_deg`.
    Rectangle,
    /// A circle: `center_m`, `radius_m`.
    Circle,
}

/// One extended target as written. Fields that do not belong to the shape are refused.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TargetSpec {
    /// Human-readable name (documentation and error messages only).
    #[serde(default)]
    pub name: String,
    /// "rectangle" or "circle".
    pub shape: ShapeKind,
    /// Centre (m), map frame.
    pub center_m: [f64; 2],
    /// Rectangle: [width, height] (m) along its own x and y axes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub size_m: Option<[f64; 2]>,
    /// Rectangle: rotation of its own x axis from the map's +x (degrees, counter-clockwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub yaw_deg: Option<f64>,
    /// Circle: radius (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub radius_m: Option<f64>,
}

// ---------------------------------------------------------------------------------------------
// Built scene
// ---------------------------------------------------------------------------------------------

/// The exact geometry of an extended target (convex).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A (possibly rotated) rectangle, given by its corners counter-clockwise.
    Rectangle {
        /// Corners, counter-clockwise, starting at the one at local (−w/2, −h/2).
        corners: [Vec2; 4],
    },
    /// A circle.
    Circle {
        /// Centre (m).
        center: Vec2,
        /// Radius (m).
        radius_m: f64,
    },
}

impl Shape {
    /// A rectangle of `width_m` × `height_m` centred on `center`, its x axis at `yaw_rad`.
    pub fn rectangle(center: Vec2, width_m: f64, height_m: f64, yaw_rad: f64) -> Self {
        let (s, c) = yaw_rad.sin_cos();
        let axis_x = Vec2::new(c, s) * (width_m / 2.0);
        let axis_y = Vec2::new(-s, c) * (height_m / 2.0);
        Shape::Rectangle {
            corners: [
                center - axis_x - axis_y,
                center + axis_x - axis_y,
                center + axis_x + axis_y,
                center - axis_x + axis_y,
            ],
        }
    }

    /// A circle.
    pub fn circle(center: Vec2, radius_m: f64) -> Self {
        Shape::Circle { center, radius_m }
    }

    /// "rectangle" or "circle", as in the `Target` message.
    pub fn kind_name(&self) -> &'static str {
        match self {
            Shape::Rectangle { .. } => "rectangle",
            Shape::Circle { .. } => "circle",
        }
    }

    /// Closed outline polygon, counter-clockwise, last vertex not repeated; a circle as a
    /// [`CIRCLE_OUTLINE_VERTICES`]-gon with a vertex at 0°.
    pub fn outline(&self) -> Vec<Vec2> {
        match self {
            Shape::Rectangle { corners } => corners.to_vec(),
            Shape::Circle { center, radius_m } => (0..CIRCLE_OUTLINE_VERTICES)
                .map(|k| {
                    let phi = TAU * k as f64 / CIRCLE_OUTLINE_VERTICES as f64;
                    center + Vec2::new(phi.cos(), phi.sin()) * *radius_m
                })
                .collect(),
        }
    }

    /// The 4 ET-GOPSA sample points: a rectangle's corners, a circle's points at 0°, 90°, 180°,
    /// 270°.
    pub fn samples(&self) -> Vec<Vec2> {
        match self {
            Shape::Rectangle { corners } => corners.to_vec(),
            Shape::Circle { center, radius_m } => (0..4)
                .map(|k| {
                    let phi = FRAC_PI_2 * k as f64;
                    center + Vec2::new(phi.cos(), phi.sin()) * *radius_m
                })
                .collect(),
        }
    }

    /// Scatterers along the outline, at most `spacing_m` apart, each with its outward normal(s).
    ///
    /// A rectangle's edges are each divided evenly, starting at a corner, so the corners are
    /// scatterers; a corner carries both adjacent edges' normals (it reflects toward either
    /// side). A circle gets `ceil(2πr / spacing)` scatterers (at least 4) from 0°.
    pub fn scatterers(&self, spacing_m: f64) -> Vec<Scatterer> {
        match self {
            Shape::Rectangle { corners } => {
                let normal = |i: usize| {
                    let d = corners[(i + 1) % 4] - corners[i];
                    Vec2::new(d.y, -d.x).normalize() // outward for a counter-clockwise polygon
                };
                let mut out = Vec::new();
                for i in 0..4 {
                    let start = corners[i];
                    let edge = corners[(i + 1) % 4] - start;
                    let pieces = pieces_for(edge.norm(), spacing_m);
                    let n_here = normal(i);
                    let n_before = normal((i + 3) % 4);
                    for j in 0..pieces {
                        let position = start + edge * (j as f64 / pieces as f64);
                        let normals = if j == 0 {
                            [n_before, n_here]
                        } else {
                            [n_here, n_here]
                        };
                        out.push(Scatterer { position, normals });
                    }
                }
                out
            }
            Shape::Circle { center, radius_m } => {
                let count = pieces_for(TAU * radius_m, spacing_m).max(4);
                (0..count)
                    .map(|k| {
                        let phi = TAU * k as f64 / count as f64;
                        let n = Vec2::new(phi.cos(), phi.sin());
                        Scatterer {
                            position: center + n * *radius_m,
                            normals: [n, n],
                        }
                    })
                    .collect()
            }
        }
    }

    /// Length of the outline (m).
    pub fn perimeter_m(&self) -> f64 {
        match self {
            Shape::Rectangle { corners } => crate::geometry::edges(corners)
                .map(|(a, b)| (b - a).norm())
                .sum(),
            Shape::Circle { radius_m, .. } => TAU * radius_m,
        }
    }

    /// Whether `p` lies inside or on the shape.
    pub fn contains(&self, p: Vec2) -> bool {
        match self {
            Shape::Rectangle { corners } => point_in_convex_polygon(corners, p),
            Shape::Circle { center, radius_m } => (p - center).norm() <= *radius_m,
        }
    }

    /// Distance from the closed segment [a, b] to the shape (0 if they meet).
    pub fn distance_to_segment(&self, a: Vec2, b: Vec2) -> f64 {
        match self {
            Shape::Rectangle { corners } => segment_convex_polygon_distance(corners, a, b),
            Shape::Circle { center, radius_m } => {
                (point_segment_distance(a, b, *center) - radius_m).max(0.0)
            }
        }
    }

    /// Whether the closed segment [a, b] meets the shape (touching counts: a grazing ray is
    /// blocked). Exact for circles, not through the 64-gon.
    pub fn blocks_segment(&self, a: Vec2, b: Vec2) -> bool {
        match self {
            Shape::Rectangle { corners } => {
                // Cheap rejection by the circumscribed circle: most lines of sight pass far
                // from most targets, and this runs for every seen scatterer and target.
                let center = (corners[0] + corners[2]) / 2.0;
                let radius_m = (corners[2] - corners[0]).norm() / 2.0;
                // The small margin keeps the rejection conservative under rounding.
                point_segment_distance(a, b, center) <= radius_m * (1.0 + 1e-12) + 1e-12
                    && segment_meets_convex_polygon(corners, a, b)
            }
            Shape::Circle { center, radius_m } => {
                point_segment_distance(a, b, *center) <= *radius_m
            }
        }
    }

    /// Distance between two shapes (0 if they overlap or touch).
    pub fn distance_to_shape(&self, other: &Shape) -> f64 {
        match (self, other) {
            (Shape::Rectangle { corners: a }, Shape::Rectangle { corners: b }) => {
                convex_polygons_distance(a, b)
            }
            (Shape::Rectangle { corners }, Shape::Circle { center, radius_m })
            | (Shape::Circle { center, radius_m }, Shape::Rectangle { corners }) => {
                (point_convex_polygon_distance(corners, *center) - radius_m).max(0.0)
            }
            (
                Shape::Circle {
                    center: c1,
                    radius_m: r1,
                },
                Shape::Circle {
                    center: c2,
                    radius_m: r2,
                },
            ) => ((c1 - c2).norm() - r1 - r2).max(0.0),
        }
    }

    /// Axis-aligned bounding box (min corner, max corner).
    pub fn bounding_box(&self) -> (Vec2, Vec2) {
        match self {
            Shape::Rectangle { corners } => {
                let min = corners
                    .iter()
                    .fold(Vec2::repeat(f64::INFINITY), |m, c| m.inf(c));
                let max = corners
                    .iter()
                    .fold(Vec2::repeat(f64::NEG_INFINITY), |m, c| m.sup(c));
                (min, max)
            }
            Shape::Circle { center, radius_m } => (
                center - Vec2::repeat(*radius_m),
                center + Vec2::repeat(*radius_m),
            ),
        }
    }
}

/// Number of equal pieces a length is cut into so that none is longer than `spacing_m`.
fn pieces_for(length_m: f64, spacing_m: f64) -> usize {
    // The small tolerance keeps a 4 m edge at spacing 0.25 at 16 pieces despite rounding.
    ((length_m / spacing_m) - 1e-9).ceil().max(1.0) as usize
}

/// A point reflector on a target's outline.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scatterer {
    /// Position (m), map frame.
    pub position: Vec2,
    /// Outward unit normal(s) of the surface at the scatterer: equal along an edge, the two
    /// adjacent edges' normals at a corner. The scatterer faces a sensor if either normal does.
    pub normals: [Vec2; 2],
}

impl Scatterer {
    /// Whether the surface at the scatterer faces `sensor_position` (strictly: a sensor in the
    /// plane of the surface does not see it).
    pub fn faces(&self, sensor_position: Vec2) -> bool {
        let to_sensor = sensor_position - self.position;
        self.normals.iter().any(|n| n.dot(&to_sensor) > 0.0)
    }
}

/// One extended target, ready for simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct Target {
    /// Identifier (index in the scene file), 0-based.
    pub id: u32,
    /// Name from the scene file.
    pub name: String,
    /// Exact geometry.
    pub shape: Shape,
    /// Scatterers along the outline.
    pub scatterers: Vec<Scatterer>,
}

/// One AGV of a validated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Agv {
    /// Its name (`agvN` unless the file names it).
    pub name: String,
    /// Its path.
    pub trajectory: Trajectory,
    /// Its radar, mounted relative to its heading.
    pub sensor: Sensor,
}

/// A fixed sensing station of a validated scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Station {
    /// Its name (`stationN` unless the file names it).
    pub name: String,
    /// Its surveyed pose: the array's position, heading = boresight in the map frame.
    pub pose: Pose2,
    /// Its radar: boresight 0 relative to the pose (the pose's heading is the boresight), the
    /// station's range and field of view.
    pub sensor: Sensor,
}

/// A validated scene: hall, sensors, paths and targets.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Hall extent along x (m).
    pub hall_width_m: f64,
    /// Hall extent along y (m).
    pub hall_height_m: f64,
    /// Scatterer spacing used to build the targets (m).
    pub scatterer_spacing_m: f64,
    /// agv1's radar (the same as `agvs[0].sensor`).
    pub sensor: Sensor,
    /// agv1's path (the same as `agvs[0].trajectory`): the run's clock for stations.
    pub trajectory: Trajectory,
    /// Every AGV, agv1 first; at least one.
    pub agvs: Vec<Agv>,
    /// The fixed sensing stations, station1 first.
    pub stations: Vec<Station>,
    /// The targets, id = index.
    pub targets: Vec<Target>,
}

impl Scene {
    /// Reads and validates a scene file. A missing file is an error naming the path.
    pub fn load(path: &Path) -> Result<Self, SceneError> {
        Self::load_with_spacing(path, None)
    }

    /// As [`Scene::load`], with the scatterer spacing (m) replaced when `scatterer_spacing_m`
    /// is given (the radar's override of the scene's density).
    pub fn load_with_spacing(
        path: &Path,
        scatterer_spacing_m: Option<f64>,
    ) -> Result<Self, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let origin = path.display().to_string();
        // The last scene parsed, by its text, name and spacing: every trial of a Monte Carlo
        // study loads the same file (twice: the radar and the frame count), and parsing and
        // validating it cost about 1 % of a hall trial. A scene is a function of these three.
        type Parsed = (String, String, Option<u64>, Scene);
        static LAST: std::sync::Mutex<Option<Parsed>> = std::sync::Mutex::new(None);
        let spacing_bits = scatterer_spacing_m.map(f64::to_bits);
        let lock = || {
            LAST.lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
        };
        if let Some((_, _, _, scene)) = lock()
            .as_ref()
            .filter(|(t, o, b, _)| *t == text && *o == origin && *b == spacing_bits)
        {
            return Ok(scene.clone());
        }
        let scene = Self::parse(&text, &origin, scatterer_spacing_m)?;
        *lock() = Some((text, origin, spacing_bits, scene.clone()));
        Ok(scene)
    }

    /// Parses and validates scene TOML; `origin` names the text in errors (a path or a label).
    pub fn from_toml_str(text: &str, origin: &str) -> Result<Self, SceneError> {
        Self::parse(text, origin, None)
    }

    fn parse(
        text: &str,
        origin: &str,
        scatterer_spacing_m: Option<f64>,
    ) -> Result<Self, SceneError> {
        let mut spec: SceneSpec = toml::from_str(text).map_err(|e| SceneError::Parse {
            origin: origin.to_owned(),
            message: e.to_string(),
        })?;
        if let Some(spacing_m) = scatterer_spacing_m {
            spec.scatterer_spacing_m = spacing_m;
        }
        Self::from_spec(&spec).map_err(|error| SceneError::Invalid {
            origin: origin.to_owned(),
            error,
        })
    }

    /// Validates a parsed scene and builds its targets, AGVs and stations.
    pub fn from_spec(spec: &SceneSpec) -> Result<Self, FieldError> {
        let hall = &spec.hall;
        positive("hall.width_m", hall.width_m)?;
        positive("hall.height_m", hall.height_m)?;
        positive("scatterer_spacing_m", spec.scatterer_spacing_m)?;
        let sensor = sensor_from_spec(&spec.sensor, "sensor")?;

        let mut targets = Vec::with_capacity(spec.targets.len());
        for (index, t) in spec.targets.iter().enumerate() {
            let shape = shape_from_spec(index, t)?;
            let (min, max) = shape.bounding_box();
            if min.x < 0.0 || min.y < 0.0 || max.x > hall.width_m || max.y > hall.height_m {
                return Err(FieldError::new(
                    target_field(index, t, "center_m"),
                    format!(
                        "the target reaches outside the hall [0, {}] × [0, {}] m",
                        hall.width_m, hall.height_m
                    ),
                ));
            }
            let perimeter_m = shape.perimeter_m();
            let count = perimeter_m / spec.scatterer_spacing_m;
            if !count.is_finite() || count > MAX_SCATTERERS_PER_TARGET {
                return Err(FieldError::new(
                    "scatterer_spacing_m",
                    format!(
                        "{} m on the {perimeter_m} m outline of targets[{index}]{} gives more \
                         than {MAX_SCATTERERS_PER_TARGET} scatterers",
                        spec.scatterer_spacing_m,
                        name_suffix(&t.name)
                    ),
                ));
            }
            let scatterers = shape.scatterers(spec.scatterer_spacing_m);
            targets.push(Target {
                id: index as u32,
                name: t.name.clone(),
                shape,
                scatterers,
            });
        }
        // Targets must be strictly apart: a shared surface would make occlusion ambiguous and two
        // touching boxes are one extended target, not two.
        for i in 0..targets.len() {
            for j in 0..i {
                if targets[i].shape.distance_to_shape(&targets[j].shape) <= 0.0 {
                    return Err(FieldError::new(
                        target_field(i, &spec.targets[i], "center_m"),
                        format!(
                            "overlaps or touches targets[{j}]{}; targets must be apart",
                            name_suffix(&spec.targets[j].name)
                        ),
                    ));
                }
            }
        }

        let agvs = match (&spec.trajectory, spec.agv.is_empty()) {
            (Some(loop_spec), true) => {
                let trajectory = Trajectory::new(loop_spec)?;
                check_path_clearance(&trajectory, &targets, &spec.targets, hall, "trajectory")?;
                vec![Agv {
                    name: default_name("agv", 0),
                    trajectory,
                    sensor,
                }]
            }
            (None, false) => spec
                .agv
                .iter()
                .enumerate()
                .map(|(index, agv)| agv_from_spec(index, agv, spec, &targets))
                .collect::<Result<Vec<_>, _>>()?,
            (Some(_), false) => {
                return Err(FieldError::new(
                    "trajectory",
                    "is given together with [[agv]]: with [[agv]], every AGV is listed there \
                     (agv1 first) and [trajectory] must go",
                ))
            }
            (None, true) => {
                return Err(FieldError::new(
                    "trajectory",
                    "is missing: a scene has [trajectory] (one AGV) or [[agv]] entries",
                ))
            }
        };
        check_unique_names("agv", agvs.iter().map(|a| a.name.as_str()))?;
        let stations = spec
            .station
            .iter()
            .enumerate()
            .map(|(index, station)| station_from_spec(index, station, spec, &targets))
            .collect::<Result<Vec<_>, _>>()?;
        check_unique_names("station", stations.iter().map(|s| s.name.as_str()))?;

        Ok(Self {
            hall_width_m: hall.width_m,
            hall_height_m: hall.height_m,
            scatterer_spacing_m: spec.scatterer_spacing_m,
            sensor: agvs[0].sensor,
            trajectory: agvs[0].trajectory.clone(),
            agvs,
            stations,
            targets,
        })
    }

    /// Total number of scatterers over all targets.
    pub fn scatterer_count(&self) -> usize {
        self.targets.iter().map(|t| t.scatterers.len()).sum()
    }
}

/// `agv1`, `station2`, ...: the name an entry has when the file gives none (1-based, as the
/// radar's `sensor` parameter counts).
fn default_name(kind: &str, index: usize) -> String {
    format!("{kind}{}", index + 1)
}

fn effective_name(kind: &str, index: usize, name: &str) -> String {
    if name.is_empty() {
        default_name(kind, index)
    } else {
        name.to_owned()
    }
}

/// `agv[1] (agv2)`: the entry's place in the file and the name it goes by.
fn entry_prefix(kind: &str, index: usize, name: &str) -> String {
    format!("{kind}[{index}] ({})", effective_name(kind, index, name))
}

fn check_unique_names<'a>(
    kind: &str,
    names: impl Iterator<Item = &'a str>,
) -> Result<(), FieldError> {
    let names: Vec<&str> = names.collect();
    for (i, name) in names.iter().enumerate() {
        if let Some(j) = names[..i].iter().position(|other| other == name) {
            return Err(FieldError::new(
                format!("{kind}[{i}].name"),
                format!("\"{name}\" is also {kind}[{j}]'s name; names must differ"),
            ));
        }
    }
    Ok(())
}

/// One `[[agv]]` entry: its path (a loop or waypoints, exactly one), the path's clearance, and
/// its sensor (the scene's `[sensor]` with the entry's fields replacing it).
fn agv_from_spec(
    index: usize,
    agv: &AgvSpec,
    spec: &SceneSpec,
    targets: &[Target],
) -> Result<Agv, FieldError> {
    let prefix = entry_prefix("agv", index, &agv.name);
    let within = |e: FieldError| FieldError::new(format!("{prefix}.{}", e.field), e.problem);
    let waypoint_fields = [
        ("closed", agv.closed.is_some()),
        ("start_offset_m", agv.start_offset_m.is_some()),
        ("speed_mps", agv.speed_mps.is_some()),
        ("frame_period_s", agv.frame_period_s.is_some()),
        ("laps", agv.laps.is_some()),
        ("agv_radius_m", agv.agv_radius_m.is_some()),
    ];
    let (trajectory, path_field) =
        match (&agv.trajectory, &agv.waypoints_m) {
            (Some(loop_spec), None) => {
                if let Some((name, _)) = waypoint_fields.iter().find(|(_, given)| *given) {
                    return Err(FieldError::new(
                        format!("{prefix}.{name}"),
                        "is for waypoints_m paths; a loop takes it inside trajectory = { ... }",
                    ));
                }
                (Trajectory::new(loop_spec).map_err(within)?, "trajectory")
            }
            (None, Some(points)) => {
                let waypoints = WaypointsSpec {
                    waypoints_m: points.clone(),
                    closed: agv.closed.unwrap_or(true),
                    start_offset_m: agv.start_offset_m.unwrap_or(0.0),
                    speed_mps: agv.speed_mps.unwrap_or_else(default_speed),
                    frame_period_s: agv.frame_period_s.unwrap_or_else(default_period),
                    laps: agv.laps.unwrap_or_else(default_laps),
                    agv_radius_m: agv.agv_radius_m.unwrap_or_else(default_agv_radius),
                };
                (
                    Trajectory::from_waypoints(&waypoints).map_err(within)?,
                    "waypoints_m",
                )
            }
            (Some(_), Some(_)) => {
                return Err(FieldError::new(
                    format!("{prefix}.waypoints_m"),
                    "is given together with trajectory; an AGV drives one path",
                ))
            }
            (None, None) => return Err(FieldError::new(
                prefix,
                "has no path: give trajectory = { ... } (a loop, the fields of [trajectory]) or \
                 waypoints_m = [[x, y], ...]",
            )),
        };
    check_path_clearance(
        &trajectory,
        targets,
        &spec.targets,
        &spec.hall,
        &format!("{prefix}.{path_field}"),
    )?;
    let own = agv.sensor.clone().unwrap_or_default();
    let merged = SensorSpec {
        boresight_deg: own.boresight_deg.unwrap_or(spec.sensor.boresight_deg),
        max_range_m: own.max_range_m.unwrap_or(spec.sensor.max_range_m),
        half_fov_deg: own.half_fov_deg.unwrap_or(spec.sensor.half_fov_deg),
    };
    Ok(Agv {
        name: effective_name("agv", index, &agv.name),
        trajectory,
        sensor: sensor_from_spec(&merged, &format!("{prefix}.sensor"))?,
    })
}

/// One `[[station]]` entry: inside the hall (a wall counts), clear of every target, a sensor
/// that validates like `[sensor]`.
fn station_from_spec(
    index: usize,
    station: &StationSpec,
    spec: &SceneSpec,
    targets: &[Target],
) -> Result<Station, FieldError> {
    let prefix = entry_prefix("station", index, &station.name);
    let [x, y] = station.position_m;
    if !(x.is_finite() && y.is_finite()) {
        return Err(FieldError::new(
            format!("{prefix}.position_m"),
            format!("must be finite, got [{x}, {y}]"),
        ));
    }
    let hall = &spec.hall;
    if !((0.0..=hall.width_m).contains(&x) && (0.0..=hall.height_m).contains(&y)) {
        return Err(FieldError::new(
            format!("{prefix}.position_m"),
            format!(
                "[{x}, {y}] is outside the hall [0, {}] × [0, {}] m; a station stands inside \
                 it or on a wall",
                hall.width_m, hall.height_m
            ),
        ));
    }
    let position = Vec2::new(x, y);
    for (k, target) in targets.iter().enumerate() {
        // On the outline counts as inside: every line of sight would graze the target.
        if target.shape.distance_to_segment(position, position) <= 0.0 {
            return Err(FieldError::new(
                format!("{prefix}.position_m"),
                format!(
                    "[{x}, {y}] is inside or on targets[{k}]{}; a station stands clear of \
                     every target (in front of a pillar, not in it)",
                    name_suffix(&spec.targets[k].name)
                ),
            ));
        }
    }
    let sensor = sensor_from_spec(
        &SensorSpec {
            boresight_deg: station.boresight_deg,
            max_range_m: station.max_range_m.unwrap_or(spec.sensor.max_range_m),
            half_fov_deg: station.half_fov_deg.unwrap_or(spec.sensor.half_fov_deg),
        },
        &prefix,
    )?;
    Ok(Station {
        name: effective_name("station", index, &station.name),
        pose: Pose2::new(x, y, sensor.boresight_rad),
        sensor: Sensor {
            boresight_rad: 0.0,
            ..sensor
        },
    })
}

/// The sensor table at `prefix` (`sensor`, `agv[1] (agv2).sensor`, `station[0] (station1)`).
fn sensor_from_spec(spec: &SensorSpec, prefix: &str) -> Result<Sensor, FieldError> {
    if !(spec.boresight_deg.is_finite() && spec.boresight_deg.abs() <= 180.0) {
        return Err(FieldError::new(
            format!("{prefix}.boresight_deg"),
            format!("must lie in [−180, 180], got {}", spec.boresight_deg),
        ));
    }
    positive(&format!("{prefix}.max_range_m"), spec.max_range_m)?;
    if !(spec.half_fov_deg > 0.0 && spec.half_fov_deg < 90.0) {
        return Err(FieldError::new(
            format!("{prefix}.half_fov_deg"),
            format!(
                "must lie in (0, 90) (a linear array resolves angles within ±90°), got {}",
                spec.half_fov_deg
            ),
        ));
    }
    Ok(Sensor {
        boresight_rad: spec.boresight_deg.to_radians(),
        max_range_m: spec.max_range_m,
        half_fov_rad: spec.half_fov_deg.to_radians(),
    })
}

fn shape_from_spec(index: usize, t: &TargetSpec) -> Result<Shape, FieldError> {
    let field = |name: &str| target_field(index, t, name);
    if !(t.center_m[0].is_finite() && t.center_m[1].is_finite()) {
        return Err(FieldError::new(field("center_m"), "must be finite"));
    }
    let center = Vec2::new(t.center_m[0], t.center_m[1]);
    match t.shape {
        ShapeKind::Rectangle => {
            if t.radius_m.is_some() {
                return Err(FieldError::new(
                    field("radius_m"),
                    "is for circles; a rectangle takes size_m and yaw_deg",
                ));
            }
            let [width_m, height_m] = t.size_m.ok_or_else(|| {
                FieldError::new(field("size_m"), "is required for shape = \"rectangle\"")
            })?;
            positive(&field("size_m[0]"), width_m)?;
            positive(&field("size_m[1]"), height_m)?;
            let yaw_deg = t.yaw_deg.unwrap_or(0.0);
            if !yaw_deg.is_finite() {
                return Err(FieldError::new(field("yaw_deg"), "must be finite"));
            }
            Ok(Shape::rectangle(
                center,
                width_m,
                height_m,
                yaw_deg.to_radians(),
            ))
        }
        ShapeKind::Circle => {
            if t.size_m.is_some() {
                return Err(FieldError::new(
                    field("size_m"),
                    "is for rectangles; a circle takes radius_m",
                ));
            }
            if t.yaw_deg.is_some() {
                return Err(FieldError::new(
                    field("yaw_deg"),
                    "is for rectangles; a circle has no orientation",
                ));
            }
            let radius_m = t.radius_m.ok_or_else(|| {
                FieldError::new(field("radius_m"), "is required for shape = \"circle\"")
            })?;
            positive(&field("radius_m"), radius_m)?;
            Ok(Shape::circle(center, radius_m))
        }
    }
}

/// The AGV body (a disc of `agv_radius_m` about the path) must stay clear of every target and
/// inside the hall; `field` names the path in errors (`trajectory`, `agv[1] (agv2).waypoints_m`).
fn check_path_clearance(
    trajectory: &Trajectory,
    targets: &[Target],
    specs: &[TargetSpec],
    hall: &HallSpec,
    field: &str,
) -> Result<(), FieldError> {
    let radius_m = trajectory.agv_radius_m();
    let leaves = |x_min: f64, y_min: f64, x_max: f64, y_max: f64| {
        x_min - radius_m < 0.0
            || y_min - radius_m < 0.0
            || x_max + radius_m > hall.width_m
            || y_max + radius_m > hall.height_m
    };
    if let Some(spec) = trajectory.loop_spec() {
        if leaves(spec.x_min_m, spec.y_min_m, spec.x_max_m, spec.y_max_m) {
            return Err(FieldError::new(
                field,
                format!(
                    "the loop (with agv_radius_m = {radius_m}) leaves the hall [0, {}] × [0, {}] m",
                    hall.width_m, hall.height_m
                ),
            ));
        }
    }
    if let Some(spec) = trajectory.waypoints_spec() {
        // The hall is convex: a path whose waypoints keep the clearance keeps it throughout.
        for (i, p) in spec.waypoints_m.iter().enumerate() {
            if leaves(p[0], p[1], p[0], p[1]) {
                return Err(FieldError::new(
                    format!("{field}[{i}]"),
                    format!(
                        "[{}, {}] (with agv_radius_m = {radius_m}) leaves the hall [0, {}] × \
                         [0, {}] m",
                        p[0], p[1], hall.width_m, hall.height_m
                    ),
                ));
            }
        }
    }
    // Chords at most 1° of arc: the sagitta is below 4e-5 of the corner radius.
    let chords = trajectory.chords(PI / 180.0);
    let what = if trajectory.loop_spec().is_some() {
        "loop"
    } else {
        "path"
    };
    for (index, target) in targets.iter().enumerate() {
        let closest_m = chords
            .iter()
            .map(|(a, b)| target.shape.distance_to_segment(*a, *b))
            .fold(f64::INFINITY, f64::min);
        if closest_m <= 0.0 || closest_m < radius_m {
            return Err(FieldError::new(
                field,
                format!(
                    "the {what} passes {closest_m:.3} m from targets[{index}]{}, closer than \
                     agv_radius_m = {radius_m} m (it must not cross a target)",
                    name_suffix(&specs[index].name)
                ),
            ));
        }
    }
    Ok(())
}

fn target_field(index: usize, t: &TargetSpec, name: &str) -> String {
    format!("targets[{index}]{}.{name}", name_suffix(&t.name))
}

fn name_suffix(name: &str) -> String {
    if name.is_empty() {
        String::new()
    } else {
        format!(" ({name})")
    }
}

/// `value` must be finite and > 0.
pub(crate) fn positive(field: &str, value: f64) -> Result<(), FieldError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(FieldError::new(
            field,
            format!("must be finite and > 0, got {value}"),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Pose2;

    pub(crate) const MINIMAL: &str = r#"
        [hall]
        width_m = 20.0
        height_m = 20.0
        [trajectory]
        x_min_m = 2.0
        y_min_m = 2.0
        x_max_m = 18.0
        y_max_m = 18.0
        corner_radius_m = 2.0
        [[targets]]
        name = "box"
        shape = "rectangle"
        center_m = [10.0, 10.0]
        size_m = [4.0, 2.0]
        [[targets]]
        name = "tank"
        shape = "circle"
        center_m = [6.0, 6.0]
        radius_m = 1.0
    "#;

    fn with(extra_target: &str) -> String {
        format!("{MINIMAL}\n[[targets]]\n{extra_target}")
    }

    fn invalid_field(text: &str) -> String {
        match Scene::from_toml_str(text, "test") {
            Err(SceneError::Invalid { error, .. }) => error.field,
            other => panic!("expected a validation error, got {other:?}"),
        }
    }

    #[test]
    fn minimal_scene_builds() {
        let scene = Scene::from_toml_str(MINIMAL, "test").unwrap();
        assert_eq!(scene.targets.len(), 2);
        assert_eq!(scene.targets[0].shape.kind_name(), "rectangle");
        // Box 4 × 2 at spacing 0.25: 16 + 8 + 16 + 8 scatterers.
        assert_eq!(scene.targets[0].scatterers.len(), 48);
        // Circle r = 1: ceil(2π / 0.25) = 26.
        assert_eq!(scene.targets[1].scatterers.len(), 26);
        assert_eq!(scene.sensor, Sensor::default());
    }

    #[test]
    fn outlines_and_samples() {
        let rect = Shape::rectangle(Vec2::new(1.0, 2.0), 4.0, 2.0, 0.0);
        let outline = rect.outline();
        assert_eq!(outline.len(), 4);
        assert_eq!(outline[0], Vec2::new(-1.0, 1.0));
        assert_eq!(outline[2], Vec2::new(3.0, 3.0));
        assert_eq!(rect.samples(), outline);
        let circle = Shape::circle(Vec2::new(0.0, 0.0), 2.0);
        let outline = circle.outline();
        assert_eq!(outline.len(), CIRCLE_OUTLINE_VERTICES);
        // Counter-clockwise: positive signed area.
        let area: f64 = (0..outline.len())
            .map(|i| crate::geometry::cross(outline[i], outline[(i + 1) % outline.len()]))
            .sum::<f64>()
            / 2.0;
        assert!(area > 0.0);
        let samples = circle.samples();
        assert_eq!(samples.len(), 4);
        for (s, expected) in samples
            .iter()
            .zip([(2.0, 0.0), (0.0, 2.0), (-2.0, 0.0), (0.0, -2.0)])
        {
            assert!((s - Vec2::new(expected.0, expected.1)).norm() < 1e-12);
        }
    }

    #[test]
    fn scatterers_lie_on_outline_at_most_spacing_apart() {
        let spacing = 0.3;
        for shape in [
            Shape::rectangle(Vec2::new(5.0, 5.0), 3.1, 1.7, 0.4),
            Shape::circle(Vec2::new(1.0, 1.0), 1.3),
        ] {
            let s = shape.scatterers(spacing);
            for (k, sc) in s.iter().enumerate() {
                let next = s[(k + 1) % s.len()].position;
                assert!((next - sc.position).norm() <= spacing + 1e-12);
                // On the outline: inside-or-on, and a nudge outward leaves the shape.
                assert!(shape.contains(sc.position + (sc.normals[0] + sc.normals[1]) * -1e-9));
                assert!(!shape.contains(sc.position + (sc.normals[0] + sc.normals[1]) * 1e-6));
            }
        }
    }

    #[test]
    fn validation_names_fields() {
        // An extra target and the field its validation error names.
        for (target, field) in [
            (
                "shape = \"circle\"\ncenter_m = [15.0, 15.0]\nradius_m = -1.0",
                "targets[2].radius_m",
            ),
            (
                "shape = \"rectangle\"\nname = \"flat\"\ncenter_m = [15.0, 15.0]\nsize_m = [0.0, 1.0]",
                "targets[2] (flat).size_m[0]",
            ),
            (
                "shape = \"circle\"\ncenter_m = [15.0, 15.0]",
                "targets[2].radius_m",
            ),
            (
                "shape = \"circle\"\ncenter_m = [15.0, 15.0]\nradius_m = 1.0\nyaw_deg = 3.0",
                "targets[2].yaw_deg",
            ),
            // Overlapping the box at (10, 10).
            (
                "shape = \"circle\"\ncenter_m = [12.5, 10.0]\nradius_m = 1.0",
                "targets[2].center_m",
            ),
            // Touching counts as overlapping.
            (
                "shape = \"circle\"\ncenter_m = [13.0, 10.0]\nradius_m = 1.0",
                "targets[2].center_m",
            ),
            // On the loop's bottom straight (y = 2).
            (
                "shape = \"circle\"\ncenter_m = [10.0, 2.5]\nradius_m = 1.0",
                "trajectory",
            ),
            // Outside the hall.
            (
                "shape = \"circle\"\ncenter_m = [19.5, 10.0]\nradius_m = 1.0",
                "targets[2].center_m",
            ),
        ] {
            assert_eq!(invalid_field(&with(target)), field, "{target}");
        }
        assert_eq!(
            invalid_field(&MINIMAL.replace("width_m = 20.0", "width_m = 0.0")),
            "hall.width_m"
        );
        // A spacing that would need billions of scatterers is an error, not an abort.
        assert_eq!(
            invalid_field(&format!("scatterer_spacing_m = 1e-9\n{MINIMAL}")),
            "scatterer_spacing_m"
        );
    }

    #[test]
    fn unknown_fields_and_shapes_are_refused() {
        for bad in [
            MINIMAL.replace("[hall]", "[hall]\ncolour = 3"),
            with("shape = \"triangle\"\ncenter_m = [15.0, 15.0]"),
            with("shape = \"circle\"\ncenter_m = [15.0, 15.0]\nradius = 1.0"),
        ] {
            assert!(matches!(
                Scene::from_toml_str(&bad, "test"),
                Err(SceneError::Parse { .. })
            ));
        }
    }

    #[test]
    fn missing_file_names_the_path() {
        let err = Scene::load(Path::new("/nonexistent/dir/hall.toml")).unwrap_err();
        assert!(matches!(err, SceneError::Read { .. }));
        assert!(err.to_string().contains("/nonexistent/dir/hall.toml"));
    }

    #[test]
    fn corners_face_both_ways() {
        let rect = Shape::rectangle(Vec2::new(0.0, 0.0), 2.0, 2.0, 0.0);
        let s = rect.scatterers(0.5);
        let corner = s[0]; // (−1, −1)
        assert_eq!(corner.position, Vec2::new(-1.0, -1.0));
        assert!(corner.faces(Vec2::new(-5.0, 0.0)));
        assert!(corner.faces(Vec2::new(0.0, -5.0)));
        assert!(!corner.faces(Vec2::new(5.0, 5.0)));
    }

    /// MINIMAL's hall and targets with `agents` instead of its `[trajectory]`.
    fn with_agents(agents: &str) -> String {
        let start = MINIMAL.find("[trajectory]").unwrap();
        let end = MINIMAL.find("[[targets]]").unwrap();
        format!("{}{agents}\n{}", &MINIMAL[..start], &MINIMAL[end..])
    }

    /// Two AGVs (a clockwise loop looking right, a waypoint path) and two stations.
    const AGENTS: &str = r#"
        [[agv]]
        trajectory = { x_min_m = 2.0, y_min_m = 2.0, x_max_m = 18.0, y_max_m = 18.0, corner_radius_m = 2.0, clockwise = true }
        sensor = { boresight_deg = -90.0 }
        [[agv]]
        name = "shuttle"
        waypoints_m = [[3.0, 10.0], [3.0, 3.0], [16.0, 3.0], [16.0, 16.0]]
        closed = false
        speed_mps = 0.5
        sensor = { max_range_m = 12.0 }
        [[station]]
        position_m = [0.0, 10.0]
        boresight_deg = 0.0
        [[station]]
        name = "north"
        position_m = [10.0, 20.0]
        boresight_deg = -90.0
        half_fov_deg = 45.0
        max_range_m = 15.0
    "#;

    #[test]
    fn agvs_and_stations_build() {
        let scene = Scene::from_toml_str(&with_agents(AGENTS), "test").unwrap();
        assert_eq!(scene.agvs.len(), 2);
        assert_eq!(scene.agvs[0].name, "agv1");
        assert_eq!(scene.agvs[1].name, "shuttle");
        // agv1 is the scene's trajectory and sensor; its sensor overrides only the boresight.
        assert_eq!(scene.trajectory, scene.agvs[0].trajectory);
        assert_eq!(scene.sensor, scene.agvs[0].sensor);
        assert!(scene.trajectory.loop_spec().unwrap().clockwise);
        assert_eq!(
            scene.sensor,
            Sensor {
                boresight_rad: -FRAC_PI_2,
                ..Sensor::default()
            }
        );
        let shuttle = &scene.agvs[1];
        assert!(!shuttle.trajectory.is_closed());
        assert_eq!(shuttle.trajectory.speed_mps(), 0.5);
        assert_eq!(shuttle.sensor.max_range_m, 12.0);
        assert_eq!(shuttle.sensor.boresight_rad, FRAC_PI_2);
        // Stations: pose heading = boresight, sensor boresight 0, defaults from [sensor].
        assert_eq!(scene.stations.len(), 2);
        let west = &scene.stations[0];
        assert_eq!(west.name, "station1");
        assert_eq!(west.pose, Pose2::new(0.0, 10.0, 0.0));
        assert_eq!(
            west.sensor,
            Sensor {
                boresight_rad: 0.0,
                ..Sensor::default()
            }
        );
        let north = &scene.stations[1];
        assert_eq!(north.name, "north");
        assert_eq!(north.pose, Pose2::new(10.0, 20.0, -FRAC_PI_2));
        assert_eq!(north.sensor.max_range_m, 15.0);
        assert!((north.sensor.half_fov_rad - 45f64.to_radians()).abs() < 1e-15);
        // Written and read back, the spec is the same.
        let spec: SceneSpec = toml::from_str(&with_agents(AGENTS)).unwrap();
        let text = toml::to_string(&spec).unwrap();
        assert_eq!(toml::from_str::<SceneSpec>(&text).unwrap(), spec, "{text}");
    }

    #[test]
    fn single_agv_scene_has_agv1_and_no_station() {
        let scene = Scene::from_toml_str(MINIMAL, "test").unwrap();
        assert_eq!(scene.agvs.len(), 1);
        assert_eq!(scene.agvs[0].name, "agv1");
        assert_eq!(scene.agvs[0].trajectory, scene.trajectory);
        assert_eq!(scene.agvs[0].sensor, scene.sensor);
        assert!(scene.stations.is_empty());
        // A [trajectory] scene is written as before: no agv or station keys appear.
        let spec: SceneSpec = toml::from_str(MINIMAL).unwrap();
        let text = toml::to_string(&spec).unwrap();
        assert!(
            !text.contains("agv]") && !text.contains("station") && !text.contains("clockwise"),
            "{text}"
        );
    }

    #[test]
    fn agent_errors_name_the_field() {
        let agv1 = "[[agv]]\ntrajectory = { x_min_m = 2.0, y_min_m = 2.0, x_max_m = 18.0, y_max_m = 18.0, corner_radius_m = 2.0 }\n";
        let station = |body: &str| format!("{agv1}[[station]]\n{body}");
        for (agents, field) in [
            // [trajectory] and [[agv]] together.
            (
                format!("[trajectory]\nx_min_m = 2.0\ny_min_m = 2.0\nx_max_m = 18.0\ny_max_m = 18.0\ncorner_radius_m = 2.0\n{agv1}"),
                "trajectory",
            ),
            // Neither.
            (String::new(), "trajectory"),
            ("[[agv]]\nname = \"lost\"\n".to_owned(), "agv[0] (lost)"),
            (
                format!("{agv1}[[agv]]\nwaypoints_m = [[3.0, 3.0], [17.0, 3.0]]\ntrajectory = {{ x_min_m = 2.0, y_min_m = 2.0, x_max_m = 18.0, y_max_m = 18.0, corner_radius_m = 2.0 }}\n"),
                "agv[1] (agv2).waypoints_m",
            ),
            (
                format!("{agv1}[[agv]]\nspeed_mps = 2.0\ntrajectory = {{ x_min_m = 2.0, y_min_m = 2.0, x_max_m = 18.0, y_max_m = 18.0, corner_radius_m = 2.0 }}\n"),
                "agv[1] (agv2).speed_mps",
            ),
            (
                format!("{agv1}[[agv]]\ntrajectory = {{ x_min_m = 2.0, y_min_m = 2.0, x_max_m = 18.0, y_max_m = 18.0, corner_radius_m = 2.0, speed_mps = 0.0 }}\n"),
                "agv[1] (agv2).trajectory.speed_mps",
            ),
            // A loop through the box at (10, 10).
            (
                format!("{agv1}[[agv]]\ntrajectory = {{ x_min_m = 9.0, y_min_m = 2.0, x_max_m = 18.0, y_max_m = 18.0, corner_radius_m = 2.0 }}\n"),
                "agv[1] (agv2).trajectory",
            ),
            // A waypoint path through the box, and one leaving the hall.
            (
                format!("{agv1}[[agv]]\nwaypoints_m = [[3.0, 10.0], [17.0, 10.0]]\n"),
                "agv[1] (agv2).waypoints_m",
            ),
            (
                format!("{agv1}[[agv]]\nwaypoints_m = [[3.0, 3.0], [17.0, 3.0], [19.8, 17.0]]\n"),
                "agv[1] (agv2).waypoints_m[2]",
            ),
            (
                format!("{agv1}[[agv]]\nwaypoints_m = [[3.0, 3.0], [nan, 3.0]]\n"),
                "agv[1] (agv2).waypoints_m[1]",
            ),
            (
                format!("{agv1}[[agv]]\nwaypoints_m = [[3.0, 3.0], [17.0, 3.0]]\nclosed = false\nlaps = 2.0\n"),
                "agv[1] (agv2).laps",
            ),
            (
                format!("{agv1}[[agv]]\nname = \"b\"\nwaypoints_m = [[3.0, 3.0], [17.0, 3.0]]\nsensor = {{ half_fov_deg = 95.0 }}\n"),
                "agv[1] (b).sensor.half_fov_deg",
            ),
            (
                format!("{agv1}[[agv]]\nname = \"agv1\"\nwaypoints_m = [[3.0, 3.0], [17.0, 3.0]]\n"),
                "agv[1].name",
            ),
            (
                station("position_m = [nan, 3.0]\nboresight_deg = 0.0"),
                "station[0] (station1).position_m",
            ),
            // Outside the hall, just beyond a wall.
            (
                station("name = \"out\"\nposition_m = [20.01, 3.0]\nboresight_deg = 180.0"),
                "station[0] (out).position_m",
            ),
            // Inside the tank at (6, 6), and on its outline.
            (
                station("position_m = [6.0, 6.5]\nboresight_deg = 0.0"),
                "station[0] (station1).position_m",
            ),
            (
                station("position_m = [7.0, 6.0]\nboresight_deg = 0.0"),
                "station[0] (station1).position_m",
            ),
            (
                station("position_m = [0.0, 3.0]\nboresight_deg = 0.0\nhalf_fov_deg = 90.0"),
                "station[0] (station1).half_fov_deg",
            ),
            (
                station("position_m = [0.0, 3.0]\nboresight_deg = 0.0\nhalf_fov_deg = nan"),
                "station[0] (station1).half_fov_deg",
            ),
            (
                station("position_m = [0.0, 3.0]\nboresight_deg = 200.0"),
                "station[0] (station1).boresight_deg",
            ),
            (
                station("position_m = [0.0, 3.0]\nboresight_deg = 0.0\nmax_range_m = 0.0"),
                "station[0] (station1).max_range_m",
            ),
            (
                format!("{}\n[[station]]\nposition_m = [20.0, 20.0]\nboresight_deg = -135.0\nname = \"station1\"", station("position_m = [0.0, 3.0]\nboresight_deg = 0.0")),
                "station[1].name",
            ),
        ] {
            let text = with_agents(&agents);
            let error = match Scene::from_toml_str(&text, "test") {
                Err(SceneError::Invalid { error, .. }) => error,
                other => panic!("{agents}: expected a validation error, got {other:?}"),
            };
            assert_eq!(error.field, field, "{agents}: {error}");
        }
        // The allowed range is in the message.
        let text = with_agents(&station(
            "position_m = [0.0, 3.0]\nboresight_deg = 0.0\nhalf_fov_deg = 90.0",
        ));
        let message = Scene::from_toml_str(&text, "test").unwrap_err().to_string();
        assert!(message.contains("(0, 90)"), "{message}");
        // A station on a wall or a corner is inside the hall.
        let corner = with_agents(&station("position_m = [20.0, 0.0]\nboresight_deg = 135.0"));
        assert_eq!(
            Scene::from_toml_str(&corner, "test")
                .unwrap()
                .stations
                .len(),
            1
        );
    }

    #[test]
    fn unknown_agent_fields_are_refused() {
        let agv1 = "[[agv]]\ntrajectory = { x_min_m = 2.0, y_min_m = 2.0, x_max_m = 18.0, y_max_m = 18.0, corner_radius_m = 2.0 }\n";
        for bad in [
            format!("{agv1}colour = 3\n"),
            format!("{agv1}sensor = {{ fov_deg = 3.0 }}\n"),
            "[[agv]]\ntrajectory = { x_min_m = 2.0, y_min_m = 2.0, x_max_m = 18.0, y_max_m = 18.0, corner_radius_m = 2.0, direction = \"cw\" }\n".to_owned(),
            format!("{agv1}[[station]]\nposition_m = [0.0, 3.0]\nboresight_deg = 0.0\nyaw_deg = 3.0\n"),
            format!("{agv1}[[station]]\nposition_m = [0.0, 3.0]\n"),
        ] {
            assert!(
                matches!(
                    Scene::from_toml_str(&with_agents(&bad), "test"),
                    Err(SceneError::Parse { .. })
                ),
                "{bad}"
            );
        }
    }
}
