//! Standard ROS 2 messages for tools that draw the graph (RViz, Foxglove), field for field as in
//! ROS 2 Jazzy: `tf2_msgs/msg/TFMessage` (with `geometry_msgs` `TransformStamped` and
//! `Transform`), `nav_msgs/msg/Path` and `visualization_msgs/msg/MarkerArray` (with `Marker` and
//! what Jazzy's `Marker` holds: `std_msgs/ColorRGBA`, `builtin_interfaces/Duration`,
//! `sensor_msgs/CompressedImage`, `visualization_msgs/UVCoordinate` and `MeshFile`).
//!
//! Field order is the wire order (see [`crate::ros`]).

use crate::ros::{Header, Point, Pose, PoseStamped, Quaternion, Time, Vector3};
use serde::{Deserialize, Serialize};

/// `geometry_msgs/msg/Transform`: the child frame's pose in the parent frame.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// Child origin in the parent frame (m).
    pub translation: Vector3,
    /// Child orientation in the parent frame.
    pub rotation: Quaternion,
}

impl Transform {
    /// A planar transform: translation (m) and rotation about z (rad).
    pub fn from_planar(x_m: f64, y_m: f64, yaw_rad: f64) -> Self {
        Self {
            translation: Vector3 {
                x: x_m,
                y: y_m,
                z: 0.0,
            },
            rotation: Quaternion::from_yaw(yaw_rad),
        }
    }
}

/// `geometry_msgs/msg/TransformStamped`: `header.frame_id` → `child_frame_id`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and the parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent frame.
    pub transform: Transform,
}

/// `tf2_msgs/msg/TFMessage`: what `/tf` and `/tf_static` carry.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TFMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `nav_msgs/msg/Path`: a trajectory.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Path {
    /// Stamp and the frame of the poses.
    pub header: Header,
    /// The poses, oldest first.
    pub poses: Vec<PoseStamped>,
}

/// `std_msgs/msg/ColorRGBA`, each channel in 0..=1.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct ColorRGBA {
    /// Red.
    pub r: f32,
    /// Green.
    pub g: f32,
    /// Blue.
    pub b: f32,
    /// Opacity.
    pub a: f32,
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Duration {
    /// Whole seconds.
    pub sec: i32,
    /// Nanoseconds, 0..1e9.
    pub nanosec: u32,
}

/// `sensor_msgs/msg/CompressedImage` (a marker's texture).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Stamp and frame.
    pub header: Header,
    /// `jpeg`, `png`, …
    pub format: String,
    /// The compressed image.
    pub data: Vec<u8>,
}

/// `visualization_msgs/msg/UVCoordinate`: a texture coordinate.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct UVCoordinate {
    /// u.
    pub u: f32,
    /// v.
    pub v: f32,
}

/// `visualization_msgs/msg/MeshFile`: a mesh sent inline.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MeshFile {
    /// Name, whose extension tells the format.
    pub filename: String,
    /// The file's bytes.
    pub data: Vec<u8>,
}

/// `visualization_msgs/msg/Marker` (Jazzy: with texture, UV coordinates and an inline mesh).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Marker {
    /// Stamp and frame of `pose` and `points`.
    pub header: Header,
    /// Namespace; (ns, id) names a marker.
    pub ns: String,
    /// Id within the namespace.
    pub id: i32,
    /// [`Marker::LINE_STRIP`], [`Marker::SPHERE_LIST`], …
    #[serde(rename = "type")]
    pub marker_type: i32,
    /// [`Marker::ADD`], [`Marker::DELETE`], [`Marker::DELETEALL`].
    pub action: i32,
    /// Pose of the marker (of the points' frame for lists).
    pub pose: Pose,
    /// Size (m); for lines `scale.x` is the width, for lists each element's size.
    pub scale: Vector3,
    /// Colour (of every element unless `colors` gives one each).
    pub color: ColorRGBA,
    /// How long the marker lives; 0 is forever.
    pub lifetime: Duration,
    /// Re-transform with the frame every update.
    pub frame_locked: bool,
    /// Points of line strips, lists, points.
    pub points: Vec<Point>,
    /// One colour per point, or empty.
    pub colors: Vec<ColorRGBA>,
    /// Texture URI (empty: none).
    pub texture_resource: String,
    /// Inline texture.
    pub texture: CompressedImage,
    /// Texture coordinates, one per point.
    pub uv_coordinates: Vec<UVCoordinate>,
    /// Text of a text marker.
    pub text: String,
    /// Mesh URI.
    pub mesh_resource: String,
    /// Inline mesh.
    pub mesh_file: MeshFile,
    /// Use the mesh's own materials.
    pub mesh_use_embedded_materials: bool,
}

impl Marker {
    /// `type`: arrow.
    pub const ARROW: i32 = 0;
    /// `type`: cube.
    pub const CUBE: i32 = 1;
    /// `type`: sphere.
    pub const SPHERE: i32 = 2;
    /// `type`: cylinder.
    pub const CYLINDER: i32 = 3;
    /// `type`: connected line through `points`.
    pub const LINE_STRIP: i32 = 4;
    /// `type`: a line per pair of `points`.
    pub const LINE_LIST: i32 = 5;
    /// `type`: a cube per point.
    pub const CUBE_LIST: i32 = 6;
    /// `type`: a sphere per point.
    pub const SPHERE_LIST: i32 = 7;
    /// `type`: a square point per point.
    pub const POINTS: i32 = 8;
    /// `type`: text facing the viewer.
    pub const TEXT_VIEW_FACING: i32 = 9;
    /// `action`: add or replace.
    pub const ADD: i32 = 0;
    /// `action`: delete (ns, id).
    pub const DELETE: i32 = 2;
    /// `action`: delete every marker (of the namespace, if `ns` is set, in newer viewers).
    pub const DELETEALL: i32 = 3;

    /// A marker of `marker_type` to add (or replace) under (`ns`, `id`), drawn in
    /// `header.frame_id` with the identity pose.
    pub fn added(header: Header, ns: &str, id: i32, marker_type: i32) -> Self {
        Marker {
            header,
            ns: ns.to_owned(),
            id,
            marker_type,
            action: Marker::ADD,
            pose: Pose::default(),
            ..Marker::default()
        }
    }

    /// Clears what earlier arrays drew, so that things that merged or vanished disappear.
    pub fn delete_all(header: Header) -> Self {
        Marker {
            action: Marker::DELETEALL,
            ..Marker::added(header, "", 0, Marker::ARROW)
        }
    }

    /// A closed line through `outline` (its first point repeated at the end), `width_m` wide.
    pub fn closed_line(
        header: Header,
        (ns, id): (&str, i32),
        outline: &[Point],
        width_m: f64,
        color: ColorRGBA,
    ) -> Self {
        let mut points = outline.to_vec();
        points.extend(outline.first().copied());
        Marker {
            scale: Vector3 {
                x: width_m,
                y: 0.0,
                z: 0.0,
            },
            color,
            points,
            ..Marker::added(header, ns, id, Marker::LINE_STRIP)
        }
    }

    /// A sphere of diameter `size_m` at each of `points`.
    pub fn spheres(
        header: Header,
        (ns, id): (&str, i32),
        points: &[Point],
        size_m: f64,
        color: ColorRGBA,
    ) -> Self {
        Marker {
            scale: Vector3 {
                x: size_m,
                y: size_m,
                z: size_m,
            },
            color,
            points: points.to_vec(),
            ..Marker::added(header, ns, id, Marker::SPHERE_LIST)
        }
    }

    /// A cube of side `size_m` at each of `points` (the cells of a grid): [`Marker::spheres`]
    /// drawn as cubes, which viewers size alike.
    pub fn cubes(
        header: Header,
        at: (&str, i32),
        points: &[Point],
        size_m: f64,
        color: ColorRGBA,
    ) -> Self {
        Marker {
            marker_type: Marker::CUBE_LIST,
            ..Marker::spheres(header, at, points, size_m, color)
        }
    }

    /// A marker id for an id of the graph's messages (`u32`), saturating at `i32::MAX`.
    pub fn id_of(value: u32) -> i32 {
        i32::try_from(value).unwrap_or(i32::MAX)
    }
}

/// `visualization_msgs/msg/MarkerArray`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MarkerArray {
    /// The markers.
    #[serde(deserialize_with = "few_reserved")]
    pub markers: Vec<Marker>,
}

/// A sequence whose elements are large in memory (a [`Marker`] is about 450 bytes, for 190 or
/// more on the wire): nothing is reserved from the decoder's size hint (which is bounded by the
/// bytes left / 8, not by the element's size, so it would let a false count reserve ~56 bytes per
/// payload byte); the vector grows as elements actually decode.
pub(crate) fn few_reserved<'de, D, T>(deserializer: D) -> Result<Vec<T>, D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct Few<T>(std::marker::PhantomData<T>);
    impl<'de, T: Deserialize<'de>> serde::de::Visitor<'de> for Few<T> {
        type Value = Vec<T>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a sequence")
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
            let mut out = Vec::new();
            while let Some(element) = seq.next_element()? {
                out.push(element);
            }
            Ok(out)
        }
    }
    deserializer.deserialize_seq(Few(std::marker::PhantomData))
}

impl TFMessage {
    /// Stamp of the first transform (0 if there is none).
    pub fn stamp(&self) -> Time {
        self.transforms
            .first()
            .map(|t| t.header.stamp)
            .unwrap_or_default()
    }
}

impl MarkerArray {
    /// Stamp of the first marker (0 if there is none).
    pub fn stamp(&self) -> Time {
        self.markers
            .first()
            .map(|m| m.header.stamp)
            .unwrap_or_default()
    }
}
